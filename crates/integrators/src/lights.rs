//! Light selection and sampling: lights are chosen in proportion to their
//! power, then a point (or direction) on the chosen light is sampled.

use std::f32::consts::PI;

use glam::{Vec2, Vec3};
use scene::{Light, Scene};

/// Luminance weights (Rec. 709) to turn RGB power into one number.
fn luminance(c: Vec3) -> f32 {
    c.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}

/// Spot falloff (KHR_lights_punctual's recommended smooth falloff):
/// ((cos - cos_outer) / (cos_inner - cos_outer))^2, clamped to [0, 1].
pub fn spot_falloff(cos_theta: f32, cos_inner: f32, cos_outer: f32) -> f32 {
    let t =
        ((cos_theta - cos_outer) / (cos_inner - cos_outer).max(f32::MIN_POSITIVE)).clamp(0.0, 1.0);
    t * t
}

/// A sampled light contribution at a receiving point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightSample {
    /// Unit direction from the receiver to the light.
    pub wi: Vec3,
    /// Incident radiance for area and environment lights; for delta lights
    /// the delta's weight (I/d^2, or the irradiance E): in both cases the
    /// contribution is f |cos| `li` / `pdf`.
    pub li: Vec3,
    /// Density of `wi` in solid angle, times the selection probability; for
    /// delta lights the selection probability alone.
    pub pdf: f32,
    /// The light point (for shadow rays); `None` for lights at infinity.
    pub point: Option<LightPoint>,
    /// True for point, spot and directional lights (no MIS with BSDF sampling).
    pub is_delta: bool,
}

/// A point on a light, with the normal to offset a shadow ray's end.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightPoint {
    /// Position.
    pub p: Vec3,
    /// Geometric normal (zero for point lights).
    pub n: Vec3,
}

/// The scene's lights with a power-proportional selection distribution.
#[derive(Clone, Debug)]
pub struct Lights {
    lights: Vec<Light>,
    /// Cumulative selection probabilities (last entry 1).
    cdf: Vec<f32>,
    /// Selection probability per light.
    pmf: Vec<f32>,
    /// Light index of each emissive triangle (`u32::MAX` for others).
    triangle_light: Vec<u32>,
    /// Index of the environment light, if any.
    environment: Option<u32>,
    /// Radius of the scene's bounding sphere (power of lights at infinity).
    scene_radius: f32,
}

impl Lights {
    /// Builds the selection distribution over `scene.lights`.
    pub fn new(scene: &Scene) -> Self {
        let (lo, hi) = scene.bounds();
        let scene_radius = (0.5 * (hi - lo).length()).max(1e-3);
        let mut triangle_light = vec![u32::MAX; scene.triangles.len()];
        let mut environment = None;
        let power: Vec<f32> = scene
            .lights
            .iter()
            .enumerate()
            .map(|(i, light)| {
                let p = match *light {
                    Light::Point { intensity, .. } => 4.0 * PI * luminance(intensity),
                    Light::Spot {
                        intensity,
                        cos_inner,
                        cos_outer,
                        ..
                    } => 2.0 * PI * luminance(intensity) * (1.0 - 0.5 * (cos_inner + cos_outer)),
                    Light::Directional { irradiance, .. } => {
                        PI * scene_radius * scene_radius * luminance(irradiance)
                    }
                    Light::Environment { radiance } => {
                        environment = Some(i as u32);
                        4.0 * PI * PI * scene_radius * scene_radius * luminance(radiance)
                    }
                    Light::Area { triangle } => {
                        triangle_light[triangle as usize] = i as u32;
                        let m =
                            &scene.materials[scene.triangle_materials[triangle as usize] as usize];
                        PI * scene.triangle_area(triangle as usize) * luminance(m.emission)
                    }
                };
                if p.is_finite() { p.max(0.0) } else { 0.0 }
            })
            .collect();
        let total: f64 = power.iter().map(|&p| f64::from(p)).sum();
        let pmf: Vec<f32> = if total > 0.0 && total.is_finite() {
            power
                .iter()
                .map(|&p| (f64::from(p) / total) as f32)
                .collect()
        } else {
            vec![1.0 / power.len().max(1) as f32; power.len()]
        };
        let mut acc = 0.0f64;
        let mut cdf: Vec<f32> = pmf
            .iter()
            .map(|&p| {
                acc += f64::from(p);
                acc as f32
            })
            .collect();
        if let Some(last) = cdf.last_mut() {
            *last = 1.0;
        }
        Self {
            lights: scene.lights.clone(),
            cdf,
            pmf,
            triangle_light,
            environment,
            scene_radius,
        }
    }

    /// True when the scene has no light.
    pub fn is_empty(&self) -> bool {
        self.lights.is_empty()
    }

    /// The environment light's radiance, if there is one.
    pub fn environment(&self) -> Option<Vec3> {
        self.environment.map(|i| match self.lights[i as usize] {
            Light::Environment { radiance } => radiance,
            _ => Vec3::ZERO,
        })
    }

    /// Density of the environment light's sampling technique for any
    /// direction (selection probability / 4 pi).
    pub fn environment_pdf(&self) -> f32 {
        self.environment
            .map_or(0.0, |i| self.pmf[i as usize] / (4.0 * PI))
    }

    /// Density, in solid angle at `from`, with which [`Lights::sample`]
    /// produces the point `p` (normal `n`) of emissive triangle `triangle`.
    pub fn area_pdf(&self, scene: &Scene, triangle: u32, from: Vec3, p: Vec3, n: Vec3) -> f32 {
        let Some(&light) = self.triangle_light.get(triangle as usize) else {
            return 0.0;
        };
        if light == u32::MAX {
            return 0.0;
        }
        let d = p - from;
        let dist2 = d.length_squared();
        let cos = (n.dot(d) / dist2.sqrt()).abs();
        let pdf = self.pmf[light as usize] / scene.triangle_area(triangle as usize) * dist2 / cos;
        if pdf.is_finite() { pdf } else { 0.0 }
    }

    /// Samples a light for the receiver at `p` from `u_select` and `u`.
    /// `None` when the sample carries nothing (back side of an area light,
    /// outside a spot cone, no light).
    pub fn sample(&self, scene: &Scene, p: Vec3, u_select: f32, u: Vec2) -> Option<LightSample> {
        let index = self
            .cdf
            .partition_point(|&c| c <= u_select)
            .min(self.lights.len().checked_sub(1)?);
        let pmf = self.pmf[index];
        if pmf <= 0.0 {
            return None;
        }
        let delta = |position: Vec3, intensity: Vec3| {
            let d = position - p;
            let dist2 = d.length_squared();
            let wi = d.try_normalize()?;
            Some(LightSample {
                wi,
                li: intensity / dist2,
                pdf: pmf,
                point: Some(LightPoint {
                    p: position,
                    n: Vec3::ZERO,
                }),
                is_delta: true,
            })
        };
        let sample = match self.lights[index] {
            Light::Point {
                position,
                intensity,
            } => delta(position, intensity)?,
            Light::Spot {
                position,
                direction,
                intensity,
                cos_inner,
                cos_outer,
            } => {
                let s = delta(position, intensity)?;
                let falloff = spot_falloff((-s.wi).dot(direction), cos_inner, cos_outer);
                LightSample {
                    li: s.li * falloff,
                    ..s
                }
            }
            Light::Directional {
                direction,
                irradiance,
            } => LightSample {
                wi: -direction,
                li: irradiance,
                pdf: pmf,
                point: None,
                is_delta: true,
            },
            Light::Environment { radiance } => LightSample {
                wi: uniform_sphere(u),
                li: radiance,
                pdf: pmf / (4.0 * PI),
                point: None,
                is_delta: false,
            },
            Light::Area { triangle } => {
                let [a, b, c] = scene.triangles[triangle as usize];
                let su = u.x.sqrt();
                let (b1, b2) = (u.y * su, 1.0 - su);
                let q = a * (1.0 - b1 - b2) + b * b1 + c * b2;
                let n = (b - a).cross(c - a).normalize_or_zero();
                let d = q - p;
                let wi = d.try_normalize()?;
                if n.dot(-wi) <= 0.0 {
                    return None; // One-sided emitter seen from behind.
                }
                let material =
                    &scene.materials[scene.triangle_materials[triangle as usize] as usize];
                let pdf = self.area_pdf(scene, triangle, p, q, n);
                if pdf <= 0.0 {
                    return None;
                }
                LightSample {
                    wi,
                    li: material.emission,
                    pdf,
                    point: Some(LightPoint { p: q, n }),
                    is_delta: false,
                }
            }
        };
        (sample.li.max_element() > 0.0 && sample.pdf.is_finite()).then_some(sample)
    }

    /// Radius of the scene's bounding sphere.
    pub fn scene_radius(&self) -> f32 {
        self.scene_radius
    }
}

/// A uniformly distributed unit vector from two uniforms.
pub fn uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}
