//! What the tests of `pyramid listen` against a stand-in device on 127.0.0.1 share: reading
//! the frames the binary sends, and a refusal before it connects.
#![allow(dead_code)]
use std::process::Command;
use terrain_pyramid::wire::link::{Decoded, FrameAccumulator, Header, Message, MAX_FRAME};
use terrain_pyramid::wire::FeedResult;

/// Feeds `bytes` to `acc` and hands `take` every frame that passed its checks, in order
/// (refused frames are skipped; a frame not yet complete stays in `acc`).
pub fn each_frame(
    acc: &mut FrameAccumulator<MAX_FRAME>,
    bytes: &[u8],
    mut take: impl FnMut(Header, Message<'_>),
) {
    let mut rest = bytes;
    while !rest.is_empty() {
        match acc.feed(rest) {
            FeedResult::Item {
                item: Decoded { header, message },
                remaining,
                ..
            } => {
                take(header, message);
                rest = remaining;
            }
            FeedResult::Consumed => break,
            FeedResult::Rejected { remaining, .. } => rest = remaining,
        }
    }
}

/// Runs `pyramid listen` on a device at 127.0.0.1:9 (nothing listens there) with `flags` and
/// checks it refuses them before connecting (exit status 2); its stderr.
pub fn refused_before_connecting(flags: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_pyramid"))
        .args([
            "listen",
            "--tcp",
            "127.0.0.1:9",
            "--out",
            "/nonexistent-dir",
        ])
        .args(flags)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    String::from_utf8_lossy(&out.stderr).into_owned()
}
