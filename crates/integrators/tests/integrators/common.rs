//! Shared helpers of the integrator tests: scene loading at test size and
//! statistical comparison of films from their measured variance.

use std::path::{Path, PathBuf};

use glam::{DVec3, UVec2, Vec3};
use integrators::{Film, Mode, Regularization, RenderConfig, Renderer, Strategies};
use stats::{chi2::sidak, special::chi2_survival};

/// A bundled scene's manifest.
pub fn bundled(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenes")
        .join(name)
        .join("scene.toml")
}

/// Loads `path` at `width` x `height`.
pub fn load(path: &Path, width: u32, height: u32) -> scene::Scene {
    scene::load(
        path,
        &scene::LoadOptions {
            resolution: Some(UVec2::new(width, height)),
            ..Default::default()
        },
    )
    .unwrap_or_else(|e| panic!("{e}"))
}

/// Writes `manifest` as `scene.toml` into a temporary folder of its own
/// (named after `what`, the process and a counter: tests run in parallel),
/// with copies of `files` beside it, loads it at `width` x `height`, and
/// removes the folder.
pub fn load_manifest(
    what: &str,
    manifest: &str,
    files: &[&Path],
    (width, height): (u32, u32),
) -> scene::Scene {
    static CALLS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let call = CALLS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!("rlt-{what}-{}-{call}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for file in files {
        std::fs::copy(file, dir.join(file.file_name().unwrap())).unwrap();
    }
    let path = dir.join("scene.toml");
    std::fs::write(&path, manifest).unwrap();
    let scene = load(&path, width, height);
    std::fs::remove_dir_all(&dir).unwrap();
    scene
}

/// A PT configuration.
pub fn config(strategies: Strategies, mode: Mode, max_depth: u32) -> RenderConfig {
    RenderConfig {
        strategies,
        max_depth,
        seed: 1,
        regularization: Regularization::new(mode, integrators::DEFAULT_TAU_0, true).unwrap(),
        ..RenderConfig::default()
    }
}

/// Renders `iterations` iterations; asserts that no sample was NaN or infinite.
pub fn render(scene: scene::Scene, config: RenderConfig, iterations: u64) -> Film {
    let renderer = Renderer::new(scene, config);
    let mut film = renderer.new_film();
    renderer.render(&mut film, 1, iterations);
    assert_eq!(renderer.invalid_samples(), 0, "NaN or infinite samples");
    film
}

/// Per-channel means and variances of the means of `blocks` x `blocks`
/// rectangles of the image (pixels are independent, so the variance of a
/// block mean is the sum of the pixel variances of the mean over n^2).
pub fn block_means(film: &Film, blocks: u32) -> Vec<(DVec3, DVec3)> {
    let (w, h) = (film.width(), film.height());
    let se = film.standard_error();
    let mut out = Vec::new();
    for by in 0..blocks {
        for bx in 0..blocks {
            let (x0, x1) = (bx * w / blocks, (bx + 1) * w / blocks);
            let (y0, y1) = (by * h / blocks, (by + 1) * h / blocks);
            let (mut sum, mut var) = (DVec3::ZERO, DVec3::ZERO);
            for y in y0..y1 {
                for x in x0..x1 {
                    sum += film.pixel_mean(x, y);
                    let s = se[(y * w + x) as usize];
                    var += s * s;
                }
            }
            let n = f64::from((x1 - x0) * (y1 - y0));
            out.push((sum / n, var / (n * n)));
        }
    }
    out
}

/// Two-sided p-value of a standard normal deviate z.
pub fn p_value(z: f64) -> f64 {
    chi2_survival(z * z, 1)
}

/// Two-sided p-value of a difference `diff` with standard error `sd`; with
/// no variance, 1 for an exact match and 0 otherwise.
pub fn difference_p_value(diff: f64, sd: f64) -> f64 {
    if sd > 0.0 {
        p_value(diff / sd)
    } else if diff == 0.0 {
        1.0
    } else {
        0.0
    }
}

/// Asserts that every channel of every block (and of the whole image) of
/// `a` and `b` agree: each difference, over its standard error, has a
/// two-sided p-value above the Sidak-corrected significance 0.01. Returns
/// the smallest p-value.
pub fn assert_films_agree(a: &Film, b: &Film, blocks: u32, what: &str) -> f64 {
    let (ba, bb) = (block_means(a, blocks), block_means(b, blocks));
    let (wa, wb) = (block_means(a, 1), block_means(b, 1));
    let pairs: Vec<_> = ba.iter().zip(&bb).chain(wa.iter().zip(&wb)).collect();
    let threshold = sidak(0.01, pairs.len() * 3);
    let mut smallest = 1.0f64;
    for (i, ((ma, va), (mb, vb))) in pairs.into_iter().enumerate() {
        for c in 0..3 {
            let sd = (va[c] + vb[c]).sqrt();
            let diff = ma[c] - mb[c];
            let p = difference_p_value(diff, sd);
            smallest = smallest.min(p);
            assert!(
                p > threshold,
                "{what}: block {i} channel {c}: {} vs {} (sd {sd:.3e}), p = {p:.2e} < {threshold:.2e}",
                ma[c],
                mb[c]
            );
        }
    }
    smallest
}

/// Asserts that every block of `film` agrees with the constant `expected`
/// (Sidak-corrected significance 0.01). Returns the smallest p-value.
pub fn assert_film_equals(film: &Film, expected: f64, blocks: u32, what: &str) -> f64 {
    let means = block_means(film, blocks);
    let threshold = sidak(0.01, means.len() * 3);
    let mut smallest = 1.0f64;
    for (i, (m, v)) in means.iter().enumerate() {
        for c in 0..3 {
            let p = p_value((m[c] - expected) / v[c].sqrt());
            smallest = smallest.min(p);
            assert!(
                p > threshold,
                "{what}: block {i} channel {c}: {} vs {expected} (sd {:.3e}), p = {p:.2e}",
                m[c],
                v[c].sqrt()
            );
        }
    }
    smallest
}

/// Pixels of `caustic-glass` whose camera ray hits the mirror and whose
/// reflection lands on the floor in the sphere's shadow, where only light
/// refracted by the glass (the caustic) or bounced off other surfaces
/// arrives. Computed from the manifest's geometry: mirror plane z = -1.5,
/// |x| < 2, 0 < y < 2.5; floor y = 0; sphere at (0, 0.6, 0), radius 0.5;
/// point light at (0.3, 2.6, 0.2).
pub fn caustic_in_mirror_mask(renderer: &Renderer) -> Vec<bool> {
    let rays = integrators::camera::CameraRays::new(renderer.scene().camera);
    let (w, h) = renderer.resolution();
    let (light, centre) = (Vec3::new(0.3, 2.6, 0.2), Vec3::new(0.0, 0.6, 0.0));
    // Does the segment from o along unit d, up to length t_max, meet the sphere?
    let meets_sphere = |o: Vec3, d: Vec3, t_max: f32| {
        let oc = o - centre;
        let b = oc.dot(d);
        let disc = b * b - (oc.length_squared() - 0.25);
        disc > 0.0 && -b - disc.sqrt() > 0.0 && -b - disc.sqrt() < t_max
    };
    let mut mask = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let (o, d) = rays.ray(x, y, glam::Vec2::splat(0.5));
            let t = (-1.5 - o.z) / d.z;
            let m = o + d * t;
            let r = Vec3::new(d.x, d.y, -d.z);
            let s = -m.y / r.y;
            let f = m + r * s;
            let to_light = light - f;
            mask.push(
                t > 0.0
                    && m.x.abs() < 2.0
                    && (0.0..2.5).contains(&m.y)
                    && !meets_sphere(o, d, t)
                    && s > 0.0
                    && !meets_sphere(m, r, s)
                    && meets_sphere(f, to_light.normalize(), to_light.length()),
            );
        }
    }
    mask
}
