#!/usr/bin/env python3
"""Writes the lidar byte streams of `lidar/tests/data/` from real scans (issue 25).

An encoder independent of the Rust parsers (`lidar/src/`): it shares no code
with them and follows the manufacturers' documents directly (LDRobot LD06
development manual, Slamtec LR001 protocol document, YDLIDAR X4 development
manual, the XV-11 community protocol page; see `docs/lidar/`). The tests
decode the streams and check every range and angle against what is written
here.

Source scans: the 20 `FLASER` scans of `cli/data/logs/seattle-excerpt.log`
(real Seattle scans, 361 beams over 180 degrees, 0.5 degree apart, robot
front at the middle beam). Each becomes one turn of a 360-degree lidar with
720 points 0.5 degree apart: point k lies at 0.5*k degrees clockwise from the
sensor's front (the lidars' own direction), i.e. at -0.5*k degrees
counter-clockwise, which is Seattle beam j = 180 - k (mod 720) when 0 <= j <=
360; the points behind the robot have no return (distance 0). Ranges of
81.9 m and more (the log's "no return") and ranges beyond what the protocol
can carry become 0.

Each stream is: a lead-in (the second half of a turn with no return: the
capture starts mid-turn), the scans' turns, and one packet of a further
turn that closes the last one (three nodes for RPLIDAR). RPLIDAR's starts
with the SCAN response descriptor `A5 5A 05 00 00 40 81`.

The XV-11 turns have 360 readings, one a degree, counter-clockwise (as the
ROS xv_11_laser_driver publishes them): reading k is Seattle beam
180 + 2k (mod 720); no return is the invalid flag.

Files, per protocol P in ld06, rplidar, ydlidar, xv11:

- `P.bin`: the bytes, as they would come off the UART;
- `P.json`: {"protocol", "points_per_turn": 720, "lead_in_points",
  "unit_mm": the distance unit on the wire, "turns": [[distance in wire units
  of point k, k = 0..719], ...], and for ydlidar "corrections_deg": {sample:
  the X4 manual's angle correction atan(21.8*(155.3-d)/(155.3*d)) in degrees,
  d = sample/4 mm}}.

Run from the repository root: python3 tools/lidar_streams.py
"""

import json
import math
import struct
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
LOG = ROOT / "cli/data/logs/seattle-excerpt.log"
OUT = ROOT / "lidar/tests/data"
POINTS = 720  # per turn, 0.5 degree apart
NO_RETURN_M = 81.9


def seattle_scans():
    scans = []
    for line in LOG.read_text().splitlines():
        fields = line.split()
        if fields and fields[0] == "FLASER":
            n = int(fields[1])
            scans.append([float(v) for v in fields[2 : 2 + n]])
    return scans


def turn_ranges_m(scan):
    """Range in metres (0.0 = no return) of point k, k = 0..719."""
    out = []
    for k in range(POINTS):
        j = (180 - k) % POINTS
        r = scan[j] if 0 <= j < len(scan) else 0.0
        out.append(0.0 if r >= NO_RETURN_M or r <= 0.0 else r)
    return out


def to_wire(ranges_m, per_mm, limit):
    """Distances in wire units (per_mm units a millimetre), 0 beyond limit."""
    out = []
    for r in ranges_m:
        v = int(round(r * 1000.0 * per_mm))
        out.append(v if 0 < v <= limit else 0)
    return out


# --- LDRobot LD06: 47-byte packets, CRC-8 polynomial 0x4D -------------------


def crc8_4d(data):
    crc = 0
    for byte in data:
        crc ^= byte
        for _ in range(8):
            crc = ((crc << 1) ^ 0x4D) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
    return crc


def ld06_packet(first_k, distances, stamp):
    start = (first_k * 50) % 36000  # 0.01 degree
    end = (start + 11 * 50) % 36000
    body = struct.pack("<BBHH", 0x54, 0x2C, 3600, start)
    for d in distances:
        body += struct.pack("<HB", d, 200 if d else 0)
    body += struct.pack("<HH", end, stamp % 30000)
    return body + bytes([crc8_4d(body)])


def ld06_stream(turns):
    out = bytearray()
    stamp = 0
    lead = [0] * POINTS
    for first in range(POINTS // 2, POINTS, 12):
        out += ld06_packet(first, lead[first : first + 12], stamp)
        stamp += 2
    for turn in turns + [[0] * 12]:
        for first in range(0, len(turn), 12):
            out += ld06_packet(first, turn[first : first + 12], stamp)
            stamp += 2
    return bytes(out)


# --- Slamtec RPLIDAR: descriptor, then 5-byte standard scan nodes ----------


def rplidar_node(k, distance_q2):
    start = 1 if k == 0 else 0
    quality = 47 if distance_q2 else 0
    b0 = (quality << 2) | ((1 - start) << 1) | start
    angle_q6 = k * 32  # 0.5 degree = 32/64
    return struct.pack("<BHH", b0, (angle_q6 << 1) | 1, distance_q2)


def rplidar_stream(turns):
    out = bytearray([0xA5, 0x5A, 0x05, 0x00, 0x00, 0x40, 0x81])
    for k in range(POINTS // 2, POINTS):
        out += rplidar_node(k, 0)
    # Three nodes of a further turn: the first closes the last turn, the
    # next two let the receiver check it (nodes carry no checksum).
    for turn in turns + [[0, 0, 0]]:
        for k, d in enumerate(turn):
            out += rplidar_node(k, d)
    return bytes(out)


# --- YDLIDAR X2/X4: AA 55 packets, 16-bit XOR check code -------------------


def ydlidar_packet(first_k, samples, start_of_turn):
    ct = 1 if start_of_turn else 0
    fsa = ((first_k * 32) << 1) | 1
    lsa = (((first_k + len(samples) - 1) * 32) << 1) | 1
    words = [0x55AA, ct | (len(samples) << 8), fsa, lsa] + list(samples)
    cs = 0
    for w in words:
        cs ^= w
    return struct.pack("<HBBHHH", 0x55AA, ct, len(samples), fsa, lsa, cs) + struct.pack(
        f"<{len(samples)}H", *samples
    )


def ydlidar_turn(turn):
    out = bytearray(ydlidar_packet(0, turn[:1], True))
    for first in range(1, len(turn), 40):
        out += ydlidar_packet(first, turn[first : first + 40], False)
    return out


def ydlidar_stream(turns):
    out = bytearray()
    for first in range(POINTS // 2, POINTS, 40):
        out += ydlidar_packet(first, [0] * min(40, POINTS - first), False)
    for turn in turns:
        out += ydlidar_turn(turn)
    out += ydlidar_packet(0, [0], True)
    return bytes(out)


# --- Neato XV-11: 22-byte packets, 15-bit checksum --------------------------


def xv11_checksum(first20):
    c = 0
    for w in struct.unpack("<10H", first20):
        c = ((c << 1) + w) & 0xFFFFFFFF
    return ((c & 0x7FFF) + (c >> 15)) & 0x7FFF


def xv11_packet(index, distances):
    body = struct.pack("<BBH", 0xFA, 0xA0 + index, 300 * 64)
    for d in distances:
        # No return: the invalid flag (bit 15), as the sensor sends it.
        body += struct.pack("<HH", d if d else 0x8000, 500 if d else 0)
    return body + struct.pack("<H", xv11_checksum(body))


def xv11_stream(turns):
    out = bytearray()
    for index in range(45, 90):
        out += xv11_packet(index, [0] * 4)
    for turn in turns + [[0] * 4]:
        for index in range(len(turn) // 4):
            out += xv11_packet(index, turn[4 * index : 4 * index + 4])
    return bytes(out)


def xv11_turn_m(scan):
    """XV-11: 360 readings a turn, reading k at k degrees counter-clockwise
    (as the ROS driver publishes them): Seattle beam j = 180 + 2k (mod 720)."""
    out = []
    for k in range(360):
        j = (180 + 2 * k) % 720
        r = scan[j] if 0 <= j < len(scan) else 0.0
        out.append(0.0 if r >= NO_RETURN_M or r <= 0.0 else r)
    return out


def x4_correction_deg(sample):
    d = sample / 4.0
    return math.degrees(math.atan(21.8 * (155.3 - d) / (155.3 * d)))


def main():
    scans = seattle_scans()
    assert len(scans) == 20, len(scans)
    metres = [turn_ranges_m(s) for s in scans]
    specs = {
        # protocol: (distance units per mm, largest value, turns, encoder)
        "ld06": (1, 65535, len(scans), ld06_stream),
        "rplidar": (4, 65535, 6, rplidar_stream),
        "ydlidar": (4, 65535, 6, ydlidar_stream),
        # 14-bit millimetres.
        "xv11": (1, 0x3FFF, 6, xv11_stream),
    }
    OUT.mkdir(parents=True, exist_ok=True)
    for name, (per_mm, limit, count, encode) in specs.items():
        source = [xv11_turn_m(s) for s in scans] if name == "xv11" else metres
        turns = [to_wire(m, per_mm, limit) for m in source[:count]]
        data = encode(turns)
        (OUT / f"{name}.bin").write_bytes(data)
        meta = {
            "protocol": name,
            "source": "cli/data/logs/seattle-excerpt.log (FLASER scans 0..%d)" % (count - 1),
            "points_per_turn": 360 if name == "xv11" else POINTS,
            "lead_in_points": 180 if name == "xv11" else POINTS // 2,
            "unit_mm": 1.0 / per_mm,
            "turns": turns,
        }
        if name == "ydlidar":
            samples = sorted({s for t in turns for s in t if s})
            meta["corrections_deg"] = {str(s): x4_correction_deg(s) for s in samples}
        (OUT / f"{name}.json").write_text(json.dumps(meta, separators=(",", ":")) + "\n")
        print(f"{name}: {len(data)} bytes, {count} turns")


if __name__ == "__main__":
    main()
