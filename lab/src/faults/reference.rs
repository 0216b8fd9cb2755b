//! The host's reference for one fault run: the library's co-processor fed exactly the
//! telegrams the firmware decodes intact, and the SICK accumulator over the same damaged bytes
//! that tells intact from corrupt.

use super::*;

/// The host's reference: the library's co-processor in this process, configured as the
/// board, sent the same PanAngle and Pose frames and fed exactly the intact telegrams; and
/// the accumulator the firmware runs, over the same (damaged) bytes, which tells the intact
/// telegrams from the corrupt ones and when each is decoded.
pub(super) struct Reference {
    pub(super) device: HostDevice,
    pub(super) acc: Box<SickAccumulator>,
    /// Stream offset of each intact telegram's STX → its line.
    pub(super) expected: HashMap<u64, usize>,
    pub(super) written: u64,
    pub(super) intact: Vec<bool>,
    pub(super) delayed: u64,
    pub(super) corrupt: u64,
    /// Runs of damaged lines that left no trace in the accumulator's counters.
    pub(super) unaccounted: u64,
    pub(super) resync_max: u64,
}

impl Reference {
    /// The co-processor booted as the board, configured with the default design and the
    /// recording's setup (as the harness configures the board), nothing fed yet.
    pub(super) fn new(setup: &SetupEvent, lines: usize) -> Result<Self, String> {
        let mut device = boot_host_device()?;
        device.configure_after_hello(&default_design(), &Config::default())?;
        device.command(
            "Setup",
            &Message::Setup(setup_message(setup, &ClassifierConfig::default())),
        )?;
        Ok(Self {
            device,
            acc: Box::new(SickAccumulator::new()),
            expected: HashMap::new(),
            written: 0,
            intact: vec![false; lines],
            delayed: 0,
            corrupt: 0,
            unaccounted: 0,
            resync_max: 0,
        })
    }

    /// A host frame, as the board gets it.
    pub(super) fn send(&mut self, message: &Message<'_>) -> Result<(), String> {
        self.device.send(message).map(|_| ())
    }

    /// The pyramid the intact telegrams built.
    pub(super) fn pyramid(&self) -> &DefaultPyramid {
        self.device.core().pyramid()
    }

    pub(super) fn trace(&self) -> u64 {
        let s = self.acc.stats();
        u64::from(s.crc_errors)
            + u64::from(s.length_errors)
            + u64::from(s.truncated)
            + u64::from(s.garbage_bytes)
            + u64::from(s.ack)
            + u64::from(s.nak)
    }

    /// Feeds line `i`'s chunk, as the firmware will take it: the intact telegrams it decodes
    /// go to the co-processor.
    pub(super) fn feed(&mut self, i: usize, step: &Step, lines: &[Line]) -> Result<(), String> {
        if let Some(at) = step.intact_at {
            self.expected.insert(self.written + at as u64, i);
        }
        self.written += step.chunk.len() as u64;
        let mut rest = &step.chunk[..];
        loop {
            let (bytes, offset) = match self.acc.feed(rest) {
                FeedResult::Consumed => return Ok(()),
                FeedResult::Item {
                    item: SickItem::Telegram(telegram),
                    offset,
                    remaining,
                } => {
                    rest = remaining;
                    (telegram.as_bytes().to_vec(), offset)
                }
                other => {
                    rest = other.remaining();
                    continue;
                }
            };
            match self.expected.remove(&offset) {
                Some(k) if lines[k].telegram == bytes => {
                    if k != i {
                        self.delayed += 1;
                    }
                    self.intact[k] = true;
                    self.device.laser(&bytes)?;
                }
                _ => self.corrupt += 1,
            }
        }
    }

    /// After the run: the most untouched telegrams lost in one run of lines between two
    /// intact ones.
    pub(super) fn settle(&mut self, steps: &[Step]) {
        let mut lost = 0_u64;
        for (i, step) in steps.iter().enumerate() {
            if self.intact[i] {
                self.resync_max = self.resync_max.max(lost);
                lost = 0;
            } else if step.intact_at.is_some() {
                lost += 1;
            }
        }
        self.resync_max = self.resync_max.max(lost);
    }
}
