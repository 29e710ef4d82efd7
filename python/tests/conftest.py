"""Shared fixtures: the repository, the tool's binary, the data.

The tool's answers are the references: ``HOUGH_HEADING_BIN`` names the
binary, else ``target/release/hough-heading`` of the repository (built by
``cargo build --release --bin hough-heading``, as ``.ci/run`` does before).
The shared scan pairs are ``../shared/data`` beside the repository: absent,
their tests skip unless ``CI`` is set (then they fail).
"""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
LOGS = REPO / "cli" / "data" / "logs"
SHARED = REPO.parent / "shared" / "data"


def on_ci() -> bool:
    return os.environ.get("CI", "") not in ("", "0", "false")


@pytest.fixture(scope="session")
def tool() -> Path:
    path = Path(os.environ.get("HOUGH_HEADING_BIN", REPO / "target" / "release" / "hough-heading"))
    if not path.exists():
        if on_ci():
            pytest.fail(f"{path}: the tool is not built (cargo build --release --bin hough-heading)")
        pytest.skip(f"{path}: the tool is not built")
    return path


def run_tool(tool: Path, *args: str, check: bool = True) -> subprocess.CompletedProcess:
    out = subprocess.run([str(tool), *args], capture_output=True, text=True)
    if check and out.returncode != 0:
        raise AssertionError(f"{args}: exit {out.returncode}: {out.stderr}")
    return out


def json_lines(text: str) -> list:
    return [json.loads(line) for line in text.splitlines() if line.strip()]


@pytest.fixture(scope="session")
def shared_pair_files() -> list:
    files = sorted(SHARED.glob("*.jsonl"))
    if not files:
        if on_ci():
            pytest.fail(f"CI is set but {SHARED}/*.jsonl is missing")
        pytest.skip(f"{SHARED}/*.jsonl absent")
    return files
