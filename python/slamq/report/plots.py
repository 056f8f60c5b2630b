"""The report's figures (matplotlib, Agg backend, PNG).

- :func:`metric_figure`: one metric, one panel per sequence, the runs of each algorithm as
  points over a box plot; logarithmic axis where the paper uses one (symlog for counts,
  which can be zero).
- :func:`curve_figure`: enclosed areas over the unknown value ``u`` (SPEC section 4).
- :func:`timeline_figure`: the metrics over map snapshots (for the map-building GIF).
- :func:`trajectory_figure`: a trajectory over its map, coloured by the ATE of each pose.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any, Callable, TypeVar

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from matplotlib.ticker import FuncFormatter, MaxNLocator, NullFormatter  # noqa: E402

from slamq.report.markup import metric_title  # noqa: E402
from slamq.verdict.ranking import Metric  # noqa: E402

__all__ = [
    "algorithm_colours",
    "curve_figure",
    "metric_figure",
    "timeline_figure",
    "trajectory_figure",
]

_DPI = 110
#: matplotlib's tab10, fixed (other libraries, e.g. evo, change the rcParams cycle).
_TAB10 = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2",
          "#7f7f7f", "#bcbd22", "#17becf")

_F = TypeVar("_F", bound=Callable[..., Any])


def _plain_text(fn: _F) -> _F:
    """Draw every text as it is: algorithm, sequence and file names are user strings, and
    matplotlib would read ``$...$`` in them as mathtext (and fail on ``$\\x$``)."""

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        with plt.rc_context({"text.parse_math": False}):
            return fn(*args, **kwargs)

    return wrapper  # type: ignore[return-value]


def algorithm_colours(algorithms: Sequence[str]) -> dict[str, str]:
    """A stable colour per algorithm (same in every figure of one report).

    Examples
    --------
    >>> algorithm_colours(["b", "a"])["a"]
    '#1f77b4'
    """
    cycle = _TAB10
    return {a: cycle[i % len(cycle)] for i, a in enumerate(sorted(set(algorithms)))}


@_plain_text
def metric_figure(
    ok: pd.DataFrame,
    metric: Metric,
    path: Path,
    *,
    sequences: Sequence[str] | None = None,
    colours: dict[str, str] | None = None,
    seed: int = 0,
) -> dict[str, int]:
    """Plot one metric: per sequence panel, each algorithm's runs as points over a box plot.

    Parameters
    ----------
    ok : pandas.DataFrame
        Successful records (``sequence``, ``algorithm``, the metric column).
    metric : Metric
    path : Path
        Where to write the PNG.
    sequences : sequence of str, optional
        Panel order (default: sorted sequences that have values).
    colours : dict, optional
        Colour per algorithm (default :func:`algorithm_colours`).
    seed : int
        Seed of the horizontal jitter of the points (reproducible pictures).

    Returns
    -------
    dict
        ``{sequence: number of points drawn}`` (finite values only).

    Examples
    --------
    >>> import pandas as pd, tempfile, pathlib
    >>> from slamq.verdict.ranking import METRICS
    >>> df = pd.DataFrame({"sequence": "s", "algorithm": ["a", "a", "b"], "corners": [3, 4, 9]})
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "corners.png"
    >>> metric_figure(df, METRICS[2], out)
    {'s': 3}
    """
    values = pd.to_numeric(ok[metric.key], errors="coerce") if metric.key in ok else None
    frame = ok.assign(_v=values)
    frame = frame[np.isfinite(frame["_v"].to_numpy(dtype=float))]
    seqs = [s for s in (sequences or sorted(frame["sequence"].unique()))
            if (frame["sequence"] == s).any()]
    colours = colours or algorithm_colours(ok["algorithm"].astype(str))
    n = max(1, len(seqs))
    cols = min(n, 3)
    rows = int(math.ceil(n / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 3.4 * rows), squeeze=False)
    rng = np.random.default_rng(seed)
    counts: dict[str, int] = {}
    for i, ax in enumerate(axes.flat):
        if i >= len(seqs):
            ax.set_visible(False)
            continue
        seq = seqs[i]
        sub = frame[frame["sequence"] == seq]
        algs = sorted(sub["algorithm"].astype(str).unique())
        data = [sub.loc[sub["algorithm"].astype(str) == a, "_v"].to_numpy(float) for a in algs]
        ax.boxplot(data, positions=range(len(algs)), widths=0.55, showfliers=False,
                   medianprops={"color": "black"}, boxprops={"color": "#555"},
                   whiskerprops={"color": "#555"}, capprops={"color": "#555"})
        total = 0
        for j, (a, v) in enumerate(zip(algs, data)):
            x = j + rng.uniform(-0.18, 0.18, size=len(v))
            ax.scatter(x, v, s=22, color=colours.get(a, "C0"), edgecolor="black",
                       linewidth=0.4, zorder=3)
            total += len(v)
        counts[str(seq)] = total
        ax.set_xticks(range(len(algs)))
        ax.set_xticklabels(algs, rotation=30, ha="right", fontsize=8)
        ax.set_title(str(seq), fontsize=10)
        if metric.log:
            allv = np.concatenate(data) if data else np.empty(0)
            if len(allv) and allv.min() > 0:
                ax.set_yscale("log")
            else:
                ax.set_yscale("symlog", linthresh=1.0)
                ax.set_ylim(bottom=0)
            plain = FuncFormatter(lambda v, _pos: f"{v:g}")
            ax.yaxis.set_major_formatter(plain)
            ax.yaxis.set_minor_formatter(plain if _decades(allv) < 1.0 else NullFormatter())
        ax.grid(axis="y", alpha=0.3, which="both")
        if i % cols == 0:
            ax.set_ylabel(metric.heading + (" (log)" if metric.log else ""))
    title = metric_title(metric)
    fig.suptitle(title, fontsize=11)
    fig.tight_layout()
    fig.savefig(path, dpi=_DPI, metadata={"Title": title})
    plt.close(fig)
    return counts


def _decades(v: np.ndarray) -> float:
    v = v[v > 0]
    return float(np.log10(v.max() / v.min())) if len(v) else 0.0


@_plain_text
def curve_figure(curve: Sequence[int], sweep_values: Sequence[int], best_u: int,
                 path: Path) -> None:
    """Enclosed areas counted at every unknown value ``u``, the maximum marked.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "c.png"
    >>> curve_figure([0, 2, 1], [0, 1, 2], 1, p); p.stat().st_size > 0
    True
    """
    fig, ax = plt.subplots(figsize=(6, 2.8))
    ax.step(list(sweep_values), list(curve), where="mid", color="C0")
    best = max(curve) if len(curve) else 0
    ax.axvline(best_u, color="C3", linestyle="--", linewidth=1)
    ax.annotate(f"max {best} at u = {best_u}", (best_u, best), xytext=(6, -12),
                textcoords="offset points", color="C3", fontsize=9)
    ax.set_xlabel("value given to unknown cells, u (0 = black)")
    ax.set_ylabel("enclosed areas")
    ax.set_xlim(0, 255)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=_DPI)
    plt.close(fig)


@_plain_text
def timeline_figure(
    series: dict[str, Sequence[float]], labels: Sequence[str], size_px: tuple[int, int],
) -> tuple[np.ndarray, list[int]]:
    """Small stacked plots of metrics over snapshots, rendered to an RGB array.

    Parameters
    ----------
    series : dict
        ``{metric label: values per snapshot}``.
    labels : sequence of str
        Snapshot names (x axis).
    size_px : (width, height)

    Returns
    -------
    (image, xs)
        ``image`` RGB uint8 of ``size_px``; ``xs[i]`` = pixel column of snapshot ``i``
        (where the animation draws its cursor).

    Examples
    --------
    >>> img, xs = timeline_figure({"corners": [1, 2, 3]}, ["a", "b", "c"], (300, 200))
    >>> img.shape, xs[0] < xs[1] < xs[2]
    ((200, 300, 3), True)
    """
    w, h = size_px
    n = len(labels)
    fig, axes = plt.subplots(len(series), 1, figsize=(w / 100, h / 100), dpi=100,
                             sharex=True, squeeze=False)
    x = np.arange(n)
    for ax, (name, vals) in zip(axes[:, 0], series.items()):
        ax.plot(x, np.asarray(vals, float), marker="o", markersize=2.5, color="C0")
        ax.set_ylabel(name, fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
    axes[-1, 0].set_xlabel("snapshot", fontsize=8)
    axes[-1, 0].xaxis.set_major_locator(MaxNLocator(integer=True, nbins=6))
    axes[-1, 0].xaxis.set_major_formatter(FuncFormatter(lambda v, _pos: f"{int(v) + 1}"))
    axes[-1, 0].set_xlim(-0.5, max(n - 0.5, 0.5))
    fig.tight_layout(pad=0.4)
    fig.canvas.draw()
    rgba = np.asarray(fig.canvas.buffer_rgba())
    img = np.ascontiguousarray(rgba[:, :, :3])
    trans = axes[-1, 0].transData
    xs = [int(round(trans.transform((i, 0))[0])) for i in range(n)]
    plt.close(fig)
    return img, xs


@_plain_text
def trajectory_figure(
    base_rgb: np.ndarray,
    rows: np.ndarray,
    cols: np.ndarray,
    errors: np.ndarray,
    path: Path,
    *,
    title: str = "",
    gt_rows: np.ndarray | None = None,
    gt_cols: np.ndarray | None = None,
    box: tuple[int, int, int, int] | None = None,
) -> None:
    """The estimated trajectory over its map (cells), each pose coloured by its ATE (m), and
    the ground truth (already in the map's frame) as a dashed line when given; ``box``
    ``(r0, r1, c0, c1)`` crops the view (to the known cells), widened to the paths.

    Examples
    --------
    >>> import numpy as np, tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "t.png"
    >>> base = np.full((20, 30, 3), 255, np.uint8)
    >>> trajectory_figure(base, np.array([2., 5.]), np.array([3., 9.]), np.array([.1, .3]), p)
    >>> p.stat().st_size > 0
    True
    """
    h, w = base_rgb.shape[:2]
    if box is not None:
        rr = [r for r in (rows, gt_rows) if r is not None and len(r)]
        cc = [c for c in (cols, gt_cols) if c is not None and len(c)]
        r0 = int(min([box[0], *(np.floor(r.min()) - 2 for r in rr)]))
        r1 = int(max([box[1], *(np.ceil(r.max()) + 3 for r in rr)]))
        c0 = int(min([box[2], *(np.floor(c.min()) - 2 for c in cc)]))
        c1 = int(max([box[3], *(np.ceil(c.max()) + 3 for c in cc)]))
        h, w = max(1, r1 - r0), max(1, c1 - c0)
    scale = 7.0 / max(h, w)
    fig, ax = plt.subplots(figsize=(max(3.0, w * scale + 1.4), max(3.0, h * scale)))
    ax.imshow(base_rgb, interpolation="nearest")
    if gt_rows is not None and gt_cols is not None:
        ax.plot(gt_cols, gt_rows, color="#d62728", linewidth=0.9, linestyle="--",
                label="ground truth (aligned)")
        ax.legend(loc="lower right", fontsize=7)
    ax.plot(cols, rows, color="black", linewidth=0.6, alpha=0.5)
    sc = ax.scatter(cols, rows, c=errors, cmap="viridis", s=9, zorder=3)
    fig.colorbar(sc, ax=ax, label="ATE of the pose (m)", shrink=0.8)
    if box is not None:
        ax.set_xlim(c0 - 0.5, c1 - 0.5)
        ax.set_ylim(r1 - 0.5, r0 - 0.5)
    ax.set_xticks([])
    ax.set_yticks([])
    if title:
        ax.set_title(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=_DPI)
    plt.close(fig)


def error_time_figure(seconds: np.ndarray, errors: np.ndarray, path: Path, *,
                      title: str = "", unit: str = "m") -> None:
    """Per-pose error over time since the first pose, with its mean and RMSE, as evo plots.

    Examples
    --------
    >>> import numpy as np, tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "e.png"
    >>> error_time_figure(np.arange(5.0), np.array([.1, .2, .1, .3, .2]), p)
    >>> p.stat().st_size > 0
    True
    """
    fig, ax = plt.subplots(figsize=(6.4, 2.6))
    ax.plot(seconds, errors, color="#1f77b4", linewidth=0.9, label="error")
    if len(errors):
        ax.axhline(float(np.mean(errors)), color="#2ca02c", linestyle="--", linewidth=0.8,
                   label="mean")
        ax.axhline(float(np.sqrt(np.mean(np.square(errors)))), color="#d62728",
                   linestyle=":", linewidth=0.9, label="RMSE")
    ax.set_xlabel("time since the first pose (s)")
    ax.set_ylabel(f"error ({unit})")
    ax.legend(fontsize=7, loc="upper left")
    if title:
        ax.set_title(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=_DPI)
    plt.close(fig)
