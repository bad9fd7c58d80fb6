//! `render-cli merge`: sums partial films (`--partial`) of one render into
//! its image, or into a partial film of their union for a further merge.

use std::ffi::OsString;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use clap::Parser;
use image_io::{write_exr, write_png};

use image_io::film_file::{self, EXTENSION};

use crate::cli::one_line;
use crate::outputs::check_writable;
use crate::shard;
use crate::values::parse_exposure;

const AFTER_LONG_HELP: &str = "\
The films must be of one render (same scene content, settings, seed and size) and their \
iteration ranges must tile one range without gaps or overlaps; they may be given in any order. \
Their sums are added in the order of their ranges: the image equals the single-process render of \
the same iterations (to f64 rounding of the sums, below what the f32 image resolves).

Exit status: 0 merged; 1 error (one line on stderr naming the file); 2 invalid command line.

Examples:
  render-cli merge shards/*.rltfilm -o image.exr
  render-cli merge a.rltfilm b.rltfilm -o ab.rltfilm   # merge again later";

/// Sums partial films of one render into its image.
#[derive(Debug, Parser)]
#[command(
    name = "render-cli merge",
    about = "Sums partial films (.rltfilm) of one render into its OpenEXR image (or into one partial film).",
    after_long_help = AFTER_LONG_HELP,
    max_term_width = 100
)]
pub struct MergeCli {
    /// The partial films, in any order.
    #[arg(value_name = "FILM", required = true)]
    pub films: Vec<PathBuf>,

    /// The merged result: an OpenEXR image (.exr), or a partial film (.rltfilm) to merge again.
    #[arg(short, long, value_name = "PATH")]
    pub output: PathBuf,

    /// Where to write the sRGB PNG preview of an .exr output.
    /// [default: next to the EXR, same name with .png]
    #[arg(long, value_name = "PATH", conflicts_with = "no_png")]
    pub png: Option<PathBuf>,

    /// Write no PNG preview.
    #[arg(long)]
    pub no_png: bool,

    /// Exposure of the PNG preview, in stops. [default: 0]
    #[arg(long, value_name = "STOPS", value_parser = parse_exposure, allow_hyphen_values = true)]
    pub exposure: Option<f32>,
}

/// Why a merge failed; `Display` is the one line printed after `error: `.
#[derive(Debug, thiserror::Error)]
enum MergeError {
    #[error(transparent)]
    Args(#[from] crate::error::ArgError),
    #[error("--output: {0} (expected .exr or .{EXTENSION})")]
    OutputKind(String),
    #[error(transparent)]
    Film(#[from] film_file::FilmFileError),
    #[error("cannot write {0}")]
    Write(image_io::ImageError),
    #[error("the merged film's pixel data does not match its size")]
    Size,
}

/// Parses `args` (starting with `merge`) and merges; the exit code.
pub fn main(args: &[OsString]) -> ExitCode {
    let cli = match MergeCli::try_parse_from(args) {
        Ok(cli) => cli,
        Err(e) if !e.use_stderr() => {
            let _ = e.print();
            return ExitCode::SUCCESS;
        }
        Err(e) => {
            eprintln!("{}", one_line(&e));
            return ExitCode::from(2);
        }
    };
    match run(&cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(cli: &MergeCli) -> Result<(), MergeError> {
    let start = Instant::now();
    let extension = cli
        .output
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let to_film = match extension.as_deref() {
        Some(EXTENSION) => true,
        Some("exr") => false,
        _ => return Err(MergeError::OutputKind(cli.output.display().to_string())),
    };
    check_writable("--output", &cli.output)?;
    let png = match (&cli.png, cli.no_png || to_film) {
        (_, true) => None,
        (Some(png), false) => Some(png.clone()),
        (None, false) => Some(cli.output.with_extension("png")),
    };
    if let Some(png) = &png {
        check_writable("--png", png)?;
    }
    let merged = film_file::merge(&cli.films)?;
    let h = &merged.header;
    let what = format!(
        "merged {} partial films (iterations {} of {}x{})",
        cli.films.len(),
        h.range(),
        h.width,
        h.height
    );
    let mut files = cli.output.display().to_string();
    if to_film {
        film_file::write(&cli.output, &merged)?;
    } else {
        let (width, height) = (h.width, h.height);
        let pixels = shard::film(merged).ok_or(MergeError::Size)?.mean();
        write_exr(&cli.output, width, height, &pixels).map_err(MergeError::Write)?;
        if let Some(png) = &png {
            let exposure = cli.exposure.unwrap_or(0.0);
            write_png(png, width, height, &pixels, exposure).map_err(MergeError::Write)?;
            files += &format!(", {}", png.display());
        }
    }
    eprintln!(
        "{what} in {:.2} s -> {files}",
        start.elapsed().as_secs_f64()
    );
    Ok(())
}
