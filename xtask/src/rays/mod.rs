//! `cargo xtask rays dump|bench`: ray-query throughput on its own, apart
//! from shading, on files another ray tracer can read (an Embree harness,
//! for instance; docs/benchmarks.md, "Ray throughput against Embree").
//!
//! `bench` timings are only meaningful in a release build: when this
//! binary is a debug build, `rays bench` runs `cargo run --release -p xtask
//! -- rays bench ...` and passes the arguments on (as `mitsuba` does).
//!
//! - `files`: the dump's file layout (plain little-endian arrays)
//! - `dump`: scene -> mesh and ray sets, through the renderer's loader
//! - `bench`: times `accel::Bvh` on a dump

mod bench;
mod dump;
mod files;

use std::path::{Path, PathBuf};

use glam::UVec2;

use bench::BenchOptions;
use dump::{DumpOptions, Source};

/// The task's lines in `cargo xtask help`.
pub const USAGE: &str =
    "  rays dump|bench   ray-query throughput alone, on files another ray tracer reads
  rays dump (--scene PATH | --height-field N) --out DIR [options]
                    writes the scene's triangles in world space
                    (mesh.vertices: 3 f32 a vertex, mesh.indices: 3 u32 a
                    triangle) and three ray sets made as the path tracer
                    makes them (7 f32 a ray: origin, direction, t_max):
                    camera.rays (one per pixel centre), diffuse.rays (a
                    cosine-distributed bounce at each camera hit, from the
                    renderer's offset origin) and shadow.rays (a light
                    sample at each camera hit, any-hit), and rays.json.
                    Scenes with analytic spheres or alpha-tested materials
                    are refused (the files hold opaque triangles only)
      --scene PATH          scene file or folder (the renderer's loaders)
      --height-field N      instead: the generated height field of `bench
                            --scaling` with about N triangles (written to
                            DIR/terrain-N-obj/)
      --resolution WxH      image size (default: the scene's)
      --seed N              seed of the bounces and light samples (default 1)
      --out DIR             output folder
  rays bench --dir DIR [--passes N] [--layout L] [--isa I] [--batch N]
                    times accel::Bvh (default build, the renderer's) on a
                    dump, one thread: closest hit for camera and diffuse
                    rays, any hit for shadow rays; median and best Mrays/s
                    of N passes (default 9) after a warm-up, timed by the
                    thread's CPU time (the wall clock beside it), hits and
                    sum of hit t (to compare results with another tracer).
                    Writes DIR/bench-rlt.md and .json. Runs itself as a
                    release build
      --layout L            wide (the default, the renderer's: compressed
                            nodes; no tree for up to 64 triangles on an
                            AVX-512 CPU), bvh8 (float nodes, SIMD node tests,
                            leaves of up to 4 triangles tested at once),
                            binary, or flat (no tree, up to 64 primitives):
                            accel's layouts
      --isa I               best (default), baseline (SSE4.2), avx2 or avx512:
                            the instruction set of bvh8's and flat's tests
      --batch N             queries of N rays at once (Bvh::intersect_batch,
                            occluded_batch: packets of rays in scenes of up
                            to 64 primitives); 0 (default) one ray a query";

/// Timed passes per set when `--passes` is not given.
const DEFAULT_PASSES: usize = 9;
/// Seed of the dump's random numbers when `--seed` is not given.
const DEFAULT_SEED: u64 = 1;
/// Set on the release child so that a release profile with debug
/// assertions cannot loop.
const CHILD_ENV: &str = "RLT_XTASK_RAYS_CHILD";

/// Runs `cargo xtask rays ARGS`.
pub fn run(root: &Path, args: &[String]) -> Result<(), String> {
    match args.first().map(String::as_str) {
        Some("dump") => match parse_dump(root, &args[1..])? {
            Some(options) => dump::run(&options),
            None => help(),
        },
        Some("bench") => {
            let Some(options) = parse_bench(root, &args[1..])? else {
                return help();
            };
            if cfg!(debug_assertions) && std::env::var_os(CHILD_ENV).is_none() {
                return crate::rerun_in_release(root, "rays", args, CHILD_ENV);
            }
            bench::run(&options)
        }
        Some("-h" | "--help") | None => help(),
        Some(other) => Err(format!(
            "unknown `rays` command `{other}` (dump or bench; see `cargo xtask rays --help`)"
        )),
    }
}

/// Prints the usage.
fn help() -> Result<(), String> {
    println!("{USAGE}");
    Ok(())
}

/// `args` as (flag, value) pairs (`--flag value` or `--flag=value`);
/// `Ok(None)` when help is asked for. Flags must be in `known`.
fn flag_values<'a>(
    args: &'a [String],
    known: &[&str],
) -> Result<Option<Vec<(&'a str, &'a str)>>, String> {
    let mut pairs = Vec::new();
    let mut rest = args.iter();
    while let Some(arg) = rest.next() {
        if matches!(arg.as_str(), "-h" | "--help") {
            return Ok(None);
        }
        let (flag, inline) = match arg.split_once('=') {
            Some((f, v)) if f.starts_with("--") => (f, Some(v)),
            _ => (arg.as_str(), None),
        };
        if !known.contains(&flag) {
            return Err(format!(
                "unknown option '{arg}' (see `cargo xtask rays --help`)"
            ));
        }
        let value = match inline {
            Some(v) => v,
            None => rest
                .next()
                .ok_or_else(|| format!("{flag}: missing value"))?,
        };
        pairs.push((flag, value));
    }
    Ok(Some(pairs))
}

/// A path given on the command line, relative to the current folder (or,
/// where that is unknown, to `root`).
fn path_arg(root: &Path, value: &str) -> PathBuf {
    let base = std::env::current_dir().unwrap_or_else(|_| root.to_path_buf());
    base.join(value)
}

/// Parses `rays dump` flags.
fn parse_dump(root: &Path, args: &[String]) -> Result<Option<DumpOptions>, String> {
    let known = [
        "--scene",
        "--height-field",
        "--resolution",
        "--seed",
        "--out",
    ];
    let Some(pairs) = flag_values(args, &known)? else {
        return Ok(None);
    };
    let (mut source, mut resolution, mut seed, mut out) = (None, None, DEFAULT_SEED, None);
    for (flag, value) in pairs {
        let number = || {
            value
                .parse::<u64>()
                .map_err(|_| format!("{flag}: '{value}' is not a whole number"))
        };
        match flag {
            "--scene" | "--height-field" if source.is_some() => {
                return Err("give one of --scene and --height-field".into());
            }
            "--scene" => source = Some(Source::Scene(path_arg(root, value))),
            "--height-field" => match number()? {
                0 => return Err("--height-field: the triangle count must be positive".into()),
                n => source = Some(Source::HeightField(n)),
            },
            "--resolution" => resolution = Some(parse_resolution(value)?),
            "--seed" => seed = number()?,
            _ => out = Some(path_arg(root, value)),
        }
    }
    Ok(Some(DumpOptions {
        source: source.ok_or("rays dump: give --scene PATH or --height-field N")?,
        resolution,
        seed,
        out: out.ok_or("rays dump: give --out DIR")?,
    }))
}

/// `WxH` with both positive.
fn parse_resolution(value: &str) -> Result<UVec2, String> {
    let bad = || format!("--resolution: '{value}' is not WxH with positive W and H");
    let (w, h) = value.split_once('x').ok_or_else(bad)?;
    match (w.parse::<u32>(), h.parse::<u32>()) {
        (Ok(w), Ok(h)) if w > 0 && h > 0 => Ok(UVec2::new(w, h)),
        _ => Err(bad()),
    }
}

/// Parses `rays bench` flags.
fn parse_bench(root: &Path, args: &[String]) -> Result<Option<BenchOptions>, String> {
    let Some(pairs) = flag_values(args, &["--dir", "--passes", "--layout", "--isa", "--batch"])?
    else {
        return Ok(None);
    };
    let (mut dir, mut passes, mut batch) = (None, DEFAULT_PASSES, 0);
    let (mut layout, mut isa) = (accel::Layout::default(), accel::Isa::default());
    for (flag, value) in pairs {
        match flag {
            "--dir" => dir = Some(path_arg(root, value)),
            "--layout" => {
                layout = match value {
                    "bvh8" => accel::Layout::Bvh8,
                    "wide" => accel::Layout::Wide,
                    "binary" => accel::Layout::Binary,
                    "flat" => accel::Layout::Flat,
                    _ => {
                        return Err(format!(
                            "--layout: '{value}' is not bvh8, wide, binary or flat"
                        ));
                    }
                }
            }
            "--isa" => {
                isa = match value {
                    "best" => accel::Isa::Best,
                    "baseline" => accel::Isa::Baseline,
                    "avx2" => accel::Isa::Avx2,
                    "avx512" => accel::Isa::Avx512,
                    _ => {
                        return Err(format!(
                            "--isa: '{value}' is not best, baseline, avx2 or avx512"
                        ));
                    }
                }
            }
            "--batch" => {
                batch = value
                    .parse::<usize>()
                    .map_err(|_| format!("--batch: '{value}' is not a whole number"))?;
            }
            _ => {
                passes = match value.parse::<usize>() {
                    Ok(n) if n > 0 => n,
                    _ => {
                        return Err(format!(
                            "--passes: '{value}' is not a positive whole number"
                        ));
                    }
                };
            }
        }
    }
    Ok(Some(BenchOptions {
        dir: dir.ok_or("rays bench: give --dir DIR (a `rays dump` folder)")?,
        passes,
        layout,
        isa,
        batch,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn strings(args: &[&str]) -> Vec<String> {
        args.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn options_parse_and_reject_bad_values() {
        let root = Path::new("/r");
        let o = parse_dump(
            root,
            &strings(&[
                "--height-field",
                "1000",
                "--resolution=64x32",
                "--out",
                "/d",
            ]),
        )
        .unwrap()
        .unwrap();
        assert_eq!(o.source, Source::HeightField(1000));
        assert_eq!(o.resolution, Some(UVec2::new(64, 32)));
        assert_eq!((o.seed, o.out.as_path()), (DEFAULT_SEED, Path::new("/d")));
        let o = parse_bench(root, &strings(&["--dir", "/d", "--passes", "3"]))
            .unwrap()
            .unwrap();
        assert_eq!((o.dir.as_path(), o.passes), (Path::new("/d"), 3));
        assert_eq!((o.layout, o.isa), (accel::Layout::Wide, accel::Isa::Best));
        let o = parse_bench(
            root,
            &strings(&["--dir=/d", "--layout=bvh8", "--isa=baseline"]),
        )
        .unwrap()
        .unwrap();
        assert_eq!(
            (o.layout, o.isa),
            (accel::Layout::Bvh8, accel::Isa::Baseline)
        );
        assert_eq!(parse_bench(root, &strings(&["--help"])).unwrap(), None);
        for bad in [
            &["--scene", "a", "--height-field", "5", "--out", "/d"][..],
            &["--scene", "a"],
            &["--out", "/d"],
            &["--height-field", "0", "--out", "/d"],
            &["--scene", "a", "--resolution", "64", "--out", "/d"],
            &["--scene", "a", "--resolution", "0x4", "--out", "/d"],
            &["--scene", "a", "--out"],
            &["--frobnicate", "1"],
        ] {
            assert!(parse_dump(root, &strings(bad)).is_err(), "{bad:?}");
        }
        for bad in [
            &["--passes", "0", "--dir", "/d"][..],
            &["--passes", "2"],
            &["--dir", "/d", "--layout", "cwbvh"],
            &["--dir", "/d", "--isa", "sse2"],
        ] {
            assert!(parse_bench(root, &strings(bad)).is_err(), "{bad:?}");
        }
    }

    /// A dump of a bundled Cornell box at 16x16 read back and timed: the
    /// bench agrees with the dump (each camera hit gave a diffuse ray, in
    /// pixel order), and no diffuse ray hits the triangle it leaves
    /// (origins offset as the renderer does; a flat triangle cannot be
    /// hit again by a ray leaving it).
    #[test]
    fn dump_reads_back_and_bounces_clear_their_surface() {
        let out = std::env::temp_dir().join(format!("rlt-rays-dump-{}", std::process::id()));
        let options = DumpOptions {
            source: Source::Scene(crate::workspace_root().join("scenes/cornell-box")),
            resolution: Some(UVec2::new(16, 16)),
            seed: DEFAULT_SEED,
            out: out.clone(),
        };
        dump::run(&options).unwrap();
        let (positions, triangles) = files::read_mesh(&out).unwrap();
        let bvh = accel::Bvh::build_indexed(&positions, &triangles, &[], Default::default());
        let timing = |(name, query): (&'static str, files::Query)| {
            let rays = files::read_rays(&out, name).unwrap();
            (
                bench::time_set(&bvh, name, query, &rays, 1, 0).unwrap(),
                rays,
            )
        };
        let [(camera, camera_rays), (diffuse, diffuse_rays), (shadow, _)] = files::SETS.map(timing);
        assert_eq!(camera.rays, 16 * 16);
        assert!(camera.hits > 0 && camera.t_sum > 0.0);
        assert_eq!(diffuse.rays as u64, camera.hits);
        assert!(shadow.rays > 0 && shadow.hits < shadow.rays as u64);
        let left = camera_rays
            .iter()
            .filter_map(|r| bvh.intersect(r.origin, r.direction, r.t_max));
        for (from, r) in left.zip(&diffuse_rays) {
            let again = bvh.intersect(r.origin, r.direction, r.t_max);
            assert!(
                again.is_none_or(|h| h.primitive != from.primitive),
                "{r:?} hits its own triangle {} again",
                from.primitive
            );
        }
        std::fs::remove_dir_all(&out).unwrap();
    }
}
