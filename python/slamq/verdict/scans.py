"""A record's map against its own scans (docs/spec.md section 7b), as the verdict weighs it
(section 9) and the detail page draws it: the record's ``scans`` (the recording the map
was built from, :func:`slamq.load_scans`) placed at its ``trajectory``.

At most :data:`MAX_SCANS` of the scans the trajectory places are scored per map, evenly
spread over them (every scan of a short recording): the figures are means over scans, and
the verdict of 6 maps with their scans must stay within a few seconds (issue 41). The last
:data:`CACHED` recordings read are kept in memory: the maps of one sequence share one.

The record's path is also scored against its own scans split in time (section 7e,
:func:`record_split`), with at most :data:`SPLIT_SCANS` scans drawn and tested a half, and
split within short stretches of itself (section 7f, :func:`record_local`): the program's map
is not read.
"""

from __future__ import annotations

import os
from collections import OrderedDict
from pathlib import Path
from typing import Any

import numpy as np

from slamq.errors import SlamqError
from slamq.metrics.scans import scan_consistency
from slamq.metrics.sync import evenly_spread, interpolate_poses
from slamq.models import OccupancyMap, Trajectory
from slamq.models.scans import ScanConsistency, Scans, ScanSplit

__all__ = ["CACHED", "MAX_SCANS", "SPLIT_SCANS", "has_scans", "record_consistency",
           "record_local", "record_split", "recording"]

#: Scans scored per map at most (evenly spread over those the trajectory places). 2000 and
#: 500 gave the same decision in all 304 cases of docs/validity.md's sets; 500 costs a
#: quarter of the time.
MAX_SCANS = 500
#: Scans drawn and scans tested a half at most in :func:`record_split` (docs/spec.md 7e's
#: ``max_draw`` and ``max_test``). The verdict's rule with 300 met its criterion on two sets
#: made after it was frozen (docs/validity.md, "C2 with 300 scans a half ... measured") at
#: a quarter to a third of the cost of the defaults.
SPLIT_SCANS = 300
#: Recordings kept in memory.
CACHED = 2

_CACHE: OrderedDict[tuple[str, int, int], Scans] = OrderedDict()


def has_scans(record: dict[str, Any]) -> bool:
    """Whether a record names both its recording (``scans``) and its ``trajectory``.

    Examples
    --------
    >>> has_scans({"scans": "a.rawlog", "trajectory": "t.tum"}), has_scans({"scans": None})
    (True, False)
    """
    def usable(v: Any) -> bool:
        return isinstance(v, (str, os.PathLike)) and str(v).strip() != ""

    return usable(record.get("scans")) and usable(record.get("trajectory"))


def recording(path: str | os.PathLike[str]) -> Scans:
    """The scans of a recording, read once while it is among the last :data:`CACHED`.

    Raises
    ------
    slamq.SlamqError
        The recording cannot be read (the file and the reason are named).
    """
    from slamq.sources.scans import load_scans

    p = Path(path)
    try:
        st = p.stat()
        key = (str(p.resolve()), st.st_mtime_ns, st.st_size)
    except OSError:
        return load_scans(p)  # names the file and why it cannot be read
    if key in _CACHE:
        _CACHE.move_to_end(key)
        return _CACHE[key]
    scans = load_scans(p)
    _CACHE[key] = scans
    while len(_CACHE) > CACHED:
        _CACHE.popitem(last=False)
    return scans


def _recorded(record: dict[str, Any]) -> tuple[Scans, Trajectory]:
    """The record's recording (:func:`recording`) and its ``trajectory``, read sorted by
    time."""
    from slamq.sources.trajectories import load_trajectory

    return recording(record["scans"]), load_trajectory(record["trajectory"], unsorted="sort")


def record_consistency(record: dict[str, Any], grid: OccupancyMap, *,
                       max_scans: int = MAX_SCANS, threads: int | None = None
                       ) -> ScanConsistency:
    """The record's map against its own scans, placed at its trajectory.

    Parameters
    ----------
    record : dict
        With ``scans`` (a recording) and ``trajectory`` (in the map's frame, on the
        recording's clock; read sorted by time).
    grid : OccupancyMap
        The record's map, loaded.
    max_scans : int, default :data:`MAX_SCANS`
        Of the scans the trajectory places, at most this many, evenly spread.
    threads : int, optional

    Returns
    -------
    ScanConsistency
        Over the scored scans only (``len(counts)`` of them).

    Raises
    ------
    slamq.SlamqError
        The recording or the trajectory cannot be read, or no scan can be placed.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from slamq.synth import LaserSpec, simulate, world
    >>> from slamq.synth.writers import write_groundtruth
    >>> from slamq.synth.writers.rawlog import write_rawlog
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> w = world(2, kind="office", size=(8.0, 6.0))
    >>> seq = simulate(w, seed=1, noise="none", laser=LaserSpec(beams=91), length=5.0)
    >>> rec = {"scans": str(write_rawlog(seq, d / "s.rawlog")),
    ...        "trajectory": str(write_groundtruth(seq, d / "gt.tum"))}
    >>> c = record_consistency(rec, w)
    >>> c.scans == len(seq), c.hit_share > 0.99, c.violation_share < 0.01
    (True, True, True)
    """
    scans, traj = _recorded(record)
    placed = interpolate_poses(traj, scans.stamps)[0]
    index = np.flatnonzero(placed)
    if index.size == 0:
        raise SlamqError(f"{record['trajectory']}: places none of the {len(scans)} scans of "
                         f"{scans.source} (another clock, or another recording?)")
    index = index[evenly_spread(index.size, max_scans)]
    part = Scans(scans.stamps[index], scans.angles, scans.ranges[index], scans.max_range,
                 min_range=scans.min_range, offset=scans.offset, source=scans.source,
                 meta=dict(scans.meta))
    return scan_consistency(grid, part, traj, threads=threads)


def record_split(record: dict[str, Any], *, max_scans: int = SPLIT_SCANS,
                 threads: int | None = None) -> ScanSplit:
    """The record's path against its own scans split in time (docs/spec.md 7e): each half
    of the scans its ``trajectory`` places drawn at its poses, scored with the other half.

    Parameters
    ----------
    record : dict
        With ``scans`` (a recording) and ``trajectory`` (on the recording's clock; read
        sorted by time). Its map is not read.
    max_scans : int, default :data:`SPLIT_SCANS`
        Scans drawn and scans tested a half, at most (evenly spread).
    threads : int, optional

    Returns
    -------
    ScanSplit

    Raises
    ------
    slamq.SlamqError
        The recording or the trajectory cannot be read, or it places fewer than 2 scans.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from slamq.synth import LaserSpec, simulate, world
    >>> from slamq.synth.writers import write_groundtruth
    >>> from slamq.synth.writers.rawlog import write_rawlog
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> seq = simulate(world(2, kind="office", size=(8.0, 6.0)), seed=1, noise="none",
    ...                laser=LaserSpec(beams=91), length=5.0)
    >>> rec = {"scans": str(write_rawlog(seq, d / "s.rawlog")),
    ...        "trajectory": str(write_groundtruth(seq, d / "gt.tum"))}
    >>> record_split(rec).crossing_share < 0.01
    True
    """
    from slamq.metrics.split import scan_split
    scans, traj = _recorded(record)
    return scan_split(scans, traj, max_draw=max_scans, max_test=max_scans, threads=threads)


def record_local(record: dict[str, Any], *, threads: int | None = None) -> dict[str, float]:
    """The record's path against its own scans split within short stretches of it
    (docs/spec.md 7f, :func:`slamq.metrics.split.local_split`).

    Parameters
    ----------
    record : dict
        With ``scans`` and ``trajectory``, as :func:`record_split`'s.
    threads : int, optional

    Returns
    -------
    dict
        ``local_crossing`` (the mean of the windows' crossing shares; NaN without a window)
        and ``windows`` (how many were scored).

    Raises
    ------
    slamq.SlamqError
        The recording or the trajectory cannot be read.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from slamq.synth import LaserSpec, simulate, world
    >>> from slamq.synth.writers import write_groundtruth
    >>> from slamq.synth.writers.rawlog import write_rawlog
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> seq = simulate(world(2, kind="office", size=(8.0, 6.0)), seed=1, noise="none",
    ...                laser=LaserSpec(beams=91), length=5.0)
    >>> rec = {"scans": str(write_rawlog(seq, d / "s.rawlog")),
    ...        "trajectory": str(write_groundtruth(seq, d / "gt.tum"))}
    >>> out = record_local(rec)
    >>> out["windows"] >= 1, out["local_crossing"] < 0.02
    (True, True)
    """
    from slamq.metrics.split import local_split
    scans, traj = _recorded(record)
    shares = local_split(scans, traj, threads=threads)
    finite = shares[np.isfinite(shares)]
    return {"local_crossing": float(finite.mean()) if finite.size else float("nan"),
            "windows": int(finite.size)}
