//! Materials: what a surface does to light, as `microfacet` lobes, plus emission.
//!
//! # Mapping from the file formats
//!
//! glTF 2.0 metallic-roughness (per material, or per texel when textured):
//! - `alpha = roughness^2` (glTF's perceptual roughness r).
//! - `KHR_materials_transmission` factor > 0: a rough or smooth dielectric with
//!   index `KHR_materials_ior` (glTF default 1.5). Base colour tint, the
//!   transmission texture and `KHR_materials_volume` are not used.
//! - otherwise: the coated lobe (`microfacet::Coated`, Appendix B's BRDF):
//!   base colour, metallic as the mix weight of the metal, the coat's index
//!   from `KHR_materials_ior` (1.5) and its strength and F0 colour from
//!   `KHR_materials_specular` (specularFactor, specularColorFactor: 1; their
//!   textures are not used). A material with metallic 0 and specularFactor 0
//!   is Lambertian (the lobe reduces to it, and a Lambertian vertex has no
//!   roughness for regularization to change).
//! - emission = emissiveFactor x `KHR_materials_emissive_strength`; emissive
//!   textures are not used. Material `extras` may choose `"ndf"`
//!   (`"ggx"` default, `"beckmann"`, `"blinn-phong"`) and `"shadowing"`
//!   (`"smith"` default, `"v-cavity"`).
//!
//! OBJ/MTL:
//! - `illum 5` (mirror): conductor, F0 = Ks, alpha from `Pr` (r^2) or 0;
//!   `illum 7` (glass): dielectric with index `Ni` (1.5 if absent), alpha from `Pr` or 0.
//! - `Pm` >= 0.5: conductor with F0 = Kd and alpha = Pr^2.
//! - `d` < 1 (or `Tr` > 0): dielectric, as `illum 7`. `Tf` is ignored (real files
//!   put it on opaque materials, lights included).
//! - max(Ks) > 0 (and not one of the above): the coated lobe with a
//!   Blinn-Phong NDF of alpha = sqrt(2 / (Ns + 2)) (supp. eq. 5; Ns 0 if
//!   absent), base Kd, metallic 0, and a coat whose F0 is Ks: Phong's Ks is
//!   the specular reflectance at normal incidence, which is what F0 means.
//!   Expressed in glTF's terms: specularFactor 1, ior 1.5 and
//!   specularColor = Ks / 0.04 (0.04 the F0 of ior 1.5; `Ni` is not used
//!   for opaque materials, where real files often write 1, which would make
//!   F0 = 0). The coat's Fresnel brightens Ks towards grazing angles, and
//!   the base loses what the coat reflects (energy stays <= 1; Kd + Ks <= 1
//!   only approximated that). `map_Ks` (sRGB) multiplies Ks per texel and
//!   `map_Ns` (a scalar texture, linear) multiplies Ns before the alpha
//!   above; both only where the material has Ks (a warning otherwise).
//! - otherwise Lambertian Kd.
//! - `Ke`: emission. `map_Kd`: base colour texture (sRGB).
//!
//! Emission is one-sided, on the side the geometric normal (counter-clockwise
//! winding) points to.

use glam::{Vec2, Vec3};
use microfacet::{
    Bsdf, Coated, Conductor, Dielectric, Fresnel, Lambertian, MicrofacetModel, NdfKind, Shadowing,
};

use crate::texture::Texture;

/// How a surface scatters light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Surface {
    /// Ideal diffuse reflection.
    Diffuse {
        /// Albedo per channel, in [0, 1].
        reflectance: Vec3,
    },
    /// Metal.
    Conductor {
        /// NDF, shadowing and alpha.
        model: MicrofacetModel,
        /// Reflectance model.
        fresnel: Fresnel,
    },
    /// Glass-like interface; `ior` is the index inside (behind the geometric normal).
    Dielectric {
        /// NDF, shadowing and alpha.
        model: MicrofacetModel,
        /// Index of refraction of the inside, > 0 (outside is 1).
        ior: f32,
    },
    /// glTF metallic-roughness: a specular coat over a diffuse base, mixed
    /// with a metal (the module docs' mapping).
    Coated(Coated),
    /// glTF metallic-roughness resolved per shading point from textures.
    Textured(TexturedPbr),
}

/// glTF metallic-roughness factors with their textures (indices into
/// `Scene::textures`); mapped to a lobe per texel as the module docs say.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TexturedPbr {
    /// Base colour factor (linear).
    pub base_color: Vec3,
    /// Base colour texture (sRGB-decoded), multiplied with the factor.
    pub base_color_texture: Option<usize>,
    /// Metallic factor.
    pub metallic: f32,
    /// Roughness factor (perceptual).
    pub roughness: f32,
    /// Metallic-roughness texture: roughness in G, metallic in B.
    pub metallic_roughness_texture: Option<usize>,
    /// `KHR_materials_specular` specularFactor (0 for an OBJ diffuse texture).
    pub specular: f32,
    /// `KHR_materials_specular` specularColorFactor.
    pub specular_color: Vec3,
    /// `KHR_materials_ior` index of the coat.
    pub ior: f32,
    /// Specular colour texture (sRGB-decoded), multiplied with
    /// `specular_color`: MTL `map_Ks`.
    pub specular_color_texture: Option<usize>,
    /// MTL `map_Ns`: the exponent Ns and a scalar texture (red, linear) that
    /// multiplies it; the roughness is then that of alpha =
    /// sqrt(2 / (Ns t + 2)) (supp. eq. 5), in place of `roughness`.
    pub shininess_texture: Option<(f32, usize)>,
    /// NDF and shadowing of the microfacet lobes.
    pub ndf: NdfKind,
    /// Shadowing model.
    pub shadowing: Shadowing,
}

/// A named material.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// Name from the file (or generated), for overrides and error messages.
    pub name: String,
    /// Scattering.
    pub surface: Surface,
    /// Emitted radiance (W sr^-1 m^-2 per channel), zero for non-emitters.
    pub emission: Vec3,
}

impl Material {
    /// True when the material emits light.
    pub fn is_emissive(&self) -> bool {
        self.emission.max_element() > 0.0
    }
}

impl Surface {
    /// The lobe at texture coordinate `uv`.
    pub fn bsdf(&self, uv: Vec2, textures: &[Texture]) -> Bsdf {
        match *self {
            Surface::Diffuse { reflectance } => Bsdf::Lambertian(Lambertian { reflectance }),
            Surface::Conductor { model, fresnel } => Bsdf::Conductor(Conductor { model, fresnel }),
            Surface::Dielectric { model, ior } => Bsdf::Dielectric(Dielectric { model, eta: ior }),
            Surface::Coated(coated) => Bsdf::Coated(coated),
            Surface::Textured(pbr) => pbr.resolve(uv, textures).bsdf(uv, textures),
        }
    }

    /// The microfacet model, if the surface has one (textured surfaces: the factors').
    pub fn microfacet(&self) -> Option<MicrofacetModel> {
        match *self {
            Surface::Diffuse { .. } => None,
            Surface::Conductor { model, .. } | Surface::Dielectric { model, .. } => Some(model),
            Surface::Coated(coated) => Some(coated.model),
            Surface::Textured(pbr) => Some(MicrofacetModel::new(
                pbr.ndf,
                pbr.roughness * pbr.roughness,
                pbr.shadowing,
            )),
        }
    }
}

impl TexturedPbr {
    /// The untextured surface for the factors modulated by the textures at `uv`.
    pub fn resolve(&self, uv: Vec2, textures: &[Texture]) -> Surface {
        let mut base = self.base_color;
        if let Some(t) = self.base_color_texture.and_then(|i| textures.get(i)) {
            base *= t.sample(uv).truncate();
        }
        let (mut roughness, mut metallic) = (self.roughness, self.metallic);
        if let Some(t) = self
            .metallic_roughness_texture
            .and_then(|i| textures.get(i))
        {
            let texel = t.sample(uv);
            roughness *= texel.y;
            metallic *= texel.z;
        }
        let mut specular_color = self.specular_color;
        if let Some(t) = self.specular_color_texture.and_then(|i| textures.get(i)) {
            specular_color *= t.sample(uv).truncate();
        }
        if let Some((ns, t)) = self
            .shininess_texture
            .and_then(|(ns, i)| Some((ns, textures.get(i)?)))
        {
            let ns = (ns * t.sample(uv).x).max(0.0);
            // supp. eq. 5: alpha = sqrt(2 / (n + 2)), and alpha = roughness^2.
            roughness = (2.0 / (ns + 2.0)).sqrt().sqrt();
        }
        metal_rough_surface(
            MetalRough {
                base,
                metallic,
                roughness,
                specular: self.specular,
                specular_color,
                ior: self.ior,
            },
            self.ndf,
            self.shadowing,
        )
    }
}

/// The factors of a glTF metallic-roughness material (textures applied).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MetalRough {
    /// Base colour (linear).
    pub base: Vec3,
    /// Metallic factor.
    pub metallic: f32,
    /// Perceptual roughness r (alpha = r^2).
    pub roughness: f32,
    /// `KHR_materials_specular` specularFactor (1 without the extension).
    pub specular: f32,
    /// `KHR_materials_specular` specularColorFactor (1 without the extension).
    pub specular_color: Vec3,
    /// `KHR_materials_ior` ior (1.5 without the extension).
    pub ior: f32,
}

impl MetalRough {
    /// glTF's defaults for the extensions: specular 1, colour 1, ior 1.5.
    pub fn new(base: Vec3, metallic: f32, roughness: f32) -> Self {
        Self {
            base,
            metallic,
            roughness,
            specular: 1.0,
            specular_color: Vec3::ONE,
            ior: 1.5,
        }
    }
}

/// The glTF metallic-roughness mapping of the module docs (no transmission):
/// the coated lobe, or Lambertian where it reduces to one (metallic 0 and
/// specular 0). Factors are clamped to [0, 1] (the colour of the coat to
/// [0, inf), as `KHR_materials_specular` allows).
pub fn metal_rough_surface(m: MetalRough, ndf: NdfKind, shadowing: Shadowing) -> Surface {
    let base = m.base.clamp(Vec3::ZERO, Vec3::ONE);
    let (metallic, specular) = (m.metallic.clamp(0.0, 1.0), m.specular.clamp(0.0, 1.0));
    if metallic == 0.0 && specular == 0.0 {
        return Surface::Diffuse { reflectance: base };
    }
    Surface::Coated(Coated {
        model: MicrofacetModel::new(ndf, m.roughness * m.roughness, shadowing),
        base_color: base,
        metallic,
        specular,
        specular_color: m.specular_color.max(Vec3::ZERO),
        ior: m.ior,
    })
}
