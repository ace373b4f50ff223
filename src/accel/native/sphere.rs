//! Analytic ray/sphere intersection, in the form of Haines et al. 2019,
//! "Precision improvements for ray/sphere intersection" (Ray Tracing Gems,
//! ch. 7): the discriminant from the distance of the centre to the line, and
//! the second root from the product of the roots, so that neither far
//! origins nor small spheres lose the hit to cancellation.

use glam::Vec3;

use crate::geom::Ray;

/// The nearest root in `(t_min, t_max]` of the ray against the sphere.
#[inline]
pub fn intersect_sphere(
    center: Vec3,
    radius: f32,
    ray: &Ray,
    t_min: f32,
    t_max: f32,
) -> Option<f32> {
    let f = ray.origin - center;
    let a = ray.dir.length_squared();
    let b = -f.dot(ray.dir); // roots are (b ± sqrt(disc)) / a
    let l = f + ray.dir * (b / a); // centre-to-line vector
    let disc = a * (radius * radius - l.length_squared());
    if disc < 0.0 {
        return None;
    }
    let c = f.length_squared() - radius * radius;
    let q = b + disc.sqrt().copysign(b);
    let (mut t0, mut t1) = if q == 0.0 { (0.0, 0.0) } else { (c / q, q / a) };
    if t0 > t1 {
        std::mem::swap(&mut t0, &mut t1);
    }
    if t0 > t_min && t0 <= t_max {
        Some(t0)
    } else if t1 > t_min && t1 <= t_max {
        Some(t1)
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hits_from_outside_and_inside() {
        let ray = Ray::new(Vec3::new(0.0, 0.0, 5.0), Vec3::new(0.0, 0.0, -1.0));
        let t = intersect_sphere(Vec3::ZERO, 1.0, &ray, 0.0, f32::INFINITY).unwrap();
        assert!((t - 4.0).abs() < 1e-6, "outside hit at t={t}, expected 4");
        let inside = Ray::new(Vec3::ZERO, Vec3::X);
        let t = intersect_sphere(Vec3::ZERO, 1.0, &inside, 0.0, f32::INFINITY).unwrap();
        assert!((t - 1.0).abs() < 1e-6, "inside hit at t={t}, expected 1");
    }

    #[test]
    fn keeps_precision_far_from_the_origin() {
        let c = Vec3::new(1e5, 0.0, 0.0);
        let ray = Ray::new(Vec3::new(1e5, 0.0, 1e4), Vec3::new(0.0, 0.0, -1.0));
        let t = intersect_sphere(c, 0.01, &ray, 0.0, f32::INFINITY)
            .expect("a small far sphere was missed");
        assert!((t - (1e4 - 0.01)).abs() < 2e-3, "t={t}");
    }
}
