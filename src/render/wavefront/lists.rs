//! The wave's lists: three per vector, generators side by side, and the
//! loads, stores and sizes the passes share.

use glam::Vec3;

use crate::each3;
use crate::geom::sampling::Rng;
use crate::render::times::held;
use crate::simd::lanes::F16;

/// Three lists, one per coordinate.
pub(super) type Lists = [Vec<f32>; 3];

/// Generators side by side: each one's state and increment
/// ([`Rng::parts`]).
#[derive(Default)]
pub(super) struct Rngs {
    pub(super) state: Vec<u64>,
    pub(super) inc: Vec<u64>,
}

impl Rngs {
    #[inline(always)]
    pub(super) fn get(&self, v: usize) -> Rng {
        Rng::from_parts(self.state[v], self.inc[v])
    }

    #[inline(always)]
    pub(super) fn set(&mut self, v: usize, rng: &Rng) {
        (self.state[v], self.inc[v]) = rng.parts();
    }

    /// At least `n` generators each (see [`sized`]).
    pub(super) fn sized(&mut self, n: usize) {
        if self.state.len() < n {
            self.state.resize(n, 0);
            self.inc.resize(n, 0);
        }
    }

    pub(super) fn held_bytes(&self) -> usize {
        held(&self.state) + held(&self.inc)
    }
}

/// Gives `lists` at least `n` values each, for a pass that writes the
/// first `n`: what they held before stays until then, and they never
/// shrink (zeroing them took 25 ms of the 0.6 s of stepping in CBempty's
/// frame, and so did growing them back from bounce to bounce).
pub(super) fn sized(lists: &mut [Vec<f32>], n: usize) {
    for l in lists {
        if l.len() < n {
            l.resize(n, 0.0);
        }
    }
}

/// Three coordinates of sixteen vertices from `lists` at vertex `i`.
#[inline(always)]
pub(super) fn v3(lists: &Lists, i: usize) -> [F16; 3] {
    each3!(|a| F16::load(&lists[a][i..]))
}

#[inline(always)]
pub(super) fn store3(v: [F16; 3], lists: &mut Lists, i: usize) {
    for (a, v) in v.into_iter().enumerate() {
        v.store(&mut lists[a][i..]);
    }
}

#[inline(always)]
pub(super) fn dot(a: [F16; 3], b: [F16; 3]) -> F16 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[inline(always)]
pub(super) fn splat3(v: Vec3) -> [F16; 3] {
    [F16::splat(v.x), F16::splat(v.y), F16::splat(v.z)]
}

#[inline(always)]
pub(super) fn lane(lists: &Lists, i: usize) -> Vec3 {
    Vec3::new(lists[0][i], lists[1][i], lists[2][i])
}

#[inline(always)]
pub(super) fn set_lane(lists: &mut Lists, i: usize, v: Vec3) {
    for a in 0..3 {
        lists[a][i] = v[a];
    }
}

/// `Ray::spawn`'s origin: the point moved past its error bound along the
/// normal, to the side `dir` leaves on, then one ulp further away.
#[inline(always)]
pub(super) fn spawn(p: [F16; 3], error: [F16; 3], ng: [F16; 3], dir: [F16; 3]) -> [F16; 3] {
    let zero = F16::splat(0.0);
    let d = ng[0].abs() * error[0] + ng[1].abs() * error[1] + ng[2].abs() * error[2];
    let d = F16::select(dot(dir, ng).lt(zero), -d, d);
    let mut origin = [zero; 3];
    for k in 0..3 {
        let offset = ng[k] * d;
        origin[k] = (p[k] + offset).away(offset);
    }
    origin
}
