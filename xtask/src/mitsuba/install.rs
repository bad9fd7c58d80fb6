//! Mitsuba 3 for `python3`: from `<out>/venv`, else the system's, else
//! installed into `<out>/venv` with pip.

use std::path::{Path, PathBuf};
use std::process::Command;

use super::process::run_quiet;

pub(super) struct Mitsuba {
    pub(super) python: PathBuf,
    pub(super) version: String,
    pub(super) how: String,
}

/// Mitsuba from `<out>/venv`, else the system `python3`, else installed
/// into `<out>/venv`.
pub(super) fn ensure_mitsuba(out: &Path) -> Result<Mitsuba, String> {
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
