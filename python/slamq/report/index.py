"""The report's index page: the verdict in one sentence per sequence, which numbers to
trust, how to read the page, then per sequence its ranking table in the verdict's order, a
gallery of each algorithm's runs at both ends of the deciding column, and every run; the
plots; the failed maps."""

from __future__ import annotations

import datetime as _dt
import math
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from slamq.columns import COLUMNS
from slamq.report.formatting import format_mean_std, format_value
from slamq.report.markup import MapPage, metric_title
from slamq.report.markup import esc as _e
from slamq.report.markup import slug as _slug
from slamq.results.columns import GROUND_TRUTH_ALGORITHMS
from slamq.verdict.ranking import CANONICAL, METRICS, SequenceRanking
from slamq.verdict.records import usable
from slamq.verdict.rule import basis_name, rule_summary, verdict_sentence

__all__ = ["best_worst", "comparability_notes", "index_body", "mixed_settings", "plots",
           "run_known_share", "scroll"]

_WINNER = ' class="winner"'

_BEST = " best"

_METRIC_HELP = COLUMNS


def scroll(table: str) -> str:
    """``table`` in a box that scrolls sideways on a narrow screen (the page itself never
    does).

    Examples
    --------
    >>> scroll("<table></table>")
    '<div class="scroll"><table></table></div>'
    """
    return f"<div class=\"scroll\">{table}</div>"


def comparability_notes(messages: Iterable[str], verdict: dict[str, Any]) -> list[str]:
    """The comparability warnings of a sequence (:func:`slamq.results.summary.
    comparability_warnings`, without their ``"sequence: "``) as the page prints them above
    the verdict's table: where corners only break the tie among the maps the others confirm
    equally (the verdict's basis ``["agreement", "corners"]``), a warning that the corners
    of all maps are not comparable says so, so that it does not deny the table.

    Examples
    --------
    >>> msg = ("s: the maps are turned differently (wall angles 0.1, 4.0 deg modulo 90): "
    ...        "their corners are not comparable; compare corners_canonical")
    >>> comparability_notes([msg], {"basis": ["ate_rmse"]})[0][:31]
    'the maps are turned differently'
    >>> print(comparability_notes([msg], {"basis": ["agreement", "corners"]})[0])
    ... # doctest: +NORMALIZE_WHITESPACE
    the maps are turned differently (wall angles 0.1, 4.0 deg modulo 90): the corners of
    all the maps are not comparable; the verdict compares corners only among the maps the
    others confirm equally, which share one grid and orientation, to break their tie
    """
    basis = list(verdict.get("basis") or [])
    tie_corners = basis[:1] == ["agreement"] and "corners" in basis[1:]
    out = []
    for msg in messages:
        text = msg.split(": ", 1)[-1]
        if tie_corners and "their corners are not comparable" in text:
            text = text.split("their corners are not comparable", 1)[0] + (
                "the corners of all the maps are not comparable; the verdict compares "
                "corners only among the maps the others confirm equally, which share one "
                "grid and orientation, to break their tie")
        out.append(text)
    return out


def mixed_settings(frame: pd.DataFrame) -> str:
    """A warning paragraph when the records were made with different settings, else "".

    Examples
    --------
    >>> import pandas as pd
    >>> mixed_settings(pd.DataFrame({"corners": [1, 2]}))
    ''
    """
    if "config" not in frame:
        return ""
    from slamq.results.columns import settings_difference

    mixed = settings_difference(frame["config"])
    if not mixed:
        return ""
    return (f"<p class=\"warn\" id=\"mixed-settings\">These results were computed with "
            f"different settings ({_e(mixed)}): the tables and plots mix them. Evaluate every "
            "map again with one setting, or write the batch to another results file.</p>")


#: Columns a gallery orders an algorithm's runs by: the verdict's basis first, then these.
_RUN_ORDER = ("ate_rmse", "rel_trans_abs_mean", "gt_f1", "corners_canonical", "corners")


def _run_key(group: pd.DataFrame, basis: Iterable[str] = ()) -> str | None:
    """The column the runs of ``group`` are ordered by: the verdict's basis when the runs
    have it, else the first of :data:`_RUN_ORDER` they have."""
    for key in [*basis, *_RUN_ORDER]:
        if key in group and pd.to_numeric(group[key], errors="coerce").notna().any():
            return key
    return None


def best_worst(group: pd.DataFrame, basis: Iterable[str] = ()) -> list[int]:
    """Indices of the best and the worst run by the verdict's basis column (one index when
    they are the same run); runs without the figure come last.

    Examples
    --------
    >>> import pandas as pd
    >>> runs = pd.DataFrame({"run": [0, 1, 2], "corners": [9, 3, float("nan")]})
    >>> best_worst(runs, ["corners"])
    [1, 2]
    """
    key = _run_key(group, basis)
    if key is None:
        order = sorted(group.index, key=lambda i: str(group.loc[i, "run"]))
    else:
        higher = _METRIC_HELP[key].higher if key in _METRIC_HELP else False
        v = pd.to_numeric(group[key], errors="coerce")
        order = sorted(group.index, key=lambda i: (
            math.isnan(v[i]), (-v[i] if higher else v[i]) if not math.isnan(v[i]) else 0.0,
            str(group.loc[i, "run"])))
    return [order[0]] if len(order) == 1 else [order[0], order[-1]]


def plots(ok: pd.DataFrame, out: Path, sequences: list[str],
          cache: dict[str, str] | None = None) -> list[tuple[str, str]]:
    """One figure per ranked metric that has values (every run a point, one panel per
    sequence, SVG), reference maps left out; returns ``(metric key, path)`` pairs. With
    ``cache`` (``{path: stamp of its inputs}``, updated), a figure whose inputs did not
    change is kept (:func:`slamq.report.cache.figure_digest`).

    Examples
    --------
    >>> import pandas as pd, tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()); (out / "img").mkdir()
    >>> ok = pd.DataFrame({"sequence": "s", "algorithm": ["a", "b"], "run": 0,
    ...                    "corners": [3, 5]})
    >>> plots(ok, out, ["s"])
    [('corners', 'img/plot_corners.svg')]
    """
    from slamq.report.plots import algorithm_colours, metric_figure

    # a reference (ground-truth) map is shown beside the ranking, never plotted as an
    # algorithm among the others
    ok = ok[~ok["algorithm"].astype(str).str.lower().isin(GROUND_TRUTH_ALGORITHMS)]
    if ok.empty:
        return []
    colours = algorithm_colours(ok["algorithm"].astype(str))
    made = []
    for m in METRICS:
        if m.key not in ok or not np.isfinite(pd.to_numeric(ok[m.key], errors="coerce")).any():
            continue
        png = f"img/plot_{m.key}.svg"
        if cache is not None:
            from slamq.report.cache import figure_digest

            digest = figure_digest(ok, m, sequences, colours)
            kept = cache.get(png) == digest and (out / png).is_file()
            cache[png] = digest
            if kept:
                made.append((m.key, png))
                continue
        metric_figure(ok, m, out / png, sequences=sequences, colours=colours)
        made.append((m.key, png))
    return made


def index_body(
    title: str,
    frame: pd.DataFrame,
    ok: pd.DataFrame,
    failed: pd.DataFrame,
    summary: pd.DataFrame,
    sequences: list[str],
    rankings: dict[str, SequenceRanking],
    verdicts: dict[str, dict[str, Any]],
    gallery: dict[tuple[str, str], list[int]],
    pages: dict[int, MapPage],
    plots: list[tuple[str, str]],
    warning: str = "",
) -> str:
    """The body of ``index.html``: the verdict's sentences, which numbers to trust, how to
    read the page, a section per sequence (its ranking table, gallery and runs), the plots
    (``plots``: from :func:`plots`) and the failed maps; ``warning`` (as from
    :func:`mixed_settings`) under the heading. Everything comes from the caller: the
    records, :class:`slamq.verdict.judge.Judgement`'s summary, rankings and verdicts, and
    the detail pages drawn.

    Examples
    --------
    >>> import pandas as pd
    >>> from slamq.verdict.judge import judge
    >>> ok = pd.DataFrame({"sequence": "s", "algorithm": ["a", "b"], "run": 0,
    ...                    "map": "", "ate_rmse": [0.1, 0.2], "corners": [3, 5]})
    >>> j = judge(ok)
    >>> body = index_body("t", ok, ok, ok.iloc[:0], j.summary, j.sequences, j.rankings,
    ...                   j.by_sequence, {}, {}, [])
    >>> "<b>a</b> is best by ATE RMSE" in body
    True
    """
    from slamq.version import __version__

    n_alg = ok["algorithm"].nunique() if len(ok) else 0
    parts = [
        f"<h1>{_e(title)}</h1>",
        f"<p class=\"sub\">{len(frame)} maps: {len(ok)} evaluated, {len(failed)} failed; "
        f"{len(sequences)} sequences, {n_alg} algorithms. Generated "
        f"{_dt.datetime.now().strftime('%Y-%m-%d %H:%M')} by slamq {__version__}.</p>",
        warning,
        "<section class=\"verdict\" id=\"verdict\"><b>In one sentence per sequence</b> "
        "(also in <a href=\"verdict.json\">verdict.json</a>; the tables below follow it and "
        "show every metric for reference)<ul>",
    ]
    for s in sequences:
        v = verdicts[s]
        sent = _e(verdict_sentence(v))
        head = _e(f"{s}:")
        if sent.startswith(head):
            sent = sent[len(head):]
        if v["best"]:
            sent = sent.replace(_e(v["best"]), f"<b>{_e(v['best'])}</b>", 1)
        notes = "".join(f"<br><small>{_e(w)}</small>" for w in v["warnings"])
        parts.append(f"<li><a href=\"#seq-{_slug(s)}\">{_e(s)}</a>:{sent}{notes}</li>")
    if not sequences:
        parts.append("<li>No map was evaluated successfully.</li>")
    parts.append("</ul></section>")
    parts.append(_validity_section(ok))
    parts.append(_how_to_read())
    for s in sequences:
        parts.append(_sequence_section(s, ok, summary, rankings[s], gallery, pages))
    if plots:
        parts.append("<h2 id=\"plots\">Plots</h2><p>Every run is a point; boxes show the "
                     "spread per algorithm; one panel per sequence. Each figure's title says "
                     "which way is better for its metric.</p><div class=\"plots\">")
        for key, png in plots:
            m = _METRIC_HELP[key]
            parts.append(f"<figure data-metric=\"{_e(key)}\"><img src=\"{png}\" "
                         f"alt=\"{_e(m.label)} per run\"><figcaption>{_e(metric_title(m))}"
                         "</figcaption></figure>")
        parts.append("</div>")
    if len(failed):
        rows = "".join(f"<tr><td>{_e(r['map'])}</td><td>{_e(r['error'])}</td></tr>"
                       for _, r in failed.iterrows())
        parts.append(f"<h2 id=\"failed\">Failed maps ({len(failed)})</h2>"
                     + scroll(f"<table><tr><th>map</th><th>error</th></tr>{rows}</table>"))
    parts.append(
        "<footer>Metrics: Filatov, Filatov, Krinkin, Chen, Molodan, <i>2D SLAM Quality "
        "Evaluation Methods</i>, arXiv:1708.02354, as pinned down by slamq's spec (docs/spec.md). "
        "Means and sample standard deviations (n&minus;1) over runs; "
        "<a href=\"summary.csv\">summary.csv</a> holds them unrounded; the tables as "
        "<a href=\"tables.md\">Markdown</a> and <a href=\"tables.tex\">LaTeX</a>.</footer>")
    return "".join(parts)


def _validity_section(ok: pd.DataFrame) -> str:
    """How well each no-reference metric agreed with this report's own ground truth
    (slamq.results.validity, pooled over its sequences), and the figures measured once on
    slam_comparison_tools and the synthetic study (shipped with slamq)."""
    from slamq.results.validity import SHIPPED_CONCORDANCE, validate

    shipped = "".join(
        f"<tr><td>{_e(metric)}</td>" + "".join(f"<td>{v:.2f}</td>" for v in values) + "</tr>"
        for metric, values in SHIPPED_CONCORDANCE.items())
    parts = [
        "<section id=\"validity\"><h2>Which numbers to trust</h2>"
        "<p>Pairwise concordance of each map metric (0.5 = chance, 1 = always the same "
        "order), measured once: with the trajectory error on slam_comparison_tools (3 "
        "worlds x 5 algorithms), and with the damage in slamq's synthetic study (slamq.synth;"
        " for rotation the ideal is 0.5, no change). The verdict follows the rule of "
        "docs/spec.md section 9: " + _e(rule_summary()) + "; the other metrics never decide "
        "(how far it can be trusted: docs/validity.md, \"The verdict without ground "
        "truth\").</p>"
        + scroll("<table class=\"validity shipped\"><tr><th>metric</th><th>vs ATE</th>"
                 "<th>drift</th><th>wall doubling</th><th>rotation</th><th>specks</th></tr>"
                 f"{shipped}</table>")]
    table = validate(ok)        # as `slamq validate`: the same shuffles, the same p
    pooled = table[table["sequence"] == "(pooled)"]
    sizes: dict[tuple[str, str], list[int]] = {}  # (metric, truth): maps per sequence
    for r in table.itertuples():
        if r.sequence != "(pooled)":
            sizes.setdefault((r.metric, r.truth), []).append(int(r.n))
    keep = [_can_be_significant(sizes.get((r.metric, r.truth), [])) for r in pooled.itertuples()]
    shown = pooled[keep] if len(pooled) else pooled
    if len(shown):
        rows = "".join(
            f"<tr><td>{_e(r.metric)}</td><td>{_e(r.truth)}</td><td>{r.n}</td>"
            f"<td>{r.spearman:+.2f}</td><td>{r.concordance:.2f}</td>"
            f"<td>{'–' if r.p_value != r.p_value else f'{r.p_value:.3f}'}</td></tr>"
            for r in shown.itertuples())
        parts.append(
            "<h3>Measured on these results</h3>"
            "<p>How well each map metric orders the maps as the ground truth does, pooled "
            "over the sequences with ground truth (Spearman: rank correlation, +1 = the "
            "same order; concordance: share of map pairs in the same order, 0.5 = chance; p: "
            "permutation test; the figures of <code>slamq validate</code> on the results "
            "file).</p>"
            + scroll("<table class=\"validity\"><tr><th>metric</th><th>ground truth</th>"
                     "<th>maps</th><th>Spearman</th><th>concordance</th><th>p</th></tr>"
                     + rows + "</table>"))
    left = sorted({str(r.truth) for r, k in zip(pooled.itertuples(), keep) if not k})
    if left:
        n = int(pooled["n"].max())
        parts.append(
            "<p class=\"too-few\">Not measured on these results against "
            f"{_e(', '.join(left))}: too few maps ({n} with ground truth) for a permutation "
            "test to reach p &lt; 0.05.</p>")
    return "".join(parts) + "</section>"


#: A pooled row of the validity table is shown when its permutation test can reach this p.
_SIGNIFICANT = 0.05


def _can_be_significant(sizes: list[int]) -> bool:
    """Whether the permutation test of a ``(metric, truth)`` pair whose sequences have
    ``sizes`` maps can reach p < 0.05 at all: the shuffles within the sequences yield
    ``prod(n_i!)`` orders, and the observed one is at best one of the two most extreme
    (two-sided).

    Examples
    --------
    >>> _can_be_significant([4]), _can_be_significant([5]), _can_be_significant([3, 4])
    (False, True, True)
    """
    orders = math.prod(math.factorial(n) for n in sizes)
    return 2 / max(orders, 1) < _SIGNIFICANT


def _how_to_read() -> str:
    items = "".join(
        f"<li><b>{_e(m.heading)}</b>: {m.direction} &mdash; {_e(m.why)}.</li>" for m in METRICS)
    return (
        "<details id=\"how\"><summary>How to read this page</summary><ul>" + items +
        "<li><b>Ranking</b>: each table is in the verdict's order (verdict.json; the rule of "
        "docs/spec.md section 9, in short: " + _e(rule_summary()) + "); the column that "
        "decides is marked <i>decides</i>. The other columns are shown for reference and "
        "decide nothing. &#9733; marks the best value per column. Algorithms without the "
        "deciding figure are listed last, unranked (&ndash;).</li><li>The map metrics "
        "compare maps of one sequence with similar coverage (paper III.A, III.B): a map that "
        "covers much less ground looks good on all three. Such maps are flagged.</li>"
        "<li>Gallery: each algorithm's runs at both ends of the deciding column, drawn plain."
        " Click a map for its detail page, where the counted corners, the counted enclosed "
        "areas, the comparison with a ground-truth map, any defects and (without ground "
        "truth) the walls the other maps have that the map lacks are layers to switch "
        "on and off.</li></ul></details>")


def _sequence_section(
    seq: str,
    ok: pd.DataFrame,
    summary: pd.DataFrame,
    ranking: SequenceRanking,
    gallery: dict[tuple[str, str], list[int]],
    pages: dict[int, MapPage],
) -> str:
    block = summary.xs(seq, level="sequence")
    metrics = ranking.metrics
    basis = ranking.verdict.get("basis", [])
    decides = basis[0] if basis else None
    head = "".join(
        f"<th class=\"basis\">{_e(m.heading)}<br><small>decides</small></th>"
        if m.key == decides else f"<th>{_e(m.heading)}</th>" for m in metrics)
    head += "<th title=\"mean known area relative to the most complete map of the sequence\">"
    head += "known area</th>"
    rows = []
    place = 0
    for alg in ranking.order + ranking.ground_truths:
        row = block.loc[alg]
        reference = alg in ranking.ground_truths
        ranked = alg in ranking.ranked
        place += ranked
        cells = []
        for m in metrics:
            mean, std, n = row[f"{m.key}_mean"], row[f"{m.key}_std"], int(row[f"{m.key}_n"])
            best = (not reference and alg in ranking.best.get(m.key, [])
                    and len(ranking.ranks[m.key]) > 1)
            cells.append(
                f"<td class=\"num{_BEST if best else ''}\" data-metric=\"{m.key}\" "
                f"data-mean=\"{float(mean)!r}\" data-std=\"{float(std)!r}\" data-n=\"{n}\">"
                f"{_e(format_mean_std(mean, std))}</td>")
        cov = ranking.coverage.get(str(alg))
        cells.append(
            f"<td class=\"num{' warn' if alg in ranking.partial else ''}\" "
            f"data-known-share=\"{'' if cov is None else repr(cov)}\">"
            f"{'–' if cov is None else f'{100 * cov:.0f}%'}</td>")
        rank = "ref." if reference else str(place) if ranked else "–"
        title = (" title=\"reference map, not ranked\"" if reference else "" if ranked else
                 f" title=\"not ranked: no {_e(decides or 'figure to rank by')}\"")
        rows.append(
            f"<tr data-algorithm=\"{_e(alg)}\"{_WINNER if alg == ranking.winner else ''}>"
            f"<td class=\"num\"{title}>{rank}</td><td class=\"alg\">{_e(alg)}</td>"
            f"<td class=\"num\">{int(row['n'])}</td>{''.join(cells)}</tr>")
    parts = [
        f"<h2 id=\"seq-{_slug(seq)}\">{_e(seq)}</h2>",
        f"<p class=\"ranking-sentence\">{_e(ranking.sentence())}</p>",
    ]
    from slamq.results.summary import comparability_warnings

    mine = ok[ok["sequence"].astype(str) == str(seq)] if "sequence" in ok.columns else ok
    for msg in comparability_notes(comparability_warnings(mine), ranking.verdict):
        parts.append(f"<p class=\"warn comparability\">{_e(msg)}</p>")
    for alg in ranking.partial:
        parts.append(
            f"<p class=\"warn\">{_e(alg)}'s maps know "
            f"{100 * ranking.coverage.get(alg, 0.0):.0f}% of the area of the most complete map "
            "of this sequence (under 80%): a partial map scores well on every map metric "
            "(paper III.A), so compare it with care; it is never named best.</p>")
    parts.append(scroll(
        f"<table class=\"ranking\" data-sequence=\"{_e(seq)}\"><tr><th>rank</th>"
        f"<th>algorithm</th><th>runs</th>{head}</tr>" + "".join(rows) + "</table>"))
    parts.append(
        "<h3>Maps: each algorithm's runs at both ends of the deciding column</h3>"
        "<p class=\"legend\">The maps as they are: grey unknown, black occupied, white "
        "free. Click one for its detail page, with the counted corners (docs/spec.md "
        "section 3), enclosed areas (section 4), ground-truth comparison and defects as "
        "layers.</p><div class=\"gallery\">")
    for alg in ranking.order + ranking.ground_truths:
        picks = gallery.get((seq, alg), [])
        group = ok.loc[picks] if picks else ok.iloc[:0]
        key = _run_key(group, basis)
        figs = []
        ends = ("first", "last") if len(picks) > 1 else ("",)
        for which, i in zip(ends, picks):
            figs.append(_thumb(pages.get(i), ok.loc[i], which, key))
        badge = (f" <span class=\"badge\">best by {_e(basis_name(decides))}</span>"
                 if alg == ranking.winner else "")
        parts.append(f"<div class=\"card\" data-algorithm=\"{_e(alg)}\"><h4>{_e(alg)}{badge}"
                     "</h4><div class=\"pair\">" + "".join(figs) + "</div></div>")
    parts.append("</div>")
    parts.append(_runs_table(ok[ok["sequence"] == seq], pages, metrics))
    return "".join(parts)


def _thumb(mp: MapPage | None, rec: pd.Series, which: str, key: str | None = None) -> str:
    """A gallery figure: the plain map (a badge when it has defects), its run and numbers.
    ``which`` is "first" / "last" (the ends of the run order by ``key``) or ""."""
    label = f"run {rec['run']}"
    if which and key is not None:
        higher = _METRIC_HELP[key].higher if key in _METRIC_HELP else False
        low = (which == "first") != higher
        name = _METRIC_HELP[key].label if key in _METRIC_HELP else basis_name(key)
        label += f" ({'lowest' if low else 'highest'} {name})"
    shown = METRICS + ((CANONICAL,) if key == CANONICAL.key else ())
    nums = ", ".join(f"{m.label} {format_value(_num(rec.get(m.key)))}" for m in shown
                     if usable(rec.get(m.key)) and math.isfinite(_num(rec.get(m.key))))
    if mp is None or not mp.thumb:
        why = "; ".join(mp.notes) if mp else "no detail page"
        return f"<figure><figcaption>{_e(label)}<br>{_e(nums)}<br>{_e(why)}</figcaption></figure>"
    kinds = "; ".join(d["kind"] + (" (the building's)" if mp.lifted_by(d) else "")
                      for d in mp.defects)
    badge = (f"<span class=\"badge\" title=\"{_e(kinds)}\">"
             f"{len(mp.defects)} defect{'s' if len(mp.defects) != 1 else ''}</span>"
             if mp.defects else "")
    return (f"<figure><a class=\"detail\" href=\"{mp.page}\"><span class=\"thumb\">"
            f"<img src=\"{mp.thumb}\" alt=\"{_e(label)}\">{badge}</span></a><figcaption>"
            f"<a href=\"{mp.page}\">{_e(label)}</a> "
            f"&middot; <a href=\"{mp.full}\">full size</a><br>{_e(nums)}</figcaption></figure>")


def _num(x: Any) -> float:
    try:
        return float(x)
    except (TypeError, ValueError):
        return math.nan


def run_known_share(sub: pd.DataFrame) -> dict[Any, float]:
    """Each run's known area relative to the most complete map of ``sub`` (one sequence),
    reference maps left out of the maximum: ``known_area_m2`` when every run has it, else
    its ``known`` cells; empty when the runs have neither.

    Examples
    --------
    >>> import pandas as pd
    >>> run_known_share(pd.DataFrame({"algorithm": ["a", "b"], "known": [50, 100]}))
    {0: 0.5, 1: 1.0}
    """
    def col(name: str) -> pd.Series:
        return pd.to_numeric(sub.get(name, pd.Series(index=sub.index, dtype=float)),
                             errors="coerce")

    area = col("known_area_m2")
    known = area if area.notna().all() else col("known")
    algs = sub["algorithm"].astype(str).str.lower() if "algorithm" in sub else None
    mine = known if algs is None else known[~algs.isin(GROUND_TRUTH_ALGORITHMS)]
    top = mine.max()
    if not top > 0:
        return {}
    return {i: float(v / top) for i, v in known.items() if math.isfinite(v)}


def _runs_table(sub: pd.DataFrame, pages: dict[int, MapPage], metrics: Iterable) -> str:
    metrics = list(metrics)
    head = "".join(f"<th>{_e(m.heading)}</th>" for m in metrics)
    head += "<th title=\"known area relative to the most complete map of the sequence\">"
    head += "known area</th>"
    known = run_known_share(sub)
    rows = []
    for i, r in sub.sort_values(["algorithm", "run"], key=lambda s: s.astype(str)).iterrows():
        mp = pages.get(i)
        link = f"<a href=\"{mp.page}\">{_e(r['run'])}</a>" if mp else _e(r["run"])
        cells = "".join(f"<td class=\"num\">{_e(format_value(_num(r.get(m.key))))}</td>"
                        for m in metrics)
        share = known.get(i)
        cells += (f"<td class=\"num\" data-known-share=\"{'' if share is None else repr(share)}"
                  f"\">{'–' if share is None else f'{100 * share:.0f}%'}</td>")
        rows.append(f"<tr><td>{_e(r['algorithm'])}</td><td>{link}</td>{cells}</tr>")
    table = (f"<table class=\"runs\"><tr><th>algorithm</th><th>run</th>{head}</tr>"
             + "".join(rows) + "</table>")
    return f"<details><summary>All {len(sub)} runs</summary>{scroll(table)}</details>"

