//! The native BVH: structural invariants, SAH quality, and agreement with
//! brute force on random rays.

use hybrid::accel::brute::BruteForce;
use hybrid::accel::native::build::BuildMethod;
use hybrid::accel::native::node::{is_leaf, leaf_count};
use hybrid::accel::native::triangle::TriangleMode;
use hybrid::accel::native::{NativeBvh, NativeOptions};
use hybrid::accel::{Accel, TraceCounters};
use hybrid::geom::Bounds;
use hybrid::geom::{Hit, Ray};
use hybrid::parity::rays;
use hybrid::scene::Scene;

use crate::common::{self, scene_or_skip};

/// Every triangle sits in exactly one leaf of at most `max_leaf`, inside
/// the leaf's box; every child box lies inside its parent's.
fn check_invariants(name: &str, bvh: &NativeBvh, scene: &Scene, max_leaf: usize) -> usize {
    let mut largest = 0;
    let mut seen = vec![0u32; scene.mesh.len()];
    let inside = |inner: &Bounds, outer: &Bounds| {
        inner.min.cmpge(outer.min).all() && inner.max.cmple(outer.max).all()
    };
    let nodes = bvh.triangle_nodes();
    let mut stack = vec![(0usize, None::<Bounds>)];
    while let Some((i, parent)) = stack.pop() {
        for (r, b) in nodes[i].children() {
            if let Some(p) = parent {
                assert!(
                    inside(&b, &p),
                    "{name}: a child of node {i} sticks out of it"
                );
            }
            if is_leaf(r) {
                let prims = bvh.leaf_triangles(r);
                largest = largest.max(prims.len());
                assert!(
                    prims.len() <= max_leaf,
                    "{name}: a leaf holds {} > {max_leaf} ({} blocks)",
                    prims.len(),
                    leaf_count(r)
                );
                for prim in prims {
                    seen[prim as usize] += 1;
                    for corner in scene.mesh.corners(prim as usize) {
                        assert!(
                            inside(
                                &Bounds {
                                    min: corner,
                                    max: corner
                                },
                                &b
                            ),
                            "{name}: triangle {prim} sticks out of its leaf"
                        );
                    }
                }
            } else {
                stack.push((r as usize, Some(b)));
            }
        }
    }
    let missing = seen.iter().filter(|&&n| n == 0).count();
    let doubled = seen.iter().filter(|&&n| n > 1).count();
    assert!(
        missing == 0 && doubled == 0,
        "{name}: {missing} triangles in no leaf, {doubled} in several"
    );
    largest
}

/// By default leaves hold one block of four triangles, and up to two
/// blocks from 2^19 triangles on (large trees, whose nodes leave the
/// cache); the SAH fills the second block where it pays.
#[test]
fn large_meshes_get_leaves_of_two_blocks_by_default() {
    use hybrid::accel::native::LARGE_TREE;
    use hybrid::scene::generate::sphere_cloud;
    // 20480 triangles per sphere: just above and just below the threshold.
    for (count, cap) in [(26, 8), (25, 4)] {
        let scene = sphere_cloud(count, 5, 1);
        let n = scene.mesh.len();
        assert_eq!(n >= LARGE_TREE, cap == 8, "{n} triangles");
        let bvh = NativeBvh::build(&scene, &NativeOptions::default()).expect("builds");
        let largest = check_invariants(&format!("{n} triangles"), &bvh, &scene, cap);
        assert!(
            largest > cap / 2,
            "{n} triangles: no leaf above {}",
            cap / 2
        );
        assert!(bvh.stats().details.contains(&format!("max leaf {cap}")));
    }
}

#[test]
fn every_primitive_sits_in_exactly_one_bounded_leaf() {
    for rel in [
        "sky/CBbunny.dae",
        "meshedit/maxplanck.dae",
        "keenan/banana.dae",
        "basic/plane1024.dae",
    ] {
        let scene = scene_or_skip!(rel);
        for (method, leaf, triangle) in [
            (BuildMethod::Sah, 4, TriangleMode::MollerTrumbore),
            (BuildMethod::Sah, 1, TriangleMode::MollerTrumbore),
            (BuildMethod::Sah, 4, TriangleMode::Watertight),
            (BuildMethod::SahTopDown, 4, TriangleMode::MollerTrumbore),
            (BuildMethod::Median, 8, TriangleMode::MollerTrumbore),
        ] {
            let options = NativeOptions {
                method,
                max_leaf: leaf,
                triangle,
                ..NativeOptions::default()
            };
            let bvh = NativeBvh::build(&scene, &options).expect("builds");
            check_invariants(
                &format!("{rel} {method:?} leaf {leaf} {triangle:?}"),
                &bvh,
                &scene,
                leaf,
            );
        }
    }
}

#[test]
fn sah_costs_less_than_median_split_on_scanned_meshes() {
    for rel in ["sky/CBbunny.dae", "meshedit/maxplanck.dae", "sky/bunny.dae"] {
        let scene = scene_or_skip!(rel);
        let cost = |method| {
            let options = NativeOptions {
                method,
                ..NativeOptions::default()
            };
            NativeBvh::build(&scene, &options)
                .expect("builds")
                .shape()
                .sah_cost
        };
        let (sah, median) = (cost(BuildMethod::Sah), cost(BuildMethod::Median));
        println!(
            "{rel}: SAH cost {sah:.2}, median split {median:.2} ({:.0}% lower)",
            100.0 * (1.0 - sah / median)
        );
        assert!(
            sah < median,
            "{rel}: SAH cost {sah:.2} is not below the median split's {median:.2}"
        );
    }
}

/// Moving subtrees after the top-down build never raises the SAH cost, and
/// in the Cornell box, where the floor's and the light's centroids fall
/// among the bunny's and the top-down splits bury them in its subtrees, it
/// lowers it by a quarter (14.34 -> 10.57 at this commit; the margin
/// asked is half that). The planned grouping then lowers the wide tree's
/// cost on every mesh (maxplanck 12.46 -> 11.78, its binary tree nearly
/// unchanged).
#[test]
fn moving_subtrees_and_planned_grouping_lower_the_sah_cost() {
    for (rel, least_gain) in [
        ("sky/CBbunny.dae", 0.12),
        ("keenan/banana.dae", 0.12),
        ("meshedit/maxplanck.dae", 0.0),
        ("sky/bunny.dae", 0.0),
    ] {
        let scene = scene_or_skip!(rel);
        let shape = |method| {
            let options = NativeOptions {
                method,
                ..NativeOptions::default()
            };
            NativeBvh::build(&scene, &options).expect("builds").shape()
        };
        let (new, old) = (shape(BuildMethod::Sah), shape(BuildMethod::SahTopDown));
        println!(
            "{rel}: SAH cost {:.2} binary, {:.2} wide top-down; {:.2}, {:.2} moved and planned",
            old.sah_cost, old.wide_sah_cost, new.sah_cost, new.wide_sah_cost
        );
        assert!(
            new.sah_cost <= old.sah_cost * (1.0 - least_gain),
            "{rel}: SAH cost {:.2} with subtrees moved against {:.2} top-down",
            new.sah_cost,
            old.sah_cost
        );
        assert!(
            new.wide_sah_cost < old.wide_sah_cost * 0.98,
            "{rel}: wide SAH cost {:.2} moved and planned against {:.2} top-down",
            new.wide_sah_cost,
            old.wide_sah_cost
        );
    }
}

/// Compares two backends hit by hit: same hit/miss, `t` within `rel_t`,
/// same primitive unless the other primitive is hit at the same distance
/// (a tie on a shared edge).
/// Index of `r` inside `rays` (it must be an element of the slice).
fn index_in(rays: &[Ray], r: &Ray) -> usize {
    (r as *const Ray as usize - rays.as_ptr() as usize) / std::mem::size_of::<Ray>()
}

pub fn assert_agree(
    name: &str,
    a: &dyn Fn(&Ray) -> Option<Hit>,
    b: &dyn Fn(&Ray) -> Option<Hit>,
    rays: &[Ray],
    rel_t: f32,
    max_disagree: f64,
) {
    let mut hit_mismatch = 0;
    let mut t_mismatch = 0;
    // Different primitives at the same distance: ties on shared edges,
    // which either answer may win.
    let mut ties = 0;
    let mut worst = String::new();
    for ray in rays {
        match (a(ray), b(ray)) {
            (None, None) => {}
            (Some(x), Some(y)) => {
                if (x.t - y.t).abs() > rel_t * x.t.abs().max(1e-3) {
                    t_mismatch += 1;
                    worst = format!(
                        "ray {ray:?}: t {} vs {} (primitives {} / {})",
                        x.t, y.t, x.prim, y.prim
                    );
                } else if x.prim != y.prim {
                    ties += 1;
                }
            }
            (x, y) => {
                hit_mismatch += 1;
                worst = format!("ray {ray:?}: {x:?} vs {y:?}");
            }
        }
    }
    let rate = (hit_mismatch + t_mismatch) as f64 / rays.len() as f64;
    println!(
        "{name}: {} rays, {hit_mismatch} hit/miss and {t_mismatch} t disagreements, {ties} ties",
        rays.len()
    );
    assert!(
        rate <= max_disagree,
        "{name}: {hit_mismatch} hit/miss and {t_mismatch} t disagreements in {} rays (allowed rate {max_disagree}); e.g. {worst}",
        rays.len()
    );
}

#[test]
fn native_bvh_agrees_with_brute_force_on_random_rays() {
    for rel in [
        "sky/CBspheres_lambertian.dae",
        "sky/CBbunny.dae",
        "keenan/banana.dae",
        "basic/sphere_diffuse.dae",
    ] {
        let scene = scene_or_skip!(rel);
        let brute = BruteForce::build(&scene);
        let rays = rays::random_rays(&scene, 10_000, 7);
        // Brute force answers once; every variant is compared with them.
        let expected: Vec<Option<Hit>> = rays
            .iter()
            .map(|r| brute.closest_hit(r, &mut TraceCounters::default()))
            .collect();
        // Both triangle tests, on the AVX2 (where the CPU has it) and the
        // scalar traversal.
        for (mode, simd) in [
            (TriangleMode::MollerTrumbore, true),
            (TriangleMode::MollerTrumbore, false),
            (TriangleMode::Watertight, true),
            (TriangleMode::Watertight, false),
        ] {
            let native = NativeBvh::build(
                &scene,
                &NativeOptions {
                    triangle: mode,
                    simd,
                    ..NativeOptions::default()
                },
            )
            .expect("builds");
            let a = |r: &Ray| native.closest_hit(r, &mut TraceCounters::default());
            let b = |r: &Ray| expected[index_in(&rays, r)];
            // t within 1e-5 relative; watertight and Möller–Trumbore may
            // decide a few rays exactly on edges differently (<0.1%).
            let allowed = if mode == TriangleMode::MollerTrumbore {
                0.0
            } else {
                0.001
            };
            assert_agree(
                &format!(
                    "{rel} native {mode:?} {} vs brute force",
                    if native.simd() { "AVX2" } else { "scalar" }
                ),
                &a,
                &b,
                &rays,
                1e-5,
                allowed,
            );
            // Occlusion agrees with closest hit.
            let mismatched = rays
                .iter()
                .filter(|r| {
                    native.occluded(r, &mut TraceCounters::default())
                        != native
                            .closest_hit(r, &mut TraceCounters::default())
                            .is_some()
                })
                .count();
            assert_eq!(
                mismatched, 0,
                "{rel}: occluded() and closest_hit() disagree on {mismatched} rays"
            );
        }
    }
}

#[test]
fn the_default_scene_needs_no_shared_files() {
    let scene = common::default_scene();
    let native = NativeBvh::build(&scene, &NativeOptions::default()).expect("builds");
    let brute = BruteForce::build(&scene);
    let rays = rays::random_rays(&scene, 5_000, 3);
    let a = |r: &Ray| native.closest_hit(r, &mut TraceCounters::default());
    let b = |r: &Ray| brute.closest_hit(r, &mut TraceCounters::default());
    assert_agree(
        "default scene native vs brute force",
        &a,
        &b,
        &rays,
        1e-5,
        0.0,
    );
}

#[test]
fn untraceable_rays_are_misses_on_every_backend() {
    let scene = common::default_scene();
    let native = NativeBvh::build(&scene, &NativeOptions::default()).expect("builds");
    let brute = BruteForce::build(&scene);
    let nan = f32::NAN;
    let bad = [
        Ray::new(glam::Vec3::new(nan, 0.0, 0.0), glam::Vec3::Z),
        Ray::new(glam::Vec3::ZERO, glam::Vec3::new(0.0, f32::INFINITY, 0.0)),
        Ray::new(glam::Vec3::new(0.0, 1.0, 3.0), glam::Vec3::ZERO),
        Ray {
            origin: glam::Vec3::new(0.0, 1.0, 3.0),
            dir: -glam::Vec3::Z,
            t_min: 1.0,
            t_max: 0.5,
        },
    ];
    for r in bad {
        assert!(
            native
                .closest_hit(&r, &mut TraceCounters::default())
                .is_none(),
            "native hit {r:?}"
        );
        assert!(
            brute
                .closest_hit(&r, &mut TraceCounters::default())
                .is_none(),
            "brute hit {r:?}"
        );
        assert!(
            !native.occluded(&r, &mut TraceCounters::default()),
            "native occluded {r:?}"
        );
    }
}
