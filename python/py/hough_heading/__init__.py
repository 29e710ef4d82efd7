"""Rotation (and translation) of a robot between two binary images or two
laser scans, by the doubled-line Hough signature of the ``hough-heading``
Rust library: numpy in, the ``hough-heading`` tool's own answers out.

Every answer is an :class:`Estimate` made from the JSON the command-line
tool prints for the same input (``hough-heading images --json`` for images,
one line of ``hough-heading scans`` for scan pairs): the same Rust functions
make it, so ``estimate.to_dict()`` equals the tool's JSON field by field
(less the tool's line ``index`` and ``file``). A field the tool adds shows up
here as an attribute of the same name.

Conventions (the tool's and the library's):

* Images: a 2-D array, row 0 at the top, ``True`` (or 1) = occupied. Cell
  ``(col, row)`` of a ``W × H`` grid sits at ``x = col − (W−1)/2``,
  ``y = (H−1)/2 − row``: origin at the centre, x right, y up, in cells.
* ``alpha`` is the counter-clockwise rotation of the scene: a point ``p`` of
  the first view appears in the second at ``s·R(alpha)·p + t``.
* Scans follow ``sensor_msgs/LaserScan``: beam ``i`` points at
  ``angle_min + i·angle_increment`` (radians, counter-clockwise, 0 = the
  sensor's x axis, forward), ranges in metres, a range ``≥ max_range`` means
  "no return". The sensor sits at ``laser_offset = (x, y, theta)`` in the
  robot frame (x forward, y left).
* ``dtheta = −alpha`` is the robot's heading change from scan 1 to scan 2
  (positive = turned left) and ``(dx, dy)`` its displacement in the robot
  frame of scan 1: the pose of scan 2 in the frame of scan 1, as in the
  scan-pair files (``p1 = R(dtheta)·p2 + (dx, dy)``).
* Angles printed in degrees lie in (−180, 180].

Compiled configurations: grid sides 64, 128, 256 × ``n_theta`` 180, 360, 720
(:data:`CONFIGURATIONS`).
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, fields
from typing import Any, Iterable, Iterator, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _core

__all__ = [
    "CONFIGURATIONS",
    "SIZES",
    "N_THETAS",
    "Candidate",
    "Estimate",
    "Thresholds",
    "Scan",
    "LogScan",
    "Log",
    "Reference",
    "estimate_images",
    "estimate_images_batch",
    "estimate_scans",
    "estimate_scans_batch",
    "read_log",
]

#: Every compiled ``(grid side, n_theta)``.
CONFIGURATIONS: Tuple[Tuple[int, int], ...] = tuple(
    (int(s), int(n)) for s, n in _core.configurations()
)
#: The compiled grid sides.
SIZES: Tuple[int, ...] = tuple(sorted({s for s, _ in CONFIGURATIONS}))
#: The compiled θ resolutions (steps over the full circle).
N_THETAS: Tuple[int, ...] = tuple(sorted({n for _, n in CONFIGURATIONS}))

_MODES = ("improved", "paper")


def _radians(d: Optional[float]) -> Optional[float]:
    return None if d is None else math.radians(d)


def _wrap_deg(d: float) -> float:
    """Degrees to (−180, 180]."""
    r = math.fmod(d, 360.0)
    if r <= -180.0:
        r += 360.0
    elif r > 180.0:
        r -= 360.0
    return r


@dataclass(frozen=True)
class Thresholds:
    """Status thresholds (the tool's tuning options); ``None`` keeps the
    library's default.

    * ``rival_ratio`` (0–1, default 0.9): ``ambiguous_axis`` when the rival
      correlation peak reaches this fraction of the best;
    * ``direction_margin`` (0–1, default 0.10): ``ambiguous_direction`` when
      the α vs α + 180° margin is below it;
    * ``max_shift`` (0–1, default 0.25): largest translation searched, as a
      fraction of the ρ range;
    * ``alignment_ratio`` (1–4, default 2): rotations whose best alignment
      cannot reach the best one's divided by this are not searched to the
      end nor listed;
    * ``decision_gap`` (0–1, default 0.08): ambiguous unless the winner's
      support leads the runner-up's (≥ 5° away) by this much (``confident``
      exactly when ``confidence`` ≥ 0.5);
    * ``free_space_weight`` (0–64, default 2): on scans, what a share of
      points laid where the other sensor saw through costs in the support;
    * ``min_overlap`` (0–1, default 0.30): ``low_overlap`` below this share of
      the second view explained by the pose.
    """

    rival_ratio: Optional[float] = None
    direction_margin: Optional[float] = None
    max_shift: Optional[float] = None
    alignment_ratio: Optional[float] = None
    decision_gap: Optional[float] = None
    free_space_weight: Optional[float] = None
    min_overlap: Optional[float] = None


_THRESHOLD_NAMES = tuple(f.name for f in fields(Thresholds))


class Candidate:
    """A candidate rotation: ``alpha_deg`` (scene, counter-clockwise),
    ``dtheta_deg`` (= −alpha, the robot's turn), ``score`` (correlation ×
    direction share; images only, ``None`` for scans, whose JSON omits it)
    and ``alignment`` (how well its best translation lays the second view on
    the first, in [0, 1]; ``None`` without verification)."""

    __slots__ = ("alpha_deg", "dtheta_deg", "score", "alignment")

    def __init__(
        self,
        alpha_deg: float,
        dtheta_deg: float,
        score: Optional[float],
        alignment: Optional[float],
    ) -> None:
        self.alpha_deg = alpha_deg
        self.dtheta_deg = dtheta_deg
        self.score = score
        self.alignment = alignment

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Candidate):
            return NotImplemented
        return all(getattr(self, k) == getattr(other, k) for k in self.__slots__)

    def __repr__(self) -> str:
        return (
            f"Candidate(alpha_deg={self.alpha_deg}, dtheta_deg={self.dtheta_deg}, "
            f"score={self.score}, alignment={self.alignment})"
        )


class Estimate:
    """The answer for one pair: the tool's JSON as attributes, plus the
    same quantities under convention-neutral names.

    Every key of the tool's JSON is an attribute (``est.status``,
    ``est.dtheta_deg`` …); :meth:`to_dict` gives the JSON object itself.
    ``kind`` is ``"images"`` or ``"scans"``. For a failed pair of a batch
    call, ``status == "error"`` and ``error`` says why (as the tool's line).
    """

    __slots__ = ("_data", "_kind", "_extras")

    def __init__(
        self,
        data: Mapping[str, Any],
        kind: str,
        extras: Optional[Tuple[float, float, float, float]] = None,
    ) -> None:
        object.__setattr__(self, "_data", dict(data))
        object.__setattr__(self, "_kind", kind)
        object.__setattr__(self, "_extras", extras)

    @classmethod
    def _from_json(
        cls, text: str, kind: str, extras: Optional[Tuple[float, float, float, float]] = None
    ) -> "Estimate":
        data = json.loads(text)
        # The tool's line position and file name: not part of an answer.
        data.pop("index", None)
        data.pop("file", None)
        return cls(data, kind, extras)

    def __getattr__(self, name: str) -> Any:
        data = object.__getattribute__(self, "_data")
        if name in data:
            return data[name]
        raise AttributeError(
            f"Estimate has no attribute {name!r} (fields: {', '.join(sorted(data))})"
        )

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError("Estimate is read-only")

    def __dir__(self) -> Iterable[str]:
        return sorted(set(super().__dir__()) | set(self._data))

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Estimate):
            return NotImplemented
        return (self._kind, self._data, self._extras) == (other._kind, other._data, other._extras)

    def __repr__(self) -> str:
        return f"Estimate({self._kind}: {json.dumps(self._data)})"

    def to_dict(self) -> dict:
        """The tool's JSON object for this pair (a copy)."""
        return json.loads(json.dumps(self._data))

    def to_json(self) -> str:
        """The tool's JSON object as text."""
        return json.dumps(self._data)

    @property
    def kind(self) -> str:
        """``"images"`` or ``"scans"``."""
        return self._kind

    @property
    def status(self) -> str:
        """``confident``, ``ambiguous_direction``, ``ambiguous_axis``,
        ``low_overlap``, ``no_structure``, ``search_cut`` (or ``error`` in a
        batch)."""
        return self._data["status"]

    @property
    def ok(self) -> bool:
        """Whether the status is ``confident``."""
        return self._data.get("status") == "confident"

    @property
    def confidence(self) -> Optional[float]:
        """In [0, 1]."""
        return self._data.get("confidence")

    @property
    def overlap(self) -> Optional[float]:
        """Share of the second view the chosen pose puts within one cell of
        the first (``None`` without verification)."""
        return self._data.get("overlap")

    @property
    def search_rows(self) -> Optional[int]:
        """The work the verification's translation searches spent, in the
        unit of the library's ``Thresholds::search_budget`` (``None``
        without verification)."""
        return self._data.get("search_rows")

    def _angle(self, key: str, opposite: str) -> Optional[float]:
        """``key`` from the JSON, or −``opposite`` when the JSON has that."""
        if key in self._data:
            return self._data[key]
        v = self._data.get(opposite)
        return None if v is None else _wrap_deg(-v)

    @property
    def alpha_deg(self) -> Optional[float]:
        """Counter-clockwise rotation of the scene, degrees in (−180, 180]."""
        return self._angle("alpha_deg", "dtheta_deg")

    @property
    def dtheta_deg(self) -> Optional[float]:
        """The robot's heading change (= −alpha), degrees in (−180, 180]."""
        return self._angle("dtheta_deg", "alpha_deg")

    @property
    def rotation_deg(self) -> Optional[float]:
        """The rotation in the kind's own convention: ``alpha_deg`` for
        images, ``dtheta_deg`` (the robot's turn) for scans."""
        return self.alpha_deg if self._kind == "images" else self.dtheta_deg

    @property
    def alpha_rad(self) -> Optional[float]:
        """:attr:`alpha_deg` in radians."""
        return _radians(self.alpha_deg)

    @property
    def dtheta_rad(self) -> Optional[float]:
        """:attr:`dtheta_deg` in radians."""
        return _radians(self.dtheta_deg)

    @property
    def rotation_rad(self) -> Optional[float]:
        """:attr:`rotation_deg` in radians."""
        return _radians(self.rotation_deg)

    @property
    def candidates(self) -> list:
        """The candidate rotations (:class:`Candidate`), best first."""
        if self._kind == "images":
            out = []
            for c in self._data.get("candidates", []):
                a = c["alpha_deg"]
                out.append(Candidate(a, _wrap_deg(-a), c.get("score"), c.get("alignment")))
            return out
        degs = self._data.get("candidates_deg", [])
        aligns = self._data.get("alignments", [])
        return [
            Candidate(
                _wrap_deg(-d), d, None, aligns[i] if i < len(aligns) else None
            )
            for i, d in enumerate(degs)
        ]

    @property
    def translation_m(self) -> Optional[Tuple[float, float]]:
        """Scans: the robot's displacement ``(dx, dy)`` in metres, frame of
        scan 1 (``None`` when not estimated, and for images)."""
        dx, dy = self._data.get("dx_m"), self._data.get("dy_m")
        return None if dx is None or dy is None else (dx, dy)

    @property
    def translation_cells(self) -> Optional[Tuple[float, float]]:
        """The scene's translation ``t`` in cells (x right, y up): for images
        ``(tx_px, ty_px)``; for scans the estimate's ``t`` on the grids
        (frame of scan 2's grid), which ``dx_m, dy_m`` turn into metres."""
        if self._kind == "images":
            tx, ty = self._data.get("tx_px"), self._data.get("ty_px")
            return None if tx is None or ty is None else (tx, ty)
        return None if self._extras is None else (self._extras[0], self._extras[1])

    @property
    def scale(self) -> Optional[float]:
        """Scale of the second view relative to the first (1 unless
        searched; ``None`` when no translation was estimated)."""
        if self._kind == "images":
            return self._data.get("scale")
        return None if self._extras is None else self._extras[2]

    @property
    def residual_cells(self) -> Optional[float]:
        """How well the profile columns agree on the translation: weighted
        RMS, cells."""
        if self._kind == "images":
            return self._data.get("residual_px")
        return None if self._extras is None else self._extras[3]

    @property
    def residual_m(self) -> Optional[float]:
        """Scans: :attr:`residual_cells` in metres."""
        return self._data.get("residual_m")


class Scan:
    """One laser scan, as ``sensor_msgs/LaserScan`` and the scan-pair files
    give it: ``ranges`` (metres, 1-D), beam ``i`` at ``angle_min +
    i·angle_increment`` radians (counter-clockwise), ``max_range`` (a range
    at or beyond it is "no return"), ``laser_offset = (x, y, theta)`` the
    sensor's pose in the robot frame."""

    __slots__ = ("ranges", "angle_min", "angle_increment", "max_range", "laser_offset")

    def __init__(
        self,
        ranges: Any,
        angle_min: float,
        angle_increment: float,
        max_range: float,
        laser_offset: Sequence[float] = (0.0, 0.0, 0.0),
    ) -> None:
        self.ranges = np.asarray(ranges)
        self.angle_min = angle_min
        self.angle_increment = angle_increment
        self.max_range = max_range
        self.laser_offset = tuple(laser_offset)

    def points(self) -> np.ndarray:
        """The valid returns as ``(n, 2)`` points in the robot frame, metres."""
        r = np.asarray(self.ranges, dtype=np.float64)
        i = np.arange(r.size)
        ok = np.isfinite(r) & (r > 0) & (r < self.max_range)
        ox, oy, oth = self.laser_offset
        a = self.angle_min + i[ok] * self.angle_increment + oth
        return np.column_stack([ox + r[ok] * np.cos(a), oy + r[ok] * np.sin(a)])

    def __repr__(self) -> str:
        return (
            f"{type(self).__name__}({self.ranges.size} beams, angle_min={self.angle_min:.4f}, "
            f"angle_increment={self.angle_increment:.6f}, max_range={self.max_range})"
        )


class LogScan(Scan):
    """A scan of a recording (:func:`read_log`): also its ``time``
    (seconds), the odometry pose ``odom = (x, y, theta)`` at it, the log's
    own pose ``log_pose`` (a CARMEN ``FLASER`` pose: corrected in a Radish
    ``-corrected`` log) and ``name`` (where it is in the file)."""

    __slots__ = ("time", "odom", "log_pose", "name")

    def __init__(self, d: Mapping[str, Any]) -> None:
        super().__init__(
            d["ranges"], d["angle_min"], d["angle_increment"], d["max_range"], d["laser_offset"]
        )
        self.time: Optional[float] = d["time"]
        self.odom: Optional[Tuple[float, float, float]] = d["odom"]
        self.log_pose: Optional[Tuple[float, float, float]] = d["log_pose"]
        self.name: str = d["name"]


class Log(Sequence[LogScan]):
    """The scans of a recording, in order; ``errors`` lists the records that
    could not be used as ``(record, message)``; ``format`` is ``"carmen"`` or
    ``"mcap"``; ``topic`` the bag's scan topic read."""

    def __init__(self, scans: list, errors: list, format: str, topic: Optional[str]) -> None:
        self.scans = scans
        self.errors = errors
        self.format = format
        self.topic = topic

    def __len__(self) -> int:
        return len(self.scans)

    def __getitem__(self, i):  # type: ignore[override]
        return self.scans[i]

    def __iter__(self) -> Iterator[LogScan]:
        return iter(self.scans)

    def times(self) -> np.ndarray:
        """The scans' times, seconds (NaN where unknown)."""
        return np.array([np.nan if s.time is None else s.time for s in self.scans])

    def odometry(self) -> np.ndarray:
        """``(n, 3)`` odometry poses ``x, y, theta`` (NaN where unknown)."""
        return np.array([s.odom if s.odom is not None else (np.nan,) * 3 for s in self.scans])

    def log_poses(self) -> np.ndarray:
        """``(n, 3)`` log poses (NaN where unknown)."""
        return np.array(
            [s.log_pose if s.log_pose is not None else (np.nan,) * 3 for s in self.scans]
        )

    def __repr__(self) -> str:
        return f"Log({len(self.scans)} scans, {len(self.errors)} errors, format={self.format!r})"


# ---------------------------------------------------------------- arguments


def _number(value: Any, what: str) -> float:
    if isinstance(value, (bool, np.bool_)) or not isinstance(
        value, (int, float, np.integer, np.floating)
    ):
        raise ValueError(f"{what}: expected a number, got {type(value).__name__}")
    v = float(value)
    if not math.isfinite(v):
        raise ValueError(f"{what} = {v}: must be a finite number")
    return v


def _estimator_args(
    n_theta: Any, verify: Any, mode: Any, thresholds: Any
) -> list:
    if isinstance(n_theta, bool) or not isinstance(n_theta, (int, np.integer)):
        raise ValueError(f"n_theta: expected an integer among {N_THETAS}, got {n_theta!r}")
    if mode not in _MODES:
        raise ValueError(f"mode={mode!r}: expected one of {_MODES}")
    args = [f"--n-theta={int(n_theta)}", f"--mode={mode}"]
    if not verify:
        args.append("--no-verify")
    if thresholds is None:
        items: Iterable = ()
    elif isinstance(thresholds, Thresholds):
        items = ((f.name, getattr(thresholds, f.name)) for f in fields(Thresholds))
    elif isinstance(thresholds, Mapping):
        unknown = sorted(set(thresholds) - set(_THRESHOLD_NAMES))
        if unknown:
            raise ValueError(
                f"thresholds: unknown {unknown}; known: {', '.join(_THRESHOLD_NAMES)}"
            )
        items = thresholds.items()
    else:
        raise ValueError("thresholds: expected a Thresholds, a dict or None")
    for name, value in items:
        if value is not None:
            v = _number(value, f"thresholds {name}")
            args.append(f"--{name.replace('_', '-')}={v!r}")
    return args


def _scale_args(scale_search: Any) -> list:
    if scale_search is None or scale_search is False:
        return []
    if scale_search is True:
        return ["--scale-search=0.8:1.25"]
    try:
        lo, hi = scale_search
    except (TypeError, ValueError):
        raise ValueError(
            f"scale_search={scale_search!r}: expected None, True or (min, max) "
            "with 0.5 <= min <= max <= 2"
        ) from None
    return [f"--scale-search={_number(lo, 'scale_search min')!r}:{_number(hi, 'scale_search max')!r}"]


def _grid_array(a: Any, name: str) -> np.ndarray:
    """A 2-D ``uint8`` 0/1 array from booleans or 0/1 integers."""
    arr = np.asarray(a)
    if arr.ndim != 2:
        raise ValueError(f"{name}: expected a 2-D array, got {arr.ndim}-D shape {arr.shape}")
    if arr.dtype == np.bool_:
        return np.ascontiguousarray(arr, dtype=np.uint8)
    if arr.dtype.kind not in "iu":
        raise ValueError(
            f"{name}: dtype {arr.dtype} — expected booleans or integers 0/1 (occupied = 1)"
        )
    if arr.size and not bool(((arr == 0) | (arr == 1)).all()):
        bad = arr[(arr != 0) & (arr != 1)].flat[0]
        raise ValueError(f"{name}: holds {bad}; expected only 0 and 1 (occupied = 1)")
    return np.ascontiguousarray(arr, dtype=np.uint8)


def _check_grid_size(arr: np.ndarray, name: str, fit: str, size: Optional[int]) -> None:
    if fit != "none":
        return
    h, w = arr.shape
    want = size if size is not None else (w if w == h and w in SIZES else None)
    if want is None or (h, w) != (want, want):
        raise ValueError(
            f"{name}: shape {arr.shape}; accepted: square grids of side {', '.join(map(str, SIZES))} "
            "(or fit='centre' to pad/crop to one)"
        )


def _check_pair_sizes(ga: np.ndarray, gb: np.ndarray, names: Tuple[str, str], fit: str,
                      size: Optional[int]) -> None:
    _check_grid_size(ga, names[0], fit, size)
    _check_grid_size(gb, names[1], fit, size)
    if fit == "none" and ga.shape != gb.shape:
        raise ValueError(
            f"{names[1]}: shape {gb.shape} differs from {names[0]}'s {ga.shape}: both views "
            "must have the same compiled side (or fit='centre')"
        )


def _image_args(fit: Any, size: Any) -> list:
    if fit not in ("none", "centre"):
        raise ValueError(f"fit={fit!r}: expected 'none' or 'centre'")
    args = [f"--fit={fit}"]
    if size is not None:
        if isinstance(size, bool) or not isinstance(size, (int, np.integer)) or int(size) not in SIZES:
            raise ValueError(f"size={size!r}: expected one of {SIZES}")
        args.append(f"--size={int(size)}")
    return args


def _field(scan: Any, name: str, default: Any = None, *alts: str) -> Any:
    for key in (name,) + alts:
        if isinstance(scan, Mapping):
            if key in scan:
                return scan[key]
        elif hasattr(scan, key):
            return getattr(scan, key)
    if default is not None:
        return default
    raise ValueError(f"scan: missing {name!r}")


def _scan_tuple(scan: Any, name: str) -> tuple:
    """``(ranges float64, angle_min, angle_increment, max_range, offset)``."""
    try:
        raw = _field(scan, "ranges")
        if isinstance(raw, (list, tuple)):
            raw = [math.nan if r is None else r for r in raw]
        ranges = np.asarray(raw)
        if ranges.ndim != 1:
            raise ValueError(f"ranges: expected a 1-D array, got shape {ranges.shape}")
        if ranges.dtype.kind not in "fiu":
            raise ValueError(f"ranges: dtype {ranges.dtype}; expected numbers (metres)")
        ranges = np.ascontiguousarray(ranges, dtype=np.float64)
        offset = _field(scan, "laser_offset", (0.0, 0.0, 0.0), "offset")
        offset = tuple(offset)
        if len(offset) != 3:
            raise ValueError(f"laser_offset: expected (x, y, theta), got {offset!r}")
        return (
            ranges,
            _number(_field(scan, "angle_min"), "angle_min"),
            _number(_field(scan, "angle_increment"), "angle_increment"),
            _number(_field(scan, "max_range"), "max_range"),
            tuple(_number(v, "laser_offset") for v in offset),
        )
    except (TypeError, ValueError) as e:
        raise ValueError(f"{name}: {e}") from None


def _scan_options(
    size: Any, cell: Any, connect: Any, disc: Any, nan: Any
) -> tuple:
    if isinstance(size, bool) or not isinstance(size, (int, np.integer)) or int(size) not in SIZES:
        raise ValueError(f"size={size!r}: expected one of {SIZES}")
    if nan not in ("drop", "raise"):
        raise ValueError(f"nan={nan!r}: expected 'drop' or 'raise'")
    cell_v = None if cell is None else _number(cell, "cell")
    return int(size), cell_v, _number(connect, "connect"), bool(disc), nan == "drop"


# ---------------------------------------------------------------- estimates


def estimate_images(
    a: Any,
    b: Any,
    *,
    n_theta: int = 360,
    verify: bool = True,
    scale_search: Union[None, bool, Tuple[float, float]] = None,
    thresholds: Union[None, Thresholds, Mapping[str, float]] = None,
    mode: str = "improved",
    fit: str = "none",
    size: Optional[int] = None,
) -> Estimate:
    """Rotation (and translation, scale) of image ``b`` relative to image
    ``a``: the answer of ``hough-heading images --json``.

    ``a``, ``b``: 2-D arrays of booleans or 0/1 integers, row 0 at the top,
    occupied = ``True``/1. With ``fit='none'`` (default) both must be
    square with a compiled side (:data:`SIZES`: 64, 128, 256); with
    ``fit='centre'`` they are centred on a ``size`` grid (default: the
    smallest that holds both), padded or cropped, and the translation is
    given in the images' own centred coordinates.

    The answer (:class:`Estimate`): ``alpha_deg`` is the counter-clockwise
    rotation of the scene (a point ``p`` of ``a`` appears in ``b`` at
    ``scale·R(alpha)·p + (tx_px, ty_px)``, x right, y up, origin at the
    image centre, cells), ``status``, ``confidence``, ``candidates`` (with
    ``alignment`` when verified), ``overlap``, ``scale``, ``residual_px``.

    ``n_theta``: θ steps over the full circle (180, 360, 720). ``verify``:
    the verification by alignment (improved mode). ``scale_search``:
    ``True`` searches the scale in 0.8–1.25, ``(min, max)`` in that range
    (0.5 ≤ min ≤ max ≤ 2); ``None``: scale 1. ``thresholds``: a
    :class:`Thresholds` or a dict of its fields. ``mode``: ``'improved'``
    or ``'paper'`` (the paper as written).

    Raises ``ValueError`` for a wrong shape, dtype, value, size or option.
    """
    args = _estimator_args(n_theta, verify, mode, thresholds) + _scale_args(scale_search)
    args += _image_args(fit, size)
    ga, gb = _grid_array(a, "a"), _grid_array(b, "b")
    _check_pair_sizes(ga, gb, ("a", "b"), fit, size)
    return Estimate._from_json(_core.images_json(ga, gb, args), "images")


def estimate_scans(
    scan1: Any,
    scan2: Any,
    *,
    size: int = 256,
    n_theta: int = 360,
    verify: bool = True,
    cell: Optional[float] = None,
    connect: float = 0.3,
    disc: bool = False,
    thresholds: Union[None, Thresholds, Mapping[str, float]] = None,
    mode: str = "improved",
    prior: Optional[Tuple[float, float]] = None,
    nan: str = "drop",
) -> Estimate:
    """The robot's motion between two laser scans: one line of
    ``hough-heading scans`` for the pair (same options, same answer).

    A scan is a :class:`Scan`, a :class:`LogScan`, a dict such as a
    scan-pair file's ``scan1`` / ``scan2`` object, or any object with these
    attributes (``sensor_msgs/LaserScan`` conventions):

    * ``ranges``: 1-D array of distances in metres, one per beam;
    * ``angle_min``: direction of beam 0, radians, counter-clockwise from the
      sensor's x axis (forward);
    * ``angle_increment``: radians between beams (beam ``i`` at
      ``angle_min + i·angle_increment``);
    * ``max_range``: a range at or beyond it means "no return" (dropped);
    * ``laser_offset`` (or ``offset``), optional: the sensor's pose
      ``(x, y, theta)`` in the robot frame (metres, radians); default at
      the robot's origin.

    Ranges that are NaN or ±inf (``sensor_msgs/LaserScan``'s "no
    measurement", REP 117) are dropped and counted in ``dropped``, as the
    tool does (``nan='raise'`` makes them an error); a negative range is an
    error; zero is dropped.

    The answer (:class:`Estimate`, fields as the tool's line):
    ``dtheta_deg`` is the robot's heading change from scan 1 to scan 2
    (positive = turned left; the scene turns by ``alpha = −dtheta``),
    ``(dx_m, dy_m)`` its displacement in the robot frame of scan 1 (the
    pose of scan 2 in the frame of scan 1, as the pair files'
    ``dx, dy, dtheta``), ``status`` (with ``flagged_by``, ``"estimate"`` or
    ``"beam_check"``, when it is not ``"confident"``), ``confidence``, ``candidates_deg`` with
    their ``alignments``, ``overlap``, ``correlation``, ``rival``,
    ``cell_m``, ``residual_m``, ``columns``, ``unobservable``, ``dropped``,
    ``beam_check``, ``beam_fit``. ``dtheta_deg``, ``dx_m`` and ``dy_m`` are
    the pose checked and refined on the beams (the tool's defaults:
    ``beam_check`` says whether the beams contradicted the grid's answer,
    did not confirm it (``too_weak``) or replaced it by a rival,
    ``beam_fit`` how many end points the refinement
    matched, or why it ``kept`` the grid's pose);
    :attr:`Estimate.translation_cells` and :attr:`Estimate.scale` give the
    same pose on the grids (cells).

    Grids: ``size`` × ``size`` cells (64, 128, 256) centred on each sensor;
    ``cell`` metres per cell, or ``None`` for the tool's default (per pair,
    a window radius of the 90th percentile of both scans' valid ranges,
    2–40 m); ``connect``: segments between neighbouring beams at most this
    far apart (metres; 0: one cell per beam); ``disc``: keep only the
    inscribed disc. ``prior``: ``(dtheta_deg, sigma_deg)``, e.g. from
    odometry: picks among the candidates within 3 sigma. Other options as
    :func:`estimate_images`.

    Raises ``ValueError`` for a bad scan or option (the message names it).
    """
    args = _estimator_args(n_theta, verify, mode, thresholds)
    grid = _scan_options(size, cell, connect, disc, nan)
    p = None
    if prior is not None:
        try:
            d, s = prior
        except (TypeError, ValueError):
            raise ValueError("prior: expected (dtheta_deg, sigma_deg)") from None
        p = (_number(d, "prior dtheta_deg"), _number(s, "prior sigma_deg"))
    text, extras = _core.scans_json(
        _scan_tuple(scan1, "scan1"),
        _scan_tuple(scan2, "scan2"),
        args,
        grid,
        p,
    )
    return Estimate._from_json(text, "scans", extras)


def estimate_scans_batch(
    pairs: Iterable[Tuple[Any, Any]],
    *,
    threads: int = 0,
    size: int = 256,
    n_theta: int = 360,
    verify: bool = True,
    cell: Optional[float] = None,
    connect: float = 0.3,
    disc: bool = False,
    thresholds: Union[None, Thresholds, Mapping[str, float]] = None,
    mode: str = "improved",
    nan: str = "drop",
) -> list:
    """:func:`estimate_scans` on many ``(scan1, scan2)`` pairs, in order,
    with the GIL released and ``threads`` threads (0: one per core). A pair
    the tool would fail (e.g. a scan with no beam after checks) gives an
    :class:`Estimate` with ``status == 'error'`` and its ``error``, as the
    tool's line; a malformed scan raises ``ValueError`` naming the pair."""
    args = _estimator_args(n_theta, verify, mode, thresholds)
    grid = _scan_options(size, cell, connect, disc, nan)
    tuples = []
    for i, pair in enumerate(pairs):
        try:
            s1, s2 = pair
        except (TypeError, ValueError):
            raise ValueError(f"pair {i}: expected (scan1, scan2)") from None
        tuples.append((_scan_tuple(s1, f"pair {i}: scan1"), _scan_tuple(s2, f"pair {i}: scan2")))
    answers = _core.scans_json_batch(tuples, args, grid, _threads(threads))
    return [Estimate._from_json(text, "scans", extras) for text, extras in answers]


def _threads(threads: Any) -> int:
    if isinstance(threads, bool) or not isinstance(threads, (int, np.integer)) or threads < 0:
        raise ValueError(f"threads={threads!r}: expected 0 (one per core) or a positive count")
    return int(threads)


def estimate_images_batch(
    pairs: Iterable[Tuple[Any, Any]],
    *,
    threads: int = 0,
    n_theta: int = 360,
    verify: bool = True,
    scale_search: Union[None, bool, Tuple[float, float]] = None,
    thresholds: Union[None, Thresholds, Mapping[str, float]] = None,
    mode: str = "improved",
    fit: str = "none",
    size: Optional[int] = None,
) -> list:
    """:func:`estimate_images` on many ``(a, b)`` pairs, in order, with the
    GIL released and ``threads`` threads (0: one per core). A pair the tool
    refuses (e.g. nothing occupied) gives an :class:`Estimate` with
    ``status == 'error'`` and ``error``."""
    args = _estimator_args(n_theta, verify, mode, thresholds) + _scale_args(scale_search)
    args += _image_args(fit, size)
    arrays = []
    for i, pair in enumerate(pairs):
        try:
            a, b = pair
        except (TypeError, ValueError):
            raise ValueError(f"pair {i}: expected (a, b)") from None
        ga, gb = _grid_array(a, f"pair {i}: a"), _grid_array(b, f"pair {i}: b")
        _check_pair_sizes(ga, gb, (f"pair {i}: a", f"pair {i}: b"), fit, size)
        arrays.append((ga, gb))
    out = []
    for ok, text in _core.images_json_batch(arrays, args, _threads(threads)):
        if ok:
            out.append(Estimate._from_json(text, "images"))
        else:
            out.append(Estimate({"status": "error", "error": text}, "images"))
    return out


class Reference:
    """A grid prepared once (signature, column profiles and the grid, the
    library's ``Reference``), storable as bytes in the library's format
    (what a robot keeps in flash: ``Reference::from_bytes`` reads them), and
    estimated against: ``ref.estimate(b)`` equals
    ``estimate_images(ref.grid, b)`` field by field."""

    __slots__ = ("_native",)

    def __init__(self, native: Any) -> None:
        self._native = native

    @classmethod
    def prepare(cls, grid: Any, *, n_theta: int = 360, mode: str = "improved") -> "Reference":
        """Prepares a square grid of a compiled side (booleans or 0/1)."""
        _estimator_args(n_theta, True, mode, None)
        g = _grid_array(grid, "grid")
        _check_grid_size(g, "grid", "none", None)
        return cls(_core.NativeReference.prepare(g, int(n_theta), mode))

    @classmethod
    def from_bytes(cls, data: bytes) -> "Reference":
        """Reads :meth:`to_bytes`' bytes (any compiled size: the header says
        which); ``ValueError`` for bytes of another format, size or a bad
        checksum."""
        if not isinstance(data, (bytes, bytearray, memoryview)):
            raise ValueError(f"expected bytes, got {type(data).__name__}")
        return cls(_core.NativeReference.from_bytes(bytes(data)))

    def to_bytes(self) -> bytes:
        """The library's byte format (version 3)."""
        return self._native.to_bytes()

    @property
    def size(self) -> int:
        """Grid side, cells."""
        return self._native.size

    @property
    def n_theta(self) -> int:
        """θ steps over the full circle."""
        return self._native.n_theta

    @property
    def mode(self) -> str:
        """The mode it was prepared for."""
        return self._native.mode

    @property
    def grid(self) -> np.ndarray:
        """The reference grid (booleans, row 0 at the top)."""
        return self._native.grid

    def estimate(
        self,
        image: Any,
        *,
        verify: bool = True,
        scale_search: Union[None, bool, Tuple[float, float]] = None,
        thresholds: Union[None, Thresholds, Mapping[str, float]] = None,
    ) -> Estimate:
        """Rotation of ``image`` (same side as the reference) relative to
        the reference, as :func:`estimate_images`."""
        args = _estimator_args(self.n_theta, verify, self.mode, thresholds)
        args += _scale_args(scale_search)
        g = _grid_array(image, "image")
        return Estimate._from_json(self._native.estimate_json(g, args), "images")

    def __repr__(self) -> str:
        return f"Reference({self.size}×{self.size}, n_theta={self.n_theta}, mode={self.mode!r})"


def read_log(
    path: Union[str, "os.PathLike[str]"],
    *,
    format: str = "auto",
    topic: Optional[str] = None,
    odom_topic: Optional[str] = None,
    max_range: float = 81.91,
    laser_offset: Optional[Sequence[float]] = None,
) -> Log:
    """Reads what ``hough-heading log`` reads, with its readers: a CARMEN
    log (``FLASER``, ``ROBOTLASER1``, ``ODOM`` lines; plain or gzip), a
    ROS 2 bag (its directory, or its ``.mcap`` or ``.db3`` file;
    ``sensor_msgs/msg/LaserScan`` and ``nav_msgs/msg/Odometry``, CDR) or a
    ROS 1 bag (``sensor_msgs/LaserScan`` or ``MultiEchoLaserScan``,
    ``nav_msgs/Odometry``).

    ``format``: ``'auto'`` (a directory is a ROS 2 bag; SQLite, MCAP and
    ROS 1 bags by their first bytes; otherwise CARMEN), ``'carmen'``,
    ``'mcap'``, ``'db3'`` or ``'ros1'``. ``topic``: the bag's scan topic (default:
    its only ``LaserScan`` topic; with several, ``ValueError`` lists them).
    ``odom_topic``: default ``/odom`` when the bag has it, else its ``/tf``
    (the ``odom`` → ``base_link`` transform). ``max_range``
    and ``laser_offset = (x, y, theta)``: for CARMEN ``FLASER`` lines, which
    carry neither (``laser_offset`` also overrides a bag's).

    Returns a :class:`Log` of :class:`LogScan` (``ranges`` float32 numpy
    arrays, NaN where the recording has none), each with its time, odometry
    and the log's own pose; records that fail are listed in
    ``Log.errors``.
    """
    p = os.fspath(path)
    if not os.path.exists(p):
        raise FileNotFoundError(p)
    if format not in ("auto", "carmen", "mcap", "db3", "ros1"):
        raise ValueError(
            f"format={format!r}: expected 'auto', 'carmen', 'mcap', 'db3' or 'ros1'"
        )
    args = [p, f"--format={format}", f"--max-range={_number(max_range, 'max_range')!r}"]
    if topic is not None:
        args.append(f"--topic={topic}")
    if odom_topic is not None:
        args.append(f"--odom-topic={odom_topic}")
    if laser_offset is not None:
        offset = [_number(v, "laser_offset") for v in laser_offset]
        if len(offset) != 3:
            raise ValueError("laser_offset: expected (x, y, theta)")
        args.append("--laser-offset=" + ",".join(repr(v) for v in offset))
    scans, errors, fmt, used_topic = _core.read_log(args)
    return Log([LogScan(d) for d in scans], list(errors), fmt, used_topic)
