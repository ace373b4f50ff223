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
