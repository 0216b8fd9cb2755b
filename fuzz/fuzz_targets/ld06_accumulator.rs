//! Arbitrary bytes, arbitrarily chunked, into the LD06 accumulator.
//!
//! Invariants: no panic; the events do not depend on the chunking; every packet handed out
//! passes `Ld06Packet::new_checked`, is the stream's own 47 bytes at its offset, does not
//! overlap the previous one, and yields 12 returns; the counters match the events; every
//! byte is accounted for exactly (47·packets + rejections + garbage = stream length).
#![no_main]

mod common;

use libfuzzer_sys::fuzz_target;
use terrain_pyramid::wire::ld06::{Ld06Accumulator, Ld06Counters, Ld06Error, Ld06Packet};

type Ev = common::Event<(), Ld06Error>;

/// Checks a packet handed out: valid, with 12 returns; its bytes.
fn packet(item: Ld06Packet<&[u8]>) -> ((), Vec<u8>) {
    let bytes = item.as_bytes();
    let checked = Ld06Packet::new_checked(bytes).expect("a delivered packet is valid");
    assert_eq!(checked.returns().count(), 12);
    let _ = checked.wrap_index();
    ((), bytes.to_vec())
}

fn run(chunks: &[&[u8]]) -> (Vec<Ev>, Ld06Counters) {
    common::run_accumulator!(
        Ld06Accumulator::new(),
        chunks,
        |len| 2 * (len + 47) + 2,
        packet,
        counters
    )
}

fn check(stream: &[u8], events: &[Ev], c: Ld06Counters) {
    let (mut packets, mut crc, mut truncated) = (0u32, 0u32, 0u32);
    let mut last_end = 0u64;
    for ev in events {
        match ev {
            Ev::Unit(offset, (), bytes) => {
                packets += 1;
                common::assert_next_unit(stream, *offset, bytes, &mut last_end, "packets");
            }
            Ev::Refused(offset, e) => {
                assert_eq!(common::byte_at(stream, *offset), 0x54);
                match e {
                    Ld06Error::BadCrc { .. } => crc += 1,
                    Ld06Error::Truncated => truncated += 1,
                    other => panic!("unexpected rejection {other:?}"),
                }
            }
        }
    }
    assert_eq!(
        (c.packets, c.checksum, c.truncated),
        (packets, crc, truncated)
    );
    let accounted = 47 * u64::from(c.packets)
        + u64::from(c.checksum)
        + u64::from(c.truncated)
        + u64::from(c.garbage_bytes);
    assert_eq!(accounted, stream.len() as u64, "bytes not accounted for");
}

fuzz_target!(|data: &[u8]| {
    let (sizes, stream) = common::split_sizes(data);
    common::check_chunking(stream, sizes, run, check);
});
