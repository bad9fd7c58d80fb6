//! `--explain`: what the renderer will do with a scene and why, in prose.
//! Presentation only: every number comes from the `integrators` crate.

use std::fmt::Write as _;

use integrators::merge_radius::MAX_MERGE_RADIUS_PIXELS;
use integrators::{Algorithm, Mode, ROULETTE_DEPTH, Renderer, Strategies};

/// A human-readable account of the integrator, its techniques, the shadow
/// roulette, the merge radius and the regularization of `renderer`.
pub fn integrator(renderer: &Renderer) -> String {
    let c = renderer.config();
    let f = renderer.features();
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
    if renderer.techniques().is_some_and(|t| t.merging) {
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
    let r = &c.regularization;
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
        if !renderer.regularization_matters(r.tau_at(1)) {
            let _ = write!(
                s,
                "\n                  inactive: no surface is sharper than alpha_tau (smallest alpha {}), so the render equals the unregularized one",
                f.smallest_alpha.map_or("none".into(), |a| a.to_string())
            );
        }
    }
    let _ = writeln!(s);
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
    s
}

/// The techniques that reach the lights.
fn strategies(renderer: &Renderer) -> String {
    let c = renderer.config();
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
