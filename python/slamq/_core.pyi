"""Type stubs of the Rust core (rust/src/bindings/, one file per domain). Use
:func:`slamq.evaluate` instead: it loads maps, checks parameters and turns these integers
into a :class:`slamq.MapQuality`. tests/test_architecture.py checks these names and
signatures against the built module."""

import os

import numpy as np
import numpy.typing as npt

from slamq.params import Params

__version__: str

class RawQuality:
    """The integers of one evaluation (SPEC sections 2-4, and 3a)."""

    @property
    def known(self) -> int: ...
    @property
    def occupied(self) -> int: ...
    @property
    def sum_darkness(self) -> int: ...
    @property
    def corners(self) -> int: ...
    @property
    def wall_angle(self) -> float: ...
    @property
    def wall_harmonics(self) -> tuple[int, int, int, int, int]: ...
    @property
    def corners_canonical(self) -> int | None: ...
    @property
    def curve(self) -> list[int]: ...
    @property
    def known_levels(self) -> int: ...
    @property
    def unknown_shade(self) -> int | None: ...
    @property
    def known_box(self) -> tuple[int, int, int, int] | None: ...

class RawComparison:
    """The counts and sums of one ground-truth comparison (SPEC section 7); distances in
    cells of the ground truth's grid."""

    @property
    def estimate_occupied(self) -> int: ...
    @property
    def ground_truth_occupied(self) -> int: ...
    @property
    def estimate_matched(self) -> int: ...
    @property
    def ground_truth_matched(self) -> int: ...
    @property
    def intersection(self) -> int: ...
    @property
    def union(self) -> int: ...
    @property
    def sum_reverse(self) -> float: ...
    @property
    def sum_ne(self) -> float: ...
    @property
    def truncated_reverse(self) -> int: ...
    @property
    def truncated_ne(self) -> int: ...
    @property
    def ground_truth_free(self) -> int: ...
    @property
    def covered(self) -> int: ...
    @property
    def outside(self) -> int: ...
    @property
    def theta(self) -> float: ...
    @property
    def tx(self) -> float: ...
    @property
    def ty(self) -> float: ...
    @property
    def icp_rms(self) -> float: ...
    @property
    def icp_iterations(self) -> int: ...
    @property
    def icp_inliers(self) -> int: ...

def evaluate(
    values: npt.NDArray[np.uint8],
    unknown: npt.NDArray[np.bool_],
    params: Params,
    threads: int = 0,
    resolution: float | None = None,
    shade: npt.NDArray[np.uint8] | None = None,
) -> RawQuality: ...
def evaluate_many(
    maps: list[tuple[npt.NDArray[np.uint8], npt.NDArray[np.bool_], float | None]],
    params: Params,
    threads: int = 0,
) -> list[RawQuality]: ...
def read_table(
    path: str | os.PathLike[str], sep: str, skip: int = 0
) -> npt.NDArray[np.float64] | None: ...
def read_tum(
    path: str | os.PathLike[str],
) -> (
    tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]] | None
): ...
def match_stamps(
    stamps_1: npt.NDArray[np.float64],
    stamps_2: npt.NDArray[np.float64],
    max_dt: float,
    offset_2: float = 0.0,
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]: ...
def ate_moments(
    gt: npt.NDArray[np.float64],
    est: npt.NDArray[np.float64],
    gi: npt.NDArray[np.int64],
    ei: npt.NDArray[np.int64],
    dims: int,
) -> tuple[list[float], list[float], float, list[list[float]]]: ...
def ate_errors(
    gt: npt.NDArray[np.float64],
    est: npt.NDArray[np.float64],
    gi: npt.NDArray[np.int64],
    ei: npt.NDArray[np.int64],
    rotation: list[list[float]] | None,
    translation: list[float],
    scale: float,
) -> tuple[npt.NDArray[np.float64], tuple[float, float, float, float, float, float]]: ...
def otsu_table(
    values: npt.NDArray[np.uint8], unknown: npt.NDArray[np.bool_]
) -> list[int]: ...
def wall_harmonics(
    values: npt.NDArray[np.uint8], unknown: npt.NDArray[np.bool_], threads: int = 0
) -> tuple[int, int, int, int, int]: ...
def default_params() -> dict[str, float | int]: ...
def adopt_thread() -> bool: ...
def map_saver_shades(
    grey: npt.NDArray[np.uint8],
) -> tuple[list[int] | None, npt.NDArray[np.bool_]]: ...
def compare(
    est_values: npt.NDArray[np.uint8],
    est_unknown: npt.NDArray[np.bool_],
    est_frame: tuple[float, float, float, float],
    gt_values: npt.NDArray[np.uint8],
    gt_unknown: npt.NDArray[np.bool_],
    gt_frame: tuple[float, float, float, float],
    tolerance: float = 2.0,
    occupied_threshold: float = 0.5,
    align: str = "icp",
    max_distance: float | None = None,
    cells: bool = False,
    threads: int = 0,
    cells_box: tuple[int, int, int, int] | None = None,
) -> tuple[RawComparison, npt.NDArray[np.uint8] | None]: ...

class RawRegistration:
    """One registration of a map onto another of the same place (SPEC section 7a):
    moving world -> fixed world, and how far to trust it."""

    @property
    def ok(self) -> bool: ...
    @property
    def reason(self) -> str: ...
    @property
    def theta(self) -> float: ...
    @property
    def tx(self) -> float: ...
    @property
    def ty(self) -> float: ...
    @property
    def inliers(self) -> float: ...
    @property
    def inliers_moving(self) -> float: ...
    @property
    def inliers_fixed(self) -> float: ...
    @property
    def overlap(self) -> float: ...
    @property
    def overlap_moving(self) -> float: ...
    @property
    def overlap_fixed(self) -> float: ...
    @property
    def score(self) -> float: ...
    @property
    def runner_up_score(self) -> float: ...
    @property
    def runner_up(self) -> tuple[float, float, float] | None: ...
    @property
    def margin(self) -> float: ...
    @property
    def confidence(self) -> float: ...
    @property
    def icp_rms(self) -> float: ...
    @property
    def icp_iterations(self) -> int: ...
    @property
    def rotations(self) -> int: ...
    @property
    def candidates(self) -> int: ...
    @property
    def tolerance(self) -> float: ...

# Maps of one place onto each other (rust/src/register.rs); slamq.register is the entry.
def register(
    moving_values: npt.NDArray[np.uint8],
    moving_unknown: npt.NDArray[np.bool_],
    moving_frame: tuple[float, float, float, float],
    fixed_values: npt.NDArray[np.uint8],
    fixed_unknown: npt.NDArray[np.bool_],
    fixed_frame: tuple[float, float, float, float],
    occupied_threshold: float = 0.5,
    tolerance: float | None = None,
    min_inliers: float = 0.6,
    min_overlap: float = 0.1,
    min_margin: float = 0.05,
    threads: int = 0,
) -> RawRegistration: ...
def register_many(
    maps: list[
        tuple[npt.NDArray[np.uint8], npt.NDArray[np.bool_], tuple[float, float, float, float]]
    ],
    occupied_threshold: float = 0.5,
    tolerance: float | None = None,
    min_inliers: float = 0.6,
    min_overlap: float = 0.1,
    min_margin: float = 0.05,
    threads: int = 0,
) -> list[tuple[tuple[int, int], RawRegistration]]: ...

# Ground truth on demand: the simulator's laser (rust/src/raycast.rs);
# slamq.synth.sensors.cast is the Python entry, cast_numpy its reference.
def raycast(
    blocked: npt.NDArray[np.uint8],
    resolution: float,
    origin: tuple[float, float, float],
    poses: npt.NDArray[np.float64],
    angles: npt.NDArray[np.float64],
    max_range: float,
    threads: int = 0,
) -> npt.NDArray[np.float64]: ...

# A map against its own laser scans (rust/src/scans.rs, SPEC section 7b);
# slamq.metrics.scans.scan_consistency is the Python entry, scan_consistency_reference its
# reference. Returns per-scan counts (n, 7), the violation grid and the crossing grid
# (H, W).
def scan_consistency(
    values: npt.NDArray[np.uint8],
    unknown: npt.NDArray[np.bool_],
    resolution: float,
    origin: tuple[float, float, float],
    occupied_threshold: float,
    tolerance: float,
    poses: npt.NDArray[np.float64],
    angles: npt.NDArray[np.float64],
    ranges: npt.NDArray[np.float64],
    min_range: float,
    max_range: float,
    threads: int = 0,
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.uint32], npt.NDArray[np.uint32]]: ...

# Scans that see walls in one direction only (rust/src/degeneracy.rs, SPEC section 7c);
# slamq.metrics.degeneracy.scan_ratios is the Python entry, scan_ratios_reference its
# reference. Returns per scan the smaller over the larger eigenvalue (NaN: too few).
def scan_ratios(
    angles: npt.NDArray[np.float64],
    ranges: npt.NDArray[np.float64],
    min_range: float,
    max_range: float,
    threads: int = 0,
) -> npt.NDArray[np.float64]: ...

# A trajectory against its own scans, split in time (rust/src/split.rs, SPEC section 7e);
# slamq.metrics.split.scan_split is the Python entry, scan_split_reference its reference.
# Returns the tested scans' counts per half ((k, 7) each), each half's drawn map (values,
# unknown; (H, W)) and the maps' lower-left corner (x0, y0).
def scan_split(
    poses: npt.NDArray[np.float64],
    angles: npt.NDArray[np.float64],
    ranges: npt.NDArray[np.float64],
    min_range: float,
    max_range: float,
    drawn_1: npt.NDArray[np.int64],
    tested_1: npt.NDArray[np.int64],
    drawn_2: npt.NDArray[np.int64],
    tested_2: npt.NDArray[np.int64],
    resolution: float,
    margin: float,
    occupied_share: float,
    tolerance: float,
    threads: int = 0,
) -> tuple[
    tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]],
    tuple[npt.NDArray[np.uint8], npt.NDArray[np.bool_]],
    tuple[npt.NDArray[np.uint8], npt.NDArray[np.bool_]],
    tuple[float, float],
]: ...

#: Peak working memory of one evaluation, bytes per cell (reserved before it starts;
#: ``MemoryError`` when it cannot be).
WORK_BYTES_PER_CELL: int
