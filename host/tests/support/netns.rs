//! Tests that publish or subscribe over DDS run inside a network namespace of their own, so
//! that multicast never leaves the machine: the outer test runs this test binary's inner,
//! ignored test again under `unshare -n`, marked by [`NETNS_MARK`].
#![allow(dead_code)]
use std::process::Command;

/// The environment variable that marks the inner test's run inside its network namespace.
pub const NETNS_MARK: &str = "TERRAIN_PYRAMID_TEST_NETNS";

/// Runs this test binary's ignored test `inner` inside a new network namespace with only
/// loopback (multicast on, routed to lo; `unshare -n`, root needed), [`NETNS_MARK`] set, and
/// fails unless it passed; its stderr.
pub fn run_in_own_network_namespace(inner: &str) -> String {
    let exe = std::env::current_exe().unwrap();
    let out = Command::new("unshare")
        .args([
            "-n",
            "sh",
            "-c",
            &format!(
                "ip link set lo up multicast on && ip route add 224.0.0.0/4 dev lo && exec \"$0\" {inner} --exact --ignored --nocapture"
            ),
        ])
        .arg(&exe)
        .env(NETNS_MARK, "1")
        .output()
        .expect("unshare runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success() && stdout.contains("1 passed"),
        "the test inside `unshare -n` (root needed) failed:\n{stdout}\n{stderr}"
    );
    stderr.into_owned()
}
