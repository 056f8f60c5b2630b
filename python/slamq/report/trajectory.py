"""A run's estimated trajectory drawn over its map, each pose coloured by its ATE.

Uses :func:`slamq.sources.trajectories.load_pair` and :func:`slamq.ate`; the estimate is
drawn in the map's frame as it was logged (the map was built in that frame), the colours are the
per-pose errors after the association and alignment the batch used (the record's
``config``: SE(2) by default, SPEC section 6).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from slamq.errors import TrajectoryError
from slamq.models import OccupancyMap

__all__ = ["draw_trajectory", "world_to_cells"]


def world_to_cells(grid: OccupancyMap, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Map-frame positions (metres) to (row, col) image coordinates of cell centres' grid.

    The origin ``(x, y, yaw)`` is the lower-left corner of the lower-left cell (ROS);
    row 0 is the top (north) of the image; a cell's centre is at integer coordinates.

    Examples
    --------
    >>> import numpy as np, slamq
    >>> m = slamq.OccupancyMap(np.zeros((10, 20), np.uint8), np.zeros((10, 20), bool),
    ...                        resolution=0.5, origin=(-1.0, -2.0, 0.0))
    >>> r, c = world_to_cells(m, np.array([[-1.0 + 0.25, -2.0 + 0.25]]))
    >>> float(r[0]), float(c[0])
    (9.0, 0.0)
    """
    if grid.resolution is None:
        raise TrajectoryError(f"{grid.source}: the map has no resolution; cannot place poses")
    ox, oy, yaw = (float(v) for v in grid.origin)
    dx, dy = xy[:, 0] - ox, xy[:, 1] - oy
    c, s = math.cos(-yaw), math.sin(-yaw)
    mx, my = c * dx - s * dy, s * dx + c * dy
    res = float(grid.resolution)
    cols = mx / res - 0.5
    rows = grid.shape[0] - my / res - 0.5
    return rows, cols


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


def draw_trajectory(record: dict, grid: OccupancyMap, path: Path) -> str:
    """Draw the record's trajectory over ``grid`` into ``path``; return a caption.

    Without ground truth the trajectory is drawn in one colour.

    Raises
    ------
    TrajectoryError
        The trajectory cannot be read or placed on the map.
    """
    from slamq.report.overlays import known_box, render_base
    from slamq.report.plots import trajectory_figure

    traj = str(record["trajectory"])
    gt = record.get("groundtruth")
    align, max_dt, unsorted = ate_options(record)
    base = render_base(grid)
    if gt is None or (isinstance(gt, float) and math.isnan(gt)):
        from slamq.sources.trajectories import load_trajectory

        est = load_trajectory(traj, unsorted=unsorted)
        rows, cols = world_to_cells(grid, est.positions[:, :2])
        trajectory_figure(base, rows, cols, np.zeros(len(rows)), path,
                          title=Path(traj).name, box=known_box(grid))
        return f"{Path(traj).name}: {len(rows)} poses (no ground truth, so no ATE colours)."
    from slamq.metrics.ate import ate
    from slamq.sources.trajectories import load_pair

    est, ref = load_pair(traj, str(gt), unsorted)
    res = ate(ref, est, align=align, max_dt=max_dt)
    errors = np.asarray(res.errors, float)
    idx = _per_pose(est, ref, errors, max_dt)
    rows, cols = world_to_cells(grid, est.positions[idx, :2])
    # the ground truth brought into the map's frame: the inverse of the ATE alignment
    gt_rows, gt_cols = world_to_cells(grid, _unalign(res.alignment, ref.positions)[:, :2])
    trajectory_figure(base, rows, cols, errors, path, title=Path(traj).name,
                      gt_rows=gt_rows, gt_cols=gt_cols, box=known_box(grid))
    from slamq.report.plots import error_time_figure

    error_time_figure(res.timestamps - res.timestamps[0], errors, time_plot_path(path),
                      title=f"ATE over time (align {align})")
    return (f"{Path(traj).name} against {Path(str(gt)).name}: {len(errors)} poses, "
            f"ATE RMSE {float(res.rmse):.3g} m (max {float(res.max):.3g} m), align {align}; "
            "the colour is each pose's error after alignment, the dashed line the ground "
            "truth in the map's frame.")


def time_plot_path(path: Path) -> Path:
    """Where :func:`draw_trajectory` puts the error-over-time plot beside ``path``."""
    return path.with_name(path.stem + "_time.png")


def _unalign(alignment: Any, positions: np.ndarray) -> np.ndarray:
    """``positions`` through the inverse of ``alignment`` (``scale * R p + t``)."""
    if alignment.kind == "none":
        return positions
    p = (positions - alignment.translation) @ alignment.rotation
    return p / alignment.scale
