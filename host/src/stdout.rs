//! A command's answer on stdout. `print!` panics when the reader has gone away
//! (`pyramid design --json | head -c 100`); here that ends the process quietly with status
//! 0, as a Unix tool ends on SIGPIPE, and any other failure to write says so on stderr with
//! status 1.
use std::io::{ErrorKind, Write};

/// Writes `text` to stdout and flushes it; see the module.
pub fn write(text: std::fmt::Arguments<'_>) {
    let mut out = std::io::stdout().lock();
    if let Err(e) = out.write_fmt(text).and_then(|()| out.flush()) {
        if e.kind() == ErrorKind::BrokenPipe {
            std::process::exit(0);
        }
        eprintln!("error: cannot write to stdout: {e}");
        std::process::exit(1);
    }
}

/// `print!` through [`write()`].
#[macro_export]
macro_rules! out {
    ($($arg:tt)*) => { $crate::stdout::write(format_args!($($arg)*)) };
}

/// `println!` through [`write()`].
#[macro_export]
macro_rules! outln {
    ($($arg:tt)*) => { $crate::stdout::write(format_args!("{}\n", format_args!($($arg)*))) };
}
