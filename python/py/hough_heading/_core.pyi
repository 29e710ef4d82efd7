"""Type stubs of the native module ``hough_heading._core`` (Rust, PyO3).

Use the package's functions (``hough_heading.estimate_scans`` …): they check
the arguments and wrap these answers. Each ``args`` list holds the
``hough-heading`` tool's own options (``["--n-theta=360", "--no-verify"]``),
parsed by the tool's own definitions; each JSON text is the tool's answer.
"""

from typing import List, Optional, Sequence, Tuple

import numpy as np
import numpy.typing as npt

#: A scan: ranges (metres, float64), angle_min, angle_increment, max_range,
#: sensor offset (x, y, theta) in the robot frame.
ScanTuple = Tuple[npt.NDArray[np.float64], float, float, float, Tuple[float, float, float]]
#: Grid options: side, metres per cell (None: per pair), segment gap (metres,
#: 0: none), disc only, NaN ranges allowed.
GridTuple = Tuple[int, Optional[float], float, bool, bool]
#: Translation in cells (x, y), scale and residual (cells) of a scan pair.
Extras = Optional[Tuple[float, float, float, float]]

def configurations() -> List[Tuple[int, int]]:
    """The compiled ``(grid side, n_theta)``."""

def images_json(a: npt.NDArray[np.uint8], b: npt.NDArray[np.uint8], args: Sequence[str]) -> str:
    """``hough-heading images --json`` on two 0/1 arrays."""

def scans_json(
    scan1: ScanTuple,
    scan2: ScanTuple,
    args: Sequence[str],
    grid: GridTuple,
    prior: Optional[Tuple[float, float]],
) -> Tuple[str, Extras]:
    """One line of ``hough-heading scans`` (index 0) and the extras."""

def scans_json_batch(
    pairs: Sequence[Tuple[ScanTuple, ScanTuple]],
    args: Sequence[str],
    grid: GridTuple,
    threads: int,
) -> List[Tuple[str, Extras]]:
    """``scans_json`` on many pairs, GIL released, ``threads`` threads."""

def images_json_batch(
    pairs: Sequence[Tuple[npt.NDArray[np.uint8], npt.NDArray[np.uint8]]],
    args: Sequence[str],
    threads: int,
) -> List[Tuple[bool, str]]:
    """``images_json`` on many pairs: ``(True, json)`` or ``(False, message)``."""

def read_log(
    args: Sequence[str],
) -> Tuple[List[dict], List[Tuple[str, str]], str, Optional[str]]:
    """Reads a recording with the tool's ``log`` options ``[FILE, …]``:
    the scans as dicts, the failed records, the format, the scan topic."""

class NativeReference:
    """A prepared reference grid of one compiled configuration."""

    @staticmethod
    def prepare(grid: npt.NDArray[np.uint8], n_theta: int, mode: str) -> "NativeReference": ...
    @staticmethod
    def from_bytes(bytes: bytes) -> "NativeReference": ...
    def to_bytes(self) -> bytes: ...
    @property
    def size(self) -> int: ...
    @property
    def n_theta(self) -> int: ...
    @property
    def mode(self) -> str: ...
    @property
    def grid(self) -> npt.NDArray[np.bool_]: ...
    def estimate_json(self, image: npt.NDArray[np.uint8], args: Sequence[str]) -> str: ...
