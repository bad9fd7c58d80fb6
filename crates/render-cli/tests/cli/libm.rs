//! Images do not depend on the routines glibc's libm picks when the process
//! starts: on x86_64 its `exp`, `log`, `pow`, `sin`, `cos`, `sincosf`, ...
//! come in an FMA/AVX2 variant and an SSE2 one, which round some inputs
//! differently (0.07 % of f64 `exp` inputs, ../shared/notes/simd-and-wavefront.md
//! §2), chosen by the CPU's features. The renderer's own code has no such
//! choice (the x86-64-v2 build has no FMA; the BVH8 layout's run-time
//! dispatched kernels are compared across instruction sets in accel's
//! tests), so this is the one run-time instruction-set choice in a default
//! render. `GLIBC_TUNABLES=glibc.cpu.hwcaps=-AVX2,-FMA` makes glibc take
//! its SSE2 fallbacks; the image must keep its bytes.

use crate::{bundled, render_cli};

/// glibc's tunable that hides AVX2 and FMA from its routine selection.
const SSE2_FALLBACKS: &str = "glibc.cpu.hwcaps=-AVX2,-FMA";

#[test]
fn images_keep_their_bytes_when_glibc_takes_its_sse2_routines() {
    if !cfg!(all(
        target_os = "linux",
        target_env = "gnu",
        target_arch = "x86_64"
    )) {
        eprintln!("not glibc on x86_64: nothing to compare");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    // Scenes whose pixels go through exp, log1p, pow, sin and cos: Beckmann
    // and GGX lobes (regularized in glossy-caustic and veach-mis), an
    // environment map, rough glass (unregularized: its energy tables would
    // take seconds to build).
    for (scene, integrator, regularize) in [
        ("smallvcm-2", "vcm", "unsampleable"),
        ("glossy-caustic", "pt", "selective"),
        ("veach-mis", "pt", "unsampleable"),
        ("env-sphere", "bpt", "unsampleable"),
        ("glossy-cornell-glass", "vcm", "off"),
    ] {
        let render = |name: &str, tunables: Option<&str>| {
            let exr = dir.path().join(format!("{scene}-{name}.exr"));
            // The folder: veach-mis is a Mitsuba scene.xml.
            let path = bundled(scene).parent().unwrap().to_path_buf();
            let args = [
                path.to_str().unwrap(),
                "--integrator",
                integrator,
                "--regularize",
                regularize,
                "--resolution",
                "40x30",
                "--iterations",
                "4",
                "-o",
                exr.to_str().unwrap(),
            ];
            let output = match tunables {
                Some(t) => crate::render_cli_with_env(&args, ("GLIBC_TUNABLES", t)),
                None => render_cli(&args),
            };
            assert!(
                output.status.success(),
                "{scene}: {}",
                crate::stderr(&output)
            );
            std::fs::read(&exr).unwrap()
        };
        let default = render("default", None);
        let sse2 = render("sse2", Some(SSE2_FALLBACKS));
        assert!(
            default == sse2,
            "{scene} ({integrator}): the EXR bytes differ"
        );
    }
}
