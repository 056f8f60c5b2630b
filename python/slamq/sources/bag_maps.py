"""Maps from ROS bags: every (or every N-th) ``nav_msgs/OccupancyGrid`` on a topic, with
``map_msgs/OccupancyGridUpdate`` patches applied, as :class:`~slamq.models.OccupancyMap`."""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Iterator
from typing import Any

import numpy as np

from slamq.errors import BagError, MapError, MapWarning
from slamq.models import OccupancyMap
from slamq.sources.bagfile import (
    GRID_TYPE,
    UPDATE_TYPE,
    bag_connections,
    bag_deserialize,
    bag_messages,
    describe_topics,
    header_stamp,
    open_bag,
    quat_yaw,
    topic_types,
)
from slamq.sources.files import MAX_CELLS, PathLike
from slamq.sources.grids import from_occupancy_grid

__all__ = ["read_bag_maps", "read_last_map"]


@dataclasses.dataclass
class _Grid:
    """An OccupancyGrid's state: the int8 cells (row 0 = bottom) and its metadata."""

    cells: np.ndarray  # (height, width) int8
    resolution: float
    origin: tuple[float, float, float]
    frame_id: str
    stamp: float

    @classmethod
    def from_msg(cls, msg: Any, bag_ns: int, path: PathLike, topic: str) -> _Grid:
        info = msg.info
        width, height = int(info.width), int(info.height)
        if width * height > MAX_CELLS:
            raise BagError(f"{path}: {topic} message claims {width}x{height} cells, more "
                           f"than the limit of {MAX_CELLS}")
        data = np.asarray(msg.data).astype(np.int8, copy=False).reshape(-1)
        if data.size != width * height:
            raise BagError(
                f"{path}: {topic} message holds {data.size} cells, "
                f"width*height = {width}*{height} = {width * height}"
            )
        o = info.origin
        origin = (float(o.position.x), float(o.position.y), quat_yaw(o.orientation))
        return cls(
            cells=data.reshape(height, width).copy(),
            resolution=float(info.resolution),
            origin=origin,
            frame_id=str(msg.header.frame_id),
            stamp=header_stamp(msg.header, bag_ns),
        )

    def apply(self, upd: Any, bag_ns: int, path: PathLike, topic: str) -> bool:
        """Paste an OccupancyGridUpdate patch (x, y = column, row of its lower-left cell).

        A patch that does not fit the map (it was meant for a full map of another size,
        e.g. received just before the enlarged map) or whose data is not width x height
        cells is skipped with a :class:`slamq.MapWarning`, as rviz and nav2's static
        layer ignore it; returns whether the patch was applied.
        """
        x, y, w, h = int(upd.x), int(upd.y), int(upd.width), int(upd.height)
        data = np.asarray(upd.data).astype(np.int8, copy=False).reshape(-1)
        height, width = self.cells.shape
        problem = None
        if data.size != w * h:
            problem = f"holds {data.size} cells, width*height = {w}*{h} = {w * h}"
        elif x < 0 or y < 0 or x + w > width or y + h > height:
            problem = f"x={x} y={y} {w}x{h} lies outside the {width}x{height} map"
        if problem is not None:
            warnings.warn(
                MapWarning(f"{path}: skipped a {topic} update at "
                           f"{header_stamp(upd.header, bag_ns):.3f} s: it {problem}"),
                stacklevel=2,
            )
            return False
        self.cells[y : y + h, x : x + w] = data.reshape(h, w)
        self.stamp = header_stamp(upd.header, bag_ns)
        return True

    def to_map(self, path: PathLike, topic: str, index: int) -> OccupancyMap:

        source = f"{path}:{topic}[{index}]"
        try:
            m = from_occupancy_grid(
                self.cells,
                resolution=self.resolution,
                origin=self.origin,
                source=source,
            )
        except BagError:
            raise
        except MapError as exc:
            raise BagError(str(exc) if source in str(exc) else f"{source}: {exc}") from None
        meta = dict(m.meta)
        meta.update(
            bag=str(path), topic=topic, index=index, stamp=self.stamp, frame_id=self.frame_id
        )
        return dataclasses.replace(m, meta=meta)


def _decode_grid(
    reader: Any, bag: PathLike, topic: str, item: tuple[Any, int, Any, int]
) -> _Grid:
    """Decode one full map message; errors name the message's index on the topic."""
    conn, ns, raw, number = item
    try:
        return _Grid.from_msg(bag_deserialize(reader, bag, conn, raw), ns, bag, topic)
    except (BagError, MapError) as exc:
        text = str(exc)
        prefix = f"{bag}: "
        rest = text[len(prefix):] if text.startswith(prefix) else text
        raise BagError(f"{bag}: {topic} message {number}: {rest}") from None


def read_bag_maps(
    bag: PathLike,
    topic: str = "/map",
    every: int = 1,
    *,
    updates: bool | str = True,
    include_last: bool = False,
    last_only: bool = False,
) -> Iterator[tuple[float, OccupancyMap]]:
    """Yield ``(timestamp_seconds, OccupancyMap)`` for the maps of a bag, in bag order.

    Parameters
    ----------
    bag : path
        ROS1 ``.bag``, ROS2 ``.db3`` / ``.mcap`` file, or ROS2 bag folder.
    topic : str, default "/map"
        A ``nav_msgs/OccupancyGrid`` topic.
    every : int, default 1
        Keep maps number 0, N, 2N, ... (counting every full map and every applied update).
    updates : bool or str, default True
        Apply ``map_msgs/OccupancyGridUpdate`` patches from ``<topic>_updates`` when the bag
        has that topic (a string names another update topic; False ignores updates). Each
        applied patch is a new map in the sequence; patches before the first full map are
        skipped, and so are patches that do not fit the map (with a ``MapWarning``).
    include_last : bool, default False
        Also yield the last map when ``every`` skipped it.
    last_only : bool, default False
        Yield only the last map (with the patches after it); no other message is decoded,
        so a bad earlier map does not hide a good last one. Its ``index`` counts the full
        maps before it and the patches applied to it.

    Yields
    ------
    (float, OccupancyMap)
        The header stamp in seconds (the bag time when the stamp is zero) and the map,
        held image-style; ``map.meta`` has ``bag``, ``topic``, ``index``, ``stamp`` and
        ``frame_id``.

    Raises
    ------
    BagError
        Missing/truncated/corrupt bag, no such topic (the message lists the topics), wrong
        message type.

    Examples
    --------
    >>> for t, m in read_bag_maps("run1.bag", every=10):  # doctest: +SKIP
    ...     print(f"{t:.1f}", m.shape)
    >>> next(read_bag_maps("map.yaml"))
    Traceback (most recent call last):
    ...
    slamq.errors.BagError: map.yaml: not a bag (expected .bag, .db3, .mcap or a ROS2 folder)
    """
    if isinstance(every, bool) or not isinstance(every, int) or every < 1:
        raise BagError(f"{bag}: every must be a positive integer, got {every!r}")
    with open_bag(bag) as reader:
        conns = bag_connections(reader, bag, topic, (GRID_TYPE,))
        update_topic: str | None = None
        if updates:
            update_topic = updates if isinstance(updates, str) else topic + "_updates"
            types = topic_types(reader)
            if update_topic not in types:
                if isinstance(updates, str):
                    raise BagError(
                        f"{bag}: no topic {update_topic}; {describe_topics(types)}"
                    )
                update_topic = None
            else:
                conns = conns + bag_connections(reader, bag, update_topic, (UPDATE_TYPE,))
        index = -1
        grid: _Grid | None = None  # decoded state (needed when updates arrive)
        pending: tuple[Any, int, Any, int] | None = None  # last full map, not decoded yet
        last_yielded = -1
        maps_seen = 0  # full map messages so far: the number errors name
        patches: list[tuple[Any, int, Any]] = []  # last_only: the patches after `pending`
        for conn, ns, raw in bag_messages(reader, bag, conns):
            if last_only:  # decode nothing until the last full map is known
                if conn.topic == topic:
                    pending, patches = (conn, ns, raw, maps_seen), []
                    maps_seen += 1
                elif pending is not None:
                    patches.append((conn, ns, raw))
                continue
            if conn.topic == topic:
                pending, grid = (conn, ns, raw, maps_seen), None
                maps_seen += 1
            else:
                if pending is None and grid is None:
                    continue
                if grid is None:
                    assert pending is not None
                    grid = _decode_grid(reader, bag, topic, pending)
                    pending = None
                if not grid.apply(bag_deserialize(reader, bag, conn, raw), ns, bag, conn.topic):
                    continue
            index += 1
            if not last_only and index % every == 0:
                if grid is None:
                    assert pending is not None
                    current = _decode_grid(reader, bag, topic, pending)
                else:
                    current = grid
                last_yielded = index
                yield current.stamp, current.to_map(bag, topic, index)
        if last_only:
            if pending is None:
                raise BagError(f"{bag}: topic {topic} has no messages")
            grid = _decode_grid(reader, bag, topic, pending)
            index = pending[3]
            for conn, ns, raw in patches:
                if grid.apply(bag_deserialize(reader, bag, conn, raw), ns, bag, conn.topic):
                    index += 1
            yield grid.stamp, grid.to_map(bag, topic, index)
            return
        if index < 0:
            raise BagError(f"{bag}: topic {topic} has no messages")
        if (include_last or last_only) and last_yielded != index:
            if grid is None:
                assert pending is not None
                grid = _decode_grid(reader, bag, topic, pending)
            yield grid.stamp, grid.to_map(bag, topic, index)


def read_last_map(bag: PathLike, topic: str = "/map") -> OccupancyMap:
    """The last map of a bag (with ``<topic>_updates`` patches applied).

    Only the last full map and the patches after it are decoded.

    Examples
    --------
    >>> m = read_last_map("run1.bag")  # doctest: +SKIP
    >>> m.meta["topic"], m.meta["stamp"]  # doctest: +SKIP
    ('/map', 1503324571.12)
    >>> read_last_map("missing.mcap")
    Traceback (most recent call last):
    ...
    slamq.errors.BagError: missing.mcap: no such file or folder
    """
    last = None
    for _, m in read_bag_maps(bag, topic, last_only=True):
        last = m
    assert last is not None  # read_bag_maps raises when the topic has no messages
    return last
