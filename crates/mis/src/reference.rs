//! An explicit, non-recursive evaluation of the MIS weights of every technique
//! that can produce a given path, from the path's per-vertex area pdfs. It is
//! the oracle the tests hold the recursion against; it allocates, and it is
//! slow (quadratic in the path length).
//!
//! # The path and its techniques
//!
//! Vertices x_0 (on the emitter) ... x_k (the camera), k >= 1. Per vertex,
//! p->(x_i) is its area pdf when the light sub-path samples it (from x_{i-1};
//! for x_0 the emission position pdf) and p<-(x_i) when the camera sub-path
//! samples it (from x_{i+1}). The camera vertex's own pdf is common to all
//! techniques and left out. For infinite emitters, "area" at x_0 means solid
//! angle; for delta emitters and specular vertices the delta factor is left out
//! (it is common to all techniques that can produce the path).
//!
//! With L_j = p->(x_0) ... p->(x_j) and C_j = p<-(x_j) ... p<-(x_{k-1}):
//!
//! | technique | path pdf q | exists when |
//! |---|---|---|
//! | emitter hit (s = 0) | C_0 | emitter hittable |
//! | next-event estimation (edge 0-1) | p_direct(x_0) C_1 | connections, k >= 2, x_1 non-specular |
//! | connection on edge i-(i+1), 1 <= i <= k-2 | L_i C_{i+1} | connections, x_i and x_{i+1} non-specular |
//! | light tracing (edge (k-1)-k) | N L_{k-1} | connections, k >= 2, x_{k-1} non-specular |
//! | merge at x_j, 1 <= j <= k-1 | eta_VCM L_j C_j | merging, x_j non-specular |
//! | virtual merge sampled at x_i towards x_{i+1} | q(edge i) a->(x_i) | virtual merges, edge i's connection exists, 1 <= i |
//! | virtual merge sampled at x_{i+1} towards x_i | q(edge i) a<-(x_{i+1}) | virtual merges, edge i's connection exists, i + 1 <= k - 1 |
//!
//! a->(x_i) and a<-(x_i) are the acceptance probabilities of virtual merges
//! sampled at x_i towards x_{i+1} and towards x_{i-1} (supp. eq. 14; 0 at a
//! vertex that is not regularized). The weight of technique T is
//! q_T^beta / sum_T' q_T'^beta (Veach's power heuristic over all techniques).
//! The sums are taken in log space, so the reference stays exact where the
//! products of pdfs leave the range of f64.

use crate::subpath::EmitterKind;
use crate::{MisConfig, MisError};

/// One vertex of a reference path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathVertex {
    /// p->(x_i): area pdf when the light sub-path samples the vertex (for the
    /// emitter vertex: the emission position pdf, or direction pdf for an
    /// infinite emitter). Ignored for the camera vertex.
    pub pdf_light: f64,
    /// p<-(x_i): area pdf when the camera sub-path samples the vertex.
    /// Ignored for the camera vertex, and for the emitter when it cannot be hit.
    pub pdf_camera: f64,
    /// The vertex is specular (delta): no connection, merge or virtual merge
    /// there. Ignored for the emitter and camera vertices.
    pub specular: bool,
    /// a->(x_i): acceptance of a virtual merge sampled at this vertex towards
    /// the next vertex (the camera side); 0 if the vertex is not regularized.
    pub accept_towards_camera: f64,
    /// a<-(x_i): acceptance of a virtual merge sampled at this vertex towards
    /// the previous vertex (the emitter side); 0 if the vertex is not
    /// regularized.
    pub accept_towards_light: f64,
}

/// A complete path for the reference.
#[derive(Clone, Debug, PartialEq)]
pub struct Path {
    /// The emitter at x_0.
    pub emitter: EmitterKind,
    /// p_direct(x_0): the pdf with which next-event estimation chooses x_0, in
    /// the measure of `vertices[0].pdf_light`.
    pub direct_pdf: f64,
    /// x_0 (emitter) ... x_k (camera).
    pub vertices: Vec<PathVertex>,
}

/// A sampling technique that can produce a path.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Technique {
    /// The camera sub-path hits the emitter (s = 0).
    EmitterHit,
    /// The connection on the edge (x_i, x_{i+1}), `light_vertex` = i, i.e.
    /// s = i + 1: next-event estimation for i = 0, light tracing for i = k - 1.
    Connection {
        /// The light sub-path's last vertex, i.
        light_vertex: usize,
    },
    /// Merging at x_j.
    Merge {
        /// j.
        vertex: usize,
    },
    /// A virtual merge on the edge (x_i, x_{i+1}).
    VirtualMerge {
        /// The edge's light-side vertex, i.
        light_vertex: usize,
        /// Sampled at x_{i+1} towards x_i (camera end) instead of at x_i
        /// towards x_{i+1} (light end).
        at_camera_end: bool,
    },
}

impl Technique {
    /// The technique an integrator executes to obtain this one's sample: a
    /// virtual merge is executed as the connection on its edge (see the crate
    /// documentation), every other technique as itself.
    pub fn executed_as(self) -> Technique {
        match self {
            Self::VirtualMerge { light_vertex, .. } => Self::Connection { light_vertex },
            other => other,
        }
    }
}

/// The weight of one technique for the path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TechniqueWeight {
    /// The technique.
    pub technique: Technique,
    /// Its MIS weight, in [0, 1].
    pub weight: f64,
}

/// The MIS weights of every technique that can produce `path` under
/// `config`, in the order emitter hit, connections and their virtual merges
/// by edge, merges by vertex. Techniques whose path pdf is 0 are listed with
/// weight 0; when no technique can produce the path all weights are 0.
///
/// # Errors
/// [`MisError::PathTooShort`] for fewer than 2 vertices,
/// [`MisError::InvalidPathValue`] for a negative, NaN or infinite pdf or
/// acceptance (or a negative, NaN or infinite `direct_pdf`, reported as
/// vertex 0).
pub fn weights(config: &MisConfig, path: &Path) -> Result<Vec<TechniqueWeight>, MisError> {
    let v = &path.vertices;
    if v.len() < 2 {
        return Err(MisError::PathTooShort);
    }
    let valid = |x: f64| x >= 0.0 && x.is_finite();
    if !valid(path.direct_pdf) {
        return Err(MisError::InvalidPathValue { vertex: 0 });
    }
    for (i, x) in v.iter().enumerate() {
        let fields = [
            x.pdf_light,
            x.pdf_camera,
            x.accept_towards_camera,
            x.accept_towards_light,
        ];
        if !fields.into_iter().all(valid) {
            return Err(MisError::InvalidPathValue { vertex: i });
        }
    }

    let k = v.len() - 1;
    let t = config.techniques();
    let ln = |x: f64| x.ln(); // ln 0 = -inf: the technique's pdf is 0.
    // ln L_j for j = 0..k-1 (emission-sampled x_0).
    let mut ln_l = vec![0.0; k];
    ln_l[0] = ln(v[0].pdf_light);
    for j in 1..k {
        ln_l[j] = ln_l[j - 1] + ln(v[j].pdf_light);
    }
    // ln C_j for j = 0..k (C_k = 1: the camera vertex).
    let mut ln_c = vec![0.0; k + 1];
    for j in (0..k).rev() {
        ln_c[j] = ln_c[j + 1] + ln(v[j].pdf_camera);
    }
    let connectable = |i: usize| i == 0 || i == k || !v[i].specular;

    let mut list: Vec<(Technique, f64)> = Vec::new();
    if path.emitter.is_hittable() {
        list.push((Technique::EmitterHit, ln_c[0]));
    }
    if t.connections {
        for i in 0..k {
            let ln_q = if i == 0 {
                if k < 2 {
                    continue; // light tracing of the emitter itself: not a technique
                }
                ln(path.direct_pdf) + ln_c[1]
            } else if i == k - 1 {
                config.light_paths().ln() + ln_l[k - 1]
            } else {
                ln_l[i] + ln_c[i + 1]
            };
            if !(connectable(i) && connectable(i + 1)) {
                continue;
            }
            list.push((Technique::Connection { light_vertex: i }, ln_q));
            if t.virtual_merges {
                if i >= 1 {
                    list.push((
                        Technique::VirtualMerge {
                            light_vertex: i,
                            at_camera_end: false,
                        },
                        ln_q + ln(v[i].accept_towards_camera),
                    ));
                }
                if i + 1 < k {
                    list.push((
                        Technique::VirtualMerge {
                            light_vertex: i,
                            at_camera_end: true,
                        },
                        ln_q + ln(v[i + 1].accept_towards_light),
                    ));
                }
            }
        }
    }
    if t.merging {
        let ln_eta = config.eta_vcm().ln();
        for j in 1..k {
            if connectable(j) {
                list.push((Technique::Merge { vertex: j }, ln_eta + ln_l[j] + ln_c[j]));
            }
        }
    }

    // Power heuristic in log space: w_T = exp(beta ln q_T - logsumexp).
    let beta = config.heuristic().beta();
    let max = list
        .iter()
        .map(|&(_, l)| beta * l)
        .fold(f64::NEG_INFINITY, f64::max);
    let weight_of = |ln_q: f64| {
        if max == f64::NEG_INFINITY || ln_q == f64::NEG_INFINITY {
            0.0
        } else {
            let sum: f64 = list.iter().map(|&(_, l)| (beta * l - max).exp()).sum();
            (beta * ln_q - max).exp() / sum
        }
    };
    Ok(list
        .iter()
        .map(|&(technique, ln_q)| TechniqueWeight {
            technique,
            weight: weight_of(ln_q),
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Heuristic;

    fn vertex(pdf_light: f64, pdf_camera: f64) -> PathVertex {
        PathVertex {
            pdf_light,
            pdf_camera,
            specular: false,
            accept_towards_camera: 0.0,
            accept_towards_light: 0.0,
        }
    }

    #[test]
    fn two_vertex_path_has_only_the_hit() {
        let c = MisConfig::vcm(10, 0.1, Heuristic::BALANCE).unwrap();
        let path = Path {
            emitter: EmitterKind::Area,
            direct_pdf: 1.0,
            vertices: vec![vertex(1.0, 2.0), vertex(1.0, 1.0)],
        };
        let w = weights(&c, &path).unwrap();
        assert_eq!(w.len(), 1);
        assert_eq!(w[0].technique, Technique::EmitterHit);
        assert_eq!(w[0].weight, 1.0);
    }

    #[test]
    fn three_vertex_bpt_by_hand() {
        // x0 (area light), x1, camera. q_hit = pc0 pc1, q_nee = pd pc1,
        // q_lt = N pe pl1.
        let c = MisConfig::bpt(3, Heuristic::BALANCE).unwrap();
        let path = Path {
            emitter: EmitterKind::Area,
            direct_pdf: 0.5,
            vertices: vec![vertex(0.25, 2.0), vertex(4.0, 3.0), vertex(1.0, 1.0)],
        };
        let w = weights(&c, &path).unwrap();
        let (hit, nee, lt) = (2.0 * 3.0, 0.5 * 3.0, 3.0 * 0.25 * 4.0);
        let sum = hit + nee + lt;
        let expect = [hit / sum, nee / sum, lt / sum];
        assert_eq!(w.len(), 3);
        for (got, want) in w.iter().zip(expect) {
            assert!((got.weight - want).abs() < 1e-15, "{got:?} {want}");
        }
    }

    #[test]
    fn virtual_merges_by_hand() {
        // x0 (area light), x1 (regularized), camera; BPT with virtual merges.
        // Next-event estimation gets the virtual merge sampled at x1 towards
        // the light (acceptance 0.5), light tracing the one sampled at x1
        // towards the camera (0.2): q_vm = q_conn * acceptance.
        let t = crate::Techniques::BPT.with_virtual_merges(true);
        let c = MisConfig::new(t, 3, 0.0, Heuristic::BALANCE).unwrap();
        let mut x1 = vertex(4.0, 3.0);
        x1.accept_towards_camera = 0.2;
        x1.accept_towards_light = 0.5;
        let path = Path {
            emitter: EmitterKind::Area,
            direct_pdf: 0.5,
            vertices: vec![vertex(0.25, 2.0), x1, vertex(1.0, 1.0)],
        };
        let w = weights(&c, &path).unwrap();
        let (hit, nee, lt) = (6.0, 1.5, 3.0);
        let (nee_vm, lt_vm) = (nee * 0.5, lt * 0.2);
        let sum = hit + nee + nee_vm + lt + lt_vm;
        let expect = [
            (Technique::EmitterHit, hit),
            (Technique::Connection { light_vertex: 0 }, nee),
            (
                Technique::VirtualMerge {
                    light_vertex: 0,
                    at_camera_end: true,
                },
                nee_vm,
            ),
            (Technique::Connection { light_vertex: 1 }, lt),
            (
                Technique::VirtualMerge {
                    light_vertex: 1,
                    at_camera_end: false,
                },
                lt_vm,
            ),
        ];
        assert_eq!(w.len(), expect.len());
        for (got, (technique, q)) in w.iter().zip(expect) {
            assert_eq!(got.technique, technique);
            assert!((got.weight - q / sum).abs() < 1e-15);
        }
        assert_eq!(
            expect[2].0.executed_as(),
            Technique::Connection { light_vertex: 0 }
        );
    }

    #[test]
    fn invalid_paths_are_errors() {
        let c = MisConfig::bpt(1, Heuristic::BALANCE).unwrap();
        let mut path = Path {
            emitter: EmitterKind::Area,
            direct_pdf: 1.0,
            vertices: vec![vertex(1.0, 1.0)],
        };
        assert_eq!(weights(&c, &path), Err(MisError::PathTooShort));
        path.vertices.push(vertex(f64::NAN, 1.0));
        assert_eq!(
            weights(&c, &path),
            Err(MisError::InvalidPathValue { vertex: 1 })
        );
        path.vertices[1] = vertex(1.0, 1.0);
        path.direct_pdf = -1.0;
        assert_eq!(
            weights(&c, &path),
            Err(MisError::InvalidPathValue { vertex: 0 })
        );
    }
}
