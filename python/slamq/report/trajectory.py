"""A run's estimated trajectory drawn over its map, each pose coloured by its ATE.

The estimate is drawn in the map's frame as it was logged (the map was built in that frame),
the colours are the per-pose errors the verdict layer computed
(:func:`slamq.verdict.trajectory.trajectory_evidence`).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from slamq.errors import TrajectoryError
from slamq.models import OccupancyMap
from slamq.verdict.trajectory import TrajectoryEvidence

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


def draw_trajectory(evidence: TrajectoryEvidence, grid: OccupancyMap, path: Path) -> str:
    """Draw a run's trajectory (:func:`slamq.verdict.trajectory.trajectory_evidence`) over
    ``grid`` into ``path``; return a caption.

    Without ground truth the trajectory is drawn in one colour.

    Raises
    ------
    TrajectoryError
        The trajectory cannot be placed on the map (it has no resolution).
    """
    from slamq.report.overlays import known_box, render_base
    from slamq.report.plots import trajectory_figure

    ev = evidence
    base = render_base(grid)
    rows, cols = world_to_cells(grid, ev.positions)
    if ev.ground_truth is None:
        trajectory_figure(base, rows, cols, np.zeros(len(rows)), path,
                          title=ev.name, box=known_box(grid))
        return f"{ev.name}: {len(rows)} poses (no ground truth, so no ATE colours)."
    assert ev.gt_positions is not None and ev.seconds is not None
    gt_rows, gt_cols = world_to_cells(grid, ev.gt_positions)
    trajectory_figure(base, rows, cols, ev.errors, path, title=ev.name,
                      gt_rows=gt_rows, gt_cols=gt_cols, box=known_box(grid))
    from slamq.report.plots import error_time_figure

    error_time_figure(ev.seconds, ev.errors, time_plot_path(path),
                      title=f"ATE over time (align {ev.align})")
    return (f"{ev.name} against {ev.ground_truth}: {len(ev.errors)} poses, "
            f"ATE RMSE {ev.rmse:.3g} m (max {ev.max:.3g} m), align {ev.align}; "
            "the colour is each pose's error after alignment, the dashed line the ground "
            "truth in the map's frame.")


def time_plot_path(path: Path) -> Path:
    """Where :func:`draw_trajectory` puts the error-over-time plot beside ``path``."""
    return path.with_name(path.stem + "_time.svg")
