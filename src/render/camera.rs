//! The pinhole camera: image position -> camera space on the plane z = -1
//! (fields of view) -> world space.
//!
//! Framing (`scene-format.md`, Camera): the canonical mode reproduces the
//! reference renders (look at the centre of the scene's bounds from
//! `1.5 * |extent|` along the camera node's direction); the node mode uses
//! the node's own placement. In both, the image aspect wins over the file's:
//! the field of view of the side that is relatively narrower is widened, so
//! the file's view always fits in the image.

use glam::{Mat4, Vec3};

use crate::accel::Ray;
use crate::scene::{CameraSpec, Scene};

/// Where the camera stands: the reference framing or the node's own.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum CameraMode {
    #[default]
    Canonical,
    Node,
}

crate::choice!(CameraMode { Canonical => "canonical", Node => "node" });

#[derive(Clone, Copy, Debug)]
pub struct Camera {
    pub position: Vec3,
    /// Camera-to-world axes: right, up, and backward (camera looks along -z).
    right: Vec3,
    up: Vec3,
    back: Vec3,
    tan_half_x: f32,
    tan_half_y: f32,
    width: u32,
    height: u32,
}

impl Camera {
    pub fn new(scene: &Scene, mode: CameraMode, width: u32, height: u32) -> Camera {
        let spec = &scene.camera;
        let (position, forward, up_hint) = match mode {
            CameraMode::Canonical => {
                let b = scene.framing_bounds;
                let target = b.center();
                let d = spec
                    .transform
                    .transform_point3(Vec3::new(0.0, 0.0, -1.0))
                    .normalize_or(Vec3::Z);
                let position = target + d * 1.5 * b.extent().length();
                (
                    position,
                    (target - position).normalize_or(-Vec3::Z),
                    Vec3::Y,
                )
            }
            CameraMode::Node => {
                let t: &Mat4 = &spec.transform;
                let position = t.transform_point3(Vec3::ZERO);
                let forward = t
                    .transform_vector3(Vec3::new(0.0, 0.0, -1.0))
                    .normalize_or(-Vec3::Z);
                (
                    position,
                    forward,
                    t.transform_vector3(Vec3::Y).normalize_or(Vec3::Y),
                )
            }
        };
        let up_hint = if forward.cross(up_hint).length_squared() < 1e-8 {
            Vec3::Z
        } else {
            up_hint
        };
        let right = forward.cross(up_hint).normalize();
        let up = right.cross(forward);
        let (tan_half_x, tan_half_y) = fit_fov(spec, width as f32 / height as f32);
        Camera {
            position,
            right,
            up,
            back: -forward,
            tan_half_x,
            tan_half_y,
            width,
            height,
        }
    }

    /// The ray through image position `(x, y)` in pixels, `(0, 0)` the top
    /// left corner of the image.
    #[inline]
    pub fn ray(&self, x: f32, y: f32) -> Ray {
        let sx = (2.0 * x / self.width as f32 - 1.0) * self.tan_half_x;
        let sy = (1.0 - 2.0 * y / self.height as f32) * self.tan_half_y;
        let dir = (self.right * sx + self.up * sy - self.back).normalize();
        Ray::new(self.position, dir)
    }
}

/// Half-angle tangents that contain the file's view at the image aspect.
fn fit_fov(spec: &CameraSpec, image_aspect: f32) -> (f32, f32) {
    let tx = (spec.xfov.to_radians() * 0.5).tan();
    let ty = (spec.yfov.to_radians() * 0.5).tan();
    if image_aspect > tx / ty {
        (ty * image_aspect, ty)
    } else {
        (tx, tx / image_aspect)
    }
}
