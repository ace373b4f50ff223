//! [`SceneBuilder`]: how every scene is assembled and finished, whether it
//! comes from a COLLADA file (`collada.rs`) or from code (`generate.rs`).
//! Finishing happens here only, in one order: scaling into the range both
//! backends trace exactly, framing bounds (meshes and spheres), lights for
//! emissive triangles and spheres, the rectangles of area lights as
//! geometry, then shading normals.

use glam::{Mat4, Vec3};

use super::{AreaLight, Bounds, CameraSpec, Light, Material, NormalMode, Scene, Sphere};

/// Coordinates up to this magnitude (and down to its inverse) are used as
/// they are; see [`SceneBuilder::finish`].
pub const RANGE: f32 = (1u64 << 40) as f32;

/// Whether triangle `t` lies in the plane of the rectangle of `light`
/// (within 1e-4 of its size) with its centroid inside the rectangle.
fn on_rectangle(light: &AreaLight, t: &[Vec3; 3]) -> bool {
    let (u, v) = (light.edge_u, light.edge_v);
    let size = u.length().max(v.length());
    let tolerance = 1e-4 * size;
    let off_plane = |p: Vec3| (p - light.origin).dot(light.normal).abs();
    if t.iter().any(|&p| !(off_plane(p) <= tolerance)) {
        return false;
    }
    let centroid = (t[0] + t[1] + t[2]) / 3.0 - light.origin;
    let s = centroid.dot(u) / u.length_squared();
    let r = centroid.dot(v) / v.length_squared();
    (-1e-4..=1.0 + 1e-4).contains(&s) && (-1e-4..=1.0 + 1e-4).contains(&r)
}

/// Builds a [`Scene`] piece by piece.
pub struct SceneBuilder {
    scene: Scene,
}

impl SceneBuilder {
    pub fn new(name: &str) -> SceneBuilder {
        let scene = Scene {
            name: name.to_string(),
            ..Scene::default()
        };
        SceneBuilder { scene }
    }

    /// Adds a material; returns its index.
    pub fn material(&mut self, m: Material) -> u32 {
        self.scene.materials.push(m);
        self.scene.materials.len() as u32 - 1
    }

    /// Adds world-space vertices; returns the index of the first.
    pub fn vertices(&mut self, positions: impl IntoIterator<Item = Vec3>) -> u32 {
        let base = self.scene.mesh.positions.len() as u32;
        self.scene.mesh.positions.extend(positions);
        base
    }

    /// Adds a triangle of a file's polygon (indices into the vertices
    /// added so far). Zero-area triangles (collinear corners, as in
    /// `basic/plane1024.dae`'s T-junctions) can never be hit and have no
    /// normal: they are skipped and counted, not loaded.
    pub fn face(&mut self, corners: [u32; 3], material: u32) {
        let [a, b, c] = corners.map(|i| self.scene.mesh.positions[i as usize]);
        // In double: the squared area of a tiny (or huge) triangle leaves
        // the f32 range before the scene is scaled into range.
        let (a, b, c) = (a.as_dvec3(), b.as_dvec3(), c.as_dvec3());
        if (b - a).cross(c - a).length_squared() == 0.0 {
            self.scene.degenerate_triangles += 1;
            return;
        }
        self.scene.mesh.indices.push(corners);
        self.scene.mesh.materials.push(material);
    }

    /// Records a warning for the user (one line).
    pub fn warn(&mut self, message: impl Into<String>) {
        self.scene.warnings.push(message.into());
    }

    /// Counts polygons as the file states them (before triangulation).
    pub fn polygons(&mut self, count: usize) {
        self.scene.polygon_count += count;
    }

    /// Adds triangles (indices into `positions`) with one material, exactly
    /// as given: generated test scenes keep their degenerate triangles.
    pub fn mesh(&mut self, positions: &[Vec3], triangles: &[[u32; 3]], material: u32) -> &mut Self {
        let base = self.vertices(positions.iter().copied());
        for t in triangles {
            self.scene
                .mesh
                .indices
                .push([t[0] + base, t[1] + base, t[2] + base]);
            self.scene.mesh.materials.push(material);
        }
        self.polygons(triangles.len());
        self
    }

    pub fn sphere(&mut self, center: Vec3, radius: f32, material: u32) -> &mut Self {
        self.scene.spheres.push(Sphere {
            center,
            radius,
            material,
        });
        self
    }

    pub fn light(&mut self, light: Light) -> &mut Self {
        self.scene.lights.push(light);
        self
    }

    pub fn camera_spec(&mut self, spec: CameraSpec) -> &mut Self {
        self.scene.camera = spec;
        self
    }

    /// A camera at `position` looking at `target` (node placement).
    pub fn camera(&mut self, position: Vec3, target: Vec3, xfov: f32, yfov: f32) -> &mut Self {
        let view = Mat4::look_at_rh(position, target, Vec3::Y);
        self.camera_spec(CameraSpec {
            transform: view.inverse(),
            xfov,
            yfov,
        })
    }

    /// Finishes the scene (see the module documentation for the order).
    pub fn finish(mut self, normal_mode: NormalMode) -> Scene {
        self.scale_into_range();
        let scene = &mut self.scene;
        scene.framing_bounds = scene.bounds();
        if scene.framing_bounds.is_empty() {
            scene.framing_bounds = Bounds {
                min: Vec3::splat(-1.0),
                max: Vec3::splat(1.0),
            };
        }
        scene.add_emitter_lights();
        if scene.primitive_count() == 0 {
            scene.warnings.push(format!(
                "{}: the scene has no geometry: every ray misses",
                scene.name
            ));
        }
        if scene.lights.is_empty() {
            scene.warnings.push(format!(
                "{}: the scene has no lights and nothing emits: path-traced images are black unless -e MAP.exr lights it (--normals still shows the geometry)",
                scene.name
            ));
        } else if scene.lights.iter().all(Light::is_dark) {
            let kinds: Vec<&str> = scene.lights.iter().map(Light::kind).collect();
            scene.warnings.push(format!(
                "{}: every light emits nothing ({} of radiance 0 0 0): path-traced images are black unless -e MAP.exr lights it (a sky: cargo run --release --example sky_map -- sky.exr)",
                scene.name,
                kinds.join(", ")
            ));
        }
        self.add_light_rectangles();
        let scene = &mut self.scene;
        scene.normal_mode = normal_mode;
        if normal_mode == NormalMode::Smooth {
            scene.mesh.compute_smooth_normals();
        }
        self.scene
    }

    /// Scenes whose coordinates reach beyond [`RANGE`] (or stay below its
    /// inverse) are scaled by a power of two, which is exact in floating
    /// point, so that their largest coordinate lies in [2^20, 2^21): Embree
    /// aborts on rays beyond 1.8e18 and both backends lose precision in
    /// squared magnitudes long before (a scene at 1e16 rendered wrong on
    /// both). Images do not change: point lights keep their irradiance
    /// (intensity scaled by the square), directions are untouched.
    fn scale_into_range(&mut self) {
        let s = &mut self.scene;
        let mut m = 0.0f32;
        let mut see = |p: Vec3| m = m.max(p.abs().max_element());
        s.mesh.positions.iter().for_each(|&p| see(p));
        for sp in &s.spheres {
            see(sp.center.abs() + sp.radius);
        }
        for l in &s.lights {
            match *l {
                Light::Area(a) => {
                    see(a.origin);
                    see(a.origin + a.edge_u + a.edge_v);
                }
                Light::Point { position, .. } => see(position),
                _ => {}
            }
        }
        see(s.camera.transform.w_axis.truncate());
        if !(m > 0.0) || !m.is_finite() || (1.0 / RANGE..=RANGE).contains(&m) {
            return;
        }
        // m = f 2^e with f in [1, 2): scale by 2^(20 - e), exact in f64.
        let e = m.log2().floor() as i32;
        let k = 20 - e;
        let scale = 2f64.powi(k);
        let by = |x: f32| (x as f64 * scale) as f32;
        let v = |p: Vec3| Vec3::new(by(p.x), by(p.y), by(p.z));
        for p in &mut s.mesh.positions {
            *p = v(*p);
        }
        for sp in &mut s.spheres {
            sp.center = v(sp.center);
            sp.radius = by(sp.radius);
        }
        let square = |x: f32| (x as f64 * scale * scale) as f32;
        for l in &mut s.lights {
            match l {
                Light::Area(a) => {
                    a.origin = v(a.origin);
                    a.edge_u = v(a.edge_u);
                    a.edge_v = v(a.edge_v);
                    a.area = (a.edge_u.as_dvec3().length() * a.edge_v.as_dvec3().length()) as f32;
                }
                Light::Point {
                    position,
                    intensity,
                } => {
                    *position = v(*position);
                    *intensity = Vec3::new(
                        square(intensity.x),
                        square(intensity.y),
                        square(intensity.z),
                    );
                }
                _ => {}
            }
        }
        s.camera.transform = Mat4::from_scale(Vec3::splat(scale as f32)) * s.camera.transform;
        s.warnings.push(format!(
            "{}: coordinates reach {m:.3e}, beyond the range both backends trace exactly (2^-40..2^40); the scene is scaled by 2^{k} (exactly), which leaves the image unchanged",
            s.name
        ));
    }

    /// Adds the rectangles of area lights as geometry (two triangles each,
    /// wound so that the geometric normal is the emitting side) with an
    /// emission material of the light's radiance, so camera rays and
    /// bounces see them. They come after the emitter lights of the file's
    /// own emissive triangles, since each rectangle already is a light.
    ///
    /// An area light whose rectangle the file already covers with emissive
    /// triangles (the course's coil scene models its lamp both ways) is
    /// dropped with a warning: its rectangle would lie in the same plane as
    /// that geometry, a tie each backend breaks its own way, and sampling
    /// both would count the lamp twice. The file's geometry is the light.
    fn add_light_rectangles(&mut self) {
        let emissive: Vec<[Vec3; 3]> = (0..self.scene.mesh.len())
            .filter(|&i| {
                let m = self.scene.mesh.materials[i] as usize;
                self.scene.materials[m].emission() != Vec3::ZERO
            })
            .map(|i| self.scene.mesh.corners(i))
            .collect();
        let mut doubled = Vec::new();
        self.scene.lights.retain(|l| match l {
            Light::Area(a) if !a.triangle => {
                let covering = emissive.iter().filter(|t| on_rectangle(a, t)).count();
                if covering > 0 {
                    doubled.push((a.origin + (a.edge_u + a.edge_v) * 0.5, covering));
                }
                covering == 0
            }
            _ => true,
        });
        for (centre, covering) in doubled {
            let message = format!(
                "{}: the area light centred at ({:.3}, {:.3}, {:.3}) lies on {covering} emissive triangles of the file; the light is left out and those triangles are the light",
                self.scene.name, centre.x, centre.y, centre.z
            );
            self.warn(message);
        }
        let quads: Vec<(usize, AreaLight)> = self
            .scene
            .lights
            .iter()
            .enumerate()
            .filter_map(|(i, l)| match l {
                Light::Area(a) if !a.triangle => Some((i, *a)),
                _ => None,
            })
            .collect();
        for (light, quad) in quads {
            if let Light::Area(a) = &mut self.scene.lights[light] {
                a.surface = self.scene.mesh.len() as u32;
            }
            let material = self.material(Material::Emission {
                radiance: quad.radiance,
            });
            let (o, u, v) = (quad.origin, quad.edge_u, quad.edge_v);
            let flip = u.cross(v).dot(quad.normal) < 0.0;
            let base = self.vertices([o, o + u, o + u + v, o + v]);
            for tri in [[0, 1, 2], [0, 2, 3]] {
                let t = if flip { [tri[0], tri[2], tri[1]] } else { tri };
                self.scene
                    .mesh
                    .indices
                    .push([base + t[0], base + t[1], base + t[2]]);
                self.scene.mesh.materials.push(material);
            }
        }
    }
}
