"""``Scans``: a planar laser's scans (what a map's own data is), ``ScanConsistency``: a
map scored against them (SPEC section 7b), ``ScanDegeneracy``: how many of them see
walls in one direction only (section 7c), and ``ScanSplit``: a trajectory scored against
its own scans split in time (section 7e). Plain data: the metrics live in
:mod:`slamq.metrics.scans`, :mod:`slamq.metrics.degeneracy` and :mod:`slamq.metrics.split`."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from slamq.errors import SequenceError

__all__ = ["ScanConsistency", "ScanDegeneracy", "ScanSplit", "Scans"]


@dataclass(frozen=True, eq=False)
class Scans:
    """Laser scans with their timestamps, one beam layout for all of them.

    Attributes
    ----------
    stamps : numpy.ndarray
        ``(N,)`` float64 seconds, non-decreasing.
    angles : numpy.ndarray
        ``(B,)`` float64 beam angles in the laser frame, radians (counter-clockwise from
        the laser's heading).
    ranges : numpy.ndarray
        ``(N, B)`` float64 metres; a beam is valid when finite and
        ``min_range < r < max_range`` (``inf`` or NaN: no return).
    max_range : float
        Metres (> ``min_range``; may be ``inf``).
    min_range : float, default 0
        Metres (>= 0).
    offset : tuple of float, default (0, 0, 0)
        ``(x, y, yaw)`` of the laser on the robot (``base_link -> laser``): the poses a
        metric is given are the robot's.
    source : str
        Where the scans came from.
    meta : dict

    Examples
    --------
    >>> s = Scans.from_layout([0.0, 0.1], -0.5, 1.0, [[1.0, 2.0], [np.inf, 3.0]], 20.0)
    >>> s
    Scans('<array>', 2 scans x 2 beams, max_range=20)
    >>> s.angles.tolist()
    [-0.5, 0.5]
    """

    stamps: np.ndarray
    angles: np.ndarray
    ranges: np.ndarray
    max_range: float
    min_range: float = 0.0
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    source: str = "<array>"
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        src = self.source
        stamps = np.ascontiguousarray(self.stamps, dtype=np.float64)
        angles = np.ascontiguousarray(self.angles, dtype=np.float64)
        ranges = np.ascontiguousarray(self.ranges, dtype=np.float64)
        if stamps.ndim != 1:
            raise SequenceError(f"{src}: stamps must be a 1-D array, got shape {stamps.shape}")
        if angles.ndim != 1:
            raise SequenceError(f"{src}: angles must be a 1-D array, got shape {angles.shape}")
        if ranges.shape != (stamps.shape[0], angles.shape[0]):
            raise SequenceError(f"{src}: ranges must have shape ({stamps.shape[0]}, "
                                f"{angles.shape[0]}) (scans x beams), got {ranges.shape}")
        if not np.isfinite(stamps).all() or (np.diff(stamps) < 0).any():
            raise SequenceError(f"{src}: stamps must be finite and non-decreasing")
        if not np.isfinite(angles).all():
            raise SequenceError(f"{src}: angles must be finite")
        lo, hi = float(self.min_range), float(self.max_range)
        if not (math.isfinite(lo) and lo >= 0 and hi > lo):
            raise SequenceError(f"{src}: need 0 <= min_range < max_range, got {lo}, {hi}")
        off = tuple(float(v) for v in self.offset)
        if len(off) != 3 or not all(math.isfinite(v) for v in off):
            raise SequenceError(f"{src}: offset must be 3 finite numbers, got {self.offset}")
        for name, value in (("stamps", stamps), ("angles", angles), ("ranges", ranges),
                            ("min_range", lo), ("max_range", hi), ("offset", off)):
            object.__setattr__(self, name, value)

    @classmethod
    def from_layout(cls, stamps: Any, angle_min: float, angle_increment: float, ranges: Any,
                    max_range: float, **kwargs: Any) -> Scans:
        """Scans whose beams are ``angle_min + i * angle_increment`` (ROS ``LaserScan``)."""
        ranges = np.asarray(ranges, dtype=np.float64)
        b = ranges.shape[1] if ranges.ndim == 2 else 0
        angles = angle_min + angle_increment * np.arange(b, dtype=np.float64)
        return cls(np.asarray(stamps, dtype=np.float64), angles, ranges, max_range, **kwargs)

    @classmethod
    def from_sequence(cls, seq: Any) -> Scans:
        """The scans of a simulated :class:`slamq.synth.Recording` (its stamps, its laser's
        beams, minimum and maximum range and offset on the robot).

        Examples
        --------
        >>> from slamq.synth import LaserSpec, simulate, world
        >>> seq = simulate(world(2, kind="office", size=(8.0, 6.0)), seed=1, noise="none",
        ...                laser=LaserSpec(beams=91), length=5.0)
        >>> s = Scans.from_sequence(seq)
        >>> s.ranges.shape == (len(seq), 91), s.max_range
        (True, 20.0)
        """
        laser = seq.laser
        return cls(seq.stamps, laser.angles(), seq.ranges, laser.max_range,
                   min_range=laser.min_range, offset=tuple(laser.offset),
                   source=str(getattr(seq, "name", "<sequence>")))

    def __len__(self) -> int:
        return int(self.stamps.shape[0])

    def __repr__(self) -> str:
        return (f"Scans({self.source!r}, {len(self)} scans x {self.angles.shape[0]} beams, "
                f"max_range={self.max_range:g})")

    def laser_poses(self, poses: np.ndarray) -> np.ndarray:
        """The laser's ``(x, y, yaw)`` in the world for robot poses ``(N, 3)``: the robot
        pose composed with :attr:`offset`."""
        p = np.asarray(poses, dtype=np.float64)
        ox, oy, oyaw = self.offset
        if (ox, oy, oyaw) == (0.0, 0.0, 0.0):
            return np.ascontiguousarray(p)
        c, s = np.cos(p[:, 2]), np.sin(p[:, 2])
        return np.ascontiguousarray(np.column_stack(
            [p[:, 0] + c * ox - s * oy, p[:, 1] + s * ox + c * oy, p[:, 2] + oyaw]))


#: The per-scan counts, in the order of :attr:`ScanConsistency.counts`' columns.
COUNTS = ("valid", "hits", "misses", "unknown", "outside", "violations", "crossings")


def _per_scan(counts: np.ndarray, name: str) -> np.ndarray:
    """Per scan (row of :data:`COUNTS` counts): ``name`` / valid beams (NaN without any)."""
    valid = counts[:, COUNTS.index("valid")]
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(valid > 0, counts[:, COUNTS.index(name)] / np.maximum(valid, 1),
                        np.nan)


def _mean_over(shares: np.ndarray, keep: np.ndarray) -> float:
    """The mean of ``shares`` where ``keep`` (NaN where nothing is kept)."""
    return float(shares[keep].mean()) if keep.any() else math.nan


@dataclass(frozen=True, eq=False)
class ScanConsistency:
    """A map scored against its own scans (SPEC section 7b).

    Attributes
    ----------
    counts : numpy.ndarray
        ``(N, 7)`` int64 per scan: valid beams, hits, misses, unknown, outside, violations,
        crossings (:data:`COUNTS`); zeros for a scan without a pose. A crossing is a
        violation after which the beam came out into known free space clear of every wall
        (it saw through the wall, not along it).
    placed : numpy.ndarray
        ``(N,)`` bool: the scan had a pose.
    violation_grid : numpy.ndarray
        ``(H, W)`` uint32 on the map's grid: how many beams passed through each occupied
        cell before their end (grazes included).
    tolerance : float
        Metres.
    occupied_threshold : float
    source : str
        The map's source.
    crossing_grid : numpy.ndarray, optional
        ``(H, W)`` uint32: of those beams, the ones that crossed a wall (where the map
        contradicts its data); None when not computed.

    Examples
    --------
    >>> c = ScanConsistency(np.array([[4, 3, 1, 0, 0, 2, 1], [0, 0, 0, 0, 0, 0, 0]]),
    ...                     np.array([True, False]), np.zeros((2, 2), np.uint32), 0.1, 0.5)
    >>> c.hit_share, c.violation_share, c.crossing_share, c.scans
    (0.75, 0.5, 0.25, 1)
    """

    counts: np.ndarray
    placed: np.ndarray
    violation_grid: np.ndarray
    tolerance: float
    occupied_threshold: float
    source: str = "<array>"
    crossing_grid: np.ndarray | None = None

    def _column(self, name: str) -> np.ndarray:
        return self.counts[:, COUNTS.index(name)]

    def _share(self, name: str) -> np.ndarray:
        return _per_scan(self.counts, name)

    @property
    def hit_shares(self) -> np.ndarray:
        """``(N,)`` per scan: hits / valid beams (NaN without valid beams)."""
        return self._share("hits")

    @property
    def violation_shares(self) -> np.ndarray:
        """``(N,)`` per scan: beams with a violation / valid beams (NaN without any)."""
        return self._share("violations")

    @property
    def crossing_shares(self) -> np.ndarray:
        """``(N,)`` per scan: beams that cross a wall / valid beams (NaN without any)."""
        return self._share("crossings")

    @property
    def scans(self) -> int:
        """Scans with a pose and at least one valid beam (those the means are over)."""
        return int(np.count_nonzero(self.placed & (self._column("valid") > 0)))

    @property
    def beams(self) -> int:
        """Valid beams of all scans."""
        return int(self._column("valid").sum())

    def _mean(self, shares: np.ndarray) -> float:
        return _mean_over(shares, self.placed & (self._column("valid") > 0))

    @property
    def crossing_share(self) -> float:
        """Mean over scans of the crossing share: beams that pass through a wall and come
        out into free space clear of it (0 = the laser never saw through a wall)."""
        return self._mean(self.crossing_shares)

    @property
    def hit_share(self) -> float:
        """Mean over scans of the hit share (1 = every beam ends on a wall of the map)."""
        return self._mean(self.hit_shares)

    @property
    def violation_share(self) -> float:
        """Mean over scans of the violation share (0 = no beam sees through a wall)."""
        return self._mean(self.violation_shares)

    def _pooled(self, name: str) -> float:
        return float(self._column(name).sum() / self.beams) if self.beams else math.nan

    @property
    def unknown_share(self) -> float:
        """Of all valid beams, those ending on an unknown cell away from any wall."""
        return self._pooled("unknown")

    @property
    def outside_share(self) -> float:
        """Of all valid beams, those ending off the map's grid."""
        return self._pooled("outside")

    def to_dict(self) -> dict[str, float | int]:
        """The map-level figures (no arrays)."""
        return {"scans": self.scans, "beams": self.beams, "hit_share": self.hit_share,
                "violation_share": self.violation_share,
                "crossing_share": self.crossing_share, "unknown_share": self.unknown_share,
                "outside_share": self.outside_share, "tolerance": self.tolerance}

    def __repr__(self) -> str:
        return (f"ScanConsistency({self.source!r}, {self.scans} scans, hit_share="
                f"{self.hit_share:.3f}, violation_share={self.violation_share:.3f})")


@dataclass(frozen=True, eq=False)
class ScanDegeneracy:
    """How many of a recording's scans see walls in one direction only (SPEC section 7c).

    Attributes
    ----------
    ratios : numpy.ndarray
        ``(scored,)`` float64 per scored scan: the smaller over the larger eigenvalue of its
        straight wall stretches' normals' sum n n^T (0: one direction; NaN: too few).
    share : float
        Of the scored scans with a ratio, those under
        :data:`slamq.metrics.degeneracy.DEGENERATE_RATIO` (NaN when none has a ratio).
    scored : int
        Scans scored (evenly spread over the recording).
    source : str
        The recording.
    stamps : numpy.ndarray, optional
        ``(scored,)`` float64, the scored scans' times (the recording's clock), for
        :func:`slamq.metrics.travel.corridor_travel_ratio`.
    """

    ratios: np.ndarray
    share: float
    scored: int
    source: str = "<array>"
    stamps: np.ndarray | None = None

    def to_dict(self) -> dict[str, float | int]:
        """The recording-level figures (no arrays)."""
        return {"degenerate_share": self.share, "scored": self.scored,
                "with_ratio": int(np.isfinite(self.ratios).sum())}

    def __repr__(self) -> str:
        return (f"ScanDegeneracy({self.source!r}, {self.scored} scans, "
                f"share={self.share:.3f})")


@dataclass(frozen=True, eq=False)
class ScanSplit:
    """A trajectory scored against its own scans, split in time (SPEC section 7e).

    Half 1 is the earlier half of the placed scans, half 2 the later; map ``i`` is drawn
    from half ``i``'s scans at the trajectory's poses and scored with the other half's.

    Attributes
    ----------
    counts : tuple of numpy.ndarray
        ``counts[i]``: ``(len(tested[i]), 7)`` int64, the SPEC 7b counts (:data:`COUNTS`)
        of the scans ``tested[i]`` against map ``i``.
    drawn, tested : tuple of numpy.ndarray
        int64 indices into the scans: those drawn as map ``i``, those scored against it.
    maps : tuple
        The two drawn maps (:class:`slamq.OccupancyMap`: 0 occupied, 254 free, 205
        unknown), on one grid aligned with the world.
    placed : numpy.ndarray
        ``(N,)`` bool: the trajectory placed the scan.
    resolution, occupied_share, tolerance : float
        The drawn maps' metres per cell, the share of visits a cell's hits must reach to be
        occupied, and the SPEC 7b tolerance (metres) the halves are scored with.
    source : str
        The scans' source.

    Examples
    --------
    >>> one = np.array([[10, 9, 0, 0, 0, 1, 1], [10, 10, 0, 0, 0, 0, 0]])
    >>> two = np.array([[10, 7, 0, 0, 0, 3, 3]])
    >>> s = ScanSplit((one, two), (np.array([0]), np.array([2])),
    ...               (np.array([2, 3]), np.array([0])), (None, None),
    ...               np.ones(4, bool), 0.05, 0.5, 0.1)
    >>> s.crossing_shares.tolist(), round(s.crossing_share, 3)
    ([0.05, 0.3], 0.175)
    """

    counts: tuple[np.ndarray, np.ndarray]
    drawn: tuple[np.ndarray, np.ndarray]
    tested: tuple[np.ndarray, np.ndarray]
    maps: tuple[Any, Any]
    placed: np.ndarray
    resolution: float
    occupied_share: float
    tolerance: float
    source: str = "<array>"

    def _means(self, name: str) -> np.ndarray:
        return np.array([_mean_over(_per_scan(c, name), c[:, COUNTS.index("valid")] > 0)
                         for c in self.counts])

    @property
    def crossing_shares(self) -> np.ndarray:
        """``(2,)``: per half, the mean over its tested scans (with valid beams) of the
        share of beams that cross a wall of the other half's map."""
        return self._means("crossings")

    @property
    def hit_shares(self) -> np.ndarray:
        """``(2,)``: per half, the mean share of beams ending on the other half's walls."""
        return self._means("hits")

    @property
    def crossing_share(self) -> float:
        """The figure: the mean of the two halves' crossing shares (0: the two halves of
        the recording, each placed by the trajectory, never see through each other's
        walls; NaN when a half has no valid beam)."""
        return float(self.crossing_shares.mean())

    def to_dict(self) -> dict[str, float | int]:
        """The figures (no arrays)."""
        c, h = self.crossing_shares, self.hit_shares
        return {"split_crossing": self.crossing_share, "crossing_1": float(c[0]),
                "crossing_2": float(c[1]), "hit_1": float(h[0]), "hit_2": float(h[1]),
                "drawn": int(sum(len(d) for d in self.drawn)),
                "tested": int(sum(len(t) for t in self.tested))}

    def __repr__(self) -> str:
        return (f"ScanSplit({self.source!r}, crossing_share={self.crossing_share:.4f}, "
                f"{len(self.tested[0]) + len(self.tested[1])} scans scored)")
