//! Puts the chip's memory map (`memory-f446.x` or `memory-f405.x`, by the `chip-*` feature)
//! where the linker finds it as `memory.x`, and links with `cortex-m-rt`'s `link.x` and
//! defmt's `defmt.x`.
use std::env;
use std::fs;
use std::path::PathBuf;

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let f446 = env::var_os("CARGO_FEATURE_CHIP_F446").is_some();
    let f405 = env::var_os("CARGO_FEATURE_CHIP_F405").is_some();
    let map = match (f446, f405) {
        (true, false) => "memory-f446.x",
        (false, true) => "memory-f405.x",
        _ => panic!(
            "choose exactly one chip feature: chip-f446 (the default) or chip-f405 \
             (--no-default-features --features chip-f405,log-semihosting)"
        ),
    };
    let rtt = env::var_os("CARGO_FEATURE_LOG_RTT").is_some();
    let semihosting = env::var_os("CARGO_FEATURE_LOG_SEMIHOSTING").is_some();
    assert!(
        rtt != semihosting,
        "choose exactly one logging feature: log-rtt (the default) or log-semihosting"
    );
    fs::copy(map, out.join("memory.x")).expect("the memory map is readable");
    println!("cargo:rustc-link-search={}", out.display());
    // No `memory.x` in this folder: the linker would take one in its working directory ahead
    // of OUT_DIR's, whatever the features.
    println!("cargo:rerun-if-changed=memory-f446.x");
    println!("cargo:rerun-if-changed=memory-f405.x");
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rustc-link-arg-bins=--nmagic");
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
}
