//! Accepting the binary's connection to a stand-in device on 127.0.0.1.
use std::io::ErrorKind;
use std::net::{TcpListener, TcpStream};
use std::time::{Duration, Instant};

/// The next connection to `listener` (which this makes non-blocking), its stream non-blocking
/// as `nonblocking` says; fails the test when none comes within `patience` (the host exited
/// early or never connected).
pub fn accept(listener: &TcpListener, patience: Duration, nonblocking: bool) -> TcpStream {
    listener.set_nonblocking(true).unwrap();
    let start = Instant::now();
    loop {
        match listener.accept() {
            Ok((stream, _)) => {
                stream.set_nonblocking(nonblocking).unwrap();
                return stream;
            }
            Err(e) if e.kind() == ErrorKind::WouldBlock => {
                assert!(start.elapsed() < patience, "the host never connected");
                std::thread::sleep(Duration::from_millis(5));
            }
            Err(e) => panic!("accept: {e}"),
        }
    }
}
