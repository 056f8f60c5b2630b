"""MRPT rawlog writer: the binary ``CArchive`` stream of ``CActionCollection`` /
``CSensoryFrame`` pairs that ``rbpf-slam``, ``icp-slam`` and ``graphslam-engine`` read.

Written from the serialization format of MRPT 2.x (checked against 2.5.8, Debian
``mrpt-apps``), in plain Python; no MRPT needed to write. The stream is:

* per object: ``0x80 | len(class name)`` (one byte), the class name (MRPT 2 writes the
  fully qualified name, e.g. ``mrpt::obs::CSensoryFrame``), the class's serialization
  version (one byte), its fields (little endian), the end flag ``0x88``;
* ``CActionCollection`` v0: ``uint32`` count, the actions;
* ``CActionRobotMovement2D`` v7: ``uint32`` estimation method (0 = odometry), the raw
  odometry increment as a ``CPose2D`` object (v1: ``x y phi`` doubles), ``uint32`` motion
  model (0 = Gaussian), its ``a1 a2 a3 a4 minStdXY minStdPHI`` as floats, the Thrun model
  (``uint32`` particles, six floats), ``bool`` has velocities, ``bool`` has encoders,
  ``uint64`` timestamp; the reader rebuilds the Gaussian pose PDF from the increment;
* ``CSensoryFrame`` v2: ``uint32`` count, the observations;
* ``CObservation2DRangeScan`` v7: ``float`` aperture, ``bool`` rightToLeft, ``float``
  maxRange, the sensor pose as a ``CPose3D`` object (v3: ``x y z`` and the row-major 3x3
  rotation, doubles), ``uint32`` N, N ``float`` ranges, N ``int8`` valid flags, ``float``
  stdError, ``uint64`` timestamp, ``float`` beamAperture, the sensor label (``uint32``
  length + bytes), ``double`` deltaPitch, ``bool`` has intensity.

Timestamps (``TTimeStamp``) count 100 ns ticks since 1601-01-01 UTC.
"""

from __future__ import annotations

import math
import struct
from pathlib import Path
from typing import Any

import numpy as np

from slamq.errors import SlamqError
from slamq.synth.recording import EPOCH, Recording

__all__ = ["EPOCH", "MOTION_MODEL", "graphslam_nodes", "mrpt_timestamp", "odometry_increments",
           "write_rawlog", "write_step_times"]

#: MRPT's Gaussian odometry motion model (``CActionRobotMovement2D``'s defaults): the
#: standard deviations grow with the increment as ``a1`` (m/m), ``a2`` (m/rad), ``a3``
#: (rad/m), ``a4`` (rad/rad), at least ``min_std_xy`` m and ``min_std_phi`` rad.
MOTION_MODEL: dict[str, float] = {
    "a1": 0.01, "a2": math.degrees(0.001), "a3": math.radians(1.0), "a4": 0.05,
    "min_std_xy": 0.01, "min_std_phi": math.radians(0.2),
}

_END = b"\x88"
_UNIX_TO_1601 = 11_644_473_600  # seconds from 1601-01-01 to 1970-01-01


def mrpt_timestamp(seconds: float | np.ndarray) -> Any:
    """MRPT ``TTimeStamp`` (100 ns ticks since 1601-01-01 UTC) of Unix times in seconds.

    Examples
    --------
    >>> mrpt_timestamp(0.0)
    116444736000000000
    >>> mrpt_timestamp(EPOCH + 0.5) - mrpt_timestamp(EPOCH)
    5000000
    """
    s = np.asarray(seconds, np.float64)
    whole = np.floor(s)
    # whole seconds in integers (1.3e17 ticks is past float64's exact integers)
    ticks = ((whole.astype(np.int64) + _UNIX_TO_1601) * 10_000_000
             + np.round((s - whole) * 1e7).astype(np.int64))
    return int(ticks) if ticks.ndim == 0 else ticks.astype(np.uint64)


def odometry_increments(odom: np.ndarray) -> np.ndarray:
    """``(N, 3)`` increments ``(dx, dy, dyaw)`` of each odometry pose from the one before, in
    the earlier pose's frame (row 0 is zero): what a wheel odometer reports between scans.

    Examples
    --------
    >>> odometry_increments(np.array([[1.0, 1, np.pi / 2], [1, 2, np.pi]])).round(6).tolist()
    [[0.0, 0.0, 0.0], [1.0, 0.0, 1.570796]]
    """
    odom = np.asarray(odom, np.float64)
    inc = np.zeros_like(odom)
    if len(odom) > 1:
        d = odom[1:, :2] - odom[:-1, :2]
        c, s = np.cos(odom[:-1, 2]), np.sin(odom[:-1, 2])
        inc[1:, 0] = c * d[:, 0] + s * d[:, 1]
        inc[1:, 1] = -s * d[:, 0] + c * d[:, 1]
        inc[1:, 2] = np.angle(np.exp(1j * (odom[1:, 2] - odom[:-1, 2])))
    return inc


def graphslam_nodes(odom: np.ndarray, max_distance: float = 0.5,
                    max_angle: float = math.radians(30.0)) -> np.ndarray:
    """Indices of the scans at which ``graphslam-engine``'s ``CFixedIntervalsNRD`` adds a
    graph node: the first scan, then each scan where the odometry since the last node has
    moved more than ``max_distance`` metres or turned more than ``max_angle`` radians
    (``[NodeRegistrationDeciderParameters] registration_max_distance`` /
    ``registration_max_angle``; MRPT 2.5.8 composes the increments exactly so). Node ``k``
    of its output graph is the robot at scan ``graphslam_nodes(...)[k]``.

    Examples
    --------
    >>> odom = np.column_stack([np.arange(12) * 0.2, np.zeros(12), np.zeros(12)])
    >>> graphslam_nodes(odom).tolist()
    [0, 3, 6, 9]
    """
    inc = odometry_increments(odom)
    nodes = [0] if len(inc) else []
    x = y = th = 0.0
    for i in range(1, len(inc)):
        dx, dy, dth = inc[i]
        c, s = math.cos(th), math.sin(th)
        x, y, th = x + c * dx - s * dy, y + s * dx + c * dy, th + dth
        th = math.atan2(math.sin(th), math.cos(th))
        if math.hypot(x, y) > max_distance or abs(th) > max_angle:
            nodes.append(i)
            x = y = th = 0.0
    return np.asarray(nodes, np.int64)


def write_step_times(seq: Recording, rawlog: str | Path, *, epoch: float = EPOCH,
                     node_interval: tuple[float, float] = (0.5, 30.0)) -> tuple[Path, Path]:
    """Write the sidecars that put index-only pose logs on the sequence's clock.

    ``<rawlog>.steps.txt``: the Unix time of each scan, one per line (``icp-slam``'s pose
    log numbers its poses by step); ``<rawlog>.nodes.txt``: the time of each
    ``graphslam-engine`` graph node (:func:`graphslam_nodes` with ``node_interval`` =
    (metres, degrees), its ``registration_max_distance`` / ``registration_max_angle``).
    ``slamq run`` reads them through an output's ``times:`` (e.g.
    ``times: "{input}.steps.txt"``).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from slamq.models import OccupancyMap
    >>> from slamq.synth import LaserSpec
    >>> world = OccupancyMap(np.full((4, 4), 254, np.uint8), np.zeros((4, 4), bool), 0.1)
    >>> odom = np.column_stack([np.arange(4) * 0.3, np.zeros(4), np.zeros(4)])
    >>> seq = Recording(np.arange(4) * 0.1, odom, odom, np.ones((4, 3), np.float32),
    ...                LaserSpec(beams=3), world)
    >>> steps, nodes = write_step_times(seq, pathlib.Path(tempfile.mkdtemp()) / "s.rawlog")
    >>> nodes.read_text().split()
    ['1700000000.000000', '1700000000.200000']
    """
    rawlog = Path(rawlog)
    t = epoch + np.asarray(seq.stamps, np.float64)
    nodes = graphslam_nodes(seq.odom, node_interval[0], math.radians(node_interval[1]))
    steps_path = rawlog.with_name(rawlog.name + ".steps.txt")
    nodes_path = rawlog.with_name(rawlog.name + ".nodes.txt")
    try:
        np.savetxt(steps_path, t, fmt="%.6f")
        np.savetxt(nodes_path, t[nodes], fmt="%.6f")
    except OSError as exc:
        raise SlamqError(f"{steps_path}: cannot write ({exc.strerror or exc})") from exc
    return steps_path, nodes_path


def _header(name: str, version: int) -> bytes:
    raw = name.encode()
    return bytes([0x80 | len(raw)]) + raw + bytes([version])


_POSE2D = _header("mrpt::poses::CPose2D", 1)
_POSE3D = _header("mrpt::poses::CPose3D", 3)
_ACTIONS = _header("mrpt::obs::CActionCollection", 0)
_MOVE = _header("mrpt::obs::CActionRobotMovement2D", 7)
_FRAME = _header("mrpt::obs::CSensoryFrame", 2)
_SCAN = _header("mrpt::obs::CObservation2DRangeScan", 7)


def _pose3d(x: float, y: float, yaw: float) -> bytes:
    c, s = math.cos(yaw), math.sin(yaw)
    return _POSE3D + struct.pack("<12d", x, y, 0.0, c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0) + _END


def _action(inc: np.ndarray, ticks: int, model: dict[str, float]) -> bytes:
    body = (struct.pack("<I", 0) + _POSE2D + struct.pack("<3d", *map(float, inc)) + _END
            + struct.pack("<I6f", 0, model["a1"], model["a2"], model["a3"], model["a4"],
                          model["min_std_xy"], model["min_std_phi"])
            # Thrun model (unused with the Gaussian model): MRPT's defaults
            + struct.pack("<I6f", 300, 0.05, math.radians(4.0), 0.01, math.degrees(0.0001),
                          0.001, math.radians(0.05))
            + struct.pack("<??Q", False, False, ticks))
    return _ACTIONS + struct.pack("<I", 1) + _MOVE + body + _END + _END


def write_rawlog(seq: Recording, path: str | Path, *, motion_model: dict[str, float] | None = None,
                 sensor_label: str = "LASER", epoch: float = EPOCH) -> Path:
    """Write a sequence as an MRPT rawlog in the action + sensory-frame form.

    Each scan becomes a ``CActionCollection`` holding one ``CActionRobotMovement2D`` (the
    odometry increment since the previous scan, zero before the first, with MRPT's
    Gaussian motion model) followed by a ``CSensoryFrame`` holding one
    ``CObservation2DRangeScan`` (aperture = the laser's field of view, beams right to
    left, ``maxRange``, the sensor pose = the laser's offset on the robot, ranges with a
    valid flag per beam: no return, or a range outside ``[min_range, max_range]``, is
    invalid and written as ``max_range``). Timestamps are ``epoch + seq.stamps``. This is
    the form ``rbpf-slam`` needs (it crashes on observation-only rawlogs such as
    ``carmen2rawlog`` writes); ``icp-slam`` and ``graphslam-engine`` read it too.

    Parameters
    ----------
    seq : Recording
    path : path
        The ``.rawlog`` file to write (uncompressed; MRPT reads plain and gzip alike).
    motion_model : dict, optional
        Overrides of :data:`MOTION_MODEL` (keys ``a1 a2 a3 a4 min_std_xy min_std_phi``).
    sensor_label : str, default "LASER"
    epoch : float, default :data:`EPOCH`
        Unix time of the sequence's time 0.

    Returns
    -------
    pathlib.Path

    Examples
    --------
    >>> import tempfile, pathlib, numpy as np
    >>> from slamq.models import OccupancyMap
    >>> from slamq.synth import LaserSpec, Recording
    >>> laser = LaserSpec(beams=3)
    >>> world = OccupancyMap(np.full((4, 4), 254, np.uint8), np.zeros((4, 4), bool), 0.1)
    >>> seq = Recording(np.array([0.0, 0.1]), np.zeros((2, 3)), np.zeros((2, 3)),
    ...                np.array([[1, np.inf, 2]] * 2, np.float32), laser, world)
    >>> p = write_rawlog(seq, pathlib.Path(tempfile.mkdtemp()) / "s.rawlog")
    >>> p.read_bytes()[:29]
    b'\\x9cmrpt::obs::CActionCollection'
    """
    model = dict(MOTION_MODEL)
    if motion_model:
        unknown = set(motion_model) - set(MOTION_MODEL)
        if unknown:
            raise SlamqError(f"motion_model: unknown keys {sorted(unknown)} "
                             f"(known: {', '.join(MOTION_MODEL)})")
        model.update({k: float(v) for k, v in motion_model.items()})
    path = Path(path)
    laser = seq.laser
    n, beams = seq.ranges.shape
    ranges = np.asarray(seq.ranges, np.float32)
    valid = np.isfinite(ranges) & (ranges >= laser.min_range) & (ranges <= laser.max_range)
    ranges = np.where(valid, ranges, np.float32(laser.max_range)).astype("<f4")
    valid_bytes = valid.astype(np.int8)
    # the epoch's whole seconds apart: stamps keep their 100 ns precision
    whole = math.floor(epoch)
    ticks = mrpt_timestamp(whole) + mrpt_timestamp(epoch - whole + np.asarray(
        seq.stamps, np.float64)) - mrpt_timestamp(0.0)
    inc = odometry_increments(seq.odom)
    label = sensor_label.encode()
    scan_head = (_FRAME + struct.pack("<I", 1) + _SCAN
                 + struct.pack("<f?f", laser.fov, True, laser.max_range)
                 + _pose3d(*map(float, laser.offset)) + struct.pack("<I", beams))
    scan_mid = struct.pack("<f", laser.range_noise)
    scan_tail = (struct.pack("<f", laser.angle_increment) + struct.pack("<I", len(label))
                 + label + struct.pack("<d?", 0.0, False) + _END + _END)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(path, "wb", buffering=1 << 20) as f:  # streamed: flat memory
            for i in range(n):
                t = int(ticks[i])
                f.write(b"".join((_action(inc[i], t, model), scan_head, ranges[i].tobytes(),
                                  valid_bytes[i].tobytes(), scan_mid, struct.pack("<Q", t),
                                  scan_tail)))
    except OSError as exc:
        raise SlamqError(f"{path}: cannot write the rawlog ({exc.strerror or exc})") from exc
    return path
