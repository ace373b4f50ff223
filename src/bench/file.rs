//! The exported ray sets and triangles (`docs/rays.md`): little-endian,
//! a 24-byte header, then the records. Small enough to read from any
//! language in twenty lines, so that another program can replay exactly
//! the rays hybrid times.
//!
//! - `NAME.rays`: magic `HYBRAYS1`, `u32` query (0 closest hit, 1 any
//!   hit), `u32` 0, `u64` count, then per ray eight `f32`: origin xyz,
//!   direction xyz, `t_min`, `t_max`.
//! - `triangles.bin`: magic `HYBTRIS1`, `u32` 9, `u32` 0, `u64` count,
//!   then per triangle nine `f32`: its corners, world space.

use std::io::Write;
use std::path::Path;

use crate::geom::ray::FlatRay;
use crate::measure::Query;

const RAYS_MAGIC: &[u8; 8] = b"HYBRAYS1";
const TRIANGLES_MAGIC: &[u8; 8] = b"HYBTRIS1";
const HEADER: usize = 24;

/// The largest file read: 2^27 rays (4 GiB) or as many triangles' bytes.
const MAX_BYTES: u64 = (1 << 32) + HEADER as u64;

/// Why a file is not a ray set or a triangle file.
#[derive(Debug, thiserror::Error)]
pub enum FileError {
    #[error("{file}: {why}")]
    Bad { file: String, why: String },
    #[error("{file}: cannot {what}: {source}")]
    Io {
        file: String,
        what: &'static str,
        source: std::io::Error,
    },
}

fn bad(path: &Path, why: impl Into<String>) -> FileError {
    FileError::Bad {
        file: path.display().to_string(),
        why: why.into(),
    }
}

fn write(
    path: &Path,
    magic: &[u8; 8],
    tag: u32,
    records: &[f32],
    per: usize,
) -> Result<(), FileError> {
    let io = |source| FileError::Io {
        file: path.display().to_string(),
        what: "write",
        source,
    };
    let mut bytes = Vec::with_capacity(HEADER + records.len() * 4);
    bytes.extend_from_slice(magic);
    bytes.extend_from_slice(&tag.to_le_bytes());
    bytes.extend_from_slice(&0u32.to_le_bytes());
    bytes.extend_from_slice(&((records.len() / per) as u64).to_le_bytes());
    for x in records {
        bytes.extend_from_slice(&x.to_le_bytes());
    }
    let mut file = std::fs::File::create(path).map_err(io)?;
    file.write_all(&bytes).map_err(io)
}

/// Reads a file of `magic` with records of `per` floats: the header's tag
/// and the floats. The size must be exactly what the header promises.
fn read(path: &Path, magic: &[u8; 8], per: usize) -> Result<(u32, Vec<f32>), FileError> {
    let bytes = crate::input::read_regular(path, MAX_BYTES).map_err(|e| bad(path, e))?;
    parse(&bytes, path, magic, per)
}

/// [`read`] of bytes already in memory, `path` naming them in errors.
fn parse(
    bytes: &[u8],
    path: &Path,
    magic: &[u8; 8],
    per: usize,
) -> Result<(u32, Vec<f32>), FileError> {
    if bytes.len() < HEADER || &bytes[..8] != magic {
        return Err(bad(
            path,
            format!("not a {} file", String::from_utf8_lossy(magic)),
        ));
    }
    let word = |at: usize| u32::from_le_bytes(bytes[at..at + 4].try_into().expect("4 bytes"));
    let count = u64::from_le_bytes(bytes[16..24].try_into().expect("8 bytes"));
    let expected = count
        .checked_mul(per as u64 * 4)
        .and_then(|b| b.checked_add(HEADER as u64));
    if expected != Some(bytes.len() as u64) {
        return Err(bad(
            path,
            format!(
                "its header promises {count} records of {per} floats, but it holds {} bytes",
                bytes.len()
            ),
        ));
    }
    if word(12) != 0 {
        return Err(bad(path, "the reserved header word is not 0"));
    }
    let floats = bytes[HEADER..]
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes")))
        .collect();
    Ok((word(8), floats))
}

pub fn write_rays(path: &Path, query: Query, rays: &[FlatRay]) -> Result<(), FileError> {
    let tag = match query {
        Query::Closest => 0,
        Query::Occluded => 1,
    };
    write(path, RAYS_MAGIC, tag, rays.as_flattened(), 8)
}

pub fn read_rays(path: &Path) -> Result<(Query, Vec<FlatRay>), FileError> {
    let bytes = crate::input::read_regular(path, MAX_BYTES).map_err(|e| bad(path, e))?;
    parse_rays(&bytes, path)
}

/// A ray file's bytes as [`read_rays`] checks them (the fuzz target `rays`
/// feeds it arbitrary bytes).
pub fn parse_rays(bytes: &[u8], path: &Path) -> Result<(Query, Vec<FlatRay>), FileError> {
    let (tag, floats) = parse(bytes, path, RAYS_MAGIC, 8)?;
    let query = match tag {
        0 => Query::Closest,
        1 => Query::Occluded,
        q => {
            return Err(bad(
                path,
                format!("unknown query {q} (0 closest, 1 any hit)"),
            ))
        }
    };
    let rays: Vec<FlatRay> = floats
        .chunks_exact(8)
        .map(|c| c.try_into().expect("8 floats"))
        .collect();
    if rays.is_empty() {
        return Err(bad(path, "holds no rays: there is nothing to time"));
    }
    for (i, ray) in rays.iter().enumerate() {
        check_ray(ray).map_err(|why| bad(path, format!("ray {i}: {why}")))?;
    }
    Ok((query, rays))
}

/// `Err` with the reason when a ray is not one every backend takes as it
/// is: Embree asserts on non-finite or out-of-range origins and
/// directions and on `t_min` outside `[0, t_max]` (its `ray.valid()`),
/// where the other backends would treat the ray as a miss, so a replay of
/// such a ray would time different work on each.
fn check_ray(ray: &FlatRay) -> Result<(), String> {
    let limit = crate::geom::ray::COORDINATE_LIMIT;
    let in_range = |v: &[f32]| v.iter().all(|x| x.is_finite() && x.abs() <= limit);
    let (origin, dir, t_min, t_max) = (&ray[0..3], &ray[3..6], ray[6], ray[7]);
    if !in_range(origin) {
        return Err(format!(
            "origin {origin:?} is not finite within ±{limit:e} (Embree's range)"
        ));
    }
    if !in_range(dir) || dir.iter().all(|&x| x == 0.0) {
        return Err(format!(
            "direction {dir:?} is not a finite non-zero vector within ±{limit:e}"
        ));
    }
    // Written so that NaN fails every test.
    if !(t_min.is_finite() && t_min >= 0.0 && t_max >= t_min) {
        return Err(format!(
            "t from {t_min} to {t_max} is not 0 <= t_min <= t_max"
        ));
    }
    Ok(())
}

pub fn write_triangles(path: &Path, triangles: &[[f32; 9]]) -> Result<(), FileError> {
    write(path, TRIANGLES_MAGIC, 9, triangles.as_flattened(), 9)
}

pub fn read_triangles(path: &Path) -> Result<Vec<[f32; 9]>, FileError> {
    let (tag, floats) = read(path, TRIANGLES_MAGIC, 9)?;
    if tag != 9 {
        return Err(bad(path, format!("{tag} floats per triangle; expected 9")));
    }
    if floats.iter().any(|x| !x.is_finite()) {
        return Err(bad(path, "a corner is not a finite number"));
    }
    Ok(floats
        .chunks_exact(9)
        .map(|c| c.try_into().expect("9 floats"))
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rays_and_triangles_round_trip_and_short_files_are_refused() {
        let dir = std::env::temp_dir().join(format!("hybrid-file-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let rays = vec![[1.0, 2.0, 3.0, 0.0, 0.0, -1.0, 0.0, f32::INFINITY]; 3];
        let p = dir.join("a.rays");
        write_rays(&p, Query::Occluded, &rays).unwrap();
        let (q, back) = read_rays(&p).unwrap();
        assert_eq!((q, back.len()), (Query::Occluded, 3));
        assert_eq!(back[2], rays[2]);
        // One byte short of the promise.
        let bytes = std::fs::read(&p).unwrap();
        std::fs::write(&p, &bytes[..bytes.len() - 1]).unwrap();
        let e = read_rays(&p).unwrap_err().to_string();
        assert!(e.contains("promises 3 records"), "{e}");
        let t = dir.join("triangles.bin");
        write_triangles(&t, &[[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]]).unwrap();
        assert_eq!(read_triangles(&t).unwrap().len(), 1);
        assert!(read_rays(&t)
            .unwrap_err()
            .to_string()
            .contains("not a HYBRAYS1"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
