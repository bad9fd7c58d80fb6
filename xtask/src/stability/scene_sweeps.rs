//! Short renders through `scene` and `integrators`: bundled scenes scaled by
//! 1e-4..1e5 (written as temporary manifests and OBJ files, so the loader
//! sees the scaled numbers), `stiff` as it is, and degenerate geometry.

use std::fs;
use std::path::{Path, PathBuf};
use std::time::Instant;

use glam::{UVec2, Vec3};
use integrators::{Algorithm, DEFAULT_TAU_0, Film, Mode, Regularization, RenderConfig, Renderer};
use scene::{LoadOptions, Scene};

use super::Budget;
use super::tally::{Row, Tally};

/// Keys of a manifest whose values are positions or lengths.
const LENGTH_KEYS: [&str; 8] = [
    "from", "at", "center", "radius", "origin", "u", "v", "position",
];

/// Regularization modes every render case runs (with every integrator).
const MODES: [Mode; 4] = [
    Mode::Off,
    Mode::Uniform,
    Mode::Selective,
    Mode::Unsampleable,
];

/// Seed of every render (the images do not matter, only their numbers).
const SEED: u64 = 7;

/// Every row of this module; temporary files go to `tmp`.
pub fn rows(budget: Budget, root: &Path, tmp: &Path) -> Vec<Row> {
    let scales: Vec<f64> = if budget.quick {
        vec![1e-4, 1.0, 1e5]
    } else {
        (-4..=5).map(|e| 10f64.powi(e)).collect()
    };
    let scenes = root.join("scenes");
    vec![
        scaled_row(&scenes.join("cornell-box"), &scales, tmp),
        scaled_row(&scenes.join("stiff"), &scales, tmp),
        stiff_row(budget, &scenes.join("stiff")),
        degenerate_row(budget, tmp),
    ]
}

/// Multiplies every number of `value` (a number or an array of numbers).
fn scale_value(value: &str, factor: f64) -> Option<String> {
    let v = value.trim();
    let (inner, array) = match v.strip_prefix('[').and_then(|s| s.strip_suffix(']')) {
        Some(inner) => (inner, true),
        None => (v, false),
    };
    let numbers: Option<Vec<String>> = inner
        .split(',')
        .map(|x| {
            x.trim()
                .parse::<f64>()
                .ok()
                .map(|x| format!("{:e}", x * factor))
        })
        .collect();
    let numbers = numbers?.join(", ");
    Some(if array {
        format!("[{numbers}]")
    } else {
        numbers
    })
}

/// The manifest `text` with every position and length multiplied by
/// `factor`, and point and spot intensities by `factor^2` (so that the
/// irradiance they give, and the image, stay the same).
pub fn scale_manifest(text: &str, factor: f64) -> Result<String, String> {
    // Each block: a header line and the lines up to the next header.
    let mut blocks: Vec<Vec<&str>> = vec![Vec::new()];
    for line in text.lines() {
        if line.trim_start().starts_with('[') {
            blocks.push(Vec::new());
        }
        blocks.last_mut().expect("non-empty").push(line);
    }
    let mut out = String::new();
    for block in blocks {
        let header = block.first().map_or("", |l| l.trim());
        let header = if header.starts_with('[') { header } else { "" };
        let light_type = block.iter().find_map(|l| {
            let (k, v) = l.split_once('=')?;
            (k.trim() == "type").then(|| v.trim().trim_matches('"').to_string())
        });
        for line in block {
            let scaled = line.split_once('=').and_then(|(key, rest)| {
                let key = key.trim();
                let (value, comment) = match rest.split_once('#') {
                    Some((v, c)) => (v, format!(" #{c}")),
                    None => (rest, String::new()),
                };
                let f = if header != "[render]" && LENGTH_KEYS.contains(&key) {
                    factor
                } else if header == "[[light]]"
                    && key == "intensity"
                    && matches!(light_type.as_deref(), Some("point" | "spot"))
                {
                    factor * factor
                } else {
                    return None;
                };
                Some(
                    scale_value(value, f)
                        .map(|v| format!("{key} = {v}{comment}"))
                        .ok_or_else(|| format!("cannot scale `{}`", line.trim())),
                )
            });
            match scaled {
                Some(Ok(l)) => out.push_str(&l),
                Some(Err(e)) => return Err(e),
                None => out.push_str(line),
            }
            out.push('\n');
        }
    }
    Ok(out)
}

/// The OBJ `text` with every vertex position multiplied by `factor`.
pub fn scale_obj(text: &str, factor: f64) -> Result<String, String> {
    let mut out = String::new();
    for line in text.lines() {
        match line.strip_prefix("v ") {
            Some(rest) => {
                let mut numbers = Vec::new();
                for (i, x) in rest.split_whitespace().enumerate() {
                    let x: f64 = x
                        .parse()
                        .map_err(|_| format!("cannot scale OBJ line `{line}`"))?;
                    numbers.push(format!("{:e}", if i < 3 { x * factor } else { x }));
                }
                out.push_str(&format!("v {}", numbers.join(" ")));
            }
            None => out.push_str(line),
        }
        out.push('\n');
    }
    Ok(out)
}

/// Writes a copy of the scene folder `dir` scaled by `factor` into `out`.
fn write_scaled(dir: &Path, factor: f64, out: &Path) -> Result<PathBuf, String> {
    fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    let entries = fs::read_dir(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    for entry in entries.flatten() {
        let path = entry.path();
        let name = entry.file_name();
        let target = out.join(&name);
        let read = || fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()));
        let text = match path.extension().and_then(|e| e.to_str()) {
            Some("toml") => Some(scale_manifest(&read()?, factor)?),
            Some("obj") => Some(scale_obj(&read()?, factor)?),
            _ => None,
        };
        match text {
            Some(t) => fs::write(&target, t),
            None => fs::copy(&path, &target).map(|_| ()),
        }
        .map_err(|e| format!("{}: {e}", target.display()))?;
    }
    Ok(out.join("scene.toml"))
}

/// Loads `manifest` at `size`, counting a panic; a typed error is returned.
fn load(t: &mut Tally, manifest: &Path, size: UVec2) -> Option<Result<Scene, String>> {
    let options = LoadOptions {
        resolution: Some(size),
        ..Default::default()
    };
    t.guard(
        || format!("scene::load({:?})", manifest.display()),
        |_| scene::load(manifest, &options).map_err(|e| e.to_string()),
    )
}

fn config(algorithm: Algorithm, mode: Mode, max_depth: u32) -> RenderConfig {
    RenderConfig {
        algorithm,
        regularization: Regularization::new(mode, DEFAULT_TAU_0, true)
            .expect("the default tau_0 is valid"),
        max_depth,
        seed: SEED,
        ..RenderConfig::default()
    }
}

/// Counts NaN, Inf and negative pixels of the mean image (one per pixel, by
/// its worst channel) and returns the image's mean value.
fn check_film(t: &mut Tally, film: &Film, describe: &dyn Fn() -> String) -> f64 {
    let mean = film.mean();
    let mut sum = 0.0;
    for (i, p) in mean.iter().enumerate() {
        let worst = if p.is_nan() {
            f64::NAN
        } else if !p.is_finite() {
            f64::INFINITY
        } else {
            f64::from(p.min_element())
        };
        let (x, y) = (i as u32 % film.width(), i as u32 / film.width());
        if t.value(worst, || {
            format!("pixel ({x}, {y}) = {p} of {}", describe())
        }) {
            sum += f64::from(p.x + p.y + p.z);
        }
    }
    sum / (3.0 * mean.len().max(1) as f64)
}

/// Renders `scene` with `config` for `iterations`; counts pixel problems,
/// samples the renderer zeroed, and panics. Returns the image mean.
fn render(
    t: &mut Tally,
    scene: &Scene,
    config: RenderConfig,
    iterations: u64,
    describe: &dyn Fn() -> String,
) -> Option<f64> {
    let what = || {
        format!(
            "{} with {} {:?} (max depth {}, seed {SEED}, {iterations} iterations)",
            describe(),
            config.algorithm,
            config.regularization.mode,
            config.max_depth
        )
    };
    t.guard(what, |t| {
        let renderer = Renderer::new(scene.clone(), config);
        let mut film = renderer.new_film();
        renderer.render(&mut film, 1, iterations);
        t.evaluations(u64::from(film.width() * film.height()) * iterations);
        let invalid = renderer.invalid_samples();
        t.require(invalid == 0, || {
            format!(
                "{invalid} NaN/Inf samples zeroed by the renderer: {}",
                what()
            )
        });
        check_film(t, &film, &what)
    })
}

/// A bundled scene scaled by every factor, rendered with every integrator
/// and mode; the image means are compared with the scale-1 renders.
fn scaled_row(dir: &Path, scales: &[f64], tmp: &Path) -> Row {
    let start = Instant::now();
    let mut t = Tally::default();
    let name = dir
        .file_name()
        .map_or("?".into(), |n| n.to_string_lossy().to_string());
    let size = UVec2::new(32, 24);
    let iterations = 2;
    let max_depth = 8;
    let mut unit_means: Vec<Option<f64>> = vec![None; Algorithm::ALL.len() * MODES.len()];
    let mut unit_degenerate = None;
    // Scale 1 first: the others are compared with it.
    let mut ordered = vec![1.0];
    ordered.extend(scales.iter().copied().filter(|&s| s != 1.0));
    for &scale in &ordered {
        let Some((scene, manifest)) = load_scaled(&mut t, dir, &name, scale, tmp, size) else {
            continue;
        };
        check_degenerate(
            &mut t,
            &scene,
            &mut unit_degenerate,
            (&name, scale, &manifest),
        );
        let describe = || {
            format!(
                "{name} scaled by {scale:e} (manifest {})",
                manifest.display()
            )
        };
        for (a, algorithm) in Algorithm::every().into_iter().enumerate() {
            for (m, &mode) in MODES.iter().enumerate() {
                let mean = render(
                    &mut t,
                    &scene,
                    config(algorithm, mode, max_depth),
                    iterations,
                    &describe,
                );
                let slot = &mut unit_means[a * MODES.len() + m];
                match (scale == 1.0, mean, *slot) {
                    (true, Some(mean), _) => *slot = Some(mean),
                    (false, Some(mean), Some(unit)) => t.compare(mean, unit, || {
                        format!("image mean of {} with {algorithm} {mode:?}", describe())
                    }),
                    _ => {}
                }
            }
        }
    }
    Row {
        name: format!("scene: {name} scaled"),
        covers: format!(
            "scenes/{name} with positions and lengths x s (point/spot intensities x s^2, so the image is the same), \
             s = {}; 32x24, {iterations} iterations, max depth {max_depth}; pt, bpt, ppm, bpm, vcm x off, uniform, selective, unsampleable",
            ordered
                .iter()
                .map(|s| format!("{s:e}"))
                .collect::<Vec<_>>()
                .join(", ")
        ),
        other: "samples the renderer zeroed (invalid_samples), a scaled scene that does not load, \
                or more triangles dropped as degenerate than at scale 1",
        reference: Some(
            "the image mean of the same render at scale 1 (same seed; informational, not a limit)",
        ),
        tally: t,
        seconds: start.elapsed().as_secs_f64(),
    }
}

/// The bundled scene in `dir` scaled by `scale`, written under `tmp` and
/// loaded at `size`, with its manifest; None (tallied) when either fails.
fn load_scaled(
    t: &mut Tally,
    dir: &Path,
    name: &str,
    scale: f64,
    tmp: &Path,
    size: UVec2,
) -> Option<(scene::Scene, PathBuf)> {
    let out = tmp.join(format!("{name}-x{scale:e}"));
    let manifest = match write_scaled(dir, scale, &out) {
        Ok(m) => m,
        Err(e) => {
            t.require(false, || format!("cannot write the scaled scene: {e}"));
            return None;
        }
    };
    let scene = match load(t, &manifest, size)? {
        Ok(s) => s,
        Err(e) => {
            t.require(false, || {
                format!("{name} scaled by {scale:e} does not load: {e}")
            });
            return None;
        }
    };
    if scene.report.degenerate_triangles > 0 {
        t.note(format!(
            "scale {scale:e}: {} degenerate triangles skipped by the loader",
            scene.report.degenerate_triangles
        ));
    }
    Some((scene, manifest))
}

/// Scaling changes no triangle's shape: the loader must not find more of
/// them degenerate than at scale 1 (`unit`, set by the first call). (The
/// triangle count itself may differ: shapes::sphere drops pole triangles
/// whose vertices round to one point, which depends on the scale.)
fn check_degenerate(
    t: &mut Tally,
    scene: &scene::Scene,
    unit: &mut Option<usize>,
    (name, scale, manifest): (&str, f64, &Path),
) {
    let degenerate = scene.report.degenerate_triangles;
    match *unit {
        None => *unit = Some(degenerate),
        Some(unit) => {
            t.require(degenerate <= unit, || {
                format!(
                    "{name} scaled by {scale:e}: the loader drops {degenerate} triangles as degenerate \
                     ({unit} at scale 1; manifest {})",
                    manifest.display()
                )
            });
        }
    }
}

/// `stiff` as bundled (its resolution and depth; fewer iterations in --quick).
fn stiff_row(budget: Budget, dir: &Path) -> Row {
    let start = Instant::now();
    let mut t = Tally::default();
    let manifest = dir.join("scene.toml");
    // Not its own 128x96: PPM, BPM and VCM merge within 0.3 % of the scene's
    // bounding radius, which its 1e5 backdrop makes about 200 units, so every
    // camera vertex merges with every photon and an iteration costs O(pixels^2)
    // (6 s at 128x96 against 0.03 s for PT).
    let (size, iterations) = if budget.quick {
        (UVec2::new(32, 24), 4)
    } else {
        (UVec2::new(64, 48), 8)
    };
    if let Some(result) = load(&mut t, &manifest, size) {
        match result {
            Err(e) => {
                t.require(false, || format!("stiff does not load: {e}"));
            }
            Ok(scene) => {
                let max_depth = scene.render.max_depth.unwrap_or(16);
                let describe = || "scenes/stiff/scene.toml".to_string();
                for algorithm in Algorithm::every() {
                    for mode in MODES {
                        render(
                            &mut t,
                            &scene,
                            config(algorithm, mode, max_depth),
                            iterations,
                            &describe,
                        );
                    }
                }
            }
        }
    }
    Row {
        name: "scene: stiff as bundled".into(),
        covers: format!(
            "scenes/stiff unscaled at {}x{}, {iterations} iterations, its max depth (16); pt, bpt, ppm, bpm, vcm x off, uniform, selective, unsampleable",
            size.x, size.y
        ),
        other: "samples the renderer zeroed (invalid_samples), or the scene does not load",
        reference: None,
        tally: t,
        seconds: start.elapsed().as_secs_f64(),
    }
}

/// The shared part of the degenerate scenes: camera, materials, a floor.
const BASE: &str = r#"
[camera]
from = [0, 1, 3]
at = [0, 0.5, 0]
fov = 50

[[material]]
name = "white"
type = "diffuse"
reflectance = [0.8, 0.8, 0.8]

[[material]]
name = "lamp"
type = "diffuse"
reflectance = [0, 0, 0]
emission = [10, 10, 10]

[[material]]
name = "glass"
type = "dielectric"
alpha = 0.0
ior = 1.5

[[material]]
name = "glossy"
type = "conductor"
alpha = 0.01
reflectance = [0.9, 0.9, 0.9]
"#;

const FLOOR: &str = r#"
[[shape]]
type = "quad"
material = "white"
origin = [-2, 0, 2]
u = [4, 0, 0]
v = [0, 0, -4]
"#;

const POINT_LIGHT: &str = r#"
[[light]]
type = "point"
position = [0, 2, 1]
intensity = [5, 5, 5]
"#;

fn quad(material: &str, origin: [f32; 3], u: [f32; 3], v: [f32; 3]) -> String {
    let a = |x: [f32; 3]| format!("[{:e}, {:e}, {:e}]", x[0], x[1], x[2]);
    format!(
        "\n[[shape]]\ntype = \"quad\"\nmaterial = \"{material}\"\norigin = {}\nu = {}\nv = {}\n",
        a(origin),
        a(u),
        a(v)
    )
}

/// One degenerate scene: its name, manifest and OBJ files.
struct Case {
    name: &'static str,
    manifest: String,
    objs: Vec<(&'static str, &'static str)>,
}

/// An OBJ with one good triangle and zero-area faces: a repeated index, a
/// repeated position, collinear vertices.
const ZERO_AREA_OBJ: &str = "v -1 0 -1\nv 1 0 -1\nv 0 1 -1\nv 0 1 -1\nv 2 0 -1\nv 3 0 -1\n\
f 1 2 3\nf 1 1 2\nf 3 4 1\nf 1 2 5\nf 2 5 6\nf 4 4 4\n";

const SINGLE_TRIANGLE_OBJ: &str = "v -1 0 -1\nv 1 0 -1\nv 0 1.5 -1\nf 1 2 3\n";

fn cases() -> Vec<Case> {
    let lamp = quad("lamp", [-0.3, 1.9, -0.3], [0.6, 0.0, 0.0], [0.0, 0.0, 0.6]);
    vec![
        Case {
            name: "zero-area triangles (OBJ: repeated index, repeated position, collinear)",
            manifest: format!(
                "{BASE}{FLOOR}{lamp}{POINT_LIGHT}\n[[model]]\nfile = \"zero-area.obj\"\n"
            ),
            objs: vec![("zero-area.obj", ZERO_AREA_OBJ)],
        },
        Case {
            name: "a single triangle, lit by a point light",
            manifest: format!("{BASE}{POINT_LIGHT}\n[[model]]\nfile = \"one.obj\"\n"),
            objs: vec![("one.obj", SINGLE_TRIANGLE_OBJ)],
        },
        Case {
            name: "a single emitting triangle and nothing else",
            manifest: format!(
                "{BASE}\n[[model]]\nfile = \"one.obj\"\n\n[[material]]\nname = \"default\"\nemission = [3, 3, 3]\n"
            ),
            objs: vec![("one.obj", SINGLE_TRIANGLE_OBJ)],
        },
        Case {
            name: "coincident triangles (emitter on a diffuse quad, glass on glass, opposite facing, glossy on diffuse)",
            manifest: format!(
                "{BASE}{FLOOR}{}{}{}{}{}{}{POINT_LIGHT}",
                quad("white", [-0.5, 0.5, -1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
                quad("lamp", [-0.5, 0.5, -1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
                quad("glass", [-1.0, 0.2, 0.0], [2.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
                quad("glass", [-1.0, 0.2, 0.0], [0.0, 1.0, 0.0], [2.0, 0.0, 0.0]),
                quad(
                    "glossy",
                    [-2.0, 0.0, 2.0],
                    [4.0, 0.0, 0.0],
                    [0.0, 0.0, -4.0]
                ),
                lamp,
            ),
            objs: vec![],
        },
        Case {
            name: "zero-area emitters (quad with u = 0, quad with u parallel to v) beside a point light",
            manifest: format!(
                "{BASE}{FLOOR}{}{}{POINT_LIGHT}",
                quad("lamp", [0.0, 1.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.5]),
                quad("lamp", [0.0, 1.0, 0.0], [0.5, 0.0, 0.0], [1.0, 0.0, 0.0]),
            ),
            objs: vec![],
        },
        Case {
            name: "an emitting sphere of radius 0",
            manifest: format!(
                "{BASE}{FLOOR}{POINT_LIGHT}\n[[shape]]\ntype = \"sphere\"\nmaterial = \"lamp\"\ncenter = [0, 1, 0]\nradius = 0\n"
            ),
            objs: vec![],
        },
        Case {
            name: "tiny emitters: quads of side 1e-10 (area 1e-20) and 1e-19 (area underflows)",
            manifest: format!(
                "{BASE}{FLOOR}{}{}",
                quad(
                    "lamp",
                    [0.0, 1.0, 0.0],
                    [1e-10, 0.0, 0.0],
                    [0.0, 0.0, 1e-10]
                ),
                quad(
                    "lamp",
                    [0.2, 1.0, 0.0],
                    [1e-19, 0.0, 0.0],
                    [0.0, 0.0, 1e-19]
                ),
            ),
            objs: vec![],
        },
        Case {
            name: "no geometry (a point light only)",
            manifest: format!("{BASE}{POINT_LIGHT}"),
            objs: vec![],
        },
        Case {
            name: "no lights",
            manifest: format!("{BASE}{FLOOR}"),
            objs: vec![],
        },
    ]
}

/// A scene with zero-area triangles, one of them emitting, put into the
/// `Scene` directly (bypassing the loader, which skips such triangles).
fn in_memory_degenerate(mut scene: Scene) -> Scene {
    let lamp = scene
        .materials
        .iter()
        .position(|m| m.name == "lamp")
        .unwrap_or(0) as u32;
    let white = scene
        .materials
        .iter()
        .position(|m| m.name == "white")
        .unwrap_or(0) as u32;
    let p = Vec3::new(0.0, 1.0, 0.0);
    for (triangle, material) in [
        ([p, p, p], lamp),
        ([p, p + Vec3::X, p + 2.0 * Vec3::X], lamp),
        ([Vec3::ZERO, Vec3::X, Vec3::X], white),
    ] {
        let first = scene.positions.len() as u32;
        scene.positions.extend(triangle);
        scene.triangles.push([first, first + 1, first + 2]);
        scene.normals.resize(first as usize, Vec3::ZERO);
        scene.normals.extend([Vec3::Y; 3]);
        if !scene.uvs.is_empty() {
            scene.uvs.extend([glam::Vec2::ZERO; 3]);
        }
        if !scene.tangents.is_empty() {
            scene.tangents.extend([glam::Vec4::ZERO; 3]);
        }
        scene.triangle_materials.push(material);
        if material == lamp {
            scene.lights.push(scene::Light::Area {
                triangle: (scene.triangles.len() - 1) as u32,
            });
        }
    }
    scene
}

/// Every degenerate case: loaded (a typed error is fine), then rendered
/// with every integrator and mode.
fn degenerate_row(budget: Budget, tmp: &Path) -> Row {
    let start = Instant::now();
    let mut t = Tally::default();
    let size = UVec2::new(32, 24);
    let iterations = 2;
    let modes: &[Mode] = if budget.quick {
        &[Mode::Off, Mode::Selective]
    } else {
        &MODES
    };
    let cases = cases();
    let mut rendered = Vec::new();
    for (i, case) in cases.iter().enumerate() {
        let dir = tmp.join(format!("degenerate-{i}"));
        let written = fs::create_dir_all(&dir)
            .and_then(|()| fs::write(dir.join("scene.toml"), &case.manifest))
            .and_then(|()| {
                case.objs
                    .iter()
                    .try_for_each(|(name, text)| fs::write(dir.join(name), text))
            });
        if let Err(e) = written {
            t.require(false, || format!("cannot write {}: {e}", dir.display()));
            continue;
        }
        let manifest = dir.join("scene.toml");
        t.evaluation();
        match load(&mut t, &manifest, size) {
            Some(Ok(scene)) => {
                t.note(format!(
                    "{}: loaded ({} triangles, {} skipped as degenerate, {} lights)",
                    case.name,
                    scene.triangles.len(),
                    scene.report.degenerate_triangles,
                    scene.lights.len()
                ));
                if i == 0 {
                    rendered.push((
                        "in memory: the zero-area case plus zero-area triangles (two emitting) the loader would skip",
                        in_memory_degenerate(scene.clone()),
                        manifest.clone(),
                    ));
                }
                rendered.push((case.name, scene, manifest));
            }
            Some(Err(e)) => t.note(format!("{}: typed error: {e}", case.name)),
            None => {}
        }
    }
    for (name, scene, manifest) in &rendered {
        let describe = || format!("{name} ({})", manifest.display());
        for algorithm in Algorithm::every() {
            for &mode in modes {
                render(
                    &mut t,
                    scene,
                    config(algorithm, mode, 8),
                    iterations,
                    &describe,
                );
            }
        }
    }
    Row {
        name: "scene: degenerate geometry".into(),
        covers: format!(
            "{} cases ({}), and the first with zero-area triangles injected into the Scene; each loaded (a typed error is fine) \
             and rendered 32x24, {iterations} iterations, pt, bpt, ppm, bpm, vcm x {}",
            cases.len(),
            cases.iter().map(|c| c.name).collect::<Vec<_>>().join("; "),
            modes
                .iter()
                .map(|m| format!("{m:?}").to_lowercase())
                .collect::<Vec<_>>()
                .join(", ")
        ),
        other: "samples the renderer zeroed (invalid_samples)",
        reference: None,
        tally: t,
        seconds: start.elapsed().as_secs_f64(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn manifest_scaling_touches_positions_lengths_and_point_intensities_only() {
        let text = r#"description = "a = [1, 2, 3]"
resolution = [64, 48]
[camera]
from = [0, 1, 4]   # eye
at = [0, 0.5, 0]
up = [0, 1, 0]
fov = 40
[render]
iterations = 16
[[material]]
name = "m"
eta = [1, 1, 1]
[[shape]]
type = "sphere"
center = [1, 2, 3]
radius = 0.5
axis = [0, 1, 0]
[[light]]
type = "point"
position = [1, 1, 1]
intensity = [2, 2, 2]
[[light]]
type = "environment"
intensity = [1, 1, 1]
"#;
        let scaled = scale_manifest(text, 10.0).unwrap();
        let lines: Vec<&str> = scaled.lines().collect();
        assert_eq!(lines[0], r#"description = "a = [1, 2, 3]""#);
        assert_eq!(lines[1], "resolution = [64, 48]");
        assert_eq!(lines[3], "from = [0e0, 1e1, 4e1] # eye");
        assert_eq!(lines[4], "at = [0e0, 5e0, 0e0]");
        assert_eq!(lines[5], "up = [0, 1, 0]");
        assert_eq!(lines[6], "fov = 40");
        assert_eq!(lines[8], "iterations = 16");
        assert_eq!(lines[11], "eta = [1, 1, 1]");
        assert_eq!(lines[14], "center = [1e1, 2e1, 3e1]");
        assert_eq!(lines[15], "radius = 5e0");
        assert_eq!(lines[16], "axis = [0, 1, 0]");
        assert_eq!(lines[19], "position = [1e1, 1e1, 1e1]");
        assert_eq!(lines[20], "intensity = [2e2, 2e2, 2e2]");
        assert_eq!(lines[23], "intensity = [1, 1, 1]");
        assert!(scale_manifest("[camera]\nfrom = [a, b, c]\n", 2.0).is_err());
    }

    #[test]
    fn obj_scaling_touches_vertex_positions_only() {
        let scaled = scale_obj("# c\nv 1 -2 3\nvn 0 1 0\nf 1 2 3\n", 0.5).unwrap();
        assert_eq!(scaled, "# c\nv 5e-1 -1e0 1.5e0\nvn 0 1 0\nf 1 2 3\n");
        assert!(scale_obj("v 1 x 3\n", 2.0).is_err());
    }

    #[test]
    fn bundled_scenes_scale_and_load() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let tmp = std::env::temp_dir().join(format!("xtask-stability-test-{}", std::process::id()));
        for name in ["stiff", "cornell-box"] {
            let manifest =
                write_scaled(&root.join("scenes").join(name), 1e-3, &tmp.join(name)).unwrap();
            let scene = scene::load(&manifest, &LoadOptions::default()).unwrap();
            let original = scene::load(
                &root.join("scenes").join(name).join("scene.toml"),
                &LoadOptions::default(),
            )
            .unwrap();
            let (lo, hi) = scene.bounds();
            let (olo, ohi) = original.bounds();
            assert!(
                ((hi - lo).length() / (ohi - olo).length() / 1e-3 - 1.0).abs() < 1e-4,
                "{name}"
            );
            assert!((scene.camera.position - original.camera.position * 1e-3).length() < 1e-6);
        }
        let _ = fs::remove_dir_all(&tmp);
    }
}
