//! Our reference image at `--reference-spp`, with the variance of its
//! pixel means, cached in `<out>/cache/`.

use std::fs;
use std::path::PathBuf;

use glam::Vec3;
use image_io::read_exr;
use scene::Scene;
use serde_json::{Value, json};

use super::render::{Job, fastest, render_film};
use super::{Options, SEED_REFERENCE};
use crate::study::cache::{self, Fnv64};

/// Our reference: the mean image and how it was made.
pub(super) struct Reference {
    pub(super) spp: u32,
    pub(super) mean: Vec<Vec3>,
    /// Per pixel and channel: sample variance of the iterations over their
    /// number, the squared standard error of the mean (an upper bound of the
    /// reference's own squared error: our sampler is Owen-scrambled Sobol).
    pub(super) variance_of_mean: Vec<Vec3>,
    pub(super) path: PathBuf,
    pub(super) render_s: f64,
    pub(super) cached: bool,
}

/// Our reference image, from the cache or rendered now on all cores.
pub(super) fn reference(scene: &Scene, options: &Options) -> Result<Reference, String> {
    let files = CacheFiles::of(options)?;
    match load_cached(&files, options) {
        Some(reference) => Ok(reference),
        None => render_and_store(scene, options, files),
    }
}

/// A cache entry: the mean image, its variance of the mean, and a JSON
/// sidecar with the render time.
struct CacheFiles {
    mean: PathBuf,
    variance: PathBuf,
    info: PathBuf,
}

impl CacheFiles {
    /// The entry of `options`' reference: `<out>/cache/reference-<key>*`.
    fn of(options: &Options) -> Result<Self, String> {
        let stem = format!("reference-{:016x}", cache_key(options)?);
        let cache = options.out.join("cache");
        Ok(Self {
            mean: cache.join(format!("{stem}.exr")),
            variance: cache.join(format!("{stem}-variance-of-mean.exr")),
            info: cache.join(format!("{stem}.json")),
        })
    }
}

/// The cache key: the settings and the scene's files, hashed as the
/// study's reference cache hashes them (`study::cache`: FNV-1a over
/// length-prefixed fields, files by relative path). Not the renderer's
/// sources (they change all the time): after a change to the renderer,
/// delete <out>/cache. A stale reference shows as our own image
/// disagreeing with it in the report's agreement table.
fn cache_key(options: &Options) -> Result<u64, String> {
    let mut key = Fnv64::default();
    key.field(
        format!(
            "reference v1|{}x{}|depth {}|spp {}|seed {SEED_REFERENCE}|{}",
            options.width,
            options.height,
            options.max_depth,
            options.reference_spp,
            options.integrator.name()
        )
        .as_bytes(),
    );
    key.field(&cache::scene_hash_of(&options.scene)?.to_le_bytes());
    Ok(key.finish())
}

/// The cached reference, if all three files are there and the images
/// have the options' size.
fn load_cached(files: &CacheFiles, options: &Options) -> Option<Reference> {
    let mean = read_exr(&files.mean).ok()?;
    let variance = read_exr(&files.variance).ok()?;
    let info = fs::read_to_string(&files.info).ok()?;
    if mean.pixels.len() != options.pixels() || variance.pixels.len() != options.pixels() {
        return None;
    }
    let render_s = serde_json::from_str::<Value>(&info)
        .ok()
        .and_then(|v| v["render_s"].as_f64())
        .unwrap_or(f64::NAN);
    println!(
        "reference: ours at {} spp, cached ({}; rendered in {render_s:.1} s)",
        options.reference_spp,
        files.mean.display()
    );
    Some(Reference {
        spp: options.reference_spp,
        mean: mean.pixels,
        variance_of_mean: variance.pixels,
        path: files.mean.clone(),
        render_s,
        cached: true,
    })
}

/// Renders the reference on all cores and stores it in the cache.
fn render_and_store(
    scene: &Scene,
    options: &Options,
    files: CacheFiles,
) -> Result<Reference, String> {
    let cores = crate::cores();
    println!(
        "reference: rendering ours at {} spp on {cores} thread(s) ...",
        options.reference_spp
    );
    let job = Job {
        spp: options.reference_spp,
        seed: SEED_REFERENCE,
        threads: cores,
    };
    let (film, _, times, invalid) = render_film(scene, options, job)?;
    let render_s = fastest(&times);
    if invalid > 0 {
        println!("reference: warning: {invalid} NaN/inf samples dropped");
    }
    let mean = film.mean();
    let variance_of_mean: Vec<Vec3> = film
        .standard_error()
        .into_iter()
        .map(|s| (s * s).as_vec3())
        .collect();
    let info = json!({ "spp": options.reference_spp, "render_s": render_s, "threads": cores });
    store(&files, options, (&mean, &variance_of_mean), &info)?;
    println!(
        "reference: rendered in {render_s:.1} s -> {}",
        files.mean.display()
    );
    Ok(Reference {
        spp: options.reference_spp,
        mean,
        variance_of_mean,
        path: files.mean,
        render_s,
        cached: false,
    })
}

/// Writes a cache entry: both images, then the sidecar.
fn store(
    files: &CacheFiles,
    options: &Options,
    (mean, variance): (&[Vec3], &[Vec3]),
    info: &Value,
) -> Result<(), String> {
    if let Some(cache) = files.mean.parent() {
        fs::create_dir_all(cache).map_err(|e| format!("cannot create {}: {e}", cache.display()))?;
    }
    let (w, h) = (options.width, options.height);
    crate::write_exr(&files.mean, w, h, mean)?;
    crate::write_exr(&files.variance, w, h, variance)?;
    crate::write_file(&files.info, info.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mitsuba::test_options;

    #[test]
    fn cache_files_follow_the_settings_and_the_scene() {
        let base = CacheFiles::of(&test_options(&[])).unwrap();
        let name = base
            .mean
            .file_name()
            .unwrap()
            .to_string_lossy()
            .into_owned();
        assert!(
            name.starts_with("reference-") && name.ends_with(".exr"),
            "{name}"
        );
        assert_eq!(base.mean, CacheFiles::of(&test_options(&[])).unwrap().mean);
        for changed in [
            &["--reference-spp", "512"][..],
            &["--resolution", "64x64"],
            &["--max-depth", "8"],
            &["--scene", "scenes/diffuse-only/scene.toml"],
            &["--scene", "scenes/veach-mis"],
        ] {
            assert_ne!(
                base.mean,
                CacheFiles::of(&test_options(changed)).unwrap().mean
            );
        }
        // Where the timed renders go does not matter to the reference.
        assert_eq!(
            base.mean.file_name(),
            CacheFiles::of(&test_options(&["--spp", "16"]))
                .unwrap()
                .mean
                .file_name()
        );
    }
}
