//! Light sampling: for a shading point, a direction towards a light, the
//! radiance arriving along it, and its density (`sample_li`), plus what
//! escaped rays see.

use glam::Vec3;

use super::sampling::{cosine_hemisphere, uniform_sphere, Frame, Rng};
use crate::scene::Light;

/// Incident light from one sample of a light.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Unit direction from the shading point towards the light.
    pub wi: Vec3,
    /// Distance to the sampled point (infinite for lights at infinity).
    pub distance: f32,
    /// Incident radiance divided by the sample's density (solid angle), so
    /// that `f * cos * contribution` is the estimate.
    pub contribution: Vec3,
}

/// The sample for point `q` (normal `normal`) drawn uniformly on an
/// emitter of total `area`, seen from `p`: the area density 1/A becomes
/// the solid-angle density d^2 / (cos A).
fn from_area_point(
    p: Vec3,
    q: Vec3,
    normal: Vec3,
    area: f32,
    radiance: Vec3,
) -> Option<LightSample> {
    let to = q - p;
    let d2 = to.length_squared();
    if d2 == 0.0 {
        return None;
    }
    let distance = d2.sqrt();
    let wi = to / distance;
    let cos_light = -wi.dot(normal);
    if cos_light <= 0.0 {
        return None;
    }
    Some(LightSample {
        wi,
        distance,
        contribution: radiance * (cos_light * area / d2),
    })
}

/// Samples `light` as seen from `p` with normal `n` (facing the side being
/// lit). `None` when the sample carries no light.
pub fn sample_li(light: &Light, p: Vec3, n: Vec3, rng: &mut Rng) -> Option<LightSample> {
    match *light {
        Light::Area(a) => {
            let (u, v) = rng.next_2d();
            from_area_point(p, a.point_at(u, v), a.normal, a.area, a.radiance)
        }
        Light::Point {
            position,
            intensity,
        } => {
            let to = position - p;
            let d2 = to.length_squared();
            if d2 == 0.0 {
                return None;
            }
            let distance = d2.sqrt();
            Some(LightSample {
                wi: to / distance,
                distance,
                contribution: intensity / d2,
            })
        }
        Light::Directional { to_light, radiance } => Some(LightSample {
            wi: to_light,
            distance: f32::INFINITY,
            contribution: radiance,
        }),
        Light::Sphere {
            center,
            radius,
            radiance,
        } => {
            // Uniform over the sphere's area; the far side faces away and
            // gives nothing.
            let (u, v) = rng.next_2d();
            let normal = uniform_sphere(u, v);
            let area = 4.0 * std::f32::consts::PI * radius * radius;
            from_area_point(p, center + normal * radius, normal, area, radiance)
        }
        Light::Ambient { radiance } => {
            // Cosine-weighted around n: contribution = L / pdf = L pi / cos.
            let (u, v) = rng.next_2d();
            let local = cosine_hemisphere(u, v);
            let wi = Frame::new(n).to_world(local);
            if wi.y <= 0.0 || local.z <= 0.0 {
                return None;
            }
            Some(LightSample {
                wi,
                distance: f32::INFINITY,
                contribution: radiance * (std::f32::consts::PI / local.z),
            })
        }
    }
}

/// The summed radiance of the ambient lights: what an escaped ray going up
/// sees. Computed once per render, not per ray.
pub fn ambient_radiance(lights: &[Light]) -> Vec3 {
    lights
        .iter()
        .map(|l| match l {
            Light::Ambient { radiance } => *radiance,
            _ => Vec3::ZERO,
        })
        .sum()
}

/// Radiance that a ray escaping the scene in direction `dir` receives:
/// `ambient` (see [`ambient_radiance`]) from the +Y hemisphere.
#[inline]
pub fn escaped_radiance(ambient: Vec3, dir: Vec3) -> Vec3 {
    if dir.y > 0.0 {
        ambient
    } else {
        Vec3::ZERO
    }
}
