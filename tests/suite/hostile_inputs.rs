//! Hostile input on the paths besides the scene file (issue 29's audit):
//! environment maps, camera files, merge parts, series values, numbers on
//! the command line, and output names. Every case ends in one short
//! `hybrid: error:` line, exit code 2, bounded time and memory (the
//! harness of `hostile.rs` runs the binary under both limits), and leaves
//! every existing file as it was.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use crate::common;
use crate::hostile::{fails, run};

/// The longest error line a case may print.
const SHORT_LINE: usize = 500;

/// A FIFO at `dir/name`, which a reader that opens it would block on.
fn fifo(dir: &Path, name: &str) -> String {
    let path = dir.join(name);
    let _ = std::fs::remove_file(&path);
    let status = Command::new("mkfifo").arg(&path).status().expect("mkfifo");
    assert!(status.success(), "mkfifo {}", path.display());
    path.to_str().unwrap().to_string()
}

/// A camera file of the default scene, as `--save-camera` writes it.
fn saved_camera(dir: &Path) -> String {
    let path = dir.join("saved.cam");
    let o = run(
        dir,
        &[
            "render",
            "-r",
            "8 6",
            "--save-camera",
            "saved.cam",
            "-f",
            "saved.png",
        ],
    );
    assert_eq!(o.code, Some(2), "-r takes two numbers: {}", o.stderr);
    let o = run(
        dir,
        &[
            "render",
            "-r",
            "8",
            "6",
            "--save-camera",
            "saved.cam",
            "-f",
            "saved.png",
        ],
    );
    assert_eq!(o.code, Some(0), "{}", o.stderr);
    std::fs::read_to_string(&path).expect("camera file")
}

#[test]
fn special_files_as_map_camera_or_part_are_refused_at_once() {
    let dir = common::scratch("hostile-fifo");
    let map = fifo(&dir, "map.exr");
    let line = fails(
        &dir,
        &["render", "-r", "8", "6", "-e", &map, "-f", "a.png"],
        &["map.exr", "not a regular file"],
    );
    println!("{line}");
    let cam = fifo(&dir, "camera.txt");
    fails(
        &dir,
        &["render", "-r", "8", "6", "-c", &cam, "-f", "b.png"],
        &["camera.txt", "not a regular file"],
    );
    fails(
        &dir,
        &["render", "-r", "8", "6", "-c", "/dev/zero", "-f", "c.png"],
        &["/dev/zero", "not a regular file"],
    );
    let part = fifo(&dir, "part.exr");
    fails(
        &dir,
        &["merge", "-f", "d.png", &part],
        &["part.exr", "not a regular file"],
    );
}

#[test]
fn camera_files_are_read_within_a_cap_and_quoted_in_short() {
    let dir = common::scratch("hostile-camera");
    let camera = saved_camera(&dir);
    // A valid camera padded with blanks past the cap.
    let padded = dir.join("padded.cam");
    std::fs::write(&padded, format!("{camera}{}", " ".repeat(1 << 20))).unwrap();
    fails(
        &dir,
        &["render", "-r", "8", "6", "-c", "padded.cam", "-f", "a.png"],
        &["padded.cam", "bytes"],
    );
    // A token of 40 KB: the error quotes a prefix.
    let token = dir.join("token.cam");
    std::fs::write(&token, format!("{}\n{camera}", "7".repeat(40_000))).unwrap();
    let line = fails(
        &dir,
        &["render", "-r", "8", "6", "-c", "token.cam", "-f", "b.png"],
        &["token.cam", "(40000 bytes)"],
    );
    assert!(line.len() < SHORT_LINE, "{} characters: {line}", line.len());
    // NULs are not text.
    std::fs::write(dir.join("nul.cam"), vec![0u8; 4096]).unwrap();
    let line = fails(
        &dir,
        &["render", "-r", "8", "6", "-c", "nul.cam", "-f", "c.png"],
        &["nul.cam"],
    );
    assert!(line.len() < SHORT_LINE, "{line}");
}

#[test]
fn a_mirrored_camera_matrix_is_not_a_rotation() {
    let dir = common::scratch("hostile-mirror");
    let camera = saved_camera(&dir);
    // Line 4 holds the 3x3 camera-to-world matrix, row-major: negating its
    // first column mirrors the image while keeping the columns orthonormal.
    let mut lines: Vec<String> = camera.lines().map(str::to_string).collect();
    let mut m: Vec<f64> = lines[3]
        .split_whitespace()
        .map(|w| w.parse().unwrap())
        .collect();
    assert_eq!(m.len(), 9, "{}", lines[3]);
    for row in 0..3 {
        m[row * 3] = -m[row * 3];
    }
    lines[3] = m
        .iter()
        .map(|v| format!("{v}"))
        .collect::<Vec<_>>()
        .join(" ");
    std::fs::write(dir.join("mirror.cam"), lines.join("\n") + "\n").unwrap();
    fails(
        &dir,
        &["render", "-r", "8", "6", "-c", "mirror.cam", "-f", "a.png"],
        &["mirror.cam:4", "right-handed"],
    );
}

#[test]
fn a_huge_number_in_a_scene_is_quoted_in_short() {
    let dir = common::scratch("hostile-token");
    let scene = include_str!("../data/tiny.dae");
    let at = scene.find("<float_array").expect("an array");
    let close = at + scene[at..].find('>').unwrap() + 1;
    let edited = format!(
        "{}{}x {}",
        &scene[..close],
        "1".repeat(1 << 20),
        &scene[close..]
    );
    std::fs::write(dir.join("token.dae"), edited).unwrap();
    let line = fails(
        &dir,
        &["render", "token.dae", "-r", "8", "6", "-f", "a.png"],
        &["token.dae", "bytes)"],
    );
    assert!(line.len() < SHORT_LINE, "{} characters", line.len());
}

#[test]
fn numbers_at_their_limits_neither_wrap_nor_hang() {
    let dir = common::scratch("hostile-numbers");
    std::fs::write(dir.join("tiny.dae"), include_str!("../data/tiny.dae")).unwrap();
    // A limit of 2^44 MiB saturates instead of wrapping to nothing.
    let o = run(
        &dir,
        &[
            "render",
            "tiny.dae",
            "--max-scene-mb",
            "17592186044416",
            "-r",
            "4",
            "3",
            "-f",
            "a.png",
        ],
    );
    assert_eq!(o.code, Some(0), "{}", o.stderr);
    // The last samples of a 2^32 - 1 sample render: the batch end saturates.
    let o = run(
        &dir,
        &[
            "render",
            "tiny.dae",
            "-r",
            "1",
            "1",
            "-s",
            "4294967295",
            "--samples",
            "4294967290..4294967295",
            "-f",
            "b.exr",
        ],
    );
    assert_eq!(o.code, Some(0), "{}", o.stderr);
    assert!(
        o.stdout.contains("samples 4294967290..4294967295"),
        "{}",
        o.stdout
    );
    // Far into the range costs what its own samples cost.
    let start = std::time::Instant::now();
    let o = run(
        &dir,
        &[
            "render",
            "tiny.dae",
            "-r",
            "1",
            "1",
            "-s",
            "200000000",
            "--samples",
            "100000000..100000001",
            "-f",
            "c.exr",
        ],
    );
    assert_eq!(o.code, Some(0), "{}", o.stderr);
    println!("one sample far into the range: {:?}", start.elapsed());
}

#[test]
fn series_values_and_columns_are_bounded() {
    let dir = common::scratch("hostile-series");
    let list: Vec<String> = (1..=65).map(|v| v.to_string()).collect();
    let vary = format!("s={}", list.join(","));
    fails(
        &dir,
        &["series", "--vary", &vary, "-r", "4", "3"],
        &["65 values", "at most 64"],
    );
    fails(
        &dir,
        &[
            "series",
            "--vary",
            "s=1,2",
            "--columns",
            "0",
            "-r",
            "4",
            "3",
        ],
        &["--columns"],
    );
}

#[test]
fn outputs_never_replace_links_or_devices() {
    let dir = common::scratch("hostile-output");
    let target = dir.join("target.png");
    std::fs::write(&target, b"keep me").unwrap();
    let link = dir.join("link.png");
    let _ = std::fs::remove_file(&link);
    std::os::unix::fs::symlink(&target, &link).unwrap();
    fails(
        &dir,
        &["render", "-r", "4", "3", "-f", "link.png"],
        &["link.png", "symbolic link"],
    );
    assert!(std::fs::symlink_metadata(&link)
        .unwrap()
        .file_type()
        .is_symlink());
    assert_eq!(std::fs::read(&target).unwrap(), b"keep me");
    let fifo = fifo(&dir, "fifo.png");
    fails(
        &dir,
        &["render", "-r", "4", "3", "-f", &fifo],
        &["fifo.png", "not a regular file"],
    );
    assert!(!std::fs::symlink_metadata(&fifo).unwrap().is_file());
}

#[test]
fn a_full_stderr_is_exit_2_not_a_panic() {
    let dir = common::scratch("hostile-stderr");
    let full = std::fs::OpenOptions::new()
        .write(true)
        .open("/dev/full")
        .expect("/dev/full");
    let status = Command::new(env!("CARGO_BIN_EXE_hybrid"))
        .args(["render", "-r", "0", "0"])
        .current_dir(&dir)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::from(full))
        .status()
        .expect("runs");
    assert_eq!(status.code(), Some(2), "{status}");
    let _: PathBuf = dir;
}

/// A triangle file (docs/rays.md) whose header promises `count` records,
/// holding `floats`.
fn triangle_file(count: u64, floats: &[f32]) -> Vec<u8> {
    let mut bytes = b"HYBTRIS1".to_vec();
    bytes.extend_from_slice(&9u32.to_le_bytes());
    bytes.extend_from_slice(&0u32.to_le_bytes());
    bytes.extend_from_slice(&count.to_le_bytes());
    for x in floats {
        bytes.extend_from_slice(&x.to_le_bytes());
    }
    bytes
}

/// A closest-hit ray file (docs/rays.md) of `rays`.
fn ray_file(rays: &[[f32; 8]]) -> Vec<u8> {
    let mut bytes = b"HYBRAYS1".to_vec();
    bytes.extend_from_slice(&0u32.to_le_bytes());
    bytes.extend_from_slice(&0u32.to_le_bytes());
    bytes.extend_from_slice(&(rays.len() as u64).to_le_bytes());
    for x in rays.as_flattened() {
        bytes.extend_from_slice(&x.to_le_bytes());
    }
    bytes
}

#[test]
fn ray_files_that_break_their_promise_are_refused_in_one_line() {
    let dir = common::scratch("hostile-rays");
    let set = dir.join("set");
    std::fs::create_dir_all(&set).unwrap();
    // No triangles file at all.
    fails(&dir, &["bench", "set"], &["set/triangles.bin"]);
    // A triangle file whose header promises more than it holds.
    let tris = triangle_file(u64::MAX / 2, &[0.0; 9]);
    std::fs::write(set.join("triangles.bin"), &tris).unwrap();
    fails(&dir, &["bench", "set"], &["triangles.bin", "promises"]);
    // A FIFO where the triangles should be.
    std::fs::remove_file(set.join("triangles.bin")).unwrap();
    fifo(&set, "triangles.bin");
    fails(&dir, &["bench", "set"], &["triangles.bin"]);
    std::fs::remove_file(set.join("triangles.bin")).unwrap();
    // One good triangle, then a ray file of the wrong kind.
    let one = triangle_file(1, &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
    std::fs::write(set.join("triangles.bin"), &one).unwrap();
    std::fs::write(set.join("camera.rays"), b"not a ray file at all").unwrap();
    fails(&dir, &["bench", "set"], &["camera.rays", "not a HYBRAYS1"]);
    std::fs::remove_file(set.join("camera.rays")).unwrap();
    fails(&dir, &["bench", "set"], &["no ray files"]);
    fails(&dir, &["bench", "set", "--within", "0"], &["--within 0"]);
    fails(
        &dir,
        &["bench", "set", "--min-rounds", "9", "--max-rounds", "5"],
        &["--min-rounds 9"],
    );
    // Rays Embree would assert on, and a set of none: one line naming the
    // file and the ray, before any timing.
    let good = [0.2f32, 0.2, -1.0, 0.0, 0.0, 1.0, 0.0, f32::INFINITY];
    let cases: [(usize, f32, &str); 7] = [
        (0, f32::NAN, "origin"),
        (1, 1e30, "origin"),
        (4, f32::INFINITY, "direction"),
        (6, -1.0, "t from"),
        (6, f32::NAN, "t from"),
        (7, -2.0, "t from"),
        (5, 0.0, "direction"),
    ];
    for (field, value, why) in cases {
        let mut bad = good;
        bad[field] = value;
        if why == "direction" && value == 0.0 {
            bad[3..6].fill(0.0);
        }
        std::fs::write(set.join("camera.rays"), ray_file(&[good, bad])).unwrap();
        fails(&dir, &["bench", "set"], &["camera.rays", "ray 1:", why]);
    }
    std::fs::write(set.join("camera.rays"), ray_file(&[])).unwrap();
    fails(&dir, &["bench", "set"], &["camera.rays", "no rays"]);
    std::fs::remove_file(set.join("camera.rays")).unwrap();
    // A scene of spheres alone has nothing the files can hold.
    if let Some(spheres) = common::shared("basic/sphere_diffuse.dae") {
        let spheres = spheres.to_string_lossy().into_owned();
        fails(
            &dir,
            &["rays", "export", "out", &spheres],
            &["no triangles"],
        );
        assert!(!dir.join("out").exists(), "the export made its folder");
    }
    // An export of a scene that does not load writes nothing.
    fails(
        &dir,
        &["rays", "export", "out", "missing.dae"],
        &["missing.dae"],
    );
    assert!(!dir.join("out").exists(), "the export made its folder");
}

#[test]
fn an_exported_set_replays_with_the_same_hits_on_every_backend() {
    let dir = common::scratch("rays-export");
    let o = run(&dir, &["rays", "export", "set", "--rays", "4000"]);
    assert_eq!(o.code, Some(0), "{}", o.describe());
    for kind in [
        "camera",
        "camera_rows",
        "incoherent",
        "shadow",
        "bounce",
        "light",
        "wave_bounce",
        "wave_shadow",
    ] {
        let bytes = std::fs::read(dir.join("set").join(format!("{kind}.rays"))).unwrap();
        assert_eq!(&bytes[..8], b"HYBRAYS1", "{kind}");
        let count = u64::from_le_bytes(bytes[16..24].try_into().unwrap());
        assert_eq!(bytes.len() as u64, 24 + 32 * count, "{kind}");
        // A render's waves give at most the rays asked for.
        assert!((1..=4000).contains(&count), "{kind}: {count} rays");
    }
    let o = run(
        &dir,
        &["bench", "set", "--max-rounds", "3", "--min-rounds", "3"],
    );
    assert_eq!(o.code, Some(0), "{}", o.describe());
    for kind in [
        "| camera |",
        "| camera rows |",
        "| light |",
        "| wave bounce |",
        "| wave shadow |",
        "native / ",
    ] {
        assert!(
            o.stdout.contains(kind),
            "bench lacks '{kind}': {}",
            o.stdout
        );
    }
}

/// Issue 73: the corpus export writes one replayable folder per mesh,
/// every shared mesh and the generated ones, and `bench` on it answers
/// with the worst mesh first and times every mesh.
#[test]
fn the_corpus_is_every_mesh_and_its_bench_names_the_worst_first() {
    let Some(scenes) = common::scenes_dir() else {
        return;
    };
    let scenes = scenes.to_string_lossy().into_owned();
    let dir = common::scratch("corpus");
    let args = ["rays", "corpus", "c", "--rays", "3000", "--scenes", &scenes];
    common::succeeds(&args, &dir);
    let names = hybrid::bench::corpus::names();
    assert_eq!(names.len(), 10);
    for name in &names {
        let folder = dir.join("c").join(name);
        assert!(folder.join("triangles.bin").is_file(), "{name}");
        assert!(folder.join("camera.rays").is_file(), "{name}");
        assert!(folder.join("wave_bounce.rays").is_file(), "{name}");
    }
    let o = common::hybrid(
        &["bench", "c", "--min-rounds", "3", "--max-rounds", "3"],
        &dir,
    );
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let first = out.lines().find(|l| l.starts_with("**")).unwrap_or("");
    assert!(first.contains("the worst is"), "no answer first: {out}");
    for name in &names {
        assert!(
            out.contains(&format!("| {name} |")),
            "{name} missing: {out}"
        );
    }
    for needle in ["worst mesh", "native / best Embree", "ms |"] {
        assert!(out.contains(needle), "lacks '{needle}': {out}");
    }
    // A folder holding anything else is refused, and left as it was.
    std::fs::write(dir.join("c").join("notes.txt"), "mine").unwrap();
    fails(&dir, &args, &["notes.txt", "no corpus export writes"]);
    assert_eq!(
        std::fs::read(dir.join("c").join("notes.txt")).unwrap(),
        b"mine"
    );
    // A replay of a corpus in batched modes is refused in one line.
    std::fs::remove_file(dir.join("c").join("notes.txt")).unwrap();
    fails(&dir, &["bench", "c", "--batched"], &["--batched", "corpus"]);
}

/// Issue 46, class 7: a library override naming the other Embree major
/// version is refused in one line (it segfaulted after loading), and so is
/// a library that is no Embree at all; nothing is written.
#[test]
fn an_embree_override_of_the_wrong_version_is_refused() {
    let dir = common::scratch("hostile-embree-override");
    for (variable, library, accel, expected) in [
        (
            "HYBRID_EMBREE4",
            "libembree3.so.3",
            "embree4",
            "is not Embree 4",
        ),
        ("HYBRID_EMBREE3", "libc.so.6", "embree3", "is not Embree 3"),
    ] {
        let o = Command::new(env!("CARGO_BIN_EXE_hybrid"))
            .args(["render", "--accel", accel, "-r", "8", "6", "-f", "x.png"])
            .env(variable, library)
            .current_dir(&dir)
            .output()
            .expect("run hybrid");
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{variable}={library}: {stderr}");
        assert_eq!(stderr.lines().count(), 1, "{stderr}");
        assert!(stderr.contains(expected), "{stderr}");
        assert!(!dir.join("x.png").exists());
    }
}

/// Issue 46, class 4: arguments that are not UTF-8 (a Latin-1 file name)
/// are file names like any other: `render` and `series` take such a
/// scene, and a mistyped command line quoting one is one error line
/// (the error path panicked on `std::env::args`).
#[test]
fn arguments_that_are_not_utf8_are_file_names_not_panics() {
    use std::ffi::OsStr;
    use std::os::unix::ffi::OsStrExt;
    let dir = common::scratch("hostile-latin1");
    let name = OsStr::from_bytes(b"sc\xe9ne.dae");
    std::fs::copy(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/tiny.dae"),
        dir.join(name),
    )
    .unwrap();
    let hybrid = |args: &[&OsStr]| {
        Command::new(env!("CARGO_BIN_EXE_hybrid"))
            .args(args)
            .current_dir(&dir)
            .stdin(Stdio::null())
            .output()
            .expect("run hybrid")
    };
    let os = |s: &'static str| OsStr::new(s);
    let o = hybrid(&[
        os("render"),
        name,
        os("-r"),
        os("8"),
        os("6"),
        os("-f"),
        os("a.png"),
    ]);
    assert_eq!(o.status.code(), Some(0), "{o:?}");
    let o = hybrid(&[
        os("series"),
        os("--vary"),
        os("s=1,2"),
        os("-r"),
        os("8"),
        os("6"),
        name,
        os("-f"),
        os("sheet.png"),
    ]);
    assert_eq!(o.status.code(), Some(0), "{o:?}");
    assert!(dir.join("sheet.png").is_file());
    let o = hybrid(&[os("rende"), name]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(stderr.starts_with("hybrid: error:"), "{stderr}");
}

/// Issue 46, class 9: `report` checks every scene it will read before any
/// work: a `--scenes` folder without one of them is one error line naming
/// it, and the new `--out` folder is not made.
#[test]
fn the_report_finds_a_missing_scene_before_it_measures() {
    let Some(shared) = common::scenes_dir() else {
        return;
    };
    let dir = common::scratch("hostile-report-scenes");
    let partial = dir.join("scenes");
    std::fs::create_dir_all(&partial).unwrap();
    // Every folder of the shared scenes but keenan/.
    for sub in ["sky", "meshedit", "basic"] {
        std::os::unix::fs::symlink(shared.join(sub), partial.join(sub)).unwrap();
    }
    let empty = dir.join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    for scenes in [&partial, &empty] {
        let scenes = scenes.to_string_lossy().into_owned();
        fails(
            &dir,
            &["report", "--quick", "--scenes", &scenes, "--out", "new"],
            &["keenan/banana.dae"],
        );
        assert!(!dir.join("new").exists(), "the report made its folder");
    }
}

/// Issue 46, class 6: no output of a run may name one of its inputs or
/// another output, and `--save-camera` follows `-f`'s rules: the scene,
/// the map and a FIFO are left as they were, in one error line each.
#[test]
fn outputs_never_replace_inputs_or_block() {
    let dir = common::scratch("hostile-outputs");
    let tiny = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/tiny.dae");
    std::fs::copy(&tiny, dir.join("t.dae")).unwrap();
    let o = run(&dir, &["render", "t.dae", "-r", "8", "6", "-f", "map.exr"]);
    assert_eq!(o.code, Some(0), "{}", o.describe());
    let (scene, map) = (
        std::fs::read(dir.join("t.dae")).unwrap(),
        std::fs::read(dir.join("map.exr")).unwrap(),
    );
    let f = fifo(&dir, "pipe");
    for (args, needle) in [
        (&["--save-camera", "t.dae"][..], "names the scene"),
        (&["-e", "map.exr", "-f", "map.exr"][..], "names -e"),
        (&["--save-camera", &f][..], "FIFO"),
        (&["--save-camera", "o.png", "-f", "o.png"][..], "is also -f"),
    ] {
        let mut all = vec!["render", "t.dae", "-r", "8", "6"];
        all.extend_from_slice(args);
        if !args.contains(&"-f") {
            all.extend_from_slice(&["-f", "o.png"]);
        }
        fails(&dir, &all, &[needle]);
    }
    assert_eq!(std::fs::read(dir.join("t.dae")).unwrap(), scene);
    assert_eq!(std::fs::read(dir.join("map.exr")).unwrap(), map);
}

/// Issue 46, class 2: counts the options allow but the machine cannot
/// hold are refused before any work with the memory they would take
/// (under the suite's 1 GiB address-space cap: the largest `rays export`
/// aborted on allocation, and `parity --rays` had no bound).
#[test]
fn counts_beyond_the_memory_are_refused_before_any_work() {
    let dir = common::scratch("hostile-counts");
    let tiny = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/tiny.dae");
    let tiny = tiny.to_string_lossy().into_owned();
    for args in [
        &["rays", "export", "out", &tiny, "--rays", "67108864"][..],
        &["parity", "--rays", "30000000", &tiny][..],
        &["parity", "--hard", "--rays", "4000000000"][..],
    ] {
        fails(&dir, args, &["--rays", "GiB of memory"]);
    }
    assert!(!dir.join("out").exists(), "the export made its folder");
}

/// Issue 46, class 5: `series` checks every file it will write before any
/// render, and never removes a file it did not create: an existing
/// `SHEET.csv` directory, a value given twice and two scenes of one file
/// name are errors, and the user's files are left as they were.
#[test]
fn a_series_never_deletes_the_users_files() {
    let dir = common::scratch("hostile-series-files");
    let tiny = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/tiny.dae");
    for sub in ["a", "b"] {
        std::fs::create_dir_all(dir.join(sub)).unwrap();
        std::fs::copy(&tiny, dir.join(sub).join("t.dae")).unwrap();
    }
    // The user's own files under the names the series would write.
    std::fs::write(dir.join("sheet.png"), b"the user's sheet").unwrap();
    std::fs::write(dir.join("sheet_1.png"), b"the user's tile").unwrap();
    std::fs::create_dir_all(dir.join("sheet.csv")).unwrap();
    let small = ["-r", "8", "6", "a/t.dae", "-f", "sheet.png"];
    let with = |vary: &'static str| {
        let mut args = vec!["series", "--vary", vary];
        args.extend_from_slice(&small);
        args
    };
    fails(&dir, &with("s=1,2"), &["sheet.csv", "directory"]);
    std::fs::remove_dir(dir.join("sheet.csv")).unwrap();
    fails(&dir, &with("s=1,1"), &["two of the series' files"]);
    let scenes = [
        "series",
        "--vary",
        "scene=a/t.dae,b/t.dae",
        "-r",
        "8",
        "6",
        "-f",
        "sheet.png",
    ];
    fails(&dir, &scenes, &["two of the series' files"]);
    assert_eq!(
        std::fs::read(dir.join("sheet.png")).unwrap(),
        b"the user's sheet"
    );
    assert_eq!(
        std::fs::read(dir.join("sheet_1.png")).unwrap(),
        b"the user's tile"
    );
}

/// Issue 46, class 3: an export is written whole beside its folder and
/// then takes its place: a re-export replaces every file of the old one
/// (never new triangles beside old rays), a folder holding anything an
/// export does not write is refused untouched, and no hidden partial
/// folder is left either way.
#[test]
fn an_export_replaces_an_older_one_whole_or_not_at_all() {
    let dir = common::scratch("hostile-export-atomic");
    let tiny = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/tiny.dae");
    let tiny = tiny.to_string_lossy().into_owned();
    let count = |kind: &str| {
        let bytes = std::fs::read(dir.join("set").join(format!("{kind}.rays"))).unwrap();
        u64::from_le_bytes(bytes[16..24].try_into().unwrap())
    };
    for rays in ["3000", "1000"] {
        let o = run(&dir, &["rays", "export", "set", &tiny, "--rays", rays]);
        assert_eq!(o.code, Some(0), "{}", o.describe());
        assert_eq!(count("camera"), rays.parse::<u64>().unwrap());
        assert_eq!(count("incoherent"), rays.parse::<u64>().unwrap());
    }
    std::fs::write(dir.join("set").join("notes.txt"), b"mine").unwrap();
    fails(
        &dir,
        &["rays", "export", "set", &tiny, "--rays", "2000"],
        &["notes.txt", "no export writes"],
    );
    assert_eq!(count("camera"), 1000);
    assert_eq!(
        std::fs::read(dir.join("set").join("notes.txt")).unwrap(),
        b"mine"
    );
    let hidden: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().starts_with('.'))
        .map(|e| e.file_name())
        .collect();
    assert!(hidden.is_empty(), "left behind: {hidden:?}");
}

/// Issue 46: the check before any work, which the `cli` fuzz target calls,
/// reaches a series' output plan and an export's folder. It refuses what
/// `series` and `rays export` refuse before their first render or ray,
/// accepts their good command lines, and writes nothing either way.
#[test]
fn the_command_line_check_plans_series_and_export_outputs() {
    use hybrid::cli::check_command_line;
    let dir = common::scratch("hostile-check-outputs");
    let tiny = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/tiny.dae");
    let path = |p: &Path| p.to_string_lossy().into_owned();
    let sheet = path(&dir.join("sheet.png"));
    let series = |vary: &str| -> Vec<String> {
        [
            "series",
            "--vary",
            vary,
            "-r",
            "8",
            "6",
            &path(&tiny),
            "-f",
            &sheet,
        ]
        .map(String::from)
        .to_vec()
    };
    std::fs::create_dir_all(dir.join("sheet.csv")).unwrap();
    let refused = check_command_line(&series("s=1,2")).unwrap_err();
    assert!(refused.contains("sheet.csv"), "{refused}");
    std::fs::remove_dir(dir.join("sheet.csv")).unwrap();
    let refused = check_command_line(&series("s=1,1")).unwrap_err();
    assert!(refused.contains("two of the series' files"), "{refused}");
    check_command_line(&series("s=1,2")).expect("a good series");

    let old = dir.join("old");
    std::fs::create_dir_all(&old).unwrap();
    std::fs::write(old.join("notes.txt"), b"the user's notes").unwrap();
    let export = |into: &Path| -> Vec<String> {
        ["rays", "export", &path(into), &path(&tiny)]
            .map(String::from)
            .to_vec()
    };
    let refused = check_command_line(&export(&old)).unwrap_err();
    assert!(refused.contains("notes.txt"), "{refused}");
    check_command_line(&export(&dir.join("new"))).expect("a new folder");

    let mut left: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    left.sort();
    assert_eq!(left, ["old"], "the checks wrote files");
    assert_eq!(
        std::fs::read(old.join("notes.txt")).unwrap(),
        b"the user's notes"
    );
}

/// Issue 50: a relative scene path that is not there says where the shared
/// scenes are, and names the file when it is one of them.
#[test]
fn a_missing_scene_points_to_the_shared_scenes() {
    let dir = common::scratch("hostile-missing-scene");
    let shared = dir.join("shared");
    std::fs::create_dir_all(shared.join("sky")).unwrap();
    let tiny = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/tiny.dae");
    std::fs::copy(&tiny, shared.join("sky/tiny.dae")).unwrap();
    let work = dir.join("work");
    std::fs::create_dir_all(&work).unwrap();
    let error = |scene: &str| {
        let o = Command::new(env!("CARGO_BIN_EXE_hybrid"))
            .args(["render", "-r", "8", "6", scene, "-f", "out.png"])
            .current_dir(&work)
            .env("HYBRID_SCENES", &shared)
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(2), "{scene}");
        String::from_utf8_lossy(&o.stderr).trim_end().to_string()
    };
    let shared = shared.canonicalize().unwrap();
    let named = error("sky/tiny.dae");
    let expected = shared.join("sky/tiny.dae");
    assert!(named.contains(&expected.display().to_string()), "{named}");
    let elsewhere = error("sky/CBnothing.dae");
    assert!(elsewhere.contains("HYBRID_SCENES"), "{elsewhere}");
    assert!(
        elsewhere.contains(&shared.display().to_string()),
        "{elsewhere}"
    );
    assert_eq!(named.lines().count(), 1);
    assert!(
        std::fs::read_dir(&work).unwrap().next().is_none(),
        "wrote files"
    );
}
