//! Mitsuba's camera and handedness conventions, rendered: the asymmetric
//! scene measured with Mitsuba 3.9.1 (`shared/notes/mitsuba-format.md` §3):
//! a camera at the origin looking along +z (up +y, fov 60 along x, 32x24,
//! box filter), emitters of radius 0.3 seen directly (max depth 1).

use std::path::PathBuf;

use integrators::{Mode, RenderConfig, Strategies};

use crate::common::{config, render};

/// Loads a Mitsuba file of one emitting sphere at `center`, with `extra`
/// transform operations before the camera's lookat.
fn sphere_scene(center: &str, extra: &str) -> scene::Scene {
    let xml = format!(
        r#"<scene version="3.0.0">
    <sensor type="perspective">
        <float name="fov" value="60"/>
        <transform name="to_world">{extra}<lookat origin="0,0,0" target="0,0,1" up="0,1,0"/></transform>
        <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="24"/>
            <rfilter type="box"/></film>
    </sensor>
    <shape type="sphere"><point name="center" value="{center}"/><float name="radius" value="0.3"/>
        <emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>
</scene>"#
    );
    load_xml(&xml)
}

/// Loads a Mitsuba file written to a temporary folder of its own.
fn load_xml(xml: &str) -> scene::Scene {
    static CALLS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let call = CALLS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let dir: PathBuf =
        std::env::temp_dir().join(format!("rlt-mitsuba-camera-{}-{call}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("scene.xml"), xml).unwrap();
    let scene = scene::load(&dir.join("scene.xml"), &scene::LoadOptions::default())
        .unwrap_or_else(|e| panic!("{e}"));
    std::fs::remove_dir_all(&dir).unwrap();
    scene
}

/// The centroid (x, y) in pixels of the image's brightness.
fn centroid(scene: scene::Scene) -> (f64, f64) {
    let config: RenderConfig = config(Strategies::Mis, Mode::Off, 1);
    let film = render(scene, config, 16);
    let (mut sum, mut x, mut y) = (0.0, 0.0, 0.0);
    for j in 0..film.height() {
        for i in 0..film.width() {
            let v = film.pixel_mean(i, j).x;
            sum += v;
            x += v * (f64::from(i) + 0.5);
            y += v * (f64::from(j) + 0.5);
        }
    }
    assert!(sum > 0.0, "the sphere is not in view");
    (x / sum, y / sum)
}

/// Mitsuba 3.9.1 put the sphere at (+1, 0, 5) at centroid x = 10.45 (world
/// +x on the image's left), the one at (0, +1, 5) at y = 6.41 (row 0 at
/// the top), and, with `<scale x="-1"/>` before the lookat, the first at
/// x = 21.60. Our centroids are within a quarter pixel (anti-aliased edge
/// pixels at 16 samples).
#[test]
fn images_match_mitsubas_orientation() {
    const TOLERANCE: f64 = 0.25;
    let (x, y) = centroid(sphere_scene("1, 0, 5", ""));
    assert!(
        (x - 10.45).abs() < TOLERANCE && (y - 12.0).abs() < TOLERANCE,
        "{x} {y}"
    );
    let (x, y) = centroid(sphere_scene("0, 1, 5", ""));
    assert!(
        (x - 16.0).abs() < TOLERANCE && (y - 6.41).abs() < TOLERANCE,
        "{x} {y}"
    );
    let (x, _) = centroid(sphere_scene("1, 0, 5", r#"<scale x="-1"/>"#));
    assert!((x - 21.60).abs() < TOLERANCE, "{x}");
}

/// Mitsuba's `near_clip`: what lies before the near plane is not seen. A
/// black sphere 0.5 in front of the camera hides a wall lit by a point
/// light at Mitsuba's default near plane (0.01), and not beyond a near
/// plane at 1: for camera rays (PT) and for light tracing's connections
/// to the camera (BPT, which agrees with PT there; blocking its connections
/// at the sphere darkens it to 0.75 of PT).
#[test]
fn near_clip_hides_what_lies_before_it() {
    let scene_with = |near: &str| {
        let xml = format!(
            r#"<scene version="3.0.0">
    <sensor type="perspective">
        <float name="fov" value="30"/>{near}
        <transform name="to_world"><lookat origin="0,0,0" target="0,0,1" up="0,1,0"/></transform>
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film>
    </sensor>
    <shape type="sphere"><point name="center" value="0, 0, 0.5"/><float name="radius" value="0.2"/>
        <bsdf type="diffuse"><rgb name="reflectance" value="0"/></bsdf></shape>
    <shape type="rectangle">
        <transform name="to_world"><scale value="3"/><rotate y="1" angle="180"/><translate z="4"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.8"/></bsdf></shape>
    <emitter type="point"><point name="position" value="0, 0, 3"/><rgb name="intensity" value="5"/></emitter>
</scene>"#
        );
        load_xml(&xml)
    };
    let centre = |algorithm, near: &str| {
        let config = RenderConfig {
            algorithm,
            shadow_roulette: 0.0,
            ..config(Strategies::Mis, Mode::Off, 2)
        };
        let film = render(scene_with(near), config, 64);
        (3..5)
            .flat_map(|y| (3..5).map(move |x| (x, y)))
            .map(|(x, y)| film.pixel_mean(x, y).x)
            .sum::<f64>()
            / 4.0
    };
    let near = r#"<float name="near_clip" value="1"/>"#;
    let (pt, bpt) = (integrators::Algorithm::Pt, integrators::Algorithm::Bpt);
    for algorithm in [pt, bpt] {
        let hidden = centre(algorithm, "");
        assert!(hidden < 1e-3, "{algorithm:?}: {hidden}");
    }
    // About (0.8 / pi) 5 / 1^2 = 1.27 on the axis, less off it.
    let seen = centre(pt, near);
    assert!(seen > 1.0, "{seen}");
    let bpt_seen = centre(bpt, near);
    assert!(
        (bpt_seen / seen - 1.0).abs() < 0.03,
        "bpt {bpt_seen} vs pt {seen}"
    );
}
