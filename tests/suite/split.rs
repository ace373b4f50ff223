//! Splitting a frame: cells (`-p`) and sample ranges (`--samples A..B`)
//! rendered as separate processes and combined by `hybrid merge` give the
//! image one process renders, on both backends; overlapping, missing or
//! foreign parts are errors.

use std::path::Path;

use hybrid::render::part::read_part;

use crate::common::{self, fails_in_one_line as fails, succeeds as ok};

const FRAME: [&str; 8] = ["-r", "40", "30", "-s", "8", "-m", "3", "--seed"];

fn render(dir: &Path, accel: &str, extra: &[&str], out: &str) {
    let mut args = vec!["render", "--accel", accel];
    args.extend(FRAME);
    args.push("5");
    args.extend(extra);
    args.extend(["-f", out]);
    ok(&args, dir);
}

#[test]
fn cells_and_sample_ranges_merge_into_the_single_render() {
    let dir = common::scratch("split");
    for accel in ["native", "embree"] {
        render(&dir, accel, &[], &format!("{accel}.png"));
        render(&dir, accel, &[], &format!("{accel}.exr"));
        // Two cells (rows 0..12, 12..30), each in two sample ranges.
        let mut parts = Vec::new();
        for (cell, name) in [
            (["0", "0", "40", "12"], "top"),
            (["0", "12", "40", "18"], "bottom"),
        ] {
            for range in ["0..3", "3..8"] {
                let part = format!("{accel}-{name}-{}.exr", range.replace("..", "-"));
                let mut extra = vec!["-p"];
                extra.extend(cell);
                extra.extend(["--samples", range]);
                render(&dir, accel, &extra, &part);
                parts.push(part);
            }
        }
        let merged_png = format!("{accel}-merged.png");
        let merged_exr = format!("{accel}-merged.exr");
        for out in [&merged_png, &merged_exr] {
            let mut args = vec!["merge", "-f", out.as_str()];
            args.extend(parts.iter().map(String::as_str));
            ok(&args, &dir);
        }
        let bytes = |f: &str| std::fs::read(dir.join(f)).unwrap();
        assert!(
            bytes(&merged_png) == bytes(&format!("{accel}.png")),
            "{accel}: the merged PNG differs from the single render's"
        );
        let (single, merged) = (
            read_part(&dir.join(format!("{accel}.exr"))).unwrap(),
            read_part(&dir.join(&merged_exr)).unwrap(),
        );
        assert_eq!(single.samples, merged.samples);
        let worst = single
            .sums
            .iter()
            .zip(&merged.sums)
            .map(|(a, b)| ((*a - *b).abs() / a.abs().max(glam::DVec3::splat(1e-30))).max_element())
            .fold(0.0f64, f64::max);
        assert!(
            worst <= 1e-6,
            "{accel}: merged EXR sums differ by {worst:e} relative"
        );
        let single_image = image::open(dir.join(format!("{accel}.exr")))
            .unwrap()
            .to_rgb32f();
        let merged_image = image::open(dir.join(&merged_exr)).unwrap().to_rgb32f();
        assert_eq!(
            single_image.as_raw(),
            merged_image.as_raw(),
            "{accel}: radiance differs"
        );
        // A part taken twice, a missing part, and a part of another render.
        let p = |i: usize| parts[i].as_str();
        fails(
            &["merge", "-f", "x.png", p(0), p(0), p(1), p(2), p(3)],
            &dir,
            "overlap",
        );
        fails(
            &["merge", "-f", "x.png", p(0), p(1), p(2)],
            &dir,
            "a part is missing",
        );
        ok(
            &[
                "render",
                "--accel",
                accel,
                "-r",
                "40",
                "30",
                "-s",
                "8",
                "-m",
                "3",
                "--seed",
                "6",
                "-p",
                "0",
                "0",
                "40",
                "12",
                "--samples",
                "0..3",
                "-f",
                "other.exr",
            ],
            &dir,
        );
        fails(
            &["merge", "-f", "x.png", "other.exr", p(1), p(2), p(3)],
            &dir,
            "a different render",
        );
        assert!(!dir.join("x.png").exists(), "a failed merge left an image");
    }
    fails(
        &["render", "-s", "8", "--samples", "3..9", "-f", "y.exr"],
        &dir,
        "--samples 3..9",
    );
    fails(
        &[
            "render",
            "-s",
            "8",
            "-a",
            "4",
            "0.1",
            "--samples",
            "0..4",
            "-f",
            "y.exr",
        ],
        &dir,
        "cannot be split by samples",
    );
}

#[test]
fn bands_of_rows_cover_the_frame() {
    let dir = common::scratch("split-bands");
    render(&dir, "native", &[], "whole.png");
    let parts: Vec<String> = (0..7).map(|k| format!("band-{k}.exr")).collect();
    for (k, part) in parts.iter().enumerate() {
        render(&dir, "native", &["--part", &format!("{k}/7")], part);
    }
    let mut args = vec!["merge", "-f", "bands.png"];
    args.extend(parts.iter().map(String::as_str));
    ok(&args, &dir);
    assert!(
        std::fs::read(dir.join("bands.png")).unwrap()
            == std::fs::read(dir.join("whole.png")).unwrap()
    );
    fails(
        &["render", "-r", "40", "30", "--part", "7/7", "-f", "z.exr"],
        &dir,
        "--part 7/7",
    );
    fails(
        &["render", "-r", "40", "30", "--part", "0/31", "-f", "z.exr"],
        &dir,
        "--part 0/31",
    );
}
