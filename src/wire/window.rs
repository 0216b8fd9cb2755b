//! The bounded byte window the lidar accumulators reassemble their units in.
//!
//! A fixed array with a live range `start..end`; bytes enter from the chunks the caller
//! feeds, leave from the front. The window counts every byte taken from a chunk, so a live
//! index maps back to its stream position. Nothing here panics: indices are clamped and every
//! slice is taken with `get`.

/// A fixed buffer of `N` bytes with a live range, the unit handed out at its front, and the
/// count of bytes taken from chunks.
#[derive(Debug, Clone)]
pub(crate) struct Window<const N: usize> {
    buf: [u8; N],
    start: usize,
    end: usize,
    /// Length of the unit handed out by the last call, at the front; dropped on the next.
    handed: usize,
    /// Bytes taken from chunks since the window was made (wrapping at 2⁶⁴).
    consumed: u64,
}

impl<const N: usize> Window<N> {
    /// An empty window at stream position 0.
    pub(crate) const fn new() -> Self {
        Self {
            buf: [0; N],
            start: 0,
            end: 0,
            handed: 0,
            consumed: 0,
        }
    }

    /// The live bytes.
    pub(crate) fn live(&self) -> &[u8] {
        self.buf.get(self.start..self.end).unwrap_or(&[])
    }

    /// How many bytes are live.
    pub(crate) const fn len(&self) -> usize {
        self.end.saturating_sub(self.start)
    }

    /// Drops `n` live bytes from the front (all of them when fewer are live).
    pub(crate) fn drop_front(&mut self, n: usize) {
        self.start = self.start.saturating_add(n).min(self.end);
        if self.start == self.end {
            self.start = 0;
            self.end = 0;
        }
    }

    /// Drops every live byte (a unit handed out included); keeps the stream position.
    pub(crate) fn clear(&mut self) {
        self.start = 0;
        self.end = 0;
        self.handed = 0;
    }

    /// Marks the first `len` live bytes as the unit handed out, dropped by [`Self::release`].
    pub(crate) fn hand_out(&mut self, len: usize) {
        self.handed = len;
    }

    /// The unit handed out (empty when there is none).
    pub(crate) fn handed_out(&self) -> &[u8] {
        let live = self.live();
        live.get(..self.handed).unwrap_or(live)
    }

    /// Drops the unit handed out, if any.
    pub(crate) fn release(&mut self) {
        if self.handed > 0 {
            self.drop_front(self.handed);
            self.handed = 0;
        }
    }

    /// How many live bytes are not yet resolved (the unit handed out not included).
    pub(crate) const fn unresolved(&self) -> usize {
        self.len().saturating_sub(self.handed)
    }

    /// Counts `n` bytes taken from a chunk without buffering them (skipped in place).
    pub(crate) fn skip(&mut self, n: usize) {
        let n = u64::try_from(n).unwrap_or(u64::MAX);
        self.consumed = self.consumed.wrapping_add(n);
    }

    /// Appends up to `want` bytes from the front of `chunk` (fewer when the chunk is shorter
    /// or the window is full, even after moving the live bytes to the front) and returns the
    /// rest of the chunk.
    pub(crate) fn fill<'c>(&mut self, chunk: &'c [u8], want: usize) -> &'c [u8] {
        if self.end.saturating_add(want) > N && self.start > 0 {
            self.compact();
        }
        let take = want.min(chunk.len()).min(N.saturating_sub(self.end));
        let (head, rest) = chunk.split_at_checked(take).unwrap_or((&[], chunk));
        if let Some(dst) = self
            .buf
            .get_mut(self.end..self.end.saturating_add(head.len()))
        {
            if dst.len() == head.len() {
                crate::wire::copy_bytes(dst, head);
                self.end += head.len();
                self.skip(head.len());
                return rest;
            }
        }
        chunk
    }

    /// The stream position of the next byte fed.
    pub(crate) const fn position(&self) -> u64 {
        self.consumed
    }

    /// The stream position of live byte `at` (0 = the first live byte).
    pub(crate) fn offset_of(&self, at: usize) -> u64 {
        let behind = self.len().saturating_sub(at);
        self.consumed
            .wrapping_sub(u64::try_from(behind).unwrap_or(u64::MAX))
    }

    /// Moves the live bytes to the front of the buffer.
    fn compact(&mut self) {
        if self.start > 0 && self.start <= self.end && self.end <= N {
            self.buf.copy_within(self.start..self.end, 0);
            self.end -= self.start;
            self.start = 0;
        }
    }
}

/// Adds 1 to a counter, saturating at `u32::MAX`.
pub(crate) fn bump(counter: &mut u32) {
    *counter = counter.saturating_add(1);
}

/// Adds `n` to a counter, saturating at `u32::MAX`.
pub(crate) fn bump_by(counter: &mut u32, n: usize) {
    *counter = counter.saturating_add(u32::try_from(n).unwrap_or(u32::MAX));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fill_compacts_and_counts() {
        let mut w = Window::<4>::new();
        let rest = w.fill(&[1, 2, 3, 4, 5], 3);
        assert_eq!(
            (w.live(), rest, w.position()),
            (&[1, 2, 3][..], &[4, 5][..], 3)
        );
        w.drop_front(2);
        assert_eq!(w.offset_of(0), 2);
        let rest = w.fill(rest, 3);
        assert_eq!((w.live(), rest, w.position()), (&[3, 4, 5][..], &[][..], 5));
        // Full: nothing more fits, the chunk comes back whole.
        let rest = w.fill(&[6, 7], 2);
        assert_eq!((w.live(), rest), (&[3, 4, 5, 6][..], &[7][..]));
        let rest = w.fill(rest, 1);
        assert_eq!(rest, &[7]);
        w.skip(10);
        assert_eq!(w.position(), 16);
        w.drop_front(99);
        assert_eq!(w.len(), 0);
        w.clear();
        let mut c = u32::MAX - 1;
        bump(&mut c);
        bump(&mut c);
        bump_by(&mut c, usize::MAX);
        assert_eq!(c, u32::MAX);
    }
}
