//! Light: each vertex's light stream and light samples, their terms and
//! shadow rays in lanes; the shadow rays gathered; the direct light summed
//! once they are answered.

use super::leave::cosine_hemisphere8;
use super::lists::{dot, lane, sized, spawn, splat3, store3, v3};
use super::rng::Rng16;
use super::{Plan, Source, Wave, L};
use crate::geom::{gamma, Ray};
use crate::render::integrator::{DirectEstimator, PathSettings};
use crate::simd::lanes::{lane_pass, F16};
use crate::{each3, map3};

impl Wave {
    /// Each vertex's light stream, and its light samples' terms and
    /// shadow rays, in lanes (`Integrator::direct` for area lights).
    pub(super) fn light(&mut self, plan: &Plan) {
        let padded = self.padded;
        let slots = plan.groups().map(|(_, n)| n as usize).sum();
        self.term.resize_with(slots, Default::default);
        self.has_ray.resize_with(slots, Vec::new);
        self.shadow.resize_with(slots, Default::default);
        // Each slot's lists are written whole by its light pass.
        for j in 0..slots {
            sized(&mut self.term[j], padded);
            sized(std::slice::from_mut(&mut self.has_ray[j]), padded);
            sized(&mut self.shadow[j], padded);
        }
        // `Integrator::light_stream`: split at every vertex that is not
        // specular (none here is), used or not. Every slot splits: a
        // path that went on alone gets its generator back when leaving.
        self.light_rng.sized(padded);
        split_pass(plan.vectors, self);
        // An area light's two numbers per vertex, in `draws`.
        sized(&mut self.draws, padded);
        let mut slot = 0;
        for (source, n) in plan.groups() {
            for _ in 0..n {
                if let Source::Area(_) | Source::Ambient { .. } = source {
                    light_draws_pass(plan.vectors, self);
                }
                light_pass(plan.vectors, &plan.s, self, source, slot);
                slot += 1;
            }
        }
    }

    /// The shadow rays of the vertices that take direct light, vertex by
    /// vertex and sample by sample, and where each came from; `open`
    /// cleared for their answers.
    pub(super) fn shadow_gather(&mut self) {
        let padded = self.padded;
        self.shadow_rays.clear();
        self.shadow_at.clear();
        self.open.resize_with(self.term.len(), Vec::new);
        for open in &mut self.open {
            sized(std::slice::from_mut(open), padded);
            open[..padded].fill(0.0);
        }
        let lit = &self.lit[..self.count];
        for (v, _) in lit.iter().enumerate().filter(|(_, &l)| l != 0.0) {
            for (j, (has, r)) in self.has_ray.iter().zip(&self.shadow).enumerate() {
                if has[v] != 0.0 {
                    let ray = Ray::from_flat(&std::array::from_fn(|c| r[c][v]));
                    self.shadow_rays.push(ray);
                    self.shadow_at.push((j as u32, v as u32));
                }
            }
        }
    }

    /// Each vertex's direct light, as the tape sums it: each light's
    /// samples (zero where blocked or without a ray) averaged, the means
    /// summed, times the path's throughput (in lanes), added to its
    /// path's sum.
    pub(super) fn sum(&mut self, plan: &Plan) {
        for (&(j, v), &blocked) in self.shadow_at.iter().zip(&self.blocked) {
            self.open[j as usize][v as usize] = if blocked { 0.0 } else { 1.0 };
        }
        sized(&mut self.direct, self.padded);
        sum_pass(plan.vectors, plan, self);
        let (lit, path) = (&self.lit[..self.count], &self.path[..]);
        for (v, _) in lit.iter().enumerate().filter(|(_, &l)| l != 0.0) {
            self.total[path[v] as usize] += lane(&self.direct, v);
        }
    }
}

/// Each vertex's direct light times its throughput into `direct`, as
/// [`super::ShadowTape::sum`] sums it: each light's samples (zero where
/// blocked or without a ray) averaged, the means summed; sixteen vertices
/// at a time.
#[inline(always)]
pub(super) fn sum_lanes(plan: &Plan, wave: &mut Wave) {
    let zero = F16::splat(0.0);
    for i in (0..wave.padded).step_by(L) {
        let mut sum = [zero; 3];
        let mut slot = 0;
        for (_, n) in plan.groups() {
            let mut group = [zero; 3];
            for _ in 0..n {
                let open = F16::load(&wave.open[slot][i..]).gt(zero);
                let term = v3(&wave.term[slot], i);
                group = each3!(|k| group[k] + F16::select(open, term[k], zero));
                slot += 1;
            }
            let n = F16::splat(n as f32);
            sum = each3!(|k| sum[k] + group[k] / n);
        }
        let beta = v3(&wave.beta, i);
        store3(each3!(|k| beta[k] * sum[k]), &mut wave.direct, i);
    }
}

lane_pass!(pub(super) sum_pass = sum_lanes(plan: &Plan, wave: &mut Wave));

/// Each slot's light stream split off its generator (`Rng::split`),
/// sixteen slots at a time.
#[inline(always)]
pub(super) fn split_lanes(wave: &mut Wave) {
    for i in (0..wave.padded).step_by(L) {
        let mut rng = Rng16::load(&wave.rng, i);
        let light = rng.split();
        rng.store(&mut wave.rng, i);
        light.store(&mut wave.light_rng, i);
    }
}

lane_pass!(pub(super) split_pass = split_lanes(wave: &mut Wave));

/// Two numbers from each slot's light stream into `draws[0..2]`
/// (`Rng::next_2d`), sixteen slots at a time.
#[inline(always)]
pub(super) fn light_draws_lanes(wave: &mut Wave) {
    let all = F16::splat(f32::from_bits(u32::MAX));
    for i in (0..wave.padded).step_by(L) {
        let mut light = Rng16::load(&wave.light_rng, i);
        let (u, v) = light.next_2d(all);
        u.store(&mut wave.draws[0][i..]);
        v.store(&mut wave.draws[1][i..]);
        light.store(&mut wave.light_rng, i);
    }
}

lane_pass!(pub(super) light_draws_pass = light_draws_lanes(wave: &mut Wave));

/// One sample of `source` (at `draws[0..2]` of the unit square for an
/// area light) from each vertex: its term (MIS-weighted for an area light) and
/// shadow ray (`sample_li`, `Integrator::unoccluded`), sixteen vertices at a
/// time.
#[inline(always)]
pub(super) fn light_lanes(s: &PathSettings, wave: &mut Wave, source: Source, slot: usize) {
    let g1 = F16::splat(gamma(1));
    let (zero, one, inf) = (F16::splat(0.0), F16::splat(1.0), F16::splat(f32::INFINITY));
    let yes = zero.le(zero);
    let frac_1_pi = F16::splat(std::f32::consts::FRAC_1_PI);
    let end = F16::splat(crate::geom::ray::SHADOW_END);
    // MIS's weight counts the samples a group takes: `samples * pick`.
    let mis = matches!(source, Source::Area(_) | Source::Ambient { .. })
        && s.estimator == DirectEstimator::Mis;
    let samples = mis.then(|| F16::splat(s.light_samples.max(1) as f32 * 1.0));
    for i in (0..wave.padded).step_by(L) {
        let p = v3(&wave.p, i);
        let (ng, ns) = (v3(&wave.ng, i), v3(&wave.ns, i));
        let lifted = F16::load(&wave.lifted[i..]).gt(zero);
        // The sample: direction, distance, radiance over density, the
        // density, and whether there is one.
        let (wi, distance, contribution, pdf, some) = match source {
            Source::Area(light) => {
                let (u, v) = (
                    F16::load(&wave.draws[0][i..]),
                    F16::load(&wave.draws[1][i..]),
                );
                let (o, eu, ev) = (
                    splat3(light.origin),
                    splat3(light.edge_u),
                    splat3(light.edge_v),
                );
                // `point_at`, then `area_to_solid_angle` and
                // `from_area_point`.
                let to = each3!(|k| o[k] + eu[k] * u + ev[k] * v - p[k]);
                let d2 = dot(to, to);
                let distance = d2.sqrt();
                let cos_light = -dot(to, splat3(light.normal)) / distance;
                let pdf = d2 / (cos_light * F16::splat(light.area));
                let some = d2
                    .ne(zero)
                    .and(cos_light.gt(zero))
                    .and(pdf.gt(zero))
                    .and(pdf.lt(inf));
                let wi = map3!(to, |x| x / distance);
                let contribution = map3!(splat3(light.radiance), |x| x / pdf);
                (wi, distance, contribution, pdf, some)
            }
            Source::Point {
                position,
                intensity,
            } => {
                let to = each3!(|k| F16::splat(position[k]) - p[k]);
                let d2 = dot(to, to);
                let distance = d2.sqrt();
                let wi = map3!(to, |x| x / distance);
                let contribution = map3!(splat3(intensity), |x| x / d2);
                (wi, distance, contribution, inf, d2.ne(zero))
            }
            Source::Directional { to_light, radiance } => {
                (splat3(to_light), inf, splat3(radiance), inf, yes)
            }
            Source::Ambient { radiance } => {
                // `sample_li`: cosine-weighted around the geometric
                // normal, or, from a lifted point (which faces by its
                // smooth normal too), around either, picked by the first
                // number.
                let (u, v) = (
                    F16::load(&wave.draws[0][i..]),
                    F16::load(&wave.draws[1][i..]),
                );
                let (half, two) = (F16::splat(0.5), F16::splat(2.0));
                let smooth = lifted.and(half.le(u));
                let u = F16::select(lifted, F16::select(smooth, two * u - one, two * u), u);
                let around = each3!(|k| F16::select(smooth, ns[k], ng[k]));
                let local = cosine_hemisphere8(u.min(F16::splat(1.0 - f32::EPSILON / 2.0)), v);
                // `Frame::new(around).to_world(local)`.
                let sign = one.copysign(around[2]);
                let fa = -one / (sign + around[2]);
                let fb = around[0] * around[1] * fa;
                let fs = [
                    one + sign * around[0] * around[0] * fa,
                    sign * fb,
                    -sign * around[0],
                ];
                let ft = [fb, sign + around[1] * around[1] * fa, -around[1]];
                let wi = each3!(|k| fs[k] * local[0] + ft[k] * local[1] + around[k] * local[2]);
                let some = yes.and_not(wi[1].le(zero)).and_not(local[2].le(zero));
                // `Facing::ambient_pdf`.
                let (cos_g, cos_s) = (
                    dot(wi, ng).max(zero) * frac_1_pi,
                    dot(wi, ns).max(zero) * frac_1_pi,
                );
                let pdf = F16::select(lifted, half * (cos_g + cos_s), cos_g);
                let contribution = map3!(splat3(radiance), |x| x / pdf);
                (wi, inf, contribution, pdf, some)
            }
        };
        // `unoccluded`: in front of the shading normal, and of the facet
        // unless the point is lifted; the BSDF (Lambertian) not zero.
        let z = dot(wi, ns);
        let in_front = dot(wi, ng).gt(zero);
        let f = map3!(v3(&wave.albedo, i), |x| F16::select(
            z.gt(zero),
            x * frac_1_pi,
            zero
        ));
        let black = f[0].ne(zero).or(f[1].ne(zero)).or(f[2].ne(zero));
        let ok = some.and(z.gt(zero)).and(in_front.or(lifted)).and(black);
        let weight = match samples {
            Some(n) => {
                // `power_heuristic(samples * pick * pdf, material::pdf)`.
                let a = n * pdf;
                let b = z.max(zero) * frac_1_pi;
                let (a2, b2) = (a * a, b * b);
                let sum = a2 + b2;
                let plain = sum.gt(zero).and(sum.lt(inf));
                let heuristic = F16::select(plain, a2 / sum, F16::select(a.ne(inf), zero, one));
                F16::select(in_front.and(pdf.lt(inf)), heuristic, one)
            }
            None => one,
        };
        let scale = z.abs() * weight / one;
        // The shadow ray, from the lifted point where there is one.
        let error = v3(&wave.error, i);
        let lift = v3(&wave.lift, i);
        let from = each3!(|k| F16::select(lifted, p[k] + lift[k], p[k]));
        // From a lifted point towards a point (not a direction), the ray
        // aims at the sample's point.
        let aimed = lifted.and(distance.lt(inf));
        let from_error = each3!(|k| F16::select(
            lifted,
            error[k] + (p[k].abs() + lift[k].abs()) * g1,
            error[k]
        ));
        let reach = each3!(|k| p[k] + wi[k] * distance - from[k]);
        let length = dot(reach, reach).sqrt();
        let dir = each3!(|k| F16::select(aimed, reach[k] / length, wi[k]));
        let far = F16::select(aimed, length, distance);
        let origin = spawn(from, from_error, ng, dir);
        let term = each3!(|k| f[k] * contribution[k] * scale);
        store3(term, &mut wave.term[slot], i);
        F16::select(ok, one, zero).store(&mut wave.has_ray[slot][i..]);
        let ray = &mut wave.shadow[slot];
        for k in 0..3 {
            origin[k].store(&mut ray[k][i..]);
            dir[k].store(&mut ray[3 + k][i..]);
        }
        zero.store(&mut ray[6][i..]);
        (far * end).store(&mut ray[7][i..]);
    }
}

lane_pass!(
    pub(super) light_pass = light_lanes(
        s: &PathSettings,
        wave: &mut Wave,
        source: Source,
        slot: usize,
    )
);
