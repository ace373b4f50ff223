//! Generates Embree 3's bindings with bindgen, as a table of functions
//! loaded at run time, compiles the plain-C Embree driver
//! (`csrc/embree_plain.c`, the report's baseline), and records the
//! compiler's version for the report.
//!
//! No Embree is linked. Embree 3 and Embree 4 export the same `rtc*` symbol
//! names, so at most one of them could be linked the ordinary way; hybrid
//! loads both with `dlopen` (`src/accel/embree/`), each into its own symbol
//! scope. Embree 3's types come from its headers here (`EMBREE_DIR`, a
//! prefix with `include/embree3`, or Debian 12's `/usr/include/embree3`);
//! without them the binary is built without Embree 3 (`cfg(hybrid_embree3)`
//! unset) and says so when asked for it. Embree 4's types come from the
//! `embree4-sys` crate, whose build script asks the linker for `embree4`:
//! an empty linker script of that name satisfies the request, since the
//! library is loaded, never linked.

use std::env;
use std::path::{Path, PathBuf};
use std::process::Command;

const INSTALL_HINT: &str =
    "install the Debian packages with `apt-get install -y libembree-dev libclang-dev` (bash scripts/setup.sh does)";

fn fail(what: &str) -> ! {
    eprintln!("error: hybrid cannot build: {what}; {INSTALL_HINT}");
    std::process::exit(1);
}

/// The folder holding `embree3/rtcore.h`, if any.
fn embree3_include() -> Option<PathBuf> {
    let candidates = env::var_os("EMBREE_DIR")
        .map(|d| Path::new(&d).join("include"))
        .into_iter()
        .chain(std::iter::once(PathBuf::from("/usr/include")));
    candidates
        .into_iter()
        .find(|d| d.join("embree3/rtcore.h").exists())
}

fn main() {
    println!("cargo:rerun-if-changed=ffi/embree.h");
    println!("cargo:rerun-if-env-changed=EMBREE_DIR");
    println!("cargo:rustc-check-cfg=cfg(hybrid_embree3)");
    let out = PathBuf::from(env::var("OUT_DIR").expect("cargo sets OUT_DIR"));

    // embree4-sys's `cargo:rustc-link-lib=embree4`, answered without a
    // library: GNU ld and lld read a file they do not recognise as a linker
    // script, and one holding only a comment adds nothing to the link.
    let stub = out.join("embree4-link");
    std::fs::create_dir_all(&stub)
        .unwrap_or_else(|e| fail(&format!("cannot create {}: {e}", stub.display())));
    std::fs::write(
        stub.join("libembree4.so"),
        "/* hybrid loads Embree 4 at run time (dlopen); nothing is linked. */\n",
    )
    .unwrap_or_else(|e| fail(&format!("cannot write the embree4 link stub: {e}")));
    println!("cargo:rustc-link-search=native={}", stub.display());

    // Embree as a plain C caller calls it: the baseline the report and
    // `hybrid bench` compare with (it takes the functions as pointers, so
    // it needs no Embree header).
    println!("cargo:rerun-if-changed=csrc/embree_plain.c");
    cc::Build::new()
        .file("csrc/embree_plain.c")
        .opt_level(2)
        .warnings(true)
        .compile("hybrid_embree_plain");

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

    let Some(include) = embree3_include() else {
        println!("cargo:warning=Embree 3 headers not found (no EMBREE_DIR, no /usr/include/embree3): building without Embree 3");
        return;
    };
    if !clang_sys_available() {
        fail("libclang (needed by bindgen) was not found");
    }
    println!("cargo:rustc-cfg=hybrid_embree3");
    let builder = bindgen::Builder::default()
        .header("ffi/embree.h")
        .clang_arg(format!("-I{}", include.display()))
        .allowlist_function("rtc.*")
        .allowlist_type("RTC.*")
        .allowlist_var("RTC_.*")
        .prepend_enum_name(false)
        .derive_default(true)
        .layout_tests(false)
        .generate_comments(false)
        // Functions become fields of a struct filled from the library at
        // run time; every one must be present.
        .dynamic_library_name("Embree3")
        .dynamic_link_require_all(true);
    let bindings =
        match std::panic::catch_unwind(std::panic::AssertUnwindSafe(move || builder.generate())) {
            Ok(Ok(b)) => b,
            Ok(Err(e)) => fail(&format!("bindgen could not read Embree's headers ({e})")),
            Err(_) => fail("bindgen failed (is libclang installed?)"),
        };
    let path = out.join("embree3_bindings.rs");
    bindings
        .write_to_file(&path)
        .unwrap_or_else(|e| fail(&format!("cannot write {}: {e}", path.display())));
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
