//! The comparison report, quick mode: every section filled from real
//! measurements, `report.json` with the headline fields.

use hybrid::report::{run, ReportOptions};

use crate::common;

#[test]
fn quick_report_writes_every_section_and_the_headline_figures() {
    let Some(scenes_dir) = common::scenes_dir() else {
        return;
    };
    let out = common::scratch("report");
    let options = ReportOptions {
        scenes_dir,
        out_dir: out.clone(),
        quick: true,
        threads: 2,
        tile: Some((64, 48)),
    };
    run(&options, &mut |line| println!("{line}")).expect("the report runs");

    let md = std::fs::read_to_string(out.join("report.md")).expect("report.md");
    for section in [
        "## Build and trace, per scene",
        "## With and without acceleration",
        "## Packets",
        "## Speed against error",
        "## How cost grows with scene size",
        "## Adaptive against uniform sampling at equal time",
        "## Gallery",
    ] {
        assert!(md.contains(section), "report.md lacks '{section}'");
    }
    // The first sentence says which backend is faster here and names the
    // worst case against each Embree; then the answer, one sentence with
    // every Embree present: coherent and incoherent rays, builds and
    // frames.
    let mut paragraphs = md.split("\n\n").skip(1);
    let first = paragraphs.next().expect("a paragraph after the title");
    assert!(
        first.starts_with("**Which is faster here:** native is faster than "),
        "{first}"
    );
    for rival in ["embree3", "embree4"] {
        assert!(first.contains(rival), "{first}");
    }
    assert!(
        first.contains("at worst on") || first.contains("smallest lead"),
        "{first}"
    );
    let answer = paragraphs.next().expect("the answer");
    assert!(answer.starts_with("**In short:** against "), "{answer}");
    for needed in [
        "embree3",
        "embree4",
        "coherent rays",
        "incoherent ones",
        "builds",
        "frames",
    ] {
        assert!(
            answer.contains(needed),
            "the answer lacks '{needed}': {answer}"
        );
    }
    assert_eq!(json_answer(&out), format!("{first}\n\n{}", answer.trim()));
    // The verdict opens the report, before any table: one paragraph per
    // Embree present.
    let opening = &md[..md.find("## Headline").expect("a headline")];
    let paragraph = |rival: &str| {
        opening
            .split("\n\n")
            .find(|p| p.starts_with(&format!("Against {rival},")))
            .unwrap_or_else(|| panic!("no verdict paragraph against {rival}: {opening}"))
    };
    let rivals = ["embree3", "embree4"];
    for rival in rivals {
        assert!(
            paragraph(rival).contains("greater than 1 means native is faster"),
            "{}",
            paragraph(rival)
        );
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap())
            .expect("valid JSON");
    let scenes = json["scenes"].as_array().expect("scenes");
    // Quick covers fewer scenes, with the full report's rays.
    assert_eq!(scenes.len(), hybrid::report::budget::QUICK_SCENES.len());
    assert_eq!(json["settings"]["rays"], 1_000_000);
    // Packets: per scene, camera and light rays, with each ratio measured
    // and Embree's best mode named; each scene's batched tables list native
    // packets and Embree's packets of 8 beside their single rays.
    let targets = json["packets"]["targets"]
        .as_array()
        .expect("packet targets");
    assert_eq!(targets.len(), 2 * scenes.len());
    for t in targets {
        for key in [
            "packets_over_single",
            "packets_over_best_1",
            "packets_over_best_all",
        ] {
            let x = t[key].as_f64().unwrap_or(f64::NAN);
            assert!(x.is_finite() && x > 0.0, "packets {key} = {x}: {t}");
        }
        let best = t["best_embree_1"].as_str().unwrap_or_default();
        assert!(best.starts_with("embree"), "best Embree {best:?}");
        // A batched mode says which hint it ran with (the faster one).
        if best.contains("packet") || best.contains("stream") {
            assert!(
                best.ends_with(", coherent hint") || best.ends_with(", no hint"),
                "best Embree {best:?} names no hint"
            );
        }
    }
    for scene in scenes {
        let rows = scene["batched"].as_array().expect("batched rows");
        assert_eq!(rows.len(), 2, "camera and light");
        for key in [
            "native_mrays",
            "native_packets_mrays",
            "embree3_packet8_mrays",
            "embree3_stream_mrays",
            "embree4_packet8_mrays",
        ] {
            assert!(
                rows[0][key].is_object() || rows[0][key].is_number(),
                "batched lacks {key}: {}",
                rows[0]
            );
        }
        assert!(scene["frame_seconds_without_packets"]["native"]
            .as_f64()
            .is_some());
        // Every backend's frame in the three modes, and the default and
        // the waves on one thread, with where its waves' time went.
        let frames = scene["frames"].as_array().expect("frame rows");
        let backends = scene["frame_seconds"].as_object().expect("frames").len();
        assert!(backends >= 3, "native and both Embrees: {backends}");
        assert_eq!(frames.len(), backends, "{frames:?}");
        for row in frames {
            for key in [
                "default_seconds",
                "alone_seconds",
                "waves_seconds",
                "one_thread_default_seconds",
                "one_thread_waves_seconds",
            ] {
                let x = row[key].as_f64().unwrap_or(f64::NAN);
                assert!(x.is_finite() && x > 0.0, "{key} = {x}: {row}");
            }
            let percent: Vec<f64> = [
                "waves_extension_percent",
                "waves_shadow_percent",
                "waves_paths_percent",
            ]
            .iter()
            .map(|k| row[*k].as_f64().unwrap_or(f64::NAN))
            .collect();
            assert!(percent.iter().all(|p| *p > 0.0), "{row}");
            assert!((percent.iter().sum::<f64>() - 100.0).abs() < 1e-6, "{row}");
            // The stepping's steps, where the wavefront ran, make
            // up the stepping; elsewhere they are empty.
            let steps: Vec<Option<f64>> = [
                "waves_arrive_percent",
                "waves_light_percent",
                "waves_leave_percent",
            ]
            .iter()
            .map(|k| row[*k].as_f64())
            .collect();
            if steps.iter().any(Option::is_some) {
                let steps: Vec<f64> = steps.iter().map(|p| p.unwrap_or(f64::NAN)).collect();
                assert!(steps.iter().all(|p| *p > 0.0), "{row}");
                assert!(
                    (steps.iter().sum::<f64>() - percent[2]).abs() < 1e-6,
                    "{row}"
                );
            }
        }
    }
    let headline = json["headline"].as_array().expect("headline rows");
    let row = |measure: &str| {
        headline
            .iter()
            .find(|r| r["measure"] == measure)
            .unwrap_or_else(|| panic!("headline lacks '{measure}'"))
    };
    let positive = |v: &serde_json::Value, what: &str| {
        let x = v.as_f64().unwrap_or_else(|| panic!("{what} missing"));
        assert!(x.is_finite() && x > 0.0, "{what} = {x}");
        x
    };
    for rival in rivals {
        for (i, s) in scenes.iter().enumerate() {
            let name = s["scene"].as_str().unwrap();
            let column = format!("scene_{i}");
            positive(
                &row(&format!("build, 1 thread, vs {rival}"))[&column],
                &format!("{name} build ratio against {rival}"),
            );
            for t in s["traces"].as_array().expect("traces") {
                let kind = t["kind"].as_str().unwrap();
                let n = positive(&t["native_mrays"], &format!("{name} {kind} native"));
                // The headline compares with Embree called as plain C calls
                // it; the wrapper's own speed is beside it.
                let e = positive(
                    &t[format!("{rival}_plain_c_mrays")],
                    &format!("{name} {kind} {rival} plain C"),
                );
                let wrapper = positive(
                    &t[format!("{rival}_mrays")],
                    &format!("{name} {kind} {rival}"),
                );
                let cost = positive(
                    &t[format!("{rival}_wrapper_over_plain_c")],
                    &format!("{name} {kind} {rival} wrapper/plain C"),
                );
                assert!(
                    (cost - wrapper / e).abs() < 1e-9,
                    "{name} {kind}: {cost} != {wrapper}/{e}"
                );
                let ratio = positive(
                    &row(&format!("{kind} rays, 1 thread, vs {rival}"))[&column],
                    &format!("{name} {kind} headline ratio against {rival}"),
                );
                assert!(
                    (ratio - n / e).abs() < 1e-9 * ratio.max(1.0),
                    "{name} {kind}: headline ratio {ratio} != {n}/{e} ({rival})"
                );
            }
        }
        // The verdict quotes the meshes' camera-ray range from the same
        // figures.
        let camera: Vec<f64> = scenes
            .iter()
            .enumerate()
            .filter(|(_, s)| s["primitives"].as_u64().unwrap() >= 10_000)
            .map(|(i, _)| {
                row(&format!("camera rays, 1 thread, vs {rival}"))[&format!("scene_{i}")]
                    .as_f64()
                    .unwrap()
            })
            .collect();
        let lo = camera.iter().copied().fold(f64::INFINITY, f64::min);
        let verdict = paragraph(rival);
        assert!(
            verdict.contains(&format!("{lo:.2}")),
            "the verdict does not quote the slowest camera ratio {lo:.2} against {rival}: {verdict}"
        );
    }
    let verdict = &opening[opening.find("Against ").expect("a verdict")..];
    assert_eq!(json["verdict"].as_str(), Some(verdict.trim()));
    assert!(
        md.contains("### Embree 4 against Embree 3"),
        "no Embree 3 / Embree 4 table"
    );
    // The samplers: both on every scene, estimator and sample count, each
    // with its relative MSE, time and efficiency; the section says the
    // range of Sobol's gains.
    let samplers = json["samplers"].as_array().expect("sampler rows");
    assert_eq!(samplers.len(), 4 * 2 * 2 * 2, "{samplers:?}");
    for r in samplers {
        for key in ["rel_mse", "seconds", "efficiency"] {
            positive(&r[key], key);
        }
    }
    assert!(md.contains("## Samplers: error at equal samples and at equal time"));
    // Adaptive against uniform: one row per scene, each with a winner.
    let adaptive = json["adaptive_vs_uniform"]
        .as_array()
        .expect("adaptive rows");
    assert_eq!(adaptive.len(), 3);
    for r in adaptive {
        positive(&r["advantage"], "adaptive advantage");
        let scene = r["scene"].as_str().unwrap();
        assert!(
            md.contains(&format!("- `{scene}`: ")),
            "no finding for {scene}"
        );
    }
    // The mesh corpus: every mesh timed, the worst named first.
    assert!(md.contains("## The mesh corpus"));
    let corpus_rows = json["corpus"]["rays"].as_array().expect("corpus rows");
    for name in hybrid::bench::corpus::names() {
        assert!(
            corpus_rows.iter().any(|r| r["mesh"] == name.as_str()),
            "corpus lacks {name}"
        );
    }
    assert!(json["corpus"]["answer"]
        .as_str()
        .is_some_and(|a| a.contains("the worst is")));
    let rows = json["scaling"]["rows"].as_array().unwrap();
    assert!(
        rows.last().unwrap()["triangles"].as_f64().unwrap() >= 1e6 * 0.99,
        "scaling stops below 10^6 triangles"
    );
    for file in [
        "speed_vs_error.svg",
        "scaling_build.svg",
        "scaling_trace.svg",
    ] {
        let svg =
            std::fs::read_to_string(out.join(file)).unwrap_or_else(|_| panic!("{file} missing"));
        assert!(
            svg.contains("<svg") && svg.contains("polyline"),
            "{file} has no lines"
        );
    }
    for file in [
        "gallery_normals.png",
        "gallery_light_samples.png",
        "gallery_bounces.png",
        "gallery_russian_roulette.png",
        "gallery_samples.png",
        "gallery_adaptive.png",
    ] {
        let img = image::open(out.join(file)).unwrap_or_else(|e| panic!("{file}: {e}"));
        assert!(
            img.width() > 100 && img.height() > 50,
            "{file} is {}x{}",
            img.width(),
            img.height()
        );
        // Labelled sheets of --tile 64 48 images: a gap of 8 around each
        // and a caption under it, so the width is a whole number of tiles.
        assert_eq!(
            (img.width() - 8) % (64 + 8),
            0,
            "{file}: {} wide is not a sheet of 64-pixel tiles",
            img.width()
        );
    }
}

/// The report's JSON `answer`.
fn json_answer(out: &std::path::Path) -> String {
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap())
            .expect("valid JSON");
    json["answer"].as_str().expect("an answer").to_string()
}
