"""slamq: score 2D SLAM results.

The three no-reference map metrics of Filatov et al. (arXiv 1708.02354) on occupancy
grids, pinned down by SPEC.md, computed by a Rust core and checked against a plain
OpenCV reference (:mod:`slamq.reference`).

>>> import numpy as np, slamq
>>> slamq.evaluate(np.full((8, 8), 254, np.uint8)).occupied
0
"""

from __future__ import annotations

from slamq.bags import read_bag_maps, read_bag_trajectory, read_last_map
from slamq.batch import discover_runs, evaluate_many, read_results, summarize
from slamq.errors import (
    BagError,
    ConformanceError,
    MapError,
    MapWarning,
    ParamError,
    SlamqError,
    TrajectoryError,
)
from slamq.maps import OccupancyMap, load_map
from slamq.params import Params
from slamq.pbstream import read_pbstream_trajectory
from slamq.quality import MapQuality, evaluate
from slamq.trajectory import Trajectory, ate, ate_runs, load_trajectory, rpe

__version__ = "0.1.0"

__all__ = [
    "BagError",
    "ConformanceError",
    "MapError",
    "MapQuality",
    "MapWarning",
    "OccupancyMap",
    "ParamError",
    "Params",
    "SlamqError",
    "Trajectory",
    "TrajectoryError",
    "ate",
    "ate_runs",
    "discover_runs",
    "evaluate",
    "evaluate_many",
    "load_map",
    "load_trajectory",
    "read_bag_maps",
    "read_bag_trajectory",
    "read_last_map",
    "read_pbstream_trajectory",
    "read_results",
    "rpe",
    "summarize",
]
