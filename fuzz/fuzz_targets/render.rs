//! A `scene.toml` manifest from the input, loaded at 8x6 pixels and rendered
//! for one iteration with each integrator (`pt`, `bpt`, `ppm`, `bpm`,
//! `vcm`). Every pixel estimate must be finite and non-negative, and no panic
//! may escape (libFuzzer reports a panic as a crash). `render_iteration`
//! replaces NaN and infinite estimates by zero and counts them, so the count
//! (`invalid_samples`) must be zero too.
#![no_main]
use glam::{UVec2, Vec3};
use integrators::{Algorithm, RenderConfig, Renderer};
use libfuzzer_sys::fuzz_target;

fuzz_target!(
    init: {
        // One worker: the machine is shared, and libFuzzer runs one input at a time.
        let _ = rayon::ThreadPoolBuilder::new().num_threads(1).build_global();
    },
    |data: &[u8]| {
        let path = rlt_fuzz::write_input("scene.toml", data);
        let options = scene::LoadOptions {
            resolution: Some(UVec2::new(8, 6)),
            ..Default::default()
        };
        let Ok(scene) = scene::load(&path, &options) else {
            return;
        };
        for algorithm in Algorithm::every() {
            let config = RenderConfig {
                algorithm,
                ..RenderConfig::default()
            };
            let renderer = Renderer::new(scene.clone(), config);
            let (w, h) = renderer.resolution();
            let mut estimates = vec![Vec3::ZERO; w as usize * h as usize];
            renderer.render_iteration(1, &mut estimates);
            for (i, e) in estimates.iter().enumerate() {
                assert!(
                    e.is_finite() && e.min_element() >= 0.0,
                    "{algorithm:?}: pixel {i} = {e}"
                );
            }
            assert_eq!(
                renderer.invalid_samples(),
                0,
                "{algorithm:?}: NaN/Inf estimates zeroed by the renderer"
            );
        }
    }
);
