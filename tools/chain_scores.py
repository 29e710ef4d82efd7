"""Scoring a `hough-heading log` run against a log's own headings, for
tools/drift_figures.py and tools/stream_figures.py."""

import collections
import csv
import math


def wrap(d):
    """An angle in degrees, wrapped into [-180, 180)."""
    return (d + 180.0) % 360.0 - 180.0


def log_headings(lines):
    """The log's heading of each scan, degrees (the first scan at 0), chained
    over the run's lines through each one's `log_pose` (consecutive or
    keyframe pairs)."""
    truth = {lines[0]["scan1"]: 0.0} if lines else {}
    for r in lines:
        if "log_pose" in r and r["scan1"] in truth:
            truth[r["scan2"]] = truth[r["scan1"]] + r["log_pose"]["dtheta_deg"]
    return truth


def trajectory_headings(csv_path):
    """Each scan's heading in a `--trajectory` CSV file, degrees."""
    with open(csv_path) as f:
        return {int(r["scan"]): math.degrees(float(r["theta"])) for r in csv.DictReader(f)}


def score(lines, truth, corrected=None):
    """The run's `lines` against `truth` (scan -> heading, degrees): over the
    lines whose two scans have a truth, the pairs within 2 deg, flagged, and
    confident and more than 5 deg off; the chained heading's error (the
    line's `chain.theta_deg`, or `corrected`'s heading of the scan where
    given: a run that closed loops), largest and last (signed), degrees; the
    share of scans whose truth lies within 2 sigma of the chained heading;
    the chain's steps by source. None when no line has a truth."""
    n = within = flagged = wrong = covered = 0
    sources = collections.Counter()
    largest = last = 0.0
    chained = False
    for r in lines:
        a, b = r.get("scan1"), r.get("scan2")
        if a not in truth or b not in truth:
            continue
        n += 1
        if r.get("dtheta_deg") is None:
            flagged += 1
        else:
            e = abs(wrap(r["dtheta_deg"] - (truth[b] - truth[a])))
            within += e <= 2.0
            if r["status"] != "confident":
                flagged += 1
            elif e > 5.0:
                wrong += 1
        chain = r.get("chain")
        if chain:
            chained = True
            sources[chain["source"]] += 1
            stated = wrap(chain["theta_deg"] - truth[b])
            covered += abs(stated) <= 2.0 * chain.get("heading_sigma_deg", 0.0)
            theta = corrected[b] if corrected and b in corrected else chain["theta_deg"]
            last = wrap(theta - truth[b])
            largest = max(largest, abs(last))
    if n == 0:
        return None
    return {
        "pairs": n,
        "within": 100.0 * within / n,
        "flagged": 100.0 * flagged / n,
        "wrong": wrong,
        "confident": n - flagged,
        "drift": (largest, last) if chained else None,
        "cover": 100.0 * covered / n,
        "sources": sources,
    }
