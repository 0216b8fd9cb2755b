//! The status line of `pyramid listen`: the counters it shows, their rates over the last
//! [`RATE_WINDOW`], the mirror's state in a word, and the writer that keeps it on stderr.
use super::RATE_WINDOW;
use crate::link::Mirror;
use std::collections::VecDeque;
use std::io::{IsTerminal, Write};
use std::time::{Duration, Instant};

/// The counters the status line shows, at one moment.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Counts {
    /// Good frames applied.
    pub frames: u64,
    /// Bad frames dropped (every kind).
    pub errors: u64,
    /// Patches applied.
    pub patches: u64,
    /// Sequence gaps.
    pub gaps: u64,
    /// Snapshots requested.
    pub snapshots: u64,
}

/// Rates per second of frames, errors and patches.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Rates {
    /// Frames per second.
    pub frames: f64,
    /// Errors per second.
    pub errors: f64,
    /// Patches per second.
    pub patches: f64,
}

/// Rates over the last [`RATE_WINDOW`], from samples of the counters.
#[derive(Debug, Default)]
pub struct RateMeter {
    pub(super) samples: VecDeque<(Instant, Counts)>,
}

impl RateMeter {
    /// Adds a sample and returns the rates since the oldest sample within the window (the one
    /// just before it, so that the span is at least the window once there is history).
    pub fn sample(&mut self, now: Instant, counts: Counts) -> Rates {
        self.samples.push_back((now, counts));
        while self.samples.len() > 2
            && self
                .samples
                .get(1)
                .is_some_and(|(t, _)| now.duration_since(*t) >= RATE_WINDOW)
        {
            self.samples.pop_front();
        }
        let Some(&(t0, c0)) = self.samples.front() else {
            return Rates::default();
        };
        let dt = now.duration_since(t0).as_secs_f64();
        if dt <= 0.0 {
            return Rates::default();
        }
        #[allow(clippy::cast_precision_loss)]
        let per_s = |a: u64, b: u64| b.saturating_sub(a) as f64 / dt;
        Rates {
            frames: per_s(c0.frames, counts.frames),
            errors: per_s(c0.errors, counts.errors),
            patches: per_s(c0.patches, counts.patches),
        }
    }
}

/// The mirror's state in a word.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SyncState {
    /// No Hello yet.
    Waiting,
    /// The copy may differ from the device's (frames lost, or a resend under way).
    Syncing,
    /// The copy equals the device's as of the last frame.
    Synced,
}

impl SyncState {
    pub(super) fn of(mirror: &Mirror) -> Self {
        if mirror.firmware().is_none() {
            Self::Waiting
        } else if mirror.is_synced() {
            Self::Synced
        } else {
            Self::Syncing
        }
    }

    const fn word(self) -> &'static str {
        match self {
            Self::Waiting => "waiting for Hello",
            Self::Syncing => "syncing",
            Self::Synced => "synced",
        }
    }
}

/// The status line: elapsed time, frames, errors and patches (totals and per second), gaps,
/// snapshots requested, and the mirror's state.
#[must_use]
pub fn status_line(elapsed: Duration, counts: &Counts, rates: &Rates, state: SyncState) -> String {
    format!(
        "{:7.1} s  frames {} ({:.0}/s)  errors {} ({:.0}/s)  patches {} ({:.0}/s)  gaps {}  snapshots {}  {}",
        elapsed.as_secs_f64(),
        counts.frames,
        rates.frames,
        counts.errors,
        rates.errors,
        counts.patches,
        rates.patches,
        counts.gaps,
        counts.snapshots,
        state.word()
    )
}

/// Writes the status line and notices to stderr.
pub(super) struct StatusOutput {
    terminal: bool,
    /// The length of the line now on the terminal (0 = none).
    shown: usize,
}

impl StatusOutput {
    pub(super) fn new() -> Self {
        Self {
            terminal: std::io::stderr().is_terminal(),
            shown: 0,
        }
    }

    pub(super) fn status(&mut self, line: &str) {
        let mut err = std::io::stderr().lock();
        if self.terminal {
            let pad = self.shown.saturating_sub(line.len());
            let _ = write!(err, "\r{line}{:pad$}", "");
            let _ = err.flush();
            self.shown = line.len();
        } else {
            let _ = writeln!(err, "{line}");
        }
    }

    /// A line of its own (the status line, if shown, is ended first).
    pub(super) fn notice(&mut self, line: &str) {
        self.finish();
        eprintln!("{line}");
    }

    /// Ends the rewritten line.
    pub(super) fn finish(&mut self) {
        if self.terminal && self.shown > 0 {
            eprintln!();
            self.shown = 0;
        }
    }
}
