//! The thin lens (`-b`, `-d`): an edge at the focal distance stays sharp
//! whatever the lens radius; an edge away from it blurs, more with a larger
//! radius.

use glam::Vec3;
use hybrid::accel::BackendConfig;
use hybrid::render::camera::{CameraMode, ThinLens};
use hybrid::render::integrator::Shading;
use hybrid::render::{render, Cell, RenderSettings, Silent};
use hybrid::scene::generate::SceneBuilder;
use hybrid::scene::{Material, NormalMode, Scene};

/// A wall covering the left half of the view at distance 2, seen from the
/// origin looking down -z.
fn edge_scene() -> Scene {
    let mut b = SceneBuilder::new("edge at distance 2");
    let m = b.material(Material::lambertian(Vec3::splat(0.5)));
    let p = [
        Vec3::new(-10.0, -10.0, -2.0),
        Vec3::new(0.0, -10.0, -2.0),
        Vec3::new(0.0, 10.0, -2.0),
        Vec3::new(-10.0, 10.0, -2.0),
    ];
    b.mesh(&p, &[[0, 1, 2], [0, 2, 3]], m);
    b.camera(Vec3::ZERO, Vec3::new(0.0, 0.0, -1.0), 40.0, 30.0);
    b.finish(NormalMode::Flat)
}

/// Pixels of the middle row between 10% and 90% of the wall's brightness.
fn edge_width(scene: &Scene, backend: BackendConfig, lens: Option<ThinLens>) -> usize {
    let accel = backend.build(scene).expect("builds");
    // The frame keeps the file's 4:3 aspect (so a pixel spans 2 tan 20° /
    // 96 of the view); only four rows across its middle are rendered.
    let (w, h) = (96, 72);
    let settings = RenderSettings {
        width: w,
        height: h,
        cell: Some(Cell {
            x: 0,
            y: h / 2 - 2,
            width: w,
            height: 4,
        }),
        samples: 256,
        seed: 3,
        threads: 2,
        camera: CameraMode::Node,
        shading: Shading::Normals,
        lens,
        ..RenderSettings::default()
    };
    let film = render(scene, &accel, &settings, &Silent).film;
    let row: Vec<f32> = (0..w)
        .map(|x| film.pixels[(2 * w + x) as usize].z)
        .collect();
    let wall = row[2];
    assert!(
        wall > 0.5 && row[w as usize - 3] < 0.05,
        "no edge in {row:?}"
    );
    row.iter()
        .filter(|&&v| v > 0.1 * wall && v < 0.9 * wall)
        .count()
}

#[test]
fn the_plane_of_focus_stays_sharp_and_the_rest_blurs_with_the_radius() {
    let scene = edge_scene();
    for backend in [BackendConfig::NATIVE, BackendConfig::EMBREE] {
        let lens = |radius, focal_distance| {
            Some(ThinLens {
                radius,
                focal_distance,
            })
        };
        let pinhole = edge_width(&scene, backend, None);
        let focused = [0.05, 0.2].map(|r| edge_width(&scene, backend, lens(r, 2.0)));
        let defocused = [0.02, 0.05, 0.2].map(|r| edge_width(&scene, backend, lens(r, 1.0)));
        println!(
            "{}: edge width in pixels, pinhole {pinhole}; in focus r 0.05 {}, r 0.2 {}; focused at 1 r 0.02 {}, r 0.05 {}, r 0.2 {}",
            backend.label(),
            focused[0],
            focused[1],
            defocused[0],
            defocused[1],
            defocused[2]
        );
        assert!(pinhole <= 1, "pinhole edge {pinhole} px wide");
        assert!(
            focused.iter().all(|&n| n <= 1),
            "edge in focus blurred: {focused:?}"
        );
        assert!(
            defocused[0] >= 1 && defocused[0] < defocused[1] && defocused[1] < defocused[2],
            "blur does not grow with the radius: {defocused:?}"
        );
        // A ray from lens point o through the focus at depth 1 meets the
        // wall at depth 2 where the pinhole sees image offset o / 2: a disk
        // of radius r / 2 / (2 tan 20° / 96) = 66 r pixels, whose edge
        // rises from 10% to 90% over 1.37 radii (the segment area of a
        // disk): 18.1 px for r = 0.2, 4.5 px for r = 0.05.
        for (r, n) in [(0.05f64, defocused[1]), (0.2, defocused[2])] {
            let expected = 1.37 * r / 2.0 / (2.0 * 20f64.to_radians().tan() / 96.0);
            assert!(
                (n as f64 - expected).abs() <= 0.25 * expected + 1.0,
                "r {r}: edge {n} px wide, expected about {expected:.1}"
            );
        }
    }
}

#[test]
fn a_saved_camera_file_renders_the_same_image_and_bad_ones_name_their_line() {
    let dir = crate::common::scratch("camera-file");
    let run = |args: &[&str]| crate::common::succeeds(args, &dir);
    let bytes = |f: &str| std::fs::read(dir.join(f)).unwrap();
    for accel in ["native", "embree"] {
        let frame = [
            "render", "--accel", accel, "-r", "60", "45", "-s", "4", "-m", "2",
        ];
        run(&[&frame[..], &["--save-camera", "cam.txt", "-f", "a.png"]].concat());
        run(&[&frame[..], &["-c", "cam.txt", "-f", "b.png"]].concat());
        assert!(
            bytes("a.png") == bytes("b.png"),
            "{accel}: the camera read back renders another image"
        );
        // The node camera differs from the canonical framing, and survives the round trip too.
        run(&[
            &frame[..],
            &[
                "--camera",
                "node",
                "--save-camera",
                "node.txt",
                "-f",
                "c.png",
            ],
        ]
        .concat());
        run(&[&frame[..], &["-c", "node.txt", "-f", "d.png"]].concat());
        assert!(bytes("c.png") == bytes("d.png") && bytes("a.png") != bytes("c.png"));
    }
    // Made by hand, matrix over three lines: in front of the box looking at it.
    std::fs::write(
        dir.join("hand.txt"),
        "45 45 1 0.1 100\n0 1 3.5 0 1 0\n0 0 3.5 0.3 30\n1 0 0\n0 1 0\n0 0 1\n60 45 100\n3.5 0\n",
    )
    .unwrap();
    run(&[
        "render",
        "-r",
        "60",
        "45",
        "--normals",
        "-c",
        "hand.txt",
        "-f",
        "hand.png",
    ]);
    let img = image::open(dir.join("hand.png")).unwrap().to_rgb8();
    assert!(
        img.get_pixel(30, 22).0.iter().any(|&c| c > 40),
        "the hand-made camera sees nothing"
    );
    for (name, text, expected) in [
        (
            "short.txt",
            "45 45 1 0.1 100\n0 0 3 0 0\n",
            "short.txt:2: the file ends after 5 of the 6 numbers",
        ),
        (
            "word.txt",
            "45 45 1 0.1 100\n0 0 3 0 0 x\n",
            "word.txt:2: 'x' is not a finite number",
        ),
        (
            "skew.txt",
            "45 45 1 0.1 100\n0 0 3 0 0 0\n0 0 3 0.3 30\n1 0 0 0 2 0 0 0 1\n60 45 100\n3 0\n",
            "skew.txt:4: the camera-to-world matrix is not a rotation",
        ),
        (
            "extra.txt",
            "45 45 1 0.1 100\n0 0 3 0 0 0\n0 0 3 0.3 30\n1 0 0 0 1 0 0 0 1\n60 45 100\n3 0 7\n",
            "extra.txt:6: unexpected '7'",
        ),
    ] {
        std::fs::write(dir.join(name), text).unwrap();
        crate::common::fails_in_one_line(&["render", "-c", name, "-f", "bad.png"], &dir, expected);
    }
}
