//! The byte stream of `pyramid listen`: the device's serial port or TCP socket, opened,
//! read, written and released while the device is looked for again.
use super::{Args, CONNECT_TIMEOUT, DEFAULT_BAUD, POSE_READ_TIMEOUT, READ_TIMEOUT};
use std::io::{Read, Write};
use std::net::{TcpStream, ToSocketAddrs};

/// Where the device's bytes come from.
pub(super) enum Transport {
    Serial(Box<dyn serialport::SerialPort>),
    Tcp(TcpStream),
    /// Released while the device is looked for again (a serial port must be closed, and its
    /// lock released, before it can be opened again).
    Closed,
}

/// What one read gave.
pub(super) enum Received {
    Bytes(usize),
    Nothing,
    /// The stream ended; the reason, when it was an error.
    Ended(Option<String>),
}

impl Transport {
    pub(super) fn open(args: &Args) -> Result<(Self, String), String> {
        let read_timeout = if args.odom_topic.is_some() || args.pose_udp.is_some() {
            POSE_READ_TIMEOUT
        } else {
            READ_TIMEOUT
        };
        if let Some(path) = &args.port {
            let baud = args.baud.unwrap_or(DEFAULT_BAUD);
            let port = crate::serial::open(path, baud, read_timeout)?;
            return Ok((Self::Serial(port), format!("{path} at {baud} Bd")));
        }
        let address = args.tcp.as_deref().unwrap_or_default();
        let addrs: Vec<_> = address
            .to_socket_addrs()
            .map_err(|e| format!("cannot connect to {address}: {e}"))?
            .collect();
        let mut last = format!("cannot connect to {address}: no address");
        for addr in addrs {
            match TcpStream::connect_timeout(&addr, CONNECT_TIMEOUT) {
                Ok(stream) => {
                    stream
                        .set_read_timeout(Some(read_timeout))
                        .and_then(|()| stream.set_nodelay(true))
                        .map_err(|e| format!("cannot set up the connection to {address}: {e}"))?;
                    return Ok((Self::Tcp(stream), format!("tcp {address}")));
                }
                Err(e) => last = format!("cannot connect to {address}: {e}"),
            }
        }
        Err(last)
    }

    pub(super) fn read(&mut self, buf: &mut [u8]) -> Received {
        let (result, is_tcp) = match self {
            Self::Serial(port) => (port.read(buf), false),
            Self::Tcp(stream) => (stream.read(buf), true),
            Self::Closed => return Received::Ended(None),
        };
        match result {
            Ok(0) if is_tcp => Received::Ended(None),
            Ok(0) => Received::Nothing,
            Ok(n) => Received::Bytes(n),
            Err(e) => match e.kind() {
                std::io::ErrorKind::WouldBlock
                | std::io::ErrorKind::TimedOut
                | std::io::ErrorKind::Interrupted => Received::Nothing,
                _ => Received::Ended(Some(e.to_string())),
            },
        }
    }

    pub(super) fn write_all(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        match self {
            Self::Serial(port) => port.write_all(bytes).and_then(|()| port.flush()),
            Self::Tcp(stream) => stream.write_all(bytes),
            Self::Closed => Err(std::io::ErrorKind::NotConnected.into()),
        }
    }
}
