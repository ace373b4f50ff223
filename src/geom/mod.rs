//! The shared vocabulary every layer above builds on: boxes, rays, hits,
//! spawn points, rounding-error bounds, random numbers and sampling warps.
//! It imports nothing of the project, so the scene, the accelerators and
//! the renderer each import only downwards (pbrt-v4's `util/`).

pub mod bounds;
pub mod ray;
pub mod sampling;
pub mod vector;

pub use self::bounds::Bounds;
pub use self::ray::{Hit, Ray, SpawnPoint};
pub use self::vector::{gamma, unit};
