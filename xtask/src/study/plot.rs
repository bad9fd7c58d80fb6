//! Log-log charts of a study, one panel per algorithm, written as SVG
//! (plotters' SVG backend: text as `<text>` elements) and as PNG (plotters'
//! bitmap backend, text rasterized through `ab_glyph`).
//!
//! Within a panel the unregularized config is black and every regularized
//! one takes the colour of its schedule (tau_0, then the exponent) on a
//! viridis ramp, the same colour in every panel: selective ones solid with
//! triangles, `unsampleable` ones dashed with squares. All panels share
//! their axes, so that algorithms compare across panels too, and each
//! legend sits beside its panel, never over the data.
//!
//! The font is Hack (a DejaVu Sans Mono derivative, MIT and Bitstream Vera
//! licences), embedded by the `epaint_default_fonts` crate, egui's default
//! fonts: it comes through Cargo.lock like any dependency, so a clean
//! machine needs no font package. Monospace, because plotters places
//! `ab_glyph` glyphs at whole pixels, which a proportional font shows as
//! uneven spacing, and config names read as code anyway.

use std::path::Path;
use std::sync::OnceLock;

use integrators::Algorithm;
use plotters::coord::Shift;
use plotters::coord::combinators::WithKeyPoints;
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::{FontStyle, register_font};
use regularization::DEFAULT_SCHEDULE_EXPONENT;

use super::Config;
use super::raster::write_rgb_png;

/// The font family of every text, under the generic name that SVG viewers
/// resolve to a font of the same kind.
const FONT: &str = "monospace";
/// Size of a panel's plot (caption, axes, ticks and data), pixels.
const PLOT: (u32, u32) = (560, 400);
/// Width of the legend beside each plot.
const LEGEND_WIDTH: u32 = 230;
/// Height of the figure's title strip.
const TITLE_HEIGHT: u32 = 44;
/// Top of a legend's first row (level with the plot's data area) and the
/// height of a row.
const LEGEND_TOP: u32 = 52;
const LEGEND_ROW: u32 = 21;
/// Panels per row, at most.
const COLUMNS: usize = 2;
/// The part of the viridis ramp that schedules use: its yellow end is too
/// pale on white.
const RAMP: (f64, f64) = (0.0, 0.85);

/// One line of a chart.
pub struct Series {
    /// The config it measures (legend label, panel, colour and line style).
    pub config: Config,
    /// (x, y) points; non-positive or non-finite ones are left out (log axes).
    pub points: Vec<(f64, f64)>,
}

/// A log-log chart.
pub struct Chart {
    /// Caption.
    pub title: String,
    /// X axis description.
    pub x_label: String,
    /// Y axis description.
    pub y_label: String,
    /// The study's tau_0: the schedule of a regularized config that does
    /// not sweep tau_0.
    pub tau0: f64,
    /// Lines.
    pub series: Vec<Series>,
}

/// A config's regularization rule, which sets its line and marker.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Rule {
    Off,
    Selective,
    Unsampleable,
}

impl Rule {
    fn of(config: &Config) -> Self {
        match (config.regularized, config.unsampleable) {
            (false, _) => Self::Off,
            (true, false) => Self::Selective,
            (true, true) => Self::Unsampleable,
        }
    }
}

/// How one series is drawn and named.
#[derive(Clone, Debug, PartialEq)]
struct Style {
    label: String,
    color: RGBColor,
    rule: Rule,
}

/// One panel: an algorithm and the indices of its series in the chart.
#[derive(Debug, PartialEq)]
struct Panel {
    algorithm: Algorithm,
    series: Vec<usize>,
}

/// The chart's algorithms in order of first appearance, each with its
/// series in the chart's order.
fn panels(chart: &Chart) -> Vec<Panel> {
    let mut panels: Vec<Panel> = Vec::new();
    for (i, s) in chart.series.iter().enumerate() {
        let algorithm = s.config.algorithm;
        match panels.iter_mut().find(|p| p.algorithm == algorithm) {
            Some(p) => p.series.push(i),
            None => panels.push(Panel {
                algorithm,
                series: vec![i],
            }),
        }
    }
    panels
}

/// A regularized config's schedule: (tau_0, exponent), with the study's
/// values where the config does not sweep them.
fn schedule(config: &Config, tau0: f64) -> (f64, f64) {
    (
        config.tau0.unwrap_or(tau0),
        config.exponent.unwrap_or(DEFAULT_SCHEDULE_EXPONENT),
    )
}

/// Matplotlib's viridis at t = 0, 1/8, ..., 1: a sequential map that is
/// perceptually uniform and reads in grey and to colour-blind readers.
const VIRIDIS: [(u8, u8, u8); 9] = [
    (68, 1, 84),
    (71, 45, 123),
    (59, 82, 139),
    (44, 114, 142),
    (33, 144, 140),
    (39, 173, 129),
    (93, 200, 99),
    (170, 220, 50),
    (253, 231, 37),
];

/// Viridis at `t` in [0, 1] (clamped), linear between the anchors.
fn viridis(t: f64) -> RGBColor {
    let x = t.clamp(0.0, 1.0) * (VIRIDIS.len() - 1) as f64;
    let i = (x.floor() as usize).min(VIRIDIS.len() - 2);
    let f = x - i as f64;
    let (a, b) = (VIRIDIS[i], VIRIDIS[i + 1]);
    let mix = |p: u8, q: u8| (f64::from(p) + (f64::from(q) - f64::from(p)) * f).round() as u8;
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

/// The style of every series of `chart`: black for an unregularized config;
/// for a regularized one the colour of its schedule's rank among all the
/// chart's schedules (smallest tau_0, the most blur, darkest), so that one
/// schedule has one colour in every panel. A label is the config's name,
/// with the study's tau_0 where the config does not sweep it.
fn styles(chart: &Chart) -> Vec<Style> {
    let mut schedules: Vec<(f64, f64)> = chart
        .series
        .iter()
        .filter(|s| s.config.regularized)
        .map(|s| schedule(&s.config, chart.tau0))
        .collect();
    schedules.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    schedules.dedup();
    let color = |config: &Config| {
        let key = schedule(config, chart.tau0);
        let rank = schedules.iter().position(|&s| s == key).unwrap_or(0);
        let t = match schedules.len() {
            0 | 1 => 0.5,
            n => rank as f64 / (n - 1) as f64,
        };
        viridis(RAMP.0 + (RAMP.1 - RAMP.0) * t)
    };
    chart
        .series
        .iter()
        .map(|s| {
            let rule = Rule::of(&s.config);
            let mut label = s.config.to_string();
            if rule != Rule::Off && s.config.tau0.is_none() {
                label.push_str(&format!(" (tau0={})", chart.tau0));
            }
            Style {
                label,
                color: if rule == Rule::Off {
                    BLACK
                } else {
                    color(&s.config)
                },
                rule,
            }
        })
        .collect()
}

/// The figure's grid and pixel size.
#[derive(Debug, PartialEq)]
struct Layout {
    rows: usize,
    columns: usize,
    size: (u32, u32),
}

impl Layout {
    /// Room for `panels` in rows of [`COLUMNS`], each cell a plot and its
    /// legend, tall enough for the longest legend.
    fn of(panels: &[Panel]) -> Self {
        let columns = panels.len().clamp(1, COLUMNS);
        let rows = panels.len().div_ceil(columns).max(1);
        let entries = panels.iter().map(|p| p.series.len()).max().unwrap_or(0) as u32;
        let cell_height = PLOT.1.max(LEGEND_TOP + (entries + 1) * LEGEND_ROW);
        Self {
            rows,
            columns,
            size: (
                (PLOT.0 + LEGEND_WIDTH) * columns as u32,
                TITLE_HEIGHT + cell_height * rows as u32,
            ),
        }
    }
}

/// Registers the embedded font as [`FONT`] (once per process).
fn register_fonts() -> Result<(), String> {
    static REGISTERED: OnceLock<Result<(), String>> = OnceLock::new();
    REGISTERED
        .get_or_init(|| {
            register_font(FONT, FontStyle::Normal, epaint_default_fonts::HACK_REGULAR)
                .map_err(|_| "the chart font (epaint_default_fonts' Hack) does not parse".into())
        })
        .clone()
}

/// Writes `dir/<stem>.svg` and `dir/<stem>.png`; returns the file names
/// written (none when no series has a point that a log axis can show).
pub fn write_chart(dir: &Path, stem: &str, chart: &Chart) -> Result<Vec<String>, String> {
    let Some(ranges) = ranges(chart) else {
        return Ok(Vec::new());
    };
    register_fonts()?;
    let figure = Figure {
        chart,
        panels: panels(chart),
        styles: styles(chart),
        ranges,
    };
    let layout = Layout::of(&figure.panels);
    let (width, height) = layout.size;
    let svg_name = format!("{stem}.svg");
    let svg_path = dir.join(&svg_name);
    {
        let root = SVGBackend::new(&svg_path, layout.size).into_drawing_area();
        figure
            .draw(&root, &layout)
            .map_err(|e| format!("{}: {e}", svg_path.display()))?;
    }
    let png_name = format!("{stem}.png");
    let png_path = dir.join(&png_name);
    let mut rgb = vec![0u8; width as usize * height as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, layout.size).into_drawing_area();
        figure
            .draw(&root, &layout)
            .map_err(|e| format!("{}: {e}", png_path.display()))?;
    }
    write_rgb_png(&png_path, layout.size, &rgb)?;
    Ok(vec![svg_name, png_name])
}

/// Points a log-log chart can show.
fn visible(points: &[(f64, f64)]) -> impl Iterator<Item = (f64, f64)> + '_ {
    points
        .iter()
        .copied()
        .filter(|&(x, y)| x.is_finite() && y.is_finite() && x > 0.0 && y > 0.0)
}

/// The axis ranges ((x lo, x hi), (y lo, y hi)).
type Ranges = ((f64, f64), (f64, f64));

/// The axis ranges: the data's, widened by a margin in log space.
fn ranges(chart: &Chart) -> Option<Ranges> {
    let points: Vec<(f64, f64)> = chart
        .series
        .iter()
        .flat_map(|s| visible(&s.points))
        .collect();
    if points.is_empty() {
        return None;
    }
    let span = |values: &mut dyn Iterator<Item = f64>| {
        let (lo, hi) = values.fold((f64::INFINITY, 0.0f64), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
        let widen = if hi > lo { 1.3 } else { 2.0 };
        (lo / widen, hi * widen)
    };
    let x = span(&mut points.iter().map(|p| p.0));
    let y = span(&mut points.iter().map(|p| p.1));
    Some((x, y))
}

/// The values m 10^k in [lo, hi] for m in `mantissas` (tick marks of a log
/// axis); with fewer than three of 1, 2, 5, every integer mantissa.
fn ticks(lo: f64, hi: f64, mantissas: &[f64]) -> Vec<f64> {
    let mut out = Vec::new();
    let (k0, k1) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
    for k in k0..=k1 {
        for &m in mantissas {
            let v = m * 10f64.powi(k);
            if v >= lo && v <= hi {
                out.push(v);
            }
        }
    }
    if out.len() < 3 && mantissas.len() < 9 {
        return ticks(lo, hi, &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0]);
    }
    out
}

/// Tick labels: plain decimals from 0.01 to 10^4, else scientific.
fn short(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 {
        "0".into()
    } else if (1e-2..1e4).contains(&a) {
        let s = format!("{v:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        format!("{v:.1e}").replace(".0e", "e")
    }
}

/// A log axis over [lo, hi] with labelled ticks at 1, 2, 5 per decade (at
/// 1 only over more than three decades, where more would crowd a panel)
/// and grid lines at every integer mantissa.
fn log_axis(lo: f64, hi: f64) -> WithKeyPoints<LogCoord<f64>> {
    let labelled: &[f64] = if hi / lo > 1e3 {
        &[1.0]
    } else {
        &[1.0, 2.0, 5.0]
    };
    (lo..hi)
        .log_scale()
        .with_key_points(ticks(lo, hi, labelled))
        .with_light_points(ticks(
            lo,
            hi,
            &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0],
        ))
}

/// Marker sizes: circles for unregularized configs, triangles for
/// selective ones, squares (half a side) for `unsampleable` ones.
const CIRCLE: u32 = 4;
const TRIANGLE: u32 = 5;
const SQUARE: i32 = 3;

/// Dash length and gap of `unsampleable` configs' lines, pixels.
const DASH: (u32, u32) = (8, 5);

/// Everything a drawing of the chart needs, worked out once for both files.
struct Figure<'a> {
    chart: &'a Chart,
    panels: Vec<Panel>,
    styles: Vec<Style>,
    ranges: Ranges,
}

impl Figure<'_> {
    /// Draws the title, then every panel with its legend on `root`, laid
    /// out by `layout`.
    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        layout: &Layout,
    ) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
        root.fill(&WHITE)?;
        let (title, body) = root.split_vertically(TITLE_HEIGHT);
        let centered = (FONT, 22)
            .into_font()
            .color(&BLACK)
            .pos(Pos::new(HPos::Center, VPos::Center));
        title.draw_text(
            &self.chart.title,
            &centered,
            (layout.size.0 as i32 / 2, TITLE_HEIGHT as i32 / 2),
        )?;
        let cells = body.split_evenly((layout.rows, layout.columns));
        for (panel, cell) in self.panels.iter().zip(&cells) {
            let (plot, legend) = cell.split_horizontally(PLOT.0);
            self.draw_panel(&plot, panel)?;
            self.draw_legend(&legend, panel)?;
        }
        root.present()
    }

    /// One algorithm's series on log-log axes shared by every panel.
    fn draw_panel<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        panel: &Panel,
    ) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
        let ((x0, x1), (y0, y1)) = self.ranges;
        let mut c = ChartBuilder::on(area)
            .caption(panel.algorithm.name().to_uppercase(), (FONT, 20))
            .margin(12)
            .x_label_area_size(48)
            .y_label_area_size(72)
            .build_cartesian_2d(log_axis(x0, x1), log_axis(y0, y1))?;
        c.configure_mesh()
            .x_desc(self.chart.x_label.as_str())
            .y_desc(self.chart.y_label.as_str())
            .x_label_formatter(&|v| short(*v))
            .y_label_formatter(&|v| short(*v))
            .label_style((FONT, 14))
            .axis_desc_style((FONT, 15))
            .light_line_style(RGBColor(235, 235, 235))
            .draw()?;
        for &i in &panel.series {
            let Style { color, rule, .. } = self.styles[i];
            let points: Vec<(f64, f64)> = visible(&self.chart.series[i].points).collect();
            let line = color.stroke_width(2);
            if rule == Rule::Unsampleable {
                c.draw_series(DashedLineSeries::new(points.clone(), DASH.0, DASH.1, line))?;
            } else {
                c.draw_series(LineSeries::new(points.clone(), line))?;
            }
            let fill = color.filled();
            let square = [(-SQUARE, -SQUARE), (SQUARE, SQUARE)];
            match rule {
                Rule::Off => c.draw_series(points.iter().map(|&p| Circle::new(p, CIRCLE, fill))),
                Rule::Selective => c.draw_series(
                    points
                        .iter()
                        .map(|&p| TriangleMarker::new(p, TRIANGLE, fill)),
                ),
                Rule::Unsampleable => c.draw_series(
                    points
                        .iter()
                        .map(|&p| EmptyElement::at(p) + Rectangle::new(square, fill)),
                ),
            }?;
        }
        Ok(())
    }

    /// The panel's legend, one row per series: a stretch of its line with
    /// its marker, then its label.
    fn draw_legend<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        panel: &Panel,
    ) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
        let text = (FONT, 15)
            .into_font()
            .color(&BLACK)
            .pos(Pos::new(HPos::Left, VPos::Center));
        for (row, &i) in panel.series.iter().enumerate() {
            let Style {
                ref label,
                color,
                rule,
            } = self.styles[i];
            let y = (LEGEND_TOP + row as u32 * LEGEND_ROW) as i32;
            let (x0, x1) = (4, 40);
            let line = color.stroke_width(2);
            if rule == Rule::Unsampleable {
                area.draw(&DashedPathElement::new(
                    [(x0, y), (x1, y)],
                    DASH.0,
                    DASH.1,
                    line,
                ))?;
            } else {
                area.draw(&PathElement::new([(x0, y), (x1, y)], line))?;
            }
            let (x, fill) = ((x0 + x1) / 2, color.filled());
            match rule {
                Rule::Off => area.draw(&Circle::new((x, y), CIRCLE, fill)),
                Rule::Selective => area.draw(&TriangleMarker::new((x, y), TRIANGLE, fill)),
                Rule::Unsampleable => area.draw(&Rectangle::new(
                    [(x - SQUARE, y - SQUARE), (x + SQUARE, y + SQUARE)],
                    fill,
                )),
            }?;
            area.draw_text(label, &text, (x1 + 8, y))?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_one_two_five_per_decade() {
        assert_eq!(
            ticks(0.8, 30.0, &[1.0, 2.0, 5.0]),
            [1.0, 2.0, 5.0, 10.0, 20.0]
        );
        // A narrow range falls back to every integer mantissa.
        assert_eq!(ticks(2.5, 4.5, &[1.0, 2.0, 5.0]), [3.0, 4.0]);
    }

    #[test]
    fn tick_labels_are_short() {
        assert_eq!(short(0.5), "0.5");
        assert_eq!(short(100.0), "100");
        assert_eq!(short(0.001), "1e-3");
        assert_eq!(short(2.5e-5), "2.5e-5");
        assert_eq!(short(1e5), "1e5");
    }

    #[test]
    fn viridis_runs_from_purple_to_yellow_getting_lighter() {
        assert_eq!(viridis(0.0), RGBColor(68, 1, 84));
        assert_eq!(viridis(1.0), RGBColor(253, 231, 37));
        assert_eq!(viridis(-1.0), viridis(0.0));
        let luma = |RGBColor(r, g, b): RGBColor| {
            0.2126 * f64::from(r) + 0.7152 * f64::from(g) + 0.0722 * f64::from(b)
        };
        let ramp: Vec<f64> = (0..=20)
            .map(|i| luma(viridis(f64::from(i) / 20.0)))
            .collect();
        assert!(ramp.windows(2).all(|w| w[0] < w[1]), "{ramp:?}");
    }

    /// `name` parsed, with `tau0` swept when given.
    fn config(name: &str, tau0: Option<f64>) -> Config {
        Config {
            tau0,
            ..Config::parse(name).unwrap()
        }
    }

    /// A study of PT, BPT with both rules at two tau_0 and VCM at the
    /// study's tau_0: three algorithms.
    fn synthetic() -> Chart {
        let series = [
            ("pt", None),
            ("pt-reg", None),
            ("bpt", None),
            ("bpt-reg", Some(2.0)),
            ("bpt-reg", Some(120.0)),
            ("bpt-uns", Some(2.0)),
            ("bpt-uns", Some(120.0)),
            ("vcm", None),
            ("vcm-uns", None),
        ]
        .into_iter()
        .enumerate()
        .map(|(i, (name, tau0))| Series {
            config: config(name, tau0),
            points: (0..6)
                .map(|k| {
                    let t = 0.1 * 2f64.powi(k);
                    (t, (1.0 + i as f64) / t.sqrt())
                })
                .collect(),
        })
        .collect();
        Chart {
            title: "RMSE vs CPU time".into(),
            x_label: "CPU seconds".into(),
            y_label: "RMSE".into(),
            tau0: 30.0,
            series,
        }
    }

    /// Unregularized configs are black; a schedule has one colour in every
    /// panel, darker for smaller tau_0; the rules differ in line and marker.
    #[test]
    fn styles_are_black_then_a_ramp_by_schedule() {
        let chart = synthetic();
        let styles = styles(&chart);
        let by_name = |name: &str| {
            let i = chart
                .series
                .iter()
                .position(|s| s.config.to_string() == name)
                .unwrap();
            styles[i].clone()
        };
        for name in ["pt", "bpt", "vcm"] {
            assert_eq!(by_name(name).color, BLACK);
            assert_eq!(by_name(name).rule, Rule::Off);
        }
        // tau0 2, 30 (the study's), 120: three colours, the ramp's ends first.
        assert_eq!(by_name("bpt-reg@tau0=2").color, viridis(RAMP.0));
        assert_eq!(by_name("bpt-uns@tau0=120").color, viridis(RAMP.1));
        assert_eq!(by_name("pt-reg").color, by_name("vcm-uns").color);
        assert_eq!(
            by_name("bpt-reg@tau0=2").color,
            by_name("bpt-uns@tau0=2").color
        );
        assert_eq!(by_name("bpt-uns@tau0=2").rule, Rule::Unsampleable);
        assert_eq!(by_name("pt-reg").label, "pt-reg (tau0=30)");
        assert_eq!(by_name("bpt-reg@tau0=2").label, "bpt-reg@tau0=2");
    }

    /// Three algorithms: three panels in two columns, each legend beside
    /// its panel; both files name every config and every panel.
    #[test]
    fn charts_are_written_as_svg_and_png_one_panel_per_algorithm() {
        let dir = std::env::temp_dir().join(format!("xtask-study-plot-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let chart = synthetic();
        let panels = panels(&chart);
        let algorithms: Vec<Algorithm> = panels.iter().map(|p| p.algorithm).collect();
        assert_eq!(algorithms, [Algorithm::Pt, Algorithm::Bpt, Algorithm::Vcm]);
        assert_eq!(panels[1].series, [2, 3, 4, 5, 6]);
        let layout = Layout::of(&panels);
        assert_eq!((layout.rows, layout.columns), (2, 2));

        let files = write_chart(&dir, "c", &chart).unwrap();
        assert_eq!(files, ["c.svg", "c.png"]);
        let svg = std::fs::read_to_string(dir.join("c.svg")).unwrap();
        for style in styles(&chart) {
            assert!(svg.contains(&style.label), "{} not in the SVG", style.label);
        }
        for caption in ["PT", "BPT", "VCM"] {
            assert!(
                svg.contains(&format!(">\n{caption}\n<")),
                "no panel {caption}"
            );
        }
        assert!(svg.contains(&format!(
            r#"width="{}" height="{}""#,
            layout.size.0, layout.size.1
        )));
        let png = std::fs::read(dir.join("c.png")).unwrap();
        let decoder = png::Decoder::new(std::io::Cursor::new(png));
        let reader = decoder.read_info().unwrap();
        assert_eq!((reader.info().width, reader.info().height), layout.size);

        // Nothing a log axis can show: no files.
        let empty = Chart {
            series: vec![Series {
                config: config("pt", None),
                points: vec![(1.0, 0.0)],
            }],
            ..chart
        };
        assert!(write_chart(&dir, "e", &empty).unwrap().is_empty());
        std::fs::remove_dir_all(dir).unwrap();
    }
}
