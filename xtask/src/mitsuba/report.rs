//! The report: a table of times and errors, the agreement of both
//! renderers with the reference, warnings; `report.md` and `report.json`.

use std::fmt::Write as _;
use std::fs;
use std::path::Path;

use serde_json::{Value, json};

use super::Options;
use super::compare::{
    Agreement, BLOCKS, Errors, ReferenceError, agreement, errors, floor_fit, reference_floor,
};
use super::install::Mitsuba;
use super::reference::Reference;
use super::render::{MITSUBA, OURS, Run};

/// Above this relative difference of the image means the two renderers do
/// not render the same scene (the export is suspect, not the comparison).
const MEAN_TOLERANCE: f64 = 0.03;

/// Largest |z| of an image mean (per channel) before the report calls it a
/// disagreement beyond noise.
const Z_ALARM: f64 = 5.0;

/// Largest root mean square of the block z-scores (1 for pure noise) before
/// the report calls it a disagreement. Single blocks are not judged: with
/// few samples per block the z-score is skewed (rare bright paths).
const BLOCK_RMS_ALARM: f64 = 1.5;

/// One row of the table: a run, its errors, and its time-to-equal-error
/// ratios against Mitsuba at the same spp and threads.
struct RowMetrics<'a> {
    run: &'a Run,
    raw: Errors,
    /// Errors less the reference's own error (clamped at 0).
    corrected: Errors,
    ratio_raw: Option<f64>,
    ratio_corrected: Option<f64>,
    ratio_rel_raw: Option<f64>,
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
    agreements: Vec<(&'static str, u32, Agreement)>,
    /// Per renderer: MSE ~ spp^-rate between --spp and --check-spp (1 for
    /// plain Monte Carlo), from reference-corrected MSEs.
    convergence: Vec<(&'static str, f64)>,
    scene_load_s: f64,
    load_average: (String, String),
}

impl<'a> Report<'a> {
    pub(super) fn new(
        context: (&'a Options, usize, &Mitsuba, f64, String),
        reference: &'a Reference,
        runs: &'a [Run],
    ) -> Self {
        let (options, cores, mitsuba, scene_load_s, load_before) = context;
        let raw: Vec<Errors> = runs
            .iter()
            .map(|run| errors(&run.image, &reference.mean))
            .collect();
        let level = |name: &str, spp: u32| {
            runs.iter()
                .position(|r| r.renderer == name && r.spp == spp && r.threads == cores)
        };
        let (n1, n2) = (f64::from(options.spp), f64::from(options.check_spp));
        let two_levels = |name: &str| {
            if options.check_spp == 0 {
                return None;
            }
            Some((level(name, options.spp)?, level(name, options.check_spp)?))
        };
        let from_variance = reference_floor(reference);
        let extrapolated = level(OURS, options.spp).map_or(from_variance, |i| {
            let f = n1 / f64::from(options.reference_spp);
            Errors {
                mse: (raw[i].mse * f).min(from_variance.mse),
                rel_mse: (raw[i].rel_mse * f).min(from_variance.rel_mse),
            }
        });
        let reference_error = ReferenceError {
            from_variance,
            used: extrapolated,
            mitsuba_floor: two_levels(MITSUBA)
                .map(|(a, b)| floor_fit(&runs[a], &runs[b], &reference.mean)),
        };
        let mut rows: Vec<RowMetrics> = runs
            .iter()
            .zip(&raw)
            .map(|(run, &raw)| RowMetrics {
                run,
                raw,
                corrected: Errors {
                    mse: (raw.mse - reference_error.used.mse).max(0.0),
                    rel_mse: (raw.rel_mse - reference_error.used.rel_mse).max(0.0),
                },
                ratio_raw: None,
                ratio_corrected: None,
                ratio_rel_raw: None,
            })
            .collect();
        // Time to equal error relative to Mitsuba at the same spp and threads.
        let work = |r: &RowMetrics, e: Errors| (r.run.render_s * e.mse, r.run.render_s * e.rel_mse);
        let baselines: Vec<_> = rows
            .iter()
            .filter(|r| r.run.renderer == MITSUBA)
            .map(|r| {
                (
                    r.run.spp,
                    r.run.threads,
                    work(r, r.raw),
                    work(r, r.corrected),
                )
            })
            .collect();
        for r in &mut rows {
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
        let agreements = rows
            .iter()
            .filter(|r| r.run.threads == cores)
            .map(|r| {
                let a = agreement(&r.run.image, &reference.mean, options.width, options.height);
                (r.run.renderer, r.run.spp, a)
            })
            .collect();
        let convergence = [OURS, MITSUBA]
            .into_iter()
            .filter_map(|name| {
                let (a, b) = two_levels(name)?;
                let (ea, eb) = (rows[a].corrected.mse, rows[b].corrected.mse);
                (ea > 0.0 && eb > 0.0).then(|| (name, (ea / eb).ln() / (n2 / n1).ln()))
            })
            .collect();
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
            scene_load_s,
            load_average: (load_before, crate::load_average()),
        }
    }

    /// Warnings: the two renderers do not estimate the same image.
    fn alarms(&self) -> Vec<String> {
        let mut alarms = Vec::new();
        for (name, spp, a) in &self.agreements {
            if a.mean_rel_diff.iter().any(|d| d.abs() > MEAN_TOLERANCE) {
                alarms.push(format!(
                    "{name} @ {spp} spp: the image mean differs from the reference's by more than {:.0} % \
                     (if Mitsuba's: the export is suspect: emitter side, fov, colours)",
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
        let o = self.options;
        let pixels = o.pixels();
        let mut md = String::new();
        let _ = writeln!(md, "# Our path tracer vs Mitsuba 3\n");
        let _ = writeln!(
            md,
            "Scene `{}` at {}x{}, max depth {} (segments), Russian roulette from depth 3, box filter, \
             regularization off. Mitsuba {} (`scalar_rgb`, `path`, `independent` sampler; {}). \
             Machine: {} logical cores, load average {} before and {} after (other work on the \
             machine slows both renderers). Times: the render call only, release build, fastest of \
             {} alternating runs (ours, Mitsuba, ours, ...) at all cores and `--spp`, one run otherwise.\n",
            o.scene.display(),
            o.width,
            o.height,
            o.max_depth,
            self.mitsuba_version,
            self.mitsuba_how,
            self.cores,
            self.load_average.0,
            self.load_average.1,
            o.repeat,
        );
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
        md.push_str(
            "| renderer | threads | spp | time (s) | samples/s | RMSE | relMSE | efficiency 1/(t MSE) | time to equal MSE vs Mitsuba | same, reference error removed | time to equal relMSE vs Mitsuba | BVH build / scene load (s) |\n\
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
        md.push_str(
            "\nTime to equal MSE = (t MSE)_row / (t MSE)_Mitsuba at the same spp and threads: the time \
             ours takes to reach its MSE over the time Mitsuba needs for that MSE (Mitsuba's independent \
             samples give MSE ~ 1/time exactly); below 1, ours is faster. Ours is Owen-scrambled Sobol, \
             whose MSE falls faster than 1/spp (rate below), so the ratio depends on the spp.\n",
        );
        if !self.convergence.is_empty() {
            md.push_str("\nMSE ~ spp^-rate between the two spp levels (reference error removed; 1 = plain Monte Carlo):");
            for (name, rate) in &self.convergence {
                let _ = write!(md, " {name} {rate:.2};");
            }
            md.push('\n');
        }
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
        let _ = writeln!(
            md,
            "\nScene load (ours) {:.3} s; whole command {total_s:.1} s.",
            self.scene_load_s
        );
        md
    }

    fn json(&self, total_s: f64, alarms: &[String]) -> Value {
        let o = self.options;
        let pixels = o.pixels();
        let re = &self.reference_error;
        json!({
            "scene": o.scene.display().to_string(),
            "width": o.width,
            "height": o.height,
            "max_depth": o.max_depth,
            "rr_depth": 3,
            "repeat": o.repeat,
            "cores": self.cores,
            "load_average_before": self.load_average.0,
            "load_average_after": self.load_average.1,
            "mitsuba_version": self.mitsuba_version,
            "mitsuba_install": self.mitsuba_how,
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
                "rmse": r.raw.mse.sqrt(),
                "rel_mse": r.raw.rel_mse,
                "mse_reference_removed": r.corrected.mse,
                "rel_mse_reference_removed": r.corrected.rel_mse,
                "efficiency": r.efficiency(),
                "time_to_equal_mse_vs_mitsuba": r.ratio_raw,
                "time_to_equal_mse_vs_mitsuba_reference_removed": r.ratio_corrected,
                "time_to_equal_rel_mse_vs_mitsuba": r.ratio_rel_raw,
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

    pub(super) fn write(&self, out: &Path, total_s: f64) -> Result<(), String> {
        let alarms = self.alarms();
        let md = self.markdown(total_s, &alarms);
        let md_path = out.join("report.md");
        fs::write(&md_path, &md).map_err(|e| format!("cannot write {}: {e}", md_path.display()))?;
        let json_path = out.join("report.json");
        let text = serde_json::to_string_pretty(&self.json(total_s, &alarms))
            .map_err(|e| e.to_string())?;
        fs::write(&json_path, text)
            .map_err(|e| format!("cannot write {}: {e}", json_path.display()))?;
        println!("\n{md}");
        println!("written: {} and {}", md_path.display(), json_path.display());
        Ok(())
    }
}
