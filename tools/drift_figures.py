#!/usr/bin/env python3
"""The heading over whole runs (issue 46): docs/drift.md's tables.

For each CARMEN log with truth poses (default: ../shared/data/logs/*.log.gz
and ../shared/data/dense/sim/*.log.gz; the first pose of a FLASER line is
the truth), runs `hough-heading log` in each way asked (default: the tool's default,
which takes keyframes and loop closures on a dense stream and consecutive
pairs on a sparse one; consecutive pairs and keyframes without closures;
each with `--loops`) and prints one markdown row per stream and way:

- pairs within 2 deg / flagged / confident and > 5 deg off (the line's
  own estimate against the log's relative heading);
- the chained heading against the log's: largest and final error, degrees
  (where the run closed loops: the corrected trajectory, `--trajectory
  x.csv`);
- the share of scans whose true heading lies within 2 sigma of the chained
  one (`chain.heading_sigma_deg`);
- the steps by source (estimate, prior, unplaced, carried);
- where the run closed loops: the closures tried, accepted, accepted and
  more than 5 deg off the log's poses, and accepted and within 1 deg of the
  optimized trajectory (the tool's stderr).

Usage: python3 tools/drift_figures.py [--tool target/release/hough-heading]
       [--ways default,consecutive,keyframes,consecutive+loops,keyframes+loops]
       [--out DIR] [LOG ...]
"""

import argparse
import glob
import json
import os
import re
import subprocess

import chain_scores

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
SHARED = os.path.join(ROOT, "..", "shared", "data")
WAYS = {
    "default": [],
    "consecutive": ["--pairs", "consecutive", "--no-loops"],
    "keyframes": ["--keyframes", "--no-loops"],
    "consecutive+loops": ["--pairs", "consecutive", "--loops"],
    "keyframes+loops": ["--keyframes", "--loops"],
}


def run(tool, log, way, out):
    name = os.path.basename(log).replace(".log.gz", "")
    base = os.path.join(out, f"{name}.{way}")
    args = [tool, "log", log] + WAYS[way] + ["--trajectory", base + ".csv"]
    with open(base + ".jsonl", "w") as o, open(base + ".err", "w") as e:
        subprocess.run(args, stdout=o, stderr=e, check=False)
    lines = [json.loads(x) for x in open(base + ".jsonl") if x.strip()]
    err = open(base + ".err").read()
    return name, lines, err, base + ".csv"


def score(lines, err, csv_path):
    """The run's scores (chain_scores.score; the corrected trajectory where
    it closed loops), its closures and the way it took, or None."""
    closed = "loop closures:" in err and os.path.exists(csv_path)
    corrected = chain_scores.trajectory_headings(csv_path) if closed else None
    s = chain_scores.score(lines, chain_scores.log_headings(lines), corrected)
    if s is None:
        return None
    closures = re.search(r"loop closures: (\d+) confident tried, (\d+) accepted", err)
    agreeing = re.search(r"scans, (\d+) of them within 1", err)
    wrong_closures = re.search(r"poses: (\d+) of the accepted", err)
    taken = re.search(r"scans, \d+ (\w+) pairs", err)
    s["closures"] = (
        closures.groups()
        + (wrong_closures.group(1) if wrong_closures else None, agreeing.group(1) if agreeing else None)
        if closures
        else None
    )
    s["taken"] = taken.group(1) if taken else "?"
    return s


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--tool", default=os.path.join(ROOT, "target", "release", "hough-heading"))
    p.add_argument("--ways", default="default,consecutive,keyframes,consecutive+loops,keyframes+loops")
    p.add_argument("--out", default=os.path.join(ROOT, "target", "drift"))
    p.add_argument("logs", nargs="*")
    a = p.parse_args()
    logs = a.logs or sorted(glob.glob(os.path.join(SHARED, "logs", "*.log.gz"))) + sorted(
        glob.glob(os.path.join(SHARED, "dense", "sim", "*.log.gz")))
    os.makedirs(a.out, exist_ok=True)
    print("| stream | way | pairs | within 2° | flagged | conf. > 5° off | heading error max / end (°) "
          "| truth within 2σ | steps: estimate / prior / unplaced / carried "
          "| closures tried / accepted / wrong / within 1° of the graph |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for log in logs:
        for way in a.ways.split(","):
            name, lines, err, csv_path = run(a.tool, log, way, a.out)
            s = score(lines, err, csv_path)
            if s is None:
                continue
            src = s["sources"]
            largest, last = s["drift"] or (0.0, 0.0)
            c = s["closures"]
            closures = f"{c[0]} / {c[1]} / {c[2] or 0} / {c[3] or 0}" if c else "–"
            shown = f"default ({s['taken']}{', loops' if c else ''})" if way == "default" else way
            print(f"| {name} | {shown} | {s['pairs']} | {s['within']:.1f} % | {s['flagged']:.1f} % | {s['wrong']} "
                  f"| {largest:.1f} / {last:.1f} | {s['cover']:.1f} % "
                  f"| {src['estimate']} / {src['prior']} / {src['unplaced']} / {src['carried']} | {closures} |",
                  flush=True)


if __name__ == "__main__":
    main()
