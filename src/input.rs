//! Reading what users hand in (scene files, camera files, environment
//! maps, merge parts) under the same promise: only regular files are read
//! (a FIFO would block, a device never end), never more than a stated cap,
//! and an error quotes at most a short prefix of what it found.

use std::io::Read;
use std::path::Path;

/// The most characters of a found token an error line repeats.
pub const QUOTE_CHARS: usize = 40;

/// `token` as an error line quotes it: whole when short, else its first
/// [`QUOTE_CHARS`] characters and how long it was.
pub fn quote(token: &str) -> String {
    match token.char_indices().nth(QUOTE_CHARS) {
        None => token.to_string(),
        Some((end, _)) => format!("{}… ({} bytes)", &token[..end], token.len()),
    }
}

/// The size of `path` if it is a regular file of at most `max_bytes`,
/// else the reason (prefixed by nothing: the caller names the file).
pub fn check_regular(path: &Path, max_bytes: u64) -> Result<u64, String> {
    let meta = std::fs::metadata(path).map_err(|e| e.to_string())?;
    if !meta.is_file() {
        return Err("not a regular file (a directory, device, FIFO or socket)".into());
    }
    if meta.len() > max_bytes {
        return Err(format!(
            "{} bytes; files over {max_bytes} bytes are refused here",
            meta.len()
        ));
    }
    Ok(meta.len())
}

/// The bytes of `path`, a regular file of at most `max_bytes` (a file that
/// grows past the cap while it is read is refused too).
pub fn read_regular(path: &Path, max_bytes: u64) -> Result<Vec<u8>, String> {
    let len = check_regular(path, max_bytes)?;
    let file = std::fs::File::open(path).map_err(|e| e.to_string())?;
    let mut bytes = Vec::with_capacity(len as usize);
    file.take(max_bytes.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(|e| e.to_string())?;
    if bytes.len() as u64 > max_bytes {
        return Err(format!("grew past {max_bytes} bytes while being read"));
    }
    Ok(bytes)
}

/// Bytes this process may still allocate: the smaller of what the system
/// has available (`MemAvailable`) and what its address-space limit
/// (`ulimit -v`) leaves beside what it has mapped; `None` when neither can
/// be read.
pub fn memory_available() -> Option<u64> {
    let meminfo = std::fs::read_to_string("/proc/meminfo").ok();
    let available = meminfo.as_deref().and_then(|m| {
        m.lines()
            .find_map(|l| l.strip_prefix("MemAvailable:"))
            .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
            .map(|kib| kib << 10)
    });
    let mut limit = libc::rlimit {
        rlim_cur: 0,
        rlim_max: 0,
    };
    // SAFETY: getrlimit writes the limit into the struct we own.
    let capped = unsafe { libc::getrlimit(libc::RLIMIT_AS, &mut limit) } == 0
        && limit.rlim_cur != libc::RLIM_INFINITY;
    // `rlim_t` is narrower than u64 on some targets.
    #[allow(clippy::unnecessary_cast)]
    let cur = limit.rlim_cur as u64;
    let left_by_limit = capped.then(|| {
        let mapped = std::fs::read_to_string("/proc/self/statm")
            .ok()
            .and_then(|s| s.split_whitespace().next()?.parse::<u64>().ok())
            .map_or(0, |pages| pages * 4096);
        cur.saturating_sub(mapped)
    });
    match (available, left_by_limit) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, b) => a.or(b),
    }
}

/// `Err` naming `what` and the memory it would take when `bytes` is more
/// than [`memory_available`]: checked before the work, so a count the
/// machine cannot hold is refused at once instead of aborting on
/// allocation minutes later.
pub fn check_memory(what: &str, bytes: u64) -> Result<(), String> {
    let gib = |b: u64| b as f64 / (1u64 << 30) as f64;
    match memory_available() {
        Some(free) if bytes > free => Err(format!(
            "{what} would take about {:.1} GiB of memory, and {:.1} GiB is available here",
            gib(bytes),
            gib(free)
        )),
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quote_keeps_short_tokens_and_cuts_long_ones() {
        assert_eq!(quote("1.5e3"), "1.5e3");
        let long = "9".repeat(1_000_000);
        let q = quote(&long);
        assert!(q.len() < 80, "{q}");
        assert!(q.ends_with("(1000000 bytes)"), "{q}");
        // Never cuts inside a character.
        assert_eq!(
            quote(&"é".repeat(50)).chars().filter(|&c| c == 'é').count(),
            40
        );
    }

    #[test]
    fn only_regular_files_under_the_cap_are_read() {
        let dir = std::env::temp_dir().join(format!("hybrid-input-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("f.txt");
        std::fs::write(&file, b"0123456789").unwrap();
        assert_eq!(read_regular(&file, 10).unwrap(), b"0123456789");
        assert!(read_regular(&file, 9).unwrap_err().contains("10 bytes"));
        assert!(read_regular(&dir, 1 << 20)
            .unwrap_err()
            .contains("not a regular file"));
        assert!(read_regular(Path::new("/dev/zero"), 1 << 20)
            .unwrap_err()
            .contains("not a regular file"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
