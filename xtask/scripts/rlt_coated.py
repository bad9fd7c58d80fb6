"""Our coated lobe (crates/microfacet/src/coated.rs: the glTF metallic-roughness BRDF with
the coat-coupled base) as a Mitsuba 3 scalar_rgb BSDF plugin, `rlt_coated`.

Mitsuba has no BSDF with this formula (`principled` has Burley's base and exact Fresnel,
`roughplastic` models internal scattering), so `cargo xtask mitsuba` exports a coated
material as this plugin: both renderers then evaluate the same lobe, and the comparison
checks the light transport (integrator, emitter sampling, MIS) rather than two material
models. Same formula, written again from the module docs of `microfacet::coated`:

    f = (1 - m) [T(mu_i) T(mu_o) / T_avg base/pi + F_s(<wi,h>) f_spec] + m F_m(<wi,h>) f_spec

with f_spec = D G / (4 mu_i mu_o) (GGX, separable Smith G, Mitsuba's
`MicrofacetDistribution`), F_s(c) = w Schlick(F0, c), F0 = min(((ior-1)/(ior+1))^2 specColor, 1),
F_m(c) = Schlick(base, c), T(mu) = 1 - max_rgb F_s(mu), T_avg = 1 - w (F0max + (1 - F0max)/21).
Sampling is Mitsuba's own here (an even coin between visible-normal and cosine sampling):
only the value must match, any density with the right support gives the same image.

Imported by mitsuba_pt.py after `mi.set_variant("scalar_rgb")`.
"""

import math

import drjit as dr
import mitsuba as mi

# The coin between the specular and the diffuse sampler.
P_SPECULAR = 0.5


def schlick(f0, c):
    return f0 + (mi.Color3f(1.0) - f0) * (1.0 - c) ** 5


class RltCoated(mi.BSDF):
    def __init__(self, props):
        mi.BSDF.__init__(self, props)
        self.base = mi.Color3f(props["base_color"])
        self.metallic = props["metallic"]
        self.w = props["specular"]
        r = (props["ior"] - 1.0) / (props["ior"] + 1.0)
        self.f0 = dr.minimum(r * r * mi.Color3f(props["specular_color"]), mi.Color3f(1.0))
        f0max = dr.max(self.f0)
        self.t_avg = max(1.0 - self.w * (f0max + (1.0 - f0max) / 21.0), 0.0)
        self.distr = mi.MicrofacetDistribution(mi.MicrofacetType.GGX, props["alpha"], True)
        flags = (
            mi.BSDFFlags.DiffuseReflection
            | mi.BSDFFlags.GlossyReflection
            | mi.BSDFFlags.FrontSide
        )
        self.m_components = [flags]
        self.m_flags = flags

    def coat(self, c):
        return self.w * schlick(self.f0, c)

    def transmittance(self, mu):
        return max(1.0 - dr.max(self.coat(mu)), 0.0)

    def value(self, wi, wo):
        if wi.z <= 0 or wo.z <= 0:
            return mi.Color3f(0.0)
        h = dr.normalize(wi + wo)
        c = dr.dot(wi, h)
        f_spec = self.distr.eval(h) * self.distr.G(wi, wo, h) / (4.0 * wi.z * wo.z)
        fresnel = self.coat(c) * (1.0 - self.metallic) + schlick(self.base, c) * self.metallic
        f = fresnel * f_spec
        if self.t_avg > 0:
            coupling = self.transmittance(wi.z) * self.transmittance(wo.z) / self.t_avg
            f += (1.0 - self.metallic) * self.base * (coupling / math.pi)
        return f

    def density(self, wi, wo):
        if wi.z <= 0 or wo.z <= 0:
            return 0.0
        h = dr.normalize(wi + wo)
        specular = self.distr.pdf(wi, h) / (4.0 * dr.dot(wo, h))
        return P_SPECULAR * specular + (1.0 - P_SPECULAR) * wo.z / math.pi

    def sample(self, ctx, si, sample1, sample2, active=True):
        bs = mi.BSDFSample3f()
        wi = si.wi
        if wi.z <= 0:
            return (bs, mi.Color3f(0.0))
        if sample1 < P_SPECULAR:
            m, _ = self.distr.sample(wi, sample2)
            wo = mi.reflect(wi, m)
            bs.sampled_type = mi.UInt32(+mi.BSDFFlags.GlossyReflection)
        else:
            wo = mi.warp.square_to_cosine_hemisphere(sample2)
            bs.sampled_type = mi.UInt32(+mi.BSDFFlags.DiffuseReflection)
        pdf = self.density(wi, wo)
        if pdf <= 0:
            return (bs, mi.Color3f(0.0))
        bs.wo, bs.pdf, bs.eta, bs.sampled_component = wo, pdf, 1.0, 0
        return (bs, self.value(wi, wo) * (wo.z / pdf))

    def eval(self, ctx, si, wo, active=True):
        return self.value(si.wi, wo) * max(wo.z, 0.0)

    def pdf(self, ctx, si, wo, active=True):
        return self.density(si.wi, wo)

    def eval_pdf(self, ctx, si, wo, active=True):
        return (self.eval(ctx, si, wo), self.pdf(ctx, si, wo))

    def to_string(self):
        return "RltCoated[]"


mi.register_bsdf("rlt_coated", lambda props: RltCoated(props))
