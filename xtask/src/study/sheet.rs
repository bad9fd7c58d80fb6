//! The contact sheet (as in supp. Figure 2): the whole reference with the
//! crop window outlined, then close-ups of the same window in the reference
//! and in every config's final image, side by side with their names.

use std::path::Path;

use glam::Vec3;

use super::metrics::luminance;
use super::raster::{for_each_text_pixel, text_size};

/// A window of the image, in pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Crop {
    /// Left column.
    pub x: u32,
    /// Top row.
    pub y: u32,
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
}

/// How much a pixel's luminance `x` is off the reference `r`, in [0, 1]:
/// |x - r| / (r + 0.05), saturated at 1, so that one firefly counts no more
/// than one badly wrong pixel.
fn disagreement(x: f64, r: f64) -> f64 {
    ((x - r).abs() / (r.max(0.0) + 0.05)).min(1.0)
}

/// The crop window: a quarter of the width and height (at least 8 px, at
/// most the image), placed where the configs disagree most with the
/// reference: the window that maximises the sum over its pixels and over
/// the configs of [`disagreement`]. That is where the methods differ (a
/// caustic some of them miss or render noisily), not where the image is
/// merely bright (a light seen directly). Ties go to the top-left-most window.
pub fn choose_crop(width: u32, height: u32, reference: &[f64], finals: &[Vec<f64>]) -> Crop {
    let (w, h) = (width as usize, height as usize);
    let cw = (w.div_ceil(4)).max(8).min(w);
    let ch = (h.div_ceil(4)).max(8).min(h);
    // Summed-area table of the per-pixel disagreement summed over configs.
    let mut table = vec![0.0f64; (w + 1) * (h + 1)];
    for y in 0..h {
        let mut row = 0.0;
        for x in 0..w {
            let i = y * w + x;
            row += finals
                .iter()
                .map(|img| disagreement(img[i], reference[i]))
                .sum::<f64>();
            table[(y + 1) * (w + 1) + x + 1] = table[y * (w + 1) + x + 1] + row;
        }
    }
    let at = |x: usize, y: usize| table[y * (w + 1) + x];
    let mut best = (f64::NEG_INFINITY, 0, 0);
    for y in 0..=h - ch {
        for x in 0..=w - cw {
            let sum = at(x + cw, y + ch) - at(x, y + ch) - at(x + cw, y) + at(x, y);
            if sum > best.0 {
                best = (sum, x, y);
            }
        }
    }
    Crop {
        x: best.1 as u32,
        y: best.2 as u32,
        width: cw as u32,
        height: ch as u32,
    }
}

/// The exposure (a linear factor) that maps the 99th percentile of the
/// luminance in `crop` of `reference` to 1; 1 when that is not positive.
pub fn exposure(reference: &[Vec3], width: u32, crop: Crop) -> f64 {
    let mut values: Vec<f64> = crop_pixels(reference, width, crop)
        .map(luminance)
        .filter(|v| v.is_finite())
        .collect();
    if values.is_empty() {
        return 1.0;
    }
    values.sort_by(f64::total_cmp);
    let p99 = values[((values.len() - 1) as f64 * 0.99).round() as usize];
    if p99 > 0.0 { 1.0 / p99 } else { 1.0 }
}

fn crop_pixels(image: &[Vec3], width: u32, crop: Crop) -> impl Iterator<Item = Vec3> + '_ {
    (crop.y..crop.y + crop.height).flat_map(move |y| {
        (crop.x..crop.x + crop.width).map(move |x| image[(y * width + x) as usize])
    })
}

/// An image being assembled, linear RGB.
struct Sheet {
    width: u32,
    height: u32,
    pixels: Vec<Vec3>,
}

impl Sheet {
    fn set(&mut self, x: i64, y: i64, c: Vec3) {
        if x >= 0 && y >= 0 && x < i64::from(self.width) && y < i64::from(self.height) {
            self.pixels[y as usize * self.width as usize + x as usize] = c;
        }
    }

    /// Draws `src` (`sw` x `sh`) scaled to `dw` x `dh` (nearest) at (`ox`, `oy`).
    #[allow(clippy::too_many_arguments)]
    fn blit(&mut self, src: &[Vec3], sw: u32, sh: u32, dw: u32, dh: u32, ox: u32, oy: u32) {
        for y in 0..dh {
            let sy = (u64::from(y) * u64::from(sh) / u64::from(dh)) as u32;
            for x in 0..dw {
                let sx = (u64::from(x) * u64::from(sw) / u64::from(dw)) as u32;
                let c = src[(sy * sw + sx) as usize];
                self.set(i64::from(ox + x), i64::from(oy + y), c);
            }
        }
    }

    fn text(&mut self, text: &str, scale: i32, x: u32, y: u32) {
        let mut points = Vec::new();
        for_each_text_pixel(text, scale, |px, py| points.push((px, py)));
        for (px, py) in points {
            self.set(
                i64::from(x) + i64::from(px),
                i64::from(y) + i64::from(py),
                Vec3::ONE,
            );
        }
    }
}

/// What the contact sheet shows.
pub struct SheetInfo {
    /// Tile labels, left to right, top to bottom.
    pub order: Vec<String>,
    /// Magnification of the close-ups.
    pub zoom: u32,
    /// Exposure factor applied before the sRGB curve.
    pub exposure: f64,
}

/// Writes the contact sheet PNG: tile 1 is the whole reference (scaled to
/// the tile height) with the crop outlined in red, tile 2 the reference's
/// close-up, then one close-up per entry of `finals`, in order; labels
/// below each tile. Five tiles a row.
pub fn write(
    path: &Path,
    (width, height): (u32, u32),
    (reference_label, reference): (&str, &[Vec3]),
    finals: &[(String, Vec<Vec3>)],
    crop: Crop,
) -> Result<SheetInfo, String> {
    const COLUMNS: u32 = 5;
    const GAP: u32 = 8;
    // Close-ups about 192 px wide.
    let zoom = (192 / crop.width.max(1)).max(1);
    let (tw, th) = (crop.width * zoom, crop.height * zoom);
    let mut tiles: Vec<(String, Vec<Vec3>, u32, u32)> = Vec::new();
    // The whole image, fitted into the tile.
    let fit = (f64::from(tw) / f64::from(width)).min(f64::from(th) / f64::from(height));
    let (fw, fh) = (
        ((f64::from(width) * fit).round() as u32).max(1),
        ((f64::from(height) * fit).round() as u32).max(1),
    );
    let mut whole = vec![Vec3::ZERO; (fw * fh) as usize];
    {
        let mut s = Sheet {
            width: fw,
            height: fh,
            pixels: whole,
        };
        s.blit(reference, width, height, fw, fh, 0, 0);
        // The crop outline.
        // Bright enough to stay saturated red after any exposure.
        let red = Vec3::new(1e30, 0.0, 0.0);
        let x0 = (f64::from(crop.x) * fit) as i64;
        let y0 = (f64::from(crop.y) * fit) as i64;
        let x1 = (f64::from(crop.x + crop.width) * fit) as i64 - 1;
        let y1 = (f64::from(crop.y + crop.height) * fit) as i64 - 1;
        for x in x0..=x1 {
            s.set(x, y0, red);
            s.set(x, y1, red);
        }
        for y in y0..=y1 {
            s.set(x0, y, red);
            s.set(x1, y, red);
        }
        whole = s.pixels;
    }
    tiles.push((format!("{reference_label} (whole)"), whole, fw, fh));
    let close_up = |image: &[Vec3]| crop_pixels(image, width, crop).collect::<Vec<_>>();
    tiles.push((
        reference_label.to_string(),
        close_up(reference),
        crop.width,
        crop.height,
    ));
    for (name, image) in finals {
        tiles.push((name.clone(), close_up(image), crop.width, crop.height));
    }

    let exposure = exposure(reference, width, crop);
    let longest = tiles.iter().map(|t| t.0.len()).max().unwrap_or(1) as i32;
    let scale = if text_size("x", 2).0 * longest <= tw as i32 {
        2
    } else {
        1
    };
    let label_h = text_size("x", scale).1 as u32 + 2 * GAP;
    let columns = COLUMNS.min(tiles.len() as u32);
    let rows = (tiles.len() as u32).div_ceil(columns);
    let mut sheet = Sheet {
        width: columns * (tw + GAP) + GAP,
        height: rows * (th + label_h) + GAP,
        pixels: Vec::new(),
    };
    sheet.pixels = vec![Vec3::ZERO; (sheet.width * sheet.height) as usize];
    let mut order = Vec::new();
    for (i, (label, pixels, sw, sh)) in tiles.iter().enumerate() {
        let (col, row) = (i as u32 % columns, i as u32 / columns);
        let ox = GAP + col * (tw + GAP);
        let oy = GAP + row * (th + label_h);
        let scaled: Vec<Vec3> = pixels.iter().map(|&p| p * exposure as f32).collect();
        // Close-ups fill the tile; the whole image keeps its aspect ratio.
        let (dw, dh) = if i == 0 { (*sw, *sh) } else { (tw, th) };
        sheet.blit(&scaled, *sw, *sh, dw, dh, ox, oy);
        sheet.text(label, scale, ox, oy + th + GAP / 2);
        order.push(label.clone());
    }
    image_io::write_png(path, sheet.width, sheet.height, &sheet.pixels, 0.0)
        .map_err(|e| e.to_string())?;
    Ok(SheetInfo {
        order,
        zoom,
        exposure,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crop_lands_where_configs_disagree() {
        let (w, h) = (32u32, 32u32);
        let reference = vec![1.0; (w * h) as usize];
        let mut wrong = reference.clone();
        // A block of wrong pixels at (20..26, 4..10), and one huge firefly elsewhere.
        for y in 4..10 {
            for x in 20..26 {
                wrong[y * 32 + x] = 3.0;
            }
        }
        wrong[30 * 32 + 2] = 1e9;
        let crop = choose_crop(w, h, &reference, &[wrong]);
        assert_eq!((crop.width, crop.height), (8, 8));
        assert!(crop.x <= 20 && crop.x + 8 >= 26, "{crop:?}");
        assert!(crop.y <= 4 && crop.y + 8 >= 10, "{crop:?}");
        // Small images: the window is the whole image.
        let tiny = choose_crop(4, 4, &[0.0; 16], &[]);
        assert_eq!(
            tiny,
            Crop {
                x: 0,
                y: 0,
                width: 4,
                height: 4
            }
        );
    }

    #[test]
    fn exposure_maps_the_99th_percentile_to_one() {
        let image: Vec<Vec3> = (0..100).map(|i| Vec3::splat(i as f32 + 1.0)).collect();
        let crop = Crop {
            x: 0,
            y: 0,
            width: 100,
            height: 1,
        };
        let e = exposure(&image, 100, crop);
        assert!((e - 1.0 / 99.0).abs() < 1e-9, "{e}");
        assert_eq!(
            exposure(
                &[Vec3::ZERO; 4],
                2,
                Crop {
                    x: 0,
                    y: 0,
                    width: 2,
                    height: 2
                }
            ),
            1.0
        );
    }
}
