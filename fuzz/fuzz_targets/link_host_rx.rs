//! Device-to-host bytes into the library's frame accumulator and `decode`, and into the host
//! crate's `HostLink` (decoder and layer mirror).
//!
//! The input is a chunking prefix, a mode byte (odd: raw stream) and a list of segments `[flags, type, len, body...]` that the harness turns into
//! valid frames (or raw bytes, a wrong version, a flipped bit: see `common::link_stream`).
//!
//! Invariants: no panic; the accumulator's events do not depend on the chunking; its counters
//! match its events; every frame it decodes re-encodes to the same bytes (the decoder accepts
//! only what the encoder writes) and `decode` of those bytes agrees; `HostLink` reports one
//! bad frame per accumulator error and its mirror stays within its own bounds.
#![no_main]

mod common;

use libfuzzer_sys::fuzz_target;
use terrain_pyramid::wire::link::{
    cobs, decode, encode, DecodeError, Decoded, FrameAccumulator, Header, Undecoded,
    MAX_ENCODED_FRAME, MAX_FRAME,
};
use terrain_pyramid::wire::FeedResult;
use terrain_pyramid_host::link::{HostLink, LinkEvent};

#[derive(Debug, PartialEq)]
enum Ev {
    /// Header and the frame re-encoded.
    Frame(Header, Vec<u8>),
    Error(DecodeError, Option<Header>),
}

/// The COBS-decoded bytes of one encoded frame (delimiter included).
fn unstuff(encoded: &[u8]) -> Vec<u8> {
    let mut d = cobs::Decoder::new();
    let mut out = Vec::new();
    for &b in encoded {
        match d.step(b) {
            cobs::Step::Byte(x) => out.push(x),
            cobs::Step::None => {}
            cobs::Step::End => break,
            cobs::Step::Error => panic!("our own encoding is bad COBS"),
        }
    }
    out
}

fn run(chunks: &[&[u8]]) -> Vec<Ev> {
    let mut acc = Box::new(FrameAccumulator::<MAX_FRAME>::new());
    let mut out = Vec::new();
    let mut scratch = vec![0_u8; MAX_ENCODED_FRAME];
    // Every item or refusal takes at least one byte: no more calls than bytes.
    common::feed_chunks(
        chunks,
        |len| len,
        |window| {
            let r = acc.feed(window);
            let rest = r.remaining();
            let handed_out = match r {
                FeedResult::Consumed => false,
                FeedResult::Item {
                    item: Decoded { header, message },
                    ..
                } => {
                    let n = encode(header.seq, &message, &mut scratch)
                        .expect("a decoded message encodes");
                    assert!(n <= message.encoded_len_max());
                    let encoded = scratch[..n].to_vec();
                    let raw = unstuff(&encoded);
                    let (h2, m2) = decode(&raw).expect("a re-encoded message decodes");
                    assert_eq!(h2, header);
                    // Compare through the encoder again: messages may hold NaNs.
                    let n2 = encode(h2.seq, &m2, &mut scratch).expect("encodes again");
                    assert_eq!(&scratch[..n2], &encoded[..]);
                    out.push(Ev::Frame(header, encoded));
                    true
                }
                FeedResult::Rejected {
                    error: Undecoded { error, header },
                    ..
                } => {
                    out.push(Ev::Error(error, header));
                    true
                }
            };
            assert!(!handed_out || rest.len() < window.len());
            (rest, handed_out)
        },
    );
    let counters = acc.counters();
    let frames = out.iter().filter(|e| matches!(e, Ev::Frame(..))).count();
    assert_eq!(counters.frames_ok as usize, frames);
    assert_eq!(counters.errors() as usize, out.len() - frames);
    out
}

fuzz_target!(|data: &[u8]| {
    let (sizes, rest) = common::split_sizes(data);
    // A mode byte: odd, the rest is the raw stream; even, structured segments.
    let Some((&mode, rest)) = rest.split_first() else {
        return;
    };
    let stream = if mode & 1 != 0 {
        rest.to_vec()
    } else {
        common::link_stream(rest)
    };
    let reference = run(&[&stream]);
    let chunked = common::chunks(&stream, sizes);
    let events = run(&chunked);
    assert_eq!(events, reference, "the events depend on the chunking");

    // The decoder alone, on the raw input as one frame.
    let _ = decode(rest);

    // The host's end: decoder and mirror.
    let mut host = HostLink::new();
    let mut bad = 0usize;
    for chunk in &chunked {
        for event in host.feed(chunk) {
            if matches!(event, LinkEvent::BadFrame(_)) {
                bad += 1;
            }
        }
    }
    let errors = reference
        .iter()
        .filter(|e| matches!(e, Ev::Error(..)))
        .count();
    assert_eq!(bad, errors);
    assert_eq!(host.rx_counters().errors() as usize, errors);
    let mirror = host.mirror();
    let w = mirror.cells_per_side();
    for k in 0..mirror.layer_count() {
        if let Some(layer) = mirror.layer(k) {
            assert_eq!(layer.cells().len(), w * w);
        }
    }
});
