//! Finds Embree, links it, and generates its bindings with bindgen.
//!
//! Search order: `EMBREE_DIR` (a prefix with `include/` and `lib/`),
//! `pkg-config embree4`, then the Debian 12 layout (`/usr/include/embree3`,
//! `libembree3.so`, no pkg-config file). Emits `cfg(embree_major = "3")` or
//! `"4"` for the few API differences.

use std::env;
use std::path::{Path, PathBuf};
use std::process::Command;

const INSTALL_HINT: &str = "install the Debian packages with `apt-get install -y libembree-dev libclang-dev` (Debian 12: Embree 3; Debian 13: Embree 4), or set EMBREE_DIR to an Embree prefix";

struct Embree {
    major: u32,
    include_dirs: Vec<PathBuf>,
    lib_dirs: Vec<PathBuf>,
    lib: String,
}

fn from_prefix(prefix: &Path) -> Option<Embree> {
    for major in [4, 3] {
        let header = prefix.join(format!("include/embree{major}/rtcore.h"));
        if header.exists() {
            return Some(Embree {
                major,
                include_dirs: vec![prefix.join("include")],
                lib_dirs: vec![prefix.join("lib"), prefix.join("lib64")],
                lib: format!("embree{major}"),
            });
        }
    }
    None
}

fn from_pkg_config() -> Option<Embree> {
    let run = |arg: &str| -> Option<String> {
        let out = Command::new("pkg-config")
            .args([arg, "embree4"])
            .output()
            .ok()?;
        out.status
            .success()
            .then(|| String::from_utf8_lossy(&out.stdout).into_owned())
    };
    let cflags = run("--cflags-only-I")?;
    let libs = run("--libs-only-L")?;
    let include_dirs: Vec<PathBuf> = cflags
        .split_whitespace()
        .filter_map(|f| f.strip_prefix("-I"))
        .map(PathBuf::from)
        .collect();
    let lib_dirs = libs
        .split_whitespace()
        .filter_map(|f| f.strip_prefix("-L"))
        .map(PathBuf::from)
        .collect();
    // pkg-config may point at .../include/embree4 or at .../include.
    let include_dirs = include_dirs
        .into_iter()
        .map(|d| {
            if d.ends_with("embree4") {
                d.parent().map(Path::to_path_buf).unwrap_or(d)
            } else {
                d
            }
        })
        .chain(std::iter::once(PathBuf::from("/usr/include")))
        .collect();
    Some(Embree {
        major: 4,
        include_dirs,
        lib_dirs,
        lib: "embree4".into(),
    })
}

fn from_debian() -> Option<Embree> {
    for major in [4, 3] {
        if Path::new(&format!("/usr/include/embree{major}/rtcore.h")).exists() {
            let lib = format!("libembree{major}.so");
            let lib_dirs: Vec<PathBuf> = [
                "/usr/lib/x86_64-linux-gnu",
                "/usr/lib/aarch64-linux-gnu",
                "/usr/lib",
                "/usr/local/lib",
            ]
            .iter()
            .map(PathBuf::from)
            .filter(|d| d.join(&lib).exists())
            .collect();
            if !lib_dirs.is_empty() {
                return Some(Embree {
                    major,
                    include_dirs: vec![PathBuf::from("/usr/include")],
                    lib_dirs,
                    lib: format!("embree{major}"),
                });
            }
        }
    }
    None
}

fn fail(what: &str) -> ! {
    eprintln!("error: hybrid cannot build: {what}; {INSTALL_HINT}");
    std::process::exit(1);
}

fn main() {
    println!("cargo:rerun-if-changed=ffi/embree.h");
    println!("cargo:rerun-if-env-changed=EMBREE_DIR");
    println!("cargo:rustc-check-cfg=cfg(embree_major, values(\"3\", \"4\"))");

    let embree = match env::var_os("EMBREE_DIR") {
        Some(dir) => from_prefix(Path::new(&dir)).unwrap_or_else(|| fail(&format!("EMBREE_DIR={} holds no include/embree3 or include/embree4", Path::new(&dir).display()))),
        None => from_pkg_config().or_else(from_debian).unwrap_or_else(|| fail("Embree was not found (no EMBREE_DIR, no pkg-config embree4, no /usr/include/embree3)")),
    };
    for dir in &embree.lib_dirs {
        println!("cargo:rustc-link-search=native={}", dir.display());
    }
    println!("cargo:rustc-link-lib=dylib={}", embree.lib);
    println!("cargo:rustc-cfg=embree_major=\"{}\"", embree.major);
    println!("cargo:rustc-env=HYBRID_EMBREE_MAJOR={}", embree.major);
    // The compiler's version, for the report's header.
    let rustc = env::var("RUSTC").unwrap_or_else(|_| "rustc".into());
    let version = Command::new(rustc)
        .arg("--version")
        .output()
        .ok()
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string());
    println!(
        "cargo:rustc-env=HYBRID_RUSTC_VERSION={}",
        version.unwrap_or_else(|| "unknown".into())
    );

    if !clang_sys_available() {
        fail("libclang (needed by bindgen) was not found");
    }
    let mut builder = bindgen::Builder::default()
        .header("ffi/embree.h")
        .clang_arg(format!("-DHYBRID_EMBREE_MAJOR={}", embree.major))
        .allowlist_function("rtc.*")
        .allowlist_type("RTC.*")
        .allowlist_var("RTC_.*")
        .prepend_enum_name(false)
        .derive_default(true)
        .layout_tests(false)
        .generate_comments(false);
    for dir in &embree.include_dirs {
        builder = builder.clang_arg(format!("-I{}", dir.display()));
    }
    let bindings =
        match std::panic::catch_unwind(std::panic::AssertUnwindSafe(move || builder.generate())) {
            Ok(Ok(b)) => b,
            Ok(Err(e)) => fail(&format!("bindgen could not read Embree's headers ({e})")),
            Err(_) => fail("bindgen failed (is libclang installed?)"),
        };
    let out =
        PathBuf::from(env::var("OUT_DIR").expect("cargo sets OUT_DIR")).join("embree_bindings.rs");
    bindings
        .write_to_file(&out)
        .unwrap_or_else(|e| fail(&format!("cannot write {}: {e}", out.display())));
}

/// True when a libclang shared library can be found where bindgen looks.
fn clang_sys_available() -> bool {
    if let Some(p) = env::var_os("LIBCLANG_PATH") {
        return Path::new(&p).exists();
    }
    let dirs = [
        "/usr/lib/x86_64-linux-gnu",
        "/usr/lib/aarch64-linux-gnu",
        "/usr/lib",
        "/usr/local/lib",
        "/usr/lib64",
    ];
    let llvm = (7..=30).map(|v| format!("/usr/lib/llvm-{v}/lib"));
    dirs.iter().map(|s| s.to_string()).chain(llvm).any(|d| {
        std::fs::read_dir(&d)
            .map(|entries| {
                entries.flatten().any(|e| {
                    let name = e.file_name().to_string_lossy().into_owned();
                    name.starts_with("libclang.so")
                        || (name.starts_with("libclang-")
                            && !name.contains("cpp")
                            && name.contains(".so"))
                })
            })
            .unwrap_or(false)
    })
}
