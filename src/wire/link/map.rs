//! The device's map frames of `docs/protocol.md`, section 4: Hello (the pyramid in force),
//! LayerPatch (a rectangle of cells), WindowMoved (new origins) and Decayed (rows that took a
//! decay step), as typed values; `message.rs` parses and encodes their bodies.

use super::{MAX_LAYERS, MAX_PATCH_SIDE};

/// Bytes of a Hello before its layers.
pub(crate) const HELLO_FIXED: usize = 16;
/// Bytes of one layer in a Hello.
pub(crate) const HELLO_LAYER: usize = 20;
/// Bytes of a LayerPatch before its cells.
pub(crate) const PATCH_FIXED: usize = 19;
/// Bytes of a Decayed body before its layers.
pub(crate) const DECAYED_FIXED: usize = 5;
/// Bytes of one layer in a Decayed body.
pub(crate) const DECAYED_LAYER: usize = 8;

/// A firmware version, `major.minor.patch`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FirmwareVersion {
    /// Major.
    pub major: u8,
    /// Minor.
    pub minor: u8,
    /// Patch.
    pub patch: u8,
}

byte_enum! {
/// Why a Hello was sent.
pub enum HelloReason {
    /// The device started: every cell unknown.
    Boot = 0,
    /// A configuration was adopted: every cell unknown.
    Configured = 1,
    /// The maps were reset: every cell unknown.
    Reset = 2,
    /// A snapshot was requested: maps kept, the layers in `resend` follow in full.
    Snapshot = 3,
}
/// The reason of a Hello's reason byte, or `None`.
pub(super) fn from_u8;
}

impl HelloReason {
    /// Whether the device's maps were cleared: the host must clear its copy.
    #[must_use]
    pub const fn clears_maps(self) -> bool {
        !matches!(self, Self::Snapshot)
    }
}

byte_enum! {
/// The clock the device's board runs on, as it started it (Hello offset 12): how a host
/// learns that a board fell back to its internal oscillator (its UARTs' rates and its
/// timing then carry that oscillator's tolerance, about ±1 % on an STM32F4's HSI).
#[derive(Default)]
pub enum ClockSource {
    /// The board does not say.
    #[default]
    NotReported = 0,
    /// The external crystal or clock (through the PLL where there is one): as intended.
    External = 1,
    /// The internal oscillator through the PLL: the external clock never became ready.
    InternalPll = 2,
    /// The internal oscillator alone: neither the external clock nor a PLL became ready.
    Internal = 3,
    /// No clock tree answered (every ready flag reads 0): an emulator that does not model it.
    Unmodelled = 4,
}
/// The source of a wire code, if it is one.
pub fn from_code;
/// The wire code, 0 ..= 4.
pub fn code;
}

impl ClockSource {
    /// Whether the board runs on a fallback, not on the clock it was built for.
    #[must_use]
    pub const fn is_fallback(self) -> bool {
        matches!(self, Self::InternalPll | Self::Internal)
    }
}

/// One layer as a Hello describes it.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LayerInfo {
    /// The cell size, raw Q16.16 metres.
    pub resolution_q16: i32,
    /// The band's inner edge d_k, metres (0 when the device does not know the design).
    pub band_inner_m: f32,
    /// The band's outer edge d_{k+1}, metres (0 when unknown).
    pub band_outer_m: f32,
    /// The window origin, world cell index x.
    pub origin_x: i32,
    /// The window origin, world cell index y.
    pub origin_y: i32,
}

/// Device to host: the pyramid in force.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Hello {
    /// The protocol version the firmware implements.
    pub protocol: u8,
    /// The firmware's version.
    pub firmware: FirmwareVersion,
    /// Why this Hello was sent.
    pub reason: HelloReason,
    /// W, cells per side of every window.
    pub cells_per_side: u16,
    /// Bit k: every tile of layer k follows (reason [`HelloReason::Snapshot`]).
    pub resend: u32,
    /// The clock the board runs on.
    pub clock: ClockSource,
    /// The layers in force, finest first.
    pub layers: heapless::Vec<LayerInfo, MAX_LAYERS>,
}

/// Where a [`LayerPatch`] lies: its layer, the window it was made in, its rectangle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PatchArea {
    /// The layer, 0 = finest; below [`MAX_LAYERS`] (32).
    pub layer: u8,
    /// The layer's window origin when the patch was made, x.
    pub origin_x: i32,
    /// The layer's window origin when the patch was made, y.
    pub origin_y: i32,
    /// World cell index of the rectangle's lower-left cell, x.
    pub x: i32,
    /// World cell index of the rectangle's lower-left cell, y.
    pub y: i32,
    /// Cells along x, 1 ..= 16.
    pub width: u8,
    /// Cells along y, 1 ..= 16.
    pub height: u8,
}

impl PatchArea {
    /// Cells in the rectangle.
    #[must_use]
    pub const fn cells(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// Checks the format's limits: sides 1 ..= 16, layer < 16, no overflow of x + width.
    pub(super) fn check(&self) -> Result<(), &'static str> {
        let side = 1..=MAX_PATCH_SIDE;
        if usize::from(self.layer) >= MAX_LAYERS {
            return Err("LayerPatch.layer");
        }
        if !side.contains(&usize::from(self.width)) {
            return Err("LayerPatch.width");
        }
        if !side.contains(&usize::from(self.height)) {
            return Err("LayerPatch.height");
        }
        if self.x.checked_add(i32::from(self.width)).is_none() {
            return Err("LayerPatch.x");
        }
        if self.y.checked_add(i32::from(self.height)).is_none() {
            return Err("LayerPatch.y");
        }
        Ok(())
    }
}

/// The cells of a [`LayerPatch`]: raw Q8.8 `i16`, little-endian, row-major, row 0 = lowest y,
/// read in place from the frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PatchCells<'a> {
    bytes: &'a [u8],
}

impl<'a> PatchCells<'a> {
    /// The cells of a LayerPatch body's tail, whose length the parser has checked.
    pub(super) const fn of_body(bytes: &'a [u8]) -> Self {
        Self { bytes }
    }

    /// Cells from their little-endian bytes, or `None` for an odd length.
    #[must_use]
    pub const fn from_le_bytes(bytes: &'a [u8]) -> Option<Self> {
        if bytes.len().is_multiple_of(2) {
            Some(Self { bytes })
        } else {
            None
        }
    }

    /// The little-endian bytes.
    #[must_use]
    pub const fn as_bytes(&self) -> &'a [u8] {
        self.bytes
    }

    /// The number of cells.
    #[must_use]
    pub const fn len(&self) -> usize {
        self.bytes.len() / 2
    }

    /// Whether there are no cells.
    #[must_use]
    pub const fn is_empty(&self) -> bool {
        self.bytes.len() < 2
    }

    /// Cell `index` (row-major), raw.
    #[must_use]
    pub fn get(&self, index: usize) -> Option<i16> {
        let at = index.checked_mul(2)?;
        let pair = self.bytes.get(at..at.checked_add(2)?)?;
        Some(i16::from_le_bytes([
            pair.first().copied()?,
            pair.get(1).copied()?,
        ]))
    }

    /// The cells in order, raw.
    pub fn iter(&self) -> impl Iterator<Item = i16> + 'a {
        self.bytes.chunks_exact(2).map(|p| {
            i16::from_le_bytes([
                p.first().copied().unwrap_or(0),
                p.get(1).copied().unwrap_or(0),
            ])
        })
    }
}

/// Device to host: the current values of a rectangle of one layer's cells.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LayerPatch<'a> {
    /// Where the cells lie.
    pub area: PatchArea,
    /// `width · height` cells.
    pub cells: PatchCells<'a>,
}

/// Device to host: new window origins for the layers in `mask`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct WindowMoved {
    mask: u32,
    origins: [(i32, i32); MAX_LAYERS],
}

impl WindowMoved {
    /// No layer moved yet.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            mask: 0,
            origins: [(0, 0); MAX_LAYERS],
        }
    }

    /// Records layer `layer`'s new origin; `false` for a layer ≥ [`MAX_LAYERS`].
    pub fn set(&mut self, layer: usize, origin: (i32, i32)) -> bool {
        match self.origins.get_mut(layer) {
            Some(slot) => {
                *slot = origin;
                self.mask |= 1 << layer;
                true
            }
            None => false,
        }
    }

    /// Bit k set: layer k moved.
    #[must_use]
    pub const fn mask(&self) -> u32 {
        self.mask
    }

    /// Layer `layer`'s new origin, or `None` when it did not move.
    #[must_use]
    pub fn origin(&self, layer: usize) -> Option<(i32, i32)> {
        if layer < MAX_LAYERS && self.mask & (1 << layer) != 0 {
            self.origins.get(layer).copied()
        } else {
            None
        }
    }

    /// The moved layers and their new origins, ascending.
    pub fn iter(&self) -> impl Iterator<Item = (usize, (i32, i32))> + '_ {
        (0..MAX_LAYERS).filter_map(|k| self.origin(k).map(|o| (k, o)))
    }

    /// The number of layers that moved.
    #[must_use]
    pub const fn len(&self) -> usize {
        self.mask.count_ones() as usize
    }

    /// Whether no layer moved.
    #[must_use]
    pub const fn is_empty(&self) -> bool {
        self.mask == 0
    }
}

/// One layer's rows in a [`Decayed`]: `rows` storage rows from `first` (wrapping modulo W)
/// took one decay step each.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DecayedRows {
    /// The first storage row: the world rows j of the window with `j mod W` = `first`, …
    pub first: u16,
    /// How many consecutive storage rows (modulo W), ≥ 1.
    pub rows: u16,
    /// Cells of those rows that became unknown on the device.
    pub faded: u32,
}

/// Device to host: the rows of the layers in `mask` took one decay step each, in `mode`
/// (1 all, 2 obstacle only, 3 free only), at this point of the stream.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Decayed {
    /// The decay mode in force, 1 ..= 3.
    pub mode: u8,
    mask: u32,
    rows: [DecayedRows; MAX_LAYERS],
}

impl Decayed {
    /// No rows yet, in `mode`.
    #[must_use]
    pub const fn new(mode: u8) -> Self {
        Self {
            mode,
            mask: 0,
            rows: [DecayedRows {
                first: 0,
                rows: 0,
                faded: 0,
            }; MAX_LAYERS],
        }
    }

    /// Records layer `layer`'s rows; `false` for a layer ≥ [`MAX_LAYERS`].
    pub fn set(&mut self, layer: usize, rows: DecayedRows) -> bool {
        match self.rows.get_mut(layer) {
            Some(slot) => {
                *slot = rows;
                self.mask |= 1 << layer;
                true
            }
            None => false,
        }
    }

    /// Bit k set: layer k decayed rows.
    #[must_use]
    pub const fn mask(&self) -> u32 {
        self.mask
    }

    /// Layer `layer`'s rows, or `None` when it decayed none.
    #[must_use]
    pub fn rows(&self, layer: usize) -> Option<DecayedRows> {
        if layer < MAX_LAYERS && self.mask & (1 << layer) != 0 {
            self.rows.get(layer).copied()
        } else {
            None
        }
    }

    /// The layers that decayed and their rows, ascending.
    pub fn iter(&self) -> impl Iterator<Item = (usize, DecayedRows)> + '_ {
        (0..MAX_LAYERS).filter_map(|k| self.rows(k).map(|r| (k, r)))
    }

    /// The number of layers.
    #[must_use]
    pub const fn len(&self) -> usize {
        self.mask.count_ones() as usize
    }

    /// Whether no layer decayed.
    #[must_use]
    pub const fn is_empty(&self) -> bool {
        self.mask == 0
    }
}
