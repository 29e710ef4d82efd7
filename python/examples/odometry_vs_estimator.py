"""The estimator against the odometry on the bundled Seattle excerpt
(`cli/data/logs/seattle-excerpt.log.gz`: 20 real scans, the log's corrected
poses as the reference, a synthetic drifting odometry).

For each consecutive pair of scans it compares the heading change and the
displacement of the estimator and of the odometry with the log's poses,
chains both into trajectories, and draws them with matplotlib (Agg, no
display needed):

    python python/examples/odometry_vs_estimator.py --out odometry_vs_estimator.png [--check]

`--check` exits non-zero unless the estimator's heading errors are smaller
than the odometry's (CI runs it so).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import hough_heading as hh  # noqa: E402

REPO = Path(__file__).resolve().parents[2]


def between(p, q):
    """Pose ``q`` in the frame of pose ``p`` (x, y, theta)."""
    c, s = math.cos(p[2]), math.sin(p[2])
    dx, dy = q[0] - p[0], q[1] - p[1]
    return (c * dx + s * dy, -s * dx + c * dy, math.remainder(q[2] - p[2], math.tau))


def compose(p, d):
    """``p ⊕ d``: the step ``d`` (in the frame of ``p``) in the world."""
    c, s = math.cos(p[2]), math.sin(p[2])
    return (p[0] + c * d[0] - s * d[1], p[1] + s * d[0] + c * d[1],
            math.remainder(p[2] + d[2], math.tau))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--log", default=str(REPO / "cli/data/logs/seattle-excerpt.log.gz"))
    ap.add_argument("--out", default="odometry_vs_estimator.png")
    ap.add_argument("--check", action="store_true")
    args = ap.parse_args()

    log = hh.read_log(args.log)
    pairs = list(zip(log, log[1:]))
    estimates = hh.estimate_scans_batch(pairs)  # threads, GIL released

    truth = [between(a.log_pose, b.log_pose) for a, b in pairs]
    odom = [between(a.odom, b.odom) for a, b in pairs]
    rows = []
    chain_est, chain_odom, chain_true = [(0.0, 0.0, 0.0)], [(0.0, 0.0, 0.0)], [(0.0, 0.0, 0.0)]
    for e, t, o in zip(estimates, truth, odom):
        # The estimate when confident, else the odometry's step; in a
        # corridor (`unobservable`: the direction the scans cannot fix) the
        # odometry gives the component along it (as `log --trajectory`).
        if e.ok and e.translation_m is not None:
            dx, dy = e.translation_m
            u = e.to_dict().get("unobservable")
            if u is not None:
                along = (o[0] - dx) * u[0] + (o[1] - dy) * u[1]
                dx, dy = dx + along * u[0], dy + along * u[1]
            step = (dx, dy, e.dtheta_rad)
        else:
            step = o
        chain_est.append(compose(chain_est[-1], step))
        chain_odom.append(compose(chain_odom[-1], o))
        chain_true.append(compose(chain_true[-1], t))
        rows.append((
            abs(math.degrees(math.remainder(e.dtheta_rad - t[2], math.tau))),
            abs(math.degrees(math.remainder(o[2] - t[2], math.tau))),
            math.dist(e.translation_m, t[:2]) if e.translation_m else math.nan,
            math.dist(o[:2], t[:2]),
            e.status,
        ))
    err = np.array([r[:4] for r in rows], dtype=float)
    ape = lambda chain: float(np.sqrt(np.mean(
        [math.dist(p[:2], q[:2]) ** 2 for p, q in zip(chain, chain_true)])))
    print(f"{args.log}: {len(log)} scans, {len(pairs)} consecutive pairs, "
          f"{sum(r[4] == 'confident' for r in rows)} confident")
    print(f"heading error per pair (deg), median / max: estimator {np.median(err[:, 0]):.3f} / "
          f"{err[:, 0].max():.3f}, odometry {np.median(err[:, 1]):.3f} / {err[:, 1].max():.3f}")
    print(f"step error per pair (m), median: estimator {np.nanmedian(err[:, 2]):.4f}, "
          f"odometry {np.median(err[:, 3]):.4f}")
    print(f"chained trajectory APE RMSE (m): estimator {ape(chain_est):.4f}, "
          f"odometry {ape(chain_odom):.4f}")

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(12, 5))
    for chain, label, style in ((chain_true, "log poses (corrected)", "g-"),
                                (chain_odom, "odometry", "C1-"),
                                (chain_est, "estimates, chained", "C0.-")):
        xy = np.array(chain)
        ax1.plot(xy[:, 0], xy[:, 1], style, label=label, lw=4 if style == "g-" else 2)
    pts = log[0].points()
    pts = pts[np.hypot(pts[:, 0], pts[:, 1]) < 10.0]  # the room, not the far returns
    ax1.scatter(pts[:, 0], pts[:, 1], s=1, c="0.6", label="scan 0")
    ax1.set_aspect("equal")
    ax1.set_xlabel("x (m)")
    ax1.set_ylabel("y (m)")
    ax1.legend(loc="best", fontsize=8)
    ax1.set_title("trajectories from the first scan's pose")
    k = np.arange(len(rows))
    ax2.bar(k - 0.2, err[:, 0], 0.4, label="estimator")
    ax2.bar(k + 0.2, err[:, 1], 0.4, label="odometry")
    ax2.set_xlabel("pair (scan k → k + 1)")
    ax2.set_ylabel("|heading error| (deg)")
    ax2.legend()
    ax2.set_title("heading change vs the log's poses")
    fig.tight_layout()
    fig.savefig(args.out, dpi=100)
    print(f"figure: {args.out}")
    if args.check and not (np.median(err[:, 0]) < np.median(err[:, 1])
                           and ape(chain_est) < ape(chain_odom)):
        print("check failed: the estimator does not beat the odometry", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
