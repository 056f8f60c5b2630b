"""Map-building animations: snapshots of one run, side by side with the metrics over time.

A run folder that holds numbered snapshots (``map_0001.pgm``, ``map_0002.yaml``, ...; a YAML
wins over the image it names) gets an animated GIF: the map as it grows (north up, scaled
to a fixed box) beside the occupied fraction, corners and enclosed areas of every snapshot,
with a cursor on the current one. A ROS bag with a ``/map`` topic gives the same when
:mod:`slamq.sources.bag_maps` can read its maps.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image, ImageDraw

from slamq.models import OccupancyMap
from slamq.params import Params
from slamq.report.data import evaluate_map
from slamq.report.overlays import render_base
from slamq.sources import load_map

__all__ = ["Timeline", "find_snapshots", "build_timeline", "write_timeline_gif"]

_SNAP = re.compile(r"^map_(\d+)\.(yaml|yml|pgm|png)$", re.IGNORECASE)
#: Frames kept at most (evenly subsampled, always keeping the last).
MAX_FRAMES = 120


def find_snapshots(folder: Path) -> list[Path]:
    """Numbered map snapshots in a folder (or its ``snapshots/`` subfolder), in order.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> for n in ("map_0002.pgm", "map_0001.pgm", "map_0001.yaml", "map.pgm"):
    ...     _ = (d / n).write_text("")
    >>> [p.name for p in find_snapshots(d)]
    ['map_0001.yaml', 'map_0002.pgm']
    """
    folder = Path(folder)
    found: dict[int, Path] = {}
    for where in (folder, folder / "snapshots"):
        if not where.is_dir():
            continue
        for p in sorted(where.iterdir()):
            m = _SNAP.match(p.name)
            if not m or not p.is_file():
                continue
            k = int(m.group(1))
            is_yaml = m.group(2).lower() in ("yaml", "yml")
            if k not in found or is_yaml:
                found[k] = p
        if found:
            break
    return [found[k] for k in sorted(found)]


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


def _fit(rgb: np.ndarray, box: int) -> Image.Image:
    img = Image.fromarray(rgb)
    scale = box / max(img.size)
    size = (max(1, round(img.size[0] * scale)), max(1, round(img.size[1] * scale)))
    resample = Image.Resampling.NEAREST if scale >= 1 else Image.Resampling.BOX
    img = img.resize(size, resample)
    canvas = Image.new("RGB", (box, box), (255, 255, 255))
    canvas.paste(img, ((box - size[0]) // 2, (box - size[1]) // 2))
    return canvas


def write_timeline_gif(
    timeline: Timeline, path: Path, *, box: int = 360, duration_ms: int = 250,
) -> Path:
    """An animated GIF: each snapshot beside the metric curves, a cursor on it.

    Examples
    --------
    >>> import numpy as np, slamq, tempfile, pathlib
    >>> a = slamq.OccupancyMap(np.full((9, 9), 254, np.uint8), np.zeros((9, 9), bool))
    >>> p = write_timeline_gif(build_timeline([a, a]), pathlib.Path(tempfile.mkdtemp()) / "t.gif")
    >>> from PIL import Image; Image.open(p).n_frames
    2
    """
    from slamq.report.plots import timeline_figure

    series = {
        "occupied fraction": timeline.occupied_fraction,
        "corners": timeline.corners,
        "enclosed areas": timeline.enclosed_areas,
    }
    chart, xs = timeline_figure(series, timeline.names, (box + 60, box))
    frames: list[np.ndarray] = []
    for i, grid in enumerate(timeline.maps):
        left = _fit(render_base(grid), box)
        right = Image.fromarray(chart.copy())
        draw = ImageDraw.Draw(right)
        draw.line([(xs[i], 4), (xs[i], right.size[1] - 4)], fill=(220, 0, 0), width=2)
        frame = Image.new("RGB", (left.size[0] + right.size[0], box + 24), (255, 255, 255))
        frame.paste(left, (0, 24))
        frame.paste(right, (left.size[0], 24))
        ImageDraw.Draw(frame).text(
            (6, 6),
            f"{timeline.names[i]}  ({i + 1}/{len(timeline)}): occupied "
            f"{timeline.occupied_fraction[i]:.3g}, corners {timeline.corners[i]}, "
            f"enclosed {timeline.enclosed_areas[i]}",
            fill=(0, 0, 0),
        )
        frames.append(np.asarray(frame))
    return _write_gif(frames, Path(path), duration_ms)


def _write_gif(frames: list[np.ndarray], path: Path, duration_ms: int) -> Path:
    from slamq.report.animation import write_gif

    return Path(write_gif(frames, path, duration_ms=duration_ms))


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
