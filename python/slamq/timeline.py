"""``slamq timeline``: the map metrics over time, from the maps a SLAM run published in a bag.

The paper's service kept "PGM representations of a map at every stage as it is built";
a bag holds the same stages on ``/map``. :func:`timeline` evaluates every N-th of them
(and the last one) and writes, into one folder:

- ``metrics.jsonl`` and ``metrics.csv``: one row per map: ``index`` (message number,
  counting ``/map_updates`` patches), ``timestamp`` (header stamp, s), ``elapsed`` (s since
  the first selected map), then every :class:`slamq.MapQuality` field;
- ``frames/frame_00000.png`` ...: each map rendered (:func:`slamq.animation.render_map`);
- ``timeline.gif``: the frames aligned in world coordinates, with a progress bar;
- ``metrics.png``: occupied fraction, corners and enclosed areas over time.
"""

from __future__ import annotations

import argparse
import csv
import inspect
import json
import math
import os
from pathlib import Path
from typing import Any, NamedTuple, Union

import numpy as np

from slamq.errors import ParamError, SlamqError

__all__ = ["timeline", "add_parser"]

PathLike = Union[str, "os.PathLike[str]"]

#: Output file names inside the timeline folder.
JSONL, CSV, GIF, PLOT = "metrics.jsonl", "metrics.csv", "timeline.gif", "metrics.png"
FRAMES = "frames"


def _jsonable(v: Any) -> Any:
    if isinstance(v, float) and not math.isfinite(v):
        return None
    if isinstance(v, (np.integer,)):
        return int(v)
    if isinstance(v, (np.floating,)):
        return _jsonable(float(v))
    return v


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
        :func:`slamq.bags.read_bag_maps`; ``<topic>_updates`` patches are applied).
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
    from slamq.animation import render_frames, render_map, write_gif
    from slamq.bags import read_bag_maps
    from slamq.params import Params
    from slamq.quality import evaluate

    # fail on a bad parameter before reading the bag
    accepted = set(inspect.signature(evaluate).parameters) - {"source"}
    unknown = sorted(set(params) - accepted)
    if unknown:
        raise ParamError(
            f"unknown parameter(s) {', '.join(unknown)}; known: {', '.join(sorted(accepted))}"
        )
    Params.from_kwargs(**{k: v for k, v in params.items() if k in Params.__dataclass_fields__})
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    if frames:
        (out / FRAMES).mkdir(exist_ok=True)
    rows: list[dict[str, Any]] = []
    geometry: list[_Geometry] = []  # the maps without their cells, for the GIF
    renders: list[np.ndarray] = []
    t0 = None
    for stamp, grid in read_bag_maps(bag, topic, every, include_last=True):
        q = evaluate(grid, **params)
        t0 = stamp if t0 is None else t0
        row: dict[str, Any] = {
            "index": int(grid.meta["index"]),
            "timestamp": float(stamp),
            "elapsed": float(stamp - t0),
        }
        row.update({k: _jsonable(v) for k, v in q.to_dict().items() if k != "curve"})
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
    """What :func:`slamq.animation.render_frames` needs of a map when given its render."""

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
    series = (
        ("occupied_fraction", "occupied fraction"),
        ("corners", "corners"),
        ("enclosed_areas", "enclosed areas"),
    )
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


# ----------------------------------------------------------------------------- CLI


def add_parser(subparsers: Any) -> None:
    """Register ``slamq timeline`` (see :mod:`slamq.cli`)."""
    from slamq.cli import add_metric_options

    p = subparsers.add_parser(
        "timeline",
        help="map metrics over time from the maps in a ROS bag, with frames and a GIF",
        description="Evaluate every N-th map a SLAM run published in a ROS1/ROS2/MCAP bag "
        "(and the last one); write metrics.jsonl, metrics.csv, PNG frames, timeline.gif "
        "and metrics.png into --out.",
    )
    p.add_argument("bag", help="a .bag, .db3 or .mcap file, or a ROS2 bag folder")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder (created)")
    p.add_argument("--every", type=int, default=1, metavar="N",
                   help="evaluate maps 0, N, 2N, ... and the last (default %(default)s)")
    p.add_argument("--topic", default="/map",
                   help="nav_msgs/OccupancyGrid topic (default %(default)s); "
                   "<topic>_updates patches are applied")
    p.add_argument("--max-size", type=int, default=512, metavar="PX",
                   help="longest side of frames and GIF in pixels (default %(default)s)")
    p.add_argument("--duration-ms", type=int, default=200,
                   help="GIF frame time (default %(default)s)")
    p.add_argument("--no-frames", action="store_true", help="do not write PNG frames")
    p.add_argument("--threads", type=int, default=None, help="cap on worker threads")
    add_metric_options(p)
    p.set_defaults(func=_cmd_timeline)


def _cmd_timeline(args: argparse.Namespace) -> int:
    from slamq.cli import EXIT_BAD_INPUT, EXIT_OK, error_line, metric_kwargs

    if args.every < 1:
        error_line("", ValueError(f"--every must be >= 1, got {args.every}"))
        return EXIT_BAD_INPUT
    if args.max_size < 1:
        error_line("", ValueError(f"--max-size must be >= 1, got {args.max_size}"))
        return EXIT_BAD_INPUT
    kwargs = metric_kwargs(args)
    if args.unknown_value is not None:
        kwargs["unknown_value"] = args.unknown_value
    if args.threads is not None:
        kwargs["threads"] = args.threads
    try:
        rows = timeline(args.bag, args.out, every=args.every, topic=args.topic,
                        max_size=args.max_size, duration_ms=args.duration_ms,
                        frames=not args.no_frames, **kwargs)
    except SlamqError as exc:
        error_line(args.bag, exc)
        return EXIT_BAD_INPUT
    out = Path(args.out)
    print(f"{len(rows)} maps from {args.bag} ({args.topic}) -> {out}/")
    print(f"{'index':>6} {'time s':>9} {'occupied':>9} {'corners':>8} {'enclosed':>8}")
    for r in rows:
        frac = r["occupied_fraction"]
        frac_s = "nan" if frac is None else f"{frac:.4f}"
        print(f"{r['index']:>6} {r['elapsed']:>9.2f} {frac_s:>9} {r['corners']:>8} "
              f"{r['enclosed_areas']:>8}")
    return EXIT_OK
