#!/usr/bin/env python3
"""How self-consistent the rotations are, the tool's and the ground truth's:
the closure θ_ab + θ_bc − θ_ac over triangles of pairs that share scans.

A pair file's ground truth has its own errors (gmapping trajectories about
0.5°, FLIRT graph edges 0.03–0.4°), so the median error against it is
bounded below by them. Closure needs no truth: with independent errors of
median m per edge, its median is about √3 · m. Triangles are formed from
the pairs of a file with `check.overlap_gt` ≥ 0.5 whose scans share their
time stamps (`t1`, `t2`), and counted only when all three of the tool's
answers are within 2° of the ground truth (a gross error is another
measure's business). Only files whose ground truth are graph edges
(`gt_source`), measured one by one, are read: a trajectory's relative
poses close by construction.

    hough-heading scans -q ../shared/data/*.jsonl > OUT.jsonl
    python3 tools/triangle_closure.py OUT.jsonl ../shared/data/*.jsonl

Prints one line per file with triangles: their count and the median
|closure| of the tool's rotations and of the ground truth's, degrees.
"""

import collections
import json
import math
import os
import sys

MIN_OVERLAP = 0.5
GATE_DEG = 2.0


def wrap(d):
    return (d + 180.0) % 360.0 - 180.0


def median(values):
    v = sorted(values)
    return v[len(v) // 2] if v else float("nan")


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    answers = collections.defaultdict(dict)
    with open(sys.argv[1], encoding="utf-8") as f:
        for line in f:
            o = json.loads(line)
            if o.get("dtheta_deg") is not None:
                answers[os.path.basename(o["file"])][o["index"]] = o["dtheta_deg"]
    print("| file | triangles | median \\|closure\\|, tool | median \\|closure\\|, ground truth |")
    print("|---|---|---|---|")
    for path in sys.argv[2:]:
        name = os.path.basename(path)
        # (t1, t2) → (tool's rotation, truth's rotation), degrees.
        edges = {}
        with open(path, encoding="utf-8") as f:
            for index, line in enumerate(f):
                if not line.strip():
                    continue
                d = json.loads(line)
                if "graph-edge" not in d.get("gt_source", ""):
                    break
                if (d.get("check", {}).get("overlap_gt") or 0.0) < MIN_OVERLAP:
                    continue
                truth = math.degrees(d["dtheta"])
                tool = answers[name].get(index)
                if tool is None or abs(wrap(tool - truth)) > GATE_DEG:
                    continue
                edges.setdefault((d["t1"], d["t2"]), (tool, truth))
        neighbours = collections.defaultdict(set)
        for a, b in edges:
            neighbours[a].add(b)
            neighbours[b].add(a)

        def rotation(a, b, which):
            if (a, b) in edges:
                return edges[(a, b)][which]
            return -edges[(b, a)][which]

        triangles = set()
        for a, b in edges:
            for c in neighbours[a] & neighbours[b]:
                triangles.add(tuple(sorted((a, b, c))))
        closures = ([], [])
        for a, b, c in sorted(triangles):
            for which in (0, 1):
                closure = rotation(a, b, which) + rotation(b, c, which) - rotation(a, c, which)
                closures[which].append(abs(wrap(closure)))
        if triangles:
            print(
                f"| {name[: -len('_pairs.jsonl')]} | {len(triangles)} "
                f"| {median(closures[0]):.3f}° | {median(closures[1]):.3f}° |"
            )


if __name__ == "__main__":
    main()
