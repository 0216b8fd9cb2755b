//! The Foxglove WebSocket protocol under both of its names.
//!
//! The protocol (foxglove/ws-protocol) was negotiated as `foxglove.websocket.v1` until the
//! Foxglove SDK renamed it `foxglove.sdk.v1`; the messages are the same. The SDK's server (the
//! `foxglove` crate) accepts only the new name, so Foxglove releases from before the rename,
//! Lichtblick and other `ws-protocol` clients would be refused at the handshake. This gate sits
//! in front of it: it listens on the user's address, and for each connection rewrites the
//! client's offer of `foxglove.websocket.v1` (when it does not also offer the new name) to
//! `foxglove.sdk.v1` on the way in and the server's choice back on the way out; after the
//! handshake it copies bytes both ways untouched. A client that offers the new name goes
//! through unchanged.
//!
//! A slow client stays the server's business: the gate's copy blocks on that client's socket
//! only, the server sees a connection that does not drain and drops messages for it as it
//! would without the gate.
use std::io::{self, Read, Write};
use std::net::{Shutdown, SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

/// The protocol's name before the rename.
pub const LEGACY: &str = "foxglove.websocket.v1";
/// The protocol's name the SDK's server accepts.
pub const CURRENT: &str = "foxglove.sdk.v1";
/// The longest handshake head accepted, bytes.
const MAX_HEAD: usize = 16 * 1024;
/// How often the accepting thread looks for a stop.
const ACCEPT_POLL: Duration = Duration::from_millis(20);

/// The listening gate; dropping it stops accepting (open connections end with their peers).
pub struct Gate {
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
    addr: SocketAddr,
}

impl Gate {
    /// Listens on `listener` and forwards every connection to `server`.
    ///
    /// # Errors
    /// The listener cannot be made non-blocking.
    pub fn start(listener: TcpListener, server: SocketAddr) -> io::Result<Self> {
        listener.set_nonblocking(true)?;
        let addr = listener.local_addr()?;
        let stop = Arc::new(AtomicBool::new(false));
        let flag = Arc::clone(&stop);
        let thread = std::thread::Builder::new()
            .name("foxglove-gate".into())
            .spawn(move || accept(&listener, server, &flag))?;
        Ok(Self {
            stop,
            thread: Some(thread),
            addr,
        })
    }

    /// The address the gate listens on.
    #[must_use]
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }
}

impl Drop for Gate {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn accept(listener: &TcpListener, server: SocketAddr, stop: &AtomicBool) {
    while !stop.load(Ordering::Relaxed) {
        match listener.accept() {
            Ok((client, _)) => {
                let _ = std::thread::Builder::new()
                    .name("foxglove-gate-conn".into())
                    .spawn(move || {
                        let _ = connection(client, server);
                    });
            }
            // Nothing waiting (the listener does not block), or a failed accept: look again.
            Err(_) => std::thread::sleep(ACCEPT_POLL),
        }
    }
}

/// Reads up to and including the blank line that ends an HTTP head; returns the head and any
/// bytes read past it.
fn read_head(stream: &mut TcpStream) -> io::Result<(Vec<u8>, Vec<u8>)> {
    let mut buf = Vec::with_capacity(1024);
    let mut chunk = [0_u8; 1024];
    loop {
        if let Some(end) = find(&buf, b"\r\n\r\n") {
            let rest = buf.split_off(end + 4);
            return Ok((buf, rest));
        }
        if buf.len() > MAX_HEAD {
            return Err(io::Error::new(
                io::ErrorKind::InvalidData,
                "handshake head too long",
            ));
        }
        let n = stream.read(&mut chunk)?;
        if n == 0 {
            return Err(io::ErrorKind::UnexpectedEof.into());
        }
        buf.extend_from_slice(chunk.get(..n).unwrap_or(&[]));
    }
}

fn find(haystack: &[u8], needle: &[u8]) -> Option<usize> {
    haystack.windows(needle.len()).position(|w| w == needle)
}

/// The head with `from` replaced by `to` in its `Sec-WebSocket-Protocol` lines, when `when`
/// says so of that header's value; whether anything was replaced.
fn rewrite_protocol(
    head: &[u8],
    when: impl Fn(&str) -> bool,
    from: &str,
    to: &str,
) -> (Vec<u8>, bool) {
    let text = String::from_utf8_lossy(head);
    let mut changed = false;
    let mut out = String::with_capacity(text.len());
    for line in text.split_inclusive("\r\n") {
        let header = line
            .split_once(':')
            .filter(|(name, _)| name.trim().eq_ignore_ascii_case("sec-websocket-protocol"));
        if let Some((name, value)) = header {
            let tokens: Vec<&str> = value.split(',').map(str::trim).collect();
            if when(value) && tokens.contains(&from) {
                let replaced: Vec<&str> = tokens
                    .iter()
                    .map(|t| if *t == from { to } else { t })
                    .collect();
                out.push_str(name);
                out.push_str(": ");
                out.push_str(&replaced.join(", "));
                out.push_str("\r\n");
                changed = true;
                continue;
            }
        }
        out.push_str(line);
    }
    (out.into_bytes(), changed)
}

/// The client's request with the legacy name made current (when it offers only the legacy
/// one); whether it was.
#[must_use]
pub fn rewrite_request(head: &[u8]) -> (Vec<u8>, bool) {
    rewrite_protocol(
        head,
        |value| !value.split(',').any(|t| t.trim().starts_with(CURRENT)),
        LEGACY,
        CURRENT,
    )
}

/// The server's answer with the current name given back as the legacy one.
#[must_use]
pub fn rewrite_response(head: &[u8]) -> Vec<u8> {
    rewrite_protocol(head, |_| true, CURRENT, LEGACY).0
}

fn connection(mut client: TcpStream, server: SocketAddr) -> io::Result<()> {
    client.set_nodelay(true)?;
    let (request, early) = read_head(&mut client)?;
    let (request, renamed) = rewrite_request(&request);
    let mut upstream = TcpStream::connect(server)?;
    upstream.set_nodelay(true)?;
    upstream.write_all(&request)?;
    upstream.write_all(&early)?;
    let (response, rest) = read_head(&mut upstream)?;
    let response = if renamed {
        rewrite_response(&response)
    } else {
        response
    };
    client.write_all(&response)?;
    client.write_all(&rest)?;
    // The protocol itself: bytes both ways, each direction ending the other's write half.
    let (mut c_in, mut u_out) = (client.try_clone()?, upstream.try_clone()?);
    let inbound = std::thread::Builder::new()
        .name("foxglove-gate-in".into())
        .spawn(move || {
            let _ = io::copy(&mut c_in, &mut u_out);
            let _ = u_out.shutdown(Shutdown::Write);
        })?;
    let _ = io::copy(&mut upstream, &mut client);
    let _ = client.shutdown(Shutdown::Both);
    let _ = upstream.shutdown(Shutdown::Both);
    let _ = inbound.join();
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const REQUEST: &str = "GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\n\
        Sec-WebSocket-Protocol: foxglove.websocket.v1\r\n\r\n";

    #[test]
    fn a_legacy_offer_is_renamed_and_the_answer_renamed_back() {
        let (out, renamed) = rewrite_request(REQUEST.as_bytes());
        assert!(renamed);
        let out = String::from_utf8(out).unwrap();
        assert!(
            out.contains("Sec-WebSocket-Protocol: foxglove.sdk.v1\r\n"),
            "{out}"
        );
        assert!(out.ends_with("\r\n\r\n") && out.starts_with("GET / HTTP/1.1\r\n"));
        let answer =
            "HTTP/1.1 101 Switching Protocols\r\nsec-websocket-protocol: foxglove.sdk.v1\r\n\r\n";
        let back = String::from_utf8(rewrite_response(answer.as_bytes())).unwrap();
        assert!(
            back.contains("sec-websocket-protocol: foxglove.websocket.v1\r\n"),
            "{back}"
        );
    }

    #[test]
    fn an_offer_of_the_current_name_passes_untouched() {
        let both = REQUEST.replace(
            "foxglove.websocket.v1",
            "foxglove.sdk.v1.1, foxglove.websocket.v1",
        );
        let (out, renamed) = rewrite_request(both.as_bytes());
        assert!(!renamed);
        assert_eq!(out, both.as_bytes());
        let other = REQUEST.replace("foxglove.websocket.v1", "something.else");
        assert!(!rewrite_request(other.as_bytes()).1);
    }
}
