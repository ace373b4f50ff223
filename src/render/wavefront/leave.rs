//! Leaving: Russian roulette, the BSDF's sample and the next rays, in
//! lanes; the paths that went on alone take their state back.

use glam::Vec3;

use super::lists::{dot, set_lane, sized, spawn, store3, v3};
use super::rng::Rng16;
use super::{Plan, Wave, L};
use crate::geom::Ray;
use crate::render::integrator::PathSettings;
use crate::simd::lanes::{lane_pass, F16};
use crate::{each3, map3};

impl Wave {
    /// Each vertex's path leaves along a BSDF sample (after Russian
    /// roulette from the second vertex on), as [`Integrator::leave`]
    /// takes it, and the paths that went on alone take their state back:
    /// the slots that go on give the next bounce's rays.
    pub(super) fn leave(&mut self, plan: &Plan) {
        let padded = self.padded;
        sized(&mut self.draws, padded);
        sized(std::slice::from_mut(&mut self.going), padded);
        sized(&mut self.next, padded);
        leave_pass(plan.vectors, &plan.s, self);
        // Where each path left, for the next vertex: this one's lists,
        // whole (a slot that does not go on is not read again, and the
        // passes write these lists whole before they read them).
        std::mem::swap(&mut self.prev_from, &mut self.p);
        std::mem::swap(&mut self.prev_ng, &mut self.ng);
        std::mem::swap(&mut self.prev_ns, &mut self.ns);
        std::mem::swap(&mut self.prev_smooth, &mut self.lifted);
        std::mem::swap(&mut self.prev_pdf, &mut self.draws[2]);
        // The paths that went on alone, in their slots.
        for a in &self.alone {
            let Some((v, walk, rng)) = &a.goes else {
                continue;
            };
            let v = *v as usize;
            set_lane(&mut self.beta, v, walk.beta);
            self.depth[v] = walk.depth;
            self.prev_pdf[v] = walk.prev.bsdf_pdf;
            set_lane(&mut self.prev_from, v, walk.prev.from);
            set_lane(&mut self.prev_ng, v, walk.prev.facing.geometric);
            let smooth = walk.prev.facing.smooth;
            self.prev_smooth[v] = if smooth.is_some() { 1.0 } else { 0.0 };
            set_lane(&mut self.prev_ns, v, smooth.unwrap_or(Vec3::ZERO));
            self.rng.set(v, rng);
            self.going[v] = 1.0;
        }
        let mut alone_rays = self.alone.iter().filter_map(|a| a.goes.as_ref());
        self.rays.clear();
        self.traced.clear();
        let (going, lanes, next) = (&self.going[..], &self.lanes[..], &self.next);
        for v in 0..self.count {
            if going[v] == 0.0 {
                continue;
            }
            self.traced.push(v as u32);
            if lanes[v] == 0.0 {
                let (_, walk, _) = alone_rays.next().expect("an alone path's ray");
                self.rays.push(walk.ray);
                continue;
            }
            self.rays.push(Ray {
                origin: Vec3::new(next[0][v], next[1][v], next[2][v]),
                dir: Vec3::new(next[3][v], next[4][v], next[5][v]),
                t_min: 0.0,
                t_max: f32::INFINITY,
            });
        }
    }
}

/// Each vertex's path leaves (`Integrator::leave` at a Lambertian
/// vertex), sixteen slots at a time: Russian roulette from the second
/// vertex on, the BSDF's two numbers, a cosine-weighted direction
/// (`material::sample`) with its density in `draws[2]`, and its ray
/// (`Ray::spawn`) in `next`; the throughput times the albedo, and
/// `going` for the paths that go on with a throughput neither zero nor
/// infinite. The slots of paths that went on alone compute values that
/// are replaced.
#[inline(always)]
pub(super) fn leave_lanes(s: &PathSettings, wave: &mut Wave) {
    let (zero, one, inf) = (F16::splat(0.0), F16::splat(1.0), F16::splat(f32::INFINITY));
    let frac_1_pi = F16::splat(std::f32::consts::FRAC_1_PI);
    let (roulette, p) = match s.russian_roulette {
        Some(p) => (true, F16::splat(p)),
        None => (false, one),
    };
    for i in (0..wave.padded).step_by(L) {
        let lanes = F16::load(&wave.lanes[i..]).gt(zero);
        let depth: [u32; L] = wave.depth[i..i + L].try_into().expect("sixteen depths");
        // All ones where a lane takes Russian roulette.
        let rolled =
            F16(depth.map(|d| f32::from_bits(0u32.wrapping_sub(u32::from(roulette && d >= 1)))));
        let rolled = rolled.and(lanes);
        let mut rng = Rng16::load(&wave.rng, i);
        let u = rng.next_f32(rolled);
        let survives = u.lt(p);
        let going = lanes.and_not(rolled.and_not(survives));
        let mut beta = v3(&wave.beta, i);
        beta = map3!(beta, |x| F16::select(rolled.and(survives), x / p, x));
        // `material::sample`'s two numbers (a Lambertian surface).
        let (u0, u1) = rng.next_2d(going);
        rng.store(&mut wave.rng, i);
        let local = cosine_hemisphere8(u0, u1);
        let (s, t, n) = (v3(&wave.s, i), v3(&wave.t, i), v3(&wave.ns, i));
        let wi = each3!(|k| s[k] * local[0] + t[k] * local[1] + n[k] * local[2]);
        let ng = v3(&wave.ng, i);
        // (As `leave` tests them: a NaN would go on.)
        let going = going
            .and_not(local[2].le(zero))
            .and_not(dot(wi, ng).le(zero));
        let beta = each3!(|k| beta[k] * F16::load(&wave.albedo[k][i..]));
        let black = beta[0].ne(zero).or(beta[1].ne(zero)).or(beta[2].ne(zero));
        let finite = beta[0]
            .abs()
            .lt(inf)
            .and(beta[1].abs().lt(inf))
            .and(beta[2].abs().lt(inf));
        let going = going.and(black).and(finite);
        F16::select(going, one, zero).store(&mut wave.going[i..]);
        store3(beta, &mut wave.beta, i);
        (local[2] * frac_1_pi).store(&mut wave.draws[2][i..]);
        let origin = spawn(v3(&wave.p, i), v3(&wave.error, i), ng, wi);
        for k in 0..3 {
            origin[k].store(&mut wave.next[k][i..]);
            wi[k].store(&mut wave.next[3 + k][i..]);
        }
        wave.depth[i..i + L].copy_from_slice(&depth.map(|d| d + 1));
    }
}

lane_pass!(pub(super) leave_pass = leave_lanes(s: &PathSettings, wave: &mut Wave));

/// [`crate::geom::sampling::cosine_hemisphere`] lane by lane, its bits.
#[inline(always)]
pub(super) fn cosine_hemisphere8(u: F16, v: F16) -> [F16; 3] {
    let r = u.sqrt();
    let (sin, cos) = v.sin_cos_turns();
    [
        r * cos,
        r * sin,
        (F16::splat(1.0) - u).max(F16::splat(0.0)).sqrt(),
    ]
}
