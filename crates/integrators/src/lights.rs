//! Light selection and sampling: lights are chosen in proportion to their
//! power, then a point (or direction) on the chosen light is sampled
//! (emissive triangles and spheres uniformly by area; for the path tracer,
//! spheres by the cone of directions they subtend, [`Lights::with_sphere_cones`]). The
//! constant environment is sampled uniformly over the sphere; an environment
//! map by its distribution ([`crate::environment`]), and both emit light
//! subpaths from a disk covering the scene's bounding sphere.

use std::f32::consts::PI;

use glam::{Vec2, Vec3};
use microfacet::frame::sin_cos_turns;
use mis::EmitterKind;
use scene::{Light, Scene};

use crate::colour::luminance;
use crate::environment::EnvironmentDistribution;
use crate::geometry::{BoundingSphere, PointError, vertex_scale};

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
    /// What the bidirectional MIS needs to know about the light (SmallVCM's
    /// `directPdfW`, `emissionPdfW`, `cosAtLight`).
    pub mis: EmitterPdfs,
}

impl LightSample {
    /// The sample as the `mis` crate takes it for next-event estimation.
    /// Area lights: the solid-angle pdf of the sample; the others'
    /// `direct_pdf` is already in the measure the crate takes.
    pub fn mis_sample(&self) -> mis::LightSample {
        let direct_pdf_w = if self.mis.kind == EmitterKind::Area {
            self.pdf
        } else {
            self.mis.direct_pdf
        };
        mis::LightSample {
            kind: self.mis.kind,
            direct_pdf_w: f64::from(direct_pdf_w),
            emission_pdf_w: f64::from(self.mis.emission_pdf_w),
            cos_light: f64::from(self.mis.cos_light),
        }
    }
}

/// The pdfs of an emitter point or direction as the `mis` crate takes them
/// (SmallVCM conventions, light-selection probability included).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EmitterPdfs {
    /// The light's kind.
    pub kind: EmitterKind,
    /// Next-event pdf of the point: area measure for area lights, solid
    /// angle for the environment, pmf d^2 for point and spot lights, the pmf
    /// for directional lights.
    pub direct_pdf: f32,
    /// Density of emitting this ray from the light (position and direction).
    pub emission_pdf_w: f32,
    /// |cos| at the emitter surface (1 without a surface).
    pub cos_light: f32,
}

impl EmitterPdfs {
    /// The emitter as the `mis` crate takes it when a camera subpath hits it.
    pub fn hit(&self) -> mis::EmitterHit {
        mis::EmitterHit {
            direct_pdf_a: f64::from(self.direct_pdf),
            emission_pdf_w: f64::from(self.emission_pdf_w),
        }
    }

    /// The emission as the `mis` crate takes it (a light subpath's start).
    pub fn emission(&self) -> mis::Emission {
        mis::Emission {
            kind: self.kind,
            direct_pdf_a: f64::from(self.direct_pdf),
            emission_pdf_w: f64::from(self.emission_pdf_w),
            cos_light: f64::from(self.cos_light),
        }
    }
}

/// A ray leaving a light: where light subpaths start.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Emission {
    /// Ray origin (offset from the emitting surface).
    pub origin: Vec3,
    /// Unit direction.
    pub direction: Vec3,
    /// Emitted radiance (intensity, irradiance) times cos over the emission pdf.
    pub throughput: Vec3,
    /// The emission's pdfs for MIS.
    pub mis: EmitterPdfs,
}

/// A light choice that is one point, as [`Lights::point_target`] gives
/// it.
#[derive(Clone, Copy, Debug)]
pub struct PointTarget {
    /// The point (a point light's position, with a zero normal).
    pub point: LightPoint,
    /// Radiance of a triangle's point, intensity of a point light.
    pub emitted: Vec3,
    /// A triangle's density in area, selection included
    /// ([`Lights::area_pdfs`]' `direct_pdf`); a point light's selection
    /// probability.
    pub pdf: f32,
    /// A point light: its sample's radiance is the intensity over the
    /// squared distance, its density the selection probability, and BSDF
    /// sampling cannot find it (no MIS).
    pub delta: bool,
}

/// What [`Lights::choose`] draws: a light, its selection probability and
/// the sample numbers, and on an area or sphere light the point.
#[derive(Clone, Copy, Debug)]
pub struct LightChoice {
    index: usize,
    pmf: f32,
    u: Vec2,
    surface: Option<SurfaceSample>,
}

/// A point sampled uniformly on an emissive triangle or sphere.
#[derive(Clone, Copy, Debug)]
struct SurfaceSample {
    /// The point, its emitting side's normal and the triangle it lies on.
    point: LightPoint,
    /// Its emitted radiance.
    le: Vec3,
    /// The emitter's primitive (`SurfacePoint::primitive`).
    primitive: u32,
}

/// A point on a light, with the normal to offset a shadow ray's end.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightPoint {
    /// Position.
    pub p: Vec3,
    /// Geometric normal (zero for point lights).
    pub n: Vec3,
    /// The error of `p` (an emitting triangle's
    /// [`crate::geometry::vertex_scale`], infinity for point lights: no
    /// offset; a sphere point's bound).
    pub error: PointError,
    /// The emitting triangle, which a shadow ray to `p` need not test
    /// (`accel::Bvh::occluded_between`); [`accel::NO_SURFACE`] for other
    /// lights.
    pub surface: u32,
}

/// The scene's lights with a power-proportional selection distribution.
#[derive(Clone, Debug)]
pub struct Lights {
    lights: Vec<Light>,
    /// Cumulative selection probabilities (last entry 1).
    cdf: Vec<f32>,
    /// Selection probability per light.
    pmf: Vec<f32>,
    /// Per light: the area density of choosing a point of an area light
    /// (selection probability / triangle or sphere area), 0 for other lights.
    area_pdf_a: Vec<f32>,
    /// Per light: an emissive triangle's geometric normal (emitting side),
    /// zero for other lights (a sphere's varies). Stored: every light
    /// sample needs it.
    area_normal: Vec<Vec3>,
    /// Per light: an area light's [`vertex_scale`] (ray-origin offsets),
    /// infinity for other lights.
    area_scale: Vec<f32>,
    /// Light index of each emissive primitive, by primitive id (triangles,
    /// then spheres; `u32::MAX` for others).
    primitive_light: Vec<u32>,
    /// The first sphere's primitive id (the triangle count).
    first_sphere: u32,
    /// Index of the environment light, if any.
    environment: Option<u32>,
    /// The environment map's index in `Scene::environment_maps` and its
    /// sampling distribution, when the environment is a map (`None` also
    /// for a dark map: it emits nothing).
    environment_map: Option<(usize, EnvironmentDistribution)>,
    /// Centre and radius of the scene's bounding sphere (power and
    /// emission of lights at infinity).
    scene_centre: Vec3,
    scene_radius: f32,
    /// Per light: the sphere whose cone of directions next-event
    /// estimation samples ([`Lights::with_sphere_cones`]); `None` for other
    /// lights, inward-facing spheres, and without cones.
    cones: Vec<Option<accel::Sphere>>,
}

/// Below this sin^2 of the cone's half-angle (that of 1.5 degrees),
/// 1 - cos is taken from its Taylor expansion sin^2 / 2, as pbrt-v4's
/// `Sphere::Sample` does: the difference of two numbers near 1 would lose
/// the cone's size for small, distant spheres.
const SMALL_CONE_SIN2: f64 = 0.000_685_23;

/// Receivers closer to a sphere's centre than this many radii sample it by
/// area: on (or inside) the surface the cone is a hemisphere or undefined.
const CONE_MIN_DISTANCE: f64 = 1.0 + 1e-4;

/// The cone a sphere subtends from a receiver: its axis towards the
/// receiver, sin^2 of its half-angle and 1 - cos of it (Shirley and Wang
/// 1996; pbrt-v4 `Sphere::Sample` with a reference point).
#[derive(Clone, Copy, Debug)]
struct Cone {
    /// Unit vector from the centre towards the receiver.
    axis: glam::DVec3,
    sin2_max: f64,
    one_minus_cos_max: f64,
}

impl Cone {
    /// The cone of `sphere` seen from `p`, or `None` within
    /// [`CONE_MIN_DISTANCE`] of the centre.
    fn of(sphere: &accel::Sphere, p: Vec3) -> Option<Self> {
        let to_receiver = p.as_dvec3() - sphere.center.as_dvec3();
        let d2 = to_receiver.length_squared();
        let r = f64::from(sphere.radius);
        if !(d2 > (CONE_MIN_DISTANCE * r).powi(2)) || !d2.is_finite() {
            return None;
        }
        let sin2_max = r * r / d2;
        let one_minus_cos_max = if sin2_max < SMALL_CONE_SIN2 {
            0.5 * sin2_max
        } else {
            1.0 - (1.0 - sin2_max).sqrt()
        };
        Some(Self {
            axis: to_receiver / d2.sqrt(),
            sin2_max,
            one_minus_cos_max,
        })
    }

    /// Density in solid angle of [`Cone::sample`]: 1 / (2 pi (1 - cos_max)).
    fn pdf(&self) -> f64 {
        1.0 / (2.0 * std::f64::consts::PI * self.one_minus_cos_max)
    }

    /// The outward unit normal of the sphere point that a direction uniform
    /// in the cone (numbers `u`) meets first: cos theta uniform in
    /// [cos_max, 1] about the axis, then the angle alpha at the centre of
    /// the nearer intersection (pbrt-v4 `Sphere::Sample`).
    fn sample(&self, u: Vec2) -> glam::DVec3 {
        let u0 = f64::from(u.x);
        let (sin2_theta, cos_theta) = if self.sin2_max < SMALL_CONE_SIN2 {
            let sin2 = self.sin2_max * u0;
            (sin2, (1.0 - sin2).sqrt())
        } else {
            let cos = 1.0 - u0 * self.one_minus_cos_max;
            (1.0 - cos * cos, cos)
        };
        let sin_max = self.sin2_max.sqrt();
        let cos_alpha =
            sin2_theta / sin_max + cos_theta * (1.0 - sin2_theta / self.sin2_max).max(0.0).sqrt();
        let sin_alpha = (1.0 - cos_alpha * cos_alpha).max(0.0).sqrt();
        let (sin_phi, cos_phi) = sin_cos_turns(u.y);
        let (t, b) = self.axis.any_orthonormal_pair();
        (t * f64::from(cos_phi) + b * f64::from(sin_phi)) * sin_alpha + self.axis * cos_alpha
    }
}

impl Lights {
    /// Builds the selection distribution over `scene.lights`; lights at
    /// infinity emit into the scene's bounding sphere `bounds`.
    pub fn new(scene: &Scene, bounds: BoundingSphere) -> Self {
        let scene_radius = bounds.radius;
        let first_sphere = scene.triangles.len() as u32;
        let mut primitive_light = vec![u32::MAX; scene.triangles.len() + scene.spheres.len()];
        let mut environment = None;
        let mut environment_map = None;
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
                        // The last environment is the one escaping rays
                        // see (`scene::validate` allows only one).
                        environment = Some(i as u32);
                        environment_map = None;
                        4.0 * PI * PI * scene_radius * scene_radius * luminance(radiance)
                    }
                    Light::EnvironmentMap { map } => {
                        // As for the constant environment: the disk the
                        // light enters through times the radiance
                        // integrated over the sphere (4 pi L for a constant).
                        environment = Some(i as u32);
                        environment_map = scene
                            .environment_maps
                            .get(map as usize)
                            .and_then(EnvironmentDistribution::new)
                            .map(|d| (map as usize, d));
                        environment_map.as_ref().map_or(0.0, |(_, d)| {
                            (f64::from(PI * scene_radius * scene_radius) * d.luminance_integral())
                                as f32
                        })
                    }
                    Light::Area { triangle } => {
                        primitive_light[triangle as usize] = i as u32;
                        let m =
                            &scene.materials[scene.triangle_materials[triangle as usize] as usize];
                        PI * scene.triangle_area(triangle as usize) * luminance(m.emission)
                    }
                    Light::Sphere { sphere } => {
                        // pi L A, A = 4 pi r^2, as for a triangle.
                        primitive_light[(first_sphere + sphere) as usize] = i as u32;
                        let s = &scene.spheres[sphere as usize];
                        let m = &scene.materials[s.material as usize];
                        (std::f64::consts::PI * s.area() * f64::from(luminance(m.emission))) as f32
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
        let area_triangle = |light: &Light| match *light {
            Light::Area { triangle } => Some(triangle as usize),
            _ => None,
        };
        let area_pdf_a = scene
            .lights
            .iter()
            .zip(&pmf)
            .map(|(light, &pmf)| match *light {
                Light::Area { triangle } => pmf / scene.triangle_area(triangle as usize),
                Light::Sphere { sphere } => {
                    (f64::from(pmf) / scene.spheres[sphere as usize].area()) as f32
                }
                _ => 0.0,
            })
            .collect();
        let area_normal = scene
            .lights
            .iter()
            .map(|light| area_triangle(light).map_or(Vec3::ZERO, |t| scene.geometric_normal(t)))
            .collect();
        let area_scale = scene
            .lights
            .iter()
            .map(|light| {
                area_triangle(light).map_or(f32::INFINITY, |t| vertex_scale(&scene.triangle(t)))
            })
            .collect();
        Self {
            lights: scene.lights.clone(),
            cdf,
            pmf,
            area_pdf_a,
            area_normal,
            area_scale,
            primitive_light,
            first_sphere,
            environment,
            environment_map,
            scene_centre: bounds.centre,
            scene_radius,
            cones: vec![None; scene.lights.len()],
        }
    }

    /// These lights with next-event estimation sampling each outward-facing
    /// emissive sphere by the cone of directions it subtends from the
    /// receiver, uniformly in solid angle (Shirley and Wang 1996, as pbrt-v4
    /// and Mitsuba 3 do), instead of uniformly by area: only the visible cap,
    /// with a density that no longer varies with cos / d^2 across it. On
    /// Veach's MIS scene (four sphere lights over glossy plates; 64 spp,
    /// means over 8 seeds) the path tracer's MSE away from the lights seen
    /// directly fell to 0.42 of area sampling's, its relMSE to 0.68.
    ///
    /// For the path tracer only: its emitter hits ask [`Lights::area_pdf_w`],
    /// which knows the receiver. The bidirectional core's MIS recursion
    /// (SmallVCM's) stores a light point's next-event density in area
    /// measure when the light subpath leaves it, before any receiver exists,
    /// so it needs the receiver-free uniform area density.
    #[must_use]
    pub fn with_sphere_cones(mut self, scene: &Scene) -> Self {
        self.cones = self
            .lights
            .iter()
            .map(|light| match *light {
                Light::Sphere { sphere } => {
                    let s = &scene.spheres[sphere as usize];
                    (!s.inside).then_some(accel::Sphere {
                        center: s.center,
                        radius: s.radius,
                    })
                }
                _ => None,
            })
            .collect();
        self
    }

    /// True when the scene has no light.
    pub fn is_empty(&self) -> bool {
        self.lights.is_empty()
    }

    /// The radiance arriving from the environment along unit direction
    /// `d` (towards the environment), if the scene has one.
    #[inline]
    pub fn environment(&self, scene: &Scene, d: Vec3) -> Option<Vec3> {
        self.environment.map(|i| match self.lights[i as usize] {
            Light::Environment { radiance } => radiance,
            Light::EnvironmentMap { map } => scene
                .environment_maps
                .get(map as usize)
                .map_or(Vec3::ZERO, |m| m.radiance(d)),
            _ => Vec3::ZERO,
        })
    }

    /// Density in solid angle of the environment light's sampling technique
    /// for unit direction `d`, selection probability included (pmf / 4 pi
    /// for a constant environment).
    #[inline]
    pub fn environment_pdf(&self, scene: &Scene, d: Vec3) -> f32 {
        let Some(i) = self.environment else {
            return 0.0;
        };
        let pmf = self.pmf[i as usize];
        match &self.environment_map {
            Some((map, distribution)) => pmf * distribution.pdf(&scene.environment_maps[*map], d),
            None if matches!(self.lights[i as usize], Light::EnvironmentMap { .. }) => 0.0,
            None => pmf / (4.0 * PI),
        }
    }

    /// Density, in solid angle at `from`, with which [`Lights::sample`]
    /// produces the point `p` (normal `n`) of emissive primitive
    /// `primitive` (a triangle or sphere, see `SurfacePoint::primitive`):
    /// [`Lights::area_pdfs`]'s area density times d^2 / |cos|.
    #[inline]
    pub fn area_pdf_w(&self, primitive: u32, from: Vec3, p: Vec3, n: Vec3) -> f32 {
        if let Some(light) = self.sphere_light(primitive)
            && let Some(sphere) = &self.cones[light]
            && let Some(cone) = Cone::of(sphere, from)
        {
            return self.cone_pdf_w(light, &cone);
        }
        let d = p - from;
        let dist2 = d.length_squared();
        let cos = (n.dot(d) / dist2.sqrt()).abs();
        let pdf = self.area_pdfs(primitive, cos).direct_pdf * dist2 / cos;
        if pdf.is_finite() { pdf } else { 0.0 }
    }

    /// Next-event density in solid angle, selection included, of sphere
    /// light `light` sampled by its cone `cone`.
    fn cone_pdf_w(&self, light: usize, cone: &Cone) -> f32 {
        (f64::from(self.pmf[light]) * cone.pdf()) as f32
    }

    /// The light index of `primitive` when it is an emissive sphere.
    fn sphere_light(&self, primitive: u32) -> Option<usize> {
        if primitive < self.first_sphere {
            return None;
        }
        let light = *self.primitive_light.get(primitive as usize)?;
        (light != u32::MAX).then_some(light as usize)
    }

    /// The light chosen by `u_select` (in proportion to power) and its
    /// selection probability; `None` without lights or for a powerless one.
    fn select(&self, u_select: f32) -> Option<(usize, f32)> {
        let index = self
            .cdf
            .partition_point(|&c| c <= u_select)
            .min(self.lights.len().checked_sub(1)?);
        let pmf = self.pmf[index];
        (pmf > 0.0).then_some((index, pmf))
    }

    /// Samples a light for the receiver at `p` from `u_select` and `u`.
    /// `None` when the sample carries nothing (back side of an area light,
    /// outside a spot cone, no light).
    pub fn sample(&self, scene: &Scene, p: Vec3, u_select: f32, u: Vec2) -> Option<LightSample> {
        self.sample_chosen(scene, &self.choose(scene, u_select, u)?, p)
    }

    /// The part of [`Lights::sample`] that does not depend on the receiver:
    /// the light chosen by `u_select` and, on an area or sphere light, the
    /// point `u` gives. `None` without lights or for a powerless one.
    ///
    /// Camera subpaths draw it before the ray that finds the receiver, so
    /// that its dependent loads and square root overlap that ray's query.
    #[inline(always)]
    pub fn choose(&self, scene: &Scene, u_select: f32, u: Vec2) -> Option<LightChoice> {
        let (index, pmf) = self.select(u_select)?;
        let surface = match self.lights[index] {
            Light::Area { triangle } => Some(SurfaceSample {
                point: LightPoint {
                    p: uniform_triangle(scene.triangle(triangle as usize), u),
                    n: self.area_normal[index],
                    error: PointError::Vertices(self.area_scale[index]),
                    surface: triangle,
                },
                le: area_radiance(scene, triangle, u),
                primitive: triangle,
            }),
            // Sampled by its cone in `sample_chosen`, which needs the receiver.
            Light::Sphere { .. } if self.cones[index].is_some() => None,
            Light::Sphere { sphere } => {
                // A uniform point of the whole sphere (density 1 / 4 pi r^2
                // in area; the half facing away is rejected by
                // `sample_chosen`).
                let s = &scene.spheres[sphere as usize];
                let outward = uniform_sphere(u);
                let (p, error) = sphere_point(s, outward);
                Some(SurfaceSample {
                    point: LightPoint {
                        p,
                        n: if s.inside { -outward } else { outward },
                        error: PointError::Bounded(error),
                        surface: accel::NO_SURFACE,
                    },
                    le: sphere_radiance(scene, s, outward),
                    primitive: self.first_sphere + sphere,
                })
            }
            _ => None,
        };
        Some(LightChoice {
            index,
            pmf,
            u,
            surface,
        })
    }

    /// `choice` as [`Lights::sample_chosen`] reads it, when it is a point
    /// on an emissive triangle or a point light: what it computes from that
    /// for a receiver is simple enough to run for a batch of receivers at
    /// once (the path tracer's wavefront does).
    #[inline]
    pub fn point_target(&self, choice: &LightChoice) -> Option<PointTarget> {
        match self.lights[choice.index] {
            Light::Area { .. } => {
                let sample = choice.surface?;
                Some(PointTarget {
                    point: sample.point,
                    emitted: sample.le,
                    pdf: self.area_pdfs(sample.primitive, 0.0).direct_pdf,
                    delta: false,
                })
            }
            Light::Point {
                position,
                intensity,
            } => Some(PointTarget {
                point: delta_light_point(position),
                emitted: intensity,
                pdf: choice.pmf,
                delta: true,
            }),
            _ => None,
        }
    }

    /// [`Lights::sample`] of the light and point `choice`, for the receiver
    /// at `p`.
    #[inline]
    pub fn sample_chosen(
        &self,
        scene: &Scene,
        choice: &LightChoice,
        p: Vec3,
    ) -> Option<LightSample> {
        let LightChoice { index, pmf, u, .. } = *choice;
        let delta = |position: Vec3, intensity: Vec3| {
            let d = position - p;
            let dist2 = d.length_squared();
            let wi = d.try_normalize()?;
            Some(LightSample {
                wi,
                li: intensity / dist2,
                pdf: pmf,
                point: Some(delta_light_point(position)),
                is_delta: true,
                mis: EmitterPdfs {
                    kind: EmitterKind::Point,
                    direct_pdf: pmf * dist2,
                    emission_pdf_w: pmf * UNIFORM_SPHERE_PDF,
                    cos_light: 1.0,
                },
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
                let mis = EmitterPdfs {
                    emission_pdf_w: pmf * uniform_cone_pdf(cos_outer),
                    ..s.mis
                };
                LightSample {
                    li: s.li * falloff,
                    mis,
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
                mis: EmitterPdfs {
                    kind: EmitterKind::Directional,
                    direct_pdf: pmf,
                    emission_pdf_w: pmf / self.disk_area(),
                    cos_light: 1.0,
                },
            },
            Light::Environment { radiance } => LightSample {
                wi: uniform_sphere(u),
                li: radiance,
                pdf: pmf * UNIFORM_SPHERE_PDF,
                point: None,
                is_delta: false,
                mis: self.environment_pdfs_of(pmf / (4.0 * PI)),
            },
            Light::EnvironmentMap { .. } => {
                let (map, distribution) = self.environment_map.as_ref()?;
                let s = distribution.sample(&scene.environment_maps[*map], u)?;
                LightSample {
                    wi: s.direction,
                    li: s.radiance,
                    pdf: pmf * s.pdf,
                    point: None,
                    is_delta: false,
                    mis: self.environment_pdfs_of(pmf * s.pdf),
                }
            }
            Light::Sphere { sphere } if self.cones[index].is_some() => {
                self.sample_cone(scene, sphere, index, u, p)?
            }
            Light::Area { .. } | Light::Sphere { .. } => {
                let SurfaceSample {
                    point,
                    le,
                    primitive,
                } = choice.surface?;
                let wi = (point.p - p).try_normalize()?;
                if point.n.dot(-wi) <= 0.0 {
                    return None; // One-sided emitter seen from behind.
                }
                let pdf = self.area_pdf_w(primitive, p, point.p, point.n);
                if pdf <= 0.0 {
                    return None;
                }
                LightSample {
                    wi,
                    li: le,
                    pdf,
                    point: Some(point),
                    is_delta: false,
                    mis: self.area_pdfs(primitive, point.n.dot(-wi)),
                }
            }
        };
        (sample.li.max_element() > 0.0 && sample.pdf.is_finite()).then_some(sample)
    }

    /// Next-event estimation of sphere light `index` (sphere `sphere`) by its
    /// cone from the receiver `p` ([`Lights::with_sphere_cones`]); by area,
    /// as without cones, when `p` is at (or in) the sphere.
    fn sample_cone(
        &self,
        scene: &Scene,
        sphere: u32,
        index: usize,
        u: Vec2,
        p: Vec3,
    ) -> Option<LightSample> {
        let s = &scene.spheres[sphere as usize];
        let cone = Cone::of(self.cones[index].as_ref()?, p);
        let outward = match &cone {
            Some(cone) => cone.sample(u).as_vec3(),
            None => uniform_sphere(u),
        };
        let (point, error) = sphere_point(s, outward);
        let wi = (point - p).try_normalize()?;
        let cos_light = outward.dot(-wi);
        if cos_light <= 0.0 {
            return None;
        }
        // The density emitter hits are weighted with (`area_pdf_w`).
        let primitive = self.first_sphere + sphere;
        let pdf = match &cone {
            Some(cone) => self.cone_pdf_w(index, cone),
            None => self.area_pdf_w(primitive, p, point, outward),
        };
        let mut mis = self.area_pdfs(primitive, cos_light);
        mis.direct_pdf = pdf * cos_light / (point - p).length_squared();
        Some(LightSample {
            wi,
            li: sphere_radiance(scene, s, outward),
            pdf,
            point: Some(LightPoint {
                p: point,
                n: outward,
                error: PointError::Bounded(error),
                surface: accel::NO_SURFACE,
            }),
            is_delta: false,
            mis,
        })
    }

    /// Area of the disk (the scene's bounding sphere's cross-section) from
    /// which lights at infinity emit.
    fn disk_area(&self) -> f32 {
        PI * self.scene_radius * self.scene_radius
    }

    /// MIS pdfs of the point of emissive primitive `primitive` (triangle
    /// or sphere) seen at cosine `cos_light` (towards the other vertex):
    /// the one area density of every technique that reaches an area light.
    #[inline]
    pub fn area_pdfs(&self, primitive: u32, cos_light: f32) -> EmitterPdfs {
        let pdf_a = self
            .primitive_light
            .get(primitive as usize)
            .filter(|&&l| l != u32::MAX)
            .map_or(0.0, |&l| self.area_pdf_a[l as usize]);
        EmitterPdfs {
            kind: EmitterKind::Area,
            direct_pdf: pdf_a,
            emission_pdf_w: pdf_a * cos_light.abs() / PI,
            cos_light: cos_light.abs(),
        }
    }

    /// MIS pdfs of the environment light for unit direction `d` (towards
    /// the environment).
    #[inline]
    pub fn environment_pdfs(&self, scene: &Scene, d: Vec3) -> EmitterPdfs {
        self.environment_pdfs_of(self.environment_pdf(scene, d))
    }

    /// MIS pdfs of an environment direction whose next-event density
    /// (selection included) is `direct_pdf`: emission adds the uniform
    /// point of the disk the light enters the scene through.
    fn environment_pdfs_of(&self, direct_pdf: f32) -> EmitterPdfs {
        EmitterPdfs {
            kind: EmitterKind::Environment,
            direct_pdf,
            emission_pdf_w: direct_pdf / self.disk_area(),
            cos_light: 1.0,
        }
    }

    /// Samples a ray leaving a light (the start of a light subpath) from
    /// `u_select`, `u_position` and `u_direction`: area lights emit
    /// cosine-distributed from a uniform point, point lights uniformly, spot
    /// lights uniformly in their outer cone, lights at infinity parallel rays
    /// through a disk covering the scene (SmallVCM's emitters). `None` when
    /// the sample carries nothing.
    pub fn sample_emission(
        &self,
        scene: &Scene,
        u_select: f32,
        u_position: Vec2,
        u_direction: Vec2,
    ) -> Option<Emission> {
        let (index, pmf) = self.select(u_select)?;
        let centre = self.scene_centre;
        // A ray entering the scene's bounding sphere along `d`, from a
        // uniform point of the disk facing it.
        let from_disk = |d: Vec3| {
            let frame = crate::geometry::Frame::from_normal(d);
            let disk = concentric_disk(u_position) * self.scene_radius;
            centre + frame.s * disk.x + frame.t * disk.y - d * self.scene_radius
        };
        let emission = match self.lights[index] {
            Light::Point {
                position,
                intensity,
            } => Emission {
                origin: position,
                direction: uniform_sphere(u_direction),
                throughput: intensity / (pmf * UNIFORM_SPHERE_PDF),
                mis: EmitterPdfs {
                    kind: EmitterKind::Point,
                    direct_pdf: pmf,
                    emission_pdf_w: pmf * UNIFORM_SPHERE_PDF,
                    cos_light: 1.0,
                },
            },
            Light::Spot {
                position,
                direction,
                intensity,
                cos_inner,
                cos_outer,
            } => {
                let local = uniform_cone(u_direction, cos_outer);
                let emission_pdf_w = pmf * uniform_cone_pdf(cos_outer);
                Emission {
                    origin: position,
                    direction: crate::geometry::Frame::from_normal(direction).to_world(local),
                    throughput: intensity * spot_falloff(local.z, cos_inner, cos_outer)
                        / emission_pdf_w,
                    mis: EmitterPdfs {
                        kind: EmitterKind::Point,
                        direct_pdf: pmf,
                        emission_pdf_w,
                        cos_light: 1.0,
                    },
                }
            }
            Light::Directional {
                direction,
                irradiance,
            } => {
                let emission_pdf_w = pmf / self.disk_area();
                Emission {
                    origin: from_disk(direction),
                    direction,
                    throughput: irradiance / emission_pdf_w,
                    mis: EmitterPdfs {
                        kind: EmitterKind::Directional,
                        direct_pdf: pmf,
                        emission_pdf_w,
                        cos_light: 1.0,
                    },
                }
            }
            Light::Environment { radiance } => {
                let direction = -uniform_sphere(u_direction);
                let mis = self.environment_pdfs_of(pmf / (4.0 * PI));
                Emission {
                    origin: from_disk(direction),
                    direction,
                    throughput: radiance / mis.emission_pdf_w,
                    mis,
                }
            }
            Light::EnvironmentMap { .. } => {
                // A direction from the map's distribution, entering through
                // the disk facing it (pbrt-v4 `ImageInfiniteLight::SampleLe`,
                // SmallVCM's background light): density pdf_w / (pi r^2).
                let (map, distribution) = self.environment_map.as_ref()?;
                let s = distribution.sample(&scene.environment_maps[*map], u_direction)?;
                let direction = -s.direction;
                let mis = self.environment_pdfs_of(pmf * s.pdf);
                Emission {
                    origin: from_disk(direction),
                    direction,
                    throughput: s.radiance / mis.emission_pdf_w,
                    mis,
                }
            }
            Light::Area { triangle } => {
                let p = uniform_triangle(scene.triangle(triangle as usize), u_position);
                let n = self.area_normal[index];
                let local = cosine_hemisphere(u_direction);
                if local.z <= 0.0 {
                    return None;
                }
                let mis = self.area_pdfs(triangle, local.z);
                Emission {
                    origin: accel::offset_ray_origin_scaled(p, n, self.area_scale[index]),
                    direction: crate::geometry::Frame::from_normal(n).to_world(local),
                    throughput: area_radiance(scene, triangle, u_position) * local.z
                        / mis.emission_pdf_w,
                    mis,
                }
            }
            Light::Sphere { sphere } => {
                // A uniform point of the sphere, a cosine-distributed
                // direction around its emitting normal.
                let s = &scene.spheres[sphere as usize];
                let outward = uniform_sphere(u_position);
                let (p, error) = sphere_point(s, outward);
                let n = if s.inside { -outward } else { outward };
                let local = cosine_hemisphere(u_direction);
                if local.z <= 0.0 {
                    return None;
                }
                let mis = self.area_pdfs(self.first_sphere + sphere, local.z);
                Emission {
                    origin: accel::offset_ray_origin_bounded(p, n, error),
                    direction: crate::geometry::Frame::from_normal(n).to_world(local),
                    throughput: sphere_radiance(scene, s, outward) * local.z / mis.emission_pdf_w,
                    mis,
                }
            }
        };
        (emission.throughput.is_finite() && emission.throughput.max_element() > 0.0)
            .then_some(emission)
    }
}

/// A uniformly distributed point of triangle [a, b, c] (square-root
/// parametrisation, pbrt-v4 `SampleUniformTriangle`'s classic form).
pub fn uniform_triangle([a, b, c]: [Vec3; 3], u: Vec2) -> Vec3 {
    let (b1, b2) = uniform_triangle_barycentrics(u);
    a * (1.0 - b1 - b2) + b * b1 + c * b2
}

/// The barycentrics (b1, b2) of the point [`uniform_triangle`] samples from `u`.
pub fn uniform_triangle_barycentrics(u: Vec2) -> (f32, f32) {
    let su = u.x.sqrt();
    (u.y * su, 1.0 - su)
}

/// Radiance emitted at the point of emissive triangle `triangle` sampled
/// from `u` ([`uniform_triangle`]): the material's factor, times its
/// emissive texture and its alpha coverage there when it has them. The
/// triangle was chosen by its factor's power, so a texel darker than the
/// factor only lowers the sample's value: the estimator stays unbiased.
/// Coverage enters as a factor: a cut-out part emits nothing, a blended
/// one alpha times the radiance (what a ray reaching it sees on average).
#[inline(always)]
fn area_radiance(scene: &Scene, triangle: u32, u: Vec2) -> Vec3 {
    let material = &scene.materials[scene.triangle_materials[triangle as usize] as usize];
    if material.maps.emission.is_none() && material.maps.alpha.is_opaque() {
        material.emission
    } else {
        mapped_area_radiance(scene, material, triangle as usize, u)
    }
}

/// [`area_radiance`] of a material with an emissive texture or alpha (out
/// of line: untextured lights stay a lookup).
#[inline(never)]
fn mapped_area_radiance(scene: &Scene, material: &scene::Material, i: usize, u: Vec2) -> Vec3 {
    let (b1, b2) = uniform_triangle_barycentrics(u);
    let [t0, t1, t2] = scene.triangle_uvs(i);
    let uv = t0 * (1.0 - b1 - b2) + t1 * b1 + t2 * b2;
    material.emission_at(uv, &scene.textures) * material.maps.alpha.coverage(uv, &scene.textures)
}

/// The point of sphere `s` in outward unit direction `n` and its error
/// bound (`accel::Sphere::point_at`).
fn sphere_point(s: &scene::Sphere, n: Vec3) -> (Vec3, Vec3) {
    accel::Sphere {
        center: s.center,
        radius: s.radius,
    }
    .point_at(n)
}

/// The light point of a point or spot light at `position`: no surface, no
/// normal, and no error bound (a shadow ray ends exactly there).
fn delta_light_point(position: Vec3) -> LightPoint {
    LightPoint {
        p: position,
        n: Vec3::ZERO,
        error: PointError::Vertices(f32::INFINITY),
        surface: accel::NO_SURFACE,
    }
}

/// Radiance emitted by sphere `s` at its point in outward direction `n`:
/// the material's factor, times its emissive texture at the point's uv
/// when it has one (chosen by the factor's power, as triangles are; alpha
/// does not apply to spheres).
fn sphere_radiance(scene: &Scene, s: &scene::Sphere, n: Vec3) -> Vec3 {
    let material = &scene.materials[s.material as usize];
    match material.maps.emission {
        None => material.emission,
        Some(_) => material.emission_at(s.uv(n), &scene.textures),
    }
}

/// Density of [`uniform_sphere`]: 1 / (4 pi).
pub const UNIFORM_SPHERE_PDF: f32 = 1.0 / (4.0 * PI);

/// Density of [`uniform_cone`] with opening cosine `cos_max`.
pub fn uniform_cone_pdf(cos_max: f32) -> f32 {
    1.0 / (2.0 * PI * (1.0 - cos_max).max(f32::MIN_POSITIVE))
}

/// A direction uniformly distributed in the cone around +z with opening
/// cosine `cos_max`.
pub fn uniform_cone(u: Vec2, cos_max: f32) -> Vec3 {
    let z = 1.0 - u.x * (1.0 - cos_max);
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (sin_phi, cos_phi) = sin_cos_turns(u.y);
    Vec3::new(r * cos_phi, r * sin_phi, z)
}

/// Shirley-Chiu concentric map of the unit square onto the unit disk.
pub fn concentric_disk(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o == Vec2::ZERO {
        return Vec2::ZERO;
    }
    let (r, theta) = if o.x.abs() > o.y.abs() {
        (o.x, 0.25 * PI * (o.y / o.x))
    } else {
        (o.y, 0.5 * PI - 0.25 * PI * (o.x / o.y))
    };
    r * Vec2::new(theta.cos(), theta.sin())
}

/// A cosine-distributed direction around +z (density cos / pi).
pub fn cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = concentric_disk(u);
    Vec3::new(d.x, d.y, (1.0 - d.length_squared()).max(0.0).sqrt())
}

/// A uniformly distributed unit vector from two uniforms.
pub fn uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (sin_phi, cos_phi) = sin_cos_turns(u.y);
    Vec3::new(r * cos_phi, r * sin_phi, z)
}
