#!/usr/bin/env python3
"""An independent encoder of the link's Setup frame (docs/protocol.md, version 3), from the
document alone: struct for the little-endian body, zlib.crc32 for CRC-32/ISO-HDLC, COBS by
hand.

Usage: link_setup.py SEQ FIELD...   (the fields in wire order, as numbers; see SETUP below)
Prints the encoded frame as hex bytes separated by spaces, delimiter included.
"""
import struct
import sys
import zlib

VERSION = 3
SETUP = 0x87

# Base part (offset 0), rule block (offset 38), laser block (offset 59).
BASE = "<BBHH3fI4f"
RULE = "<B5f"
LASER = "<BBI4f"


def cobs(data: bytes) -> bytes:
    out = bytearray()
    run = bytearray()
    for b in data:
        if b == 0:
            out.append(len(run) + 1)
            out += run
            run = bytearray()
        else:
            run.append(b)
            if len(run) == 254:
                out.append(0xFF)
                out += run
                run = bytearray()
    out.append(len(run) + 1)
    out += run
    return bytes(out)


def setup_body(fields):
    base, rule, laser = fields[:12], fields[12:18], fields[18:]
    assert len(laser) == 7, "12 base fields, 6 rule fields, 7 laser fields"
    ints = lambda fmt, vs: [int(v) if c in "BHI" else float(v) for c, v in zip(expand(fmt), vs)]
    body = struct.pack(BASE, *ints(BASE, base))
    body += struct.pack(RULE, *ints(RULE, rule))
    body += struct.pack(LASER, *ints(LASER, laser))
    assert len(body) == 38 + 21 + 22, len(body)
    return body


def expand(fmt):
    out, n = [], ""
    for c in fmt[1:]:
        if c.isdigit():
            n += c
        else:
            out += [c] * int(n or "1")
            n = ""
    return out


def frame(seq, body):
    decoded = struct.pack("<BBH", VERSION, SETUP, seq) + body
    decoded += struct.pack("<I", zlib.crc32(decoded) & 0xFFFFFFFF)
    return cobs(decoded) + b"\x00"


if __name__ == "__main__":
    seq = int(sys.argv[1])
    print(" ".join(f"{b:02x}" for b in frame(seq, setup_body(sys.argv[2:]))))
