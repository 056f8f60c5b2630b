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

__all__ = ["WINDOW_S", "shortfalls"]


def shortfalls(records: list[dict[str, Any]], notes: list[str] | None = None,
               directions: dict[str, Any] | None = None
               ) -> dict[str, tuple[float, str | None]]:
    """Per program, how much shorter its path is than another program's at most.

    For programs a and b, the median of :func:`~slamq.metrics.travel.travel_ratio` over
    the pairs of their runs that have a trajectory; a's *shortfall* is the largest
    ``1 - ratio`` over the other programs, with the program it is measured against. NaN
    (and None) for a program without a trajectory, or when no other program has one.
    With ``directions``, the ratio of a pair is
    :func:`~slamq.metrics.travel.corridor_travel_ratio` with the scored scans of a's
    run's recording (its ``scans``), :func:`~slamq.metrics.travel.travel_ratio` where
    that recording was not measured: the shortfall along the corridors beyond the
    shortfall elsewhere.

    Parameters
    ----------
    records : list of dict
        Result rows with ``algorithm`` and ``trajectory`` (a path, str or path-like;
        missing, NaN or empty: none).
    notes : list of str, optional
        A trajectory that cannot be read is left out and said here.
    directions : dict, optional
        Recording path (a record's ``scans``, as str) -> its
        :class:`~slamq.models.ScanDegeneracy` with ``stamps``
        (:func:`slamq.metrics.degeneracy.scan_degeneracy`).

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
    from slamq.sources.trajectories import load_trajectory

    paths: dict[str, list[Any]] = {}
    seen: dict[str, list[Any]] = {}  # the scored scans of each run's recording, or None
    for rec in records:
        path = rec.get("trajectory")
        path = os.fspath(path) if isinstance(path, os.PathLike) else path
        alg = str(rec.get("algorithm"))
        if not isinstance(path, str) or not path.strip():
            paths.setdefault(alg, [])
            continue
        try:
            paths.setdefault(alg, []).append(load_trajectory(path, unsorted="sort"))
            d = (directions or {}).get(str(rec.get("scans")))
            seen.setdefault(alg, []).append(
                d if d is not None and getattr(d, "stamps", None) is not None else None)
        except SlamqError as exc:
            paths.setdefault(alg, [])
            if notes is not None:
                notes.append(f"{path}: its path not compared with the others' ({exc})")
    out: dict[str, tuple[float, str | None]] = {}
    for a, runs in paths.items():
        worst, against = math.nan, None
        for b, others in paths.items():
            if b == a:
                continue
            ratios = [travel_ratio(x, y) if d is None else
                      corridor_travel_ratio(x, y, d.stamps, d.ratios)
                      for x, d in zip(runs, seen.get(a, []), strict=True) for y in others]
            ratios = [r for r in ratios if math.isfinite(r)]
            if not ratios:
                continue
            short = 1.0 - float(np.median(ratios))
            if not math.isfinite(worst) or short > worst:
                worst, against = short, b
        out[a] = (worst, against)
    return out
