//! The files a render writes, checked before the scene is loaded.

use std::path::{Path, PathBuf};

use crate::cli::Cli;
use crate::error::ArgError;

/// The OpenEXR file written without `--output`.
pub const DEFAULT_OUTPUT: &str = "render.exr";

/// The files a render writes.
#[derive(Clone, Debug, PartialEq)]
pub struct Outputs {
    /// The linear OpenEXR image.
    pub exr: PathBuf,
    /// The sRGB PNG preview, unless `--no-png`.
    pub png: Option<PathBuf>,
    /// Exposure of the preview, in stops.
    pub exposure: f32,
    /// With `--partial`: the partial film written instead of the images.
    pub partial: Option<PathBuf>,
}

impl Cli {
    /// The files to write; an error if a folder to write into does not exist.
    pub fn outputs(&self) -> Result<Outputs, ArgError> {
        if let Some(partial) = &self.partial {
            check_writable("--partial", partial)?;
        }
        if let Some(checkpoint) = &self.checkpoint {
            check_writable("--checkpoint", checkpoint)?;
            // The partial film is whole; the checkpoint is not, and is removed.
            if self
                .partial
                .as_ref()
                .is_some_and(|p| same_path(p, checkpoint))
            {
                return Err(ArgError::Flag {
                    flag: "--checkpoint",
                    message: "must be another file than --partial".to_owned(),
                });
            }
        }
        let exr = self
            .output
            .clone()
            .unwrap_or_else(|| PathBuf::from(DEFAULT_OUTPUT));
        check_writable("--output", &exr)?;
        let png = if self.no_png || self.partial.is_some() {
            None
        } else if let Some(png) = &self.png {
            check_writable("--png", png)?;
            Some(png.clone())
        } else {
            Some(exr.with_extension("png"))
        };
        Ok(Outputs {
            exr,
            png,
            exposure: self.exposure.unwrap_or(0.0),
            partial: self.partial.clone(),
        })
    }
}

/// Whether two paths name one file, as far as can be told before either exists.
fn same_path(a: &Path, b: &Path) -> bool {
    match (std::path::absolute(a), std::path::absolute(b)) {
        (Ok(a), Ok(b)) => a == b,
        _ => a == b,
    }
}

/// Checks that `path` can be created: its folder exists and it is not a folder.
pub fn check_writable(flag: &'static str, path: &Path) -> Result<(), ArgError> {
    let folder = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let message = if !folder.is_dir() {
        format!("folder {} does not exist", folder.display())
    } else if path.is_dir() {
        format!("{} is a folder", path.display())
    } else {
        return Ok(());
    };
    Err(ArgError::Flag { flag, message })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cli(args: &[&str]) -> Result<Cli, clap::Error> {
        Cli::parse_test(args)
    }

    #[test]
    fn default_png_sits_next_to_the_exr() {
        let dir = std::env::temp_dir();
        let exr = dir.join("x.exr");
        let o = cli(&["-o", exr.to_str().unwrap()])
            .unwrap()
            .outputs()
            .unwrap();
        assert_eq!(o.png, Some(dir.join("x.png")));
        let o = cli(&["--no-png"]).unwrap().outputs().unwrap();
        assert_eq!((o.exr, o.png), (PathBuf::from(DEFAULT_OUTPUT), None));
        let e = cli(&["-o", "no/such/folder/x.exr"])
            .unwrap()
            .outputs()
            .unwrap_err();
        assert!(e.to_string().contains("no/such/folder"), "{e}");
    }

    #[test]
    fn the_checkpoint_is_not_the_partial_film() {
        let e = cli(&["--partial", "a.rltfilm", "--checkpoint", "./a.rltfilm"])
            .unwrap()
            .outputs()
            .unwrap_err();
        assert!(
            e.to_string()
                .starts_with("--checkpoint: must be another file"),
            "{e}"
        );
        assert!(
            cli(&["--partial", "a.rltfilm", "--checkpoint", "b.rltfilm"])
                .unwrap()
                .outputs()
                .is_ok()
        );
        assert!(cli(&["--checkpoint-every", "5"]).is_err());
        assert!(cli(&["--checkpoint", "c.exr"]).is_err());
        assert!(cli(&["--checkpoint", "c.rltfilm", "--checkpoint-every", "-1"]).is_err());
    }
}
