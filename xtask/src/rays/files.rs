//! The files of a ray dump: plain little-endian arrays that another ray
//! tracer (an Embree harness in C++, say) reads with a few lines of code,
//! and a JSON manifest for people and for `rays bench`.
//!
//! In the dump folder:
//! - `mesh.vertices`: the world-space vertex positions, 3 `f32` each;
//! - `mesh.indices`: the triangles, 3 `u32` vertex indices each;
//! - `camera.rays`, `diffuse.rays`, `shadow.rays`: 7 `f32` per ray, origin
//!   xyz, direction xyz (not always unit length: a shadow ray's direction
//!   spans the segment to the light, with `t_max` = 1) and `t_max`
//!   (infinity for rays that go on to the end of the scene); a ray query
//!   covers `0 < t < t_max`;
//! - `rays.json`: the scene, the counts and each set's query.

use std::fs;
use std::path::Path;

use glam::Vec3;

/// The vertex file, 3 `f32` per vertex.
pub(super) const VERTICES_FILE: &str = "mesh.vertices";
/// The index file, 3 `u32` per triangle.
pub(super) const INDICES_FILE: &str = "mesh.indices";
/// The manifest.
pub(super) const MANIFEST_FILE: &str = "rays.json";
/// `f32` values per ray in a ray file.
const RAY_FLOATS: usize = 7;

/// One ray of a set: the query is `0 < t < t_max` along
/// `origin + t * direction`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Ray {
    pub origin: Vec3,
    pub direction: Vec3,
    pub t_max: f32,
}

/// What a ray set asks of the tracer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Query {
    /// The closest hit (`Bvh::intersect`, `rtcIntersect1`).
    Closest,
    /// Whether anything is hit (`Bvh::occluded`, `rtcOccluded1`).
    Any,
}

impl Query {
    /// The query's name in the manifest and the reports.
    pub(super) fn name(self) -> &'static str {
        match self {
            Self::Closest => "closest",
            Self::Any => "any",
        }
    }
}

/// The three ray sets, in the order the dump writes and the bench times
/// them: (name, query). The file of set `name` is `<name>.rays`.
pub(super) const SETS: [(&str, Query); 3] = [
    ("camera", Query::Closest),
    ("diffuse", Query::Closest),
    ("shadow", Query::Any),
];

/// The file of ray set `name`.
pub(super) fn ray_file(name: &str) -> String {
    format!("{name}.rays")
}

/// Writes `values` as little-endian 4-byte words to `dir/file`.
fn write_words(
    dir: &Path,
    file: &str,
    values: impl Iterator<Item = [u8; 4]>,
) -> Result<(), String> {
    let bytes: Vec<u8> = values.flatten().collect();
    crate::write_file(&dir.join(file), bytes)
}

/// Reads `dir/file` as little-endian 4-byte words, in groups of `group`.
fn read_words(dir: &Path, file: &str, group: usize) -> Result<Vec<[u8; 4]>, String> {
    let path = dir.join(file);
    let bytes = fs::read(&path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    if bytes.len() % (4 * group) != 0 {
        return Err(format!(
            "{}: {} bytes is not a whole number of {}-byte records",
            path.display(),
            bytes.len(),
            4 * group
        ));
    }
    Ok(bytes
        .chunks_exact(4)
        .map(|w| [w[0], w[1], w[2], w[3]])
        .collect())
}

/// Writes the mesh files.
pub(super) fn write_mesh(
    dir: &Path,
    positions: &[Vec3],
    triangles: &[[u32; 3]],
) -> Result<(), String> {
    write_words(
        dir,
        VERTICES_FILE,
        positions
            .iter()
            .flat_map(|p| p.to_array())
            .map(f32::to_le_bytes),
    )?;
    write_words(
        dir,
        INDICES_FILE,
        triangles.iter().flatten().map(|i| i.to_le_bytes()),
    )
}

/// Reads the mesh files; an index out of range is an error naming it.
pub(super) fn read_mesh(dir: &Path) -> Result<(Vec<Vec3>, Vec<[u32; 3]>), String> {
    let floats: Vec<f32> = read_words(dir, VERTICES_FILE, 3)?
        .into_iter()
        .map(f32::from_le_bytes)
        .collect();
    let positions: Vec<Vec3> = floats.chunks_exact(3).map(Vec3::from_slice).collect();
    let indices: Vec<u32> = read_words(dir, INDICES_FILE, 3)?
        .into_iter()
        .map(u32::from_le_bytes)
        .collect();
    if let Some((k, &i)) = indices
        .iter()
        .enumerate()
        .find(|&(_, &i)| i as usize >= positions.len())
    {
        return Err(format!(
            "{}: triangle {} names vertex {i}, but {} has {} vertices",
            dir.join(INDICES_FILE).display(),
            k / 3,
            VERTICES_FILE,
            positions.len()
        ));
    }
    let triangles = indices
        .chunks_exact(3)
        .map(|t| [t[0], t[1], t[2]])
        .collect();
    Ok((positions, triangles))
}

/// Writes ray set `name`.
pub(super) fn write_rays(dir: &Path, name: &str, rays: &[Ray]) -> Result<(), String> {
    write_words(
        dir,
        &ray_file(name),
        rays.iter()
            .flat_map(|r| {
                let (o, d) = (r.origin, r.direction);
                [o.x, o.y, o.z, d.x, d.y, d.z, r.t_max]
            })
            .map(f32::to_le_bytes),
    )
}

/// Reads ray set `name`.
pub(super) fn read_rays(dir: &Path, name: &str) -> Result<Vec<Ray>, String> {
    let floats: Vec<f32> = read_words(dir, &ray_file(name), RAY_FLOATS)?
        .into_iter()
        .map(f32::from_le_bytes)
        .collect();
    Ok(floats
        .chunks_exact(RAY_FLOATS)
        .map(|r| Ray {
            origin: Vec3::from_slice(&r[0..3]),
            direction: Vec3::from_slice(&r[3..6]),
            t_max: r[6],
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mesh_and_rays_round_trip_and_bad_files_are_named() {
        let dir = std::env::temp_dir().join(format!("rlt-rays-files-{}", std::process::id()));
        fs::create_dir_all(&dir).unwrap();
        let positions = [Vec3::ZERO, Vec3::X, Vec3::new(0.0, 1.5, -2.0)];
        let triangles = [[0, 1, 2], [2, 1, 0]];
        write_mesh(&dir, &positions, &triangles).unwrap();
        assert_eq!(
            read_mesh(&dir).unwrap(),
            (positions.to_vec(), triangles.to_vec())
        );
        let rays = [Ray {
            origin: Vec3::new(1.0, -2.0, 3.0),
            direction: Vec3::Y,
            t_max: f32::INFINITY,
        }];
        write_rays(&dir, "camera", &rays).unwrap();
        assert_eq!(read_rays(&dir, "camera").unwrap(), rays);
        // An index beyond the vertices, and a truncated ray file.
        write_mesh(&dir, &positions[..2], &triangles).unwrap();
        let e = read_mesh(&dir).unwrap_err();
        assert!(e.contains("names vertex 2"), "{e}");
        fs::write(dir.join(ray_file("camera")), [0u8; 8]).unwrap();
        let e = read_rays(&dir, "camera").unwrap_err();
        assert!(e.contains("28-byte records"), "{e}");
        fs::remove_dir_all(&dir).unwrap();
    }
}
