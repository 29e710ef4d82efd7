#!/usr/bin/env python3
"""What "confident" means on real scan pairs: the issue-23 rows and the
confidence trade-off table, from the tool's own JSON lines and the pair
files' ground truth (standard library only; shares no code with the tool).

    python3 tools/confidence_table.py OUT_DIR PAIRS.jsonl...

OUT_DIR holds one `NAME.out` per pair file `NAME.jsonl`, the stdout of
`hough-heading scans NAME.jsonl` (see `tools/confidence.sh`, which runs the
tool and writes `docs/confidence.md`). An answer is *right* within 2° and
*wrong* beyond 5° of the ground truth's dθ; *flagged* means any status but
`confident`.
"""
import json
import math
import os
import sys


def wrap(d):
    d = math.fmod(d, 360.0)
    if d > 180.0:
        d -= 360.0
    if d <= -180.0:
        d += 360.0
    return d


def load(out_dir, pair_files):
    rows = []
    for path in pair_files:
        name = os.path.basename(path)[: -len(".jsonl")]
        truth = []
        with open(path, encoding="utf-8") as f:
            for line in f:
                line = line.strip()
                if not line:
                    continue
                d = json.loads(line)
                check = d.get("check", {})
                truth.append(
                    (
                        math.degrees(d["dtheta"]),
                        check.get("overlap_gt") or 0.0,
                        check.get("res_gt"),
                    )
                )
        with open(os.path.join(out_dir, name + ".out"), encoding="utf-8") as f:
            for line in f:
                o = json.loads(line)
                gt, overlap, res_gt = truth[o["index"]]
                est = o.get("dtheta_deg")
                err = 180.0 if est is None else abs(wrap(est - gt))
                rows.append(
                    {
                        "file": name,
                        "gt": gt,
                        "overlap_gt": overlap,
                        "res_gt": math.inf if res_gt is None else res_gt,
                        "err": err,
                        "status": o["status"],
                        "confidence": o.get("confidence") or 0.0,
                    }
                )
    return rows


def stats(rows):
    n = len(rows)
    if n == 0:
        return (0, float("nan"), float("nan"), float("nan"), float("nan"))
    within = sum(r["err"] <= 2.0 for r in rows)
    unflagged = [r for r in rows if r["status"] == "confident"]
    wrong = sum(r["err"] > 5.0 for r in unflagged)
    right_errs = sorted(r["err"] for r in rows if r["err"] <= 2.0)
    median = right_errs[len(right_errs) // 2] if right_errs else float("nan")
    return (
        n,
        100.0 * within / n,
        100.0 * (n - len(unflagged)) / n,
        100.0 * wrong / max(len(unflagged), 1),
        median,
    )


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    rows = load(sys.argv[1], sys.argv[2:])
    subsets = [
        ("all pairs", rows),
        ("\\|dθ\\| > 90°", [r for r in rows if abs(r["gt"]) > 90.0]),
        ("overlap ≥ 0.5", [r for r in rows if r["overlap_gt"] >= 0.5]),
        ("overlap 0.3–0.5", [r for r in rows if 0.3 <= r["overlap_gt"] < 0.5]),
        ("overlap < 0.3", [r for r in rows if r["overlap_gt"] < 0.3]),
        (
            "\\|dθ\\| > 90°, the truth aligns the scans (`res_gt` ≤ 0.2 m)",
            [r for r in rows if abs(r["gt"]) > 90.0 and r["res_gt"] <= 0.2],
        ),
        (
            "\\|dθ\\| > 90°, it does not (`res_gt` > 0.2 m)",
            [r for r in rows if abs(r["gt"]) > 90.0 and r["res_gt"] > 0.2],
        ),
    ]
    print("| subset | pairs | within 2° | flagged | wrong among unflagged | median error within 2° |")
    print("|---|---|---|---|---|---|")
    for name, sub in subsets:
        n, within, flagged, wrong, median = stats(sub)
        print(f"| {name} | {n} | {within:.1f} % | {flagged:.1f} % | {wrong:.2f} % | {median:.3f}° |")
    print()
    print("Confidence threshold → share of all pairs at or above it, and the share")
    print("of those more than 5° off (every status counted, a caller's own cut):")
    print()
    print("| confidence ≥ | kept | wrong among kept | kept, \\|dθ\\| > 90° | wrong among those |")
    print("|---|---|---|---|---|")
    big = [r for r in rows if abs(r["gt"]) > 90.0]
    for c in [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9]:
        kept = [r for r in rows if r["confidence"] >= c]
        kept_big = [r for r in big if r["confidence"] >= c]
        wrong = sum(r["err"] > 5.0 for r in kept)
        wrong_big = sum(r["err"] > 5.0 for r in kept_big)
        print(
            f"| {c:.1f} | {100.0 * len(kept) / max(len(rows), 1):.1f} % "
            f"| {100.0 * wrong / max(len(kept), 1):.2f} % "
            f"| {100.0 * len(kept_big) / max(len(big), 1):.1f} % "
            f"| {100.0 * wrong_big / max(len(kept_big), 1):.2f} % |"
        )


if __name__ == "__main__":
    main()
