//! Constructed paths: per-vertex geometry and pdfs, their explicit reference
//! form, and the weights the recursion gives every technique.
//!
//! Vertices x_0 (emitter) ... x_k (camera). Each interior vertex has ONE pair
//! of directional pdfs, used by every technique (SPEC §6, `off` and `uniform`
//! modes): `to_camera[i]` = p(x_i: x_{i-1} -> x_{i+1}) and
//! `to_light[i]` = p(x_i: x_{i+1} -> x_{i-1}), in solid angle.

use mis::reference::{self, PathVertex, Technique};
use mis::*;
use stats::Pcg32;
use std::collections::BTreeMap;

/// A path with everything the two evaluations need.
#[derive(Clone, Debug)]
pub struct TestPath {
    /// Number of segments; vertices x_0..x_k.
    pub k: usize,
    pub emitter: EmitterKind,
    /// Pdf with which next-event estimation picks x_0 (area for finite, solid
    /// angle for infinite emitters; the selection probability for delta ones).
    pub direct: f64,
    /// Emission position pdf (finite) or direction pdf (infinite) of x_0.
    pub emit_pos: f64,
    /// Emission direction pdf (finite, solid angle) or disc pdf (infinite, area).
    pub emit_dir: f64,
    /// Solid-angle pdf of the camera ray towards x_{k-1}.
    pub camera_pdf_w: f64,
    /// dist[i] = |x_i x_{i+1}|.
    pub dist: Vec<f64>,
    /// cos_minus[i] = |cos| at x_i towards x_{i-1} (index 0 unused).
    pub cos_minus: Vec<f64>,
    /// cos_plus[i] = |cos| at x_i towards x_{i+1} (cos_plus[0]: the emitter).
    pub cos_plus: Vec<f64>,
    pub to_camera: Vec<f64>,
    pub to_light: Vec<f64>,
    pub specular: Vec<bool>,
    /// Regularization bound per vertex (infinity: not regularized).
    pub tau: Vec<f64>,
}

/// Ranges of the random draws.
#[derive(Clone, Copy, Debug)]
pub struct Ranges {
    /// Directional (solid-angle) pdfs: log-uniform in [lo, hi].
    pub pdf: (f64, f64),
    pub dist: (f64, f64),
    pub cos: (f64, f64),
    pub tau: (f64, f64),
    pub specular_probability: f64,
    pub regularized_probability: f64,
}

impl Ranges {
    /// Wide ranges that still keep every product of ratios inside f64 for
    /// beta <= 2 over ten vertices (checked by `max_ratio_exponent`).
    pub const WIDE: Self = Self {
        pdf: (1e-3, 1e3),
        dist: (0.1, 10.0),
        cos: (1e-2, 1.0),
        tau: (1.0 / (2.0 * std::f64::consts::PI) + 1e-9, 1e4),
        specular_probability: 0.25,
        regularized_probability: 0.5,
    };
}

pub fn random_emitter(rng: &mut Pcg32) -> EmitterKind {
    match (rng.uniform_f64() * 4.0) as u32 {
        0 => EmitterKind::Area,
        1 => EmitterKind::Point,
        2 => EmitterKind::Directional,
        _ => EmitterKind::Environment,
    }
}

impl TestPath {
    pub fn random(rng: &mut Pcg32, k: usize, emitter: EmitterKind, r: &Ranges) -> Self {
        let mut p = Self {
            k,
            emitter,
            direct: rng.log_uniform(r.pdf.0, r.pdf.1),
            emit_pos: rng.log_uniform(r.pdf.0, r.pdf.1),
            emit_dir: rng.log_uniform(r.pdf.0, r.pdf.1),
            camera_pdf_w: rng.log_uniform(r.pdf.0, r.pdf.1),
            dist: (0..k)
                .map(|_| rng.log_uniform(r.dist.0, r.dist.1))
                .collect(),
            cos_minus: (0..=k).map(|_| rng.log_uniform(r.cos.0, r.cos.1)).collect(),
            cos_plus: (0..=k).map(|_| rng.log_uniform(r.cos.0, r.cos.1)).collect(),
            to_camera: (0..=k).map(|_| rng.log_uniform(r.pdf.0, r.pdf.1)).collect(),
            to_light: (0..=k).map(|_| rng.log_uniform(r.pdf.0, r.pdf.1)).collect(),
            specular: vec![false; k + 1],
            tau: vec![NOT_REGULARIZED; k + 1],
        };
        for i in 1..k {
            if rng.uniform_f64() < r.specular_probability {
                p.specular[i] = true;
                // A discrete lobe probability, the same both ways or not.
                p.to_camera[i] = rng.range_f64(0.05, 1.0);
                p.to_light[i] = rng.range_f64(0.05, 1.0);
            } else if rng.uniform_f64() < r.regularized_probability {
                p.tau[i] = rng.log_uniform(r.tau.0, r.tau.1);
            }
        }
        p
    }

    fn finite(&self) -> bool {
        !self.emitter.is_infinite()
    }

    /// |cos| at the emitter towards x_1 as the API sees it (1 unless Area).
    fn cos_light(&self) -> f64 {
        if self.emitter == EmitterKind::Area {
            self.cos_plus[0]
        } else {
            1.0
        }
    }

    pub fn emission_pdf_w(&self) -> f64 {
        self.emit_pos * self.emit_dir
    }

    /// Area pdf of x_i sampled by the light sub-path (i >= 1).
    pub fn pl(&self, i: usize) -> f64 {
        if i == 1 {
            if self.finite() {
                self.emit_dir * self.cos_minus[1] / self.dist[0].powi(2)
            } else {
                self.emit_dir * self.cos_minus[1]
            }
        } else {
            self.to_camera[i - 1] * self.cos_minus[i] / self.dist[i - 1].powi(2)
        }
    }

    /// Area pdf of x_i sampled by the camera sub-path (i <= k - 1).
    pub fn pc(&self, i: usize) -> f64 {
        let sampler_pdf = if i == self.k - 1 {
            self.camera_pdf_w
        } else {
            self.to_light[i + 1]
        };
        if i == 0 && self.emitter.is_infinite() {
            sampler_pdf
        } else {
            sampler_pdf * self.cos_plus[i] / self.dist[i].powi(2)
        }
    }

    fn accept(&self, config: &MisConfig, pdf: f64, i: usize) -> f64 {
        if self.specular[i] || !config.techniques().virtual_merges {
            0.0
        } else {
            acceptance_probability(pdf, self.tau[i])
        }
    }

    /// The path in the reference's form.
    pub fn reference_path(&self, config: &MisConfig) -> reference::Path {
        let k = self.k;
        let mut vertices = Vec::with_capacity(k + 1);
        for i in 0..=k {
            let interior = i >= 1 && i < k;
            vertices.push(PathVertex {
                pdf_light: match i {
                    0 => self.emit_pos,
                    _ if i == k => 1.0,
                    _ => self.pl(i),
                },
                pdf_camera: if i == k { 1.0 } else { self.pc(i) },
                specular: self.specular[i],
                accept_towards_camera: if interior {
                    self.accept(config, self.to_camera[i], i)
                } else {
                    0.0
                },
                accept_towards_light: if interior {
                    self.accept(config, self.to_light[i], i)
                } else {
                    0.0
                },
            });
        }
        reference::Path {
            emitter: self.emitter,
            direct_pdf: self.direct,
            vertices,
        }
    }

    /// A bound on log10 of the largest ratio of path pdfs (to the power beta)
    /// the evaluation can form, to check that a test's ranges cannot saturate
    /// the recursion's guards (1e300).
    pub fn max_ratio_exponent(&self, config: &MisConfig) -> f64 {
        let l = |x: f64| x.log10().abs();
        let mut total = l(self.pc(0)) + l(self.direct) + l(self.emit_pos) + l(self.emit_dir);
        for i in 1..self.k {
            total += l(self.pl(i)) + l(self.pc(i)) + l(self.to_camera[i]) + l(self.to_light[i]);
        }
        let eta = if config.techniques().merging {
            l(config.eta_vcm())
        } else {
            0.0
        };
        total += l(config.light_paths()) + eta + 2.0;
        total * config.heuristic().beta()
    }

    fn pdfs(&self, i: usize, towards_camera: bool) -> VertexPdfs {
        let (fwd, rev) = if towards_camera {
            (self.to_camera[i], self.to_light[i])
        } else {
            (self.to_light[i], self.to_camera[i])
        };
        VertexPdfs::regularized(fwd, rev, self.tau[i])
    }

    /// Light sub-path states at x_1 .. x_{k-1} (index i; index 0 unused).
    pub fn light_states(&self, config: &MisConfig) -> Vec<SubpathState> {
        let emission = Emission {
            kind: self.emitter,
            direct_pdf_a: self.direct,
            emission_pdf_w: self.emission_pdf_w(),
            cos_light: self.cos_light(),
        };
        let mut states = Vec::with_capacity(self.k);
        let first = SubpathRay::from_light(config, &emission).arrive(
            config,
            self.dist[0],
            self.cos_minus[1],
        );
        states.push(first); // placeholder for index 0
        states.push(first);
        for i in 1..self.k.saturating_sub(1) {
            let event = Scatter {
                pdfs: self.pdfs(i, true),
                cos_out: self.cos_plus[i],
                specular: self.specular[i],
            };
            let next = states[i].scatter(config, &event).arrive(
                config,
                self.dist[i],
                self.cos_minus[i + 1],
            );
            states.push(next);
        }
        states
    }

    /// Camera sub-path states at x_{k-1} .. x_1 (index i), plus the state at
    /// the emitter (finite hittable emitters) or the escaped ray (infinite).
    pub fn camera_states(&self, config: &MisConfig) -> (Vec<Option<SubpathState>>, CameraEnd) {
        let k = self.k;
        let mut states = vec![None; k + 1];
        let mut ray = SubpathRay::from_camera(config, self.camera_pdf_w);
        for i in (1..k).rev() {
            let here = ray.arrive(config, self.dist[i], self.cos_plus[i]);
            states[i] = Some(here);
            let event = Scatter {
                pdfs: self.pdfs(i, false),
                cos_out: self.cos_minus[i],
                specular: self.specular[i],
            };
            ray = here.scatter(config, &event);
        }
        let end = if self.emitter.is_infinite() {
            CameraEnd::Escaped(ray)
        } else {
            CameraEnd::Arrived(ray.arrive(config, self.dist[0], self.cos_plus[0]))
        };
        (states, end)
    }

    /// The weight of every executed technique, computed by the recursion.
    pub fn recursive_weights(&self, config: &MisConfig) -> BTreeMap<Technique, f64> {
        let k = self.k;
        let mut out = BTreeMap::new();
        let light = self.light_states(config);
        let (camera, end) = self.camera_states(config);
        let hit = EmitterHit {
            direct_pdf_a: self.direct,
            emission_pdf_w: self.emission_pdf_w(),
        };
        if self.emitter.is_hittable() {
            let w = match end {
                CameraEnd::Arrived(state) => config.emitter_hit_weight(&state, &hit),
                CameraEnd::Escaped(ray) => config.environment_hit_weight(&ray, &hit),
            };
            out.insert(Technique::EmitterHit, w);
        }
        let t = config.techniques();
        if t.connections && k >= 2 {
            // Next-event estimation at x_1.
            if !self.specular[1] {
                let end = ConnectionEnd {
                    pdfs: self.pdfs(1, false),
                    cos: self.cos_minus[1],
                };
                let direct_pdf_w = match self.emitter {
                    EmitterKind::Area => self.direct * self.dist[0].powi(2) / self.cos_plus[0],
                    EmitterKind::Point => self.direct * self.dist[0].powi(2),
                    _ => self.direct,
                };
                let sample = LightSample {
                    kind: self.emitter,
                    direct_pdf_w,
                    emission_pdf_w: self.emission_pdf_w(),
                    cos_light: self.cos_light(),
                };
                let camera_1 = camera[1].expect("camera reaches x_1");
                out.insert(
                    Technique::Connection { light_vertex: 0 },
                    config.next_event_weight(&camera_1, &end, &sample),
                );
            }
            // Vertex connections on edges (i, i+1), 1 <= i <= k-2.
            for i in 1..k - 1 {
                if self.specular[i] || self.specular[i + 1] {
                    continue;
                }
                let light_end = ConnectionEnd {
                    pdfs: self.pdfs(i, true),
                    cos: self.cos_plus[i],
                };
                let camera_end = ConnectionEnd {
                    pdfs: self.pdfs(i + 1, false),
                    cos: self.cos_minus[i + 1],
                };
                let w = config.connection_weight(
                    &light[i],
                    &light_end,
                    &camera[i + 1].expect("camera vertex"),
                    &camera_end,
                    self.dist[i],
                );
                out.insert(Technique::Connection { light_vertex: i }, w);
            }
            // Light tracing from x_{k-1}.
            if !self.specular[k - 1] {
                let light_end = ConnectionEnd {
                    pdfs: self.pdfs(k - 1, true),
                    cos: self.cos_plus[k - 1],
                };
                let w = config.light_tracing_weight(
                    &light[k - 1],
                    &light_end,
                    self.camera_pdf_w,
                    self.dist[k - 1],
                );
                out.insert(
                    Technique::Connection {
                        light_vertex: k - 1,
                    },
                    w,
                );
            }
        }
        if t.merging {
            for j in 1..k {
                if self.specular[j] {
                    continue;
                }
                let w = config.merge_weight(
                    &light[j],
                    &camera[j].expect("camera vertex"),
                    &self.pdfs(j, false),
                );
                out.insert(Technique::Merge { vertex: j }, w);
            }
        }
        out
    }
}

/// The camera sub-path's end at the emitter.
#[derive(Clone, Copy, Debug)]
pub enum CameraEnd {
    /// At a finite emitter's surface.
    Arrived(SubpathState),
    /// Leaving the scene towards an infinite emitter.
    Escaped(SubpathRay),
}

/// The reference's weights summed per executed technique.
pub fn reference_by_executed(
    config: &MisConfig,
    path: &reference::Path,
) -> BTreeMap<Technique, f64> {
    let mut out = BTreeMap::new();
    for tw in reference::weights(config, path).expect("valid reference path") {
        *out.entry(tw.technique.executed_as()).or_insert(0.0) += tw.weight;
    }
    out
}
