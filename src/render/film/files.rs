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
