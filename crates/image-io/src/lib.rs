//! The files of a render: linear HDR OpenEXR images (the result), a
//! tone-mapped 8-bit sRGB PNG (a preview), and partial films of iteration
//! shards ([`film_file`]).
//!
//! Every writer goes through a temporary file in the target folder that is
//! synced and renamed at the end ([`atomic`]), so a failed or interrupted
//! write never leaves a partial file under the requested name; [`lock`]
//! keeps two renders from writing one checkpoint.

use std::fs;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use glam::Vec3;

pub mod atomic;
pub mod film_file;
pub mod lock;

/// An image file could not be written or read.
#[derive(Debug, thiserror::Error)]
pub enum ImageError {
    /// The file system refused (missing folder, permissions, disk full).
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The EXR encoder or decoder failed (e.g. not an EXR file, no RGB layer).
    #[error("{path}: {message}")]
    Format {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
}

fn io_error(path: &Path) -> impl FnOnce(std::io::Error) -> ImageError + '_ {
    move |source| ImageError::Io {
        path: path.to_owned(),
        source,
    }
}

/// Writes `path` atomically ([`atomic`]): through `path.partial`, synced
/// and renamed when complete.
fn write_atomically(
    path: &Path,
    write: impl FnOnce(&Path) -> Result<(), ImageError>,
) -> Result<(), ImageError> {
    let result = atomic::write_atomically(path, write, io_error(path));
    // Errors name the file the caller asked for, not the temporary one.
    result.map_err(|e| match e {
        ImageError::Io { source, .. } => ImageError::Io {
            path: path.to_owned(),
            source,
        },
        ImageError::Format { message, .. } => ImageError::Format {
            path: path.to_owned(),
            message,
        },
    })
}

/// Writes a linear RGB image (row-major, `width * height` pixels) as a 32-bit
/// float OpenEXR file: RLE-compressed 64x64 tiles (the `exr` crate's
/// default), stored in increasing order, so that an image always gives the
/// same bytes (the crate's default order is whichever tile finished
/// compressing first).
pub fn write_exr(path: &Path, width: u32, height: u32, pixels: &[Vec3]) -> Result<(), ImageError> {
    use exr::prelude::*;
    assert_eq!(pixels.len(), width as usize * height as usize);
    let channels = SpecificChannels::rgb(|Vec2(x, y): Vec2<usize>| {
        let p = pixels[y * width as usize + x];
        (p.x, p.y, p.z)
    });
    let encoding = Encoding {
        line_order: LineOrder::Increasing,
        ..Encoding::FAST_LOSSLESS
    };
    let image = Image::from_encoded_channels((width as usize, height as usize), encoding, channels);
    write_atomically(path, |tmp| {
        image.write().to_file(tmp).map_err(|e| exr_error(tmp, e))
    })
}

fn exr_error(path: &Path, e: exr::error::Error) -> ImageError {
    match e {
        exr::error::Error::Io(source) => ImageError::Io {
            path: path.to_owned(),
            source,
        },
        other => ImageError::Format {
            path: path.to_owned(),
            message: other.to_string(),
        },
    }
}

/// A linear RGB image read from disk.
#[derive(Clone, Debug, PartialEq)]
pub struct RgbImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Row-major pixels.
    pub pixels: Vec<Vec3>,
}

/// Reads the first RGB(A) layer of an OpenEXR file (alpha is dropped).
pub fn read_exr(path: &Path) -> Result<RgbImage, ImageError> {
    use exr::prelude::*;
    let image = read_first_rgba_layer_from_file(
        path,
        |resolution, _| RgbImage {
            width: resolution.width() as u32,
            height: resolution.height() as u32,
            pixels: vec![glam::Vec3::ZERO; resolution.width() * resolution.height()],
        },
        |image: &mut RgbImage, position, (r, g, b, _a): (f32, f32, f32, f32)| {
            let i = position.y() * image.width as usize + position.x();
            image.pixels[i] = glam::Vec3::new(r, g, b);
        },
    )
    .map_err(|e| exr_error(path, e))?;
    Ok(image.layer_data.channel_data.pixels)
}

/// The sRGB transfer function (IEC 61966-2-1) of a linear value in [0, 1].
pub fn linear_to_srgb(c: f32) -> f32 {
    if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// Tone mapping of the preview: exposure `2^stops`, then clamp to [0, 1] and
/// the sRGB curve; NaN maps to 0 (a preview must never fail).
pub fn tone_map(p: Vec3, stops: f32) -> [u8; 3] {
    let scale = stops.exp2();
    (p * scale).to_array().map(|c| {
        let c = if c.is_nan() { 0.0 } else { c.clamp(0.0, 1.0) };
        (linear_to_srgb(c) * 255.0 + 0.5) as u8
    })
}

/// Writes an 8-bit sRGB PNG preview of a linear image, with exposure `stops`
/// (0: values of 1 map to white).
pub fn write_png(
    path: &Path,
    width: u32,
    height: u32,
    pixels: &[Vec3],
    stops: f32,
) -> Result<(), ImageError> {
    assert_eq!(pixels.len(), width as usize * height as usize);
    let bytes: Vec<u8> = pixels.iter().flat_map(|&p| tone_map(p, stops)).collect();
    write_atomically(path, |tmp| {
        let file = fs::File::create(tmp).map_err(io_error(tmp))?;
        let mut encoder = png::Encoder::new(BufWriter::new(file), width, height);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        let png_error = |e: png::EncodingError| match e {
            png::EncodingError::IoError(source) => ImageError::Io {
                path: tmp.to_owned(),
                source,
            },
            other => ImageError::Format {
                path: tmp.to_owned(),
                message: other.to_string(),
            },
        };
        let mut writer = encoder.write_header().map_err(png_error)?;
        writer.write_image_data(&bytes).map_err(png_error)?;
        writer.finish().map_err(png_error)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp_dir(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("rlt-image-io-{name}-{}", std::process::id()));
        fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn exr_round_trip_is_exact() {
        let dir = temp_dir("exr");
        let (w, h) = (5, 3);
        let pixels: Vec<Vec3> = (0..w * h)
            .map(|i| Vec3::new(i as f32 * 0.37, 1e-7 * i as f32, 1e6 + i as f32))
            .collect();
        let path = dir.join("a.exr");
        write_exr(&path, w, h, &pixels).unwrap();
        let back = read_exr(&path).unwrap();
        assert_eq!((back.width, back.height), (w, h));
        assert_eq!(back.pixels, pixels);
        assert!(!dir.join("a.exr.partial").exists());
        fs::remove_dir_all(dir).unwrap();
    }

    /// The same image gives the same bytes: the tiles are compressed in
    /// parallel, and a file whose bytes depended on which finished first
    /// could not be compared with `cmp` or a checksum.
    #[test]
    fn exr_bytes_do_not_depend_on_scheduling() {
        let dir = temp_dir("exr-bytes");
        let (w, h) = (640, 384);
        let pixels: Vec<Vec3> = (0..w * h)
            .map(|i| Vec3::splat(((i as u64 * 0x9e37_79b9) % 1000) as f32))
            .collect();
        let path = dir.join("a.exr");
        let write = || {
            write_exr(&path, w, h, &pixels).unwrap();
            fs::read(&path).unwrap()
        };
        let first = write();
        for _ in 0..8 {
            assert!(write() == first, "two writes of one image differ");
        }
        fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn failed_writes_leave_no_file_and_name_the_path() {
        let dir = temp_dir("fail");
        let path = dir.join("missing-folder").join("a.exr");
        let err = write_exr(&path, 1, 1, &[Vec3::ONE]).unwrap_err();
        assert!(err.to_string().contains("missing-folder"), "{err}");
        assert!(!err.to_string().contains(".partial"), "{err}");
        let png = dir.join("missing-folder").join("a.png");
        assert!(write_png(&png, 1, 1, &[Vec3::ONE], 0.0).is_err());
        let not_exr = dir.join("b.exr");
        fs::write(&not_exr, b"not an exr").unwrap();
        assert!(
            read_exr(&not_exr)
                .unwrap_err()
                .to_string()
                .contains("b.exr")
        );
        fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn tone_map_is_srgb_with_exposure_and_safe_on_bad_values() {
        assert_eq!(tone_map(Vec3::new(0.0, 1.0, 0.5), 0.0), [0, 255, 188]);
        assert_eq!(tone_map(Vec3::new(0.25, f32::NAN, -1.0), 1.0), [188, 0, 0]);
        assert_eq!(tone_map(Vec3::splat(f32::INFINITY), 0.0), [255; 3]);
        let dir = temp_dir("png");
        let path = dir.join("p.png");
        write_png(&path, 2, 1, &[Vec3::ZERO, Vec3::ONE], 0.0).unwrap();
        assert!(fs::read(&path).unwrap().starts_with(b"\x89PNG"));
        fs::remove_dir_all(dir).unwrap();
    }
}
