//! The program end to end: renders, the no-argument default, and bad input
//! (exit code 2, one error line, no file under the output name).

use std::process::Output;

use crate::common::{self, hybrid};

fn text(o: &Output) -> String {
    format!(
        "stdout:\n{}\nstderr:\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

#[test]
fn renders_a_shared_scene_framed_like_the_course() {
    let Some(scene) = common::shared("sky/CBspheres_lambertian.dae") else {
        return;
    };
    let dir = common::scratch("cli-render");
    let out = dir.join("spheres.png");
    let o = hybrid(
        &[
            "render",
            "--normals",
            "-r",
            "80",
            "60",
            "-f",
            out.to_str().unwrap(),
            scene.to_str().unwrap(),
        ],
        &dir,
    );
    assert!(o.status.success(), "{}", text(&o));
    let stdout = String::from_utf8_lossy(&o.stdout);
    for part in ["14 primitives", "native built in", "Mrays/s", "wrote"] {
        assert!(stdout.contains(part), "output lacks '{part}': {stdout}");
    }
    let img = image::open(&out).expect("a readable PNG").to_rgb8();
    assert_eq!(img.dimensions(), (80, 60));
    // The box fills the middle; the margins (outside the open box) are black.
    let centre = img.get_pixel(40, 30);
    assert!(
        centre.0.iter().any(|&c| c > 50),
        "centre pixel is black: {centre:?}"
    );
    let corner = img.get_pixel(1, 1);
    assert_eq!(corner.0, [0, 0, 0], "corner pixel is not background");
    // Left wall at x ~ 0.25 W faces +x (normal colour red-heavy), right wall -x.
    let (left, right) = (img.get_pixel(20, 30), img.get_pixel(60, 30));
    assert!(
        left.0[0] > right.0[0],
        "left wall {left:?} should face +x, right wall {right:?} -x"
    );
}

#[test]
fn no_argument_renders_the_default_scene() {
    let dir = common::scratch("cli-default");
    let o = hybrid(&["render", "-r", "32", "24"], &dir);
    assert!(o.status.success(), "{}", text(&o));
    let img = image::open(dir.join("cornell.png"))
        .expect("cornell.png written")
        .to_rgb8();
    assert_eq!(img.dimensions(), (32, 24));
    let lit = img.pixels().filter(|p| p.0.iter().any(|&c| c > 20)).count();
    assert!(
        lit > 32 * 24 / 5,
        "only {lit} lit pixels in the default render"
    );
}

/// Without a scene, the options not given take the converged preset and
/// the equivalent command is printed; with a scene file (the same scene)
/// the course's defaults hold. The preset's images of two seeds agree far
/// better than those of the same settings at 2 spp do.
#[test]
fn the_default_scene_renders_converged_and_says_how() {
    let dir = common::scratch("cli-preset");
    let file = concat!(env!("CARGO_MANIFEST_DIR"), "/dae/cornell.dae");
    let run = |args: &[&str], out: &str| {
        let mut all = vec!["render", "-r", "32", "24", "-f", out];
        all.extend_from_slice(args);
        let o = hybrid(&all, &dir);
        assert!(o.status.success(), "{}", text(&o));
        let img = image::open(dir.join(out)).expect("written").to_rgb8();
        (
            String::from_utf8_lossy(&o.stdout).to_string(),
            img.into_raw(),
        )
    };
    let rms = |a: &[u8], b: &[u8]| {
        (a.iter()
            .zip(b)
            .map(|(&x, &y)| (x as f64 - y as f64).powi(2))
            .sum::<f64>()
            / a.len() as f64)
            .sqrt()
    };
    let (said, preset0) = run(&[], "p0.png");
    let equivalent = format!("hybrid render {file} -s 256 -m 8 --rr 0.8");
    assert!(
        said.contains(&equivalent),
        "the preset and its command (by the file's absolute path) are not printed: {said}"
    );
    assert!(said.contains("at 256 spp"), "{said}");
    let (_, preset1) = run(&["--seed", "1"], "p1.png");
    // A given option is kept; the rest of the preset still applies.
    let (said, few0) = run(&["-s", "2"], "f0.png");
    assert!(
        said.contains("-m 8 --rr 0.8") && !said.contains("-s 256"),
        "{said}"
    );
    assert!(said.contains("at 2 spp"), "{said}");
    // The printed command, run from this scratch folder (not the
    // repository), renders the same image.
    let command = said
        .split('`')
        .nth(1)
        .expect("a command in backquotes")
        .to_string();
    let words: Vec<&str> = command.split_whitespace().skip(2).collect();
    let mut again = words.clone();
    again.extend(["-s", "2"]);
    let (_, named) = run(&again, "named.png");
    assert!(named == few0, "`{command} -s 2` rendered another image");
    let (_, few1) = run(&["-s", "2", "--seed", "1"], "f1.png");

    let (said, course0) = run(&[file], "c0.png");
    assert!(
        !said.contains("converged"),
        "a scene file took the preset: {said}"
    );
    assert!(said.contains("at 1 spp"), "{said}");
    let (preset, few) = (rms(&preset0, &preset1), rms(&few0, &few1));
    println!("8-bit RMS between seeds: preset {preset:.2}, the preset at 2 spp {few:.2}");
    assert!(
        preset * 3.0 < few,
        "the preset is not converged: seeds differ by {preset:.2} against {few:.2} at 2 spp"
    );
    // Indirect light: the preset's image is brighter than direct light alone.
    let mean = |v: &[u8]| v.iter().map(|&c| c as f64).sum::<f64>() / v.len() as f64;
    assert!(mean(&preset0) > mean(&course0) + 5.0);
}

#[test]
fn bad_input_exits_2_with_one_line_and_no_image() {
    let dir = common::scratch("cli-bad");
    let broken = dir.join("broken.dae");
    std::fs::write(&broken, &hybrid::scene::builtin::CORNELL.text[..2000]).unwrap();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            vec!["render", "-f", "out.png", "missing.dae"],
            "missing.dae",
        ),
        (
            vec!["render", "-f", "out.png", broken.to_str().unwrap()],
            "malformed XML",
        ),
        (
            vec!["render", "-f", "out.png", "-r", "0", "10"],
            "resolution",
        ),
        (vec!["render", "-f", "out.png", "-s", "0"], "-s 0"),
        (
            vec!["render", "-f", "out.png", "-p", "0", "0", "900", "10"],
            "cell",
        ),
        (vec!["render", "-f", "out.txt"], "unsupported output format"),
        (vec!["render", "-f", "out.png", "--rr", "1.5"], "--rr"),
    ];
    for (args, expect) in cases {
        let o = hybrid(&args, &dir);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", text(&o));
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(
            stderr.trim_end().lines().count(),
            1,
            "{args:?}: not one line: {stderr}"
        );
        assert!(
            stderr.contains(expect),
            "{args:?}: '{stderr}' lacks '{expect}'"
        );
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
        assert!(
            !dir.join("out.png").exists(),
            "{args:?} left out.png behind"
        );
    }
    // Nothing half-written either.
    let leftovers: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .flatten()
        .map(|e| e.file_name())
        .filter(|n| n != "broken.dae")
        .collect();
    assert!(leftovers.is_empty(), "files left behind: {leftovers:?}");
}

#[test]
fn same_seed_same_bytes_for_any_thread_count() {
    let dir = common::scratch("cli-threads");
    let mut images = Vec::new();
    for t in ["1", "2"] {
        let name = format!("t{t}.png");
        let o = hybrid(
            &[
                "render", "-r", "40", "30", "-s", "8", "-m", "3", "--seed", "11", "-t", t, "-f",
                &name,
            ],
            &dir,
        );
        assert!(o.status.success(), "{}", text(&o));
        images.push(std::fs::read(dir.join(&name)).unwrap());
    }
    assert!(
        images[0] == images[1],
        "-t 1 and -t 2 wrote different bytes"
    );
}

/// `hybrid render` says which mode it runs and why, chosen in one place:
/// the wavefront by default where its lanes take the scene (CBbunny and
/// the default scene, on any CPU), the reference where they do not
/// (hemisphere sampling) or for normals, and either as asked with
/// `--mode`: the same bytes either way. `--mode wavefront --normals` is
/// refused before any work.
#[test]
fn the_mode_is_chosen_in_one_place_and_said() {
    let Some(scene) = common::shared("sky/CBbunny.dae") else {
        return;
    };
    let dir = common::scratch("cli-default-mode");
    let scene = scene.to_str().unwrap();
    let wavefront = "mode: wavefront, stepped in ";
    let reference = "mode: reference (";
    let mut images = Vec::new();
    for (extra, expected) in [
        (&[][..], wavefront),
        (&["--mode", "reference"][..], reference),
        (&["--mode", "wavefront", "--no-packets"][..], wavefront),
    ] {
        let name = format!("{}.exr", images.len());
        let mut args = vec!["render", scene, "-r", "24", "18", "-s", "4", "-m", "4"];
        args.extend(extra);
        args.extend(["-f", &name]);
        let o = hybrid(&args, &dir);
        assert!(o.status.success(), "{}", text(&o));
        let out = text(&o);
        assert!(
            out.contains(expected),
            "{extra:?}: not {expected:?} in {out}"
        );
        images.push(std::fs::read(dir.join(&name)).unwrap());
    }
    assert!(
        images.iter().all(|i| *i == images[0]),
        "the modes wrote different bytes"
    );
    for (args, expected) in [
        (
            vec!["render", "-r", "24", "18", "-s", "2", "-f", "d.png"],
            wavefront,
        ),
        (
            vec![
                "render", scene, "-H", "-r", "24", "18", "-s", "2", "-f", "h.png",
            ],
            reference,
        ),
        (
            vec![
                "render",
                scene,
                "--normals",
                "-r",
                "24",
                "18",
                "-f",
                "n.png",
            ],
            reference,
        ),
    ] {
        let o = hybrid(&args, &dir);
        assert!(o.status.success(), "{}", text(&o));
        assert!(text(&o).contains(expected), "{args:?}: {}", text(&o));
    }
    let o = hybrid(
        &[
            "render",
            scene,
            "--normals",
            "--mode",
            "wavefront",
            "-f",
            "w.png",
        ],
        &dir,
    );
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("--mode wavefront"), "{}", text(&o));
    assert!(!dir.join("w.png").exists());
}

#[test]
fn parity_command_prints_its_tables_and_passes_on_a_shared_scene() {
    let Some(scene) = common::shared("sky/CBspheres_lambertian.dae") else {
        return;
    };
    let dir = common::scratch("cli-parity");
    let o = hybrid(&["parity", "--rays", "500", scene.to_str().unwrap()], &dir);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let stdout = String::from_utf8_lossy(&o.stdout);
    for kind in [
        "camera rays",
        "random rays",
        "bounce rays",
        "shadow rays",
        "grazing rays",
    ] {
        assert!(stdout.contains(kind), "no '{kind}' table: {stdout}");
    }
    assert!(
        stdout.contains("| embree3 |")
            && stdout.contains("| embree4 |")
            && stdout.contains("| none (brute force) |"),
        "{stdout}"
    );
    let o = hybrid(&["parity", "--hard", "--rays", "200"], &dir);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(
        String::from_utf8_lossy(&o.stdout).contains("native watertight"),
        "{}",
        text(&o)
    );
}

#[test]
fn course_flags_hybrid_lacks_say_what_it_offers_instead() {
    let dir = common::scratch("course-flags");
    // A flag of an older course framework: what to use instead.
    common::fails_in_one_line(
        &["render", "-x", "0.5"],
        &dir,
        "hybrid has no ambient-occlusion mode: `--normals`",
    );
    common::fails_in_one_line(&["render", "-g", "4"], &dir, "run it once per --seed");
    // Any other short flag: the course flags hybrid takes.
    common::fails_in_one_line(
        &["render", "-q"],
        &dir,
        "hybrid render takes the course's -s -l -t -m -o -e -b -d -c -f -r -p -a -H",
    );
    // The course's command line without a command.
    common::fails_in_one_line(
        &["-t", "2", "-s", "4", "scene.dae"],
        &dir,
        "the course's options go after a command: hybrid render -t 2 -s 4 scene.dae",
    );
    // Long options keep clap's spelling hint.
    common::fails_in_one_line(&["render", "--robst"], &dir, "'--robust'");
}

#[test]
fn options_a_mode_ignores_are_warned_about_in_one_line_each() {
    let dir = common::scratch("ignored-options");
    let o = hybrid(
        &[
            "render",
            "--normals",
            "-l",
            "4",
            "-m",
            "3",
            "-r",
            "8",
            "6",
            "-f",
            "n.png",
        ],
        &dir,
    );
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{}", text(&o));
    assert!(
        stderr.contains("warning: -l is ignored with --normals"),
        "{}",
        text(&o)
    );
    assert!(
        stderr.contains("warning: -m is ignored with --normals"),
        "{}",
        text(&o)
    );
    let o = hybrid(
        &[
            "render", "-a", "64", "0.05", "-s", "16", "-r", "8", "6", "-f", "a.png",
        ],
        &dir,
    );
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("the batch is larger than -s 16"),
        "{}",
        text(&o)
    );
}

/// A course-style command line (`-l`, `-m`) without `--estimator` is told
/// that direct lighting is MIS and roulette off, where the course's
/// framework samples the lights alone; with the estimator named, or for
/// normals, nothing is said.
#[test]
fn a_course_command_line_is_told_which_estimator_it_gets() {
    let Some(scene) = common::shared("sky/CBbunny.dae") else {
        return;
    };
    let dir = common::scratch("cli-course-note");
    let scene = scene.to_str().unwrap();
    let note = "the course's estimator is light sampling alone";
    for (extra, said) in [
        (&["-l", "4"][..], true),
        (&["-m", "3"][..], true),
        (&["-l", "4", "--estimator", "light"][..], false),
        (&["-l", "4", "--estimator", "mis"][..], false),
        (&[][..], false),
    ] {
        let mut args = vec!["render", scene, "-r", "8", "6", "-f", "n.png"];
        args.extend(extra);
        let o = hybrid(&args, &dir);
        assert!(o.status.success(), "{}", text(&o));
        assert_eq!(text(&o).contains(note), said, "{extra:?}: {}", text(&o));
        if said {
            assert!(text(&o).contains("no Russian roulette"), "{}", text(&o));
        }
    }
}
