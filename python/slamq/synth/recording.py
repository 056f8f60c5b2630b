"""``Recording``: one simulated drive through a world, what every part of "ground truth on
demand" hands to the next (the simulator makes it, the writers turn it into the files SLAM
programs read, the scorer takes its exact path and map).

Conventions (ROS REP 103/105): x forward, y left, yaw counter-clockwise in radians; the
world frame is the ground-truth map's frame (``map``), the odometry frame starts at the
first ground-truth pose (``odom`` = ``map`` at time 0).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from slamq.errors import SlamqError
from slamq.models import OccupancyMap

__all__ = ["EPOCH", "LaserSpec", "Recording"]

#: Seconds since 1970 added to a sequence's stamps in every file written from it (the
#: sensor logs of :mod:`slamq.synth.writers` and the ground truth of
#: :mod:`slamq.synth.truth`): one clock, a valid ROS time (2023-11-14 22:13:20 UTC).
EPOCH = 1_700_000_000.0


@dataclass(frozen=True)
class LaserSpec:
    """A planar laser scanner.

    Attributes
    ----------
    beams : int, default 1081
        Beams per scan, evenly spaced from ``-fov/2`` to ``+fov/2`` inclusive (the ROS
        ``LaserScan`` convention: ``angle_increment = fov / (beams - 1)``).
    fov : float, default 270 degrees
        Field of view, radians.
    max_range : float, default 20.0
        Metres; a beam that hits nothing within it has no return (``inf``).
    min_range : float, default 0.05
        Metres.
    range_noise : float, default 0.01
        Standard deviation of the Gaussian range noise, metres.
    offset : tuple of float, default (0, 0, 0)
        ``(x, y, yaw)`` of the laser on the robot (``base_link -> laser``).

    Examples
    --------
    >>> LaserSpec(beams=5, fov=math.pi).angles().round(3).tolist()
    [-1.571, -0.785, 0.0, 0.785, 1.571]
    """

    beams: int = 1081
    fov: float = math.radians(270.0)
    max_range: float = 20.0
    min_range: float = 0.05
    range_noise: float = 0.01
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)

    @property
    def angle_min(self) -> float:
        return -self.fov / 2

    @property
    def angle_increment(self) -> float:
        return self.fov / (self.beams - 1) if self.beams > 1 else 0.0

    def angles(self) -> np.ndarray:
        """The beam angles in the laser frame, radians, ``(beams,)`` float64."""
        return self.angle_min + self.angle_increment * np.arange(self.beams, dtype=np.float64)


@dataclass(eq=False)
class Recording:
    """One simulated drive: exact poses, odometry, laser scans, and the world they saw.

    Attributes
    ----------
    stamps : numpy.ndarray
        ``(N,)`` float64, seconds, strictly increasing (one laser scan and one odometry
        reading at each).
    gt : numpy.ndarray
        ``(N, 3)`` float64, the exact ``(x, y, yaw)`` of ``base_link`` in the world frame.
    odom : numpy.ndarray
        ``(N, 3)`` float64, the odometry's ``(x, y, yaw)`` of ``base_link`` in the ``odom``
        frame (equal to ``gt`` when the odometry has no noise).
    ranges : numpy.ndarray
        ``(N, beams)`` float32, metres along each beam of ``laser``; ``inf`` = no return.
    laser : LaserSpec
    world : OccupancyMap
        The ground-truth map the scans were cast in.
    name : str
    meta : dict
        How it was made (world, seeds, noise, speed, rate), JSON-serialisable.
    """

    stamps: np.ndarray
    gt: np.ndarray
    odom: np.ndarray
    ranges: np.ndarray
    laser: LaserSpec
    world: OccupancyMap
    name: str = "sequence"
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        n = len(self.stamps)
        if self.gt.shape != (n, 3) or self.odom.shape != (n, 3):
            raise SlamqError(f"{self.name}: gt and odom must be ({n}, 3) arrays")
        if self.ranges.shape != (n, self.laser.beams):
            raise SlamqError(f"{self.name}: ranges must be ({n}, {self.laser.beams})")
        if n > 1 and not np.all(np.diff(self.stamps) > 0):
            raise SlamqError(f"{self.name}: stamps must increase strictly")

    def __len__(self) -> int:
        return len(self.stamps)

    def __repr__(self) -> str:
        return (f"Recording({self.name!r}, {len(self)} scans x {self.laser.beams} beams, "
                f"{self.stamps[-1] - self.stamps[0] if len(self) else 0:.1f} s)")
