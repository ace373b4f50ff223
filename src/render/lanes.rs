//! Shading many hits at once: the surface points of a wave's hits eight at
//! a time in structure-of-arrays form (issue 45's bet that shading in
//! lanes pays, measured on the kernel first: `examples/soa_shading.rs`,
//! docs/experiments.md "Against Mitsuba 3"). Each lane gathers its
//! triangle; every step after runs across the eight lanes, compiled for
//! AVX2 and left to LLVM's vectorizer, in the operations and order of
//! [`Scene::surface_point`], so the bits are the same. Lanes whose numbers
//! leave the plain case (a normal too short or too long to normalize
//! directly), spheres and flat shading go through the scalar function.

use glam::Vec3;

use crate::accel::native::cpu::Avx2;
use crate::geom::{gamma, Hit, Ray};
use crate::scene::{NormalMode, Scene, SurfacePoint};

/// Lanes of one group.
const L: usize = 8;

/// A group's surface points, one array per coordinate.
#[derive(Default, Clone, Copy)]
struct Points {
    p: [[f32; L]; 3],
    error: [[f32; L]; 3],
    ng: [[f32; L]; 3],
    ns: [[f32; L]; 3],
    /// Whether the lane took the plain case (else the scalar function
    /// answers it).
    plain: [bool; L],
}

/// The surface point of each hit of `rays` into `out` (its entry for a
/// miss is not to be read), eight triangle hits at a time where `avx2`
/// proves the CPU runs the kernel; the same values as
/// [`Scene::surface_point`] hit by hit.
pub fn surface_points(
    scene: &Scene,
    avx2: Option<Avx2>,
    rays: &[Ray],
    hits: &[Option<Hit>],
    out: &mut Vec<SurfacePoint>,
) {
    out.clear();
    out.resize(hits.len(), SurfacePoint::NONE);
    let avx2 = avx2.filter(|_| scene.normal_mode == NormalMode::Smooth);
    let mut pending = [0u32; L];
    let mut count = 0;
    for (k, (ray, hit)) in rays.iter().zip(hits).enumerate() {
        let Some(hit) = hit else {
            continue;
        };
        match avx2 {
            Some(avx2) if (hit.prim as usize) < scene.mesh.len() => {
                pending[count] = k as u32;
                count += 1;
                if count == L {
                    group(scene, avx2, rays, hits, &pending, out);
                    count = 0;
                }
            }
            _ => out[k] = scene.surface_point(ray, hit),
        }
    }
    if let (Some(avx2), 1..) = (avx2, count) {
        // The spare lanes repeat the last hit, whose point they write again.
        let last = pending[count - 1];
        pending[count..].fill(last);
        group(scene, avx2, rays, hits, &pending, out);
    }
}

/// One group of eight triangle hits (`pending`, indices into `rays` and
/// `hits`) through the kernel, written to `out`.
fn group(
    scene: &Scene,
    avx2: Avx2,
    rays: &[Ray],
    hits: &[Option<Hit>],
    pending: &[u32; L],
    out: &mut [SurfacePoint],
) {
    let group: [(Ray, Hit); L] =
        pending.map(|k| (rays[k as usize], hits[k as usize].expect("a hit")));
    let points = points_of(scene, avx2, &group);
    for (l, &k) in pending.iter().enumerate() {
        let (ray, hit) = &group[l];
        let lane = |a: &[[f32; L]; 3]| Vec3::new(a[0][l], a[1][l], a[2][l]);
        out[k as usize] = if points.plain[l] {
            SurfacePoint {
                position: lane(&points.p),
                error: lane(&points.error),
                geometric_normal: lane(&points.ng),
                shading_normal: lane(&points.ns),
                material: scene.mesh.materials[hit.prim as usize],
            }
        } else {
            scene.surface_point(ray, hit)
        };
    }
}

/// The kernel behind its proof of AVX2.
fn points_of(scene: &Scene, _avx2: Avx2, group: &[(Ray, Hit); L]) -> Points {
    // SAFETY: `Avx2` exists only where the CPU runs AVX2
    // (`Avx2::detect`), the kernel's one requirement; every hit in
    // `group` is a triangle hit of `scene` (`surface_points` checks).
    unsafe { points_avx2(scene, group) }
}

/// [`Scene::surface_point`] of eight triangle hits of a smoothly shaded
/// scene, lane by lane in the same operations and order.
///
/// # Safety
/// The CPU must run AVX2.
#[target_feature(enable = "avx2")]
unsafe fn points_avx2(scene: &Scene, group: &[(Ray, Hit); L]) -> Points {
    // Gather: corners, corner normals, barycentric weights.
    let mut c = [[[0f32; L]; 3]; 3];
    let mut n = [[[0f32; L]; 3]; 3];
    let mut w = [[0f32; L]; 3];
    for (l, (_, hit)) in group.iter().enumerate() {
        let p = hit.prim as usize;
        let corners = scene.mesh.corners(p);
        let normals = scene.corner_normals(p);
        for k in 0..3 {
            for a in 0..3 {
                c[k][a][l] = corners[k][a];
                n[k][a][l] = normals[k][a];
            }
        }
        let [wa, wb, wc] = crate::scene::barycentric_weights(hit);
        w[0][l] = wa;
        w[1][l] = wb;
        w[2][l] = wc;
    }
    let mut out = Points::default();
    let margin_ulps = gamma(crate::scene::TEST_ULPS);
    let g9 = gamma(9);
    let mut margin = [0f32; L];
    for (l, m) in margin.iter_mut().enumerate() {
        let d = |x: usize, y: usize, a: usize| (c[x][a][l] - c[y][a][l]).abs();
        // Vec3::max per coordinate, then the largest, as the scalar code.
        let s = [0, 1, 2].map(|a| d(1, 0, a).max(d(2, 0, a)).max(d(2, 1, a)));
        *m = margin_ulps * s[0].max(s[1]).max(s[2]);
    }
    let mut on_plane = [[0f32; L]; 3];
    let mut inward = [[0f32; L]; 3];
    for a in 0..3 {
        for l in 0..L {
            on_plane[a][l] = c[0][a][l] * w[0][l] + c[1][a][l] * w[1][l] + c[2][a][l] * w[2][l];
            let centroid = (c[0][a][l] + c[1][a][l] + c[2][a][l]) / 3.0;
            inward[a][l] = centroid - on_plane[a][l];
        }
    }
    for l in 0..L {
        let reach = (inward[0][l] * inward[0][l]
            + inward[1][l] * inward[1][l]
            + inward[2][l] * inward[2][l])
            .sqrt();
        let steps = reach > 2.0 * margin[l];
        let step = 2.0 * margin[l] / reach;
        for a in 0..3 {
            out.p[a][l] = if steps {
                on_plane[a][l] + inward[a][l] * step
            } else {
                on_plane[a][l]
            };
            out.error[a][l] = g9
                * ((c[0][a][l] * w[0][l]).abs()
                    + (c[1][a][l] * w[1][l]).abs()
                    + (c[2][a][l] * w[2][l]).abs())
                + margin[l];
        }
    }
    for l in 0..L {
        // The geometric normal: (b - a) x (c - a) over its length
        // (`geom::unit`'s plain case).
        let e1 = [0, 1, 2].map(|a| c[1][a][l] - c[0][a][l]);
        let e2 = [0, 1, 2].map(|a| c[2][a][l] - c[0][a][l]);
        let x = [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ];
        let squared = x[0] * x[0] + x[1] * x[1] + x[2] * x[2];
        let len = squared.sqrt();
        let ng = x.map(|v| v / len);
        // The smooth normal: interpolated, times the reciprocal of its
        // length (glam's `normalize_or_zero`), on the geometric side.
        let s =
            [0, 1, 2].map(|a| n[0][a][l] * w[0][l] + n[1][a][l] * w[1][l] + n[2][a][l] * w[2][l]);
        let recip = 1.0 / (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt();
        let unit = s.map(|v| v * recip);
        let dot = unit[0] * ng[0] + unit[1] * ng[1] + unit[2] * ng[2];
        let sign = if dot < 0.0 { -1.0 } else { 1.0 };
        for a in 0..3 {
            out.ng[a][l] = ng[a];
            out.ns[a][l] = unit[a] * sign;
        }
        out.plain[l] = squared > f32::MIN_POSITIVE
            && squared < f32::INFINITY
            && recip.is_finite()
            && recip > 0.0;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::builtin;

    /// The lanes give the scalar function's bits for every hit of the
    /// default scene's camera rays and their mirror bounces, including
    /// a short last group and misses between hits.
    #[test]
    fn lanes_give_the_bits_of_one_hit_at_a_time() {
        let Some(avx2) = Avx2::detect() else {
            eprintln!("skipping: no AVX2 here");
            return;
        };
        let scene = builtin::CORNELL.load(NormalMode::Smooth).unwrap();
        let accel = crate::accel::BackendConfig::NATIVE.build(&scene).unwrap();
        let camera = crate::render::camera::Camera::new(
            &scene,
            crate::render::camera::CameraMode::Canonical,
            37,
            29,
        );
        let mut counters = crate::accel::TraceCounters::default();
        let mut rays = Vec::new();
        for y in 0..29 {
            for x in 0..37 {
                let ray = camera.ray(x as f32 + 0.31, y as f32 + 0.57);
                rays.push(ray);
                if let Some(h) = crate::accel::Accel::closest_hit(&accel, &ray, &mut counters) {
                    let sp = scene.surface_point(&ray, &h);
                    let d =
                        ray.dir - sp.geometric_normal * (2.0 * ray.dir.dot(sp.geometric_normal));
                    rays.push(Ray::spawn(&sp.spawn_point(), d, f32::INFINITY));
                }
            }
        }
        let hits: Vec<Option<Hit>> = rays
            .iter()
            .map(|r| crate::accel::Accel::closest_hit(&accel, r, &mut counters))
            .collect();
        let mut out = Vec::new();
        surface_points(&scene, Some(avx2), &rays, &hits, &mut out);
        let grouped = hits
            .iter()
            .flatten()
            .filter(|h| (h.prim as usize) < scene.mesh.len())
            .count();
        assert!(grouped > 100 && grouped % L != 0, "{grouped} grouped hits");
        assert!(hits.iter().any(Option::is_none), "no misses among the hits");
        for ((ray, hit), point) in rays.iter().zip(&hits).zip(&out) {
            let expected = hit.map(|h| scene.surface_point(ray, &h));
            let point = &hit.map(|_| *point);
            let bits = |p: &Option<SurfacePoint>| {
                p.map(|p| {
                    [p.position, p.error, p.geometric_normal, p.shading_normal]
                        .map(|v| v.to_array().map(f32::to_bits))
                })
            };
            assert_eq!(bits(point), bits(&expected), "hit {hit:?}");
            assert_eq!(point.map(|p| p.material), expected.map(|p| p.material));
        }
    }
}
