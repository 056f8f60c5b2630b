"""ROS bags (``.bag``, ``.mcap``, ``.db3``, a ROS 2 bag folder): a container of messages,
whose map is the last nav_msgs/OccupancyGrid on a topic (``/map`` by default;
:func:`slamq.sources.bag_maps.read_last_map`). A bag is a map only when named: the
folder walk does not look into bags, and its files can be gigabytes (hashed in chunks,
read by the bag library itself)."""

from __future__ import annotations

from pathlib import Path

from slamq.sources.files import is_bag
from slamq.sources.formats.raw import RawMap

__all__ = ["NAME", "files", "read", "sniff"]

NAME = "bag"
#: Bags found inside a folder are not maps: name a bag to evaluate its last map.
IN_FOLDERS = False
#: Its files may be gigabytes and the bag library opens them itself.
LARGE = True


def sniff(path: Path) -> bool:
    """A ``.bag``/``.db3``/``.mcap`` file or a folder holding ``metadata.yaml``.

    Examples
    --------
    >>> from pathlib import Path
    >>> sniff(Path("run1.bag")), sniff(Path("map.yaml"))
    (True, False)
    """
    return is_bag(path)


def files(path: Path) -> list[Path]:
    """The bag file, or every file of a ROS 2 bag folder."""
    if path.is_dir():
        return sorted(p for p in path.rglob("*") if p.is_file())
    return [path]


def read(path: Path, topic: str | None = None) -> RawMap:
    """The last map on ``topic`` (default ``/map``), with its ``_updates`` applied."""
    from slamq.sources.bag_maps import read_last_map

    return RawMap(str(path), grid=read_last_map(path, topic or "/map"))
