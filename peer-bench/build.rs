//! Builds the Fast-CDR shim (`cpp/fastcdr_shim.cpp`) when eProsima Fast-CDR 2.x
//! headers and library can be found, and sets `cfg(fastcdr)`. Without them the
//! crate still builds and the Fast-CDR column is skipped (the bench says so; the
//! build warns only when `FASTCDR_PREFIX` is set and holds no Fast-CDR).
//!
//! Where it looks, in order: `$FASTCDR_PREFIX`, `$VIRTUAL_ENV`, and the CI venv
//! `target/interop-venv` (the PyPI wheel `ros-fastcdr` installs `include/fastcdr`
//! and `lib/libfastcdr.so` into a venv's prefix).

use std::env;
use std::path::{Path, PathBuf};

fn has_fastcdr(prefix: &Path) -> bool {
    prefix.join("include/fastcdr/Cdr.h").is_file() && prefix.join("lib/libfastcdr.so").exists()
}

fn main() {
    println!("cargo::rustc-check-cfg=cfg(fastcdr)");
    println!("cargo:rerun-if-env-changed=FASTCDR_PREFIX");
    println!("cargo:rerun-if-env-changed=VIRTUAL_ENV");
    println!("cargo:rerun-if-changed=cpp/fastcdr_shim.cpp");

    let manifest = PathBuf::from(env::var("CARGO_MANIFEST_DIR").expect("set by cargo"));
    let ci_venv = manifest.join("../target/interop-venv");
    let candidates = [
        env::var_os("FASTCDR_PREFIX").map(PathBuf::from),
        env::var_os("VIRTUAL_ENV").map(PathBuf::from),
        Some(ci_venv),
    ];
    let Some(prefix) = candidates.into_iter().flatten().find(|p| has_fastcdr(p)) else {
        // Optional: say so only to whoever asked for it. The bench itself prints
        // that the column is skipped, so a plain `cargo test` stays quiet.
        if env::var_os("FASTCDR_PREFIX").is_some() {
            println!(
                "cargo:warning=FASTCDR_PREFIX has no Fast-CDR 2.x (include/fastcdr/Cdr.h, \
                 lib/libfastcdr.so): the optional Fast-CDR column of peer-bench is skipped. \
                 `pip install ros-fastcdr==2.3.3` into a venv and point FASTCDR_PREFIX at it."
            );
        }
        return;
    };
    let prefix = prefix.canonicalize().unwrap_or(prefix);
    println!(
        "cargo:rerun-if-changed={}",
        prefix.join("lib/libfastcdr.so").display()
    );
    cc::Build::new()
        .cpp(true)
        .std("c++17")
        .opt_level(3)
        .include(prefix.join("include"))
        .file("cpp/fastcdr_shim.cpp")
        .compile("fastcdr_shim");
    let lib = prefix.join("lib");
    println!("cargo:rustc-link-search=native={}", lib.display());
    println!("cargo:rustc-link-lib=dylib=fastcdr");
    println!("cargo:rustc-link-arg=-Wl,-rpath,{}", lib.display());
    println!("cargo:rustc-cfg=fastcdr");
}
