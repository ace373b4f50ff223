//! The parity suite: the same rays through every backend, compared hit by
//! hit against the native watertight BVH (the accuracy reference).
//!
//! - [`rays`]: the ray sets (camera, random, bounce, shadow, grazing);
//! - [`hard`]: generated hard cases, measured per backend and mode.
//!
//! Tolerances and thresholds are stated here once, and in `docs/parity.md`.

pub mod hard;
pub mod rays;

use glam::Vec3;

use crate::accel::config::{parity_candidates, PARITY_REFERENCE};
use crate::accel::{Accel, AccelError, Backend, BackendConfig, Coherence, TraceCounters};
use crate::geom::{Hit, Ray};
use crate::scene::Scene;

/// Hits agree in distance when
/// `|t_a - t_b| <= T_RELATIVE * max(t_a, scene size / 100)`: rounding error
/// scales with the coordinates, not with t, so very short hits are judged
/// on the scene's scale.
pub const T_RELATIVE: f32 = 1e-4;
/// Grazing rays (within 0.5 degrees of the surface) amplify a position
/// error e normal to the surface into a t error e / sin(angle) (up to
/// ~100x at 0.5 degrees), so their t tolerance is 100x looser.
pub const T_RELATIVE_GRAZING: f32 = 1e-2;
/// Normals agree within this angle (degrees).
pub const NORMAL_DEGREES: f32 = 0.1;
/// Minimum share of rays with the same hit/miss answer.
pub const MIN_HIT_AGREEMENT: f64 = 0.999;
/// Minimum share of common hits with agreeing `t`, and with the same
/// primitive or a tie (another primitive at the same `t`).
pub const MIN_T_AGREEMENT: f64 = 0.999;
pub const MIN_PRIMITIVE_AGREEMENT: f64 = 0.999;
/// Minimum share of same-primitive hits whose normals agree.
pub const MIN_NORMAL_AGREEMENT: f64 = 0.999;
/// Grazing rays skim surfaces by design; they get a looser bound.
pub const MIN_GRAZING_AGREEMENT: f64 = 0.99;

/// How far a backend's batch answer may stand from its own single-ray
/// answer when the backend does not control both (Embree): the same hit or
/// miss, the same primitive or another at an agreeing `t` (a tie on an
/// edge), and `|t_batch - t_single| <= BATCH_T_RELATIVE * max(t, scene
/// size / 100)`. Embree's packet kernels differ from its single-ray kernel
/// by ISA (an approximate reciprocal refined by a Newton step, another
/// order of operations), so their `t` can move by an ulp or two of the
/// hit's coordinates, not of `t`: on sky/CBspheres_lambertian.dae Embree
/// 3's AVX2 packets put a hit at t = 0.0010674894 that its single-ray
/// kernel puts at 0.0010675192 (3e-8 apart, 1.5e-8 of the scene's size).
/// Native's batch and single answers are the same bits (it runs the same
/// operations lane by lane), which is checked exactly.
pub const BATCH_T_RELATIVE: f32 = 1e-5;

/// One backend configuration under test.
pub struct Candidate<'s> {
    pub name: String,
    pub accel: Backend<'s>,
    /// Whether its batch query must give its single-ray answers bit for
    /// bit (native, brute force) or within [`BATCH_T_RELATIVE`] (Embree).
    pub batch_exact: bool,
}

impl<'s> Candidate<'s> {
    pub fn build(config: &BackendConfig, scene: &'s Scene) -> Result<Candidate<'s>, AccelError> {
        Ok(Candidate {
            name: config.label(),
            accel: config.build(scene)?,
            batch_exact: !matches!(config, BackendConfig::Embree(_)),
        })
    }
}

/// Whether `batch` is an answer `single` allows in a scene of size
/// `scene_size` (its bounds' largest extent): the same bits of `t`,
/// primitive and barycentrics when `exact`, else within
/// [`BATCH_T_RELATIVE`].
pub fn batch_agrees(single: Option<Hit>, batch: Option<Hit>, exact: bool, scene_size: f32) -> bool {
    let t_floor = 0.01 * scene_size;
    match (single, batch) {
        (None, None) => true,
        (Some(s), Some(b)) if exact => {
            (s.t.to_bits(), s.prim, s.u.to_bits(), s.v.to_bits())
                == (b.t.to_bits(), b.prim, b.u.to_bits(), b.v.to_bits())
        }
        (Some(s), Some(b)) => (s.t - b.t).abs() <= BATCH_T_RELATIVE * s.t.abs().max(t_floor),
        _ => false,
    }
}

/// The reference ([`PARITY_REFERENCE`]) and the candidates
/// ([`parity_candidates`] that suit the scene) for `scene`.
pub fn candidates(scene: &Scene) -> Result<(Candidate<'_>, Vec<Candidate<'_>>), AccelError> {
    let reference = Candidate::build(&PARITY_REFERENCE, scene)?;
    let list = parity_candidates()
        .iter()
        .filter(|c| c.suits(scene))
        .map(|c| Candidate::build(c, scene))
        .collect::<Result<_, _>>()?;
    Ok((reference, list))
}

/// Agreement of one candidate with the reference on one ray set.
#[derive(Clone, Debug, Default)]
pub struct Agreement {
    pub backend: String,
    pub rays: usize,
    pub same_hit_or_miss: usize,
    pub both_hit: usize,
    pub t_agree: usize,
    /// Same primitive, or a different one at an agreeing `t` (a tie).
    pub primitive_agree: usize,
    pub ties: usize,
    pub same_primitive: usize,
    pub normal_agree: usize,
    pub worst_geometric_degrees: f32,
    pub worst_shading_degrees: f32,
    /// Rays whose answer through the candidate's batch query
    /// ([`crate::accel::Accel::closest_hits`]: packets) is not one its
    /// single-ray answer allows ([`BATCH_T_RELATIVE`]).
    pub batch_differs: usize,
    /// The worst disagreement seen, for the reader.
    pub worst_case: String,
}

fn share(n: usize, of: usize) -> f64 {
    if of == 0 {
        1.0
    } else {
        n as f64 / of as f64
    }
}

impl Agreement {
    pub fn hit_rate(&self) -> f64 {
        share(self.same_hit_or_miss, self.rays)
    }
    pub fn t_rate(&self) -> f64 {
        share(self.t_agree, self.both_hit)
    }
    pub fn primitive_rate(&self) -> f64 {
        share(self.primitive_agree, self.both_hit)
    }
    pub fn normal_rate(&self) -> f64 {
        share(self.normal_agree, self.same_primitive)
    }

    /// Whether the thresholds hold (`min` for hit/miss, t and primitive)
    /// and the batch query answers as single rays do.
    pub fn passes(&self, min: f64) -> bool {
        self.batch_differs == 0
            && self.hit_rate() >= min
            && self.t_rate() >= min
            && self.primitive_rate() >= min
            && self.normal_rate() >= MIN_NORMAL_AGREEMENT
    }
}

/// Angle between unit vectors; atan2 of the cross and dot products keeps
/// precision near zero, where `acos` of a dot product cannot resolve less
/// than ~0.03 degrees in f32.
fn angle_degrees(a: Vec3, b: Vec3) -> f32 {
    a.cross(b).length().atan2(a.dot(b)).to_degrees()
}

/// Compares `candidate` with `reference` on `rays`.
pub fn compare(
    scene: &Scene,
    reference: &Candidate,
    candidate: &Candidate,
    rays: &[Ray],
    t_relative: f32,
) -> Agreement {
    let mut a = Agreement {
        backend: candidate.name.clone(),
        rays: rays.len(),
        ..Agreement::default()
    };
    let scene_size = scene.bounds().extent().max_element();
    let t_floor = 0.01 * scene_size;
    let mut worst_dt = 0.0f32;
    let trace = |accel: &Backend, r: &Ray| accel.closest_hit(r, &mut TraceCounters::default());
    let mut batch = vec![None; rays.len()];
    candidate.accel.closest_hits(
        rays,
        Coherence::Incoherent,
        &mut batch,
        &mut TraceCounters::default(),
    );
    for (ray, in_batch) in rays.iter().zip(&batch) {
        let (x, y): (Option<Hit>, Option<Hit>) =
            (trace(&reference.accel, ray), trace(&candidate.accel, ray));
        if !batch_agrees(y, *in_batch, candidate.batch_exact, scene_size) {
            a.batch_differs += 1;
            a.worst_case = format!(
                "batch query {} vs single {} for {:?}",
                describe(*in_batch),
                describe(y),
                ray
            );
        }
        match (x, y) {
            (None, None) => a.same_hit_or_miss += 1,
            (Some(x), Some(y)) => {
                a.same_hit_or_miss += 1;
                a.both_hit += 1;
                let dt = (x.t - y.t).abs() / x.t.abs().max(t_floor);
                let t_ok = dt <= t_relative;
                if t_ok {
                    a.t_agree += 1;
                } else if dt > worst_dt {
                    worst_dt = dt;
                    a.worst_case = format!(
                        "t {} vs {} (primitives {} / {}) for {:?}",
                        x.t, y.t, x.prim, y.prim, ray
                    );
                }
                if x.prim == y.prim {
                    a.primitive_agree += 1;
                    a.same_primitive += 1;
                    let ng = angle_degrees(
                        scene.geometric_normal(ray, &x),
                        scene.geometric_normal(ray, &y),
                    );
                    let sx = scene.surface_point(ray, &x).shading_normal;
                    let sy = scene.surface_point(ray, &y).shading_normal;
                    let ns = angle_degrees(sx, sy);
                    a.worst_geometric_degrees = a.worst_geometric_degrees.max(ng);
                    a.worst_shading_degrees = a.worst_shading_degrees.max(ns);
                    if ng <= NORMAL_DEGREES && ns <= NORMAL_DEGREES {
                        a.normal_agree += 1;
                    }
                } else if t_ok {
                    a.primitive_agree += 1;
                    a.ties += 1;
                }
            }
            (x, y) => {
                if worst_dt < f32::INFINITY {
                    worst_dt = f32::INFINITY;
                    a.worst_case = format!("{} vs {} for {:?}", describe(x), describe(y), ray);
                }
            }
        }
    }
    a
}

fn describe(h: Option<Hit>) -> String {
    match h {
        Some(h) => format!("hit t={} primitive {}", h.t, h.prim),
        None => "miss".into(),
    }
}

/// One table of the parity report: a ray kind and every candidate's row.
pub struct RayKindTable {
    pub kind: &'static str,
    pub minimum: f64,
    pub t_relative: f32,
    pub rows: Vec<Agreement>,
}

/// Runs every ray kind through every candidate.
pub fn run_scene(scene: &Scene, n: usize, seed: u64) -> Result<Vec<RayKindTable>, AccelError> {
    let (reference, list) = candidates(scene)?;
    let sets: Vec<(&'static str, f64, f32, Vec<Ray>)> = vec![
        (
            "camera",
            MIN_HIT_AGREEMENT,
            T_RELATIVE,
            rays::camera_rays(scene, n, seed),
        ),
        (
            "random",
            MIN_HIT_AGREEMENT,
            T_RELATIVE,
            rays::random_rays(scene, n, seed),
        ),
        (
            "bounce",
            MIN_HIT_AGREEMENT,
            T_RELATIVE,
            rays::bounce_rays(scene, &reference.accel, n, seed),
        ),
        (
            "shadow",
            MIN_HIT_AGREEMENT,
            T_RELATIVE,
            rays::shadow_rays(scene, &reference.accel, n, seed),
        ),
        (
            "grazing",
            MIN_GRAZING_AGREEMENT,
            T_RELATIVE_GRAZING,
            rays::grazing_rays(scene, &reference.accel, n, seed),
        ),
    ];
    Ok(sets
        .into_iter()
        .map(|(kind, minimum, t_relative, rays)| RayKindTable {
            kind,
            minimum,
            t_relative,
            rows: list
                .iter()
                .map(|c| compare(scene, &reference, c, &rays, t_relative))
                .collect(),
        })
        .collect())
}

/// The tables as Markdown.
pub fn format_tables(tables: &[RayKindTable]) -> String {
    let mut out = String::new();
    for t in tables {
        out += &format!(
            "\n{} rays (reference: {}; t within {:.0e} relative; pass: >= {:.1}% agreement)\n\n| backend | rays | hit/miss agree | t agree | same primitive (ties) | geometric normal max | shading normal max | batch ≠ single | pass |\n|---|---|---|---|---|---|---|---|---|\n",
            t.kind,
            PARITY_REFERENCE.label(),
            t.t_relative,
            t.minimum * 100.0
        );
        for r in &t.rows {
            out += &format!(
                "| {} | {} | {:.3}% | {:.3}% | {:.3}% ({}) | {:.4}° | {:.4}° | {} | {} |\n",
                r.backend,
                r.rays,
                r.hit_rate() * 100.0,
                r.t_rate() * 100.0,
                r.primitive_rate() * 100.0,
                r.ties,
                r.worst_geometric_degrees,
                r.worst_shading_degrees,
                r.batch_differs,
                if r.passes(t.minimum) { "yes" } else { "NO" }
            );
        }
        for r in t.rows.iter().filter(|r| !r.worst_case.is_empty()) {
            out += &format!("\n- worst {}: {}", r.backend, r.worst_case);
        }
        out += "\n";
    }
    out
}
