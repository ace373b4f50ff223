//! The image being rendered and how it is written: PNG with the reference
//! tone map, EXR with raw radiance, and the adaptive sample-rate image.
//! Files are written under a temporary name and renamed, so a failed run
//! never leaves a half image under the requested name.

use std::path::{Path, PathBuf};

use glam::Vec3;

/// How radiance becomes 8-bit colour.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ToneMap {
    /// The reference renders' map: `clamp((L * sqrt 2)^(1/2.2), 0, 1)`.
    Reference,
    /// Values are display colours already (normal shading).
    Identity,
}

#[derive(Clone, Debug)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    /// Mean radiance per pixel, row-major from the top-left.
    pub pixels: Vec<Vec3>,
    /// Camera samples taken per pixel.
    pub samples: Vec<u32>,
}

#[derive(Debug, thiserror::Error)]
pub enum FilmError {
    #[error("{path}: cannot write the image: {message}")]
    Write { path: String, message: String },
    #[error("{path}: unsupported output format (use .png or .exr)")]
    Format { path: String },
}

impl Film {
    pub fn new(width: u32, height: u32) -> Film {
        let n = (width * height) as usize;
        Film {
            width,
            height,
            pixels: vec![Vec3::ZERO; n],
            samples: vec![0; n],
        }
    }

    pub fn tone_map(value: f32, map: ToneMap) -> u8 {
        let v = match map {
            ToneMap::Reference => (value * std::f32::consts::SQRT_2).max(0.0).powf(1.0 / 2.2),
            ToneMap::Identity => value,
        };
        (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8
    }

    /// 8-bit RGB bytes of the image.
    pub fn to_rgb8(&self, map: ToneMap) -> Vec<u8> {
        self.pixels
            .iter()
            .flat_map(|p| [p.x, p.y, p.z].map(|c| Film::tone_map(c, map)))
            .collect()
    }

    /// Writes PNG (tone-mapped) or EXR (raw radiance) by the extension.
    pub fn write(&self, path: &Path, map: ToneMap) -> Result<(), FilmError> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase());
        match ext.as_deref() {
            Some("png") => write_atomically(path, |tmp| {
                image::save_buffer_with_format(
                    tmp,
                    &self.to_rgb8(map),
                    self.width,
                    self.height,
                    image::ColorType::Rgb8,
                    image::ImageFormat::Png,
                )
            }),
            Some("exr") => {
                let data: Vec<f32> = self.pixels.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
                write_atomically(path, |tmp| {
                    let img = image::Rgb32FImage::from_raw(self.width, self.height, data.clone())
                        .ok_or_else(|| {
                        image::ImageError::Parameter(image::error::ParameterError::from_kind(
                            image::error::ParameterErrorKind::DimensionMismatch,
                        ))
                    })?;
                    img.save_with_format(tmp, image::ImageFormat::OpenExr)
                })
            }
            _ => Err(FilmError::Format {
                path: path.display().to_string(),
            }),
        }
    }

    /// The sample-rate image of adaptive sampling: rate = samples / cap,
    /// blue (0) -> green (0.5) -> red (1).
    pub fn write_rate(&self, path: &Path, cap: u32) -> Result<(), FilmError> {
        let bytes: Vec<u8> = self
            .samples
            .iter()
            .flat_map(|&n| rate_colour(n as f32 / cap.max(1) as f32))
            .collect();
        write_atomically(path, |tmp| {
            image::save_buffer_with_format(
                tmp,
                &bytes,
                self.width,
                self.height,
                image::ColorType::Rgb8,
                image::ImageFormat::Png,
            )
        })
    }
}

/// Blue -> green -> red by rate in [0, 1].
pub fn rate_colour(rate: f32) -> [u8; 3] {
    let r = rate.clamp(0.0, 1.0);
    let (red, green, blue) = if r < 0.5 {
        (0.0, 2.0 * r, 1.0 - 2.0 * r)
    } else {
        (2.0 * r - 1.0, 2.0 - 2.0 * r, 0.0)
    };
    [red, green, blue].map(|c| (c * 255.0 + 0.5) as u8)
}

/// `NAME_rate.png` beside `NAME.ext`.
pub fn rate_path(output: &Path) -> PathBuf {
    let stem = output.file_stem().and_then(|s| s.to_str()).unwrap_or("out");
    output.with_file_name(format!("{stem}_rate.png"))
}

fn write_atomically(
    path: &Path,
    write: impl FnOnce(&Path) -> image::ImageResult<()>,
) -> Result<(), FilmError> {
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("image");
    let tmp = path.with_file_name(format!(".{name}.partial-{}", std::process::id()));
    let fail = |message: String| FilmError::Write {
        path: path.display().to_string(),
        message,
    };
    if let Err(e) = write(&tmp) {
        let _ = std::fs::remove_file(&tmp);
        return Err(fail(e.to_string()));
    }
    std::fs::rename(&tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        fail(e.to_string())
    })
}
