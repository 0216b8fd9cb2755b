#!/usr/bin/env python3
"""An independent encoder of the link's Setup and SetRule frames (docs/protocol.md, version
5), from the document alone: struct for the little-endian body, zlib.crc32 for
CRC-32/ISO-HDLC, COBS by hand.

Usage: link_setup.py SEQ FIELD...           a Setup (51 fields in wire order, as numbers:
                                            the reserved bytes of the mount block left out)
       link_setup.py setrule SEQ FIELD...   a SetRule (the step, then the 6 rule fields)
Prints the encoded frame as hex bytes separated by spaces, delimiter included.
"""
import struct
import sys
import zlib

VERSION = 5
SETUP = 0x87

# Base part (offset 0), rule block (offset 38), laser block (offset 59), mount block
# (offset 81: axis, sense, 2 reserved bytes, zero, roll, pitch, yaw), filter block (offset
# 101: min range cm, max range cm, min quality, sector count, 8 x (start, end) centidegrees).
BASE = "<BBHH3fI4f"
RULE = "<B5f"
LASER = "<BBI4f"
MOUNT = "<Bb2x4f"
FILTER = "<HHBB16H"


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
    base, rule, laser = fields[:12], fields[12:18], fields[18:25]
    mount, filt = fields[25:31], fields[31:]
    assert len(filt) == 20, "12 base, 6 rule, 7 laser, 6 mount and 20 filter fields"
    ints = lambda fmt, vs: [
        int(v) if c in "BbHI" else float(v)
        for c, v in zip([c for c in expand(fmt) if c != "x"], vs)
    ]
    body = struct.pack(BASE, *ints(BASE, base))
    body += struct.pack(RULE, *ints(RULE, rule))
    body += struct.pack(LASER, *ints(LASER, laser))
    body += struct.pack(MOUNT, *ints(MOUNT, mount))
    body += struct.pack(FILTER, *ints(FILTER, filt))
    assert len(body) == 38 + 21 + 22 + 20 + 38, len(body)
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


SET_RULE = 0x8B


def set_rule_body(fields):
    assert len(fields) == 7, "the step, then 6 rule fields"
    body = struct.pack("<f", float(fields[0]))
    body += struct.pack(RULE, int(fields[1]), *[float(v) for v in fields[2:]])
    assert len(body) == 25, len(body)
    return body


def frame(seq, body, msg_type=SETUP):
    decoded = struct.pack("<BBH", VERSION, msg_type, seq) + body
    decoded += struct.pack("<I", zlib.crc32(decoded) & 0xFFFFFFFF)
    return cobs(decoded) + b"\x00"


if __name__ == "__main__":
    if sys.argv[1] == "setrule":
        out = frame(int(sys.argv[2]), set_rule_body(sys.argv[3:]), SET_RULE)
    else:
        out = frame(int(sys.argv[1]), setup_body(sys.argv[2:]))
    print(" ".join(f"{b:02x}" for b in out))
