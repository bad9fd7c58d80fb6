//! A thin dielectric sheet (a window pane) in a white furnace: a clear
//! pane reflects and transmits everything it receives, so with a constant
//! environment of radiance 1 every pixel is 1, behind the pane and in its
//! reflection, for every integrator.

use integrators::{Algorithm, Mode, Strategies};

use crate::common;

/// The pane seen at an angle, filling most of the view, as a Mitsuba file.
fn pane_in_a_furnace() -> scene::Scene {
    let xml = r#"<scene version="3.0.0">
    <sensor type="perspective">
        <float name="fov" value="60"/>
        <transform name="to_world"><lookat origin="0, 0, 3" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="12"/><integer name="height" value="8"/>
            <rfilter type="box"/></film>
    </sensor>
    <emitter type="constant"><rgb name="radiance" value="1"/></emitter>
    <shape type="rectangle">
        <transform name="to_world"><scale value="2"/><rotate y="1" angle="50"/></transform>
        <bsdf type="thindielectric"><float name="int_ior" value="1.5"/></bsdf>
    </shape>
</scene>"#;
    let dir = std::env::temp_dir().join(format!("rlt-thin-pane-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("scene.xml"), xml).unwrap();
    let scene = common::load(&dir.join("scene.xml"), 12, 8);
    std::fs::remove_dir_all(&dir).unwrap();
    assert!(
        scene
            .materials
            .iter()
            .any(|m| matches!(m.surface, scene::Surface::ThinDielectric { .. }))
    );
    scene
}

/// Path tracing carries weight 1 through either lobe: every pixel is 1 to
/// rounding. BPT and VCM (light subpaths, connections, merges, MIS) agree
/// within their noise.
#[test]
fn a_clear_pane_keeps_the_furnace_white() {
    let scene = pane_in_a_furnace();
    let film = common::render(
        scene.clone(),
        common::config(Strategies::Mis, Mode::Off, 8),
        16,
    );
    for j in 0..film.height() {
        for i in 0..film.width() {
            let p = film.pixel_mean(i, j);
            assert!(
                (p - glam::DVec3::ONE).abs().max_element() < 1e-5,
                "pt ({i}, {j}): {p}"
            );
        }
    }
    for algorithm in [Algorithm::Bpt, Algorithm::Vcm] {
        let config = integrators::RenderConfig {
            algorithm,
            ..common::config(Strategies::Mis, Mode::Unsampleable, 8)
        };
        let film = common::render(scene.clone(), config, 64);
        let mean = common::block_means(&film, 1)[0].0;
        assert!(
            (mean - glam::DVec3::ONE).abs().max_element() < 1e-3,
            "{algorithm:?}: {mean}"
        );
    }
}
