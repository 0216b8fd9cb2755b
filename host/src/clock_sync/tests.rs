//! The filter against a simulated device clock: a known offset and drift, the u32 wrap,
//! asymmetric random delays. The true device time is computed here in integers from the
//! simulation's own parameters, never from the filter.
use super::*;

/// xorshift64*: a fixed, seedable source of delays.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    /// Uniform in `0..n`.
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n.max(1)
    }
}

/// A device whose µs clock reads `start + host × (1 + ppm / 10⁶)` (wrapping), in integers.
#[derive(Clone, Copy)]
struct Device {
    start: u64,
    ppm: i64,
}

impl Device {
    fn at(&self, host_us: u64) -> u32 {
        let h = i128::from(host_us);
        let d = i128::from(self.start) + h + h * i128::from(self.ppm) / 1_000_000;
        (d.rem_euclid(1 << 32)) as u32
    }
}

/// The link's delays: a fixed part each way (asymmetric) and a random queue, mostly on the
/// way back (the reply waits behind map data), sometimes long.
struct Link {
    up_us: u64,
    down_us: u64,
    rng: Rng,
}

impl Link {
    fn delays(&mut self) -> (u64, u64) {
        let up = self.up_us + self.rng.below(200);
        let queued = match self.rng.below(10) {
            0..=3 => 0,
            4..=7 => self.rng.below(3_000),
            _ => self.rng.below(40_000),
        };
        (up, self.down_us + queued + self.rng.below(200))
    }
}

/// Exchanges at the host's schedule (10 Hz for the first 2 s, then 2 Hz), from `t0` for
/// `seconds`; after each, `check(filter, now)`.
fn run(
    sync: &mut ClockSync,
    device: Device,
    link: &mut Link,
    t0: u64,
    seconds: u64,
    mut check: impl FnMut(&ClockSync, u64),
) -> u64 {
    let mut t = t0;
    while t < t0 + seconds * 1_000_000 {
        let (up, down) = link.delays();
        let outcome = sync.add(Exchange {
            host_sent_us: t,
            device_us: device.at(t + up),
            host_received_us: t + up + down,
            queued_ahead: u16::from(down > link.down_us + 200),
        });
        assert_eq!(outcome, Outcome::Taken);
        check(sync, t + up + down);
        t += if t - t0 < 2_000_000 { 100_000 } else { 500_000 };
    }
    t
}

/// `|mapped − true|` in µs, on the wrapping difference.
fn error_us(mapped: u32, truth: u32) -> f64 {
    f64::from((mapped.wrapping_sub(truth) as i32).unsigned_abs())
}

#[test]
fn no_mapping_before_two_blocks() {
    let mut sync = ClockSync::new();
    let device = Device {
        start: 123_456_789,
        ppm: 0,
    };
    for i in 0..(BLOCK * MIN_BLOCKS) as u64 {
        assert!(!sync.is_synced());
        assert_eq!(sync.to_device(1_000), None);
        assert_eq!(sync.to_host(1_000), None);
        let t = 1_000_000 + i * 100_000;
        sync.add(Exchange {
            host_sent_us: t,
            device_us: device.at(t + 400),
            host_received_us: t + 800,
            queued_ahead: 0,
        });
    }
    assert!(sync.is_synced());
    // Symmetric 400 µs each way: exact.
    let h = 2_000_000;
    let mapped = sync.to_device(h).unwrap();
    assert!(error_us(mapped, device.at(h)) <= 1.0, "{mapped}");
    assert!(sync.accuracy_at(h).unwrap() >= 400.0);
}

#[test]
fn offset_drift_and_wrap_stay_within_the_stated_accuracy() {
    // 100 ppm fast, starting 20 s before its wrap, for 80 minutes: more than one whole wrap
    // (71.6 min) of the device's clock.
    let device = Device {
        start: (1 << 32) - 20_000_000,
        ppm: 100,
    };
    let mut link = Link {
        up_us: 300,
        down_us: 700,
        rng: Rng(0x9E37_79B9_7F4A_7C15),
    };
    let mut sync = ClockSync::new();
    let mut checked = 0_u64;
    let mut worst_ratio = 0.0_f64;
    let mut worst_error = 0.0_f64;
    let mut worst_accuracy = 0.0_f64;
    let t0 = 5_000_000;
    run(&mut sync, device, &mut link, t0, 80 * 60, |s, now| {
        if !s.is_synced() {
            return;
        }
        // Poses are stamped up to a few hundred ms before they arrive; data a little later.
        for h in [now - 300_000, now - 30_000, now, now + 100_000] {
            let mapped = s.to_device(h).unwrap();
            let error = error_us(mapped, device.at(h));
            let accuracy = s.accuracy_at(h).unwrap();
            assert!(
                error <= accuracy,
                "at host {h} µs: error {error} µs > accuracy {accuracy} µs"
            );
            worst_ratio = worst_ratio.max(error / accuracy);
            worst_error = worst_error.max(error);
            if now > t0 + 60_000_000 {
                worst_accuracy = worst_accuracy.max(accuracy);
            }
            // And back: within a µs of rounding (and the drift's µs per second).
            let back = s.to_host(device.at(h)).unwrap();
            let back_error = (back as f64 - h as f64).abs();
            assert!(back_error <= accuracy + 2.0, "to_host {back} vs {h}");
            checked += 1;
        }
    });
    assert!(checked > 35_000, "{checked}");
    // The fitted drift, at the end of the run.
    let e = sync.estimate().unwrap();
    assert!((e.drift_ppm - 100.0).abs() < 5.0, "{e:?}");
    // The bound is useful once a minute of exchanges is in: near the least round trip
    // (≈ 1 ms), far under the link's worst (≈ 41 ms).
    assert!(
        worst_accuracy < 1_500.0,
        "accuracy up to {worst_accuracy} µs"
    );
    assert!(worst_error < 1_000.0, "error up to {worst_error} µs");
    assert!(
        worst_ratio > 0.05,
        "the bound is never approached: {worst_ratio}"
    );
    let c = sync.counters();
    assert_eq!(c.resets(), 0);
    assert_eq!(c.discarded, 0);
    assert!(c.queued_replies > c.exchanges / 3, "{c:?}");
}

#[test]
fn an_internal_oscillator_one_percent_slow_is_followed() {
    let device = Device {
        start: 42,
        ppm: -10_000,
    };
    let mut link = Link {
        up_us: 250,
        down_us: 250,
        rng: Rng(7),
    };
    let mut sync = ClockSync::new();
    run(&mut sync, device, &mut link, 1_000, 120, |s, now| {
        if let Some(a) = s.accuracy_at(now - 30_000) {
            let e = error_us(s.to_device(now - 30_000).unwrap(), device.at(now - 30_000));
            assert!(e <= a, "error {e} > accuracy {a}");
        }
    });
    let e = sync.estimate().unwrap();
    assert!((e.drift_ppm + 10_000.0).abs() < 5.0, "{e:?}");
}

#[test]
fn a_device_clock_jump_resets_and_a_bad_round_trip_is_discarded() {
    let device = Device {
        start: 1_000_000_000,
        ppm: 30,
    };
    let mut link = Link {
        up_us: 300,
        down_us: 300,
        rng: Rng(99),
    };
    let mut sync = ClockSync::new();
    let t = run(&mut sync, device, &mut link, 0, 10, |_, _| {});
    assert!(sync.is_synced());
    // Negative and over-long round trips: discarded, the mapping kept.
    assert_eq!(
        sync.add(Exchange {
            host_sent_us: t,
            device_us: 0,
            host_received_us: t - 1,
            queued_ahead: 0,
        }),
        Outcome::Discarded
    );
    assert_eq!(
        sync.add(Exchange {
            host_sent_us: t,
            device_us: device.at(t),
            host_received_us: t + MAX_ROUND_TRIP_US + 1,
            queued_ahead: 0,
        }),
        Outcome::Discarded
    );
    assert!(sync.is_synced());
    assert_eq!(sync.counters().discarded, 2);
    // A reply that queued 90 ms is consistent (its bounds hold the true offset): taken.
    let t = t + 500_000;
    assert_eq!(
        sync.add(Exchange {
            host_sent_us: t,
            device_us: device.at(t + 300),
            host_received_us: t + 90_600,
            queued_ahead: 8_000,
        }),
        Outcome::Taken
    );
    // The device rebooted unseen: its clock restarted near 0.
    let rebooted = Device { start: 0, ppm: 30 };
    let t = t + 500_000;
    assert_eq!(
        sync.add(Exchange {
            host_sent_us: t,
            device_us: rebooted.at(t + 300),
            host_received_us: t + 600,
            queued_ahead: 0,
        }),
        Outcome::Reset
    );
    assert!(!sync.is_synced());
    let c = sync.counters();
    assert_eq!((c.resets_inconsistent, c.resets()), (1, 1));
    // A reset by the caller is counted by its reason.
    sync.reset(ResetReason::DeviceBoot);
    sync.reset(ResetReason::Reconnect);
    let c = sync.counters();
    assert_eq!((c.resets_boot, c.resets_reconnect, c.resets()), (1, 1, 3));
}

#[test]
fn a_jump_of_just_over_the_limit_resets_and_just_under_does_not() {
    let device = Device { start: 5, ppm: 0 };
    let mut link = Link {
        up_us: 400,
        down_us: 400,
        rng: Rng(3),
    };
    for (jump, expected) in [
        (MAX_INCONSISTENCY_US as u32 - 2_000, Outcome::Taken),
        (MAX_INCONSISTENCY_US as u32 + 2_000, Outcome::Reset),
    ] {
        let mut sync = ClockSync::new();
        let t = run(&mut sync, device, &mut link, 0, 5, |_, _| {});
        // Round trip 1 ms: bounds [t2 − t4, t2 − t1] are 1 ms wide.
        let outcome = sync.add(Exchange {
            host_sent_us: t,
            device_us: device.at(t + 500).wrapping_add(jump),
            host_received_us: t + 1_000,
            queued_ahead: 0,
        });
        assert_eq!(outcome, expected, "jump {jump} µs");
    }
}

#[test]
fn unwrapping_takes_the_nearest_turn() {
    assert_eq!(unwrap_near(5, (1 << 32) - 5), (1 << 32) + 5);
    assert_eq!(unwrap_near(u32::MAX - 4, 1 << 32), (1 << 32) - 5);
    assert_eq!(unwrap_near(100, 90), 100);
    assert_eq!(unwrap_near(u32::MAX, 0), -1);
}
