//! `cargo xtask rays bench`: times `accel::Bvh`'s ray queries alone on a
//! ray dump (`rays dump`), single-threaded, through the crate's public API
//! only: the BVH the renderer builds (default options) over the dumped
//! mesh, then each ray set one query after the other, several passes.
//!
//! Every pass gives the same hit count and sum of hit distances (checked):
//! the figures another ray tracer's harness reports on the same files, to
//! compare results before speed.

use std::fmt::Write as _;
use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::time::Instant;

use accel::{BuildOptions, Bvh};
use serde_json::{Value, json};

use super::files::{self, Query, Ray, SETS};

/// What `rays bench` times.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct BenchOptions {
    /// The dump folder.
    pub dir: PathBuf,
    /// Timed passes over each set (after one untimed warm-up pass).
    pub passes: usize,
}

/// One ray set's timing and result.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct SetTiming {
    pub name: &'static str,
    pub query: Query,
    pub rays: usize,
    /// Seconds of each timed pass, in order.
    pub seconds: Vec<f64>,
    /// Rays that hit something.
    pub hits: u64,
    /// Sum of the hit distances `t` of closest-hit queries (0 for any-hit).
    pub t_sum: f64,
}

impl SetTiming {
    /// Million rays per second of the median pass.
    pub(super) fn median_mrays(&self) -> f64 {
        let mut s = self.seconds.clone();
        s.sort_by(f64::total_cmp);
        let mid = s.len() / 2;
        let median = if s.len() % 2 == 1 {
            s[mid]
        } else {
            0.5 * (s[mid - 1] + s[mid])
        };
        self.rays as f64 / median / 1e6
    }

    /// Million rays per second of the fastest pass.
    pub(super) fn best_mrays(&self) -> f64 {
        let best = self.seconds.iter().copied().fold(f64::INFINITY, f64::min);
        self.rays as f64 / best / 1e6
    }
}

/// Runs `rays bench`: reads the dump, builds the BVH, times every set,
/// prints the table and writes `bench-rlt.md` and `bench-rlt.json` into
/// the dump folder.
pub(super) fn run(options: &BenchOptions) -> Result<(), String> {
    let (positions, triangles) = files::read_mesh(&options.dir)?;
    let started = Instant::now();
    let bvh = Bvh::build_indexed(&positions, &triangles, &[], BuildOptions::default());
    let build_s = started.elapsed().as_secs_f64();
    let mut timings = Vec::new();
    for &(name, query) in &SETS {
        let rays = files::read_rays(&options.dir, name)?;
        timings.push(time_set(&bvh, name, query, &rays, options.passes)?);
    }
    let md = markdown(&options.dir, triangles.len(), build_s, &timings);
    let doc = json!({
        "benchmark": "rays",
        "tracer": "rlt accel",
        "profile": if cfg!(debug_assertions) { "dev" } else { "release" },
        "dir": options.dir.display().to_string(),
        "triangles": triangles.len(),
        "build_seconds": build_s,
        "load_average": crate::load_average(),
        "sets": timings.iter().map(set_json).collect::<Vec<_>>(),
    });
    let (md_path, json_path) = crate::write_report(&options.dir, "bench-rlt", &md, &doc)?;
    print!("{md}");
    println!(
        "\nwritten: {} and {}",
        md_path.display(),
        json_path.display()
    );
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
) -> Result<SetTiming, String> {
    let expected = trace(bvh, query, rays);
    let mut seconds = Vec::with_capacity(passes);
    for _ in 0..passes {
        let started = Instant::now();
        let result = trace(bvh, query, black_box(rays));
        seconds.push(started.elapsed().as_secs_f64());
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
        hits: expected.0,
        t_sum: expected.1,
    })
}

/// One pass: the number of rays that hit and the sum of the closest hits'
/// `t` (in ray order, f64).
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

/// A set's JSON record.
fn set_json(t: &SetTiming) -> Value {
    json!({
        "name": t.name,
        "query": t.query.name(),
        "rays": t.rays,
        "seconds": t.seconds,
        "median_mrays_per_s": t.median_mrays(),
        "best_mrays_per_s": t.best_mrays(),
        "hits": t.hits,
        "t_sum": t.t_sum,
    })
}

/// The table of a run.
fn markdown(dir: &Path, triangles: usize, build_s: f64, timings: &[SetTiming]) -> String {
    let mut md = format!(
        "rlt accel on {} ({triangles} triangles, BVH built in {build_s:.3} s), 1 thread, \
         {} passes\n\n\
         | rays | query | count | median Mrays/s | best Mrays/s | hits | sum of t |\n\
         |---|---|---:|---:|---:|---:|---:|\n",
        dir.display(),
        timings.first().map_or(0, |t| t.seconds.len()),
    );
    for t in timings {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {:.2} | {:.2} | {} | {:.6e} |",
            t.name,
            t.query.name(),
            t.rays,
            t.median_mrays(),
            t.best_mrays(),
            t.hits,
            t.t_sum
        );
    }
    md
}
