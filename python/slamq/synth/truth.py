"""The ground truth of a simulated sequence, as files: the world's map, the part of it the
laser saw, the exact and the odometry paths, and how it was made; and a sequence saved and
loaded whole (``.npz``).

``visible_map`` is the map a SLAM run can fairly be compared to: the wall cells the laser
actually hit (a wall never seen, or a transparent one, is not in it) and the free cells its
beams swept, unknown elsewhere.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any

import numpy as np

from slamq.errors import SlamqError
from slamq.models import OccupancyMap, Trajectory
from slamq.synth.recording import EPOCH, LaserSpec, Recording
from slamq.synth.sensors import cast

__all__ = ["load_sequence", "save_sequence", "visible_map", "write_truth"]


def _laser_poses(seq: Recording) -> np.ndarray:
    ox, oy, oyaw = (float(v) for v in seq.laser.offset)
    g = seq.gt
    c, s = np.cos(g[:, 2]), np.sin(g[:, 2])
    return np.column_stack([g[:, 0] + c * ox - s * oy, g[:, 1] + s * ox + c * oy,
                            g[:, 2] + oyaw])


def visible_map(seq: Recording, *, threads: int | None = None) -> OccupancyMap:
    """The part of ``seq.world`` the laser saw: 0 on every wall cell a beam of the exact
    (noise-free) scans entered, 254 on the free cells inside the area the scans' returns
    swept, 205 elsewhere; the world's grid, resolution and origin.

    Examples
    --------
    >>> from slamq.synth.worldgen import world
    >>> from slamq.synth.simulation import simulate
    >>> seq = simulate(world(0, kind="hall", size=(10.0, 8.0)), noise="none",
    ...                laser=LaserSpec(beams=361), length=8.0)
    >>> v = visible_map(seq)
    >>> 0 < int((v.values == 0).sum()) <= int((seq.world.values == 0).sum())
    True
    """
    import cv2

    w = seq.world
    res = float(w.resolution)  # type: ignore[arg-type]
    h, wd = w.shape
    ox, oy, oyaw = w.origin
    poses = _laser_poses(seq)
    angles = seq.laser.angles()
    exact = cast(w, poses, angles, seq.laser.max_range, threads=threads)
    hit = np.isfinite(exact) & (exact >= seq.laser.min_range)
    a = poses[:, 2:3] + angles[None, :]
    # a point just inside the cell each beam entered, in grid units (x right, y down)
    r = np.where(hit, exact + min(1e-4, res * 1e-3), 0.0)
    wx = poses[:, 0:1] + r * np.cos(a) - ox
    wy = poses[:, 1:2] + r * np.sin(a) - oy
    c, s = math.cos(oyaw), math.sin(oyaw)
    gx = (c * wx + s * wy) / res
    gy = h - (c * wy - s * wx) / res
    walls = (w.values < 128) & ~w.unknown
    seen = np.zeros((h, wd), bool)
    col = np.floor(gx[hit]).astype(np.int64)
    row = np.floor(gy[hit]).astype(np.int64)
    inside = (row >= 0) & (row < h) & (col >= 0) & (col < wd)
    seen[row[inside], col[inside]] = True
    seen &= walls
    # the swept area: each scan's polygon (laser, then each return's end; a beam without a
    # return folds back to the laser), 1/8-cell fixed point
    swept = np.zeros((h, wd), np.uint8)
    lx = (c * (poses[:, 0] - ox) + s * (poses[:, 1] - oy)) / res
    ly = h - (c * (poses[:, 1] - oy) - s * (poses[:, 0] - ox)) / res
    ex = np.where(hit, gx, lx[:, None])
    ey = np.where(hit, gy, ly[:, None])
    for k in range(len(poses)):
        poly = np.concatenate([[[lx[k], ly[k]]], np.column_stack([ex[k], ey[k]])])
        pts = np.round((poly - 0.5) * 8).astype(np.int32)
        cv2.fillPoly(swept, [pts], 1, lineType=cv2.LINE_8, shift=3)
    free = (swept > 0) & (w.values >= 128) & ~w.unknown
    values = np.full((h, wd), 205, np.uint8)
    values[free] = 254
    values[seen] = 0
    return OccupancyMap(values, ~(free | seen), res, w.origin, source=f"{seq.name}:visible",
                        meta={"seen_walls": int(seen.sum()), "swept_free": int(free.sum())})


def _trajectory(seq: Recording, poses: np.ndarray, what: str) -> Trajectory:
    """A path on the clock of the sensor logs (``EPOCH + stamps``)."""
    return Trajectory.from_xy_yaw(EPOCH + seq.stamps, poses[:, 0], poses[:, 1], poses[:, 2],
                                  source=f"{seq.name}:{what}")


def start_frame_yaml(yaml_path: str | os.PathLike[str], first: Any) -> Path:
    r"""Beside a map_server YAML, ``<stem>_start.yaml``: the same image with its origin
    moved into the frame of the robot's first pose ``first`` (x, y, yaw).

    A SLAM program fed odometry increments (an MRPT rawlog, a CARMEN log) maps in that
    frame, so its map is compared with this one: exact, nothing resampled.

    Examples
    --------
    >>> import tempfile, pathlib, yaml
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "m.yaml"
    >>> _ = p.write_text("image: m.pgm\nresolution: 0.05\norigin: [-1.0, -1.0, 0.0]\n")
    >>> d = yaml.safe_load(start_frame_yaml(p, [1.0, 0.0, np.pi / 2]).read_text())
    >>> [round(v, 6) for v in d["origin"]], d["image"]
    ([-1.0, 2.0, -1.570796], 'm.pgm')
    """
    import yaml

    path = Path(yaml_path)
    doc = yaml.safe_load(path.read_text())
    ox, oy, oyaw = (float(v) for v in doc["origin"])
    x0, y0, th = (float(v) for v in first)
    c, s = math.cos(th), math.sin(th)
    dx, dy = ox - x0, oy - y0
    doc["origin"] = [c * dx + s * dy, -s * dx + c * dy,
                     math.atan2(math.sin(oyaw - th), math.cos(oyaw - th))]
    out = path.with_name(path.stem + "_start.yaml")
    out.write_text(yaml.safe_dump(doc, sort_keys=False))
    return out


def write_truth(seq: Recording, folder: str | os.PathLike[str], *,
                threads: int | None = None) -> dict[str, Path]:
    """Write the ground truth of ``seq`` into ``folder``.

    Files: ``gt_map.yaml``/``.pgm`` (the world, map_server trinary; its meta and
    transparent walls beside it, :func:`slamq.synth.worldgen.save_world`),
    ``visible_map.yaml``/``.pgm`` (:func:`visible_map`), ``gt_map_start.yaml`` and
    ``visible_map_start.yaml`` (the same images in the frame of the first pose, where maps
    built from odometry increments start: :func:`start_frame_yaml`), ``gt.tum`` and ``odom.tum``
    (``t x y z qx qy qz qw``) and ``sequence.json`` (``seq.meta``, the name, the laser, the
    files).

    Returns
    -------
    dict
        ``{"gt_map", "visible_map", "gt_map_start", "visible_map_start", "gt", "odom",
        "sequence"}`` -> path.

    Examples
    --------
    >>> import tempfile
    >>> from slamq.synth.worldgen import world
    >>> from slamq.synth.simulation import simulate
    >>> seq = simulate(world(0, kind="office", size=(10.0, 8.0)), noise="none",
    ...                laser=LaserSpec(beams=181), length=6.0)
    >>> sorted(write_truth(seq, tempfile.mkdtemp()))
    ['gt', 'gt_map', 'gt_map_start', 'odom', 'sequence', 'visible_map', 'visible_map_start']
    """
    from slamq.synth.worldgen import save_world

    out = Path(folder)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise SlamqError(f"{out}: cannot create the folder: {exc.strerror or exc}") from None
    files: dict[str, Path] = {}
    files["gt_map"] = save_world(seq.world, out / "gt_map.yaml")
    vis = visible_map(seq, threads=threads)
    files["visible_map"] = save_world(vis, out / "visible_map.yaml")
    files["gt_map_start"] = start_frame_yaml(files["gt_map"], seq.gt[0])
    files["visible_map_start"] = start_frame_yaml(files["visible_map"], seq.gt[0])
    files["gt"] = _trajectory(seq, seq.gt, "gt").write_tum(out / "gt.tum")
    files["odom"] = _trajectory(seq, seq.odom, "odom").write_tum(out / "odom.tum")
    doc = {"name": seq.name, "scans": len(seq), "duration": float(seq.stamps[-1] -
                                                                   seq.stamps[0]),
           "laser": _laser_dict(seq.laser), "visible": vis.meta,
           "files": {k: v.name for k, v in files.items()}, "meta": seq.meta}
    files["sequence"] = out / "sequence.json"
    files["sequence"].write_text(json.dumps(doc, indent=1, default=_json_default))
    return files


def _laser_dict(laser: LaserSpec) -> dict[str, Any]:
    return {"beams": laser.beams, "fov": laser.fov, "max_range": laser.max_range,
            "min_range": laser.min_range, "range_noise": laser.range_noise,
            "offset": list(laser.offset), "angle_min": laser.angle_min,
            "angle_increment": laser.angle_increment}


def _json_default(v: Any) -> Any:
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, np.ndarray):
        return v.tolist()
    raise TypeError(f"not JSON: {type(v).__name__}")


def save_sequence(seq: Recording, path: str | os.PathLike[str]) -> Path:
    """Save a whole sequence (world included) as one ``.npz``; :func:`load_sequence` reads
    it back equal.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from slamq.synth.worldgen import world
    >>> from slamq.synth.simulation import simulate
    >>> seq = simulate(world(0, kind="office", size=(10.0, 8.0)), laser=LaserSpec(beams=91),
    ...                length=6.0)
    >>> back = load_sequence(save_sequence(seq, pathlib.Path(tempfile.mkdtemp()) / "s.npz"))
    >>> bool((back.ranges == seq.ranges).all() and (back.odom == seq.odom).all())
    True
    """
    p = Path(path)
    w = seq.world
    glass = w.meta.get("transparent")
    wmeta = {k: v for k, v in w.meta.items() if k != "transparent"}
    head = {"name": seq.name, "meta": seq.meta, "laser": _laser_dict(seq.laser),
            "world": {"resolution": w.resolution, "origin": list(w.origin),
                      "source": w.source, "meta": wmeta}}
    p.parent.mkdir(parents=True, exist_ok=True)
    with open(p, "wb") as f:
        np.savez_compressed(
            f, stamps=seq.stamps, gt=seq.gt, odom=seq.odom, ranges=seq.ranges,
            values=w.values, unknown=w.unknown,
            transparent=np.zeros(w.shape, bool) if glass is None else np.asarray(glass, bool),
            head=np.frombuffer(json.dumps(head, default=_json_default).encode(), np.uint8))
    return p


def load_sequence(path: str | os.PathLike[str]) -> Recording:
    """A sequence :func:`save_sequence` wrote (raises :class:`~slamq.errors.SlamqError`
    naming the file when it is not one)."""
    p = Path(path)
    try:
        with np.load(p, allow_pickle=False) as z:
            d = {k: z[k] for k in z.files}
        head = json.loads(d["head"].tobytes().decode())
        lz = head["laser"]
        laser = LaserSpec(beams=int(lz["beams"]), fov=float(lz["fov"]),
                          max_range=float(lz["max_range"]), min_range=float(lz["min_range"]),
                          range_noise=float(lz["range_noise"]),
                          offset=tuple(float(v) for v in lz["offset"]))
        wz = head["world"]
        wmeta = dict(wz["meta"])
        if d["transparent"].any():
            wmeta["transparent"] = d["transparent"]
        world = OccupancyMap(d["values"], d["unknown"], wz["resolution"],
                             tuple(wz["origin"]), source=wz["source"], meta=wmeta)
        return Recording(d["stamps"], d["gt"], d["odom"], d["ranges"], laser, world,
                        name=head["name"], meta=head["meta"])
    except SlamqError as exc:
        raise SlamqError(f"{p}: {exc}") from None
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise SlamqError(f"{p}: not a saved sequence ({type(exc).__name__}: {exc})") from None
