//! The wavefront path tracer against the scalar one: the same image, bit
//! for bit (each path makes the same operations in the same order; only the
//! interleaving of paths differs), on every bundled scene and on the
//! features the bundled scenes lack (alpha, absorbing media), with each
//! technique and regularization mode, at any thread count.

use crate::common;

use accel::Isa;
use glam::Vec3;
use integrators::{Mode, RenderConfig, Renderer, Strategies};
use scene::material::Alpha;

/// Per-iteration estimates of `iterations` iterations, as bits, with the
/// ray count and the invalid-sample count, rendered on `threads` threads.
fn estimates(scene: &scene::Scene, config: RenderConfig, threads: usize) -> (Vec<u32>, u64, u64) {
    estimates_on(scene, config, threads, Isa::Best).expect("the best set exists")
}

/// [`estimates`] with the SIMD kernels on the instruction set `isa`;
/// `None` when the CPU lacks it.
fn estimates_on(
    scene: &scene::Scene,
    config: RenderConfig,
    threads: usize,
    isa: Isa,
) -> Option<(Vec<u32>, u64, u64)> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        let mut renderer = Renderer::new(scene.clone(), config);
        if !renderer.set_isa(isa) {
            return None;
        }
        let (w, h) = renderer.resolution();
        let mut bits = Vec::new();
        let mut estimates = vec![Vec3::ZERO; w as usize * h as usize];
        for n in 1..=ITERATIONS {
            renderer.render_iteration(n, &mut estimates);
            bits.extend(
                estimates
                    .iter()
                    .flat_map(|e| e.to_array().map(f32::to_bits)),
            );
        }
        Some((bits, renderer.rays_traced(), renderer.invalid_samples()))
    })
}

/// Iterations per comparison: enough for several sampler dimensions per
/// pixel; every iteration's estimates are compared.
const ITERATIONS: u64 = 2;

/// Asserts that the wavefront (2 threads) gives the scalar loop's (1 thread)
/// estimates, ray count and invalid-sample count; `what` names the case.
fn assert_same_image(scene: &scene::Scene, config: RenderConfig, what: &str) {
    let scalar = estimates(
        scene,
        RenderConfig {
            wavefront: false,
            ..config
        },
        1,
    );
    let wavefront = estimates(
        scene,
        RenderConfig {
            wavefront: true,
            ..config
        },
        2,
    );
    assert!(scalar.1 > 0, "{what}: no rays traced");
    assert_eq!(scalar.1, wavefront.1, "{what}: ray counts differ");
    assert_eq!(scalar.2, wavefront.2, "{what}: invalid samples differ");
    if let Some(i) = (0..scalar.0.len()).find(|&i| scalar.0[i] != wavefront.0[i]) {
        panic!(
            "{what}: estimate word {i} differs: {} (scalar) against {} (wavefront)",
            f32::from_bits(scalar.0[i]),
            f32::from_bits(wavefront.0[i])
        );
    }
}

/// A bundled scene (manifest or Mitsuba folder) at `width` x `height`.
fn bundled(name: &str, width: u32, height: u32) -> scene::Scene {
    let manifest = common::bundled(name);
    let path = if manifest.exists() {
        manifest
    } else {
        manifest.with_file_name("scene.xml")
    };
    common::load(&path, width, height)
}

#[test]
fn wavefront_gives_the_scalar_image_on_every_bundled_scene() {
    let scenes = std::fs::read_dir(common::bundled("x").parent().unwrap().parent().unwrap())
        .unwrap()
        .filter_map(|e| e.ok().filter(|e| e.path().is_dir()))
        .map(|e| e.file_name().into_string().unwrap())
        .collect::<Vec<_>>();
    assert!(scenes.len() >= 15, "bundled scenes: {scenes:?}");
    for name in &scenes {
        let scene = bundled(name, 20, 12);
        for mode in [Mode::Off, Mode::Selective] {
            let config = common::config(Strategies::Mis, mode, 8);
            assert_same_image(&scene, config, &format!("{name}, {mode:?}"));
        }
    }
}

#[test]
fn wavefront_gives_the_scalar_image_with_each_technique_and_long_rows() {
    // 300 pixels a row: two runs of the wavefront per row.
    let scene = bundled("caustic-glass", 300, 4);
    for strategies in [Strategies::Mis, Strategies::NeeOnly, Strategies::BsdfOnly] {
        for mode in [Mode::Off, Mode::Uniform, Mode::Unsampleable] {
            let config = common::config(strategies, mode, 12);
            assert_same_image(&scene, config, &format!("{strategies:?}, {mode:?}"));
        }
    }
}

#[test]
fn wavefront_gives_the_scalar_image_with_alpha_and_media() {
    let mut scene = bundled("cornell-box", 24, 16);
    let blend = Alpha::Blend {
        factor: 0.5,
        texture: None,
    };
    scene.materials[0].maps.alpha = blend;
    let config = common::config(Strategies::Mis, Mode::Off, 8);
    assert_same_image(&scene, config, "cornell-box with a BLEND material");

    let absorbing = "[camera]\nfrom = [0, 1.2, 1.8]\nat = [0, 0.45, 0]\nfov = 40\n\n\
        [[material]]\nname = \"glass\"\ntype = \"dielectric\"\nior = 1.5\nalpha = 0.3\n\
        absorption = [0.2, 1.0, 3.0]\n\n\
        [[material]]\nname = \"lamp\"\ntype = \"diffuse\"\nreflectance = [0, 0, 0]\nemission = [12, 12, 12]\n\n\
        [[shape]]\ntype = \"quad\"\nmaterial = \"lamp\"\norigin = [-0.5, 2, -0.5]\nu = [1, 0, 0]\nv = [0, 0, 1]\n\n\
        [[shape]]\ntype = \"sphere\"\nmaterial = \"glass\"\ncenter = [0, 0.5, 0]\nradius = 0.5\n";
    let scene = common::load_manifest("wavefront-media", absorbing, &[], (24, 16));
    let config = common::config(Strategies::Mis, Mode::Selective, 12);
    assert_same_image(&scene, config, "absorbing sphere");
}

/// The wavefront's SIMD lanes (`pt/lanes.rs`) and the BVH's kernels give
/// the scalar loop's image on every instruction set the CPU has, the
/// build's SSE4.2 baseline included: scenes whose Lambertian vertices are
/// lit by triangle lights and by a point light.
#[test]
fn wavefront_gives_the_scalar_image_on_every_instruction_set() {
    for name in ["cornell-mcguire", "smallvcm-2"] {
        let scene = bundled(name, 24, 16);
        let config = common::config(Strategies::Mis, Mode::Off, 8);
        let scalar = estimates(
            &scene,
            RenderConfig {
                wavefront: false,
                ..config
            },
            1,
        );
        let mut tested = 0;
        for isa in Isa::ALL {
            if let Some(wavefront) = estimates_on(&scene, config, 2, isa) {
                assert!(
                    wavefront == scalar,
                    "{name}: the wavefront on {isa:?} differs from the scalar loop"
                );
                tested += 1;
            }
        }
        assert!(
            tested >= 2,
            "{name}: the best set and the baseline at least"
        );
    }
}
