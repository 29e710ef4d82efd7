#!/usr/bin/env python3
"""Independent precision check of the real-data figures (host-tests/REAL_DATA.md).

For the pairs with overlap_gt >= 0.5 whose estimate is within 2 degrees of the
ground truth, refine the estimate with a float point-to-point ICP on the raw
scan points (nothing shared with the library) and compare the median rotation
errors of the estimate and of the refined pose against the ground truth. When
both are equal, the figure is bounded by the ground truth, not the estimator.

    cargo run -q --release --bin hough-heading -- scans ../shared/data/fr079-flirt_pairs.jsonl -q > /tmp/out.jsonl
    python3 tools/float_icp_check.py ../shared/data/fr079-flirt_pairs.jsonl /tmp/out.jsonl

Needs numpy.
"""
import json
import math
import statistics
import sys

import numpy as np


def points(scan):
    r = np.array([np.nan if v is None else v for v in scan["ranges"]], float)
    a = scan["angle_min"] + np.arange(len(r)) * scan["angle_increment"]
    ok = np.isfinite(r) & (r < scan["max_range"]) & (r > 0)
    ox, oy, oth = scan.get("laser_offset", [0, 0, 0])
    return np.stack([r[ok] * np.cos(a[ok] + oth) + ox, r[ok] * np.sin(a[ok] + oth) + oy], 1)


def icp(p1, p2, th, dx, dy, iterations=30, gate=0.2):
    """Pose p1 = R(th) p2 + (dx, dy) refined by point-to-point ICP."""
    for _ in range(iterations):
        c, s = math.cos(th), math.sin(th)
        q = p2 @ np.array([[c, s], [-s, c]]) + [dx, dy]
        d = ((q[:, None, :] - p1[None, :, :]) ** 2).sum(-1)
        j = d.argmin(1)
        keep = np.sqrt(d[np.arange(len(q)), j]) < gate
        if keep.sum() < 5:
            break
        a, b = q[keep], p1[j[keep]]
        ma, mb = a.mean(0), b.mean(0)
        h = (a - ma).T @ (b - mb)
        dth = math.atan2(h[0, 1] - h[1, 0], h[0, 0] + h[1, 1])
        c, s = math.cos(dth), math.sin(dth)
        rot = np.array([[c, -s], [s, c]])
        th += dth
        dx, dy = rot @ np.array([dx, dy]) + (mb - rot @ ma)
    return th, dx, dy


def wrap(deg):
    return abs((deg + 180) % 360 - 180)


def main():
    pairs = [json.loads(l) for l in open(sys.argv[1])]
    estimates = [json.loads(l) for l in open(sys.argv[2])]
    ours, refined = [], []
    for g, o in zip(pairs, estimates):
        if o.get("dtheta_deg") is None or (g["check"].get("overlap_gt") or 0) < 0.5:
            continue
        truth = math.degrees(g["dtheta"])
        error = wrap(o["dtheta_deg"] - truth)
        if error > 2:
            continue
        th, _, _ = icp(points(g["scan1"]), points(g["scan2"]), math.radians(o["dtheta_deg"]),
                       o.get("dx_m") or 0.0, o.get("dy_m") or 0.0)
        ours.append(error)
        refined.append(wrap(math.degrees(th) - truth))
    print(f"{len(ours)} pairs within 2 deg: estimate median {statistics.median(ours):.3f} deg, "
          f"float ICP from it {statistics.median(refined):.3f} deg")


if __name__ == "__main__":
    main()
