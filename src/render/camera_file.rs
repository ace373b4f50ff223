//! The course framework's camera settings file (`-c FILE`, and
//! `--save-camera FILE` to write one): plain text, thirty numbers in six
//! groups, one group per line:
//!
//! ```text
//! hFov vFov aspect nClip fClip
//! position.x position.y position.z target.x target.y target.z
//! phi theta r minR maxR
//! c2w (3x3 camera-to-world, row by row; its columns are the camera's
//!      right, up and backward axes: the camera looks down -z)
//! screenW screenH screenDist
//! focalDistance lensRadius
//! ```
//!
//! `hybrid` reads the fields of view, the position, the axes and the lens;
//! the clip planes, the orbit (phi theta r minR maxR) and the screen line
//! are written for the course's viewer and ignored on reading (the
//! resolution is `-r`). Line breaks inside a group are accepted, so a matrix
//! written over three lines reads too. Numbers are written in the shortest
//! form that reads back to the same `f32`, so a saved camera renders the
//! same image.

use glam::Vec3;

/// The groups of the file, in order: name and size.
const GROUPS: [(&str, usize); 6] = [
    ("hFov vFov aspect nClip fClip", 5),
    ("position xyz and target xyz", 6),
    ("phi theta r minR maxR", 5),
    ("the 3x3 camera-to-world matrix", 9),
    ("screenW screenH screenDist", 3),
    ("focalDistance lensRadius", 2),
];

/// A camera as the course framework saves it.
#[derive(Clone, Debug, PartialEq)]
pub struct CourseCamera {
    /// Horizontal and vertical fields of view, degrees.
    pub hfov: f32,
    pub vfov: f32,
    pub position: Vec3,
    pub target: Vec3,
    /// Camera-to-world axes: right, up, backward.
    pub right: Vec3,
    pub up: Vec3,
    pub back: Vec3,
    /// Image size and the screen distance, for the course's viewer.
    pub screen: (f32, f32),
    pub focal_distance: f32,
    pub lens_radius: f32,
}

impl CourseCamera {
    /// Reads a camera file's text; `file` names it in errors, which say
    /// the line and what was expected there.
    pub fn parse(text: &str, file: &str) -> Result<CourseCamera, String> {
        let mut tokens = text
            .lines()
            .enumerate()
            .flat_map(|(i, line)| line.split_whitespace().map(move |w| (i + 1, w)));
        let mut values = Vec::with_capacity(30);
        let mut lines = Vec::with_capacity(30);
        let mut last_line = 1;
        for (group, size) in GROUPS {
            for k in 0..size {
                let Some((line, word)) = tokens.next() else {
                    return Err(format!(
                        "{file}:{last_line}: the file ends after {k} of the {size} numbers of '{group}'"
                    ));
                };
                last_line = line;
                match word.parse::<f32>() {
                    Ok(v) if v.is_finite() => {
                        values.push(v);
                        lines.push(line);
                    }
                    _ => {
                        return Err(format!(
                            "{file}:{line}: '{}' is not a finite number (in '{group}')",
                            crate::input::quote(word)
                        ))
                    }
                }
            }
        }
        if let Some((line, word)) = tokens.next() {
            return Err(format!(
                "{file}:{line}: unexpected '{}' after the 30 numbers of a camera file",
                crate::input::quote(word)
            ));
        }
        let v = |i: usize| values[i];
        let (hfov, vfov) = (v(0), v(1));
        if !(hfov > 0.0 && hfov < 180.0 && vfov > 0.0 && vfov < 180.0) {
            return Err(format!(
                "{file}:{}: fields of view {hfov} x {vfov} degrees: each must be in (0, 180)",
                lines[0]
            ));
        }
        // Rows of the matrix in 16..25; its columns are the axes.
        let column = |c: usize| Vec3::new(v(16 + c), v(19 + c), v(22 + c));
        let (right, up, back) = (column(0), column(1), column(2));
        let orthonormal = [right, up, back]
            .iter()
            .all(|a| (a.length() - 1.0).abs() < 1e-3)
            && right.dot(up).abs() < 1e-3
            && right.dot(back).abs() < 1e-3
            && up.dot(back).abs() < 1e-3
            // A reflection has orthonormal columns too: the axes must be
            // right-handed (determinant +1), or the image is mirrored.
            && right.cross(up).dot(back) > 0.0;
        let matrix_line = lines[16];
        if !orthonormal {
            return Err(format!(
                "{file}:{matrix_line}: the camera-to-world matrix is not a rotation (its columns must be unit length, at right angles and right-handed)"
            ));
        }
        let (focal_distance, lens_radius) = (v(28), v(29));
        if lens_radius < 0.0 || (lens_radius > 0.0 && focal_distance <= 0.0) {
            return Err(format!(
                "{file}:{}: focalDistance {focal_distance} lensRadius {lens_radius}: the radius must be 0 or more, the distance more than 0 with a lens",
                lines[28]
            ));
        }
        Ok(CourseCamera {
            hfov,
            vfov,
            position: Vec3::new(v(5), v(6), v(7)),
            target: Vec3::new(v(8), v(9), v(10)),
            right,
            up,
            back,
            screen: (v(25), v(26)),
            focal_distance,
            lens_radius,
        })
    }

    /// The file's text.
    pub fn text(&self) -> String {
        let d = self.position - self.target;
        let r = d.length();
        let theta = if r > 0.0 {
            (d.y / r).clamp(-1.0, 1.0).acos()
        } else {
            0.0
        };
        let phi = d.z.atan2(d.x);
        let (w, h) = self.screen;
        let screen_distance = h / 2.0 / (self.vfov.to_radians() / 2.0).tan();
        let line = |v: &[f32]| {
            v.iter()
                .map(|x| format!("{x:?}"))
                .collect::<Vec<_>>()
                .join(" ")
        };
        let (a, b, c) = (self.right, self.up, self.back);
        [
            line(&[
                self.hfov,
                self.vfov,
                w / h,
                0.01 * r.max(1e-3),
                100.0 * r.max(1e-3),
            ]),
            line(&[
                self.position.x,
                self.position.y,
                self.position.z,
                self.target.x,
                self.target.y,
                self.target.z,
            ]),
            line(&[phi, theta, r, 0.1 * r, 10.0 * r]),
            line(&[a.x, b.x, c.x, a.y, b.y, c.y, a.z, b.z, c.z]),
            line(&[w, h, screen_distance]),
            line(&[self.focal_distance, self.lens_radius]),
        ]
        .join("\n")
            + "\n"
    }
}
