//! The sizes the firmware is built with (`src/main.rs`, and the same program as the binary
//! `qemu-mps2-paper-stairs`).
//!
//! By default the library's: W = 64, 8 layers, 1 024 classifier slots (72 KiB of pyramid in
//! the 4 MiB of SSRAM2/3) and a 2 KiB link queue (22 ms of the UART at 921 600 Bd, ahead of a
//! patch budget of half the link), within 96 KiB of static RAM.
//!
//! With `--features paper-stairs` (the binary `qemu-mps2-paper-stairs`), the paper's stairs
//! experiment: every layer at 0.1 m to 24 m needs 32 layers of 488 × 488 cells (15.3 MB, in
//! the board's 16 MiB of PSRAM, see `memory-paper-stairs.x`) and 16 384 classifier slots (a
//! soft-gated point feeds several layers). QEMU's UARTs have no baud rate, so the link's
//! budget is 16 MB/s: a snapshot of all layers takes seconds, not minutes.

use terrain_pyramid::link::LinkConfig;

#[cfg(not(feature = "paper-stairs"))]
mod chosen {
    use terrain_pyramid::link::LinkConfig;
    pub const CELLS: usize = terrain_pyramid::DEFAULT_CELLS_PER_SIDE;
    pub const LAYERS: usize = terrain_pyramid::DEFAULT_LAYERS;
    pub const SLOTS: usize = terrain_pyramid::DEFAULT_CLASSIFIER_SLOTS;
    pub const QUEUE: usize = 2048;
    pub const LINK: LinkConfig = LinkConfig::DEFAULT;
}

#[cfg(feature = "paper-stairs")]
mod chosen {
    use terrain_pyramid::link::LinkConfig;
    pub const CELLS: usize = 488;
    pub const LAYERS: usize = 32;
    pub const SLOTS: usize = 16_384;
    pub const QUEUE: usize = 16_384;
    pub const LINK: LinkConfig = LinkConfig {
        budget_bytes_per_s: 16_000_000,
        burst_bytes: 65_536,
        ..LinkConfig::DEFAULT
    };
}

/// W, cells per side of every window.
pub const CELLS: usize = chosen::CELLS;
/// The pyramid's layer capacity.
pub const LAYERS: usize = chosen::LAYERS;
/// Classifier slots.
pub const SLOTS: usize = chosen::SLOTS;
/// The link's outgoing queue, bytes.
pub const QUEUE: usize = chosen::QUEUE;
/// The link's settings.
pub const LINK: LinkConfig = chosen::LINK;
