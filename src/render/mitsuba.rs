//! A render as a Mitsuba 3 scene (`hybrid render --mitsuba DIR`): the same
//! triangles, normals, materials, lights, camera, image size, samples and
//! path depth, so the two renderers' frames and times can be compared on
//! one scene (issue 45's "samples per second against Mitsuba 3's
//! `llvm_ad_rgb`"; `tools/mitsuba_render.py` renders and compares).
//!
//! What maps one to one: Lambertian surfaces (`diffuse`), mirrors
//! (`conductor` with no metal), smooth glass (`dielectric`), rough metals
//! (`roughconductor`, Beckmann), emitting triangles and spheres (`area`
//! emitters, one-sided as here), point and directional lights, the pinhole
//! and thin-lens cameras, a box pixel filter and `path`'s MIS of light and
//! BSDF samples. Every opaque surface is `twosided`, as this renderer
//! shades both faces. The shading normals are written per corner, so
//! Mitsuba interpolates the normals this renderer interpolates. The
//! ambient light (radiance from the world's upper hemisphere; Mitsuba has
//! no such emitter) becomes an environment map, black below the horizon.
//! What does not map is refused with the option or scene part named:
//! environment maps (`-e`), refraction-only surfaces, a black background
//! under an ambient light, and the render options Mitsuba's path tracer
//! has no counterpart of.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use glam::Vec3;

use super::integrator::{Background, BounceView, DirectEstimator, Shading};
use super::RenderSettings;
use crate::scene::{Light, Material, NormalMode, Scene};

/// The files of a Mitsuba scene: `scene.xml` and the files it names.
pub struct MitsubaScene {
    pub xml: String,
    /// `(file name, bytes)` per file the XML names: a binary PLY per
    /// material, and the sky's EXR where the scene has an ambient light.
    pub files: Vec<(String, Vec<u8>)>,
}

/// The ambient light as an environment map: this many rows, the upper
/// half the light's radiance and the lower half black (Mitsuba's maps
/// put +Y at the top row). Bilinear lookups blur the horizon over one
/// row, 0.09°.
const SKY_ROWS: u32 = 2048;

/// The XML's file name in the folder.
pub const SCENE_FILE: &str = "scene.xml";

/// `Err` naming the option when `settings` ask for something Mitsuba's
/// `path` integrator cannot render the same way; checked before any work.
pub fn check_settings(settings: &RenderSettings) -> Result<(), String> {
    let refuse = |what: &str| Err(format!("--mitsuba: {what} has no Mitsuba 3 counterpart"));
    let Shading::Path(path) = settings.shading else {
        return refuse("--normals");
    };
    if path.estimator != DirectEstimator::Mis {
        return refuse("--estimator other than mis (Mitsuba's path tracer weighs light and BSDF samples by MIS)");
    }
    if path.light_samples != 1 {
        return refuse("-l other than 1 (Mitsuba's path tracer takes one light sample per vertex)");
    }
    if !path.accumulate {
        return refuse("-o 0");
    }
    if path.view != BounceView::All {
        return refuse("--only");
    }
    if settings.adaptive.is_some() {
        return refuse("-a (adaptive sampling)");
    }
    if settings.cell.is_some() || settings.sample_range.is_some() {
        return refuse("a part of a frame (-p, --part, --samples)");
    }
    Ok(())
}

/// The Mitsuba scene of rendering `scene` with `settings` (already
/// accepted by [`check_settings`]).
pub fn export(scene: &Scene, settings: &RenderSettings) -> Result<MitsubaScene, String> {
    check_settings(settings)?;
    let Shading::Path(path) = settings.shading else {
        unreachable!("check_settings refuses normal shading");
    };
    if scene.environment.is_some() {
        return Err("--mitsuba: -e (environment maps) has no Mitsuba 3 counterpart here".into());
    }
    let mut xml = String::from("<?xml version=\"1.0\" encoding=\"utf-8\"?>\n");
    let _ = writeln!(
        xml,
        "<!-- {} as `hybrid render` renders it; written by hybrid {} -->",
        escape(&scene.name),
        env!("CARGO_PKG_VERSION")
    );
    xml += "<scene version=\"3.0.0\">\n";
    // Mitsuba counts path segments: depth 2 is direct light, so M bounces
    // are M + 1 segments.
    let max_depth = path.max_bounces + 1;
    let rr_depth = match path.russian_roulette {
        // Off here, so off there: a depth it never reaches.
        None => max_depth + 1,
        // From the second vertex on, as here (Mitsuba's continuation
        // probability follows the throughput, not a constant).
        Some(_) => 2,
    };
    let _ = writeln!(
        xml,
        "  <integrator type=\"path\">\n    <integer name=\"max_depth\" value=\"{max_depth}\"/>\n    <integer name=\"rr_depth\" value=\"{rr_depth}\"/>\n  </integrator>"
    );
    sensor(&mut xml, scene, settings);

    let mut files = Vec::new();
    let mut by_material: BTreeMap<u32, Vec<usize>> = BTreeMap::new();
    for (t, &m) in scene.mesh.materials.iter().enumerate() {
        by_material.entry(m).or_default().push(t);
    }
    for (m, triangles) in &by_material {
        let material = &scene.materials[*m as usize];
        let emits = material.emission() != Vec3::ZERO;
        // Emitters are flat in both renderers: the face's winding says
        // which side emits.
        let normals = scene.normal_mode == NormalMode::Smooth && !emits;
        let name = format!("mesh_{m}.ply");
        files.push((name.clone(), ply(scene, triangles, normals)));
        let _ = writeln!(
            xml,
            "  <shape type=\"ply\">\n    <string name=\"filename\" value=\"{name}\"/>"
        );
        if !normals {
            xml += "    <boolean name=\"face_normals\" value=\"true\"/>\n";
        }
        shape_body(&mut xml, material, *m)?;
        xml += "  </shape>\n";
    }
    for s in &scene.spheres {
        let material = &scene.materials[s.material as usize];
        let _ = writeln!(
            xml,
            "  <shape type=\"sphere\">\n    <point name=\"center\" value=\"{}\"/>\n    <float name=\"radius\" value=\"{}\"/>",
            triple(s.center),
            s.radius
        );
        shape_body(&mut xml, material, s.material)?;
        xml += "  </shape>\n";
    }
    let mut ambient = Vec3::ZERO;
    for light in &scene.lights {
        match *light {
            // Their surfaces are shapes above, with area emitters.
            Light::Area(_) | Light::Sphere { .. } => {}
            Light::Point {
                position,
                intensity,
            } => {
                let _ = writeln!(
                    xml,
                    "  <emitter type=\"point\">\n    <point name=\"position\" value=\"{}\"/>\n    <rgb name=\"intensity\" value=\"{}\"/>\n  </emitter>",
                    triple(position),
                    triple(intensity)
                );
            }
            Light::Directional { to_light, radiance } => {
                let _ = writeln!(
                    xml,
                    "  <emitter type=\"directional\">\n    <vector name=\"direction\" value=\"{}\"/>\n    <rgb name=\"irradiance\" value=\"{}\"/>\n  </emitter>",
                    triple(-to_light),
                    triple(radiance)
                );
            }
            Light::Ambient { radiance } => ambient += radiance,
        }
    }
    if ambient != Vec3::ZERO {
        if path.background == Background::Black {
            return Err("--mitsuba: --background black under an ambient light has no Mitsuba 3 counterpart (its sky is seen where it lights)".into());
        }
        let name = "sky.exr".to_string();
        files.push((name.clone(), sky(ambient)?));
        let _ = writeln!(
            xml,
            "  <emitter type=\"envmap\">\n    <string name=\"filename\" value=\"{name}\"/>\n  </emitter>"
        );
    }
    xml += "</scene>\n";
    Ok(MitsubaScene { xml, files })
}

/// The camera, sampler and film.
fn sensor(xml: &mut String, scene: &Scene, settings: &RenderSettings) {
    let camera = settings.camera_for(scene);
    let view = camera.view();
    let (kind, lens) = match view.lens {
        Some(l) => (
            "thinlens",
            format!(
                "    <float name=\"aperture_radius\" value=\"{}\"/>\n    <float name=\"focus_distance\" value=\"{}\"/>\n",
                l.radius, l.focal_distance
            ),
        ),
        None => ("perspective", String::new()),
    };
    let fov = 2.0 * view.tan_half_x.atan().to_degrees();
    let target = view.position + view.forward;
    let _ = writeln!(
        xml,
        "  <sensor type=\"{kind}\">\n    <float name=\"fov\" value=\"{fov}\"/>\n    <string name=\"fov_axis\" value=\"x\"/>\n{lens}    <transform name=\"to_world\">\n      <lookat origin=\"{}\" target=\"{}\" up=\"{}\"/>\n    </transform>\n    <sampler type=\"independent\">\n      <integer name=\"sample_count\" value=\"{}\"/>\n      <integer name=\"seed\" value=\"{}\"/>\n    </sampler>\n    <film type=\"hdrfilm\">\n      <integer name=\"width\" value=\"{}\"/>\n      <integer name=\"height\" value=\"{}\"/>\n      <string name=\"pixel_format\" value=\"rgb\"/>\n      <rfilter type=\"box\"/>\n    </film>\n  </sensor>",
        triple(view.position),
        triple(target),
        triple(view.up),
        settings.samples,
        // Mitsuba's seed is a 32-bit integer.
        settings.seed as u32,
        settings.width,
        settings.height,
    );
}

/// The ambient light's sky: `radiance` above the horizon, black below.
fn sky(radiance: Vec3) -> Result<Vec<u8>, String> {
    let image = image::Rgb32FImage::from_fn(4, SKY_ROWS, |_, row| {
        let above = row < SKY_ROWS / 2;
        image::Rgb(if above { radiance.to_array() } else { [0.0; 3] })
    });
    let mut bytes = std::io::Cursor::new(Vec::new());
    image::DynamicImage::ImageRgb32F(image)
        .write_to(&mut bytes, image::ImageFormat::OpenExr)
        .map_err(|e| format!("--mitsuba: the sky's EXR: {e}"))?;
    Ok(bytes.into_inner())
}

/// A shape's BSDF and, if its material emits, its area emitter.
fn shape_body(xml: &mut String, material: &Material, index: u32) -> Result<(), String> {
    let diffuse = |albedo: Vec3| {
        format!(
            "<bsdf type=\"twosided\"><bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"{}\"/></bsdf></bsdf>",
            triple(albedo)
        )
    };
    let bsdf = match *material {
        Material::Lambertian { albedo, .. } => diffuse(albedo),
        // Emits and reflects nothing.
        Material::Emission { .. } => diffuse(Vec3::ZERO),
        Material::Mirror { reflectance } => format!(
            "<bsdf type=\"twosided\"><bsdf type=\"conductor\"><string name=\"material\" value=\"none\"/><rgb name=\"specular_reflectance\" value=\"{}\"/></bsdf></bsdf>",
            triple(reflectance)
        ),
        // The scene format's glass is smooth; its roughness is not used.
        Material::Glass {
            reflectance,
            transmittance,
            ior,
            ..
        } => format!(
            "<bsdf type=\"dielectric\"><float name=\"int_ior\" value=\"{ior}\"/><float name=\"ext_ior\" value=\"1\"/><rgb name=\"specular_reflectance\" value=\"{}\"/><rgb name=\"specular_transmittance\" value=\"{}\"/></bsdf>",
            triple(reflectance),
            triple(transmittance)
        ),
        Material::Microfacet { alpha, eta, k } => format!(
            "<bsdf type=\"twosided\"><bsdf type=\"roughconductor\"><string name=\"distribution\" value=\"beckmann\"/><float name=\"alpha\" value=\"{alpha}\"/><rgb name=\"eta\" value=\"{}\"/><rgb name=\"k\" value=\"{}\"/></bsdf></bsdf>",
            triple(eta),
            triple(k)
        ),
        Material::Refraction { .. } => {
            return Err(format!(
                "--mitsuba: material {index} refracts without reflecting, which no Mitsuba 3 BSDF does"
            ))
        }
    };
    let _ = writeln!(xml, "    {bsdf}");
    let emission = material.emission();
    if emission != Vec3::ZERO {
        let _ = writeln!(
            xml,
            "    <emitter type=\"area\"><rgb name=\"radiance\" value=\"{}\"/></emitter>",
            triple(emission)
        );
    }
    Ok(())
}

/// A binary PLY of `triangles` of the scene's mesh: three vertices per
/// triangle (corners are not shared, so each carries the normal this
/// renderer interpolates there), with their shading normals if `normals`.
fn ply(scene: &Scene, triangles: &[usize], normals: bool) -> Vec<u8> {
    let properties = if normals {
        "property float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\n"
    } else {
        "property float x\nproperty float y\nproperty float z\n"
    };
    let header = format!(
        "ply\nformat binary_little_endian 1.0\ncomment written by hybrid\nelement vertex {}\n{properties}element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        3 * triangles.len(),
        triangles.len()
    );
    let floats = if normals { 6 } else { 3 };
    let mut out = Vec::with_capacity(header.len() + triangles.len() * (3 * floats * 4 + 13));
    out.extend_from_slice(header.as_bytes());
    for &t in triangles {
        let corners = scene.mesh.corners(t);
        let shading = if normals {
            scene.corner_normals(t)
        } else {
            [Vec3::ZERO; 3]
        };
        for (p, n) in corners.iter().zip(shading) {
            let values = [p.x, p.y, p.z, n.x, n.y, n.z];
            for v in &values[..floats] {
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
    }
    for k in 0..3 * triangles.len() as i32 {
        if k % 3 == 0 {
            out.push(3);
        }
        out.extend_from_slice(&k.to_le_bytes());
    }
    out
}

/// `x, y, z` as Mitsuba's attributes take three numbers (shortest
/// round-trip decimal: the file holds the same `f32`s).
fn triple(v: Vec3) -> String {
    format!("{:?}, {:?}, {:?}", v.x, v.y, v.z)
}

/// `text` safe inside an XML comment.
fn escape(text: &str) -> String {
    text.replace("--", "- -")
}
