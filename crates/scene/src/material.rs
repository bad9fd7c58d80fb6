//! Materials: what a surface does to light, as `microfacet` lobes, plus emission.
//!
//! # Mapping from the file formats
//!
//! glTF 2.0 metallic-roughness (per material, or per texel when textured):
//! - `alpha = roughness^2` (glTF's perceptual roughness r).
//! - `KHR_materials_transmission` factor > 0: a rough or smooth dielectric with
//!   index `KHR_materials_ior` (glTF default 1.5). Base colour tint, the
//!   transmission texture and `KHR_materials_volume` are not used.
//! - otherwise metallic >= 0.5: a conductor with Schlick's Fresnel, F0 = base colour.
//! - otherwise: Lambertian with the base colour. The thin specular layer of
//!   glTF dielectrics (F0 = 0.04) is not modelled: there is no layered lobe yet.
//! - emission = emissiveFactor x `KHR_materials_emissive_strength`, times the
//!   sRGB-decoded `emissiveTexture` where there is one ([`Maps::emission`]).
//!   Material `extras` may choose `"ndf"`
//!   (`"ggx"` default, `"beckmann"`, `"blinn-phong"`) and `"shadowing"`
//!   (`"smith"` default, `"v-cavity"`).
//!
//! OBJ/MTL:
//! - `illum 5` (mirror): conductor, F0 = Ks, alpha from `Pr` (r^2) or 0;
//!   `illum 7` (glass): dielectric with index `Ni` (1.5 if absent), alpha from `Pr` or 0.
//! - `Pm` >= 0.5: conductor with F0 = Kd and alpha = Pr^2.
//! - `d` < 1 (or `Tr` > 0): dielectric, as `illum 7`. `Tf` is ignored (real files
//!   put it on opaque materials, lights included).
//! - max(Ks) > max(Kd) with `Ns`: glossy conductor, Blinn-Phong NDF with
//!   alpha = sqrt(2 / (Ns + 2)) (supp. eq. 5), F0 = Ks; otherwise Lambertian Kd.
//! - `Ke`: emission. `map_Kd`: base colour texture (sRGB).
//!
//! Maps on every material ([`Maps`], both formats): glTF `normalTexture`
//! (with `scale`), `alphaMode` MASK (with `alphaCutoff`) and BLEND from the
//! base colour's alpha, `KHR_texture_transform` on every texture read (in
//! [`Texture`]); MTL `norm` (tangent-space normal map) and `bump`/`map_Bump`
//! (height map).
//!
//! Emission is one-sided, on the side the geometric normal (counter-clockwise
//! winding) points to.

use glam::{Vec2, Vec3};
use microfacet::{
    Bsdf, Conductor, Dielectric, Fresnel, Lambertian, MicrofacetModel, NdfKind, Shadowing,
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
    /// Emitted radiance (W sr^-1 m^-2 per channel), zero for non-emitters;
    /// the emissive texture, if any, multiplies it.
    pub emission: Vec3,
    /// Emission, normal and alpha maps.
    pub maps: Maps,
}

/// The textures of a material other than its lobe's: emission, shading
/// normal and coverage. All absent by default (no cost at render time).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Maps {
    /// Emissive texture (sRGB-decoded), multiplied with `Material::emission`.
    pub emission: Option<usize>,
    /// Perturbation of the shading normal.
    pub normal: Option<NormalMap>,
    /// Coverage (cut-outs and stochastic transparency).
    pub alpha: Alpha,
}

impl Maps {
    /// The maps with every texture index shifted by `offset` (scenes appended).
    pub fn with_texture_offset(mut self, offset: usize) -> Self {
        self.emission = self.emission.map(|t| t + offset);
        if let Some(n) = &mut self.normal {
            n.texture += offset;
        }
        if let Alpha::Mask { texture, .. } | Alpha::Blend { texture, .. } = &mut self.alpha {
            *texture = texture.map(|t| t + offset);
        }
        self
    }
}

/// A texture that perturbs the shading normal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NormalMap {
    /// The texture (linear values).
    pub texture: usize,
    /// What the texture holds.
    pub kind: NormalMapKind,
}

/// How a [`NormalMap`]'s texels become a shading normal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum NormalMapKind {
    /// Tangent-space normals, rgb = (n + 1) / 2 (glTF 2.0 spec, 3.9.3
    /// "Additional Textures"): x along the tangent (+u), y along the bitangent,
    /// z along the normal; x and y are multiplied by `scale`.
    Tangent {
        /// glTF `normalTexture.scale`.
        scale: f32,
    },
    /// A height map (its first channel) displacing the surface along the
    /// normal by `scale` x height, in uv units (Blinn 1978; pbrt-v3 §9.3).
    Height {
        /// MTL `-bm` multiplier.
        scale: f32,
    },
}

/// glTF `alphaMode` (glTF 2.0 spec, 3.9.4 "Alpha Coverage"): the coverage
/// alpha is `factor` x the alpha of `texture` (the base colour texture).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Alpha {
    /// Alpha is ignored (the default): the surface is everywhere.
    #[default]
    Opaque,
    /// Cut-out: where alpha < `cutoff` the surface does not exist for any ray.
    Mask {
        /// Base colour factor's alpha.
        factor: f32,
        /// Base colour texture (its alpha channel).
        texture: Option<usize>,
        /// `alphaCutoff` (glTF default 0.5).
        cutoff: f32,
    },
    /// Stochastic transparency: a ray meets the surface with probability alpha.
    Blend {
        /// Base colour factor's alpha.
        factor: f32,
        /// Base colour texture (its alpha channel).
        texture: Option<usize>,
    },
}

impl Alpha {
    /// True for `Opaque`, whose surface every ray meets.
    pub fn is_opaque(&self) -> bool {
        matches!(self, Alpha::Opaque)
    }

    /// The fraction of rays that meet the surface at `uv`: 1 (opaque), 0 or
    /// 1 (mask), alpha in [0, 1] (blend).
    pub fn coverage(&self, uv: Vec2, textures: &[Texture]) -> f32 {
        let alpha = |factor: f32, texture: Option<usize>| {
            let texel = texture
                .and_then(|i| textures.get(i))
                .map_or(1.0, |t| t.sample(uv).w);
            (factor * texel).clamp(0.0, 1.0)
        };
        match *self {
            Alpha::Opaque => 1.0,
            Alpha::Mask {
                factor,
                texture,
                cutoff,
            } => {
                if alpha(factor, texture) < cutoff {
                    0.0
                } else {
                    1.0
                }
            }
            Alpha::Blend { factor, texture } => alpha(factor, texture),
        }
    }
}

impl Material {
    /// A material with no maps.
    pub fn new(name: String, surface: Surface, emission: Vec3) -> Self {
        Self {
            name,
            surface,
            emission,
            maps: Maps::default(),
        }
    }

    /// True when the material emits light (its factor; a texture may still
    /// be black in places).
    pub fn is_emissive(&self) -> bool {
        self.emission.max_element() > 0.0
    }

    /// Emitted radiance at texture coordinate `uv`: the factor, times the
    /// emissive texture where there is one (glTF 2.0 spec, 3.9.5).
    #[inline]
    pub fn emission_at(&self, uv: Vec2, textures: &[Texture]) -> Vec3 {
        match self.maps.emission.and_then(|i| textures.get(i)) {
            Some(t) => self.emission * t.sample(uv).truncate(),
            None => self.emission,
        }
    }
}

impl Surface {
    /// The lobe at texture coordinate `uv`.
    pub fn bsdf(&self, uv: Vec2, textures: &[Texture]) -> Bsdf {
        match *self {
            Surface::Diffuse { reflectance } => Bsdf::Lambertian(Lambertian { reflectance }),
            Surface::Conductor { model, fresnel } => Bsdf::Conductor(Conductor { model, fresnel }),
            Surface::Dielectric { model, ior } => Bsdf::Dielectric(Dielectric { model, eta: ior }),
            Surface::Textured(pbr) => pbr.resolve(uv, textures).bsdf(uv, textures),
        }
    }

    /// The microfacet model, if the surface has one (textured surfaces: the factors').
    pub fn microfacet(&self) -> Option<MicrofacetModel> {
        match *self {
            Surface::Diffuse { .. } => None,
            Surface::Conductor { model, .. } | Surface::Dielectric { model, .. } => Some(model),
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
        metal_rough_surface(base, metallic, roughness, self.ndf, self.shadowing)
    }
}

/// The glTF metallic-roughness mapping of the module docs (no transmission).
pub fn metal_rough_surface(
    base: Vec3,
    metallic: f32,
    roughness: f32,
    ndf: NdfKind,
    shadowing: Shadowing,
) -> Surface {
    if metallic >= 0.5 {
        Surface::Conductor {
            model: MicrofacetModel::new(ndf, roughness * roughness, shadowing),
            fresnel: Fresnel::Schlick {
                f0: base.clamp(Vec3::ZERO, Vec3::ONE),
            },
        }
    } else {
        Surface::Diffuse {
            reflectance: base.clamp(Vec3::ZERO, Vec3::ONE),
        }
    }
}
