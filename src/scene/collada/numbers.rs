//! The numbers inside elements: floats (finite only), vectors, indices.

use glam::Vec3;
use roxmltree::Node;

use super::{Loader, Result};

impl<'a, 'input> Loader<'a, 'input> {
    /// The numbers of `node`'s text; `expected` (from the file, so never
    /// trusted to size memory) must match their count.
    pub(super) fn floats(&self, node: Node, expected: Option<usize>) -> Result<Vec<f32>> {
        let text = node.text().unwrap_or("");
        // A number takes at least two characters with its separator.
        let mut out = Vec::with_capacity(expected.unwrap_or(0).min(text.len() / 2 + 1));
        for token in text.split_ascii_whitespace() {
            let v: f32 = token.parse().map_err(|_| {
                self.error(
                    node,
                    format!("'{}' is not a number", crate::input::quote(token)),
                )
            })?;
            if !v.is_finite() {
                return Err(self.error(
                    node,
                    format!("non-finite number '{}'", crate::input::quote(token)),
                ));
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

    pub(super) fn vec3(&self, node: Node) -> Result<Vec3> {
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

    /// A colour (radiance, intensity, albedo, reflectance): three numbers,
    /// each finite, not negative and at most [`MAX_COLOUR`]. A negative
    /// light or albedo would put negative radiance in the image, and one
    /// near the float range infinite pixels; the environment map's loader
    /// refuses the same values.
    pub(super) fn colour(&self, node: Node) -> Result<Vec3> {
        let c = self.vec3(node)?;
        if c.to_array().iter().all(|x| (0.0..=MAX_COLOUR).contains(x)) {
            return Ok(c);
        }
        Err(self.error(
            node,
            format!(
                "colour {} {} {}: each number must be finite, not negative and at most {MAX_COLOUR:e}",
                c.x, c.y, c.z
            ),
        ))
    }

    pub(super) fn integers(&self, node: Node) -> Result<Vec<u32>> {
        node.text()
            .unwrap_or("")
            .split_ascii_whitespace()
            .map(|t| {
                t.parse::<u32>().map_err(|_| {
                    self.error(
                        node,
                        format!("'{}' is not an index", crate::input::quote(t)),
                    )
                })
            })
            .collect()
    }
}

/// The largest colour component a scene may give: far above any real
/// light or albedo, and far enough below the float range that a path's
/// throughput over a sample's density stays finite.
pub const MAX_COLOUR: f32 = 1e18;
