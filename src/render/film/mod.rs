//! The image being rendered and how it is written: PNG with the reference
//! tone map, EXR with raw radiance and the film's [`Origin`] (the format
//! `part.rs` reads back and merges), and the adaptive sample-rate image.
//! Files are written under a temporary name and renamed, so a failed run
//! never leaves a half image under the requested name.

use std::io::{Seek, Write};
use std::path::{Path, PathBuf};

/// The most pixels one run renders (8192 x 8192), and so the most a part
/// (`render/part.rs`) can hold: a film costs 40 bytes a pixel (mean, sample
/// count, double-precision sum), and writing it a few more.
pub const MAX_PIXELS: u64 = 1 << 26;

use glam::{DVec3, Vec3};

mod exr;
mod files;

pub use self::exr::{write_exr, Origin};
pub(super) use self::exr::{ATTRIBUTE, SUMS};
pub use self::files::{abandon_writes, check_writable, write_files, HOLD_WRITE_VARIABLE};

/// How radiance becomes 8-bit colour.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ToneMap {
    /// The reference renders' map after an exposure:
    /// `clamp((2^EV L sqrt 2)^(1/2.2), 0, 1)`.
    Reference(Exposure),
    /// Values are display colours already (normal shading).
    Identity,
}

impl ToneMap {
    /// The reference renders' map as they use it (no exposure).
    pub const REFERENCE: ToneMap = ToneMap::Reference(Exposure::NONE);
}

/// An exposure in hundredths of a stop: radiance is scaled by `2^EV`
/// before the tone map (PNG and sheets; EXR keeps the radiance as it is).
/// Whole hundredths, so the value a part records reads back exactly.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Exposure {
    hundredths: i32,
}

impl Exposure {
    pub const NONE: Exposure = Exposure { hundredths: 0 };
    /// The largest exposure either way, in stops.
    pub const LIMIT: f64 = 64.0;
    /// Mid grey: the luminance an automatic exposure brings the mean to.
    const MID_GREY: f64 = 0.18;

    /// `stops` rounded to a hundredth, if finite and within [`Self::LIMIT`].
    pub fn stops(stops: f64) -> Option<Exposure> {
        (stops.is_finite() && stops.abs() <= Self::LIMIT).then(|| Exposure {
            hundredths: (stops * 100.0).round() as i32,
        })
    }

    /// The exposure that brings the mean of `pixels` to mid grey: the
    /// geometric mean of the luminance of the pixels that see any light
    /// (Reinhard et al. 2002's key; black surroundings and a few bright
    /// pixels do not move it); none for a black image.
    pub fn by_mean(pixels: &[Vec3]) -> Exposure {
        let (sum, n) = pixels
            .iter()
            .map(|p| f64::from(crate::geom::sampling::luminance(*p)))
            .filter(|l| l.is_finite() && *l > 0.0)
            .fold((0.0f64, 0usize), |(s, n), l| (s + l.ln(), n + 1));
        if n == 0 {
            return Exposure::NONE;
        }
        let stops = (Self::MID_GREY.ln() - sum / n as f64) / std::f64::consts::LN_2;
        Exposure::stops(stops.clamp(-Self::LIMIT, Self::LIMIT)).unwrap_or_default()
    }

    pub fn ev(self) -> f64 {
        f64::from(self.hundredths) / 100.0
    }

    fn scale(self) -> f32 {
        (self.ev().exp2()) as f32
    }

    /// As a caption shows it: `+1.5 EV`.
    pub fn label(self) -> String {
        format!("{:+} EV", self.ev())
    }
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
            ToneMap::Reference(exposure) => (value * exposure.scale() * std::f32::consts::SQRT_2)
                .max(0.0)
                .powf(1.0 / 2.2),
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

    /// `Err` unless `path` names an image file hybrid writes: `.png` or
    /// `.exr`, checked before any work.
    pub fn check_image_name(path: &Path) -> Result<(), FilmError> {
        let ext = path.extension().and_then(|e| e.to_str());
        match ext.map(|e| e.to_ascii_lowercase()).as_deref() {
            Some("png") | Some("exr") => Ok(()),
            _ => Err(FilmError::Format {
                path: path.display().to_string(),
            }),
        }
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

    /// Mean camera samples per pixel over the pixels that took any.
    pub fn mean_samples(&self) -> f64 {
        let covered = self.samples.iter().filter(|&&n| n > 0).count().max(1);
        self.samples.iter().map(|&n| n as f64).sum::<f64>() / covered as f64
    }

    /// The sample-rate image of adaptive sampling (PNG), see
    /// [`Film::rate_image`].
    pub fn rate_file(&self) -> ImageFile<'_> {
        ImageFile::Rate(self)
    }

    /// The sample-rate image: each pixel coloured by the samples it took on
    /// the absolute scale [`RateScale::of`] gives (the same colour is the
    /// same count in any render of the same batch whose cap is at most
    /// [`RATE_TOP`]), with a legend strip of [`LEGEND_HEIGHT`] rows under
    /// it.
    pub fn rate_image(&self) -> image::RgbImage {
        let scale = RateScale::of(&self.origin);
        let mut img = image::RgbImage::from_pixel(
            self.width,
            self.height + LEGEND_HEIGHT,
            image::Rgb([255, 255, 255]),
        );
        for (i, &n) in self.samples.iter().enumerate() {
            let (x, y) = (i as u32 % self.width, i as u32 / self.width);
            img.put_pixel(x, y, image::Rgb(scale.colour(n)));
        }
        scale.draw_legend(&mut img, self.height);
        img
    }
}

/// The top of the rate image's scale: 4096 samples, or the cap rounded up
/// to a power of two when it is larger.
pub const RATE_TOP: u32 = 4096;

/// Rows the rate image's legend strip adds under the pixels.
pub const LEGEND_HEIGHT: u32 = 26;

/// The rate image's colour scale: logarithmic in samples per pixel, from
/// one batch (blue: the pixel stopped at its first check) to
/// [`RATE_TOP`] (red), green half way (at -a 64, 512 samples).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RateScale {
    pub low: u32,
    pub top: u32,
}

impl RateScale {
    /// The scale of a render: its batch (1 without adaptive sampling) up
    /// to [`RATE_TOP`] or its cap's next power of two.
    pub fn of(origin: &Origin) -> RateScale {
        let top = origin
            .total
            .max(1)
            .checked_next_power_of_two()
            .unwrap_or(1 << 31)
            .max(RATE_TOP);
        let low = origin.adaptive.unwrap_or(1).clamp(1, top / 2);
        RateScale { low, top }
    }

    /// Where `n` samples lie on the scale, 0 (at or below one batch) to 1.
    pub fn position(&self, n: u32) -> f32 {
        let (low, top) = ((self.low as f32).log2(), (self.top as f32).log2());
        (((n.max(1) as f32).log2() - low) / (top - low)).clamp(0.0, 1.0)
    }

    pub fn colour(&self, n: u32) -> [u8; 3] {
        rate_colour(self.position(n))
    }

    /// The legend under a rate image whose pixels end at row `y0`: the
    /// scale as a colour bar, and sample counts (the batch times powers of
    /// 4, and the top) under it where they fit.
    fn draw_legend(&self, img: &mut image::RgbImage, y0: u32) {
        const MARGIN: u32 = 4;
        const LABEL_PX: f32 = 11.0;
        let width = img.width();
        let span = width.saturating_sub(2 * MARGIN).max(2);
        for x in MARGIN..(MARGIN + span).min(width) {
            let colour = rate_colour((x - MARGIN) as f32 / (span - 1) as f32);
            for y in y0 + 3..y0 + 11 {
                img.put_pixel(x, y, image::Rgb(colour));
            }
        }
        let font = crate::text::font();
        let mut values: Vec<u32> = std::iter::successors(Some(self.low), |v| v.checked_mul(4))
            .take_while(|&v| v < self.top)
            .collect();
        values.push(self.top);
        // The ends first, so they win where labels would collide.
        let mut order: Vec<usize> = vec![values.len() - 1, 0];
        order.extend(1..values.len() - 1);
        let mut taken: Vec<(f32, f32)> = Vec::new();
        for k in order {
            let v = values[k];
            let text = if k + 1 == values.len() {
                format!("{v} spp")
            } else {
                v.to_string()
            };
            let w = crate::text::text_width(&font, LABEL_PX, &text);
            let centre = MARGIN as f32 + self.position(v) * (span - 1) as f32;
            let left = (centre - w / 2.0).clamp(0.0, (width as f32 - w).max(0.0));
            let right = left + w;
            if right > width as f32
                || taken
                    .iter()
                    .any(|&(l, r)| left < r + 4.0 && l < right + 4.0)
            {
                continue;
            }
            taken.push((left, right));
            crate::text::draw_centred(
                img,
                &font,
                LABEL_PX,
                &text,
                left as u32,
                w.ceil() as u32 + 1,
                y0 + 12,
            );
        }
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
    /// The adaptive sampling rate, with its legend.
    Rate(&'a Film),
    /// An image composed from films (a contact sheet), as PNG.
    Picture(&'a image::RgbImage),
    /// A table written with the images (Markdown, CSV), as it is.
    Text(&'a str),
    /// Any other file the render writes (a mesh for another renderer), as
    /// it is.
    Bytes(&'a [u8]),
}

impl ImageFile<'_> {
    /// Encodes the image into `out`.
    pub fn write_to<W: Write + Seek>(&self, out: &mut W) -> Result<(), String> {
        match *self {
            ImageFile::Radiance {
                film,
                map,
                format: image::ImageFormat::OpenExr,
            } => write_exr(out, film, map),
            ImageFile::Radiance { film, map, .. } => image::write_buffer_with_format(
                out,
                &film.to_rgb8(map),
                film.width,
                film.height,
                image::ColorType::Rgb8,
                image::ImageFormat::Png,
            )
            .map_err(|e| e.to_string()),
            ImageFile::Rate(film) => film
                .rate_image()
                .write_to(out, image::ImageFormat::Png)
                .map_err(|e| e.to_string()),
            ImageFile::Picture(img) => img
                .write_to(out, image::ImageFormat::Png)
                .map_err(|e| e.to_string()),
            ImageFile::Text(text) => out.write_all(text.as_bytes()).map_err(|e| e.to_string()),
            ImageFile::Bytes(bytes) => out.write_all(bytes).map_err(|e| e.to_string()),
        }
    }
}

/// Blue -> green -> red by position in [0, 1].
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
