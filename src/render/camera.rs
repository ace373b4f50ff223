//! The pinhole camera: image position -> camera space on the plane z = -1
//! (fields of view) -> world space.
//!
//! Framing (`scene-format.md`, Camera): the canonical mode reproduces the
//! reference renders (look at the centre of the scene's bounds from
//! `1.5 * |extent|` along the camera node's direction); the node mode uses
//! the node's own placement. In both, the image aspect wins over the file's:
//! the field of view of the side that is relatively narrower is widened, so
//! the file's view always fits in the image.
//!
//! A thin lens (`-b R -d D`, as the course): rays start on a disk of radius
//! R around the camera position in the image plane's directions and pass
//! through the point the pinhole ray reaches at distance D along the view
//! axis, so points at that distance stay sharp and others blur with R.

use glam::{Mat4, Vec3};

use super::camera_file::CourseCamera;
use crate::geom::sampling::concentric_disk;
use crate::geom::Ray;
use crate::scene::Scene;

/// Depth of field: the lens radius and the distance in focus, along the
/// view axis, in scene units (0 or less: the distance to the framing's
/// centre).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThinLens {
    pub radius: f32,
    pub focal_distance: f32,
}

/// Where the camera stands: the reference framing or the node's own.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum CameraMode {
    #[default]
    Canonical,
    Node,
}

crate::choice!(CameraMode { Canonical => "canonical", Node => "node" });

/// A camera's placement as another renderer takes it: the image spans
/// `±tan_half_x` along the right axis one unit ahead, and the height
/// follows from the image's aspect.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraView {
    pub position: Vec3,
    /// Unit view direction.
    pub forward: Vec3,
    /// Unit up axis of the image.
    pub up: Vec3,
    pub tan_half_x: f32,
    pub lens: Option<ThinLens>,
}

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
    /// The point the canonical framing looks at (the scene's centre), or
    /// one unit ahead for the node camera: the default focal distance.
    target_distance: f32,
    lens: Option<ThinLens>,
    /// The fields of view asked for (degrees), before fitting the image.
    fov: (f32, f32),
}

impl Camera {
    pub fn new(scene: &Scene, mode: CameraMode, width: u32, height: u32) -> Camera {
        let spec = &scene.camera;
        let (position, forward, up_hint, target_distance) = match mode {
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
                    (target - position).length(),
                )
            }
            CameraMode::Node => {
                let t: &Mat4 = &spec.transform;
                let position = t.transform_point3(Vec3::ZERO);
                let forward = t
                    .transform_vector3(Vec3::new(0.0, 0.0, -1.0))
                    .normalize_or(-Vec3::Z);
                let centre = scene.framing_bounds.center();
                (
                    position,
                    forward,
                    t.transform_vector3(Vec3::Y).normalize_or(Vec3::Y),
                    (centre - position).dot(forward).max(1e-3),
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
        let (tan_half_x, tan_half_y) = fit_fov(spec.xfov, spec.yfov, width as f32 / height as f32);
        Camera {
            position,
            right,
            up,
            back: -forward,
            tan_half_x,
            tan_half_y,
            width,
            height,
            target_distance,
            lens: None,
            fov: (spec.xfov, spec.yfov),
        }
    }

    /// The camera a course camera file describes (`-c`), at this image
    /// size; its lens, if any, is the file's.
    pub fn from_course(c: &CourseCamera, width: u32, height: u32) -> Camera {
        let (tan_half_x, tan_half_y) = fit_fov(c.hfov, c.vfov, width as f32 / height as f32);
        Camera {
            position: c.position,
            right: c.right,
            up: c.up,
            back: c.back,
            tan_half_x,
            tan_half_y,
            width,
            height,
            target_distance: (c.position - c.target).dot(c.back).max(1e-3),
            lens: None,
            fov: (c.hfov, c.vfov),
        }
        .with_lens((c.lens_radius > 0.0).then_some(ThinLens {
            radius: c.lens_radius,
            focal_distance: c.focal_distance,
        }))
    }

    /// The course camera file of this camera (`--save-camera`): reading it
    /// back with `-c` gives this camera.
    pub fn to_course(&self) -> CourseCamera {
        CourseCamera {
            hfov: self.fov.0,
            vfov: self.fov.1,
            position: self.position,
            target: self.position - self.back * self.target_distance,
            right: self.right,
            up: self.up,
            back: self.back,
            screen: (self.width as f32, self.height as f32),
            focal_distance: self.lens.map_or(self.target_distance, |l| l.focal_distance),
            lens_radius: self.lens.map_or(0.0, |l| l.radius),
        }
    }

    /// The camera with a thin lens (`radius` 0: still a pinhole).
    pub fn with_lens(mut self, lens: Option<ThinLens>) -> Camera {
        self.lens = lens.filter(|l| l.radius > 0.0).map(|l| ThinLens {
            focal_distance: if l.focal_distance > 0.0 {
                l.focal_distance
            } else {
                self.target_distance
            },
            ..l
        });
        self
    }

    /// Distance along the view axis to the framing's centre: where a lens
    /// focuses when no distance is given.
    pub fn target_distance(&self) -> f32 {
        self.target_distance
    }

    /// Where the camera stands and what it sees, for another renderer
    /// to frame the same image (`--mitsuba`).
    pub fn view(&self) -> CameraView {
        CameraView {
            position: self.position,
            forward: -self.back,
            up: self.up,
            tan_half_x: self.tan_half_x,
            lens: self.lens,
        }
    }

    /// Whether rays need a lens sample ([`Camera::origin_and_dir`]).
    pub fn has_lens(&self) -> bool {
        self.lens.is_some()
    }

    /// The ray through image position `(x, y)` in pixels, as its origin
    /// and unit direction: from lens sample `(u, v)` in the unit square
    /// where the camera has a lens, else (or without a sample) the pinhole
    /// ray. Two values, so that a caller can write them into a ray in
    /// place.
    #[inline(always)]
    pub fn origin_and_dir(&self, x: f32, y: f32, lens_sample: Option<(f32, f32)>) -> (Vec3, Vec3) {
        let sx = (2.0 * x / self.width as f32 - 1.0) * self.tan_half_x;
        let sy = (1.0 - 2.0 * y / self.height as f32) * self.tan_half_y;
        let pinhole = self.right * sx + self.up * sy - self.back;
        match (self.lens, lens_sample) {
            (Some(lens), Some((u, v))) => {
                // The pinhole ray reaches the plane of focus at depth D.
                let focus = pinhole * lens.focal_distance;
                let (dx, dy) = concentric_disk(u, v);
                let offset = (self.right * dx + self.up * dy) * lens.radius;
                (self.position + offset, (focus - offset).normalize())
            }
            _ => (self.position, pinhole.normalize()),
        }
    }

    /// The ray through image position `(x, y)` in pixels, `(0, 0)` the top
    /// left corner of the image.
    #[inline]
    pub fn ray(&self, x: f32, y: f32) -> Ray {
        let (origin, dir) = self.origin_and_dir(x, y, None);
        Ray::new(origin, dir)
    }
}

/// Half-angle tangents that contain the file's view at the image aspect.
fn fit_fov(xfov: f32, yfov: f32, image_aspect: f32) -> (f32, f32) {
    let tx = (xfov.to_radians() * 0.5).tan();
    let ty = (yfov.to_radians() * 0.5).tan();
    if image_aspect > tx / ty {
        (ty * image_aspect, ty)
    } else {
        (tx, tx / image_aspect)
    }
}
