//! Numbers in Mitsuba XML attribute values: one, a list, or a triple. Shared
//! by the document reader (`super::xml`) and the transform operations
//! (`super::transform`).

use glam::DVec3;

use crate::error::quoted;

/// One finite number (`fast_float`'s syntax: no trailing junk).
pub fn parse_f64(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Err(format!("{} is not finite", quoted(s))),
        Err(_) => Err(format!("{} is not a number", quoted(s))),
    }
}

/// The numbers of a list (split on commas and white space).
pub fn numbers(s: &str) -> Result<Vec<f64>, String> {
    s.split(|c: char| c == ',' || c.is_whitespace())
        .filter(|t| !t.is_empty())
        .map(parse_f64)
        .collect()
}

/// One or three numbers (one stands for all three).
pub fn triple(s: &str) -> Result<DVec3, String> {
    match numbers(s)?.as_slice() {
        [v] => Ok(DVec3::splat(*v)),
        [x, y, z] => Ok(DVec3::new(*x, *y, *z)),
        other => Err(format!(
            "{} has {} numbers, expected 1 or 3",
            quoted(s),
            other.len()
        )),
    }
}
