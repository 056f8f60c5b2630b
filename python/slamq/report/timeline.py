"""Timelines drawn: the map metrics of one map as it is built, over its snapshots or the
maps a SLAM run published in a bag (scored by :mod:`slamq.verdict.building`):

* :func:`timeline` (``slamq timeline``): every N-th map of a bag evaluated, written as
  files (below).
* :func:`write_timeline_gif`: the report's "map building" animation of a
  :class:`~slamq.verdict.building.Timeline`: the map as it grows (north up, scaled to a
  fixed box) beside the occupied fraction, corners and enclosed areas of every snapshot,
  with a cursor on the current one.

``slamq timeline``:

The paper's service kept "PGM representations of a map at every stage as it is built";
a bag holds the same stages on ``/map``. :func:`timeline` evaluates every N-th of them
(and the last one) and writes, into one folder:

- ``metrics.jsonl`` and ``metrics.csv``: one row per map: ``index`` (message number,
  counting ``/map_updates`` patches), ``timestamp`` (header stamp, s), ``elapsed`` (s since
  the first selected map), then every :class:`slamq.MapQuality` field;
- ``frames/frame_00000.png`` ...: each map rendered (:func:`slamq.report.animation.render_map`);
- ``timeline.gif``: the frames aligned in world coordinates, with a progress bar;
- ``metrics.png``: occupied fraction, corners and enclosed areas over time.
"""

from __future__ import annotations

import csv
import json
import os
from pathlib import Path
from typing import Any, NamedTuple, Union

import numpy as np
from PIL import Image, ImageDraw

from slamq.columns import shown
from slamq.report.overlays import render_base
from slamq.results.columns import json_value
from slamq.verdict.building import Timeline, evaluated_bag_maps

PathLike = Union[str, "os.PathLike[str]"]

__all__ = ["timeline", "write_timeline_gif"]

#: Output file names inside the timeline folder.
JSONL, CSV, GIF, PLOT = "metrics.jsonl", "metrics.csv", "timeline.gif", "metrics.png"
FRAMES = "frames"


def timeline(
    bag: PathLike,
    out_dir: PathLike,
    *,
    every: int = 1,
    topic: str = "/map",
    max_size: int | None = 512,
    duration_ms: int = 200,
    frames: bool = True,
    gif: bool = True,
    plot: bool = True,
    **params: Any,
) -> list[dict[str, Any]]:
    """Evaluate every ``every``-th map of a bag (and the last one); write metrics and pictures.

    Parameters
    ----------
    bag : path
        ROS1 ``.bag``, ROS2 ``.db3``/``.mcap`` file or ROS2 bag folder (see
        :func:`slamq.sources.bag_maps.read_bag_maps`; ``<topic>_updates`` patches are applied).
    out_dir : path
        Folder for ``metrics.jsonl``, ``metrics.csv``, ``frames/``, ``timeline.gif`` and
        ``metrics.png`` (created).
    every : int, default 1
        Keep maps 0, N, 2N, ... and always the last one.
    topic : str, default "/map"
    max_size : int, optional, default 512
        Longest side of PNG frames and of the GIF, in pixels (never enlarged; None: full
        size).
    duration_ms : int, default 200
        GIF frame time.
    frames, gif, plot : bool, default True
        Write the PNG frames, the GIF, the metrics plot.
    **params
        Passed to :func:`slamq.evaluate` (metric parameters, ``threads``,
        ``unknown_value``...).

    Returns
    -------
    list of dict
        The rows written to ``metrics.jsonl`` (``curve`` left out), in bag order.

    Raises
    ------
    BagError
        The bag cannot be read, lacks the topic, or holds no map.
    ParamError
        A bad metric parameter.

    Examples
    --------
    >>> rows = timeline("run1.bag", "out/run1", every=10)  # doctest: +SKIP
    >>> [(r["timestamp"], r["corners"]) for r in rows]  # doctest: +SKIP
    """
    from slamq.report.animation import render_frames, render_map, write_gif

    # fails on a bad parameter before the bag is read
    maps = evaluated_bag_maps(bag, every=every, topic=topic, **params)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    if frames:
        (out / FRAMES).mkdir(exist_ok=True)
    rows: list[dict[str, Any]] = []
    geometry: list[_Geometry] = []  # the maps without their cells, for the GIF
    renders: list[np.ndarray] = []
    t0 = None
    for stamp, grid, q in maps:
        t0 = stamp if t0 is None else t0
        row: dict[str, Any] = {
            "index": int(grid.meta["index"]),
            "timestamp": float(stamp),
            "elapsed": float(stamp - t0),
        }
        row.update({k: json_value(v) for k, v in q.to_dict().items() if k != "curve"})
        rows.append(row)
        if frames or gif:
            small = render_map(grid, max_size=max_size)
            if frames:
                from PIL import Image

                Image.fromarray(small).save(out / FRAMES / f"frame_{len(rows) - 1:05d}.png")
            if gif:
                renders.append(small)
                geometry.append(_Geometry(grid.shape, grid.resolution, grid.origin))
    _write_rows(out, rows)
    if gif and renders:
        pictures = render_frames(geometry, max_size=max_size, renders=renders)
        write_gif([_progress(f, i, len(pictures)) for i, f in enumerate(pictures)],
                  out / GIF, duration_ms=duration_ms)
    if plot and rows:
        _plot(rows, out / PLOT)
    return rows


class _Geometry(NamedTuple):
    """What :func:`slamq.report.animation.render_frames` needs of a map when given its render."""

    shape: tuple[int, int]
    resolution: float | None
    origin: tuple[float, float, float]


def _progress(frame: np.ndarray, i: int, n: int) -> np.ndarray:
    """A 3-pixel progress bar under the frame (consecutive GIF frames then never merge)."""
    h, w = frame.shape[:2]
    bar = np.full((3, w, 3), 255, np.uint8)
    bar[:, : max(1, round(w * (i + 1) / n))] = (220, 40, 40)
    return np.concatenate([frame, bar], axis=0)


def _write_rows(out: Path, rows: list[dict[str, Any]]) -> None:
    with open(out / JSONL, "w", encoding="utf-8") as f:
        for row in rows:
            f.write(json.dumps(row, allow_nan=False) + "\n")
    names: list[str] = []
    for row in rows:
        names.extend(k for k in row if k not in names)
    with open(out / CSV, "w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=names)
        writer.writeheader()
        for row in rows:
            writer.writerow({k: ("" if v is None else v) for k, v in row.items()})


def _plot(rows: list[dict[str, Any]], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg", force=False)
    from matplotlib.figure import Figure

    t = [r["elapsed"] for r in rows]
    series = [(c.name, c.label) for c in shown("timeline")]
    fig = Figure(figsize=(6.0, 5.0), dpi=100)
    axes = fig.subplots(len(series), 1, sharex=True)
    for ax, (key, label) in zip(axes, series):
        ys = [np.nan if r[key] is None else r[key] for r in rows]
        ax.plot(t, ys, marker="o", markersize=3, linewidth=1.2)
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
    axes[-1].set_xlabel("time since first map (s)")
    fig.suptitle(f"{Path(str(rows[0]['source']).split(':')[0]).name}: map metrics over time",
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(path)


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
    >>> from slamq.verdict.building import build_timeline
    >>> p = write_timeline_gif(build_timeline([a, a]), pathlib.Path(tempfile.mkdtemp()) / "t.gif")
    >>> from PIL import Image; Image.open(p).n_frames
    2
    """
    from slamq.report.plots import timeline_figure

    series = {c.label: getattr(timeline, c.name) for c in shown("timeline")
              if hasattr(timeline, c.name)}  # the series a Timeline holds
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
