//! Regressions found by the fuzz targets (`fuzz/README.md`).
#[path = "support/device.rs"]
mod support;

use support::hello_message;
use terrain_pyramid::wire::link::{encode, MAX_ENCODED_FRAME};
use terrain_pyramid_host::link::{HostLink, LinkEvent};

fn hello(cells_per_side: u16, layers: usize) -> Vec<u8> {
    let mut out = vec![0_u8; MAX_ENCODED_FRAME];
    let n = encode(0, &hello_message(cells_per_side, layers, 0), &mut out).unwrap();
    out.truncate(n);
    out
}

/// link_host_rx: a Hello with W = 65 534 and 16 layers made the mirror allocate 16 × W² cells
/// (about 200 GB) and abort. A window outside the protocol's even 4 ..= 1024 is refused whole,
/// with a snapshot request; a valid Hello after it applies.
#[test]
fn a_hello_with_an_impossible_window_is_refused_not_allocated() {
    let mut host = HostLink::new();
    for w in [65_534, 65_535, 1026, 2, 0, 63] {
        let events = host.feed(&hello(w, 16));
        assert!(
            events.contains(&LinkEvent::SnapshotNeeded),
            "W = {w}: {events:?}"
        );
        assert!(!events.iter().any(|e| matches!(e, LinkEvent::Hello(_))));
        assert_eq!(host.mirror().layer_count(), 0);
    }
    let events = host.feed(&hello(1024, 2));
    assert!(events.iter().any(|e| matches!(e, LinkEvent::Hello(_))));
    assert_eq!(host.mirror().cells_per_side(), 1024);
    assert_eq!(host.mirror().layer_count(), 2);
}
