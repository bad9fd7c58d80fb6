//! The report: a table of times and errors, the agreement of both
//! renderers with the reference, warnings; `report.md` and `report.json`.

use std::fmt::Write as _;
use std::path::Path;

use serde_json::{Value, json};

use super::Options;
use super::compare::{
    Agreement, BLOCKS, Errors, ReferenceError, agreement, floor_fit, reference_floor, run_errors,
};
use super::install::Mitsuba;
use super::reference::Reference;
use super::render::{Run, ours};

/// Above this relative difference of the image means the two renderers do
/// not render the same scene (the export, or in the XML mode our reading of
/// the scene file, is suspect, not the comparison).
const MEAN_TOLERANCE: f64 = 0.03;

/// Largest |z| of an image mean (per channel) before the report calls it a
/// disagreement beyond noise.
const Z_ALARM: f64 = 5.0;

/// Largest root mean square of the block z-scores (1 for pure noise) before
/// the report calls it a disagreement. Single blocks are not judged: with
/// few samples per block the z-score is skewed (rare bright paths).
const BLOCK_RMS_ALARM: f64 = 1.5;

/// One row of the table: a run, its errors, and its time-to-equal-error
/// ratios against the anchor (the first `--mitsuba` configuration) at the
/// same spp and threads.
struct RowMetrics<'a> {
    run: &'a Run,
    /// The mean over its seeds of `per_seed`.
    raw: Errors,
    /// Each seed's errors (its image's, then `--seeds`'), raw.
    per_seed: Vec<Errors>,
    /// Errors less the reference's own error (clamped at 0).
    corrected: Errors,
    ratio_raw: Option<f64>,
    ratio_corrected: Option<f64>,
    ratio_rel_raw: Option<f64>,
}

/// Finds the all-core runs of a renderer at `--spp` and `--check-spp`.
struct Levels<'a> {
    options: &'a Options,
    runs: &'a [Run],
    cores: usize,
}

impl Levels<'_> {
    /// The index of `name`'s all-core run at `spp`.
    fn level(&self, name: &str, spp: u32) -> Option<usize> {
        self.runs
            .iter()
            .position(|r| r.renderer == name && r.spp == spp && r.threads == self.cores)
    }

    /// The indices of `name`'s all-core runs at `--spp` and `--check-spp`.
    fn two_levels(&self, name: &str) -> Option<(usize, usize)> {
        if self.options.check_spp == 0 {
            return None;
        }
        Some((
            self.level(name, self.options.spp)?,
            self.level(name, self.options.check_spp)?,
        ))
    }
}

/// The reference's own error (see [`ReferenceError`]) from its variances,
/// our all-core error at `--spp` (`raw`, one per run) and Mitsuba's two
/// spp levels.
fn reference_error(levels: &Levels, reference: &Reference, raw: &[Errors]) -> ReferenceError {
    let options = levels.options;
    let from_variance = reference_floor(reference);
    let extrapolated = levels
        .level(&ours(options), options.spp)
        .map_or(from_variance, |i| {
            let f = f64::from(options.spp) / f64::from(options.reference_spp);
            Errors {
                mse: (raw[i].mse * f).min(from_variance.mse),
                rel_mse: (raw[i].rel_mse * f).min(from_variance.rel_mse),
            }
        });
    ReferenceError {
        from_variance,
        used: extrapolated,
        mitsuba_floor: levels
            .two_levels(&levels.options.mitsuba[0].label())
            .map(|(a, b)| floor_fit(&levels.runs[a], &levels.runs[b], &reference.mean)),
    }
}

/// One row per run: its errors, raw and less the reference's own.
fn rows<'a>(
    runs: &'a [Run],
    raw: Vec<(Errors, Vec<Errors>)>,
    reference_error: &ReferenceError,
) -> Vec<RowMetrics<'a>> {
    runs.iter()
        .zip(raw)
        .map(|(run, (raw, per_seed))| RowMetrics {
            run,
            raw,
            per_seed,
            corrected: Errors {
                mse: (raw.mse - reference_error.used.mse).max(0.0),
                rel_mse: (raw.rel_mse - reference_error.used.rel_mse).max(0.0),
            },
            ratio_raw: None,
            ratio_corrected: None,
            ratio_rel_raw: None,
        })
        .collect()
}

/// Time to equal error relative to the anchor at the same spp and threads:
/// (t MSE)_row / (t MSE)_anchor, raw, reference-corrected and by relMSE.
fn set_ratios_to_anchor(rows: &mut [RowMetrics], anchor: &str) {
    let work = |r: &RowMetrics, e: Errors| (r.run.render_s * e.mse, r.run.render_s * e.rel_mse);
    let baselines: Vec<_> = rows
        .iter()
        .filter(|r| r.run.renderer == anchor)
        .map(|r| {
            (
                r.run.spp,
                r.run.threads,
                work(r, r.raw),
                work(r, r.corrected),
            )
        })
        .collect();
    for r in rows {
        if let Some(&(_, _, (m_raw, m_rel), (m_cor, _))) = baselines
            .iter()
            .find(|b| b.0 == r.run.spp && b.1 == r.run.threads)
        {
            let (raw, rel) = work(r, r.raw);
            let (cor, _) = work(r, r.corrected);
            r.ratio_raw = Some(raw / m_raw);
            r.ratio_rel_raw = Some(rel / m_rel);
            r.ratio_corrected = (m_cor > 0.0).then(|| cor / m_cor);
        }
    }
}

/// (renderer, spp, agreement with the reference) of every all-core run.
fn agreements(
    rows: &[RowMetrics],
    reference: &Reference,
    options: &Options,
    cores: usize,
) -> Vec<(String, u32, Agreement)> {
    rows.iter()
        .filter(|r| r.run.threads == cores)
        .map(|r| {
            let a = agreement(&r.run.image, &reference.mean, options.width, options.height);
            (r.run.renderer.clone(), r.run.spp, a)
        })
        .collect()
}

/// Per renderer, the rate of MSE ~ spp^-rate between its two spp levels:
/// rate = ln(MSE_1 / MSE_2) / ln(spp_2 / spp_1), on reference-corrected MSEs.
fn convergence(rows: &[RowMetrics], levels: &Levels) -> Vec<(String, f64)> {
    let (n1, n2) = (
        f64::from(levels.options.spp),
        f64::from(levels.options.check_spp),
    );
    let mitsuba = levels.options.mitsuba.iter().map(|c| c.label());
    std::iter::once(ours(levels.options))
        .chain(mitsuba)
        .filter_map(|name| {
            let (a, b) = levels.two_levels(&name)?;
            let (ea, eb) = (rows[a].corrected.mse, rows[b].corrected.mse);
            (ea > 0.0 && eb > 0.0).then(|| (name, (ea / eb).ln() / (n2 / n1).ln()))
        })
        .collect()
}

impl RowMetrics<'_> {
    fn samples_per_s(&self, pixels: usize) -> f64 {
        pixels as f64 * f64::from(self.run.spp) / self.run.render_s
    }
    fn efficiency(&self) -> f64 {
        1.0 / (self.run.render_s * self.raw.mse)
    }
}

pub(super) struct Report<'a> {
    options: &'a Options,
    cores: usize,
    mitsuba_version: String,
    mitsuba_how: String,
    reference: &'a Reference,
    reference_error: ReferenceError,
    rows: Vec<RowMetrics<'a>>,
    /// (renderer, spp, agreement with the reference) for all-core runs.
    agreements: Vec<(String, u32, Agreement)>,
    /// Per renderer: MSE ~ spp^-rate between --spp and --check-spp (1 for
    /// plain Monte Carlo), from reference-corrected MSEs.
    convergence: Vec<(String, f64)>,
    /// The label of the configuration ratios are taken against.
    anchor: String,
    scene_load_s: f64,
    load_average: (String, String),
}

impl<'a> Report<'a> {
    /// Errors, ratios, agreement and convergence of every run; `context` is
    /// (options, cores, Mitsuba, scene load seconds, load average before).
    pub(super) fn new(
        context: (&'a Options, usize, &Mitsuba, f64, String),
        reference: &'a Reference,
        runs: &'a [Run],
    ) -> Self {
        let (options, cores, mitsuba, scene_load_s, load_before) = context;
        let levels = Levels {
            options,
            runs,
            cores,
        };
        let raw: Vec<(Errors, Vec<Errors>)> = runs
            .iter()
            .map(|run| run_errors(run, &reference.mean))
            .collect();
        let means: Vec<Errors> = raw.iter().map(|(mean, _)| *mean).collect();
        let reference_error = reference_error(&levels, reference, &means);
        let mut rows = rows(runs, raw, &reference_error);
        let anchor = options.mitsuba[0].label();
        set_ratios_to_anchor(&mut rows, &anchor);
        let agreements = agreements(&rows, reference, options, cores);
        let convergence = convergence(&rows, &levels);
        Self {
            options,
            cores,
            mitsuba_version: mitsuba.version.clone(),
            mitsuba_how: mitsuba.how.clone(),
            reference,
            reference_error,
            rows,
            agreements,
            convergence,
            anchor,
            scene_load_s,
            load_average: (load_before, crate::load_average()),
        }
    }

    /// Warnings: the two renderers do not estimate the same image.
    fn alarms(&self) -> Vec<String> {
        let mut alarms = Vec::new();
        for (name, spp, a) in &self.agreements {
            if a.mean_rel_diff.iter().any(|d| d.abs() > MEAN_TOLERANCE) {
                let suspect = if self.options.is_xml() {
                    "our reading of the scene file"
                } else {
                    "the export"
                };
                alarms.push(format!(
                    "{name} @ {spp} spp: the image mean differs from the reference's by more than {:.0} % \
                     (if Mitsuba's: {suspect} is suspect: emitter side, fov, colours)",
                    100.0 * MEAN_TOLERANCE
                ));
            } else if a.z_image.iter().any(|z| z.abs() > Z_ALARM) || a.z_block_rms > BLOCK_RMS_ALARM
            {
                alarms.push(format!(
                    "{name} @ {spp} spp: differs from the reference beyond noise \
                     (image |z| > {Z_ALARM} or block z rms > {BLOCK_RMS_ALARM})"
                ));
            }
        }
        if let Some((c, se)) = self.reference_error.mitsuba_floor {
            let bound = self.reference_error.from_variance.mse;
            if c - 3.0 * se > bound {
                alarms.push(format!(
                    "Mitsuba's error levels off at MSE {c:.3e} +- {se:.1e}, above the reference's own error bound {bound:.3e}: \
                     a bias between the renderers of RMS about {:.3e} per pixel and channel",
                    (c - self.reference_error.used.mse).max(0.0).sqrt()
                ));
            }
        }
        alarms
    }

    fn markdown(&self, total_s: f64, alarms: &[String]) -> String {
        let mut md = String::new();
        self.md_settings(&mut md);
        self.md_reference(&mut md);
        self.md_times_and_errors(&mut md);
        self.md_convergence(&mut md);
        self.md_agreement(&mut md);
        self.md_bias_and_warnings(&mut md, alarms);
        let _ = writeln!(
            md,
            "\nScene load (ours) {:.3} s; whole command {total_s:.1} s.",
            self.scene_load_s
        );
        md
    }

    /// The title and the settings: scene, Mitsuba, machine, how times are taken.
    fn md_settings(&self, md: &mut String) {
        let o = self.options;
        let _ = writeln!(md, "# {} vs Mitsuba 3 (`path`)\n", ours(o));
        let _ = writeln!(
            md,
            "Scene `{}`{} at {}x{}, max depth {} (segments), Russian roulette from depth 3, box filter, \
             regularization off. Mitsuba {} (`path`; {}): {}; ratios are against the first. \
             Machine: {} logical cores, load average {} before and {} after (other work on the \
             machine slows both renderers). Times: the render call only, release build, fastest of \
             {} alternating runs (ours, Mitsuba, ours, ...) at all cores and `--spp`, one run otherwise; \
             an LLVM variant renders twice per run and its second (warm: kernels traced and compiled) \
             time counts.\n",
            o.scene.display(),
            if o.is_xml() {
                " (a Mitsuba scene file: Mitsuba renders it itself with these settings \
                 substituted, we load it with `scene::load`)"
            } else {
                " (exported for Mitsuba)"
            },
            o.width,
            o.height,
            o.max_depth,
            self.mitsuba_version,
            self.mitsuba_how,
            o.mitsuba
                .iter()
                .map(|c| format!("`{}` with the `{}` sampler", c.variant, c.sampler))
                .collect::<Vec<_>>()
                .join(", "),
            self.cores,
            self.load_average.0,
            self.load_average.1,
            o.repeat,
        );
    }

    /// The reference and its own error.
    fn md_reference(&self, md: &mut String) {
        let o = self.options;
        let re = &self.reference_error;
        let _ = writeln!(
            md,
            "Reference: ours at {} spp ({}, {:.1} s, `{}`), seeds independent of the test images. \
             Its own error, which adds to every MSE below: MSE {:.3e}, relMSE {:.3e} (ours at {} spp \
             scaled by {}/{}: the most it can be if our error falls at least as fast as 1/spp; the \
             looser bound from its pixel variances is MSE {:.3e}, relMSE {:.3e}). The last column \
             removes it.\n",
            self.reference.spp,
            if self.reference.cached {
                "cached"
            } else {
                "rendered now"
            },
            self.reference.render_s,
            self.reference.path.display(),
            re.used.mse,
            re.used.rel_mse,
            o.spp,
            o.spp,
            self.reference.spp,
            re.from_variance.mse,
            re.from_variance.rel_mse,
        );
    }

    /// The table: a row per run, times, errors and ratios to the anchor.
    fn md_times_and_errors(&self, md: &mut String) {
        let o = self.options;
        let pixels = o.pixels();
        md.push_str(
            "| renderer | threads | spp | time (s) | samples/s | RMSE | relMSE | efficiency 1/(t MSE) | time to equal MSE vs anchor | same, reference error removed | time to equal relMSE vs anchor | BVH build / scene load (s) |\n\
             |---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
        );
        let ratio = |r: Option<f64>| r.map_or("-".to_string(), |r| format!("{r:.3}"));
        for r in &self.rows {
            let _ = writeln!(
                md,
                "| {} | {} | {} | {:.3} | {:.3e} | {:.4e} | {:.4e} | {:.3e} | {} | {} | {} | {:.4} |",
                r.run.renderer,
                r.run.threads,
                r.run.spp,
                r.run.render_s,
                r.samples_per_s(pixels),
                r.raw.mse.sqrt(),
                r.raw.rel_mse,
                r.efficiency(),
                ratio(r.ratio_raw),
                ratio(r.ratio_corrected),
                ratio(r.ratio_rel_raw),
                r.run.setup_s,
            );
        }
        let _ = writeln!(
            md,
            "\nTime to equal MSE = (t MSE)_row / (t MSE)_anchor at the same spp and threads, the anchor \
             being {}: the time a row takes to reach its MSE over the time the anchor needs for that MSE \
             (exact when the anchor's MSE falls as 1/time, as with independent samples; stratified \
             samplers and our Owen-scrambled Sobol fall faster, rate below, so then the ratio depends on \
             the spp); below 1, the row is faster.",
            self.anchor
        );
        self.md_seeds(md);
    }

    /// With `--seeds`: every seed's RMSE of the `--spp` rows.
    fn md_seeds(&self, md: &mut String) {
        let o = self.options;
        if o.seeds < 2 {
            return;
        }
        let _ = writeln!(
            md,
            "\nErrors at {} spp are means over {} sampler seeds (one render each, the first timed). \
             RMSE per seed:\n",
            o.spp, o.seeds
        );
        for r in self.rows.iter().filter(|r| r.per_seed.len() > 1) {
            let each: Vec<String> = r
                .per_seed
                .iter()
                .map(|e| format!("{:.4e}", e.mse.sqrt()))
                .collect();
            let _ = writeln!(
                md,
                "- {}, {} thread(s): {}",
                r.run.renderer,
                r.run.threads,
                each.join(", ")
            );
        }
    }

    /// The rate of MSE ~ spp^-rate per renderer.
    fn md_convergence(&self, md: &mut String) {
        if !self.convergence.is_empty() {
            md.push_str("\nMSE ~ spp^-rate between the two spp levels (reference error removed; 1 = plain Monte Carlo):");
            for (name, rate) in &self.convergence {
                let _ = write!(md, " {name} {rate:.2};");
            }
            md.push('\n');
        }
    }

    /// The agreement table: image means and z-scores against the reference.
    fn md_agreement(&self, md: &mut String) {
        let _ = writeln!(md, "\n## Agreement: do both render the same image?\n");
        let _ = writeln!(
            md,
            "d = image - reference per pixel; z = sum d / sqrt(sum d^2) per channel, over the image \
             and over {BLOCKS}x{BLOCKS} blocks, is about N(0, 1) when both are unbiased estimates of \
             one image (skewed at few samples per block). Ours against our reference is the control.\n"
        );
        md.push_str(
            "| image | mean rel. diff R, G, B | image z R, G, B | block z rms | largest block z (x, y, ch) |\n\
             |---|---|---|---:|---|\n",
        );
        for (name, spp, a) in &self.agreements {
            let _ = writeln!(
                md,
                "| {name} @ {spp} spp | {:+.3} %, {:+.3} %, {:+.3} % | {:+.2}, {:+.2}, {:+.2} | {:.2} | {:+.2} ({}, {}, {}) |",
                100.0 * a.mean_rel_diff[0],
                100.0 * a.mean_rel_diff[1],
                100.0 * a.mean_rel_diff[2],
                a.z_image[0],
                a.z_image[1],
                a.z_image[2],
                a.z_block_rms,
                a.z_block_max.0,
                a.z_block_max.1,
                a.z_block_max.2,
                ["R", "G", "B"][a.z_block_max.3],
            );
        }
    }

    /// The bias test of Mitsuba's error floor, and the warnings.
    fn md_bias_and_warnings(&self, md: &mut String, alarms: &[String]) {
        let re = &self.reference_error;
        if let Some((c, se)) = re.mitsuba_floor {
            let _ = writeln!(
                md,
                "\nBias test: Mitsuba's MSE = a/spp + c over its two spp levels gives c = {c:.3e} +- {se:.1e} \
                 (the reference's error plus the squared bias between the renderers; the reference's error \
                 is at most {:.3e}).",
                re.from_variance.mse
            );
        }
        if alarms.is_empty() {
            md.push_str("\nNo disagreement beyond noise.\n");
        } else {
            md.push_str("\n**Warnings**\n\n");
            for a in alarms {
                let _ = writeln!(md, "- {a}");
            }
        }
    }

    fn json(&self, total_s: f64, alarms: &[String]) -> Value {
        let o = self.options;
        let pixels = o.pixels();
        let re = &self.reference_error;
        json!({
            "scene": o.scene.display().to_string(),
            "mitsuba_scene": if o.is_xml() { "file" } else { "export" },
            "width": o.width,
            "height": o.height,
            "max_depth": o.max_depth,
            "rr_depth": 3,
            "repeat": o.repeat,
            "seeds": o.seeds,
            "cores": self.cores,
            "load_average_before": self.load_average.0,
            "load_average_after": self.load_average.1,
            "mitsuba_version": self.mitsuba_version,
            "mitsuba_install": self.mitsuba_how,
            "anchor": self.anchor,
            "reference": {
                "spp": self.reference.spp,
                "path": self.reference.path.display().to_string(),
                "cached": self.reference.cached,
                "render_s": self.reference.render_s,
                "error_bound_from_variance_mse": re.from_variance.mse,
                "error_bound_from_variance_rel_mse": re.from_variance.rel_mse,
                "removed_mse": re.used.mse,
                "removed_rel_mse": re.used.rel_mse,
                "mitsuba_floor_mse": re.mitsuba_floor.map(|f| f.0),
                "mitsuba_floor_mse_standard_error": re.mitsuba_floor.map(|f| f.1),
            },
            "rows": self.rows.iter().map(|r| json!({
                "renderer": r.run.renderer,
                "threads": r.run.threads,
                "spp": r.run.spp,
                "render_s": r.run.render_s,
                "render_s_all_repeats": r.run.render_times,
                "setup_s": r.run.setup_s,
                "samples_per_s": r.samples_per_s(pixels),
                "mse": r.raw.mse,
                "mse_per_seed": r.per_seed.iter().map(|e| e.mse).collect::<Vec<_>>(),
                "rmse": r.raw.mse.sqrt(),
                "rel_mse": r.raw.rel_mse,
                "mse_reference_removed": r.corrected.mse,
                "rel_mse_reference_removed": r.corrected.rel_mse,
                "efficiency": r.efficiency(),
                "time_to_equal_mse_vs_anchor": r.ratio_raw,
                "time_to_equal_mse_vs_anchor_reference_removed": r.ratio_corrected,
                "time_to_equal_rel_mse_vs_anchor": r.ratio_rel_raw,
                "image": r.run.path.display().to_string(),
                "note": r.run.note,
            })).collect::<Vec<_>>(),
            "convergence_rate": self.convergence.iter().map(|(n, r)| json!({"renderer": n, "rate": r})).collect::<Vec<_>>(),
            "agreement": self.agreements.iter().map(|(name, spp, a)| json!({
                "renderer": name,
                "spp": spp,
                "mean_rel_diff": a.mean_rel_diff,
                "z_image": a.z_image,
                "z_block_rms": a.z_block_rms,
                "z_block_max": a.z_block_max.0,
                "z_block_max_at": [a.z_block_max.1, a.z_block_max.2, a.z_block_max.3],
            })).collect::<Vec<_>>(),
            "warnings": alarms,
            "scene_load_s": self.scene_load_s,
            "total_s": total_s,
        })
    }

    /// Writes `<out>/report.md` and `report.json` and prints the markdown.
    pub(super) fn write(&self, out: &Path, total_s: f64) -> Result<(), String> {
        let alarms = self.alarms();
        let md = self.markdown(total_s, &alarms);
        let (md_path, json_path) =
            crate::write_report(out, "report", &md, &self.json(total_s, &alarms))?;
        println!("\n{md}");
        println!("written: {} and {}", md_path.display(), json_path.display());
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    /// The label of our rows under the default `--integrator pt`.
    const OURS: &str = "ours (pt)";
    use std::fs;
    use std::path::{Path, PathBuf};

    use glam::Vec3;

    use super::*;

    /// A deterministic stand-in for noise: x in [-1, 1) per pixel, channel
    /// and seed.
    fn noise(i: usize, c: usize, seed: u64) -> f32 {
        let mut h = (i as u64 * 3 + c as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ seed;
        h ^= h >> 29;
        h = h.wrapping_mul(0xBF58_476D_1CE4_E5B9);
        h ^= h >> 32;
        (h % 2000) as f32 / 1000.0 - 1.0
    }

    fn image(reference: &[Vec3], spp: u32, seed: u64, bias: f32) -> Vec<Vec3> {
        let scale = 0.2 / (spp as f32).sqrt();
        reference
            .iter()
            .enumerate()
            .map(|(i, r)| {
                *r + Vec3::new(noise(i, 0, seed), noise(i, 1, seed), noise(i, 2, seed)) * scale
                    + Vec3::splat(bias)
            })
            .collect()
    }

    fn run(renderer: &str, spp: u32, threads: usize, image: Vec<Vec3>) -> Run {
        Run {
            renderer: renderer.into(),
            threads,
            spp,
            setup_s: 0.01,
            render_s: 0.001 * f64::from(spp) * (if threads == 1 { 2.0 } else { 1.0 }),
            render_times: vec![0.001 * f64::from(spp)],
            image,
            seed_images: Vec::new(),
            path: PathBuf::from(format!("/out/{spp}.exr")),
            note: String::new(),
        }
    }

    /// The whole report from made-up renders (no Mitsuba needed): the
    /// numbers, the agreement table, and a warning for a biased renderer.
    #[test]
    fn report_of_synthetic_runs() {
        let options =
            crate::mitsuba::test_options(&["--resolution", "32x32", "--spp", "8", "--seeds", "2"]);
        let mean: Vec<Vec3> = (0..options.pixels())
            .map(|i| Vec3::new(0.5, 0.25, 1.0) * (1.0 + (i % 7) as f32 / 7.0))
            .collect();
        let reference = Reference {
            spp: options.reference_spp,
            variance_of_mean: vec![Vec3::splat(1e-4); mean.len()],
            mean,
            path: PathBuf::from("/out/cache/reference.exr"),
            render_s: 12.5,
            cached: true,
        };
        let mitsuba = Mitsuba {
            python: PathBuf::from("python3"),
            version: "3.0.0".into(),
            how: "made up".into(),
        };
        let r = &reference.mean;
        let mitsuba_label = options.mitsuba[0].label();
        const MITSUBA: &str = "mitsuba 3 (path, scalar_rgb, independent)";
        assert_eq!(mitsuba_label, MITSUBA);
        let mut runs = vec![
            run(OURS, 8, 2, image(r, 8, 1, 0.0)),
            run(MITSUBA, 8, 2, image(r, 8, 2, 0.05)),
            run(OURS, 8, 1, image(r, 8, 3, 0.0)),
            run(MITSUBA, 8, 1, image(r, 8, 4, 0.05)),
            run(OURS, 2, 2, image(r, 2, 5, 0.0)),
            run(MITSUBA, 2, 2, image(r, 2, 6, 0.05)),
        ];
        // --seeds 2: a second image of each 8-spp run (here one with no error).
        for run in &mut runs[..4] {
            run.seed_images.push(r.clone());
        }
        let context = (&options, 2, &mitsuba, 0.25, "1.00 0.50 0.25".to_string());
        let mut report = Report::new(context, &reference, &runs);
        report.load_average.1 = "2.00 1.00 0.50".into();
        let alarms = report.alarms();
        let md = report.markdown(3.0, &alarms);
        let json = serde_json::to_string_pretty(&report.json(3.0, &alarms)).unwrap();
        if let Some(dir) = std::env::var_os("XTASK_KEEP_REPORT") {
            fs::write(Path::new(&dir).join("report.md"), &md).unwrap();
            fs::write(Path::new(&dir).join("report.json"), &json).unwrap();
        }
        assert_eq!(md.matches("| ours (pt) |").count(), 3, "{md}");
        assert!(md.contains("| ours (pt) @ 8 spp |"), "{md}");
        assert!(
            alarms.iter().any(|a| a.starts_with(MITSUBA)),
            "a bias of 0.05 is beyond noise: {alarms:?}"
        );
        assert!(!alarms.iter().any(|a| a.starts_with(OURS)), "{alarms:?}");
        assert_eq!(report.convergence.len(), 2);
        // The second seed's zero error halves the first's MSE.
        let first = super::super::compare::errors(&runs[0].image, r).mse;
        assert!((report.rows[0].raw.mse - first / 2.0).abs() < 1e-12 * first);
        assert!(md.contains("means over 2 sampler seeds"), "{md}");
        assert!(
            md.contains(&format!(
                "- {OURS}, 2 thread(s): {:.4e}, 0.0000e0",
                first.sqrt()
            )),
            "{md}"
        );
    }
}
