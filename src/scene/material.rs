//! What a surface is made of, as the file states it (`scene-format.md`,
//! Materials); how each one scatters is `render::material`.

use glam::Vec3;

/// How a surface scatters or emits light (`scene-format.md`, Materials).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Material {
    /// Diffuse reflection. `emission` (one-sided, front face) is zero for
    /// every file; generated scenes such as the white furnace use it.
    Lambertian {
        albedo: Vec3,
        emission: Vec3,
    },
    Emission {
        radiance: Vec3,
    },
    Mirror {
        reflectance: Vec3,
    },
    Glass {
        reflectance: Vec3,
        transmittance: Vec3,
        roughness: f32,
        ior: f32,
    },
    Refraction {
        transmittance: Vec3,
        roughness: f32,
        ior: f32,
    },
    /// Rough conductor: Beckmann roughness `alpha`, complex IOR `eta + i k`.
    Microfacet {
        alpha: f32,
        eta: Vec3,
        k: Vec3,
    },
}

impl Material {
    /// Albedo used where a file gives no material.
    pub const DEFAULT: Material = Material::Lambertian {
        albedo: Vec3::splat(0.5),
        emission: Vec3::ZERO,
    };

    /// A Lambertian material that does not emit.
    pub fn lambertian(albedo: Vec3) -> Material {
        Material::Lambertian {
            albedo,
            emission: Vec3::ZERO,
        }
    }

    /// Radiance emitted from the front face.
    pub fn emission(&self) -> Vec3 {
        match *self {
            Material::Emission { radiance } => radiance,
            Material::Lambertian { emission, .. } => emission,
            Material::Mirror { .. }
            | Material::Glass { .. }
            | Material::Refraction { .. }
            | Material::Microfacet { .. } => Vec3::ZERO,
        }
    }

    /// Short name for summaries.
    pub fn kind(&self) -> &'static str {
        match self {
            Material::Lambertian { .. } => "lambertian",
            Material::Emission { .. } => "emission",
            Material::Mirror { .. } => "mirror",
            Material::Glass { .. } => "glass",
            Material::Refraction { .. } => "refraction",
            Material::Microfacet { .. } => "microfacet",
        }
    }
}
