//! The `none` backend: every ray tests every primitive. The baseline that
//! shows what a BVH buys, and an independent reference for the BVH tests.

use std::time::Instant;

use glam::Vec3;

use super::native::sphere::intersect_sphere;
use super::native::triangle::{MollerTrumbore, TriangleTest};
use super::{Accel, AccelStats, TraceCounters};
use crate::geom::{Hit, Ray};
use crate::scene::Scene;

pub struct BruteForce {
    /// `v0, e1, e2` per triangle, in scene order.
    triangles: Vec<[Vec3; 3]>,
    spheres: Vec<(Vec3, f32)>,
    build_ms: f64,
}

impl BruteForce {
    pub fn build(scene: &Scene) -> BruteForce {
        let start = Instant::now();
        let triangles = (0..scene.mesh.len())
            .map(|i| {
                let [a, b, c] = scene.mesh.corners(i);
                MollerTrumbore::prepare(a, b, c)
            })
            .collect();
        let spheres = scene.spheres.iter().map(|s| (s.center, s.radius)).collect();
        BruteForce {
            triangles,
            spheres,
            build_ms: start.elapsed().as_secs_f64() * 1e3,
        }
    }

    fn search(&self, ray: &Ray, any: bool, counters: &mut TraceCounters) -> Option<Hit> {
        counters.rays += 1;
        if !ray.is_traceable() {
            return None;
        }
        let setup = MollerTrumbore::setup(ray);
        let mut best: Option<Hit> = None;
        let mut t_max = ray.t_max;
        for (i, tri) in self.triangles.iter().enumerate() {
            counters.prim_tests += 1;
            if let Some((t, u, v)) = MollerTrumbore::intersect(tri, &setup, ray.t_min, t_max) {
                t_max = t;
                best = Some(Hit {
                    t,
                    prim: i as u32,
                    u,
                    v,
                });
                if any {
                    return best;
                }
            }
        }
        for (i, &(c, r)) in self.spheres.iter().enumerate() {
            counters.prim_tests += 1;
            if let Some(t) = intersect_sphere(c, r, ray, ray.t_min, t_max) {
                t_max = t;
                let prim = (self.triangles.len() + i) as u32;
                best = Some(Hit {
                    t,
                    prim,
                    u: 0.0,
                    v: 0.0,
                });
                if any {
                    return best;
                }
            }
        }
        best
    }
}

impl Accel for BruteForce {
    fn closest_hit(&self, ray: &Ray, counters: &mut TraceCounters) -> Option<Hit> {
        self.search(ray, false, counters)
    }

    fn occluded(&self, ray: &Ray, counters: &mut TraceCounters) -> bool {
        self.search(ray, true, counters).is_some()
    }

    fn stats(&self) -> AccelStats {
        AccelStats {
            backend: "none".into(),
            primitives: self.triangles.len() + self.spheres.len(),
            build_ms: self.build_ms,
            memory_bytes: self.triangles.len() * 36 + self.spheres.len() * 16,
            tree: None,
            batch_call: "closest_hit loop",
            details: format!(
                "no acceleration structure: every ray tests all {} primitives, Möller–Trumbore",
                self.triangles.len() + self.spheres.len()
            ),
        }
    }
}
