#!/usr/bin/env python3
"""An independent encoder of the link's Setup and SetRule frames (docs/protocol.md, version
6), from the document alone: the blocks, the header, the CRC (zlib.crc32, CRC-32/ISO-HDLC)
and COBS of docs/link_golden.py, the fields from the command line.

Usage: link_setup.py SEQ FIELD...           a Setup (52 fields in wire order, as numbers:
                                            the reserved bytes of the mount block left out)
       link_setup.py setrule SEQ FIELD...   a SetRule (the step, then the 7 rule fields)
Prints the encoded frame as hex bytes separated by spaces, delimiter included.
"""
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "..", "docs"))
from link_golden import (  # noqa: E402  the spec's encoder
    BASE, FILTER, LASER, MOUNT, RULE, frame, hexs, set_rule_body, setup_body,
)

SETUP = 0x87
SET_RULE = 0x8B


def expand(fmt):
    """The struct codes of a format, one a field (`3f` → `f f f`), padding left out."""
    out, n = [], ""
    for c in fmt[1:]:
        if c.isdigit():
            n += c
        else:
            out += [c] * int(n or "1")
            n = ""
    return [c for c in out if c != "x"]


def numbers(fmt, texts):
    """The fields of a block as numbers: integers for the integer codes, else floats."""
    return [int(v) if c in "BbHI" else float(v) for c, v in zip(expand(fmt), texts)]


def setup_of(fields):
    base, rule, laser = fields[:12], fields[12:19], fields[19:26]
    mount, filt = fields[26:32], fields[32:]
    assert len(filt) == 20, "12 base, 7 rule, 7 laser, 6 mount and 20 filter fields"
    return setup_body(numbers(BASE, base), numbers(RULE, rule), numbers(LASER, laser),
                      numbers(MOUNT, mount), numbers(FILTER, filt))


def set_rule_of(fields):
    assert len(fields) == 8, "the step, then 7 rule fields"
    return set_rule_body(float(fields[0]), numbers(RULE, fields[1:]))


if __name__ == "__main__":
    if sys.argv[1] == "setrule":
        out = frame(SET_RULE, int(sys.argv[2]), set_rule_of(sys.argv[3:]))
    else:
        out = frame(SETUP, int(sys.argv[1]), setup_of(sys.argv[2:]))
    print(hexs(out))
