//! `hybrid series`: the contact sheet holds every value's image, labelled,
//! in a known layout.

use crate::common::{fails_in_one_line, scratch, succeeds};

/// Row `y` of the sheet from column `x` on matches the whole image `tile`.
fn holds_at(sheet: &image::RgbImage, tile: &image::RgbImage, x: u32, y: u32) -> bool {
    (0..tile.height()).all(|ty| {
        (0..tile.width()).all(|tx| sheet.get_pixel(x + tx, y + ty) == tile.get_pixel(tx, ty))
    })
}

#[test]
fn a_series_writes_a_labelled_sheet_of_its_distinct_images() {
    let dir = scratch("series");
    succeeds(
        &[
            "series",
            "--vary",
            "l=1,4,16",
            "-r",
            "96",
            "72",
            "-s",
            "2",
            "-m",
            "2",
            "-f",
            "sheet.png",
        ],
        &dir,
    );
    let sheet = image::open(dir.join("sheet.png"))
        .expect("the sheet")
        .to_rgb8();
    let tiles: Vec<image::RgbImage> = ["1", "4", "16"]
        .iter()
        .map(|v| {
            image::open(dir.join(format!("sheet_{v}.png")))
                .expect("a single image")
                .to_rgb8()
        })
        .collect();
    // Three tiles in one row, 8-pixel gutters; a title band above and a
    // caption band below.
    assert_eq!(sheet.width(), 3 * 96 + 4 * 8, "sheet width");
    assert!(
        sheet.height() > 72 + 2 * 8 + 2 * 10,
        "no room for title and captions: {}",
        sheet.height()
    );
    for t in &tiles {
        assert_eq!(t.dimensions(), (96, 72));
    }
    assert!(
        tiles[0] != tiles[1] && tiles[1] != tiles[2],
        "the values gave the same image"
    );
    // Each tile sits in the sheet pixel for pixel, in order, on one row.
    let y = (0..sheet.height() - 72)
        .find(|&y| holds_at(&sheet, &tiles[0], 8, y))
        .expect("the first tile is not in the sheet");
    assert!(y > 8, "no title band above the tiles");
    assert!(holds_at(&sheet, &tiles[1], 8 + 104, y), "second tile");
    assert!(holds_at(&sheet, &tiles[2], 8 + 208, y), "third tile");
    // Captions: dark text on white under every tile.
    for i in 0..3u32 {
        let ink = (y + 72..sheet.height())
            .flat_map(|yy| (8 + 104 * i..8 + 104 * i + 96).map(move |xx| (xx, yy)))
            .filter(|&(xx, yy)| sheet.get_pixel(xx, yy).0[0] < 128)
            .count();
        assert!(ink > 10, "tile {i} has no caption ({ink} dark pixels)");
    }
}

#[test]
fn a_series_refuses_unknown_options_and_bad_values_before_rendering() {
    let dir = scratch("series-bad");
    fails_in_one_line(
        &["series", "--vary", "zoom=1,2", "-f", "s.png"],
        &dir,
        "not an option a series varies",
    );
    fails_in_one_line(
        &["series", "--vary", "s=1,0", "-f", "s.png"],
        &dir,
        "--vary s=0: -s 0",
    );
    fails_in_one_line(
        &["series", "--vary", "estimator=light,best", "-f", "s.png"],
        &dir,
        "--vary estimator=best",
    );
    // A scene that does not load fails before the good one renders.
    std::fs::write(dir.join("bad.dae"), "<COLLADA").unwrap();
    // (fails_in_one_line also checks that nothing was written.)
    if let Some(good) = crate::common::shared("sky/CBempty.dae") {
        let list = format!("scene={},bad.dae", good.display());
        fails_in_one_line(
            &["series", "--vary", &list, "-f", "s.png"],
            &dir,
            "--vary scene=bad.dae",
        );
    }
}

/// Without a scene, the default scene's converged settings fill in what
/// was not given, and the series says which; the varied option is its own.
#[test]
fn a_series_of_the_default_scene_takes_its_converged_settings() {
    let dir = scratch("series-preset");
    let o = crate::common::hybrid(
        &["series", "--vary", "s=1,2", "-r", "16", "12", "-f", "p.png"],
        &dir,
    );
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{out}");
    assert!(out.contains("converged settings: -m 8 --rr 0.8"), "{out}");
    assert!(
        !out.contains("-s 256"),
        "the varied -s was overridden: {out}"
    );
    // A scene file keeps the course's defaults: no preset.
    let file = concat!(env!("CARGO_MANIFEST_DIR"), "/dae/cornell.dae");
    let o = crate::common::hybrid(
        &[
            "series", "--vary", "s=1,2", "-r", "16", "12", "-f", "q.png", file,
        ],
        &dir,
    );
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success() && !out.contains("converged"), "{out}");
}

/// With `-a`, every value's sample-rate image is a file of its own
/// (`SHEET_VALUE_rate.png`, as `render -a` writes `NAME_rate.png`), and it
/// is the rate tile of the sheet.
#[test]
fn an_adaptive_series_writes_each_rate_image_beside_its_render() {
    let dir = scratch("series-rate");
    succeeds(
        &[
            "series", "--vary", "s=8,32", "-a", "4", "0.2", "-r", "40", "30", "-m", "2", "-f",
            "ad.png",
        ],
        &dir,
    );
    let sheet = image::open(dir.join("ad.png"))
        .expect("the sheet")
        .to_rgb8();
    for v in ["8", "32"] {
        let render = image::open(dir.join(format!("ad_{v}.png")))
            .expect("the render")
            .to_rgb8();
        let rate = image::open(dir.join(format!("ad_{v}_rate.png")))
            .unwrap_or_else(|e| panic!("ad_{v}_rate.png: {e}"))
            .to_rgb8();
        assert_eq!(render.dimensions(), (40, 30));
        assert_eq!(
            rate.dimensions(),
            (40, 30 + hybrid::render::film::LEGEND_HEIGHT),
            "the rate image of s={v}"
        );
        // The rate tile on the sheet is the file's image, pixel for pixel.
        let found = (0..sheet.height() - rate.height())
            .any(|y| (0..sheet.width() - rate.width()).any(|x| holds_at(&sheet, &rate, x, y)));
        assert!(found, "the rate image of s={v} is not on the sheet");
    }
}

/// Two `--vary` options render every pair, the first down the sheet and
/// the second across, and write the times as a two-way Markdown table and
/// a CSV (scene, triangles, build and render time per backend): the
/// write-up's with-and-without-BVH table in one command.
#[test]
fn two_varied_options_make_a_grid_and_a_two_way_table_of_times() {
    let (Some(empty), Some(bunny)) = (
        crate::common::shared("sky/CBempty.dae"),
        crate::common::shared("sky/bunny.dae"),
    ) else {
        return;
    };
    let dir = scratch("series-two-way");
    let scenes = format!("scene={},{}", empty.display(), bunny.display());
    succeeds(
        &[
            "series",
            "--normals",
            "--vary",
            &scenes,
            "--vary",
            "accel=native,none",
            "-r",
            "24",
            "18",
            "-f",
            "bvh.png",
        ],
        &dir,
    );
    let sheet = image::open(dir.join("bvh.png"))
        .expect("the sheet")
        .to_rgb8();
    // Two columns (the backends), two rows (the scenes).
    assert_eq!(sheet.width(), 2 * 24 + 3 * 8, "sheet width");
    for name in [
        "CBempty_native",
        "CBempty_none",
        "bunny_native",
        "bunny_none",
    ] {
        assert!(dir.join(format!("bvh_{name}.png")).is_file(), "{name}");
    }
    let csv = std::fs::read_to_string(dir.join("bvh.csv")).expect("the CSV");
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(
        lines[0], "scene,accel,triangles,build_ms,render_ms,total_ms,mean_spp",
        "{csv}"
    );
    assert_eq!(lines.len(), 5, "one line per render: {csv}");
    let triangles = |scene: &str| {
        crate::common::load(scene)
            .expect("loads")
            .triangle_count()
            .to_string()
    };
    for (line, (scene, accel, file)) in lines[1..].iter().zip([
        ("CBempty", "native", "sky/CBempty.dae"),
        ("CBempty", "none", "sky/CBempty.dae"),
        ("bunny", "native", "sky/bunny.dae"),
        ("bunny", "none", "sky/bunny.dae"),
    ]) {
        let f: Vec<&str> = line.split(',').collect();
        assert_eq!(&f[..3], &[scene, accel, &triangles(file)], "{line}");
        let ms: Vec<f64> = f[3..6].iter().map(|v| v.parse().expect("a time")).collect();
        assert!(ms[1] > 0.0, "no render time: {line}");
        assert!(
            (ms[0] + ms[1] - ms[2]).abs() < 0.01,
            "total != build + render: {line}"
        );
        if accel == "native" {
            assert!(ms[0] > 0.0, "the BVH's build took no time: {line}");
        }
    }
    let md = std::fs::read_to_string(dir.join("bvh.md")).expect("the Markdown");
    assert!(
        md.contains("| scene | triangles | accel = native build | accel = native render | accel = none build | accel = none render |"),
        "{md}"
    );
    assert!(
        md.contains(&format!("| bunny | {} |", triangles("sky/bunny.dae"))),
        "{md}"
    );
    // Three renders at most per option pair is not a limit; 65 renders is.
    fails_in_one_line(
        &[
            "series", "--vary", "s=1..9", "--vary", "m=0..7", "-f", "x.png",
        ],
        &dir,
        "72 renders",
    );
    fails_in_one_line(
        &[
            "series", "--vary", "s=1,2", "--vary", "s=3,4", "-f", "x.png",
        ],
        &dir,
        "varied twice",
    );
}

/// `--exposure EV` scales the PNG's radiance by 2^EV before the tone map
/// and leaves the EXR's radiance alone; `auto` brings the mean to mid grey
/// and says by how much; nonsense is one error line.
#[test]
fn exposure_brightens_the_png_only() {
    let dir = scratch("exposure");
    let common = ["render", "-r", "24", "18", "-s", "4", "-m", "3"];
    let run = |extra: &[&str]| {
        let args: Vec<&str> = common.iter().chain(extra).copied().collect();
        let o = crate::common::hybrid(&args, &dir);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8_lossy(&o.stdout).to_string()
    };
    run(&["-f", "plain.png"]);
    run(&["--exposure", "2", "-f", "bright.png"]);
    run(&["--exposure", "-3", "-f", "dark.png"]);
    let out = run(&["--exposure", "auto", "-f", "auto.png"]);
    assert!(out.contains("exposure by the image's mean: +"), "{out}");
    run(&["-f", "plain.exr"]);
    run(&["--exposure", "2", "-f", "bright.exr"]);
    let mean = |f: &str| {
        let img = image::open(dir.join(f)).expect(f).to_rgb8();
        img.pixels().map(|p| f64::from(p.0[1])).sum::<f64>() / img.pixels().len() as f64
    };
    let (plain, bright, dark) = (mean("plain.png"), mean("bright.png"), mean("dark.png"));
    assert!(
        bright > plain * 1.3 && dark < plain * 0.6,
        "{dark} {plain} {bright}"
    );
    let radiance = |f: &str| image::open(dir.join(f)).expect(f).to_rgb32f().into_raw();
    assert_eq!(
        radiance("plain.exr"),
        radiance("bright.exr"),
        "the EXR changed"
    );
    fails_in_one_line(
        &["render", "--exposure", "nan", "-f", "x.png"],
        &dir,
        "--exposure",
    );
    fails_in_one_line(
        &["render", "--exposure", "100", "-f", "x.png"],
        &dir,
        "within ±64",
    );
}
