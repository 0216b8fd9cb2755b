//! Helpers shared by the fuzz targets.
#![allow(dead_code)]

/// Cuts `data` into chunks whose sizes cycle through `sizes` (each at least 1).
pub fn chunks<'a>(data: &'a [u8], sizes: &[u8]) -> Vec<&'a [u8]> {
    let mut out = Vec::new();
    let mut rest = data;
    let mut i = 0;
    while !rest.is_empty() {
        let n = if sizes.is_empty() {
            rest.len()
        } else {
            usize::from(sizes[i % sizes.len()]).max(1)
        };
        i += 1;
        let (head, tail) = rest.split_at(n.min(rest.len()));
        out.push(head);
        rest = tail;
    }
    out
}

/// Splits the input into a chunking prefix (its first byte says how long, ≤ 8) and the data.
pub fn split_sizes(data: &[u8]) -> (&[u8], &[u8]) {
    match data.split_first() {
        None => (&[], &[]),
        Some((&n, rest)) => {
            let n = usize::from(n % 9).min(rest.len());
            rest.split_at(n)
        }
    }
}

/// A link frame, COBS-encoded with its delimiter: version, type, seq, body, CRC-32.
pub fn link_frame(version: u8, msg_type: u8, seq: u16, body: &[u8]) -> Vec<u8> {
    use terrain_pyramid::wire::link::{cobs, crc32};
    let mut raw = vec![version, msg_type];
    raw.extend_from_slice(&seq.to_le_bytes());
    raw.extend_from_slice(body);
    let crc = crc32(&raw);
    raw.extend_from_slice(&crc.to_le_bytes());
    let mut out = vec![0_u8; cobs::max_encoded_len(raw.len()) + 1];
    let mut enc = cobs::Encoder::new(&mut out);
    enc.push_all(&raw);
    let n = enc.finish().expect("sized by max_encoded_len");
    out.truncate(n);
    out
}

/// Turns fuzz input into a link byte stream: segments of `[flags, type, len, body...]`.
/// flags bit 0: raw bytes (no framing) instead of a valid frame; bit 1: wrong version;
/// bit 2: flip one bit of the encoded frame (at body[0] mod length); bits 3-7: seq skip.
pub fn link_stream(data: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    let mut rest = data;
    let mut seq: u16 = 0;
    while let [flags, msg_type, len, tail @ ..] = rest {
        let n = usize::from(*len).min(tail.len());
        let (body, tail) = tail.split_at(n);
        rest = tail;
        seq = seq.wrapping_add(1 + u16::from(flags >> 3) / 8);
        if flags & 1 != 0 {
            out.extend_from_slice(body);
            continue;
        }
        let version = if flags & 2 != 0 { 2 } else { 1 };
        let mut frame = link_frame(version, *msg_type, seq, body);
        if flags & 4 != 0 {
            let at = usize::from(body.first().copied().unwrap_or(0)) % frame.len();
            frame[at] ^= 1 << (seq % 8);
        }
        out.extend_from_slice(&frame);
    }
    out.extend_from_slice(rest);
    out
}

/// One 361-value measured-values telegram of a SICK 0.5 m above flat floor, tilted 20° down
/// (every beam below the horizon meets the floor; the others return nothing).
pub fn floor_telegram() -> Vec<u8> {
    let tau = 20_f64.to_radians();
    let mut values = Vec::new();
    for i in 0..361 {
        let theta = (f64::from(i) * 0.5).to_radians();
        let dz = -theta.sin() * tau.sin();
        let r = if dz < -1e-6 { 0.5 / -dz } else { f64::INFINITY };
        let raw: u16 = if r < 8.0 {
            (r * 1000.0).round() as u16
        } else {
            0x1FFF
        };
        values.extend_from_slice(&raw.to_le_bytes());
    }
    let line = terrain_pyramid::wire::sick::MeasuredValues::new(
        terrain_pyramid::wire::sick::Unit::Millimetre,
        0,
        &values,
        None,
        0,
    )
    .expect("a valid line");
    let mut buf = vec![0_u8; line.buffer_len()];
    let n = line.emit(&mut buf).expect("room for the telegram");
    buf.truncate(n);
    buf
}

/// Feeds every chunk to an accumulator through `feed` (one `feed` call on what is left of the
/// chunk: the rest of the chunk, and whether the call handed out something, not
/// `FeedResult::Consumed`), until the chunk is used up. Checks that no call returns more than
/// it was given and that the calls on a chunk stay within `max_calls(chunk length)`.
pub fn feed_chunks<'c>(
    chunks: &[&'c [u8]],
    max_calls: impl Fn(usize) -> usize,
    mut feed: impl FnMut(&'c [u8]) -> (&'c [u8], bool),
) {
    for chunk in chunks {
        let mut window: &[u8] = chunk;
        let mut calls = 0usize;
        loop {
            let (rest, handed_out) = feed(window);
            assert!(rest.len() <= window.len());
            window = rest;
            if !handed_out {
                assert!(window.is_empty());
                break;
            }
            calls += 1;
            assert!(calls <= max_calls(chunk.len()), "feed does not progress");
        }
    }
}

/// What a target keeps of one result of an accumulator: a unit handed out (its stream
/// offset, what the target notes of its kind, and its bytes) or a refused candidate (its
/// stream offset and the error).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Event<K, E> {
    Unit(u64, K, Vec<u8>),
    Refused(u64, E),
}

/// Records one result of an accumulator in `events`, an item as the kind and bytes `unit`
/// makes of it (checking it on the way); says whether the call handed out something (not
/// `FeedResult::Consumed`).
pub fn record<I, E, K>(
    result: terrain_pyramid::wire::FeedResult<'_, I, E>,
    events: &mut Vec<Event<K, E>>,
    unit: impl FnOnce(I) -> (K, Vec<u8>),
) -> bool {
    use terrain_pyramid::wire::FeedResult;
    match result {
        FeedResult::Consumed => return false,
        FeedResult::Item { item, offset, .. } => {
            let (kind, bytes) = unit(item);
            events.push(Event::Unit(offset, kind, bytes));
        }
        FeedResult::Rejected { error, offset, .. } => events.push(Event::Refused(offset, error)),
    }
    true
}

/// Runs `chunks` through the accumulator `$acc`: one `feed` call at a time on what is left of
/// each chunk ([`feed_chunks`], the calls on a chunk bounded by `$max_calls(chunk length)`),
/// then `flush` calls until one hands out nothing, each result [`record`]ed with `$unit`.
/// Checks that nothing stays buffered and that the stream position is the bytes fed, and
/// evaluates to the events and the counters (`$counters`, the accumulator's method that
/// returns them).
///
/// A macro: the accumulators share these methods by name, not through a trait.
#[allow(unused_macros)] // Not every target runs an accumulator.
macro_rules! run_accumulator {
    ($acc:expr, $chunks:expr, $max_calls:expr, $unit:expr, $counters:ident) => {{
        let mut acc = $acc;
        let mut events = Vec::new();
        $crate::common::feed_chunks($chunks, $max_calls, |window| {
            let r = acc.feed(window);
            (r.remaining(), $crate::common::record(r, &mut events, $unit))
        });
        while $crate::common::record(acc.flush(), &mut events, $unit) {}
        assert_eq!(acc.buffered(), 0);
        let fed: usize = $chunks.iter().map(|chunk| chunk.len()).sum();
        assert_eq!(acc.position(), fed as u64);
        (events, acc.$counters())
    }};
}
#[allow(unused_imports)]
pub(crate) use run_accumulator;

/// The stream's byte at `offset` (where a rejected candidate started, say).
pub fn byte_at(stream: &[u8], offset: u64) -> u8 {
    stream[usize::try_from(offset).unwrap()]
}

/// Asserts that `bytes`, handed out at stream offset `offset`, are the stream's own there.
pub fn assert_in_stream(stream: &[u8], offset: u64, bytes: &[u8]) {
    let at = usize::try_from(offset).unwrap();
    assert_eq!(&stream[at..at + bytes.len()], bytes);
}

/// Asserts that a unit handed out at `offset` is the stream's own `bytes` there
/// ([`assert_in_stream`]) and starts at or after `*last_end`, where the previous one ended;
/// then moves `*last_end` to its own end. `what` names the units in the message.
pub fn assert_next_unit(stream: &[u8], offset: u64, bytes: &[u8], last_end: &mut u64, what: &str) {
    assert_in_stream(stream, offset, bytes);
    assert!(offset >= *last_end, "{what} overlap");
    *last_end = offset + bytes.len() as u64;
}

/// Runs `stream` whole through `run` (events and counters) and checks the run with `check`;
/// then runs it cut into chunks whose sizes cycle through `sizes` ([`chunks`]) and asserts
/// that the events and the counters do not depend on the chunking. Returns the chunks, for
/// further runs.
pub fn check_chunking<'a, E, C>(
    stream: &'a [u8],
    sizes: &[u8],
    run: impl Fn(&[&[u8]]) -> (Vec<E>, C),
    check: impl Fn(&[u8], &[E], C),
) -> Vec<&'a [u8]>
where
    E: PartialEq + std::fmt::Debug,
    C: Copy + PartialEq + std::fmt::Debug,
{
    let (reference, counters) = run(&[stream]);
    check(stream, &reference, counters);
    let chunked = chunks(stream, sizes);
    let (events, counters2) = run(&chunked);
    assert_eq!(events, reference, "the events depend on the chunking");
    assert_eq!(counters2, counters);
    chunked
}
