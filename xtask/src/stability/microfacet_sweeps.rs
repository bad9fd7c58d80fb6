//! Sweeps through the `microfacet` crate: NDFs, their maxima, Smith Lambda
//! and G1, Fresnel, and the three lobes' eval / pdf / sample.

use std::time::Instant;

use glam::{Vec2, Vec3};
use microfacet::fresnel;
use microfacet::special;
use microfacet::{
    Bsdf, Coated, Conductor, Dielectric, Fresnel, Lambertian, MicrofacetModel, Ndf, NdfKind,
    Shadowing, ThinDielectric, TransportMode,
};
use rayon::prelude::*;

use super::reference;
use super::tally::{Row, Tally};
use super::{Budget, KINDS, alphas, direction, etas, log_space, signed_cosines, v};

/// Azimuths of query directions: the second is the mirror azimuth of the
/// first, so pairs include exact specular configurations (h = n).
const AZIMUTHS: [f64; 3] = [0.3, 0.3 + std::f64::consts::PI, 1.9];

/// Relative slack of the bound checks (D <= D_max, G1/cos <= sup): the
/// library evaluates in f32.
const BOUND_SLACK: f64 = 1e-5;

/// Largest allowed | |wo| - 1 | of a sampled direction.
const UNIT_TOLERANCE: f32 = 1e-3;

/// Every row of this module.
pub fn rows(budget: Budget) -> Vec<Row> {
    let mut rows = Vec::from(ndf_rows(budget));
    rows.extend(lambda_rows(budget));
    rows.push(special_row(budget));
    rows.push(fresnel_row(budget));
    rows.extend(bsdf_rows(budget));
    rows
}

fn ndf_label(kind: NdfKind, alpha: f32) -> String {
    format!("Ndf::new(NdfKind::{kind:?}, {alpha:?})")
}

/// `Ndf::d` against the f64 formula, and `d_max` / `d_max_bound` against
/// the table (and against the largest D seen on the grid).
fn ndf_rows(budget: Budget) -> [Row; 2] {
    let start = Instant::now();
    let mut d_row = Tally::default();
    let mut max_row = Tally::default();
    let alphas = alphas(budget.n(12, 60));
    let mut cos = log_space(1e-9, 1.0, budget.n(24, 200));
    cos.extend([0.0, -0.5, -1e-9]);
    for kind in KINDS {
        for &alpha in &alphas {
            let ndf = Ndf::new(kind, alpha);
            let a = f64::from(ndf.alpha());
            let label = || ndf_label(kind, alpha);
            let mut hs: Vec<Vec3> = cos.iter().map(|&c| direction(c, 0.7)).collect();
            // Beckmann's off-normal peak (supp. eq. 3), GGX's grazing one.
            let peak = 1.0 / (std::f64::consts::SQRT_2 * a);
            if peak < 1.0 {
                hs.push(direction(peak, 0.7));
            }
            let mut largest = 0.0f64;
            for h in hs {
                d_row.guard(
                    || format!("{}.d({})", label(), v(h)),
                    |t| {
                        t.evaluation();
                        let got = f64::from(ndf.d(h));
                        let what = || format!("{}.d({})", label(), v(h));
                        if t.value(got, what) {
                            largest = largest.max(got);
                        }
                        if h.z <= 0.0 {
                            t.require(got == 0.0, || format!("{} = {got:e}, not 0", what()));
                        } else {
                            let case = format!("{kind:?}");
                            t.compare_in(&case, got, reference::d(kind, a, h.as_dvec3()), what);
                        }
                    },
                );
            }
            max_row.guard(
                || format!("{}.d_max()", label()),
                |t| {
                    t.evaluations(2);
                    let d_max = f64::from(ndf.d_max());
                    let bound = f64::from(ndf.d_max_bound());
                    t.value(d_max, || format!("{}.d_max()", label()));
                    t.value(bound, || format!("{}.d_max_bound()", label()));
                    t.compare(d_max, reference::d_max(kind, a), || {
                        format!("{}.d_max()", label())
                    });
                    t.require(d_max > 0.0, || format!("{}.d_max() = {d_max:e}", label()));
                    t.require(bound >= d_max * (1.0 - 1e-6), || {
                        format!("{}: d_max_bound {bound:e} < d_max {d_max:e}", label())
                    });
                    t.require(largest <= d_max * (1.0 + BOUND_SLACK), || {
                        format!("{}: D reaches {largest:e} > d_max {d_max:e}", label())
                    });
                },
            );
        }
    }
    let seconds = start.elapsed().as_secs_f64();
    [
        Row {
            name: "microfacet: Ndf::d".into(),
            covers: format!(
                "D(h) for GGX, Beckmann, Blinn-Phong; alpha {} values 1e-8..10 (with 1e-7, 1e-4, 0.01, 1/sqrt2, 1); \
                 h.z {} values 1e-9..1 log-spaced, Beckmann's off-normal peak, and h.z = 0, -1e-9, -0.5 (must give 0)",
                alphas.len(),
                cos.len() - 3
            ),
            other: "D != 0 for h.z <= 0",
            reference: Some("f64 D of SPEC §1 (all three NDFs), same h"),
            tally: d_row,
            seconds,
        },
        Row {
            name: "microfacet: Ndf::d_max, d_max_bound".into(),
            covers: "the D rows' NDFs and alphas".into(),
            other: "d_max <= 0, d_max_bound < d_max, or D(h) on the grid above d_max (1e-5 rel.)",
            reference: Some("f64 D_max of the SPEC §1 table (GGX alpha > 1: alpha^2/pi)"),
            tally: max_row,
            seconds: 0.0,
        },
    ]
}

/// `Ndf::lambda` and `Ndf::g1` against f64 Lambda (GGX, Beckmann;
/// Blinn-Phong below 0.01 and at 1), plus the G1/cos supremum bound.
fn lambda_rows(budget: Budget) -> [Row; 2] {
    let start = Instant::now();
    let mut lambda_row = Tally::default();
    let mut g1_row = Tally::default();
    let alphas = alphas(budget.n(12, 60));
    let cos = signed_cosines(budget.n(24, 200));
    for kind in KINDS {
        for &alpha in &alphas {
            let ndf = Ndf::new(kind, alpha);
            let label = || ndf_label(kind, alpha);
            let sup = g1_row
                .guard(
                    || format!("{}.g1_over_cos_sup()", label()),
                    |t| {
                        t.evaluations(2);
                        let limit = f64::from(ndf.g1_over_cos_limit());
                        let sup = f64::from(ndf.g1_over_cos_sup());
                        t.value(limit, || format!("{}.g1_over_cos_limit()", label()));
                        t.value(sup, || format!("{}.g1_over_cos_sup()", label()));
                        sup
                    },
                )
                .unwrap_or(f64::INFINITY);
            for &c in &cos {
                let w = direction(c, 0.7);
                if c != 0.0 {
                    lambda_row.guard(
                        || format!("{}.lambda({})", label(), v(w)),
                        |t| {
                            t.evaluation();
                            let got = f64::from(ndf.lambda(w));
                            let what = || format!("{}.lambda({})", label(), v(w));
                            t.value(got, what);
                            if let Some(r) = reference::lambda(kind, ndf.alpha(), w.as_dvec3()) {
                                t.compare_in(&format!("{kind:?}"), got, r, what);
                            }
                        },
                    );
                }
                g1_row.guard(
                    || format!("{}.g1({})", label(), v(w)),
                    |t| {
                        t.evaluation();
                        let got = f64::from(ndf.g1(w));
                        let what = || format!("{}.g1({})", label(), v(w));
                        t.value(got, what);
                        t.require(got <= 1.0, || format!("{} = {got:e} > 1", what()));
                        if c == 0.0 {
                            t.require(got == 0.0, || format!("{} = {got:e}, not 0", what()));
                        } else {
                            let ratio = got / f64::from(w.z).abs();
                            t.require(ratio <= sup * (1.0 + BOUND_SLACK), || {
                                format!(
                                    "{}: G1/|cos| = {ratio:e} > g1_over_cos_sup {sup:e}",
                                    what()
                                )
                            });
                            if let Some(r) = reference::lambda(kind, ndf.alpha(), w.as_dvec3()) {
                                t.compare_in(&format!("{kind:?}"), got, 1.0 / (1.0 + r), what);
                            }
                        }
                    },
                );
            }
        }
    }
    let seconds = start.elapsed().as_secs_f64();
    let domain = format!(
        "GGX, Beckmann, Blinn-Phong; alpha {} values 1e-8..10; w.z = +-({} values 1e-9..1)",
        alphas.len(),
        cos.len() / 2
    );
    [
        Row {
            name: "microfacet: Ndf::lambda".into(),
            covers: domain.clone(),
            other: "-",
            reference: Some(
                "f64 Smith Lambda: GGX closed form, Beckmann with our own erfc (series / continued fraction); \
                 Blinn-Phong only below alpha 0.01 (Beckmann's, as documented) and at alpha 1 (closed form)",
            ),
            tally: lambda_row,
            seconds,
        },
        Row {
            name: "microfacet: Ndf::g1, g1_over_cos_sup".into(),
            covers: format!("{domain}, plus w.z = 0 (must give 0)"),
            other: "G1 > 1, G1 != 0 at w.z = 0, or G1/|cos| above g1_over_cos_sup (1e-5 rel.)",
            reference: Some("1/(1 + Lambda) with the f64 Lambda above"),
            tally: g1_row,
            seconds: 0.0,
        },
    ]
}

/// `special::erfc` / `erf` (Beckmann's Lambda and sampler run on them)
/// against our f64 erfc.
fn special_row(budget: Budget) -> Row {
    let start = Instant::now();
    let mut t = Tally::default();
    let mut xs = log_space(1e-12, 30.0, budget.n(200, 2000));
    xs.extend(xs.clone().iter().map(|x| -x));
    xs.push(0.0);
    for &x in &xs {
        t.guard(
            || format!("special::erfc({x:?})"),
            |t| {
                t.evaluations(2);
                let got = special::erfc(x);
                t.value(got, || format!("special::erfc({x:?})"));
                t.compare(got, reference::erfc(x), || format!("special::erfc({x:?})"));
                let erf = special::erf(x);
                t.finite(erf, || format!("special::erf({x:?})"));
                t.require(erf.abs() <= 1.0, || {
                    format!("special::erf({x:?}) = {erf:e}")
                });
            },
        );
    }
    Row {
        name: "microfacet: special::erfc, erf".into(),
        covers: format!("x = +-({} values 1e-12..30) and 0", xs.len() / 2),
        other: "|erf| > 1 (erf may be negative)",
        reference: Some("our f64 erfc (positive-term series below 3, continued fraction above)"),
        tally: t,
        seconds: start.elapsed().as_secs_f64(),
    }
}

/// Dielectric Fresnel against f64, conductor and Schlick Fresnel in [0, 1].
fn fresnel_row(budget: Budget) -> Row {
    let start = Instant::now();
    let mut t = Tally::default();
    let cos = signed_cosines(budget.n(40, 400));
    let mut eta_list = etas(budget.n(12, 60));
    eta_list.push(1.0);
    for &eta in &eta_list {
        for &c in &cos {
            let c = c as f32;
            t.guard(
                || format!("fresnel::dielectric({c:?}, {eta:?})"),
                |t| {
                    t.evaluation();
                    let got = f64::from(fresnel::dielectric(c, eta));
                    let what = || format!("fresnel::dielectric({c:?}, {eta:?})");
                    t.value(got, what);
                    t.require(got <= 1.0, || format!("{} = {got:e} > 1", what()));
                    let reference = reference::fresnel_dielectric(f64::from(c), f64::from(eta));
                    // Total internal reflection (F = 1) where the exact value is far from it.
                    if got == 1.0 && c != 0.0 && reference < 0.5 {
                        t.note(format!(
                            "F = 1 where the exact value is below 0.5, eta {eta:?}"
                        ));
                    }
                    t.require(!(got == 1.0 && c != 0.0 && reference < 0.5), || {
                        format!(
                            "{} = 1 (total internal reflection), exact value {reference:e}",
                            what()
                        )
                    });
                    t.compare_in(eta_case(eta), got, reference, what);
                },
            );
        }
    }
    let conductor_etas = log_space(0.05, 10.0, budget.n(5, 12));
    let ks = [0.0, 1e-3, 1.0, 10.0];
    for &eta in &conductor_etas {
        for k in ks {
            for &c in &cos {
                let (c, eta3, k3) = (c as f32, Vec3::splat(eta as f32), Vec3::splat(k));
                t.guard(
                    || format!("fresnel::conductor({c:?}, {}, {})", v(eta3), v(k3)),
                    |t| {
                        t.evaluations(2);
                        let what = || format!("fresnel::conductor({c:?}, {}, {})", v(eta3), v(k3));
                        let f = fresnel::conductor(c, eta3, k3);
                        t.values(f.to_array(), what);
                        t.require(f.max_element() <= 1.0, || format!("{} = {f} > 1", what()));
                        let s = fresnel::schlick(c, Vec3::splat(k.min(1.0)));
                        t.values(s.to_array(), || format!("fresnel::schlick({c:?}, {k:?})"));
                    },
                );
            }
        }
    }
    Row {
        name: "microfacet: fresnel".into(),
        covers: format!(
            "dielectric: cos = +-({} values 1e-9..1) and 0, eta 1, 1 + (1e-7..9), 1.5 and inverses ({} values); \
             conductor: eta 0.05..10 x k 0..10; Schlick F0 0..1",
            cos.len() / 2,
            eta_list.len()
        ),
        other: "F > 1, or dielectric F = 1 (total internal reflection) where the exact value is below 0.5",
        reference: Some("f64 exact dielectric Fresnel (dielectric only)"),
        tally: t,
        seconds: start.elapsed().as_secs_f64(),
    }
}

/// Errors are reported by how close an interface is to index-matched: its
/// Fresnel reflectance is a difference of nearly equal f32 terms there, and
/// the generalized half vector of refraction wi + eta wo nearly cancels.
fn eta_case(eta: f32) -> &'static str {
    let d = (eta - 1.0).abs();
    if d == 0.0 {
        "eta = 1"
    } else if d < 1e-5 {
        "0 < |eta - 1| < 1e-5"
    } else if d < 1e-3 {
        "1e-5 <= |eta - 1| < 1e-3"
    } else {
        "|eta - 1| >= 1e-3"
    }
}

/// The case a lobe's errors are reported under: its type, the eta class of
/// a dielectric and whether alpha is near the delta threshold.
fn lobe_case(bsdf: &Bsdf) -> String {
    let alpha = match bsdf.alpha() {
        Some(a) if a < 1e-3 => ", alpha < 1e-3",
        Some(_) => ", alpha >= 1e-3",
        None => "",
    };
    match bsdf {
        Bsdf::Lambertian(_) => "Lambertian".into(),
        Bsdf::Conductor(_) => format!("conductor{alpha}"),
        Bsdf::Dielectric(d) => format!("dielectric {}{alpha}", eta_case(d.eta)),
        Bsdf::Coated(_) => format!("coated{alpha}"),
        Bsdf::ThinDielectric(t) => format!("thin dielectric {}", eta_case(t.eta)),
    }
}

/// What the f64 reference of a lobe is, where there is one.
#[derive(Clone, Copy)]
enum LobeReference {
    None,
    /// GGX-Smith conductor with Schlick F0 (one value for all channels).
    Conductor {
        alpha: f64,
        f0: f64,
    },
    /// GGX-Smith dielectric.
    Dielectric {
        alpha: f64,
        eta: f64,
    },
}

/// One BSDF of the sweep, its reproduction and its reference.
struct Lobe {
    bsdf: Bsdf,
    repro: String,
    reference: LobeReference,
}

fn model_repro(kind: NdfKind, alpha: f32, shadowing: Shadowing) -> String {
    format!("MicrofacetModel::new(NdfKind::{kind:?}, {alpha:?}, Shadowing::{shadowing:?})")
}

fn lobes(alphas: &[f32], etas: &[f32]) -> Vec<Lobe> {
    let mut out = vec![Lobe {
        bsdf: Bsdf::Lambertian(Lambertian {
            reflectance: Vec3::new(0.9, 0.5, 0.0),
        }),
        repro: "Bsdf::Lambertian(Lambertian { reflectance: Vec3::new(0.9, 0.5, 0.0) })".into(),
        reference: LobeReference::None,
    }];
    out.extend(etas.iter().map(|&eta| Lobe {
        bsdf: Bsdf::ThinDielectric(ThinDielectric::new(eta)),
        repro: format!("Bsdf::ThinDielectric(ThinDielectric::new({eta:?}))"),
        reference: LobeReference::None,
    }));
    let gold = Fresnel::Conductor {
        eta: Vec3::new(0.2, 0.9, 1.1),
        k: Vec3::new(3.0, 2.5, 2.0),
        tint: Vec3::ONE,
    };
    let schlick = Fresnel::Schlick {
        f0: Vec3::splat(0.9),
    };
    for kind in KINDS {
        for shadowing in [Shadowing::Smith, Shadowing::VCavity] {
            for &alpha in alphas {
                let model = MicrofacetModel::new(kind, alpha, shadowing);
                let m = model_repro(kind, alpha, shadowing);
                let rough_ggx_smith =
                    kind == NdfKind::Ggx && shadowing == Shadowing::Smith && !model.is_smooth();
                let a = f64::from(model.alpha());
                for (fresnel, name) in [(schlick, "schlick"), (gold, "gold")] {
                    let f = match name {
                        "schlick" => "Fresnel::Schlick { f0: Vec3::splat(0.9) }",
                        _ => {
                            "Fresnel::Conductor { eta: Vec3::new(0.2, 0.9, 1.1), k: Vec3::new(3.0, 2.5, 2.0), tint: Vec3::ONE }"
                        }
                    };
                    out.push(Lobe {
                        bsdf: Bsdf::Conductor(Conductor { model, fresnel }),
                        repro: format!("Bsdf::Conductor(Conductor {{ model: {m}, fresnel: {f} }})"),
                        reference: if rough_ggx_smith && name == "schlick" {
                            LobeReference::Conductor { alpha: a, f0: 0.9 }
                        } else {
                            LobeReference::None
                        },
                    });
                }
                out.extend(coated_lobes(model, &m));
                for &eta in etas {
                    let d = Dielectric::new(model, eta);
                    out.push(Lobe {
                        bsdf: Bsdf::Dielectric(d),
                        repro: format!("Bsdf::Dielectric(Dielectric::new({m}, {eta:?}))"),
                        reference: if rough_ggx_smith && !d.is_specular() {
                            LobeReference::Dielectric {
                                alpha: a,
                                eta: f64::from(eta),
                            }
                        } else {
                            LobeReference::None
                        },
                    });
                }
            }
        }
    }
    out
}

/// The glTF metallic-roughness lobes of one model: a plastic; a half metal
/// whose coat has `KHR_materials_ior`'s special 0 (F0 = 1), weakened by a
/// specular factor; and a coat that reflects everything (specular 1, ior 0:
/// no diffuse part left, a delta when smooth).
fn coated_lobes(model: MicrofacetModel, m: &str) -> Vec<Lobe> {
    [
        (Vec3::new(0.8, 0.5, 0.2), 0.0, 1.0, 1.5),
        (Vec3::new(0.3, 0.6, 0.9), 0.5, 0.6, 0.0),
        (Vec3::splat(0.5), 0.0, 1.0, 0.0),
    ]
    .into_iter()
    .map(|(base_color, metallic, specular, ior)| Lobe {
        bsdf: Bsdf::Coated(Coated {
            model,
            base_color,
            metallic,
            specular,
            specular_color: Vec3::ONE,
            ior,
        }),
        repro: format!(
            "Bsdf::Coated(Coated {{ model: {m}, base_color: Vec3::new({:?}, {:?}, {:?}), metallic: {metallic:?}, specular: {specular:?}, specular_color: Vec3::ONE, ior: {ior:?} }})",
            base_color.x, base_color.y, base_color.z
        ),
        reference: LobeReference::None,
    })
    .collect()
}

fn modes(bsdf: &Bsdf) -> &'static [TransportMode] {
    match bsdf {
        Bsdf::Dielectric(_) => &[TransportMode::Radiance, TransportMode::Importance],
        // The mode only matters for refraction.
        Bsdf::Conductor(_) | Bsdf::Lambertian(_) | Bsdf::Coated(_) | Bsdf::ThinDielectric(_) => {
            &[TransportMode::Radiance]
        }
    }
}

/// eval, pdf and sample of one lobe over all direction pairs and uniforms.
fn sweep_lobe(lobe: &Lobe, dirs: &[Vec3], uniforms: &[f32], ucs: &[f32]) -> [Tally; 3] {
    let [mut eval, mut pdf, mut sample] = [Tally::default(), Tally::default(), Tally::default()];
    let bsdf = lobe.bsdf;
    let r = &lobe.repro;
    let case = lobe_case(&bsdf);
    for &mode in modes(&bsdf) {
        for &wi in dirs {
            for &wo in dirs {
                let call =
                    |f: &str| format!("{r}.{f}({}, {}, TransportMode::{mode:?})", v(wi), v(wo));
                let reference = lobe_reference(lobe, wi, wo, mode);
                eval.guard(
                    || call("eval"),
                    |t| check_eval(t, &bsdf, (wi, wo, mode), reference, &case, &call),
                );
                if mode == TransportMode::Importance {
                    continue; // pdf does not depend on the mode
                }
                pdf.guard(
                    || call("pdf"),
                    |t| check_pdf(t, &bsdf, (wi, wo), reference, &case, &call),
                );
            }
            for &u1 in uniforms {
                for &u2 in uniforms {
                    for &uc in ucs {
                        let u = Vec2::new(u1, u2);
                        let call = || {
                            format!(
                                "{r}.sample({}, {uc:?}, Vec2::new({u1:?}, {u2:?}), TransportMode::{mode:?})",
                                v(wi)
                            )
                        };
                        sample.guard(call, |t| {
                            check_sample(t, &bsdf, (wi, uc, u, mode), &case, &call);
                        });
                    }
                }
            }
        }
    }
    [eval, pdf, sample]
}

/// The lobe's f64 reference (f, pdf) at (wi, wo), where it has one.
fn lobe_reference(lobe: &Lobe, wi: Vec3, wo: Vec3, mode: TransportMode) -> Option<(f64, f64)> {
    match lobe.reference {
        LobeReference::None => None,
        LobeReference::Conductor { alpha, f0 } => Some(reference::conductor_ggx(
            alpha,
            f0,
            wi.as_dvec3(),
            wo.as_dvec3(),
        )),
        LobeReference::Dielectric { alpha, eta } => Some(reference::dielectric_ggx(
            alpha,
            eta,
            wi.as_dvec3(),
            wo.as_dvec3(),
            mode == TransportMode::Importance,
        )),
    }
}

/// `eval` at (wi, wo): finite, non-negative, zero for a delta lobe, and
/// against the reference.
fn check_eval(
    t: &mut Tally,
    bsdf: &Bsdf,
    (wi, wo, mode): (Vec3, Vec3, TransportMode),
    reference: Option<(f64, f64)>,
    case: &str,
    call: &dyn Fn(&str) -> String,
) {
    t.evaluation();
    let f = bsdf.eval(wi, wo, mode);
    t.values(f.to_array(), || call("eval"));
    if bsdf.is_specular() {
        t.require(f == Vec3::ZERO, || {
            format!("{} = {f} for a delta lobe", call("eval"))
        });
    }
    if let Some((f_ref, _)) = reference
        && f_ref <= f64::from(f32::MAX)
    {
        t.compare_in(case, f64::from(f.x), f_ref, || call("eval"));
    }
}

/// `pdf` and `pdf_reverse` at (wi, wo): finite, non-negative, zero for a
/// delta lobe, and against the reference.
fn check_pdf(
    t: &mut Tally,
    bsdf: &Bsdf,
    (wi, wo): (Vec3, Vec3),
    reference: Option<(f64, f64)>,
    case: &str,
    call: &dyn Fn(&str) -> String,
) {
    t.evaluations(2);
    let p = f64::from(bsdf.pdf(wi, wo));
    let q = f64::from(bsdf.pdf_reverse(wi, wo));
    t.value(p, || call("pdf"));
    t.value(q, || call("pdf_reverse"));
    if bsdf.is_specular() {
        t.require(p == 0.0, || {
            format!("{} = {p:e} for a delta lobe", call("pdf"))
        });
    }
    if let Some((_, p_ref)) = reference
        && p_ref <= f64::from(f32::MAX)
    {
        t.compare_in(case, p, p_ref, || call("pdf"));
    }
}

/// Below this min(|cos wi|, |cos wo|) a sample is grazing: its consistency
/// with eval and pdf is tallied in a case of its own (f32 cosines lose
/// digits there).
const GRAZING_COS: f32 = 1e-3;

/// One `sample`: finite fields, a positive pdf and eta, a unit direction,
/// and (non-delta) the value and density eval and pdf give at its wo.
fn check_sample(
    t: &mut Tally,
    bsdf: &Bsdf,
    (wi, uc, u, mode): (Vec3, f32, Vec2, TransportMode),
    case: &str,
    call: &dyn Fn() -> String,
) {
    t.evaluation();
    let Some(s) = bsdf.sample(wi, uc, u, mode) else {
        t.note("None");
        return;
    };
    t.note(if s.is_specular {
        "Some (delta)"
    } else {
        "Some"
    });
    let field = |name: &str| format!("{}.{name}", call());
    t.values(s.f.to_array(), || field("f"));
    let ok = t.value(f64::from(s.pdf), || field("pdf"));
    t.value(f64::from(s.pdf_reverse), || field("pdf_reverse"));
    t.value(f64::from(s.eta), || field("eta"));
    t.require(ok && s.pdf > 0.0, || {
        format!(
            "{} = {:e}: a returned sample with pdf 0",
            field("pdf"),
            s.pdf
        )
    });
    t.require(s.eta > 0.0, || format!("{} = {}", field("eta"), s.eta));
    let len = s.wo.length();
    t.require((len - 1.0).abs() <= UNIT_TOLERANCE, || {
        format!("{} = {} has length {len}", field("wo"), v(s.wo))
    });
    if s.is_specular {
        return;
    }
    // Consistency: the same value and density from eval / pdf at wo.
    let f = bsdf.eval(wi, s.wo, mode);
    let p = bsdf.pdf(wi, s.wo);
    let grazing = if wi.z.abs().min(s.wo.z.abs()) < GRAZING_COS {
        format!("grazing (min |cos| < {GRAZING_COS:e})")
    } else {
        format!("min |cos| >= {GRAZING_COS:e}")
    };
    let case = format!("{case}, {grazing}");
    if p == 0.0 {
        t.note(format!("non-delta sample where pdf(wi, wo) = 0: {case}"));
    }
    t.compare_in(
        &case,
        f64::from(s.f.max_element()),
        f64::from(f.max_element()),
        || format!("{}.f vs eval at wo = {}: {f}", call(), v(s.wo)),
    );
    t.compare_in(&case, f64::from(s.pdf), f64::from(p), || {
        format!("{}.pdf vs pdf at wo = {}", call(), v(s.wo))
    });
}

/// `Bsdf::eval`, `Bsdf::pdf` (+ `pdf_reverse`) and `Bsdf::sample` for every
/// lobe, in parallel over lobes.
fn bsdf_rows(budget: Budget) -> [Row; 3] {
    let start = Instant::now();
    let alphas = alphas(budget.n(6, 16));
    let mut eta_list = etas(budget.n(3, 6));
    eta_list.push(1.0);
    let lobes = lobes(&alphas, &eta_list);
    let cos = signed_cosines(budget.n(8, 14));
    let azimuths = &AZIMUTHS[..budget.n(2, 3)];
    let dirs: Vec<Vec3> = cos
        .iter()
        .flat_map(|&c| azimuths.iter().map(move |&phi| direction(c, phi)))
        .collect();
    let uniforms: Vec<f32> = if budget.quick {
        vec![0.0, 0.37, 1.0 - f32::EPSILON / 2.0]
    } else {
        vec![0.0, 1e-7, 0.13, 0.5, 0.77, 1.0 - f32::EPSILON / 2.0]
    };
    let ucs = [0.0, 0.5, 1.0 - f32::EPSILON / 2.0];
    let [eval, pdf, sample] = lobes
        .par_iter()
        .map(|lobe| sweep_lobe(lobe, &dirs, &uniforms, &ucs))
        .reduce(
            || [Tally::default(), Tally::default(), Tally::default()],
            |[mut a, mut b, mut c], [x, y, z]| {
                a.merge(x);
                b.merge(y);
                c.merge(z);
                [a, b, c]
            },
        );
    let seconds = start.elapsed().as_secs_f64();
    let domain = format!(
        "{} lobes: Lambertian; conductor (Schlick 0.9, complex gold-like), coated (plastic, half metal with ior 0, full-reflecting coat) and dielectric (eta 1, 1 + (1e-7..9), 1.5 and inverses: {} values) \
         x GGX/Beckmann/Blinn-Phong x Smith/V-cavity x alpha {} values 1e-8..10 (with 1e-4 +- 1 ulp, 0.01, 1/sqrt2, 1); \
         directions: cos = +-({} values 1e-9..1) and 0 at {} azimuths (incl. the mirror azimuth), both hemispheres",
        lobes.len(),
        eta_list.len(),
        alphas.len(),
        cos.len() / 2,
        azimuths.len()
    );
    [
        Row {
            name: "microfacet: Bsdf::eval".into(),
            covers: format!("{domain}; every (wi, wo) pair; Radiance and Importance (dielectric)"),
            other: "non-zero value of a delta lobe",
            reference: Some(
                "f64 GGX-Smith conductor (Schlick) and dielectric (Walter, both modes), rough lobes, where the reference fits f32",
            ),
            tally: eval,
            seconds,
        },
        Row {
            name: "microfacet: Bsdf::pdf, pdf_reverse".into(),
            covers: format!("{domain}; every (wi, wo) pair"),
            other: "non-zero pdf of a delta lobe",
            reference: Some(
                "f64 GGX-Smith visible-normal pdfs (x F / x (1 - F) for the dielectric)",
            ),
            tally: pdf,
            seconds: 0.0,
        },
        Row {
            name: "microfacet: Bsdf::sample".into(),
            covers: format!(
                "{domain}; every wi x u in {{{}}}^2 x uc in {{0, 0.5, 1-2^-24}}; both modes (dielectric)",
                uniforms
                    .iter()
                    .map(|u| format!("{u:?}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
            other: "returned sample with pdf 0 or eta <= 0, or | |wo| - 1 | > 1e-3",
            reference: Some(
                "consistency: Bsdf::eval and Bsdf::pdf at the sampled wo (non-delta samples; both f32)",
            ),
            tally: sample,
            seconds: 0.0,
        },
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lobe_list_has_references_only_for_rough_ggx_smith() {
        let lobes = lobes(&[1e-5, 0.3], &[1.5, 1.0]);
        // Lambertian + a thin sheet per eta + 3 kinds x 2 shadowing x 2 alphas
        // x (2 conductors + 3 coated + 2 dielectrics).
        assert_eq!(lobes.len(), 1 + 2 + 3 * 2 * 2 * 7);
        let with_reference: Vec<&str> = lobes
            .iter()
            .filter(|l| !matches!(l.reference, LobeReference::None))
            .map(|l| l.repro.as_str())
            .collect();
        // alpha 0.3 only (1e-5 is a delta), Schlick conductor and eta 1.5 (eta 1 is a delta).
        assert_eq!(with_reference.len(), 2, "{with_reference:?}");
        assert!(
            with_reference
                .iter()
                .all(|r| r.contains("Ggx, 0.3, Shadowing::Smith"))
        );
    }

    #[test]
    fn reference_lobes_agree_with_the_library_at_a_plain_configuration() {
        let wi = Vec3::new(0.3, 0.1, 0.9).normalize();
        let wo = Vec3::new(-0.2, 0.05, 0.95).normalize();
        let model = MicrofacetModel::new(NdfKind::Ggx, 0.3, Shadowing::Smith);
        let c = Conductor {
            model,
            fresnel: Fresnel::Schlick {
                f0: Vec3::splat(0.9),
            },
        };
        let (f, p) = reference::conductor_ggx(0.3, 0.9, wi.as_dvec3(), wo.as_dvec3());
        assert!((f64::from(c.eval(wi, wo).x) / f - 1.0).abs() < 1e-5);
        assert!((f64::from(c.pdf(wi, wo)) / p - 1.0).abs() < 1e-5);
        let d = Dielectric::new(model, 1.5);
        let wt = Vec3::new(-0.2, 0.05, -0.95).normalize();
        for mode in [TransportMode::Radiance, TransportMode::Importance] {
            let (f, p) = reference::dielectric_ggx(
                0.3,
                1.5,
                wi.as_dvec3(),
                wt.as_dvec3(),
                mode == TransportMode::Importance,
            );
            assert!((f64::from(d.eval(wi, wt, mode).x) / f - 1.0).abs() < 1e-5);
            assert!((f64::from(d.pdf(wi, wt)) / p - 1.0).abs() < 1e-5);
        }
        // And a direction built from the grid is unit length.
        let w = direction(1e-9, 0.3).as_dvec3();
        assert!((w.length() - 1.0).abs() < 1e-7);
    }
}
