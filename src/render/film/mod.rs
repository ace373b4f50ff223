//! The image being rendered and how it is written: PNG with the reference
//! tone map, EXR with raw radiance and the film's [`Origin`] (the format
//! `part.rs` reads back and merges), and the adaptive sample-rate image.
//! Files are written under a temporary name and renamed, so a failed run
//! never leaves a half image under the requested name.

use std::fs::File;
use std::io::{BufWriter, Seek, Write};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard};

/// The most pixels one run renders (8192 x 8192), and so the most a part
/// (`render/part.rs`) can hold: a film costs 40 bytes a pixel (mean, sample
/// count, double-precision sum), and writing it a few more.
pub const MAX_PIXELS: u64 = 1 << 26;

use exr::prelude::{
    AnyChannel, AnyChannels, AttributeValue, Encoding, FlatSamples, Image, Layer, LayerAttributes,
    SmallVec, Text, WritableImage,
};
use glam::{DVec3, Vec3};

use super::Cell;

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

/// `Err` when something other than a regular file has the output's name: a
/// directory, a symbolic link, a device, a FIFO or a socket. The finished
/// image is renamed onto the name, which would replace such an entry
/// rather than write through it, so it is refused instead.
fn refuse_special(path: &Path) -> Result<(), String> {
    match std::fs::symlink_metadata(path) {
        Ok(meta) if meta.is_dir() => Err("is a directory".into()),
        Ok(meta) if meta.file_type().is_symlink() => Err(
            "is a symbolic link; hybrid writes by renaming a finished file onto the name, which would replace the link: give the link's target instead".into(),
        ),
        Ok(meta) if !meta.is_file() => Err(
            "is a device, FIFO or socket, not a regular file: hybrid writes images to regular files only".into(),
        ),
        _ => Ok(()),
    }
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
            hold_if_asked();
        }
        Ok(())
    })();
    let result = result.and_then(|()| {
        // Every name is checked before any is replaced, so a directory in
        // the way of the last file cannot cost the user the first ones.
        for (k, (path, _)) in files.iter().enumerate() {
            refuse_special(path).map_err(|e| fail(path, e))?;
            if files[..k].iter().any(|(p, _)| p == path) {
                return Err(fail(path, "named twice in one write".into()));
            }
        }
        let existed: Vec<bool> = files.iter().map(|(p, _)| p.exists()).collect();
        for (k, ((path, _), tmp)) in files.iter().zip(&written).enumerate() {
            if let Err(e) = std::fs::rename(tmp, path) {
                // Only files this call created are removed; one that
                // replaced an older file stays (the older one is gone).
                for ((done, _), &old) in files[..k].iter().zip(&existed) {
                    if !old {
                        let _ = std::fs::remove_file(done);
                    }
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

/// Set to stop every write with its temporary file complete and not yet
/// renamed, until a signal ends the process: the point a signal must find
/// handled, reached by construction, so the test of it races nothing.
pub const HOLD_WRITE_VARIABLE: &str = "HYBRID_TEST_HOLD_WRITE";

fn hold_if_asked() {
    if std::env::var_os(HOLD_WRITE_VARIABLE).is_some() {
        loop {
            std::thread::park();
        }
    }
}

/// Checks, before any work, that `path` can be written: its folder exists
/// and takes a new file (the temporary name is created and removed).
pub fn check_writable(path: &Path) -> Result<(), FilmError> {
    let fail = |message: String| FilmError::Write {
        path: path.display().to_string(),
        message,
    };
    refuse_special(path).map_err(fail)?;
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
/// The header attribute holding the [`Origin`].
pub(super) const ATTRIBUTE: &str = "hybrid.part";

/// Where a film belongs in the frame one process would have rendered.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Origin {
    /// The whole frame's size.
    pub frame: (u32, u32),
    /// The pixels this film holds.
    pub cell: Cell,
    /// The samples of every pixel this film holds: `start..end`.
    pub samples: (u32, u32),
    /// Samples per pixel of the whole render (`-s`; the cap with `-a`).
    pub total: u32,
    pub seed: u64,
    /// Adaptive sampling's batch (`-a BATCH TOL`), if adaptive.
    pub adaptive: Option<u32>,
}

impl Origin {
    /// A whole frame of `width` x `height`, no samples yet.
    pub fn whole(width: u32, height: u32) -> Origin {
        Origin {
            frame: (width, height),
            cell: Cell {
                x: 0,
                y: 0,
                width,
                height,
            },
            samples: (0, 0),
            total: 0,
            seed: 0,
            adaptive: None,
        }
    }

    pub(super) fn text(&self, map: ToneMap) -> String {
        let c = self.cell;
        format!(
            "frame {} {}; cell {} {} {} {}; samples {} {} of {}; seed {}; adaptive {}; tone {}",
            self.frame.0,
            self.frame.1,
            c.x,
            c.y,
            c.width,
            c.height,
            self.samples.0,
            self.samples.1,
            self.total,
            self.seed,
            self.adaptive.unwrap_or(0),
            match map {
                ToneMap::Reference(e) if e == Exposure::NONE => "reference".to_string(),
                ToneMap::Reference(e) => format!("reference {}", e.ev()),
                ToneMap::Identity => "identity".to_string(),
            }
        )
    }

    pub(super) fn parse(text: &str) -> Option<(Origin, ToneMap)> {
        let fields: Vec<(&str, Vec<&str>)> = text
            .split(';')
            .map(|f| {
                let mut words = f.split_whitespace();
                (words.next().unwrap_or(""), words.collect())
            })
            .collect();
        // A field given twice has no one meaning.
        for (i, (key, _)) in fields.iter().enumerate() {
            if !key.is_empty() && fields[..i].iter().any(|(k, _)| k == key) {
                return None;
            }
        }
        let get = |key: &str| fields.iter().find(|(k, _)| *k == key).map(|(_, v)| v);
        let nums = |key: &str, n: usize| -> Option<Vec<u64>> {
            let v = get(key)?;
            let v: Vec<u64> = v
                .iter()
                .filter(|w| **w != "of")
                .map(|w| w.parse().ok())
                .collect::<Option<_>>()?;
            (v.len() == n).then_some(v)
        };
        let u = |v: u64| u32::try_from(v).ok();
        let frame = nums("frame", 2)?;
        let cell = nums("cell", 4)?;
        let samples = nums("samples", 3)?;
        let origin = Origin {
            frame: (u(frame[0])?, u(frame[1])?),
            cell: Cell {
                x: u(cell[0])?,
                y: u(cell[1])?,
                width: u(cell[2])?,
                height: u(cell[3])?,
            },
            samples: (u(samples[0])?, u(samples[1])?),
            total: u(samples[2])?,
            seed: nums("seed", 1)?[0],
            // 0: not adaptive; else the batch.
            adaptive: u(nums("adaptive", 1)?[0]).filter(|&b| b > 0),
        };
        let map = match get("tone")?.as_slice() {
            ["reference"] => ToneMap::REFERENCE,
            ["reference", ev] => ToneMap::Reference(Exposure::stops(ev.parse().ok()?)?),
            ["identity"] => ToneMap::Identity,
            _ => return None,
        };
        Some((origin, map))
    }
}

/// The sum channels: the high and low 32 bits of each f64 sum.
pub(super) const SUMS: [&str; 6] = [
    "sum.B.hi", "sum.B.lo", "sum.G.hi", "sum.G.lo", "sum.R.hi", "sum.R.lo",
];

/// Encodes `film` as an EXR part (see the module's text).
pub fn write_exr<W: Write + Seek>(out: &mut W, film: &Film, map: ToneMap) -> Result<(), String> {
    let size = (film.width as usize, film.height as usize);
    let mean = |c: fn(&Vec3) -> f32| FlatSamples::F32(film.pixels.iter().map(c).collect());
    let bits = |c: fn(&DVec3) -> f64, high: bool| {
        FlatSamples::U32(
            film.sums
                .iter()
                .map(|s| {
                    let b = c(s).to_bits();
                    if high {
                        (b >> 32) as u32
                    } else {
                        b as u32
                    }
                })
                .collect(),
        )
    };
    let channels = SmallVec::from_vec(vec![
        AnyChannel::new("R", mean(|p| p.x)),
        AnyChannel::new("G", mean(|p| p.y)),
        AnyChannel::new("B", mean(|p| p.z)),
        AnyChannel::new("samples", FlatSamples::U32(film.samples.clone())),
        AnyChannel::new(SUMS[4], bits(|s| s.x, true)),
        AnyChannel::new(SUMS[5], bits(|s| s.x, false)),
        AnyChannel::new(SUMS[2], bits(|s| s.y, true)),
        AnyChannel::new(SUMS[3], bits(|s| s.y, false)),
        AnyChannel::new(SUMS[0], bits(|s| s.z, true)),
        AnyChannel::new(SUMS[1], bits(|s| s.z, false)),
    ]);
    let mut attributes = LayerAttributes::default();
    attributes.other.insert(
        Text::from(ATTRIBUTE),
        AttributeValue::Text(Text::from(film.origin.text(map).as_str())),
    );
    let layer = Layer::new(
        size,
        attributes,
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(channels),
    );
    Image::from_layer(layer)
        .write()
        .to_buffered(out)
        .map_err(|e| e.to_string())
}
