//! Light sampling: for a shading point, a direction towards a light, the
//! radiance arriving along it, and its density (`sample_li`); the density
//! of any direction that reaches a light (`pdf_li`, for multiple importance
//! sampling); which lights a vertex samples and how often (`LightSet`);
//! and what escaped rays see.

use std::collections::HashMap;
use std::sync::Arc;

use glam::Vec3;

use crate::geom::sampling::{cosine_hemisphere, luminance, uniform_sphere, Frame, Rng};
use crate::scene::environment::Environment;
use crate::scene::{Light, Scene};

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
    /// The density (solid angle) the direction was drawn with; infinite for
    /// delta lights, which no other strategy can find.
    pub pdf: f32,
}

/// Solid-angle density at `p` of a point `q` with normal `normal` drawn
/// uniformly on an emitter of total `area`: `d² / (cos · A)`; zero from
/// behind.
fn area_to_solid_angle(p: Vec3, q: Vec3, normal: Vec3, area: f32) -> f32 {
    let to = q - p;
    let d2 = to.length_squared();
    if d2 == 0.0 {
        return 0.0;
    }
    let cos_light = -to.dot(normal) / d2.sqrt();
    if cos_light <= 0.0 {
        return 0.0;
    }
    d2 / (cos_light * area)
}

/// The sample for point `q` (normal `normal`) drawn uniformly on an
/// emitter of total `area`, seen from `p`.
fn from_area_point(
    p: Vec3,
    q: Vec3,
    normal: Vec3,
    area: f32,
    radiance: Vec3,
) -> Option<LightSample> {
    let pdf = area_to_solid_angle(p, q, normal, area);
    if !(pdf > 0.0) || !pdf.is_finite() {
        return None;
    }
    let to = q - p;
    let distance = to.length();
    Some(LightSample {
        wi: to / distance,
        distance,
        contribution: radiance / pdf,
        pdf,
    })
}

/// Which way a vertex faces, for the ambient light's sampling: its
/// geometric normal (facing the side being lit) and, where shadow rays
/// leave from the point lifted onto the smooth surface (the
/// shadow-terminator fix), its shading normal too, since such a point
/// takes light from in front of either.
#[derive(Clone, Copy, Debug)]
pub struct Facing {
    pub geometric: Vec3,
    pub smooth: Option<Vec3>,
}

impl Facing {
    pub fn geometric(n: Vec3) -> Facing {
        Facing {
            geometric: n,
            smooth: None,
        }
    }

    /// The ambient light's density of direction `wi`: cosine-weighted
    /// around the geometric normal, or half around each normal.
    fn ambient_pdf(&self, wi: Vec3) -> f32 {
        let cosine = |n: Vec3| wi.dot(n).max(0.0) * std::f32::consts::FRAC_1_PI;
        match self.smooth {
            None => cosine(self.geometric),
            Some(ns) => 0.5 * (cosine(self.geometric) + cosine(ns)),
        }
    }
}

/// Samples `light` as seen from `p` facing `facing`. `None` when the
/// sample carries no light.
pub fn sample_li(light: &Light, p: Vec3, facing: Facing, rng: &mut Rng) -> Option<LightSample> {
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
                pdf: f32::INFINITY,
            })
        }
        Light::Directional { to_light, radiance } => Some(LightSample {
            wi: to_light,
            distance: f32::INFINITY,
            contribution: radiance,
            pdf: f32::INFINITY,
        }),
        Light::Sphere {
            center,
            radius,
            radiance,
            ..
        } => {
            // Uniform over the sphere's area; the far side faces away and
            // gives nothing.
            let (u, v) = rng.next_2d();
            let normal = uniform_sphere(u, v);
            let area = 4.0 * std::f32::consts::PI * radius * radius;
            from_area_point(p, center + normal * radius, normal, area, radiance)
        }
        Light::Ambient { radiance } => {
            // Cosine-weighted around the normal (or, with a smooth normal,
            // around either, picked by the first number).
            let (u, v) = rng.next_2d();
            let (around, u) = match facing.smooth {
                Some(ns) if u >= 0.5 => (ns, 2.0 * u - 1.0),
                Some(_) => (facing.geometric, 2.0 * u),
                None => (facing.geometric, u),
            };
            let local = cosine_hemisphere(u.min(1.0 - f32::EPSILON / 2.0), v);
            let wi = Frame::new(around).to_world(local);
            if wi.y <= 0.0 || local.z <= 0.0 {
                return None;
            }
            let pdf = facing.ambient_pdf(wi);
            Some(LightSample {
                wi,
                distance: f32::INFINITY,
                contribution: radiance / pdf,
                pdf,
            })
        }
    }
}

/// Samples the environment map (`-e`): a direction drawn from the map as a
/// light sample at infinity.
pub fn sample_environment(env: &Environment, rng: &mut Rng) -> Option<LightSample> {
    let (u, v) = rng.next_2d();
    let s = env.sample(u, v)?;
    Some(LightSample {
        wi: s.wi,
        distance: f32::INFINITY,
        contribution: s.radiance / s.pdf,
        pdf: s.pdf,
    })
}

/// The density with which [`sample_li`] on `light` from `p` (facing
/// `facing`) draws the direction that reaches point `q` of the light
/// (normal `q_normal`), or direction `wi` for the ambient light.
pub fn pdf_li(light: &Light, p: Vec3, facing: Facing, q: Vec3, q_normal: Vec3, wi: Vec3) -> f32 {
    match *light {
        Light::Area(a) => area_to_solid_angle(p, q, a.normal, a.area),
        Light::Sphere { radius, .. } => {
            area_to_solid_angle(p, q, q_normal, 4.0 * std::f32::consts::PI * radius * radius)
        }
        Light::Ambient { .. } => facing.ambient_pdf(wi),
        Light::Point { .. } | Light::Directional { .. } => 0.0,
    }
}

/// Which lights a vertex samples, and with what probability each sample
/// picks a light:
/// - the file's own lights (area rectangles, ambient) take `-l` samples
///   each, as in the course;
/// - emissive triangles and spheres (one light per triangle of an emissive
///   mesh) share `-l` samples, each choosing an emitter with probability
///   proportional to its power, so a lamp of ten thousand triangles costs
///   one shadow ray per sample, not ten thousand;
/// - the environment map takes `-l` samples;
/// - delta lights (point, directional) take one sample each.
pub struct LightSet {
    pub each: Vec<Light>,
    pub emitters: Vec<Light>,
    /// Cumulative selection probabilities of `emitters`.
    emitter_cdf: Vec<f32>,
    pub delta: Vec<Light>,
    /// For every primitive that is a light's surface: the light's group
    /// and index (for the density of a BSDF-sampled ray that hits it).
    by_primitive: HashMap<u32, LightRef>,
    /// Index into `each` of the ambient light, if any.
    ambient: Option<usize>,
    pub environment: Option<Arc<Environment>>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightRef {
    Each(usize),
    Emitter(usize),
}

impl LightSet {
    pub fn new(scene: &Scene) -> LightSet {
        let mut set = LightSet {
            each: Vec::new(),
            emitters: Vec::new(),
            emitter_cdf: Vec::new(),
            delta: Vec::new(),
            by_primitive: HashMap::new(),
            ambient: None,
            environment: scene.environment.clone(),
        };
        let mut refs = Vec::with_capacity(scene.lights.len());
        for light in &scene.lights {
            let r = match light {
                Light::Point { .. } | Light::Directional { .. } => {
                    set.delta.push(*light);
                    None
                }
                Light::Area(a) if a.triangle => {
                    set.emitters.push(*light);
                    Some(LightRef::Emitter(set.emitters.len() - 1))
                }
                Light::Sphere { .. } => {
                    set.emitters.push(*light);
                    Some(LightRef::Emitter(set.emitters.len() - 1))
                }
                Light::Area(_) | Light::Ambient { .. } => {
                    if matches!(light, Light::Ambient { .. }) {
                        set.ambient = Some(set.each.len());
                    }
                    set.each.push(*light);
                    Some(LightRef::Each(set.each.len() - 1))
                }
            };
            refs.push(r);
        }
        for (prim, light) in scene.light_surfaces() {
            if let Some(r) = refs[light] {
                set.by_primitive.insert(prim, r);
            }
        }
        let power: Vec<f64> = set
            .emitters
            .iter()
            .map(|l| match *l {
                Light::Area(a) => luminance(a.radiance) as f64 * a.area as f64,
                Light::Sphere {
                    radius, radiance, ..
                } => {
                    luminance(radiance) as f64
                        * (radius as f64).powi(2)
                        * 4.0
                        * std::f64::consts::PI
                }
                _ => 0.0,
            })
            .collect();
        let total: f64 = power.iter().sum();
        let mut acc = 0.0;
        set.emitter_cdf = power
            .iter()
            .map(|p| {
                acc += if total > 0.0 {
                    p / total
                } else {
                    1.0 / power.len() as f64
                };
                acc as f32
            })
            .collect();
        if let Some(last) = set.emitter_cdf.last_mut() {
            *last = 1.0;
        }
        set
    }

    /// The lights a vertex samples (the delta lights, then the others in
    /// their order), when they are all point and directional lights,
    /// rectangular area lights of the file's and the ambient light (no
    /// emitting triangle or sphere, nor map): the lights the wavefront
    /// samples in lanes ([`crate::render::wavefront::Plan`]).
    pub fn plain(&self) -> Option<(&[Light], &[Light])> {
        let each = self.each.iter().all(|l| match l {
            Light::Area(a) => !a.triangle,
            Light::Ambient { .. } => true,
            _ => false,
        });
        let plain = self.emitters.is_empty()
            && self.environment.is_none()
            && each
            && !(self.delta.is_empty() && self.each.is_empty());
        plain.then_some((&self.delta[..], &self.each[..]))
    }

    /// Probability that one emitter sample picks emitter `i`.
    pub fn emitter_pmf(&self, i: usize) -> f32 {
        let below = if i == 0 { 0.0 } else { self.emitter_cdf[i - 1] };
        self.emitter_cdf[i] - below
    }

    /// An emitter chosen by power with `u` in [0, 1): index and probability.
    pub fn pick_emitter(&self, u: f32) -> (usize, f32) {
        let i = self
            .emitter_cdf
            .partition_point(|&c| c <= u)
            .min(self.emitters.len() - 1);
        (i, self.emitter_pmf(i))
    }

    /// The light whose surface primitive `prim` is, if any.
    pub fn light_of(&self, prim: u32) -> Option<LightRef> {
        self.by_primitive.get(&prim).copied()
    }

    /// The ambient light, sampled like the file's lights.
    pub fn ambient(&self) -> Option<&Light> {
        self.ambient.map(|i| &self.each[i])
    }

    /// Sample groups that light sampling (or hemisphere sampling) takes
    /// `-l` samples of: one per file light, one for all emitters, one for
    /// the environment map.
    pub fn groups(&self) -> usize {
        self.each.len()
            + usize::from(!self.emitters.is_empty())
            + usize::from(self.environment.is_some())
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
