//! Scattering at a surface: evaluation and importance sampling of each
//! material of the dialect, in the local frame of the shading normal
//! (z = normal, both directions pointing away from the surface).

use glam::Vec3;
use std::f32::consts::{FRAC_1_PI, PI};

use super::sampling::{cosine_hemisphere, Rng};
use crate::scene::Material;

/// A sampled direction and its throughput weight `f * |cos| / pdf`.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    pub wi: Vec3,
    pub weight: Vec3,
    /// True for perfectly specular (delta) events: no light sampling there.
    pub specular: bool,
}

/// True for materials whose BSDF is a delta distribution (or emits only):
/// light sampling is skipped there.
pub fn is_specular(m: &Material) -> bool {
    matches!(
        m,
        Material::Mirror { .. } | Material::Glass { .. } | Material::Refraction { .. }
    )
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

/// BSDF value `f(wo, wi)` for non-delta materials (zero for delta ones).
pub fn eval(m: &Material, wo: Vec3, wi: Vec3) -> Vec3 {
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return Vec3::ZERO;
    }
    match *m {
        Material::Lambertian { albedo, .. } => albedo * FRAC_1_PI,
        Material::Microfacet { alpha, eta, k } => {
            let h = (wo + wi).normalize_or_zero();
            if h == Vec3::ZERO {
                return Vec3::ZERO;
            }
            let f = fresnel_conductor(wi.dot(h), eta, k);
            f * beckmann_d(h, alpha) * smith_g(wo, wi, alpha) / (4.0 * wo.z * wi.z)
        }
        _ => Vec3::ZERO,
    }
}

/// Samples an incoming direction for outgoing `wo` (local frame; `wo.z` may
/// be negative only for dielectrics, seen from inside).
pub fn sample(m: &Material, wo: Vec3, rng: &mut Rng) -> Option<BsdfSample> {
    let (u, v) = rng.next_2d();
    match *m {
        Material::Lambertian { albedo, .. } => {
            if wo.z <= 0.0 {
                return None;
            }
            let wi = cosine_hemisphere(u, v);
            Some(BsdfSample {
                wi,
                weight: albedo,
                specular: false,
            })
        }
        Material::Emission { .. } => None,
        Material::Mirror { reflectance } => Some(BsdfSample {
            wi: Vec3::new(-wo.x, -wo.y, wo.z),
            weight: reflectance,
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
                    specular: true,
                })
            } else {
                let wi = refract(wo, eta)?;
                // Radiance is compressed by eta^2 when it enters a denser
                // medium (pbrt-v4 §9.5.2, non-symmetric scattering).
                Some(BsdfSample {
                    wi,
                    weight: transmittance / (eta * eta),
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
                specular: true,
            })
        }
        Material::Microfacet { alpha, .. } => {
            if wo.z <= 0.0 {
                return None;
            }
            // Sample h with density D(h) cos(theta_h) (Walter et al. 2007).
            let tan2 = -alpha * alpha * (1.0 - u).max(1e-12).ln();
            let cos_h = 1.0 / (1.0 + tan2).sqrt();
            let sin_h = (1.0 - cos_h * cos_h).max(0.0).sqrt();
            let phi = 2.0 * PI * v;
            let h = Vec3::new(sin_h * phi.cos(), sin_h * phi.sin(), cos_h);
            let wi = 2.0 * wo.dot(h) * h - wo;
            if wi.z <= 0.0 || wo.dot(h) <= 0.0 {
                return None;
            }
            let pdf = beckmann_d(h, alpha) * cos_h / (4.0 * wo.dot(h));
            if pdf <= 0.0 {
                return None;
            }
            let weight = eval(m, wo, wi) * wi.z / pdf;
            Some(BsdfSample {
                wi,
                weight,
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

/// Smith shadowing-masking for Beckmann, rational approximation of Walter
/// et al. 2007 (eq. 27).
fn smith_g(wo: Vec3, wi: Vec3, alpha: f32) -> f32 {
    let g1 = |w: Vec3| {
        let cos = w.z;
        let tan = (1.0 - cos * cos).max(0.0).sqrt() / cos;
        if tan == 0.0 {
            return 1.0;
        }
        let a = 1.0 / (alpha * tan);
        if a >= 1.6 {
            1.0
        } else {
            (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a)
        }
    };
    g1(wo) * g1(wi)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn microfacet_sampling_matches_its_evaluation() {
        // E[weight] = integral f cos over the hemisphere, estimated both by
        // importance sampling and by uniform sampling; they must agree.
        let m = Material::Microfacet {
            alpha: 0.3,
            eta: Vec3::splat(0.2),
            k: Vec3::splat(3.0),
        };
        let wo = Vec3::new(0.4, 0.1, 0.91).normalize();
        let mut rng = Rng::new(1, 2);
        let n = 400_000;
        let mut importance = 0.0f64;
        let mut uniform = 0.0f64;
        for _ in 0..n {
            if let Some(s) = sample(&m, wo, &mut rng) {
                importance += s.weight.x as f64;
            }
            let (u, v) = rng.next_2d();
            let wi = super::super::sampling::uniform_hemisphere(u, v);
            uniform += (eval(&m, wo, wi).x * wi.z) as f64 * 2.0 * std::f64::consts::PI;
        }
        let (a, b) = (importance / n as f64, uniform / n as f64);
        assert!(
            (a - b).abs() < 0.02 * b.max(0.05),
            "importance {a:.4} vs uniform {b:.4}"
        );
    }

    #[test]
    fn glass_reflectance_at_normal_incidence() {
        let f = fresnel_dielectric(1.0, 1.5);
        assert!((f - 0.04).abs() < 1e-4, "F(0) = {f}");
    }
}
