//! The operations of a Mitsuba `<transform>` (mitsuba3 v3.9.1,
//! `src/core/parser.cpp` and `include/mitsuba/core/transform.h`; note
//! §1.3, measured): `translate`, `scale`, `rotate` (degrees, right-handed,
//! axis *not* normalized), `matrix` (row-major, 16 or 9 numbers) and
//! `lookat` (local +z towards the target, local +x = "left").

use glam::{DMat3, DMat4, DVec3, DVec4};

use super::numbers::{numbers, parse_f64, triple};

/// The matrix of one operation element, its attributes read through `attr`.
pub fn operation<'a>(tag: &str, attr: impl Fn(&str) -> Option<&'a str>) -> Result<DMat4, String> {
    let component = |name: &str, default: f64| attr(name).map_or(Ok(default), parse_f64);
    let vector = |default: f64| -> Result<DVec3, String> {
        match attr("value") {
            Some(v) => triple(v),
            None => Ok(DVec3::new(
                component("x", default)?,
                component("y", default)?,
                component("z", default)?,
            )),
        }
    };
    match tag {
        "translate" => Ok(DMat4::from_translation(vector(0.0)?)),
        "scale" => Ok(DMat4::from_scale(vector(1.0)?)),
        "rotate" => {
            let angle = attr("angle").ok_or("needs an angle attribute (degrees)")?;
            rotation(vector(0.0)?, parse_f64(angle)?)
        }
        "matrix" => matrix(attr("value").ok_or("needs a value attribute")?),
        "lookat" => {
            let point = |name: &str| {
                attr(name)
                    .ok_or_else(|| format!("needs an {name} attribute"))
                    .and_then(triple)
            };
            let up = attr("up").map(triple).transpose()?;
            look_at(point("origin")?, point("target")?, up)
        }
        other => Err(format!(
            "<{other}> is not a transform operation (translate, rotate, scale, matrix, lookat)"
        )),
    }
}

/// Rotation by `degrees` about `axis`, counter-clockwise looking down the
/// axis; Mitsuba does not normalize the axis (a non-unit one gives a
/// non-rotation, measured), and neither do we.
pub fn rotation(axis: DVec3, degrees: f64) -> Result<DMat4, String> {
    if axis == DVec3::ZERO {
        return Err("rotation axis is zero".into());
    }
    let (s, c) = degrees.to_radians().sin_cos();
    let a = axis;
    let rows = [
        [
            a.x * a.x + (1.0 - a.x * a.x) * c,
            a.x * a.y * (1.0 - c) - a.z * s,
            a.x * a.z * (1.0 - c) + a.y * s,
        ],
        [
            a.x * a.y * (1.0 - c) + a.z * s,
            a.y * a.y + (1.0 - a.y * a.y) * c,
            a.y * a.z * (1.0 - c) - a.x * s,
        ],
        [
            a.x * a.z * (1.0 - c) - a.y * s,
            a.y * a.z * (1.0 - c) + a.x * s,
            a.z * a.z + (1.0 - a.z * a.z) * c,
        ],
    ];
    Ok(DMat4::from_mat3(
        DMat3::from_cols_array_2d(&rows).transpose(),
    ))
}

/// A `matrix` value: 16 numbers row by row, or 9 for the linear part.
pub fn matrix(value: &str) -> Result<DMat4, String> {
    let v = numbers(value)?;
    match v.len() {
        16 => Ok(DMat4::from_cols_array(&[
            v[0], v[4], v[8], v[12], v[1], v[5], v[9], v[13], v[2], v[6], v[10], v[14], v[3], v[7],
            v[11], v[15],
        ])),
        9 => Ok(DMat4::from_mat3(DMat3::from_cols_array(&[
            v[0], v[3], v[6], v[1], v[4], v[7], v[2], v[5], v[8],
        ]))),
        n => Err(format!("a matrix needs 16 or 9 numbers, got {n}")),
    }
}

/// Mitsuba's `look_at`: columns (left, up', d, origin) with d the unit
/// direction to the target, left = normalize(up x d), up' = d x left;
/// without an up (or a zero one), up is the first tangent of Duff et al.'s
/// orthonormal basis of d (Mitsuba's `coordinate_system`).
pub fn look_at(origin: DVec3, target: DVec3, up: Option<DVec3>) -> Result<DMat4, String> {
    let d = (target - origin)
        .try_normalize()
        .ok_or("lookat target equals its origin")?;
    let up = up
        .filter(|u| *u != DVec3::ZERO)
        .unwrap_or_else(|| coordinate_system(d).0);
    let left = up
        .cross(d)
        .try_normalize()
        .ok_or("lookat up is parallel to the viewing direction")?;
    let new_up = d.cross(left);
    Ok(DMat4::from_cols(
        left.extend(0.0),
        new_up.extend(0.0),
        d.extend(0.0),
        DVec4::new(origin.x, origin.y, origin.z, 1.0),
    ))
}

/// Duff et al. 2017, "Building an Orthonormal Basis, Revisited" (Mitsuba's
/// `coordinate_system`).
pub fn coordinate_system(n: DVec3) -> (DVec3, DVec3) {
    let sign = 1f64.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        DVec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        DVec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn op(tag: &str, attrs: &[(&str, &str)]) -> DMat4 {
        operation(tag, |k| {
            attrs.iter().find(|(n, _)| *n == k).map(|(_, v)| *v)
        })
        .unwrap()
    }

    /// The measured facts of note §1.3.
    #[test]
    fn operations_match_mitsuba() {
        let r = op("rotate", &[("y", "1"), ("angle", "90")]);
        assert!((r.transform_vector3(DVec3::X) - DVec3::NEG_Z).length() < 1e-12);
        let r = op("rotate", &[("z", "1"), ("angle", "90")]);
        assert!((r.transform_vector3(DVec3::X) - DVec3::Y).length() < 1e-12);
        // Row-major: translation in the last column.
        let m = op("matrix", &[("value", "1 0 0 5  0 1 0 6  0 0 1 7  0 0 0 1")]);
        assert_eq!(m.transform_point3(DVec3::ZERO), DVec3::new(5.0, 6.0, 7.0));
        // No up, d = +z: left (0,-1,0), up' (1,0,0).
        let l = look_at(DVec3::ZERO, DVec3::Z, None).unwrap();
        assert!((l.x_axis.truncate() - DVec3::NEG_Y).length() < 1e-12);
        assert!((l.y_axis.truncate() - DVec3::X).length() < 1e-12);
        let l = op(
            "lookat",
            &[("origin", "0 0 0"), ("target", "0 0 1"), ("up", "0 1 0")],
        );
        assert!(
            (l.x_axis.truncate() - DVec3::X).length() < 1e-12,
            "left = +x"
        );
        // Composition: later operations apply after earlier ones.
        let t = op("translate", &[("x", "1")]);
        let s = op("scale", &[("value", "2")]);
        assert_eq!(
            (s * t).transform_point3(DVec3::ZERO),
            DVec3::new(2.0, 0.0, 0.0)
        );
        assert!(operation("rotate", |k| (k == "angle").then_some("10")).is_err());
    }
}
