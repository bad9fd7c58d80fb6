//! The reference cache: `target/study/cache/<key>.exr` with a JSON sidecar
//! `<key>.json` holding the settings and the render time.
//!
//! The key is a 64-bit FNV-1a hash of the scene's files (by relative path
//! and bytes: for a `scene.toml` or a Mitsuba scene file (`.xml`), every file
//! under its folder, so the model and texture files it names count; for a
//! model file given directly, the files next to it, such as an OBJ's .mtl or
//! a glTF's buffers), the reference's settings
//! and the renderer's version (xtask's package version, the git commit and
//! a hash of uncommitted changes to the renderer's sources). FNV-1a is
//! written out here rather than taken from std, whose hasher may change
//! between Rust releases: a key must stay the same across toolchains.

use std::fs;
use std::path::{Path, PathBuf};

use glam::Vec3;
use serde_json::Value;

/// 64-bit FNV-1a.
#[derive(Clone, Copy, Debug)]
pub struct Fnv64(u64);

impl Default for Fnv64 {
    fn default() -> Self {
        Self(0xcbf2_9ce4_8422_2325)
    }
}

impl Fnv64 {
    /// Hashes raw bytes.
    pub fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 ^= u64::from(b);
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }

    /// Hashes a field with its length first, so that ("ab", "c") and
    /// ("a", "bc") differ.
    pub fn field(&mut self, bytes: &[u8]) {
        self.write(&(bytes.len() as u64).to_le_bytes());
        self.write(bytes);
    }

    /// The hash so far.
    pub fn finish(&self) -> u64 {
        self.0
    }
}

/// Every regular file in `dir` (in its subfolders too when `recursive`;
/// hidden entries skipped) as (path relative to `dir` with `/` separators,
/// bytes), sorted by path.
pub fn scene_files(dir: &Path, recursive: bool) -> Result<Vec<(String, Vec<u8>)>, String> {
    let mut files = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        let entries = fs::read_dir(&d).map_err(|e| format!("{}: {e}", d.display()))?;
        for entry in entries {
            let path = entry.map_err(|e| format!("{}: {e}", d.display()))?.path();
            let hidden = path
                .file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with('.'));
            if hidden {
                continue;
            }
            if path.is_dir() {
                if recursive {
                    stack.push(path);
                }
            } else if path.is_file() {
                let bytes = fs::read(&path).map_err(|e| format!("{}: {e}", path.display()))?;
                let relative = path
                    .strip_prefix(dir)
                    .unwrap_or(&path)
                    .components()
                    .map(|c| c.as_os_str().to_string_lossy())
                    .collect::<Vec<_>>()
                    .join("/");
                files.push((relative, bytes));
            }
        }
    }
    files.sort_by(|a, b| a.0.cmp(&b.0));
    Ok(files)
}

/// Hash of a scene's files (see [`scene_files`]).
pub fn scene_hash(files: &[(String, Vec<u8>)]) -> u64 {
    let mut h = Fnv64::default();
    for (name, bytes) in files {
        h.field(name.as_bytes());
        h.field(bytes);
    }
    h.finish()
}

/// Hash of the files of the scene `scene_file` names: the folder of a
/// manifest or of a Mitsuba scene file (`.xml`) is the scene (with
/// subfolders, so the model, mesh and texture files it names count, and the
/// files a Mitsuba scene includes; files it names outside its folder do
/// not); a model file given directly is hashed with the files next to it
/// (an OBJ's .mtl, a glTF's buffers).
pub fn scene_hash_of(scene_file: &Path) -> Result<u64, String> {
    let dir = scene_file
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let whole_folder = scene_file
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("toml") || e.eq_ignore_ascii_case("xml"));
    Ok(scene_hash(&scene_files(dir, whole_folder)?))
}

/// The renderer's version, the cache key's input: xtask's package version,
/// the git object ids of the renderer's sources at HEAD (the `crates/` tree
/// and `Cargo.lock`) when git works, and a hash of `git diff HEAD` over them
/// when that is not empty, so an uncommitted change to the renderer does
/// not reuse a stale reference while a commit that changes only documents,
/// scenes or xtask keeps the cache.
pub fn renderer_version(root: &Path) -> String {
    let mut version = format!("xtask {}", env!("CARGO_PKG_VERSION"));
    let git = |args: &[&str]| crate::git(root, args);
    let id = |object: &str| {
        git(&["rev-parse", object]).map(|o| String::from_utf8_lossy(&o).trim().to_owned())
    };
    if let (Some(crates), Some(lock)) = (id("HEAD:crates"), id("HEAD:Cargo.lock")) {
        version.push_str(&format!(", sources {crates}/{lock}"));
        if let Some(diff) = git(&["diff", "HEAD", "--", "crates", "Cargo.lock"])
            && !diff.is_empty()
        {
            let mut h = Fnv64::default();
            h.write(&diff);
            version.push_str(&format!(", uncommitted changes {:016x}", h.finish()));
        }
    }
    version
}

/// `version` with the commit it was measured at, for reports.
pub fn with_commit(root: &Path, version: &str) -> String {
    match crate::git(root, &["rev-parse", "HEAD"]) {
        Some(head) => format!(
            "{version}, commit {}",
            String::from_utf8_lossy(&head).trim()
        ),
        None => version.to_owned(),
    }
}

/// What a reference render depends on besides the scene and the renderer.
#[derive(Clone, Debug, PartialEq)]
pub struct ReferenceSpec {
    /// Config name (`vcm-reg`, ...).
    pub config: String,
    /// Iterations.
    pub iterations: u64,
    /// Seed.
    pub seed: u64,
    /// Resolution.
    pub width: u32,
    /// Resolution.
    pub height: u32,
    /// Longest path.
    pub max_depth: u32,
    /// tau_0 of the regularized configs.
    pub tau0: f64,
}

impl ReferenceSpec {
    /// The settings as one canonical line (hashed into the key).
    pub fn canonical(&self) -> String {
        format!(
            "config={};iterations={};seed={};resolution={}x{};max_depth={};tau0={:e}",
            self.config,
            self.iterations,
            self.seed,
            self.width,
            self.height,
            self.max_depth,
            self.tau0
        )
    }

    /// The cache key: 16 hex digits.
    pub fn key(&self, scene_hash: u64, renderer_version: &str) -> String {
        let mut h = Fnv64::default();
        h.field(b"rlt study reference v1");
        h.field(&scene_hash.to_le_bytes());
        h.field(self.canonical().as_bytes());
        h.field(renderer_version.as_bytes());
        format!("{:016x}", h.finish())
    }
}

/// A cache entry's files.
pub fn paths(dir: &Path, key: &str) -> (PathBuf, PathBuf) {
    (
        dir.join(format!("{key}.exr")),
        dir.join(format!("{key}.json")),
    )
}

/// The cached image and sidecar of `key`, if both are there, readable, and
/// the sidecar names the same key and resolution as the image.
pub fn load(dir: &Path, key: &str, width: u32, height: u32) -> Option<(Vec<Vec3>, Value)> {
    let (exr, json) = paths(dir, key);
    let meta: Value = serde_json::from_str(&fs::read_to_string(json).ok()?).ok()?;
    if meta["key"].as_str() != Some(key) {
        return None;
    }
    let image = image_io::read_exr(&exr).ok()?;
    ((image.width, image.height) == (width, height)).then_some((image.pixels, meta))
}

/// Stores an entry: the image first, then the sidecar, each written
/// atomically ([`write_atomic`]), so a sidecar always has its whole image
/// and a process killed at any moment leaves the entry whole or missing.
pub fn store(
    dir: &Path,
    key: &str,
    (width, height): (u32, u32),
    pixels: &[Vec3],
    meta: &Value,
) -> Result<(), String> {
    fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let (exr, json) = paths(dir, key);
    write_atomic(&exr, |tmp| crate::write_exr(tmp, width, height, pixels))?;
    let text = serde_json::to_string_pretty(meta).map_err(|e| e.to_string())? + "\n";
    write_atomic_bytes(&json, text.as_bytes())
}

/// Writes `path` whole or not at all ([`image_io::atomic`]: a temporary
/// file in the same folder, synced, renamed over `path`, the folder
/// synced); a process killed at any moment leaves `path` as it was or
/// complete. The error names `path`.
pub(crate) fn write_atomic(
    path: &Path,
    write: impl FnOnce(&Path) -> Result<(), String>,
) -> Result<(), String> {
    image_io::atomic::write_atomically(path, write, |e| {
        format!("cannot write {}: {e}", path.display())
    })
}

/// [`write_atomic`] of `bytes`.
pub(crate) fn write_atomic_bytes(path: &Path, bytes: &[u8]) -> Result<(), String> {
    write_atomic(path, |tmp| {
        fs::write(tmp, bytes).map_err(|e| format!("cannot write {}: {e}", tmp.display()))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec() -> ReferenceSpec {
        ReferenceSpec {
            config: "vcm-reg".into(),
            iterations: 10_000,
            seed: 7,
            width: 64,
            height: 48,
            max_depth: 12,
            tau0: 7.5,
        }
    }

    fn temp_dir(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("xtask-study-{name}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn fnv_matches_published_test_vectors() {
        let hash = |s: &str| {
            let mut h = Fnv64::default();
            h.write(s.as_bytes());
            h.finish()
        };
        assert_eq!(hash(""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(hash("a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(hash("foobar"), 0x8594_4171_f739_67e8);
    }

    #[test]
    fn key_is_stable_and_follows_every_input() {
        let s = spec();
        let key = s.key(1, "v");
        assert_eq!(key, spec().key(1, "v"));
        assert_eq!(key.len(), 16);
        assert_ne!(key, s.key(2, "v"));
        assert_ne!(key, s.key(1, "w"));
        let changed = [
            ReferenceSpec {
                iterations: 9_999,
                ..spec()
            },
            ReferenceSpec { seed: 8, ..spec() },
            ReferenceSpec {
                width: 48,
                height: 64,
                ..spec()
            },
            ReferenceSpec {
                config: "vcm".into(),
                ..spec()
            },
            ReferenceSpec {
                tau0: 7.6,
                ..spec()
            },
            ReferenceSpec {
                max_depth: 11,
                ..spec()
            },
        ];
        for c in changed {
            assert_ne!(c.key(1, "v"), key, "{}", c.canonical());
        }
    }

    /// A commit of documents keeps the renderer version (and the cache); a
    /// change under `crates/`, committed or not, changes it.
    #[test]
    fn renderer_version_follows_the_sources_not_the_commit() {
        let dir = temp_dir("renderer-version");
        let git = |args: &[&str]| {
            let out = std::process::Command::new("git")
                .args(["-c", "user.name=t", "-c", "user.email=t@t"])
                .args(args)
                .current_dir(&dir)
                .output()
                .unwrap();
            assert!(out.status.success(), "git {args:?}: {out:?}");
        };
        git(&["init", "-q"]);
        fs::create_dir_all(dir.join("crates")).unwrap();
        fs::write(dir.join("crates").join("lib.rs"), "fn a() {}\n").unwrap();
        fs::write(dir.join("Cargo.lock"), "lock\n").unwrap();
        git(&["add", "-A"]);
        git(&["commit", "-qm", "sources"]);
        let first = renderer_version(&dir);
        assert!(first.contains("sources "), "{first}");
        fs::write(dir.join("README.md"), "text\n").unwrap();
        git(&["add", "-A"]);
        git(&["commit", "-qm", "docs"]);
        assert_eq!(renderer_version(&dir), first);
        fs::write(dir.join("crates").join("lib.rs"), "fn b() {}\n").unwrap();
        let uncommitted = renderer_version(&dir);
        assert!(uncommitted.contains("uncommitted changes"), "{uncommitted}");
        git(&["commit", "-qam", "change"]);
        let committed = renderer_version(&dir);
        assert!(
            committed != first && committed != uncommitted,
            "{committed}"
        );
        assert!(with_commit(&dir, &committed).contains(", commit "));
        fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn scene_hash_follows_file_bytes_and_names() {
        let dir = temp_dir("scene-hash");
        fs::write(dir.join("scene.toml"), "resolution = [4, 4]\n").unwrap();
        fs::create_dir_all(dir.join("models")).unwrap();
        fs::write(dir.join("models").join("a.obj"), "v 0 0 0\n").unwrap();
        fs::write(dir.join(".hidden"), "ignored").unwrap();
        let files = scene_files(&dir, true).unwrap();
        let names: Vec<&str> = files.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, ["models/a.obj", "scene.toml"]);
        let before = scene_hash(&files);
        assert_eq!(before, scene_hash(&scene_files(&dir, true).unwrap()));
        // A changed model file changes the key.
        fs::write(dir.join("models").join("a.obj"), "v 0 0 1\n").unwrap();
        let after = scene_hash(&scene_files(&dir, true).unwrap());
        assert_ne!(before, after);
        assert_ne!(spec().key(before, "v"), spec().key(after, "v"));
        // Hidden files do not count.
        fs::write(dir.join(".hidden"), "changed").unwrap();
        assert_eq!(after, scene_hash(&scene_files(&dir, true).unwrap()));
        // Without recursion, only the folder's own files count.
        let flat = scene_files(&dir, false).unwrap();
        assert_eq!(flat.len(), 1);
        // A Mitsuba scene file's meshes in a subfolder count, as a manifest's.
        let xml = dir.join("scene.xml");
        fs::write(&xml, "<scene version=\"3.0.0\"/>").unwrap();
        let with_mesh = scene_hash_of(&xml).unwrap();
        fs::write(dir.join("models").join("a.obj"), "v 0 0 2\n").unwrap();
        assert_ne!(with_mesh, scene_hash_of(&xml).unwrap());
        fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn entries_round_trip_and_mismatches_miss() {
        let dir = temp_dir("cache");
        let pixels: Vec<Vec3> = (0..6).map(|i| Vec3::splat(i as f32 * 0.25)).collect();
        let meta = serde_json::json!({ "key": "abc", "render_seconds": 1.5 });
        store(&dir, "abc", (3, 2), &pixels, &meta).unwrap();
        let (back, m) = load(&dir, "abc", 3, 2).unwrap();
        assert_eq!(back, pixels);
        assert_eq!(m["render_seconds"], 1.5);
        assert!(load(&dir, "abc", 2, 3).is_none());
        assert!(load(&dir, "abd", 3, 2).is_none());
        fs::remove_dir_all(dir).unwrap();
    }
}
