//! Puts the memory map, `memory-an386.x` (or, with `paper-stairs`, `memory-paper-stairs.x`),
//! where the linker finds it as `memory.x`, and links with `cortex-m-rt`'s `link.x` and defmt's `defmt.x`, for the firmware and the
//! on-target tests alike.
use std::env;
use std::fs;
use std::path::PathBuf;

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    // The paper's stairs pyramid does not fit SSRAM2/3: that build links into PSRAM.
    let map = if env::var_os("CARGO_FEATURE_PAPER_STAIRS").is_some() {
        "memory-paper-stairs.x"
    } else {
        "memory-an386.x"
    };
    fs::copy(map, out.join("memory.x")).expect("the memory map is readable");
    println!("cargo:rustc-link-search={}", out.display());
    // No `memory.x` in this folder: the linker would take one in its working directory
    // ahead of OUT_DIR's, whatever the features.
    println!("cargo:rerun-if-changed=memory-an386.x");
    println!("cargo:rerun-if-changed=memory-paper-stairs.x");
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rustc-link-arg=--nmagic");
    println!("cargo:rustc-link-arg=-Tlink.x");
    println!("cargo:rustc-link-arg=-Tdefmt.x");
}
