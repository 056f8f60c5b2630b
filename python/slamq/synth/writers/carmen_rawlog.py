"""Real sensor logs as MRPT rawlogs with their own timestamps: a CARMEN log (or any stream
of :class:`~slamq.sources.carmen.Scan`) written in the action + sensory-frame form of
:func:`~slamq.synth.writers.rawlog.write_rawlog`, with the same encoding.

MRPT's ``carmen2rawlog`` stamps every entry with the time of the conversion, so its
rawlogs cannot be matched to a log's relations or ground truth by time; and it writes the
observation-only form on which ``rbpf-slam`` crashes. Here each entry keeps the log's
timestamp (microseconds, as CARMEN writes them: exact in MRPT's 100 ns ticks) and the
file order of the log (stamps that run backwards in the log run backwards here too).

Each scan is written with its own geometry: ``aperture`` = the span of its beams
(``angle_increment * (beams - 1)``), the beams counter-clockwise, the sensor pose = the
laser's offset on the robot turned so that the first beam lies at the scan's
``angle_min`` (MRPT puts it at ``-aperture / 2``), invalid beams (no return) written as
``max_range`` with a zero valid flag. The odometry action before a scan holds the
increment since the previous scan's odometry pose (zero before the first).
"""

from __future__ import annotations

import math
import os
import struct
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from slamq.errors import SequenceError, SlamqError
from slamq.sources.carmen import CarmenLog, Scan
from slamq.synth.writers.rawlog import (
    _END,
    _FRAME,
    _SCAN,
    MOTION_MODEL,
    _action,
    _pose3d,
    graphslam_nodes,
    odometry_increments,
)

__all__ = ["carmen_to_rawlog", "write_scans_rawlog", "ticks"]

_UNIX_TO_1601_US = 11_644_473_600 * 1_000_000


def ticks(stamp: float) -> int:
    """MRPT ``TTimeStamp`` (100 ns ticks since 1601) of a Unix time given to the
    microsecond, exactly (a float64 Unix time is rounded to the microsecond first, so
    ``976052857.337530`` gives ``...3375300`` and not a tick either side).

    Examples
    --------
    >>> ticks(976052857.33753)
    126205264573375300
    >>> ticks(0.0)
    116444736000000000
    """
    return (round(stamp * 1e6) + _UNIX_TO_1601_US) * 10


def write_scans_rawlog(scans: Iterable[Scan], path: str | os.PathLike[str], *,
                       motion_model: dict[str, float] | None = None,
                       sensor_label: str = "LASER",
                       node_interval: tuple[float, float] = (0.5, 30.0)) -> dict[str, Any]:
    """Write scans as an MRPT rawlog (streamed: one scan in memory at a time), with the
    sidecars that put ``icp-slam``'s and ``graphslam-engine``'s index-only pose logs on
    the scans' clock: ``<rawlog>.steps.txt`` (the time of each scan, ``%.6f``) and
    ``<rawlog>.nodes.txt`` (the times of ``graphslam-engine``'s graph nodes,
    :func:`~slamq.synth.writers.rawlog.graphslam_nodes` with ``node_interval`` = (metres,
    degrees)); the same sidecars :func:`~slamq.synth.writers.rawlog.write_step_times`
    writes for generated sequences.

    Parameters
    ----------
    scans : iterable of Scan
    path : path
        The ``.rawlog`` file to write.
    motion_model : dict, optional
        Overrides of :data:`~slamq.synth.writers.rawlog.MOTION_MODEL`.
    sensor_label : str, default "LASER"
    node_interval : (float, float), default (0.5, 30.0)

    Returns
    -------
    dict
        ``rawlog``, ``steps``, ``nodes`` (paths), ``scans`` (count), ``first`` / ``last``
        (the first and last scan's Unix time, NaN when there is none).

    Raises
    ------
    slamq.SlamqError
        A file cannot be written; an unknown motion-model key.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> scan = Scan(976052857.33753, (0.0, 0.0, 0.0), np.array([1, np.inf], np.float32),
    ...             -math.pi / 2, math.pi, 80.0, 0.01, (0.0, 0.0, 0.0), "FLASER", 1)
    >>> out = write_scans_rawlog([scan, scan], pathlib.Path(tempfile.mkdtemp()) / "a.rawlog")
    >>> out["scans"], out["steps"].read_text().split()
    (2, ['976052857.337530', '976052857.337530'])
    """
    model = dict(MOTION_MODEL)
    if motion_model:
        unknown = set(motion_model) - set(MOTION_MODEL)
        if unknown:
            raise SlamqError(f"motion_model: unknown keys {sorted(unknown)} "
                             f"(known: {', '.join(MOTION_MODEL)})")
        model.update({k: float(v) for k, v in motion_model.items()})
    path = Path(path)
    label = sensor_label.encode()
    steps_path = path.with_name(path.name + ".steps.txt")
    nodes_path = path.with_name(path.name + ".nodes.txt")
    stamps: list[float] = []
    odom: list[tuple[float, float, float]] = []  # 32 bytes a scan, for the node sidecar
    prev: tuple[float, float, float] | None = None
    # complete files only: written as .part, renamed when done (the rawlog last)
    part, steps_part, nodes_part = (p.with_name(p.name + ".part")
                                    for p in (path, steps_path, nodes_path))
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(part, "wb", buffering=1 << 20) as f, \
                open(steps_part, "w", encoding="ascii") as steps:
            for scan in scans:
                n = len(scan.ranges)
                t = ticks(scan.stamp)
                inc = (np.zeros(3) if prev is None
                       else odometry_increments(np.array([prev, scan.odom]))[1])
                prev = scan.odom
                aperture = scan.angle_increment * (n - 1) if n > 1 else 0.0
                ox, oy, oyaw = scan.offset
                yaw = oyaw + scan.angle_min + aperture / 2
                r = np.asarray(scan.ranges, np.float32)
                valid = np.isfinite(r) & (r < scan.max_range)
                r = np.where(valid, r, np.float32(scan.max_range)).astype("<f4")
                f.write(b"".join((
                    _action(inc, t, model),
                    _FRAME, struct.pack("<I", 1), _SCAN,
                    struct.pack("<f?f", aperture, True, scan.max_range),
                    _pose3d(ox, oy, math.atan2(math.sin(yaw), math.cos(yaw))),
                    struct.pack("<I", n), r.tobytes(), valid.astype(np.int8).tobytes(),
                    struct.pack("<f", scan.range_noise), struct.pack("<Q", t),
                    struct.pack("<f", scan.angle_increment), struct.pack("<I", len(label)),
                    label, struct.pack("<d?", 0.0, False), _END, _END)))
                steps.write(f"{scan.stamp:.6f}\n")
                stamps.append(scan.stamp)
                odom.append(scan.odom)
        nodes = graphslam_nodes(np.array(odom, np.float64).reshape(-1, 3), node_interval[0],
                                math.radians(node_interval[1]))
        np.savetxt(nodes_part, np.asarray(stamps, np.float64)[nodes], fmt="%.6f")
        os.replace(steps_part, steps_path)
        os.replace(nodes_part, nodes_path)
        os.replace(part, path)
    except OSError as exc:
        raise SlamqError(f"{path}: cannot write the rawlog ({exc.strerror or exc})") from exc
    finally:  # after a failure (a bad line, a full disk): no debris
        for p in (part, steps_part, nodes_part):
            p.unlink(missing_ok=True)
    return {"rawlog": path, "steps": steps_path, "nodes": nodes_path, "scans": len(stamps),
            "first": stamps[0] if stamps else math.nan,
            "last": stamps[-1] if stamps else math.nan}


def carmen_to_rawlog(log: str | os.PathLike[str], out: str | os.PathLike[str], *,
                     max_scans: int | None = None, laser: str = "front",
                     odometry: str = "auto", motion_model: dict[str, float] | None = None,
                     sensor_label: str = "LASER",
                     node_interval: tuple[float, float] = (0.5, 30.0)) -> dict[str, Any]:
    """Convert a CARMEN log into an MRPT rawlog that keeps the log's timestamps.

    The scans of one laser (:meth:`slamq.sources.carmen.CarmenLog.scans`) in file order,
    each after the odometry increment since the one before; with the
    ``<rawlog>.steps.txt`` / ``<rawlog>.nodes.txt`` sidecars (:func:`write_scans_rawlog`)
    whose times tie ``icp-slam``'s and ``graphslam-engine``'s pose logs to the log's
    clock. ``rbpf-slam``, ``icp-slam`` and ``graphslam-engine`` read it.

    Parameters
    ----------
    log : path
        The CARMEN log (``.clf`` / ``.log``, plain or gzip).
    out : path
        The ``.rawlog`` to write.
    max_scans : int, optional
        Only the first ``max_scans`` scans (a cut of the log's head).
    laser : {"front", "rear"}, default "front"
    odometry : {"auto", "odom"}, default "auto"
        See :meth:`~slamq.sources.carmen.CarmenLog.scans`.
    motion_model, sensor_label, node_interval
        See :func:`write_scans_rawlog`.

    Returns
    -------
    dict
        What :func:`write_scans_rawlog` returns, plus ``log`` (the path read) and
        ``skipped`` (unknown record types skipped, type -> lines; only after a full pass).

    Raises
    ------
    slamq.SequenceError
        The log cannot be read or has a malformed line (file and line named), or holds no
        scan of the laser.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (d / "a.clf").write_text(
    ...     "FLASER 3 1 2 3 0 0 0 0 0 0 100.25 h 0.1\\n"
    ...     "FLASER 3 1 2 3 0.1 0 0 0.1 0 0 100.5 h 0.2\\n")
    >>> info = carmen_to_rawlog(d / "a.clf", d / "a.rawlog")
    >>> info["scans"], info["first"], info["last"]
    (2, 100.25, 100.5)
    """
    source = CarmenLog(log)
    info = write_scans_rawlog(source.scans(laser=laser, odometry=odometry,
                                           max_scans=max_scans), out,
                              motion_model=motion_model, sensor_label=sensor_label,
                              node_interval=node_interval)
    if info["scans"] == 0 and max_scans != 0:
        for p in (info["rawlog"], info["steps"], info["nodes"]):
            p.unlink(missing_ok=True)
        raise SequenceError(f"{source.path}: no {laser} laser scans "
                            f"({', '.join(sorted(source.counts)) or 'no records'} read)")
    info.update(log=source.path, skipped=dict(source.skipped))
    return info
