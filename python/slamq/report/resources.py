"""The report's "Resources and parameters" page: scores against cost and against the swept
parameters, mean +- std over iterations.

From a frame with one row per run (``slamq run``'s ``scores.csv``: ``algorithm``,
``program``, ``sequence``, ``wall_s``, ``cpu_s``, ``peak_rss_mb``, ``param.NAME`` and the
metric columns), :func:`resources_page` writes ``resources.html`` beside the report's
``index.html`` (and links it from there):

- ATE RMSE and ground-truth-map F1 (those present) against CPU time and against peak
  memory: a point per algorithm[variant] and sequence at the mean over iterations, with
  std bars on both axes;
- for every program with a swept parameter (``params: {particles: [5, 20, 50, 100]}``):
  ATE, F1 (when present), CPU time, wall time and peak memory against the parameter's
  value, one line per sequence (and per value of the other axes), mean +- std.
"""

from __future__ import annotations

import html
import re
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from slamq.columns import shown  # noqa: E402

__all__ = ["resources_page", "QUALITY", "COSTS"]

#: Quality columns plotted (when present with a value): column -> heading (the columns
#: shown at ``resources``, :data:`slamq.columns.COLUMNS`).
QUALITY = {c.name: c.heading for c in shown("resources")}
#: Cost columns: column -> label.
COSTS = {"cpu_s": "CPU time [s]", "wall_s": "wall time [s]", "peak_rss_mb": "peak RSS [MiB]"}
_DPI = 100
_TAB10 = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2",
          "#7f7f7f", "#bcbd22", "#17becf")


def _e(x: Any) -> str:
    return html.escape(str(x), quote=True)


def _present(frame: pd.DataFrame, cols: dict[str, str]) -> dict[str, str]:
    return {c: label for c, label in cols.items() if c in frame
            and np.isfinite(pd.to_numeric(frame[c], errors="coerce")).any()}


def _stats(frame: pd.DataFrame, by: list[str], cols: list[str]) -> pd.DataFrame:
    num = frame[by + cols].copy()
    for c in cols:
        num[c] = pd.to_numeric(num[c], errors="coerce")
    g = num.groupby(by, dropna=False, sort=True)[cols].agg(["mean", "std", "count"])
    g.columns = [f"{c}_{s}" for c, s in g.columns]
    return g.reset_index()


def _quality_vs_cost(frame: pd.DataFrame, quality: dict[str, str], path: Path) -> None:
    costs = {"cpu_s": COSTS["cpu_s"], "peak_rss_mb": COSTS["peak_rss_mb"]}
    st = _stats(frame, ["algorithm", "sequence"], list(quality) + list(costs))
    fig, axes = plt.subplots(len(quality), 2, figsize=(10, 3.6 * len(quality)), squeeze=False)
    algos = sorted(st["algorithm"].astype(str).unique())
    colour = {a: _TAB10[i % len(_TAB10)] for i, a in enumerate(algos)}
    seqs = sorted(st["sequence"].astype(str).unique())
    marker = {s: "os^Dv<>p*h"[i % 10] for i, s in enumerate(seqs)}
    for r, (q, qlabel) in enumerate(quality.items()):
        for c, (k, klabel) in enumerate(costs.items()):
            ax = axes[r][c]
            for _, row in st.iterrows():
                if not np.isfinite(row[f"{q}_mean"]) or not np.isfinite(row[f"{k}_mean"]):
                    continue
                ax.errorbar(row[f"{k}_mean"], row[f"{q}_mean"],
                            xerr=np.nan_to_num(row[f"{k}_std"]),
                            yerr=np.nan_to_num(row[f"{q}_std"]), fmt=marker[str(row["sequence"])],
                            color=colour[str(row["algorithm"])], capsize=3,
                            label=f"{row['algorithm']} / {row['sequence']}")
            ax.set_xlabel(klabel)
            ax.set_ylabel(qlabel)
            ax.grid(alpha=0.3)
    handles, labels = axes[0][0].get_legend_handles_labels()
    if handles:
        fig.legend(handles, labels, loc="lower center", ncol=min(3, len(labels)), fontsize=8,
                   frameon=False)
    fig.tight_layout(rect=(0, 0.06 + 0.02 * (len(handles) // 3), 1, 1))
    with plt.rc_context({"text.parse_math": False}):
        fig.savefig(path, dpi=_DPI)
    plt.close(fig)


def _mean_std(mean: float, std: float, n: float) -> str:
    """``mean ± std`` over iterations; the value alone for one iteration, "–" for none.

    Examples
    --------
    >>> _mean_std(1.234, 0.05, 2), _mean_std(1.234, float("nan"), 1), _mean_std(float("nan"), 0, 0)
    ('1.234 ± 0.05', '1.234', '–')
    """
    if not np.isfinite(mean):
        return "–"
    if n <= 1 or not np.isfinite(std):
        return f"{mean:.4g}"
    return f"{mean:.4g} ± {std:.2g}"


def _numeric(values: pd.Series) -> bool:
    return bool(pd.to_numeric(values, errors="coerce").notna().all())


def _sweep(frame: pd.DataFrame, program: str, axis: str, others: list[str],
           panels: dict[str, str], path: Path) -> None:
    sub = frame[frame["program"] == program].copy()
    x_numeric = _numeric(sub[axis])
    sub["_x"] = pd.to_numeric(sub[axis], errors="coerce") if x_numeric else sub[axis].astype(str)
    by = ["sequence", *others]
    st = _stats(sub, [*by, "_x"], list(panels))
    fig, axes = plt.subplots(1, len(panels), figsize=(3.4 * len(panels), 3.3), squeeze=False)
    groups = list(st.groupby(by, dropna=False, sort=True))
    for gi, (key, g) in enumerate(groups):
        key = key if isinstance(key, tuple) else (key,)
        label = ", ".join(f"{n}={v}" if n != "sequence" else str(v) for n, v in zip(by, key))
        g = g.sort_values("_x")
        xs = g["_x"].to_numpy() if x_numeric else np.arange(len(g))
        for ax, (col, clabel) in zip(axes[0], panels.items()):
            ax.errorbar(xs, g[f"{col}_mean"], yerr=np.nan_to_num(g[f"{col}_std"]),
                        marker="o", capsize=3, color=_TAB10[gi % len(_TAB10)], label=label)
            ax.set_ylabel(clabel)
            ax.set_xlabel(axis.removeprefix("param."))
            if not x_numeric:
                ax.set_xticks(xs, g["_x"].tolist())
            ax.grid(alpha=0.3)
    if x_numeric and len(sub["_x"].unique()) > 2 and \
            sub["_x"].min() > 0 and sub["_x"].max() / sub["_x"].min() >= 10:
        from matplotlib.ticker import FixedLocator, NullLocator

        values = sorted(sub["_x"].unique())
        for ax in axes[0]:
            ax.set_xscale("log")
            ax.xaxis.set_major_locator(FixedLocator(values))
            ax.xaxis.set_minor_locator(NullLocator())
            ax.set_xticklabels([f"{v:g}" for v in values])
    axes[0][0].legend(fontsize=7, frameon=False)
    fig.suptitle(f"{program}: mean ± std over iterations", fontsize=10)
    fig.tight_layout()
    with plt.rc_context({"text.parse_math": False}):
        fig.savefig(path, dpi=_DPI)
    plt.close(fig)


def resources_page(frame: pd.DataFrame, out_dir: Any, *, link_from_index: bool = True,
                   config: str | None = None) -> Path | None:
    """Write ``resources.html`` (and its figures under ``img/``) for a frame of runs.

    With ``link_from_index``, the report's ``index.html`` beside it gains a paragraph on the
    run (:func:`run_summary`: ``config``, the path of the run's config file, its commands,
    time and winners) and a link to the page.

    Returns the page, or None when no run has resource figures.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> f = pd.DataFrame({"algorithm": [f"pf[particles={p}]" for p in (5, 5, 20, 20)],
    ...     "program": "pf", "sequence": "s", "run": ["1", "2", "1", "2"],
    ...     "param.particles": [5, 5, 20, 20], "wall_s": [1.0, 1.2, 3.0, 3.1],
    ...     "cpu_s": [0.9, 1.0, 2.9, 3.0], "peak_rss_mb": [50, 52, 80, 81],
    ...     "ate_rmse": [0.30, 0.34, 0.12, 0.10]})
    >>> page = resources_page(f, d)
    >>> page.name, sorted(p.name for p in (d / "img").iterdir())
    ('resources.html', ['resources_quality_cost.png', 'resources_sweep_pf_particles.png'])
    """
    out = Path(out_dir)
    if frame is None or frame.empty or not _present(frame, COSTS):
        return None
    (out / "img").mkdir(parents=True, exist_ok=True)
    quality = _present(frame, QUALITY)
    sections = []
    if quality:
        png = "img/resources_quality_cost.png"
        _quality_vs_cost(frame, quality, out / png)
        sections.append(
            "<h2>Quality against cost</h2><p>" + " and ".join(quality.values()) + " against CPU "
            "time and peak memory: one point per algorithm[variant] and sequence at the mean "
            f"over iterations, bars one std.</p><img src=\"{png}\" alt=\"quality vs cost\">")
    axes = [c for c in frame.columns if c.startswith("param.")]
    panels = {**quality, **_present(frame, COSTS)}
    for program in sorted(frame["program"].dropna().astype(str).unique()) \
            if "program" in frame else []:
        sub = frame[frame["program"] == program]
        swept = [a for a in axes if sub[a].notna().any() and sub[a].nunique() > 1]
        for axis in swept:
            slug = re.sub(r"[^A-Za-z0-9_.-]+", "_", f"{program}_{axis[6:]}")
            png = f"img/resources_sweep_{slug}.png"
            _sweep(frame, program, axis, [a for a in swept if a != axis], panels, out / png)
            sections.append(
                f"<h2>{_e(program)}: {_e(axis[6:])}</h2><p>" + ", ".join(panels.values())
                + f" against {_e(axis[6:])}, mean ± std over iterations.</p>"
                f"<img src=\"{png}\" alt=\"{_e(program)} {_e(axis[6:])}\">")
    table = _stats(frame, ["algorithm", "sequence"], list(panels))
    rows = "".join(
        "<tr>" + f"<td>{_e(r['algorithm'])}</td><td>{_e(r['sequence'])}</td>"
        + "".join(f"<td>{_mean_std(r[f'{c}_mean'], r[f'{c}_std'], r[f'{c}_count'])}</td>"
                  for c in panels) + "</tr>"
        for _, r in table.iterrows())
    head = "".join(f"<th>{_e(v)}</th>" for v in panels.values())
    body = (
        "<p><a href=\"index.html\">&larr; report</a></p><h1>Resources and parameters</h1>"
        "<p>Wall time, CPU time (the program and the descendants it waited for) and peak "
        "resident memory of every run (its <code>run.json</code>; per run in "
        "<code>scores.csv</code>).</p>"
        f"<div class=\"scroll\"><table><tr><th>algorithm</th><th>sequence</th>{head}</tr>"
        f"{rows}</table></div>"
        + "".join(sections))
    page = out / "resources.html"
    page.write_text(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
        "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">"
        "<title>Resources and parameters</title><style>body{font:15px/1.45 system-ui,"
        "sans-serif;max-width:1180px;margin:0 auto;padding:18px 22px 60px;color:#222}"
        "img{max-width:100%;height:auto}.scroll{overflow-x:auto}"
        "table{border-collapse:collapse}td,th{border:1px solid #ddd;"
        "padding:3px 8px;text-align:right}td:first-child,td:nth-child(2){text-align:left}"
        f"</style></head><body>{body}</body></html>\n", encoding="utf-8")
    index = out / "index.html"
    if link_from_index and index.exists():
        text = index.read_text(encoding="utf-8")
        link = ("<section class=\"slamq-resources\" id=\"run\">"
                + run_summary(frame, out, config=config) +
                "<p><a href=\"resources.html\">Resources and parameters</a>: quality against "
                "CPU time and memory, and against each swept parameter</p></section>")
        if "slamq-resources" not in text:
            # under the title and its line of counts, else at the top of the page
            h1 = text.find("<h1")
            at = text.find("</p>", h1) + len("</p>") if h1 >= 0 and "</p>" in text[h1:] \
                else text.find("<main>") + len("<main>") if "<main>" in text \
                else text.find("<body>") + len("<body>")
            index.write_text(text[:at] + link + text[at:], encoding="utf-8")
    return page


def run_summary(frame: pd.DataFrame, out_dir: Any, *, config: str | None = None) -> str:
    """What a ``slamq run`` report says first: the config file, the command of each
    algorithm (from a ``run.json`` of its runs), how many runs and how long they took, and
    the best algorithm of each sequence (the report's ``verdict.json`` in ``out_dir``).

    Examples
    --------
    >>> import tempfile
    >>> f = pd.DataFrame({"algorithm": ["a", "b"], "sequence": "s", "wall_s": [1.0, 2.5]})
    >>> print(run_summary(f, tempfile.mkdtemp(), config="run.yaml"))
    ... # doctest: +NORMALIZE_WHITESPACE
    <h2>The run</h2><p>Config <code>run.yaml</code>: 2 runs of 2 algorithms on 1 sequence,
    3.5 s of wall time in all (the longest run 2.5 s).</p>
    """
    import json

    from slamq.report.detail import run_info

    n_alg = frame["algorithm"].nunique() if "algorithm" in frame else 0
    n_seq = frame["sequence"].nunique() if "sequence" in frame else 0
    wall = pd.to_numeric(frame.get("wall_s", pd.Series(dtype=float)), errors="coerce").dropna()
    head = f"Config <code>{_e(config)}</code>: " if config else ""
    text = (f"{head}{len(frame)} run{'s' if len(frame) != 1 else ''} of {n_alg} "
            f"algorithm{'s' if n_alg != 1 else ''} on {n_seq} sequence"
            f"{'s' if n_seq != 1 else ''}")
    if len(wall):
        text += (f", {wall.sum():.3g} s of wall time in all (the longest run "
                 f"{wall.max():.3g} s)")
    parts = [f"<h2>The run</h2><p>{text}.</p>"]
    try:
        verdicts = json.loads((Path(out_dir) / "verdict.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        verdicts = []
    best = [f"{_e(v['sequence'])}: <b>{_e(v['best'])}</b>" if v.get("best") else
            f"{_e(v['sequence'])}: none named" for v in verdicts if isinstance(v, dict)]
    if best:
        parts.append(f"<p class=\"run-winner\">Best: {'; '.join(best)} (the verdict below)."
                     "</p>")
    commands = {}
    for _, r in frame.iterrows():
        alg = str(r.get("algorithm"))
        if alg in commands:
            continue
        info = run_info(r.to_dict())
        cmd = info.get("command") if info else None
        if isinstance(cmd, list):
            commands[alg] = " ".join(str(c) for c in cmd)
        elif isinstance(cmd, dict):
            commands[alg] = "; ".join(f"{k}: {' '.join(map(str, v)) if isinstance(v, list) else v}"
                                      for k, v in cmd.items())
    if commands:
        parts.append("<details class=\"run-commands\" open><summary>Commands</summary><ul>"
                     + "".join(f"<li>{_e(a)}: <code>{_e(c)}</code></li>"
                               for a, c in sorted(commands.items()))
                     + "</ul></details>")
    return "".join(parts)
