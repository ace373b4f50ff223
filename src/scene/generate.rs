//! Scenes made in code: the white furnace, closed test meshes for the
//! parity suite, and meshes of any size for the scaling study.

use glam::Vec3;

pub use super::builder::SceneBuilder;
use super::environment::Environment;
use super::{Material, NormalMode, Scene};

/// An axis-aligned box `[-1, 1]^3` as 12 triangles, wound outward (or
/// inward with `inward`).
pub fn cube(inward: bool) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let positions: Vec<Vec3> = (0..8)
        .map(|i| {
            Vec3::new(
                if i & 4 != 0 { 1.0 } else { -1.0 },
                if i & 2 != 0 { 1.0 } else { -1.0 },
                if i & 1 != 0 { 1.0 } else { -1.0 },
            )
        })
        .collect();
    // Quads wound counter-clockwise seen from outside.
    let quads = [
        [0, 1, 3, 2],
        [4, 6, 7, 5],
        [0, 4, 5, 1],
        [2, 3, 7, 6],
        [0, 2, 6, 4],
        [1, 5, 7, 3],
    ];
    let mut tris = Vec::new();
    for q in quads {
        for t in [[q[0], q[1], q[2]], [q[0], q[2], q[3]]] {
            tris.push(if inward { [t[0], t[2], t[1]] } else { t });
        }
    }
    (positions, tris)
}

/// A unit icosphere: the icosahedron subdivided `level` times (20 * 4^level
/// triangles), vertices shared, wound outward.
pub fn icosphere(level: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut positions: Vec<Vec3> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
    .collect();
    let mut tris: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..level {
        (positions, tris) = subdivide(&positions, &tris);
        for p in &mut positions {
            *p = p.normalize();
        }
    }
    (positions, tris)
}

/// A unit "quad ball": each face of a cube split into `n x n` quads, its
/// vertices pushed onto the unit sphere, and each quad split into two
/// triangles along one diagonal (6 * 2 n^2 triangles, vertices shared,
/// wound outward), as modelling tools make them. Its triangles differ in
/// shape and size (the cube's corners squeeze them), unlike an icosphere's.
pub fn quad_ball(n: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let mut index = std::collections::HashMap::new();
    let mut positions = Vec::new();
    let mut tris = Vec::with_capacity((12 * n * n) as usize);
    // Each face: its normal axis and side, and two in-face axes whose
    // cross product points out.
    let faces: [(usize, f32, usize, usize); 6] = [
        (0, 1.0, 1, 2),
        (0, -1.0, 2, 1),
        (1, 1.0, 2, 0),
        (1, -1.0, 0, 2),
        (2, 1.0, 0, 1),
        (2, -1.0, 1, 0),
    ];
    let n = n as i32;
    for (axis, side, a, b) in faces {
        let mut vertex = |i: i32, j: i32| -> u32 {
            // Integer coordinates on the cube [-n, n]^3 name a vertex once.
            let mut key = [0i32; 3];
            key[axis] = side as i32 * n;
            key[a] = 2 * i - n;
            key[b] = 2 * j - n;
            *index.entry(key).or_insert_with(|| {
                let p = Vec3::new(key[0] as f32, key[1] as f32, key[2] as f32);
                positions.push(p.normalize());
                positions.len() as u32 - 1
            })
        };
        for j in 0..n {
            for i in 0..n {
                let q = [
                    vertex(i, j),
                    vertex(i + 1, j),
                    vertex(i + 1, j + 1),
                    vertex(i, j + 1),
                ];
                tris.push([q[0], q[1], q[2]]);
                tris.push([q[0], q[2], q[3]]);
            }
        }
    }
    (positions, tris)
}

/// Every triangle split into four at its edges' midpoints (shared edges
/// share their midpoint): four times the triangles, the same surface.
pub fn subdivide(positions: &[Vec3], tris: &[[u32; 3]]) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let mut positions = positions.to_vec();
    let mut midpoints = std::collections::HashMap::with_capacity(tris.len() * 3 / 2);
    let mut mid = |a: u32, b: u32, positions: &mut Vec<Vec3>| -> u32 {
        let key = (a.min(b), a.max(b));
        *midpoints.entry(key).or_insert_with(|| {
            positions.push((positions[a as usize] + positions[b as usize]) * 0.5);
            positions.len() as u32 - 1
        })
    };
    let mut next = Vec::with_capacity(tris.len() * 4);
    for &[a, b, c] in tris {
        let ab = mid(a, b, &mut positions);
        let bc = mid(b, c, &mut positions);
        let ca = mid(c, a, &mut positions);
        next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
    }
    (positions, next)
}

/// A flat `n x n` grid of quads (2 n^2 triangles) on `z = 0` over
/// `[-1, 1]^2`, normal +z.
pub fn plate(n: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let mut positions = Vec::with_capacity(((n + 1) * (n + 1)) as usize);
    for j in 0..=n {
        for i in 0..=n {
            positions.push(Vec3::new(
                -1.0 + 2.0 * i as f32 / n as f32,
                -1.0 + 2.0 * j as f32 / n as f32,
                0.0,
            ));
        }
    }
    let mut tris = Vec::with_capacity((2 * n * n) as usize);
    for j in 0..n {
        for i in 0..n {
            let v = |di: u32, dj: u32| (j + dj) * (n + 1) + i + di;
            tris.push([v(0, 0), v(1, 0), v(1, 1)]);
            tris.push([v(0, 0), v(1, 1), v(0, 1)]);
        }
    }
    (positions, tris)
}

/// The white furnace: the camera inside a closed box whose walls are all
/// Lambertian with `albedo` and emit `emission` inwards. The radiance
/// everywhere is `emission * sum_{k=0..M} albedo^k` with `M` bounces.
pub fn white_furnace(albedo: f32, emission: f32) -> Scene {
    let mut b = SceneBuilder::new("white furnace");
    let m = b.material(Material::Lambertian {
        albedo: Vec3::splat(albedo),
        emission: Vec3::splat(emission),
    });
    let (p, t) = cube(true);
    b.mesh(&p, &t, m);
    b.camera(
        Vec3::new(0.1, 0.05, 0.2),
        Vec3::new(0.3, -0.2, -1.0),
        60.0,
        45.0,
    );
    b.finish(NormalMode::Flat)
}

/// A cloud of `count` icospheres (level `level`, 20 * 4^level triangles
/// each) of random sizes at random places in `[-1, 1]^3`, some overlapping,
/// with an area light above: many separate objects of varying size and
/// density, a harder case for a BVH than one smooth mesh. The same `seed`
/// gives the same scene.
pub fn sphere_cloud(count: u32, level: u32, seed: u64) -> Scene {
    let mut rng = crate::geom::sampling::Rng::new(seed, 21);
    let (unit, tris) = icosphere(level);
    let mut b = SceneBuilder::new(&format!(
        "generated: {count} icospheres, {} triangles",
        count as usize * tris.len()
    ));
    let m = b.material(Material::lambertian(Vec3::splat(0.6)));
    for _ in 0..count {
        let centre = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 1.8 - 0.9;
        let radius = 0.04 + 0.2 * rng.next_f32() * rng.next_f32();
        let positions: Vec<Vec3> = unit.iter().map(|p| centre + *p * radius).collect();
        b.mesh(&positions, &tris, m);
    }
    b.light(crate::scene::Light::Area(crate::scene::AreaLight {
        origin: Vec3::new(-0.5, 1.5, -0.5),
        edge_u: Vec3::new(1.0, 0.0, 0.0),
        edge_v: Vec3::new(0.0, 0.0, 1.0),
        triangle: false,
        normal: Vec3::new(0.0, -1.0, 0.0),
        radiance: Vec3::splat(4.0),
        area: 1.0,
        surface: crate::scene::AreaLight::NO_SURFACE,
    }));
    b.camera(Vec3::new(0.0, 0.4, 3.5), Vec3::ZERO, 50.0, 40.0);
    b.finish(NormalMode::Smooth)
}

/// A sky for the environment light: `sky` above the horizon, a dim ground
/// (a fifth of it) below, and a sun of angular radius `sun_degrees` towards
/// `sun` (need not be unit) emitting `sun_radiance`. A small bright sun is
/// where sampling the map by luminance pays most over uniform sampling.
pub fn sun_and_sky(
    width: u32,
    height: u32,
    sun: Vec3,
    sun_degrees: f32,
    sun_radiance: Vec3,
    sky: Vec3,
) -> Environment {
    let sun = sun.normalize();
    let cos_sun = sun_degrees.to_radians().cos();
    Environment::from_fn(
        &format!("generated sun ({sun_degrees} degrees) and sky"),
        width,
        height,
        |d| {
            if d.dot(sun) >= cos_sun {
                sun_radiance
            } else if d.y > 0.0 {
                sky
            } else {
                sky * 0.2
            }
        },
    )
}

/// The project's demonstration sky (`examples/sky_map.rs` writes it): 512
/// x 256 texels, a bluish sky of radiance about 0.5, and a sun of 2 degrees
/// radius at 35 degrees elevation whose radiance (1000) gives a horizontal
/// surface about as much light as the whole sky does.
pub fn demo_sky() -> Environment {
    sun_and_sky(
        512,
        256,
        Vec3::new(-0.6, 35f32.to_radians().tan(), 0.8),
        2.0,
        Vec3::new(1000.0, 950.0, 850.0),
        Vec3::new(0.4, 0.5, 0.65),
    )
}

/// Three spheres on a grey plate, no lights of their own: a diffuse one,
/// rough gold (Beckmann alpha 0.25) and nearly polished silver (alpha
/// 0.05), for environment lighting (`-e`). No mirror: a sun's sharp
/// reflection would make pixel-area noise, the same for every way of
/// sampling the map, the largest error in the image.
pub fn spheres_on_a_plate() -> Scene {
    let mut b = SceneBuilder::new("generated: three spheres on a plate");
    let grey = b.material(Material::lambertian(Vec3::splat(0.6)));
    let white = b.material(Material::lambertian(Vec3::splat(0.8)));
    let gold = b.material(Material::Microfacet {
        alpha: 0.25,
        eta: Vec3::new(0.143119, 0.374957, 1.44248),
        k: Vec3::new(3.98316, 2.38572, 1.60322),
    });
    let silver = b.material(Material::Microfacet {
        alpha: 0.05,
        eta: Vec3::new(0.155265, 0.116723, 0.138342),
        k: Vec3::new(4.82835, 3.12225, 2.14696),
    });
    let (p, t) = plate(4);
    // The plate lies on y = 0, facing up, 6 x 6.
    let floor: Vec<Vec3> = p
        .iter()
        .map(|v| Vec3::new(v.x * 3.0, 0.0, -v.y * 3.0))
        .collect();
    b.mesh(&floor, &t, grey);
    b.sphere(Vec3::new(-1.1, 0.5, 0.0), 0.5, white);
    b.sphere(Vec3::new(0.0, 0.5, -0.3), 0.5, gold);
    b.sphere(Vec3::new(1.1, 0.5, 0.0), 0.5, silver);
    b.camera(
        Vec3::new(0.0, 1.6, 4.0),
        Vec3::new(0.0, 0.4, 0.0),
        50.0,
        38.0,
    );
    b.finish(NormalMode::Smooth)
}
