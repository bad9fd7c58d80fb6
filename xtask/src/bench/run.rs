//! The child process of `cargo xtask bench`: `xtask bench-run SCENE_FILE
//! INTEGRATOR WIDTH HEIGHT ITERATIONS` measures one (scene, integrator) run
//! and prints it as one JSON line on stdout. Hidden from `cargo xtask help`.
//!
//! One process per run, so that the peak memory it reads at its end
//! (VmHWM) is this run's and not the largest of all runs so far.

use std::fs;
use std::path::Path;
use std::time::Instant;

use glam::{UVec2, Vec3};
use integrators::{Algorithm, DEFAULT_TAU_0, Mode, Regularization, RenderConfig, Renderer};
use scene::{LoadOptions, RenderSettings};
use serde_json::json;

use crate::study::cpu_seconds;

/// Runs `xtask bench-run ARGS`.
pub fn child(args: &[String]) -> Result<(), String> {
    let [scene_file, integrator, width, height, iterations] = args else {
        return Err(
            "usage: xtask bench-run SCENE_FILE INTEGRATOR WIDTH HEIGHT ITERATIONS \
                    (spawned by `cargo xtask bench`)"
                .into(),
        );
    };
    let algorithm: Algorithm = integrator.parse().map_err(|e| format!("bench-run: {e}"))?;
    let positive = |name: &str, s: &str| {
        s.parse::<u32>()
            .ok()
            .filter(|&n| n > 0)
            .ok_or_else(|| format!("bench-run: {name}: expected a positive integer, got '{s}'"))
    };
    let (w, h) = (positive("WIDTH", width)?, positive("HEIGHT", height)?);
    let iterations = u64::from(positive("ITERATIONS", iterations)?);

    // Build: scene load, then Renderer::new (BVH, lights); build_seconds is both.
    let started = Instant::now();
    let options = LoadOptions {
        resolution: Some(UVec2::new(w, h)),
        ..Default::default()
    };
    let scene = scene::load(Path::new(scene_file), &options).map_err(|e| e.to_string())?;
    let load_seconds = started.elapsed().as_secs_f64();
    let triangles = scene.triangles.len();
    let config = render_config(&scene.render, algorithm)?;
    let renderer = Renderer::new(scene, config);
    let build_seconds = started.elapsed().as_secs_f64();

    // One untimed iteration first: page faults, rayon's thread start-up.
    let mut film = renderer.new_film();
    let mut estimates = vec![Vec3::ZERO; w as usize * h as usize];
    let t = Instant::now();
    renderer.render_iteration(1, &mut estimates);
    film.add_iteration(&estimates);
    let warmup_seconds = t.elapsed().as_secs_f64();

    // The timed iterations: rendering and accumulation, as a render does.
    let rays_before = renderer.rays_traced();
    let cpu_before = cpu_seconds();
    let t = Instant::now();
    for n in 2..=iterations + 1 {
        renderer.render_iteration(n, &mut estimates);
        film.add_iteration(&estimates);
    }
    let seconds = t.elapsed().as_secs_f64();
    let cpu = cpu_before.zip(cpu_seconds()).map(|(a, b)| (b - a).max(0.0));
    let rays = renderer.rays_traced() - rays_before;
    let samples = u64::from(w) * u64::from(h) * iterations;

    let config = renderer.config();
    let line = json!({
        "width": w,
        "height": h,
        "iterations": iterations,
        "max_depth": config.max_depth,
        "regularize": config.regularization.mode.name(),
        "tau0": config.regularization.schedule.tau_0(),
        "threads": rayon::current_num_threads(),
        "triangles": triangles,
        "load_seconds": load_seconds,
        "build_seconds": build_seconds,
        "warmup_seconds": warmup_seconds,
        "seconds": seconds,
        "cpu_seconds": cpu,
        "samples": samples,
        "rays": rays,
        "invalid_samples": renderer.invalid_samples(),
        "peak_rss_mib": peak_rss_mib(),
        "seconds_per_iteration": seconds / iterations as f64,
        "samples_per_second": samples as f64 / seconds,
        "rays_per_second": rays as f64 / seconds,
        "rays_per_sample": rays as f64 / samples as f64,
    });
    println!("{line}");
    Ok(())
}

/// The settings `render-cli` would pick for the scene's manifest (max
/// depth, regularization mode and tau_0; their defaults where the manifest
/// is silent), with the run's integrator: the throughput a user of the
/// scene sees.
fn render_config(manifest: &RenderSettings, algorithm: Algorithm) -> Result<RenderConfig, String> {
    let defaults = RenderConfig::default();
    let mode = match manifest.regularize.as_deref() {
        Some(name) => name.parse::<Mode>().map_err(|e| e.to_string())?,
        None => defaults.regularization.mode,
    };
    let tau0 = manifest.tau0.unwrap_or(DEFAULT_TAU_0);
    Ok(RenderConfig {
        algorithm,
        max_depth: manifest.max_depth.unwrap_or(defaults.max_depth),
        regularization: Regularization::new(mode, tau0, true).map_err(|e| e.to_string())?,
        ..defaults
    })
}

/// Peak resident set size of this process so far, in MiB (`VmHWM` of
/// /proc/self/status); None where /proc does not tell.
fn peak_rss_mib() -> Option<f64> {
    let status = fs::read_to_string("/proc/self/status").ok()?;
    let kib = status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))?
        .trim()
        .trim_end_matches("kB")
        .trim()
        .parse::<f64>()
        .ok()?;
    Some(kib / 1024.0)
}
