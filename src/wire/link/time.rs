//! The messages of protocol version 4 that put the device's clock on the wire
//! (`docs/protocol.md`, "0x8C TimeRequest", "0x07 TimeReply", "0x08 Observed"): the host's
//! time exchange and the device's report of the times an observation's returns were measured.
//! Their bodies are fixed little-endian fields; [`super::Message`] parses and encodes them
//! through the readers and writers of `message.rs`.

/// Bytes of a TimeRequest body.
pub(crate) const TIME_REQUEST_LEN: usize = 8;
/// Bytes of a TimeReply body.
pub(crate) const TIME_REPLY_LEN: usize = 14;
/// Bytes of an Observed body.
pub(crate) const OBSERVED_LEN: usize = 12;

/// Host to device (0x8C): asks for the device's clock. Not answered with a Reply but with a
/// [`TimeReply`] that echoes `host_us`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TimeRequest {
    /// The host's clock when it sent the request, µs (opaque to the device: echoed).
    pub host_us: u64,
}

/// Device to host (0x07): the answer to a [`TimeRequest`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TimeReply {
    /// The request's `host_us`, echoed.
    pub host_us: u64,
    /// The device's µs clock (wrapping) when the request's last byte was taken: the time the
    /// board passed with the host bytes that completed the request.
    pub device_us: u32,
    /// Bytes already queued for the host ahead of this reply when it was queued (saturating
    /// at 65 535): each waits 10 bits at the link's baud rate before the reply leaves.
    pub queued_ahead: u16,
}

/// Device to host (0x08): an observation was applied to the maps. Queued ahead of the patches
/// it changed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Observed {
    /// The device's observation count (Stats `observations`) after this one.
    pub observation: u32,
    /// The device's µs clock (wrapping): the measurement time of the earliest return this
    /// observation placed.
    pub first_us: u32,
    /// The device's µs clock (wrapping): the measurement time of the latest return.
    pub last_us: u32,
}

/// Little-endian fields read from a fixed body.
struct Fields<'a>(&'a [u8]);

impl Fields<'_> {
    fn take<const N: usize>(&mut self) -> [u8; N] {
        let mut out = [0_u8; N];
        let (head, tail) = self.0.split_at(N.min(self.0.len()));
        for (o, b) in out.iter_mut().zip(head) {
            *o = *b;
        }
        self.0 = tail;
        out
    }
}

/// Copies `bytes` into `out` from `*at` and moves `*at` past them.
fn put(out: &mut [u8], at: &mut usize, bytes: &[u8]) {
    for (o, b) in out.iter_mut().skip(*at).zip(bytes) {
        *o = *b;
    }
    *at += bytes.len();
}

impl TimeRequest {
    /// The request of its body's bytes.
    #[must_use]
    pub fn from_le_bytes(body: &[u8; TIME_REQUEST_LEN]) -> Self {
        Self {
            host_us: u64::from_le_bytes(*body),
        }
    }

    /// The body's bytes.
    #[must_use]
    pub const fn to_le_bytes(&self) -> [u8; TIME_REQUEST_LEN] {
        self.host_us.to_le_bytes()
    }
}

/// `from_le_bytes` and `to_le_bytes` for the message `$name` whose `$len`-byte body is its
/// fields, little-endian, in the order given, written once; `$what` names it in the docs.
macro_rules! le_body {
    ($name:ident, $len:ident, $what:literal, $($field:ident: $ty:ty),+) => {
        impl $name {
            #[doc = concat!("The ", $what, " of its body's bytes.")]
            #[must_use]
            pub fn from_le_bytes(body: &[u8; $len]) -> Self {
                let mut f = Fields(body);
                Self {
                    $($field: <$ty>::from_le_bytes(f.take()),)+
                }
            }

            /// The body's bytes.
            #[must_use]
            pub fn to_le_bytes(&self) -> [u8; $len] {
                let mut out = [0_u8; $len];
                let mut at = 0;
                $(put(&mut out, &mut at, &self.$field.to_le_bytes());)+
                out
            }
        }
    };
}

le_body!(TimeReply, TIME_REPLY_LEN, "reply", host_us: u64, device_us: u32, queued_ahead: u16);
le_body!(Observed, OBSERVED_LEN, "report", observation: u32, first_us: u32, last_us: u32);
