//! The perspective pinhole camera.

use glam::{UVec2, Vec3};

/// A pinhole camera: position, orthonormal frame, vertical field of view and
/// image resolution. Looks along `forward`; `up` is the image's up direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Centre of projection.
    pub position: Vec3,
    /// Viewing direction (unit).
    pub forward: Vec3,
    /// Image up (unit, orthogonal to `forward`).
    pub up: Vec3,
    /// Image right (unit): forward x up.
    pub right: Vec3,
    /// Vertical field of view in radians, in (0, pi).
    pub vertical_fov: f32,
    /// Image size in pixels.
    pub resolution: UVec2,
    /// Distance along `forward` before which nothing is seen (Mitsuba's
    /// `near_clip`: camera rays start on this plane); 0 for none.
    pub near_clip: f32,
}

impl Camera {
    /// A camera at `from` looking at `at`, with `up` as the approximate image
    /// up and `vertical_fov_degrees` in (0, 180). Errors name the problem.
    pub fn look_at(
        from: Vec3,
        at: Vec3,
        up: Vec3,
        vertical_fov_degrees: f32,
        resolution: UVec2,
    ) -> Result<Self, String> {
        if !(from.is_finite() && at.is_finite() && up.is_finite()) {
            return Err("camera position, target and up must be finite".into());
        }
        let forward = (at - from)
            .try_normalize()
            .ok_or("camera target equals its position")?;
        let right = forward
            .cross(up)
            .try_normalize()
            .ok_or("camera up is parallel to the viewing direction")?;
        if !(vertical_fov_degrees > 0.0 && vertical_fov_degrees < 180.0) {
            return Err(format!(
                "vertical field of view must be in (0, 180) degrees, got {vertical_fov_degrees}"
            ));
        }
        if resolution.x == 0 || resolution.y == 0 {
            return Err(format!(
                "resolution must be at least 1x1, got {}x{}",
                resolution.x, resolution.y
            ));
        }
        Ok(Self {
            position: from,
            forward,
            up: right.cross(forward),
            right,
            vertical_fov: vertical_fov_degrees.to_radians(),
            resolution,
            near_clip: 0.0,
        })
    }

    /// A camera that frames the box [min, max]: looking along -z from in front
    /// of it (the usual glTF/OBJ view), far enough that the bounding sphere
    /// fits the vertical field of view of 40 degrees.
    pub fn framing(min: Vec3, max: Vec3, resolution: UVec2) -> Self {
        const FOV_DEGREES: f32 = 40.0;
        let (min, max) = if min.is_finite() && max.is_finite() && min.cmple(max).all() {
            (min, max)
        } else {
            (Vec3::splat(-1.0), Vec3::splat(1.0))
        };
        let centre = 0.5 * (min + max);
        let radius = (0.5 * (max - min).length()).max(1e-3);
        let distance = radius / (0.5 * FOV_DEGREES.to_radians()).sin();
        let from = centre + Vec3::Z * distance;
        let resolution = resolution.max(UVec2::ONE);
        Self::look_at(from, centre, Vec3::Y, FOV_DEGREES, resolution).unwrap_or(Self {
            // Bounds so large that the camera position overflows: look at the origin.
            position: Vec3::new(0.0, 0.0, 5.0),
            forward: Vec3::NEG_Z,
            up: Vec3::Y,
            right: Vec3::X,
            vertical_fov: FOV_DEGREES.to_radians(),
            resolution,
            near_clip: 0.0,
        })
    }

    /// Width over height.
    pub fn aspect(&self) -> f32 {
        self.resolution.x as f32 / self.resolution.y as f32
    }
}

/// A camera as a file describes it, before the resolution is known.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraSpec {
    /// Position.
    pub from: Vec3,
    /// A point on the viewing axis.
    pub at: Vec3,
    /// Approximate image up.
    pub up: Vec3,
    /// Field of view in degrees, along `fov_axis`.
    pub fov_degrees: f32,
    /// The image axis `fov_degrees` spans.
    pub fov_axis: FovAxis,
    /// Width over height, if the file gives one.
    pub aspect: Option<f32>,
    /// The image is mirrored left to right (a Mitsuba `to_world` with a
    /// negative determinant): image right is `up x forward`, not
    /// `forward x up`.
    pub mirrored: bool,
    /// [`Camera::near_clip`].
    pub near_clip: f32,
}

/// Which extent of the image a field of view spans (Mitsuba's `fov_axis`;
/// glTF and manifests give the vertical one).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FovAxis {
    /// Width.
    X,
    /// Height.
    Y,
    /// Diagonal.
    Diagonal,
    /// The shorter side.
    Smaller,
    /// The longer side.
    Larger,
}

impl FovAxis {
    /// The vertical field of view in degrees of `degrees` along this axis,
    /// for an image of `aspect` = width / height (Mitsuba's `perspective`
    /// conversion, note §2.5: tan(fov_y/2) = tan(fov/2) / scale, where the
    /// axis is `scale` times the height).
    pub fn vertical_degrees(self, degrees: f32, aspect: f32) -> f32 {
        let scale = match self {
            FovAxis::Y => 1.0,
            FovAxis::X => aspect,
            FovAxis::Diagonal => (1.0 + aspect * aspect).sqrt(),
            FovAxis::Smaller => aspect.min(1.0),
            FovAxis::Larger => aspect.max(1.0),
        };
        let half = (0.5 * f64::from(degrees)).to_radians().tan() / f64::from(scale);
        (2.0 * half.atan()).to_degrees() as f32
    }
}

impl CameraSpec {
    /// The camera at `resolution`.
    pub fn camera(&self, resolution: UVec2) -> Result<Camera, String> {
        let aspect = resolution.x as f32 / resolution.y.max(1) as f32;
        let mut camera = Camera::look_at(
            self.from,
            self.at,
            self.up,
            self.fov_axis.vertical_degrees(self.fov_degrees, aspect),
            resolution,
        )?;
        if self.mirrored {
            camera.right = -camera.right;
        }
        if !(self.near_clip.is_finite() && self.near_clip >= 0.0) {
            return Err(format!(
                "near_clip must be finite and >= 0, got {}",
                self.near_clip
            ));
        }
        camera.near_clip = self.near_clip;
        Ok(camera)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Note §2.5's measured example: fov 40 along the smaller axis of a
    /// 16x12 image is an x fov of 51.774 degrees.
    #[test]
    fn fov_axes_convert_as_mitsuba() {
        let aspect = 16.0 / 12.0;
        let vertical = FovAxis::Smaller.vertical_degrees(40.0, aspect);
        assert!((vertical - 40.0).abs() < 1e-4);
        let from_x = FovAxis::X.vertical_degrees(51.774, aspect);
        assert!((from_x - 40.0).abs() < 1e-3, "{from_x}");
        assert_eq!(FovAxis::Larger.vertical_degrees(30.0, 0.5), 30.0);
    }
}
