//! `cargo xtask mitsuba`: our path tracer against Mitsuba 3's `scalar_rgb`
//! path tracer on the same scene, at the same samples per pixel, by wall
//! time and by error against one reference.
//!
//! What it does, in order:
//! 1. loads the scene with `scene::load` and exports it to a Mitsuba 3 scene
//!    (`<out>/mitsuba-scene/scene.xml`, one binary PLY per material, written
//!    from our world-space triangles; see [`export`] for the mapping);
//! 2. finds Mitsuba (`<out>/venv`, else the system `python3`), or installs it
//!    into `<out>/venv` with `python3 -m venv` and `pip install mitsuba`;
//! 3. renders a reference with our renderer at `--reference-spp` (cached in
//!    `<out>/cache/`, keyed by the settings and the scene's files: delete
//!    that folder after changing the renderer; for a manifest or a Mitsuba
//!    scene file, every file under its folder);
//! 4. renders with both renderers at `--spp` (with all cores, and with one
//!    core unless `--no-single-thread`) and at `--check-spp` (all cores),
//!    timing the render call only; with `--seeds N`, N - 1 more `--spp`
//!    renders per renderer with other seeds (untimed, all cores), whose
//!    errors are averaged with the first's;
//! 5. compares every image with the reference (RMSE, relMSE, efficiency
//!    1/(time MSE), time-to-equal-error ratio against Mitsuba) and checks
//!    that the two renderers estimate the same image (image means, and
//!    noise-normalised block means), then writes `<out>/report.md` and
//!    `<out>/report.json`.
//!
//! **XML mode.** When `--scene` is a Mitsuba scene file (`.xml`, or a folder
//! whose scene file is `scene.xml`), there is no export: Mitsuba renders that
//! file itself, with the comparison's settings substituted (see [`xml`]:
//! integrator `path` with `--max-depth` and rr_depth 3, film of
//! `--resolution` with a box filter, the configuration's sampler with
//! sample_count = spp; everything else as the file has it) and the file's
//! folder on Mitsuba's file resolver, and our side loads the same file with
//! `scene::load`. Steps 1 and 2 become: find Mitsuba, let it load the file
//! once (no render), then load it ourselves. This compares our reading of a
//! Mitsuba scene with Mitsuba's as well as the two renderers.
//!
//! Timings are only meaningful in a release build: when this binary is a
//! debug build (as `cargo xtask` builds it), it runs itself again through
//! `cargo run --release -p xtask -- mitsuba ...` and passes the arguments on.
//!
//! No light transport happens here: our images come from the `integrators`
//! library, Mitsuba's from `xtask/scripts/mitsuba_pt.py`.
//!
//! - this file: flags, the release re-run, the steps above in order
//! - `export`: the scene as Mitsuba 3 XML and binary PLY meshes
//! - `xml`: the XML mode (a Mitsuba scene file rendered as itself)
//! - `install`: finding Mitsuba, or installing it with pip
//! - `process`: child processes with captured output and a watchdog
//! - `render`: the timed renders, ours in-process and Mitsuba's script
//! - `reference`: our reference image and its cache
//! - `compare`: per-channel errors, agreement beyond noise, the bias fit
//! - `report`: report.md and report.json

mod compare;
mod export;
mod install;
mod process;
mod reference;
mod render;
mod report;
mod xml;

use std::fs;
use std::path::{Path, PathBuf};
use std::time::Instant;

use glam::UVec2;
use scene::{LoadOptions, Scene};

use export::{Exported, export};
use install::ensure_mitsuba;
use reference::reference;
use render::render_all;
use report::Report;
use xml::MitsubaScene;

pub const USAGE: &str =
    "  mitsuba [options] compare our path tracer with Mitsuba 3's `path` integrator
                    on one scene: export, render both, error against a
                    reference of ours, time to equal error; writes
                    <out>/report.md and report.json. Runs itself in release
                    (timings need it).
      --scene PATH          scene (default scenes/cornell-box/scene.toml): a
                            manifest, model or folder, exported for Mitsuba;
                            or a Mitsuba scene file (.xml, or a folder with a
                            scene.xml), which Mitsuba renders as it is but with
                            this comparison's integrator (path, --max-depth),
                            film (--resolution, box filter) and sampler (spp)
                            and our side loads with scene::load. The copy
                            Mitsuba loads is <out>/mitsuba-xml/scene.xml
      --mitsuba LIST        Mitsuba configurations, comma-separated, each
                            VARIANT[:SAMPLER]: variant scalar_rgb or
                            llvm_ad_rgb (vectorized; needs libLLVM, installed
                            with apt-get when missing and run as root),
                            sampler independent, stratified, multijitter,
                            orthogonal or ldsampler (default independent).
                            The first is the one ratios are taken against
                            (default scalar_rgb:independent). Time to equal
                            error against Mitsuba's fastest:
                            --mitsuba llvm_ad_rgb:multijitter,scalar_rgb
      --spp N               samples per pixel of the timed renders (default 64)
      --resolution WxH      image size (default 512x512)
      --max-depth D         longest path in segments, both renderers (default 16)
      --reference-spp M     spp of our reference (default 1024; >= 16x --spp
                            keeps its own error small). Cached in <out>/cache
                            by settings: delete it after renderer changes
      --check-spp K         spp of a second pair of renders (all cores, one
                            repeat) for the convergence rate and the floor fit
                            (default spp/4; 0 skips them)
      --repeat R            time each all-core --spp render R times and report
                            the fastest (default 2; the machine may be shared)
      --seeds N             the MSE at --spp is the mean over N sampler seeds
                            (default 1): N - 1 more renders per renderer, all
                            cores, untimed. On a scene whose error is a few
                            rare bright samples (Veach's MIS scene) one seed's
                            MSE is luck; the report lists every seed's
      --no-single-thread    skip the one-thread renders
      --integrator NAME     ours: pt (default), bpt, ppm, bpm or vcm, for our
                            reference and our timed renders (unregularized);
                            Mitsuba always runs `path`, so its image against
                            our bpt or vcm reference checks that both
                            estimate one image
      --out DIR             output folder (default target/mitsuba)
                            (relative paths are from the workspace root)";

/// The reference's sampler seed (see `render::SEED_TEST`).
const SEED_REFERENCE: u64 = 0x5EED_0000_0000_0001;

/// Set on the release child so that a release profile with debug
/// assertions cannot loop.
const CHILD_ENV: &str = "RLT_XTASK_MITSUBA_CHILD";

#[derive(Clone, Debug)]
pub(super) struct Options {
    pub(super) scene: PathBuf,
    pub(super) spp: u32,
    pub(super) width: u32,
    pub(super) height: u32,
    pub(super) max_depth: u32,
    pub(super) reference_spp: u32,
    pub(super) check_spp: u32,
    pub(super) repeat: u32,
    /// Sampler seeds whose mean MSE the `--spp` rows report (`--seeds`).
    pub(super) seeds: u32,
    pub(super) single_thread: bool,
    pub(super) out: PathBuf,
    /// Mitsuba's configurations; ratios are against the first.
    pub(super) mitsuba: Vec<MitsubaConfig>,
    /// Our integrator, for the reference and the timed renders (`--integrator`).
    pub(super) integrator: integrators::Algorithm,
}

/// Mitsuba variants this task knows how to run (`mi.set_variant`).
const VARIANTS: [&str; 2] = ["scalar_rgb", "llvm_ad_rgb"];

/// Mitsuba 3 samplers (plugin names) that take `sample_count`.
const SAMPLERS: [&str; 5] = [
    "independent",
    "stratified",
    "multijitter",
    "orthogonal",
    "ldsampler",
];

/// One Mitsuba configuration: a variant and a sampler.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(super) struct MitsubaConfig {
    pub(super) variant: String,
    pub(super) sampler: String,
}

impl MitsubaConfig {
    /// `VARIANT[:SAMPLER]`.
    fn parse(s: &str) -> Result<Self, String> {
        let (variant, sampler) = s
            .trim()
            .split_once(':')
            .unwrap_or((s.trim(), "independent"));
        if !VARIANTS.contains(&variant) {
            return Err(format!(
                "--mitsuba: unknown variant `{variant}` (expected {})",
                VARIANTS.join(" or ")
            ));
        }
        if !SAMPLERS.contains(&sampler) {
            return Err(format!(
                "--mitsuba: unknown sampler `{sampler}` (expected one of {})",
                SAMPLERS.join(", ")
            ));
        }
        Ok(Self {
            variant: variant.into(),
            sampler: sampler.into(),
        })
    }

    /// The name of its rows in the report.
    pub(super) fn label(&self) -> String {
        format!("mitsuba 3 (path, {}, {})", self.variant, self.sampler)
    }

    /// Whether this is the vectorized LLVM variant (JIT-compiled kernels).
    pub(super) fn is_llvm(&self) -> bool {
        self.variant.starts_with("llvm")
    }
}

impl Options {
    fn parse(root: &Path, args: &[String]) -> Result<Self, String> {
        let mut o = Self {
            scene: root.join("scenes/cornell-box/scene.toml"),
            spp: 64,
            width: 512,
            height: 512,
            max_depth: 16,
            reference_spp: 1024,
            check_spp: u32::MAX,
            repeat: 2,
            seeds: 1,
            single_thread: true,
            out: root.join("target/mitsuba"),
            mitsuba: vec![MitsubaConfig::parse("scalar_rgb")?],
            integrator: integrators::Algorithm::Pt,
        };
        let mut it = args.iter();
        while let Some(flag) = it.next() {
            if flag == "--no-single-thread" {
                o.single_thread = false;
                continue;
            }
            let value = it
                .next()
                .ok_or_else(|| format!("{flag} needs a value\n\n{USAGE}"))?;
            let number = |what: &str| -> Result<u32, String> {
                value
                    .parse::<u32>()
                    .map_err(|_| format!("{what}: expected a whole number, got `{value}`"))
            };
            match flag.as_str() {
                "--scene" => o.scene = root.join(value),
                "--spp" => o.spp = number("--spp")?,
                "--max-depth" => o.max_depth = number("--max-depth")?,
                "--reference-spp" => o.reference_spp = number("--reference-spp")?,
                "--check-spp" => o.check_spp = number("--check-spp")?,
                "--repeat" => o.repeat = number("--repeat")?.max(1),
                "--seeds" => o.seeds = number("--seeds")?,
                "--out" => o.out = root.join(value),
                "--integrator" => {
                    o.integrator = value.parse().map_err(|e| format!("--integrator: {e}"))?;
                }
                "--mitsuba" => {
                    o.mitsuba = value
                        .split(',')
                        .map(MitsubaConfig::parse)
                        .collect::<Result<_, _>>()?;
                    let repeated =
                        (1..o.mitsuba.len()).any(|i| o.mitsuba[..i].contains(&o.mitsuba[i]));
                    if repeated {
                        return Err("--mitsuba: give each configuration once".into());
                    }
                }
                "--resolution" => {
                    let size = crate::study::parse_resolution(value)?;
                    (o.width, o.height) = (size.x, size.y);
                }
                other => return Err(format!("unknown option `{other}`\n\nusage:\n{USAGE}")),
            }
        }
        if let Some(file) = xml::scene_file(&o.scene) {
            o.scene = file;
        }
        if o.spp == 0 || o.reference_spp == 0 || o.seeds == 0 || o.width == 0 || o.height == 0 {
            return Err(
                "--spp, --reference-spp, --seeds and the resolution must be positive".into(),
            );
        }
        if o.check_spp == u32::MAX {
            o.check_spp = o.spp / 4;
        }
        if o.check_spp == o.spp {
            o.check_spp = 0;
        }
        if o.reference_spp < 16 * o.spp {
            println!(
                "warning: --reference-spp {} is below 16x --spp {}: the reference's own error is not negligible (the report removes an estimate of it)",
                o.reference_spp, o.spp
            );
        }
        if o.max_depth == 0 {
            return Err("--max-depth must be at least 1 (1: emitters seen directly)".into());
        }
        Ok(o)
    }

    pub(super) fn pixels(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// Whether `--scene` is a Mitsuba scene file (the XML mode, see [`xml`]).
    pub(super) fn is_xml(&self) -> bool {
        xml::is_xml(&self.scene)
    }
}

/// Runs `cargo xtask mitsuba ARGS` (in a release build: see the module docs).
pub fn run(root: &Path, args: &[String]) -> Result<(), String> {
    let options = Options::parse(root, args)?;
    if cfg!(debug_assertions) && std::env::var_os(CHILD_ENV).is_none() {
        return crate::rerun_in_release(root, "mitsuba", args, CHILD_ENV);
    }
    let started = Instant::now();
    let load_before = crate::load_average();
    fs::create_dir_all(&options.out)
        .map_err(|e| format!("cannot create {}: {e}", options.out.display()))?;
    if cfg!(debug_assertions) {
        println!("warning: this is a debug build; timings are not release numbers");
    }
    let (scene, scene_load_s, mitsuba, mitsuba_scene) = if options.is_xml() {
        // Mitsuba first: a file it refuses is not worth our reference.
        let mitsuba = find_mitsuba(&options)?;
        let mitsuba_scene = xml::check(root, &mitsuba, &options)?;
        let (scene, scene_load_s) = load_scene(&options)?;
        println!(
            "scene: ours: {} triangles, {} spheres, loaded in {scene_load_s:.3} s",
            scene.triangles.len(),
            scene.spheres.len()
        );
        (scene, scene_load_s, mitsuba, mitsuba_scene)
    } else {
        let (scene, scene_load_s) = load_scene(&options)?;
        let exported = export_scene(&scene, &options, scene_load_s)?;
        let mitsuba = find_mitsuba(&options)?;
        (
            scene,
            scene_load_s,
            mitsuba,
            MitsubaScene::Exported(exported),
        )
    };
    let reference = reference(&scene, &options)?;
    let runs = render_all(root, &scene, &options, &mitsuba, &mitsuba_scene)?;
    let context = (
        &options,
        crate::cores(),
        &mitsuba,
        scene_load_s,
        load_before,
    );
    Report::new(context, &reference, &runs).write(&options.out, started.elapsed().as_secs_f64())
}

/// Mitsuba with every configuration's variant, and says which.
fn find_mitsuba(options: &Options) -> Result<install::Mitsuba, String> {
    let mitsuba = ensure_mitsuba(&options.out, &options.mitsuba)?;
    println!("mitsuba: {} ({})", mitsuba.version, mitsuba.how);
    Ok(mitsuba)
}

/// Our scene at the options' resolution, and the seconds loading took.
fn load_scene(options: &Options) -> Result<(Scene, f64), String> {
    let t = Instant::now();
    let scene = scene::load(
        &options.scene,
        &LoadOptions {
            resolution: Some(UVec2::new(options.width, options.height)),
            ..Default::default()
        },
    )
    .map_err(|e| format!("cannot load the scene: {e}"))?;
    Ok((scene, t.elapsed().as_secs_f64()))
}

/// Exports `scene` to `<out>/mitsuba-scene/` and says so.
fn export_scene(scene: &Scene, options: &Options, scene_load_s: f64) -> Result<Exported, String> {
    let exported = export(scene, options, &options.out.join("mitsuba-scene"))?;
    println!(
        "scene: {} ({} triangles, loaded in {scene_load_s:.3} s); Mitsuba export: {} ({})",
        options.scene.display(),
        scene.triangles.len(),
        exported.xml.display(),
        exported.summary
    );
    Ok(exported)
}

/// The options of `args` (flags as string slices) with the workspace as
/// the root, for tests.
#[cfg(test)]
fn test_options(args: &[&str]) -> Options {
    let args: Vec<String> = args.iter().map(|s| s.to_string()).collect();
    Options::parse(&crate::workspace_root(), &args).unwrap()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn options_parse_and_reject_bad_values() {
        let root = Path::new("/r");
        let args: Vec<String> = [
            "--spp",
            "8",
            "--resolution",
            "64x32",
            "--no-single-thread",
            "--seeds",
            "5",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        let o = Options::parse(root, &args).unwrap();
        assert_eq!(
            (o.spp, o.width, o.height, o.single_thread, o.seeds),
            (8, 64, 32, false, 5)
        );
        assert_eq!(o.out, Path::new("/r/target/mitsuba"));
        assert_eq!(
            o.mitsuba[0].label(),
            "mitsuba 3 (path, scalar_rgb, independent)"
        );
        let args: Vec<String> = ["--mitsuba", "llvm_ad_rgb:multijitter,scalar_rgb"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        let o = Options::parse(root, &args).unwrap();
        assert_eq!(
            o.mitsuba.iter().map(|c| c.label()).collect::<Vec<_>>(),
            [
                "mitsuba 3 (path, llvm_ad_rgb, multijitter)",
                "mitsuba 3 (path, scalar_rgb, independent)"
            ]
        );
        for bad in [
            &["--spp"][..],
            &["--spp", "x"],
            &["--resolution", "64"],
            &["--max-depth", "0"],
            &["--seeds", "0"],
            &["--frobnicate", "1"],
            &["--mitsuba", "cuda_rgb"],
            &["--mitsuba", "scalar_rgb:sobol"],
            &["--mitsuba", "scalar_rgb,scalar_rgb:independent"],
        ] {
            let bad: Vec<String> = bad.iter().map(|s| s.to_string()).collect();
            let e = Options::parse(root, &bad).unwrap_err();
            assert!(!e.is_empty());
        }
    }
}
