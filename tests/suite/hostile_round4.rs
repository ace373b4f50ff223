//! Hostile input, round 4 (issue 75): a test per class fixed at its root.
//! Each case failed on the binary before the fix: a panic, a late or
//! misleading error, an existing file replaced, a hang through an
//! environment variable, a line over the cap.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::common;
use crate::hostile::{fails, renders, run};

const TINY: &str = include_str!("../data/tiny.dae");

fn tiny(dir: &Path) -> String {
    let path = dir.join("tiny.dae");
    std::fs::write(&path, TINY).unwrap();
    path.to_str().unwrap().to_string()
}

/// Class 2: a range whose width overflows is refused, not a panic.
#[test]
fn a_series_range_as_wide_as_i64_is_one_error() {
    let dir = common::scratch("round4-range");
    let scene = tiny(&dir);
    fails(
        &dir,
        &[
            "series",
            &scene,
            "--vary",
            "s=-9223372036854775808..9223372036854775807",
            "-f",
            "sheet.png",
        ],
        &["--vary", "at most 64 values"],
    );
}

/// Class 6: a negative tolerance is the tolerance's error, not "unknown
/// option '-0'"; `report -t` is capped as `render -t` is; an output that
/// ends with '/' is refused before any work; `merge -f o.jpg` names the
/// output's format before reading a part; a 250-byte output name renders.
#[test]
fn errors_come_early_and_name_what_is_wrong() {
    let dir = common::scratch("round4-early");
    let scene = tiny(&dir);
    fails(
        &dir,
        &["render", &scene, "-a", "4", "-0.1", "-f", "a.png"],
        &["-a 4 -0.1", "TOL"],
    );
    fails(
        &dir,
        &["report", "-t", "100000", "--quick", "--out", "r"],
        &["-t 100000", "256"],
    );
    let line = fails(
        &dir,
        &["render", &scene, "-s", "64", "-f", "o.png/"],
        &["o.png/", "folder"],
    );
    assert!(!line.contains("rendered"), "{line}");
    std::fs::write(dir.join("bad.exr"), b"not an exr").unwrap();
    fails(
        &dir,
        &["merge", "-f", "o.jpg", "bad.exr"],
        &["o.jpg", "unsupported output format"],
    );
    let long = format!("{}.png", "n".repeat(246));
    assert_eq!(long.len(), 250);
    renders(
        &dir,
        &["render", &scene, "--normals", "-r", "8", "6", "-f", &long],
        &long,
        &[],
    );
}

/// Class 3: `merge` never writes over one of its own parts.
#[test]
fn merge_never_replaces_a_part() {
    let dir = common::scratch("round4-merge");
    let scene = tiny(&dir);
    for (k, band) in ["0/2", "1/2"].iter().enumerate() {
        let name = format!("part{k}.exr");
        renders(
            &dir,
            &[
                "render", &scene, "-r", "8", "6", "--part", band, "-f", &name,
            ],
            &name,
            &[],
        );
    }
    let before = std::fs::read(dir.join("part0.exr")).unwrap();
    fails(
        &dir,
        &["merge", "-f", "part0.exr", "part0.exr", "part1.exr"],
        &["part0.exr", "part of this merge"],
    );
    fails(
        &dir,
        &["merge", "-f", "./part0.exr", "part0.exr", "part1.exr"],
        &["part of this merge"],
    );
    assert_eq!(std::fs::read(dir.join("part0.exr")).unwrap(), before);
}

/// Class 4: `HYBRID_TEST_HOLD_WRITE=0` or empty does not hold the write:
/// the render finishes (only `1` holds, tested in `hostile`).
#[test]
fn a_hold_variable_that_says_no_does_not_hold() {
    let dir = common::scratch("round4-hold");
    for value in ["0", ""] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_hybrid"))
            .args(["render", "--normals", "-r", "16", "12", "-f", "held.png"])
            .env("HYBRID_TEST_HOLD_WRITE", value)
            .current_dir(&dir)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("run hybrid");
        let start = Instant::now();
        let status = loop {
            if let Some(status) = child.try_wait().unwrap() {
                break status;
            }
            if start.elapsed() > Duration::from_secs(60) {
                let _ = child.kill();
                panic!("HYBRID_TEST_HOLD_WRITE={value:?} held the write");
            }
            std::thread::sleep(Duration::from_millis(10));
        };
        assert!(status.success(), "{value:?}: {status:?}");
        assert!(dir.join("held.png").is_file());
    }
}

/// Class 6: the cap on an error line is the whole line's, prefix included.
#[test]
fn an_error_line_is_at_most_400_characters() {
    let dir = common::scratch("round4-line");
    let missing = format!("{}.dae", "x".repeat(600));
    let o = run(&dir, &["render", &missing, "-f", "o.png"]);
    assert_eq!(o.code, Some(2), "{}", o.describe());
    let line = o.stderr.trim_end();
    assert_eq!(line.lines().count(), 1, "{}", o.describe());
    assert!(
        line.chars().count() <= 400,
        "{} characters: {line}",
        line.chars().count()
    );
}
