"""The package's surface: the stubs name what the native module has, the
help explains the conventions, the batch call runs in parallel."""

from __future__ import annotations

import ast
import math
import pydoc
import threading
import time
from pathlib import Path

import numpy as np

import hough_heading as hh
from hough_heading import _core


def test_the_stub_names_the_native_module_s_items():
    stub = Path(_core.__file__).with_name("_core.pyi")
    if not stub.exists():  # an installed wheel keeps it beside the package
        stub = Path(hh.__file__).with_name("_core.pyi")
    tree = ast.parse(stub.read_text())
    named = {n.name for n in tree.body if isinstance(n, (ast.FunctionDef, ast.ClassDef))}
    public = {n for n in dir(_core) if not n.startswith("_")}
    assert named == public
    methods = {n.name for c in tree.body if isinstance(c, ast.ClassDef) for n in c.body
               if isinstance(n, ast.FunctionDef)}
    assert methods == {n for n in dir(_core.NativeReference) if not n.startswith("_")}


def test_help_explains_the_conventions():
    text = pydoc.render_doc(hh.estimate_scans, renderer=pydoc.plaintext)
    for needle in ("angle_min", "angle_increment", "max_range", "laser_offset",
                   "counter-clockwise", "dtheta", "turned left", "frame of scan 1",
                   "REP 117", "metres"):
        assert needle in text, needle
    assert "row 0 at the top" in hh.estimate_images.__doc__
    assert "y up" in hh.__doc__


def test_configurations_are_the_tool_s():
    assert hh.SIZES == (64, 128, 256) and hh.N_THETAS == (180, 360, 720)
    assert len(hh.CONFIGURATIONS) == 9


def room_pairs(n: int) -> list:
    rng = np.random.default_rng(11)
    angles = np.linspace(-math.pi / 2, math.pi / 2, 361)
    pairs = []
    for _ in range(n):
        turn = rng.uniform(-0.5, 0.5)
        r1 = 2 + np.abs(np.sin(3 * angles)) + rng.normal(0, 0.01, angles.size)
        r2 = 2 + np.abs(np.sin(3 * (angles + turn))) + rng.normal(0, 0.01, angles.size)
        s = lambda r: hh.Scan(r, float(angles[0]), float(angles[1] - angles[0]), 30.0)
        pairs.append((s(r1), s(r2)))
    return pairs


def test_batch_releases_the_gil_and_equals_single_calls():
    pairs = room_pairs(24)
    single = [hh.estimate_scans(a, b, size=128) for a, b in pairs]
    for threads in (1, 2, 0):
        assert hh.estimate_scans_batch(pairs, size=128, threads=threads) == single
    # While a batch runs, a Python thread keeps running (the GIL is free).
    ticks = []
    stop = threading.Event()

    def count():
        while not stop.is_set():
            ticks.append(time.perf_counter())
            time.sleep(0.001)

    t = threading.Thread(target=count)
    t.start()
    start = time.perf_counter()
    hh.estimate_scans_batch(pairs * 4, size=128, threads=1)
    end = time.perf_counter()
    stop.set()
    t.join()
    during = [x for x in ticks if start < x < end]
    assert len(during) > 0.2 * (end - start) / 0.001 * 0.5, (len(during), end - start)
