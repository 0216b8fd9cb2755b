//! Opening a serial port as the lasers and the device links here use it: 8 data bits, no
//! parity, one stop bit, no flow control, exclusive to this process (serialport's default).

use std::time::Duration;

/// The serial port `path` opened at `baud` (bits per second), each read waiting at most
/// `read_timeout`.
///
/// # Errors
/// The port cannot be opened, in words: a port another process holds is named as such (the
/// port is exclusive: TIOCEXCL and an exclusive `flock`).
pub fn open(
    path: &str,
    baud: u32,
    read_timeout: Duration,
) -> Result<Box<dyn serialport::SerialPort>, String> {
    serialport::new(path, baud)
        .data_bits(serialport::DataBits::Eight)
        .parity(serialport::Parity::None)
        .stop_bits(serialport::StopBits::One)
        .flow_control(serialport::FlowControl::None)
        .timeout(read_timeout)
        .open()
        .map_err(|e| open_error(path, &e))
}

/// Why a serial port cannot be opened, in words.
fn open_error(path: &str, e: &serialport::Error) -> String {
    let busy = e.description.contains("exclusive lock")
        || e.description.contains("busy")
        || e.description.contains("EBUSY");
    if busy {
        format!("cannot open the serial port {path}: it is already open in another process ({e})")
    } else {
        format!("cannot open the serial port {path}: {e}")
    }
}
