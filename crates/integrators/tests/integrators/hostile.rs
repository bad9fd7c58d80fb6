//! Hostile input through to the image: random edits of a valid manifest
//! (numbers replaced by extreme or invalid values, tokens dropped) either
//! fail to load with an error or render with every integrator without a
//! panic, a NaN or infinite sample, or a negative pixel.

use crate::common;

use integrators::{Algorithm, Mode, Renderer, Strategies};
use stats::Pcg32;

/// A small valid scene: glass, a glossy reflector, a diffuse floor, an area
/// lamp and a point light (every kind of lobe and light the integrators use).
const MANIFEST: &str = r#"resolution = [8, 6]
[camera]
from = [0, 1.6, 3.4]
at = [0, 0.3, 0]
fov = 45
[[material]]
name = "floor"
type = "diffuse"
reflectance = [0.7, 0.7, 0.7]
[[material]]
name = "metal"
type = "conductor"
alpha = 0.02
reflectance = [0.95, 0.85, 0.6]
[[material]]
name = "glass"
type = "dielectric"
alpha = 0.05
ior = 1.5
[[material]]
name = "lamp"
type = "diffuse"
reflectance = [0, 0, 0]
emission = [40, 40, 40]
[[shape]]
type = "quad"
material = "floor"
origin = [-3, 0, 3]
u = [6, 0, 0]
v = [0, 0, -6]
[[shape]]
type = "sphere"
material = "glass"
center = [0.5, 0.5, 0]
radius = 0.5
rings = 8
tessellate = true
[[shape]]
type = "sphere"
material = "metal"
center = [-0.6, 0.4, 0.2]
radius = 0.4
rings = 8
tessellate = true
[[shape]]
type = "quad"
material = "lamp"
origin = [-0.5, 2.5, -0.5]
u = [0, 0, 1]
v = [1, 0, 0]
[[light]]
type = "point"
position = [0.3, 2.2, 1.2]
intensity = [30, 30, 30]
"#;

/// Values an edit writes in place of a number.
const EXTREMES: [&str; 12] = [
    "nan", "inf", "-inf", "0", "-1", "1e39", "1e-39", "1e30", "-1e30", "3e38", "1e-7", "0.999999",
];

/// `MANIFEST` with one to three numbers replaced by extremes, or a line
/// dropped, chosen by `rng`.
fn edited(rng: &mut Pcg32) -> String {
    let mut lines: Vec<String> = MANIFEST.lines().map(str::to_owned).collect();
    for _ in 0..=rng.next_u32() % 3 {
        let i = (rng.next_u32() as usize) % lines.len();
        if rng.next_u32().is_multiple_of(8) {
            lines.remove(i);
            continue;
        }
        let line = lines[i].clone();
        let numbers: Vec<(usize, usize)> = number_spans(&line);
        if let Some(&(a, b)) = numbers.get((rng.next_u32() as usize) % numbers.len().max(1)) {
            let value = EXTREMES[(rng.next_u32() as usize) % EXTREMES.len()];
            lines[i] = format!("{}{value}{}", &line[..a], &line[b..]);
        }
    }
    lines.join("\n") + "\n"
}

/// Byte ranges of the numbers in `line`.
fn number_spans(line: &str) -> Vec<(usize, usize)> {
    let bytes = line.as_bytes();
    let mut spans = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        let starts = bytes[i].is_ascii_digit()
            || (bytes[i] == b'-' && bytes.get(i + 1).is_some_and(u8::is_ascii_digit));
        if starts {
            let a = i;
            i += 1;
            while i < bytes.len() && (bytes[i].is_ascii_digit() || b".e-".contains(&bytes[i])) {
                i += 1;
            }
            spans.push((a, i));
        } else {
            i += 1;
        }
    }
    spans
}

#[test]
fn random_edits_never_give_a_nan_or_negative_pixel() {
    let dir = tempfile_dir();
    let mut rng = Pcg32::new(19, 7);
    let (mut loaded, mut refused) = (0, 0);
    for case in 0..120 {
        let text = edited(&mut rng);
        let path = dir.join(format!("case-{case}.toml"));
        std::fs::write(&path, &text).unwrap();
        let scene = match scene::load(&path, &scene::LoadOptions::default()) {
            Ok(scene) => scene,
            Err(e) => {
                assert!(!e.to_string().contains('\n'), "case {case}: {e}");
                refused += 1;
                continue;
            }
        };
        loaded += 1;
        for (algorithm, _) in Algorithm::ALL {
            let config = integrators::RenderConfig {
                algorithm,
                ..common::config(Strategies::Mis, Mode::Selective, 6)
            };
            let renderer = Renderer::new(scene.clone(), config);
            let mut film = renderer.new_film();
            renderer.render(&mut film, 1, 2);
            let what = format!("case {case} {algorithm}:\n{text}");
            assert_eq!(renderer.invalid_samples(), 0, "{what}");
            assert!(
                film.mean()
                    .iter()
                    .all(|p| p.is_finite() && p.min_element() >= 0.0),
                "{what}"
            );
        }
    }
    eprintln!("{loaded} edited scenes rendered, {refused} refused");
    assert!(
        loaded > 20 && refused > 20,
        "{loaded} loaded, {refused} refused"
    );
    std::fs::remove_dir_all(dir).unwrap();
}

fn tempfile_dir() -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("rlt-hostile-render-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}
