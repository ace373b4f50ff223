//! Vector helpers and rounding-error bounds.

use glam::Vec3;

/// `v` scaled to unit length, or zero for a zero or non-finite `v`. Safe
/// for any finite `v`: when its squared length overflows or underflows
/// (a cross product of long edges, 1e12 squared and squared again), it is
/// divided by its largest component first and still has a direction.
/// Every hit pays for this, so the common case is one square root and one
/// division.
#[inline]
pub fn unit(v: Vec3) -> Vec3 {
    let squared = v.length_squared();
    if squared > f32::MIN_POSITIVE && squared < f32::INFINITY {
        return v / squared.sqrt();
    }
    let m = v.abs().max_element();
    if !(m > 0.0) || !m.is_finite() {
        return Vec3::ZERO;
    }
    (v / m).normalize_or_zero()
}

/// `n u / (1 - n u)` for the unit roundoff `u = 2^-24`: the relative error
/// bound of `n` chained f32 operations (Higham; pbrt-v4's `gamma`).
#[inline]
pub fn gamma(n: u32) -> f32 {
    let nu = n as f32 * (f32::EPSILON * 0.5);
    nu / (1.0 - nu)
}
