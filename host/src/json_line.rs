//! A command's `--json` answer: one line of JSON on stdout.
use serde::Serialize;

/// Prints `value` as one line of JSON on stdout; when it cannot be encoded, says `failure`
/// followed by the encoder's error on stderr and returns `false` (the command then fails).
#[must_use]
pub fn print(value: &impl Serialize, failure: &str) -> bool {
    match serde_json::to_string(value) {
        Ok(json) => {
            crate::outln!("{json}");
            true
        }
        Err(e) => {
            eprintln!("{failure}{e}");
            false
        }
    }
}
