//! The EXR part: mean radiance, sample counts and the exact double sums of
//! a film, with its [`Origin`] in a header attribute (`render/part.rs`
//! reads it back and merges).

use std::io::{Seek, Write};

use exr::prelude::{
    AnyChannel, AnyChannels, AttributeValue, Encoding, FlatSamples, Image, Layer, LayerAttributes,
    SmallVec, Text, WritableImage,
};
use glam::{DVec3, Vec3};

use super::{Exposure, Film, ToneMap};
use crate::render::Cell;

/// The header attribute holding the [`Origin`].
pub(in crate::render) const ATTRIBUTE: &str = "hybrid.part";

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

    pub(in crate::render) fn text(&self, map: ToneMap) -> String {
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

    pub(in crate::render) fn parse(text: &str) -> Option<(Origin, ToneMap)> {
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
pub(in crate::render) const SUMS: [&str; 6] = [
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
