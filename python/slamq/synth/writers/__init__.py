"""Writers: a :class:`~slamq.synth.Recording` as the files real SLAM programs read.

:data:`FORMATS` names them; :func:`write` writes several into one folder. One function per
format: :func:`write_rawlog` (MRPT), :func:`write_carmen`, :func:`write_rosbag1`,
:func:`write_rosbag2`, :func:`write_mcap`; :func:`write_groundtruth` writes the exact path
on the same clock (``EPOCH + seq.stamps``).
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import numpy as np

from slamq.errors import SlamqError
from slamq.synth.recording import Recording
from slamq.synth.writers.carmen import read_carmen, write_carmen
from slamq.synth.writers.rawlog import (
    EPOCH,
    MOTION_MODEL,
    graphslam_nodes,
    mrpt_timestamp,
    odometry_increments,
    write_rawlog,
    write_step_times,
)
from slamq.synth.writers.ros import FRAMES, write_mcap, write_rosbag1, write_rosbag2

__all__ = ["EPOCH", "FORMATS", "FRAMES", "MOTION_MODEL", "graphslam_nodes", "mrpt_timestamp",
           "odometry_increments", "read_carmen", "write", "write_carmen", "write_groundtruth",
           "write_mcap", "write_rawlog", "write_rosbag1", "write_rosbag2", "write_step_times"]

#: The formats :func:`write` knows, name -> description.
FORMATS: dict[str, str] = {
    "rawlog": "MRPT rawlog, action + sensory-frame form (rbpf-slam, icp-slam, "
              "graphslam-engine); <name>.rawlog, with <name>.rawlog.steps.txt and "
              "<name>.rawlog.nodes.txt (the times of icp-slam's steps and graphslam-engine's "
              "nodes)",
    "carmen": "CARMEN log: PARAM, ODOM and ROBOTLASER1 lines; <name>.log",
    "rosbag1": "ROS 1 bag: /scan, /odom, /tf (odom -> base_link -> laser), /clock; <name>.bag",
    "rosbag2": "ROS 2 bag, sqlite3 storage: /scan, /odom, /tf, /tf_static, /clock; "
               "folder <name>_ros2/",
    "mcap": "ROS 2 bag, MCAP storage: the same topics as rosbag2; folder <name>_mcap/",
}


def write_groundtruth(seq: Recording, path: str | Path, *, epoch: float = EPOCH) -> Path:
    """Write the exact path (``seq.gt``, world frame) as a TUM file on the writers' clock
    (``epoch + seq.stamps``): the ground truth for ``slamq ate`` / ``slamq run``.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from slamq.models import OccupancyMap
    >>> from slamq.synth import LaserSpec
    >>> world = OccupancyMap(np.full((4, 4), 254, np.uint8), np.zeros((4, 4), bool), 0.1)
    >>> gt = np.array([[0.0, 0, 0], [1, 0, np.pi / 2]])
    >>> seq = Recording(np.array([0.0, 0.1]), gt, gt, np.ones((2, 3), np.float32),
    ...                LaserSpec(beams=3), world)
    >>> p = write_groundtruth(seq, pathlib.Path(tempfile.mkdtemp()) / "gt.tum")
    >>> p.read_text().splitlines()[1]
    '1700000000.100000 1.000000 0.000000 0.000000 0.000000 0.000000 0.707107 0.707107'
    """
    path = Path(path)
    gt = np.asarray(seq.gt, np.float64)
    n = len(gt)
    rows = np.column_stack([epoch + np.asarray(seq.stamps, np.float64), gt[:, :2], np.zeros(n),
                            np.zeros((n, 2)), np.sin(gt[:, 2] / 2), np.cos(gt[:, 2] / 2)])
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        np.savetxt(path, rows, fmt="%.6f")
    except OSError as exc:
        raise SlamqError(f"{path}: cannot write ({exc.strerror or exc})") from exc
    return path


def write(seq: Recording, folder: str | Path, formats: Iterable[str] | str = tuple(FORMATS), *,
          epoch: float = EPOCH) -> dict[str, Path]:
    """Write a sequence in several formats into ``folder``.

    Files are named after ``seq.name`` (see :data:`FORMATS`); all share one clock,
    ``epoch + seq.stamps``.

    Parameters
    ----------
    seq : Recording
    folder : path
    formats : str or iterable of str, default every format
        Names from :data:`FORMATS`.
    epoch : float, default :data:`EPOCH`

    Returns
    -------
    dict
        format name -> the file or bag folder written.

    Raises
    ------
    slamq.SlamqError
        An unknown format, or a file that cannot be written.

    Examples
    --------
    >>> import tempfile
    >>> from slamq.models import OccupancyMap
    >>> from slamq.synth import LaserSpec
    >>> world = OccupancyMap(np.full((4, 4), 254, np.uint8), np.zeros((4, 4), bool), 0.1)
    >>> seq = Recording(np.array([0.0, 0.1]), np.zeros((2, 3)), np.zeros((2, 3)),
    ...                np.ones((2, 3), np.float32), LaserSpec(beams=3), world, name="demo")
    >>> out = write(seq, tempfile.mkdtemp(), ["rawlog", "carmen"])
    >>> {k: v.name for k, v in out.items()}
    {'rawlog': 'demo.rawlog', 'carmen': 'demo.log'}
    """
    names = [formats] if isinstance(formats, str) else list(formats)
    unknown = [f for f in names if f not in FORMATS]
    if unknown:
        raise SlamqError(f"unknown format(s) {', '.join(map(repr, unknown))} "
                         f"(known: {', '.join(FORMATS)})")
    folder = Path(folder)
    stem = seq.name
    out: dict[str, Path] = {}
    for fmt in names:
        if fmt == "rawlog":
            out[fmt] = write_rawlog(seq, folder / f"{stem}.rawlog", epoch=epoch)
            write_step_times(seq, out[fmt], epoch=epoch)
        elif fmt == "carmen":
            out[fmt] = write_carmen(seq, folder / f"{stem}.log", epoch=epoch)
        elif fmt == "rosbag1":
            out[fmt] = write_rosbag1(seq, folder / f"{stem}.bag", epoch=epoch)
        elif fmt == "rosbag2":
            out[fmt] = write_rosbag2(seq, folder / f"{stem}_ros2", epoch=epoch)
        else:
            out[fmt] = write_mcap(seq, folder / f"{stem}_mcap", epoch=epoch)
    return out
