//! Finding and loading an Embree library at run time, and what both
//! versions' FFI modules share: the error sink their callbacks write to.
//!
//! Embree 3 and Embree 4 export the same `rtc*` names, so a process that
//! linked one the ordinary way would have every call of the other resolved
//! to it. Each is opened with `dlopen(RTLD_NOW | RTLD_LOCAL)` instead: its
//! symbols (and those of the TBB it brings, Debian's for Embree 3, the
//! wheel's renamed copy for Embree 4) stay in its own scope, and hybrid
//! reaches its functions only through the table read from that handle.

use std::ffi::{c_char, c_void, CStr, OsString};
use std::path::PathBuf;
use std::sync::atomic::{AtomicI64, Ordering};
use std::sync::Mutex;

use libloading::os::unix::{Library, RTLD_LOCAL, RTLD_NOW};

/// Where `scripts/setup.sh` puts the Embree 4 of the `embreex` wheel on
/// Debian 12, under the user's home.
pub const EMBREE4_USER_DIR: &str = ".local/lib/hybrid/embree4";

/// The files to try for one Embree version, in order: the path in
/// `override_var` when set (then only it), else the system's library by
/// its SONAME, else the same name in `user_dir` under the user's home.
pub fn candidates(override_var: &str, soname: &str, user_dir: Option<&str>) -> Vec<OsString> {
    if let Some(path) = std::env::var_os(override_var) {
        return vec![path];
    }
    let mut list = vec![OsString::from(soname)];
    if let (Some(home), Some(dir)) = (std::env::var_os("HOME"), user_dir) {
        list.push(PathBuf::from(home).join(dir).join(soname).into_os_string());
    }
    list
}

/// Opens the first of `candidates` that loads, or says why none did.
pub fn open(candidates: &[OsString]) -> Result<(Library, String), String> {
    let mut errors = Vec::new();
    for name in candidates {
        // SAFETY: loading Embree runs its static initialisers (C++ globals
        // and TBB's), which have no preconditions on the caller; RTLD_LOCAL
        // keeps its symbols from interposing on anything else.
        match unsafe { Library::open(Some(name), RTLD_NOW | RTLD_LOCAL) } {
            Ok(library) => return Ok((library, name.to_string_lossy().into_owned())),
            Err(e) => errors.push(e.to_string()),
        }
    }
    Err(errors.join("; "))
}

/// `Err` unless `library` is the Embree major version `major`, judged by
/// a function only that version exports (`marker`) and one only the other
/// exports (`foreign`): Embree 4 added `rtcForwardIntersect1` and removed
/// Embree 3's `rtcIntersect1M`. A library of the other version would take
/// the table's calls with other struct layouts and crash; an override
/// (`HYBRID_EMBREE3`, `HYBRID_EMBREE4`) naming the wrong one is refused
/// here instead.
pub fn check_version(
    library: &Library,
    path: &str,
    major: u32,
    marker: &str,
    foreign: &str,
) -> Result<(), String> {
    let has = |name: &str| {
        let symbol = format!("{name}\0");
        // SAFETY: only looks the name up (dlsym); nothing is called or read
        // through the address.
        unsafe { library.get::<*const c_void>(symbol.as_bytes()) }.is_ok()
    };
    let (ours, theirs) = (has(marker), has(foreign));
    if ours && !theirs {
        return Ok(());
    }
    let says = |exported: bool| if exported { "exports" } else { "lacks" };
    Err(format!(
        "{path} is not Embree {major}: it {} {marker} and {} {foreign} ({})",
        says(ours),
        says(theirs),
        if theirs {
            "another Embree major version"
        } else {
            "not Embree"
        }
    ))
}

/// Where a device's last error is kept until the next check reads it, and
/// the bytes Embree holds on the device (its memory monitor callback).
pub struct ErrorSink {
    pub last: Mutex<Option<String>>,
    pub bytes: AtomicI64,
}

impl ErrorSink {
    pub fn new() -> Box<ErrorSink> {
        Box::new(ErrorSink {
            last: Mutex::new(None),
            bytes: AtomicI64::new(0),
        })
    }

    /// The message recorded since the last call, if any.
    pub fn take(&self) -> Option<String> {
        self.last.lock().ok().and_then(|mut m| m.take())
    }

    pub fn memory_bytes(&self) -> usize {
        self.bytes.load(Ordering::Relaxed).max(0) as usize
    }
}

/// Embree's error codes (`RTCError`, the same values in versions 3 and 4).
pub fn error_name(code: u32) -> &'static str {
    match code {
        0 => "no error",
        1 => "unknown error",
        2 => "invalid argument",
        3 => "invalid operation",
        4 => "out of memory",
        5 => "unsupported CPU",
        6 => "cancelled",
        _ => "unknown error",
    }
}

/// Embree's memory monitor callback: only adds to an atomic counter, so it
/// cannot unwind. Returning true lets the allocation proceed.
pub unsafe extern "C" fn track_memory(user: *mut c_void, bytes: isize, _post: bool) -> bool {
    // SAFETY: `user` is the `ErrorSink` registered with the device, alive
    // until the callback is unregistered when the device is dropped.
    let sink = unsafe { &*(user as *const ErrorSink) };
    sink.bytes.fetch_add(bytes as i64, Ordering::Relaxed);
    true
}

/// Embree's error callback. Never unwinds: the body runs under
/// `catch_unwind` and a poisoned lock is skipped. The code is taken as the
/// `u32` it is in C, so a value newer than our bindings cannot be an
/// invalid Rust enum.
pub unsafe extern "C" fn record_error(user: *mut c_void, code: u32, message: *const c_char) {
    let _ = std::panic::catch_unwind(|| {
        // SAFETY: `user` is the `ErrorSink` registered with the device; the
        // callback is unregistered before the sink is freed. `message` is a
        // NUL-terminated string owned by Embree for the duration of the call
        // (or null).
        let sink = unsafe { &*(user as *const ErrorSink) };
        let text = if message.is_null() {
            String::new()
        } else {
            // SAFETY: `message` is not null and, as said above, a
            // NUL-terminated string Embree owns during the call.
            unsafe { CStr::from_ptr(message) }
                .to_string_lossy()
                .into_owned()
        };
        if let Ok(mut last) = sink.last.lock() {
            *last = Some(format!("{} ({})", text, error_name(code)));
        }
    });
}

/// `Err` with the recorded message (or the code's name) unless both say
/// nothing went wrong.
pub fn check(code: u32, sink: &ErrorSink) -> Result<(), String> {
    match (code, sink.take()) {
        (0, None) => Ok(()),
        (_, Some(m)) => Err(m),
        (c, None) => Err(error_name(c).to_string()),
    }
}

/// A hit as Embree reports it (either version).
#[derive(Clone, Copy, Debug)]
pub struct RawHit {
    pub t: f32,
    pub geometry: u32,
    pub primitive: u32,
    pub u: f32,
    pub v: f32,
}

/// `RTC_INVALID_GEOMETRY_ID`.
pub const INVALID_GEOMETRY_ID: u32 = u32::MAX;
