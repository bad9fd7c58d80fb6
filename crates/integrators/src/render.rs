//! The renderer: a scene prepared once ([`SceneContext`]) and the
//! integrator of the configuration, rendering iterations into a film.
//!
//! Modules depend downwards only: `render` -> `bidir` -> `pt` -> `nee`,
//! `walk` -> `roulette`, `vertex` -> `context` -> `lights`, `camera`,
//! `geometry`, `sampler`; each integrator implements `Integrator`.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use glam::Vec3;
use microfacet::compensation::EnergyTable;
use mis::Techniques;
use rayon::prelude::*;
use regularization::{Energy, Mode};
use scene::{Scene, SceneFeatures};

use crate::bidir::{Bidirectional, ProgressivePhotonMapper};
use crate::config::{Algorithm, RenderConfig};
use crate::context::SceneContext;
use crate::film::Film;
use crate::integrator::{Integrator, Stop};
use crate::merge_radius::MergeRadius;
use crate::pt::PathTracer;

/// The integrator of a configuration: a new algorithm is a new file with
/// a type that implements `Integrator`, and one arm here.
#[derive(Clone, Debug)]
pub enum AnyIntegrator {
    /// Path tracing (`pt`).
    PathTracer(PathTracer),
    /// The bidirectional core (`bpt`, `bpm`, `vcm`).
    Bidirectional(Bidirectional),
    /// Progressive photon mapping (`ppm`).
    ProgressivePhotonMapper(ProgressivePhotonMapper),
}

impl AnyIntegrator {
    /// The integrator of `ctx.config.algorithm`.
    pub fn new(ctx: &SceneContext) -> Self {
        match ctx.config.algorithm {
            Algorithm::Pt => {
                Self::PathTracer(PathTracer::new(ctx.config.strategies, ctx.config.wavefront))
            }
            Algorithm::Bpt | Algorithm::Bpm | Algorithm::Vcm => {
                Self::Bidirectional(Bidirectional::new(ctx))
            }
            Algorithm::Ppm => Self::ProgressivePhotonMapper(ProgressivePhotonMapper::new(ctx)),
        }
    }
}

impl Integrator for AnyIntegrator {
    fn render_iteration(&self, ctx: &SceneContext, n: u64, estimates: &mut [Vec3], stop: Stop<'_>) {
        match self {
            Self::PathTracer(pt) => pt.render_iteration(ctx, n, estimates, stop),
            Self::Bidirectional(bidir) => bidir.render_iteration(ctx, n, estimates, stop),
            Self::ProgressivePhotonMapper(ppm) => ppm.render_iteration(ctx, n, estimates, stop),
        }
    }
}

/// A scene ready to render with one configuration.
pub struct Renderer {
    ctx: SceneContext,
    integrator: AnyIntegrator,
    /// Samples that were NaN or infinite and were dropped (set to zero).
    invalid_samples: AtomicU64,
}

impl Renderer {
    /// Prepares `scene` (builds the BVH on the current rayon pool).
    pub fn new(scene: Scene, config: RenderConfig) -> Self {
        let ctx = SceneContext::new(scene, config);
        Self {
            integrator: AnyIntegrator::new(&ctx),
            ctx,
            invalid_samples: AtomicU64::new(0),
        }
    }

    /// Renders iteration `iteration` (1-based; it drives tau_N and the merge
    /// radius and selects the random streams) into `estimates`: one
    /// estimate per pixel, row-major. NaN and infinite estimates are
    /// replaced by zero and counted ([`Renderer::invalid_samples`]).
    /// Parallel on the current rayon pool; the result does not depend on
    /// the number of threads.
    ///
    /// # Panics
    /// If `estimates` does not have one entry per pixel.
    pub fn render_iteration(&self, iteration: u64, estimates: &mut [Vec3]) {
        self.render_iteration_unless(iteration, estimates, Stop::NEVER);
    }

    /// [`Renderer::render_iteration`], abandoned within about one block of
    /// work (an image row, 256 subpaths) once `stop` is set: returns false
    /// when the iteration did not complete, and `estimates` must then be
    /// discarded. For interrupts: at 4K one iteration can take a minute.
    pub fn render_iteration_until(
        &self,
        iteration: u64,
        estimates: &mut [Vec3],
        stop: &AtomicBool,
    ) -> bool {
        self.render_iteration_unless(iteration, estimates, Stop::when(stop))
    }

    fn render_iteration_unless(
        &self,
        iteration: u64,
        estimates: &mut [Vec3],
        stop: Stop<'_>,
    ) -> bool {
        let (width, height) = self.resolution();
        assert_eq!(estimates.len(), width as usize * height as usize);
        self.integrator
            .render_iteration(&self.ctx, iteration, estimates, stop);
        if stop.requested() {
            return false;
        }
        let mut invalid = 0;
        for e in estimates.iter_mut().filter(|e| !e.is_finite()) {
            *e = Vec3::ZERO;
            invalid += 1;
        }
        if invalid > 0 {
            self.invalid_samples.fetch_add(invalid, Ordering::Relaxed);
        }
        true
    }

    /// Renders iterations `first..first + count` into `film`.
    pub fn render(&self, film: &mut Film, first: u64, count: u64) {
        let mut estimates = vec![Vec3::ZERO; film.width() as usize * film.height() as usize];
        for n in first..first + count {
            self.render_iteration(n, &mut estimates);
            film.add_iteration(&estimates);
        }
    }

    /// Runs the SIMD kernels (the BVH's and the path tracer's lanes) on
    /// `isa` instead of the CPU's best instruction set; returns `false`,
    /// changing nothing, when the CPU lacks it. Images are the same on
    /// every one (for measuring, and for the tests that show it).
    pub fn set_isa(&mut self, isa: accel::Isa) -> bool {
        self.ctx.bvh.set_isa(isa)
    }

    /// The prepared scene: geometry, lights, camera, settings.
    pub fn context(&self) -> &SceneContext {
        &self.ctx
    }

    /// The scene.
    pub fn scene(&self) -> &Scene {
        &self.ctx.scene
    }

    /// The configuration.
    pub fn config(&self) -> &RenderConfig {
        &self.ctx.config
    }

    /// What the scene contains.
    pub fn features(&self) -> &SceneFeatures {
        &self.ctx.features
    }

    /// Image size (width, height).
    pub fn resolution(&self) -> (u32, u32) {
        self.ctx.resolution()
    }

    /// An empty film of the image size.
    pub fn new_film(&self) -> Film {
        let (w, h) = self.resolution();
        Film::new(w, h)
    }

    /// The MIS techniques of the bidirectional core (BPT, BPM, VCM: VCM
    /// without merging on a scene where merging cannot help); `None` for
    /// the path tracer and the photon mapper, which weight nothing.
    pub fn techniques(&self) -> Option<Techniques> {
        match &self.integrator {
            AnyIntegrator::Bidirectional(core) => Some(core.techniques()),
            AnyIntegrator::PathTracer(_) | AnyIntegrator::ProgressivePhotonMapper(_) => None,
        }
    }

    /// The mean pixel value of a small path-traced preview, the scale of
    /// the shadow-ray roulette threshold; 0 when the roulette is off.
    pub fn shadow_roulette_scale(&self) -> f32 {
        match &self.integrator {
            AnyIntegrator::Bidirectional(core) => core.pixel_scale(),
            AnyIntegrator::PathTracer(_) | AnyIntegrator::ProgressivePhotonMapper(_) => 0.0,
        }
    }

    /// An estimate of the photon map's memory in one iteration, in bytes
    /// (from a few pilot light subpaths; 0 for integrators without one).
    pub fn photon_map_bytes(&self) -> u64 {
        match &self.integrator {
            AnyIntegrator::Bidirectional(core) => core.photon_map_bytes(&self.ctx),
            AnyIntegrator::ProgressivePhotonMapper(ppm) => ppm.photon_map_bytes(&self.ctx),
            AnyIntegrator::PathTracer(_) => 0,
        }
    }

    /// The merge-radius rule, fixed when the renderer is made.
    pub fn merge_radius_rule(&self) -> &MergeRadius {
        &self.ctx.merge_radius
    }

    /// Merge radius of iteration `n` (SPEC §7; see [`MergeRadius`]).
    pub fn merge_radius(&self, n: u64) -> f32 {
        self.ctx.merge_radius.at(n)
    }

    /// tau_N at iteration `n` (infinity when regularization is off).
    pub fn tau_at(&self, n: u64) -> f64 {
        self.ctx.tau_at(n)
    }

    /// True when regularization with bound `tau` can raise the roughness of
    /// some surface of the scene (see [`SceneContext::regularization_matters`]).
    pub fn regularization_matters(&self, tau: f64) -> bool {
        self.ctx.regularization_matters(tau)
    }

    /// True when iteration `n` will read the energy-compensation tables
    /// that `prepare_energy_tables` builds: the energy is preserved and the
    /// rule widens every lobe tau_n binds (`uniform`, `selective`, and
    /// `unsampleable` in PT, which applies it as `selective`), and tau_n
    /// binds some lobe of the scene (`regularization_matters`). Under
    /// `unsampleable` the bidirectional methods widen a lobe only on paths
    /// that no technique samples, which a scene may not have (VCM on
    /// caustic-glass widens none); their tables are built at first use.
    pub fn reads_energy_tables(&self, n: u64) -> bool {
        let regularization = &self.ctx.config.regularization;
        let widens_where_bound = match regularization.mode {
            Mode::Off => false,
            Mode::Uniform | Mode::Selective => true,
            Mode::Unsampleable => self.ctx.config.algorithm == Algorithm::Pt,
        };
        widens_where_bound
            && regularization.energy == Energy::Preserved
            && self.regularization_matters(regularization.tau_at(n))
    }

    /// Builds now, in parallel, the energy-compensation tables
    /// (`microfacet::compensation::EnergyTable`) of every lobe of the scene
    /// that regularization may widen; nothing when it is off or loses
    /// energy. Otherwise each table is built at its first use, inside the
    /// first iteration that widens such a lobe (seconds each:
    /// `microfacet::compensation::tables` gives the cost), so timed
    /// comparisons call this first: no configuration then pays
    /// for tables in its measured time, whichever ran before it in the
    /// process. Returns the number of tables (or slices) it asked for,
    /// built now or before.
    pub fn prepare_energy_tables(&self) -> usize {
        let tables = self.energy_tables();
        // The albedo tables first, the gain scalings (which read them) next.
        let (albedos, gains): (Vec<_>, Vec<_>) = tables.iter().partition(|t| !t.reads_albedos());
        for phase in [albedos, gains] {
            phase.into_par_iter().for_each(EnergyTable::build);
        }
        tables.len()
    }

    /// How many of the tables that `prepare_energy_tables` would build are
    /// built now (by it, or at first use in an iteration): a caller compares
    /// before and after a render whose tables were left to first use
    /// (`reads_energy_tables` false), to say where their time went.
    pub fn energy_tables_built(&self) -> usize {
        self.energy_tables()
            .into_iter()
            .filter(|table| table.is_built())
            .count()
    }

    /// The energy-compensation tables of every lobe of the scene that
    /// regularization may widen, each once; none when it is off or loses
    /// energy.
    fn energy_tables(&self) -> Vec<EnergyTable> {
        let regularization = &self.ctx.config.regularization;
        if regularization.mode == Mode::Off || regularization.energy == Energy::Lost {
            return Vec::new();
        }
        let mut tables = Vec::new();
        for material in &self.ctx.scene.materials {
            let surface = &material.surface;
            let Some(model) = surface.microfacet() else {
                continue;
            };
            let (kind, shadowing) = (model.ndf.kind(), model.shadowing);
            if !matches!(surface, scene::Surface::Dielectric { .. }) {
                tables.extend(EnergyTable::of_reflection(kind, shadowing));
            }
            if surface.may_transmit() {
                let eta = match *surface {
                    scene::Surface::Dielectric { ior, .. } => ior,
                    scene::Surface::Textured(pbr) => pbr.ior,
                    _ => 1.0,
                };
                tables.extend(EnergyTable::of_interface(kind, shadowing, eta));
            }
        }
        let mut seen = std::collections::HashSet::new();
        tables.retain(|t| seen.insert(*t));
        tables
    }

    /// Number of samples so far that were NaN or infinite and were replaced
    /// by zero (a correct renderer keeps this at 0; tests assert it).
    pub fn invalid_samples(&self) -> u64 {
        self.invalid_samples.load(Ordering::Relaxed)
    }

    /// Rays traced so far (camera, light, continuation and shadow rays), for
    /// throughput figures (`cargo xtask bench`).
    pub fn rays_traced(&self) -> u64 {
        self.ctx.rays_traced()
    }
}
