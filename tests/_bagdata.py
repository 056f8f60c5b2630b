"""Writing small ROS bags in tests (rosbags writer): maps, map updates and poses.

Shared by test_bags.py and test_timeline.py. Maps are given image-style (row 0 = top) as
int8 OccupancyGrid values; the writer flips them to the message's bottom-row-first order.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

UPDATE_MSGDEF = """\
std_msgs/Header header
int32 x
int32 y
uint32 width
uint32 height
int8[] data
"""

FORMATS = ("ros1", "sqlite3", "mcap")


def bag_path(tmp: Path, fmt: str, name: str = "run") -> Path:
    """Where a bag of format ``fmt`` goes: ``name.bag`` for ROS1, a folder for ROS2."""
    return tmp / (f"{name}.bag" if fmt == "ros1" else f"{name}_{fmt}")


def _store(fmt: str) -> Any:
    store = get_typestore(Stores.ROS1_NOETIC if fmt == "ros1" else Stores.ROS2_HUMBLE)
    store.register(get_types_from_msg(UPDATE_MSGDEF, "map_msgs/msg/OccupancyGridUpdate"))
    if "tf2_msgs/msg/TFMessage" not in store.types:
        store.register(get_types_from_msg("geometry_msgs/TransformStamped[] transforms",
                                          "tf2_msgs/msg/TFMessage"))
    return store


class BagWriter:
    """A bag of one format, with helpers building the messages slamq reads."""

    def __init__(self, path: Path, fmt: str, compressed: bool = False):
        """``compressed``: bz2 chunks (ROS1), zstd chunks (MCAP)."""
        self.fmt = fmt
        self.store = _store(fmt)
        self.T = self.store.types
        if fmt == "ros1":
            self.writer: Any = Writer1(path)
            if compressed:
                self.writer.set_compression(Writer1.CompressionFormat.BZ2)
        else:
            plugin = StoragePlugin.SQLITE3 if fmt == "sqlite3" else StoragePlugin.MCAP
            self.writer = Writer2(path, version=9, storage_plugin=plugin)
            if compressed:
                from rosbags.rosbag2 import CompressionFormat, CompressionMode

                self.writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
        self.conns: dict[str, Any] = {}

    def __enter__(self) -> BagWriter:
        self.writer.open()
        return self

    def __exit__(self, *exc: object) -> None:
        self.writer.close()

    # -- message builders
    def time(self, t: float) -> Any:
        sec = int(np.floor(t))
        return self.T["builtin_interfaces/msg/Time"](sec=sec, nanosec=int(round((t - sec) * 1e9)))

    def header(self, t: float, frame: str = "map") -> Any:
        kw: dict[str, Any] = {"stamp": self.time(t), "frame_id": frame}
        if self.fmt == "ros1":
            kw["seq"] = 0
        return self.T["std_msgs/msg/Header"](**kw)

    def pose(self, p: Sequence[float], q_wxyz: Sequence[float]) -> Any:
        return self.T["geometry_msgs/msg/Pose"](
            position=self.T["geometry_msgs/msg/Point"](x=p[0], y=p[1], z=p[2]),
            orientation=self.quat(q_wxyz),
        )

    def quat(self, q: Sequence[float]) -> Any:
        return self.T["geometry_msgs/msg/Quaternion"](x=q[1], y=q[2], z=q[3], w=q[0])

    def grid(self, t: float, image_rows: np.ndarray, resolution: float = 0.05,
             origin: Sequence[float] = (0.0, 0.0, 0.0)) -> Any:
        rows = np.asarray(image_rows, dtype=np.int8)
        h, w = rows.shape
        yaw = origin[2]
        info = self.T["nav_msgs/msg/MapMetaData"](
            map_load_time=self.time(0.0),
            resolution=resolution,
            width=w,
            height=h,
            origin=self.pose((origin[0], origin[1], 0.0),
                             (np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2))),
        )
        data = np.ascontiguousarray(rows[::-1]).reshape(-1)  # row 0 of the message = bottom
        return self.T["nav_msgs/msg/OccupancyGrid"](header=self.header(t), info=info, data=data)

    def update(self, t: float, x: int, y: int, patch_bottom_first: np.ndarray) -> Any:
        patch = np.asarray(patch_bottom_first, dtype=np.int8)
        h, w = patch.shape
        return self.T["map_msgs/msg/OccupancyGridUpdate"](
            header=self.header(t), x=x, y=y, width=w, height=h, data=patch.reshape(-1)
        )

    # -- writing
    def write(self, topic: str, msgtype: str, msg: Any, t: float | None = None) -> None:
        if topic not in self.conns:
            self.conns[topic] = self.writer.add_connection(topic, msgtype, typestore=self.store)
        if t is None:
            head = msg.header if hasattr(msg, "header") else msg.transforms[0].header
            t = head.stamp.sec + head.stamp.nanosec * 1e-9
        raw = (
            self.store.serialize_ros1(msg, msgtype)
            if self.fmt == "ros1"
            else self.store.serialize_cdr(msg, msgtype)
        )
        self.writer.write(self.conns[topic], int(round(t * 1e9)), raw)


def grid_from_map(values: np.ndarray, unknown: np.ndarray) -> np.ndarray:
    """Image-style OccupancyGrid values (int8 0..100, -1 unknown) that load back to ``values``.

    Exact only for values on the 0..100 grid of ``rint(255 * (100 - g) / 100)``.
    """
    g = np.rint(100.0 - values.astype(np.float64) * 100.0 / 255.0).astype(np.int8)
    g[unknown] = -1
    return g


def expected_values(grid_rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """SPEC section 1: v = rint(255 * (100 - g) / 100), unknown for g outside 0..100."""
    g = grid_rows.astype(np.int16)
    unknown = (g < 0) | (g > 100)
    v = np.rint(255.0 * (100.0 - np.clip(g, 0, 100)) / 100.0).astype(np.uint8)
    return v, unknown


def asymmetric_grid(h: int = 6, w: int = 9, seed: int = 0) -> np.ndarray:
    """An image-style grid with distinct rows (a flip would show) and some unknown cells."""
    rng = np.random.default_rng(seed)
    g = rng.integers(0, 101, size=(h, w)).astype(np.int8)
    g[0, :] = 100  # top row occupied, bottom row free
    g[-1, :] = 0
    g[1, 1:3] = -1
    g[2, 0] = 120  # out of range: unknown too
    return g


def room_grid(size: int = 40, wall: int = 2, door: int | None = None) -> np.ndarray:
    """A free room walled by occupied cells in an unknown canvas (image-style int8)."""
    g = np.full((size + 8, size + 8), -1, np.int8)
    g[4 : 4 + size, 4 : 4 + size] = 100
    g[4 + wall : 4 + size - wall, 4 + wall : 4 + size - wall] = 0
    if door is not None:
        g[4 + size // 2 : 4 + size // 2 + door, 4 + size - wall : 4 + size] = 0
    return g
