"""The recordings `log` reads, read from Python: the same scans, and their
pairs give the tool's `log` lines."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import hough_heading as hh
from conftest import LOGS, json_lines, run_tool

LOG_KEYS = {"scan1", "scan2", "t1", "t2", "odom", "log_pose"}


def test_carmen_excerpt_scans_equal_the_pair_file():
    log = hh.read_log(LOGS / "seattle-excerpt.log.gz")
    assert (len(log), log.errors, log.format) == (20, [], "carmen")
    assert all(s.ranges.dtype == np.float32 and s.ranges.shape == (361,) for s in log)
    # The excerpt's pair file holds the same scans (consecutive pairs).
    pairs = [json.loads(l) for l in open(LOGS / "seattle-excerpt.pairs.jsonl")]
    for k, p in enumerate(pairs):
        for scan, rec in ((log[k], p["scan1"]), (log[k + 1], p["scan2"])):
            assert np.array_equal(scan.ranges, np.array(rec["ranges"], dtype=np.float32))
            assert scan.angle_min == pytest.approx(rec["angle_min"], abs=1e-6)
            assert scan.angle_increment == pytest.approx(rec["angle_increment"], rel=1e-6)
        # The log's poses give the pair's ground truth.
        (x1, y1, t1), (x2, y2, t2) = log[k].log_pose, log[k + 1].log_pose
        c, s = math.cos(t1), math.sin(t1)
        dx, dy = c * (x2 - x1) + s * (y2 - y1), -s * (x2 - x1) + c * (y2 - y1)
        assert (dx, dy) == pytest.approx((p["dx"], p["dy"]), abs=2e-6)
    assert np.all(np.diff(log.times()) > 0)
    assert log.odometry().shape == (20, 3) and not np.isnan(log.odometry()).any()
    # Plain and gzip read the same.
    plain = hh.read_log(LOGS / "seattle-excerpt.log")
    assert all(np.array_equal(a.ranges, b.ranges) and a.time == b.time for a, b in zip(plain, log))


@pytest.mark.parametrize("name, options", [
    ("seattle-excerpt.log.gz", ()),
    ("seattle-bag.mcap", ("--topic", "/scan")),
])
def test_consecutive_pairs_equal_the_tool_s_log_lines(tool, name, options):
    # The pairs alone (`--prior none`): by default `log` chains them.
    want = json_lines(run_tool(tool, "log", "-q", "--prior", "none", str(LOGS / name),
                               *options).stdout)
    log = hh.read_log(LOGS / name)
    got = hh.estimate_scans_batch(list(zip(log, log[1:])))
    assert len(got) == len(want) == len(log) - 1
    for i, (g, w) in enumerate(zip(got, want)):
        assert w["scan1"] == i and w["scan2"] == i + 1
        assert w["t1"] == pytest.approx(log[i].time) and w["t2"] == pytest.approx(log[i + 1].time)
        w = {k: v for k, v in w.items() if k not in LOG_KEYS}
        w.pop("index")
        assert g.to_dict() == w, i


def test_a_bag_s_only_scan_topic_is_used():
    log = hh.read_log(LOGS / "seattle-bag.mcap")
    assert (log.format, log.topic, len(log)) == ("mcap", "/scan", 12)
    assert all(s.odom is not None for s in log)
    same = hh.read_log(LOGS / "seattle-bag.mcap", topic="/scan")
    assert all(np.array_equal(a.ranges, b.ranges) for a, b in zip(log, same))
    with pytest.raises(ValueError, match="no messages on topic /nope"):
        hh.read_log(LOGS / "seattle-bag.mcap", topic="/nope")


@pytest.mark.parametrize(
    "name, fmt",
    [
        ("seattle-bag.bag", "ros1"),
        ("seattle-bag-lz4.bag", "ros1"),
        ("seattle-bag-db3", "db3"),
        ("seattle-bag-db3/seattle-bag-db3.db3", "db3"),
        ("seattle-bag-dir", "mcap"),
    ],
)
def test_other_bag_kinds_hold_the_mcap_bag_s_scans(name, fmt):
    # The same messages written by the `rosbags` package (ROS 1, SQLite, an
    # MCAP bag directory): the same scans, times and odometry.
    want = hh.read_log(LOGS / "seattle-bag.mcap")
    log = hh.read_log(LOGS / name)
    assert (log.format, log.topic, len(log), log.errors) == (fmt, "/scan", 12, [])
    for a, b in zip(log, want):
        assert np.array_equal(a.ranges, b.ranges, equal_nan=True)
        assert (a.time, a.odom) == (b.time, b.odom)


def test_a_bag_s_unusable_scan_is_a_listed_error_as_in_the_tool():
    log = hh.read_log(LOGS / "nan-scan.mcap")
    # The all-NaN scan is the reader's error (as `log` reports it); the
    # other two are read.
    assert len(log) == 2
    assert len(log.errors) == 1 and "all 361 ranges are NaN or infinite" in log.errors[0][1]
    ranges = log[1].ranges.copy()
    ranges[::2] = np.nan
    partial = hh.Scan(ranges, log[1].angle_min, log[1].angle_increment, log[1].max_range)
    e = hh.estimate_scans(log[0], partial)
    assert e.dropped[1]["not_finite"] == int(np.isnan(ranges).sum())
    with pytest.raises(ValueError, match="NaN"):
        hh.estimate_scans(log[0], partial, nan="raise")
