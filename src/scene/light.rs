//! The lights of a scene, as placed in world space by the loader; how each
//! is sampled is `render::light`.

use glam::Vec3;

/// A planar emitter that light sampling can pick points on: a parallelogram
/// (the file's rectangular area lights) or a triangle (emissive meshes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AreaLight {
    /// A corner of the shape.
    pub origin: Vec3,
    pub edge_u: Vec3,
    pub edge_v: Vec3,
    /// True for a triangle `origin, origin + edge_u, origin + edge_v`.
    pub triangle: bool,
    /// Unit normal of the emitting side.
    pub normal: Vec3,
    pub radiance: Vec3,
    pub area: f32,
    /// The first of the mesh triangles that are this light's surface (one
    /// for a triangle, two for a rectangle), [`AreaLight::NO_SURFACE`] until
    /// the builder adds them.
    pub surface: u32,
}

impl AreaLight {
    pub const NO_SURFACE: u32 = u32::MAX;

    /// The point at `(s, t)` in the unit square, mapped uniformly onto the
    /// shape (triangles use the square-root warp, pbrt-v4 §A.5.5).
    #[inline]
    pub fn point_at(&self, s: f32, t: f32) -> Vec3 {
        if self.triangle {
            let r = s.sqrt();
            self.origin + self.edge_u * (r * (1.0 - t)) + self.edge_v * (r * t)
        } else {
            self.origin + self.edge_u * s + self.edge_v * t
        }
    }
}

/// The lights of `scene-format.md`, with the project's physically consistent
/// choices (point lights fall off with 1/r²).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Light {
    Area(AreaLight),
    /// Intensity `intensity` (W/sr per channel) at `position`.
    Point {
        position: Vec3,
        intensity: Vec3,
    },
    /// Irradiance `radiance` on a surface facing `to_light`.
    Directional {
        to_light: Vec3,
        radiance: Vec3,
    },
    /// A sphere whose material emits `radiance` outwards, sampled
    /// uniformly by area.
    Sphere {
        center: Vec3,
        radius: f32,
        radiance: Vec3,
        /// Index of the sphere in the scene's spheres.
        sphere: u32,
    },
    /// Uniform radiance arriving from the world's +Y hemisphere.
    Ambient {
        radiance: Vec3,
    },
}

impl Light {
    pub fn kind(&self) -> &'static str {
        match self {
            Light::Area(l) if l.triangle => "emissive triangle",
            Light::Sphere { .. } => "emissive sphere",
            Light::Area(_) => "area",
            Light::Point { .. } => "point",
            Light::Directional { .. } => "directional",
            Light::Ambient { .. } => "ambient",
        }
    }

    /// True when the light gives no light at all (all channels zero).
    pub fn is_dark(&self) -> bool {
        let power = match self {
            Light::Area(l) => l.radiance,
            Light::Point { intensity, .. } => *intensity,
            Light::Directional { radiance, .. }
            | Light::Sphere { radiance, .. }
            | Light::Ambient { radiance } => *radiance,
        };
        power.max_element() <= 0.0
    }

    /// True for lights with a delta distribution, which take one sample.
    pub fn is_delta(&self) -> bool {
        matches!(self, Light::Point { .. } | Light::Directional { .. })
    }
}
