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
  log's: the largest and the final (signed) difference, degrees.

Usage: python3 tools/stream_figures.py [--tool target/release/hough-heading]
       [--out DIR] [LOG ...]
"""

import argparse
import glob
import json
import os
import subprocess
import sys

import chain_scores

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


def run(tool, args, out_path):
    """The run's JSON lines, and its trajectory's headings (scan -> degrees)
    when it closed loops (the lines keep the chain's own)."""
    csv_path = out_path.replace(".jsonl", ".csv")
    with open(out_path, "w") as out:
        done = subprocess.run([tool, "log", "-q", "--summary", "--trajectory", csv_path] + args,
                              stdout=out, stderr=subprocess.PIPE, text=True, check=False)
    with open(out_path) as f:
        lines = [json.loads(line) for line in f if line.strip()]
    closed = "loop closures:" in done.stderr and os.path.exists(csv_path)
    return lines, chain_scores.trajectory_headings(csv_path) if closed else None


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
        truth_run = run(a.tool, [log, "--prior", "none"], os.path.join(a.out, f"{name}.truth.jsonl"))
        truth = chain_scores.log_headings(truth_run[0])
        for source, args in sources:
            for way, extra in ways:
                path = os.path.join(a.out, f"{name}.{source}.{way.replace(' ', '-').replace(',', '')}.jsonl")
                lines, corrected = run(a.tool, args + extra, path)
                s = chain_scores.score(lines, truth, corrected)
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
