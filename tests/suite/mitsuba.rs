//! `hybrid render --mitsuba DIR`: the render as a Mitsuba 3 scene holds the
//! scene's triangles, normals, lights (the ambient light as a sky map),
//! camera and path settings, and what Mitsuba cannot render the same way
//! is refused before any file is made.

use std::path::Path;

use glam::Vec3;
use hybrid::render::camera::{Camera, CameraMode};

use crate::common::{fails_in_one_line, scratch, shared, succeeds};

/// A binary PLY as `--mitsuba` writes it: its vertices (3 or 6 floats
/// each) and face count.
fn read_ply(path: &Path) -> (Vec<Vec<f32>>, usize) {
    let bytes = std::fs::read(path).unwrap();
    let end = b"end_header\n";
    let at = bytes.windows(end.len()).position(|w| w == end).unwrap() + end.len();
    let header = std::str::from_utf8(&bytes[..at]).unwrap();
    let count = |element: &str| -> usize {
        header
            .lines()
            .find_map(|l| l.strip_prefix(&format!("element {element} ")))
            .unwrap()
            .parse()
            .unwrap()
    };
    let (vertices, faces) = (count("vertex"), count("face"));
    let floats = header
        .lines()
        .filter(|l| l.starts_with("property float"))
        .count();
    let body = &bytes[at..];
    assert_eq!(
        body.len(),
        vertices * floats * 4 + faces * 13,
        "{}",
        path.display()
    );
    let vertex = (0..vertices)
        .map(|v| {
            (0..floats)
                .map(|k| {
                    let o = (v * floats + k) * 4;
                    f32::from_le_bytes(body[o..o + 4].try_into().unwrap())
                })
                .collect()
        })
        .collect();
    (vertex, faces)
}

fn numbers(text: &str) -> Vec<f32> {
    text.split(',').map(|n| n.trim().parse().unwrap()).collect()
}

#[test]
fn a_render_as_a_mitsuba_scene_holds_its_triangles_light_and_camera() {
    let Some(path) = shared("sky/CBbunny.dae") else {
        return;
    };
    let scene = crate::common::load("sky/CBbunny.dae").unwrap();
    let dir = scratch("mitsuba-export");
    let file = path.to_str().unwrap();
    succeeds(
        &[
            "render",
            file,
            "-r",
            "64",
            "48",
            "-s",
            "2",
            "-m",
            "5",
            "--seed",
            "9",
            "--mitsuba",
            "mi",
            "-f",
            "ours.exr",
        ],
        &dir,
    );
    let text = std::fs::read_to_string(dir.join("mi/scene.xml")).unwrap();
    let doc = roxmltree::Document::parse(&text).unwrap();
    let named = |node: roxmltree::Node, name: &str| {
        node.descendants()
            .find(|n| n.attribute("name") == Some(name))
            .and_then(|n| n.attribute("value"))
            .unwrap_or_else(|| panic!("no {name}"))
            .to_string()
    };
    let root = doc.root_element();
    let integrator = root
        .children()
        .find(|n| n.has_tag_name("integrator"))
        .unwrap();
    assert_eq!(
        named(integrator, "max_depth"),
        "6",
        "five bounces are six segments"
    );
    assert_eq!(
        named(integrator, "rr_depth"),
        "7",
        "no Russian roulette here, none there"
    );

    // Every triangle once, at its place, with unit normals off the light.
    let mut triangles = 0;
    let mut sum = Vec3::ZERO;
    let mut emitters = Vec::new();
    for shape in root.children().filter(|n| n.has_tag_name("shape")) {
        assert_eq!(shape.attribute("type"), Some("ply"));
        let (vertices, faces) = read_ply(&dir.join("mi").join(named(shape, "filename")));
        assert_eq!(vertices.len(), 3 * faces);
        triangles += faces;
        for v in &vertices {
            sum += Vec3::new(v[0], v[1], v[2]);
            if v.len() == 6 {
                let n = Vec3::new(v[3], v[4], v[5]).length();
                assert!((n - 1.0).abs() < 1e-4, "a shading normal of length {n}");
            }
        }
        if let Some(e) = shape.children().find(|n| n.has_tag_name("emitter")) {
            assert_eq!(e.attribute("type"), Some("area"));
            assert!(vertices.iter().all(|v| v.len() == 3), "the light is flat");
            emitters.push(numbers(&named(e, "radiance")));
        }
    }
    assert_eq!(triangles, scene.triangle_count());
    let expected: Vec3 = (0..scene.triangle_count())
        .flat_map(|t| scene.mesh.corners(t))
        .sum();
    assert!(
        (sum - expected).abs().max_element() <= 1e-3 * expected.abs().max_element().max(1.0),
        "corners sum to {sum} in the meshes, {expected} in the scene"
    );
    let hybrid::scene::Light::Area(light) = scene.lights[0] else {
        panic!("CBbunny's light is an area light");
    };
    assert_eq!(emitters, vec![light.radiance.to_array().to_vec()]);

    // The camera this render used, at this image size.
    let sensor = root.children().find(|n| n.has_tag_name("sensor")).unwrap();
    let view = Camera::new(&scene, CameraMode::Canonical, 64, 48).view();
    let fov: f32 = named(sensor, "fov").parse().unwrap();
    assert!((fov - 2.0 * view.tan_half_x.atan().to_degrees()).abs() < 1e-4);
    let lookat = sensor
        .descendants()
        .find(|n| n.has_tag_name("lookat"))
        .unwrap();
    let origin = numbers(lookat.attribute("origin").unwrap());
    assert_eq!(origin, view.position.to_array().to_vec());
    assert_eq!(named(sensor, "sample_count"), "2");
    assert_eq!(named(sensor, "width"), "64");
    assert_eq!(named(sensor, "height"), "48");
    assert!(
        dir.join("ours.exr").is_file(),
        "the render itself is written too"
    );
}

#[test]
fn what_mitsuba_cannot_render_the_same_way_is_refused_before_any_file() {
    let (Some(bunny), Some(sky)) = (shared("sky/CBbunny.dae"), shared("sky/bunny.dae")) else {
        return;
    };
    let dir = scratch("mitsuba-refusals");
    let (bunny, sky) = (bunny.to_str().unwrap(), sky.to_str().unwrap());
    let frame = [
        "-r",
        "16",
        "12",
        "-s",
        "1",
        "-f",
        "x.png",
        "--mitsuba",
        "mi",
    ];
    let with = |scene: &str, extra: &[&str]| -> Vec<String> {
        let mut args = vec!["render".to_string(), scene.to_string()];
        args.extend(frame.iter().chain(extra).map(|s| s.to_string()));
        args
    };
    for (scene, extra, expected) in [
        (
            sky,
            &["--background", "black"][..],
            "--background black under an ambient light",
        ),
        (bunny, &["-l", "4"][..], "-l other than 1"),
        (bunny, &["--estimator", "light"][..], "--estimator"),
        (bunny, &["-o", "0"][..], "-o 0"),
        (bunny, &["--normals"][..], "--normals"),
        (bunny, &["-a", "1", "0.05"][..], "-a"),
    ] {
        let args = with(scene, extra);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        fails_in_one_line(&args, &dir, expected);
    }
    // A folder with something in it is left as it is.
    std::fs::create_dir(dir.join("mi")).unwrap();
    std::fs::write(dir.join("mi/scene.xml"), "mine").unwrap();
    let args = with(bunny, &[]);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    fails_in_one_line(&args, &dir, "is not empty");
    assert_eq!(
        std::fs::read_to_string(dir.join("mi/scene.xml")).unwrap(),
        "mine"
    );
    let series = [
        "series",
        bunny,
        "--vary",
        "s=1,2",
        "-r",
        "16",
        "12",
        "--mitsuba",
        "m2",
    ];
    fails_in_one_line(&series, &dir, "--mitsuba");
}

#[test]
fn an_ambient_light_becomes_a_sky_black_below_the_horizon() {
    let Some(path) = shared("sky/bunny.dae") else {
        return;
    };
    let scene = crate::common::load("sky/bunny.dae").unwrap();
    let ambient: Vec3 = scene
        .lights
        .iter()
        .filter_map(|l| match l {
            hybrid::scene::Light::Ambient { radiance } => Some(*radiance),
            _ => None,
        })
        .sum();
    assert!(
        ambient.max_element() > 0.0,
        "sky/bunny.dae has an ambient light"
    );
    let dir = scratch("mitsuba-sky");
    let args = [
        "render",
        path.to_str().unwrap(),
        "-r",
        "16",
        "12",
        "-s",
        "1",
    ];
    succeeds(
        &[&args[..], &["--mitsuba", "mi", "-f", "x.png"]].concat(),
        &dir,
    );
    let text = std::fs::read_to_string(dir.join("mi/scene.xml")).unwrap();
    let doc = roxmltree::Document::parse(&text).unwrap();
    let envmap = doc
        .descendants()
        .find(|n| n.has_tag_name("emitter") && n.attribute("type") == Some("envmap"))
        .expect("an envmap emitter");
    let file = envmap
        .children()
        .find(|n| n.attribute("name") == Some("filename"))
        .and_then(|n| n.attribute("value"))
        .unwrap();
    let sky = image::open(dir.join("mi").join(file)).unwrap().to_rgb32f();
    let h = sky.height();
    assert!(
        h >= 1024,
        "a horizon sharp to a tenth of a degree needs rows: {h}"
    );
    for (_, y, p) in sky.enumerate_pixels() {
        let expected = if y < h / 2 {
            ambient.to_array()
        } else {
            [0.0; 3]
        };
        assert_eq!(p.0, expected, "row {y} of {h}");
    }
}
