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
