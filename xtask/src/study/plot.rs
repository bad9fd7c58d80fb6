//! Log-log charts, one line per config, written as SVG (plotters' SVG
//! backend: text as `<text>` elements) and as PNG (the same drawing on
//! [`Canvas`], whose text uses an 8x8 bitmap font).

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::raster::{Canvas, Painter};

/// Pixel size of every chart.
const SIZE: (u32, u32) = (960, 640);

/// One line of a chart.
pub struct Series {
    /// Legend label (a config name).
    pub name: String,
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
    /// Lines.
    pub series: Vec<Series>,
}

/// A fixed colour per config name, so that every chart of every study
/// shows a config in the same colour (Tableau 10). A swept config
/// (`bpt-reg@tau0=30@exp=0.25`) gets its base config's colour, darker for
/// more blur than the defaults (smaller tau0, smaller exponent) and lighter
/// for less, so a sweep reads as a ramp.
pub fn color_of(name: &str) -> RGBColor {
    let Some((base, sweep)) = name.split_once('@') else {
        return base_color(name);
    };
    let RGBColor(r, g, b) = base_color(base);
    let shade = sweep_shade(sweep);
    let mix = |c: u8| {
        let c = f64::from(c);
        let target = if shade < 0.0 { 0.0 } else { 255.0 };
        (c + (target - c) * SWEEP_SHADE_RANGE * shade.abs()).round() as u8
    };
    RGBColor(mix(r), mix(g), mix(b))
}

/// How far towards black or white the most extreme sweep value moves its
/// base colour (beyond that the ramp loses its hue).
const SWEEP_SHADE_RANGE: f64 = 0.6;

/// The shade of a sweep suffix (`tau0=30@exp=0.25`) in [-1, 1]: the sum of
/// ln(tau0 / 7.5) / ln(16) and (exponent - 1/6) / (1/3), clamped, so tau0
/// 7.5 with exponent 1/6 is 0, tau0 120 is +1 and tau0 0.47 is -1.
fn sweep_shade(sweep: &str) -> f64 {
    let mut shade = 0.0;
    for part in sweep.split('@') {
        match part.split_once('=') {
            Some(("tau0", v)) => {
                if let Ok(t) = v.parse::<f64>() {
                    shade += (t / integrators::DEFAULT_TAU_0).ln() / 16f64.ln();
                }
            }
            Some(("exp", v)) => {
                if let Ok(k) = v.parse::<f64>() {
                    shade += (k - regularization::DEFAULT_SCHEDULE_EXPONENT) * 3.0;
                }
            }
            _ => {}
        }
    }
    if shade.is_finite() {
        shade.clamp(-1.0, 1.0)
    } else {
        0.0
    }
}

/// The colour of an unswept config name.
fn base_color(name: &str) -> RGBColor {
    match name {
        "pt" => RGBColor(31, 119, 180),
        "pt-reg" => RGBColor(23, 190, 207),
        "bpt" => RGBColor(255, 127, 14),
        "bpt-reg" => RGBColor(140, 86, 75),
        "ppm" => RGBColor(44, 160, 44),
        "ppm-reg" => RGBColor(188, 189, 34),
        "bpm" => RGBColor(227, 119, 194),
        "bpm-reg" => RGBColor(247, 182, 210),
        "vcm" => RGBColor(214, 39, 40),
        "vcm-reg" => RGBColor(148, 103, 189),
        // The `unsampleable` rule; PT treats it as selective.
        "pt-uns" => RGBColor(23, 190, 207),
        "bpt-uns" => RGBColor(0, 128, 128),
        "ppm-uns" => RGBColor(110, 140, 0),
        "bpm-uns" => RGBColor(200, 80, 150),
        "vcm-uns" => RGBColor(0, 60, 140),
        _ => RGBColor(127, 127, 127),
    }
}

/// Writes `dir/<stem>.svg` and `dir/<stem>.png`; returns the file names
/// written (none when no series has a point that a log axis can show).
pub fn write_chart(dir: &Path, stem: &str, chart: &Chart) -> Result<Vec<String>, String> {
    let Some(ranges) = ranges(chart) else {
        return Ok(Vec::new());
    };
    let svg_name = format!("{stem}.svg");
    let svg_path = dir.join(&svg_name);
    {
        let root = SVGBackend::new(&svg_path, SIZE).into_drawing_area();
        draw(root, chart, ranges).map_err(|e| format!("{}: {e}", svg_path.display()))?;
    }
    let png_name = format!("{stem}.png");
    let png_path = dir.join(&png_name);
    let mut canvas = Canvas::new(SIZE.0, SIZE.1, [255, 255, 255]);
    draw(Painter(&mut canvas).into_drawing_area(), chart, ranges)
        .map_err(|e| format!("{}: {e}", png_path.display()))?;
    canvas.write_png(&png_path)?;
    Ok(vec![svg_name, png_name])
}

/// Points a log-log chart can show.
fn visible(points: &[(f64, f64)]) -> impl Iterator<Item = (f64, f64)> + '_ {
    points
        .iter()
        .copied()
        .filter(|&(x, y)| x.is_finite() && y.is_finite() && x > 0.0 && y > 0.0)
}

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

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    chart: &Chart,
    ((x0, x1), (y0, y1)): Ranges,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    root.fill(&WHITE)?;
    let mut c = ChartBuilder::on(&root)
        .caption(&chart.title, ("sans-serif", 22))
        .margin(16)
        .x_label_area_size(56)
        .y_label_area_size(90)
        .build_cartesian_2d(
            (x0..x1)
                .log_scale()
                .with_key_points(ticks(x0, x1, &[1.0, 2.0, 5.0]))
                .with_light_points(ticks(
                    x0,
                    x1,
                    &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0],
                )),
            (y0..y1)
                .log_scale()
                .with_key_points(ticks(y0, y1, &[1.0, 2.0, 5.0]))
                .with_light_points(ticks(
                    y0,
                    y1,
                    &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0],
                )),
        )?;
    c.configure_mesh()
        .x_desc(chart.x_label.as_str())
        .y_desc(chart.y_label.as_str())
        .x_label_formatter(&|v| short(*v))
        .y_label_formatter(&|v| short(*v))
        .label_style(("sans-serif", 14))
        .axis_desc_style(("sans-serif", 18))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()?;
    for series in &chart.series {
        let color = color_of(&series.name);
        let points: Vec<(f64, f64)> = visible(&series.points).collect();
        let base = series.name.split('@').next().unwrap_or_default();
        let regularized = base.ends_with("-reg") || base.ends_with("-uns");
        c.draw_series(LineSeries::new(points.clone(), color.stroke_width(2)))?
            .label(series.name.as_str())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 24, y)], color.stroke_width(2))
            });
        // Regularized configs get triangles, the others circles.
        if regularized {
            c.draw_series(
                points
                    .iter()
                    .map(|&p| TriangleMarker::new(p, 5, color.filled())),
            )?;
        } else {
            c.draw_series(points.iter().map(|&p| Circle::new(p, 3, color.filled())))?;
        }
    }
    c.configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .label_font(("sans-serif", 16))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()?;
    root.present()
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

    /// A sweep reads as a ramp of its base colour: darker for more blur,
    /// lighter for less, the study's values unchanged.
    #[test]
    fn swept_configs_shade_their_base_colour() {
        let sum = |c: RGBColor| u32::from(c.0) + u32::from(c.1) + u32::from(c.2);
        let base = color_of("bpt-reg");
        let default = format!("bpt-reg@tau0={}", integrators::DEFAULT_TAU_0);
        assert_eq!(color_of(&default), base);
        let ramp: Vec<u32> = [
            "bpt-reg@tau0=2",
            "bpt-reg@tau0=7.5",
            "bpt-reg",
            "bpt-reg@tau0=120",
        ]
        .iter()
        .map(|n| sum(color_of(n)))
        .collect();
        assert!(ramp.windows(2).all(|w| w[0] < w[1]), "{ramp:?}");
        assert!(sum(color_of("bpt-reg@exp=0.1")) < sum(base));
        assert!(sum(color_of("bpt-reg@exp=0.3")) > sum(base));
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
    fn charts_are_written_as_svg_and_png() {
        let dir = std::env::temp_dir().join(format!("xtask-study-plot-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let chart = Chart {
            title: "RMSE vs time".into(),
            x_label: "seconds".into(),
            y_label: "RMSE".into(),
            series: vec![
                Series {
                    name: "bpt".into(),
                    points: vec![(0.1, 1.0), (0.2, 0.7), (0.4, 0.5)],
                },
                Series {
                    name: "bpt-reg".into(),
                    points: vec![(0.1, 0.5), (0.0, 0.4), (0.4, 0.25)],
                },
            ],
        };
        let files = write_chart(&dir, "c", &chart).unwrap();
        assert_eq!(files, ["c.svg", "c.png"]);
        let svg = std::fs::read_to_string(dir.join("c.svg")).unwrap();
        assert!(svg.contains("bpt-reg") && svg.contains("RMSE"));
        assert!(std::fs::metadata(dir.join("c.png")).unwrap().len() > 1000);
        // Nothing a log axis can show: no files.
        let empty = Chart {
            series: vec![Series {
                name: "pt".into(),
                points: vec![(1.0, 0.0)],
            }],
            ..chart
        };
        assert!(write_chart(&dir, "e", &empty).unwrap().is_empty());
        std::fs::remove_dir_all(dir).unwrap();
    }
}
