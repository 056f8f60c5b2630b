"""Each program's path against the others' (docs/spec.md 7d), as the verdict weighs it in
recordings whose scans see walls in one direction only (section 9).

:func:`shortfalls` loads the runs' trajectories and compares every pair of runs of
different programs with :func:`slamq.metrics.travel.travel_ratio`.
"""

from __future__ import annotations

import math
import os
from typing import Any

import numpy as np

from slamq.errors import SlamqError
from slamq.metrics.travel import WINDOW_S, corridor_travel_ratio, travel_ratio

__all__ = ["WINDOW_S", "path_shortfalls", "shortfalls"]


def shortfalls(records: list[dict[str, Any]], notes: list[str] | None = None
               ) -> dict[str, tuple[float, str | None]]:
    """Per program, how much shorter its path is than another program's at most.

    For programs a and b, the median of :func:`~slamq.metrics.travel.travel_ratio` over
    the pairs of their runs that have a trajectory; a's *shortfall* is the largest
    ``1 - ratio`` over the other programs, with the program it is measured against. NaN
    (and None) for a program without a trajectory, or when no other program has one.
    :func:`path_shortfalls` gives it with the shortfall along the corridors.

    Parameters
    ----------
    records : list of dict
        Result rows with ``algorithm`` and ``trajectory`` (a path, str or path-like;
        missing, NaN or empty: none).
    notes : list of str, optional
        A trajectory that cannot be read is left out and said here.

    Returns
    -------
    dict
        ``{algorithm: (shortfall, against)}``.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> import numpy as np
    >>> from slamq import Trajectory
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> t = np.arange(0.0, 30.0, 0.1)
    >>> for name, scale in (("a", 1.0), ("b", 0.9)):
    ...     _ = Trajectory.from_xy_yaw(t, 0.5 * t * scale, 0 * t, 0 * t).write_tum(
    ...         d / f"{name}.tum")
    >>> s = shortfalls([{"algorithm": n, "trajectory": d / f"{n}.tum"} for n in "ab"])
    >>> round(s["b"][0], 3), s["b"][1], round(s["a"][0], 3)
    (0.1, 'a', -0.111)
    """
    return path_shortfalls(records, notes)[0]


def path_shortfalls(records: list[dict[str, Any]], notes: list[str] | None = None,
                    directions: dict[str, Any] | None = None
                    ) -> tuple[dict[str, tuple[float, str | None]],
                               dict[str, tuple[float, str | None]]]:
    """:func:`shortfalls`, and the same along the recording's corridors beyond elsewhere,
    each trajectory read once.

    The second is built as the first with :func:`~slamq.metrics.travel.
    corridor_travel_ratio` for the ratio of a pair, with the scored scans of a's run's
    recording (its ``scans``); where that recording was not measured, the pair's
    :func:`~slamq.metrics.travel.travel_ratio`.

    Parameters
    ----------
    records, notes
        As :func:`shortfalls`'s.
    directions : dict, optional
        Recording path (a record's ``scans``, as str) -> its
        :class:`~slamq.models.ScanDegeneracy` with ``stamps``
        (:func:`slamq.metrics.degeneracy.scan_degeneracy`).

    Returns
    -------
    tuple of dict
        ``({algorithm: (shortfall, against)}, {algorithm: (corridor shortfall,
        against)})``; without ``directions`` the two are equal.
    """
    from slamq.sources.trajectories import load_trajectory

    runs: dict[str, list[tuple[Any, Any]]] = {}  # each run's path and scored scans
    for rec in records:
        path = rec.get("trajectory")
        path = os.fspath(path) if isinstance(path, os.PathLike) else path
        alg = str(rec.get("algorithm"))
        runs.setdefault(alg, [])
        if not isinstance(path, str) or not path.strip():
            continue
        try:
            traj = load_trajectory(path, unsorted="sort")
        except SlamqError as exc:
            if notes is not None:
                notes.append(f"{path}: its path not compared with the others' ({exc})")
            continue
        d = (directions or {}).get(str(rec.get("scans")))
        runs[alg].append((traj, d if getattr(d, "stamps", None) is not None else None))
    whole: dict[str, tuple[float, str | None]] = {}
    along: dict[str, tuple[float, str | None]] = {}
    for a, mine in runs.items():
        worst = {"whole": (math.nan, None), "along": (math.nan, None)}
        for b, others in runs.items():
            if b == a:
                continue
            ratios: dict[str, list[float]] = {"whole": [], "along": []}
            for x, d in mine:
                for y, _ in others:
                    r = travel_ratio(x, y)
                    ratios["whole"].append(r)
                    ratios["along"].append(
                        r if d is None else corridor_travel_ratio(x, y, d.stamps, d.ratios))
            for kind, values in ratios.items():
                finite = [v for v in values if math.isfinite(v)]
                if not finite:
                    continue
                short = 1.0 - float(np.median(finite))
                if not math.isfinite(worst[kind][0]) or short > worst[kind][0]:
                    worst[kind] = (short, b)
        whole[a], along[a] = worst["whole"], worst["along"]
    return whole, along
