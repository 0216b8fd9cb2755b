//! Requests to a spinning UART lidar through any [`embedded_io::Write`] (a UART's transmit
//! side): the pure emitters of [`crate::wire::rplidar`] and [`crate::wire::ydlidar`], written
//! out. Reading the answers is the accumulators' job ([`crate::wire::rplidar`],
//! [`crate::wire::ydlidar`], [`crate::wire::ld06`]), fed from the receive side.

use crate::wire::laser::{LidarCommand, LIDAR_COMMAND_MAX_LEN};
use embedded_io::Write;

/// Writes one request in full and flushes the writer.
///
/// ```
/// use terrain_pyramid::drivers::lidar::send;
/// use terrain_pyramid::wire::rplidar::RplidarRequest;
///
/// let mut tx = [0_u8; 16];
/// let mut port = &mut tx[..];
/// send(&mut port, &RplidarRequest::EXPRESS_SCAN).unwrap();
/// assert_eq!(tx[..9], [0xA5, 0x82, 0x05, 0x00, 0x00, 0x00, 0x00, 0x00, 0x22]);
/// ```
///
/// # Errors
/// The writer's error, from `write_all` or `flush`.
pub fn send<W: Write>(w: &mut W, command: &impl LidarCommand) -> Result<(), W::Error> {
    let mut bytes = [0_u8; LIDAR_COMMAND_MAX_LEN];
    let len = command.encode(&mut bytes);
    w.write_all(bytes.get(..len).unwrap_or(&bytes))?;
    w.flush()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::wire::ydlidar::YdlidarCommand;
    use embedded_io::{ErrorKind, ErrorType};

    /// Accepts `room` bytes, then fails.
    struct Port {
        written: [u8; 4],
        len: usize,
        room: usize,
    }

    impl ErrorType for Port {
        type Error = ErrorKind;
    }

    impl Write for Port {
        fn write(&mut self, buf: &[u8]) -> Result<usize, ErrorKind> {
            let Some(&b) = buf.first() else { return Ok(0) };
            if self.len >= self.room {
                return Err(ErrorKind::Other);
            }
            self.written[self.len] = b;
            self.len += 1;
            Ok(1)
        }

        fn flush(&mut self) -> Result<(), ErrorKind> {
            Ok(())
        }
    }

    #[test]
    fn writes_whole_commands_and_reports_errors() {
        let mut port = Port {
            written: [0; 4],
            len: 0,
            room: 4,
        };
        send(&mut port, &YdlidarCommand::Scan).unwrap();
        send(&mut port, &YdlidarCommand::Stop).unwrap();
        assert_eq!(port.written, [0xA5, 0x60, 0xA5, 0x65]);
        assert_eq!(
            send(&mut port, &YdlidarCommand::Scan),
            Err(ErrorKind::Other)
        );
    }
}
