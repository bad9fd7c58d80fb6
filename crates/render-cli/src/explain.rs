//! `--explain`: what the renderer will do with a scene and why, in prose,
//! and every resolved setting with its origin. Presentation only: every
//! number comes from the `integrators` crate or from `settings`.

use std::fmt::Write as _;

use integrators::merge_radius::MAX_MERGE_RADIUS_PIXELS;
use integrators::{Algorithm, Energy, Mode, ROULETTE_DEPTH, Renderer, Strategies};

use crate::settings::{Budget, Settings};

/// A human-readable account of the integrator, its techniques, the shadow
/// roulette, the merge radius and the regularization of `renderer`.
pub fn integrator(renderer: &Renderer) -> String {
    let c = renderer.config();
    let mut s = String::new();
    let _ = writeln!(
        s,
        "integrator:       {} (max depth {}, seed {})",
        c.algorithm, c.max_depth, c.seed
    );
    let _ = writeln!(
        s,
        "strategies:       {}; Russian roulette from depth {ROULETTE_DEPTH}",
        strategies(renderer)
    );
    if c.algorithm == Algorithm::Pt {
        let path_loop = if c.wavefront {
            "a wavefront: the paths of a run of pixels of a row, bounce by bounce, the light and BSDF samples of their Lambertian vertices 16 at a time in SIMD lanes (--scalar-loop traces one path after the other: the same image)"
        } else {
            "one path after the other (--scalar-loop; the default wavefront gives the same image)"
        };
        let _ = writeln!(s, "path loop:        {path_loop}");
    }
    ray_queries(&mut s, renderer);
    shadow_roulette(&mut s, renderer);
    merging(&mut s, renderer);
    regularization(&mut s, renderer);
    left_out(&mut s, renderer);
    s
}

/// The acceleration structure and the instruction set its kernels (and the
/// path tracer's lanes) run on.
fn ray_queries(s: &mut String, renderer: &Renderer) {
    let bvh = &renderer.context().bvh;
    let structure = match bvh.layout() {
        accel::Layout::Flat => "no tree (every primitive tested, 16 at a time)",
        accel::Layout::Bvh8 => "an 8-wide BVH of float boxes",
        accel::Layout::Binary => "a binary BVH",
        _ => "an 8-wide BVH of compressed boxes",
    };
    let _ = writeln!(
        s,
        "ray queries:      {} triangles, {} spheres; {structure}; SIMD kernels on {} (the CPU's best, chosen at run time; every instruction set gives the same image)",
        bvh.triangle_count(),
        bvh.spheres().len(),
        bvh.simd_name()
    );
}

/// The shadow-ray roulette's threshold, if there is one.
fn shadow_roulette(s: &mut String, renderer: &Renderer) {
    let c = renderer.config();
    let scale = renderer.shadow_roulette_scale();
    if scale > 0.0 {
        let _ = writeln!(
            s,
            "shadow roulette:  next-event, connection and light-tracing contributions below {:.4e} ({} x the preview's mean pixel value {:.4e}) keep their shadow ray with probability contribution / threshold (Veach 1997, §10.4.1)",
            c.shadow_roulette * scale,
            c.shadow_roulette,
            scale
        );
    }
}

/// The merge radius and its rule, or why VCM does not merge.
fn merging(s: &mut String, renderer: &Renderer) {
    let c = renderer.config();
    let merges = c.algorithm == Algorithm::Ppm || renderer.techniques().is_some_and(|t| t.merging);
    if merges {
        let radius = renderer.merge_radius_rule();
        let rule = if radius.is_capped() {
            format!(
                "capped at {MAX_MERGE_RADIUS_PIXELS} pixel footprints; {} x scene radius would be {:.4e}",
                c.radius_factor, radius.from_scene
            )
        } else {
            format!("{} x scene radius", c.radius_factor)
        };
        let _ = writeln!(
            s,
            "merge radius:     r_1 = {:.4e} ({rule}; {:.2} pixel footprints), r_N = r_1 N^(({} - 1)/2)",
            radius.r1,
            radius.r1 / radius.pixel_footprint,
            c.radius_alpha
        );
    } else if c.algorithm == Algorithm::Vcm {
        let _ = writeln!(
            s,
            "merging:          left out: no near-specular or refractive surface, so connections sample every path well (VCM runs as BPT)"
        );
    }
}

/// The regularization mode, its schedule, and whether it changes anything.
fn regularization(s: &mut String, renderer: &Renderer) {
    let r = &renderer.config().regularization;
    let _ = write!(s, "regularization:   {}", r.mode);
    if r.mode != Mode::Off {
        let _ = write!(
            s,
            ", tau_0 = {} ({}), alpha_tau at N = 1: {:.4}",
            r.schedule.tau_0(),
            if r.progressive {
                "progressive: tau_N = tau(r_0 N^(-1/6))"
            } else {
                "fixed"
            },
            r.alpha_tau_at(1)
        );
        if r.mode == Mode::Unsampleable {
            let _ = write!(
                s,
                "\n                  unsampleable: regularizes camera subpaths only until their prefix has a bounded edge (connections) or vertex (merges), never light subpaths; path tracing uses the selective rule"
            );
        }
        if !renderer.regularization_matters(r.tau_at(1)) {
            let _ = write!(
                s,
                "\n                  inactive: no surface is sharper than alpha_tau (smallest alpha {}), so the render equals the unregularized one",
                renderer
                    .features()
                    .smallest_alpha
                    .map_or("none".into(), |a| a.to_string())
            );
        }
    }
    let _ = writeln!(s);
}

/// The scene's environment light and how it is sampled, if it has one;
/// `from_flag` when `--env` replaced the scene's own.
pub fn environment(renderer: &Renderer, from_flag: bool) -> Option<String> {
    let scene = renderer.scene();
    let light = scene.lights.iter().find(|l| l.is_environment())?;
    let origin = if from_flag {
        " (--env: replaces the scene's own environment)"
    } else {
        ""
    };
    Some(match *light {
        scene::Light::EnvironmentMap { map } => {
            let m = &scene.environment_maps[map as usize];
            let file = m
                .file
                .as_ref()
                .map_or_else(|| "an image".to_string(), |f| f.display().to_string());
            format!(
                "environment:      map {file}{origin}: {}x{} texels, scale {}, rotated {} degrees about +y; \
                 next-event estimation and light subpaths draw texels by luminance x solid angle \
                 (density proportional to the radiance), MIS with BSDF sampling; light subpaths enter \
                 through a disk covering the scene's bounding sphere",
                m.width, m.height, m.scale, m.rotation_degrees
            )
        }
        scene::Light::Environment { radiance } => format!(
            "environment:      constant radiance {radiance}{origin}, sampled uniformly over the sphere"
        ),
        _ => return None,
    })
}

/// The code paths the scene does not need, and a warning if it has no light.
fn left_out(s: &mut String, renderer: &Renderer) {
    let f = renderer.features();
    let _ = writeln!(
        s,
        "left out:         {}{}{}",
        if f.transmission {
            ""
        } else {
            "refraction code (no dielectric); "
        },
        if f.textured {
            ""
        } else {
            "texture lookups (no textures); "
        },
        if f.environment {
            ""
        } else {
            "environment lookups (no environment light)"
        },
    );
    if renderer.scene().lights.is_empty() {
        let _ = writeln!(
            s,
            "warning:          the scene has no light; the image will be black"
        );
    }
}

/// The techniques that reach the lights.
fn strategies(renderer: &Renderer) -> String {
    let c = renderer.config();
    if c.algorithm == Algorithm::Ppm {
        return "one light subpath per pixel (the photons); camera paths follow delta lobes and merge at their first non-specular vertex, no MIS (Hachisuka et al. 2008)".to_owned();
    }
    let Some(t) = renderer.techniques() else {
        return match c.strategies {
            Strategies::Mis => "next-event estimation + BSDF sampling, power-heuristic MIS",
            Strategies::NeeOnly => "next-event estimation only",
            Strategies::BsdfOnly => "BSDF sampling only",
        }
        .to_owned();
    };
    let mut list = Vec::new();
    if t.connections {
        list.push("emitter hits, next-event estimation, vertex connections, light tracing");
    }
    if t.merging {
        list.push("vertex merging");
    }
    if t.virtual_merges && renderer.regularization_matters(c.regularization.tau_at(1)) {
        list.push("virtual merges (supp. §6)");
    }
    format!(
        "one light subpath per pixel; {}; balance-heuristic VCM MIS",
        list.join(", ")
    )
}

/// The resolved settings, one line each with its value and origin.
pub fn settings(settings: &Settings) -> String {
    let c = &settings.config;
    let r = &c.regularization;
    let (budget, budget_value) = match settings.budget.value {
        Budget::Iterations(n) if settings.first_iteration > 1 => (
            "iterations",
            format!(
                "{}..{}",
                settings.first_iteration,
                settings.first_iteration + n - 1
            ),
        ),
        Budget::Iterations(n) => ("iterations", n.to_string()),
        Budget::Time(t) => ("time", format!("{} s", t.as_secs_f64())),
    };
    let on_off = |on: bool| if on { "on" } else { "off" }.to_owned();
    // Unless given, the integrator decides (on for vcm with regularization).
    let virtual_merges = c.virtual_merges.unwrap_or_else(|| c.uses_virtual_merges());
    let rows = [
        ("integrator", c.algorithm.to_string(), settings.algorithm),
        (budget, budget_value, settings.budget.origin),
        ("regularize", r.mode.to_string(), settings.mode),
        ("tau0", r.schedule.tau_0().to_string(), settings.tau0),
        (
            "progressive",
            if r.progressive { "yes" } else { "no" }.to_owned(),
            settings.progressive,
        ),
        (
            "energy",
            on_off(r.energy == Energy::Preserved),
            settings.energy,
        ),
        ("max depth", c.max_depth.to_string(), settings.max_depth),
        ("seed", c.seed.to_string(), settings.seed),
        ("radius", c.radius_factor.to_string(), settings.radius),
        (
            "shadow roulette",
            c.shadow_roulette.to_string(),
            settings.shadow_roulette,
        ),
        (
            "virtual merges",
            on_off(virtual_merges),
            settings.virtual_merges,
        ),
    ];
    let mut text = "settings:         value (origin: flag, manifest or default)\n".to_owned();
    for (name, value, origin) in rows {
        let _ = writeln!(text, "{:<18}{value} ({origin})", format!("{name}:"));
    }
    text
}

#[cfg(test)]
mod tests {
    use scene::RenderSettings;

    use super::*;
    use crate::cli::Cli;

    fn explain(args: &[&str], manifest: &RenderSettings) -> String {
        let cli = Cli::parse_test(args).unwrap();
        settings(&Settings::resolve(&cli, manifest, std::path::Path::new("scene.toml")).unwrap())
    }

    #[test]
    fn every_setting_shows_its_value_and_origin() {
        let manifest = RenderSettings {
            integrator: Some("vcm".into()),
            tau0: Some(30.0),
            radius: Some(0.01),
            shadow_roulette: Some(0.25),
            virtual_merges: Some(false),
            regularize_energy: Some(false),
            ..Default::default()
        };
        let text = explain(&["--iterations", "2", "--seed", "3"], &manifest);
        for line in [
            "integrator:       vcm (scene file)",
            "iterations:       2 (flag)",
            "regularize:       unsampleable (default)",
            "tau0:             30 (scene file)",
            "progressive:      yes (default)",
            "energy:           off (scene file)",
            "max depth:        12 (default)",
            "seed:             3 (flag)",
            "radius:           0.01 (scene file)",
            "shadow roulette:  0.25 (scene file)",
            "virtual merges:   off (scene file)",
        ] {
            assert!(
                text.contains(&format!("{line}\n")),
                "'{line}' missing from:\n{text}"
            );
        }
        assert_eq!(text.lines().count(), 12, "{text}");

        let flags = [
            "--radius",
            "0.5",
            "--shadow-roulette",
            "0",
            "--virtual-merges",
            "on",
        ];
        let text = explain(&flags, &manifest);
        for line in [
            "radius:           0.5 (flag)",
            "shadow roulette:  0 (flag)",
            "virtual merges:   on (flag)",
        ] {
            assert!(text.contains(line), "'{line}' missing from:\n{text}");
        }
    }

    #[test]
    fn default_virtual_merges_show_what_the_integrator_does() {
        let none = RenderSettings::default();
        for (args, expected) in [
            (&["--integrator", "vcm"][..], "on"),
            (&["--integrator", "vcm", "--regularize", "off"][..], "off"),
            (&["--integrator", "bpt"][..], "off"),
            (&[][..], "off"),
        ] {
            let text = explain(args, &none);
            let line = format!("virtual merges:   {expected} (default)\n");
            assert!(
                text.contains(&line),
                "{args:?}: '{line}' missing from:\n{text}"
            );
        }
        let text = explain(&["--time", "1.5", "--no-progressive"], &none);
        assert!(text.contains("time:             1.5 s (flag)\n"), "{text}");
        assert!(text.contains("progressive:      no (flag)\n"), "{text}");
    }
}
