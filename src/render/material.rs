//! Scattering at a surface: evaluation, sampling and sampling density of
//! each material of the dialect, in the local frame of the shading normal
//! (z = shading normal, both directions pointing away from the surface),
//! and the answers to what the integrator asks of a material ([`Lobe`]).
//!
//! An opaque surface is seen from the front of its facet (the integrator
//! requires `wo·ng > 0`) and reflects light arriving in front of both the
//! facet and the shading normal (`wi·ng > 0`, or the point lifted onto the
//! smooth surface, and `wi.z > 0` here), as in pbrt-v4 and Mitsuba 3.
//! Sampling draws directions in front of the shading normal only, and
//! [`pdf`] is zero elsewhere, so multiple importance sampling stays
//! consistent (light sampling alone covers directions behind the facet
//! that the lift lets through).

use glam::Vec3;
use std::f32::consts::{FRAC_1_PI, PI};

use crate::geom::sampling::{cosine_hemisphere, Rng};
use crate::scene::Material;

/// A sampled direction, its throughput weight `f * |cos| / pdf`, and the
/// density it was drawn with (solid angle; meaningless when `specular`).
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    pub wi: Vec3,
    pub weight: Vec3,
    pub pdf: f32,
    /// True for perfectly specular (delta) events: no light sampling there.
    pub specular: bool,
}

/// How a material scatters: the one place each material answers what the
/// integrator asks of it ([`Lobe::is_specular`], [`Lobe::transmits`],
/// [`Lobe::turns_to_view`]). Every match on materials in this module is
/// exhaustive, so a new material answers every question before it builds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lobe {
    /// Diffuse reflection, the same for every view (Lambertian).
    Diffuse,
    /// A glossy lobe about the view's mirror direction (microfacet).
    Glossy,
    /// One reflected direction.
    Mirror,
    /// Reflection and transmission through a smooth interface: the surface
    /// has an inside, so its normals keep their outward side.
    Dielectric,
    /// Emits, scatters nothing.
    Emitter,
}

/// The lobe of material `m`.
pub fn lobe(m: &Material) -> Lobe {
    match m {
        Material::Lambertian { .. } => Lobe::Diffuse,
        Material::Microfacet { .. } => Lobe::Glossy,
        Material::Mirror { .. } => Lobe::Mirror,
        Material::Glass { .. } | Material::Refraction { .. } => Lobe::Dielectric,
        Material::Emission { .. } => Lobe::Emitter,
    }
}

impl Lobe {
    /// A delta distribution: light sampling is skipped there, and shadow
    /// rays never leave it.
    pub fn is_specular(self) -> bool {
        matches!(self, Lobe::Mirror | Lobe::Dielectric)
    }

    /// Light passes through: the surface is not two-sided, the normals
    /// keep their outward side to tell inside from out.
    pub fn transmits(self) -> bool {
        self == Lobe::Dielectric
    }

    /// Whether the integrator turns the shading frame to face the view
    /// where a smooth normal tilts away from it (seen near a coarse mesh's
    /// silhouette): a glossy lobe and a mirror are defined about `wo` and
    /// need it above the shading plane. A diffuse surface does not depend
    /// on `wo`: it keeps the smooth surface's outer side, so it is lit
    /// exactly where the smooth normal faces the light, at the silhouette
    /// too. (An emitter scatters nothing, so either answer serves.)
    pub fn turns_to_view(self) -> bool {
        self != Lobe::Diffuse
    }
}

/// Radiance emitted towards a direction whose cosine with the geometric
/// normal is `cos` (front side only).
pub fn emitted(m: &Material, cos: f32) -> Vec3 {
    if cos > 0.0 {
        m.emission()
    } else {
        Vec3::ZERO
    }
}

/// `wo` and `wi` mirrored so that `wo` lies above the shading plane, or
/// `None` when `wi` is not on `wo`'s side of it (or either lies in it):
/// where sampling draws directions.
#[inline]
fn same_side(wo: Vec3, wi: Vec3) -> Option<(Vec3, Vec3)> {
    if wo.z * wi.z <= 0.0 {
        return None;
    }
    let flip = |w: Vec3| Vec3::new(w.x, w.y, w.z.abs());
    Some((flip(wo), flip(wi)))
}

/// BSDF value `f(wo, wi)` for non-delta materials (zero for delta ones).
/// Every such material reflects only: a Lambertian surface into the
/// shading frame's upper side whatever `wo` (see [`Lobe::turns_to_view`]), a
/// microfacet one into `wo`'s side of the shading plane. Directions on the
/// other side get zero, whichever side of the facet they are on. (Counting
/// them, as these materials once did where the geometric normal let them
/// through, lit the facets beyond a coarse mesh's smooth terminator: a
/// staircase of lit triangles.)
pub fn eval(m: &Material, wo: Vec3, wi: Vec3) -> Vec3 {
    match *m {
        Material::Lambertian { albedo, .. } if wi.z > 0.0 => albedo * FRAC_1_PI,
        Material::Microfacet { alpha, eta, k } if wo.z * wi.z > 0.0 => {
            let h = (wo + wi).normalize_or_zero();
            if h == Vec3::ZERO {
                return Vec3::ZERO;
            }
            let h = if h.z < 0.0 { -h } else { h };
            let f = fresnel_conductor(wi.dot(h).abs(), eta, k);
            f * beckmann_d(h, alpha) * smith_g2(wo, wi, alpha) / (4.0 * wo.z.abs() * wi.z.abs())
        }
        Material::Lambertian { .. }
        | Material::Microfacet { .. }
        | Material::Mirror { .. }
        | Material::Glass { .. }
        | Material::Refraction { .. }
        | Material::Emission { .. } => Vec3::ZERO,
    }
}

/// The density (solid angle) with which [`sample`] draws `wi` for `wo`;
/// zero for delta materials and for directions it never draws.
pub fn pdf(m: &Material, wo: Vec3, wi: Vec3) -> f32 {
    match *m {
        Material::Lambertian { .. } => wi.z.max(0.0) * FRAC_1_PI,
        Material::Microfacet { alpha, .. } => {
            let Some((wo, wi)) = same_side(wo, wi) else {
                return 0.0;
            };
            let h = (wo + wi).normalize_or_zero();
            if h == Vec3::ZERO {
                return 0.0;
            }
            visible_normal_pdf(wo, h, alpha) / (4.0 * wo.dot(h).abs())
        }
        Material::Mirror { .. }
        | Material::Glass { .. }
        | Material::Refraction { .. }
        | Material::Emission { .. } => 0.0,
    }
}

/// Samples an incoming direction for outgoing `wo` (local frame; `wo.z` may
/// be negative for dielectrics seen from inside, and for opaque surfaces
/// seen below their shading plane).
pub fn sample(m: &Material, wo: Vec3, rng: &mut Rng) -> Option<BsdfSample> {
    let (u, v) = rng.next_2d();
    // Opaque materials sample on wo's side of the shading plane.
    let side = if wo.z < 0.0 { -1.0 } else { 1.0 };
    let to_side = |w: Vec3| Vec3::new(w.x, w.y, w.z * side);
    match *m {
        Material::Lambertian { albedo, .. } => {
            let local = cosine_hemisphere(u, v);
            if local.z <= 0.0 {
                return None;
            }
            Some(BsdfSample {
                wi: local,
                weight: albedo,
                pdf: local.z * FRAC_1_PI,
                specular: false,
            })
        }
        Material::Emission { .. } => None,
        Material::Mirror { reflectance } => Some(BsdfSample {
            wi: Vec3::new(-wo.x, -wo.y, wo.z),
            weight: reflectance,
            pdf: 0.0,
            specular: true,
        }),
        Material::Glass {
            reflectance,
            transmittance,
            ior,
            ..
        } => {
            let cos_o = wo.z;
            let eta = if cos_o > 0.0 { ior } else { 1.0 / ior }; // eta_t / eta_i
            let f = fresnel_dielectric(cos_o.abs(), eta);
            if u < f {
                Some(BsdfSample {
                    wi: Vec3::new(-wo.x, -wo.y, wo.z),
                    weight: reflectance,
                    pdf: 0.0,
                    specular: true,
                })
            } else {
                let wi = refract(wo, eta)?;
                // Radiance is compressed by eta^2 when it enters a denser
                // medium (pbrt-v4 §9.5.2, non-symmetric scattering).
                Some(BsdfSample {
                    wi,
                    weight: transmittance / (eta * eta),
                    pdf: 0.0,
                    specular: true,
                })
            }
        }
        Material::Refraction {
            transmittance, ior, ..
        } => {
            let eta = if wo.z > 0.0 { ior } else { 1.0 / ior };
            let wi = refract(wo, eta)?;
            Some(BsdfSample {
                wi,
                weight: transmittance / (eta * eta),
                pdf: 0.0,
                specular: true,
            })
        }
        Material::Microfacet { alpha, eta, k } => {
            let up = to_side(wo);
            if up.z <= 0.0 {
                return None;
            }
            // A microfacet normal as the view sees them (Heitz and d'Eon
            // 2014), so no sample is wasted on facets facing away.
            let h = sample_visible_normal(up, alpha, u, v);
            let cos_oh = up.dot(h);
            if cos_oh <= 0.0 {
                return None;
            }
            let wi = 2.0 * cos_oh * h - up;
            if wi.z <= 0.0 {
                return None;
            }
            let pdf = visible_normal_pdf(up, h, alpha) / (4.0 * cos_oh);
            if !(pdf > 0.0) {
                return None;
            }
            // f cos / pdf = F G2 / G1(wo) for visible-normal sampling.
            let weight = fresnel_conductor(wi.dot(h), eta, k) * smith_g2(up, wi, alpha)
                / smith_g1(up, alpha);
            Some(BsdfSample {
                wi: to_side(wi),
                weight,
                pdf,
                specular: false,
            })
        }
    }
}

/// Refracted direction for relative index `eta = eta_t / eta_i`, or `None`
/// on total internal reflection. The normal is +z; `wo.z < 0` means `wo`
/// is inside.
fn refract(wo: Vec3, eta: f32) -> Option<Vec3> {
    let cos_i = wo.z.abs();
    let sin2_t = (1.0 - cos_i * cos_i).max(0.0) / (eta * eta);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let sign = if wo.z > 0.0 { -1.0 } else { 1.0 };
    Some(Vec3::new(-wo.x / eta, -wo.y / eta, sign * cos_t))
}

/// Unpolarized Fresnel reflectance of a dielectric interface.
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    let sin2_t = (1.0 - cos_i * cos_i).max(0.0) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    0.5 * (rs * rs + rp * rp)
}

/// Fresnel reflectance of a conductor with complex index `eta + i k`, per
/// channel (the common air-conductor approximation, Pharr et al. §8.2).
fn fresnel_conductor(cos_i: f32, eta: Vec3, k: Vec3) -> Vec3 {
    let c = cos_i.clamp(0.0, 1.0);
    let c2 = Vec3::splat(c * c);
    let e2k2 = eta * eta + k * k;
    let two_eta_c = 2.0 * c * eta;
    let rs = (e2k2 - two_eta_c + c2) / (e2k2 + two_eta_c + c2);
    let rp = (e2k2 * c2 - two_eta_c + Vec3::ONE) / (e2k2 * c2 + two_eta_c + Vec3::ONE);
    (rs + rp) * 0.5
}

/// Beckmann normal distribution.
fn beckmann_d(h: Vec3, alpha: f32) -> f32 {
    if h.z <= 0.0 {
        return 0.0;
    }
    let cos2 = h.z * h.z;
    let tan2 = (1.0 - cos2) / cos2;
    (-tan2 / (alpha * alpha)).exp() / (PI * alpha * alpha * cos2 * cos2)
}

/// Smith's Λ for the Beckmann distribution, exact (Walter et al. 2007,
/// eq. 24 in terms of erf): `(erf(a) - 1) / 2 + e^(-a²) / (2 a √π)`,
/// `a = 1 / (alpha tan θ)`.
fn beckmann_lambda(w: Vec3, alpha: f32) -> f32 {
    let cos = w.z.abs();
    let sin = (1.0 - cos * cos).max(0.0).sqrt();
    if sin == 0.0 {
        return 0.0;
    }
    let a = cos / (alpha * sin);
    if a > 6.0 {
        return 0.0; // below f32 resolution
    }
    0.5 * (erf(a) - 1.0) + (-a * a).exp() / (2.0 * a * PI.sqrt())
}

/// Masking of one direction.
fn smith_g1(w: Vec3, alpha: f32) -> f32 {
    1.0 / (1.0 + beckmann_lambda(w, alpha))
}

/// Height-correlated masking-shadowing (Heitz 2014, "Understanding the
/// masking-shadowing function").
fn smith_g2(wo: Vec3, wi: Vec3, alpha: f32) -> f32 {
    1.0 / (1.0 + beckmann_lambda(wo, alpha) + beckmann_lambda(wi, alpha))
}

/// Density of visible normal `h` seen from `wo` (upper hemisphere):
/// `G1(wo) max(0, wo·h) D(h) / wo.z`.
fn visible_normal_pdf(wo: Vec3, h: Vec3, alpha: f32) -> f32 {
    let cos_oh = wo.dot(h);
    if cos_oh <= 0.0 || wo.z <= 0.0 {
        return 0.0;
    }
    smith_g1(wo, alpha) * cos_oh * beckmann_d(h, alpha) / wo.z
}

/// A Beckmann microfacet normal distributed as the visible normals from
/// `wo` (Heitz and d'Eon 2014, "Importance sampling microfacet-based BSDFs
/// using the distribution of visible normals"): stretch the view to unit
/// roughness, sample the slopes of the visible facets (the x slope by
/// numerically inverting its CDF, the y slope as a normal variate), rotate
/// and unstretch. The x-slope inversion is the safeguarded Newton iteration
/// of Jakob's Mitsuba implementation (also in pbrt-v3), written anew.
fn sample_visible_normal(wo: Vec3, alpha: f32, u: f32, v: f32) -> Vec3 {
    let stretched = Vec3::new(alpha * wo.x, alpha * wo.y, wo.z).normalize();
    let cos_theta = stretched.z;
    let (sx, sy) = visible_slopes(cos_theta, u, v);
    // Rotate by the view's azimuth.
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    let (cos_phi, sin_phi) = if sin_theta > 1e-7 {
        (stretched.x / sin_theta, stretched.y / sin_theta)
    } else {
        (1.0, 0.0)
    };
    let (rx, ry) = (cos_phi * sx - sin_phi * sy, sin_phi * sx + cos_phi * sy);
    // Unstretch; the normal of a facet with slopes (x, y) is (-x, -y, 1).
    Vec3::new(-alpha * rx, -alpha * ry, 1.0).normalize()
}

/// Slopes of a visible facet of the unit-roughness Beckmann surface seen at
/// `cos_theta` from the x-z plane.
fn visible_slopes(cos_theta: f32, u: f32, v: f32) -> (f32, f32) {
    let v = v.max(1e-6);
    if cos_theta > 0.9999 {
        // Seen from above: the slope distribution itself.
        let r = (-(1.0 - u).max(1e-12).ln()).sqrt();
        let phi = 2.0 * PI * v;
        return (r * phi.cos(), r * phi.sin());
    }
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    let tan_theta = sin_theta / cos_theta;
    let cot_theta = 1.0 / tan_theta;
    // The CDF of the x slope in terms of b = erf(x): solve
    // C(b) = n (1 + b + tan θ e^(-erfinv(b)²) / √π) = u on [-1, erf(cot θ)].
    let (mut lo, mut hi) = (-1.0f32, erf(cot_theta));
    let u = u.max(1e-6);
    let theta = cos_theta.acos();
    // A good first guess (Jakob's fit), then safeguarded Newton steps.
    let fit = 1.0 + theta * (-0.876 + theta * (0.4265 - 0.0594 * theta));
    let mut b = hi - (1.0 + hi) * (1.0 - u).powf(fit);
    let norm = 1.0 / (1.0 + hi + tan_theta * (-cot_theta * cot_theta).exp() / PI.sqrt());
    for _ in 0..10 {
        if !(b >= lo && b <= hi) {
            b = 0.5 * (lo + hi);
        }
        let x = erf_inv(b);
        let value = norm * (1.0 + b + tan_theta * (-x * x).exp() / PI.sqrt()) - u;
        if value.abs() < 1e-5 {
            break;
        }
        if value > 0.0 {
            hi = b;
        } else {
            lo = b;
        }
        let derivative = norm * (1.0 - x * tan_theta);
        b -= value / derivative;
    }
    (erf_inv(b), erf_inv(2.0 * v - 1.0))
}

/// The error function (Abramowitz and Stegun 7.1.26, |error| < 1.5e-7).
fn erf(x: f32) -> f32 {
    let t = 1.0 / (1.0 + 0.327_591_1 * x.abs());
    let poly = t
        * (0.254_829_6
            + t * (-0.284_496_74 + t * (1.421_413_7 + t * (-1.453_152_1 + t * 1.061_405_4))));
    let y = 1.0 - poly * (-x * x).exp();
    y.copysign(x)
}

/// The inverse error function (Giles 2010, "Approximating the erfinv
/// function", single-precision version).
fn erf_inv(x: f32) -> f32 {
    let x = x.clamp(-0.999_999_9, 0.999_999_9);
    let mut w = -((1.0 - x) * (1.0 + x)).ln();
    let p = if w < 5.0 {
        w -= 2.5;
        let mut p = 2.810_226_4e-8;
        for c in [
            3.432_739_4e-7,
            -3.523_387_7e-6,
            -4.391_506_5e-6,
            0.000_218_580_87,
            -0.001_253_725,
            -0.004_177_681_6,
            0.246_640_73,
            1.501_409_4,
        ] {
            p = c + p * w;
        }
        p
    } else {
        w = w.sqrt() - 3.0;
        let mut p = -0.000_200_214_25;
        for c in [
            0.000_100_950_56,
            0.001_349_343_2,
            -0.003_673_428_4,
            0.005_739_507_7,
            -0.007_622_461,
            0.009_438_870_5,
            1.001_674,
            2.832_976_8,
        ] {
            p = c + p * w;
        }
        p
    };
    p * x
}

#[cfg(test)]
mod tests;
