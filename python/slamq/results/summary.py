"""``summarize``: mean and standard deviation over runs, per (algorithm, sequence).

This is the paper's Table I (trajectory RMSE "0.239 +- 0.011" per algorithm and
sequence) extended to every map metric. The standard deviation is the **sample** standard
deviation (``ddof=1``, dividing by ``n - 1``; NaN for a single run) unless you pass
``ddof=0`` (population). The paper does not say which it used; with few runs the sample
estimate is the honest one.
"""

from __future__ import annotations

import math
import os
import warnings
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from slamq.columns import Column, shown, shown_names
from slamq.errors import ParamError
from slamq.models.quality import WALL_PERIODS
from slamq.results.columns import settings_difference

__all__ = ["summarize", "SUMMARY_METRICS", "ATE_METRICS", "GT_METRICS", "REL_METRICS",
           "spreadsheet_safe",
           "summary_table", "comparability_warnings", "resolution_warnings", "angle_spread",
           "ANGLE_TOLERANCE_DEG", "Orientation", "map_names", "orientation"]

#: The map metrics summarised (every numeric MapQuality output): the map columns shown at
#: ``summary`` (:data:`slamq.columns.COLUMNS`).
SUMMARY_METRICS = shown_names("summary", "map")
#: Trajectory error columns summarised when the results have any.
ATE_METRICS = shown_names("summary", "ate")
#: Ground-truth map comparison columns (SPEC section 7) summarised when any run has them.
GT_METRICS = shown_names("summary", "gt")
#: Relations error columns (SPEC section 6a) summarised when any run has them.
REL_METRICS = shown_names("summary", "rel")
#: Maps ranked together whose wall angles (modulo the period of their walls' symmetry, 90
#: degrees for rectilinear ones) differ by more than this are turned differently: their
#: corners are not comparable.
ANGLE_TOLERANCE_DEG = 1.0
#: What each loader flag means, for the warnings.
FLAG_MEANING = {
    "yaml_beside": "a bare image whose YAML is beside it (loaded without its thresholds, "
                   "resolution and origin)",
    "screenshot": "a screenshot (colour pixels), not a saved map",
    "mostly_unknown": "mostly unknown under map_server's default thresholds",
}

def _frame(results: Any) -> Any:
    import pandas as pd

    from slamq.results.formats import read_results

    if isinstance(results, pd.DataFrame):
        return results
    if isinstance(results, (str, os.PathLike)):
        return read_results(Path(results))
    return pd.DataFrame(list(results))


def distinct_resolutions(values: Any) -> list[float]:
    """The different resolutions among ``values`` (metres per cell; missing ones ignored),
    to 6 significant digits: a map saved at 0.0700001 m has the resolution of one at 0.07.

    Examples
    --------
    >>> distinct_resolutions([0.07, 0.0700000001, None, 0.05])
    [0.05, 0.07]
    """
    import pandas as pd

    numbers = pd.to_numeric(pd.Series(list(values), dtype=object), errors="coerce").dropna()
    return sorted({float(f"{float(r):.6g}") for r in numbers})


def resolution_warnings(records: Any) -> list[str]:
    """One sentence per sequence whose maps have different resolutions: their corners and
    enclosed areas are not comparable (a map saved on a 2x finer grid counts about twice the
    corners), nor their cell counts.

    Examples
    --------
    >>> import pandas as pd
    >>> for w in resolution_warnings(pd.DataFrame({"sequence": "s", "resolution": [0.05, 0.1]})):
    ...     print(w[:60])
    s: the maps have different resolutions (0.05 m: 0; 0.1 m: 1)
    """
    import pandas as pd

    if "resolution" not in records.columns:
        return []
    seqs = records["sequence"] if "sequence" in records.columns else pd.Series(
        "all maps", index=records.index)
    out = []
    for seq, part in records.groupby(seqs.astype(str), sort=True):
        res = distinct_resolutions(part["resolution"])
        if len(res) > 1:
            names = map_names(part)
            by: dict[float, list[str]] = {}
            for name, r in zip(names, part["resolution"], strict=False):
                if isinstance(r, (int, float)) and math.isfinite(r):
                    by.setdefault(float(f"{r:.6g}"), []).append(name)
            shown = "; ".join(f"{r:g} m: {', '.join(sorted(set(n)))}" for r, n in sorted(
                by.items()))
            out.append(f"{seq}: the maps have different resolutions ({shown}): their "
                       "corners, enclosed areas and cell counts are not comparable")
    return out


def map_names(part: Any) -> list[str]:
    """A name for each record that a user recognises: its algorithm (with the run when an
    algorithm has several), else its map file's name, else its source.

    Examples
    --------
    >>> import pandas as pd
    >>> map_names(pd.DataFrame({"map": ["/r/a/map.yaml", "/r/b/gm.yaml"]}))
    ['map.yaml', 'gm.yaml']
    >>> map_names(pd.DataFrame({"algorithm": ["icp", "icp"], "run": ["1", "2"]}))
    ['icp#1', 'icp#2']
    """
    n = len(part)
    if "algorithm" in part.columns and part["algorithm"].notna().all():
        algos = [str(a) for a in part["algorithm"]]
        if len(set(algos)) == n or "run" not in part.columns:
            return algos
        return [f"{a}#{r}" for a, r in zip(algos, part["run"], strict=False)]
    for col in ("map", "source"):
        if col in part.columns:
            return [Path(str(v)).name for v in part[col]]
    return [str(i) for i in part.index]


def angle_spread(angles: Any, period: float = 90.0) -> float:
    """The largest difference between two wall angles, modulo ``period`` degrees (NaN
    ignored).

    Examples
    --------
    >>> angle_spread([44.0, -44.5, float("nan")]), angle_spread([1.0])
    (1.5, 0.0)
    >>> round(angle_spread([29.5, -29.8], period=60.0), 6)
    0.7
    """
    import numpy as np

    a = np.asarray([x for x in angles if isinstance(x, (int, float)) and math.isfinite(x)],
                   float)
    if a.size < 2:
        return 0.0
    half = period / 2.0
    d = (a[:, None] - a[None, :] + half) % period - half
    return float(np.abs(d).max())


@dataclass(frozen=True)
class Orientation:
    """How the wall angles of maps of one place compare (docs/spec.md 3a.2 and section 9):
    :func:`orientation`.

    Attributes
    ----------
    differ : bool
        Two maps of one periodic class (rectilinear, hexagonal) have wall angles more than
        ``within`` degrees apart modulo the class's period: their corners do not compare.
    turned : tuple of str
        The maps outside every largest group of maps within ``within`` of each other,
        when such a group holds more than half of the maps of its class: the maps turned
        against the others. Empty when no map is singled out (two maps, or a spread with
        no majority: then every map of the class is listed in ``angles``).
    angles : dict
        Class -> ``[(name, angle)]`` of the maps with a periodic class, in order.
    classes : dict
        Name -> class of every map with an angle (``rectilinear`` for a record without a
        class: results written before the classes existed).
    """

    differ: bool
    turned: tuple[str, ...]
    angles: dict[str, list[tuple[str, float]]]
    classes: dict[str, str]

    @property
    def not_periodic(self) -> list[str]:
        """The maps whose walls have no direction period (``irregular``, or runs of one
        algorithm that disagree): their wall angles are not compared."""
        return [n for n, c in self.classes.items() if c not in WALL_PERIODS]

    @property
    def mixed(self) -> bool:
        """The maps' walls differ in symmetry: some rectilinear, some hexagonal."""
        return len(self.angles) > 1


def orientation(names: Iterable[Any], angles: Iterable[Any],
                symmetries: Iterable[Any] | None = None,
                within: float = ANGLE_TOLERANCE_DEG) -> Orientation:
    """Compare the wall angles of maps of one place, each modulo the period of its walls'
    symmetry (``wall_symmetry``: 90 degrees for rectilinear maps, 60 for hexagonal ones);
    maps of different classes, and irregular maps, are not compared by wall angle at all.
    Within a class, ``differ`` when two angles are more than ``within`` degrees apart; then
    the largest groups of maps within ``within`` of each other are found, and when such a
    group holds more than half of the class, the maps in none of them are ``turned``.

    Examples
    --------
    >>> o = orientation(["a", "b", "c"], [0.2, 0.6, 1.9])
    >>> o.differ, o.turned
    (True, ('c',))
    >>> o = orientation("abcd", [29.8, -29.9, 29.5, -29.6], ["hexagonal"] * 4)
    >>> o.differ, o.turned
    (False, ())
    >>> orientation("ab", [3.0, 40.0], ["irregular", "rectilinear"]).differ
    False
    """
    import numpy as np

    by_class: dict[str, list[tuple[str, float]]] = {}
    classes: dict[str, str] = {}
    syms = list(symmetries) if symmetries is not None else None
    for i, (name, angle) in enumerate(zip(names, angles, strict=False)):
        try:
            a = float(angle)
        except (TypeError, ValueError):
            continue
        if not math.isfinite(a):
            continue
        s = syms[i] if syms is not None and i < len(syms) else None
        cls = s if isinstance(s, str) and s else "rectilinear"
        classes[str(name)] = cls
        if cls in WALL_PERIODS:
            by_class.setdefault(cls, []).append((str(name), a))
    differ = False
    turned: list[str] = []
    for cls, items in by_class.items():
        period = WALL_PERIODS[cls]
        vals = np.array([a for _, a in items])
        if angle_spread(vals, period) <= within:
            continue
        differ = True
        # the maps within [vals[i], vals[i] + within] modulo the period, for each i
        ahead = (vals[None, :] - vals[:, None]) % period <= within + 1e-9
        sizes = ahead.sum(axis=1)
        top = int(sizes.max())
        if 2 * top > len(items):
            kept = ahead[sizes == top].any(axis=0)
            turned += [n for (n, _), k in zip(items, kept, strict=True) if not k]
    return Orientation(differ, tuple(turned), by_class, classes)


def orientation_sentence(o: Orientation, hint: str = "") -> list[str]:
    """The comparability warnings of :func:`orientation` (without the sequence): maps turned
    differently (naming the turned ones), maps whose walls differ in symmetry, maps that are
    not rectilinear. ``hint``: what to compare instead, appended to the first.

    Examples
    --------
    >>> o = orientation(["a", "b", "c"], [0.2, 0.6, 1.9])
    >>> print(orientation_sentence(o)[0])  # doctest: +NORMALIZE_WHITESPACE
    the maps are turned differently (wall angles modulo 90: a 0.2, b 0.6, c 1.9 deg; c is
    turned against the others): their corners are not comparable
    >>> print(orientation_sentence(orientation("ab", [1.0, 2.0], ["irregular"] * 2))[0])
    ... # doctest: +NORMALIZE_WHITESPACE
    the maps' walls are not rectilinear (irregular: a, b; no clear direction period): their
    wall angles are not compared, so whether they are turned against each other is not known
    """
    out = []
    if o.differ:
        parts = []
        for cls, items in o.angles.items():
            shown = ", ".join(f"{n} {a:.1f}" for n, a in sorted(items, key=lambda t: t[1]))
            parts.append(f"wall angles modulo {WALL_PERIODS[cls]:g}: {shown} deg")
        who = ""
        if o.turned:
            verb = "is" if len(o.turned) == 1 else "are"
            who = f"; {', '.join(o.turned)} {verb} turned against the others"
        out.append(f"the maps are turned differently ({'; '.join(parts)}{who}): their "
                   f"corners are not comparable{'; ' + hint if hint else ''}")
    if o.mixed:
        shown = "; ".join(f"{cls}: {', '.join(n for n, _ in items)}"
                          for cls, items in o.angles.items())
        out.append(f"the maps' walls differ in symmetry ({shown}): their wall angles are "
                   "not compared across classes")
    odd = o.not_periodic
    if odd:
        names = ", ".join(f"{n}" + ("" if o.classes[n] == "irregular" else
                                    f" ({o.classes[n]})") for n in odd)
        whom = ("they are turned against each other" if len(odd) == len(o.classes) else
                "they are turned against the other maps")
        out.append(f"the maps' walls are not rectilinear (irregular: {names}; no clear "
                   f"direction period): their wall angles are not compared, so whether "
                   f"{whom} is not known")
    return out


def comparability_warnings(records: Any) -> list[str]:
    """One sentence per problem that makes the maps of a sequence not comparable, naming the
    metrics it affects: different resolutions (:func:`resolution_warnings`), wall angles
    that differ by more than 1 degree modulo 90 (corners; use ``corners_canonical``),
    different savers (occupied fraction, enclosed areas), canvases (proportion), and maps
    the loader flagged (a bare image with a YAML beside it, a screenshot). Reference maps
    (``ground_truth`` and the like) are left out.

    Examples
    --------
    >>> import pandas as pd
    >>> df = pd.DataFrame({"sequence": "s", "map": ["a.yaml", "b.yaml"],
    ...                    "wall_angle": [0.2, 5.1]})
    >>> for w in comparability_warnings(df):
    ...     print(w[:81])
    s: the maps are turned differently (wall angles modulo 90: a.yaml 0.2, b.yaml 5.1
    """
    import pandas as pd

    from slamq.results.columns import GROUND_TRUTH_ALGORITHMS

    if "algorithm" in records.columns:
        records = records[~records["algorithm"].astype(str).str.lower().isin(
            GROUND_TRUTH_ALGORITHMS)]
    out = resolution_warnings(records)
    seqs = records["sequence"] if "sequence" in records.columns else pd.Series(
        "all maps", index=records.index)
    for seq, part in records.groupby(seqs.astype(str), sort=True):
        if "wall_angle" in part.columns:
            angles = pd.to_numeric(part["wall_angle"], errors="coerce")
            syms = part["wall_symmetry"] if "wall_symmetry" in part.columns else None
            o = orientation(map_names(part), angles, syms)
            have = "corners_canonical" in part.columns and pd.to_numeric(
                part["corners_canonical"], errors="coerce").notna().any()
            hint = ("compare their corners_canonical" if have else
                    "compare corners_canonical (canonical_resolution=0.07)")
            out.extend(f"{seq}: {msg}" for msg in orientation_sentence(o, hint))
        if "saver" in part.columns:
            savers = sorted({str(x) for x in part["saver"] if isinstance(x, str) and x})
            if len(savers) > 1:
                out.append(f"{seq}: the maps were saved differently ({'; '.join(savers)}): "
                           "their occupied fractions and enclosed areas are not comparable")
        if {"unknown", "known"} <= set(part.columns):
            k = pd.to_numeric(part["known"], errors="coerce")
            u = pd.to_numeric(part["unknown"], errors="coerce")
            ratio = (u / k.where(k > 0)).dropna()
            if len(ratio) > 1 and ratio.max() > 2 * max(ratio.min(), 0.05):
                out.append(f"{seq}: the maps have different canvases (unknown cells per "
                           f"known cell {ratio.min():.2f} to {ratio.max():.2f}): their "
                           "proportions are not comparable")
        if "flags" in part.columns:
            files = next(([Path(str(v)).name for v in part[c]] for c in ("map", "source")
                          if c in part.columns), None) or map_names(part)
            for name, flags in zip(files, part["flags"], strict=False):
                for flag in (str(flags).split(";") if isinstance(flags, str) else []):
                    if flag in FLAG_MEANING:
                        out.append(f"{seq}: {name} is {FLAG_MEANING[flag]}: "
                                   "its numbers are not comparable with the others'")
    return out


def summarize(
    results: Any | str | os.PathLike[str] | Iterable[dict[str, Any]], *, ddof: int = 1,
    check_settings: bool = True,
) -> Any:
    """Mean and standard deviation of every metric over runs, per (algorithm, sequence).

    Parameters
    ----------
    results : pandas.DataFrame, path, or iterable of records
        The output of :func:`slamq.evaluate_many` / :func:`slamq.read_results`, or a
        results file.
    ddof : int, default 1
        Delta degrees of freedom of the standard deviation: 1 = sample (divide by n - 1),
        0 = population (divide by n).
    check_settings : bool, default True
        Warn when the records were computed with different settings (below); the report
        says so on its page instead.

    Returns
    -------
    pandas.DataFrame
        One row per (algorithm, sequence), sorted; columns ``algorithm``, ``sequence``,
        ``n`` (runs without error), ``failed`` (runs with an error, left out of the
        statistics), then ``<metric>_mean`` and ``<metric>_std`` for every metric in
        :data:`SUMMARY_METRICS`, and for the ``ate_*`` columns when any run has a
        trajectory error (``ate_runs`` counts the runs that have one), for the ``gt_*``
        figures of :data:`GT_METRICS` when any run has a ground-truth map, for the ``rel_*``
        figures of :data:`REL_METRICS` when any run has a relations error, and ``<metric>_n``,
        the number of runs where the metric is a number: a metric's mean and std are over
        those runs (a map with no known cell has NaN ratios), so they may cover fewer than
        ``n`` runs.

    Warns
    -----
    UserWarning
        The records were computed with different settings (their ``config`` column:
        metric parameters, ``unknown_value``, ATE options), e.g. a results file resumed
        with other parameters and interrupted, or shared by two batches.

    Examples
    --------
    >>> recs = [{"algorithm": "a", "sequence": "s", "run": str(i), "corners": c,
    ...          "error": None} for i, c in enumerate([10, 12, 14])]
    >>> s = summarize(recs)
    >>> int(s.loc[0, "n"]), s.loc[0, ["corners_mean", "corners_std"]].tolist()
    (3, [12.0, 2.0])
    """
    import numpy as np
    import pandas as pd

    if ddof not in (0, 1):
        raise ParamError(f"ddof must be 0 or 1, got {ddof!r}")
    df = _frame(results)
    mixed = (settings_difference(df["config"]) if check_settings and "config" in df.columns
             else None)
    if mixed:
        warnings.warn(
            f"the results were computed with different settings ({mixed}); their "
            "statistics mix them (evaluate every map again with one setting, or use another "
            "results file)", UserWarning,
            stacklevel=2,
        )
    if "algorithm" not in df.columns:  # each map its own row, named by its file
        stems = [Path(str(m)).stem if isinstance(m, str) else "" for m in
                 (df["map"] if "map" in df.columns else [None] * len(df))]
        df = df.assign(algorithm=stems)
    if "sequence" not in df.columns:
        df = df.assign(sequence="all maps")
    err = df["error"] if "error" in df.columns else pd.Series([None] * len(df), index=df.index)
    failed_mask = err.notna() & (err.astype(object) != "")
    if check_settings:
        for msg in comparability_warnings(df[~failed_mask]):
            warnings.warn(msg, UserWarning, stacklevel=2)
    has_ate = "ate_rmse" in df.columns and df.loc[~failed_mask, "ate_rmse"].notna().any()
    metrics = [m for m in SUMMARY_METRICS if m in df.columns]
    if has_ate:
        metrics += [m for m in ATE_METRICS if m in df.columns]
    if "gt_f1" in df.columns and df.loc[~failed_mask, "gt_f1"].notna().any():
        metrics += [m for m in GT_METRICS if m in df.columns]
    if "rel_n" in df.columns and df.loc[~failed_mask, "rel_n"].notna().any():
        metrics += [m for m in REL_METRICS if m in df.columns]
    rows = []
    keys = df[["algorithm", "sequence"]].astype(str)
    for (alg, seq), idx in keys.groupby(["algorithm", "sequence"], sort=True).groups.items():
        part = df.loc[idx]
        ok = part[~failed_mask.loc[idx]]
        row: dict[str, Any] = {
            "algorithm": alg, "sequence": seq, "n": int(len(ok)),
            "failed": int(len(part) - len(ok)),
        }
        if has_ate:
            row["ate_runs"] = int(ok["ate_rmse"].notna().sum())
        symmetry = _symmetry(ok)
        if symmetry is not None:
            row["wall_symmetry"] = symmetry
        for m in metrics:
            vals = pd.to_numeric(ok[m], errors="coerce").to_numpy(dtype=float)
            vals = vals[~np.isnan(vals)]
            if m == "wall_angle":
                vals = _unwrapped(vals, WALL_PERIODS.get(symmetry or "", 90.0))
            row[f"{m}_n"] = int(len(vals))
            row[f"{m}_mean"] = float(vals.mean()) if len(vals) else math.nan
            row[f"{m}_std"] = (
                float(vals.std(ddof=ddof)) if len(vals) > ddof else math.nan
            )
        rows.append(row)
    cols = ["algorithm", "sequence", "n", "failed"] + (["ate_runs"] if has_ate else [])
    cols += [f"{m}_{s}" for m in metrics for s in ("mean", "std", "n")]
    if "wall_symmetry" in df.columns:
        cols.append("wall_symmetry")
    out = pd.DataFrame(rows, columns=cols)
    if "wall_angle_mean" in out.columns and "wall_symmetry" in out.columns:
        # the mean of angles unwrapped about the first run is brought back into the period
        for i, sym in out["wall_symmetry"].items():
            p = WALL_PERIODS.get(sym or "", 90.0)
            a = out.at[i, "wall_angle_mean"]
            if isinstance(a, float) and math.isfinite(a) and not -p / 2 < a <= p / 2:
                out.at[i, "wall_angle_mean"] = p / 2 - (p / 2 - a) % p
    return out


def _symmetry(runs: Any) -> str | None:
    """The wall symmetry of an algorithm's runs: their common class, ``"mixed"`` when they
    differ (no wall angle of theirs is then compared), None without the column (results
    written before it: read as rectilinear)."""
    if "wall_symmetry" not in runs.columns:
        return None
    found = sorted({s for s in runs["wall_symmetry"] if isinstance(s, str) and s})
    if not found:
        return None
    return found[0] if len(found) == 1 else "mixed"


def _unwrapped(angles: Any, period: float) -> Any:
    """Wall angles of one algorithm's runs, as they are unless they straddle the ends of the
    period (one run at +44.9 degrees, another at -44.8 modulo 90): then each unwrapped to
    within half a period of the first, so that their mean and spread are the angles'."""

    if len(angles) < 2 or float(angles.max() - angles.min()) <= period / 2:
        return angles
    half = period / 2
    return angles[0] + ((angles - angles[0] + half) % period - half)


def _pm(mean: float, std: float, col: Column) -> str:
    """``mean ± std`` in the column's format; whole numbers without decimals, float noise
    as 0."""
    if mean is None or (isinstance(mean, float) and math.isnan(mean)):
        return "-"
    text = col.format_number(mean)
    if std is not None and not (isinstance(std, float) and math.isnan(std)):
        noise = abs(std) <= 1e-9 * max(abs(mean), 1.0)
        text += " ± " + ("0" if noise else col.format_number(std))
    return text


def summary_table(summary: Any, *, title: str = "") -> Any:
    """A :class:`rich.table.Table` of a :func:`summarize` frame: ``mean ± std`` cells of the
    columns shown at ``console`` (:data:`slamq.columns.COLUMNS`)."""
    from rich.table import Table

    table = Table(title=title or None)
    table.add_column("sequence")
    table.add_column("algorithm")
    table.add_column("n", justify="right")
    cols = [c for c in shown("console") if f"{c.name}_mean" in summary.columns]
    for c in cols:
        table.add_column(c.heading, justify="right")
    if "failed" in summary.columns and summary["failed"].sum():
        table.add_column("failed", justify="right")
    ordered = summary.sort_values(["sequence", "algorithm"], kind="stable")
    for _, row in ordered.iterrows():
        cells = [str(row["sequence"]), str(row["algorithm"]), str(int(row["n"]))]
        cells += [_pm(row[f"{c.name}_mean"], row[f"{c.name}_std"], c) for c in cols]
        if len(table.columns) > len(cells):
            cells.append(str(int(row["failed"])))
        table.add_row(*cells)
    return table


def spreadsheet_safe(frame: Any) -> Any:
    """``frame`` with text cells that a spreadsheet would run as a formula (starting with
    ``=``, ``+``, ``-``, ``@``, a tab or a carriage return) prefixed with ``'``: algorithm
    and sequence names come from folder names, which anyone can choose.

    Examples
    --------
    >>> import pandas as pd
    >>> spreadsheet_safe(pd.DataFrame({"algorithm": ["=HYPERLINK(1)", "gmapping"], "n": [1, 2]})
    ...                  )["algorithm"].tolist()
    ["'=HYPERLINK(1)", 'gmapping']
    """
    import pandas as pd

    out = frame.copy()
    for col in out.columns:
        if out[col].dtype == object or pd.api.types.is_string_dtype(out[col]):
            out[col] = [f"'{v}" if isinstance(v, str) and v[:1] in _FORMULA_STARTS else v
                        for v in out[col]]
    return out


_FORMULA_STARTS = ("=", "+", "-", "@", "\t", "\r")
