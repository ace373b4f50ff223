//! Surface points, facing, shading frames and the terminator lift of a
//! wave's vertices, sixteen at a time.

use super::lists::{dot, store3, v3};
use super::{Wave, L};
use crate::geom::gamma;
use crate::simd::lanes::{lane_pass, F16};
use crate::{each3, map3};

/// Each vertex's surface point (`Scene::surface_point` of a smoothly
/// shaded triangle, in its operations and order, as
/// `render::lanes::surface_points`), sixteen vertices at a time; `plain`
/// marks the lanes whose normals took the plain case (the others are the
/// scalar function's to answer).
#[inline(always)]
pub(super) fn surface_lanes(wave: &mut Wave) {
    let margin_ulps = F16::splat(gamma(crate::scene::TEST_ULPS));
    let g9 = F16::splat(gamma(9));
    let (zero, one, two, three) = (
        F16::splat(0.0),
        F16::splat(1.0),
        F16::splat(2.0),
        F16::splat(3.0),
    );
    let (tiny, inf) = (F16::splat(f32::MIN_POSITIVE), F16::splat(f32::INFINITY));
    for i in (0..wave.padded).step_by(L) {
        let w = v3(&wave.w, i);
        let c = each3!(|k| v3(&wave.corner[k], i));
        let nm = each3!(|k| v3(&wave.normal[k], i));
        // Vec3::max per coordinate, then the largest.
        let d = |x: usize, y: usize, a: usize| (c[x][a] - c[y][a]).abs();
        let size = each3!(|a| d(1, 0, a).max(d(2, 0, a)).max(d(2, 1, a)));
        let margin = margin_ulps * size[0].max(size[1]).max(size[2]);
        let on = each3!(|a| c[0][a] * w[0] + c[1][a] * w[1] + c[2][a] * w[2]);
        let inward = each3!(|a| (c[0][a] + c[1][a] + c[2][a]) / three - on[a]);
        let reach = dot(inward, inward).sqrt();
        let steps = reach.gt(two * margin);
        let step = two * margin / reach;
        let e1 = each3!(|a| c[1][a] - c[0][a]);
        let e2 = each3!(|a| c[2][a] - c[0][a]);
        let x = [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ];
        let squared = dot(x, x);
        let len = squared.sqrt();
        let ng = map3!(x, |v| v / len);
        let smooth = each3!(|a| nm[0][a] * w[0] + nm[1][a] * w[1] + nm[2][a] * w[2]);
        let recip = one / dot(smooth, smooth).sqrt();
        let unit = map3!(smooth, |v| v * recip);
        let outward = dot(unit, ng).lt(zero);
        let plain = squared
            .gt(tiny)
            .and(squared.lt(inf))
            .and(recip.lt(inf))
            .and(recip.gt(zero));
        F16::select(plain, one, zero).store(&mut wave.plain[i..]);
        for a in 0..3 {
            F16::select(steps, on[a] + inward[a] * step, on[a]).store(&mut wave.p[a][i..]);
            let e = (c[0][a] * w[0]).abs() + (c[1][a] * w[1]).abs() + (c[2][a] * w[2]).abs();
            (g9 * e + margin).store(&mut wave.error[a][i..]);
            ng[a].store(&mut wave.ng[a][i..]);
            F16::select(outward, -unit[a], unit[a]).store(&mut wave.ns[a][i..]);
        }
    }
}

lane_pass!(pub(super) surface_pass = surface_lanes(wave: &mut Wave));

/// Facing (opaque surfaces are two-sided: the normals turned towards
/// `wo`; a diffuse surface keeps the smooth normal's side), the shading
/// frame (`Frame::new`) and the terminator lift (`Scene::shadow_lift`,
/// `terminator_lift`), sixteen vertices at a time.
#[inline(always)]
pub(super) fn vertex_lanes(wave: &mut Wave) {
    let (zero, one) = (F16::splat(0.0), F16::splat(1.0));
    for i in (0..wave.padded).step_by(L) {
        let wo = map3!(v3(&wave.dir, i), |x| -x);
        let (ng0, ns0) = (v3(&wave.ng, i), v3(&wave.ns, i));
        let back = dot(wo, ng0).lt(zero);
        let ng = map3!(ng0, |x| F16::select(back, -x, x));
        let ns = map3!(ns0, |x| F16::select(back, -x, x));
        let sign = one.copysign(ns[2]);
        let fa = -one / (sign + ns[2]);
        let fb = ns[0] * ns[1] * fa;
        let s = [one + sign * ns[0] * ns[0] * fa, sign * fb, -sign * ns[0]];
        let t = [fb, sign + ns[1] * ns[1] * fa, -ns[1]];
        let w = v3(&wave.w, i);
        let nk = each3!(|k| v3(&wave.normal[k], i));
        let interp = each3!(|a| nk[0][a] * w[0] + nk[1][a] * w[1] + nk[2][a] * w[2]);
        let flip = dot(interp, ng).lt(zero);
        let p = v3(&wave.p, i);
        let mut lift = [zero; 3];
        for k in 0..3 {
            let nn = map3!(nk[k], |x| F16::select(flip, -x, x));
            let c = v3(&wave.corner[k], i);
            let below = dot(each3!(|a| p[a] - c[a]), nn).min(zero);
            for a in 0..3 {
                lift[a] = lift[a] - nn[a] * (below * w[k]);
            }
        }
        F16::select(dot(lift, ng).gt(zero), one, zero).store(&mut wave.lifted[i..]);
        store3(ng, &mut wave.ng, i);
        store3(ns, &mut wave.ns, i);
        store3(s, &mut wave.s, i);
        store3(t, &mut wave.t, i);
        store3(lift, &mut wave.lift, i);
    }
}

lane_pass!(pub(super) vertex_pass = vertex_lanes(wave: &mut Wave));
