"""A map as it is built, scored snapshot by snapshot: the snapshots of a run folder
(:func:`slamq.sources.snapshots.find_snapshots`) or the maps a SLAM run published in a bag,
each evaluated. :mod:`slamq.report.timeline` draws them (the report's "map building"
animation, ``slamq timeline``).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from slamq.models import MapQuality, OccupancyMap
from slamq.params import Params
from slamq.sources.maps import load_map
from slamq.verdict.records import evaluate_map

__all__ = ["MAX_FRAMES", "Timeline", "bag_maps", "build_timeline", "building_maps",
           "evaluated_bag_maps"]

#: Frames of a report animation kept at most (evenly subsampled, always keeping the last).
MAX_FRAMES = 120


@dataclass
class Timeline:
    """Metrics of a sequence of snapshots of one map being built.

    Attributes
    ----------
    names : list of str
        One label per snapshot.
    maps : list of OccupancyMap
    occupied_fraction, corners, enclosed_areas : list
        The metrics of each snapshot.
    """

    names: list[str]
    maps: list[OccupancyMap]
    occupied_fraction: list[float]
    corners: list[int]
    enclosed_areas: list[int]

    def __len__(self) -> int:
        return len(self.maps)


def _subsample(items: Sequence[Any], limit: int) -> list[Any]:
    if len(items) <= limit:
        return list(items)
    idx = np.unique(np.linspace(0, len(items) - 1, limit).round().astype(int))
    return [items[i] for i in idx]


def build_timeline(
    sources: Sequence[Any], params: Params | None = None, *, names: list | None = None,
) -> Timeline:
    """Load and evaluate snapshots (paths or OccupancyMaps), at most :data:`MAX_FRAMES`.

    Examples
    --------
    >>> import numpy as np, slamq
    >>> a = slamq.OccupancyMap(np.full((9, 9), 254, np.uint8), np.zeros((9, 9), bool))
    >>> build_timeline([a, a]).corners
    [0, 0]
    """
    params = params or Params()
    picked = _subsample(list(range(len(sources))), MAX_FRAMES)
    maps, labels, frac, corners, enclosed = [], [], [], [], []
    for i in picked:
        src = sources[i]
        grid = src if isinstance(src, OccupancyMap) else load_map(src)
        q = evaluate_map(grid, params, curve=False)
        maps.append(grid)
        labels.append(str(names[i]) if names else (Path(str(src)).stem
                                                   if not isinstance(src, OccupancyMap)
                                                   else str(i + 1)))
        frac.append(float(q.occupied_fraction))
        corners.append(int(q.corners))
        enclosed.append(int(q.enclosed_areas))
    return Timeline(labels, maps, frac, corners, enclosed)


def bag_maps(path: Path, topic: str = "/map") -> list[OccupancyMap] | None:
    """Every map on the bag's ``/map`` topic (:func:`~slamq.sources.bag_maps.read_bag_maps`),
    else None.

    At most :data:`MAX_FRAMES` maps are kept (evenly spaced, the last one included).
    """
    from slamq.errors import BagError
    from slamq.sources.bag_maps import read_bag_maps
    from slamq.sources.bagfile import bag_topics

    try:
        if topic not in bag_topics(path):
            return None
    except BagError:  # not a readable bag (or the 'bags' extra is missing): no animation
        return None
    maps = [m for _, m in read_bag_maps(path, topic)]
    return _subsample(maps, MAX_FRAMES) or None


def building_maps(map_path: Any) -> tuple[list[Any], str]:
    """The stages of a run's map and how to name them: every ``/map`` message when the map
    is a bag, else the numbered snapshots beside the map file.

    Returns
    -------
    (list, str)
        The maps (OccupancyMaps from a bag, paths of snapshots) and a phrase saying what
        they are.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> building_maps(pathlib.Path(tempfile.mkdtemp()) / "map.pgm")[0]
    []
    """
    from slamq.sources.snapshots import find_snapshots

    path = Path(map_path)
    if path.suffix.lower() in (".bag", ".mcap", ".db3") or (path / "metadata.yaml").is_file():
        return bag_maps(path) or [], f"every /map message of {path.name}"
    sources = find_snapshots(path.parent)
    return sources, f"{len(sources)} snapshots in {path.parent.name}/"


def evaluated_bag_maps(bag: Any, *, every: int = 1, topic: str = "/map", **params: Any
                       ) -> Iterator[tuple[float, OccupancyMap, MapQuality]]:
    """``(timestamp, map, quality)`` of every ``every``-th map of a bag and the last one,
    read and evaluated one at a time.

    The parameters are checked at the call, before the bag is read.

    Parameters
    ----------
    bag : path
        ROS1 ``.bag``, ROS2 ``.db3``/``.mcap`` file or ROS2 bag folder.
    every : int, default 1
    topic : str, default "/map"
    **params
        Passed to :func:`slamq.metrics.evaluate.evaluate` (metric parameters, ``threads``,
        ``unknown_value``...).

    Raises
    ------
    ParamError
        A bad metric parameter (at the call).
    BagError
        The bag cannot be read, lacks the topic, or holds no map (while iterating).

    Examples
    --------
    >>> evaluated_bag_maps("run1.bag", min_area=-1)
    Traceback (most recent call last):
    ...
    slamq.errors.ParamError: min_area must be an integer in 0..2147483647, got -1
    """
    from slamq.params import check_threads

    options = {k: params.pop(k) for k in ("threads", "unknown_value") if k in params}
    metric_params = Params.from_kwargs(**params)
    check_threads(options.get("threads"))
    return _evaluate_each(bag, topic, every, metric_params, options)


def _evaluate_each(bag: Any, topic: str, every: int, params: Params, options: dict[str, Any]
                   ) -> Iterator[tuple[float, OccupancyMap, MapQuality]]:
    from slamq.metrics.evaluate import evaluate
    from slamq.sources.bag_maps import read_bag_maps

    for stamp, grid in read_bag_maps(bag, topic, every, include_last=True):
        yield stamp, grid, evaluate(grid, params=params, **options)
