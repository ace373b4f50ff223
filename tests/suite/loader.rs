//! The COLLADA loader: every shared scene loads with the counts and
//! conventions of `scene-format.md`; every kind of bad input gives its
//! error, naming file and element, never a panic.

use glam::Vec3;
use hybrid::scene::{collada, Light, Material, NormalMode};

use crate::common::{self, scene_or_skip};

/// (file, triangles incl. area-light quads, spheres, light kinds, file xfov)
const SHARED: &[(&str, usize, usize, &[&str], f32)] = &[
    ("basic/plane1024.dae", 2048, 0, &["point"], 49.13434),
    ("basic/plane64.dae", 128, 0, &["point"], 49.13434),
    (
        "basic/sphere_diffuse.dae",
        0,
        1,
        &["ambient", "directional"],
        49.13434,
    ),
    ("basic/trigs5.dae", 5, 0, &["point"], 49.13434),
    (
        "keenan/banana.dae",
        2458,
        0,
        &["ambient", "directional"],
        49.13434,
    ),
    ("meshedit/cow.dae", 5856, 0, &["directional"], 39.5978),
    (
        "meshedit/maxplanck.dae",
        50801,
        0,
        &["directional"],
        39.5978,
    ),
    ("meshedit/teapot.dae", 2464, 0, &["directional"], 39.5978),
    ("sky/CBbunny.dae", 28588, 0, &["area"], 49.13434),
    ("sky/CBempty.dae", 10, 0, &["point"], 49.13434),
    ("sky/CBspheres.dae", 12, 2, &["area"], 49.13434),
    ("sky/CBspheres_lambertian.dae", 12, 2, &["area"], 49.13434),
    ("sky/bunny.dae", 33696, 0, &["ambient"], 49.13434),
];

#[test]
fn every_shared_scene_loads_with_its_counts() {
    let Some(dir) = common::scenes_dir() else {
        return;
    };
    let mut found = 0;
    for entry in walk(&dir) {
        let rel = entry
            .strip_prefix(&dir)
            .unwrap()
            .to_string_lossy()
            .replace('\\', "/");
        let scene =
            collada::load(&entry, NormalMode::Smooth).unwrap_or_else(|e| panic!("{rel}: {e}"));
        let Some(&(_, tris, spheres, lights, xfov)) = SHARED.iter().find(|s| s.0 == rel) else {
            // A scene this test does not know yet: loading it is the check.
            continue;
        };
        found += 1;
        assert_eq!(scene.triangle_count(), tris, "{rel}: triangles");
        assert_eq!(scene.spheres.len(), spheres, "{rel}: spheres");
        let kinds: Vec<&str> = scene.lights.iter().map(|l| l.kind()).collect();
        assert_eq!(kinds, lights, "{rel}: lights");
        assert!(
            (scene.camera.xfov - xfov).abs() < 1e-3,
            "{rel}: xfov {} != {xfov}",
            scene.camera.xfov
        );
        assert!(
            scene.camera.yfov > 0.0 && scene.camera.yfov < scene.camera.xfov,
            "{rel}: yfov {}",
            scene.camera.yfov
        );
        assert!(!scene.materials.is_empty(), "{rel}: no materials");
        assert_eq!(
            scene.mesh.normals.len(),
            scene.mesh.positions.len(),
            "{rel}: smooth normals"
        );
    }
    assert_eq!(
        found,
        SHARED.len(),
        "not every known shared scene was found under {}",
        dir.display()
    );
}

fn walk(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            out.extend(walk(&p));
        } else if p.extension().is_some_and(|x| x == "dae") {
            out.push(p);
        }
    }
    out.sort();
    out
}

#[test]
fn cornell_spheres_follow_the_dialect_conventions() {
    let scene = scene_or_skip!("sky/CBspheres_lambertian.dae");
    // Z_UP (x, y, z) -> (-x, z, y): the light hangs under the ceiling and
    // emits downwards; dim_x x dim_y = 0.6 x 0.8.
    let Light::Area(light) = scene.lights[0] else {
        panic!("first light is not an area light")
    };
    assert!(
        (light.normal - Vec3::new(0.0, -1.0, 0.0)).length() < 1e-5,
        "light normal {}",
        light.normal
    );
    assert!(
        (light.area - 0.48).abs() < 1e-5,
        "light area {}",
        light.area
    );
    let centre = light.origin + (light.edge_u + light.edge_v) * 0.5;
    assert!(
        (centre - Vec3::new(0.0, 1.49, 0.0)).length() < 1e-5,
        "light centre {centre}"
    );
    // Spheres: node transform of the origin; radius 0.3.
    let mut centres: Vec<Vec3> = scene.spheres.iter().map(|s| s.center).collect();
    centres.sort_by(|a, b| a.x.total_cmp(&b.x));
    assert!(
        (centres[0] - Vec3::new(-0.4, 0.3, -0.3)).length() < 1e-5,
        "{centres:?}"
    );
    assert!(
        (centres[1] - Vec3::new(0.4, 0.3, 0.3)).length() < 1e-5,
        "{centres:?}"
    );
    assert!(scene.spheres.iter().all(|s| (s.radius - 0.3).abs() < 1e-6));
    // The red wall is on the left (-x), the blue one on the right.
    let wall_colour = |x: f32| {
        let i = (0..scene.mesh.len())
            .find(|&i| scene.mesh.corners(i).iter().all(|p| (p.x - x).abs() < 1e-4))
            .unwrap();
        match scene.materials[scene.mesh.materials[i] as usize] {
            Material::Lambertian { albedo, .. } => albedo,
            m => panic!("wall material {m:?}"),
        }
    };
    assert!(
        wall_colour(-1.0).x > wall_colour(-1.0).z,
        "left wall is not red"
    );
    assert!(
        wall_colour(1.0).z > wall_colour(1.0).x,
        "right wall is not blue"
    );
}

#[test]
fn cgl_materials_are_read() {
    let scene = scene_or_skip!("sky/CBspheres.dae");
    let kinds: Vec<&str> = scene.materials.iter().map(|m| m.kind()).collect();
    assert!(
        kinds.contains(&"mirror") && kinds.contains(&"glass"),
        "{kinds:?}"
    );
    let glass = scene
        .materials
        .iter()
        .find(|m| matches!(m, Material::Glass { .. }))
        .unwrap();
    assert!(
        matches!(glass, Material::Glass { ior, .. } if (*ior - 1.45).abs() < 1e-6),
        "{glass:?}"
    );
}

#[test]
fn smooth_normals_are_area_weighted_and_unit() {
    let scene = scene_or_skip!("meshedit/teapot.dae");
    for n in &scene.mesh.normals {
        assert!(
            (n.length() - 1.0).abs() < 1e-4 || *n == Vec3::ZERO,
            "normal {n} is not unit"
        );
    }
    let flat = collada::load(
        &common::shared("meshedit/teapot.dae").unwrap(),
        NormalMode::Flat,
    )
    .unwrap();
    assert!(
        flat.mesh.normals.is_empty(),
        "flat mode stores no vertex normals"
    );
}

#[test]
fn the_default_scene_has_everything_it_promises() {
    let scene = common::default_scene();
    assert_eq!(scene.spheres.len(), 2);
    assert!(
        scene.triangle_count() >= 10 + 12,
        "walls and cube: {}",
        scene.triangle_count()
    );
    assert!(scene.lights.iter().any(|l| matches!(l, Light::Area(_))));
    assert!(scene
        .materials
        .iter()
        .any(|m| matches!(m, Material::Microfacet { .. })));
}

/// Loads the default scene text after `edit`; returns the error line.
fn error_after(edit: impl Fn(&str) -> String) -> String {
    let text = edit(hybrid::scene::builtin::CORNELL.text);
    assert_ne!(
        text,
        hybrid::scene::builtin::CORNELL.text,
        "the edit changed nothing"
    );
    match collada::load_str(&text, "bad.dae", NormalMode::Smooth) {
        Ok(_) => panic!("a bad scene loaded"),
        Err(e) => e.to_string(),
    }
}

fn assert_mentions(error: &str, parts: &[&str]) {
    assert!(!error.contains('\n'), "error is not one line: {error}");
    for p in parts {
        assert!(error.contains(p), "error '{error}' does not mention '{p}'");
    }
}

#[test]
fn bad_input_gives_one_clear_error() {
    assert_mentions(
        &error_after(|t| t.replacen("<library_geometries>", "<library_geometries", 1)),
        &["bad.dae:", "malformed XML"],
    );
    assert_mentions(
        &error_after(|t| t[..t.len() / 2].to_string()),
        &["bad.dae:", "malformed XML"],
    );
    assert_mentions(
        &error_after(|t| t.replacen("url=\"#cube-mesh\"", "url=\"#no-such-mesh\"", 1)),
        &["bad.dae:", "<instance_geometry>", "missing id"],
    );
    assert_mentions(
        &error_after(|t| t.replacen("<p>0 1 2 3</p>", "<p>0 1 2 9</p>", 1)),
        &["bad.dae:", "<p>", "out of range"],
    );
    assert_mentions(
        &error_after(|t| t.replacen("count=\"12\"", "count=\"13\"", 1)),
        &[
            "bad.dae:",
            "<float_array id=\"floor-positions-array\">",
            "13",
        ],
    );
    assert_mentions(
        &error_after(|t| t.replacen("1 1.98", "1 nan", 1)),
        &["bad.dae:", "<matrix>", "non-finite"],
    );
    assert_mentions(
        &error_after(|t| t.replacen("1 1.98", "1 inf", 1)),
        &["bad.dae:", "<matrix>", "non-finite"],
    );
    assert_mentions(
        &error_after(|t| t.replacen("<vcount>4</vcount>", "<vcount>4 4</vcount>", 1)),
        &["bad.dae:", "<vcount>"],
    );
    assert_mentions(
        &error_after(|t| {
            t.replacen(
                "<instance_camera url=\"#main-camera\"/>",
                "<instance_controller url=\"#main-camera\"/>",
                1,
            )
        }),
        &["bad.dae:", "<instance_controller>", "unsupported"],
    );
    assert_mentions(
        &error_after(|t| {
            t.replacen(
                "<polylist material=\"floor-material\"",
                "<polygons material=\"floor-material\"",
                1,
            )
            .replacen("</polylist>", "</polygons>", 1)
        }),
        &["<polygons>", "unsupported"],
    );
    assert_mentions(
        &error_after(|t| {
            t.replacen("<area>", "<spot>", 1)
                .replacen("</area>", "</spot>", 1)
        }),
        &["<spot>", "unsupported light"],
    );
    assert_mentions(
        &error_after(|t| {
            t.replacen("<mirror>", "<velvet>", 1)
                .replacen("</mirror>", "</velvet>", 1)
        }),
        &["<velvet>", "unknown CGL material"],
    );
    assert_mentions(
        &error_after(|t| t.replacen("<instance_visual_scene url=\"#scene\"/>", "", 1)),
        &["no <instance_visual_scene>"],
    );
}

#[test]
fn a_missing_file_names_the_file() {
    let e = collada::load(
        std::path::Path::new("/no/such/scene.dae"),
        NormalMode::Smooth,
    )
    .unwrap_err()
    .to_string();
    assert_mentions(&e, &["/no/such/scene.dae", "cannot read"]);
}

/// The default scene's cube has its own corners per face, so smooth
/// normals leave it a cube (with eight shared corners they averaged it into
/// a rounded blob).
#[test]
fn the_default_cube_keeps_flat_faces() {
    let scene = common::default_scene();
    let gold = scene
        .materials
        .iter()
        .position(|m| matches!(m, Material::Microfacet { .. }))
        .expect("the gold cube's material") as u32;
    let cube: Vec<usize> = (0..scene.mesh.len())
        .filter(|&i| scene.mesh.materials[i] == gold)
        .collect();
    assert_eq!(cube.len(), 12);
    for i in cube {
        let face = scene.mesh.face_normal(i).normalize();
        for v in scene.mesh.indices[i] {
            let n = scene.mesh.normals[v as usize];
            assert!(
                n.dot(face) > 0.9999,
                "cube triangle {i}: vertex normal {n} vs face {face}"
            );
        }
    }
}

/// A crease angle splits smooth normals at sharp edges only: a cube with
/// shared corners gets flat faces, a finely tessellated sphere keeps the
/// plain smooth normals.
#[test]
fn a_crease_angle_keeps_sharp_edges_and_smooth_curves() {
    use hybrid::scene::generate::{cube, icosphere, SceneBuilder};
    let build = |(positions, tris): (Vec<Vec3>, Vec<[u32; 3]>)| {
        let mut b = SceneBuilder::new("creased");
        let m = b.material(Material::DEFAULT);
        b.mesh(&positions, &tris, m);
        b.finish(NormalMode::Smooth)
    };
    let mut box_scene = build(cube(false));
    let corner = box_scene.mesh.normals[0];
    assert!(
        (corner.abs() - Vec3::splat(1.0 / 3f32.sqrt())).length() < 1e-5,
        "without a crease a shared corner averages three faces: {corner}"
    );
    box_scene.mesh.crease(60.0);
    for (i, corners) in box_scene.mesh.corner_normals.iter().enumerate() {
        let face = box_scene.mesh.face_normal(i).normalize();
        for n in corners {
            assert!(n.dot(face) > 0.9999, "triangle {i}: {n} vs face {face}");
        }
    }
    let mut sphere = build(icosphere(3));
    let smooth = sphere.mesh.normals.clone();
    sphere.mesh.crease(60.0);
    for (i, corners) in sphere.mesh.corner_normals.iter().enumerate() {
        for (k, n) in corners.iter().enumerate() {
            let v = sphere.mesh.indices[i][k] as usize;
            assert!(
                (*n - smooth[v]).length() < 1e-5,
                "sphere corner {i}.{k}: {n} vs {}",
                smooth[v]
            );
        }
    }
}

#[test]
fn a_light_instanced_by_a_dangling_url_is_one_warning_and_left_out() {
    let whole = collada::load_str(
        hybrid::scene::builtin::CORNELL.text,
        "ok.dae",
        NormalMode::Smooth,
    )
    .expect("the default scene loads");
    let text = hybrid::scene::builtin::CORNELL.text.replacen(
        "url=\"#area-light\"",
        "url=\"#Hemi-light\"",
        1,
    );
    let scene = collada::load_str(&text, "gems.dae", NormalMode::Smooth)
        .expect("a dangling light instance is not an error");
    assert_eq!(
        scene.lights.len() + 1,
        whole.lights.len(),
        "the light is left out"
    );
    let warned: Vec<&String> = scene
        .warnings
        .iter()
        .filter(|w| w.contains("Hemi-light") && w.contains("left out"))
        .collect();
    assert_eq!(warned.len(), 1, "warnings: {:?}", scene.warnings);
    // A dangling geometry instance is still an error.
    assert_mentions(
        &error_after(|t| t.replacen("url=\"#cube-mesh\"", "url=\"#no-such-mesh\"", 1)),
        &["missing id"],
    );
}

#[test]
fn repeated_ids_of_one_file_are_one_warning_with_a_count() {
    let text = hybrid::scene::builtin::CORNELL.text;
    // Five elements whose ids repeat three times (x three times, y twice);
    // nothing refers to them.
    let extra = "<asset><contributor id=\"x\"/><contributor id=\"x\"/><contributor id=\"x\"/><contributor id=\"y\"/><contributor id=\"y\"/></asset>";
    let edited = text.replacen(
        "<library_geometries>",
        &format!("{extra}<library_geometries>"),
        1,
    );
    assert_ne!(edited, text);
    let scene = collada::load_str(&edited, "dups.dae", NormalMode::Smooth);
    let warnings: Vec<String> = match scene {
        Ok(s) => s.warnings,
        Err(e) => panic!("{e}"),
    };
    let repeated: Vec<&String> = warnings
        .iter()
        .filter(|w| w.contains("was already given"))
        .collect();
    assert_eq!(repeated.len(), 1, "{warnings:?}");
    assert!(repeated[0].contains("3 in all"), "{}", repeated[0]);
}

#[test]
fn a_scene_whose_lights_all_emit_nothing_warns_and_suggests_an_environment_map() {
    let text = hybrid::scene::builtin::CORNELL.text;
    // The light's colour, in its common and its area technique.
    let dark = text.replace(
        "<color sid=\"color\">2 2 2</color>",
        "<color sid=\"color\">0 0 0</color>",
    );
    assert_ne!(dark, text);
    let scene = collada::load_str(&dark, "unlit.dae", NormalMode::Smooth).expect("it loads");
    let warned: Vec<&String> = scene
        .warnings
        .iter()
        .filter(|w| w.contains("every light emits nothing") && w.contains("-e MAP.exr"))
        .collect();
    assert_eq!(warned.len(), 1, "warnings: {:?}", scene.warnings);
    // A lit scene says nothing of the kind.
    let lit = collada::load_str(text, "lit.dae", NormalMode::Smooth).expect("it loads");
    assert!(
        lit.warnings.iter().all(|w| !w.contains("emits nothing")),
        "{:?}",
        lit.warnings
    );
}
