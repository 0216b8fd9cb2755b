#!/usr/bin/env python3
"""Drives the micro:bit firmware in QEMU's `microbit` through its one UART.

QEMU listens on a Unix socket for the UART (`-serial unix:PATH,server=on,wait=on`) and starts
the guest once it is connected. This script then

1. sends an echo payload (every byte value but 0x04, then pseudo-random bytes) and checks that
   it comes back byte for byte; sends EOT (0x04), which ends the echo;
2. sends `--lines` SICK LMS2xx measured-values telegrams (361 values, 180°/0.5°, millimetres,
   8 m mode) of a scene seen by a scanner 1 m up whose vertical scan plane is panned by
   364/65 536 turn per line (line i at (i - lines/2) steps, as the firmware assumes): a flat
   floor, and a 0.3 m curb 1.5 m away within ±10° of straight ahead;
3. reads the firmware's summary line (`PIPELINE lines=... digest=0x...`) and checks that every
   line was counted and no classifier slot overflowed.

Exits 0 on success. The telegrams are built from docs/sick-lms2xx.md alone (the CRC is checked
against the maker's own example telegrams below).
"""
import argparse
import math
import os
import random
import re
import socket
import struct
import sys
import threading
import time

EOT = 0x04
NO_ECHO = 0x1FFF  # the 8 m mode's all-ones 13-bit distance: no return
HEIGHT_M = 1.0
CURB_M, CURB_HEIGHT_M, CURB_HALF_WIDTH_DEG = 1.5, 0.3, 10.0
MAX_RANGE_M = 2.9


def sick_crc(data: bytes) -> int:
    crc, prev = 0, 0
    for b in data:
        crc = ((crc << 1) & 0xFFFF) ^ (0x8005 if crc & 0x8000 else 0)
        crc ^= b | (prev << 8)
        prev = b
    return crc


# The LMS2xx manual's own telegrams: "switch to 500 kBd" and "continuous output" end in these CRCs.
assert sick_crc(bytes([0x02, 0x00, 0x02, 0x00, 0x20, 0x48])) == 0x0858
assert sick_crc(bytes([0x02, 0x00, 0x02, 0x00, 0x20, 0x24])) == 0x0834


def sick_telegram(payload: bytes) -> bytes:
    head = bytes([0x02, 0x80]) + struct.pack("<H", len(payload)) + payload
    return head + struct.pack("<H", sick_crc(head))


def scene_line(pan_deg: float) -> bytes:
    """361 ranges (mm) of beam θ = 0°, 0.5°, ..., 180° (0° straight down, 90° ahead)."""
    values = []
    for j in range(361):
        theta = math.radians(j * 0.5)
        r = math.inf
        if math.cos(theta) > 1e-9:
            r = HEIGHT_M / math.cos(theta)  # the floor
        if abs(pan_deg) <= CURB_HALF_WIDTH_DEG and math.sin(theta) > 1e-9:
            rc = CURB_M / math.sin(theta)
            z = HEIGHT_M - rc * math.cos(theta)
            if 0.0 <= z <= CURB_HEIGHT_M and rc < r:
                r = rc
        values.append(round(r * 1000) if r <= MAX_RANGE_M else NO_ECHO)
    payload = bytes([0xB0]) + struct.pack("<H", 361 | (1 << 14)) + struct.pack("<361H", *values) + b"\x10"
    return sick_telegram(payload)


def echo_payload() -> bytes:
    rng = random.Random(20240611)
    body = bytes(b for b in range(256) if b != EOT)
    return body + bytes(rng.choice([b for b in range(256) if b != EOT]) for _ in range(2000))


def connect(path: str, deadline: float) -> socket.socket:
    while True:
        try:
            s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            s.connect(path)
            return s
        except OSError:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.05)


def read_until(sock: socket.socket, buf: bytearray, done, deadline: float) -> bool:
    while not done(buf):
        left = deadline - time.monotonic()
        if left <= 0:
            return False
        sock.settimeout(min(left, 0.5))
        try:
            chunk = sock.recv(65536)
        except socket.timeout:
            continue
        if not chunk:
            return done(buf)
        buf += chunk
    return True


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--uart", required=True, help="the UART's socket")
    ap.add_argument("--lines", type=int, default=30, help="telegrams (the firmware's LINES)")
    ap.add_argument("--timeout", type=float, default=60.0)
    args = ap.parse_args()

    deadline = time.monotonic() + args.timeout
    sock = connect(args.uart, deadline)

    payload = echo_payload()
    sender = threading.Thread(target=sock.sendall, args=(payload,), daemon=True)
    t0 = time.monotonic()
    sender.start()
    got = bytearray()
    read_until(sock, got, lambda b: len(b) >= len(payload), deadline)
    elapsed = time.monotonic() - t0
    if bytes(got[: len(payload)]) != payload:
        diff = next((i for i, (a, b) in enumerate(zip(got, payload)) if a != b), min(len(got), len(payload)))
        print(f"FAIL: echo differs at byte {diff} ({len(got)} of {len(payload)} bytes back)")
        return 1
    print(f"echo: {len(payload)} bytes back unchanged in {elapsed:.2f} s")
    sender.join()

    sock.sendall(bytes([EOT]))
    step = 364 / 65536 * 360.0
    telegrams = [scene_line((i - args.lines // 2) * step) for i in range(args.lines)]
    threading.Thread(target=sock.sendall, args=(b"".join(telegrams),), daemon=True).start()
    rest = bytearray(got[len(payload):])
    t0 = time.monotonic()
    if not read_until(sock, rest, lambda b: b"\n" in b, deadline + args.timeout):
        print(f"FAIL: no summary line (got {bytes(rest)!r})")
        return 1
    line = bytes(rest).split(b"\n")[0].decode("ascii", "replace")
    print(f"after {time.monotonic() - t0:.2f} s ({args.lines} telegrams, "
          f"{sum(map(len, telegrams))} bytes): {line}")
    fields = dict(re.findall(r"(\w+)=(\S+)", line))
    ok = (line.startswith("PIPELINE") and fields.get("lines") == str(args.lines)
          and fields.get("overflows") == "0" and int(fields.get("applied", "0")) > 0)
    print("UART check: " + ("passed" if ok else "FAILED"))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
