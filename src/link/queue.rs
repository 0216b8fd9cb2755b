//! The outgoing byte queue: a fixed ring of whole encoded frames, drained by a UART writer.

/// A ring of `Q` bytes holding encoded frames back to back (each ends with its `0x00`).
/// Frames go in whole or not at all; bytes come out in any chunking.
#[derive(Debug, Clone)]
pub struct FrameQueue<const Q: usize> {
    buf: [u8; Q],
    /// Index of the oldest byte.
    head: usize,
    /// Bytes held.
    len: usize,
    /// The most bytes held at once.
    high_water: usize,
}

impl<const Q: usize> Default for FrameQueue<Q> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const Q: usize> FrameQueue<Q> {
    /// An empty queue. `const`, for a `static`.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            buf: [0; Q],
            head: 0,
            len: 0,
            high_water: 0,
        }
    }

    /// The capacity, bytes.
    #[must_use]
    pub const fn capacity(&self) -> usize {
        Q
    }

    /// Bytes waiting.
    #[must_use]
    pub const fn len(&self) -> usize {
        self.len
    }

    /// Whether nothing waits.
    #[must_use]
    pub const fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Bytes free.
    #[must_use]
    pub const fn free(&self) -> usize {
        Q - self.len
    }

    /// The most bytes held at once since construction.
    #[must_use]
    pub const fn high_water(&self) -> usize {
        self.high_water
    }

    /// Appends a whole frame; `false` (and nothing appended) when it does not fit.
    pub fn push(&mut self, frame: &[u8]) -> bool {
        if frame.len() > self.free() {
            return false;
        }
        let tail = (self.head + self.len) % Q.max(1);
        let first = frame.len().min(Q - tail);
        let (a, b) = frame.split_at(first);
        if let Some(dst) = self.buf.get_mut(tail..tail + a.len()) {
            copy_frame(dst, a);
        }
        if let Some(dst) = self.buf.get_mut(..b.len()) {
            copy_frame(dst, b);
        }
        self.len += frame.len();
        self.high_water = self.high_water.max(self.len);
        true
    }

    /// The oldest waiting bytes that lie contiguously in the ring (all of them, or up to the
    /// wrap point): hand them to a DMA or a non-blocking write, then [`consume`](Self::consume)
    /// what was taken.
    #[must_use]
    pub fn peek(&self) -> &[u8] {
        let end = (self.head + self.len).min(Q);
        self.buf.get(self.head..end).unwrap_or(&[])
    }

    /// Drops the `n` oldest bytes (at most all of them).
    pub fn consume(&mut self, n: usize) {
        let n = n.min(self.len);
        self.len -= n;
        self.head = if self.len == 0 {
            0
        } else {
            (self.head + n) % Q.max(1)
        };
    }

    /// Moves up to `out.len()` of the oldest bytes into `out`; returns how many.
    pub fn pop_bytes(&mut self, out: &mut [u8]) -> usize {
        let mut done = 0;
        while done < out.len() && !self.is_empty() {
            let chunk = self.peek();
            let n = chunk.len().min(out.len() - done);
            if let (Some(dst), Some(src)) = (out.get_mut(done..done + n), chunk.get(..n)) {
                copy_frame(dst, src);
            }
            self.consume(n);
            done += n;
        }
        done
    }
}

/// Copies a frame's bytes into or out of the ring (equal lengths): on ARMv7-M by words at any
/// alignment ([`crate::wire::copy_bytes`]: the ring's tail and a frame's bytes are at any
/// byte alignment, where `memcpy` takes its slow misaligned path); on ARMv6-M by `memcpy`,
/// which measured no dearer there.
#[inline]
fn copy_frame(dst: &mut [u8], src: &[u8]) {
    if crate::wide::HALVES {
        if dst.len() == src.len() {
            dst.copy_from_slice(src);
        }
    } else {
        crate::wire::copy_bytes(dst, src);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_wrap_and_come_out_in_order() {
        let mut q = FrameQueue::<8>::new();
        assert!(q.push(&[1, 2, 3, 0]));
        assert!(q.push(&[4, 5, 0]));
        assert!(!q.push(&[6, 7, 0]), "9 bytes > 8");
        let mut out = [0_u8; 3];
        assert_eq!(q.pop_bytes(&mut out), 3);
        assert_eq!(out, [1, 2, 3]);
        assert!(q.push(&[6, 7, 0])); // wraps
        assert_eq!(q.len(), 7);
        assert_eq!(q.high_water(), 7);
        assert_eq!(q.peek(), &[0, 4, 5, 0, 6]);
        let mut all = [0_u8; 16];
        assert_eq!(q.pop_bytes(&mut all), 7);
        assert_eq!(&all[..7], &[0, 4, 5, 0, 6, 7, 0]);
        assert!(q.is_empty());
        assert_eq!(q.pop_bytes(&mut all), 0);
    }
}
