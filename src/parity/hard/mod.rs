//! Hard numerical cases, each a generated scene and ray set with an
//! expected answer, run against every configuration of
//! [`hard_case_modes`]: native Möller–Trumbore, native watertight, and each
//! Embree present, plain and with its robust flag.
//!
//! Every case counts the rays whose answer breaks the expectation (a leak,
//! a false hit, a wrong distance, a self-intersection), the NaN answers and
//! the panics; nothing is only asserted, everything is printed.
//!
//! - this file: what a case is and the harness that runs it;
//! - [`families`]: the cases, one function per family;
//! - [`table`]: the table of outcomes.

mod families;
mod table;

pub use self::table::format_table;

use std::panic::{catch_unwind, AssertUnwindSafe};

use glam::Vec3;

use crate::accel::config::hard_case_modes;
use crate::accel::native::triangle::{MollerTrumbore, TriangleMode, TriangleTest, Watertight};
use crate::accel::{Accel, AccelError, BackendConfig, TraceCounters};
use crate::geom::{Hit, Ray};
use crate::scene::Scene;

/// What a ray should find.
#[derive(Clone, Copy, Debug)]
pub enum Expect {
    /// Something, anywhere: a miss is a leak.
    Hit,
    /// Something, no farther than `t` (relative slack 1e-3): a miss, or a
    /// first hit beyond the aimed point, is a leak.
    HitBy(f32),
    /// Something at `t` within the relative tolerance.
    HitAt(f32, f32),
    /// Nothing: a hit is a false hit (or a self-intersection).
    Miss,
    /// Not this primitive (a degenerate one): hitting it is a false hit.
    NotPrimitive(u32),
    /// Measured only.
    Anything,
}

/// One hard case.
pub struct Case {
    pub name: String,
    /// What a failure of the expectation is called in the table.
    pub failure: &'static str,
    pub scene: Scene,
    pub rays: Vec<(Ray, Expect)>,
    /// Whether the watertight design promises zero failures here.
    pub watertight_promise: bool,
    /// For edge-aimed rays: the two triangles sharing the edge, to count
    /// double hits with the native triangle tests.
    pub edge_pairs: Vec<Option<(u32, u32)>>,
}

impl Case {
    /// A case without edge-aimed rays, outside the watertight promise.
    fn new(
        name: impl Into<String>,
        failure: &'static str,
        scene: Scene,
        rays: Vec<(Ray, Expect)>,
    ) -> Case {
        Case {
            name: name.into(),
            failure,
            scene,
            rays,
            watertight_promise: false,
            edge_pairs: Vec::new(),
        }
    }
}

/// A case's outcome for one mode.
#[derive(Clone, Debug, Default)]
pub struct Outcome {
    pub rays: usize,
    pub failures: usize,
    pub nans: usize,
    pub panics: usize,
    /// Rays that hit both triangles of the edge they aim at (native only).
    pub double_hits: Option<usize>,
    /// Largest relative `t` error among `HitAt` rays that hit.
    pub worst_t_error: f32,
}

pub struct CaseReport {
    pub name: String,
    pub failure: &'static str,
    pub watertight_promise: bool,
    pub outcomes: Vec<(BackendConfig, Outcome)>,
}

fn is_nan(h: &Hit) -> bool {
    !h.t.is_finite() || h.u.is_nan() || h.v.is_nan()
}

fn judge(expect: Expect, hit: Option<Hit>) -> (bool, f32) {
    match (expect, hit) {
        (Expect::Hit, h) => (h.is_some(), 0.0),
        (Expect::HitBy(t), Some(h)) => (h.t <= t * (1.0 + 1e-3), 0.0),
        (Expect::HitBy(_), None) => (false, 0.0),
        (Expect::HitAt(t, tol), Some(h)) => {
            let e = (h.t - t).abs() / t.abs().max(f32::MIN_POSITIVE);
            (e <= tol, e)
        }
        (Expect::HitAt(..), None) => (false, 0.0),
        (Expect::Miss, h) => (h.is_none(), 0.0),
        (Expect::NotPrimitive(p), h) => (h.is_none_or(|h| h.prim != p), 0.0),
        (Expect::Anything, _) => (true, 0.0),
    }
}

/// Runs one case on one configuration.
pub fn run_case(case: &Case, mode: &BackendConfig) -> Result<Outcome, AccelError> {
    let accel = mode.build(&case.scene)?;
    let mut out = Outcome {
        rays: case.rays.len(),
        ..Outcome::default()
    };
    let mut counters = TraceCounters::default();
    for (ray, expect) in &case.rays {
        let hit = match catch_unwind(AssertUnwindSafe(|| accel.closest_hit(ray, &mut counters))) {
            Ok(h) => h,
            Err(_) => {
                out.panics += 1;
                continue;
            }
        };
        if hit.as_ref().is_some_and(is_nan) {
            out.nans += 1;
        }
        let (ok, t_error) = judge(*expect, hit);
        if !ok {
            out.failures += 1;
        }
        out.worst_t_error = out.worst_t_error.max(t_error);
    }
    if let (false, BackendConfig::Native(options)) = (case.edge_pairs.is_empty(), mode) {
        let doubles = case
            .rays
            .iter()
            .zip(&case.edge_pairs)
            .filter(|(_, pair)| pair.is_some())
            .filter(|((ray, _), pair)| {
                let (a, b) = pair.unwrap();
                let test = |t: u32| {
                    let [p, q, r] = case.scene.mesh.corners(t as usize);
                    match options.triangle {
                        TriangleMode::MollerTrumbore => hits::<MollerTrumbore>([p, q, r], ray),
                        TriangleMode::Watertight => hits::<Watertight>([p, q, r], ray),
                    }
                };
                test(a) && test(b)
            })
            .count();
        out.double_hits = Some(doubles);
    }
    Ok(out)
}

/// Whether triangle test `T` reports a hit of `ray` on a triangle.
fn hits<T: TriangleTest>([p, q, r]: [Vec3; 3], ray: &Ray) -> bool {
    T::intersect(&T::prepare(p, q, r), &T::setup(ray), ray.t_min, ray.t_max).is_some()
}

/// Runs every case on every configuration of [`hard_case_modes`].
pub fn run_all(cases: &[Case]) -> Result<Vec<CaseReport>, AccelError> {
    let modes = hard_case_modes();
    cases
        .iter()
        .map(|case| {
            let outcomes = modes
                .iter()
                .map(|m| run_case(case, m).map(|o| (*m, o)))
                .collect::<Result<Vec<_>, _>>()?;
            Ok(CaseReport {
                name: case.name.clone(),
                failure: case.failure,
                watertight_promise: case.watertight_promise,
                outcomes,
            })
        })
        .collect()
}

/// The hard cases; `scanned` adds a shared scanned mesh when given. The
/// notes say what could not become a case, and why.
pub fn cases(rays_per_case: usize, seed: u64, scanned: Option<&Scene>) -> (Vec<Case>, Vec<String>) {
    let n = rays_per_case.max(100);
    let mut notes = Vec::new();
    let mut cases = families::closed_meshes(n, seed, scanned, &mut notes);
    cases.extend(families::far_from_the_origin(n, seed));
    cases.push(families::axis_aligned_rays(n, seed));
    cases.push(families::parallel_rays(n, seed));
    cases.push(families::grazing_rays(n, seed));
    cases.extend(families::tiny_and_huge_triangles(n, seed));
    cases.push(families::degenerate_triangles(n, seed));
    cases.extend(families::rays_leaving_a_surface(n, seed));
    cases.extend(families::junctions(n, seed));
    cases.extend(families::spheres(n, seed));
    cases.push(families::untraceable_rays(n));
    (cases, notes)
}
