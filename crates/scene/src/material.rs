//! Materials: what a surface does to light, as `microfacet` lobes, plus emission.
//!
//! # Mapping from the file formats
//!
//! glTF 2.0 metallic-roughness (per material, or per texel when textured):
//! - `alpha = roughness^2` (glTF's perceptual roughness r).
//! - transmission t >= 0.5 (`KHR_materials_transmission` factor times the R
//!   channel of its `transmissionTexture`) where metallic < 0.5: a rough or
//!   smooth dielectric with index `KHR_materials_ior` (glTF default 1.5) whose
//!   refracted part is tinted by the base colour (the extension's
//!   `specular_btdf * baseColor`). glTF mixes the base BRDF and the BTDF by t;
//!   one lobe per shading point cannot mix them, so the larger weight wins,
//!   per texel when textured (t = 0.5 is glass). With `KHR_materials_volume`
//!   and thicknessFactor > 0 the mesh is a closed volume that absorbs
//!   (`Medium`, from attenuationColor and attenuationDistance); the thickness
//!   itself and its texture are not used.
//! - otherwise: the coated lobe (`microfacet::Coated`, Appendix B's BRDF):
//!   base colour, metallic as the mix weight of the metal, the coat's index
//!   from `KHR_materials_ior` (1.5) and its strength and F0 colour from
//!   `KHR_materials_specular` (specularFactor, specularColorFactor: 1; their
//!   textures are not used). A material with metallic 0 and specularFactor 0
//!   is Lambertian (the lobe reduces to it, and a Lambertian vertex has no
//!   roughness for regularization to change).
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
    Bsdf, Coated, Conductor, Dielectric, Fresnel, Lambertian, MicrofacetModel, NdfKind, Shadowing,
    ThinDielectric,
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
        /// Colour of the refracted part, each channel in [0, 1] (glTF's base
        /// colour; `Vec3::ONE` for clear glass). Reflection is not tinted.
        tint: Vec3,
    },
    /// glTF metallic-roughness: a specular coat over a diffuse base, mixed
    /// with a metal (the module docs' mapping).
    Coated(Coated),
    /// A thin sheet of glass (a window pane; Mitsuba's `thindielectric`):
    /// delta reflection, and straight transmission tinted by `tint`.
    ThinDielectric {
        /// Index of refraction of the sheet, > 0 (around it: 1).
        ior: f32,
        /// Colour of the transmitted part, each channel in [0, 1].
        tint: Vec3,
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
    /// `KHR_materials_transmission` factor (0 without the extension).
    pub transmission: f32,
    /// Transmission texture: the factor is multiplied by its R channel.
    pub transmission_texture: Option<usize>,
    /// `KHR_materials_ior`: the coat's index, and the glass's where transmissive.
    pub ior: f32,
    /// `KHR_materials_specular` specularFactor (0 for an OBJ diffuse texture).
    pub specular: f32,
    /// `KHR_materials_specular` specularColorFactor.
    pub specular_color: Vec3,
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
    /// Emitted radiance (W sr^-1 m^-2 per channel), zero for non-emitters;
    /// the emissive texture, if any, multiplies it.
    pub emission: Vec3,
    /// What fills the inside of a closed dielectric mesh with this material
    /// (behind the geometric normal); `None` for clear glass and for every
    /// opaque material.
    pub medium: Option<Medium>,
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

/// A homogeneous absorbing medium (no scattering): Beer-Lambert
/// attenuation along every path segment inside it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Medium {
    /// Absorption coefficient sigma_a per channel, per unit of scene
    /// length, finite and >= 0.
    pub sigma_a: Vec3,
}

impl Medium {
    /// The medium that turns white light into `color` after `distance`
    /// (Khronos KHR_materials_volume: sigma_a = -ln(attenuationColor) /
    /// attenuationDistance per channel). `None` when it absorbs nothing
    /// (colour white, or an infinite distance, the extension's default).
    /// A colour channel of 0 absorbs everything it crosses: its sigma_a is
    /// `OPAQUE_SIGMA_A` instead of infinity.
    /// Expects colour channels in [0, 1] and a distance > 0.
    pub fn from_attenuation(color: Vec3, distance: f32) -> Option<Self> {
        if distance == f32::INFINITY {
            return None;
        }
        let sigma_a = color.map(|c| {
            if c > 0.0 {
                (-c.ln() / distance).clamp(0.0, OPAQUE_SIGMA_A)
            } else {
                OPAQUE_SIGMA_A
            }
        });
        Self::absorbing(sigma_a)
    }

    /// The medium with absorption coefficient `sigma_a`, or `None` when it
    /// absorbs nothing.
    pub fn absorbing(sigma_a: Vec3) -> Option<Self> {
        (sigma_a.max_element() > 0.0).then_some(Self { sigma_a })
    }

    /// The fraction of light per channel that crosses `distance` of the
    /// medium: exp(-sigma_a d) (Beer-Lambert; pbrt-v4 §11.2). A channel
    /// that does not absorb passes 1 whatever the distance (also an
    /// infinite one, where sigma_a d would be 0 x inf).
    pub fn transmittance(&self, distance: f32) -> Vec3 {
        self.sigma_a
            .map(|s| if s > 0.0 { (-s * distance).exp() } else { 1.0 })
    }
}

/// sigma_a of a channel whose attenuation colour is 0 (ln 0 = -inf): light
/// that crosses 1e-30 of such a medium keeps e^-1 at most, so any segment a
/// scene resolves is dark, and sigma_a d stays finite (no inf x 0 = NaN at a
/// zero-length segment).
pub const OPAQUE_SIGMA_A: f32 = 1e30;

impl Material {
    /// A material with no maps and no medium.
    pub fn new(name: String, surface: Surface, emission: Vec3) -> Self {
        Self {
            name,
            surface,
            emission,
            medium: None,
            maps: Maps::default(),
        }
    }

    /// True when some texture of the material is read at a point's texture
    /// coordinates (its lobe's or any map): points of other materials need
    /// no uv.
    pub fn reads_uv(&self) -> bool {
        matches!(self.surface, Surface::Textured(_)) || self.maps != Maps::default()
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
    ///
    /// Always inlined, with the textured case out of line
    /// ([`TexturedPbr::bsdf`]): returned through memory, the lobe's fields
    /// were reloaded by every path vertex right after this function stored
    /// them, and the loads waited on the stores.
    #[inline(always)]
    pub fn bsdf(&self, uv: Vec2, textures: &[Texture]) -> Bsdf {
        match *self {
            Surface::Diffuse { reflectance } => Bsdf::Lambertian(Lambertian { reflectance }),
            Surface::Conductor { model, fresnel } => Bsdf::Conductor(Conductor { model, fresnel }),
            Surface::Dielectric { model, ior, tint } => {
                Bsdf::Dielectric(Dielectric::new(model, ior).with_tint(tint))
            }
            Surface::Coated(coated) => Bsdf::Coated(coated),
            Surface::ThinDielectric { ior, tint } => {
                Bsdf::ThinDielectric(ThinDielectric { eta: ior, tint })
            }
            Surface::Textured(pbr) => pbr.bsdf(uv, textures),
        }
    }

    /// True when some point of the surface may be a refracting dielectric
    /// interface (textured surfaces: where the textures make it no metal and
    /// fully transmissive; textures only scale the factors down). Not a thin
    /// sheet, which bounds no volume.
    pub fn may_transmit(&self) -> bool {
        match *self {
            Surface::Dielectric { .. } => true,
            Surface::Textured(pbr) => {
                let metallic = match pbr.metallic_roughness_texture {
                    Some(_) => 0.0,
                    None => pbr.metallic,
                };
                is_transmissive(metallic, pbr.transmission)
            }
            Surface::Diffuse { .. }
            | Surface::Conductor { .. }
            | Surface::Coated(_)
            | Surface::ThinDielectric { .. } => false,
        }
    }

    /// The microfacet model, if the surface has one (textured surfaces: the factors').
    pub fn microfacet(&self) -> Option<MicrofacetModel> {
        match *self {
            Surface::Diffuse { .. } | Surface::ThinDielectric { .. } => None,
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
    /// A Lambertian surface of albedo `base_color` times `texture` (sRGB):
    /// no coat (specular 0), so the lobe stays Lambertian (OBJ `map_Kd`,
    /// a Mitsuba `diffuse` with a `bitmap`).
    pub fn lambertian(base_color: Vec3, texture: Option<usize>) -> Self {
        Self {
            base_color,
            base_color_texture: texture,
            metallic: 0.0,
            roughness: 1.0,
            metallic_roughness_texture: None,
            transmission: 0.0,
            transmission_texture: None,
            specular: 0.0,
            specular_color: Vec3::ONE,
            // Unused without a coat or transmission.
            ior: 1.5,
            specular_color_texture: None,
            shininess_texture: None,
            ndf: NdfKind::Ggx,
            shadowing: Shadowing::Smith,
        }
    }

    /// The lobe at `uv`: [`TexturedPbr::resolve`]'s.
    #[inline(never)]
    pub fn bsdf(&self, uv: Vec2, textures: &[Texture]) -> Bsdf {
        self.resolve(uv, textures).bsdf(uv, textures)
    }

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
        let mut transmission = self.transmission;
        if let Some(t) = self.transmission_texture.and_then(|i| textures.get(i)) {
            transmission *= t.sample(uv).x;
        }
        if is_transmissive(metallic, transmission) {
            return transmissive_surface(base, roughness, self.ior, self.ndf, self.shadowing);
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

/// The module docs' rule: a point is glass where it is not metal
/// (metallic < 0.5) and its transmission weight is at least 0.5.
pub fn is_transmissive(metallic: f32, transmission: f32) -> bool {
    metallic < 0.5 && transmission >= 0.5
}

/// A transmissive glTF material's lobe: a dielectric of index `ior` whose
/// refraction is tinted by the base colour (module docs).
pub fn transmissive_surface(
    base: Vec3,
    roughness: f32,
    ior: f32,
    ndf: NdfKind,
    shadowing: Shadowing,
) -> Surface {
    Surface::Dielectric {
        model: MicrofacetModel::new(ndf, roughness * roughness, shadowing),
        ior,
        tint: base.clamp(Vec3::ZERO, Vec3::ONE),
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn media_follow_beer_lambert_and_have_no_nan_edges() {
        let m = Medium::from_attenuation(Vec3::new(0.5, 1.0, 0.0), 2.0).unwrap();
        assert_eq!(
            m.sigma_a,
            Vec3::new(0.5f32.ln() / -2.0, 0.0, OPAQUE_SIGMA_A)
        );
        // After the attenuation distance white light has the attenuation colour.
        let t = m.transmittance(2.0);
        assert!(
            (t - Vec3::new(0.5, 1.0, 0.0)).abs().max_element() < 1e-6,
            "{t}"
        );
        // A channel that does not absorb passes everything, even to infinity.
        assert_eq!(m.transmittance(f32::INFINITY), Vec3::new(0.0, 1.0, 0.0));
        assert_eq!(m.transmittance(0.0), Vec3::ONE);
        // White, or the extension's default infinite distance: no medium.
        assert_eq!(Medium::from_attenuation(Vec3::ONE, 1.0), None);
        assert_eq!(
            Medium::from_attenuation(Vec3::splat(0.5), f32::INFINITY),
            None
        );
    }

    /// Points skip their uv only for materials that read no texture; a
    /// texture in any map makes them need it.
    #[test]
    fn materials_read_uv_through_any_texture() {
        let plain = Material::new(
            "plain".into(),
            Surface::Diffuse {
                reflectance: Vec3::splat(0.5),
            },
            Vec3::ZERO,
        );
        assert!(!plain.reads_uv());
        let mut emissive = plain.clone();
        emissive.maps.emission = Some(0);
        assert!(emissive.reads_uv());
        let mut cut_out = plain.clone();
        cut_out.maps.alpha = Alpha::Mask {
            factor: 1.0,
            texture: Some(0),
            cutoff: 0.5,
        };
        assert!(cut_out.reads_uv());
    }
}
