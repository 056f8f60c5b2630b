"""The report's figures.

The index's figures and the animations' plots are matplotlib's (Agg backend, PNG); the
figures of a detail page are drawn without it, so that a report whose index figures are
kept from an earlier build (:mod:`slamq.report.cache`) never imports matplotlib:

- :func:`metric_figure`: one metric, one panel per sequence, the runs of each algorithm as
  points over a box plot; logarithmic axis where the paper uses one (symlog for counts,
  which can be zero). matplotlib.
- :func:`timeline_figure`: the metrics over map snapshots (for the map-building GIF).
  matplotlib.
- :func:`curve_figure`: enclosed areas over the unknown value ``u`` (SPEC section 4). SVG.
- :func:`error_time_figure`: the ATE of each pose over time. SVG.
- :func:`trajectory_figure`: a trajectory over its map, coloured by the ATE of each pose.
  PNG drawn with pillow.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, TypeVar

import numpy as np

from slamq.report.markup import esc as _e
from slamq.report.markup import metric_title

if TYPE_CHECKING:
    import pandas as pd

    from slamq.verdict.ranking import Metric

__all__ = [
    "algorithm_colours",
    "curve_figure",
    "error_time_figure",
    "metric_figure",
    "timeline_figure",
    "trajectory_figure",
]

_DPI = 110
#: matplotlib's tab10, fixed (other libraries, e.g. evo, change the rcParams cycle).
_TAB10 = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2",
          "#7f7f7f", "#bcbd22", "#17becf")

_F = TypeVar("_F", bound=Callable[..., Any])


def _pyplot() -> Any:
    """matplotlib's pyplot on the Agg backend, imported on first use (about a second)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _plain_text(fn: _F) -> _F:
    """Draw every text as it is: algorithm, sequence and file names are user strings, and
    matplotlib would read ``$...$`` in them as mathtext (and fail on ``$\\x$``)."""

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        with _pyplot().rc_context({"text.parse_math": False}):
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
        Where to write the figure: an SVG file (drawn without matplotlib) when it ends in
        ``.svg``, else a PNG (matplotlib).
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
    >>> metric_figure(df, METRICS[2], out.with_suffix(".svg"))
    {'s': 3}
    """
    if Path(path).suffix.lower() == ".svg":
        return _metric_svg(ok, metric, Path(path), sequences=sequences, colours=colours,
                           seed=seed)
    return _metric_png(ok, metric, path, sequences=sequences, colours=colours, seed=seed)


@_plain_text
def _metric_png(ok: pd.DataFrame, metric: Metric, path: Path, *,
                sequences: Sequence[str] | None, colours: dict[str, str] | None,
                seed: int) -> dict[str, int]:
    """:func:`metric_figure` as a PNG drawn by matplotlib."""
    import pandas as pd
    from matplotlib.ticker import FuncFormatter, NullFormatter

    plt = _pyplot()
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
    from matplotlib.ticker import FuncFormatter, MaxNLocator

    plt = _pyplot()
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


# ------------------------------------------------------------------ drawn without matplotlib

#: matplotlib's viridis at ten evenly spaced points (interpolated linearly in between).
_VIRIDIS = ((68, 1, 84), (72, 40, 120), (62, 73, 137), (49, 104, 142), (38, 130, 142),
            (31, 158, 137), (53, 183, 121), (110, 206, 88), (181, 222, 43), (253, 231, 37))

_FONT = "font-family=\"DejaVu Sans, Helvetica, Arial, sans-serif\""


def viridis(t: np.ndarray) -> np.ndarray:
    """RGB uint8 colours of ``t`` in [0, 1] (clipped) on the viridis colour map.

    Examples
    --------
    >>> viridis(np.array([0.0, 1.0])).tolist()
    [[68, 1, 84], [253, 231, 37]]
    """
    stops = np.asarray(_VIRIDIS, float)
    x = np.clip(np.nan_to_num(np.asarray(t, float)), 0.0, 1.0) * (len(stops) - 1)
    i = np.minimum(x.astype(int), len(stops) - 2)
    f = (x - i)[..., None]
    return np.rint(stops[i] * (1 - f) + stops[i + 1] * f).astype(np.uint8)


def nice_ticks(lo: float, hi: float, n: int = 5) -> list[float]:
    """About ``n`` round tick values covering ``[lo, hi]`` (steps of 1, 2, 2.5 or 5 x 10^k).

    Examples
    --------
    >>> nice_ticks(0, 255)
    [0.0, 50.0, 100.0, 150.0, 200.0, 250.0]
    >>> nice_ticks(3, 3)
    [3.0]
    """
    if not (math.isfinite(lo) and math.isfinite(hi)) or hi <= lo:
        return [float(lo)] if math.isfinite(lo) else []
    raw = (hi - lo) / max(n, 1)
    mag = 10.0 ** math.floor(math.log10(raw))
    step = next(m * mag for m in (1, 2, 2.5, 5, 10) if m * mag >= 0.75 * raw)
    first = math.ceil(lo / step - 1e-9)
    return [round(k * step, 12) for k in range(first, int(math.floor(hi / step + 1e-9)) + 1)]


class _Axes:
    """A plot area of an SVG figure: data ``x`` in ``[x0, x1]``, ``y`` in ``[y0, y1]``
    mapped onto the pixel box ``(left, top, width, height)``."""

    def __init__(self, box: tuple[float, float, float, float], xlim: tuple[float, float],
                 ylim: tuple[float, float]) -> None:
        self.left, self.top, self.width, self.height = box
        self.x0, self.x1 = xlim
        self.y0, self.y1 = ylim if ylim[1] > ylim[0] else (ylim[0] - 1.0, ylim[0] + 1.0)
        if self.x1 <= self.x0:
            self.x0, self.x1 = self.x0 - 1.0, self.x0 + 1.0

    def px(self, x: Any) -> np.ndarray:
        return self.left + (np.asarray(x, float) - self.x0) / (self.x1 - self.x0) * self.width

    def py(self, y: Any) -> np.ndarray:
        return self.top + (self.y1 - np.asarray(y, float)) / (self.y1 - self.y0) * self.height

    def frame(self, xlabel: str, ylabel: str, xticks: Sequence[float],
              yticks: Sequence[float], xfmt: Callable[[float], str] = "{:g}".format) -> str:
        """Grid, frame, ticks and axis labels."""
        out = []
        right, bottom = self.left + self.width, self.top + self.height
        for v in yticks:
            y = float(self.py(v))
            out.append(f"<line x1=\"{self.left:.1f}\" y1=\"{y:.1f}\" x2=\"{right:.1f}\" "
                       f"y2=\"{y:.1f}\" stroke=\"#000\" stroke-opacity=\"0.12\"/>"
                       f"<text x=\"{self.left - 5:.1f}\" y=\"{y + 4:.1f}\" "
                       f"text-anchor=\"end\">{_e(f'{v:g}')}</text>")
        for v in xticks:
            x = float(self.px(v))
            out.append(f"<line x1=\"{x:.1f}\" y1=\"{self.top:.1f}\" x2=\"{x:.1f}\" "
                       f"y2=\"{bottom:.1f}\" stroke=\"#000\" stroke-opacity=\"0.12\"/>"
                       f"<text x=\"{x:.1f}\" y=\"{bottom + 15:.1f}\" "
                       f"text-anchor=\"middle\">{_e(xfmt(v))}</text>")
        out.append(f"<rect x=\"{self.left:.1f}\" y=\"{self.top:.1f}\" width=\"{self.width:.1f}\""
                   f" height=\"{self.height:.1f}\" fill=\"none\" stroke=\"#000\" "
                   "stroke-width=\"0.8\"/>")
        out.append(f"<text x=\"{self.left + self.width / 2:.1f}\" y=\"{bottom + 32:.1f}\" "
                   f"text-anchor=\"middle\">{_e(xlabel)}</text>")
        cy = self.top + self.height / 2
        out.append(f"<text x=\"14\" y=\"{cy:.1f}\" text-anchor=\"middle\" "
                   f"transform=\"rotate(-90 14 {cy:.1f})\">{_e(ylabel)}</text>")
        return "".join(out)


def _svg(width: int, height: int, body: str, title: str = "") -> str:
    """A whole SVG document; ``title`` is its ``<title>`` (what the page's caption says)."""
    head = f"<title>{_e(title)}</title>" if title else ""
    return (f"<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{width}\" height=\"{height}\" "
            f"viewBox=\"0 0 {width} {height}\" {_FONT} font-size=\"11\">{head}"
            f"<rect width=\"{width}\" height=\"{height}\" fill=\"#fff\"/>{body}</svg>\n")


def _polyline(xs: np.ndarray, ys: np.ndarray) -> str:
    return " ".join(f"{x:.1f},{y:.1f}" for x, y in zip(xs, ys))


def curve_figure(curve: Sequence[int], sweep_values: Sequence[int], best_u: int,
                 path: Path) -> None:
    """Enclosed areas counted at every unknown value ``u``, the maximum marked (SVG).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "c.svg"
    >>> curve_figure([0, 2, 1], [0, 1, 2], 1, p); "max 2 at u = 1" in p.read_text()
    True
    """
    xs = np.asarray(list(sweep_values), float)
    ys = np.asarray(list(curve), float)
    best = int(ys.max()) if len(ys) else 0
    top = max(1.0, float(best)) * 1.08
    ax = _Axes((58, 14, 520, 214), (0.0, 255.0), (0.0, top))
    yt = [v for v in nice_ticks(0.0, top, 4) if v == int(v)] or [0.0]
    body = [ax.frame("value given to unknown cells, u (0 = black)", "enclosed areas",
                     nice_ticks(0.0, 255.0), yt)]
    if len(xs):
        # a step at each sweep value, changing half-way between two values (matplotlib's
        # where="mid")
        mids = np.concatenate([[xs[0]], (xs[:-1] + xs[1:]) / 2, [xs[-1]]])
        px = np.repeat(mids, 2)[1:-1]
        py = np.repeat(ys, 2)
        body.append(f"<polyline points=\"{_polyline(ax.px(px), ax.py(py))}\" fill=\"none\" "
                    "stroke=\"#1f77b4\" stroke-width=\"1.5\"/>")
    bx, by = float(ax.px(best_u)), float(ax.py(best))
    body.append(f"<line x1=\"{bx:.1f}\" y1=\"{ax.top}\" x2=\"{bx:.1f}\" "
                f"y2=\"{ax.top + ax.height}\" stroke=\"#d62728\" stroke-dasharray=\"5 3\"/>"
                f"<text x=\"{min(bx + 6, ax.left + ax.width - 120):.1f}\" "
                f"y=\"{by + 14:.1f}\" fill=\"#d62728\">max {best} at u = {int(best_u)}</text>")
    Path(path).write_text(_svg(600, 270, "".join(body)), encoding="utf-8")


def error_time_figure(seconds: np.ndarray, errors: np.ndarray, path: Path, *,
                      title: str = "", unit: str = "m") -> None:
    """Per-pose error over time since the first pose, with its mean and RMSE, as evo plots
    (SVG).

    Examples
    --------
    >>> import numpy as np, tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "e.svg"
    >>> error_time_figure(np.arange(5.0), np.array([.1, .2, .1, .3, .2]), p)
    >>> "RMSE" in p.read_text()
    True
    """
    t = np.asarray(seconds, float)
    e = np.asarray(errors, float)
    hi = float(np.nanmax(e)) * 1.05 if len(e) and np.isfinite(e).any() else 1.0
    lo = min(0.0, float(np.nanmin(e))) if len(e) and np.isfinite(e).any() else 0.0
    tmax = float(t.max()) if len(t) else 1.0
    ax = _Axes((62, 24 if title else 10, 560, 196), (0.0, max(tmax, 1e-9)),
               (lo, max(hi, lo + 1e-9)))
    body = [ax.frame("time since the first pose (s)", f"error ({unit})",
                     nice_ticks(0.0, tmax, 6), nice_ticks(lo, hi, 4))]
    if title:
        body.append(f"<text x=\"{ax.left + ax.width / 2:.1f}\" y=\"15\" "
                    f"text-anchor=\"middle\">{_e(title)}</text>")
    legend = [("error", "#1f77b4", "")]
    if len(e):
        body.append(f"<polyline points=\"{_polyline(ax.px(t), ax.py(e))}\" fill=\"none\" "
                    "stroke=\"#1f77b4\" stroke-width=\"1\"/>")
        for label, value, colour, dash in (
                ("mean", float(np.mean(e)), "#2ca02c", "5 3"),
                ("RMSE", float(np.sqrt(np.mean(np.square(e)))), "#d62728", "1.5 2")):
            y = float(ax.py(value))
            body.append(f"<line x1=\"{ax.left}\" y1=\"{y:.1f}\" x2=\"{ax.left + ax.width}\" "
                        f"y2=\"{y:.1f}\" stroke=\"{colour}\" stroke-dasharray=\"{dash}\"/>")
            legend.append((label, colour, dash))
    for k, (label, colour, dash) in enumerate(legend):
        y = ax.top + 12 + 14 * k
        x = ax.left + 8
        body.append(f"<line x1=\"{x}\" y1=\"{y - 4}\" x2=\"{x + 20}\" y2=\"{y - 4}\" "
                    f"stroke=\"{colour}\" stroke-width=\"1.5\""
                    + (f" stroke-dasharray=\"{dash}\"" if dash else "") + "/>"
                    f"<text x=\"{x + 25}\" y=\"{y}\" font-size=\"10\">{label}</text>")
    Path(path).write_text(_svg(640, 260, "".join(body)), encoding="utf-8")


def _dashes(pts: list[tuple[float, float]], *, on: float, off: float
            ) -> list[list[tuple[float, float]]]:
    """The pieces of the polyline ``pts`` drawn by a dash pattern (``on`` px, ``off`` px).

    Examples
    --------
    >>> _dashes([(0.0, 0.0), (20.0, 0.0)], on=8.0, off=5.0)
    [[(0.0, 0.0), (8.0, 0.0)], [(13.0, 0.0), (20.0, 0.0)]]
    """
    out: list[list[tuple[float, float]]] = []
    phase, drawing = 0.0, True  # distance into the current dash or gap
    current: list[tuple[float, float]] = [pts[0]] if pts else []
    for (x0, y0), (x1, y1) in zip(pts, pts[1:]):
        length = math.hypot(x1 - x0, y1 - y0)
        pos = 0.0
        while pos < length:
            left = (on if drawing else off) - phase
            step = min(left, length - pos)
            pos += step
            phase += step
            p = (x0 + (x1 - x0) * pos / length, y0 + (y1 - y0) * pos / length)
            if drawing:
                current.append(p)
            if phase >= (on if drawing else off) - 1e-9:
                if drawing and len(current) > 1:
                    out.append(current)
                drawing, phase = not drawing, 0.0
                current = [p]
    if drawing and len(current) > 1:
        out.append(current)
    return out


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
    """The estimated trajectory over its map (cells), each pose coloured by its ATE (m, a
    colour bar beside), and the ground truth (already in the map's frame) as a dashed red
    line when given; ``box`` ``(r0, r1, c0, c1)`` crops the view (to the known cells),
    widened to the paths. A PNG drawn with pillow.

    Examples
    --------
    >>> import numpy as np, tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "t.png"
    >>> base = np.full((20, 30, 3), 255, np.uint8)
    >>> trajectory_figure(base, np.array([2., 5.]), np.array([3., 9.]), np.array([.1, .3]), p)
    >>> p.stat().st_size > 0
    True
    """
    from PIL import Image, ImageDraw, ImageFont

    h0, w0 = base_rgb.shape[:2]
    r0, r1, c0, c1 = 0, h0, 0, w0
    if box is not None:
        rr = [r for r in (rows, gt_rows) if r is not None and len(r)]
        cc = [c for c in (cols, gt_cols) if c is not None and len(c)]
        r0 = int(min([box[0], *(np.floor(r.min()) - 2 for r in rr)]))
        r1 = int(max([box[1], *(np.ceil(r.max()) + 3 for r in rr)]))
        c0 = int(min([box[2], *(np.floor(c.min()) - 2 for c in cc)]))
        c1 = int(max([box[3], *(np.ceil(c.max()) + 3 for c in cc)]))
    h, w = max(1, r1 - r0), max(1, c1 - c0)
    view = np.full((h, w, 3), 255, np.uint8)
    a0, a1, b0, b1 = max(r0, 0), min(r1, h0), max(c0, 0), min(c1, w0)
    if a1 > a0 and b1 > b0:
        view[a0 - r0:a1 - r0, b0 - c0:b1 - c0] = base_rgb[a0:a1, b0:b1]
    scale = 700.0 / max(h, w)
    size = (max(1, round(w * scale)), max(1, round(h * scale)))
    img = Image.fromarray(view).resize(
        size, Image.Resampling.NEAREST if scale >= 1 else Image.Resampling.BOX)
    bar = 90
    head = 22 if title else 6
    canvas = Image.new("RGB", (size[0] + bar + 12, size[1] + head + 6), "white")
    canvas.paste(img, (6, head))
    draw = ImageDraw.Draw(canvas)
    font = ImageFont.load_default(size=12)

    def xy(r: np.ndarray, c: np.ndarray) -> list[tuple[float, float]]:
        return [(6 + (cc - c0 + 0.5) * scale, head + (rr - r0 + 0.5) * scale)
                for rr, cc in zip(np.asarray(r, float), np.asarray(c, float))]

    if gt_rows is not None and gt_cols is not None and len(gt_rows) > 1:
        for seg in _dashes(xy(gt_rows, gt_cols), on=8.0, off=5.0):
            draw.line(seg, fill=(214, 39, 40), width=2)
    pts = xy(rows, cols)
    if len(pts) > 1:
        draw.line(pts, fill=(90, 90, 90), width=1)
    e = np.asarray(errors, float)
    lo = float(np.nanmin(e)) if len(e) and np.isfinite(e).any() else 0.0
    hi = float(np.nanmax(e)) if len(e) and np.isfinite(e).any() else 0.0
    colours = viridis((e - lo) / (hi - lo) if hi > lo else np.zeros(len(e)))
    rad = 2.5
    for (x, y), c in zip(pts, colours.tolist()):
        draw.ellipse((x - rad, y - rad, x + rad, y + rad), fill=tuple(c))
    if title:
        draw.text((6 + size[0] / 2, 4), title, fill="black", font=font, anchor="ma")
    # the colour bar: ATE of the pose, low at the bottom
    bx, by, bh = size[0] + 18, head + 10, max(60, int(size[1] * 0.7))
    ramp = viridis(np.linspace(1.0, 0.0, bh))[:, None, :].repeat(14, axis=1)
    canvas.paste(Image.fromarray(ramp), (bx, by))
    draw.rectangle((bx, by, bx + 13, by + bh - 1), outline="black")
    for frac, value in ((0.0, hi), (0.5, (lo + hi) / 2), (1.0, lo)):
        draw.text((bx + 18, by + frac * (bh - 1)), f"{value:.3g}", fill="black", font=font,
                  anchor="lm")
    draw.text((bx, by + bh + 6), "ATE (m)", fill="black", font=font)
    canvas.save(path, optimize=False)


def _metric_values(ok: pd.DataFrame, metric: Metric, sequences: Sequence[str] | None
                   ) -> tuple[Any, list[str]]:
    """The finite values of ``metric`` (column ``_v``) and the panels that have any."""
    import pandas as pd

    values = pd.to_numeric(ok[metric.key], errors="coerce") if metric.key in ok else None
    frame = ok.assign(_v=values)
    frame = frame[np.isfinite(frame["_v"].to_numpy(dtype=float))]
    seqs = [s for s in (sequences or sorted(frame["sequence"].unique()))
            if (frame["sequence"] == s).any()]
    return frame, seqs


def _symlog(v: np.ndarray) -> np.ndarray:
    """matplotlib's symlog transform (base 10, linthresh 1, linscale 1)."""
    v = np.asarray(v, float)
    k = 1.0 / (1.0 - 0.1)
    a = np.abs(v)
    with np.errstate(divide="ignore"):
        out = np.where(a <= 1.0, a * k, k + np.log10(np.maximum(a, 1.0)))
    return np.sign(v) * out


def _log_ticks(lo: float, hi: float, zero: bool) -> list[float]:
    """Tick values of a log (or symlog, ``zero``) axis over ``[lo, hi]``: the powers of
    ten, with 2 and 5 times them when that makes fewer than three."""
    lo = max(lo, 1e-300)
    k0, k1 = math.floor(math.log10(lo)), math.ceil(math.log10(max(hi, lo)))
    for mult in ((1,), (1, 2, 5)):
        ticks = [m * 10.0 ** k for k in range(k0, k1 + 1) for m in mult]
        ticks = [t for t in ticks if lo * (1 - 1e-9) <= t <= hi * (1 + 1e-9)]
        if len(ticks) >= 3:
            break
    if zero:
        ticks = [0.0] + [t for t in ticks if t >= 1.0]
    return ticks


def _metric_svg(ok: pd.DataFrame, metric: Metric, path: Path, *,
                sequences: Sequence[str] | None, colours: dict[str, str] | None,
                seed: int) -> dict[str, int]:
    """:func:`metric_figure` as an SVG file: the same panels, boxes (quartiles, whiskers to
    the farthest run within 1.5 IQR, as matplotlib's) and jittered points."""
    frame, seqs = _metric_values(ok, metric, sequences)
    colours = colours or algorithm_colours(ok["algorithm"].astype(str))
    n = max(1, len(seqs))
    cols = min(n, 3)
    rows = int(math.ceil(n / cols))
    pw, ph = 420, 330
    width, height = pw * cols, ph * rows + 30
    rng = np.random.default_rng(seed)
    counts: dict[str, int] = {}
    title = metric_title(metric)
    body = [f"<text x=\"{width / 2:.0f}\" y=\"20\" text-anchor=\"middle\" "
            f"font-size=\"13\">{_e(title)}</text>"]
    for i, seq in enumerate(seqs):
        ox, oy = pw * (i % cols), 30 + ph * (i // cols)
        sub = frame[frame["sequence"] == seq]
        algs = sorted(sub["algorithm"].astype(str).unique())
        data = [sub.loc[sub["algorithm"].astype(str) == a, "_v"].to_numpy(float)
                for a in algs]
        allv = np.concatenate(data) if data else np.empty(0)
        log = metric.log and len(allv) and allv.min() > 0
        symlog = metric.log and not log
        tf: Callable[[Any], np.ndarray] = (
            np.log10 if log else _symlog if symlog else (lambda v: np.asarray(v, float)))
        lo, hi = (float(allv.min()), float(allv.max())) if len(allv) else (0.0, 1.0)
        if symlog:
            lo = 0.0
        t0, t1 = float(tf(lo)), float(tf(hi))
        pad = 0.05 * (t1 - t0) if t1 > t0 else 0.5
        ylim = (t0 if symlog else t0 - pad, t1 + pad)
        ax = _Axes((ox + 70, oy + 26, pw - 90, ph - 110), (-0.6, len(algs) - 0.4), ylim)
        vlo = lo if symlog else (10 ** ylim[0] if log else ylim[0])
        vhi = 10 ** ylim[1] if log else (hi * 1.1 if symlog else ylim[1])
        ticks = (_log_ticks(vlo, vhi, symlog) if metric.log
                 else nice_ticks(ylim[0], ylim[1], 5))
        if metric.log and len(ticks) < 3:  # less than a decade: round values, log-placed
            ticks = [t for t in nice_ticks(vlo, vhi, 4) if t > 0 or (symlog and t == 0)]
        ticks = [t for t in ticks if ylim[0] - 1e-9 <= float(tf(t)) <= ylim[1] + 1e-9]
        right, bottom = ax.left + ax.width, ax.top + ax.height
        for t in ticks:
            y = float(ax.py(tf(t)))
            body.append(f"<line x1=\"{ax.left:.1f}\" y1=\"{y:.1f}\" x2=\"{right:.1f}\" "
                        f"y2=\"{y:.1f}\" stroke=\"#000\" stroke-opacity=\"0.12\"/>"
                        f"<text x=\"{ax.left - 5:.1f}\" y=\"{y + 4:.1f}\" "
                        f"text-anchor=\"end\">{_e(f'{t:g}')}</text>")
        body.append(f"<rect x=\"{ax.left:.1f}\" y=\"{ax.top:.1f}\" width=\"{ax.width:.1f}\" "
                    f"height=\"{ax.height:.1f}\" fill=\"none\" stroke=\"#000\" "
                    "stroke-width=\"0.8\"/>"
                    f"<text x=\"{ax.left + ax.width / 2:.1f}\" y=\"{ax.top - 8:.1f}\" "
                    f"text-anchor=\"middle\" font-size=\"12\">{_e(seq)}</text>")
        if i % cols == 0:
            cy = ax.top + ax.height / 2
            label = metric.heading + (" (log)" if metric.log else "")
            body.append(f"<text x=\"{ox + 16}\" y=\"{cy:.1f}\" text-anchor=\"middle\" "
                        f"transform=\"rotate(-90 {ox + 16} {cy:.1f})\">{_e(label)}</text>")
        total = 0
        for j, (a, v) in enumerate(zip(algs, data)):
            x = float(ax.px(j))
            body.append(f"<text transform=\"translate({x + 4:.1f} {bottom + 12:.1f}) "
                        f"rotate(-30)\" text-anchor=\"end\" font-size=\"10\">{_e(a)}</text>")
            if len(v):
                q1, med, q3 = np.percentile(v, [25, 50, 75])
                iqr = q3 - q1
                wlo = float(v[v >= q1 - 1.5 * iqr].min())
                whi = float(v[v <= q3 + 1.5 * iqr].max())
                yq1, ymed, yq3, ylo, yhi = (float(ax.py(tf(u))) for u in (q1, med, q3, wlo, whi))
                half = 0.275 * ax.width / (ax.x1 - ax.x0)
                body.append(
                    f"<g stroke=\"#555\" fill=\"none\"><rect x=\"{x - half:.1f}\" "
                    f"y=\"{yq3:.1f}\" width=\"{2 * half:.1f}\" height=\"{yq1 - yq3:.1f}\"/>"
                    f"<path d=\"M{x:.1f} {yq3:.1f}V{yhi:.1f}M{x:.1f} {yq1:.1f}V{ylo:.1f}"
                    f"M{x - half / 2:.1f} {yhi:.1f}h{half:.1f}M{x - half / 2:.1f} {ylo:.1f}"
                    f"h{half:.1f}\"/><path d=\"M{x - half:.1f} {ymed:.1f}h{2 * half:.1f}\" "
                    "stroke=\"#000\"/></g>")
            jitter = j + rng.uniform(-0.18, 0.18, size=len(v))
            dots = "".join(f"<circle cx=\"{px:.1f}\" cy=\"{py:.1f}\" r=\"3\"/>"
                           for px, py in zip(ax.px(jitter), ax.py(tf(v))))
            body.append(f"<g fill=\"{colours.get(a, '#1f77b4')}\" stroke=\"#000\" "
                        f"stroke-width=\"0.5\">{dots}</g>")
            total += len(v)
        counts[str(seq)] = total
    path.write_text(_svg(width, height, "".join(body), title), encoding="utf-8")
    return counts
