//! COLLADA 1.4 loader for the CGL dialect (`scene-format.md`): node
//! hierarchy, up-axis, `polylist`/`triangles` meshes, CGL/CMU462 spheres,
//! CGL materials and lights, and the camera.
//!
//! Everything outside the dialect is an error naming the file, the line and
//! the element; unknown `extra` content is ignored.
//!
//! - this file: the document, references, the node hierarchy;
//! - [`geometry`]: mesh sources, `polylist`/`triangles`, spheres' data;
//! - [`shading`]: materials, lights and the camera;
//! - [`numbers`]: the numbers and indices inside elements.

mod geometry;
mod numbers;
mod shading;

use std::collections::HashMap;
use std::path::Path;

use glam::{Mat4, Vec3, Vec4};
use roxmltree::{Document, Node};

use super::builder::SceneBuilder;
use super::{CameraSpec, Material, NormalMode, Scene};

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
        /// The element's tag, with its id when it has one.
        element: String,
        problem: String,
    },
}

/// Scene files larger than this are refused unless the caller allows more
/// (`hybrid render --max-scene-mb`): the largest shipped scene is 3.4 MB.
pub const DEFAULT_MAX_BYTES: u64 = 1 << 30;

/// Elements nested deeper than this are refused before parsing: the XML
/// parser and the node walk recurse once per level, and no scene of the
/// dialect nests more than a dozen.
pub const MAX_NESTING: usize = 256;

/// Loads a scene file with the given shading-normal mode (files up to
/// [`DEFAULT_MAX_BYTES`]).
pub fn load(path: &Path, normal_mode: NormalMode) -> Result<Scene, LoadError> {
    load_limited(path, normal_mode, DEFAULT_MAX_BYTES)
}

/// Loads a scene file of at most `max_bytes`. Only regular files are read
/// (a FIFO would block, a device never end), and never more than the limit.
pub fn load_limited(
    path: &Path,
    normal_mode: NormalMode,
    max_bytes: u64,
) -> Result<Scene, LoadError> {
    let file = path.display().to_string();
    let io = |source| LoadError::Io {
        file: file.clone(),
        source,
    };
    let meta = std::fs::metadata(path).map_err(io)?;
    if !meta.is_file() {
        return Err(io(std::io::Error::other(
            "not a regular file (a directory, device, FIFO or socket)",
        )));
    }
    if meta.len() > max_bytes {
        return Err(io(std::io::Error::other(format!(
            "{} bytes; scenes over {max_bytes} bytes are refused (raise the limit with --max-scene-mb)",
            meta.len()
        ))));
    }
    let mut bytes = Vec::new();
    std::io::Read::read_to_end(
        &mut std::io::Read::take(
            std::fs::File::open(path).map_err(io)?,
            max_bytes.saturating_add(1),
        ),
        &mut bytes,
    )
    .map_err(io)?;
    if bytes.len() as u64 > max_bytes {
        return Err(io(std::io::Error::other(format!(
            "grew past {max_bytes} bytes while being read"
        ))));
    }
    let text = String::from_utf8(bytes).map_err(|e| {
        let valid = e.utf8_error().valid_up_to();
        let (line, column) = line_column(&e.as_bytes()[..valid]);
        LoadError::Xml {
            file: file.clone(),
            line,
            column,
            message: format!(
                "not UTF-8 text (invalid byte 0x{:02x})",
                e.as_bytes()[valid]
            ),
        }
    })?;
    load_str(&text, &file, normal_mode)
}

/// 1-based line and column just after `bytes`.
fn line_column(bytes: &[u8]) -> (u32, u32) {
    let line = bytes.iter().filter(|&&b| b == b'\n').count() + 1;
    let start = bytes.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
    let column = String::from_utf8_lossy(&bytes[start..]).chars().count() + 1;
    (line as u32, column as u32)
}

/// The byte offset of the first element nested deeper than `max`, if any.
/// A small scanner of tags, comments, CDATA and processing instructions;
/// quoted attribute values may hold `>`. Malformed text is left for the
/// parser to report.
fn too_deep(text: &str, max: usize) -> Option<usize> {
    let b = text.as_bytes();
    let mut depth = 0usize;
    let mut i = 0;
    let skip_to = |from: usize, end: &[u8]| -> usize {
        b[from..]
            .windows(end.len())
            .position(|w| w == end)
            .map_or(b.len(), |p| from + p + end.len())
    };
    while i < b.len() {
        if b[i] != b'<' {
            i += 1;
            continue;
        }
        let rest = &b[i..];
        if rest.starts_with(b"<!--") {
            i = skip_to(i + 4, b"-->");
        } else if rest.starts_with(b"<![CDATA[") {
            i = skip_to(i + 9, b"]]>");
        } else if rest.starts_with(b"<?") {
            i = skip_to(i + 2, b"?>");
        } else if rest.starts_with(b"<!") {
            i = skip_to(i + 2, b">");
        } else {
            let closing = rest.get(1) == Some(&b'/');
            let start = i;
            // The end of the tag, past quoted attribute values.
            let mut j = i + 1;
            let mut quote = None;
            while j < b.len() {
                match (quote, b[j]) {
                    (None, b'"') | (None, b'\'') => quote = Some(b[j]),
                    (Some(q), c) if c == q => quote = None,
                    (None, b'>') => break,
                    _ => {}
                }
                j += 1;
            }
            let self_closing = j > 0 && j < b.len() && b[j - 1] == b'/';
            if closing {
                depth = depth.saturating_sub(1);
            } else if !self_closing {
                depth += 1;
                if depth > max {
                    return Some(start);
                }
            }
            i = j + 1;
        }
    }
    None
}

/// Loads a scene from COLLADA text; `file` names it in errors.
pub fn load_str(text: &str, file: &str, normal_mode: NormalMode) -> Result<Scene, LoadError> {
    if let Some(at) = too_deep(text, MAX_NESTING) {
        let (line, column) = line_column(&text.as_bytes()[..at]);
        return Err(LoadError::Xml {
            file: file.to_string(),
            line,
            column,
            message: format!("elements nested more than {MAX_NESTING} deep"),
        });
    }
    let doc = Document::parse(text).map_err(|e| {
        // The parser reports an early end of the text at its start; the
        // place to look is where the text ends.
        let (line, column) = match e {
            roxmltree::Error::UnexpectedEndOfStream | roxmltree::Error::UnclosedRootNode => {
                line_column(text.as_bytes())
            }
            _ => (e.pos().row, e.pos().col),
        };
        LoadError::Xml {
            file: file.to_string(),
            line,
            column,
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

impl<'a, 'input> Loader<'a, 'input> {
    fn new(file: &'a str, doc: &'a Document<'input>) -> Self {
        let mut builder = SceneBuilder::new(file);
        let mut ids: HashMap<&'a str, Node<'a, 'input>> = HashMap::new();
        let mut duplicates = Vec::new();
        for n in doc.descendants().filter(|n| n.is_element()) {
            let Some(id) = n.attribute("id") else {
                continue;
            };
            if let Some(first) = ids.insert(id, n) {
                duplicates.push((n, id, first));
            }
        }
        // One line for the file however many ids repeat: the first case,
        // and the count.
        let line = |n: Node| doc.text_pos_at(n.range().start).row;
        if let Some(&(n, id, first)) = duplicates.first() {
            let more = match duplicates.len() {
                1 => String::new(),
                k => format!(" ({} more ids repeat, {k} in all)", k - 1),
            };
            builder.warn(format!(
                "{file}:{}: <{}>: id '{}' was already given at line {}; references use this later one{more}",
                line(n),
                n.tag_name().name(),
                crate::input::quote(id),
                line(first)
            ));
        }
        Loader {
            file,
            doc,
            ids,
            builder,
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
            element: match node.attribute("id") {
                Some(id) => format!(
                    "{} id=\"{}\"",
                    node.tag_name().name(),
                    crate::input::quote(id)
                ),
                None => node.tag_name().name().to_string(),
            },
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
            other => {
                return Err(self.error(
                    axis,
                    format!("unknown up axis '{}'", crate::input::quote(other)),
                ))
            }
        };
        let m = Mat4::from_cols(
            Vec4::new(rows[0][0], rows[1][0], rows[2][0], 0.0),
            Vec4::new(rows[0][1], rows[1][1], rows[2][1], 0.0),
            Vec4::new(rows[0][2], rows[1][2], rows[2][2], 0.0),
            Vec4::W,
        );
        Ok(m)
    }

    /// Whether `attr` is a local reference `#id` to an id the file lacks.
    fn dangling(&self, node: Node<'a, 'input>, attr: &str) -> bool {
        node.attribute(attr)
            .and_then(|v| v.strip_prefix('#'))
            .is_some_and(|id| !self.ids.contains_key(id))
    }

    /// Follows a `url="#id"` or `target="#id"` attribute.
    fn reference(&self, node: Node<'a, 'input>, attr: &str) -> Result<Node<'a, 'input>> {
        let value = node
            .attribute(attr)
            .ok_or_else(|| self.error(node, format!("missing attribute '{attr}'")))?;
        let id = value.strip_prefix('#').ok_or_else(|| {
            self.error(
                node,
                format!(
                    "{attr}=\"{}\" is not a local reference '#id'",
                    crate::input::quote(value)
                ),
            )
        })?;
        self.ids.get(id).copied().ok_or_else(|| {
            self.error(
                node,
                format!(
                    "{attr}=\"{}\" refers to a missing id",
                    crate::input::quote(value)
                ),
            )
        })
    }

    fn load_node(&mut self, node: Node<'a, 'input>, parent: Mat4) -> Result<()> {
        let mut local = Mat4::IDENTITY;
        for c in elements(node) {
            local = match c.tag_name().name() {
                "matrix" => {
                    let mut v = self.floats(c, None)?;
                    if v.len() == 15 {
                        // The glass gems scene's camera: the course's parser
                        // reads the missing bottom-right element as 1.
                        let line = self.doc.text_pos_at(c.range().start).row;
                        self.builder.warn(format!(
                            "{}:{line}: <matrix>: 15 numbers where 16 are expected; the missing last one is taken as 1",
                            self.file
                        ));
                        v.push(1.0);
                    }
                    if v.len() != 16 {
                        return Err(
                            self.error(c, format!("{} numbers where 16 are expected", v.len()))
                        );
                    }
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
                    // Copies of course scenes instance lights that are not
                    // in the file; the course renders them without.
                    match self.reference(c, "url") {
                        Ok(light) => self.load_light(light, node, world)?,
                        Err(e) if self.dangling(c, "url") => self
                            .builder
                            .warn(format!("{e}; the light is left out, as the course leaves it out")),
                        Err(e) => return Err(e),
                    }
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
            let node = inst.parent().unwrap_or(inst);
            return self.load_mesh(mesh, node, world, &bindings);
        }
        if let Some(sphere) = cgl_technique(geometry).and_then(|t| child(t, "sphere")) {
            let radius_el =
                child(sphere, "radius").ok_or_else(|| self.error(sphere, "no <radius>"))?;
            let r = self.floats(radius_el, Some(1))?[0];
            if r <= 0.0 {
                return Err(self.error(radius_el, format!("sphere radius {r} is not positive")));
            }
            let center = world.transform_point3(Vec3::ZERO);
            // In double: the squared length of a huge scale overflows f32.
            let radius = (r as f64 * world.transform_vector3(Vec3::X).as_dvec3().length()) as f32;
            let node = inst.parent().unwrap_or(inst);
            if !(center.is_finite() && radius.is_finite()) {
                return Err(self.error(
                    node,
                    "the node's transform puts the sphere beyond the floating-point range",
                ));
            }
            if radius == 0.0 {
                let line = self.doc.text_pos_at(node.range().start).row;
                self.builder.warn(format!(
                    "{}:{line}: <node>: the transform scales sphere '{}' to radius 0; it is left out",
                    self.file,
                    geometry.attribute("id").unwrap_or("?")
                ));
                return Ok(());
            }
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
