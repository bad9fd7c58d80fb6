//! Iteration shards: the partial film of a render over a range of
//! iterations (`--partial`), in the file format of `image_io::film_file`.

use std::hash::Hasher;
use std::path::Path;

use image_io::film_file::{FilmHeader, PartialFilm};
use integrators::{Film, RenderConfig};
use scene::Scene;

/// The header of a render of `scene` (loaded from `scene_path`) with
/// `config` over iterations `first..=last`.
pub fn header(
    scene_path: &Path,
    scene: &Scene,
    config: &RenderConfig,
    first: u64,
    last: u64,
) -> FilmHeader {
    let r = scene.camera.resolution;
    FilmHeader {
        scene: scene_path.display().to_string(),
        scene_hash: scene_hash(scene),
        // How the path loop runs does not change the image: films of either
        // path loop resume and merge with each other.
        settings: format!(
            "{:?}",
            RenderConfig {
                wavefront: false,
                ..*config
            }
        ),
        seed: config.seed,
        first,
        last,
        width: r.x,
        height: r.y,
        render_millis: None,
    }
}

/// The film of a (merged) partial film; `None` if its data does not match its size.
pub fn film(partial: PartialFilm) -> Option<Film> {
    let h = &partial.header;
    Film::from_sums(
        h.width,
        h.height,
        partial.iterations,
        partial.sum,
        partial.sum_sq,
    )
}

/// A 64-bit FNV-1a hash of what determines the image: geometry, shading
/// data, materials, textures, lights and camera (not the file names).
pub fn scene_hash(scene: &Scene) -> u64 {
    let mut h = fnv::FnvHasher::default();
    let floats = |h: &mut fnv::FnvHasher, values: &mut dyn Iterator<Item = f32>| {
        for v in values {
            h.write_u32(v.to_bits());
        }
    };
    // Corner by corner, as the scene stored them before its vertices were
    // shared: the hash of a scene is what it was.
    let triangles = 0..scene.triangles.len();
    floats(
        &mut h,
        &mut triangles
            .clone()
            .flat_map(|i| scene.triangle(i))
            .flat_map(|v| v.to_array()),
    );
    floats(
        &mut h,
        &mut triangles
            .clone()
            .flat_map(|i| scene.shading_normals(i, scene.geometric_normal(i)))
            .flat_map(|v| v.to_array()),
    );
    floats(
        &mut h,
        &mut triangles
            .clone()
            .flat_map(|i| scene.triangle_uvs(i))
            .flat_map(|v| v.to_array()),
    );
    if !scene.tangents.is_empty() {
        floats(
            &mut h,
            &mut triangles
                .flat_map(|i| scene.corner_tangents(i))
                .flat_map(|v| v.to_array()),
        );
    }
    for &m in &scene.triangle_materials {
        h.write_u32(m);
    }
    // Nothing is written for a scene without spheres: its hash is what it
    // was before spheres existed.
    for sphere in &scene.spheres {
        floats(
            &mut h,
            &mut sphere
                .center
                .to_array()
                .into_iter()
                .chain([sphere.radius])
                .chain(sphere.axis.to_array()),
        );
        h.write_u32(sphere.material);
        h.write_u8(u8::from(sphere.inside));
    }
    for t in &scene.textures {
        h.write_u32(t.width);
        h.write_u32(t.height);
        floats(&mut h, &mut t.texels.iter().flat_map(|v| v.to_array()));
        h.write(format!("{:?}{:?}", t.wrap_u, t.wrap_v).as_bytes());
        if let Some(transform) = t.transform {
            h.write(format!("{transform:?}").as_bytes());
        }
    }
    for m in &scene.environment_maps {
        h.write_u32(m.width);
        h.write_u32(m.height);
        floats(&mut h, &mut m.texels.iter().flat_map(|v| v.to_array()));
        floats(&mut h, &mut [m.scale, m.rotation_degrees].into_iter());
    }
    // Small parts: their Debug form lists every field.
    h.write(format!("{:?}{:?}{:?}", scene.materials, scene.lights, scene.camera).as_bytes());
    h.finish()
}
