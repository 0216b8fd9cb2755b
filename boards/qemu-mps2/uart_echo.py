#!/usr/bin/env python3
"""Feeds bytes into the firmware's UART0 and checks that they come back out of UART1.

QEMU listens on one socket per UART (`-serial unix:PATH,server=on,wait=on`, or
`tcp:127.0.0.1:PORT,...`); it waits for UART0's client, then UART1's, before it starts the
guest. This helper connects in that order, sends the payload to UART0 from a thread (so that a
full UART1 can never block the sender), reads UART1 until it has the expected bytes, the
firmware closes the socket, or the timeout passes, and exits 0 only on an exact echo.

The default payload is every byte value but 0x04, then 2000 pseudo-random bytes (no 0x04),
then 0x04 (which ends the echo: it and what follows must not come back), then a tail.
"""
import argparse
import os
import random
import socket
import sys
import threading
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from qemu_socket import connect  # noqa: E402

EOT = 0x04


def default_payload() -> bytes:
    rng = random.Random(20240611)
    body = bytes(b for b in range(256) if b != EOT)
    body += bytes(rng.choice([b for b in range(256) if b != EOT]) for _ in range(2000))
    return body + bytes([EOT]) + b"not echoed"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--uart0", required=True, help="UART0 socket: a path or HOST:PORT")
    ap.add_argument("--uart1", required=True, help="UART1 socket: a path or HOST:PORT")
    ap.add_argument("--payload", help="file of bytes to send (default: built in); must hold 0x04")
    ap.add_argument("--out", help="save what UART1 sent to this file")
    ap.add_argument("--timeout", type=float, default=60.0, help="seconds (default 60)")
    args = ap.parse_args()

    payload = open(args.payload, "rb").read() if args.payload else default_payload()
    if EOT not in payload:
        print("uart_echo: the payload has no 0x04: the firmware would echo forever", file=sys.stderr)
        return 2
    expected = payload[: payload.index(EOT)]

    deadline = time.monotonic() + args.timeout
    uart0 = connect(args.uart0, deadline)
    uart1 = connect(args.uart1, deadline)

    def send() -> None:
        try:
            uart0.sendall(payload)
        except OSError:
            pass  # the firmware may exit (and QEMU close the socket) before the tail is taken

    sender = threading.Thread(target=send, daemon=True)
    sender.start()

    received = bytearray()
    uart1.settimeout(0.2)
    while time.monotonic() < deadline:
        try:
            chunk = uart1.recv(4096)
        except socket.timeout:
            continue
        if not chunk:
            break  # QEMU exited
        received += chunk
        if len(received) > len(expected):
            break
    # Anything more that is already on its way (there should be nothing).
    uart1.settimeout(0.5)
    try:
        while chunk := uart1.recv(4096):
            received += chunk
    except OSError:
        pass
    uart0.close()
    uart1.close()

    if args.out:
        with open(args.out, "wb") as f:
            f.write(received)
    if bytes(received) == expected:
        print(f"uart_echo: {len(payload)} bytes sent to UART0, "
              f"{len(received)} bytes (all before 0x04) came back from UART1: match")
        return 0
    first = next((i for i, (a, b) in enumerate(zip(received, expected)) if a != b),
                 min(len(received), len(expected)))
    print(f"uart_echo: MISMATCH: expected {len(expected)} bytes, got {len(received)}; "
          f"first difference at byte {first}", file=sys.stderr)
    return 1


if __name__ == "__main__":
    sys.exit(main())
