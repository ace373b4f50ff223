//! The image being rendered and how it is written: PNG with the reference
//! tone map, EXR with raw radiance, and the adaptive sample-rate image.
//! Files are written under a temporary name and renamed, so a failed run
//! never leaves a half image under the requested name.

use std::fs::File;
use std::io::{BufWriter, Seek, Write};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard};

use glam::{DVec3, Vec3};

use super::part::{self, Origin};

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
    /// Sum of the samples per pixel, in double precision: what partial
    /// renders carry so that `hybrid merge` rebuilds the one-process image.
    pub sums: Vec<DVec3>,
    /// Which frame, cell and samples this film holds.
    pub origin: Origin,
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
        let n = width as usize * height as usize;
        Film {
            width,
            height,
            pixels: vec![Vec3::ZERO; n],
            samples: vec![0; n],
            sums: vec![DVec3::ZERO; n],
            origin: Origin::whole(width, height),
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

    /// The image file for `path`: PNG (tone-mapped) or EXR (raw radiance)
    /// by the extension.
    pub fn file(&self, path: &Path, map: ToneMap) -> Result<ImageFile<'_>, FilmError> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase());
        let format = match ext.as_deref() {
            Some("png") => image::ImageFormat::Png,
            Some("exr") => image::ImageFormat::OpenExr,
            _ => {
                return Err(FilmError::Format {
                    path: path.display().to_string(),
                })
            }
        };
        Ok(ImageFile::Radiance {
            film: self,
            map,
            format,
        })
    }

    /// Writes the image to `path` (see [`Film::file`] and [`write_files`]).
    pub fn write(&self, path: &Path, map: ToneMap) -> Result<(), FilmError> {
        write_files(&[(path, self.file(path, map)?)])
    }

    /// The sample-rate image of adaptive sampling (PNG): rate = samples /
    /// cap, blue (0) -> green (0.5) -> red (1).
    pub fn rate_file(&self, cap: u32) -> ImageFile<'_> {
        ImageFile::Rate { film: self, cap }
    }

    /// The sample-rate image: rate = samples / cap, coloured by
    /// [`rate_colour`].
    pub fn rate_image(&self, cap: u32) -> image::RgbImage {
        let rgb = self
            .samples
            .iter()
            .flat_map(|&n| rate_colour(n as f32 / cap.max(1) as f32))
            .collect();
        image::RgbImage::from_raw(self.width, self.height, rgb).expect("film size")
    }
}

/// An image to be written from a film.
pub enum ImageFile<'a> {
    /// The radiance: PNG through a tone map, or EXR as it is.
    Radiance {
        film: &'a Film,
        map: ToneMap,
        format: image::ImageFormat,
    },
    /// The adaptive sampling rate.
    Rate { film: &'a Film, cap: u32 },
    /// An image composed from films (a contact sheet), as PNG.
    Picture(&'a image::RgbImage),
}

impl ImageFile<'_> {
    /// Encodes the image into `out`.
    pub fn write_to<W: Write + Seek>(&self, out: &mut W) -> Result<(), String> {
        match *self {
            ImageFile::Radiance {
                film,
                map,
                format: image::ImageFormat::OpenExr,
            } => part::write_exr(out, film, map),
            ImageFile::Radiance { film, map, .. } => {
                png(out, film, &film.to_rgb8(map)).map_err(|e| e.to_string())
            }
            ImageFile::Rate { film, cap } => {
                png(out, film, film.rate_image(cap).as_raw()).map_err(|e| e.to_string())
            }
            ImageFile::Picture(img) => img
                .write_to(out, image::ImageFormat::Png)
                .map_err(|e| e.to_string()),
        }
    }
}

fn png<W: Write + Seek>(out: &mut W, film: &Film, rgb: &[u8]) -> image::ImageResult<()> {
    image::write_buffer_with_format(
        out,
        rgb,
        film.width,
        film.height,
        image::ColorType::Rgb8,
        image::ImageFormat::Png,
    )
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

/// Temporary files being written, so a signal handler can remove them
/// ([`abandon_writes`]); once `closing`, no new one is created.
struct InFlight {
    paths: Vec<PathBuf>,
    closing: bool,
}

static IN_FLIGHT: Mutex<InFlight> = Mutex::new(InFlight {
    paths: Vec::new(),
    closing: false,
});

fn in_flight() -> MutexGuard<'static, InFlight> {
    IN_FLIGHT.lock().unwrap_or_else(|e| e.into_inner())
}

/// The temporary name `path` is written under: hidden, beside it, unique
/// to this process.
fn temporary(path: &Path) -> PathBuf {
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("image");
    path.with_file_name(format!(".{name}.partial-{}", std::process::id()))
}

/// Writes every file or none: each is encoded straight into a temporary
/// name, and only when all are complete are they renamed into place. A
/// failure removes what this call wrote, so no half image (and no image
/// without its companion) is left under a requested name; a signal during
/// the write removes the temporary files ([`abandon_writes`]).
pub fn write_files(files: &[(&Path, ImageFile)]) -> Result<(), FilmError> {
    let fail = |path: &Path, message: String| FilmError::Write {
        path: path.display().to_string(),
        message,
    };
    let mut written: Vec<PathBuf> = Vec::new();
    let result = (|| {
        for (path, image) in files {
            let tmp = temporary(path);
            let file = {
                // Created under the lock: a signal handler either sees the
                // file registered or stops it being made.
                let mut f = in_flight();
                if f.closing {
                    return Err(fail(path, "interrupted".into()));
                }
                let file = File::create(&tmp).map_err(|e| fail(path, e.to_string()))?;
                f.paths.push(tmp.clone());
                file
            };
            written.push(tmp);
            let mut out = BufWriter::new(file);
            image.write_to(&mut out).map_err(|e| fail(path, e))?;
            out.flush().map_err(|e| fail(path, e.to_string()))?;
        }
        Ok(())
    })();
    let result = result.and_then(|()| {
        for (k, ((path, _), tmp)) in files.iter().zip(&written).enumerate() {
            if let Err(e) = std::fs::rename(tmp, path) {
                for (done, _) in &files[..k] {
                    let _ = std::fs::remove_file(done);
                }
                return Err(fail(path, e.to_string()));
            }
        }
        Ok(())
    });
    let mut f = in_flight();
    for tmp in &written {
        if result.is_err() {
            let _ = std::fs::remove_file(tmp);
        }
        f.paths.retain(|p| p != tmp);
    }
    result
}

/// Checks, before any work, that `path` can be written: its folder exists
/// and takes a new file (the temporary name is created and removed).
pub fn check_writable(path: &Path) -> Result<(), FilmError> {
    let fail = |message: String| FilmError::Write {
        path: path.display().to_string(),
        message,
    };
    if path.is_dir() {
        return Err(fail("is a directory".into()));
    }
    let tmp = temporary(path);
    File::create(&tmp).map_err(|e| fail(e.to_string()))?;
    let _ = std::fs::remove_file(&tmp);
    Ok(())
}

/// Removes every temporary file being written and stops new ones: for a
/// signal handler that is about to exit. Returns with the registry
/// locked for good, so no writer creates a file after the cleanup.
pub fn abandon_writes() {
    let mut f = in_flight();
    f.closing = true;
    for tmp in f.paths.drain(..) {
        let _ = std::fs::remove_file(tmp);
    }
    std::mem::forget(f);
}
