//! Numerical edges: near-index-matched dielectrics (sample/pdf agreement),
//! extreme uniforms in GGX refraction, and Fresnel near the critical angle
//! against an f64 reference.

use crate::common;

use common::*;
use microfacet::{Dielectric, MicrofacetModel, TransportMode};
use stats::Pcg32;

/// |a - b| within `rel` of the larger.
fn close(a: f32, b: f32, rel: f32) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs())
}

/// For eta within 1e-7..1e-2 of 1 on both sides, every sample either is a
/// delta that `eval` and `pdf` report as 0 (and the lobe says it is
/// specular), or has pdf, reverse pdf and value equal to what `pdf` and
/// `eval` give for the same pair (SPEC §3, §5 index-matched rule).
#[test]
fn near_index_matched_samples_agree_with_pdf_and_eval() {
    let mut rng = Pcg32::new(19, 1);
    let mut failures = Vec::new();
    let mut checked = 0usize;
    let mut summary = Vec::new();
    for offset in [1e-7f32, 1e-6, 1e-5, 1e-4, 1e-3, 1e-2] {
        for eta in [1.0 + offset, 1.0 - offset] {
            let before = failures.len();
            let mut worst = 0.0f32;
            for kind in NDFS {
                for shadowing in SHADOWINGS {
                    for alpha in [0.01f32, 0.1, 0.5] {
                        let model = MicrofacetModel::new(kind, alpha, shadowing);
                        let d = Dielectric::new(model, eta);
                        for k in 0..400 {
                            let cos = [0.999, 0.7, 0.3, 0.05][k % 4];
                            let side = if k % 8 < 4 { 1.0 } else { -1.0 };
                            let wi =
                                direction(cos, std::f32::consts::TAU * rng.uniform_f32()) * side;
                            let mode = if k % 2 == 0 {
                                TransportMode::Radiance
                            } else {
                                TransportMode::Importance
                            };
                            let (uc, u) = (rng.uniform_f32(), rng.uniform_vec2());
                            let Some(s) = d.sample(wi, uc, u, mode) else {
                                continue;
                            };
                            checked += 1;
                            let (p, r, f) =
                                (d.pdf(wi, s.wo), d.pdf(s.wo, wi), d.eval(wi, s.wo, mode).x);
                            let good = if s.is_specular {
                                d.is_specular() && p == 0.0 && r == 0.0 && f == 0.0
                            } else {
                                !d.is_specular()
                                    && close(s.pdf, p, 1e-3)
                                    && close(s.pdf_reverse, r, 1e-3)
                                    && close(s.f.x, f, 1e-3)
                            };
                            if !s.is_specular && !d.is_specular() {
                                worst = worst.max((s.pdf - p).abs() / s.pdf.max(p));
                            }
                            if !good {
                                failures.push(format!(
                                    "eta {eta} {kind:?}/{shadowing:?} alpha {alpha} wi {wi} u {uc} {u}: \
                                     sample pdf {} rev {} f {} specular {} | pdf {p} rev {r} eval {f}",
                                    s.pdf, s.pdf_reverse, s.f.x, s.is_specular
                                ));
                            }
                        }
                    }
                }
            }
            summary.push(format!(
                "eta {eta}: {} mismatches, worst pdf ratio error {worst:.2e}",
                failures.len() - before
            ));
        }
    }
    println!("{}", summary.join("\n"));
    assert!(checked > 10_000, "{checked}");
    let n = failures.len();
    failures.truncate(12);
    assert!(
        failures.is_empty(),
        "{n} mismatches of {checked}:\n{}\n{}",
        summary.join("\n"),
        failures.join("\n")
    );
}
