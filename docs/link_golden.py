#!/usr/bin/env python3
"""The golden frames of the host link's tests, computed from docs/protocol.md alone.

An encoder written from the specification, independent of the Rust code: the header and the
fixed little-endian bodies with `struct`, the CRC with Python's `zlib.crc32` (CRC-32/ISO-HDLC),
COBS as section 3 describes it (eager 254-byte blocks). `src/wire/link/tests.rs` holds its
output as hex literals; run it to see them again:

    python3 docs/link_golden.py
"""
import struct
import zlib

VERSION = 6

# The Setup body's blocks (section 7): the base part (38 bytes), the rule block (22 bytes:
# rule, max grade, residual, range sigma, angle sigma, noise factor, pair depth), the laser block (22
# bytes: sensor, actuator, baud, servo min, max, rate, latency), the mount block (20 bytes:
# axis, sense, 2 reserved, zero, roll, pitch, yaw) and the filter block (38 bytes: min range
# cm, max range cm, min quality, sector count, 8 sectors of start and end centidegrees).
BASE = "<BBHH3fI4f"
RULE = "<B5fB"
LASER = "<BBI4f"
MOUNT = "<Bb2x4f"
FILTER = "<HHBB16H"
SETUP_LEN = 38 + 22 + 22 + 20 + 38


def cobs(data: bytes) -> bytes:
    """COBS, section 3: runs of non-zero bytes, each with its code byte; a run of 254 bytes is
    written at once with code 0xFF, which implies no zero."""
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


def frame(msg_type: int, seq: int, body: bytes, version: int = VERSION) -> bytes:
    decoded = struct.pack("<BBH", version, msg_type, seq) + body
    decoded += struct.pack("<I", zlib.crc32(decoded) & 0xFFFFFFFF)
    return cobs(decoded) + b"\x00"


def setup_body(base, rule, laser, mount, filt) -> bytes:
    """A Setup's body from the fields of its five blocks, each in wire order (the mount's
    reserved bytes left out)."""
    body = struct.pack(BASE, *base)
    body += struct.pack(RULE, *rule)
    body += struct.pack(LASER, *laser)
    body += struct.pack(MOUNT, *mount)
    body += struct.pack(FILTER, *filt)
    assert len(body) == SETUP_LEN, len(body)
    return body


def set_rule_body(step, rule) -> bytes:
    """A SetRule's body: the step, then a rule block."""
    return struct.pack("<f", step) + struct.pack(RULE, *rule)


def hexs(b: bytes) -> str:
    return " ".join(f"{x:02x}" for x in b)


def configure_body(decay_mode=0, decay_tau=(0,) * 32) -> bytes:
    body = struct.pack("<7f", 0.5, 0.25, 0.15, 1.0, 10.0, 0.1, 2.0)
    body += struct.pack("<Bf", 1, 0.5)  # soft gate, width 0.5
    body += struct.pack("<H", 64)
    body += struct.pack("<3f", 0.7, 0.4, 0.5)
    body += struct.pack("<Bff", 1, -2.0, 3.5)  # clamp bounds
    body += struct.pack("<f", 0.0)  # fused margin
    body += struct.pack("<B", 0)  # flags
    body += struct.pack("<B", decay_mode)
    body += bytes(decay_tau)
    assert len(body) == 94
    return body


def hello_body() -> bytes:
    # protocol 1, firmware 0.1.2, reason boot, 2 layers, W 64, resend 0, clock 2 (the internal
    # oscillator through the PLL), 3 reserved bytes.
    body = struct.pack("<BBBBBBHIB3x", 1, 0, 1, 2, 0, 2, 64, 0, 2)
    body += struct.pack("<iffii", 6554, 0.0, 0.5, -32, -32)
    body += struct.pack("<iffii", 13107, 0.5, 1.5, -32, -32)
    return body


def main() -> None:
    g = {}
    g["ping 1"] = frame(0x86, 1, b"")
    g["reset 0x0203"] = frame(0x84, 0x0203, b"")
    g["snapshot all 7"] = frame(0x85, 7, b"\xff")
    g["snapshot layer 2, 8"] = frame(0x85, 8, b"\x02")
    g["pan 9"] = frame(0x82, 9, struct.pack("<HI", 0x4000, 123_456))
    # Pose: the six fields, stamp_us, flags (bit 0 STAMPED).
    g["pose 10 (unstamped)"] = frame(
        0x81, 10, struct.pack("<6fIB", 1.5, -2.25, 0, 0, 0, 3.140625, 1000, 0)
    )
    g["pose 11 (stamped at 4 000 000 us)"] = frame(
        0x81, 11, struct.pack("<6fIB", 1.5, -2.25, 0.125, 0, 0.25, -1.5, 4_000_000, 1)
    )
    # TimeRequest (host_us u64), TimeReply (host_us u64, device_us u32, queued_ahead u16),
    # Observed (observation, first_us, last_us: u32).
    g["time request 12 (host 1 234 567 890 123 us)"] = frame(
        0x8C, 12, struct.pack("<Q", 1_234_567_890_123)
    )
    g["time reply 0x0108 (host 1 234 567 890 123, device 4 000 123 us, 300 ahead)"] = frame(
        0x07, 0x0108, struct.pack("<QIH", 1_234_567_890_123, 4_000_123, 300)
    )
    g["observed 0x0109 (observation 42, 3 990 000 ..= 4 090 000 us)"] = frame(
        0x08, 0x0109, struct.pack("<III", 42, 3_990_000, 4_090_000)
    )
    g["configure 11 (decay off)"] = frame(0x83, 11, configure_body())
    tau = [54, 54, 70, 70, 86, 86, 0, 0] + [0] * 24
    g["configure 12 (decay obstacle, tau 9.9 s / 19.9 s / 39.7 s)"] = frame(
        0x83, 12, configure_body(2, tau)
    )
    g["hello 0"] = frame(0x01, 0, hello_body())
    cells = struct.pack("<4h", -32768, 217, -512, 0)
    patch = struct.pack("<BBBiiii", 1, 2, 2, -32, -32, 3, -4) + cells
    g["patch 0x0102"] = frame(0x02, 0x0102, patch)
    moved = struct.pack("<I", 0b101) + struct.pack("<ii", -31, -32) + struct.pack("<ii", -16, -33)
    g["moved 0x0103"] = frame(0x03, 0x0103, moved)
    g["stats 0x0104"] = frame(0x04, 0x0104, struct.pack("<42I", *range(1, 43)))
    g["reply ok to configure 11, 0x0105"] = frame(
        0x05, 0x0105, struct.pack("<HBBBfff", 11, 0x83, 0, 0, 0, 0, 0)
    )
    # The refusal of a gamma of 200 (param 7, OutOfRange 3, limits 0 and 100).
    g["reply refusing gamma, 0x0106"] = frame(
        0x05, 0x0106, struct.pack("<HBBBfff", 12, 0x83, 3, 7, 200.0, 0.0, 100.0)
    )
    # A refusal of layer 3's decay time constant (param 96 + 3 = 99, OutOfRange 3): tau
    # 1 s with a window that needs at least 4 s (W = 128), up to 60 097 s.
    g["reply refusing decay tau of layer 3, 0x0106"] = frame(
        0x05, 0x0106, struct.pack("<HBBBfff", 12, 0x83, 3, 99, 1.0, 4.0, 60097.0)
    )
    decayed = struct.pack("<BI", 1, 0b1001)
    decayed += struct.pack("<HHI", 62, 3, 5)  # layer 0: rows 62, 63, 0; 5 cells faded
    decayed += struct.pack("<HHI", 10, 1, 0)  # layer 3: row 10; none faded
    g["decayed 0x0107"] = frame(0x06, 0x0107, decayed)
    # Setup: the five blocks, as BASE ... FILTER above describe them.
    preset_mount = (0, 1, 0.0, 0.0, 0.0, 0.0)
    no_filter = (0, 0, 0, 0, *([0] * 16))
    spread = (0, 0.0, 0.0, 0.0, 0.0, 0.0, 0)
    # The plane rule's Q16.16 defaults, exact in f32, each return paired with the last.
    plane = (1, 23853 / 65536, 983 / 65536, 1311 / 65536, 86 / 65536, 2.0, 1)
    # The same for a spinning multi-beam laser in firing order: paired with the last three.
    plane_firing = plane[:6] + (3,)
    nodding = (1, 1, 0, -10.0, 30.0, 60.0, 25.0)
    setup = setup_body(
        (1, 0, 180, 50, 0.25, -0.5, 0.75, 0, 1.0, 0.05, 0.0, 2.0),
        spread,
        (0, 0, 0, 0.0, 0.0, 0.0, 0.0),
        preset_mount,
        no_filter,
    )
    g["setup 7 (a SICK, external actuator)"] = frame(0x87, 7, setup)
    lidar_base = (1, 0, 0, 0, 0.1, 0.0, 0.4, 2, 0.5, 0.08, 0.0, 0.0)
    lidar = setup_body(lidar_base, plane, nodding, preset_mount, no_filter)
    g["setup 8 (an LD06 on a nodding servo)"] = frame(0x87, 8, lidar)
    # The general mount (2): an LD19 upside down with its 0 deg to the left (roll 180, yaw 90)
    # on a tilt servo (axis 1) reversed (sense -1) with its zero at 5 deg; masked 135 ..< 225
    # deg and 350 ..< 10 deg, ranges 0.05 ..= 12 m, quality at least 10.
    sectors = [13500, 22500, 35000, 1000] + [0] * 12
    general = setup_body(
        (2, *lidar_base[1:]),
        spread,
        nodding,
        (1, -1, 5.0, 180.0, 0.0, 90.0),
        (5, 1200, 10, 2, *sectors),
    )
    g["setup 13 (an LD19 upside down on a reversed servo, masked)"] = frame(0x87, 13, general)
    g["request stats 2"] = frame(0x88, 2, b"")
    g["shutdown 2"] = frame(0x89, 2, b"")
    g["end observation 2"] = frame(0x8A, 2, b"")
    # SetRule: the step, then a rule block.
    g["set rule 9 (spread, step 0.08)"] = frame(0x8B, 9, set_rule_body(0.08, spread))
    g["set rule 10 (plane defaults, step 3277 / 65536)"] = frame(
        0x8B, 10, set_rule_body(3277 / 65536, plane)
    )
    g["set rule 14 (plane defaults, pair depth 3, step 3277 / 65536)"] = frame(
        0x8B, 14, set_rule_body(3277 / 65536, plane_firing)
    )
    # The refusal of a pair depth of 4 (param 81, OutOfRange 3, limits 1 and 3).
    g["reply refusing pair depth, 0x010b"] = frame(
        0x05, 0x010B, struct.pack("<HBBBfff", 15, 0x8B, 3, 81, 4.0, 1.0, 3.0)
    )
    # The refusal of a pose flag byte 2 (param 38, OutOfRange 3, limits 0 and 1).
    g["reply refusing pose flags, 0x010a"] = frame(
        0x05, 0x010A, struct.pack("<HBBBfff", 13, 0x81, 3, 38, 2.0, 0.0, 1.0)
    )
    g["ping 1, version 2"] = frame(0x86, 1, b"", version=2)
    g["ping 1, version 3"] = frame(0x86, 1, b"", version=3)
    g["ping 1, version 4"] = frame(0x86, 1, b"", version=4)
    g["ping 1, version 5"] = frame(0x86, 1, b"", version=5)
    for name, b in g.items():
        print(f"{name}:\n  {hexs(b)}")
    # The CRC's check value (section 2).
    assert zlib.crc32(b"123456789") == 0xCBF43926
    # COBS: a frame that ends on a 254-byte block ends with the empty run 0x01.
    assert cobs(b"\x01" * 254) == b"\xff" + b"\x01" * 254 + b"\x01"


if __name__ == "__main__":
    main()
