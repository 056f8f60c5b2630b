"""Readers for the files MRPT's SLAM programs write (``rbpf-slam``, ``icp-slam``); no MRPT needed.

* Grid maps: ``COccupancyGridMap2D::saveAsBitmapFile`` writes an 8-bit grey PNG of the
  cells' free probability (255 free, 0 occupied, about 128 unknown; first row = top =
  ``y_max``) and, beside it, ``<stem>_limits.txt`` with ``x_min x_max y_min y_max`` in
  metres after a ``%`` comment line. The resolution is ``(x_max - x_min) / width`` and the
  origin (lower-left corner) is ``(x_min, y_min)``: exactly a map_server image with the
  default thresholds. The map format lives in :mod:`slamq.sources.formats.mrpt_grid`
  (``slamq.load_map`` reads such a PNG); :func:`load_mrpt_grid` takes another limits file
  and :func:`write_mrpt_yaml` writes the map_server YAML that other ROS tools read.
* Pose logs: ``log_estimated_path.txt`` / ``log_odometry_path.txt`` rows
  ``index x y z yaw pitch roll t`` (``rbpf-slam``) or ``index x y yaw`` (``icp-slam``,
  no timestamps: the step index is used as the time) (:func:`read_mrpt_path`).
* ``graphslam-engine``: ``output_map.png`` + ``output_map_limits.txt`` (a grid as above)
  and ``output_graph.graph``, the optimised graph in MRPT's / g2o's text format
  (``VERTEX_SE2 id x y theta``, ``EDGE_SE2 ...``, ``FIX id``): its nodes are the
  trajectory, the node id standing for the time (:func:`read_mrpt_path` reads it too).
* Index times to clock times: :func:`apply_step_times` gives an index-timed trajectory
  the times of a file listing one time per step (or node).
"""

from __future__ import annotations

import dataclasses
import warnings
from pathlib import Path

import numpy as np

from slamq.errors import MapWarning, TrajectoryError
from slamq.models import OccupancyMap, Trajectory
from slamq.models.trajectory import order_rows
from slamq.sources.files import PathLike
from slamq.sources.formats.mrpt_grid import limits_path, read_limits, write_yaml
from slamq.sources.formats.mrpt_grid import read as read_grid
from slamq.sources.formats.raw import interpret

__all__ = ["limits_path", "read_limits", "load_mrpt_grid", "write_mrpt_yaml", "read_mrpt_path",
           "read_mrpt_most_likely", "read_mrpt_graph", "apply_step_times"]


def write_mrpt_yaml(png: PathLike, yaml_path: PathLike, limits: PathLike | None = None) -> Path:
    """Write a map_server YAML for an MRPT grid PNG (resolution and origin from its limits):
    :func:`slamq.sources.formats.mrpt_grid.write_yaml`.

    Examples
    --------
    >>> import pathlib, tempfile, numpy as np, cv2, slamq
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> _ = cv2.imwrite(str(d / "g.png"), np.full((4, 8), 255, np.uint8))
    >>> _ = (d / "g_limits.txt").write_text("0 0.4 0 0.2\\n")
    >>> slamq.load_map(write_mrpt_yaml(d / "g.png", d / "map.yaml")).origin
    (0.0, 0.0, 0.0)
    """
    return write_yaml(png, yaml_path, limits)


def load_mrpt_grid(png: PathLike, limits: PathLike | None = None) -> OccupancyMap:
    """Read an MRPT grid PNG and its ``_limits.txt`` into an :class:`OccupancyMap`
    (:func:`slamq.load_map` reads it too, when the limits file sits beside the PNG).

    Parameters
    ----------
    png : path
        The image ``saveAsBitmapFile`` wrote (``finalMap_..._COccupancyGridMap2D_00.png``).
    limits : path, optional
        Its limits file; default ``<stem>_limits.txt`` beside it.

    Examples
    --------
    >>> import pathlib, tempfile, numpy as np, cv2
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> _ = cv2.imwrite(str(d / "g.png"), np.full((4, 8), 255, np.uint8))
    >>> _ = (d / "g_limits.txt").write_text("0 0.4 0 0.2\\n")
    >>> m = load_mrpt_grid(d / "g.png")
    >>> m.shape, round(m.resolution, 6), int(m.unknown.sum())
    ((4, 8), 0.05, 0)
    """
    out: list[str] = []
    grid = interpret(read_grid(Path(png), limits), warnings_out=out)
    for msg in out:
        warnings.warn(MapWarning(msg), stacklevel=2)
    return grid


def read_mrpt_path(path: PathLike, *, unsorted: str = "error") -> Trajectory:
    """Read an MRPT pose log as a 2D trajectory.

    Rows are ``index x y z yaw pitch roll t`` (``rbpf-slam``) or ``index x y yaw``
    (``icp-slam``, which logs no time: the step index is used as the time in seconds, so
    such a log has no common clock with a ground truth; :func:`apply_step_times` gives it
    one); rows ``x y yaw`` with a ``log_times.txt`` beside them are ``rbpf-slam``'s
    ``most_likely_path.txt``, read by :func:`read_mrpt_most_likely`. Comment lines
    (``%``, ``#``) are skipped, and so are 8-column rows whose time is 0: MRPT prints its
    invalid timestamp as 0 (``rbpf-slam`` ends its log with such a row). A
    ``graphslam-engine`` graph file (``VERTEX_SE2`` lines) is read by
    :func:`read_mrpt_graph`.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "log_estimated_path.txt"
    >>> _ = p.write_text("0 0 0 0 0 0 0 100.0\\n1 1.5 0.5 0 1.57 0 0 100.5\\n")
    >>> t = read_mrpt_path(p)
    >>> len(t), t.positions[-1].tolist()
    (2, [1.5, 0.5, 0.0])
    >>> _ = p.write_text("0 0 0 0\\n1 0.5 0 0.1\\n")
    >>> read_mrpt_path(p).timestamps.tolist()
    [0.0, 1.0]
    """
    p = Path(path)
    try:
        lines = p.read_text(errors="replace").splitlines()
    except OSError as exc:
        raise TrajectoryError(f"{p}: cannot read MRPT pose log ({exc.strerror or exc})") from exc
    if any(line.lstrip().startswith(("VERTEX_SE2", "VERTEX2")) for line in lines[:50]):
        return _graph(lines, p)
    first = next((line.split() for line in lines if line.strip()
                  and line.strip()[0] not in "%#"), [])
    if len(first) == 3 and p.with_name("log_times.txt").is_file():
        return read_mrpt_most_likely(p, unsorted=unsorted)
    t = _table(lines, p, (4, 8), "MRPT pose log rows need 8 columns (index x y z yaw pitch "
               "roll t) or 4 (index x y yaw)")
    if t.shape[1] == 4:  # icp-slam: index x y yaw; the step index stands for the time
        z = np.zeros(len(t))
        a = np.column_stack([t[:, 0], t[:, 1], t[:, 2], z, t[:, 3], z, z, t[:, 0]])
    else:
        a = t[t[:, 7] != 0.0]  # MRPT's invalid timestamp
    return _traj(a, p, unsorted)


def read_mrpt_most_likely(path: PathLike, *, unsorted: str = "error") -> Trajectory:
    """Read ``rbpf-slam``'s ``most_likely_path.txt``: the path of its most likely particle,
    the one whose map ``rbpf-slam`` saves (its ``log_estimated_path.txt`` is the particles'
    weighted mean at every step, a filter estimate the map was not drawn from).

    The file holds ``x y yaw`` per step the filter ran, the first pose repeated; those
    steps are the rows of ``log_times.txt`` beside it whose last column
    (``frame_inserted?``) is 1, so pose ``k + 1`` is the pose at the ``k``-th of them. A
    step's time is the one ``log_estimated_path.txt`` beside it gives that step; without
    that file, the step index stands for the time in seconds (:func:`apply_step_times`
    gives it clock times).

    Raises
    ------
    slamq.TrajectoryError
        A file is missing or unreadable, a row is not three numbers, or the poses do not
        fit the inserted steps (both files named with their counts).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (d / "most_likely_path.txt").write_text("0 0 0\\n0 0 0\\n1.0 0.5 0.1\\n")
    >>> _ = (d / "log_times.txt").write_text("% step ms frames inserted\\n"
    ...                                       "0 5.0 1 1\\n1 0.1 1 0\\n2 4.0 2 1\\n")
    >>> _ = (d / "log_estimated_path.txt").write_text(
    ...     "0 0 0 0 0 0 0 70.0\\n1 0.4 0 0 0 0 0 70.1\\n2 0.9 0.4 0 0.1 0 0 70.2\\n")
    >>> t = read_mrpt_most_likely(d / "most_likely_path.txt")
    >>> t.timestamps.tolist(), t.positions[:, 0].tolist()
    ([70.0, 70.2], [0.0, 1.0])
    """
    p = Path(path)
    rows = _numbers(p, "rbpf-slam most likely path", 3)
    steps_file = p.with_name("log_times.txt")
    flags = _numbers(steps_file, "rbpf-slam step log", 4)
    inserted = flags[flags[:, 3] == 1.0, 0]
    if rows.shape[0] != inserted.shape[0] + 1:
        raise TrajectoryError(f"{p}: {rows.shape[0]} poses do not fit the "
                              f"{inserted.shape[0]} inserted steps of {steps_file} "
                              f"(expected one more pose than steps)")
    poses = rows[1:]
    t = inserted.astype(np.float64)
    mean_file = p.with_name("log_estimated_path.txt")
    if mean_file.is_file():
        est = _numbers(mean_file, "MRPT pose log", 8)
        est = est[est[:, 7] != 0.0]  # MRPT's invalid timestamp
        clock = dict(zip(est[:, 0].tolist(), est[:, 7].tolist(), strict=True))
        missing = [int(k) for k in inserted if clock.get(float(k), 0.0) == 0.0]
        if missing:
            raise TrajectoryError(f"{p}: step {missing[0]} has no time in {mean_file}")
        t = np.asarray([clock[float(k)] for k in inserted], np.float64)
    a = np.zeros((poses.shape[0], 8))
    a[:, 0], a[:, 1], a[:, 2], a[:, 4], a[:, 7] = inserted, poses[:, 0], poses[:, 1], \
        poses[:, 2], t
    return _traj(a, p, unsorted)


def _numbers(p: Path, what: str, width: int) -> np.ndarray:
    """The rows of a whitespace table of ``width`` numbers (``%``/``#`` comments skipped)."""
    try:
        lines = p.read_text(errors="replace").splitlines()
    except OSError as exc:
        raise TrajectoryError(f"{p}: cannot read {what} ({exc.strerror or exc})") from exc
    return _table(lines, p, (width,), f"{what} rows need {width} columns")


def _table(lines: list[str], p: Path, widths: tuple[int, ...], need: str) -> np.ndarray:
    """``lines`` as a float table (``%``/``#`` comments and blank lines skipped) whose rows
    all have one of ``widths`` columns, the first row's; ``need`` says so in the error."""
    rows: list[list[float]] = []
    width = 0
    for n, line in enumerate(lines, 1):
        s = line.strip()
        if not s or s[0] in "%#":
            continue
        parts = s.split()
        if len(parts) not in widths or (width and len(parts) != width):
            raise TrajectoryError(f"{p}:{n}: {need}, found {len(parts)}")
        width = len(parts)
        try:
            rows.append([float(x) for x in parts])
        except ValueError:
            raise TrajectoryError(f"{p}:{n}: not a number in {s[:80]!r}") from None
    return np.asarray(rows, np.float64).reshape(-1, width or widths[-1])


def _traj(a: np.ndarray, p: Path, unsorted: str = "error") -> Trajectory:
    if not len(a):
        raise TrajectoryError(f"{p}: MRPT pose log has no timestamped poses")
    if not np.all(np.isfinite(a[:, [1, 2, 4, 7]])):
        raise TrajectoryError(f"{p}: MRPT pose log holds non-finite values")
    a = a[order_rows(a[:, 7], unsorted)]
    return Trajectory.from_xy_yaw(a[:, 7], a[:, 1], a[:, 2], a[:, 4], source=str(p))


def read_mrpt_graph(path: PathLike) -> Trajectory:
    """Read the nodes of a 2D pose graph in MRPT's / g2o's text format (``graphslam-engine``'s
    ``output_graph.graph``) as a trajectory, ordered by node id, the id standing for the
    time in seconds (node ``k`` is the ``k``-th registered pose; give them clock times with
    :func:`apply_step_times`). ``EDGE``, ``FIX`` and comment lines are skipped.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "output_graph.graph"
    >>> _ = p.write_text("VERTEX_SE2 1 0.5 0 0.1\\nVERTEX_SE2 0 0 0 0\\nFIX 0\\n"
    ...                  "EDGE_SE2 0 1 0.5 0 0.1 1 0 0 1 0 1\\n")
    >>> t = read_mrpt_graph(p)
    >>> t.timestamps.tolist(), t.positions[:, 0].tolist()
    ([0.0, 1.0], [0.0, 0.5])
    """
    p = Path(path)
    try:
        lines = p.read_text(errors="replace").splitlines()
    except OSError as exc:
        raise TrajectoryError(f"{p}: cannot read MRPT graph ({exc.strerror or exc})") from exc
    return _graph(lines, p)


def _graph(lines: list[str], p: Path) -> Trajectory:
    rows: list[list[float]] = []
    for n, line in enumerate(lines, 1):
        parts = line.split()
        if not parts or parts[0] not in ("VERTEX_SE2", "VERTEX2"):
            continue
        if len(parts) < 5:
            raise TrajectoryError(f"{p}:{n}: {parts[0]} needs 'id x y theta'")
        try:
            i, x, y, yaw = (float(v) for v in parts[1:5])
        except ValueError:
            raise TrajectoryError(f"{p}:{n}: not a number in {line.strip()[:80]!r}") from None
        rows.append([i, x, y, 0.0, yaw, 0.0, 0.0, i])
    a = np.asarray(rows).reshape(-1, 8)
    a = a[np.argsort(a[:, 0], kind="stable")]
    if len(np.unique(a[:, 0])) != len(a):
        raise TrajectoryError(f"{p}: MRPT graph has repeated node ids")
    return _traj(a, p)


def apply_step_times(traj: Trajectory, times: PathLike, *, unsorted: str = "error"
                     ) -> Trajectory:
    """Give an index-timed trajectory (``icp-slam``'s pose log, a ``graphslam-engine``
    graph) clock times: pose ``k`` gets the ``k``-th number of ``times`` (one per line,
    ``#``/``%`` comments skipped), e.g. the ``<rawlog>.steps.txt`` / ``.nodes.txt`` files
    that :func:`slamq.synth.writers.write_rawlog`'s sequences come with. Times that go
    backwards (a log whose stamps do) are refused, sorted or cut by ``unsorted``
    (``"error"``, ``"sort"``, ``"last"``; :func:`slamq.models.trajectory.order_rows`).

    Raises
    ------
    slamq.TrajectoryError
        A time is not an integer index, or an index past the end of the file; times that
        go backwards with ``unsorted="error"``.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (d / "log.txt").write_text("0 0 0 0\\n1 0.5 0 0.1\\n")
    >>> _ = (d / "steps.txt").write_text("100.0\\n100.1\\n100.2\\n")
    >>> apply_step_times(read_mrpt_path(d / "log.txt"), d / "steps.txt").timestamps.tolist()
    [100.0, 100.1]
    """
    p = Path(times)
    try:
        text = p.read_text(errors="replace")
    except OSError as exc:
        raise TrajectoryError(f"{p}: cannot read step times ({exc.strerror or exc})") from exc
    values: list[float] = []
    for n, line in enumerate(text.splitlines(), 1):
        s = line.split("#", 1)[0].split("%", 1)[0].strip()
        if not s:
            continue
        try:
            values.append(float(s.split()[0]))
        except ValueError:
            raise TrajectoryError(f"{p}:{n}: not a time: {s[:80]!r}") from None
    t = np.asarray(values, np.float64)
    idx = np.asarray(traj.timestamps, np.float64)
    k = np.rint(idx).astype(np.int64)
    if len(idx) and (not np.allclose(idx, k) or k.min() < 0 or k.max() >= len(t)):
        raise TrajectoryError(f"{traj.source}: poses indexed {int(idx.min())}..{idx.max():g} "
                              f"do not fit the {len(t)} step times of {p}")
    t = t[k]
    keep = order_rows(t, unsorted)
    if keep.shape[0] != t.shape[0] or (keep != np.arange(t.shape[0])).any():
        return dataclasses.replace(traj, timestamps=t[keep], positions=traj.positions[keep],
                                   orientations=traj.orientations[keep])
    return dataclasses.replace(traj, timestamps=t)
