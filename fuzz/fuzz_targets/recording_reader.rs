//! Arbitrary bytes into the recording reader.
//!
//! If the first input byte is odd, a valid 16-byte file header is put in front of the rest, so
//! the fuzzer spends its time on events rather than on the magic.
//!
//! Invariants: no panic; event offsets strictly increase and stay within the data; times never
//! go back; nothing follows the first error; every event but a setup re-emits to exactly the
//! bytes it was read from (a setup re-emits to bytes that read back as the same setup).
#![no_main]

use libfuzzer_sys::fuzz_target;
use terrain_pyramid::wire::recording::{emit_header, Payload, Reader, HEADER_LEN};

fuzz_target!(|input: &[u8]| {
    let Some((&mode, rest)) = input.split_first() else {
        return;
    };
    let mut data = Vec::with_capacity(rest.len() + HEADER_LEN);
    if mode & 1 == 1 {
        data.resize(HEADER_LEN, 0);
        emit_header(&mut data).expect("16 bytes");
    }
    data.extend_from_slice(rest);

    let Ok(mut reader) = Reader::new(&data) else {
        return;
    };
    let mut last_time = 0_u64;
    let mut out = vec![0_u8; 4096 + 64];
    loop {
        let offset = reader.offset();
        let Some(item) = reader.next() else { break };
        match item {
            Ok(event) => {
                let end = reader.offset();
                assert!(end > offset && end <= data.len());
                assert!(event.time_us >= last_time);
                last_time = event.time_us;
                let n = event.emit(&mut out).expect("a read event emits");
                assert_eq!(n, event.buffer_len());
                if matches!(event.payload, Payload::Setup(_)) {
                    let mut file = vec![0_u8; HEADER_LEN];
                    emit_header(&mut file).expect("16 bytes");
                    file.extend_from_slice(&out[..n]);
                    let again = Reader::new(&file)
                        .expect("a valid header")
                        .next()
                        .expect("one event")
                        .expect("a re-emitted setup reads back");
                    let mut out2 = vec![0_u8; n];
                    again.emit(&mut out2).expect("emits");
                    assert_eq!(out2, &out[..n], "a setup does not round-trip");
                } else {
                    assert_eq!(&out[..n], &data[offset..end], "re-emitted bytes differ");
                }
            }
            Err(_) => {
                assert!(reader.next().is_none(), "an event after an error");
                break;
            }
        }
    }
});
