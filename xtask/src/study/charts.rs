//! The study's charts (error against time, noise against iterations), drawn
//! from a finished study or read back from its curves.json: `cargo xtask
//! study --replot DIR` redraws a study's charts without rendering anything.

use std::fs;
use std::path::Path;

use serde_json::Value;

use super::metrics::{Errors, Noise};
use super::plot::{self, Chart, Series};
use super::{Config, Point, Study};

/// What the charts show of a study.
pub struct ChartData {
    /// Scene name (in every title).
    pub scene_name: String,
    /// Image size.
    pub resolution: (u32, u32),
    /// The study's tau_0 (the schedule of unswept regularized configs).
    pub tau0: f64,
    /// Each reference's role, config and iterations, in the order of a
    /// point's errors.
    pub references: Vec<(String, Config, u64)>,
    /// Each config's checkpoints, in the study's order.
    pub runs: Vec<(Config, Vec<Point>)>,
}

impl ChartData {
    /// The charts' data of a finished study.
    pub fn of(study: &Study) -> Self {
        Self {
            scene_name: study.scene_name.clone(),
            resolution: study.resolution,
            tau0: study.tau0,
            references: study
                .references
                .iter()
                .map(|r| (r.role.to_string(), r.config, r.spec.iterations))
                .collect(),
            runs: study
                .runs
                .iter()
                .map(|r| (r.config, r.points.clone()))
                .collect(),
        }
    }

    /// File-name suffix and label of reference `i` (the first has no suffix).
    fn reference_suffix(&self, i: usize) -> (String, String) {
        let (role, config, iterations) = &self.references[i];
        if i == 0 {
            (String::new(), format!("{config} x {iterations}"))
        } else {
            (
                format!("-{role}"),
                format!("{role} {config} x {iterations}"),
            )
        }
    }

    /// One series per config: (x(p), y(p)) at each checkpoint p.
    fn series(&self, x: &dyn Fn(&Point) -> f64, y: &dyn Fn(&Point) -> f64) -> Vec<Series> {
        self.runs
            .iter()
            .map(|(config, points)| Series {
                config: *config,
                points: points.iter().map(|p| (x(p), y(p))).collect(),
            })
            .collect()
    }

    /// A chart titled `what`, then the scene, the resolution and the
    /// reference's label where the chart has one.
    fn chart(
        &self,
        (what, reference): (&str, Option<&str>),
        x_label: &str,
        y_label: &str,
        series: Vec<Series>,
    ) -> Chart {
        let (w, h) = self.resolution;
        let reference = reference.map_or(String::new(), |r| format!(", ref. {r}"));
        Chart {
            title: format!("{what}, {} {w}x{h}{reference}", self.scene_name),
            x_label: x_label.into(),
            y_label: y_label.into(),
            tau0: self.tau0,
            series,
        }
    }
}

/// Writes every chart into `out`: RMSE and relMSE against wall-clock time
/// per reference, RMSE against CPU time (where every checkpoint has one)
/// and noise against iterations; returns the names of the files written.
pub fn write(out: &Path, data: &ChartData) -> Result<Vec<String>, String> {
    let mut files = Vec::new();
    for i in 0..data.references.len() {
        let (suffix, label) = data.reference_suffix(i);
        let rmse = move |p: &Point| p.errors[i].rmse;
        let rel_mse = move |p: &Point| p.errors[i].rel_mse;
        for (stem, metric, value) in [
            ("rmse-vs-time", "RMSE", &rmse as &dyn Fn(&Point) -> f64),
            ("relmse-vs-time", "relMSE", &rel_mse),
        ] {
            let chart = data.chart(
                (&format!("{metric} vs time"), Some(&label)),
                "render time (s, wall clock)",
                &format!("{metric} (luminance)"),
                data.series(&|p| p.seconds, value),
            );
            files.extend(plot::write_chart(out, &format!("{stem}{suffix}"), &chart)?);
        }
    }
    let cpu_measured = data
        .runs
        .iter()
        .all(|(_, points)| points.iter().all(|p| p.cpu_seconds.is_some()));
    if cpu_measured && !data.references.is_empty() {
        let (_, label) = data.reference_suffix(0);
        let chart = data.chart(
            ("RMSE vs CPU time", Some(&label)),
            "render CPU time (s, all threads)",
            "RMSE (luminance)",
            data.series(&|p| p.cpu_seconds.unwrap_or(f64::NAN), &|p| {
                p.errors[0].rmse
            }),
        );
        files.extend(plot::write_chart(out, "rmse-vs-cpu-time", &chart)?);
    }
    let chart = data.chart(
        ("Noise vs iterations", None),
        "iterations N",
        "mean s^2/N (luminance)",
        data.series(&|p| p.iteration as f64, &|p| {
            p.noise.map_or(f64::NAN, |n| n.variance)
        }),
    );
    files.extend(plot::write_chart(out, "noise-vs-iterations", &chart)?);
    Ok(files)
}

/// `cargo xtask study --replot DIR`: redraws the charts of the study whose
/// curves.json is in `dir`, into `dir`.
pub fn replot(dir: &Path) -> Result<(), String> {
    let path = dir.join("curves.json");
    let text = fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
    let json: Value =
        serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))?;
    let data = from_json(&json).map_err(|e| format!("{}: {e}", path.display()))?;
    for file in write(dir, &data)? {
        println!("{}", dir.join(file).display());
    }
    Ok(())
}

/// The charts' data of a study's curves.json (see `report::json_of`).
fn from_json(json: &Value) -> Result<ChartData, String> {
    let number = |v: &Value, key: &str| v[key].as_f64().ok_or_else(|| format!("no number '{key}'"));
    let text = |v: &Value, key: &'static str| {
        v[key]
            .as_str()
            .map(str::to_string)
            .ok_or_else(|| format!("no text '{key}'"))
    };
    let resolution = match json["resolution"].as_array().map(Vec::as_slice) {
        Some([w, h]) => (
            w.as_u64().ok_or("bad 'resolution'")? as u32,
            h.as_u64().ok_or("bad 'resolution'")? as u32,
        ),
        _ => return Err("no 'resolution' [w, h]".into()),
    };
    let mut references = Vec::new();
    for r in json["references"].as_array().ok_or("no 'references'")? {
        let config = Config::parse_name(&text(r, "config")?)?;
        let iterations = r["iterations"]
            .as_u64()
            .ok_or("no reference 'iterations'")?;
        references.push((text(r, "role")?, config, iterations));
    }
    let labels: Vec<String> = references
        .iter()
        .map(|(role, config, _)| format!("{role} {config}"))
        .collect();
    let mut runs: Vec<(Config, Vec<Point>)> = Vec::new();
    for row in json["rows"].as_array().ok_or("no 'rows'")? {
        let config = Config::parse_name(&text(row, "config")?)?;
        let reference = text(row, "reference")?;
        let i = labels
            .iter()
            .position(|l| *l == reference)
            .ok_or_else(|| format!("row of unknown reference '{reference}'"))?;
        let iteration = row["iteration"].as_u64().ok_or("no row 'iteration'")?;
        if runs.last().is_none_or(|(c, _)| *c != config) {
            runs.push((config, Vec::new()));
        }
        let points = &mut runs.last_mut().expect("pushed above").1;
        if points.last().is_none_or(|p| p.iteration != iteration) {
            points.push(Point {
                iteration,
                seconds: number(row, "seconds")?,
                cpu_seconds: row["cpu_seconds"].as_f64(),
                noise: row["noise_variance"].as_f64().map(|variance| Noise {
                    std_error: row["noise_std_error"].as_f64().unwrap_or(f64::NAN),
                    variance,
                }),
                errors: vec![
                    Errors {
                        rmse: f64::NAN,
                        rel_mse: f64::NAN
                    };
                    labels.len()
                ],
            });
        }
        let point = points.last_mut().expect("pushed above");
        point.errors[i] = Errors {
            rmse: number(row, "rmse")?,
            rel_mse: number(row, "rel_mse")?,
        };
    }
    Ok(ChartData {
        scene_name: super::cli::scene_name(Path::new(&text(json, "scene")?)),
        resolution,
        tau0: number(json, "tau0")?,
        references,
        runs,
    })
}
