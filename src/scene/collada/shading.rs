//! Materials (CGL techniques or the common Phong diffuse colour), lights
//! and the camera.

use glam::{Mat4, Vec3};
use roxmltree::Node;

use super::{cgl_technique, child, elements, Loader, Result};
use crate::geom::unit;
use crate::scene::{AreaLight, CameraSpec, Light, Material};

impl<'a, 'input> Loader<'a, 'input> {
    /// Index of the material that `material` (a `<material>` element) names,
    /// loading it on first use.
    pub(super) fn material(&mut self, material: Node<'a, 'input>) -> Result<u32> {
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

    pub(super) fn effect(&self, effect: Node) -> Result<Material> {
        if let Some(kind) = cgl_technique(effect).and_then(|t| elements(t).next()) {
            let colour = |name: &str| -> Result<Vec3> {
                self.colour(
                    child(kind, name).ok_or_else(|| self.error(kind, format!("no <{name}>")))?,
                )
            };
            // The complex index of refraction is no colour: only finite.
            let index = |name: &str| -> Result<Vec3> {
                let el =
                    child(kind, name).ok_or_else(|| self.error(kind, format!("no <{name}>")))?;
                let v = self.vec3(el)?;
                if v.is_finite() {
                    Ok(v)
                } else {
                    Err(self.error(el, format!("<{name}> {v} is not finite")))
                }
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
                    eta: index("eta")?,
                    k: index("k")?,
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
            // `color` is r g b a; the alpha is not read.
            Some(c) => Ok(Material::lambertian(self.colour(c)?)),
            None => Ok(Material::DEFAULT),
        }
    }

    /// Loads `light` as placed by `node` (whose transform is `world`);
    /// problems of the placement are reported at the node.
    pub(super) fn load_light(&mut self, light: Node, node: Node, world: Mat4) -> Result<()> {
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
        let color = self.colour(color_el)?;
        let at = |p: Vec3| world.transform_point3(p);
        let light = match kind.tag_name().name() {
            "area" => {
                let c = at(Vec3::ZERO);
                let normal = unit(at(Vec3::new(0.0, 0.0, -1.0)) - c);
                let dim_y = at(Vec3::Y) - c;
                let dim_x = at(Vec3::new(-1.0, 0.0, 0.0)) - c;
                // In double: for huge scenes (scaled into range at the end)
                // the product of two edge lengths overflows f32.
                let area = dim_x.as_dvec3().length() * dim_y.as_dvec3().length();
                if normal == Vec3::ZERO
                    || !(area > 0.0)
                    || !(c.is_finite() && dim_x.is_finite() && dim_y.is_finite())
                {
                    return Err(self.error(
                        node,
                        format!(
                            "the node's transform gives area light '{}' no area or direction (a singular or non-finite matrix)",
                            light.attribute("id").unwrap_or("?")
                        ),
                    ));
                }
                Light::Area(AreaLight {
                    origin: c - dim_x * 0.5 - dim_y * 0.5,
                    edge_u: dim_x,
                    edge_v: dim_y,
                    triangle: false,
                    normal,
                    radiance: color,
                    area: area as f32,
                    surface: AreaLight::NO_SURFACE,
                })
            }
            "point" => {
                let position = at(Vec3::ZERO);
                if !position.is_finite() {
                    return Err(self.error(
                        node,
                        "the node's transform puts the point light beyond the floating-point range",
                    ));
                }
                Light::Point {
                    position,
                    intensity: color,
                }
            }
            "directional" => {
                let to_light = unit(at(Vec3::new(0.0, 0.0, -1.0)));
                if to_light == Vec3::ZERO || !to_light.is_finite() {
                    return Err(self.error(
                        node,
                        "the node's transform gives the directional light no direction",
                    ));
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

    pub(super) fn load_camera(&self, camera: Node, world: Mat4) -> Result<CameraSpec> {
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
        if let Some(a) = aspect {
            if !(a > 0.0) {
                let el = child(persp, "aspect_ratio").unwrap_or(persp);
                return Err(self.error(el, format!("aspect_ratio {a} is not positive")));
            }
        }
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
        if !world.is_finite() {
            return Err(self.error(camera, "the camera node's transform is not finite"));
        }
        Ok(CameraSpec {
            transform: world,
            xfov: x,
            yfov: y,
        })
    }
}
