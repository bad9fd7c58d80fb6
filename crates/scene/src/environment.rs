//! Equirectangular (latitude-longitude) environment maps: radiance from every
//! direction at infinity, read from an OpenEXR or Radiance `.hdr` image.
//!
//! **Orientation** (Mitsuba 3's `envmap` convention, so that the Mitsuba
//! exporter needs no extra transform): +y is up. A direction with polar
//! angle theta from +y and azimuth phi is, in the map's own frame,
//!
//! ```text
//! d = (sin theta sin phi, cos theta, -sin theta cos phi)
//! u = phi / (2 pi) in [0, 1),  v = theta / pi in [0, 1]
//! ```
//!
//! The image's top row is v = 0 (straight up), its left column u = 0, which
//! looks along -z; u = 1/4 looks along +x, u = 1/2 along +z, u = 3/4 along
//! -x. `rotation` (degrees) turns the map about +y, right-handed: the world
//! direction is `R_y(rotation) d`.
//!
//! **Lookup is nearest-texel**: the radiance is constant over each texel's
//! cell `[col, col+1) / width x [row, row+1) / height` of (u, v). The
//! integrators' importance sampling is piecewise constant over the same
//! cells, so [`EnvironmentMap::texel_index`] alone decides both what a
//! direction sees and which cell's probability it has: a texel that emits
//! has a positive probability, and a constant map is exactly a constant
//! environment. (Mitsuba 3 interpolates bilinearly, with its rows at
//! v = row / (height - 1): on smooth maps the two agree closely, on a map
//! with a one-texel spot they differ by up to half a texel.)

use std::f32::consts::PI;
use std::path::{Path, PathBuf};

use glam::Vec3;

use crate::error::SceneError;

/// Largest number of texels of a map (a 16k x 8k map, 1.5 GB as f32 RGB):
/// a corrupt header must not make the loader allocate without bound.
pub const MAX_TEXELS: u64 = 16_384 * 8_192;

/// An equirectangular environment map (see the module docs for its
/// orientation).
#[derive(Clone, Debug, PartialEq)]
pub struct EnvironmentMap {
    /// Width in texels (azimuth), >= 1.
    pub width: u32,
    /// Height in texels (polar angle), >= 1.
    pub height: u32,
    /// Row-major linear RGB radiance, top row (up) first, before `scale`.
    pub texels: Vec<Vec3>,
    /// Multiplier of every texel.
    pub scale: f32,
    /// Rotation about +y in degrees (right-handed).
    pub rotation_degrees: f32,
    /// The file it was read from, if any (the Mitsuba exporter names it).
    pub file: Option<PathBuf>,
    /// cos and sin of the rotation.
    cos_rotation: f32,
    sin_rotation: f32,
}

impl EnvironmentMap {
    /// A map of `width` x `height` texels (row-major, top row first), or why
    /// not: a wrong texel count, or a texel or `scale` that is NaN,
    /// infinite or negative, or a non-finite rotation.
    pub fn new(
        width: u32,
        height: u32,
        texels: Vec<Vec3>,
        scale: f32,
        rotation_degrees: f32,
    ) -> Result<Self, String> {
        if width == 0 || height == 0 || texels.len() as u64 != u64::from(width) * u64::from(height)
        {
            return Err(format!(
                "{} texels do not make a {width}x{height} map",
                texels.len()
            ));
        }
        if !(scale.is_finite() && scale >= 0.0) {
            return Err(format!("scale must be finite and >= 0, got {scale}"));
        }
        if !rotation_degrees.is_finite() {
            return Err(format!("rotation must be finite, got {rotation_degrees}"));
        }
        if let Some(i) = texels
            .iter()
            .position(|t| !(t.is_finite() && t.min_element() >= 0.0))
        {
            return Err(format!(
                "texel ({}, {}) is {}: radiance must be finite and non-negative",
                i as u32 % width,
                i as u32 / width,
                texels[i]
            ));
        }
        let (sin_rotation, cos_rotation) = rotation_degrees.to_radians().sin_cos();
        Ok(Self {
            width,
            height,
            texels,
            scale,
            rotation_degrees,
            file: None,
            cos_rotation,
            sin_rotation,
        })
    }

    /// A map of one texel: the constant environment `radiance`.
    pub fn constant(radiance: Vec3) -> Result<Self, String> {
        Self::new(1, 1, vec![radiance], 1.0, 0.0)
    }

    /// Reads an OpenEXR (`.exr`) or Radiance (`.hdr`) file; any error is one
    /// line naming `path`.
    pub fn load(path: &Path, scale: f32, rotation_degrees: f32) -> Result<Self, SceneError> {
        let (width, height, texels) = read_image(path)?;
        let mut map = Self::new(width, height, texels, scale, rotation_degrees)
            .map_err(|e| SceneError::invalid(path, "environment map", e))?;
        map.file = Some(path.to_path_buf());
        Ok(map)
    }

    /// The map's own-frame direction of world direction `d` (rotation undone).
    #[inline]
    pub fn to_local(&self, d: Vec3) -> Vec3 {
        let (c, s) = (self.cos_rotation, self.sin_rotation);
        Vec3::new(c * d.x - s * d.z, d.y, s * d.x + c * d.z)
    }

    /// The world direction of own-frame direction `d`.
    #[inline]
    pub fn to_world(&self, d: Vec3) -> Vec3 {
        let (c, s) = (self.cos_rotation, self.sin_rotation);
        Vec3::new(c * d.x + s * d.z, d.y, -s * d.x + c * d.z)
    }

    /// (u, v) of unit world direction `d` (module docs), each in [0, 1].
    #[inline]
    pub fn uv(&self, d: Vec3) -> (f32, f32) {
        let l = self.to_local(d);
        let mut u = l.x.atan2(-l.z) / (2.0 * PI);
        if u < 0.0 {
            u += 1.0;
        }
        let v = l.y.clamp(-1.0, 1.0).acos() / PI;
        (u, v)
    }

    /// The unit world direction of own-frame polar cosine `cos_theta` and
    /// azimuth `phi`.
    #[inline]
    pub fn direction(&self, cos_theta: f32, phi: f32) -> Vec3 {
        let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
        let (sin_phi, cos_phi) = phi.sin_cos();
        self.to_world(Vec3::new(
            sin_theta * sin_phi,
            cos_theta,
            -sin_theta * cos_phi,
        ))
    }

    /// Index into `texels` of the cell that unit world direction `d` falls
    /// in: the one function that decides both a direction's radiance and
    /// its sampling density.
    #[inline]
    pub fn texel_index(&self, d: Vec3) -> usize {
        let (u, v) = self.uv(d);
        let col = ((u * self.width as f32) as u32).min(self.width - 1);
        let row = ((v * self.height as f32) as u32).min(self.height - 1);
        (row * self.width + col) as usize
    }

    /// Radiance arriving from unit world direction `d` (travelling along -d).
    #[inline]
    pub fn radiance(&self, d: Vec3) -> Vec3 {
        self.texel(self.texel_index(d))
    }

    /// Texel `index` times `scale`.
    #[inline]
    pub fn texel(&self, index: usize) -> Vec3 {
        self.texels[index] * self.scale
    }

    /// The largest scaled texel component.
    pub fn max_value(&self) -> f32 {
        self.texels
            .iter()
            .fold(0.0f32, |m, t| m.max(t.max_element()))
            * self.scale
    }
}

/// Width, height and linear RGB texels (top row first) of an `.exr` or
/// `.hdr` file.
fn read_image(path: &Path) -> Result<(u32, u32, Vec<Vec3>), SceneError> {
    let extension = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let format = match extension.as_deref() {
        Some("exr") => image::ImageFormat::OpenExr,
        Some("hdr") => image::ImageFormat::Hdr,
        _ => {
            return Err(SceneError::unsupported(
                path,
                "unknown environment map type: expected .exr (OpenEXR) or .hdr (Radiance RGBE)",
            ));
        }
    };
    let file = std::fs::File::open(path).map_err(|e| SceneError::io(path, e))?;
    let mut reader = image::ImageReader::with_format(std::io::BufReader::new(file), format);
    // The decoder refuses a header whose image would exceed this, before
    // allocating it (RGBA f32 is the widest buffer it decodes into).
    let mut limits = image::Limits::default();
    limits.max_alloc = Some(MAX_TEXELS * 16);
    reader.limits(limits);
    let decoded = crate::error::guarded(path, "the image reader", || {
        reader.decode().map_err(|e| malformed(path, &e))
    })?;
    let rgb = decoded.into_rgb32f();
    let texels = rgb
        .pixels()
        .map(|p| Vec3::new(p.0[0], p.0[1], p.0[2]))
        .collect();
    Ok((rgb.width(), rgb.height(), texels))
}

fn malformed(path: &Path, e: &image::ImageError) -> SceneError {
    let message = e.to_string();
    let first = message.lines().next().unwrap_or_default();
    SceneError::malformed(
        path,
        format!(
            "cannot decode the environment map: {}",
            crate::error::quoted(first).trim_matches('"')
        ),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The mapping follows the module docs: up is v = 0, -z is u = 0, +x
    /// is u = 1/4; a rotation of 90 degrees turns -z into -x.
    #[test]
    fn orientation_follows_the_documented_convention() {
        let map = EnvironmentMap::constant(Vec3::ONE).unwrap();
        let close = |(u, v): (f32, f32), (a, b): (f32, f32)| {
            assert!((u - a).abs() < 1e-6 && (v - b).abs() < 1e-6, "{u} {v}")
        };
        // At the poles u is arbitrary.
        assert_eq!(map.uv(Vec3::Y).1, 0.0);
        assert_eq!(map.uv(-Vec3::Y).1, 1.0);
        close(map.uv(-Vec3::Z), (0.0, 0.5));
        close(map.uv(Vec3::X), (0.25, 0.5));
        close(map.uv(Vec3::Z), (0.5, 0.5));
        close(map.uv(-Vec3::X), (0.75, 0.5));
        let rotated = EnvironmentMap::new(1, 1, vec![Vec3::ONE], 1.0, 90.0).unwrap();
        assert!((rotated.to_world(-Vec3::Z) + Vec3::X).length() < 1e-6);
        for d in [Vec3::X, Vec3::new(0.3, -0.5, 0.8).normalize()] {
            assert!((rotated.to_local(rotated.to_world(d)) - d).length() < 1e-6);
            let (u, v) = rotated.uv(d);
            let back = rotated.direction((v * PI).cos(), u * 2.0 * PI);
            assert!((back - d).length() < 1e-5, "{back} vs {d}");
        }
    }

    #[test]
    fn bad_values_are_refused() {
        assert!(EnvironmentMap::new(2, 1, vec![Vec3::ONE], 1.0, 0.0).is_err());
        assert!(EnvironmentMap::new(1, 1, vec![Vec3::NAN], 1.0, 0.0).is_err());
        assert!(EnvironmentMap::new(1, 1, vec![-Vec3::ONE], 1.0, 0.0).is_err());
        assert!(EnvironmentMap::new(1, 1, vec![Vec3::ONE], f32::INFINITY, 0.0).is_err());
        assert!(EnvironmentMap::new(1, 1, vec![Vec3::ONE], -1.0, 0.0).is_err());
        let e = EnvironmentMap::new(2, 1, vec![Vec3::ONE, Vec3::INFINITY], 1.0, 0.0).unwrap_err();
        assert!(e.contains("texel (1, 0)"), "{e}");
    }
}
