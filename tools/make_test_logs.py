#!/usr/bin/env python3
"""Writes the recordings of `cli/data/logs/` from real scans (issue 17).

The scans are consecutive scans of the gmapping-corrected Seattle log, taken
from the shared scan-pair file `seattle-corrected_pairs.jsonl` (its
`sequential` pairs chain scan k to scan k + 1). The files are written by
programs independent of this project: a CARMEN log by hand-formatting the
real format (and Python's gzip), a ROS 2 bag by the `mcap` and
`mcap-ros2-support` packages (`pip install mcap mcap-ros2-support`), ROS 1
bags by the `rosbags` package (`pip install rosbags`).

- `seattle-excerpt.log` (and `.log.gz`): CARMEN, one `FLASER` line per scan,
  in the format of a Radish `-corrected` log: `x y θ` is the corrected pose
  (the pairs' `dx, dy, dtheta` chained from an arbitrary start pose),
  `odom_x odom_y odom_θ` a synthetic odometry (the same steps with 5 % more
  translation and a 0.02 rad bias per step: the real log's raw odometry is
  not in the pair file). `ODOM` lines carry the same odometry, and a few
  lines of types the tool skips (`PARAM`, `SYNC`, comments) are mixed in.
- `seattle-bag.mcap`: `/scan` (`sensor_msgs/msg/LaserScan`), `/odom`
  (`nav_msgs/msg/Odometry`, the same synthetic odometry) and `/chatter`
  (`std_msgs/msg/String`), zstd chunks as the writer's default.
- `nan-scan.mcap`: three of those scans, the second with every range NaN
  (bad input for the tests).
- `seattle-bag.bag` (bz2 chunks) and `seattle-bag-lz4.bag` (lz4 chunks):
  the same messages in ROS 1 bags (format 2.0, `sensor_msgs/LaserScan`,
  `nav_msgs/Odometry`, `std_msgs/String`; ROS 1 headers carry a `seq` and
  a `secs`/`nsecs` stamp), chunks of about 8 KiB, and the scans again as
  `sensor_msgs/MultiEchoLaserScan` (one echo a beam) on `/echoes`.
- `*.pairs.jsonl`: the pair-file lines of the same consecutive scans,
  copied verbatim, so the tests compare `log` with `scans`.

Ranges are written with Python's shortest round-trip `repr`, so the CARMEN
text parses to the same numbers as the pair file's JSON.

Run from the repository root:

    python3 tools/make_test_logs.py                  # the bundled excerpts
    python3 tools/make_test_logs.py --all /tmp/logs  # all 241 scans (not bundled)
    python3 tools/make_test_logs.py --all /tmp/logs \
        --pairs ../shared/data/orebro-corrected_pairs.jsonl  # 237 Örebro scans

(`--all` follows the chain of consecutive pairs from scan 0 to its first
gap; the CARMEN header comment names Seattle whatever the source.)
"""

import argparse
import gzip
import json
import math
import os
import sys

import numpy as np

PAIRS = os.path.join(os.path.dirname(__file__), "..", "..", "shared", "data",
                     "seattle-corrected_pairs.jsonl")
OUT = os.path.join(os.path.dirname(__file__), "..", "cli", "data", "logs")
START = (2.0, -1.0, 0.7)  # arbitrary world pose of the first scan


def compose(p, d):
    x, y, t = p
    c, s = math.cos(t), math.sin(t)
    return (x + c * d[0] - s * d[1], y + s * d[0] + c * d[1],
            math.atan2(math.sin(t + d[2]), math.cos(t + d[2])))


def chain(pairs_path, first, count):
    """`count` consecutive scans from scan `first`: (scans, pair lines)."""
    by_first = {}
    with open(pairs_path) as f:
        for line in f:
            r = json.loads(line)
            if r["pair_kind"] == "sequential":
                by_first[r["scan1"]["index_in_src"]] = (r, line.rstrip("\n"))
    scans, lines = [], []
    k = first
    corrected, odom = START, START
    while len(scans) < count and k in by_first:
        r, line = by_first[k]
        if not scans:
            scans.append((r["scan1"], corrected, odom))
        if r["scan2"]["index_in_src"] != k + 1:
            break
        d = (r["dx"], r["dy"], r["dtheta"])
        corrected = compose(corrected, d)
        odom = compose(odom, (1.05 * d[0], 1.05 * d[1], d[2] + 0.02))
        scans.append((r["scan2"], corrected, odom))
        lines.append(line)
        k += 1
    return scans[:count], lines[:count - 1]


def carmen(scans):
    out = [
        "# CARMEN Logfile (excerpt of the gmapping-corrected Seattle log, made by",
        "# tools/make_test_logs.py; odometry synthetic, see host-tests/data/README.md)",
        "# message_name [message contents] ipc_timestamp ipc_hostname logger_timestamp",
        "# FLASER num_readings [range_readings] x y theta odom_x odom_y odom_theta",
        "# ODOM x y theta tv rv accel",
        "PARAM robot_frontlaser_offset 0.0 nohost 0",
    ]
    for scan, (x, y, t), (ox, oy, ot) in scans:
        ts = scan["t"]
        out.append(f"ODOM {ox!r} {oy!r} {ot!r} 0.0 0.0 0.0 {ts!r} seattle {ts!r}")
        ranges = " ".join(repr(float(r)) for r in scan["ranges"])
        out.append(f"FLASER {len(scan['ranges'])} {ranges} {x!r} {y!r} {t!r} "
                   f"{ox!r} {oy!r} {ot!r} {ts!r} seattle {ts!r}")
        out.append(f"SYNC {ts!r} seattle {ts!r}")
    return "\n".join(out) + "\n"


LASER_SCAN = """std_msgs/Header header
float32 angle_min
float32 angle_max
float32 angle_increment
float32 time_increment
float32 scan_time
float32 range_min
float32 range_max
float32[] ranges
float32[] intensities
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
"""

ODOMETRY = """std_msgs/Header header
string child_frame_id
geometry_msgs/PoseWithCovariance pose
geometry_msgs/TwistWithCovariance twist
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
================================================================================
MSG: geometry_msgs/PoseWithCovariance
Pose pose
float64[36] covariance
================================================================================
MSG: geometry_msgs/Pose
Point position
Quaternion orientation
================================================================================
MSG: geometry_msgs/Point
float64 x
float64 y
float64 z
================================================================================
MSG: geometry_msgs/Quaternion
float64 x
float64 y
float64 z
float64 w
================================================================================
MSG: geometry_msgs/TwistWithCovariance
Twist twist
float64[36] covariance
================================================================================
MSG: geometry_msgs/Twist
Vector3 linear
Vector3 angular
================================================================================
MSG: geometry_msgs/Vector3
float64 x
float64 y
float64 z
"""

STRING = "string data\n"


def stamp(t):
    sec = math.floor(t)
    return {"sec": int(sec), "nanosec": int(round((t - sec) * 1e9)) % 1000000000}


def bag(scans, path, nan_scan=None):
    from mcap_ros2.writer import Writer

    with open(path, "wb") as f:
        # Small chunks, so that a truncated copy keeps whole chunks to read.
        w = Writer(f, chunk_size=8192)
        laser = w.register_msgdef("sensor_msgs/msg/LaserScan", LASER_SCAN)
        odometry = w.register_msgdef("nav_msgs/msg/Odometry", ODOMETRY)
        string = w.register_msgdef("std_msgs/msg/String", STRING)
        for i, (scan, _, (ox, oy, ot)) in enumerate(scans):
            t = scan["t"] if scan["t"] > 0 else float(i + 1)  # some logs lack times
            ns = int(round(t * 1e9))
            header = {"stamp": stamp(t), "frame_id": "laser"}
            n = len(scan["ranges"])
            w.write_message("/odom", odometry, {
                "header": {"stamp": stamp(t), "frame_id": "odom"},
                "child_frame_id": "base_link",
                "pose": {"pose": {"position": {"x": ox, "y": oy, "z": 0.0},
                                  "orientation": {"x": 0.0, "y": 0.0,
                                                  "z": math.sin(ot / 2),
                                                  "w": math.cos(ot / 2)}},
                         "covariance": [0.0] * 36},
                "twist": {"twist": {"linear": {"x": 0.0, "y": 0.0, "z": 0.0},
                                    "angular": {"x": 0.0, "y": 0.0, "z": 0.0}},
                          "covariance": [0.0] * 36},
            }, log_time=ns - 1000, publish_time=ns - 1000)
            w.write_message("/scan", laser, {
                "header": header,
                "angle_min": scan["angle_min"],
                "angle_max": scan["angle_min"] + (n - 1) * scan["angle_increment"],
                "angle_increment": scan["angle_increment"],
                "time_increment": 0.0,
                "scan_time": 0.0,
                "range_min": 0.0,
                "range_max": scan["max_range"],
                "ranges": [float("nan") if i == nan_scan else float(r)
                           for r in scan["ranges"]],
                "intensities": [],
            }, log_time=ns, publish_time=ns)
            if i % 4 == 0:
                w.write_message("/chatter", string, {"data": f"scan {i}"},
                                log_time=ns + 1000, publish_time=ns + 1000)
        w.finish()


def ros_messages(store, i, scan, odom_pose, ros1):
    """The odometry, scan and multi-echo scan messages of scan `i`, as
    `rosbags` message objects of `store` (ROS 1 headers carry `seq`)."""
    T = store.types
    t = scan["t"] if scan["t"] > 0 else float(i + 1)
    s = stamp(t)
    time = T["builtin_interfaces/msg/Time"](sec=s["sec"], nanosec=s["nanosec"])

    def header(frame):
        extra = {"seq": i} if ros1 else {}
        return T["std_msgs/msg/Header"](stamp=time, frame_id=frame, **extra)

    def vector(x, y, z):
        return T["geometry_msgs/msg/Vector3"](x=x, y=y, z=z)

    ox, oy, ot = odom_pose
    n = len(scan["ranges"])
    odom = T["nav_msgs/msg/Odometry"](
        header=header("odom"),
        child_frame_id="base_link",
        pose=T["geometry_msgs/msg/PoseWithCovariance"](
            pose=T["geometry_msgs/msg/Pose"](
                position=T["geometry_msgs/msg/Point"](x=ox, y=oy, z=0.0),
                orientation=T["geometry_msgs/msg/Quaternion"](
                    x=0.0, y=0.0, z=math.sin(ot / 2), w=math.cos(ot / 2))),
            covariance=np.zeros(36)),
        twist=T["geometry_msgs/msg/TwistWithCovariance"](
            twist=T["geometry_msgs/msg/Twist"](
                linear=vector(0.0, 0.0, 0.0), angular=vector(0.0, 0.0, 0.0)),
            covariance=np.zeros(36)))
    geometry = dict(
        angle_min=scan["angle_min"],
        angle_max=scan["angle_min"] + (n - 1) * scan["angle_increment"],
        angle_increment=scan["angle_increment"],
        time_increment=0.0,
        scan_time=0.0,
        range_min=0.0,
        range_max=scan["max_range"])
    ranges = [float(r) for r in scan["ranges"]]
    laser = T["sensor_msgs/msg/LaserScan"](
        header=header("laser"), **geometry,
        ranges=np.array(ranges, dtype=np.float32),
        intensities=np.array([], dtype=np.float32))
    echo = T["sensor_msgs/msg/LaserEcho"]
    multi = T["sensor_msgs/msg/MultiEchoLaserScan"](
        header=header("laser"), **geometry,
        ranges=[echo(echoes=np.array([r], dtype=np.float32)) for r in ranges],
        intensities=[])
    text = T["std_msgs/msg/String"](data=f"scan {i}") if i % 4 == 0 else None
    return int(round(t * 1e9)), odom, laser, multi, text


def ros1_bag(scans, path, compression):
    """The messages of `bag` in a ROS 1 bag, written by `rosbags`."""
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    if os.path.exists(path):
        os.remove(path)
    w = Writer(path)
    w.set_compression(compression)
    w.chunk_threshold = 8192  # small chunks: a truncated copy keeps whole ones
    with w:
        scan_c = w.add_connection("/scan", "sensor_msgs/msg/LaserScan", typestore=store)
        odom_c = w.add_connection("/odom", "nav_msgs/msg/Odometry", typestore=store)
        chat_c = w.add_connection("/chatter", "std_msgs/msg/String", typestore=store)
        echo_c = w.add_connection("/echoes", "sensor_msgs/msg/MultiEchoLaserScan",
                                  typestore=store)
        for i, (scan, _, odom_pose) in enumerate(scans):
            ns, odom, laser, multi, text = ros_messages(store, i, scan, odom_pose, True)
            w.write(odom_c, ns - 1000, store.serialize_ros1(odom, "nav_msgs/msg/Odometry"))
            w.write(scan_c, ns, store.serialize_ros1(laser, "sensor_msgs/msg/LaserScan"))
            w.write(echo_c, ns + 500,
                    store.serialize_ros1(multi, "sensor_msgs/msg/MultiEchoLaserScan"))
            if text is not None:
                w.write(chat_c, ns + 1000, store.serialize_ros1(text, "std_msgs/msg/String"))


def bag_directory(scans, path, storage):
    """The messages of `bag` in a ROS 2 bag directory (`metadata.yaml` and one
    `.db3` or `.mcap` file, as `storage` says), written by `rosbags`."""
    import shutil

    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    if os.path.exists(path):
        shutil.rmtree(path)
    with Writer(path, version=8, storage_plugin=storage) as w:
        scan_c = w.add_connection("/scan", "sensor_msgs/msg/LaserScan", typestore=store)
        odom_c = w.add_connection("/odom", "nav_msgs/msg/Odometry", typestore=store)
        chat_c = w.add_connection("/chatter", "std_msgs/msg/String", typestore=store)
        for i, (scan, _, odom_pose) in enumerate(scans):
            ns, odom, laser, _, text = ros_messages(store, i, scan, odom_pose, False)
            w.write(odom_c, ns - 1000, store.serialize_cdr(odom, "nav_msgs/msg/Odometry"))
            w.write(scan_c, ns, store.serialize_cdr(laser, "sensor_msgs/msg/LaserScan"))
            if text is not None:
                w.write(chat_c, ns + 1000, store.serialize_cdr(text, "std_msgs/msg/String"))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--pairs", default=PAIRS, help="seattle-corrected_pairs.jsonl")
    ap.add_argument("--all", metavar="DIR", help="write the whole log (all scans) to DIR")
    a = ap.parse_args()
    if a.all:
        os.makedirs(a.all, exist_ok=True)
        name = os.path.basename(a.pairs).split("-corrected")[0].split("_pairs")[0]
        scans, lines = chain(a.pairs, 0, 10**6)
        with gzip.GzipFile(os.path.join(a.all, f"{name}.log.gz"), "wb", mtime=0) as f:
            f.write(carmen(scans).encode())
        with open(os.path.join(a.all, f"{name}.pairs.jsonl"), "w") as f:
            f.write("\n".join(lines) + "\n")
        bag(scans, os.path.join(a.all, f"{name}.mcap"))
        from rosbags.rosbag1 import Writer
        ros1_bag(scans, os.path.join(a.all, f"{name}.bag"), Writer.CompressionFormat.LZ4)
        from rosbags.rosbag2 import StoragePlugin
        bag_directory(scans, os.path.join(a.all, f"{name}-db3"), StoragePlugin.SQLITE3)
        print(f"{len(scans)} scans to {a.all}", file=sys.stderr)
        return
    os.makedirs(OUT, exist_ok=True)
    scans, lines = chain(a.pairs, 0, 20)
    text = carmen(scans)
    with open(os.path.join(OUT, "seattle-excerpt.log"), "w") as f:
        f.write(text)
    with gzip.GzipFile(os.path.join(OUT, "seattle-excerpt.log.gz"), "wb", mtime=0) as f:
        f.write(text.encode())
    with open(os.path.join(OUT, "seattle-excerpt.pairs.jsonl"), "w") as f:
        f.write("\n".join(lines) + "\n")
    scans, lines = chain(a.pairs, 40, 12)
    bag(scans, os.path.join(OUT, "seattle-bag.mcap"))
    bag(scans[:3], os.path.join(OUT, "nan-scan.mcap"), nan_scan=1)
    from rosbags.rosbag1 import Writer
    ros1_bag(scans, os.path.join(OUT, "seattle-bag.bag"), Writer.CompressionFormat.BZ2)
    ros1_bag(scans, os.path.join(OUT, "seattle-bag-lz4.bag"), Writer.CompressionFormat.LZ4)
    from rosbags.rosbag2 import StoragePlugin
    bag_directory(scans, os.path.join(OUT, "seattle-bag-db3"), StoragePlugin.SQLITE3)
    bag_directory(scans, os.path.join(OUT, "seattle-bag-dir"), StoragePlugin.MCAP)
    with open(os.path.join(OUT, "seattle-bag.pairs.jsonl"), "w") as f:
        f.write("\n".join(lines) + "\n")
    print(f"wrote {OUT}", file=sys.stderr)


if __name__ == "__main__":
    main()
