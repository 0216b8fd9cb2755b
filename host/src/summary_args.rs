//! The flags of the commands that write maps and a summary into a directory (`pyramid
//! replay`, `run` and `listen`): the directory, and whether the summary is also printed.

use std::path::PathBuf;

/// Where the maps, the picture and `summary.json` go, and whether the summary is printed.
#[derive(clap::Args, Debug, Clone)]
pub struct SummaryArgs {
    /// The directory the maps, the picture and `summary.json` are written into (created if
    /// missing).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Print the summary as one JSON object on stdout (it is always written to
    /// `DIR/summary.json`).
    #[arg(long)]
    pub json: bool,
}
