#!/usr/bin/env python3
"""The accuracy guard of issue 40 and the search's work, from the tool's JSON
lines (`hough-heading scans -q --size S FILE.jsonl > DIR/S-FILE.out`) and the
pair files' ground truth (standard library only):

    bash tools/search_guard.sh DIR [BASE_DIR]   # runs the tool, then:
    python3 tools/search_guard.py DIR [BASE_DIR]

Per grid size: within 2° at overlap_gt ≥ 0.5, wrong (> 5°) among unflagged
at overlap_gt ≥ 0.5 and over all pairs, flagged share, and the median / max
`search_rows`. With BASE_DIR, also how many answers (dθ or status) differ.
"""
import glob
import json
import math
import os
import statistics
import sys

DATA = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "shared", "data")


def wrap(d):
    d = math.fmod(d, 360.0)
    return d - 360.0 if d > 180.0 else d + 360.0 if d <= -180.0 else d


def rows(out_dir, size):
    found = {}
    for path in sorted(glob.glob(os.path.join(out_dir, f"{size}-*.out"))):
        name = os.path.basename(path)[len(f"{size}-"):-len(".out")]
        truth = []
        with open(os.path.join(DATA, name + ".jsonl"), encoding="utf-8") as f:
            for line in f:
                if line.strip():
                    d = json.loads(line)
                    truth.append((math.degrees(d["dtheta"]), (d.get("check") or {}).get("overlap_gt") or 0.0))
        with open(path, encoding="utf-8") as f:
            for line in f:
                o = json.loads(line)
                gt, overlap = truth[o["index"]]
                est = o.get("dtheta_deg")
                err = 180.0 if est is None else abs(wrap(est - gt))
                found[(name, o["index"])] = (err, overlap, o["status"], o.get("search_rows", 0), est)
    return found


def main():
    out_dir = sys.argv[1]
    base = sys.argv[2] if len(sys.argv) > 2 else None
    for size in (256, 128):
        r = rows(out_dir, size)
        if not r:
            continue
        hi = [v for v in r.values() if v[1] >= 0.5]
        within = 100.0 * sum(v[0] <= 2.0 for v in hi) / len(hi)
        unfl_hi = [v for v in hi if v[2] == "confident"]
        wrong_hi = sum(v[0] > 5.0 for v in unfl_hi)
        unfl = [v for v in r.values() if v[2] == "confident"]
        wrong = sum(v[0] > 5.0 for v in unfl)
        flagged = 100.0 * (len(r) - len(unfl)) / len(r)
        work = sorted(v[3] for v in r.values())
        line = (f"{size}²: {len(r)} pairs; overlap ≥ 0.5: within 2° {within:.2f} %, "
                f"wrong among unflagged {wrong_hi} ({100.0 * wrong_hi / max(1, len(unfl_hi)):.2f} %); "
                f"all: wrong among unflagged {wrong} ({100.0 * wrong / max(1, len(unfl)):.2f} %), "
                f"flagged {flagged:.2f} %; search_rows median {statistics.median(work) / 1e6:.3f} M, "
                f"max {work[-1] / 1e6:.2f} M, mean {statistics.mean(work) / 1e6:.3f} M")
        if base:
            b = rows(base, size)
            changed = sum(1 for k, v in r.items() if k in b and (v[4], v[2]) != (b[k][4], b[k][2]))
            line += f"; answers changed {changed}"
        print(line)


main()
