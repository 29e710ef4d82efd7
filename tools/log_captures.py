#!/usr/bin/env python3
"""Writes a CARMEN log's `FLASER` scans as a raw lidar capture (issue 39).

The whole-log counterpart of `lidar_streams.py`: the same independent
encoders (the manufacturers' documents, no code shared with the Rust
parsers), any log, any number of points a turn. Each scan becomes one
revolution of a 360-degree lidar turning **clockwise** (as LD06 and RPLIDAR
do) with `--points` points `360/points` degrees apart, point k at
`k*360/points` degrees clockwise from the sensor's front. Point k takes the
log's beam nearest that direction when one lies within half a point's
spacing, otherwise it has no return (distance 0, as the sensors send it);
ranges at or beyond the log's no-return value (81.9 m) become 0 too. So a
180-degree log gives half a turn of returns and half a turn of zeros.

A capture starts mid-turn (half a turn of zeros) and ends with a few points
of a further turn that close the last one; the reader skips the partial
first turn, so a capture's revolution i is the log's scan i.

LD06 packets carry a time stamp (ms, wrapping at 30 s): a turn's packets
carry the log's time of its scan (2 ms more each packet), so the capture
is as sparse or as dense as the log, as a 10 Hz sensor's capture would be
with the revolutions between the log's scans left out. A turn's first
packet, which closes the turn before (the reader times a revolution by the
packet that closes it), is stamped 2 ms after that turn's last, as a
logger that keeps whole revolutions keeps it. A log without a clock (its
timestamps repeat) is written one scan a second. Captures written before
issue 56 stamped every packet 2 ms after the last, whatever the log's
rate. RPLIDAR packets carry no time.

Usage: python3 tools/log_captures.py LOG[.gz] --protocol ld06|rplidar
       [--points 360] --out CAPTURE
"""

import argparse
import gzip
import struct

from lidar_streams import crc8_4d

NO_RETURN_M = 81.9


def flaser_scans(path):
    opener = gzip.open if path.endswith(".gz") else open
    with opener(path, "rt") as f:
        for line in f:
            fields = line.split()
            if fields and fields[0] == "FLASER":
                n = int(fields[1])
                # ranges, then x y theta odom_x odom_y odom_theta timestamp
                yield [float(v) for v in fields[2 : 2 + n]], float(fields[2 + n + 6])


def carmen_increment_deg(n):
    """The beam spacing CARMEN assumes for n beams over 180 degrees."""
    return {180: 1.0, 181: 1.0, 360: 0.5, 361: 0.5, 400: 0.25, 401: 0.25}.get(n, 180.0 / (n - 1))


def turn_mm(scan, points):
    """Distance (mm, 0 = no return) of the clockwise points of one turn."""
    inc = carmen_increment_deg(len(scan))
    spacing = 360.0 / points
    out = []
    for k in range(points):
        ccw = (-k * spacing + 90.0) % 360.0  # degrees from the log's beam 0 (at -90)
        j = round(ccw / inc)
        near = abs(j * inc - ccw) <= spacing / 2 + 1e-9
        r = scan[j] if near and 0 <= j < len(scan) else 0.0
        out.append(0 if r >= NO_RETURN_M or r <= 0.0 else int(round(r * 1000.0)))
    return out


def ld06_stream(turns, points, times):
    spacing = 36000 // points  # 0.01 degree

    def packet(first_k, distances, stamp):
        start = (first_k * spacing) % 36000
        end = (start + (len(distances) - 1) * spacing) % 36000
        body = struct.pack("<BBHH", 0x54, 0x2C, 3600, start)
        for d in distances:
            d = d if d <= 65535 else 0
            body += struct.pack("<HB", d, 200 if d else 0)
        body += struct.pack("<HH", end, stamp % 30000)
        return body + bytes([crc8_4d(body)])

    out = bytearray()
    # The lead-in half turn just before the first scan, the closing points
    # just after the last.
    if len(set(times)) < len(times):
        # A log without a clock (e.g. every timestamp 0): one scan a second,
        # a sparse stream as the log is read.
        times = [float(i) for i in range(len(times))]
    starts_ms = [round(t * 1000.0) for t in times]
    starts_ms = [starts_ms[0] - 100] + starts_ms + [starts_ms[-1] + 100]
    stamp = None
    for turn, start_ms in zip([[0] * points] + turns + [[0] * 12], starts_ms):
        first = points // 2 if not out else 0
        for j, k in enumerate(range(first, len(turn), 12)):
            # A turn's first packet closes the turn before, as a logger that
            # keeps whole revolutions keeps it: its stamp follows that turn's.
            stamp = stamp + 2 if j == 0 and stamp is not None else start_ms + 2 * j
            out += packet(k, (turn[k : k + 12] + [0] * 12)[:12], stamp)
    return bytes(out)


def rplidar_stream(turns, points, _times):
    def node(k, mm):
        q2 = mm * 4 if mm * 4 <= 65535 else 0
        start = 1 if k == 0 else 0
        b0 = ((47 if q2 else 0) << 2) | ((1 - start) << 1) | start
        angle_q6 = (k * 360 * 64) // points
        return struct.pack("<BHH", b0, (angle_q6 << 1) | 1, q2)

    out = bytearray([0xA5, 0x5A, 0x05, 0x00, 0x00, 0x40, 0x81])
    for k in range(points // 2, points):
        out += node(k, 0)
    for turn in turns + [[0, 0, 0]]:
        for k, d in enumerate(turn):
            out += node(k, d)
    return bytes(out)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("log")
    p.add_argument("--protocol", choices=["ld06", "rplidar"], required=True)
    p.add_argument("--points", type=int, default=360, help="points a turn (divides 36000)")
    p.add_argument("--out", required=True)
    a = p.parse_args()
    if a.points <= 12 or 36000 % a.points:
        p.error("--points must divide 36000 and exceed 12")
    scans = list(flaser_scans(a.log))
    turns = [turn_mm(s, a.points) for s, _ in scans]
    encode = ld06_stream if a.protocol == "ld06" else rplidar_stream
    data = encode(turns, a.points, [t for _, t in scans])
    with open(a.out, "wb") as f:
        f.write(data)
    print(f"{a.out}: {len(turns)} turns, {len(data)} bytes")


if __name__ == "__main__":
    main()
