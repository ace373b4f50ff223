//! The scene model: geometry, materials, lights and camera in world space
//! (Y-up), as loaded from a COLLADA file by [`collada`].
//!
//! Primitive ids are global: triangles come first (`0..triangle_count`), then
//! spheres. Both accelerator backends report hits with these ids, and the
//! shading data of a hit are derived here, from the scene, the same way for
//! every backend.

pub mod builder;
pub mod builtin;
pub mod collada;
pub mod environment;
pub mod generate;
mod light;
mod material;

pub use self::light::{AreaLight, Light};
pub use self::material::Material;

use glam::{Mat4, Vec3};

use crate::geom::{gamma, unit, Bounds, Hit, Ray, SpawnPoint};

/// Which normal the shading uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum NormalMode {
    /// Per-vertex normals (area-weighted face normals) interpolated with the
    /// hit's barycentrics: what the reference renders use.
    #[default]
    Smooth,
    /// The geometric normal of the triangle.
    Flat,
}

/// All triangles of the scene in one indexed mesh, in world space.
#[derive(Clone, Debug, Default)]
pub struct TriangleMesh {
    pub positions: Vec<Vec3>,
    pub indices: Vec<[u32; 3]>,
    /// Material index per triangle.
    pub materials: Vec<u32>,
    /// Per-vertex shading normals; empty in [`NormalMode::Flat`].
    pub normals: Vec<Vec3>,
    /// Per-corner shading normals, used instead of `normals` when a crease
    /// angle splits them ([`TriangleMesh::crease`]); empty otherwise.
    pub corner_normals: Vec<[Vec3; 3]>,
}

impl TriangleMesh {
    pub fn len(&self) -> usize {
        self.indices.len()
    }

    pub fn is_empty(&self) -> bool {
        self.indices.is_empty()
    }

    /// The three corners of triangle `i`.
    #[inline]
    pub fn corners(&self, i: usize) -> [Vec3; 3] {
        let [a, b, c] = self.indices[i];
        [
            self.positions[a as usize],
            self.positions[b as usize],
            self.positions[c as usize],
        ]
    }

    /// Unnormalized geometric normal `(v1 - v0) x (v2 - v0)`; its length is
    /// twice the area.
    #[inline]
    pub fn face_normal(&self, i: usize) -> Vec3 {
        let [a, b, c] = self.corners(i);
        (b - a).cross(c - a)
    }

    /// Fills `normals` with the normalized, area-weighted sum of the face
    /// normals around each vertex (summed in double precision: areas of
    /// large scenes overflow `f32` when squared).
    pub fn compute_smooth_normals(&mut self) {
        let mut sums = vec![glam::DVec3::ZERO; self.positions.len()];
        for tri in &self.indices {
            let [a, b, c] = tri.map(|i| self.positions[i as usize].as_dvec3());
            let n = (b - a).cross(c - a);
            for v in tri {
                sums[*v as usize] += n;
            }
        }
        self.normals = sums
            .iter()
            .map(|n| n.normalize_or_zero().as_vec3())
            .collect();
    }

    /// Smooth normals that stop at creases: each corner of a triangle
    /// averages (area-weighted) only the faces around its vertex whose
    /// normals are within `degrees` of the triangle's own, so faces meeting
    /// at a sharper angle keep their own normals (a cube whose faces share
    /// corners stays a cube) while curved surfaces stay smooth.
    pub fn crease(&mut self, degrees: f32) {
        let faces: Vec<glam::DVec3> = (0..self.len())
            .map(|i| {
                let [a, b, c] = self.corners(i).map(|p| p.as_dvec3());
                (b - a).cross(c - a)
            })
            .collect();
        // Faces around each vertex, in compressed rows.
        let mut start = vec![0usize; self.positions.len() + 1];
        for tri in &self.indices {
            for &v in tri {
                start[v as usize + 1] += 1;
            }
        }
        for i in 0..self.positions.len() {
            start[i + 1] += start[i];
        }
        let mut fill = start.clone();
        let mut around = vec![0u32; start[self.positions.len()]];
        for (f, tri) in self.indices.iter().enumerate() {
            for &v in tri {
                around[fill[v as usize]] = f as u32;
                fill[v as usize] += 1;
            }
        }
        let cos_limit = (degrees as f64).to_radians().cos();
        self.corner_normals = (0..self.len())
            .map(|f| {
                let own = faces[f].normalize_or_zero();
                self.indices[f].map(|v| {
                    let v = v as usize;
                    let mut sum = glam::DVec3::ZERO;
                    for &g in &around[start[v]..start[v + 1]] {
                        let n = faces[g as usize];
                        if g as usize == f || n.normalize_or_zero().dot(own) >= cos_limit {
                            sum += n;
                        }
                    }
                    sum.normalize_or_zero().as_vec3()
                })
            })
            .collect();
    }
}

/// An analytic sphere.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    pub center: Vec3,
    pub radius: f32,
    pub material: u32,
}

/// The camera as the file states it; [`crate::render::camera`] turns it into
/// rays with the chosen framing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraSpec {
    /// World transform of the camera node (global up-axis matrix included).
    pub transform: Mat4,
    /// Horizontal and vertical fields of view in degrees.
    pub xfov: f32,
    pub yfov: f32,
}

impl Default for CameraSpec {
    fn default() -> Self {
        CameraSpec {
            transform: Mat4::IDENTITY,
            xfov: 50.0,
            yfov: 50.0,
        }
    }
}

/// A loaded scene.
#[derive(Clone, Debug, Default)]
pub struct Scene {
    /// Where the scene came from (for messages).
    pub name: String,
    pub mesh: TriangleMesh,
    pub spheres: Vec<Sphere>,
    pub materials: Vec<Material>,
    pub lights: Vec<Light>,
    /// The environment map (`-e`), lighting the scene from every direction
    /// rays escape in.
    pub environment: Option<std::sync::Arc<environment::Environment>>,
    pub camera: CameraSpec,
    /// Bounds of the file's meshes and spheres (lights excluded): what the
    /// canonical camera frames.
    pub framing_bounds: Bounds,
    pub normal_mode: NormalMode,
    /// Number of polygons in the file before triangulation.
    pub polygon_count: usize,
    /// Zero-area triangles skipped at load.
    pub degenerate_triangles: usize,
    /// What the loader accepted but a user should know (one line each).
    pub warnings: Vec<String>,
}

/// Shading data of a hit, derived from the scene.
#[derive(Clone, Copy, Debug)]
pub struct SurfacePoint {
    pub position: Vec3,
    /// Bound on the rounding error of each coordinate of `position`.
    pub error: Vec3,
    /// Unit geometric normal (triangle winding / sphere outward).
    pub geometric_normal: Vec3,
    /// Unit shading normal, on the same side as `geometric_normal`.
    pub shading_normal: Vec3,
    pub material: u32,
}

/// A triangle hit's barycentric weights `[w, u, v]` of its corners,
/// clamped into the triangle.
pub fn barycentric_weights(hit: &Hit) -> [f32; 3] {
    let u = hit.u.clamp(0.0, 1.0);
    let v = hit.v.clamp(0.0, 1.0 - u);
    [(1.0 - u - v).max(0.0), u, v]
}

/// The shadow-terminator offset of Hanika ("Hacking the Shadow
/// Terminator", Ray Tracing Gems II, ch. 4, 2021): a point `p` of a
/// triangle with corners `corners`, vertex normals `normals` (facing the
/// side the offset is for) and barycentric weights `weights` moves, for
/// each corner, out of the plane through that corner normal to its normal
/// by as much as it lies below that plane, and the moves are blended by
/// the weights. On a coarse mesh of a smooth object this puts the origin
/// of shadow rays on the curved surface the smooth normals shade, so the
/// facets themselves no longer shadow light that the shading normal says
/// arrives (the "staircase" of dark facets along the terminator). Where
/// the surface is flat or hollow towards that side the offset is zero.
pub fn terminator_lift(p: Vec3, corners: [Vec3; 3], normals: [Vec3; 3], weights: [f32; 3]) -> Vec3 {
    let mut lift = Vec3::ZERO;
    for k in 0..3 {
        let below = (p - corners[k]).dot(normals[k]).min(0.0);
        lift -= normals[k] * (below * weights[k]);
    }
    lift
}

/// How many ulps of a primitive's size the error bound of a surface point
/// allows for the intersection tests' own rounding.
pub const TEST_ULPS: u32 = 12;

impl SurfacePoint {
    /// A placeholder where no point is (a miss's entry in a list of them).
    pub const NONE: SurfacePoint = SurfacePoint {
        position: Vec3::ZERO,
        error: Vec3::ZERO,
        geometric_normal: Vec3::ZERO,
        shading_normal: Vec3::ZERO,
        material: 0,
    };

    /// Where rays leaving this point start (see [`Ray::spawn`]).
    pub fn spawn_point(&self) -> SpawnPoint {
        SpawnPoint {
            p: self.position,
            error: self.error,
            ng: self.geometric_normal,
        }
    }
}

impl Scene {
    pub fn triangle_count(&self) -> usize {
        self.mesh.len()
    }

    pub fn primitive_count(&self) -> usize {
        self.mesh.len() + self.spheres.len()
    }

    /// Bounds of every primitive, light geometry included.
    pub fn bounds(&self) -> Bounds {
        let mut b = Bounds::EMPTY;
        for p in &self.mesh.positions {
            b.grow(*p);
        }
        for s in &self.spheres {
            b.grow(s.center - Vec3::splat(s.radius));
            b.grow(s.center + Vec3::splat(s.radius));
        }
        b
    }

    /// Adds a light for every triangle and sphere whose material emits, so
    /// that light sampling sees the same emitters as hemisphere sampling.
    pub fn add_emitter_lights(&mut self) {
        for (i, s) in self.spheres.iter().enumerate() {
            let radiance = self.materials[s.material as usize].emission();
            if radiance != Vec3::ZERO {
                self.lights.push(Light::Sphere {
                    center: s.center,
                    radius: s.radius,
                    radiance,
                    sphere: i as u32,
                });
            }
        }
        for i in 0..self.mesh.len() {
            let radiance = self.materials[self.mesh.materials[i] as usize].emission();
            if radiance == Vec3::ZERO {
                continue;
            }
            let [a, b, c] = self.mesh.corners(i);
            let n = (b - a).cross(c - a);
            self.lights.push(Light::Area(AreaLight {
                origin: a,
                edge_u: b - a,
                edge_v: c - a,
                triangle: true,
                normal: unit(n),
                radiance,
                area: (0.5 * n.as_dvec3().length()) as f32,
                surface: i as u32,
            }));
        }
    }

    /// Which light each emitting primitive is the surface of: `(primitive,
    /// index into lights)` for emissive triangles and spheres and the
    /// rectangles of area lights.
    pub fn light_surfaces(&self) -> Vec<(u32, usize)> {
        let mut out = Vec::new();
        for (i, l) in self.lights.iter().enumerate() {
            match *l {
                Light::Area(a) if a.surface != AreaLight::NO_SURFACE => {
                    let count = if a.triangle { 1 } else { 2 };
                    out.extend((a.surface..a.surface + count).map(|p| (p, i)));
                }
                Light::Sphere { sphere, .. } => out.push((self.mesh.len() as u32 + sphere, i)),
                _ => {}
            }
        }
        out
    }

    /// The material of primitive `prim`.
    pub fn material_of(&self, prim: u32) -> u32 {
        let p = prim as usize;
        if p < self.mesh.len() {
            self.mesh.materials[p]
        } else {
            self.spheres[p - self.mesh.len()].material
        }
    }

    /// The unit geometric normal at a hit: the triangle's winding
    /// `(v1 - v0) x (v2 - v0)`, or the sphere's outward normal. The one
    /// place it is computed; backends report only where they hit.
    pub fn geometric_normal(&self, ray: &Ray, hit: &Hit) -> Vec3 {
        let p = hit.prim as usize;
        match p.checked_sub(self.mesh.len()) {
            None => unit(self.mesh.face_normal(p)),
            // From the centre to the hit as (o - c) + t d: the point itself,
            // rounded at the scale of its distance from the origin and
            // then differenced, would lose the sphere's own precision far
            // from the origin (at 10^3 units, 1e-3 of a unit sphere's
            // shading; measured by `tests/suite/spheres.rs`).
            Some(s) => unit((ray.origin - self.spheres[s].center) + ray.dir * hit.t),
        }
    }

    /// The shading normals at the corners of triangle `p` (its crease
    /// corners where a crease split them); smooth shading only.
    #[inline]
    pub fn corner_normals(&self, p: usize) -> [Vec3; 3] {
        match self.mesh.corner_normals.get(p) {
            Some(corners) => *corners,
            None => self.mesh.indices[p].map(|i| self.mesh.normals[i as usize]),
        }
    }

    /// Where shadow rays leave a triangle hit at `position` (from
    /// [`Scene::surface_point`]) on the side `facing` (the geometric
    /// normal turned towards the viewer), as an offset from it: the point
    /// lifted onto the smooth surface the vertex normals describe (see
    /// [`terminator_lift`]). Zero on flat shading, spheres, and where the
    /// surface does not bulge towards that side. Asked only where a path
    /// samples lights, not for every hit.
    pub fn shadow_lift(&self, hit: &Hit, position: Vec3, facing: Vec3) -> Vec3 {
        let p = hit.prim as usize;
        if p >= self.mesh.len() || self.normal_mode == NormalMode::Flat {
            return Vec3::ZERO;
        }
        let weights = barycentric_weights(hit);
        let normals = self.corner_normals(p);
        let n = normals[0] * weights[0] + normals[1] * weights[1] + normals[2] * weights[2];
        let normals = if n.dot(facing) < 0.0 {
            normals.map(|x| -x)
        } else {
            normals
        };
        terminator_lift(position, self.mesh.corners(p), normals, weights)
    }

    /// Shading data for `hit` of `ray`. Both backends' hits go through
    /// here, so shading never depends on the backend. The position is
    /// recomputed from the hit rather than taken as `o + t d` (pbrt-v4's
    /// approach): on a triangle from the barycentrics, clamped into the
    /// triangle, so it lies on the triangle's plane within a few ulps
    /// whatever `t`'s error; on a sphere projected onto it. Each comes with
    /// a bound on its rounding error, which the spawn rule steps past.
    pub fn surface_point(&self, ray: &Ray, hit: &Hit) -> SurfacePoint {
        let p = hit.prim as usize;
        if p < self.mesh.len() {
            let [a, b, c] = self.mesh.corners(p);
            let [w, u, v] = barycentric_weights(hit);
            let size = (b - a)
                .abs()
                .max((c - a).abs())
                .max((c - b).abs())
                .max_element();
            let margin = gamma(TEST_ULPS) * size;
            // A hit on an edge lies on the neighbour's plane too (a floor
            // meeting a wall): step it into the triangle, towards the
            // centroid, by twice the test error, so rays leaving it start
            // clear of both surfaces. The shift is invisible (ulps).
            let on_plane = a * w + b * u + c * v;
            let inward = (a + b + c) / 3.0 - on_plane;
            let reach = inward.length();
            let position = if reach > 2.0 * margin {
                on_plane + inward * (2.0 * margin / reach)
            } else {
                on_plane
            };
            // The interpolation's own rounding (pbrt-v4's bound, with two
            // more operations for the step), plus the error of a
            // ray/triangle test started at the point: the t of a ray
            // leaving the plane is off by a few ulps of the triangle's
            // size, so a ray must start farther off than that not to find
            // its own triangle again at t ~ 0.
            let error =
                gamma(9) * ((a * w).abs() + (b * u).abs() + (c * v).abs()) + Vec3::splat(margin);
            let ng = self.geometric_normal(ray, hit);
            let ns = match self.normal_mode {
                NormalMode::Flat => ng,
                NormalMode::Smooth => {
                    let [na, nb, nc] = self.corner_normals(p);
                    let n = (na * w + nb * u + nc * v).normalize_or_zero();
                    if n == Vec3::ZERO {
                        ng
                    } else if n.dot(ng) < 0.0 {
                        -n
                    } else {
                        n
                    }
                }
            };
            SurfacePoint {
                position,
                error,
                geometric_normal: ng,
                shading_normal: ns,
                material: self.mesh.materials[p],
            }
        } else {
            let s = &self.spheres[p - self.mesh.len()];
            let n = self.geometric_normal(ray, hit);
            let position = s.center + n * s.radius;
            // The projection's rounding, and the sphere test's error in t
            // for a ray started at the point (a few ulps of the radius and
            // of the centre's magnitude).
            let error = Vec3::splat(gamma(TEST_ULPS) * (s.center.abs().max_element() + s.radius));
            SurfacePoint {
                position,
                error,
                geometric_normal: n,
                shading_normal: n,
                material: s.material,
            }
        }
    }

    /// One paragraph describing the scene.
    pub fn summary(&self) -> String {
        let count = |list: &[&str]| -> String {
            let mut out: Vec<(String, usize)> = Vec::new();
            for k in list {
                match out.iter_mut().find(|(name, _)| name == k) {
                    Some(e) => e.1 += 1,
                    None => out.push((k.to_string(), 1)),
                }
            }
            // Kinds that are nouns take a plural ("2 emissive triangles");
            // the adjectives ("3 lambertian", "1 area") stand as they are.
            out.iter()
                .map(|(k, n)| {
                    let noun = k.ends_with("triangle") || k.ends_with("sphere");
                    format!("{n} {k}{}", if noun && *n != 1 { "s" } else { "" })
                })
                .collect::<Vec<_>>()
                .join(", ")
        };
        let light_kinds: Vec<&str> = self.lights.iter().map(|l| l.kind()).collect();
        let material_kinds: Vec<&str> = self.materials.iter().map(|m| m.kind()).collect();
        let b = self.framing_bounds;
        let environment = match &self.environment {
            Some(e) => format!(
                "; environment map {} ({} x {}, sampled {})",
                e.name,
                e.size().0,
                e.size().1,
                match e.sampling {
                    environment::EnvSampling::Importance => "by luminance",
                    environment::EnvSampling::Uniform => "uniformly",
                }
            ),
            None => String::new(),
        };
        format!(
            "scene {}: {} primitives ({} triangles from {} polygons{}, {} spheres); {} lights ({}){environment}; {} materials ({}); bounds [{:.3} {:.3} {:.3}] .. [{:.3} {:.3} {:.3}]; {} normals",
            self.name,
            self.primitive_count(),
            self.triangle_count(),
            self.polygon_count,
            if self.degenerate_triangles > 0 { format!(", {} zero-area triangles skipped", self.degenerate_triangles) } else { String::new() },
            self.spheres.len(),
            self.lights.len(),
            if self.lights.is_empty() { "none".into() } else { count(&light_kinds) },
            self.materials.len(),
            count(&material_kinds),
            b.min.x,
            b.min.y,
            b.min.z,
            b.max.x,
            b.max.y,
            b.max.z,
            match self.normal_mode {
                NormalMode::Smooth => "smooth",
                NormalMode::Flat => "flat",
            }
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_keeps_the_direction_of_any_finite_vector() {
        let dirs = [
            Vec3::new(3.0, -4.0, 12.0),
            Vec3::new(1e-3, 2.0, -0.5),
            Vec3::X,
        ];
        for d in dirs {
            let want = d.normalize();
            // Ordinary, overflowing when squared, underflowing when squared.
            for scale in [1.0, 1e25, 1e-25, 3e38 / d.abs().max_element()] {
                let u = unit(d * scale);
                assert!(
                    (u - want).abs().max_element() < 1e-6,
                    "unit({:?}) = {u:?}, want {want:?}",
                    d * scale
                );
            }
        }
        for bad in [
            Vec3::ZERO,
            Vec3::new(f32::NAN, 1.0, 0.0),
            Vec3::new(0.0, f32::INFINITY, 1.0),
        ] {
            assert_eq!(unit(bad), Vec3::ZERO, "unit({bad:?})");
        }
    }
}
