//! Checks of single values shared by the scene's validation
//! (`crate::validate`) and the builder's analytic spheres
//! (`crate::sphere::Sphere::check`): each returns the message that names the
//! value and what it must be.

use glam::Vec3;

/// `v` is finite in every component.
pub(crate) fn finite(name: &str, v: Vec3) -> Result<(), String> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(format!("{name} must be finite, got {v}"))
    }
}

/// `v` is a finite unit vector (length within 1e-3 of 1).
pub(crate) fn unit(name: &str, v: Vec3) -> Result<(), String> {
    if v.is_finite() && (v.length() - 1.0).abs() < 1e-3 {
        Ok(())
    } else {
        Err(format!("{name} must be a finite unit vector, got {v}"))
    }
}
