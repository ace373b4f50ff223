//! Partial renders and their merge. Every EXR `hybrid render` writes says
//! where it belongs: the frame's size, its cell (`-p`), its sample range
//! (`--samples A..B` of `-s N`), the seed and the tone map, in one header
//! attribute; and besides the mean radiance (channels R, G, B, what viewers
//! show) it carries each pixel's sample count and the exact double-precision
//! sum of its samples. `hybrid merge` adds the sums of the parts and divides
//! once, so the merged image is the one a single process would have made
//! (every sample has its own random stream, so a split changes nothing but
//! the order of one final addition).

use std::io::{Read, Seek};
use std::path::Path;

use exr::prelude::{read, AttributeValue, FlatSamples, ReadChannels, ReadLayers, Text};
use glam::{DVec3, Vec3};

use super::film::{Film, Origin, ToneMap, ATTRIBUTE, MAX_PIXELS, SUMS};
use super::Cell;

/// A part read back: its origin, tone map, and per pixel the sample count
/// and the sum.
#[derive(Debug)]
pub struct Part {
    pub origin: Origin,
    pub map: ToneMap,
    pub samples: Vec<u32>,
    pub sums: Vec<DVec3>,
}

/// The largest part file read: one run's most pixels at 40 bytes each,
/// with room for the EXR's own tables.
const MAX_PART_BYTES: u64 = (MAX_PIXELS + 1024) * 48;

/// Reads a part written by [`super::film::write_exr`]: a regular file of at most
/// [`MAX_PART_BYTES`] whose headers promise at most [`MAX_PIXELS`] pixels
/// (checked before any pixel is decoded), holding finite, non-negative sums
/// and the sample counts its attribute promises.
pub fn read_part(path: &Path) -> Result<Part, String> {
    let name = path.display();
    crate::input::check_regular(path, MAX_PART_BYTES).map_err(|e| format!("{name}: {e}"))?;
    let file = std::fs::File::open(path).map_err(|e| format!("{name}: {e}"))?;
    read_part_from(std::io::BufReader::new(file)).map_err(|e| format!("{name}: {e}"))
}

/// Reads a part from bytes in memory (as [`read_part`] does a file).
pub fn read_part_bytes(bytes: &[u8]) -> Result<Part, String> {
    read_part_from(std::io::Cursor::new(bytes))
}

fn read_part_from(mut input: impl Read + Seek) -> Result<Part, String> {
    let start = input.stream_position().map_err(|e| e.to_string())?;
    let meta = exr::meta::MetaData::read_from_buffered(&mut input, false)
        .map_err(|e| format!("not a readable EXR file ({e})"))?;
    for header in meta.headers.iter() {
        let size = header.layer_size;
        if size.0 as u64 * size.1 as u64 > MAX_PIXELS {
            return Err(format!(
                "its image is {} x {} pixels; a part holds at most {MAX_PIXELS} (one run's most)",
                size.0, size.1
            ));
        }
    }
    input
        .seek(std::io::SeekFrom::Start(start))
        .map_err(|e| e.to_string())?;
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_buffered(input)
        .map_err(|e| format!("not a readable EXR file ({e})"))?;
    let layer = &image.layer_data;
    let not_a_part = || {
        "not a partial render of hybrid (no hybrid.part attribute; render it with this version)"
            .to_string()
    };
    let text = match layer.attributes.other.get(&Text::from(ATTRIBUTE)) {
        Some(AttributeValue::Text(t)) => t.to_string(),
        _ => return Err(not_a_part()),
    };
    let (origin, map) =
        Origin::parse(&text).ok_or_else(|| format!("malformed hybrid.part attribute '{text}'"))?;
    let c = origin.cell;
    let inside =
        c.x.checked_add(c.width)
            .is_some_and(|e| e <= origin.frame.0)
            && c.y
                .checked_add(c.height)
                .is_some_and(|e| e <= origin.frame.1);
    if !inside || origin.samples.0 >= origin.samples.1 || origin.samples.1 > origin.total {
        return Err(format!("inconsistent hybrid.part attribute '{text}'"));
    }
    let (w, h) = (layer.size.0, layer.size.1);
    if (w, h) != (origin.cell.width as usize, origin.cell.height as usize) {
        return Err(format!(
            "the image is {w} x {h} but its attribute says the cell is {} x {}",
            origin.cell.width, origin.cell.height
        ));
    }
    let channel = |name: &str| -> Result<Vec<u32>, String> {
        let c = layer
            .channel_data
            .list
            .iter()
            .find(|c| c.name.eq(name))
            .ok_or_else(|| format!("channel '{name}' is missing"))?;
        match &c.sample_data {
            FlatSamples::U32(v) => Ok(v.clone()),
            _ => Err(format!("channel '{name}' is not 32-bit unsigned")),
        }
    };
    let samples = channel("samples")?;
    // What the attribute promises: every sample of the range (uniform), or
    // at least one batch and at most the cap (adaptive).
    let span = origin.samples.1 - origin.samples.0;
    let promised = |n: u32| match origin.adaptive {
        None => n == span,
        Some(_) => n >= 1 && n <= span,
    };
    if let Some(i) = samples.iter().position(|&n| !promised(n)) {
        return Err(format!(
            "pixel {i} of the cell holds {} samples where its attribute promises {}",
            samples[i],
            match origin.adaptive {
                None => format!("{span}"),
                Some(_) => format!("1 to {span}"),
            }
        ));
    }
    let words: Vec<Vec<u32>> = SUMS.iter().map(|n| channel(n)).collect::<Result<_, _>>()?;
    let f = |hi: &[u32], lo: &[u32], i: usize| {
        f64::from_bits((u64::from(hi[i]) << 32) | u64::from(lo[i]))
    };
    let sums: Vec<DVec3> = (0..w * h)
        .map(|i| {
            DVec3::new(
                f(&words[4], &words[5], i),
                f(&words[2], &words[3], i),
                f(&words[0], &words[1], i),
            )
        })
        .collect();
    // Radiance is finite and never negative, so neither are its sums.
    if let Some(i) = sums
        .iter()
        .position(|s| !s.is_finite() || s.min_element() < 0.0)
    {
        return Err(format!(
            "pixel {i} of the cell has the sum {} (radiance sums are finite and not negative)",
            sums[i]
        ));
    }
    Ok(Part {
        origin,
        map,
        samples,
        sums,
    })
}

/// Combines parts into the frame one process would have rendered. Every
/// part must describe the same frame, seed, sample total and tone map; no
/// two may share a pixel and a sample; and together they must cover every
/// sample of every pixel. `names` label the parts in errors.
pub fn merge(parts: &[Part], names: &[String]) -> Result<(Film, ToneMap), String> {
    let first = parts.first().ok_or("nothing to merge")?;
    let o = first.origin;
    for (p, name) in parts.iter().zip(names) {
        let q = p.origin;
        if q.frame != o.frame
            || q.total != o.total
            || q.seed != o.seed
            || q.adaptive != o.adaptive
            || p.map != first.map
        {
            return Err(format!(
                "{name}: a different render from {} (frame, samples per pixel, seed or shading differ)",
                names[0]
            ));
        }
    }
    for i in 0..parts.len() {
        for j in i + 1..parts.len() {
            let (a, b) = (parts[i].origin, parts[j].origin);
            let cells = a.cell.x < b.cell.x + b.cell.width
                && b.cell.x < a.cell.x + a.cell.width
                && a.cell.y < b.cell.y + b.cell.height
                && b.cell.y < a.cell.y + a.cell.height;
            let samples = a.samples.0 < b.samples.1 && b.samples.0 < a.samples.1;
            if cells && samples {
                return Err(format!(
                    "{} and {} overlap (both hold samples {}..{} of pixel ({}, {}))",
                    names[i],
                    names[j],
                    a.samples.0.max(b.samples.0),
                    a.samples.1.min(b.samples.1),
                    a.cell.x.max(b.cell.x),
                    a.cell.y.max(b.cell.y)
                ));
            }
        }
    }
    let (w, h) = o.frame;
    // The parts must cover the frame, so they hold at least its pixels:
    // checked before the frame's film is allocated.
    let held: u64 = parts
        .iter()
        .map(|p| u64::from(p.origin.cell.width) * u64::from(p.origin.cell.height))
        .sum();
    if u64::from(w) * u64::from(h) > held {
        return Err(format!(
            "the parts hold {held} pixels of a {w} x {h} frame: some are missing"
        ));
    }
    let mut film = Film::new(w, h);
    let mut covered = vec![0u64; w as usize * h as usize];
    for p in parts {
        let c = p.origin.cell;
        let span = u64::from(p.origin.samples.1 - p.origin.samples.0);
        for y in 0..c.height {
            for x in 0..c.width {
                let src = (y * c.width + x) as usize;
                let dst = ((c.y + y) * w + c.x + x) as usize;
                film.sums[dst] += p.sums[src];
                film.samples[dst] =
                    film.samples[dst]
                        .checked_add(p.samples[src])
                        .ok_or_else(|| {
                            format!(
                                "pixel ({}, {}) adds up to more than 2^32 samples",
                                c.x + x,
                                c.y + y
                            )
                        })?;
                covered[dst] += span;
            }
        }
    }
    if let Some(i) = covered.iter().position(|&n| n != u64::from(o.total)) {
        return Err(format!(
            "pixel ({}, {}) has {} of its {} samples: a part is missing",
            i as u32 % w,
            i as u32 / w,
            covered[i],
            o.total
        ));
    }
    for (pixel, (sum, &n)) in film
        .pixels
        .iter_mut()
        .zip(film.sums.iter().zip(&film.samples))
    {
        *pixel = if n == 0 {
            Vec3::ZERO
        } else {
            (*sum / f64::from(n)).as_vec3()
        };
    }
    film.origin = Origin {
        cell: Cell {
            x: 0,
            y: 0,
            width: w,
            height: h,
        },
        samples: (0, o.total),
        ..o
    };
    Ok((film, first.map))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::film::write_exr;
    use std::io::Cursor;

    /// A uniform part of `cell` at samples `range` of `total`, every pixel
    /// holding `samples` samples summing to `sum`.
    fn part(frame: (u32, u32), cell: Cell, range: (u32, u32), samples: u32, sum: DVec3) -> Vec<u8> {
        let mut film = Film::new(cell.width, cell.height);
        film.samples.iter_mut().for_each(|n| *n = samples);
        film.sums.iter_mut().for_each(|s| *s = sum);
        film.origin = Origin {
            frame,
            cell,
            samples: range,
            total: range.1,
            seed: 1,
            adaptive: None,
        };
        let mut out = Cursor::new(Vec::new());
        write_exr(&mut out, &film, ToneMap::REFERENCE).unwrap();
        out.into_inner()
    }

    fn read(bytes: Vec<u8>) -> Result<Part, String> {
        read_part_from(Cursor::new(bytes))
    }

    const CELL: Cell = Cell {
        x: 0,
        y: 0,
        width: 2,
        height: 2,
    };

    #[test]
    fn a_valid_part_reads_back() {
        let p = read(part((2, 2), CELL, (0, 4), 4, DVec3::splat(2.0))).unwrap();
        assert_eq!(p.samples, vec![4; 4]);
        assert_eq!(p.sums[3], DVec3::splat(2.0));
    }

    #[test]
    fn a_field_given_twice_is_not_an_attribute() {
        let o = Origin::whole(2, 2);
        let text = o.text(ToneMap::REFERENCE);
        assert!(Origin::parse(&text).is_some(), "{text}");
        let twice = format!("frame 4 4; {text}");
        assert!(Origin::parse(&twice).is_none(), "{twice} was accepted");
    }

    #[test]
    fn a_part_keeps_its_exposure_so_the_merged_png_has_it_too() {
        let o = Origin::whole(2, 2);
        for ev in [1.5, -2.25, 0.0] {
            let map = ToneMap::Reference(super::super::film::Exposure::stops(ev).unwrap());
            let text = o.text(map);
            assert_eq!(Origin::parse(&text).map(|(_, m)| m), Some(map), "{text}");
        }
        let bad = o.text(ToneMap::REFERENCE) + " nan";
        assert!(Origin::parse(&bad).is_none(), "{bad} was accepted");
    }

    #[test]
    fn parts_with_impossible_sums_are_refused() {
        for bad in [
            DVec3::new(f64::NAN, 0.0, 0.0),
            DVec3::new(0.0, f64::INFINITY, 0.0),
            DVec3::new(0.0, 0.0, -1.0),
        ] {
            let e = read(part((2, 2), CELL, (0, 4), 4, bad)).unwrap_err();
            assert!(e.contains("finite and not negative"), "{bad}: {e}");
        }
    }

    #[test]
    fn parts_short_of_their_promised_samples_are_refused() {
        let e = read(part((2, 2), CELL, (0, 4), 0, DVec3::ZERO)).unwrap_err();
        assert!(e.contains("promises 4"), "{e}");
        let e = read(part((2, 2), CELL, (0, 4), 5, DVec3::ZERO)).unwrap_err();
        assert!(e.contains("promises 4"), "{e}");
    }

    #[test]
    fn a_declared_frame_larger_than_its_parts_fails_before_allocating() {
        // 65536 x 65536 would be a 160 GiB film; the part holds 4 pixels.
        let p = read(part((65536, 65536), CELL, (0, 4), 4, DVec3::ONE)).unwrap();
        let e = merge(&[p], &["huge.exr".into()]).unwrap_err();
        assert!(e.contains("some are missing"), "{e}");
    }
}
