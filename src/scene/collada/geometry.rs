//! Meshes: `source` arrays with their accessors, and `polylist` /
//! `triangles` primitives triangulated as fans into the scene builder.

use std::collections::HashMap;

use glam::{Mat4, Vec3};
use roxmltree::Node;

use super::{child, elements, Loader, Result};

/// Inputs of one index layout (offsets 0..MAX_INPUTS); the dialect uses up
/// to three.
const MAX_INPUTS: usize = 64;

/// A `source` of a mesh: its numbers and accessor stride.
pub(super) struct Source {
    values: Vec<f32>,
    stride: usize,
}

impl<'a, 'input> Loader<'a, 'input> {
    /// Loads `mesh` as instanced by `node` (whose transform is `world`).
    pub(super) fn load_mesh(
        &mut self,
        mesh: Node<'a, 'input>,
        node: Node<'a, 'input>,
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
                "polylist" | "triangles" => self.load_polygons(prim, node, &sources, &vertices, world, bindings)?,
                other => {
                    return Err(self.error(prim, format!("unsupported mesh primitive <{other}> (the dialect has polylist and triangles)")))
                }
            }
        }
        Ok(())
    }

    pub(super) fn source(&self, source: Node) -> Result<Source> {
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
            if c.checked_mul(stride).is_none_or(|n| n > values.len()) {
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

    pub(super) fn count_attr(&self, node: Node) -> Result<usize> {
        let c = node
            .attribute("count")
            .ok_or_else(|| self.error(node, "missing attribute 'count'"))?;
        c.trim()
            .parse()
            .map_err(|_| self.error(node, format!("count=\"{c}\" is not a number")))
    }

    pub(super) fn load_polygons(
        &mut self,
        prim: Node<'a, 'input>,
        node: Node<'a, 'input>,
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
            if offset >= MAX_INPUTS {
                return Err(self.error(
                    input,
                    format!("offset {offset}: an index layout has at most {MAX_INPUTS} inputs"),
                ));
            }
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
        // Polygon sizes: listed for a polylist, all 3 for triangles (never
        // allocated from the file's count).
        let listed: Option<Vec<u32>> = if prim.tag_name().name() == "polylist" {
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
            Some(v)
        } else {
            None
        };
        let corners = match &listed {
            Some(v) => v
                .iter()
                .try_fold(0usize, |acc, &n| acc.checked_add(n as usize)),
            None => count.checked_mul(3),
        };
        let expected = corners.and_then(|c| c.checked_mul(stride));
        if expected != Some(indices.len()) {
            return Err(self.error(
                p_el,
                format!(
                    "{} indices, but count=\"{count}\" polygons x {stride} inputs need {}",
                    indices.len(),
                    expected.map_or("more than can be counted".into(), |n| n.to_string())
                ),
            ));
        }
        let sizes: Box<dyn Iterator<Item = u32>> = match listed {
            Some(v) => Box::new(v.into_iter()),
            None => Box::new(std::iter::repeat_n(3, count)),
        };
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
        let world_positions: Vec<Vec3> = positions
            .values
            .chunks_exact(positions.stride)
            .map(|v| world.transform_point3(Vec3::new(v[0], v[1], v[2])))
            .collect();
        if let Some(bad) = world_positions.iter().position(|p| !p.is_finite()) {
            return Err(self.error(
                node,
                format!("the node's transform takes vertex {bad} of <{}> beyond the floating-point range", prim.tag_name().name()),
            ));
        }
        let base = self.builder.vertices(world_positions);
        let mut cursor = 0usize;
        let mut polygons = 0;
        for n in sizes {
            let corner = |c: usize| base + indices[(cursor + c) * stride + vertex_offset];
            for c in 1..(n as usize - 1) {
                self.builder
                    .face([corner(0), corner(c), corner(c + 1)], material);
            }
            cursor += n as usize;
            polygons += 1;
        }
        self.builder.polygons(polygons);
        Ok(())
    }
}
