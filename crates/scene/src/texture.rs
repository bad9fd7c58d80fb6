//! Image textures: linear RGBA texels, bilinear lookup, glTF wrap modes,
//! and the uv transform of `KHR_texture_transform`.

use glam::{Mat2, Vec2, Vec4};

/// How texture coordinates outside [0, 1] are mapped (glTF sampler wrap modes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wrap {
    /// Tile (glTF REPEAT, the default).
    Repeat,
    /// Clamp to the edge texel (CLAMP_TO_EDGE).
    Clamp,
    /// Tile with every other copy mirrored (MIRRORED_REPEAT).
    Mirror,
}

/// An RGBA image in linear values (sRGB-encoded sources are decoded on load).
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    /// Width in texels (>= 1).
    pub width: u32,
    /// Height in texels (>= 1).
    pub height: u32,
    /// Row-major texels, top row first (glTF and OBJ image convention).
    pub texels: Vec<Vec4>,
    /// Wrap mode along u.
    pub wrap_u: Wrap,
    /// Wrap mode along v.
    pub wrap_v: Wrap,
    /// Applied to the uv before every lookup (`None`: identity, no cost).
    pub transform: Option<UvTransform>,
}

/// `KHR_texture_transform` (Khronos extension spec, "Overview"): the uv a
/// texture is read at is `T * R * S * uv`, with S = diag(scale), R the
/// rotation by `rotation` radians written there column-major as
/// ((cos, sin), (-sin, cos)) (glam's `Mat2::from_angle`), T the offset.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UvTransform {
    /// Translation of the uv origin, in texture widths and heights.
    pub offset: Vec2,
    /// Rotation in radians.
    pub rotation: f32,
    /// Scale per axis.
    pub scale: Vec2,
}

impl UvTransform {
    /// The transformed uv: offset + R(rotation) (scale * uv).
    pub fn apply(&self, uv: Vec2) -> Vec2 {
        self.offset + Mat2::from_angle(self.rotation) * (self.scale * uv)
    }
}

/// sRGB electro-optical transfer function (IEC 61966-2-1): encoded -> linear.
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

impl Texture {
    /// A texture from 8-bit channels (`channels` of 1..=4 per texel); colour
    /// channels are sRGB-decoded when `srgb`, alpha never is. `None` if the
    /// buffer does not hold width x height texels.
    pub fn from_u8(
        width: u32,
        height: u32,
        channels: usize,
        data: &[u8],
        srgb: bool,
    ) -> Option<Self> {
        let count = (width as usize).checked_mul(height as usize)?;
        if width == 0
            || height == 0
            || !(1..=4).contains(&channels)
            || data.len() < count.checked_mul(channels)?
        {
            return None;
        }
        let decode = |v: u8| {
            let x = f32::from(v) / 255.0;
            if srgb { srgb_to_linear(x) } else { x }
        };
        let texels = data
            .chunks_exact(channels)
            .take(count)
            .map(|c| match channels {
                1 => Vec4::new(decode(c[0]), decode(c[0]), decode(c[0]), 1.0),
                2 => Vec4::new(
                    decode(c[0]),
                    decode(c[0]),
                    decode(c[0]),
                    f32::from(c[1]) / 255.0,
                ),
                3 => Vec4::new(decode(c[0]), decode(c[1]), decode(c[2]), 1.0),
                _ => Vec4::new(
                    decode(c[0]),
                    decode(c[1]),
                    decode(c[2]),
                    f32::from(c[3]) / 255.0,
                ),
            })
            .collect();
        Some(Self {
            width,
            height,
            texels,
            wrap_u: Wrap::Repeat,
            wrap_v: Wrap::Repeat,
            transform: None,
        })
    }

    /// Bilinear lookup at `uv` (after [`Texture::transform`]; texel centres
    /// at half-integers; v = 0 is the top row, as in glTF). Non-finite
    /// coordinates read texel (0, 0).
    pub fn sample(&self, uv: Vec2) -> Vec4 {
        let uv = match self.transform {
            Some(t) => t.apply(uv),
            None => uv,
        };
        let uv = if uv.is_finite() { uv } else { Vec2::ZERO };
        let x = uv.x * self.width as f32 - 0.5;
        let y = uv.y * self.height as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let texel = |ix: f32, iy: f32| {
            let i = wrap(ix as i64, self.width, self.wrap_u);
            let j = wrap(iy as i64, self.height, self.wrap_v);
            self.texels[j * self.width as usize + i]
        };
        let top = texel(x0, y0).lerp(texel(x0 + 1.0, y0), fx);
        let bottom = texel(x0, y0 + 1.0).lerp(texel(x0 + 1.0, y0 + 1.0), fx);
        top.lerp(bottom, fy)
    }
}

fn wrap(i: i64, size: u32, mode: Wrap) -> usize {
    let n = i64::from(size);
    let wrapped = match mode {
        Wrap::Repeat => i.rem_euclid(n),
        Wrap::Clamp => i.clamp(0, n - 1),
        Wrap::Mirror => {
            let period = i.rem_euclid(2 * n);
            if period < n {
                period
            } else {
                2 * n - 1 - period
            }
        }
    };
    wrapped as usize
}

#[cfg(test)]
mod tests {
    use super::*;

    fn checker() -> Texture {
        Texture::from_u8(2, 1, 1, &[0, 255], false).unwrap()
    }

    #[test]
    fn bilinear_and_wrap_modes() {
        let mut t = checker();
        // Texel centres return the texel.
        assert_eq!(t.sample(Vec2::new(0.25, 0.5)).x, 0.0);
        assert_eq!(t.sample(Vec2::new(0.75, 0.5)).x, 1.0);
        // Halfway between the centres: the average.
        assert!((t.sample(Vec2::new(0.5, 0.5)).x - 0.5).abs() < 1e-6);
        // Repeat: u = 1.25 is u = 0.25.
        assert_eq!(t.sample(Vec2::new(1.25, 0.5)).x, 0.0);
        t.wrap_u = Wrap::Clamp;
        assert_eq!(t.sample(Vec2::new(1.25, 0.5)).x, 1.0);
        t.wrap_u = Wrap::Mirror;
        assert_eq!(t.sample(Vec2::new(1.25, 0.5)).x, 1.0);
        assert_eq!(t.sample(Vec2::new(f32::NAN, 0.5)).x, 0.0);
    }

    /// The extension's order T * R * S: scale first, then rotate, then offset.
    #[test]
    fn uv_transform_order() {
        let t = UvTransform {
            offset: Vec2::new(0.5, 0.0),
            rotation: std::f32::consts::FRAC_PI_2,
            scale: Vec2::new(2.0, 1.0),
        };
        // (1, 0) -> scale (2, 0) -> rotate by +90 degrees (0, 2) -> offset (0.5, 2).
        assert!((t.apply(Vec2::new(1.0, 0.0)) - Vec2::new(0.5, 2.0)).length() < 1e-6);
        // (0, 1) -> (0, 1) -> (-1, 0) -> (-0.5, 0).
        assert!((t.apply(Vec2::new(0.0, 1.0)) - Vec2::new(-0.5, 0.0)).length() < 1e-6);
        // On a lookup: the left half (black) read where the right one is.
        let mut tex = checker();
        tex.transform = Some(UvTransform {
            offset: Vec2::new(0.5, 0.0),
            rotation: 0.0,
            scale: Vec2::ONE,
        });
        assert_eq!(tex.sample(Vec2::new(0.25, 0.5)).x, 1.0);
        assert_eq!(tex.sample(Vec2::new(0.75, 0.5)).x, 0.0);
    }

    #[test]
    fn srgb_decoding() {
        let t = Texture::from_u8(1, 1, 3, &[255, 128, 0], true).unwrap();
        assert!((t.texels[0].y - 0.2158605).abs() < 1e-5);
        assert!(Texture::from_u8(2, 2, 3, &[0; 5], true).is_none());
    }
}
