//! Our reference image at `--reference-spp`, with the variance of its
//! pixel means, cached in `<out>/cache/`.

use std::fs;
use std::path::{Path, PathBuf};

use glam::Vec3;
use image_io::{read_exr, write_exr};
use scene::Scene;
use serde_json::{Value, json};

use super::render::{Job, fastest, render_film};
use super::{Options, SEED_REFERENCE};

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
    let mut key = Fnv::new();
    key.write(
        format!(
            "reference v1|{}x{}|depth {}|spp {}|seed {SEED_REFERENCE}",
            options.width, options.height, options.max_depth, options.reference_spp
        )
        .as_bytes(),
    );
    // The settings and the scene's files; not the renderer's sources (they
    // change all the time): after a change to the renderer, delete
    // <out>/cache. A stale reference shows as our own image disagreeing
    // with it in the report's agreement table.
    let mut files = Vec::new();
    if let Some(dir) = options.scene.parent() {
        collect_files(dir, &mut files);
    }
    files.sort();
    for f in &files {
        key.write(f.to_string_lossy().as_bytes());
        key.write(&fs::read(f).unwrap_or_default());
    }
    let stem = format!("reference-{:016x}", key.finish());
    let cache = options.out.join("cache");
    let mean_path = cache.join(format!("{stem}.exr"));
    let var_path = cache.join(format!("{stem}-variance-of-mean.exr"));
    let info_path = cache.join(format!("{stem}.json"));
    if let (Ok(mean), Ok(var), Ok(info)) = (
        read_exr(&mean_path),
        read_exr(&var_path),
        fs::read_to_string(&info_path),
    ) && mean.pixels.len() == options.pixels()
        && var.pixels.len() == options.pixels()
    {
        let render_s = serde_json::from_str::<Value>(&info)
            .ok()
            .and_then(|v| v["render_s"].as_f64())
            .unwrap_or(f64::NAN);
        println!(
            "reference: ours at {} spp, cached ({}; rendered in {render_s:.1} s)",
            options.reference_spp,
            mean_path.display()
        );
        return Ok(Reference {
            spp: options.reference_spp,
            mean: mean.pixels,
            variance_of_mean: var.pixels,
            path: mean_path,
            render_s,
            cached: true,
        });
    }
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
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
    fs::create_dir_all(&cache).map_err(|e| format!("cannot create {}: {e}", cache.display()))?;
    let (w, h) = (options.width, options.height);
    write_exr(&mean_path, w, h, &mean).map_err(|e| e.to_string())?;
    write_exr(&var_path, w, h, &variance_of_mean).map_err(|e| e.to_string())?;
    let info = json!({ "spp": options.reference_spp, "render_s": render_s, "threads": cores });
    fs::write(&info_path, info.to_string())
        .map_err(|e| format!("cannot write {}: {e}", info_path.display()))?;
    println!(
        "reference: rendered in {render_s:.1} s -> {}",
        mean_path.display()
    );
    Ok(Reference {
        spp: options.reference_spp,
        mean,
        variance_of_mean,
        path: mean_path,
        render_s,
        cached: false,
    })
}

fn collect_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        if path.is_dir() {
            collect_files(&path, out);
        } else {
            out.push(path);
        }
    }
}

/// FNV-1a, 64 bit: a stable hash for cache keys.
struct Fnv(u64);

impl Fnv {
    fn new() -> Self {
        Self(0xcbf2_9ce4_8422_2325)
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0 ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3);
        }
        // Separates consecutive writes ("ab","c" vs "a","bc").
        self.0 = (self.0 ^ 0xff).wrapping_mul(0x0100_0000_01b3);
    }
    fn finish(&self) -> u64 {
        self.0
    }
}
