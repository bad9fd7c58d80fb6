//! The timed renders: ours in-process through `integrators::Renderer`,
//! Mitsuba's through `xtask/scripts/mitsuba_pt.py` (once per `--mitsuba`
//! configuration), one image each.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use glam::Vec3;
use image_io::read_exr;
use integrators::{Regularization, RenderConfig, Renderer};
use scene::Scene;
use serde_json::Value;

use super::install::Mitsuba;
use super::process::run_with_timeout;
use super::xml::MitsubaScene;
use super::{MitsubaConfig, Options};

/// Sampler seeds: every image uses its own random numbers, so that no test
/// image shares samples with the reference (`SEED_REFERENCE`).
const SEED_TEST: u64 = 1;
const SEED_CHECK: u64 = 2;
/// The further seeds of `--seeds`: `SEED_MORE`, `SEED_MORE + 1`, ...
const SEED_MORE: u64 = 1000;

/// Every timed render, ours and Mitsuba's: `--spp` on all cores and (unless
/// `--no-single-thread`) on one, then `--check-spp` on all cores.
pub(super) fn render_all(
    root: &Path,
    scene: &Scene,
    options: &Options,
    mitsuba: &Mitsuba,
    mitsuba_scene: &MitsubaScene,
) -> Result<Vec<Run>, String> {
    let mut runs = Vec::new();
    for (job, repeat) in plan(options, crate::cores()) {
        // Alternating, so that other work on the machine hits all alike.
        let mut ours = None;
        let mut theirs = vec![None; options.mitsuba.len()];
        for _ in 0..repeat {
            merge(&mut ours, render_ours(scene, options, job)?);
            for (config, acc) in options.mitsuba.iter().zip(&mut theirs) {
                let run = render_mitsuba(root, mitsuba, mitsuba_scene, options, config, job)?;
                merge(acc, run);
            }
        }
        runs.extend(ours);
        runs.extend(theirs.into_iter().flatten());
    }
    add_seed_images(&mut runs, options, |job| {
        let mut images = vec![render_ours(scene, options, job)?.image];
        for config in &options.mitsuba {
            let run = render_mitsuba(root, mitsuba, mitsuba_scene, options, config, job)?;
            images.push(run.image);
        }
        Ok(images)
    })?;
    Ok(runs)
}

/// `--seeds`: renders `--spp` with every further seed on all cores, ours
/// and each Mitsuba configuration in turn (`render(job)`: their images in
/// that order), and gives each renderer's images to all its `--spp` runs
/// (a render's error does not depend on its thread count).
fn add_seed_images(
    runs: &mut [Run],
    options: &Options,
    mut render: impl FnMut(Job) -> Result<Vec<Vec<Vec3>>, String>,
) -> Result<(), String> {
    let labels: Vec<String> = std::iter::once(ours(options))
        .chain(options.mitsuba.iter().map(MitsubaConfig::label))
        .collect();
    for k in 1..u64::from(options.seeds) {
        let job = Job {
            spp: options.spp,
            seed: SEED_MORE + k - 1,
            threads: crate::cores(),
        };
        for (label, image) in labels.iter().zip(render(job)?) {
            for run in runs
                .iter_mut()
                .filter(|r| &r.renderer == label && r.spp == options.spp)
            {
                run.seed_images.push(image.clone());
            }
        }
    }
    Ok(())
}

/// The renders of [`render_all`] in order, with how often each is timed:
/// `--repeat` times only where the table's ratio is read (all cores,
/// `--spp`), once elsewhere.
fn plan(options: &Options, cores: usize) -> Vec<(Job, u32)> {
    let mut thread_counts = vec![cores];
    if options.single_thread && cores > 1 {
        thread_counts.push(1);
    }
    let mut plan = Vec::new();
    for &threads in &thread_counts {
        let repeat = if threads == cores { options.repeat } else { 1 };
        let job = Job {
            spp: options.spp,
            seed: SEED_TEST,
            threads,
        };
        plan.push((job, repeat));
    }
    if options.check_spp > 0 {
        let job = Job {
            spp: options.check_spp,
            seed: SEED_CHECK,
            threads: cores,
        };
        plan.push((job, 1));
    }
    plan
}

/// What to render: spp, seed, threads.
#[derive(Clone, Copy, Debug)]
pub(super) struct Job {
    pub(super) spp: u32,
    pub(super) seed: u64,
    pub(super) threads: usize,
}

impl Job {
    /// One of the further seeds of `--seeds`, rendered for its image only.
    fn is_further_seed(self) -> bool {
        self.seed >= SEED_MORE
    }

    /// Its images' file name after the renderer's: spp, threads and, for a
    /// further seed, the seed.
    fn file_stem(self) -> String {
        let Self { spp, seed, threads } = self;
        if self.is_further_seed() {
            format!("{spp}spp-{threads}t-seed{seed}")
        } else {
            format!("{spp}spp-{threads}t")
        }
    }
}

/// Adds `run`'s time to `acc` (a repeat of the same render), or starts it.
fn merge(acc: &mut Option<Run>, run: Run) {
    match acc {
        None => *acc = Some(run),
        Some(a) => {
            a.render_times.extend(run.render_times);
            a.render_s = fastest(&a.render_times);
        }
    }
}

/// One timed render and its image.
#[derive(Clone)]
pub(super) struct Run {
    /// [`ours`] or a [`MitsubaConfig::label`].
    pub(super) renderer: String,
    pub(super) threads: usize,
    pub(super) spp: u32,
    /// Acceleration-structure build (ours) or scene load (Mitsuba), seconds.
    pub(super) setup_s: f64,
    /// The fastest of `render_times`.
    pub(super) render_s: f64,
    /// Every repeat's render time (the image is the same each time).
    pub(super) render_times: Vec<f64>,
    pub(super) image: Vec<Vec3>,
    /// The same render with the further `--seeds` (untimed, all cores):
    /// errors are the mean over `image` and these.
    pub(super) seed_images: Vec<Vec<Vec3>>,
    pub(super) path: PathBuf,
    pub(super) note: String,
}

/// Our rows' label: "ours (pt)", "ours (vcm)", ...
pub(super) fn ours(options: &Options) -> String {
    format!("ours ({})", options.integrator.name())
}

fn config(options: &Options, seed: u64) -> RenderConfig {
    RenderConfig {
        algorithm: options.integrator,
        max_depth: options.max_depth,
        seed,
        regularization: Regularization::off(),
        ..Default::default()
    }
}

/// Renders `spp` iterations of one sample per pixel with our path tracer on
/// `threads` threads; returns the film's mean and variance of the mean.
/// Returns the film, the BVH build time, the render time and the number of
/// dropped NaN/inf samples.
pub(super) fn render_film(
    scene: &Scene,
    options: &Options,
    job: Job,
) -> Result<(integrators::Film, f64, Vec<f64>, u64), String> {
    let threads = job.threads;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| format!("cannot start {threads} render threads: {e}"))?;
    Ok(pool.install(|| {
        let t = Instant::now();
        let renderer = Renderer::new(scene.clone(), config(options, job.seed));
        let setup_s = t.elapsed().as_secs_f64();
        let mut film = renderer.new_film();
        let t = Instant::now();
        renderer.render(&mut film, 1, u64::from(job.spp));
        let times = vec![t.elapsed().as_secs_f64()];
        (film, setup_s, times, renderer.invalid_samples())
    }))
}

pub(super) fn fastest(times: &[f64]) -> f64 {
    times.iter().copied().fold(f64::INFINITY, f64::min)
}

fn seconds(times: &[f64]) -> String {
    let list: Vec<String> = times.iter().map(|t| format!("{t:.3}")).collect();
    list.join(", ")
}

fn render_ours(scene: &Scene, options: &Options, job: Job) -> Result<Run, String> {
    let Job { spp, threads, .. } = job;
    let (film, setup_s, render_times, invalid) = render_film(scene, options, job)?;
    let render_s = fastest(&render_times);
    let image = film.mean();
    let path = options.out.join(format!("ours-{}.exr", job.file_stem()));
    crate::write_exr(&path, options.width, options.height, &image)?;
    println!(
        "ours:    {spp:>5} spp, {threads} thread(s): render {} s (BVH {setup_s:.4} s) -> {}",
        seconds(&render_times),
        path.display()
    );
    Ok(Run {
        renderer: ours(options),
        threads,
        spp,
        setup_s,
        render_s,
        render_times,
        image,
        seed_images: Vec::new(),
        path,
        note: if invalid > 0 {
            format!("{invalid} NaN/inf samples dropped")
        } else {
            String::new()
        },
    })
}

fn render_mitsuba(
    root: &Path,
    mitsuba: &Mitsuba,
    mitsuba_scene: &MitsubaScene,
    options: &Options,
    config: &MitsubaConfig,
    job: Job,
) -> Result<Run, String> {
    let Job { spp, seed, threads } = job;
    let script = root.join("xtask/scripts/mitsuba_pt.py");
    let MitsubaConfig { variant, sampler } = config;
    let path = options.out.join(format!(
        "mitsuba-{variant}-{sampler}-{}.exr",
        job.file_stem()
    ));
    // Generous: 300 s plus 10 us per sample (Mitsuba does ~1e6 samples/s per core here).
    let samples = options.pixels() as f64 * f64::from(spp);
    let timeout = Duration::from_secs_f64(300.0 + 1e-5 * samples);
    let stdout = run_with_timeout(
        Command::new(&mitsuba.python)
            .arg(&script)
            .args(mitsuba_scene.script_args(options))
            .arg("--out")
            .arg(&path)
            .args(["--spp", &spp.to_string()])
            .args(["--seed", &seed.to_string()])
            .args(["--threads", &threads.to_string()])
            .args(["--variant", variant, "--sampler", sampler])
            .args(["--repeat", &in_process_repeats(config, job).to_string()]),
        timeout,
    )
    .map_err(|e| format!("mitsuba render failed: {e}"))?;
    let info: Value = stdout
        .lines()
        .rev()
        .find(|l| l.starts_with('{'))
        .and_then(|l| serde_json::from_str(l).ok())
        .ok_or_else(|| "mitsuba render printed no JSON result".to_string())?;
    let img = read_exr(&path).map_err(|e| format!("mitsuba image: {e}"))?;
    if img.pixels.len() != options.pixels() {
        return Err(format!(
            "mitsuba image is {}x{}, expected {}x{}",
            img.width, img.height, options.width, options.height
        ));
    }
    if info["threads"].as_u64() != Some(threads as u64) {
        return Err(format!(
            "mitsuba ran with {} threads, asked for {threads}",
            info["threads"]
        ));
    }
    if info["variant"].as_str() != Some(variant.as_str()) {
        return Err(format!(
            "mitsuba ran variant {}, asked for {variant}",
            info["variant"]
        ));
    }
    println!(
        "mitsuba: {spp:>5} spp, {threads} thread(s), {variant}, {sampler}: render {} s (load {:.3} s) -> {}",
        seconds(&times_of(&info)),
        info["load_s"].as_f64().unwrap_or(f64::NAN),
        path.display()
    );
    let render_times = times_of(&info);
    Ok(Run {
        renderer: config.label(),
        threads,
        spp,
        setup_s: info["load_s"].as_f64().unwrap_or(f64::NAN),
        render_s: fastest(&render_times),
        render_times,
        image: img.pixels,
        seed_images: Vec::new(),
        path,
        note: String::new(),
    })
}

/// Renders per Mitsuba process: an LLVM variant traces and compiles its
/// kernels in its first render of a process (from Dr.Jit's disk cache when it
/// has them), so it renders twice and the fastest (warm) time counts; once
/// for the untimed images of further seeds.
fn in_process_repeats(config: &MitsubaConfig, job: Job) -> u32 {
    if config.is_llvm() && !job.is_further_seed() {
        2
    } else {
        1
    }
}

fn times_of(info: &Value) -> Vec<f64> {
    info["render_s"]
        .as_array()
        .map(|a| a.iter().filter_map(Value::as_f64).collect())
        .unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plan_repeats_only_the_all_core_renders_at_spp() {
        let options = crate::mitsuba::test_options(&["--spp", "64", "--repeat", "3"]);
        let planned: Vec<(u32, u64, usize, u32)> = plan(&options, 4)
            .into_iter()
            .map(|(j, r)| (j.spp, j.seed, j.threads, r))
            .collect();
        assert_eq!(
            planned,
            [
                (64, SEED_TEST, 4, 3),
                (64, SEED_TEST, 1, 1),
                (16, SEED_CHECK, 4, 1)
            ]
        );
        assert_eq!(plan(&options, 1).len(), 2, "one core: no one-thread runs");
    }

    /// Each further seed's images go to every `--spp` run of their
    /// renderer, in seed order, and to no other run.
    #[test]
    fn seed_images_go_to_the_runs_at_spp() {
        let options = crate::mitsuba::test_options(&["--spp", "8", "--seeds", "3"]);
        let run = |renderer: String, spp: u32, threads: usize| Run {
            renderer,
            threads,
            spp,
            setup_s: 0.0,
            render_s: 1.0,
            render_times: vec![1.0],
            image: Vec::new(),
            seed_images: Vec::new(),
            path: PathBuf::new(),
            note: String::new(),
        };
        let (us, them) = (ours(&options), options.mitsuba[0].label());
        let mut runs = vec![
            run(us.clone(), 8, 2),
            run(them.clone(), 8, 2),
            run(us.clone(), 8, 1),
            run(us, 2, 2),
            run(them, 2, 2),
        ];
        let mut seeds = Vec::new();
        add_seed_images(&mut runs, &options, |job| {
            seeds.push(job.seed);
            let v = job.seed as f32;
            Ok(vec![vec![Vec3::splat(v)], vec![Vec3::splat(-v)]])
        })
        .unwrap();
        assert_eq!(seeds, [SEED_MORE, SEED_MORE + 1]);
        let firsts = |r: &Run| r.seed_images.iter().map(|i| i[0].x).collect::<Vec<_>>();
        let m = SEED_MORE as f32;
        assert_eq!(firsts(&runs[0]), [m, m + 1.0]);
        assert_eq!(firsts(&runs[1]), [-m, -m - 1.0]);
        assert_eq!(firsts(&runs[2]), [m, m + 1.0]);
        assert!(runs[3].seed_images.is_empty() && runs[4].seed_images.is_empty());
    }
}
