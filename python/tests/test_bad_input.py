"""Bad input is a Python exception with a message, never a crash; a seeded
random run of hostile arrays leaves the process alive."""

from __future__ import annotations

import math
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import hough_heading as hh


def scan(ranges, **kw):
    d = dict(ranges=ranges, angle_min=-math.pi / 2, angle_increment=math.pi / 180, max_range=30.0)
    d.update(kw)
    return d


GOOD = scan(np.r_[np.full(90, 2.0), np.full(91, 3.0)])


def grid(size=64):
    g = np.zeros((size, size), dtype=bool)
    g[10, 5:50] = True
    g[10:40, 5] = True
    return g


@pytest.mark.parametrize(
    "a, message",
    [
        (np.zeros((64, 64, 1), dtype=bool), "2-D"),
        (np.zeros(64, dtype=bool), "2-D"),
        (np.zeros((64, 64), dtype=np.float32), "dtype float32"),
        (np.full((64, 64), 2, dtype=np.int32), "only 0 and 1"),
        (np.full((64, 64), -1, dtype=np.int8), "only 0 and 1"),
        (np.array([["a"] * 64] * 64), "dtype"),
        (np.zeros((100, 100), dtype=bool), "accepted: square grids of side 64, 128, 256"),
        (np.zeros((64, 128), dtype=bool), "accepted: square grids of side 64, 128, 256"),
        (np.zeros((128, 128), dtype=bool), "differs from a's \\(64, 64\\)"),
        (np.zeros((64, 64), dtype=bool), "no occupied pixel"),
    ],
)
def test_bad_images_are_value_errors(a, message):
    with pytest.raises(ValueError, match=message):
        hh.estimate_images(grid(), a)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"n_theta": 361}, "no compiled configuration"),
        ({"n_theta": "360"}, "n_theta"),
        ({"mode": "fast"}, "mode"),
        ({"thresholds": {"rival_ratio": 1.5}}, "must be in \\[0, 1\\]"),
        ({"thresholds": {"alignment_ratio": 9}}, "must be in \\[1, 4\\]"),
        ({"thresholds": {"nope": 1}}, "unknown"),
        ({"thresholds": {"min_overlap": float("nan")}}, "finite"),
        ({"thresholds": hh.Thresholds(direction_margin=-0.5)}, "must be in \\[0, 1\\]"),
        ({"scale_search": (0.1, 3.0)}, "0.5"),
        ({"scale_search": "yes"}, "scale_search"),
        ({"fit": "stretch"}, "fit"),
        ({"size": 100, "fit": "centre"}, "size"),
    ],
)
def test_bad_image_options_are_value_errors(kwargs, message):
    with pytest.raises(ValueError, match=message):
        hh.estimate_images(grid(), grid(), **kwargs)


@pytest.mark.parametrize(
    "bad, message",
    [
        (scan([]), "no beams"),
        (scan(np.zeros((3, 3))), "1-D"),
        (scan([1.0, -2.0, 3.0]), "range 1 is -2: ranges are distances"),
        (scan(["a", "b"]), "dtype"),
        (scan([1.0] * 10, angle_min=float("nan")), "angle_min"),
        (scan([1.0] * 10, angle_increment=0.0), "angle_increment is 0"),
        (scan([1.0] * 10, angle_increment=float("inf")), "angle_increment"),
        (scan([1.0] * 10, max_range=-1.0), "max_range"),
        (scan([1.0] * 10, max_range=1e300), "max_range"),
        (scan([1.0] * 10, laser_offset=(0, 0)), "laser_offset"),
        (scan([1.0] * 10, laser_offset=(0, 0, "x")), "laser_offset"),
        ({"ranges": [1.0]}, "missing 'angle_min'"),
        (object(), "missing 'ranges'"),
    ],
)
def test_bad_scans_are_value_errors(bad, message):
    with pytest.raises(ValueError, match=message):
        hh.estimate_scans(GOOD, bad, size=64)
    with pytest.raises(ValueError, match="pair 1: scan2"):
        hh.estimate_scans_batch([(GOOD, GOOD), (GOOD, bad)], size=64)


def test_nan_ranges_are_dropped_as_the_tool_does_or_refused():
    ranges = GOOD["ranges"].copy()
    ranges[::3] = np.nan
    ranges[1::7] = np.inf
    e = hh.estimate_scans(GOOD, scan(ranges), size=64)
    assert e.dropped[1]["not_finite"] == int(np.sum(~np.isfinite(ranges)))
    with pytest.raises(ValueError, match="range 0 is NaN"):
        hh.estimate_scans(GOOD, scan(ranges), size=64, nan="raise")
    # A scan with no usable beam is an answer (no structure), not an error.
    e = hh.estimate_scans(GOOD, scan(np.full(181, np.nan)), size=64)
    assert e.status == "no_structure"


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"size": 100}, "size"),
        ({"cell": 0.0}, "cell"),
        ({"cell": -1}, "cell"),
        ({"connect": -0.1}, "connect"),
        ({"connect": float("nan")}, "connect"),
        ({"nan": "ignore"}, "nan"),
        ({"prior": (10.0, 0.0)}, "prior"),
        ({"prior": (10.0,)}, "prior"),
        ({"n_theta": 100}, "no compiled configuration"),
    ],
)
def test_bad_scan_options_are_value_errors(kwargs, message):
    with pytest.raises(ValueError, match=message):
        hh.estimate_scans(GOOD, GOOD, **kwargs)


def test_bad_references_are_value_errors():
    ref = hh.Reference.prepare(grid(64))
    with pytest.raises(ValueError, match="this reference is 64×64"):
        ref.estimate(np.zeros((128, 128), dtype=bool))
    with pytest.raises(ValueError, match="no occupied cell"):
        ref.estimate(np.zeros((64, 64), dtype=bool))
    with pytest.raises(ValueError, match="accepted"):
        hh.Reference.prepare(np.ones((65, 65), dtype=bool))
    data = bytearray(ref.to_bytes())
    with pytest.raises(ValueError, match="too short"):
        hh.Reference.from_bytes(bytes(data[:5]))
    with pytest.raises(ValueError, match="HHR"):
        hh.Reference.from_bytes(b"XXXX" + bytes(data[4:]))
    corrupt = bytearray(data)
    corrupt[100] ^= 0xFF
    with pytest.raises(ValueError, match="not a reference of this configuration"):
        hh.Reference.from_bytes(bytes(corrupt))
    with pytest.raises(ValueError, match="buffer too small|needs|bytes"):
        hh.Reference.from_bytes(bytes(data[:-10]))
    other = bytearray(data)
    other[4:6] = (100).to_bytes(2, "little")
    other[6:8] = (100).to_bytes(2, "little")
    with pytest.raises(ValueError, match="100×100 grid .* not compiled"):
        hh.Reference.from_bytes(bytes(other))
    version = bytearray(data)
    version[3] = ord("2")
    with pytest.raises(ValueError, match="format 2, this library reads format 3"):
        hh.Reference.from_bytes(bytes(version))
    with pytest.raises(ValueError, match="bytes"):
        hh.Reference.from_bytes("HHR3")  # type: ignore[arg-type]
    paper = hh.Reference.prepare(grid(64), mode="paper")
    assert paper.mode == "paper"
    assert paper.estimate(grid(64)) == hh.estimate_images(grid(64), grid(64), mode="paper")


def test_bad_log_input_is_an_exception(tmp_path):
    with pytest.raises(FileNotFoundError):
        hh.read_log(tmp_path / "missing.log")
    junk = tmp_path / "junk.log"
    junk.write_bytes(b"FLASER 3 1 2\nnot a log\n")
    log = hh.read_log(junk)
    assert len(log) == 0 and log.errors and "FLASER" in log.errors[0][1]
    bag = tmp_path / "bad.mcap"
    bag.write_bytes(b"\x89MCAP0\r\n" + b"\x00" * 50)
    with pytest.raises(ValueError, match="MCAP"):
        hh.read_log(bag)
    with pytest.raises(ValueError, match="format"):
        hh.read_log(junk, format="rosbag1")
    with pytest.raises(ValueError, match="laser_offset"):
        hh.read_log(junk, laser_offset=(1.0, 2.0))


FUZZ = textwrap.dedent(
    r"""
    import math, sys
    import numpy as np
    import hough_heading as hh

    rng = np.random.default_rng(int(sys.argv[1]))
    cases = int(sys.argv[2])
    DTYPES = [np.bool_, np.uint8, np.int8, np.int32, np.int64, np.uint64, np.float16,
              np.float32, np.float64, np.complex64, object, "U3"]
    SPECIAL = [np.nan, np.inf, -np.inf, 0.0, -0.0, -1.0, 1e-30, 1e30, 1e300, 2.0**24,
               3.4e38, -3.4e38, 81.91]

    def hostile_array(ndim_max=3):
        ndim = int(rng.integers(0, ndim_max + 1))
        shape = tuple(int(v) for v in rng.choice([0, 1, 2, 3, 63, 64, 65, 128, 181], ndim))
        if int(np.prod(shape, dtype=np.int64)) > 70000:
            shape = shape[:1]
        dtype = DTYPES[int(rng.integers(len(DTYPES)))]
        kind = int(rng.integers(4))
        if kind == 0:
            a = rng.integers(0, 2, shape)
        elif kind == 1:
            a = rng.normal(0, 10, shape)
        elif kind == 2:
            a = rng.choice(SPECIAL, shape)
        else:
            a = rng.integers(-300, 300, shape)
        try:
            a = np.asarray(a).astype(dtype)
        except (ValueError, OverflowError, TypeError):
            a = np.asarray(a)
        if rng.random() < 0.2 and a.ndim >= 1 and a.shape[0] > 1:
            a = a[::2]  # not contiguous
        return a

    def number():
        return float(rng.choice(SPECIAL + [rng.normal(), rng.uniform(-7, 7)]))

    def hostile_scan():
        if rng.random() < 0.5:
            ranges = np.abs(rng.normal(3, 2, int(rng.integers(1, 400))))
            ranges[rng.random(ranges.size) < 0.2] = rng.choice(SPECIAL)
        else:
            ranges = hostile_array(2)
        return dict(
            ranges=ranges,
            angle_min=number() if rng.random() < 0.3 else -1.57,
            angle_increment=number() if rng.random() < 0.3 else 0.0087,
            max_range=number() if rng.random() < 0.3 else 30.0,
            laser_offset=tuple(number() for _ in range(3)) if rng.random() < 0.2 else (0, 0, 0),
        )

    outcomes = {"ok": 0, "ValueError": 0}
    for case in range(cases):
        what = case % 4
        try:
            if what == 0:
                hh.estimate_images(hostile_array(), hostile_array(), n_theta=180,
                                   verify=bool(rng.integers(2)))
            elif what == 1:
                size = int(rng.choice([64, 128]))
                a = rng.random((size, size)) < rng.uniform(0, 0.2)
                b = rng.random((size, size)) < rng.uniform(0, 0.2)
                hh.estimate_images(a, b, n_theta=180, fit="centre" if rng.random() < 0.3 else "none",
                                   scale_search=True if rng.random() < 0.2 else None)
            elif what == 2:
                hh.estimate_scans(hostile_scan(), hostile_scan(), size=64, n_theta=180,
                                  cell=None if rng.random() < 0.7 else number(),
                                  connect=abs(number()) if rng.random() < 0.3 else 0.3)
            else:
                data = bytearray(rng.integers(0, 256, int(rng.integers(0, 5000)), dtype=np.uint8).tobytes())
                if rng.random() < 0.5:
                    ref = hh.Reference.prepare(rng.random((64, 64)) < 0.05, n_theta=180)
                    data = bytearray(ref.to_bytes())
                    for _ in range(int(rng.integers(1, 4))):
                        data[int(rng.integers(len(data)))] = int(rng.integers(256))
                ref = hh.Reference.from_bytes(bytes(data))
                ref.estimate(rng.random((64, 64)) < 0.05)
            outcomes["ok"] += 1
        except ValueError:
            outcomes["ValueError"] += 1
    print(outcomes["ok"], outcomes["ValueError"])
    """
)


def test_seeded_hostile_arrays_leave_the_process_alive(tmp_path):
    script = tmp_path / "fuzz.py"
    script.write_text(FUZZ)
    cases = 1200
    out = subprocess.run([sys.executable, str(script), "20261202", str(cases)],
                         capture_output=True, text=True, timeout=900)
    # A crash (signal, abort) or any exception other than ValueError fails.
    assert out.returncode == 0, out.stderr[-3000:]
    ok, refused = map(int, out.stdout.split())
    assert ok + refused == cases
    # Both kinds happened: the run exercised the estimator, not only the checks.
    assert ok > cases // 5 and refused > cases // 5, (ok, refused)
