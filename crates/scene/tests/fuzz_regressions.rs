//! Inputs found by the fuzz targets (`fuzz/`, `cargo xtask fuzz`) that made
//! `scene::load` panic: every file in `tests/fuzz-regressions/` is loaded
//! inside `catch_unwind`; Ok and Err are both fine, a panic is not.
//!
//! Files are named `<target>-<short-name>.<ext>` and are set up as the fuzz
//! target did: each is written to a fresh temporary folder (next to copies
//! of the fixed glTF buffers the `gltf_json` target provides), `.objmtl`
//! files are split at the first NUL byte into `input.obj` and `fuzz.mtl`,
//! `.xml` files become `scene.xml` (Mitsuba). `.ply` and `.serialized`
//! inputs go to their mesh readers directly, as their targets do (a
//! `.serialized` input's first byte is the shape index). Files of the
//! `render` target are loaded only here (at 8x6 pixels).

use std::panic::{self, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use glam::UVec2;

/// Files (names in `tests/fuzz-regressions/`) that still panic because the
/// loader fix has not landed yet. The test lists them and passes; it fails
/// if any other file panics, and also if a file listed here no longer
/// panics. Empty: the glTF validation and the MTL checks fixed all five
/// inputs found (GLB header length below 12, NORMAL declared VEC4, float
/// indices, byteStride below the element size, an MTL colour of fewer than
/// three numbers).
const EXPECTED_TO_PANIC_TODAY: &[&str] = &[];

/// The buffers the `gltf_json` fuzz target writes next to its input.
const GLTF_BUFFERS: &[&str] = &[
    "Box/glTF/Box0.bin",
    "Cameras/glTF/simpleSquare.bin",
    "MetalRoughSpheresNoTextures/glTF/MetalRoughSpheresNoTextures.bin",
];

fn tests_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests")
}

/// Writes `input` (a file of `tests/fuzz-regressions/`) into `dir` the way
/// its fuzz target did; returns the path to load.
fn stage(input: &Path, dir: &Path) -> PathBuf {
    let bytes = std::fs::read(input).unwrap();
    let ext = input.extension().and_then(|e| e.to_str()).unwrap_or("");
    match ext {
        "objmtl" => {
            let (obj, mtl) = match bytes.iter().position(|&b| b == 0) {
                Some(i) => (&bytes[..i], &bytes[i + 1..]),
                None => (&bytes[..], &[][..]),
            };
            std::fs::write(dir.join("fuzz.mtl"), mtl).unwrap();
            let path = dir.join("input.obj");
            std::fs::write(&path, obj).unwrap();
            path
        }
        "gltf" | "glb" => {
            for buffer in GLTF_BUFFERS {
                let from = tests_dir().join("data").join(buffer);
                let name = Path::new(buffer).file_name().unwrap();
                std::fs::copy(&from, dir.join(name)).unwrap();
            }
            let path = dir.join(format!("input.{ext}"));
            std::fs::write(&path, &bytes).unwrap();
            path
        }
        "xml" => {
            let path = dir.join("scene.xml");
            std::fs::write(&path, &bytes).unwrap();
            path
        }
        _ => {
            let path = dir.join("scene.toml");
            std::fs::write(&path, &bytes).unwrap();
            path
        }
    }
}

/// What the input's fuzz target does with it: a mesh reader for `.ply`
/// and `.serialized`, `scene::load` of the staged `path` otherwise.
fn read(input: &Path, path: &Path, options: &scene::LoadOptions) -> Result<(), String> {
    use scene::mitsuba::{ply, serialized};
    let bytes = || std::fs::read(input).unwrap();
    match input.extension().and_then(|e| e.to_str()) {
        Some("ply") => ply::read(&bytes()).map(drop),
        Some("serialized") => {
            let bytes = bytes();
            let (index, data) = bytes.split_first().map_or((0, &[][..]), |(i, d)| (*i, d));
            serialized::read(data, u32::from(index)).map(drop)
        }
        _ => scene::load(path, options)
            .map(drop)
            .map_err(|e| e.to_string()),
    }
}

#[test]
fn fuzz_regressions_do_not_panic() {
    let folder = tests_dir().join("fuzz-regressions");
    let mut inputs: Vec<PathBuf> = std::fs::read_dir(&folder)
        .map(|entries| entries.filter_map(Result::ok).map(|e| e.path()).collect())
        .unwrap_or_default();
    inputs.retain(|p| p.is_file() && p.extension().is_some_and(|e| e != "md"));
    inputs.sort();

    // Record panic messages instead of printing them.
    let last_panic: Arc<Mutex<Option<String>>> = Arc::default();
    let recorder = Arc::clone(&last_panic);
    let previous_hook = panic::take_hook();
    panic::set_hook(Box::new(move |info| {
        let location = info.location().map_or("?".to_string(), |l| {
            // Registry paths shortened to `crate-version/src/...`.
            let file = l.file();
            let file = file.find("index.crates.io-").map_or(file, |i| {
                file[i..].split_once('/').map_or(file, |(_, rest)| rest)
            });
            format!("{file}:{}", l.line())
        });
        let payload = info
            .payload()
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| info.payload().downcast_ref::<String>().cloned())
            .unwrap_or_default();
        *recorder.lock().unwrap() = Some(format!("{location}: {payload}"));
    }));

    let mut unexpected = Vec::new();
    let mut still_panicking = Vec::new();
    let mut stale = Vec::new();
    for (i, input) in inputs.iter().enumerate() {
        let name = input.file_name().unwrap().to_string_lossy().into_owned();
        let dir =
            std::env::temp_dir().join(format!("rlt-fuzz-regression-{}-{i}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = stage(input, &dir);
        let options = scene::LoadOptions {
            resolution: name.starts_with("render-").then(|| UVec2::new(8, 6)),
            ..Default::default()
        };
        *last_panic.lock().unwrap() = None;
        let outcome = panic::catch_unwind(AssertUnwindSafe(|| read(input, &path, &options)));
        let _ = std::fs::remove_dir_all(&dir);
        let expected = EXPECTED_TO_PANIC_TODAY.contains(&name.as_str());
        match outcome {
            Ok(result) => {
                let verdict = match result {
                    Ok(()) => "Ok".to_string(),
                    Err(e) => format!("Err({e})"),
                };
                println!("{name}: no panic: {verdict}");
                if expected {
                    stale.push(name);
                }
            }
            Err(_) => {
                let message = last_panic.lock().unwrap().take().unwrap_or_default();
                println!("{name}: PANIC at {message}");
                if expected {
                    still_panicking.push(format!("{name} ({message})"));
                } else {
                    unexpected.push(format!("{name} ({message})"));
                }
            }
        }
    }
    panic::set_hook(previous_hook);

    println!(
        "{} inputs; expected to panic today ({}):",
        inputs.len(),
        still_panicking.len()
    );
    for entry in &still_panicking {
        println!("  {entry}");
    }
    for name in EXPECTED_TO_PANIC_TODAY {
        assert!(
            inputs
                .iter()
                .any(|p| p.file_name().is_some_and(|f| f == *name)),
            "EXPECTED_TO_PANIC_TODAY names {name}, which is not in tests/fuzz-regressions/"
        );
    }
    assert!(
        unexpected.is_empty(),
        "scene::load panicked on inputs not in EXPECTED_TO_PANIC_TODAY:\n  {}",
        unexpected.join("\n  ")
    );
    assert!(
        stale.is_empty(),
        "these inputs no longer panic: remove them from EXPECTED_TO_PANIC_TODAY:\n  {}",
        stale.join("\n  ")
    );
}
