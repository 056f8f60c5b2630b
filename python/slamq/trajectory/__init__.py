"""Trajectory error: readers, association, alignment, ATE, RPE and multi-run statistics.

SPEC.md section 6. The numbers equal evo's (``evo_ape``, ``evo_rpe``) to 1e-9 for the
alignments evo has (``se3``, ``sim3``, ``origin``, ``none``); ``se2`` (rotation about z
and planar translation) is the default for 2-D SLAM.

>>> import numpy as np
>>> from slamq.trajectory import Trajectory, ate
>>> gt = Trajectory.from_xy_yaw([0, 1, 2, 3], [0, 1, 2, 3], [0, 0, 1, 1])
>>> round(ate(gt, gt).rmse, 12)
0.0
"""

from __future__ import annotations

from slamq.trajectory.align import ALIGNMENTS, Alignment, estimate_alignment, umeyama
from slamq.trajectory.io import (
    FORMATS,
    load_trajectory,
    parse_columns,
    read_euroc,
    read_kitti,
    read_table,
    read_tum,
)
from slamq.trajectory.metrics import ErrorResult, RunsResult, ate, ate_runs, rpe
from slamq.trajectory.model import Trajectory
from slamq.trajectory.sync import associate, matching_indices

__all__ = [
    "ALIGNMENTS",
    "FORMATS",
    "Alignment",
    "ErrorResult",
    "RunsResult",
    "Trajectory",
    "associate",
    "ate",
    "ate_runs",
    "estimate_alignment",
    "load_trajectory",
    "matching_indices",
    "parse_columns",
    "read_euroc",
    "read_kitti",
    "read_table",
    "read_tum",
    "rpe",
    "umeyama",
]
