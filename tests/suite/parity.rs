//! The parity suite as tests: shared scenes within the documented
//! thresholds, and the hard cases with what the design promises.

use hybrid::accel::BackendConfig;
use hybrid::parity::{format_tables, hard, run_scene};

use crate::common::scene_or_skip;

#[test]
fn every_backend_agrees_on_the_cornell_boxes_and_the_bunny() {
    for rel in [
        "sky/CBspheres_lambertian.dae",
        "sky/CBspheres.dae",
        "sky/CBbunny.dae",
        "sky/bunny.dae",
    ] {
        let scene = scene_or_skip!(rel);
        let tables = run_scene(&scene, 2_000, 5).expect("backends build");
        println!("{rel}:\n{}", format_tables(&tables));
        for t in &tables {
            for r in &t.rows {
                assert!(
                    r.rays > 0 || t.kind == "shadow",
                    "{rel} {}: no rays",
                    t.kind
                );
                assert!(
                    r.passes(t.minimum),
                    "{rel} {} rays, {}: hit/miss {:.3}%, t {:.3}%, primitive {:.3}%, normals {:.3}% (need {:.1}%); worst: {}",
                    t.kind,
                    r.backend,
                    r.hit_rate() * 100.0,
                    r.t_rate() * 100.0,
                    r.primitive_rate() * 100.0,
                    r.normal_rate() * 100.0,
                    t.minimum * 100.0,
                    r.worst_case
                );
            }
        }
    }
}

#[test]
fn hard_cases_hold_the_design_promises() {
    let scanned = crate::common::load("sky/bunny.dae");
    let (cases, _) = hard::cases(2_000, 3, scanned.as_ref());
    let reports = hard::run_all(&cases).expect("backends build");
    println!("{}", hard::format_table(&reports));
    let mut mt_leaks = 0;
    for r in &reports {
        for (mode, o) in &r.outcomes {
            assert_eq!(o.panics, 0, "{} panicked on {}", mode.label(), r.name);
            assert_eq!(o.nans, 0, "{} returned NaN on {}", mode.label(), r.name);
            if r.watertight_promise && *mode == BackendConfig::NATIVE_WATERTIGHT {
                assert_eq!(
                    o.failures, 0,
                    "watertight mode leaked {} of {} rays on {}",
                    o.failures, o.rays, r.name
                );
            }
            if r.watertight_promise && *mode == BackendConfig::NATIVE {
                mt_leaks += o.failures;
            }
            // The floor-wall junctions of a box seen from inside: with its
            // edge slack Möller-Trumbore does not leak there either (these
            // were the black pixels along the default scene's junctions).
            if r.name.starts_with("open box") && matches!(mode, BackendConfig::Native(_)) {
                assert_eq!(o.failures, 0, "{}: {} {}", r.name, mode.label(), r.failure);
            }
        }
        // Answers every mode must get right: no false hits on degenerate
        // triangles, right distances on tiny/huge triangles and spheres,
        // misses for untraceable rays, no self-intersection with the spawn
        // rule near the origin.
        let strict = r.name.starts_with("zero-area")
            || r.name.starts_with("single triangle")
            || r.name.starts_with("sphere r=")
            || r.name.starts_with("NaN")
            || r.name.starts_with("plate")
            || (r.name.contains("spawn rule"));
        if strict {
            for (mode, o) in &r.outcomes {
                assert_eq!(
                    o.failures,
                    0,
                    "{}: {} {} of {}",
                    r.name,
                    mode.label(),
                    r.failure,
                    o.rays
                );
            }
        }
    }
    // Möller–Trumbore is measured, not hidden: it does leak on shared edges.
    println!("Möller–Trumbore leaks over the watertight cases: {mt_leaks}");
    assert!(
        mt_leaks > 0,
        "Möller–Trumbore never leaked: the edge-aimed rays are not hitting edges"
    );
}
