"""`log --trajectory out.tum` and the APE / RPE of `log --summary`: a numpy
re-implementation of evo's definitions on the written files, and evo itself
(`evo_ape`, `evo_rpe`) when installed (``.ci/run`` installs it)."""

from __future__ import annotations

import re
import shutil
import subprocess

import numpy as np
import pytest

from conftest import LOGS, on_ci, run_tool


def se3(rows: np.ndarray) -> np.ndarray:
    """TUM rows ``t x y z qx qy qz qw`` → 4 × 4 matrices."""
    out = np.zeros((len(rows), 4, 4))
    for k, (_, x, y, z, qx, qy, qz, qw) in enumerate(rows):
        out[k, :3, :3] = [
            [1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qz * qw), 2 * (qx * qz + qy * qw)],
            [2 * (qx * qy + qz * qw), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qx * qw)],
            [2 * (qx * qz - qy * qw), 2 * (qy * qz + qx * qw), 1 - 2 * (qx * qx + qy * qy)],
        ]
        out[k, :3, 3] = (x, y, z)
        out[k, 3, 3] = 1
    return out


def stats(e: np.ndarray) -> dict:
    return {"rmse": float(np.sqrt(np.mean(e ** 2))), "mean": float(e.mean()),
            "median": float(np.median(e)), "std": float(e.std()), "max": float(e.max())}


def evo_errors(est: np.ndarray, ref: np.ndarray) -> dict:
    P, Q = se3(est), se3(ref)
    inv = np.linalg.inv
    ape = np.array([np.linalg.norm((inv(q) @ p)[:3, 3]) for p, q in zip(P, Q)])
    E = [inv(inv(Q[i]) @ Q[i + 1]) @ (inv(P[i]) @ P[i + 1]) for i in range(len(P) - 1)]
    rpe = np.array([np.linalg.norm(e[:3, 3]) for e in E])
    ang = np.array([np.degrees(np.arccos(np.clip((np.trace(e[:3, :3]) - 1) / 2, -1, 1))) for e in E])
    return {"ape": stats(ape), "rpe": stats(rpe), "rpe_deg": stats(ang)}


def table_row(text: str, name: str) -> list:
    row = next(l for l in text.splitlines() if l.startswith(f"| {name} |"))
    return [float(c) for c in row.strip("|").split("|")[1:]]


@pytest.fixture(scope="module")
def trajectory(tool, tmp_path_factory):
    d = tmp_path_factory.mktemp("evo")
    out = run_tool(tool, "log", "-q", str(LOGS / "seattle-excerpt.log.gz"), "--summary",
                   "--trajectory", str(d / "est.tum"))
    est = np.loadtxt(d / "est.tum")
    ref = np.loadtxt(d / "est-reference.tum")
    odom = np.loadtxt(d / "est-odometry.tum")
    return d, out.stderr, est, ref, odom


def test_summary_errors_are_evo_s_definitions(trajectory):
    _, stderr, est, ref, odom = trajectory
    assert est.shape == ref.shape == odom.shape == (20, 8)
    assert np.array_equal(est[:, 0], ref[:, 0])
    for name, track in (("estimates", est), ("odometry", odom)):
        want = evo_errors(track, ref)
        got = table_row(stderr, name)
        # Columns: APE rmse mean median std max, RPE rmse mean max, rot rmse mean.
        expect = [want["ape"][k] for k in ("rmse", "mean", "median", "std", "max")]
        expect += [want["rpe"][k] for k in ("rmse", "mean", "max")]
        expect += [want["rpe_deg"][k] for k in ("rmse", "mean")]
        assert got == pytest.approx(expect, abs=6e-5), name


def evo_stat(output: str, name: str) -> float:
    return float(re.search(rf"^\s*{name}\s+([0-9.eE+-]+)\s*$", output, re.M).group(1))


def test_evo_itself_agrees(trajectory):
    if shutil.which("evo_ape") is None:
        if on_ci():
            pytest.fail("evo is not installed in the CI environment (pip install evo)")
        pytest.skip("evo not installed (pip install evo)")
    d, stderr, *_ = trajectory
    row = table_row(stderr, "estimates")
    ref, est = str(d / "est-reference.tum"), str(d / "est.tum")
    ape = subprocess.run(["evo_ape", "tum", ref, est], capture_output=True, text=True, check=True)
    rpe = subprocess.run(["evo_rpe", "tum", ref, est], capture_output=True, text=True, check=True)
    rot = subprocess.run(["evo_rpe", "tum", ref, est, "--pose_relation", "angle_deg"],
                         capture_output=True, text=True, check=True)
    assert evo_stat(ape.stdout, "rmse") == pytest.approx(row[0], abs=6e-5)
    assert evo_stat(ape.stdout, "max") == pytest.approx(row[4], abs=6e-5)
    assert evo_stat(rpe.stdout, "rmse") == pytest.approx(row[5], abs=6e-5)
    assert evo_stat(rot.stdout, "rmse") == pytest.approx(row[8], abs=6e-4)
