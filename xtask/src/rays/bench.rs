//! `cargo xtask rays bench`: times `accel::Bvh`'s ray queries alone on a
//! ray dump (`rays dump`), single-threaded, through the crate's public API
//! only: the BVH the renderer builds (default options) over the dumped
//! mesh, then each ray set one query after the other, several passes.
//!
//! A pass is timed by the CPU time of the tracing thread where the system
//! gives it (unix, `clock_gettime(CLOCK_THREAD_CPUTIME_ID)`), else by the
//! wall clock: on a shared machine the wall clock also counts the time the
//! thread waited for a core. The wall-clock figures are kept beside them.
//!
//! Every pass gives the same hit count and sum of hit distances (checked):
//! the figures another ray tracer's harness reports on the same files, to
//! compare results before speed.

use std::fmt::Write as _;
use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::time::Instant;

use accel::{BatchRay, BuildOptions, Bvh, NO_SURFACE};
use serde_json::{Value, json};

use super::files::{self, Query, Ray, SETS};

/// What `rays bench` times.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct BenchOptions {
    /// The dump folder.
    pub dir: PathBuf,
    /// Timed passes over each set (after one untimed warm-up pass).
    pub passes: usize,
    /// The BVH's tree layout.
    pub layout: accel::Layout,
    /// The instruction set of its node and leaf tests.
    pub isa: accel::Isa,
    /// Rays per batch query (`Bvh::intersect_batch`, `occluded_batch`);
    /// 0: one query per ray.
    pub batch: usize,
}

/// One ray set's timing and result.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct SetTiming {
    pub name: &'static str,
    pub query: Query,
    pub rays: usize,
    /// Seconds of each timed pass, in order: the thread's CPU time where
    /// [`thread_cpu_seconds`] is available, else the wall clock.
    pub seconds: Vec<f64>,
    /// Wall-clock seconds of each timed pass.
    pub wall_seconds: Vec<f64>,
    /// Rays that hit something.
    pub hits: u64,
    /// Sum of the hit distances `t` of closest-hit queries (0 for any-hit).
    pub t_sum: f64,
}

impl SetTiming {
    /// Million rays per second of the median pass.
    pub(super) fn median_mrays(&self) -> f64 {
        self.rays as f64 / median(&self.seconds) / 1e6
    }

    /// Million rays per second of the median pass by the wall clock.
    pub(super) fn median_wall_mrays(&self) -> f64 {
        self.rays as f64 / median(&self.wall_seconds) / 1e6
    }

    /// Million rays per second of the fastest pass.
    pub(super) fn best_mrays(&self) -> f64 {
        let best = self.seconds.iter().copied().fold(f64::INFINITY, f64::min);
        self.rays as f64 / best / 1e6
    }
}

/// The median of `values` (not empty).
fn median(values: &[f64]) -> f64 {
    let mut s = values.to_vec();
    s.sort_by(f64::total_cmp);
    let mid = s.len() / 2;
    if s.len() % 2 == 1 {
        s[mid]
    } else {
        0.5 * (s[mid - 1] + s[mid])
    }
}

/// CPU seconds the calling thread has run, with nanosecond resolution.
#[cfg(unix)]
fn thread_cpu_seconds() -> Option<f64> {
    use nix::time::{ClockId, clock_gettime};
    let t = clock_gettime(ClockId::CLOCK_THREAD_CPUTIME_ID).ok()?;
    Some(t.tv_sec() as f64 + t.tv_nsec() as f64 * 1e-9)
}

/// No thread CPU clock here: passes are timed by the wall clock.
#[cfg(not(unix))]
fn thread_cpu_seconds() -> Option<f64> {
    None
}

/// What the passes' main figures measure.
fn clock_name() -> &'static str {
    if thread_cpu_seconds().is_some() {
        "thread CPU time"
    } else {
        "wall clock"
    }
}

/// Runs `rays bench`: reads the dump, builds the BVH, times every set,
/// prints the table and writes `bench-rlt.md` and `bench-rlt.json` into
/// the dump folder.
pub(super) fn run(options: &BenchOptions) -> Result<(), String> {
    let (positions, triangles) = files::read_mesh(&options.dir)?;
    let started = Instant::now();
    let build = BuildOptions {
        layout: options.layout,
        ..BuildOptions::default()
    };
    let mut bvh = Bvh::build_indexed(&positions, &triangles, &[], build);
    let build_s = started.elapsed().as_secs_f64();
    if !bvh.set_isa(options.isa) {
        return Err(format!("--isa: this CPU lacks {:?}", options.isa));
    }
    let mut timings = Vec::new();
    for &(name, query) in &SETS {
        let rays = files::read_rays(&options.dir, name)?;
        timings.push(time_set(
            &bvh,
            name,
            query,
            &rays,
            options.passes,
            options.batch,
        )?);
    }
    let md = markdown(&options.dir, triangles.len(), build_s, &timings);
    let doc = json!({
        "benchmark": "rays",
        "tracer": "rlt accel",
        "layout": format!("{:?}", bvh.layout()),
        "isa": format!("{:?}", options.isa),
        "profile": if cfg!(debug_assertions) { "dev" } else { "release" },
        "dir": options.dir.display().to_string(),
        "triangles": triangles.len(),
        "build_seconds": build_s,
        "clock": clock_name(),
        "load_average": crate::load_average(),
        "sets": timings.iter().map(set_json).collect::<Vec<_>>(),
    });
    crate::publish_report(&options.dir, "bench-rlt", &md, &doc)?;
    Ok(())
}

/// Times `passes` passes of `query` over `rays` after a warm-up pass; an
/// error if two passes disagree on the result.
pub(super) fn time_set(
    bvh: &Bvh,
    name: &'static str,
    query: Query,
    rays: &[Ray],
    passes: usize,
    batch: usize,
) -> Result<SetTiming, String> {
    let batch_rays: Vec<BatchRay> = rays
        .iter()
        .map(|r| BatchRay {
            origin: r.origin,
            direction: r.direction,
            t_max: r.t_max,
            skip: [NO_SURFACE; 2],
        })
        .collect();
    let trace = |rays: &[Ray]| {
        if batch == 0 {
            trace(bvh, query, rays)
        } else {
            trace_batches(bvh, query, &batch_rays, batch)
        }
    };
    let expected = trace(rays);
    let (mut seconds, mut wall_seconds) = (Vec::new(), Vec::new());
    for _ in 0..passes {
        let cpu_start = thread_cpu_seconds();
        let started = Instant::now();
        let result = trace(black_box(rays));
        let wall = started.elapsed().as_secs_f64();
        wall_seconds.push(wall);
        seconds.push(match (cpu_start, thread_cpu_seconds()) {
            (Some(a), Some(b)) => b - a,
            _ => wall,
        });
        if result != expected {
            return Err(format!(
                "{name} rays: a pass found {result:?} (hits, sum of t), the first {expected:?}"
            ));
        }
    }
    Ok(SetTiming {
        name,
        query,
        rays: rays.len(),
        seconds,
        wall_seconds,
        hits: expected.0,
        t_sum: expected.1,
    })
}

/// One pass: the number of rays that hit and the sum of the closest hits'
/// `t` (in ray order, f64). Never inlined: a symbol to which profilers
/// can restrict their counts (`valgrind --toggle-collect`).
#[inline(never)]
fn trace(bvh: &Bvh, query: Query, rays: &[Ray]) -> (u64, f64) {
    let (mut hits, mut t_sum) = (0, 0.0);
    match query {
        Query::Closest => {
            for r in rays {
                if let Some(hit) = bvh.intersect(r.origin, r.direction, r.t_max) {
                    hits += 1;
                    t_sum += f64::from(hit.t);
                }
            }
        }
        Query::Any => {
            for r in rays {
                hits += u64::from(bvh.occluded(r.origin, r.direction, r.t_max));
            }
        }
    }
    (hits, t_sum)
}

/// [`trace`] in batch queries of `batch` rays.
#[inline(never)]
fn trace_batches(bvh: &Bvh, query: Query, rays: &[BatchRay], batch: usize) -> (u64, f64) {
    let (mut hits, mut t_sum) = (0, 0.0);
    let mut found = vec![None; batch];
    let mut occluded = vec![false; batch];
    for rays in rays.chunks(batch) {
        match query {
            Query::Closest => {
                let found = &mut found[..rays.len()];
                bvh.intersect_batch(rays, found);
                for hit in found.iter().flatten() {
                    hits += 1;
                    t_sum += f64::from(hit.t);
                }
            }
            Query::Any => {
                let occluded = &mut occluded[..rays.len()];
                bvh.occluded_batch(rays, occluded);
                hits += occluded.iter().filter(|&&o| o).count() as u64;
            }
        }
    }
    (hits, t_sum)
}

/// A set's JSON record.
fn set_json(t: &SetTiming) -> Value {
    json!({
        "name": t.name,
        "query": t.query.name(),
        "rays": t.rays,
        "seconds": t.seconds,
        "wall_seconds": t.wall_seconds,
        "median_mrays_per_s": t.median_mrays(),
        "median_wall_mrays_per_s": t.median_wall_mrays(),
        "best_mrays_per_s": t.best_mrays(),
        "hits": t.hits,
        "t_sum": t.t_sum,
    })
}

/// The table of a run.
fn markdown(dir: &Path, triangles: usize, build_s: f64, timings: &[SetTiming]) -> String {
    let mut md = format!(
        "rlt accel on {} ({triangles} triangles, BVH built in {build_s:.3} s), 1 thread, \
         {} passes timed by {}\n\n\
         | rays | query | count | median Mrays/s | best Mrays/s | wall median Mrays/s | hits | sum of t |\n\
         |---|---|---:|---:|---:|---:|---:|---:|\n",
        dir.display(),
        timings.first().map_or(0, |t| t.seconds.len()),
        clock_name(),
    );
    for t in timings {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {:.2} | {:.2} | {:.2} | {} | {:.6e} |",
            t.name,
            t.query.name(),
            t.rays,
            t.median_mrays(),
            t.best_mrays(),
            t.median_wall_mrays(),
            t.hits,
            t.t_sum
        );
    }
    md
}
