#!/usr/bin/env python3
"""Re-check, in numpy, the wrong unflagged pairs that the estimate aligns better than the truth.

`hough-heading scans FILE --summary` lists them by line index after each
file's table (cli/src/summary.rs). This script redoes the same test
independently and prints each pair's point shares under the estimate and
under the truth: among the pairs whose status is not flagged and whose rotation
error exceeds 5 degrees, those where the share of scan-2 points within 0.1 m
of a scan-1 point is higher under the estimated pose than under the ground
truth (brute force on the raw points, ranges rounded to f32 as the CLI reads
them). Prints the pairs with overlap_gt >= 0.5 first, then the others.

    cargo run -q --release --bin hough-heading -- scans ../shared/data/intel-flirt_pairs.jsonl > /tmp/intel.jsonl
    python3 tools/fits_better_pairs.py ../shared/data/intel-flirt_pairs.jsonl /tmp/intel.jsonl

Needs numpy.
"""
import json
import math
import sys

import numpy as np


def points(scan):
    """Scan-frame points as summary.rs's `points` computes them (f32 inputs)."""
    r = np.array([np.nan if v is None else v for v in scan["ranges"]], np.float32).astype(float)
    ox, oy, oth = (float(np.float32(v)) for v in scan.get("laser_offset", [0, 0, 0]))
    a0, da, rmax = (float(np.float32(scan[k])) for k in ("angle_min", "angle_increment", "max_range"))
    a = a0 + np.arange(len(r)) * da + oth
    ok = np.isfinite(r) & (r > 0) & (r < rmax)
    return np.stack([ox + r[ok] * np.cos(a[ok]), oy + r[ok] * np.sin(a[ok])], 1)


def aligned_share(p1, p2, th, dx, dy):
    """Share of p2 within 0.1 m of a p1 point under p1 = R(th) p2 + (dx, dy)."""
    if len(p2) == 0:
        return 0.0
    s, c = math.sin(th), math.cos(th)
    q = np.stack([c * p2[:, 0] - s * p2[:, 1] + dx, s * p2[:, 0] + c * p2[:, 1] + dy], 1)
    d = ((q[:, None, :] - p1[None, :, :]) ** 2).sum(-1)
    return float((d < 0.01).any(1).mean())


def wrap(deg):
    r = deg % 360.0
    return r - 360.0 if r > 180.0 else r


def main():
    pairs = [json.loads(l) for l in open(sys.argv[1])]
    estimates = {}
    for line in open(sys.argv[2]):
        if line.startswith("{"):
            e = json.loads(line)
            estimates[e["index"]] = e
    rows = []
    for i, g in enumerate(pairs):
        e = estimates.get(i)
        if e is None or e.get("dtheta_deg") is None or e["status"] != "confident":
            continue
        truth = wrap(math.degrees(g["dtheta"]))
        error = abs(wrap(e["dtheta_deg"] - truth))
        if error <= 5.0:
            continue
        better, ours, theirs = False, None, None
        if e.get("dx_m") is not None:
            p1, p2 = points(g["scan1"]), points(g["scan2"])
            ours = aligned_share(p1, p2, math.radians(e["dtheta_deg"]), e["dx_m"], e["dy_m"])
            theirs = aligned_share(p1, p2, g["dtheta"], g["dx"], g["dy"])
            better = ours > theirs
        overlap = g.get("check", {}).get("overlap_gt")
        rows.append((i, overlap, truth, e["dtheta_deg"], error, better, ours, theirs, g.get("pair_kind")))
    for high in (True, False):
        subset = [r for r in rows if (r[1] is not None and r[1] >= 0.5) == high]
        fits = [r for r in subset if r[5]]
        print(f"{'overlap_gt >= 0.5' if high else 'overlap_gt < 0.5 or missing'}: "
              f"{len(subset)} wrong unflagged, {len(fits)} fit better: "
              + ", ".join(str(r[0]) for r in fits))
        for i, overlap, truth, est, error, better, ours, theirs, kind in subset:
            shares = "" if ours is None else f" share est {ours:.3f} truth {theirs:.3f}"
            ov = "-" if overlap is None else f"{overlap:.3f}"
            print(f"  {i}: overlap_gt {ov} truth {truth:.1f} est {est:.1f} error {error:.1f}"
                  f" fits better {better}{shares} {kind or ''}")


if __name__ == "__main__":
    main()
