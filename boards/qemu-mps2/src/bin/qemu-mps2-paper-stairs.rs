//! The firmware of the paper's stairs experiment: the program of `src/main.rs` with the sizes
//! of `--features paper-stairs` ([`qemu_mps2::sizes`]: 32 layers of 488 × 488 cells in the
//! AN386's PSRAM, 16 384 classifier slots), linked with `memory-paper-stairs.x`
//! (`build.rs`). A binary of its own name, so that it and the default firmware share one
//! target directory and every dependency's build:
//! `cargo build --release --features paper-stairs --bin qemu-mps2-paper-stairs`.
#![no_std]
#![no_main]
#![deny(unsafe_code)]

// The default firmware's source is this binary's one module: its crate-level attributes
// (`no_std`, `no_main`) are this file's, above.
#[allow(unused_attributes)]
#[path = "../main.rs"]
mod firmware;
