#!/usr/bin/env python3
"""The stream figures of docs/stream.md (issue 39): whole logs and their
raw lidar captures, consecutive pairs and keyframes, scored against the
logs' corrected poses.

For each CARMEN log given (default: ../shared/data/logs/*.log.gz) it writes
the log as an LD06 and an RPLIDAR capture (tools/log_captures.py: 360
points a turn, clockwise, 0 = no return), runs `hough-heading log` on the
log and on both captures in five ways (`--prior none`: the pairs alone;
the default, which on these logs kept every metre is consecutive pairs
with the motion prior and loop closures; the same without closures;
keyframes without and with loop closures), and
prints one markdown table row per log, source and way:

- within 2 deg, flagged, confident and > 5 deg off (count / confident),
  over the pairs (the truth of a pair is the difference of the log's
  corrected headings of its two scans; capture revolution i is log scan i);
- the chained heading (the line's `chain.theta_deg`, or the corrected
  trajectory, `--trajectory`, where the run closed loops) against the
  log's: the largest and the final difference, degrees.

Usage: python3 tools/stream_figures.py [--tool target/release/hough-heading]
       [--out DIR] [LOG ...]
"""

import argparse
import csv
import glob
import json
import math
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


def wrap(d):
    return (d + 180.0) % 360.0 - 180.0


def run(tool, args, out_path):
    """The run's JSON lines, and its trajectory's headings (scan -> degrees)
    when it closed loops (the lines keep the chain's own)."""
    csv_path = out_path.replace(".jsonl", ".csv")
    with open(out_path, "w") as out:
        done = subprocess.run([tool, "log", "-q", "--summary", "--trajectory", csv_path] + args,
                              stdout=out, stderr=subprocess.PIPE, text=True, check=False)
    with open(out_path) as f:
        lines = [json.loads(line) for line in f if line.strip()]
    corrected = None
    if "loop closures:" in done.stderr and os.path.exists(csv_path):
        with open(csv_path) as f:
            corrected = {int(r["scan"]): math.degrees(float(r["theta"])) for r in csv.DictReader(f)}
    return lines, corrected


def headings(carmen_lines):
    """The log's corrected heading of each scan (degrees, scan 0 = 0)."""
    step = {r["scan2"]: r["log_pose"]["dtheta_deg"] for r in carmen_lines if "log_pose" in r}
    heading = {0: 0.0}
    for i in sorted(step):
        if i - 1 in heading:
            heading[i] = heading[i - 1] + step[i]
    return heading


def score(run_result, heading):
    lines, corrected = run_result
    n = within = flagged = wrong = 0
    drift_max = drift_end = 0.0
    chained = False
    for r in lines:
        a, b = r.get("scan1"), r.get("scan2")
        if a not in heading or b not in heading:
            continue
        n += 1
        if r.get("dtheta_deg") is None:
            flagged += 1
            continue
        err = abs(wrap(r["dtheta_deg"] - (heading[b] - heading[a])))
        within += err <= 2.0
        if r["status"] != "confident":
            flagged += 1
        elif err > 5.0:
            wrong += 1
        chain = r.get("chain")
        if chain:
            chained = True
            theta = corrected[b] if corrected and b in corrected else chain["theta_deg"]
            drift_end = abs(wrap(theta - heading[b]))
            drift_max = max(drift_max, drift_end)
    if n == 0:
        return None
    return {
        "pairs": n,
        "within": 100.0 * within / n,
        "flagged": 100.0 * flagged / n,
        "wrong": wrong,
        "confident": n - flagged,
        "drift": (drift_max, drift_end) if chained else None,
    }


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--tool", default=os.path.join(ROOT, "target/release/hough-heading"))
    p.add_argument("--out", default=os.path.join(ROOT, "target/stream-figures"))
    p.add_argument("logs", nargs="*")
    a = p.parse_args()
    logs = a.logs or sorted(glob.glob(os.path.join(ROOT, "../shared/data/logs/*.log.gz")))
    if not logs:
        sys.exit("no logs: give them, or put ../shared/data/logs next to the repository")
    os.makedirs(a.out, exist_ok=True)
    ways = [
        ("pairs alone", ["--prior", "none"]),
        ("default", []),
        ("consecutive, no loops", ["--pairs", "consecutive", "--no-loops"]),
        ("keyframes", ["--keyframes", "--no-loops"]),
        ("keyframes + loops", ["--keyframes", "--loops"]),
    ]
    print("| log | source | way | pairs | within 2° | flagged | confident > 5° off | heading drift max / end (°) |")
    print("|---|---|---|---|---|---|---|---|")
    for log in logs:
        name = os.path.basename(log).split(".")[0]
        sources = [("CARMEN", [log])]
        for protocol in ("ld06", "rplidar"):
            capture = os.path.join(a.out, f"{name}.{protocol}")
            subprocess.run(
                [sys.executable, os.path.join(HERE, "log_captures.py"), log, "--protocol", protocol, "--out", capture],
                check=True,
                stdout=subprocess.DEVNULL,
            )
            sources.append((protocol.upper() if protocol == "ld06" else "RPLIDAR", [capture, "--format", protocol]))
        truth = headings(run(a.tool, [log, "--prior", "none"], os.path.join(a.out, f"{name}.truth.jsonl"))[0])
        for source, args in sources:
            for way, extra in ways:
                path = os.path.join(a.out, f"{name}.{source}.{way.replace(' ', '-').replace(',', '')}.jsonl")
                s = score(run(a.tool, args + extra, path), truth)
                if s is None:
                    continue
                drift = "–" if s["drift"] is None else "%.1f / %.1f" % s["drift"]
                print(
                    f"| {name} | {source} | {way} | {s['pairs']} | {s['within']:.1f} % | {s['flagged']:.1f} % "
                    f"| {s['wrong']} / {s['confident']} | {drift} |"
                )
                sys.stdout.flush()


if __name__ == "__main__":
    main()
