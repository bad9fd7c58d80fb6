//! An 8-bit RGB canvas with an 8x8 bitmap font (public-domain `font8x8`)
//! for the contact sheet's and the bias image's labels, and the PNG writer
//! that the charts share.

use std::fs;
use std::io::BufWriter;
use std::path::Path;

/// Width and height of a glyph of the bitmap font, in font pixels.
const GLYPH: i32 = 8;

/// An RGB image, row-major, 8 bits per channel, drawn on in sRGB values.
pub struct Canvas {
    width: u32,
    height: u32,
    pixels: Vec<[u8; 3]>,
}

impl Canvas {
    /// A canvas filled with `background`.
    pub fn new(width: u32, height: u32, background: [u8; 3]) -> Self {
        Self {
            width,
            height,
            pixels: vec![background; width as usize * height as usize],
        }
    }

    /// Blends `color` with opacity `alpha` into pixel (x, y); outside is ignored.
    pub fn blend(&mut self, x: i32, y: i32, color: [u8; 3], alpha: f64) {
        if x < 0 || y < 0 || x >= self.width as i32 || y >= self.height as i32 {
            return;
        }
        let p = &mut self.pixels[y as usize * self.width as usize + x as usize];
        let a = alpha.clamp(0.0, 1.0);
        for (c, &s) in p.iter_mut().zip(&color) {
            *c = (f64::from(*c) * (1.0 - a) + f64::from(s) * a).round() as u8;
        }
    }

    /// Writes the canvas as an 8-bit sRGB PNG file.
    pub fn write_png(&self, path: &Path) -> Result<(), String> {
        let bytes: Vec<u8> = self.pixels.iter().flatten().copied().collect();
        write_rgb_png(path, (self.width, self.height), &bytes)
    }
}

/// Writes `rgb`, row-major 8-bit RGB of `width` x `height` pixels, as an
/// sRGB PNG file.
pub fn write_rgb_png(path: &Path, (width, height): (u32, u32), rgb: &[u8]) -> Result<(), String> {
    let error = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
    let file = fs::File::create(path).map_err(|e| error(&e))?;
    let mut encoder = png::Encoder::new(BufWriter::new(file), width, height);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header().map_err(|e| error(&e))?;
    writer.write_image_data(rgb).map_err(|e| error(&e))?;
    writer.finish().map_err(|e| error(&e))
}

/// Size in pixels of `text` drawn at integer `scale` (one line, ASCII).
pub fn text_size(text: &str, scale: i32) -> (i32, i32) {
    (text.chars().count() as i32 * GLYPH * scale, GLYPH * scale)
}

/// Calls `plot(x, y)` for every set pixel of `text` at integer `scale`,
/// with (0, 0) the top left of the text box. Characters outside ASCII are
/// drawn as `?`.
pub fn for_each_text_pixel(text: &str, scale: i32, mut plot: impl FnMut(i32, i32)) {
    for (i, ch) in text.chars().enumerate() {
        let code = if ch.is_ascii() {
            ch as usize
        } else {
            '?' as usize
        };
        let glyph = font8x8::legacy::BASIC_LEGACY[code];
        for (row, bits) in glyph.iter().enumerate() {
            for col in 0..GLYPH {
                // Bit 0 is the leftmost pixel of the row.
                if bits >> col & 1 == 1 {
                    for sy in 0..scale {
                        for sx in 0..scale {
                            plot(
                                (i as i32 * GLYPH + col) * scale + sx,
                                row as i32 * scale + sy,
                            );
                        }
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_pixels_stay_in_the_text_box() {
        let (w, h) = text_size("Ab1", 2);
        assert_eq!((w, h), (48, 16));
        let mut count = 0;
        for_each_text_pixel("Ab1", 2, |x, y| {
            assert!((0..w).contains(&x) && (0..h).contains(&y));
            count += 1;
        });
        // Every glyph pixel is a 2x2 block; a space draws nothing.
        assert!(count > 0 && count % 4 == 0);
        for_each_text_pixel(" ", 1, |_, _| panic!("a space has no pixels"));
    }

    #[test]
    fn blending_and_bounds() {
        let mut c = Canvas::new(2, 1, [0, 0, 0]);
        c.blend(0, 0, [200, 100, 50], 0.5);
        c.blend(5, 5, [255, 255, 255], 1.0);
        assert_eq!(c.pixels[0], [100, 50, 25]);
        assert_eq!(c.pixels[1], [0, 0, 0]);
    }
}
