"""CARMEN log writer: ``PARAM``, ``ODOM`` and ``ROBOTLASER1`` lines.

Line formats (the CARMEN logger's)::

    PARAM name value timestamp hostname logger_timestamp
    ODOM x y theta tv rv accel timestamp hostname logger_timestamp
    ROBOTLASER1 laser_type start_angle field_of_view angular_resolution maximum_range
        accuracy remission_mode num_readings [range_readings] num_remissions [remissions]
        laser_pose_x laser_pose_y laser_pose_theta robot_pose_x robot_pose_y
        robot_pose_theta laser_tv laser_rv forward_safety_dist side_safety_dist turn_axis
        timestamp hostname logger_timestamp

Both poses of a laser line are *odometry* poses (the robot's odometry and the laser at its
offset from it): CARMEN logs them so, and MRPT's ``carmen2rawlog`` takes the laser's
offset on the robot as ``laser pose - robot pose``, so the true pose written there would
leak the ground truth. A beam with no return is written as ``maximum_range`` (the CARMEN
convention; readers treat ``>= maximum_range`` as no return).

MRPT 2.5.8's ``carmen2rawlog`` reads only ``ROBOTLASER*``, ``FLASER``/``RLASER`` and
``PARAM`` lines (``ODOM`` lines are ignored, the odometry comes from the laser lines) and
converts a line's timestamp with ``microseconds(1e-6 * timestamp)``: ordinary Unix
seconds collapse into one timestamp there. Its output is the observation-only rawlog form
on which ``rbpf-slam`` crashes; write the rawlog directly (:func:`write_rawlog`) for MRPT.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from slamq.errors import SlamqError
from slamq.synth.recording import Recording
from slamq.synth.writers.rawlog import EPOCH

__all__ = ["write_carmen", "read_carmen"]

_LASER_TYPE = 3  # SIMULATED_LASER (SICK_LMS 0, SICK_PLS 1, HOKUYO_URG 2)


def _fixed3(a: np.ndarray) -> np.ndarray:
    """``(N, M)`` non-negative floats as ``(N, M * w)`` ASCII bytes: each value right-aligned
    in ``w`` characters (a leading space, then ``%.3f``); vectorised ``"%.3f"``."""
    milli = np.round(np.asarray(a, np.float64) * 1000).astype(np.int64)
    digits = max(4, len(str(int(milli.max(initial=0)))))  # at least "0.000"
    w = digits + 2  # a space and the point
    out = np.full(milli.shape + (w,), ord(" "), np.uint8)
    rest = milli.copy()
    for k in range(digits):  # k-th digit from the right
        col = w - 1 - k - (1 if k >= 3 else 0)
        d = rest % 10
        rest //= 10
        keep = (k < 4) | (milli >= 10 ** k)  # no leading zeros before "0."
        out[..., col] = np.where(keep, ord("0") + d, ord(" "))
    out[..., w - 4] = ord(".")
    return out.reshape(milli.shape[0], -1)


def write_carmen(seq: Recording, path: str | Path, *, epoch: float = EPOCH,
                 hostname: str = "slamq") -> Path:
    """Write a sequence as a CARMEN log (``PARAM``, then an ``ODOM`` and a ``ROBOTLASER1``
    line per scan).

    Timestamps are Unix seconds, ``epoch + seq.stamps`` (also the logger timestamps);
    ranges have millimetre precision; velocities are the odometry's over each step.

    Parameters
    ----------
    seq : Recording
    path : path
    epoch : float, default :data:`~slamq.synth.writers.EPOCH`
    hostname : str, default "slamq"

    Returns
    -------
    pathlib.Path

    Examples
    --------
    >>> import tempfile, pathlib, numpy as np
    >>> from slamq.models import OccupancyMap
    >>> from slamq.synth import LaserSpec, Recording
    >>> world = OccupancyMap(np.full((4, 4), 254, np.uint8), np.zeros((4, 4), bool), 0.1)
    >>> seq = Recording(np.array([0.0, 0.1]), np.zeros((2, 3)), np.zeros((2, 3)),
    ...                np.array([[1, np.inf, 2]] * 2, np.float32), LaserSpec(beams=3), world)
    >>> p = write_carmen(seq, pathlib.Path(tempfile.mkdtemp()) / "s.log")
    >>> p.read_text().splitlines()[-1][:60]
    'ROBOTLASER1 3 -2.356194 4.712389 2.356194 20.000 0.010 0 3  '
    >>> read_carmen(p)["ranges"].tolist()
    [[1.0, inf, 2.0], [1.0, inf, 2.0]]
    """
    path = Path(path)
    laser = seq.laser
    n = len(seq)
    ranges = np.asarray(seq.ranges, np.float64)
    valid = np.isfinite(ranges) & (ranges >= laser.min_range) & (ranges < laser.max_range)
    odom = np.asarray(seq.odom, np.float64)
    ox, oy, oth = map(float, laser.offset)
    c, s = np.cos(odom[:, 2]), np.sin(odom[:, 2])
    lpose = np.column_stack([odom[:, 0] + c * ox - s * oy, odom[:, 1] + s * ox + c * oy,
                             np.angle(np.exp(1j * (odom[:, 2] + oth)))])
    t = epoch + np.asarray(seq.stamps, np.float64)
    tv = np.zeros(n)
    rv = np.zeros(n)
    if n > 1:
        dt = np.diff(t)
        tv[1:] = np.hypot(*np.diff(odom[:, :2], axis=0).T) / dt
        rv[1:] = np.angle(np.exp(1j * np.diff(odom[:, 2]))) / dt
    lines = [
        "# CARMEN log written by slamq (slamq.synth.writers.write_carmen)",
        f"# sequence {seq.name}: {n} scans x {laser.beams} beams",
        "# message formats:",
        "# ODOM x y theta tv rv accel timestamp hostname logger_timestamp",
        "# ROBOTLASER1 laser_type start_angle field_of_view angular_resolution maximum_range "
        "accuracy remission_mode num_readings [range_readings] num_remissions "
        "[remission_values] laser_pose_x laser_pose_y laser_pose_theta robot_pose_x "
        "robot_pose_y robot_pose_theta laser_tv laser_rv forward_safety_dist "
        "side_safety_dist turn_axis timestamp hostname logger_timestamp",
    ]
    t0 = float(t[0]) if n else epoch
    for key, value in (("robot_front_laser_max", f"{laser.max_range:.3f}"),
                       ("laser_front_laser_fov", f"{np.degrees(laser.fov):.6f}"),
                       ("laser_front_laser_resolution",
                        f"{np.degrees(laser.angle_increment):.6f}"),
                       ("robot_frontlaser_offset", f"{ox:.6f}"),
                       ("robot_frontlaser_side_offset", f"{oy:.6f}"),
                       ("robot_frontlaser_angular_offset", f"{oth:.6f}")):
        lines.append(f"PARAM {key} {value} {t0:.6f} {hostname} {t0:.6f}")
    head = (f"ROBOTLASER1 {_LASER_TYPE} {laser.angle_min:.6f} {laser.fov:.6f} "
            f"{laser.angle_increment:.6f} {laser.max_range:.3f} {laser.range_noise:.3f} 0 "
            f"{laser.beams} ").encode()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(path, "wb", buffering=1 << 20) as f:
            f.write("\n".join(lines).encode() + b"\n")
            for lo in range(0, n, 256):  # ranges formatted 256 scans at a time
                text = _fixed3(np.where(valid[lo:lo + 256], ranges[lo:lo + 256],
                                        laser.max_range))
                for i in range(lo, min(n, lo + 256)):
                    ts = f"{t[i]:.6f}"
                    f.write(b"".join((
                        f"ODOM {odom[i, 0]:.6f} {odom[i, 1]:.6f} {odom[i, 2]:.6f} "
                        f"{tv[i]:.6f} {rv[i]:.6f} 0.000000 {ts} {hostname} {ts}\n".encode(),
                        head, text[i - lo].tobytes(),
                        (f" 0 {lpose[i, 0]:.6f} {lpose[i, 1]:.6f} {lpose[i, 2]:.6f} "
                         f"{odom[i, 0]:.6f} {odom[i, 1]:.6f} {odom[i, 2]:.6f} {tv[i]:.6f} "
                         f"{rv[i]:.6f} 0.000000 0.000000 0.000000 {ts} {hostname} {ts}\n"
                         ).encode())))
    except OSError as exc:
        raise SlamqError(f"{path}: cannot write the CARMEN log ({exc.strerror or exc})") from exc
    return path


def read_carmen(path: str | Path) -> dict[str, np.ndarray]:
    """Read the ``ROBOTLASER1`` and ``ODOM`` lines of a CARMEN log (a small reader for
    checking written logs, not a general CARMEN parser).

    Returns
    -------
    dict
        ``stamps`` (N,), ``ranges`` (N, beams) float32 with ``inf`` for no return
        (``>= maximum_range``), ``laser_pose`` and ``robot_pose`` (N, 3), ``odom`` (M, 3),
        ``odom_stamps`` (M,), ``params`` (name -> value string), ``fov``, ``max_range``.

    Raises
    ------
    slamq.SlamqError
        A malformed line (the file and line number are named).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "a.log"
    >>> _ = p.write_text("ROBOTLASER1 0 -1.57 3.14 1.57 8.0 0.01 0 3 1.0 8.0 2.5 0 "
    ...                  "0.1 0 0 0 0 0 0 0 0 0 0 12.5 host 12.5\\n")
    >>> log = read_carmen(p)
    >>> log["ranges"].tolist(), log["laser_pose"].tolist(), log["stamps"].tolist()
    ([[1.0, inf, 2.5]], [[0.1, 0.0, 0.0]], [12.5])
    """
    path = Path(path)
    stamps, ranges, lpose, rpose, odom, ostamps = [], [], [], [], [], []
    params: dict[str, str] = {}
    fov = max_range = float("nan")
    try:
        text = path.read_text()
    except OSError as exc:
        raise SlamqError(f"{path}: cannot read ({exc.strerror or exc})") from exc
    for no, line in enumerate(text.splitlines(), 1):
        f = line.split()
        if not f or f[0].startswith("#"):
            continue
        try:
            if f[0] == "PARAM":
                params[f[1]] = f[2]
            elif f[0] == "ODOM":
                odom.append([float(x) for x in f[1:4]])
                ostamps.append(float(f[7]))
            elif f[0].startswith("ROBOTLASER"):
                fov, max_range = float(f[3]), float(f[5])
                k = int(f[8])
                r = np.array(f[9:9 + k], np.float32)
                r[r >= max_range] = np.inf
                ranges.append(r)
                j = 9 + k
                j += 1 + int(f[j])
                lpose.append([float(x) for x in f[j:j + 3]])
                rpose.append([float(x) for x in f[j + 3:j + 6]])
                stamps.append(float(f[j + 11]))
        except (IndexError, ValueError) as exc:
            raise SlamqError(f"{path}:{no}: malformed {f[0]} line ({exc})") from None
    return {"stamps": np.array(stamps), "ranges": np.array(ranges, np.float32),
            "laser_pose": np.array(lpose).reshape(-1, 3),
            "robot_pose": np.array(rpose).reshape(-1, 3), "odom": np.array(odom).reshape(-1, 3),
            "odom_stamps": np.array(ostamps), "params": params, "fov": fov,
            "max_range": max_range}
