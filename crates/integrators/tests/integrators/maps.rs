//! Emissive textures, alpha cut-outs and stochastic transparency, normal
//! maps and texture transforms in rendered images: each image is compared
//! with the image of a scene whose geometry says the same thing (a light
//! cut in half, a quad with its cut region removed, a tilted floor), with
//! tolerances from the films' measured variance (`common`).
//!
//! Scenes are manifests written here; the maps are attached to the loaded
//! scene (`Scene` is plain data), so no image file is needed.

use crate::common;

use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};

use glam::{DVec3, Vec3, Vec4};
use integrators::{Algorithm, Film, Mode, RenderConfig, Strategies};
use scene::material::{Alpha, NormalMap, NormalMapKind};
use scene::texture::{Texture, UvTransform, Wrap};
use stats::chi2::sidak;

const SIZE: (u32, u32) = (32, 24);

/// The floor (y = 0, 2 x 2, facing up), the camera looking at it from the
/// front and above, and `shapes` (manifest `[[shape]]` and `[[material]]`
/// tables).
fn floor_scene(shapes: &str) -> scene::Scene {
    let text = format!(
        r#"
[camera]
from = [0, 0.9, 2.4]
at = [0, 0, 0]
fov = 45
[[material]]
name = "floor"
type = "diffuse"
reflectance = [0.8, 0.8, 0.8]
[[material]]
name = "black"
type = "diffuse"
reflectance = [0, 0, 0]
[[material]]
name = "light"
type = "diffuse"
reflectance = [0, 0, 0]
emission = [4, 4, 4]
[[shape]]
type = "quad"
material = "floor"
origin = [-1, 0, 1]
u = [2, 0, 0]
v = [0, 0, -2]
{shapes}
"#
    );
    common::load_manifest("maps", &text, &[], SIZE)
}

/// A quad shape of `material`: `origin + s u + t v`; its uv u runs along `u`.
fn quad(material: &str, origin: [f32; 3], u: [f32; 3], v: [f32; 3]) -> String {
    format!(
        "[[shape]]\ntype = \"quad\"\nmaterial = \"{material}\"\norigin = {origin:?}\nu = {u:?}\nv = {v:?}\n"
    )
}

/// The light, facing down at y = 1.2, x in [x0, x1], z in [-0.5, 0.5].
fn light(material: &str, x0: f32, x1: f32) -> String {
    quad(
        material,
        [x0, 1.2, -0.5],
        [x1 - x0, 0.0, 0.0],
        [0.0, 0.0, 1.0],
    )
}

fn material(scene: &scene::Scene, name: &str) -> usize {
    scene.materials.iter().position(|m| m.name == name).unwrap()
}

/// A 256 x 1 texture, `left` for u < 0.5 and `right` above (clamped).
fn halves(left: Vec4, right: Vec4) -> Texture {
    let mut t = Texture::from_u8(1, 1, 1, &[0], false).unwrap();
    t.width = 256;
    t.texels = (0..256)
        .map(|x| if x < 128 { left } else { right })
        .collect();
    t.wrap_u = Wrap::Clamp;
    t
}

fn add_texture(scene: &mut scene::Scene, t: Texture) -> usize {
    scene.textures.push(t);
    scene.textures.len() - 1
}

fn config(algorithm: Algorithm, seed: u64) -> RenderConfig {
    RenderConfig {
        algorithm,
        seed,
        ..common::config(Strategies::Mis, Mode::Off, 8)
    }
}

fn render(scene: scene::Scene, algorithm: Algorithm, seed: u64, iterations: u64) -> Film {
    common::render(scene, config(algorithm, seed), iterations)
}

/// The light with its left half (u < 0.5) black through an emissive texture.
fn half_textured_light(left: Vec4, right: Vec4, transform: Option<UvTransform>) -> scene::Scene {
    let mut scene = floor_scene(&light("light", -0.5, 0.5));
    let mut t = halves(left, right);
    if transform.is_some() {
        t.wrap_u = Wrap::Repeat;
        t.transform = transform;
    }
    let t = add_texture(&mut scene, t);
    let m = material(&scene, "light");
    scene.materials[m].maps.emission = Some(t);
    scene
}

/// The light as two quads: its left half black, its right half emitting
/// (or the other way round with `mirrored`).
fn half_light_geometry(mirrored: bool) -> scene::Scene {
    let (left, right) = if mirrored {
        ("light", "black")
    } else {
        ("black", "light")
    };
    floor_scene(&format!(
        "{}{}",
        light(left, -0.5, 0.0),
        light(right, 0.0, 0.5)
    ))
}

/// An emissive texture black on one half emits as if that half were not
/// emitting at all, in PT and BPT (the triangles are still chosen by their
/// factor, so half the light samples carry nothing).
#[test]
fn emissive_texture_is_the_light_cut_in_half() {
    let reference = render(half_light_geometry(false), Algorithm::Pt, 1, 96);
    let textured = || half_textured_light(Vec4::ZERO, Vec4::ONE, None);
    for (algorithm, seed) in [(Algorithm::Pt, 2), (Algorithm::Bpt, 3)] {
        let film = render(textured(), algorithm, seed, 96);
        let p = common::assert_films_agree(
            &reference,
            &film,
            4,
            &format!("emissive texture {algorithm:?}"),
        );
        eprintln!("emissive texture, {algorithm:?}: smallest p {p:.3}");
    }
    // The whole floor receives half the power of the untextured light.
    let full = common::block_means(
        &render(
            floor_scene(&light("light", -0.5, 0.5)),
            Algorithm::Pt,
            4,
            96,
        ),
        1,
    );
    let half = common::block_means(&reference, 1);
    let ratio = half[0].0.x / full[0].0.x;
    eprintln!("textured / untextured image mean: {ratio:.4}");
    assert!((0.3..0.7).contains(&ratio), "{ratio}");
}

/// KHR_texture_transform's offset 0.5 on a repeating texture swaps its
/// halves: the image is the mirrored cut light's.
#[test]
fn texture_transform_swaps_the_halves() {
    let swap = UvTransform {
        offset: glam::Vec2::new(0.5, 0.0),
        rotation: 0.0,
        scale: glam::Vec2::ONE,
    };
    let film = render(
        half_textured_light(Vec4::ZERO, Vec4::ONE, Some(swap)),
        Algorithm::Pt,
        5,
        96,
    );
    let reference = render(half_light_geometry(true), Algorithm::Pt, 6, 96);
    let p = common::assert_films_agree(&reference, &film, 4, "texture transform");
    eprintln!("texture transform: smallest p {p:.3}");
}

/// An occluder at y = 0.7 between the light and the floor, x in [-0.6, 0.6].
fn occluder(material: &str, x0: f32, x1: f32) -> String {
    quad(
        material,
        [x0, 0.7, -0.6],
        [x1 - x0, 0.0, 0.0],
        [0.0, 0.0, 1.2],
    )
}

/// A MASK cut-out (alpha 0 on the occluder's left half) is the occluder
/// without its left half, for camera, shadow and light rays alike.
#[test]
fn mask_cuts_the_surface_out_for_every_ray() {
    let lit = light("light", -0.5, 0.5);
    let reference = render(
        floor_scene(&format!("{lit}{}", occluder("floor", 0.0, 0.6))),
        Algorithm::Pt,
        7,
        96,
    );
    let masked = || {
        let mut scene = floor_scene(&format!("{lit}{}", occluder("floor", -0.6, 0.6)));
        let t = add_texture(&mut scene, halves(Vec4::new(1.0, 1.0, 1.0, 0.0), Vec4::ONE));
        // The occluder has its own material (the floor's keeps no mask).
        let mut m = scene.materials[material(&scene, "floor")].clone();
        m.name = "occluder".into();
        m.maps.alpha = Alpha::Mask {
            factor: 1.0,
            texture: Some(t),
            cutoff: 0.5,
        };
        scene.materials.push(m);
        let id = (scene.materials.len() - 1) as u32;
        // The occluder's triangles are the last two.
        let n = scene.triangle_materials.len();
        scene.triangle_materials[n - 2..].fill(id);
        scene
    };
    for (algorithm, seed) in [(Algorithm::Pt, 8), (Algorithm::Bpt, 9)] {
        let film = render(masked(), algorithm, seed, 96);
        let p = common::assert_films_agree(&reference, &film, 4, &format!("mask {algorithm:?}"));
        eprintln!("mask, {algorithm:?}: smallest p {p:.3}");
    }
}

/// An emitter cut out by MASK emits only where it exists: light samples
/// (next-event estimation, light subpaths' starts) on the cut half carry
/// nothing, as camera rays pass through it.
#[test]
fn masked_light_emits_only_where_it_exists() {
    let reference = render(half_light_geometry(false), Algorithm::Pt, 14, 96);
    let masked = || {
        let mut scene = floor_scene(&light("light", -0.5, 0.5));
        let t = add_texture(&mut scene, halves(Vec4::new(1.0, 1.0, 1.0, 0.0), Vec4::ONE));
        let m = material(&scene, "light");
        scene.materials[m].maps.alpha = Alpha::Mask {
            factor: 1.0,
            texture: Some(t),
            cutoff: 0.5,
        };
        scene
    };
    for (algorithm, seed) in [(Algorithm::Pt, 15), (Algorithm::Bpt, 16)] {
        let film = render(masked(), algorithm, seed, 96);
        let p = common::assert_films_agree(
            &reference,
            &film,
            4,
            &format!("masked light {algorithm:?}"),
        );
        eprintln!("masked light, {algorithm:?}: smallest p {p:.3}");
    }
}

/// A black BLEND occluder of alpha 0.5 transmits half: with everything
/// above it black, each path crosses it at most once, so its image is the
/// mean of the images with and without an opaque occluder (per block,
/// within the three films' variance).
#[test]
fn blend_transmits_alpha() {
    let lit = light("light", -0.5, 0.5);
    let with = render(
        floor_scene(&format!("{lit}{}", occluder("black", -0.6, 0.6))),
        Algorithm::Pt,
        10,
        128,
    );
    let without = render(floor_scene(&lit), Algorithm::Pt, 11, 128);
    let mut blended = floor_scene(&format!("{lit}{}", occluder("black", -0.6, 0.6)));
    let m = material(&blended, "black");
    blended.materials[m].maps.alpha = Alpha::Blend {
        factor: 0.5,
        texture: None,
    };
    for (algorithm, seed) in [(Algorithm::Pt, 12), (Algorithm::Bpt, 13)] {
        let film = render(blended.clone(), algorithm, seed, 128);
        let p = assert_mixture(&film, &with, &without, 0.5, 4);
        eprintln!("blend, {algorithm:?}: smallest p {p:.3}");
    }
}

/// Asserts that the blocks of `film` agree with `w a + (1 - w) b` (Sidak
/// corrected 0.01 over blocks and channels); returns the smallest p-value.
fn assert_mixture(film: &Film, a: &Film, b: &Film, w: f64, blocks: u32) -> f64 {
    let (f, a, b) = (
        common::block_means(film, blocks),
        common::block_means(a, blocks),
        common::block_means(b, blocks),
    );
    let threshold = sidak(0.01, f.len() * 3);
    let mut smallest = 1.0f64;
    for (i, ((mf, vf), ((ma, va), (mb, vb)))) in f.iter().zip(a.iter().zip(&b)).enumerate() {
        let expected: DVec3 = w * *ma + (1.0 - w) * *mb;
        let var: DVec3 = *vf + w * w * *va + (1.0 - w) * (1.0 - w) * *vb;
        for c in 0..3 {
            let diff = mf[c] - expected[c];
            let p = common::difference_p_value(diff, var[c].sqrt());
            smallest = smallest.min(p);
            assert!(
                p > threshold,
                "block {i} channel {c}: {} vs {} (sd {:.3e}), p = {p:.2e}",
                mf[c],
                expected[c],
                var[c].sqrt()
            );
        }
    }
    smallest
}

/// A floor of GGX conductor (alpha 0.1), lit by a directional light, seen
/// from 100 units away through a 0.5 degree field: every pixel sees
/// (almost) the same directions. `tilt` rotates the floor about z.
fn glossy_floor(tilt: f32, wo: Vec3, wi: Vec3) -> scene::Scene {
    static COUNTER: AtomicUsize = AtomicUsize::new(0);
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let dir: PathBuf = std::env::temp_dir().join(format!("maps-glossy-{}-{n}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (s, c) = tilt.sin_cos();
    let from = wo * 100.0;
    let text = format!(
        r#"
[camera]
from = [{}, {}, {}]
at = [0, 0, 0]
fov = 0.5
[[material]]
name = "metal"
type = "conductor"
alpha = 0.1
reflectance = [0.9, 0.9, 0.9]
[[shape]]
type = "quad"
material = "metal"
origin = [{}, {}, 1]
u = [{}, {}, 0]
v = [0, 0, -2]
[[light]]
type = "directional"
direction = [{}, {}, {}]
intensity = [1, 1, 1]
"#,
        from.x,
        from.y,
        from.z,
        -c,
        s,
        2.0 * c,
        -2.0 * s,
        -wi.x,
        -wi.y,
        -wi.z,
    );
    let path = dir.join("scene.toml");
    std::fs::write(&path, text).unwrap();
    let scene = common::load(&path, 16, 16);
    let _ = std::fs::remove_dir_all(&dir);
    scene
}

/// A constant tangent-space normal map (float texels, so the encoding is exact).
fn constant_normal_map(scene: &mut scene::Scene, n: Vec3) {
    let mut t = Texture::from_u8(1, 1, 1, &[0], false).unwrap();
    t.texels = vec![((n + Vec3::ONE) * 0.5).extend(1.0)];
    let t = add_texture(scene, t);
    for m in &mut scene.materials {
        m.maps.normal = Some(NormalMap {
            texture: t,
            kind: NormalMapKind::Tangent { scale: 1.0 },
        });
    }
}

const TILT: f32 = 0.17; // about 10 degrees

/// The camera direction and the light direction mirrored about the tilted normal.
fn directions() -> (Vec3, Vec3, Vec3) {
    let ns = Vec3::new(TILT.sin(), TILT.cos(), 0.0);
    let wo = Vec3::new(0.3, 0.6, 0.8).normalize();
    let wi = 2.0 * wo.dot(ns) * ns - wo;
    (ns, wo, wi)
}

/// The flat normal map (0.5, 0.5, 1) changes nothing (within 1e-6); a
/// constant map tilted by 10 degrees renders as the floor tilted by 10
/// degrees: in PT (deterministic here: a directional light, no
/// environment; equal within 1e-4) and in BPT, whose light tracing goes
/// through the adjoint shading-normal correction of the perturbed frame
/// (within the film's noise).
#[test]
fn normal_maps_tilt_the_shading_normal() {
    let (_, wo, wi) = directions();
    let pt = |scene, seed| render(scene, Algorithm::Pt, seed, 16);
    // Flat map.
    let plain = pt(glossy_floor(TILT, wo, wi), 1);
    let mut flat = glossy_floor(TILT, wo, wi);
    constant_normal_map(&mut flat, Vec3::Z);
    let flat = pt(flat, 1);
    let max_rel = relative_difference(&plain, &flat);
    eprintln!("flat normal map: largest relative pixel difference {max_rel:.2e}");
    assert!(max_rel < 1e-6, "{max_rel}");

    // Tilted map on a flat floor vs the tilted floor.
    let mapped = || {
        let mut s = glossy_floor(0.0, wo, wi);
        constant_normal_map(&mut s, Vec3::new(TILT.sin(), 0.0, TILT.cos()));
        s
    };
    let tilted = pt(glossy_floor(TILT, wo, wi), 2);
    let mapped_pt = pt(mapped(), 2);
    let mean = common::block_means(&tilted, 1)[0].0.x;
    assert!(mean > 0.1, "the highlight must be in view: mean {mean}");
    let max_rel = relative_difference(&tilted, &mapped_pt);
    eprintln!(
        "tilted normal map vs tilted floor, PT: largest relative pixel difference {max_rel:.2e}, mean {mean:.4}"
    );
    assert!(max_rel < 1e-4, "{max_rel}");
    let bpt = render(mapped(), Algorithm::Bpt, 3, 64);
    let p = common::assert_films_agree(&tilted, &bpt, 2, "tilted normal map, BPT");
    eprintln!("tilted normal map, BPT vs tilted floor: smallest p {p:.3}");

    // A bump map whose height falls linearly along u by 2 tan(tilt) per uv
    // unit (the floor is 2 wide) tilts the normal the same way.
    let mut bumped = glossy_floor(0.0, wo, wi);
    let mut t = Texture::from_u8(1, 1, 1, &[0], false).unwrap();
    t.width = 256;
    t.texels = (0..256)
        .map(|i| Vec4::splat(1.0 - i as f32 / 256.0))
        .collect();
    t.wrap_u = Wrap::Clamp;
    let t = add_texture(&mut bumped, t);
    let scale = 2.0 * TILT.tan();
    for m in &mut bumped.materials {
        m.maps.normal = Some(NormalMap {
            texture: t,
            kind: NormalMapKind::Height { scale },
        });
    }
    let max_rel = relative_difference(&tilted, &pt(bumped, 2));
    eprintln!("bump ramp vs tilted floor, PT: largest relative pixel difference {max_rel:.2e}");
    assert!(max_rel < 1e-4, "{max_rel}");
}

/// PT, BPT and VCM agree on a diffuse floor with a varying normal map (a
/// sine ridge pattern, up to 45 degrees of tilt) under the area light:
/// light subpaths leave and reach the perturbed frames with the adjoint
/// correction, camera subpaths without.
#[test]
fn pt_bpt_vcm_agree_on_a_normal_mapped_floor() {
    let scene = || {
        let mut s = floor_scene(&light("light", -0.5, 0.5));
        let mut t = Texture::from_u8(1, 1, 1, &[0], false).unwrap();
        t.width = 64;
        t.texels = (0..64)
            .map(|i| {
                let slope = (i as f32 * std::f32::consts::TAU / 16.0).sin();
                let n = Vec3::new(slope, 0.0, 1.0).normalize();
                ((n + Vec3::ONE) * 0.5).extend(1.0)
            })
            .collect();
        let t = add_texture(&mut s, t);
        let m = material(&s, "floor");
        s.materials[m].maps.normal = Some(NormalMap {
            texture: t,
            kind: NormalMapKind::Tangent { scale: 1.0 },
        });
        s
    };
    let pt = render(scene(), Algorithm::Pt, 21, 256);
    for (algorithm, seed) in [(Algorithm::Bpt, 22), (Algorithm::Vcm, 23)] {
        let film = render(scene(), algorithm, seed, 256);
        let p = common::assert_films_agree(
            &pt,
            &film,
            4,
            &format!("normal-mapped floor {algorithm:?}"),
        );
        eprintln!("normal-mapped floor, PT vs {algorithm:?}: smallest p {p:.3}");
    }
}

fn relative_difference(a: &Film, b: &Film) -> f64 {
    let mut worst = 0.0f64;
    for y in 0..a.height() {
        for x in 0..a.width() {
            let (pa, pb) = (a.pixel_mean(x, y), b.pixel_mean(x, y));
            let scale = pa.abs().max(pb.abs()).max_element().max(1e-3);
            worst = worst.max((pa - pb).abs().max_element() / scale);
        }
    }
    worst
}
