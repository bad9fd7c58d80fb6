//! What a scene contains, so integrators and the CLI can leave out work the
//! scene does not need: a scene pays only for what it uses.

use std::fmt;

use microfacet::SMOOTH_ALPHA;

use crate::light::Light;
use crate::material::Surface;
use crate::scene::Scene;

/// Materials with alpha below this are "near-specular": the ones
/// regularization helps most (a lobe narrower than about 6 degrees).
pub const NEAR_SPECULAR_ALPHA: f32 = 0.1;

/// Summary of a scene's content.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SceneFeatures {
    /// Triangle count.
    pub triangles: usize,
    /// Analytic sphere count.
    pub spheres: usize,
    /// Materials used by at least one triangle or sphere.
    pub materials: usize,
    /// Textures.
    pub textures: usize,
    /// Emissive triangles and spheres.
    pub area_lights: usize,
    /// Point, spot and directional lights.
    pub delta_lights: usize,
    /// An environment light (constant or map) is present.
    pub environment: bool,
    /// The environment is an image map.
    pub environment_map: bool,
    /// A used material refracts.
    pub transmission: bool,
    /// Smallest microfacet alpha among used materials (None: all diffuse).
    pub smallest_alpha: Option<f32>,
    /// Used materials that are delta lobes (alpha below `SMOOTH_ALPHA`).
    pub specular_materials: usize,
    /// Used materials with alpha below `NEAR_SPECULAR_ALPHA` (including specular ones).
    pub near_specular_materials: usize,
    /// A used material is textured.
    pub textured: bool,
    /// Zero-area triangles skipped while loading.
    pub degenerate_triangles: usize,
}

impl SceneFeatures {
    /// Analyses `scene`.
    pub fn of(scene: &Scene) -> Self {
        let mut used = vec![false; scene.materials.len()];
        for &m in &scene.triangle_materials {
            used[m as usize] = true;
        }
        for s in &scene.spheres {
            used[s.material as usize] = true;
        }
        let mut f = SceneFeatures {
            triangles: scene.triangles.len(),
            spheres: scene.spheres.len(),
            textures: scene.textures.len(),
            degenerate_triangles: scene.report.degenerate_triangles,
            ..Default::default()
        };
        for light in &scene.lights {
            match light {
                Light::Area { .. } | Light::Sphere { .. } => f.area_lights += 1,
                Light::Environment { .. } => f.environment = true,
                Light::EnvironmentMap { .. } => {
                    f.environment = true;
                    f.environment_map = true;
                }
                _ => f.delta_lights += 1,
            }
        }
        for (material, _) in scene.materials.iter().zip(&used).filter(|(_, u)| **u) {
            f.materials += 1;
            let thin = matches!(material.surface, Surface::ThinDielectric { .. });
            f.transmission |= material.surface.may_transmit() || thin;
            // A thin sheet is a delta lobe without a roughness.
            f.specular_materials += usize::from(thin);
            f.textured |= matches!(material.surface, Surface::Textured(_));
            if let Some(model) = material.surface.microfacet() {
                let alpha = model.alpha();
                f.smallest_alpha = Some(f.smallest_alpha.map_or(alpha, |a: f32| a.min(alpha)));
                f.specular_materials += usize::from(alpha < SMOOTH_ALPHA);
                f.near_specular_materials += usize::from(alpha < NEAR_SPECULAR_ALPHA);
            }
        }
        f
    }

    /// True when some used surface is sharper than `alpha_tau`, i.e. when
    /// regularization with that bound would change anything.
    pub fn regularization_matters(&self, alpha_tau: f32) -> bool {
        self.smallest_alpha.is_some_and(|a| a < alpha_tau)
    }
}

impl fmt::Display for SceneFeatures {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "triangles:        {} ({} degenerate skipped), analytic spheres: {}",
            self.triangles, self.degenerate_triangles, self.spheres
        )?;
        writeln!(
            f,
            "materials:        {} used, {} textures{}",
            self.materials,
            self.textures,
            if self.textured { " (textured)" } else { "" }
        )?;
        writeln!(
            f,
            "lights:           {} emissive triangles or spheres, {} point/spot/directional, environment: {}",
            self.area_lights,
            self.delta_lights,
            match (self.environment, self.environment_map) {
                (true, true) => "map",
                (true, false) => "constant",
                _ => "no",
            }
        )?;
        writeln!(
            f,
            "transmission:     {}",
            if self.transmission { "yes" } else { "no" }
        )?;
        match self.smallest_alpha {
            Some(a) => write!(
                f,
                "smallest alpha:   {a} ({} specular, {} near-specular materials)",
                self.specular_materials, self.near_specular_materials
            ),
            None => write!(f, "smallest alpha:   none (all diffuse)"),
        }
    }
}
