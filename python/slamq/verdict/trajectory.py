"""A run's trajectory errors as its detail page draws them: the estimate and, with ground
truth, each pose's ATE after the association and alignment the batch used (the record's
``config``: SE(2) by default, docs/spec.md section 6), and the ground truth brought into the
map's frame.

Uses :func:`slamq.sources.trajectories.load_pair` and :func:`slamq.metrics.ate.ate`;
:func:`slamq.report.trajectory.draw_trajectory` draws the result.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from slamq.errors import TrajectoryError

__all__ = ["TrajectoryEvidence", "ate_options", "trajectory_evidence"]


@dataclass
class TrajectoryEvidence:
    """What a run's trajectory drawing shows.

    Attributes
    ----------
    name : str
        The trajectory file's name.
    positions : numpy.ndarray
        ``(N, 2)`` estimated positions in the map's frame (metres): every pose without
        ground truth, else the poses the ATE associated, in the order of ``errors``.
    errors : numpy.ndarray
        ``(N,)`` each pose's error after alignment (metres; zeros without ground truth).
    ground_truth : str or None
        The ground-truth file's name (None: no ground truth, no ATE).
    gt_positions : numpy.ndarray or None
        ``(M, 2)`` the ground truth in the map's frame (the inverse of the ATE alignment).
    seconds : numpy.ndarray or None
        ``(N,)`` time of each error since the first associated pose.
    align : str
        The ATE alignment.
    rmse, max : float
        ATE RMSE and largest error (NaN without ground truth).
    """

    name: str
    positions: np.ndarray
    errors: np.ndarray
    ground_truth: str | None = None
    gt_positions: np.ndarray | None = None
    seconds: np.ndarray | None = None
    align: str = ""
    rmse: float = math.nan
    max: float = math.nan


def ate_options(record: dict) -> tuple[str, float, str]:
    """``(align, max_dt, unsorted)`` the batch computed the record's ATE with (its
    ``config``), else the defaults.

    Examples
    --------
    >>> ate_options({"config": '{"ate": ["sim3", 0.05, "last"]}'})
    ('sim3', 0.05, 'last')
    >>> ate_options({})
    ('se2', 0.01, 'error')
    """
    from slamq.params import SETTINGS

    align, max_dt, unsorted = (SETTINGS.ate_align.default, SETTINGS.max_dt.default,
                               SETTINGS.unsorted.default)
    try:
        a, d, u = json.loads(record.get("config") or "{}").get("ate")
        align, max_dt, unsorted = str(a), _number(d, max_dt), str(u)
    except (TypeError, ValueError, AttributeError):
        pass
    return align, max_dt, unsorted


def _per_pose(est: Any, gt: Any, errors: np.ndarray, max_dt: float) -> np.ndarray:
    """Indices of the estimate's poses the ATE errors belong to (the ATE association)."""
    from slamq.metrics.sync import associate

    _, i_est = associate(gt, est, max_dt=max_dt)
    if len(i_est) != len(errors):
        raise TrajectoryError(f"{est.source}: cannot match the ATE errors to poses")
    return np.asarray(i_est)


def _number(x: Any, default: float) -> float:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return default
    return v if math.isfinite(v) else default


def trajectory_evidence(record: dict) -> TrajectoryEvidence:
    """Load the record's trajectory (and ground truth) and score it as the batch did.

    Parameters
    ----------
    record : dict
        A results record with ``trajectory`` and optionally ``groundtruth`` and ``config``.

    Returns
    -------
    TrajectoryEvidence

    Raises
    ------
    TrajectoryError
        A trajectory cannot be read or its errors matched to its poses.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "t.txt"
    >>> _ = p.write_text("0 0 0 0 0 0 0 1\\n1 1 0 0 0 0 0 1\\n")
    >>> ev = trajectory_evidence({"trajectory": str(p)})
    >>> ev.positions.tolist(), ev.ground_truth
    ([[0.0, 0.0], [1.0, 0.0]], None)
    """
    traj = str(record["trajectory"])
    gt = record.get("groundtruth")
    align, max_dt, unsorted = ate_options(record)
    if gt is None or (isinstance(gt, float) and math.isnan(gt)):
        from slamq.sources.trajectories import load_trajectory

        est = load_trajectory(traj, unsorted=unsorted)
        positions = np.asarray(est.positions[:, :2])
        return TrajectoryEvidence(Path(traj).name, positions, np.zeros(len(positions)))
    from slamq.metrics.ate import ate
    from slamq.sources.trajectories import load_pair

    est, ref = load_pair(traj, str(gt), unsorted)
    res = ate(ref, est, align=align, max_dt=max_dt)
    errors = np.asarray(res.errors, float)
    idx = _per_pose(est, ref, errors, max_dt)
    return TrajectoryEvidence(
        name=Path(traj).name, positions=np.asarray(est.positions[idx, :2]), errors=errors,
        ground_truth=Path(str(gt)).name,
        gt_positions=_unalign(res.alignment, ref.positions)[:, :2],
        seconds=res.timestamps - res.timestamps[0], align=align, rmse=float(res.rmse),
        max=float(res.max))


def _unalign(alignment: Any, positions: np.ndarray) -> np.ndarray:
    """``positions`` through the inverse of ``alignment`` (``scale * R p + t``)."""
    if alignment.kind == "none":
        return positions
    p = (positions - alignment.translation) @ alignment.rotation
    return p / alignment.scale
