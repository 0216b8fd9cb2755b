//! The two checks every wire view makes on a buffer: that it is long enough, and that the
//! check value a unit carries is the one computed over its bytes.

/// `Ok` when `bytes` holds at least `len` bytes, else `Err(short)`.
#[inline]
pub(crate) fn at_least<E>(bytes: &[u8], len: usize, short: E) -> Result<(), E> {
    if bytes.len() < len {
        Err(short)
    } else {
        Ok(())
    }
}

/// `Ok` when the check value `stored` in a unit equals `computed` over its bytes, else the
/// error `mismatch(stored, computed)` makes.
#[inline]
pub(crate) fn stored_matches<V: PartialEq, E>(
    stored: V,
    computed: V,
    mismatch: impl FnOnce(V, V) -> E,
) -> Result<(), E> {
    if stored == computed {
        Ok(())
    } else {
        Err(mismatch(stored, computed))
    }
}
