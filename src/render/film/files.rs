//! Writing image files whole or not at all: under a temporary name, renamed
//! into place once every file of a write is complete, removed by a signal
//! handler that interrupts the write.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard};

use super::{FilmError, ImageFile};

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
/// to this process and the name, and short whatever the name's length (a
/// name of 255 bytes, the most a folder entry holds, still has one).
fn temporary(path: &Path) -> PathBuf {
    temporary_as(path, "partial")
}

/// A hidden name beside `path` of the given kind, as [`temporary`].
fn temporary_as(path: &Path, kind: &str) -> PathBuf {
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    path.file_name().hash(&mut h);
    path.with_file_name(format!(
        ".hybrid-{}-{:016x}.{kind}",
        std::process::id(),
        h.finish()
    ))
}

/// Creates `tmp` as a new file: never through what is already there (a
/// symbolic link planted at the name would otherwise have its target
/// truncated). An entry left at the name (by a crash of this process id,
/// or planted) is removed first, the entry itself, not what it points to.
fn create_new(tmp: &Path) -> std::io::Result<File> {
    let open = || {
        std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(tmp)
    };
    match open() {
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
            std::fs::remove_file(tmp)?;
            open()
        }
        other => other,
    }
}

/// `Err` when something other than a regular file has the output's name: a
/// directory, a symbolic link, a device, a FIFO or a socket. The finished
/// image is renamed onto the name, which would replace such an entry
/// rather than write through it, so it is refused instead.
fn refuse_special(path: &Path) -> Result<(), String> {
    if path.as_os_str().as_encoded_bytes().ends_with(b"/") {
        return Err("ends with '/': that names a folder, not a file".into());
    }
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
                let file = create_new(&tmp).map_err(|e| fail(path, e.to_string()))?;
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
        // Each file already there is kept under a second name (a hard
        // link) until every rename has succeeded: if one fails, the files
        // renamed before it are put back as they were, so a failed write
        // replaces nothing (the main image is not replaced when its
        // companion cannot be).
        let mut kept: Vec<Option<PathBuf>> = Vec::new();
        for (path, _) in files {
            let backup = temporary_as(path, "previous");
            let _ = std::fs::remove_file(&backup);
            kept.push(std::fs::hard_link(path, &backup).ok().map(|()| backup));
        }
        let restore = |k: usize| {
            for ((done, _), old) in files[..k].iter().zip(&kept) {
                match old {
                    Some(backup) => {
                        let _ = std::fs::rename(backup, done);
                    }
                    None => {
                        let _ = std::fs::remove_file(done);
                    }
                }
            }
            for old in kept[k..].iter().flatten() {
                let _ = std::fs::remove_file(old);
            }
        };
        for (k, ((path, _), tmp)) in files.iter().zip(&written).enumerate() {
            if let Err(e) = std::fs::rename(tmp, path) {
                restore(k);
                return Err(fail(path, e.to_string()));
            }
        }
        for old in kept.iter().flatten() {
            let _ = std::fs::remove_file(old);
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
    // Only `1` holds: `0`, an empty value or anything else does not, as an
    // option's value would be read (no test leaves a writer parked by a
    // value that meant "off").
    if std::env::var_os(HOLD_WRITE_VARIABLE).is_some_and(|v| v == "1") {
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
    create_new(&tmp).map_err(|e| fail(e.to_string()))?;
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A symbolic link planted at the temporary name does not let a write
    /// truncate its target: the link is replaced by the new file, and the
    /// target keeps its bytes; nothing is left at the temporary name.
    #[test]
    fn a_link_at_the_temporary_name_does_not_reach_its_target() {
        let dir = std::env::temp_dir().join(format!("hybrid-files-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (out, victim) = (dir.join("out.txt"), dir.join("victim.txt"));
        std::fs::write(&victim, b"keep me").unwrap();
        std::os::unix::fs::symlink(&victim, temporary(&out)).unwrap();
        write_files(&[(&out, ImageFile::Text("new"))]).unwrap();
        assert_eq!(std::fs::read(&victim).unwrap(), b"keep me");
        assert_eq!(std::fs::read(&out).unwrap(), b"new");
        assert!(std::fs::symlink_metadata(temporary(&out)).is_err());
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// The temporary name stays short for the longest name a folder
    /// holds.
    #[test]
    fn temporary_names_fit_beside_any_name() {
        let long = Path::new("x").join("n".repeat(255));
        let tmp = temporary(&long);
        assert!(tmp.file_name().unwrap().len() < 64, "{tmp:?}");
        assert_eq!(tmp.parent(), long.parent());
    }
}
