//! The series' parsing, planning and tables.

use super::vary::parse_vary;
use super::*;

#[test]
fn values_are_lists_inclusive_ranges_or_continued_sequences() {
    let v = |t: &str| parse_vary(t).map(|(n, v)| (n, v.join(" ")));
    assert_eq!(v("l=1,4,16,64").unwrap(), ("l".into(), "1 4 16 64".into()));
    assert_eq!(v("m=0..5").unwrap().1, "0 1 2 3 4 5");
    assert_eq!(
        v("s=1,2,4,...,1024").unwrap().1,
        "1 2 4 8 16 32 64 128 256 512 1024"
    );
    assert_eq!(v("m=0,2,...,8").unwrap().1, "0 2 4 6 8");
    assert_eq!(
        v("estimator=hemisphere,light").unwrap().1,
        "hemisphere light"
    );
    assert!(v("x=1,2")
        .unwrap_err()
        .contains("not an option a series varies"));
    assert!(
        v("s=1,2,4,...,1000").is_err(),
        "1000 is not in the sequence"
    );
    assert!(v("l").is_err());
    assert!(v("m=5..0").is_err());
}

#[test]
fn the_title_keeps_the_shared_options_only() {
    let raw: Vec<String> = [
        "scene.dae",
        "-s",
        "64",
        "--vary",
        "m=0..5",
        "-f",
        "x.png",
        "--columns",
        "3",
        "-l",
        "4",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    assert_eq!(
        fixed_options(&raw, Some(Path::new("scene.dae"))),
        "-s 64 -l 4"
    );
}

#[test]
fn the_variable_options_are_the_render_options_of_one_value() {
    let names = variable_options();
    for wanted in [
        "scene",
        "s",
        "l",
        "m",
        "rr",
        "estimator",
        "accel",
        "crease",
        "e",
    ] {
        assert!(
            names.iter().any(|n| n == wanted),
            "{wanted} missing from {names:?}"
        );
    }
    // Output names, partial renders, switches and two-value options.
    for refused in [
        "f", "samples", "part", "flat", "normals", "r", "a", "p", "help",
    ] {
        assert!(
            !names.iter().any(|n| n == refused),
            "{refused} in {names:?}"
        );
    }
}
