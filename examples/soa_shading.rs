//! Developer tool: the bet of shading many paths at once, measured on one
//! kernel before any integrator is rewritten (issue 45, point b). The
//! surface points of real hits (camera rays and their first diffuse
//! bounce on a scene) are computed one hit at a time by
//! [`Scene::surface_point`], as the renderer does, and eight hits at a
//! time in structure-of-arrays form: each lane gathers its triangle's
//! corners and normals, then every step (interpolation, the step off the
//! edge, the error bound, the geometric normal, the smooth normal) runs
//! across the eight lanes, compiled for AVX2 and left to LLVM's
//! vectorizer. Both must give the same bits; the tool checks that, then
//! prints ns per hit, best of `PASSES` passes, on the calling thread.
//!
//! ```text
//! taskset -c 1 cargo run --release --example soa_shading -- SCENE.dae [PASSES]
//! ```

// Lane loops index several arrays by one lane: the structure-of-arrays
// form this tool measures.
#![allow(clippy::needless_range_loop)]

use std::process::ExitCode;
use std::time::Instant;

use glam::Vec3;
use hybrid::accel::{Accel, BackendConfig};
use hybrid::geom::{gamma, Hit, Ray};
use hybrid::scene::{collada, NormalMode, Scene, SurfacePoint};

/// Lanes of one structure-of-arrays group.
const L: usize = 8;

/// A group's surface points, one array per component.
#[derive(Default, Clone, Copy)]
struct Points {
    p: [[f32; L]; 3],
    error: [[f32; L]; 3],
    ng: [[f32; L]; 3],
    ns: [[f32; L]; 3],
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(path) = args.first() else {
        eprintln!("usage: soa_shading SCENE.dae [PASSES]");
        return ExitCode::from(2);
    };
    let passes: usize = args.get(1).and_then(|p| p.parse().ok()).unwrap_or(7);
    let scene = match collada::load(std::path::Path::new(path), NormalMode::Smooth) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("soa_shading: {e}");
            return ExitCode::from(2);
        }
    };
    if !std::is_x86_feature_detected!("avx2") || !scene.spheres.is_empty() {
        eprintln!("soa_shading: needs AVX2 and a scene of triangles only");
        return ExitCode::from(2);
    }
    let accel = BackendConfig::NATIVE.build(&scene).expect("native build");
    let hits = real_hits(&scene, &accel);
    let groups = hits.len() / L;
    let hits = &hits[..groups * L];
    println!("{}: {} hits (camera rays and first bounces)", scene.name, hits.len());

    let mut scalar = vec![None; hits.len()];
    let mut soa = vec![Points::default(); groups];
    let (mut best_scalar, mut best_soa) = (f64::INFINITY, f64::INFINITY);
    for _ in 0..passes {
        let t = Instant::now();
        for (out, (ray, hit)) in scalar.iter_mut().zip(hits) {
            *out = Some(std::hint::black_box(scene.surface_point(ray, hit)));
        }
        best_scalar = best_scalar.min(t.elapsed().as_secs_f64());
        let t = Instant::now();
        for (out, group) in soa.iter_mut().zip(hits.chunks_exact(L)) {
            // SAFETY: AVX2 was detected above.
            *out = std::hint::black_box(unsafe { surface_points_avx2(&scene, group) });
        }
        best_soa = best_soa.min(t.elapsed().as_secs_f64());
    }
    let mut differ = 0;
    for (k, sp) in scalar.iter().enumerate() {
        let sp: &SurfacePoint = sp.as_ref().expect("computed");
        let (g, l) = (&soa[k / L], k % L);
        let lane = |a: &[[f32; L]; 3]| Vec3::new(a[0][l], a[1][l], a[2][l]);
        if lane(&g.p) != sp.position
            || lane(&g.error) != sp.error
            || lane(&g.ng) != sp.geometric_normal
            || lane(&g.ns) != sp.shading_normal
        {
            differ += 1;
        }
    }
    let ns = |s: f64| s * 1e9 / hits.len() as f64;
    println!(
        "one at a time {:.2} ns per hit, eight lanes {:.2} ns per hit: {:.2}x; {differ} of {} hits differ in some bit",
        ns(best_scalar),
        ns(best_soa),
        best_scalar / best_soa,
        hits.len()
    );
    ExitCode::SUCCESS
}

/// Camera rays through a 320 x 240 image, 4 per pixel, and one cosine
/// bounce from each hit: the hits the renderer's first two vertices see.
fn real_hits<A: Accel>(scene: &Scene, accel: &A) -> Vec<(Ray, Hit)> {
    use hybrid::render::camera::{Camera, CameraMode};
    let camera = Camera::new(scene, CameraMode::Canonical, 320, 240);
    let mut rng = hybrid::geom::sampling::Rng::new(7, 0);
    let mut out = Vec::new();
    let mut counters = hybrid::accel::TraceCounters::default();
    for y in 0..240 {
        for x in 0..320 {
            for _ in 0..4 {
                let ray = camera.ray(x as f32 + rng.next_f32(), y as f32 + rng.next_f32());
                let Some(hit) = accel.closest_hit(&ray, &mut counters) else {
                    continue;
                };
                out.push((ray, hit));
                let sp = scene.surface_point(&ray, &hit);
                let n = if sp.geometric_normal.dot(ray.dir) > 0.0 {
                    -sp.geometric_normal
                } else {
                    sp.geometric_normal
                };
                let (u, v) = (rng.next_f32(), rng.next_f32());
                let local = hybrid::geom::sampling::cosine_hemisphere(u, v);
                let frame = hybrid::geom::sampling::Frame::new(n);
                let bounce = Ray::spawn(&sp.spawn_point(), frame.to_world(local), f32::INFINITY);
                if let Some(h) = accel.closest_hit(&bounce, &mut counters) {
                    out.push((bounce, h));
                }
            }
        }
    }
    out
}

/// `Scene::surface_point` of eight triangle hits, lane by lane in the
/// same operations and order, so the bits agree.
///
/// # Safety
/// The CPU must have AVX2.
#[target_feature(enable = "avx2")]
unsafe fn surface_points_avx2(scene: &Scene, group: &[(Ray, Hit)]) -> Points {
    // Gather: corners, corner normals, barycentrics.
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
        let u = hit.u.clamp(0.0, 1.0);
        let v = hit.v.clamp(0.0, 1.0 - u);
        w[0][l] = (1.0 - u - v).max(0.0);
        w[1][l] = u;
        w[2][l] = v;
    }
    let mut out = Points::default();
    let g12 = gamma(12);
    let g9 = gamma(9);
    // Every step below runs over the eight lanes.
    let mut size = [0f32; L];
    for (l, s) in size.iter_mut().enumerate() {
        let d = |x: usize, y: usize, a: usize| (c[x][a][l] - c[y][a][l]).abs();
        // Vec3::max per component, then max_element, as the scalar code.
        let m = [0, 1, 2].map(|a| d(1, 0, a).max(d(2, 0, a)).max(d(2, 1, a)));
        *s = m[0].max(m[1]).max(m[2]);
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
        let margin = g12 * size[l];
        let reach = (inward[0][l] * inward[0][l] + inward[1][l] * inward[1][l]
            + inward[2][l] * inward[2][l])
            .sqrt();
        let step = if reach > 2.0 * margin {
            2.0 * margin / reach
        } else {
            0.0
        };
        for a in 0..3 {
            out.p[a][l] = if reach > 2.0 * margin {
                on_plane[a][l] + inward[a][l] * step
            } else {
                on_plane[a][l]
            };
            out.error[a][l] = g9
                * ((c[0][a][l] * w[0][l]).abs()
                    + (c[1][a][l] * w[1][l]).abs()
                    + (c[2][a][l] * w[2][l]).abs())
                + margin;
        }
    }
    // Geometric normal: (b - a) x (c - a), divided by its length.
    for l in 0..L {
        let e1 = [0, 1, 2].map(|a| c[1][a][l] - c[0][a][l]);
        let e2 = [0, 1, 2].map(|a| c[2][a][l] - c[0][a][l]);
        let x = [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ];
        let len = (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt();
        for a in 0..3 {
            out.ng[a][l] = x[a] / len;
        }
    }
    // Smooth normal: interpolated, normalized, on the geometric side.
    for l in 0..L {
        let s = [0, 1, 2].map(|a| n[0][a][l] * w[0][l] + n[1][a][l] * w[1][l] + n[2][a][l] * w[2][l]);
        let len2 = s[0] * s[0] + s[1] * s[1] + s[2] * s[2];
        let inv = 1.0 / len2.sqrt();
        let unit = s.map(|x| x * inv);
        let dot = unit[0] * out.ng[0][l] + unit[1] * out.ng[1][l] + unit[2] * out.ng[2][l];
        let sign = if dot < 0.0 { -1.0 } else { 1.0 };
        for a in 0..3 {
            out.ns[a][l] = unit[a] * sign;
        }
    }
    out
}
