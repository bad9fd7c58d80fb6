//! The XML mode: `--scene` names a Mitsuba scene file (or a folder whose
//! scene file is `scene.xml`), which Mitsuba renders itself, with no export.
//!
//! Our side loads the same file with `scene::load`. Mitsuba's side is
//! `xtask/scripts/mitsuba_pt.py --original FILE`: before each render it writes
//! a copy of FILE with the comparison's settings to
//! `<out>/mitsuba-xml/scene.xml` (`xtask/scripts/mitsuba_xml.py`: integrator
//! `path` with our max depth and rr_depth 3, an `hdrfilm` of `--resolution`
//! with a `box` filter, the configuration's sampler with sample_count =
//! spp; every other element as it was), puts FILE's folder first on
//! Mitsuba's file resolver, so that the relative paths of its meshes and
//! textures resolve, and loads the copy.

use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

use serde_json::Value;

use super::Options;
use super::export::Exported;
use super::install::Mitsuba;
use super::process::run_with_timeout;

/// The scene file of the XML mode for `--scene path`: `path` itself when it
/// ends in `.xml`, `path/scene.xml` for a folder with one and no
/// `scene.toml` (a manifest wins, as `scene::load` reads it); else `None`.
pub(super) fn scene_file(path: &Path) -> Option<PathBuf> {
    let file = scene::scene_file(path);
    is_xml(&file).then_some(file)
}

/// Whether `path` names a Mitsuba scene file (by its extension).
pub(super) fn is_xml(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("xml"))
}

/// The scene Mitsuba renders.
pub(super) enum MitsubaScene {
    /// Ours, exported by `export`: Mitsuba loads it as written.
    Exported(Exported),
    /// A Mitsuba scene file: `mitsuba_pt.py` writes its copy with the
    /// comparison's settings to `prepared` and loads that.
    File {
        original: PathBuf,
        prepared: PathBuf,
    },
}

impl MitsubaScene {
    /// `options.scene` as a Mitsuba scene file (XML mode).
    pub(super) fn file(options: &Options) -> Self {
        Self::File {
            original: options.scene.clone(),
            prepared: options.out.join("mitsuba-xml").join("scene.xml"),
        }
    }

    /// The file Mitsuba loads.
    pub(super) fn loaded(&self) -> &Path {
        match self {
            Self::Exported(e) => &e.xml,
            Self::File { prepared, .. } => prepared,
        }
    }

    /// The arguments of `mitsuba_pt.py` that say what to load.
    pub(super) fn script_args(&self, options: &Options) -> Vec<OsString> {
        let mut args: Vec<OsString> = vec!["--scene".into(), self.loaded().into()];
        if let Self::File { original, .. } = self {
            args.extend([
                "--original".into(),
                original.into(),
                "--width".into(),
                options.width.to_string().into(),
                "--height".into(),
                options.height.to_string().into(),
                "--max-depth".into(),
                options.max_depth.to_string().into(),
            ]);
        }
        args
    }
}

/// Prepares and loads the scene file once with Mitsuba, without rendering,
/// so that a file Mitsuba refuses fails before our reference is rendered;
/// says what Mitsuba made of it.
pub(super) fn check(
    root: &Path,
    mitsuba: &Mitsuba,
    options: &Options,
) -> Result<MitsubaScene, String> {
    let scene = MitsubaScene::file(options);
    let config = &options.mitsuba[0];
    let stdout = run_with_timeout(
        Command::new(&mitsuba.python)
            .arg(root.join("xtask/scripts/mitsuba_pt.py"))
            .args(scene.script_args(options))
            .arg("--out")
            .arg(options.out.join("mitsuba-xml").join("unused.exr"))
            .args(["--spp", &options.spp.to_string(), "--load-only"])
            .args(["--variant", &config.variant, "--sampler", &config.sampler]),
        Duration::from_secs(300),
    )
    .map_err(|e| format!("Mitsuba cannot load {}: {e}", options.scene.display()))?;
    let info: Value = stdout
        .lines()
        .rev()
        .find(|l| l.starts_with('{'))
        .and_then(|l| serde_json::from_str(l).ok())
        .ok_or_else(|| "mitsuba_pt.py --load-only printed no JSON result".to_string())?;
    let size = (info["width"].as_u64(), info["height"].as_u64());
    if size != (Some(options.width.into()), Some(options.height.into())) {
        return Err(format!(
            "Mitsuba's film of {} is {}x{}, expected {}x{} (the settings were not substituted)",
            scene.loaded().display(),
            info["width"],
            info["height"],
            options.width,
            options.height
        ));
    }
    println!(
        "scene: {} (Mitsuba scene file: Mitsuba renders it itself, with the comparison's settings \
         written into {}; loads in {:.3} s: {})",
        options.scene.display(),
        scene.loaded().display(),
        info["load_s"].as_f64().unwrap_or(f64::NAN),
        info["integrator"].as_str().unwrap_or("?")
    );
    Ok(scene)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mitsuba::test_options;

    #[test]
    fn a_folder_with_a_scene_xml_is_the_xml_mode() {
        let dir = std::env::temp_dir().join(format!("rlt-xtask-xml-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        assert_eq!(scene_file(&dir), None, "no scene file");
        std::fs::write(dir.join("scene.xml"), "<scene version=\"3.0.0\"/>").unwrap();
        assert_eq!(scene_file(&dir), Some(dir.join("scene.xml")));
        std::fs::write(dir.join("scene.toml"), "").unwrap();
        assert_eq!(scene_file(&dir), None, "a manifest wins");
        assert!(is_xml(Path::new("a/b.XML")) && !is_xml(Path::new("a/scene.toml")));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn the_script_gets_the_original_and_the_settings() {
        let options = test_options(&[
            "--scene",
            "scenes/veach-mis",
            "--resolution",
            "64x48",
            "--max-depth",
            "5",
        ]);
        assert!(options.scene.ends_with("scenes/veach-mis/scene.xml"));
        assert!(options.is_xml());
        let args: Vec<String> = MitsubaScene::file(&options)
            .script_args(&options)
            .into_iter()
            .map(|a| a.to_string_lossy().into_owned())
            .collect();
        let after = |flag: &str| {
            let i = args.iter().position(|a| a == flag).unwrap();
            args[i + 1].clone()
        };
        assert!(after("--scene").ends_with("mitsuba-xml/scene.xml"));
        assert!(after("--original").ends_with("scenes/veach-mis/scene.xml"));
        assert_eq!(
            (after("--width"), after("--height"), after("--max-depth")),
            ("64".into(), "48".into(), "5".into())
        );
        let toml = test_options(&["--scene", "scenes/cornell-box/scene.toml"]);
        assert!(!toml.is_xml());
    }
}
