//! The mesh corpus the traversal is judged on: every mesh of the shared
//! scenes, and generated meshes of 10^4 to 10^6 triangles whose shapes the
//! shared ones lack (a noisy closed surface at two sizes, a soup of
//! unconnected triangles, a long thin tube). `hybrid rays corpus DIR`
//! writes one export per mesh into `DIR/<mesh>/`; `hybrid bench DIR` on
//! such a folder replays them all and names the worst mesh first.

use std::path::Path;

use glam::{Mat4, Vec3};

use crate::geom::sampling::Rng;
use crate::scene::generate::{icosphere, subdivide, SceneBuilder};
use crate::scene::{collada, Material, NormalMode, Scene};

/// The shared scenes of the corpus, relative to the shared scenes folder:
/// every mesh there of more than a few hundred triangles.
pub const SHARED: [&str; 6] = [
    "meshedit/maxplanck.dae",
    "meshedit/cow.dae",
    "meshedit/teapot.dae",
    "keenan/banana.dae",
    "sky/bunny.dae",
    "sky/CBbunny.dae",
];

/// The generated meshes, by folder name.
pub const GENERATED: [&str; 4] = [
    "noisy_sphere_82k",
    "noisy_sphere_1m",
    "soup_100k",
    "tube_100k",
];

/// A corpus mesh's folder name: `meshedit/maxplanck.dae` -> `maxplanck`.
pub fn folder_name(shared: &str) -> String {
    Path::new(shared)
        .file_stem()
        .map_or_else(|| shared.to_string(), |s| s.to_string_lossy().into_owned())
}

/// Every corpus mesh's folder name, the shared ones first, in the order
/// of the tables.
pub fn names() -> Vec<String> {
    SHARED
        .iter()
        .map(|s| folder_name(s))
        .chain(GENERATED.iter().map(|s| s.to_string()))
        .collect()
}

/// The corpus mesh of folder `name` (one of [`names`]): a shared scene
/// loaded from `scenes`, or a generated mesh. A missing shared scene is
/// an error that names it: the corpus is judged whole or not at all.
pub fn load(scenes: &Path, name: &str) -> Result<Scene, String> {
    match SHARED.iter().find(|s| folder_name(s) == name) {
        Some(rel) => {
            collada::load(&scenes.join(rel), NormalMode::Smooth).map_err(|e| e.to_string())
        }
        None if GENERATED.contains(&name) => Ok(generated(name)),
        None => Err(format!(
            "{name}: not a mesh of the corpus ({})",
            names().join(", ")
        )),
    }
}

/// One generated mesh by name (one of [`GENERATED`]); the same name gives
/// the same triangles.
pub fn generated(name: &str) -> Scene {
    let (positions, tris) = match name {
        "noisy_sphere_82k" => noisy_sphere(6),
        "noisy_sphere_1m" => noisy_sphere(8),
        "soup_100k" => soup(100_000),
        "tube_100k" => tube(400, 128),
        _ => unreachable!("{name} is not a generated corpus mesh"),
    };
    let mut b = SceneBuilder::new(name);
    let m = b.material(Material::DEFAULT);
    b.mesh(&positions, &tris, m);
    let mut scene = b.finish(NormalMode::Flat);
    // An oblique eye, as a user frames a model: from above and beside.
    scene.camera.transform =
        Mat4::from_rotation_y(0.6) * Mat4::from_rotation_x(-0.45) * scene.camera.transform;
    scene
}

/// A unit icosphere subdivided `level` times (20 * 4^level triangles),
/// each vertex moved along its radius by a smooth random bump of up to
/// 10% (a sum of a few random waves), so that the surface is closed and
/// scanned-looking, with no plane aligned to an axis.
fn noisy_sphere(level: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let (mut positions, tris) = icosphere(level.min(4));
    let mut tris = tris;
    for _ in 4..level {
        (positions, tris) = subdivide(&positions, &tris);
    }
    let mut rng = Rng::new(73, 1);
    let waves: Vec<(Vec3, f32)> = (0..12)
        .map(|_| {
            let k = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - 1.0;
            (k * 9.0, rng.next_f32() * std::f32::consts::TAU)
        })
        .collect();
    for p in &mut positions {
        let unit = p.normalize();
        let bump: f32 = waves
            .iter()
            .map(|(k, phase)| (k.dot(unit) + phase).sin())
            .sum();
        *p = unit * (1.0 + 0.1 * bump / waves.len() as f32 * 3.0);
    }
    (positions, tris)
}

/// `n` unconnected triangles at random places in a unit cube, each with
/// random corners within 2% of the cube's side of its centre: no surface,
/// every box overlapping its neighbours.
fn soup(n: usize) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let mut rng = Rng::new(73, 2);
    let mut next = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
    let mut positions = Vec::with_capacity(3 * n);
    for _ in 0..n {
        let centre = next();
        for _ in 0..3 {
            positions.push(centre + (next() - 0.5) * 0.04);
        }
    }
    let tris = (0..n as u32)
        .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
        .collect();
    (positions, tris)
}

/// A closed tube a hundred times longer than wide, bent into a gentle arc
/// (`rings` rings of `around` vertices; 2 * rings * around triangles):
/// long thin boxes at every level of the tree.
fn tube(rings: u32, around: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let mut positions = Vec::with_capacity((rings * around) as usize);
    for r in 0..rings {
        let s = r as f32 / (rings - 1) as f32;
        let (bend, length) = (0.8 * (s - 0.5), 100.0);
        let centre = Vec3::new(s * length - 0.5 * length, 10.0 * bend * bend, 0.0);
        for a in 0..around {
            let phi = a as f32 / around as f32 * std::f32::consts::TAU;
            positions.push(centre + Vec3::new(0.0, phi.cos(), phi.sin()) * 0.5);
        }
    }
    let mut tris = Vec::with_capacity((2 * rings * around) as usize);
    let at = |r: u32, a: u32| r * around + a % around;
    for r in 0..rings - 1 {
        for a in 0..around {
            tris.push([at(r, a), at(r + 1, a), at(r + 1, a + 1)]);
            tris.push([at(r, a), at(r + 1, a + 1), at(r, a + 1)]);
        }
    }
    (positions, tris)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_generated_meshes_have_the_sizes_their_names_say() {
        for (name, least, most) in [
            ("noisy_sphere_82k", 80_000, 84_000),
            ("noisy_sphere_1m", 1_000_000, 1_400_000),
            ("soup_100k", 100_000, 100_000),
            ("tube_100k", 100_000, 103_000),
        ] {
            let scene = generated(name);
            let n = scene.triangle_count();
            assert!((least..=most).contains(&n), "{name}: {n} triangles");
            assert_eq!(scene.degenerate_triangles, 0, "{name}");
        }
        assert_eq!(GENERATED.len(), 4);
    }

    #[test]
    fn a_generated_mesh_is_the_same_every_time() {
        let (a, b) = (generated("soup_100k"), generated("soup_100k"));
        assert_eq!(a.mesh.positions, b.mesh.positions);
    }
}
