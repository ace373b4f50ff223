//! The hard-case families, one function each. Every family builds its own
//! scenes and rays from the seed, so families can be run, reordered or
//! added independently.

use glam::Vec3;

use super::{Case, Expect};
use crate::accel::{Accel, BackendConfig, TraceCounters};
use crate::geom::sampling::{cosine_hemisphere, uniform_sphere, Frame, Rng};
use crate::geom::Ray;
use crate::scene::generate::{cube, icosphere, plate, SceneBuilder};
use crate::scene::{Material, NormalMode, Scene};

fn mesh_scene(name: &str, positions: &[Vec3], tris: &[[u32; 3]]) -> Scene {
    let mut b = SceneBuilder::new(name);
    let m = b.material(Material::DEFAULT);
    b.mesh(positions, tris, m);
    b.finish(NormalMode::Flat)
}

/// Edges shared by exactly two triangles: (vertex a, vertex b, tri 1, tri 2).
fn shared_edges(tris: &[[u32; 3]]) -> Vec<(u32, u32, u32, u32)> {
    let mut map: std::collections::HashMap<(u32, u32), Vec<u32>> = std::collections::HashMap::new();
    for (i, t) in tris.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            map.entry((a.min(b), a.max(b))).or_default().push(i as u32);
        }
    }
    let mut edges: Vec<_> = map
        .into_iter()
        .filter(|(_, v)| v.len() == 2)
        .map(|((a, b), v)| (a, b, v[0], v[1]))
        .collect();
    edges.sort();
    edges
}

/// Rays aimed exactly at points of shared edges and at vertices.
///
/// From inside a closed mesh every ray must hit something (`Expect::Hit`).
/// From outside, a ray aimed at a silhouette edge only touches the surface,
/// which is ill-posed; so only edges whose two triangles both face the
/// origin are aimed at, and the first hit must come no later than the
/// aimed point (`Expect::HitBy`). None when the mesh has no shared edge
/// (spheres only, unwelded triangles) or none faces the origins.
fn aimed_rays(
    name: &str,
    inside: bool,
    origin_of: impl Fn(&mut Rng) -> Vec3,
    positions: &[Vec3],
    tris: &[[u32; 3]],
    n: usize,
    seed: u64,
) -> Option<Case> {
    let edges = shared_edges(tris);
    if edges.is_empty() || positions.is_empty() {
        return None;
    }
    let normal = |t: u32| {
        let [a, b, c] = tris[t as usize].map(|i| positions[i as usize]);
        (b - a).cross(c - a)
    };
    let mut rng = Rng::new(seed, 11);
    let mut rays = Vec::with_capacity(n);
    let mut pairs = Vec::with_capacity(n);
    let mut attempts = 0;
    while rays.len() < n && attempts < 100 * n {
        attempts += 1;
        let origin = origin_of(&mut rng);
        let (target, pair) = if inside && rays.len() % 4 == 3 {
            (positions[(rng.next_u32() as usize) % positions.len()], None)
        } else {
            let (a, b, t1, t2) = edges[(rng.next_u32() as usize) % edges.len()];
            let s = 0.05 + 0.9 * rng.next_f32();
            (
                positions[a as usize].lerp(positions[b as usize], s),
                Some((t1, t2)),
            )
        };
        let dir = target - origin;
        if !inside {
            let (t1, t2) = pair.expect("outside rays aim at edges");
            if normal(t1).dot(dir) >= 0.0 || normal(t2).dot(dir) >= 0.0 {
                continue;
            }
        }
        let expect = if inside {
            Expect::Hit
        } else {
            Expect::HitBy(dir.length())
        };
        rays.push((Ray::new(origin, dir.normalize()), expect));
        pairs.push(pair);
    }
    (!rays.is_empty()).then(|| Case {
        name: name.into(),
        failure: "leaks",
        scene: mesh_scene(name, positions, tris),
        rays,
        watertight_promise: true,
        edge_pairs: pairs,
    })
}

/// Closed meshes (icosphere, cube, and a scanned mesh when given) hit
/// exactly at shared edges and vertices, from inside and outside. A
/// scanned mesh without shared edges gets a note instead of a case.
pub fn closed_meshes(
    n: usize,
    seed: u64,
    scanned: Option<&Scene>,
    notes: &mut Vec<String>,
) -> Vec<Case> {
    let mut cases = Vec::new();
    let (sp, st) = icosphere(4);
    cases.extend(aimed_rays(
        "icosphere 5120 tris, edges+vertices from inside",
        true,
        |r| uniform_sphere(r.next_f32(), r.next_f32()) * 0.5 * r.next_f32(),
        &sp,
        &st,
        n,
        seed,
    ));
    cases.extend(aimed_rays(
        "icosphere 5120 tris, front-facing edges from outside",
        false,
        |r| uniform_sphere(r.next_f32(), r.next_f32()) * 3.0,
        &sp,
        &st,
        n,
        seed + 1,
    ));
    let (cp, ct) = cube(false);
    cases.extend(aimed_rays(
        "cube, edges+vertices from inside",
        true,
        |r| (Vec3::new(r.next_f32(), r.next_f32(), r.next_f32()) - 0.5) * 1.6,
        &cp,
        &ct,
        n,
        seed + 2,
    ));
    cases.extend(aimed_rays(
        "cube, front-facing edges from outside",
        false,
        |r| uniform_sphere(r.next_f32(), r.next_f32()) * 4.0,
        &cp,
        &ct,
        n,
        seed + 3,
    ));
    if let Some(scene) = scanned {
        let b = scene.bounds();
        let (c, radius) = (b.center(), b.extent().length());
        let case = aimed_rays(
            &format!(
                "{} (scanned), front-facing shared edges from outside",
                scene.name.rsplit('/').next().unwrap_or("scanned")
            ),
            false,
            |r| c + uniform_sphere(r.next_f32(), r.next_f32()) * radius,
            &scene.mesh.positions,
            &scene.mesh.indices,
            n,
            seed + 4,
        );
        match case {
            Some(mut case) => {
                case.scene = scene.clone();
                cases.push(case);
            }
            None => notes.push(format!(
                "{}: no triangles share an edge (spheres only, or unwelded triangles), so it adds no edge case",
                scene.name
            )),
        }
    }

    cases
}

/// The same closed icosphere translated 10^3..10^6 from the origin, hit at
/// its edges and vertices from inside.
pub fn far_from_the_origin(n: usize, seed: u64) -> Vec<Case> {
    let (sp, st) = icosphere(4);
    let mut cases = Vec::new();
    for offset in [1e3f32, 1e4, 1e5, 1e6] {
        let shift = Vec3::new(offset, -offset * 0.5, offset * 0.25);
        let moved: Vec<Vec3> = sp.iter().map(|p| *p + shift).collect();
        let Some(mut case) = aimed_rays(
            &format!("icosphere at {offset:.0e}, from inside"),
            true,
            move |r| shift + uniform_sphere(r.next_f32(), r.next_f32()) * 0.5 * r.next_f32(),
            &moved,
            &st,
            n / 2,
            seed + 5,
        ) else {
            continue;
        };
        case.watertight_promise = true;
        cases.push(case);
    }

    cases
}

/// Axis-aligned rays with +0 / -0 direction components at the grid lines
/// of a plate: edges and vertices hit exactly.
pub fn axis_aligned_rays(n: usize, seed: u64) -> Case {
    let (pp, pt) = plate(16);
    let mut rng = Rng::new(seed, 12);
    let mut rays = Vec::new();
    for i in 0..n {
        let gx = (rng.next_u32() % 33) as f32 / 16.0 - 1.0; // edges and vertices: multiples of 1/16
        let gy = (rng.next_u32() % 33) as f32 / 16.0 - 1.0;
        let (gx, gy) = if gx.abs() == 1.0 || gy.abs() == 1.0 {
            (gx * 0.999, gy * 0.999)
        } else {
            (gx, gy)
        };
        let zx = if i & 1 == 0 { 0.0 } else { -0.0 };
        let zy = if i & 2 == 0 { 0.0 } else { -0.0 };
        rays.push((
            Ray::new(Vec3::new(gx, gy, 1.0), Vec3::new(zx, zy, -1.0)),
            Expect::HitAt(1.0, 1e-6),
        ));
    }
    Case {
        watertight_promise: true,
        ..Case::new(
            "plate 16x16, axis-aligned ±0 rays at grid lines",
            "leaks",
            mesh_scene("plate", &pp, &pt),
            rays,
        )
    }
}

/// Rays in a plate's plane, and parallel to it just above.
pub fn parallel_rays(n: usize, seed: u64) -> Case {
    let (pp, pt) = plate(16);
    let mut rng = Rng::new(seed, 17);
    let mut rays = Vec::new();
    for i in 0..n {
        let y = rng.next_f32() * 1.8 - 0.9;
        let z = if i % 2 == 0 { 0.0 } else { 1e-3 };
        let expect = if z == 0.0 {
            Expect::Anything
        } else {
            Expect::Miss
        };
        rays.push((Ray::new(Vec3::new(-2.0, y, z), Vec3::X), expect));
    }
    Case::new(
        "plate, rays parallel to the plane (in it, and 1e-3 above)",
        "false hits above",
        mesh_scene("plate", &pp, &pt),
        rays,
    )
}

/// Grazing rays at 1e-2 .. 1e-5 radians to interior points of a plate.
pub fn grazing_rays(n: usize, seed: u64) -> Case {
    let (pp, pt) = plate(16);
    let mut rng = Rng::new(seed, 18);
    let mut rays = Vec::new();
    for i in 0..n {
        let angle = 10f32.powf(-2.0 - 3.0 * (i as f32 / n as f32));
        let target = Vec3::new(
            rng.next_f32() * 0.5 - 0.25,
            rng.next_f32() * 0.5 - 0.25,
            0.0,
        );
        let dir = Vec3::new(angle.cos(), 0.0, -angle.sin());
        let dist = 0.5;
        rays.push((
            Ray::new(target - dir * dist, dir),
            Expect::HitAt(dist, 1e-3),
        ));
    }
    Case::new(
        "plate, grazing rays 1e-2..1e-5 rad",
        "misses or t err > 1e-3",
        mesh_scene("plate", &pp, &pt),
        rays,
    )
}

/// Tiny and huge triangles: interior points must be hit at the right t,
/// points outside must be missed.
pub fn tiny_and_huge_triangles(n: usize, seed: u64) -> Vec<Case> {
    let mut cases = Vec::new();
    for scale in [1e-6f32, 1e6] {
        let tri = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(scale, 0.0, 0.0),
            Vec3::new(0.0, scale, 0.0),
        ];
        let mut rng = Rng::new(seed, 13);
        let mut rays = Vec::new();
        for i in 0..n {
            let (mut a, mut b) = (0.05 + 0.9 * rng.next_f32(), 0.05 + 0.9 * rng.next_f32());
            if a + b > 0.95 {
                a *= 0.5;
                b *= 0.5;
            }
            let dir = uniform_sphere(rng.next_f32(), rng.next_f32() * 0.5);
            let dir = Vec3::new(dir.x * 0.5, dir.y * 0.5, -dir.z.abs().max(0.2)).normalize();
            let dist = scale * 3.0;
            let (target, expect) = if i % 4 == 3 {
                (
                    Vec3::new(-0.5 * scale * a - 0.01 * scale, scale * b, 0.0),
                    Expect::Miss,
                )
            } else {
                (
                    tri[0] + (tri[1] - tri[0]) * a + (tri[2] - tri[0]) * b,
                    Expect::HitAt(dist, 1e-4),
                )
            };
            rays.push((Ray::new(target - dir * dist, dir), expect));
        }
        cases.push(Case::new(
            format!("single triangle of size {scale:.0e}"),
            "wrong answers",
            mesh_scene("triangle", &tri, &[[0, 1, 2]]),
            rays,
        ));
    }

    cases
}

/// Zero-area and needle triangles inside a mesh: never hit the zero-area
/// ones.
pub fn degenerate_triangles(n: usize, seed: u64) -> Case {
    let positions = vec![
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::new(1.0, -1.0, 0.0),
        Vec3::new(1.0, 1.0, 0.0),
        // collinear (zero area) on the line y = 0.3, z = 0.5
        Vec3::new(-1.0, 0.3, 0.5),
        Vec3::new(0.0, 0.3, 0.5),
        Vec3::new(1.0, 0.3, 0.5),
        // needle: width 1e-7 along x at y = -0.3, z = 0.5
        Vec3::new(-1.0, -0.3, 0.5),
        Vec3::new(1.0, -0.3, 0.5),
        Vec3::new(1.0, -0.3 + 1e-7, 0.5),
    ];
    let tris = [[0, 1, 2], [3, 4, 5], [3, 3, 4], [6, 7, 8]];
    let mut rng = Rng::new(seed, 14);
    let mut rays = Vec::new();
    for i in 0..n {
        let x = rng.next_f32() * 1.8 - 0.9;
        let jitter = (rng.next_f32() - 0.5) * 1e-6;
        let (y, expect) = match i % 3 {
            0 => (0.3 + jitter, Expect::NotPrimitive(1)),
            1 => (0.3 + jitter, Expect::NotPrimitive(2)),
            _ => (-0.3 + jitter, Expect::Anything),
        };
        rays.push((Ray::new(Vec3::new(x, y, 2.0), -Vec3::Z), expect));
    }
    Case::new(
        "zero-area and needle triangles in a mesh",
        "false hits",
        mesh_scene("degenerate", &positions, &tris),
        rays,
    )
}

/// Secondary rays leaving a convex surface: any hit is a
/// self-intersection. The project's spawn rule against fixed offsets.
pub fn rays_leaving_a_surface(n: usize, seed: u64) -> Vec<Case> {
    let (sp, st) = icosphere(4);
    let mut cases = Vec::new();
    for offset in [0.0f32, 1e2, 1e4] {
        for (rule, label) in [
            (Spawn::Project, "spawn rule"),
            (Spawn::Fixed(1e-4), "fixed 1e-4"),
            (Spawn::Fixed(0.0), "no offset"),
        ] {
            let shift = Vec3::splat(offset);
            let moved: Vec<Vec3> = sp.iter().map(|p| *p + shift).collect();
            let scene = mesh_scene("icosphere", &moved, &st);
            let rays = leaving_rays(&scene, shift, n, seed + 6, rule);
            cases.push(Case::new(
                format!("rays leaving an icosphere at {offset:.0e}, {label}"),
                "self-intersections",
                scene,
                rays,
            ));
        }
    }

    cases
}

/// The junctions of an open box (floor, back and side walls, as in a
/// Cornell box), where two surfaces meet at a right angle. Rays from inside
/// aimed exactly at a junction must hit no farther than it (a leak is the
/// black pixel along a floor-wall edge); shadow rays from the points they
/// hit, spawned with the project's rule, towards points inside the box
/// must hit nothing (the box is convex from inside), so a hit is a ray
/// that started behind the neighbouring wall.
pub fn junctions(n: usize, seed: u64) -> Vec<Case> {
    let (positions, all) = cube(true);
    // Quads 0, 1: the side walls; 2: the floor; 4: the back wall.
    let tris: Vec<[u32; 3]> = all
        .iter()
        .enumerate()
        .filter(|(i, _)| [0, 1, 2, 4].contains(&(i / 2)))
        .map(|(_, t)| *t)
        .collect();
    let normal = |t: u32| {
        let [a, b, c] = tris[t as usize].map(|i| positions[i as usize]);
        (b - a).cross(c - a).normalize()
    };
    let corners: Vec<_> = shared_edges(&tris)
        .into_iter()
        .filter(|&(_, _, t1, t2)| normal(t1).dot(normal(t2)).abs() < 0.5)
        .collect();
    let scene = mesh_scene("open box", &positions, &tris);
    let mut rng = Rng::new(seed, 17);
    let inside = |r: &mut Rng, reach: f32| {
        (Vec3::new(r.next_f32(), r.next_f32(), r.next_f32()) * 2.0 - 1.0) * reach
    };
    let mut aimed = Vec::with_capacity(n);
    let mut pairs = Vec::with_capacity(n);
    for _ in 0..n {
        let (a, b, t1, t2) = corners[(rng.next_u32() as usize) % corners.len()];
        let target = positions[a as usize].lerp(positions[b as usize], rng.next_f32());
        let origin = inside(&mut rng, 0.9);
        let dir = target - origin;
        aimed.push((
            Ray::new(origin, dir.normalize()),
            Expect::HitBy(dir.length()),
        ));
        pairs.push(Some((t1, t2)));
    }
    let finder = BackendConfig::NATIVE_WATERTIGHT
        .build(&scene)
        .expect("the native backend cannot fail");
    let mut counters = TraceCounters::default();
    let shadows = aimed
        .iter()
        .filter_map(|(ray, _)| {
            let hit = finder.closest_hit(ray, &mut counters)?;
            let mut at = scene.surface_point(ray, &hit).spawn_point();
            if at.ng.dot(ray.dir) > 0.0 {
                at.ng = -at.ng;
            }
            let to = inside(&mut rng, 0.95) - at.p;
            (to.dot(at.ng) > 0.0).then(|| {
                let distance = to.length();
                (Ray::shadow(&at, to / distance, distance), Expect::Miss)
            })
        })
        .collect();
    drop(finder);
    vec![
        Case {
            name: "open box, rays from inside aimed at the wall junctions".into(),
            failure: "leaks",
            scene: scene.clone(),
            rays: aimed,
            watertight_promise: true,
            edge_pairs: pairs,
        },
        Case::new(
            "open box, shadow rays from junction points, spawn rule",
            "self-intersections",
            scene,
            shadows,
        ),
    ]
}

/// Spheres from inside, from outside and tangent; tiny to huge radii.
pub fn spheres(n: usize, seed: u64) -> Vec<Case> {
    let mut cases = Vec::new();
    for radius in [1e-4f32, 1.0, 1e4] {
        let mut b = SceneBuilder::new("sphere");
        let m = b.material(Material::DEFAULT);
        let centre = Vec3::new(radius * 0.3, -radius * 0.2, radius * 0.1);
        b.sphere(centre, radius, m);
        let scene = b.finish(NormalMode::Flat);
        let mut rng = Rng::new(seed, 15);
        let mut rays = Vec::new();
        for i in 0..n {
            let d = uniform_sphere(rng.next_f32(), rng.next_f32());
            let ray = match i % 3 {
                0 => (Ray::new(centre, d), Expect::HitAt(radius, 1e-4)),
                1 => (
                    Ray::new(centre - d * 3.0 * radius, d),
                    Expect::HitAt(2.0 * radius, 1e-4),
                ),
                _ => {
                    let side = Frame::new(d).s;
                    (
                        Ray::new(centre + side * radius - d * 2.0 * radius, d),
                        Expect::Anything,
                    )
                }
            };
            rays.push(ray);
        }
        cases.push(Case::new(
            format!("sphere r={radius:.0e}: inside, outside, tangent"),
            "wrong t (inside/outside)",
            scene,
            rays,
        ));
    }

    cases
}

/// NaN, infinite and zero-direction rays: reported as misses, never a
/// crash.
pub fn untraceable_rays(n: usize) -> Case {
    let (pp, pt) = plate(4);
    let bad = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY];
    let mut rays = Vec::new();
    for i in 0..n.min(300) {
        let v = bad[i % 3];
        let ray = match (i / 3) % 4 {
            0 => Ray::new(Vec3::new(v, 0.0, 1.0), -Vec3::Z),
            1 => Ray::new(Vec3::new(0.0, 0.0, 1.0), Vec3::new(0.0, v, -1.0)),
            2 => Ray {
                origin: Vec3::new(0.0, 0.0, 1.0),
                dir: -Vec3::Z,
                t_min: 0.0,
                t_max: v,
            },
            _ => Ray::new(Vec3::new(0.0, 0.0, 1.0), Vec3::ZERO),
        };
        // An infinite t_max on a valid ray is a normal ray.
        let expect = if (i / 3) % 4 == 2 && v == f32::INFINITY {
            Expect::HitAt(1.0, 1e-6)
        } else {
            Expect::Miss
        };
        rays.push((ray, expect));
    }
    Case::new(
        "NaN / infinite / zero-direction rays",
        "answers other than a miss",
        mesh_scene("plate", &pp, &pt),
        rays,
    )
}

#[derive(Clone, Copy)]
enum Spawn {
    Project,
    Fixed(f32),
}

/// Cosine-distributed rays leaving hit points of a convex mesh centred at
/// `centre`, spawned with `rule`; they must hit nothing.
fn leaving_rays(
    scene: &Scene,
    centre: Vec3,
    n: usize,
    seed: u64,
    rule: Spawn,
) -> Vec<(Ray, Expect)> {
    // Hit points from rays shot at the surface from outside (native
    // Möller–Trumbore finds them; every mode then gets the same rays).
    let finder = BackendConfig::NATIVE
        .build(scene)
        .expect("the native backend cannot fail");
    let mut rng = Rng::new(seed, 16);
    let mut rays = Vec::with_capacity(n);
    let mut counters = TraceCounters::default();
    while rays.len() < n {
        let d = uniform_sphere(rng.next_f32(), rng.next_f32());
        let probe = Ray::new(centre + d * 3.0, -d);
        let Some(hit) = finder.closest_hit(&probe, &mut counters) else {
            continue;
        };
        let mut at = scene.surface_point(&probe, &hit).spawn_point();
        if at.ng.dot(probe.dir) > 0.0 {
            at.ng = -at.ng;
        }
        let (u, v) = rng.next_2d();
        let dir = Frame::new(at.ng).to_world(cosine_hemisphere(u, v));
        let ray = match rule {
            Spawn::Project => Ray::spawn(&at, dir, f32::INFINITY),
            // The naive rule: o + t d, moved a fixed distance.
            Spawn::Fixed(eps) => Ray::new(probe.at(hit.t) + at.ng * eps, dir),
        };
        rays.push((ray, Expect::Miss));
    }
    rays
}
