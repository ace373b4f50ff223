//! COLLADA 1.4 loader for the CGL dialect (`scene-format.md`): node
//! hierarchy, up-axis, `polylist`/`triangles` meshes, CGL/CMU462 spheres,
//! CGL materials and lights, and the camera.
//!
//! Everything outside the dialect is an error naming the file, the line and
//! the element; unknown `extra` content is ignored.

use std::collections::HashMap;
use std::path::Path;

use glam::{Mat4, Vec3, Vec4};
use roxmltree::{Document, Node};

use super::builder::SceneBuilder;
use super::{AreaLight, CameraSpec, Light, Material, NormalMode, Scene};

/// Why a scene could not be loaded: always names the file and, where there
/// is one, the line and element.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    #[error("{file}: cannot read the scene: {source}")]
    Io {
        file: String,
        #[source]
        source: std::io::Error,
    },
    #[error("{file}:{line}:{column}: malformed XML: {message}")]
    Xml {
        file: String,
        line: u32,
        column: u32,
        message: String,
    },
    #[error("{file}:{line}: <{element}>: {problem}")]
    Invalid {
        file: String,
        line: u32,
        element: String,
        problem: String,
    },
}

/// Loads a scene file with the given shading-normal mode.
pub fn load(path: &Path, normal_mode: NormalMode) -> Result<Scene, LoadError> {
    let file = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|source| LoadError::Io {
        file: file.clone(),
        source,
    })?;
    let text = String::from_utf8(bytes).map_err(|e| LoadError::Xml {
        file: file.clone(),
        line: 0,
        column: 0,
        message: format!("not UTF-8 text ({e})"),
    })?;
    load_str(&text, &file, normal_mode)
}

/// Loads a scene from COLLADA text; `file` names it in errors.
pub fn load_str(text: &str, file: &str, normal_mode: NormalMode) -> Result<Scene, LoadError> {
    let doc = Document::parse(text).map_err(|e| {
        let pos = e.pos();
        LoadError::Xml {
            file: file.to_string(),
            line: pos.row,
            column: pos.col,
            message: e.to_string(),
        }
    })?;
    let mut loader = Loader::new(file, &doc);
    loader.load()?;
    Ok(loader.builder.finish(normal_mode))
}

type Result<T, E = LoadError> = std::result::Result<T, E>;

struct Loader<'a, 'input> {
    file: &'a str,
    doc: &'a Document<'input>,
    ids: HashMap<&'a str, Node<'a, 'input>>,
    builder: SceneBuilder,
    /// Material element id -> index in `scene.materials`.
    materials: HashMap<String, u32>,
    default_material: Option<u32>,
    camera: Option<CameraSpec>,
}

/// A `source` of a mesh: its numbers and accessor stride.
struct Source {
    values: Vec<f32>,
    stride: usize,
}

impl<'a, 'input> Loader<'a, 'input> {
    fn new(file: &'a str, doc: &'a Document<'input>) -> Self {
        let ids = doc
            .descendants()
            .filter(|n| n.is_element())
            .filter_map(|n| n.attribute("id").map(|id| (id, n)))
            .collect();
        Loader {
            file,
            doc,
            ids,
            builder: SceneBuilder::new(file),
            materials: HashMap::new(),
            default_material: None,
            camera: None,
        }
    }

    fn error(&self, node: Node, problem: impl Into<String>) -> LoadError {
        let pos = self.doc.text_pos_at(node.range().start);
        LoadError::Invalid {
            file: self.file.to_string(),
            line: pos.row,
            element: node.tag_name().name().to_string(),
            problem: problem.into(),
        }
    }

    fn load(&mut self) -> Result<()> {
        let root = self.doc.root_element();
        if root.tag_name().name() != "COLLADA" {
            return Err(self.error(root, "the root element is not <COLLADA>"));
        }
        let up = self.global_matrix(root)?;
        let scene_el =
            child(root, "scene").ok_or_else(|| self.error(root, "no <scene> element"))?;
        let instance = child(scene_el, "instance_visual_scene")
            .ok_or_else(|| self.error(scene_el, "no <instance_visual_scene> element"))?;
        let visual_scene = self.reference(instance, "url")?;
        if visual_scene.tag_name().name() != "visual_scene" {
            return Err(self.error(instance, "url does not name a <visual_scene>"));
        }
        for node in elements(visual_scene).filter(|n| n.tag_name().name() == "node") {
            self.load_node(node, up)?;
        }
        self.builder.camera_spec(self.camera.unwrap_or_default());
        Ok(())
    }

    /// The matrix from the file's up-axis to the renderer's Y-up.
    fn global_matrix(&self, root: Node) -> Result<Mat4> {
        let axis = child(root, "asset").and_then(|a| child(a, "up_axis"));
        let Some(axis) = axis else {
            return Ok(Mat4::IDENTITY);
        };
        let rows: [[f32; 3]; 3] = match axis.text().unwrap_or("").trim() {
            "Y_UP" => return Ok(Mat4::IDENTITY),
            "Z_UP" => [[-1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]],
            "X_UP" => [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]],
            other => return Err(self.error(axis, format!("unknown up axis '{other}'"))),
        };
        let m = Mat4::from_cols(
            Vec4::new(rows[0][0], rows[1][0], rows[2][0], 0.0),
            Vec4::new(rows[0][1], rows[1][1], rows[2][1], 0.0),
            Vec4::new(rows[0][2], rows[1][2], rows[2][2], 0.0),
            Vec4::W,
        );
        Ok(m)
    }

    /// Follows a `url="#id"` or `target="#id"` attribute.
    fn reference(&self, node: Node<'a, 'input>, attr: &str) -> Result<Node<'a, 'input>> {
        let value = node
            .attribute(attr)
            .ok_or_else(|| self.error(node, format!("missing attribute '{attr}'")))?;
        let id = value.strip_prefix('#').ok_or_else(|| {
            self.error(
                node,
                format!("{attr}=\"{value}\" is not a local reference '#id'"),
            )
        })?;
        self.ids
            .get(id)
            .copied()
            .ok_or_else(|| self.error(node, format!("{attr}=\"{value}\" refers to a missing id")))
    }

    fn load_node(&mut self, node: Node<'a, 'input>, parent: Mat4) -> Result<()> {
        let mut local = Mat4::IDENTITY;
        for c in elements(node) {
            local = match c.tag_name().name() {
                "matrix" => {
                    let v = self.floats(c, Some(16))?;
                    local * Mat4::from_cols_slice(&v).transpose()
                }
                "translate" => {
                    let v = self.floats(c, Some(3))?;
                    local * Mat4::from_translation(Vec3::new(v[0], v[1], v[2]))
                }
                "scale" => {
                    let v = self.floats(c, Some(3))?;
                    local * Mat4::from_scale(Vec3::new(v[0], v[1], v[2]))
                }
                "rotate" => {
                    let v = self.floats(c, Some(4))?;
                    let axis = Vec3::new(v[0], v[1], v[2]);
                    if axis.length_squared() == 0.0 {
                        return Err(self.error(c, "rotation axis is zero"));
                    }
                    local * Mat4::from_axis_angle(axis.normalize(), v[3].to_radians())
                }
                _ => continue,
            };
        }
        let world = parent * local;
        let mut instances = 0;
        for c in elements(node) {
            match c.tag_name().name() {
                "matrix" | "translate" | "scale" | "rotate" | "extra" | "asset" => {}
                "node" => self.load_node(c, world)?,
                "instance_geometry" => {
                    instances += 1;
                    self.load_instance_geometry(c, world)?;
                }
                "instance_light" => {
                    instances += 1;
                    let light = self.reference(c, "url")?;
                    self.load_light(light, world)?;
                }
                "instance_camera" => {
                    instances += 1;
                    if self.camera.is_none() {
                        let camera = self.reference(c, "url")?;
                        self.camera = Some(self.load_camera(camera, world)?);
                    }
                }
                other => return Err(self.error(c, format!("unsupported element in <node> (the dialect knows node, matrix, translate, rotate, scale, instance_geometry, instance_light, instance_camera), found <{other}>"))),
            }
        }
        if instances > 1 {
            return Err(self.error(
                node,
                "a node instances more than one camera, light or geometry",
            ));
        }
        Ok(())
    }

    fn load_instance_geometry(&mut self, inst: Node<'a, 'input>, world: Mat4) -> Result<()> {
        let geometry = self.reference(inst, "url")?;
        if geometry.tag_name().name() != "geometry" {
            return Err(self.error(inst, "url does not name a <geometry>"));
        }
        // Material symbols bound by this instance.
        let mut bindings: Vec<(String, u32)> = Vec::new();
        if let Some(tc) = child(inst, "bind_material").and_then(|b| child(b, "technique_common")) {
            for im in elements(tc).filter(|n| n.tag_name().name() == "instance_material") {
                let symbol = im.attribute("symbol").unwrap_or("").to_string();
                let material = self.reference(im, "target")?;
                let index = self.material(material)?;
                bindings.push((symbol, index));
            }
        }
        if let Some(mesh) = child(geometry, "mesh") {
            return self.load_mesh(mesh, world, &bindings);
        }
        if let Some(sphere) = cgl_technique(geometry).and_then(|t| child(t, "sphere")) {
            let radius_el =
                child(sphere, "radius").ok_or_else(|| self.error(sphere, "no <radius>"))?;
            let r = self.floats(radius_el, Some(1))?[0];
            if r <= 0.0 {
                return Err(self.error(radius_el, format!("sphere radius {r} is not positive")));
            }
            let center = world.transform_point3(Vec3::ZERO);
            let radius = r * world.transform_vector3(Vec3::X).length();
            let material = match bindings.first() {
                Some((_, m)) => *m,
                None => self.default_material(),
            };
            self.builder.sphere(center, radius, material);
            return Ok(());
        }
        Err(self.error(
            geometry,
            "geometry has neither a <mesh> nor a CGL/CMU462 <sphere>",
        ))
    }

    fn default_material(&mut self) -> u32 {
        if let Some(m) = self.default_material {
            return m;
        }
        let m = self.builder.material(Material::DEFAULT);
        self.default_material = Some(m);
        m
    }

    fn load_mesh(
        &mut self,
        mesh: Node<'a, 'input>,
        world: Mat4,
        bindings: &[(String, u32)],
    ) -> Result<()> {
        let mut sources: HashMap<&str, Source> = HashMap::new();
        let mut vertices: HashMap<&str, &str> = HashMap::new();
        for c in elements(mesh) {
            match c.tag_name().name() {
                "source" => {
                    let id = c.attribute("id").unwrap_or("");
                    sources.insert(id, self.source(c)?);
                }
                "vertices" => {
                    let input = elements(c)
                        .find(|i| {
                            i.tag_name().name() == "input"
                                && i.attribute("semantic") == Some("POSITION")
                        })
                        .ok_or_else(|| self.error(c, "no POSITION input"))?;
                    let src = input
                        .attribute("source")
                        .unwrap_or("")
                        .trim_start_matches('#');
                    vertices.insert(c.attribute("id").unwrap_or(""), src);
                }
                _ => {}
            }
        }
        for prim in elements(mesh) {
            let name = prim.tag_name().name();
            match name {
                "source" | "vertices" | "extra" => {}
                "polylist" | "triangles" => self.load_polygons(prim, &sources, &vertices, world, bindings)?,
                other => {
                    return Err(self.error(prim, format!("unsupported mesh primitive <{other}> (the dialect has polylist and triangles)")))
                }
            }
        }
        Ok(())
    }

    fn source(&self, source: Node) -> Result<Source> {
        let array =
            child(source, "float_array").ok_or_else(|| self.error(source, "no <float_array>"))?;
        let count: usize = self.count_attr(array)?;
        let values = self.floats(array, Some(count))?;
        let accessor = child(source, "technique_common")
            .and_then(|t| child(t, "accessor"))
            .ok_or_else(|| self.error(source, "no technique_common/accessor"))?;
        let stride: usize = match accessor.attribute("stride") {
            Some(s) => s
                .trim()
                .parse()
                .map_err(|_| self.error(accessor, format!("stride \"{s}\" is not a count")))?,
            None => 1,
        };
        if stride == 0 {
            return Err(self.error(accessor, "stride is zero"));
        }
        if let Some(c) = accessor.attribute("count") {
            let c: usize = c
                .trim()
                .parse()
                .map_err(|_| self.error(accessor, format!("count \"{c}\" is not a number")))?;
            if c * stride > values.len() {
                return Err(self.error(
                    accessor,
                    format!(
                        "count {c} x stride {stride} exceeds the {} values of the array",
                        values.len()
                    ),
                ));
            }
        }
        Ok(Source { values, stride })
    }

    fn count_attr(&self, node: Node) -> Result<usize> {
        let c = node
            .attribute("count")
            .ok_or_else(|| self.error(node, "missing attribute 'count'"))?;
        c.trim()
            .parse()
            .map_err(|_| self.error(node, format!("count=\"{c}\" is not a number")))
    }

    fn load_polygons(
        &mut self,
        prim: Node<'a, 'input>,
        sources: &HashMap<&str, Source>,
        vertices: &HashMap<&str, &str>,
        world: Mat4,
        bindings: &[(String, u32)],
    ) -> Result<()> {
        // Inputs: (offset, number of entries in the referenced source).
        let mut stride = 0usize;
        let mut vertex_offset = None;
        let mut position_source: Option<&Source> = None;
        let mut ranges: Vec<(usize, usize, Node)> = Vec::new();
        for input in elements(prim).filter(|n| n.tag_name().name() == "input") {
            let offset: usize = match input.attribute("offset") {
                Some(o) => o
                    .trim()
                    .parse()
                    .map_err(|_| self.error(input, format!("offset=\"{o}\" is not a number")))?,
                None => return Err(self.error(input, "missing attribute 'offset'")),
            };
            stride = stride.max(offset + 1);
            let src = input.attribute("source").unwrap_or("");
            let id = src.strip_prefix('#').ok_or_else(|| {
                self.error(input, format!("source=\"{src}\" is not a reference '#id'"))
            })?;
            let semantic = input.attribute("semantic").unwrap_or("");
            let source = if semantic == "VERTEX" {
                let pos_id = vertices.get(id).ok_or_else(|| {
                    self.error(
                        input,
                        format!("source=\"{src}\" does not name this mesh's <vertices>"),
                    )
                })?;
                let s = sources.get(pos_id).ok_or_else(|| {
                    self.error(input, format!("POSITION source '#{pos_id}' is missing"))
                })?;
                if s.stride < 3 {
                    return Err(self.error(input, "POSITION source has a stride below 3"));
                }
                vertex_offset = Some(offset);
                position_source = Some(s);
                s
            } else {
                sources.get(id).ok_or_else(|| {
                    self.error(input, format!("source=\"{src}\" refers to a missing id"))
                })?
            };
            ranges.push((offset, source.values.len() / source.stride, input));
        }
        let (Some(vertex_offset), Some(positions)) = (vertex_offset, position_source) else {
            return Err(self.error(prim, "no VERTEX input"));
        };
        let count = self.count_attr(prim)?;
        let p_el = child(prim, "p").ok_or_else(|| self.error(prim, "no <p> indices"))?;
        let indices = self.integers(p_el)?;
        let vcount: Vec<u32> = if prim.tag_name().name() == "polylist" {
            let vc = child(prim, "vcount").ok_or_else(|| self.error(prim, "no <vcount>"))?;
            let v = self.integers(vc)?;
            if v.len() != count {
                return Err(self.error(
                    vc,
                    format!("{} polygon sizes for count=\"{count}\"", v.len()),
                ));
            }
            if let Some(bad) = v.iter().find(|&&n| n < 3) {
                return Err(self.error(vc, format!("a polygon with {bad} corners")));
            }
            v
        } else {
            vec![3; count]
        };
        let corners: usize = vcount.iter().map(|&n| n as usize).sum();
        if corners * stride != indices.len() {
            return Err(self.error(
                p_el,
                format!(
                    "{} indices, but {corners} corners x {stride} inputs = {} expected",
                    indices.len(),
                    corners * stride
                ),
            ));
        }
        for (k, &index) in indices.iter().enumerate() {
            let offset = k % stride;
            for &(o, len, input) in &ranges {
                if o == offset && index as usize >= len {
                    let semantic = input.attribute("semantic").unwrap_or("?");
                    return Err(self.error(p_el, format!("index {index} ({semantic}) is out of range: its source has {len} entries")));
                }
            }
        }

        let material = match prim.attribute("material") {
            Some(symbol) => match bindings.iter().find(|(s, _)| s == symbol) {
                Some((_, m)) => *m,
                None => self.default_material(),
            },
            None => match bindings {
                [(_, m)] => *m,
                _ => self.default_material(),
            },
        };

        // Each instance gets its own vertices, transformed to world space;
        // polygons are triangulated as fans.
        let base = self.builder.vertices(
            positions
                .values
                .chunks_exact(positions.stride)
                .map(|v| world.transform_point3(Vec3::new(v[0], v[1], v[2]))),
        );
        let mut cursor = 0usize;
        for &n in &vcount {
            let corner = |c: usize| base + indices[(cursor + c) * stride + vertex_offset];
            for c in 1..(n as usize - 1) {
                self.builder
                    .face([corner(0), corner(c), corner(c + 1)], material);
            }
            cursor += n as usize;
        }
        self.builder.polygons(vcount.len());
        Ok(())
    }

    /// Index of the material that `material` (a `<material>` element) names,
    /// loading it on first use.
    fn material(&mut self, material: Node<'a, 'input>) -> Result<u32> {
        let id = material.attribute("id").unwrap_or("").to_string();
        if let Some(&m) = self.materials.get(&id) {
            return Ok(m);
        }
        if material.tag_name().name() != "material" {
            return Err(self.error(material, "target does not name a <material>"));
        }
        let inst = child(material, "instance_effect")
            .ok_or_else(|| self.error(material, "no <instance_effect>"))?;
        let effect = self.reference(inst, "url")?;
        let parsed = self.effect(effect)?;
        let index = self.builder.material(parsed);
        self.materials.insert(id, index);
        Ok(index)
    }

    fn effect(&self, effect: Node) -> Result<Material> {
        if let Some(kind) = cgl_technique(effect).and_then(|t| elements(t).next()) {
            let colour = |name: &str| -> Result<Vec3> {
                self.vec3(
                    child(kind, name).ok_or_else(|| self.error(kind, format!("no <{name}>")))?,
                )
            };
            let scalar = |name: &str, default: f32| -> Result<f32> {
                match child(kind, name) {
                    Some(n) => Ok(self.floats(n, Some(1))?[0]),
                    None => Ok(default),
                }
            };
            return Ok(match kind.tag_name().name() {
                "emission" => Material::Emission {
                    radiance: colour("radiance")?,
                },
                "mirror" => Material::Mirror {
                    reflectance: colour("reflectance")?,
                },
                "glass" => Material::Glass {
                    reflectance: colour("reflectance")?,
                    transmittance: colour("transmittance")?,
                    roughness: scalar("roughness", 0.0)?,
                    ior: scalar("ior", 1.5)?,
                },
                "refraction" => Material::Refraction {
                    transmittance: colour("transmittance")?,
                    roughness: scalar("roughness", 0.0)?,
                    ior: scalar("ior", 1.5)?,
                },
                "microfacet" => Material::Microfacet {
                    alpha: scalar("alpha", 0.5)?.max(1e-3),
                    eta: colour("eta")?,
                    k: colour("k")?,
                },
                other => return Err(self.error(kind, format!("unknown CGL material <{other}>"))),
            });
        }
        let diffuse = child(effect, "profile_COMMON")
            .and_then(|p| child(p, "technique"))
            .and_then(|t| {
                elements(t).find(|n| matches!(n.tag_name().name(), "phong" | "lambert" | "blinn"))
            })
            .and_then(|s| child(s, "diffuse"))
            .and_then(|d| child(d, "color"));
        match diffuse {
            Some(c) => {
                let v = self.floats(c, None)?;
                if v.len() < 3 {
                    return Err(self.error(c, "a colour needs three numbers"));
                }
                Ok(Material::lambertian(Vec3::new(v[0], v[1], v[2])))
            }
            None => Ok(Material::DEFAULT),
        }
    }

    fn load_light(&mut self, light: Node, world: Mat4) -> Result<()> {
        if light.tag_name().name() != "light" {
            return Err(self.error(light, "url does not name a <light>"));
        }
        let technique = cgl_technique(light)
            .or_else(|| child(light, "technique_common"))
            .ok_or_else(|| self.error(light, "no CGL technique and no <technique_common>"))?;
        let kind = elements(technique)
            .next()
            .ok_or_else(|| self.error(technique, "empty light technique"))?;
        let color_el = child(kind, "color").ok_or_else(|| self.error(kind, "no <color>"))?;
        let color = self.vec3(color_el)?;
        let at = |p: Vec3| world.transform_point3(p);
        let light = match kind.tag_name().name() {
            "area" => {
                let c = at(Vec3::ZERO);
                let normal = (at(Vec3::new(0.0, 0.0, -1.0)) - c).normalize_or_zero();
                let dim_y = at(Vec3::Y) - c;
                let dim_x = at(Vec3::new(-1.0, 0.0, 0.0)) - c;
                let area = dim_x.length() * dim_y.length();
                if normal == Vec3::ZERO || area == 0.0 {
                    return Err(self.error(kind, "area light has a degenerate transform"));
                }
                Light::Area(AreaLight {
                    origin: c - dim_x * 0.5 - dim_y * 0.5,
                    edge_u: dim_x,
                    edge_v: dim_y,
                    triangle: false,
                    normal,
                    radiance: color,
                    area,
                })
            }
            "point" => Light::Point {
                position: at(Vec3::ZERO),
                intensity: color,
            },
            "directional" => {
                let to_light = at(Vec3::new(0.0, 0.0, -1.0)).normalize_or_zero();
                if to_light == Vec3::ZERO {
                    return Err(self.error(kind, "directional light has no direction"));
                }
                Light::Directional {
                    to_light,
                    radiance: color,
                }
            }
            "ambient" => Light::Ambient { radiance: color },
            other => {
                return Err(self.error(
                    kind,
                    format!("unsupported light type <{other}> (area, point, directional, ambient)"),
                ))
            }
        };
        self.builder.light(light);
        Ok(())
    }

    fn load_camera(&self, camera: Node, world: Mat4) -> Result<CameraSpec> {
        if camera.tag_name().name() != "camera" {
            return Err(self.error(camera, "url does not name a <camera>"));
        }
        let optics = child(camera, "optics").ok_or_else(|| self.error(camera, "no <optics>"))?;
        let tc = child(optics, "technique_common")
            .ok_or_else(|| self.error(optics, "no <technique_common>"))?;
        let persp = child(tc, "perspective").ok_or_else(|| {
            self.error(
                tc,
                "no <perspective> (only perspective cameras are supported)",
            )
        })?;
        let get = |name: &str| -> Result<Option<f32>> {
            match child(persp, name) {
                Some(n) => Ok(Some(self.floats(n, Some(1))?[0])),
                None => Ok(None),
            }
        };
        let (xfov, yfov, aspect) = (get("xfov")?, get("yfov")?, get("aspect_ratio")?);
        let half = |deg: f32| (deg.to_radians() * 0.5).tan();
        let full = |t: f32| (2.0 * t.atan()).to_degrees();
        let (x, y) = match (xfov, yfov, aspect) {
            (Some(x), Some(y), _) => (x, y),
            (Some(x), None, Some(a)) => (x, full(half(x) / a)),
            (None, Some(y), Some(a)) => (full(half(y) * a), y),
            (Some(x), None, None) => (x, x),
            (None, Some(y), None) => (y, y),
            (None, None, _) => return Err(self.error(persp, "neither <xfov> nor <yfov>")),
        };
        for (name, v) in [("xfov", x), ("yfov", y)] {
            if !(v > 0.0 && v < 180.0) {
                return Err(self.error(
                    persp,
                    format!("{name} {v} is not between 0 and 180 degrees"),
                ));
            }
        }
        Ok(CameraSpec {
            transform: world,
            xfov: x,
            yfov: y,
        })
    }

    fn floats(&self, node: Node, expected: Option<usize>) -> Result<Vec<f32>> {
        let text = node.text().unwrap_or("");
        let mut out = Vec::with_capacity(expected.unwrap_or(0));
        for token in text.split_ascii_whitespace() {
            let v: f32 = token
                .parse()
                .map_err(|_| self.error(node, format!("'{token}' is not a number")))?;
            if !v.is_finite() {
                return Err(self.error(node, format!("non-finite number '{token}'")));
            }
            out.push(v);
        }
        if let Some(n) = expected {
            if out.len() != n {
                return Err(self.error(
                    node,
                    format!("{} numbers where {n} are expected", out.len()),
                ));
            }
        }
        Ok(out)
    }

    fn vec3(&self, node: Node) -> Result<Vec3> {
        let v = self.floats(node, None)?;
        if v.len() < 3 {
            return Err(self.error(
                node,
                format!(
                    "{} numbers where a colour or vector of 3 is expected",
                    v.len()
                ),
            ));
        }
        Ok(Vec3::new(v[0], v[1], v[2]))
    }

    fn integers(&self, node: Node) -> Result<Vec<u32>> {
        node.text()
            .unwrap_or("")
            .split_ascii_whitespace()
            .map(|t| {
                t.parse::<u32>()
                    .map_err(|_| self.error(node, format!("'{t}' is not an index")))
            })
            .collect()
    }
}

/// Element children of `node`.
fn elements<'a, 'input>(node: Node<'a, 'input>) -> impl Iterator<Item = Node<'a, 'input>> {
    node.children().filter(|n| n.is_element())
}

/// The first element child named `name`.
fn child<'a, 'input>(node: Node<'a, 'input>, name: &str) -> Option<Node<'a, 'input>> {
    elements(node).find(|n| n.tag_name().name() == name)
}

/// The `<extra><technique profile="CGL">` (or older `CMU462`) block of
/// `node`.
fn cgl_technique<'a, 'input>(node: Node<'a, 'input>) -> Option<Node<'a, 'input>> {
    elements(node)
        .filter(|n| n.tag_name().name() == "extra")
        .flat_map(elements)
        .find(|t| {
            t.tag_name().name() == "technique"
                && matches!(t.attribute("profile"), Some("CGL") | Some("CMU462"))
        })
}
