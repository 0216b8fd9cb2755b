//! The fault harness's own tests: the plans damage what each kind says and nothing else.

use super::plan::*;
use super::*;

fn lines(n: usize) -> (SetupEvent, Vec<Line>) {
    recording(n).unwrap()
}

/// Every line's angle and pose, then its chunk, as `run_kind` hands them to the
/// reference.
fn feed_all(reference: &mut Reference, steps: &[Step], lines: &[Line]) {
    for (i, step) in steps.iter().enumerate() {
        for cmd in &step.cmds {
            match cmd {
                Cmd::Angle(turns) => reference
                    .send(&Message::PanAngle(PanAngle {
                        turns: *turns,
                        timestamp_ms: 0,
                    }))
                    .unwrap(),
                Cmd::Pose(p) => reference
                    .send(&Message::Pose(PoseReport::unstamped(*p)))
                    .unwrap(),
                Cmd::Configure(_) | Cmd::Setup(_) => {}
            }
        }
        reference.feed(i, step, lines).unwrap();
    }
    reference.settle(steps);
}

#[test]
fn untouched_telegrams_are_intact_and_damaged_ones_are_not() {
    let (setup_rec, lines) = lines(40);
    assert_eq!(lines.len(), 40);
    let setup = setup_message(&setup_rec, &ClassifierConfig::default());
    for kind in [
        "truncated",
        "dropped_bytes",
        "bit_flips_1e-3",
        "garbage_bursts",
    ] {
        let steps = plan(kind, &lines, &setup);
        let damaged = steps.iter().filter(|s| s.intact_at.is_none()).count();
        assert!(damaged > 0, "{kind}: the plan damages nothing");
        let mut reference = Reference::new(&setup_rec, steps.len()).unwrap();
        feed_all(&mut reference, &steps, &lines);
        for (i, step) in steps.iter().enumerate() {
            assert_eq!(
                reference.intact[i],
                step.intact_at.is_some(),
                "{kind} line {i}"
            );
        }
        assert_eq!((reference.corrupt, reference.resync_max), (0, 0), "{kind}");
        reference.send(&Message::EndObservation).unwrap();
        assert!(known_cells(reference.pyramid()) > 0, "{kind}");
        // Every intact telegram reached the co-processor, at an angle.
        let counters = reference.device.core().counters();
        let intact = reference.intact.iter().filter(|&&b| b).count();
        assert_eq!(counters.frontend.lines_applied as usize, intact, "{kind}");
        assert_eq!(counters.app.lines_without_angle, 0, "{kind}");
    }
}

/// A telegram with a good CRC in another telegram's place is corrupt, not intact; and a
/// telegram swallowed whole is a lost one: the measures can fail.
#[test]
fn a_wrong_telegram_is_corrupt_and_a_lost_one_counts() {
    let (setup_rec, lines) = lines(12);
    let setup = setup_message(&setup_rec, &ClassifierConfig::default());
    let mut steps = plan("none", &lines, &setup);
    assert_ne!(lines[4].telegram, lines[5].telegram);
    steps[5].chunk.clone_from(&lines[4].telegram);
    // Line 7 claims to be untouched but its bytes never arrive.
    steps[6].chunk.clear();
    steps[6].intact_at = None;
    steps[7].chunk.clear();
    let mut reference = Reference::new(&setup_rec, steps.len()).unwrap();
    feed_all(&mut reference, &steps, &lines);
    assert_eq!(reference.corrupt, 1);
    assert!(!reference.intact[5] && !reference.intact[7]);
    assert_eq!(reference.resync_max, 2);
    let mut o = Outcome {
        corrupt_applied: reference.corrupt,
        telegrams_applied: 1,
        resync_max_telegrams: reference.resync_max,
        reference_known_cells: 1,
        map_equal_to_reference: true,
        ..Outcome::default()
    };
    judge(&mut o);
    assert!(!o.ok && o.failures.len() == 2, "{:?}", o.failures);
}
