"""Scan pairs through Python give exactly the tool's JSON lines."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import hough_heading as hh
from conftest import REPO, json_lines, run_tool


def tool_lines(tool, path, *options):
    lines = json_lines(run_tool(tool, "scans", "-q", str(path), *options).stdout)
    for line in lines:
        line.pop("index")
    return lines


def records(path):
    with open(path) as f:
        return [json.loads(line) for line in f if line.strip()]


def test_bundled_pairs_equal_the_tool(tool):
    path = REPO / "cli" / "data" / "scans.jsonl"
    want = tool_lines(tool, path)
    recs = records(path)
    got = [hh.estimate_scans(r["scan1"], r["scan2"]).to_dict() for r in recs]
    assert got == want
    # With other options: the same options give the same answers.
    want = tool_lines(tool, path, "--size", "128", "--n-theta", "720", "--no-verify",
                      "--connect", "0", "--rival-ratio", "0.8")
    got = [
        hh.estimate_scans(r["scan1"], r["scan2"], size=128, n_theta=720, verify=False,
                          connect=0, thresholds={"rival_ratio": 0.8}).to_dict()
        for r in recs
    ]
    assert got == want


def test_shared_pairs_equal_the_tool_field_by_field(tool, shared_pair_files):
    total = 0
    for path in shared_pair_files:
        want = tool_lines(tool, path)
        recs = records(path)
        got = hh.estimate_scans_batch([(r["scan1"], r["scan2"]) for r in recs], threads=0)
        assert len(got) == len(want) == len(recs)
        for i, (g, w) in enumerate(zip(got, want)):
            d = g.to_dict()
            assert d == w, f"{path.name} line {i}: {d} != {w}"
        # Single calls equal the batch (a few lines a file).
        for i in range(0, len(recs), max(1, len(recs) // 5)):
            single = hh.estimate_scans(recs[i]["scan1"], recs[i]["scan2"])
            assert single == got[i]
        total += len(recs)
    assert total > 1000


def test_answer_attributes_follow_the_json(tool):
    path = REPO / "cli" / "data" / "scans.jsonl"
    rec = records(path)[0]
    e = hh.estimate_scans(rec["scan1"], rec["scan2"])
    d = e.to_dict()
    # Every JSON key is an attribute.
    for k, v in d.items():
        assert getattr(e, k) == v
    assert e.kind == "scans"
    assert e.dtheta_deg == d["dtheta_deg"]
    assert e.alpha_deg == pytest.approx(-d["dtheta_deg"])
    assert e.dtheta_rad == pytest.approx(math.radians(d["dtheta_deg"]))
    assert e.rotation_deg == e.dtheta_deg
    assert e.translation_m == (d["dx_m"], d["dy_m"])
    assert [c.dtheta_deg for c in e.candidates] == d["candidates_deg"]
    assert [c.alignment for c in e.candidates] == d["alignments"]
    # The pose on the grids: t (cells), turned into metres, is the robot's
    # displacement: (dx, dy) = −R(dθ)·t·cell (the scene moves the other way).
    tx, ty = e.translation_cells
    c, s = math.cos(e.dtheta_rad), math.sin(e.dtheta_rad)
    dx = -(c * tx - s * ty) * d["cell_m"]
    dy = -(s * tx + c * ty) * d["cell_m"]
    assert (dx, dy) == pytest.approx((d["dx_m"], d["dy_m"]), abs=2e-3)
    assert e.scale == 1.0
    with pytest.raises(AttributeError):
        e.no_such_field
    with pytest.raises(AttributeError):
        e.status = "x"


def test_the_estimate_finds_a_known_turn():
    """A synthetic room seen from a robot that turned left by 30° and moved."""
    angles = np.linspace(-math.pi, math.pi, 720, endpoint=False)
    inc = angles[1] - angles[0]

    def room_scan(px, py, heading):
        # Distances from (px, py) to the walls of a 10 × 6 m room with a
        # 2 × 1 m box, by ray casting.
        walls = [((-5, -3), (5, -3)), ((5, -3), (5, 3)), ((5, 3), (-5, 3)), ((-5, 3), (-5, -3)),
                 ((1, 0), (3, 0)), ((3, 0), (3, 1)), ((3, 1), (1, 1)), ((1, 1), (1, 0))]
        out = np.full(angles.size, np.inf)
        for i, a in enumerate(angles + heading):
            d = (math.cos(a), math.sin(a))
            for (x1, y1), (x2, y2) in walls:
                ex, ey = x2 - x1, y2 - y1
                den = d[0] * ey - d[1] * ex
                if abs(den) < 1e-12:
                    continue
                t = ((x1 - px) * ey - (y1 - py) * ex) / den
                u = ((x1 - px) * d[1] - (y1 - py) * d[0]) / den
                if t > 0 and 0 <= u <= 1:
                    out[i] = min(out[i], t)
        return hh.Scan(out, float(angles[0]), float(inc), 30.0)

    s1 = room_scan(-1.0, -0.5, 0.0)
    s2 = room_scan(-0.6, -0.3, math.radians(30))
    e = hh.estimate_scans(s1, s2, size=256)
    assert e.status == "confident"
    assert e.dtheta_deg == pytest.approx(30.0, abs=1.0)
    # The robot moved by (0.4, 0.2) m in the world = its frame at scan 1.
    assert e.translation_m == pytest.approx((0.4, 0.2), abs=0.1)


def test_prior_picks_as_the_tool_does(tool):
    # `log --prior odom` with the log's odometry: Python with the same prior
    # gives the same lines.
    log = REPO / "cli" / "data" / "logs" / "seattle-excerpt.log.gz"
    want = json_lines(run_tool(tool, "log", "-q", str(log), "--prior", "odom").stdout)
    scans = hh.read_log(log)
    for w, (a, b) in zip(want, zip(scans, scans[1:])):
        odom = w["odom"]["dtheta_deg"]
        got = hh.estimate_scans(a, b, prior=(odom, 10.0)).to_dict()
        for k in got:
            assert got[k] == w[k], k
