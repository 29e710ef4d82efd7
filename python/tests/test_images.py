"""Images through Python give the library's answers (the tool's `images
--json`), and a `Reference` answers as a pair."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import hough_heading as hh
from conftest import REPO, run_tool

IMAGES = REPO / "cli" / "data" / "images"


def read_pbm(path) -> np.ndarray:
    """PBM P1 or P4 (the bundled images) as booleans."""
    data = path.read_bytes()
    tokens = []
    i = 0
    magic = data[:2]
    i = 2
    while len(tokens) < 2:
        while data[i:i + 1].isspace():
            i += 1
        if data[i:i + 1] == b"#":
            while data[i:i + 1] not in (b"\n", b""):
                i += 1
            continue
        j = i
        while not data[j:j + 1].isspace():
            j += 1
        tokens.append(int(data[i:j]))
        i = j
    w, h = tokens
    if magic == b"P4":
        i += 1
        rows = np.frombuffer(data[i:i + h * ((w + 7) // 8)], dtype=np.uint8).reshape(h, -1)
        return np.unpackbits(rows, axis=1)[:, :w].astype(bool)
    digits = [c for c in data[i:].decode() if c in "01"]
    return np.array(digits[: w * h], dtype=int).reshape(h, w).astype(bool)


def write_pbm(path, a: np.ndarray) -> None:
    h, w = a.shape
    body = "\n".join(" ".join("1" if v else "0" for v in row) for row in a)
    path.write_text(f"P1\n{w} {h}\n{body}\n")


def tool_json(tool, a, b, *options):
    return json.loads(run_tool(tool, "images", "--json", str(a), str(b), *options).stdout)


def l_shape(size: int, turn_deg: float, shift=(0.0, 0.0)) -> np.ndarray:
    """An L of two walls, turned counter-clockwise by ``turn_deg`` about the
    grid centre and shifted (cells, x right, y up)."""
    g = np.zeros((size, size), dtype=bool)
    c, s = math.cos(math.radians(turn_deg)), math.sin(math.radians(turn_deg))
    pts = [(t - 30.0, -20.0) for t in np.arange(0, 60, 0.25)]
    pts += [(-30.0, t - 20.0) for t in np.arange(0, 40, 0.25)]
    pts += [(10.0 + t / 3, 5.0) for t in np.arange(0, 30, 0.25)]
    for x, y in pts:
        xr, yr = c * x - s * y + shift[0], s * x + c * y + shift[1]
        col = int(round(xr + (size - 1) / 2))
        row = int(round((size - 1) / 2 - yr))
        if 0 <= col < size and 0 <= row < size:
            g[row, col] = True
    return g


def test_bundled_pbm_images_equal_the_tool(tool):
    for name in ("corridor", "polygon", "room"):
        a_path, b_path = IMAGES / f"{name}-a.pbm", IMAGES / f"{name}-b.pbm"
        a, b = read_pbm(a_path), read_pbm(b_path)
        for options, kwargs in [((), {}), (("--n-theta", "720", "--no-verify"),
                                           {"n_theta": 720, "verify": False}),
                                (("--mode", "paper"), {"mode": "paper"})]:
            want = tool_json(tool, a_path, b_path, *options)
            got = hh.estimate_images(a, b, **kwargs)
            assert got.to_dict() == want, name
            assert got.kind == "images"


def test_synthetic_turns_equal_the_tool_and_the_truth(tool, tmp_path):
    rng = np.random.default_rng(7)
    for k in range(4):
        turn = float(rng.uniform(-179, 179))
        shift = tuple(rng.uniform(-6, 6, 2))
        a, b = l_shape(128, 0.0), l_shape(128, turn, shift)
        pa, pb = tmp_path / f"a{k}.pbm", tmp_path / f"b{k}.pbm"
        write_pbm(pa, a)
        write_pbm(pb, b.astype(np.uint8))
        e = hh.estimate_images(a, b.astype(np.int64))
        assert e.to_dict() == tool_json(tool, pa, pb)
        err = (e.alpha_deg - turn + 180) % 360 - 180
        assert abs(err) < 1.0, (turn, e)
        assert e.translation_cells == pytest.approx(shift, abs=1.5)
        assert e.alpha_rad == pytest.approx(math.radians(e.alpha_deg))
        assert e.dtheta_deg == pytest.approx(-e.alpha_deg)


def test_scale_search_and_fit_centre_equal_the_tool(tool, tmp_path):
    a = l_shape(128, 0.0)
    b = l_shape(128, 40.0)
    small = b[14:114, 14:114]  # 100 × 100: only with fit='centre'
    pa, pb = tmp_path / "a.pbm", tmp_path / "b.pbm"
    write_pbm(pa, a)
    write_pbm(pb, small)
    got = hh.estimate_images(a, small, fit="centre", scale_search=(0.9, 1.1))
    want = tool_json(tool, pa, pb, "--fit", "centre", "--scale-search", "0.9:1.1")
    assert got.to_dict() == want
    assert got.scale == want["scale"]


def test_reference_bytes_round_trip_and_answers_as_a_pair():
    a, b = l_shape(128, 0.0), l_shape(128, 75.0, (3.0, -2.0))
    for n_theta, mode in [(360, "improved"), (180, "paper"), (720, "improved")]:
        ref = hh.Reference.prepare(a, n_theta=n_theta, mode=mode)
        assert (ref.size, ref.n_theta, ref.mode) == (128, n_theta, mode)
        assert np.array_equal(ref.grid, a)
        data = ref.to_bytes()
        if (n_theta, mode) == (360, "improved"):
            assert len(data) == 3824  # the README's figure for 128², N_θ 360
        again = hh.Reference.from_bytes(data)
        assert again.to_bytes() == data
        assert (again.size, again.n_theta, again.mode) == (128, n_theta, mode)
        pair = hh.estimate_images(a, b, n_theta=n_theta, mode=mode)
        assert ref.estimate(b) == pair
        assert again.estimate(b) == pair
        no_verify = hh.estimate_images(a, b, n_theta=n_theta, mode=mode, verify=False)
        assert again.estimate(b, verify=False) == no_verify


def test_batch_equals_single_calls():
    rng = np.random.default_rng(3)
    pairs = [(l_shape(64, 0.0), l_shape(64, float(rng.uniform(-180, 180)))) for _ in range(6)]
    pairs.append((l_shape(64, 0.0), np.zeros((64, 64), dtype=bool)))  # nothing in b
    got = hh.estimate_images_batch(pairs, threads=2)
    for (a, b), g in zip(pairs[:-1], got):
        assert g == hh.estimate_images(a, b)
    assert got[-1].status == "error" and "no occupied pixel" in got[-1].error
