"""The occupancy grid of a Cartographer ``.pbstream``: its 2D submaps rasterised, without ROS.

Cartographer saves no map, only submaps (probability grids in their own frames) and the
optimised pose of each submap. :func:`read_pbstream_map` combines them as
``cartographer_pbstream_to_ros_map`` does (cartographer/io/submap_painter.cc and
cartographer_ros ``CreateOccupancyGridMsg``):

1. each submap's grid, cropped to its known cells, becomes a texture: for a known cell of
   probability ``p``, ``delta = 128 - L(p)`` with ``L`` the log-odds integer 1..255
   (``ProbabilityToLogOddsInteger``); intensity ``max(delta, 0)``, alpha ``max(-delta, 0)``
   (alpha 1 when both are 0), "observed" when either is non-zero; unknown cells are
   transparent;
2. the textures are placed by ``global submap pose * local_pose^-1 * (max corner)`` and
   composited in SubmapId order (trajectory, then submap index) with premultiplied
   ``OVER`` onto a background of intensity 128, alpha 255, not observed;
3. a cell never observed is unknown (-1); otherwise its occupancy is
   ``round((1 - intensity / 255) * 100)``, as in a nav_msgs/OccupancyGrid.

Where slamq differs: every output cell takes the texture cell under its centre (nearest,
where cairo filters bilinearly), and the grid is aligned to whole cells of the submaps'
resolution around their bounding box with Cartographer's 5-cell padding. 3D submaps and
TSDF grids are refused with a :class:`~slamq.errors.MapError`.

Field numbers (Cartographer's ``.proto`` files): SerializedData 1 pose_graph, 3 submap;
Submap 1 submap_id {1 trajectory_id, 2 submap_index}, 2 submap_2d, 3 submap_3d;
Submap2D 1 local_pose (Rigid3d), 4 grid; Grid2D 1 limits {1 resolution, 2 max {x, y},
3 cell_limits {1 num_x_cells, 2 num_y_cells}}, 2 cells (packed int32), 3 known_cells_box
{1 max_x, 2 max_y, 3 min_x, 4 min_y}, 5 tsdf_2d; PoseGraph 4 trajectory {3 trajectory_id,
2 submap {2 submap_index, 1 pose}}.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from slamq.errors import MapError, TrajectoryError
from slamq.models import OccupancyMap
from slamq.sources.files import MAX_CELLS, PathLike
from slamq.sources.grids import from_occupancy_grid
from slamq.sources.pbstream import (
    _BEGIN,
    _END,
    _I32,
    _LEN,
    _VARINT,
    MAX_RECORD_BYTES,
    SMALL,
    _double,
    _doubles,
    _fields,
    _records,
    _rigid3d,
    _signed,
    _walk,
    _WireError,
)

__all__ = ["read_pbstream_map"]

_K_MIN_P = np.float32(0.1)  # kMinProbability; kMaxProbability = 0.9
_SCALE = np.float32(0.8) / np.float32(32766)  # (kMax - kMin correspondence cost) / 32766
_LOGIT_MIN = np.log(np.float32(0.1) / np.float32(0.9), dtype=np.float32)
_LOGIT_MAX = np.log(np.float32(0.9) / np.float32(0.1), dtype=np.float32)
_PADDING = 5  # cells, as submap_painter's kPaddingPixel


def _pose2d(buf: memoryview) -> tuple[float, float, float]:
    """``(x, y, yaw)`` of a Rigid3d (a 2D submap's rotation is about z)."""
    (x, y, _), (w, qx, qy, qz) = _rigid3d(buf)
    return x, y, math.atan2(2 * (w * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz))


def _compose(a: tuple[float, float, float], b: tuple[float, float, float]
             ) -> tuple[float, float, float]:
    c, s = math.cos(a[2]), math.sin(a[2])
    return a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], a[2] + b[2]


def _inverse(a: tuple[float, float, float]) -> tuple[float, float, float]:
    c, s = math.cos(a[2]), math.sin(a[2])
    return -c * a[0] - s * a[1], s * a[0] - c * a[1], -a[2]


def _packed_varints(buf: memoryview) -> np.ndarray:
    """The values of a packed repeated varint field, decoded with numpy."""
    b = np.frombuffer(buf, np.uint8)
    if len(b) == 0:
        return np.zeros(0, np.int64)
    ends = np.flatnonzero(b < 0x80)
    if len(ends) == 0 or ends[-1] != len(b) - 1:
        raise _WireError("truncated packed varints")
    starts = np.concatenate([[0], ends[:-1] + 1])
    lengths = ends - starts + 1
    if lengths.max() > 3:  # a cell is a uint16: at most 3 bytes
        raise _WireError("a grid cell value does not fit 16 bits")
    shift = 7 * (np.arange(len(b)) - np.repeat(starts, lengths))
    return np.add.reduceat((b & 0x7F).astype(np.int64) << shift, starts)


#: What a record is read for, streamed (nothing else is kept): SerializedData 1 pose_graph
#: {4 trajectory {3 trajectory_id, 2 submap (pose, index)}}, 3 submap {1 submap_id,
#: 2 submap_2d {1 local_pose, 4 grid {1 limits, 2 cells, 3 known_cells_box, 5 tsdf_2d,
#: 6/7 correspondence cost bounds}}, 3 submap_3d}. Only a grid's cells may be large.
_GRID = {1: SMALL, 2: MAX_RECORD_BYTES, 3: SMALL, 5: 0, 6: 0, 7: 0}
_SUBMAP = {1: SMALL, 2: {1: SMALL, 4: _GRID}, 3: 0}
_MAP_RECORD = {1: {4: {3: 0, 2: SMALL}}, 3: _SUBMAP}


class _Submap:
    def __init__(self, events: list, where: str) -> None:
        """``events``: the streamed fields of one Submap message, paths relative to it."""
        self.key = (0, 0)
        self.local = (0.0, 0.0, 0.0)
        grid: list | None = None
        for path, w, v in events:
            if path == (1,) and w == _LEN:
                ids = {k: _signed(x, 32) for k, ww, x in _fields(v)  # type: ignore[arg-type]
                       if ww == _VARINT}
                self.key = (ids.get(1, 0), ids.get(2, 0))
            elif path == (3,) and w == _LEN:
                raise MapError(f"{where}: a 3D submap: only 2D submaps are rasterised")
            elif path == (2, 1) and w == _LEN:
                self.local = _pose2d(v)
            elif path == (2, 4) and w == _BEGIN:
                grid = []  # the last grid message counts
            elif len(path) == 3 and path[:2] == (2, 4) and grid is not None:
                grid.append((path[2], w, v))
        if grid is None:
            raise MapError(f"{where}: submap {self.key} has no 2D grid")
        self._grid(grid, where)

    def _grid(self, fields: list, where: str) -> None:
        res, mx, my, nx, ny = 0.0, 0.0, 0.0, 0, 0
        cells = np.zeros(0, np.int64)
        box: dict[int, int] = {}
        for n, w, v in fields:
            if n == 1 and w == _LEN:
                for m, ww, x in _fields(v):  # type: ignore[arg-type]
                    if m == 1:
                        res = _double(ww, x)
                    elif m == 2 and ww == _LEN:
                        mx, my = _doubles(x, "xy", (0.0, 0.0))  # type: ignore[arg-type]
                    elif m == 3 and ww == _LEN:
                        lim = {k: _signed(y, 32) for k, www, y in _fields(x)  # type: ignore
                               if www == _VARINT}
                        nx, ny = lim.get(1, 0), lim.get(2, 0)
            elif n == 2 and w == _LEN:
                cells = np.concatenate([cells, _packed_varints(v)])  # type: ignore[arg-type]
            elif n == 2 and w == _VARINT:
                cells = np.append(cells, v)
            elif n == 3 and w == _LEN:
                box = {k: _signed(x, 32) for k, ww, x in _fields(v)  # type: ignore[arg-type]
                       if ww == _VARINT}
            elif n == 5:
                raise MapError(f"{where}: submap {self.key} is a TSDF grid, not a "
                               "probability grid")
            elif n in (6, 7) and w != _I32:
                raise _WireError("correspondence cost bounds must be floats")
        if not (math.isfinite(res) and res > 0):
            raise MapError(f"{where}: submap {self.key}: resolution {res} is not positive")
        if nx <= 0 or ny <= 0 or nx * ny > MAX_CELLS:
            raise MapError(f"{where}: submap {self.key}: {nx} x {ny} cells is not a grid of "
                           f"1 to {MAX_CELLS} cells")
        if len(cells) != nx * ny:
            raise MapError(f"{where}: submap {self.key}: {len(cells)} cell values for "
                           f"{nx} x {ny} cells")
        # cell (x, y) is cells[y * nx + x]; x runs along -y of the submap frame, y along -x
        grid = (cells.reshape(ny, nx) & 0x7FFF).astype(np.int64)
        x0, x1 = max(box.get(3, 0), 0), min(box.get(1, -1), nx - 1)
        y0, y1 = max(box.get(4, 0), 0), min(box.get(2, -1), ny - 1)
        if not box or x1 < x0 or y1 < y0:  # nothing known
            x0 = x1 = y0 = y1 = 0
            grid = np.zeros((1, 1), np.int64)
        else:
            grid = grid[y0:y1 + 1, x0:x1 + 1]
        self.resolution = res
        # the texture's max corner (submap_2d DrawToSubmapTexture), in the submap frame
        self.corner = (mx - res * y0, my - res * x0, 0.0)
        self.texture = _texture(grid)  # (height=y, width=x, [intensity, alpha, observed])


def _texture(values: np.ndarray) -> np.ndarray:
    """Premultiplied (intensity, alpha, observed) per cell of a cropped submap grid."""
    known = values > 0
    cost = values.astype(np.float32) * _SCALE + (np.float32(0.1) - _SCALE)
    p = np.float32(1) - cost
    logit = np.log(p / (np.float32(1) - p), dtype=np.float32)
    scaled = (logit - _LOGIT_MIN) * np.float32(254) / (_LOGIT_MAX - _LOGIT_MIN)
    log_odds = (np.sign(scaled) * np.floor(np.abs(scaled) + np.float32(0.5))).astype(
        np.int64) + 1  # RoundToInt: half away from zero
    delta = 128 - log_odds
    intensity = np.where(known, np.maximum(delta, 0), 0)
    alpha = np.where(known, np.where(delta < 0, -delta, np.where(delta == 0, 1, 0)), 0)
    observed = np.where((intensity > 0) | (alpha > 0), 255, 0)
    return np.stack([intensity, alpha, observed], axis=-1).astype(np.int64)


def _submap_poses(graph: list) -> dict[tuple[int, int], tuple[float, float, float]]:
    """``{(trajectory id, submap index): pose}`` from the streamed fields of a PoseGraph
    (paths relative to it); a trajectory without id is numbered by its order."""
    out = {}
    i = -1
    tid: int | None = None
    subs: list = []
    for path, w, v in graph:
        if path == (4,) and w == _BEGIN:
            i, tid, subs = i + 1, None, []
        elif path == (4, 3) and w == _VARINT:
            tid = _signed(v, 32)
        elif path == (4, 2) and w == _LEN:
            index, pose = 0, (0.0, 0.0, 0.0)
            for m, ww, x in _fields(v):
                if m == 2 and ww == _VARINT:
                    index = _signed(x, 32)  # type: ignore[arg-type]
                elif m == 1 and ww == _LEN:
                    pose = _pose2d(x)  # type: ignore[arg-type]
            subs.append((index, pose))
        elif path == (4,) and w == _END:
            for index, pose in subs:
                out[(i if tid is None else tid, index)] = pose
    return out


def read_pbstream_map(path: PathLike, *, resolution: float | None = None) -> OccupancyMap:
    """Rasterise the 2D submaps of a Cartographer ``.pbstream`` into one occupancy grid.

    Parameters
    ----------
    path : path
        A pbstream written by Cartographer (``finish_trajectory`` + ``write_state``).
    resolution : float, optional
        Metres per cell of the result; default the submaps' (the finest when they differ).

    Returns
    -------
    OccupancyMap
        Values and unknown cells as for a nav_msgs/OccupancyGrid (docs/spec.md section 1);
        ``meta["kind"] == "pbstream"``, ``meta["submaps"]`` the number of submaps drawn.

    Raises
    ------
    MapError
        Not a pbstream, corrupt, no 2D submap, a submap without optimised pose, 3D or TSDF
        submaps, or more than 2^30 cells; the message names the file.

    Examples
    --------
    >>> read_pbstream_map("map.pbstream").shape  # doctest: +SKIP
    (412, 388)
    """
    p = Path(path)
    where = str(p)
    if not p.is_file():
        raise MapError(f"{where}: no such file")
    submaps: list[_Submap] = []
    graph: list | None = None  # the first pose graph's fields (submap poses only)
    graphs = 0
    sub: list | None = None
    try:
        with open(p, "rb") as f:
            for record in _records(f, p):  # each streamed: only small fields and cells kept
                for path, w, v in _walk(record, _MAP_RECORD):
                    if path[0] == 1:
                        if path == (1,) and w == _BEGIN:
                            graphs += 1
                            if graphs == 1:
                                graph = []
                        elif graphs == 1 and len(path) > 1 and graph is not None:
                            graph.append((path[1:], w, v))
                    elif path == (3,) and w == _BEGIN:
                        sub = []
                    elif path == (3,) and w == _END and sub is not None:
                        submaps.append(_Submap(sub, where))
                        sub = None
                    elif sub is not None and len(path) > 1:
                        sub.append((path[1:], w, v))
    except TrajectoryError as exc:  # the stream reader's errors, as a map error
        raise MapError(str(exc)) from None
    except _WireError as exc:
        raise MapError(f"{where}: corrupt pbstream ({exc})") from None
    if not submaps:
        raise MapError(f"{where}: the pbstream holds no 2D submap")
    poses = _submap_poses(graph) if graph is not None else {}
    submaps.sort(key=lambda s: s.key)
    res = resolution if resolution is not None else min(s.resolution for s in submaps)
    if not (math.isfinite(res) and res > 0):
        raise MapError(f"{where}: resolution {res} is not positive")
    placed = []
    for s in submaps:
        if s.key not in poses:
            raise MapError(f"{where}: submap {s.key} has no pose in the pose graph")
        placed.append((s, _compose(_compose(poses[s.key], _inverse(s.local)), s.corner)))
    return _paint(placed, res, where)


def _slice_points(s: _Submap, t: tuple[float, float, float], wx: np.ndarray,
                  wy: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For world points: the texture (row, column) under each, and whether it is inside."""
    ix, iy, _ = _inverse(t)
    c, sn = math.cos(-t[2]), math.sin(-t[2])
    sx = ix + c * wx - sn * wy  # the point in the texture's max-corner frame
    sy = iy + sn * wx + c * wy
    h, w = s.texture.shape[:2]
    col = np.floor(-sy / s.resolution).astype(np.int64)  # cell x index: along -y
    row = np.floor(-sx / s.resolution).astype(np.int64)  # cell y index: along -x
    inside = (col >= 0) & (col < w) & (row >= 0) & (row < h)
    return row, col, inside


def _corners(s: _Submap, t: tuple[float, float, float]) -> np.ndarray:
    """World (x, y) of the four corners of a placed texture."""
    h, w = s.texture.shape[:2]
    c, sn = math.cos(t[2]), math.sin(t[2])
    return np.array([(t[0] + c * a - sn * b, t[1] + sn * a + c * b)
                     for a, b in ((0, 0), (-h * s.resolution, 0), (0, -w * s.resolution),
                                  (-h * s.resolution, -w * s.resolution))])


def _paint(placed: list, res: float, where: str) -> OccupancyMap:
    corners = [_corners(s, t) for s, t in placed]
    xy = np.concatenate(corners)
    eps = 1e-6  # corners on a cell boundary stay there despite 1.4 / 0.1 = 13.999...
    x_min = math.floor(xy[:, 0].min() / res + eps) - _PADDING
    y_min = math.floor(xy[:, 1].min() / res + eps) - _PADDING
    width = math.ceil(xy[:, 0].max() / res - eps) + _PADDING - x_min
    height = math.ceil(xy[:, 1].max() / res - eps) + _PADDING - y_min
    if width * height > MAX_CELLS:
        raise MapError(f"{where}: the submaps span {width} x {height} cells, more than "
                       f"the limit of {MAX_CELLS}")
    # two bytes per output cell; each submap touches only the cells of its own bounding
    # box (submaps far apart must not cost their whole span per submap). Row 0 = bottom.
    intensity = np.full((height, width), 128, np.uint8)
    observed = np.zeros((height, width), np.uint8)
    for (s, t), box in zip(placed, corners):
        c0 = max(math.floor(box[:, 0].min() / res) - x_min - 1, 0)
        c1 = min(math.ceil(box[:, 0].max() / res) - x_min + 1, width)
        r0 = max(math.floor(box[:, 1].min() / res) - y_min - 1, 0)
        r1 = min(math.ceil(box[:, 1].max() / res) - y_min + 1, height)
        gx, gy = np.meshgrid((x_min + np.arange(c0, c1) + 0.5) * res,
                             (y_min + np.arange(r0, r1) + 0.5) * res)
        row, col, inside = _slice_points(s, t, gx, gy)
        tex = s.texture[np.where(inside, row, 0), np.where(inside, col, 0)]
        src_i, src_a, src_o = (np.where(inside, tex[..., k], 0) for k in range(3))
        win = (slice(r0, r1), slice(c0, c1))
        intensity[win] = np.minimum(255, src_i + _mul_un8(intensity[win], 255 - src_a))
        observed[win] = np.minimum(255, src_o + _mul_un8(observed[win], 255 - src_a))
    grid = np.full((height, width), -1, np.int8)
    seen = observed > 0
    grid[seen] = np.floor((1.0 - intensity[seen] / 255.0) * 100.0 + 0.5).astype(np.int8)
    m = from_occupancy_grid(grid, resolution=res, origin=(x_min * res, y_min * res, 0.0),
                            source=where)
    m.meta.update(kind="pbstream", submaps=len(placed))
    return m


def _mul_un8(x: np.ndarray, a: np.ndarray) -> np.ndarray:
    """``x * a / 255`` rounded as pixman's ``MUL_UN8`` does."""
    t = x.astype(np.int64) * a + 128
    return (t + (t >> 8)) >> 8
