//! `cargo xtask bench --scaling`: how load time, BVH build time, seconds per
//! iteration and peak memory grow with the triangle count (a generated height
//! field of about 1k, 10k, 100k and 1M triangles at one image size, as OBJ
//! and as binary glTF, so both loaders are measured) and with the image
//! (256^2 to 2048^2 pixels at one mesh, OBJ). Every point is one
//! `bench-run` child process, so its peak memory is its own.
//!
//! Expected shapes: time per iteration about logarithmic in triangles (BVH
//! depth) and linear in pixels; memory linear in both. The marginal bytes
//! per triangle, (peak(n) - peak(smallest)) / (n - smallest), is the figure
//! the scene's and the BVH's layouts set.

use std::fmt::Write as _;
use std::fs::{self, File};
use std::io::{BufWriter, Write as _};
use std::path::{Path, PathBuf};

use integrators::Algorithm;
use serde_json::{Value, json};

use super::{Options, child_executable, report::sig3, spawn_run};

/// Triangle counts of the mesh sweep (the height field has `2 g^2`
/// triangles for a grid of `g x g` cells: the nearest counts).
const TRIANGLES: [u64; 4] = [1_000, 10_000, 100_000, 1_000_000];
/// Image sides of the pixel sweep (square images).
const SIDES: [u32; 4] = [256, 512, 1024, 2048];
/// The mesh of the pixel sweep, and the image side of the mesh sweep.
const PIXEL_SWEEP_TRIANGLES: u64 = 100_000;
const MESH_SWEEP_SIDE: u32 = 256;
/// `--quick`: two small points per sweep, one iteration (for tests).
const QUICK_TRIANGLES: [u64; 2] = [1_000, 10_000];
const QUICK_SIDES: [u32; 2] = [32, 64];

/// Runs `cargo xtask bench --scaling [--quick] [--iterations N] [--out DIR]`.
pub(super) fn run(root: &Path, options: &Options) -> Result<(), String> {
    let (triangles, sides, pixel_mesh, mesh_side) = if options.quick {
        (
            &QUICK_TRIANGLES[..],
            &QUICK_SIDES[..],
            QUICK_TRIANGLES[1],
            QUICK_SIDES[0],
        )
    } else {
        (
            &TRIANGLES[..],
            &SIDES[..],
            PIXEL_SWEEP_TRIANGLES,
            MESH_SWEEP_SIDE,
        )
    };
    let out = options
        .out
        .clone()
        .unwrap_or_else(|| root.join("target").join("bench"));
    let meshes = out.join("scaling-meshes");
    let (exe, profile) = child_executable(root, options.quick)?;
    let algorithm = options
        .integrators
        .first()
        .copied()
        .unwrap_or(Algorithm::Pt);
    let point = |n: u64, format: MeshFormat, side: u32| -> Result<Value, String> {
        let scene = height_field_scene(&meshes, n, format)?;
        eprint!(
            "{n} triangles ({}), {side}x{side}, {algorithm} ... ",
            format.name()
        );
        let run_options = Options {
            resolution: (side, side),
            ..options.clone()
        };
        let mut result = spawn_run(&exe, &scene, algorithm, &run_options);
        if result["status"] != "ok" {
            return Err(format!("{n} triangles at {side}^2: {}", result["error"]));
        }
        eprintln!(
            "{} s/it",
            sig3(result["seconds_per_iteration"].as_f64().unwrap_or(f64::NAN))
        );
        result["triangles_asked"] = json!(n);
        result["format"] = json!(format.name());
        Ok(result)
    };
    let by_triangles = [MeshFormat::Obj, MeshFormat::Glb]
        .iter()
        .flat_map(|&format| triangles.iter().map(move |&n| (n, format)))
        .map(|(n, format)| point(n, format, mesh_side))
        .collect::<Result<Vec<_>, _>>()?;
    let by_pixels = sides
        .iter()
        .map(|&side| point(pixel_mesh, MeshFormat::Obj, side))
        .collect::<Result<Vec<_>, _>>()?;
    let doc = json!({
        "benchmark": "scaling",
        "date": super::utc_now(),
        "git": super::git_state(root),
        "profile": profile,
        "cores": crate::cores(),
        "load_average": crate::load_average(),
        "integrator": algorithm.name(),
        "iterations": options.iterations,
        "by_triangles": by_triangles,
        "by_pixels": by_pixels,
    });
    let md = markdown(&doc);
    crate::publish_report(&out, "scaling", &md, &doc)?;
    Ok(())
}

/// The file formats of the triangle sweep.
#[derive(Clone, Copy, Debug, PartialEq)]
enum MeshFormat {
    /// Wavefront OBJ, positions and faces only.
    Obj,
    /// Binary glTF 2.0: one primitive, POSITION and u32 indices.
    Glb,
}

impl MeshFormat {
    /// The file extension, also the format's name in the reports.
    fn name(self) -> &'static str {
        match self {
            Self::Obj => "obj",
            Self::Glb => "glb",
        }
    }
}

/// `dir/terrain-N-FORMAT/scene.toml` (written once): a height field of
/// about `n` triangles over [-1, 1]^2 in `format`, lit by a point light,
/// seen from above at an angle.
fn height_field_scene(dir: &Path, n: u64, format: MeshFormat) -> Result<PathBuf, String> {
    let folder = dir.join(format!("terrain-{n}-{}", format.name()));
    let manifest = folder.join("scene.toml");
    if manifest.is_file() {
        return Ok(manifest);
    }
    fs::create_dir_all(&folder).map_err(|e| format!("cannot create {}: {e}", folder.display()))?;
    let mesh = folder.join(format!("terrain.{}", format.name()));
    match format {
        MeshFormat::Obj => write_height_field(&mesh, grid_cells(n)),
        MeshFormat::Glb => write_height_field_glb(&mesh, grid_cells(n)),
    }
    .map_err(|e| format!("cannot write {}: {e}", mesh.display()))?;
    let text = format!(
        "description = \"Generated by cargo xtask bench --scaling: a height field.\"\n\
         [camera]\nfrom = [0, 2.2, 2.2]\nat = [0, 0, 0]\nfov = 45\n\n\
         [render]\nmax_depth = 8\n\n\
         [[model]]\nfile = \"terrain.{}\"\n\n\
         [[light]]\ntype = \"point\"\nposition = [0.5, 2, 0.5]\nintensity = [4, 4, 4]\n",
        format.name()
    );
    fs::write(&manifest, text).map_err(|e| format!("cannot write {}: {e}", manifest.display()))?;
    Ok(manifest)
}

/// The OBJ height-field scene of about `n` triangles under `dir` (written
/// once): the mesh `cargo xtask rays dump --height-field` traces.
pub(crate) fn height_field_obj_scene(dir: &Path, n: u64) -> Result<PathBuf, String> {
    height_field_scene(dir, n, MeshFormat::Obj)
}

/// The grid side `g` whose `2 g^2` triangles are nearest to `n`.
fn grid_cells(n: u64) -> u64 {
    ((n as f64 / 2.0).sqrt().round() as u64).max(1)
}

/// Vertex (i, j) of the height field of `g x g` cells: y = a sum of sines.
fn height_field_vertex(g: u64, i: u64, j: u64) -> [f64; 3] {
    let (x, z) = (
        2.0 * i as f64 / g as f64 - 1.0,
        2.0 * j as f64 / g as f64 - 1.0,
    );
    let y = 0.08 * (7.0 * x).sin() * (5.0 * z).cos() + 0.03 * (23.0 * (x + z)).sin();
    [x, y, z]
}

/// The height field's triangles as 0-based vertex indices (vertex (i, j) is
/// `i (g + 1) + j`), counter-clockwise seen from +y (x right, z towards the
/// viewer).
fn height_field_triangles(g: u64) -> impl Iterator<Item = [u64; 3]> {
    let v = move |i: u64, j: u64| i * (g + 1) + j;
    (0..g).flat_map(move |i| {
        (0..g).flat_map(move |j| {
            let (a, b, c, d) = (v(i, j), v(i + 1, j), v(i + 1, j + 1), v(i, j + 1));
            [[a, d, c], [a, c, b]]
        })
    })
}

/// An OBJ height field of `g x g` cells, streamed.
fn write_height_field(path: &Path, g: u64) -> std::io::Result<()> {
    let mut w = BufWriter::new(File::create(path)?);
    writeln!(w, "# height field, {g}x{g} cells, {} triangles", 2 * g * g)?;
    for i in 0..=g {
        for j in 0..=g {
            let [x, y, z] = height_field_vertex(g, i, j);
            writeln!(w, "v {x:.6} {y:.6} {z:.6}")?;
        }
    }
    for [a, b, c] in height_field_triangles(g) {
        writeln!(w, "f {} {} {}", a + 1, b + 1, c + 1)?;
    }
    w.flush()
}

/// The same height field as a binary glTF 2.0 file, streamed: a JSON chunk
/// (one node, one mesh, one primitive) and a BIN chunk holding the f32
/// positions, then the u32 indices (glTF 2.0 specification, "Binary glTF
/// Layout"; POSITION needs its min and max, §3.7.2.1).
fn write_height_field_glb(path: &Path, g: u64) -> std::io::Result<()> {
    let vertices = (g + 1) * (g + 1);
    let triangles = 2 * g * g;
    let position = |i: u64, j: u64| height_field_vertex(g, i, j).map(|c| c as f32);
    let (mut min, mut max) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for i in 0..=g {
        for j in 0..=g {
            for (k, c) in position(i, j).into_iter().enumerate() {
                min[k] = min[k].min(c);
                max[k] = max[k].max(c);
            }
        }
    }
    let (positions_bytes, indices_bytes) = (12 * vertices, 12 * triangles);
    let mut json = json!({
        "asset": {"version": "2.0", "generator": "cargo xtask bench --scaling"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "buffers": [{"byteLength": positions_bytes + indices_bytes}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": positions_bytes},
            {"buffer": 0, "byteOffset": positions_bytes, "byteLength": indices_bytes},
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": vertices, "type": "VEC3",
             "min": min, "max": max},
            {"bufferView": 1, "componentType": 5125, "count": 3 * triangles, "type": "SCALAR"},
        ],
    })
    .to_string();
    // Chunks are 4-byte aligned: JSON padded with spaces (the BIN chunk's
    // length is a multiple of 12 already).
    json.push_str(&" ".repeat(json.len().next_multiple_of(4) - json.len()));
    let bin_bytes = positions_bytes + indices_bytes;
    let total = 12 + 8 + json.len() as u64 + 8 + bin_bytes;
    let mut w = BufWriter::new(File::create(path)?);
    let word = |w: &mut BufWriter<File>, v: u64| w.write_all(&(v as u32).to_le_bytes());
    w.write_all(b"glTF")?;
    word(&mut w, 2)?;
    word(&mut w, total)?;
    word(&mut w, json.len() as u64)?;
    w.write_all(b"JSON")?;
    w.write_all(json.as_bytes())?;
    word(&mut w, bin_bytes)?;
    w.write_all(b"BIN\0")?;
    for i in 0..=g {
        for j in 0..=g {
            for c in position(i, j) {
                w.write_all(&c.to_le_bytes())?;
            }
        }
    }
    for triangle in height_field_triangles(g) {
        for v in triangle {
            word(&mut w, v)?;
        }
    }
    w.flush()
}

/// The two tables.
fn markdown(doc: &Value) -> String {
    let mut md = String::new();
    let _ = writeln!(
        md,
        "# Scaling ({}, {} iterations after a warm-up; {} cores, load {}; {} build)\n",
        doc["integrator"].as_str().unwrap_or("?"),
        doc["iterations"],
        doc["cores"],
        doc["load_average"].as_str().unwrap_or("?"),
        doc["profile"].as_str().unwrap_or("?"),
    );
    let rows = |key: &str| doc[key].as_array().cloned().unwrap_or_default();
    let f = |v: &Value, k: &str| v[k].as_f64().unwrap_or(f64::NAN);
    let by_triangles = rows("by_triangles");
    // Marginal bytes per triangle against the smallest mesh of the same format.
    let base = |r: &Value| {
        by_triangles
            .iter()
            .find(|b| b["format"] == r["format"])
            .map(|b| (f(b, "triangles"), f(b, "peak_rss_mib")))
    };
    let _ = writeln!(
        md,
        "| triangles | format | image | load (s) | BVH + lights (s) | s / iteration | peak RSS (MiB) | bytes / triangle (marginal) |\n\
         |---:|---|---:|---:|---:|---:|---:|---:|"
    );
    for r in &by_triangles {
        let per_triangle = base(r).filter(|&(n0, _)| f(r, "triangles") > n0).map_or(
            "-".to_string(),
            |(n0, m0)| {
                format!(
                    "{:.0}",
                    (f(r, "peak_rss_mib") - m0) * 1_048_576.0 / (f(r, "triangles") - n0)
                )
            },
        );
        row(&mut md, r, &per_triangle);
    }
    let _ = writeln!(
        md,
        "\n| triangles | format | image | load (s) | BVH + lights (s) | s / iteration | peak RSS (MiB) | s / iteration / Mpixel |\n\
         |---:|---|---:|---:|---:|---:|---:|---:|"
    );
    for r in &rows("by_pixels") {
        let mpixels = f(r, "width") * f(r, "height") / 1e6;
        row(&mut md, r, &sig3(f(r, "seconds_per_iteration") / mpixels));
    }
    md
}

fn row(md: &mut String, r: &Value, last: &str) {
    let f = |k: &str| r[k].as_f64().unwrap_or(f64::NAN);
    let _ = writeln!(
        md,
        "| {} | {} | {}x{} | {} | {} | {} | {:.1} | {last} |",
        r["triangles"],
        r["format"].as_str().unwrap_or("?"),
        r["width"],
        r["height"],
        sig3(f("load_seconds")),
        sig3(f("build_seconds") - f("load_seconds")),
        sig3(f("seconds_per_iteration")),
        f("peak_rss_mib"),
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Both formats load with the asked count, facing the camera, and give
    /// the same mesh (to the OBJ's six decimals).
    #[test]
    fn height_fields_have_the_asked_triangle_counts_and_load() {
        assert_eq!(
            [1_000, 10_000, 100_000, 1_000_000].map(grid_cells),
            [22, 71, 224, 707]
        );
        let dir = std::env::temp_dir().join(format!("xtask-scaling-{}", std::process::id()));
        let [obj, glb] = [MeshFormat::Obj, MeshFormat::Glb].map(|format| {
            let manifest = height_field_scene(&dir, 1_000, format).unwrap();
            scene::load(&manifest, &scene::LoadOptions::default()).unwrap()
        });
        for scene in [&obj, &glb] {
            assert_eq!(scene.triangles.len(), 2 * 22 * 22);
            // Every triangle faces up (+y), as the camera sees it.
            assert!((0..scene.triangles.len()).all(|i| scene.geometric_normal(i).y > 0.5));
        }
        for (a, b) in obj.triangles.iter().zip(&glb.triangles) {
            for (&i, &j) in a.iter().zip(b) {
                let d = obj.positions[i as usize] - glb.positions[j as usize];
                assert!(d.abs().max_element() < 1e-6, "{d}");
            }
        }
        let _ = fs::remove_dir_all(&dir);
    }

    #[test]
    fn table_reports_marginal_bytes_per_triangle() {
        let run_as = |format: &str, n: u64, mib: f64| {
            json!({"triangles": n, "format": format, "width": 64, "height": 64, "load_seconds": 0.1,
                   "build_seconds": 0.3, "seconds_per_iteration": 0.01, "peak_rss_mib": mib})
        };
        let run = |n: u64, mib: f64| run_as("obj", n, mib);
        let mib = |bytes_per_triangle: f64| bytes_per_triangle * 1e6 / 1_048_576.0;
        // Each format against its own smallest mesh.
        let doc = json!({
            "integrator": "pt", "iterations": 1, "cores": 2, "load_average": "0.5", "profile": "dev",
            "by_triangles": [
                run(1_000, 10.0), run(1_001_000, 10.0 + mib(150.0)),
                run_as("glb", 1_000, 20.0), run_as("glb", 1_001_000, 20.0 + mib(100.0)),
            ],
            "by_pixels": [run(1_000, 10.0)],
        });
        assert!(
            markdown(&doc)
                .contains("| 1001000 | glb | 64x64 | 0.100 | 0.200 | 0.0100 | 115.4 | 100 |")
        );
        let md = markdown(&doc);
        assert!(
            md.contains("| 1001000 | obj | 64x64 | 0.100 | 0.200 | 0.0100 | 153.1 | 150 |"),
            "{md}"
        );
        assert!(
            md.contains("| 1000 | obj | 64x64 | 0.100 | 0.200 | 0.0100 | 10.0 | 2.44 |"),
            "{md}"
        );
    }
}
