//! An 8-bit RGB canvas with an 8x8 bitmap font (public-domain `font8x8`),
//! usable as a plotters drawing backend, so that charts and the contact
//! sheet get PNG versions with labels without system fonts (plotters'
//! own bitmap backend needs fontconfig/freetype or an embedded TTF file).

use std::fs;
use std::io::BufWriter;
use std::path::Path;

use plotters_backend::{
    BackendColor, BackendCoord, BackendTextStyle, DrawingBackend, DrawingErrorKind, FontTransform,
    text_anchor::{HPos, VPos},
};

/// Width and height of a glyph of the bitmap font, in font pixels.
const GLYPH: i32 = 8;

/// An RGB image, row-major, 8 bits per channel, drawn on in sRGB values.
pub struct Canvas {
    width: u32,
    height: u32,
    pixels: Vec<[u8; 3]>,
}

/// The error type of [`Painter`] (drawing cannot fail).
#[derive(Debug)]
pub struct NoError;

impl std::fmt::Display for NoError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("no error")
    }
}

impl std::error::Error for NoError {}

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
        let error = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
        let file = fs::File::create(path).map_err(|e| error(&e))?;
        let mut encoder = png::Encoder::new(BufWriter::new(file), self.width, self.height);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder.write_header().map_err(|e| error(&e))?;
        let bytes: Vec<u8> = self.pixels.iter().flatten().copied().collect();
        writer.write_image_data(&bytes).map_err(|e| error(&e))?;
        writer.finish().map_err(|e| error(&e))
    }
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

/// The integer scale of the 8x8 font for a plotters font size in pixels.
fn font_scale(size: f64) -> i32 {
    ((size / 11.0).round() as i32).max(1)
}

/// A [`Canvas`] borrowed as a plotters drawing backend.
pub struct Painter<'a>(pub &'a mut Canvas);

impl Painter<'_> {
    /// The font scale of `text` at plotters size `size`: smaller when the
    /// text would not fit the canvas's width.
    fn scale(&self, text: &str, size: f64) -> i32 {
        let scale = font_scale(size);
        if scale > 1 && text_size(text, scale).0 > self.0.width as i32 - 16 {
            1
        } else {
            scale
        }
    }
}

impl DrawingBackend for Painter<'_> {
    type ErrorType = NoError;

    fn get_size(&self) -> (u32, u32) {
        (self.0.width, self.0.height)
    }

    fn ensure_prepared(&mut self) -> Result<(), DrawingErrorKind<NoError>> {
        Ok(())
    }

    fn present(&mut self) -> Result<(), DrawingErrorKind<NoError>> {
        Ok(())
    }

    fn draw_pixel(
        &mut self,
        (x, y): BackendCoord,
        color: BackendColor,
    ) -> Result<(), DrawingErrorKind<NoError>> {
        let (r, g, b) = color.rgb;
        self.0.blend(x, y, [r, g, b], color.alpha);
        Ok(())
    }

    fn draw_text<S: BackendTextStyle>(
        &mut self,
        text: &str,
        style: &S,
        pos: BackendCoord,
    ) -> Result<(), DrawingErrorKind<NoError>> {
        let color = style.color();
        let scale = self.scale(text, style.size());
        let (width, height) = text_size(text, scale);
        // Anchor and rotation as plotters' default implementation does them.
        let anchor = style.anchor();
        let dx = match anchor.h_pos {
            HPos::Left => 0,
            HPos::Right => -width,
            HPos::Center => -width / 2,
        };
        let dy = match anchor.v_pos {
            VPos::Top => 0,
            VPos::Center => -height / 2,
            VPos::Bottom => -height,
        };
        let transform: FontTransform = style.transform();
        let (r, g, b) = color.rgb;
        let mut points = Vec::new();
        for_each_text_pixel(text, scale, |x, y| {
            let (x, y) = transform.transform(x + dx, y + dy);
            points.push((pos.0 + x, pos.1 + y));
        });
        for (x, y) in points {
            self.0.blend(x, y, [r, g, b], color.alpha);
        }
        Ok(())
    }

    fn estimate_text_size<S: BackendTextStyle>(
        &self,
        text: &str,
        style: &S,
    ) -> Result<(u32, u32), DrawingErrorKind<NoError>> {
        let (w, h) = text_size(text, self.scale(text, style.size()));
        Ok((w as u32, h as u32))
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
