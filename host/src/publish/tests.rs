//! The hand-off between the reader and the publishing thread.
use super::*;
use crate::link::HostLink;
use std::sync::mpsc::{Receiver, Sender};
use terrain_pyramid::link::{Link, LinkConfig, SensorCounters};
use terrain_pyramid::{DefaultPyramid, Evidence, EvidenceClass};

/// A sink that records what it is given and blocks on every publish until released.
struct Stuck {
    release: Receiver<()>,
    seen: Sender<(Vec<usize>, bool)>,
}

impl Sink for Stuck {
    fn publish(&mut self, update: &Update<'_>, counts: &mut BTreeMap<String, u64>) {
        let _ = self.release.recv();
        let layers = update.layers.iter().map(|l| l.index).collect();
        let _ = self.seen.send((layers, update.fused.is_some()));
        count(counts, "stuck", "all");
    }
    fn finish(self: Box<Self>) -> Result<(), String> {
        Ok(())
    }
}

/// A device and the host's link, in process.
struct Pair {
    pyramid: Box<DefaultPyramid>,
    device: Box<Link>,
    host: HostLink,
    now_ms: u32,
}

impl Pair {
    fn new() -> Self {
        let design = crate::design::firmware_design().unwrap();
        let mut pyramid = Box::new(DefaultPyramid::new());
        let mut device = Box::new(Link::new(LinkConfig::DEFAULT));
        pyramid
            .configure(&design, &terrain_pyramid::Config::default())
            .unwrap();
        device.adopt(&design);
        let mut pair = Self {
            pyramid,
            device,
            host: HostLink::new(),
            now_ms: 0,
        };
        pair.pump();
        pair
    }

    /// Moves everything the device has queued to the host.
    fn pump(&mut self) {
        let mut buf = vec![0_u8; 4096];
        for _ in 0..200 {
            self.now_ms += 20;
            self.device
                .poll(self.now_ms, &mut *self.pyramid, &SensorCounters::default());
            let n = self.device.pop_bytes(&mut buf);
            self.host.feed(&buf[..n]);
        }
    }

    fn mark(&mut self, layer: u8, x: i32) {
        self.pyramid.apply(&Evidence {
            layer,
            cell_x: x,
            cell_y: 0,
            class: EvidenceClass::Obstacle,
            weight: terrain_pyramid::Weight::ONE,
        });
        self.pump();
    }
}

fn config(hz: f64) -> Config {
    Config {
        publish_hz: hz,
        ..Config::off()
    }
}

/// Outputs publishing at most `hz` times a second to one [`Stuck`] sink (`release`, `seen`).
fn stuck_outputs(hz: f64, release: Receiver<()>, seen: Sender<(Vec<usize>, bool)>) -> Outputs {
    Outputs::start_with(&config(hz), move |_| {
        let sinks: Vec<Box<dyn Sink>> = vec![Box::new(Stuck { release, seen })];
        Ok((sinks, None))
    })
    .unwrap()
}

#[test]
fn a_stuck_output_never_holds_up_the_reader_and_the_latest_map_wins() {
    let (release_tx, release_rx) = mpsc::channel();
    let (seen_tx, seen_rx) = mpsc::channel();
    let mut outputs = stuck_outputs(1000.0, release_rx, seen_tx);
    let mut pair = Pair::new();
    // The first hand-off is taken; the sink blocks in it.
    assert!(outputs.offer(pair.host.mirror(), None));
    // Meanwhile the reader goes on: every offer returns at once and replaces the last.
    let start = Instant::now();
    let mut handed = 0;
    for i in 0..50 {
        pair.mark(1, i);
        std::thread::sleep(Duration::from_millis(2));
        handed += u32::from(outputs.offer(pair.host.mirror(), None));
    }
    assert!(handed >= 45, "{handed}");
    assert!(start.elapsed() < Duration::from_secs(20));
    // Release the sink: it gets the first frame, then only the latest of the rest.
    for _ in 0..10 {
        let _ = release_tx.send(());
    }
    let report = outputs.finish(pair.host.mirror(), None).unwrap();
    let seen: Vec<(Vec<usize>, bool)> = seen_rx.try_iter().collect();
    // The first frame publishes every layer; later ones only layer 1 (the one marked).
    assert_eq!(seen[0].0, (0..8).collect::<Vec<_>>());
    assert!(seen.len() <= 3, "{seen:?}");
    assert!(
        seen.iter().skip(1).all(|(layers, _)| layers == &[1]),
        "{seen:?}"
    );
    assert!(report.coalesced >= 40, "{report:?}");
    assert_eq!(report.pose_source, Some(PoseSource::WindowCentre));
}

#[test]
fn offers_are_bounded_by_the_rate_and_skip_unchanged_maps() {
    let (seen_tx, seen_rx) = mpsc::channel();
    let (release_tx, release_rx) = mpsc::channel();
    for _ in 0..1000 {
        release_tx.send(()).unwrap();
    }
    let mut outputs = stuck_outputs(10.0, release_rx, seen_tx);
    let mut pair = Pair::new();
    let start = Instant::now();
    let mut handed = 0;
    let mut i = 0;
    while start.elapsed() < Duration::from_millis(500) {
        pair.mark(2, i % 60 - 30);
        i += 1;
        handed += u32::from(outputs.offer(pair.host.mirror(), None));
    }
    // 10 per second over half a second (the first at once).
    assert!((4..=7).contains(&handed), "{handed}");
    // The last mark may still be news once the period is over; after that, nothing is.
    std::thread::sleep(Duration::from_millis(150));
    let _ = outputs.offer(pair.host.mirror(), None);
    std::thread::sleep(Duration::from_millis(150));
    assert!(!outputs.offer(pair.host.mirror(), None));
    // A new pose is news.
    let pose = RobotPose {
        x: 1.0,
        y: 2.0,
        yaw: 0.5,
    };
    assert!(outputs.offer(pair.host.mirror(), Some(pose)));
    let report = outputs.finish(pair.host.mirror(), Some(pose)).unwrap();
    assert_eq!(report.pose_source, Some(PoseSource::Given));
    let seen: Vec<_> = seen_rx.try_iter().collect();
    // The pose alone changed the fused map's square (it follows the robot), not the layers.
    assert!(
        seen.last().is_some_and(|(layers, _)| layers.is_empty()),
        "{seen:?}"
    );
}

#[test]
fn no_outputs_means_no_thread_and_no_work() {
    let mut outputs = Outputs::start(&Config::off()).unwrap();
    assert!(!outputs.is_on());
    let pair = Pair::new();
    assert!(!outputs.offer(pair.host.mirror(), None));
    let report = outputs.finish(pair.host.mirror(), None).unwrap();
    assert_eq!(report.handoffs, 0);
}
