//! Hostile and unusual input, one test per class of issue 12's audit. Every
//! case ends in one `hybrid: error:` line, exit code 2 and no file left
//! behind, or in a correct render (with one `hybrid: warning:` line per
//! oddity). The binary runs under an address-space limit, so an allocation
//! sized from the input fails the test instead of the machine, and under a
//! time limit, so a hang fails it too.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::common;

/// The crafted scene every case edits: a floor quad, a sphere and a
/// downward area light.
const TINY: &str = include_str!("../data/tiny.dae");

/// Address space for one run: a render of the tiny scene needs well under
/// this, an allocation sized from a hostile count far more.
const MEMORY_KIB: u64 = 1 << 20;
const TIME_LIMIT: Duration = Duration::from_secs(60);

pub(crate) struct Outcome {
    pub code: Option<i32>,
    pub stdout: String,
    pub stderr: String,
}

impl Outcome {
    pub(crate) fn describe(&self) -> String {
        format!(
            "exit {:?}\nstdout:\n{}\nstderr:\n{}",
            self.code, self.stdout, self.stderr
        )
    }
}

/// Runs `hybrid args` in `dir` under the memory and time limits.
pub(crate) fn run(dir: &Path, args: &[&str]) -> Outcome {
    let mut child = Command::new("sh")
        .arg("-c")
        .arg(format!("ulimit -v {MEMORY_KIB} && exec \"$0\" \"$@\""))
        .arg(env!("CARGO_BIN_EXE_hybrid"))
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run hybrid");
    let start = Instant::now();
    while child.try_wait().expect("wait").is_none() {
        if start.elapsed() > TIME_LIMIT {
            let _ = child.kill();
            panic!("hybrid {args:?} still running after {TIME_LIMIT:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let out = child.wait_with_output().expect("output");
    Outcome {
        code: out.status.code(),
        stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
    }
}

fn files(dir: &Path) -> BTreeSet<PathBuf> {
    std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .collect()
}

/// `args` must fail with exit 2 and one error line mentioning every
/// `needle`, leave no new file in `dir`, and not panic. Returns the line.
pub(crate) fn fails(dir: &Path, args: &[&str], needles: &[&str]) -> String {
    let before = files(dir);
    let o = run(dir, args);
    let what = format!("hybrid {args:?}: {}", o.describe());
    assert_eq!(o.code, Some(2), "{what}");
    let line = o.stderr.trim_end();
    assert_eq!(line.lines().count(), 1, "not one line: {what}");
    assert!(line.starts_with("hybrid: error: "), "{what}");
    assert!(!line.contains("panicked"), "{what}");
    for n in needles {
        assert!(line.contains(n), "the error lacks '{n}': {what}");
    }
    let new: Vec<_> = files(dir).difference(&before).cloned().collect();
    assert!(new.is_empty(), "left behind {new:?}: {what}");
    line.to_string()
}

/// `args` must render `out` with exit 0; every stderr line is a warning,
/// and each of `warnings` appears in one of them. Returns the stderr.
pub(crate) fn renders(dir: &Path, args: &[&str], out: &str, warnings: &[&str]) -> String {
    let _ = std::fs::remove_file(dir.join(out));
    let o = run(dir, args);
    let what = format!("hybrid {args:?}: {}", o.describe());
    assert_eq!(o.code, Some(0), "{what}");
    assert!(dir.join(out).is_file(), "no {out}: {what}");
    for line in o.stderr.lines() {
        assert!(line.starts_with("hybrid: warning: "), "{what}");
    }
    for w in warnings {
        assert!(
            o.stderr.lines().any(|l| l.contains(w)),
            "no warning mentions '{w}': {what}"
        );
    }
    o.stderr
}

/// Writes the tiny scene after `edit` to `dir/name`; returns its path as
/// a string for the command line.
fn scene(dir: &Path, name: &str, edit: impl Fn(&str) -> String) -> String {
    let text = edit(TINY);
    assert_ne!(text, TINY, "the edit of {name} changed nothing");
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path.to_str().unwrap().to_string()
}

/// The tiny scene with its whole visual scene inside one node that scales
/// it by `factor`.
fn scaled(factor: &str) -> impl Fn(&str) -> String + '_ {
    move |t: &str| {
        t.replacen(
            "<visual_scene id=\"scene\">",
            &format!(
                "<visual_scene id=\"scene\"><node id=\"scaler\"><scale>{factor} {factor} {factor}</scale>"
            ),
            1,
        )
        .replacen("</visual_scene>", "</node></visual_scene>", 1)
    }
}

fn pixels(path: &Path) -> Vec<[u8; 3]> {
    let img = image::open(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .to_rgb8();
    img.pixels().map(|p| p.0).collect()
}

/// Fraction of pixels that differ by more than 2 levels in some channel.
fn differing(a: &[[u8; 3]], b: &[[u8; 3]]) -> f64 {
    assert_eq!(a.len(), b.len());
    let n = a
        .iter()
        .zip(b)
        .filter(|(p, q)| p.iter().zip(q.iter()).any(|(x, y)| x.abs_diff(*y) > 2))
        .count();
    n as f64 / a.len() as f64
}

/// Class 1: scenes far beyond Embree's range (±1.8e18) render on both
/// backends, the same as the unscaled scene; vertices that a node transform
/// overflows are an error naming the node.
#[test]
fn huge_scenes_render_alike_on_both_backends() {
    let dir = common::scratch("hostile-huge");
    let plain = scene(&dir, "plain.dae", scaled("1"));
    for mode in [&["--normals"][..], &["-m", "2", "-s", "4"][..]] {
        let render = |file: &str, accel: &str, out: &str| {
            let mut args = vec![
                "render", "-r", "64", "48", "--accel", accel, "-f", out, file,
            ];
            args.extend_from_slice(mode);
            renders(&dir, &args, out, &[]);
            pixels(&dir.join(out))
        };
        let reference = render(&plain, "native", "plain.png");
        for factor in ["1e17", "1e18", "1e30", "1e38"] {
            let file = scene(&dir, &format!("x{factor}.dae"), scaled(factor));
            let native = render(&file, "native", "native.png");
            let embree = render(&file, "embree", "embree.png");
            let d = differing(&native, &embree);
            assert!(
                d <= 0.002,
                "{factor} {mode:?}: native and Embree differ on {d:.4} of pixels"
            );
            let d = differing(&native, &reference);
            assert!(
                d <= 0.002,
                "{factor} {mode:?}: differs from the unscaled scene on {d:.4}"
            );
        }
    }
    let overflowing = scene(&dir, "overflow.dae", |t| {
        t.replacen(
            "<node id=\"floor-node\">",
            "<node id=\"floor-node\"><scale>1e30 1e30 1e30</scale><scale>1e30 1e30 1e30</scale>",
            1,
        )
    });
    fails(
        &dir,
        &["render", "-f", "o.png", &overflowing],
        &[
            "overflow.dae:",
            "<node id=\"floor-node\">",
            "floating-point range",
        ],
    );
}

/// Class 2: nesting deep enough to overflow a recursive parser's stack is
/// one error line at the place it gets too deep.
#[test]
fn deep_nesting_is_an_error_not_a_stack_overflow() {
    let dir = common::scratch("hostile-deep");
    let depth = 20_000;
    let nodes = scene(&dir, "nodes.dae", |t| {
        t.replacen(
            "<node id=\"floor-node\">",
            &format!("{}<node id=\"floor-node\">", "<node>".repeat(depth)),
            1,
        )
        .replacen(
            "<node id=\"ball-node\">",
            &format!("{}<node id=\"ball-node\">", "</node>".repeat(depth)),
            1,
        )
    });
    fails(
        &dir,
        &["render", "-f", "o.png", &nodes],
        &["nodes.dae:", "nested more than"],
    );
    let elements = scene(&dir, "elements.dae", |t| {
        t.replacen(
            "<library_cameras>",
            &format!(
                "<asset>{}{}</asset><library_cameras>",
                "<x>".repeat(depth),
                "</x>".repeat(depth)
            ),
            1,
        )
    });
    fails(
        &dir,
        &["render", "-f", "o.png", &elements],
        &["elements.dae:", "nested more than"],
    );
}

/// Class 3: offsets, counts and strides near 2^64 are errors, checked
/// before any allocation or index (no wrap, no panic, no 4 TB request).
#[test]
fn huge_counts_and_offsets_are_errors() {
    let dir = common::scratch("hostile-counts");
    let cases: &[(&str, &str, &str, &str)] = &[
        (
            "offset.dae",
            "offset=\"0\"/>",
            "offset=\"18446744073709551615\"/>",
            "offset",
        ),
        (
            "accessor.dae",
            "count=\"4\" stride=\"3\"",
            "count=\"2305843009213693952\" stride=\"3\"",
            "count",
        ),
        (
            "wraps.dae",
            "count=\"4\" stride=\"3\"",
            "count=\"4611686018427387904\" stride=\"4\"",
            "count",
        ),
        (
            "array.dae",
            "count=\"12\"",
            "count=\"999999999999\"",
            "999999999999",
        ),
        (
            "polylist.dae",
            "<polylist count=\"1\">",
            "<polylist count=\"18446744073709551615\">",
            "18446744073709551615",
        ),
        (
            "vcount.dae",
            "<vcount>4</vcount>",
            "<vcount>4611686018427387904</vcount>",
            "<vcount>",
        ),
    ];
    for (name, from, to, needle) in cases {
        let file = scene(&dir, name, |t| t.replacen(from, to, 1));
        fails(&dir, &["render", "-f", "o.png", &file], &[name, needle]);
    }
}

/// Class 4: counts far beyond the data present, files over the size limit,
/// and files that are not regular files are refused before they are read
/// whole (a FIFO without a writer would block forever).
#[test]
fn oversized_and_irregular_files_are_refused() {
    let dir = common::scratch("hostile-files");
    let bloated = scene(&dir, "bloated.dae", |t| {
        t.replacen("count=\"12\"", "count=\"400000000\"", 1)
    });
    fails(
        &dir,
        &["render", "-f", "o.png", &bloated],
        &["bloated.dae:", "400000000"],
    );

    let big = scene(&dir, "big.dae", |t| {
        t.replacen(
            "<library_cameras>",
            &format!("<!--{}--><library_cameras>", " ".repeat(3 << 20)),
            1,
        )
    });
    fails(
        &dir,
        &["render", "--max-scene-mb", "2", "-f", "o.png", &big],
        &["big.dae", "--max-scene-mb"],
    );
    renders(
        &dir,
        &[
            "render",
            "--max-scene-mb",
            "4",
            "-r",
            "8",
            "6",
            "-f",
            "o.png",
            &big,
        ],
        "o.png",
        &[],
    );
    std::fs::remove_file(dir.join("o.png")).unwrap();

    fails(
        &dir,
        &["render", "-f", "o.png", "/dev/zero"],
        &["/dev/zero", "not a regular file"],
    );
    fails(
        &dir,
        &["render", "-f", "o.png", "."],
        &["not a regular file"],
    );
    let fifo = dir.join("fifo.dae");
    let made = Command::new("mkfifo").arg(&fifo).status().expect("mkfifo");
    assert!(made.success());
    fails(
        &dir,
        &["render", "-f", "o.png", fifo.to_str().unwrap()],
        &["fifo.dae", "not a regular file"],
    );
}

/// The 1-based line of byte `at` of the tiny scene.
fn line_of(at: usize) -> usize {
    TINY[..at].matches('\n').count() + 1
}

/// Class 12: errors point at the right place.
#[test]
fn errors_name_the_right_place() {
    let dir = common::scratch("hostile-places");
    // A truncated file: the position where the text ends, not 1:1.
    let cut = TINY.find("<node id=\"floor-node\">").unwrap();
    let last_line = line_of(cut);
    std::fs::write(dir.join("cut.dae"), &TINY[..cut]).unwrap();
    fails(
        &dir,
        &["render", "-f", "o.png", "cut.dae"],
        &[&format!("cut.dae:{last_line}:")],
    );

    // Not UTF-8: the line and column of the first bad byte.
    let mut bytes = TINY.as_bytes().to_vec();
    let at = TINY.find("<xfov>").unwrap();
    bytes.insert(at, 0xff);
    let line = line_of(at);
    std::fs::write(dir.join("latin.dae"), bytes).unwrap();
    fails(
        &dir,
        &["render", "-f", "o.png", "latin.dae"],
        &[&format!("latin.dae:{line}:"), "UTF-8"],
    );

    let flat = scene(&dir, "aspect.dae", |t| {
        t.replacen("<aspect_ratio>1.333", "<aspect_ratio>0", 1)
    });
    fails(
        &dir,
        &["render", "-f", "o.png", &flat],
        &["<aspect_ratio>", "aspect.dae:"],
    );

    // A singular light placement is reported at the node, not the library.
    let squashed = scene(&dir, "light.dae", |t| {
        t.replacen(
            "<node id=\"light-node\"><matrix>0.5 0 0 0 0 0 0.5 1.5 0 -1 0 0 0 0 0 1</matrix>",
            "<node id=\"light-node\"><matrix>0 0 0 0 0 0 0 1.5 0 0 0 0 0 0 0 1</matrix>",
            1,
        )
    });
    let node_line = line_of(TINY.find("<node id=\"light-node\">").unwrap());
    fails(
        &dir,
        &["render", "-f", "o.png", &squashed],
        &[&format!("light.dae:{node_line}: <node id=\"light-node\">")],
    );
}

/// Issue 46, class 8: radiance the renderer cannot mean (a negative light
/// or albedo, one near the float range) is an error naming the element,
/// as it is for environment maps; it rendered negative or infinite pixels.
#[test]
fn negative_or_huge_colours_are_errors() {
    let dir = common::scratch("hostile-colours");
    for (name, from, to) in [
        (
            "negative-area.dae",
            "<area><color>4 4 4</color>",
            "<area><color>-4 4 4</color>",
        ),
        (
            "huge-area.dae",
            "<area><color>4 4 4</color>",
            "<area><color>3e38 4 4</color>",
        ),
    ] {
        assert!(TINY.contains(from), "{from}");
        let file = scene(&dir, name, |t| t.replacen(from, to, 1));
        fails(
            &dir,
            &["render", "-f", "o.png", &file],
            &[name, "<color>", "finite, not negative"],
        );
    }
}

/// Classes 13 and 14: oddities the course accepts are loaded, with one
/// warning line each naming what and where.
#[test]
fn oddities_load_with_one_warning_each() {
    let dir = common::scratch("hostile-warnings");
    let render = |file: &str, warnings: &[&str]| {
        renders(
            &dir,
            &["render", "-r", "16", "12", "-f", "o.png", file],
            "o.png",
            warnings,
        )
    };
    let twice = scene(&dir, "ids.dae", |t| {
        t.replacen(
            "</library_geometries>",
            "<geometry id=\"ball\"><extra><technique profile=\"CGL\"><sphere><radius>0.2</radius></sphere></technique></extra></geometry></library_geometries>",
            1,
        )
    });
    // The later 'ball' wins, as in the course, and the warning says so.
    render(&twice, &["ids.dae:", "id 'ball'"]);

    let flat_ball = scene(&dir, "radius.dae", |t| {
        t.replacen("<translate>0 0.4 0</translate>", "<scale>0 0 0</scale>", 1)
    });
    let stderr = render(&flat_ball, &["radius.dae:", "radius 0"]);
    assert_eq!(stderr.lines().count(), 1, "{stderr}");

    let dark = scene(&dir, "dark.dae", |t| {
        t.replacen("<instance_light url=\"#light\"/>", "", 1)
    });
    render(&dark, &["no lights"]);

    let empty = scene(&dir, "empty.dae", |t| {
        t.replacen("<instance_geometry url=\"#quad\"/>", "", 1)
            .replacen("<instance_geometry url=\"#ball\"/>", "", 1)
            .replacen("<instance_light url=\"#light\"/>", "", 1)
    });
    let stderr = render(&empty, &["no geometry", "no lights"]);
    assert_eq!(stderr.lines().count(), 2, "{stderr}");

    // Class 14: a camera matrix with 15 numbers, read as the course does.
    let short = scene(&dir, "matrix15.dae", |t| {
        t.replacen("0 0 1 3 0 0 0 1</matrix>", "0 0 1 3 0 0 0</matrix>", 1)
    });
    render(&short, &["matrix15.dae:", "<matrix>", "15 numbers"]);
}

/// Class 5: only the cell's pixels are allocated, and a frame too large
/// for one run is refused before anything is loaded or rendered.
#[test]
fn huge_resolutions_cost_only_their_cell() {
    let dir = common::scratch("hostile-resolution");
    let args = [
        "render", "-r", "32768", "32768", "-p", "100", "200", "3", "2", "-f", "cell.png",
    ];
    renders(&dir, &args, "cell.png", &[]);
    assert_eq!(
        pixels(&dir.join("cell.png")).len(),
        6,
        "the output holds the 3 x 2 cell"
    );
    fails(
        &dir,
        &["render", "-r", "32768", "32768", "-f", "o.png"],
        &["32768 x 32768", "-p"],
    );
}

/// Class 6: the hard cases on a mesh without shared edges leave its edge
/// case out with a note instead of dividing by zero.
#[test]
fn hard_parity_on_a_mesh_without_shared_edges() {
    let dir = common::scratch("hostile-parity");
    let balls = scene(&dir, "balls.dae", |t| {
        t.replacen("<instance_geometry url=\"#quad\"/>", "", 1).replacen(
            "<extra><technique profile=\"CGL\"><area><color>4 4 4</color></area></technique></extra>",
            "",
            1,
        )
    });
    let o = run(&dir, &["parity", "--hard", "--rays", "100", &balls]);
    assert!(matches!(o.code, Some(0 | 1)), "{}", o.describe());
    assert!(
        o.stdout.contains("note: ") && o.stdout.contains("share an edge"),
        "{}",
        o.describe()
    );
    assert!(!o.stderr.contains("panicked"), "{}", o.describe());
}

/// Classes 7, 10 and 11: bad command lines are one error line before any
/// work: thread counts past the cap, an output folder that is missing or a
/// directory, and everything clap rejects.
#[test]
fn bad_command_lines_fail_at_once_in_one_line() {
    let dir = common::scratch("hostile-cli");
    std::fs::create_dir(dir.join("folder.png")).unwrap();
    let cases: &[(&[&str], &[&str])] = &[
        (&["render", "-t", "2000"], &["-t 2000", "at most"]),
        (
            &["render", "-s", "100000", "-f", "missing/o.png"],
            &["missing/o.png"],
        ),
        (
            &["render", "-s", "100000", "-f", "folder.png"],
            &["folder.png", "directory"],
        ),
        (&["render", "--bogus"], &["--bogus", "--help"]),
        (&["render", "-r", "5"], &["-r <W> <H>"]),
        (
            &["render", "--accel", "optix"],
            &["optix", "native, embree"],
        ),
        (&["render", "-s", "many"], &["many", "-s"]),
        (&["frobnicate"], &["frobnicate"]),
    ];
    for (args, needles) in cases {
        fails(&dir, args, needles);
        let o = run(&dir, args);
        assert!(
            o.stdout.is_empty(),
            "{args:?} did work before failing: {}",
            o.describe()
        );
    }
    let help = run(&dir, &["render", "--help"]);
    assert_eq!(help.code, Some(0));
    assert!(
        help.stdout.lines().count() > 10,
        "help is still the full help"
    );
}

/// Class 8: with adaptive sampling the image and its sample-rate image are
/// written together or not at all.
#[test]
fn adaptive_writes_both_images_or_neither() {
    let dir = common::scratch("hostile-adaptive");
    let args = [
        "render", "-r", "16", "12", "-s", "8", "-a", "4", "0.1", "-f", "o.png",
    ];
    renders(&dir, &args, "o.png", &[]);
    assert!(dir.join("o_rate.png").is_file());
    std::fs::remove_file(dir.join("o.png")).unwrap();
    std::fs::remove_file(dir.join("o_rate.png")).unwrap();
    // The rate image cannot be written (a folder has its name): neither is.
    std::fs::create_dir(dir.join("o_rate.png")).unwrap();
    fails(&dir, &args, &["o_rate.png"]);
}

/// Class 9: a SIGTERM while the image is being written removes the
/// temporary file; the process exits as killed by the signal (128 + 15).
/// `HYBRID_TEST_HOLD_WRITE` stops the render with its temporary file
/// written and not yet renamed, so the signal arrives there on every
/// machine, however fast.
#[test]
fn a_signal_during_the_write_leaves_nothing_behind() {
    let dir = common::scratch("hostile-signal");
    let partial = |dir: &Path| {
        files(dir).into_iter().find(|p| {
            p.to_string_lossy().ends_with(".partial")
                && std::fs::metadata(p).is_ok_and(|m| m.len() > 0)
        })
    };
    let mut child = Command::new(env!("CARGO_BIN_EXE_hybrid"))
        .args(["render", "--normals", "-r", "64", "48", "-f", "held.png"])
        .env("HYBRID_TEST_HOLD_WRITE", "1")
        .current_dir(&dir)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("run hybrid");
    // The file appears and stays; the limit only keeps a broken build from
    // hanging the suite.
    let start = Instant::now();
    while partial(&dir).is_none() {
        if let Some(status) = child.try_wait().unwrap() {
            panic!("the render ended ({status:?}) instead of holding its write");
        }
        assert!(
            start.elapsed() < TIME_LIMIT,
            "no temporary file after {TIME_LIMIT:?}"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    let pid = child.id() as libc::pid_t;
    // SAFETY: kill(2) on our own child's pid has no memory effects.
    assert_eq!(unsafe { libc::kill(pid, libc::SIGTERM) }, 0);
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(128 + libc::SIGTERM), "{status:?}");
    let left: Vec<_> = files(&dir).into_iter().collect();
    assert!(left.is_empty(), "left behind: {left:?}");
}

/// The tiny scene with an emissive panel from the file exactly where the
/// area light's rectangle goes (as in the course's coil scene), emitting
/// `radiance`.
fn with_emissive_panel(radiance: &str) -> impl Fn(&str) -> String + '_ {
    move |t: &str| {
        t.replacen(
            "<library_geometries>",
            &format!(
                r##"<library_effects><effect id="glow"><extra><technique profile="CGL"><emission><radiance>{radiance}</radiance></emission></technique></extra></effect></library_effects>
  <library_materials><material id="glow-material"><instance_effect url="#glow"/></material></library_materials>
  <library_geometries>
    <geometry id="panel"><mesh>
      <source id="panel-pos">
        <float_array id="panel-pos-array" count="12">-0.25 1.5 -0.5  0.25 1.5 -0.5  0.25 1.5 0.5  -0.25 1.5 0.5</float_array>
        <technique_common><accessor source="#panel-pos-array" count="4" stride="3"/></technique_common>
      </source>
      <vertices id="panel-vtx"><input semantic="POSITION" source="#panel-pos"/></vertices>
      <polylist count="1" material="glow"><input semantic="VERTEX" source="#panel-vtx" offset="0"/><vcount>4</vcount><p>0 1 2 3</p></polylist>
    </mesh></geometry>"##
            ),
            1,
        )
        .replacen(
            "<node id=\"ball-node\">",
            r##"<node id="panel-node"><instance_geometry url="#panel"><bind_material><technique_common><instance_material symbol="glow" target="#glow-material"/></technique_common></bind_material></instance_geometry></node>
      <node id="ball-node">"##,
            1,
        )
    }
}

/// Class 15: an emissive panel in the file where an area light's rectangle
/// would go is not doubled by the rectangle (the two surfaces would tie,
/// and the backends break ties differently); the panel is the light, said
/// in one warning, and both backends render the same image.
#[test]
fn an_area_light_on_emissive_geometry_is_not_doubled() {
    let dir = common::scratch("hostile-coplanar");
    let file = scene(&dir, "panel.dae", with_emissive_panel("3 3 3"));
    // Hemisphere sampling: direct light is whatever the rays hit.
    let render = |accel: &str, out: &str| {
        let args = [
            "render", "-r", "64", "48", "-s", "16", "-H", "--accel", accel, "-f", out, &file,
        ];
        let stderr = renders(&dir, &args, out, &["panel.dae", "emissive triangles"]);
        assert_eq!(stderr.lines().count(), 1, "{stderr}");
        pixels(&dir.join(out))
    };
    let native = render("native", "native.png");
    let embree = render("embree", "embree.png");
    let d = differing(&native, &embree);
    assert!(d <= 0.002, "native and Embree differ on {d:.4} of pixels");
}
