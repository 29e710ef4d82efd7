#!/usr/bin/env python3
"""Two independent checks on the raw beams of the shared scan pairs (issue 23).

Pure Python (no numpy); nothing shared with the library. Both read the tool's
output for the pair files of a directory (one `NAME.out` per `NAME.jsonl`):

    mkdir -p /tmp/out
    for f in ../shared/data/*.jsonl; do
      target/eval/hough-heading scans "$f" -q > /tmp/out/$(basename "$f" .jsonl).out
    done

`refine DATA OUT`: the floor of a refinement on the beams (issue 23 item 7).
For the pairs with overlap_gt >= 0.5 whose estimate is within 2 degrees, a
point-to-line ICP (PLICP-style: each scan-2 end point against the segment
between the two scan-1 beams around its bearing, trimmed at 3x the median
residual) refines (a) the estimate and (b) the ground truth itself. Prints
the median rotation error of the estimate, of the refined estimate, and how
far the refinement moves the ground truth (the agreement floor between a
beam-level fit and the file's truth).

`violations DATA OUT`: for the confident answers more than 5 degrees wrong,
the share of each scan's end points that the other scan's beams saw through
(nearer to the other sensor than every one of its three nearest beams' ranges
by 0.1 m + r/32), the larger of the two directions, at the ground truth and
at the estimate. The estimate's translation is the reported one, which drops
any unobservable component, so pairs with an unobservable direction are
listed apart.
"""
import glob
import json
import math
import os
import statistics
import sys


def points(scan):
    """End points in the laser frame, None for beams without a return."""
    out = []
    for i, r in enumerate(scan["ranges"]):
        if r is None or not (0 < r < scan["max_range"]):
            out.append(None)
            continue
        a = scan["angle_min"] + i * scan["angle_increment"]
        out.append((r * math.cos(a), r * math.sin(a)))
    return out


def compose(a, b):
    x, y, t = a
    u, v, s = b
    return (x + math.cos(t) * u - math.sin(t) * v, y + math.sin(t) * u + math.cos(t) * v, t + s)


def inverse(a):
    x, y, t = a
    c, s = math.cos(t), math.sin(t)
    return (-(c * x + s * y), -(-s * x + c * y), -t)


def laser_pose(s1, s2, robot):
    """Pose of laser 2 in laser 1's frame from the robot pose of scan 2 in scan 1."""
    return compose(compose(inverse(tuple(s1["laser_offset"])), robot), tuple(s2["laser_offset"]))


def robot_pose(s1, s2, laser):
    return compose(compose(tuple(s1["laser_offset"]), laser), inverse(tuple(s2["laser_offset"])))


def solve3(a, b):
    m = [a[i][:] + [b[i]] for i in range(3)]
    for c in range(3):
        p = max(range(c, 3), key=lambda r: abs(m[r][c]))
        if abs(m[p][c]) < 1e-12:
            return None
        m[c], m[p] = m[p], m[c]
        for r in range(3):
            if r != c:
                f = m[r][c] / m[c][c]
                for k in range(c, 4):
                    m[r][k] -= f * m[c][k]
    return [m[i][3] / m[i][i] for i in range(3)]


def plicp(s1, s2, robot, iterations=10):
    """Point-to-line ICP of scan 2's end points on scan 1's beam segments."""
    p1, p2 = points(s1), points(s2)
    x, y, t = laser_pose(s1, s2, robot)
    amin, inc, n = s1["angle_min"], s1["angle_increment"], len(p1)
    for _ in range(iterations):
        c, s = math.cos(t), math.sin(t)
        rows = []
        for q in p2:
            if q is None:
                continue
            px, py = x + c * q[0] - s * q[1], y + s * q[0] + c * q[1]
            j = int(math.floor((math.atan2(py, px) - amin) / inc))
            best = None
            for k in (j - 1, j, j + 1):
                if k < 0 or k + 1 >= n or p1[k] is None or p1[k + 1] is None:
                    continue
                (ax, ay), (bx, by) = p1[k], p1[k + 1]
                length = math.hypot(bx - ax, by - ay)
                if not 1e-6 < length <= 0.5:
                    continue
                nx, ny = -(by - ay) / length, (bx - ax) / length
                r = (px - ax) * nx + (py - ay) * ny
                if best is None or abs(r) < abs(best[0]):
                    best = (r, nx, ny, q)
            if best:
                rows.append(best)
        if len(rows) < 10:
            return None
        residuals = sorted(abs(r[0]) for r in rows)
        trim = max(0.02, min(0.3, 3 * residuals[len(residuals) // 2]))
        a = [[0.0] * 3 for _ in range(3)]
        b = [0.0] * 3
        for r, nx, ny, q in rows:
            if abs(r) > trim:
                continue
            jac = (nx, ny, nx * (-s * q[0] - c * q[1]) + ny * (c * q[0] - s * q[1]))
            for i in range(3):
                b[i] -= jac[i] * r
                for k in range(3):
                    a[i][k] += jac[i] * jac[k]
        step = solve3(a, b)
        if step is None:
            return None
        x, y, t = x + step[0], y + step[1], t + step[2]
    return robot_pose(s1, s2, (x, y, t))


def seen_through(sa, sb, robot):
    """Share of scan b's end points that scan a's beams saw through."""
    x, y, t = laser_pose(sa, sb, robot)
    c, s = math.cos(t), math.sin(t)
    ra, amin, inc = sa["ranges"], sa["angle_min"], sa["angle_increment"]

    def valid(k):
        return 0 <= k < len(ra) and ra[k] is not None and 0 < ra[k] < sa["max_range"]

    count = through = 0
    for q in points(sb):
        if q is None:
            continue
        px, py = x + c * q[0] - s * q[1], y + s * q[0] + c * q[1]
        r = math.hypot(px, py)
        j = int(round((math.atan2(py, px) - amin) / inc))
        count += 1
        if all(valid(k) for k in (j - 1, j, j + 1)):
            nearest = min(ra[k] for k in (j - 1, j, j + 1))
            through += r < nearest - 0.1 - nearest / 32
    return through / max(1, count)


def violation(pair, robot):
    s1, s2 = pair["scan1"], pair["scan2"]
    return max(seen_through(s1, s2, robot), seen_through(s2, s1, inverse(robot)))


def angle_error(a_deg, b_deg):
    return abs((a_deg - b_deg + 180) % 360 - 180)


def rows(data, out):
    for path in sorted(glob.glob(os.path.join(out, "*.out"))):
        name = os.path.basename(path)[:-4]
        with open(os.path.join(data, name + ".jsonl")) as f:
            pairs = [json.loads(line) for line in f]
        with open(path) as f:
            for line in f:
                r = json.loads(line)
                if "dtheta_deg" in r:
                    yield name, r, pairs[r["index"]]


def refine(data, out):
    before, after, floor = [], [], []
    for _, r, pair in rows(data, out):
        if (pair["check"].get("overlap_gt") or 0) < 0.5 or "dx_m" not in r:
            continue
        truth = math.degrees(pair["dtheta"])
        error = angle_error(r["dtheta_deg"], truth)
        if error > 2:
            continue
        s1, s2 = pair["scan1"], pair["scan2"]
        refined = plicp(s1, s2, (r["dx_m"], r["dy_m"], math.radians(r["dtheta_deg"])))
        before.append(error)
        after.append(error if refined is None else angle_error(math.degrees(refined[2]), truth))
        from_truth = plicp(s1, s2, (pair["dx"], pair["dy"], pair["dtheta"]))
        if from_truth is not None:
            floor.append(angle_error(math.degrees(from_truth[2]), truth))
    print(f"pairs: {len(before)} (overlap_gt >= 0.5, estimate within 2 degrees)")
    print(f"median rotation error, estimate:         {statistics.median(before):.3f} deg")
    print(f"median rotation error, refined on beams: {statistics.median(after):.3f} deg")
    print(f"median move of the truth refined on beams: {statistics.median(floor):.3f} deg")


def violations(data, out):
    groups = {False: [], True: []}
    for _, r, pair in rows(data, out):
        if r["status"] != "confident" or "dx_m" not in r:
            continue
        if angle_error(r["dtheta_deg"], math.degrees(pair["dtheta"])) <= 5:
            continue
        truth = (pair["dx"], pair["dy"], pair["dtheta"])
        estimate = (r["dx_m"], r["dy_m"], math.radians(r["dtheta_deg"]))
        groups["unobservable" in r].append((violation(pair, truth), violation(pair, estimate)))
    for unobservable, values in groups.items():
        if not values:
            continue
        label = "with an unobservable direction" if unobservable else "observable"
        print(
            f"confident and wrong, {label}: {len(values)} pairs; median seen-through share "
            f"at the truth {statistics.median(v[0] for v in values):.3f}, "
            f"at the estimate {statistics.median(v[1] for v in values):.3f}; "
            f"truth below estimate in {sum(v[0] < v[1] for v in values)}"
        )


if __name__ == "__main__":
    if len(sys.argv) != 4 or sys.argv[1] not in ("refine", "violations"):
        sys.exit(__doc__)
    {"refine": refine, "violations": violations}[sys.argv[1]](sys.argv[2], sys.argv[3])
