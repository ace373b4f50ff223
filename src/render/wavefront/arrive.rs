//! Arriving: what each path sees at its hit, which paths keep a slot,
//! their hit data gathered; the vertices the lanes do not take stepped
//! alone by the reference integrator's own code.

use glam::Vec3;

use super::lists::{lane, set_lane, sized};
use super::surface::{surface_pass, vertex_pass};
use super::{Alone, Plan, Wave, L};
use crate::accel::{Accel, TraceCounters};
use crate::geom::{Hit, Ray};
use crate::render::integrator::{Background, Deferred, Integrator, PathSettings, Span, Walk};
use crate::scene::Material;

impl Wave {
    /// What each ray's path sees at its hit, as [`Integrator::arrive`]
    /// counts it: the sky where it missed, emission where it hit a light.
    /// The paths that scatter there from a Lambertian vertex (below the
    /// last bounce) keep a slot, their vertices' hit data gathered into
    /// the lists and their surface points computed in lanes; the paths at
    /// a vertex of another material take the whole bounce alone
    /// ([`Self::alone`]) and keep a slot if they go on.
    pub(super) fn arrive<A: Accel>(
        &mut self,
        integrator: &Integrator<A>,
        plan: &Plan,
        counters: &mut TraceCounters,
    ) {
        let (scene, s) = (integrator.scene, &plan.s);
        self.alone.clear();
        self.tape.clear();
        let most = self.rays.len().div_ceil(L) * L;
        sized(&mut self.albedo, most);
        sized(std::slice::from_mut(&mut self.lanes), most);
        sized(std::slice::from_mut(&mut self.lit), most);
        self.from.clear();
        self.ray_of.clear();
        // Which paths keep a slot, and what the others see.
        for j in 0..self.rays.len() {
            let v = self.traced[j] as usize;
            let (ray, k, depth) = (self.rays[j], self.path[v] as usize, self.depth[v]);
            let Some(hit) = self.hits[j] else {
                let seen = !(depth == 0 && s.background == Background::Black);
                if plan.sky && s.counts(depth) && seen {
                    let (beta, prev) = (lane(&self.beta, v), self.prev(v));
                    self.total[k] += beta * integrator.escaped(s, &prev, ray.dir);
                }
                continue;
            };
            let m = &scene.materials[scene.material_of(hit.prim) as usize];
            let in_lanes = matches!(m, Material::Lambertian { .. } | Material::Emission { .. });
            let to = self.from.len();
            if !in_lanes || plan.lanes.is_none() {
                if self.alone(integrator, s, v, ray, hit, to, counters) {
                    self.from.push(v as u32);
                    self.ray_of.push(j as u32);
                    self.lanes[to] = 0.0;
                    self.lit[to] = 0.0;
                }
                continue;
            }
            if s.counts(depth) && m.emission() != Vec3::ZERO {
                let sp = scene.surface_point(&ray, &hit);
                let (beta, prev) = (lane(&self.beta, v), self.prev(v));
                self.total[k] =
                    integrator.with_emission(self.total[k], beta, s, &prev, m, &hit, &sp, ray.dir);
            }
            // An emitter's vertex adds nothing more: its light samples
            // and BSDF give zero.
            let Material::Lambertian { albedo, .. } = *m else {
                continue;
            };
            if depth >= s.last_bounce() {
                continue;
            }
            self.from.push(v as u32);
            self.ray_of.push(j as u32);
            self.lanes[to] = 1.0;
            self.lit[to] = if s.counts(depth + 1) { 1.0 } else { 0.0 };
            for a in 0..3 {
                self.albedo[a][to] = albedo[a];
            }
        }
        let count = self.from.len();
        let padded = count.div_ceil(L) * L;
        self.compact();
        // The vertices' lists: hit data gathered, padded with the last;
        // every other value is written by the surface pass.
        for lists in [
            &mut self.albedo,
            &mut self.dir,
            &mut self.w,
            &mut self.p,
            &mut self.error,
            &mut self.ng,
            &mut self.ns,
        ] {
            sized(lists, padded);
        }
        for k in 0..3 {
            sized(&mut self.corner[k], padded);
            sized(&mut self.normal[k], padded);
        }
        sized(std::slice::from_mut(&mut self.plain), padded);
        sized(std::slice::from_mut(&mut self.lanes), padded);
        sized(std::slice::from_mut(&mut self.lit), padded);
        if self.sphere.len() < padded {
            self.sphere.resize(padded, false);
        }
        self.lanes[count..padded].fill(0.0);
        self.lit[count..padded].fill(0.0);
        (self.count, self.padded) = (count, padded);
        let (rays, hits) = (&self.rays[..], &self.hits[..]);
        let (ray_of, lanes) = (&self.ray_of[..], &self.lanes[..]);
        let sphere = &mut self.sphere[..];
        let albedo = self.albedo.each_mut().map(|l| &mut l[..]);
        let dir = self.dir.each_mut().map(|l| &mut l[..]);
        let w = self.w.each_mut().map(|l| &mut l[..]);
        let corner = self
            .corner
            .each_mut()
            .map(|c| c.each_mut().map(|l| &mut l[..]));
        let normal = self
            .normal
            .each_mut()
            .map(|c| c.each_mut().map(|l| &mut l[..]));
        for v in 0..count {
            if lanes[v] == 0.0 {
                // A path that went on alone: its lanes compute nothing
                // that is used.
                continue;
            }
            let j = ray_of[v] as usize;
            let (ray, hit) = (&rays[j], hits[j].expect("a vertex's hit"));
            // A sphere's point is the scalar function's (below), and it
            // has no lift: its lanes take zeros meanwhile.
            let p = hit.prim as usize;
            sphere[v] = p >= scene.mesh.len();
            let (corners, normals, bary) = if sphere[v] {
                ([Vec3::ZERO; 3], [Vec3::ZERO; 3], [0.0; 3])
            } else {
                (
                    scene.mesh.corners(p),
                    scene.corner_normals(p),
                    crate::scene::barycentric_weights(&hit),
                )
            };
            for a in 0..3 {
                dir[a][v] = ray.dir[a];
                w[a][v] = bary[a];
                for c in 0..3 {
                    corner[c][a][v] = corners[c][a];
                    normal[c][a][v] = normals[c][a];
                }
            }
        }
        // The padding repeats the last slot.
        for v in count..padded {
            sphere[v] = sphere[count - 1];
            for a in 0..3 {
                albedo[a][v] = albedo[a][count - 1];
                dir[a][v] = dir[a][count - 1];
                w[a][v] = w[a][count - 1];
                for c in 0..3 {
                    corner[c][a][v] = corner[c][a][count - 1];
                    normal[c][a][v] = normal[c][a][count - 1];
                }
            }
        }
        surface_pass(plan.vectors, self);
        // Spheres, and lanes whose normals left the plain case: the
        // scalar function.
        for v in 0..count {
            if self.lanes[v] == 0.0 || (self.plain[v] != 0.0 && !self.sphere[v]) {
                continue;
            }
            let j = self.ray_of[v] as usize;
            let hit = self.hits[j].expect("a vertex's hit");
            let sp = scene.surface_point(&self.rays[j], &hit);
            set_lane(&mut self.p, v, sp.position);
            set_lane(&mut self.error, v, sp.error);
            set_lane(&mut self.ng, v, sp.geometric_normal);
            set_lane(&mut self.ns, v, sp.shading_normal);
        }
    }

    /// Each kept slot takes its path's state from the slot it was in
    /// (`from`, rising, never below the slot it fills: so in place). Where
    /// its ray left is not moved: it is read at the slot it was in, when
    /// arriving, and the vertex's own lists replace it when leaving.
    pub(super) fn compact(&mut self) {
        let from = &self.from[..];
        fn gather<T: Copy>(list: &mut [T], from: &[u32]) {
            for (to, &v) in from.iter().enumerate() {
                list[to] = list[v as usize];
            }
        }
        gather(&mut self.path, from);
        gather(&mut self.depth, from);
        for a in 0..3 {
            gather(&mut self.beta[a], from);
        }
        gather(&mut self.rng.state, from);
        gather(&mut self.rng.inc, from);
    }

    /// Slot `v`'s path, whose `ray`'s closest hit is `hit` at a vertex
    /// the lanes do not take, takes the bounce as the paths' states take
    /// it ([`Integrator::arrive_at`], `light_at`, `go_on`), its shadow
    /// rays on the tape: it arrives, records its direct light, and leaves
    /// at once (leaving draws from the path's stream after the light
    /// stream is split off, as alone); its direct light joins its total
    /// when the shadow rays are answered. Whether it goes on, in slot
    /// `to`.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn alone<A: Accel>(
        &mut self,
        integrator: &Integrator<A>,
        s: &PathSettings,
        v: usize,
        ray: Ray,
        hit: Hit,
        to: usize,
        counters: &mut TraceCounters,
    ) -> bool {
        let k = self.path[v] as usize;
        let mut walk = Walk {
            total: self.total[k],
            beta: lane(&self.beta, v),
            ray,
            prev: self.prev(v),
            depth: self.depth[v],
        };
        let mut rng = self.rng.get(v);
        let vertex = integrator.arrive(&mut walk, Some(hit), s);
        self.total[k] = walk.total;
        let Some(vertex) = vertex else {
            return false;
        };
        let (first_term, first_ray) = self.tape.ends();
        let mut deferred = Deferred {
            tape: &mut self.tape,
            counters,
        };
        let lit = integrator.light(walk.depth, &vertex, s, &mut rng, &mut deferred);
        let direct = lit.then(|| Span::since(first_term, first_ray, &self.tape));
        let beta = walk.beta;
        let goes = integrator.leave(&mut walk, &vertex, s, &mut rng);
        self.alone.push(Alone {
            path: k as u32,
            beta,
            direct,
            goes: goes.then_some((to as u32, walk, rng)),
        });
        goes
    }

    /// Each vertex's facing, shading frame and terminator lift, in lanes
    /// (the operations of `Integrator::arrive`, `Frame::new` and
    /// `Scene::shadow_lift`).
    pub(super) fn vertices(&mut self, plan: &Plan) {
        let padded = self.padded;
        for lists in [&mut self.s, &mut self.t, &mut self.lift] {
            sized(lists, padded);
        }
        sized(std::slice::from_mut(&mut self.lifted), padded);
        vertex_pass(plan.vectors, self);
        // `Scene::shadow_lift`: none on a sphere.
        for v in 0..padded {
            if self.sphere[v] {
                self.lifted[v] = 0.0;
                for a in 0..3 {
                    self.lift[a][v] = 0.0;
                }
            }
        }
    }
}
