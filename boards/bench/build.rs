//! Puts `memory.x` where the linker finds it and links with `cortex-m-rt`'s `link.x`; checks
//! that the recording to embed (`BENCH_RECORDING`, set by `cargo xtask bench`) is named.
use std::env;
use std::fs;
use std::path::PathBuf;

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    fs::copy("memory.x", out.join("memory.x")).expect("memory.x is readable");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=memory.x");
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-env-changed=BENCH_RECORDING");
    let Some(path) = env::var_os("BENCH_RECORDING") else {
        panic!("BENCH_RECORDING (the recording to embed) is not set: build through `cargo xtask bench`");
    };
    println!("cargo:rerun-if-changed={}", PathBuf::from(path).display());
    println!("cargo:rustc-link-arg=--nmagic");
    println!("cargo:rustc-link-arg=-Tlink.x");
}
