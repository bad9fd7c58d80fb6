//! The syntax and ranges of setting values, shared by the flags (as clap
//! value parsers: a bad value is a usage error naming the flag) and by the
//! manifest's `[render]` table (checked when the settings are resolved: an
//! error names the manifest and the key). Each returns the message shown
//! after the flag or the key.

use std::path::PathBuf;
use std::time::Duration;

use glam::{UVec2, Vec3};
use integrators::{Algorithm, Mode, Schedule};

/// Largest image side accepted by `--resolution`.
pub const MAX_RESOLUTION: u32 = 16384;

pub fn parse_on_off(s: &str) -> Result<bool, String> {
    match s.to_ascii_lowercase().as_str() {
        "on" => Ok(true),
        "off" => Ok(false),
        _ => Err("expected on or off".into()),
    }
}

/// The first merge radius, a fraction of the scene's radius: positive and finite.
pub fn check_radius(r: f32) -> Result<f32, String> {
    if r > 0.0 && r.is_finite() {
        return Ok(r);
    }
    Err(format!(
        "expected a positive number (a fraction of the scene radius, e.g. 0.003), got {r}"
    ))
}

/// The shadow-roulette threshold, a fraction of the mean pixel value: finite and >= 0.
pub fn check_shadow_roulette(t: f32) -> Result<f32, String> {
    if t >= 0.0 && t.is_finite() {
        return Ok(t);
    }
    Err(format!(
        "expected a number >= 0 (a fraction of the mean pixel value, e.g. 0.1; 0: off), got {t}"
    ))
}

pub fn parse_radius(s: &str) -> Result<f32, String> {
    check_radius(parse_number(s)?)
}

pub fn parse_shadow_roulette(s: &str) -> Result<f32, String> {
    check_shadow_roulette(parse_number(s)?)
}

fn parse_number(s: &str) -> Result<f32, String> {
    s.trim()
        .parse()
        .map_err(|_| format!("'{s}' is not a number"))
}

pub fn parse_algorithm(s: &str) -> Result<Algorithm, String> {
    s.parse()
        .map_err(|e: integrators::ConfigError| e.to_string())
}

pub fn parse_regularize(s: &str) -> Result<Mode, String> {
    s.parse::<Mode>().map_err(|e| e.to_string())
}

/// tau_0 must exceed 1/(2 pi) (the schedule's own check and message).
pub fn check_tau0(tau0: f64) -> Result<f64, String> {
    Schedule::new(tau0).map(|_| tau0).map_err(|e| e.to_string())
}

pub fn at_least_one(n: u64) -> Result<u64, String> {
    if n == 0 {
        return Err("must be at least 1, got 0".into());
    }
    Ok(n)
}

pub fn parse_tau0(s: &str) -> Result<f64, String> {
    check_tau0(
        s.trim()
            .parse()
            .map_err(|_| format!("'{s}' is not a number"))?,
    )
}

pub fn parse_iterations(s: &str) -> Result<u64, String> {
    at_least_one(
        s.trim()
            .parse()
            .map_err(|_| format!("'{s}' is not a whole number"))?,
    )
}

/// `A..B`: iterations A to B, 1-based and inclusive, as the progress bar
/// counts them.
pub fn parse_iteration_range(s: &str) -> Result<(u64, u64), String> {
    let expected = || format!("expected A..B with 1 <= A <= B (e.g. 1..64), got '{s}'");
    let (a, b) = s.trim().split_once("..").ok_or_else(expected)?;
    let (a, b): (u64, u64) = (
        a.trim().parse().map_err(|_| expected())?,
        b.trim().parse().map_err(|_| expected())?,
    );
    if a == 0 || b < a {
        return Err(expected());
    }
    Ok((a, b))
}

pub fn parse_max_depth(s: &str) -> Result<u32, String> {
    let d: u32 = (s.trim().parse())
        .map_err(|_| format!("'{s}' is not a whole number up to {}", u32::MAX))?;
    at_least_one(u64::from(d)).map(|_| d)
}

pub fn parse_threads(s: &str) -> Result<usize, String> {
    let k: usize = s
        .trim()
        .parse()
        .map_err(|_| format!("'{s}' is not a whole number"))?;
    at_least_one(k as u64).map(|_| k)
}

pub fn parse_time(s: &str) -> Result<Duration, String> {
    let seconds: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("'{s}' is not a number"))?;
    if !(seconds > 0.0 && seconds.is_finite()) {
        return Err(format!(
            "must be a positive, finite number of seconds, got {s}"
        ));
    }
    Duration::try_from_secs_f64(seconds).map_err(|_| format!("{s} seconds is too long"))
}

/// `--checkpoint-every`: a finite number of seconds >= 0.
pub fn parse_checkpoint_interval(s: &str) -> Result<Duration, String> {
    let seconds: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("'{s}' is not a number"))?;
    if !(seconds >= 0.0 && seconds.is_finite()) {
        return Err(format!("must be a finite number of seconds >= 0, got {s}"));
    }
    Duration::try_from_secs_f64(seconds).map_err(|_| format!("{s} seconds is too long"))
}

pub fn parse_fov(s: &str) -> Result<f32, String> {
    let fov: f32 = s
        .trim()
        .parse()
        .map_err(|_| format!("'{s}' is not a number"))?;
    if !(fov > 0.0 && fov < 180.0) {
        return Err(format!("must be in (0, 180) degrees, got {s}"));
    }
    Ok(fov)
}

/// `--env-scale`: a finite multiplier >= 0.
pub fn parse_env_scale(s: &str) -> Result<f32, String> {
    let scale: f32 = s
        .trim()
        .parse()
        .map_err(|_| format!("'{s}' is not a number"))?;
    if !(scale.is_finite() && scale >= 0.0) {
        return Err(format!("must be a finite number >= 0, got {s}"));
    }
    Ok(scale)
}

/// `--env-rotation`: a finite number of degrees.
pub fn parse_env_rotation(s: &str) -> Result<f32, String> {
    let degrees: f32 = s
        .trim()
        .parse()
        .map_err(|_| format!("'{s}' is not a number"))?;
    if !degrees.is_finite() {
        return Err(format!("must be a finite number of degrees, got {s}"));
    }
    Ok(degrees)
}

pub fn parse_exposure(s: &str) -> Result<f32, String> {
    let stops: f32 = s
        .trim()
        .parse()
        .map_err(|_| format!("'{s}' is not a number"))?;
    if !stops.is_finite() {
        return Err(format!("must be a finite number of stops, got {s}"));
    }
    Ok(stops)
}

/// `X,Y,Z`: exactly three finite numbers.
pub fn parse_vec3(s: &str) -> Result<Vec3, String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let [x, y, z] = parts[..] else {
        return Err(format!(
            "expected 3 comma-separated numbers X,Y,Z, got {}",
            parts.len()
        ));
    };
    let number = |p: &str| match p.parse::<f32>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Err(format!("{p} is not finite")),
        Err(_) => Err(format!("'{p}' is not a number")),
    };
    Ok(Vec3::new(number(x)?, number(y)?, number(z)?))
}

/// `WxH` with each side in 1..=MAX_RESOLUTION.
pub fn parse_resolution(s: &str) -> Result<UVec2, String> {
    let Some((w, h)) = s.trim().split_once(['x', 'X']) else {
        return Err("expected WIDTHxHEIGHT, e.g. 640x480".into());
    };
    let side = |p: &str| match p.trim().parse::<u32>() {
        Ok(v) if (1..=MAX_RESOLUTION).contains(&v) => Ok(v),
        _ => Err(format!(
            "each side must be a whole number in 1..={MAX_RESOLUTION}, got '{p}'"
        )),
    };
    Ok(UVec2::new(side(w)?, side(h)?))
}

fn parse_path_with_extension(s: &str, extension: &str) -> Result<PathBuf, String> {
    let path = PathBuf::from(s);
    match path.extension().and_then(|e| e.to_str()) {
        Some(e) if e.eq_ignore_ascii_case(extension) => Ok(path),
        _ => Err(format!("the file name must end in .{extension}")),
    }
}

pub fn parse_exr_path(s: &str) -> Result<PathBuf, String> {
    parse_path_with_extension(s, "exr")
}

pub fn parse_png_path(s: &str) -> Result<PathBuf, String> {
    parse_path_with_extension(s, "png")
}

pub fn parse_partial_path(s: &str) -> Result<PathBuf, String> {
    parse_path_with_extension(s, image_io::film_file::EXTENSION)
}

/// `-D NAME=VALUE`: a Mitsuba scene parameter (NAME letters, digits and _).
pub fn parse_define(s: &str) -> Result<(String, String), String> {
    let (name, value) = s
        .split_once('=')
        .ok_or_else(|| format!("expected NAME=VALUE, got {s:?}"))?;
    if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
        return Err(format!(
            "parameter name {name:?} must be letters, digits and _"
        ));
    }
    Ok((name.to_owned(), value.to_owned()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn iteration_ranges_are_one_based_and_inclusive() {
        assert_eq!(parse_iteration_range("1..64"), Ok((1, 64)));
        assert_eq!(parse_iteration_range(" 33 .. 33 "), Ok((33, 33)));
        for bad in ["0..4", "5..4", "1-4", "1..", "..4", "a..b", "1..2..3"] {
            assert!(parse_iteration_range(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn vectors_need_three_finite_numbers() {
        assert_eq!(parse_vec3("1, -2.5,3e1"), Ok(Vec3::new(1.0, -2.5, 30.0)));
        assert!(parse_vec3("1,2").unwrap_err().contains("got 2"));
        assert!(parse_vec3("1,2,3,4").unwrap_err().contains("got 4"));
        assert!(parse_vec3("1,x,3").unwrap_err().contains("'x'"));
        assert!(parse_vec3("1,inf,3").unwrap_err().contains("not finite"));
        assert!(parse_vec3("1,NaN,3").unwrap_err().contains("not finite"));
        assert!(parse_vec3("").is_err());
    }

    #[test]
    fn resolutions_are_bounded() {
        assert_eq!(parse_resolution("640x480"), Ok(UVec2::new(640, 480)));
        assert_eq!(parse_resolution("16X12"), Ok(UVec2::new(16, 12)));
        assert_eq!(parse_resolution("16384x1"), Ok(UVec2::new(16384, 1)));
        for bad in [
            "0x5", "5x0", "16385x2", "640", "x480", "-1x5", "1.5x2", "axb",
        ] {
            assert!(parse_resolution(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn scalar_values_are_checked() {
        assert!(parse_iterations("0").is_err());
        assert!(parse_time("0").is_err() && parse_time("-1").is_err());
        assert!(parse_time("inf").is_err() && parse_time("NaN").is_err());
        assert_eq!(parse_time("0.25"), Ok(Duration::from_millis(250)));
        assert!(parse_fov("0").is_err() && parse_fov("180").is_err());
        assert!(parse_tau0("0.1").unwrap_err().contains("1/(2 pi)"));
        assert!(parse_tau0("NaN").is_err());
        assert_eq!(parse_tau0("30"), Ok(30.0));
        assert!(parse_threads("0").is_err());
        assert_eq!(parse_radius("0.01"), Ok(0.01));
        for bad in ["0", "-0.1", "NaN", "inf", "x", ""] {
            assert!(parse_radius(bad).is_err(), "{bad}");
        }
        assert!(parse_radius("-1").unwrap_err().ends_with("got -1"));
        assert_eq!(parse_shadow_roulette("0"), Ok(0.0));
        for bad in ["-0.1", "NaN", "inf", "x"] {
            assert!(parse_shadow_roulette(bad).is_err(), "{bad}");
        }
        assert!(parse_exr_path("out.png").is_err() && parse_exr_path("a/b.EXR").is_ok());
    }
}
