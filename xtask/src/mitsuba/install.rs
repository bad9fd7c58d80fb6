//! Mitsuba 3 for `python3`: from `<out>/venv`, else the system's, else
//! installed into `<out>/venv` with pip; and the LLVM library its
//! `llvm_ad_rgb` variant loads at run time (Debian's `libllvm19`, installed
//! with apt-get when missing and this process is root).

use std::path::{Path, PathBuf};
use std::process::Command;

use super::MitsubaConfig;
use super::process::run_quiet;

/// The Debian package that provides the libLLVM Dr.Jit's LLVM backend loads
/// (Dr.Jit 1.x accepts LLVM 11 and later; 19 is Debian 13's).
const LLVM_PACKAGE: &str = "libllvm19";

pub(super) struct Mitsuba {
    pub(super) python: PathBuf,
    pub(super) version: String,
    pub(super) how: String,
}

/// Mitsuba from `<out>/venv`, else the system `python3`, else installed
/// into `<out>/venv`.
pub(super) fn ensure_mitsuba(out: &Path, configs: &[MitsubaConfig]) -> Result<Mitsuba, String> {
    let mitsuba = find_or_install(out)?;
    for c in configs {
        ensure_variant(&mitsuba, &c.variant)?;
    }
    Ok(mitsuba)
}

fn find_or_install(out: &Path) -> Result<Mitsuba, String> {
    let venv = out.join("venv");
    let venv_python = venv.join("bin").join("python");
    if let Some(version) = mitsuba_version(&venv_python) {
        return Ok(Mitsuba {
            python: venv_python,
            version,
            how: format!("already installed in {}", venv.display()),
        });
    }
    if let Some(version) = mitsuba_version(Path::new("python3")) {
        return Ok(Mitsuba {
            python: PathBuf::from("python3"),
            version,
            how: "from the system python3".into(),
        });
    }
    println!(
        "mitsuba: not found; installing it into {} (python3 -m venv, pip install mitsuba)",
        venv.display()
    );
    let fail = |what: &str| format!("mitsuba could not be installed: {what}");
    run_quiet(Command::new("python3").arg("-m").arg("venv").arg(&venv))
        .map_err(|e| fail(&format!("python3 -m venv: {e}")))?;
    run_quiet(Command::new(&venv_python).args([
        "-m",
        "pip",
        "install",
        "--quiet",
        "--disable-pip-version-check",
        "mitsuba",
    ]))
    .map_err(|e| fail(&format!("pip install mitsuba: {e}")))?;
    let version = mitsuba_version(&venv_python)
        .ok_or_else(|| fail("pip succeeded but `import mitsuba` still fails"))?;
    Ok(Mitsuba {
        python: venv_python,
        version,
        how: format!("installed now into {} with pip", venv.display()),
    })
}

/// `mitsuba.__version__` if `python` can import Mitsuba and its scalar_rgb variant.
fn mitsuba_version(python: &Path) -> Option<String> {
    let output = Command::new(python)
        .args([
            "-c",
            "import mitsuba as mi; mi.set_variant('scalar_rgb'); print(mi.__version__)",
        ])
        .output()
        .ok()?;
    let version = String::from_utf8_lossy(&output.stdout).trim().to_string();
    (output.status.success() && !version.is_empty()).then_some(version)
}

/// Checks that `python` can set `variant`; for an LLVM variant whose
/// libLLVM is missing, installs [`LLVM_PACKAGE`] with apt-get when root.
fn ensure_variant(mitsuba: &Mitsuba, variant: &str) -> Result<(), String> {
    let Err(first) = try_variant(&mitsuba.python, variant) else {
        return Ok(());
    };
    if !variant.starts_with("llvm") {
        return Err(format!(
            "Mitsuba's variant {variant} is not available: {first}"
        ));
    }
    let hint = format!(
        "Mitsuba's {variant} needs libLLVM: install it (`apt-get install {LLVM_PACKAGE}` as root) \
         or set DRJIT_LIBLLVM_PATH to a libLLVM.so"
    );
    if !is_root() {
        return Err(format!("{hint} ({first})"));
    }
    println!("mitsuba: {variant} cannot load libLLVM; installing {LLVM_PACKAGE} with apt-get");
    run_quiet(Command::new("apt-get").args(["install", "-y", "-q", LLVM_PACKAGE]))
        .or_else(|_| {
            run_quiet(Command::new("apt-get").args(["update", "-q"]))?;
            run_quiet(Command::new("apt-get").args(["install", "-y", "-q", LLVM_PACKAGE]))
        })
        .map_err(|e| format!("{hint}; apt-get failed: {e}"))?;
    try_variant(&mitsuba.python, variant).map_err(|e| format!("{hint} ({e})"))
}

/// `mi.set_variant(variant)` and one tiny render, so that a missing libLLVM
/// shows here (the LLVM backend loads it on first use); the error's last line.
fn try_variant(python: &Path, variant: &str) -> Result<(), String> {
    let script = format!(
        "import mitsuba as mi; mi.set_variant('{variant}'); \
         mi.render(mi.load_dict(mi.cornell_box()), spp=1)"
    );
    let output = Command::new(python)
        .args(["-c", &script])
        .output()
        .map_err(|e| format!("cannot run {}: {e}", python.display()))?;
    if output.status.success() {
        return Ok(());
    }
    let stderr = String::from_utf8_lossy(&output.stderr);
    Err(stderr.trim().lines().last().unwrap_or("failed").to_string())
}

/// Whether this process runs as root (apt-get needs it).
fn is_root() -> bool {
    Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "0")
}
