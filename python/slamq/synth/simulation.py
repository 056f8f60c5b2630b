"""``simulate``: a world, a drive through it, and what the robot's laser and odometry read
along the drive, as one :class:`~slamq.synth.Recording`."""

from __future__ import annotations

import math
import os
from dataclasses import asdict
from typing import Any

import numpy as np

from slamq.errors import SlamqError
from slamq.models import OccupancyMap
from slamq.synth.planner import Drive, drive
from slamq.synth.recording import LaserSpec, Recording
from slamq.synth.sensors import NOISE, OdometryNoise, laser_scans, odometry, odometry_noise

__all__ = ["simulate"]


def simulate(world: OccupancyMap | str | os.PathLike[str], *, seed: int = 0,
             noise: str | OdometryNoise | dict[str, float] = "low",
             laser: LaserSpec | None = None, speed: float = 0.5, rate: float = 10.0,
             path: Drive | None = None, name: str | None = None,
             threads: int | None = None, **drive_options: Any) -> Recording:
    """Simulate a robot driving through ``world``: exact poses, noisy odometry, laser scans.

    Parameters
    ----------
    world : OccupancyMap or path
        A world (:func:`slamq.synth.worldgen.world`) or a map_server YAML
        (:func:`~slamq.synth.worldgen.load_world`).
    seed : int
        Seeds the drive, the range noise and the odometry noise (independent streams):
        the same arguments give the same sequence, bit for bit.
    noise : str, OdometryNoise or dict
        Odometry noise: a name of :data:`slamq.synth.sensors.NOISE` (``"none"``, ``"low"``,
        ``"high"``), an :class:`~slamq.synth.sensors.OdometryNoise` or a dict of its fields.
    laser : LaserSpec, optional
        The scanner (default ``LaserSpec()``: 1081 beams over 270 degrees, 20 m, 0.01 m
        range noise).
    speed, rate : float
        Metres per second and scans (and odometry readings) per second.
    path : Drive, optional
        Drive this instead of planning one (its ``stamps`` and ``poses``).
    name : str, optional
        Default: ``"<kind>-<world seed>-s<seed>-<noise>"`` (a map file: its stem for
        ``<kind>-<world seed>``).
    threads : int, optional
        Ray casting threads (None: every core); the result does not depend on it.
    **drive_options
        Passed to :func:`slamq.synth.planner.drive` (``clearance_m``, ``turn_rate``,
        ``length``, ``laps``, ``pauses``, ``kidnaps``, ...).

    Returns
    -------
    Recording
        ``meta`` records the world, the drive, the noise and the seed (JSON-serialisable).

    Examples
    --------
    >>> from slamq.synth.worldgen import world
    >>> seq = simulate(world(2, kind="office", size=(10.0, 8.0)), seed=1, noise="none",
    ...                laser=LaserSpec(beams=181))
    >>> seq.ranges.shape[1], seq.ranges.dtype, bool(abs(seq.odom - seq.gt).max() < 1e-9)
    (181, dtype('float32'), True)
    """
    from slamq.synth.worldgen import load_world

    if not isinstance(world, OccupancyMap):
        world = load_world(world)
    laser = LaserSpec() if laser is None else laser
    _check_laser(laser)
    nz = odometry_noise(noise)
    if path is None:
        path = drive(world, seed, speed=speed, rate=rate, **drive_options)
    elif drive_options:
        raise SlamqError(f"simulate: drive options {sorted(drive_options)} given with a path")
    streams = np.random.SeedSequence([int(seed), 0x51A]).spawn(2)
    ranges = laser_scans(world, path.poses, laser, seed=np.random.default_rng(streams[0]),
                         threads=threads)
    odom = odometry(path.poses, nz, seed=np.random.default_rng(streams[1]),
                    carried=path.meta.get("kidnaps", ()))
    wmeta = {k: v for k, v in world.meta.items() if k in ("kind", "seed", "features",
                                                           "size", "path", "name")}
    noise_name = next((k for k, v in NOISE.items() if v == nz), "custom")
    if name is None:
        what = wmeta.get("name") or f"{wmeta.get('kind', 'world')}-{wmeta.get('seed', 0)}"
        name = f"{what}-s{seed}-{noise_name}"
    meta = {
        "seed": int(seed),
        "world": dict(wmeta, source=world.source, shape=list(world.shape),
                      resolution=world.resolution, origin=list(world.origin)),
        "drive": path.meta,
        "odometry_noise": dict(nz.to_dict(), name=noise_name),
        "laser": {k: (list(v) if isinstance(v, tuple) else v)
                  for k, v in asdict(laser).items()},
        "scans": len(path),
    }
    return Recording(path.stamps.astype(np.float64), path.poses.copy(), odom, ranges, laser,
                    world, name=name, meta=meta)


def _check_laser(laser: LaserSpec) -> None:
    checks = [
        (isinstance(laser.beams, int) and laser.beams >= 1, "beams must be >= 1"),
        (math.isfinite(laser.fov) and 0 <= laser.fov <= 2 * math.pi,
         "fov must be within [0, 2 pi]"),
        (laser.max_range > 0, "max_range must be positive"),
        (0 <= laser.min_range < laser.max_range, "min_range must be in [0, max_range)"),
        (math.isfinite(laser.range_noise) and laser.range_noise >= 0,
         "range_noise must be >= 0"),
        (len(laser.offset) == 3 and all(math.isfinite(v) for v in laser.offset),
         "offset must be 3 finite numbers"),
    ]
    for ok, what in checks:
        if not ok:
            raise SlamqError(f"laser: {what} ({laser})")
