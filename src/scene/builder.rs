//! [`SceneBuilder`]: how every scene is assembled and finished, whether it
//! comes from a COLLADA file (`collada.rs`) or from code (`generate.rs`).
//! Finishing happens here only, in one order: framing bounds (meshes and
//! spheres), lights for emissive triangles and spheres, the rectangles of
//! area lights as geometry, then shading normals.

use glam::{Mat4, Vec3};

use super::{AreaLight, Bounds, CameraSpec, Light, Material, NormalMode, Scene, Sphere};

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
        if (b - a).cross(c - a).length_squared() == 0.0 {
            self.scene.degenerate_triangles += 1;
            return;
        }
        self.scene.mesh.indices.push(corners);
        self.scene.mesh.materials.push(material);
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
        let scene = &mut self.scene;
        scene.framing_bounds = scene.bounds();
        if scene.framing_bounds.is_empty() {
            scene.framing_bounds = Bounds {
                min: Vec3::splat(-1.0),
                max: Vec3::splat(1.0),
            };
        }
        scene.add_emitter_lights();
        self.add_light_rectangles();
        let scene = &mut self.scene;
        scene.normal_mode = normal_mode;
        if normal_mode == NormalMode::Smooth {
            scene.mesh.compute_smooth_normals();
        }
        self.scene
    }

    /// Adds the rectangles of area lights as geometry (two triangles each,
    /// wound so that the geometric normal is the emitting side) with an
    /// emission material of the light's radiance, so camera rays and
    /// bounces see them. They come after the emitter lights of the file's
    /// own emissive triangles, since each rectangle already is a light.
    fn add_light_rectangles(&mut self) {
        let quads: Vec<AreaLight> = self
            .scene
            .lights
            .iter()
            .filter_map(|l| match l {
                Light::Area(a) if !a.triangle => Some(*a),
                _ => None,
            })
            .collect();
        for quad in quads {
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
