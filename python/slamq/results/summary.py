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

__all__ = ["summarize", "summary_rows", "SUMMARY_METRICS", "ATE_METRICS", "GT_METRICS",
           "REL_METRICS", "spreadsheet_safe", "summary_table", "comparability_warnings",
           "resolution_warnings", "angle_spread", "ANGLE_TOLERANCE_DEG", "Orientation",
           "map_names", "orientation"]

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

class _Rows:
    """Records as plain rows (dicts), with their columns and index labels: a DataFrame's or
    a list of records' contents, read without pandas (``slamq summary`` never imports it).
    A column a row lacks is None in that row."""

    __slots__ = ("rows", "columns", "index")

    def __init__(self, rows: list[dict[str, Any]], columns: Iterable[str],
                 index: list[Any] | None = None) -> None:
        self.rows = rows
        self.columns = dict.fromkeys(columns)
        self.index = list(range(len(rows))) if index is None else index

    def __len__(self) -> int:
        return len(self.rows)

    def col(self, name: str) -> list[Any]:
        return [r.get(name) for r in self.rows]

    def take(self, positions: Iterable[int]) -> _Rows:
        pos = list(positions)
        return _Rows([self.rows[i] for i in pos], self.columns, [self.index[i] for i in pos])

    def with_column(self, name: str, values: list[Any]) -> _Rows:
        return _Rows([{**r, name: v} for r, v in zip(self.rows, values, strict=True)],
                     [*self.columns, name], self.index)


def _rows(records: Any, wanted: Iterable[str] | None = None) -> _Rows:
    """``records`` (a DataFrame, :class:`_Rows` or an iterable of dicts) as :class:`_Rows`;
    of a DataFrame only the ``wanted`` columns (all when None) are read."""
    if isinstance(records, _Rows):
        return records
    if hasattr(records, "to_dict") and hasattr(records, "columns"):  # a DataFrame
        cols = list(records.columns)
        if wanted is not None:
            want = set(wanted)
            cols = [c for c in cols if c in want]
        return _Rows(records[cols].to_dict("records"), cols, list(records.index))
    rows = [dict(r) for r in records]
    return _Rows(rows, (k for r in rows for k in r))


def _missing(value: Any) -> bool:
    """What pandas calls NA: None, NaN, ``pd.NA``, ``pd.NaT``."""
    if value is None:
        return True
    if isinstance(value, float):
        return value != value
    return type(value).__name__ in ("NAType", "NaTType")


def _number(value: Any) -> float:
    """``value`` as ``pd.to_numeric(..., errors="coerce")`` reads it, as a float (NaN when
    it is not a number)."""
    if isinstance(value, (int, float)):
        return float(value)
    if value is None or _missing(value):
        return math.nan
    if isinstance(value, str):
        if "_" in value:
            return math.nan
        try:
            return float(value)
        except ValueError:
            return math.nan
    try:
        return float(value)  # numpy scalars
    except (TypeError, ValueError):
        return math.nan


def _key(value: Any) -> str | None:
    """A group key as ``Series.astype(str)`` makes it (None for a missing value: pandas
    leaves such rows out of the groups)."""
    return None if _missing(value) else str(value)


def _groups(keys: list[Any]) -> list[tuple[Any, list[int]]]:
    """``(key, positions)`` of the rows of each key, sorted by key (rows whose key is None
    are left out), positions in row order: ``groupby(..., sort=True)``."""
    out: dict[Any, list[int]] = {}
    for i, k in enumerate(keys):
        if k is not None and not (isinstance(k, tuple) and None in k):
            out.setdefault(k, []).append(i)
    return sorted(out.items(), key=lambda kv: kv[0])


#: numpy's block size of pairwise summation (numpy/_core/src/umath/loops_utils.h.src).
_PW_BLOCKSIZE = 128


def _pairwise_sum(a: list[float], lo: int, n: int) -> float:
    """numpy's pairwise summation of ``a[lo:lo + n]`` (float64 ``add.reduce``), the same
    additions in the same order, so the same sum to the last bit."""
    if n < 8:
        res = -0.0
        for i in range(lo, lo + n):
            res += a[i]
        return res
    if n <= _PW_BLOCKSIZE:
        r = a[lo:lo + 8]
        i = 8
        whole = n - n % 8
        while i < whole:
            for j in range(8):
                r[j] += a[lo + i + j]
            i += 8
        res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]))
        for k in range(whole, n):
            res += a[lo + k]
        return res
    n2 = n // 2
    n2 -= n2 % 8
    return _pairwise_sum(a, lo, n2) + _pairwise_sum(a, lo + n2, n - n2)


def _sum(values: list[float]) -> float:
    """``float(np.sum(values))`` for float64 values (the reduction starts at 0.0)."""
    return 0.0 + _pairwise_sum(values, 0, len(values))


def _mean_std(values: list[float], ddof: int) -> tuple[float, float]:
    """``(np.mean(v), np.std(v, ddof=ddof))`` of a non-empty list, bit for bit (numpy's
    ``_mean`` and ``_var``: the sum over the count, the squared deviations' sum over
    ``count - ddof``, its square root); the std is NaN when ``count <= ddof``."""
    n = len(values)
    mean = _sum(values) / n
    if n <= ddof:
        return mean, math.nan
    dev = [v - mean for v in values]
    var = _sum([d * d for d in dev]) / (n - ddof)
    return mean, math.sqrt(var)


def distinct_resolutions(values: Any) -> list[float]:
    """The different resolutions among ``values`` (metres per cell; missing ones ignored),
    to 6 significant digits: a map saved at 0.0700001 m has the resolution of one at 0.07.

    Examples
    --------
    >>> distinct_resolutions([0.07, 0.0700000001, None, 0.05])
    [0.05, 0.07]
    """
    numbers = (_number(v) for v in values)
    return sorted({float(f"{r:.6g}") for r in numbers if r == r})


def resolution_warnings(records: Any) -> list[str]:
    """One sentence per sequence whose maps have different resolutions: their corners and
    enclosed areas are not comparable (a map saved on a 2x finer grid counts about twice the
    corners), nor their cell counts.

    Parameters
    ----------
    records : pandas.DataFrame or list of dict
        The records (a column a record lacks is missing).

    Examples
    --------
    >>> for w in resolution_warnings([{"sequence": "s", "resolution": 0.05},
    ...                               {"sequence": "s", "resolution": 0.1}]):
    ...     print(w[:60])
    s: the maps have different resolutions (0.05 m: 0; 0.1 m: 1)
    """
    recs = _rows(records, _WARNING_COLUMNS)
    if "resolution" not in recs.columns:
        return []
    seqs = recs.col("sequence") if "sequence" in recs.columns else ["all maps"] * len(recs)
    out = []
    for seq, pos in _groups([_key(s) for s in seqs]):
        part = recs.take(pos)
        values = part.col("resolution")
        if len(distinct_resolutions(values)) > 1:
            names = _map_names(part)
            by: dict[float, list[str]] = {}
            for name, r in zip(names, values, strict=False):
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
    >>> map_names([{"map": "/r/a/map.yaml"}, {"map": "/r/b/gm.yaml"}])
    ['map.yaml', 'gm.yaml']
    >>> map_names([{"algorithm": "icp", "run": "1"}, {"algorithm": "icp", "run": "2"}])
    ['icp#1', 'icp#2']
    """
    return _map_names(_rows(part, _WARNING_COLUMNS))


def _map_names(part: _Rows) -> list[str]:
    n = len(part)
    if "algorithm" in part.columns and not any(_missing(a) for a in part.col("algorithm")):
        algos = [str(a) for a in part.col("algorithm")]
        if len(set(algos)) == n or "run" not in part.columns:
            return algos
        return [f"{a}#{r}" for a, r in zip(algos, part.col("run"), strict=False)]
    for col in ("map", "source"):
        if col in part.columns:
            return [Path(str(v)).name for v in part.col(col)]
    return [str(i) for i in part.index]


#: Above this many angles, :func:`angle_spread` takes every difference with numpy (the
#: same arithmetic, the same result).
_SPREAD_NUMPY = 64


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
    a = [float(x) for x in angles if isinstance(x, (int, float)) and math.isfinite(x)]
    if len(a) < 2:
        return 0.0
    half = period / 2.0
    if len(a) > _SPREAD_NUMPY:
        import numpy as np

        v = np.asarray(a, float)
        d = (v[:, None] - v[None, :] + half) % period - half
        return float(np.abs(d).max())
    return max(abs((x - y + half) % period - half) for x in a for y in a)


#: The columns the comparability warnings read.
_WARNING_COLUMNS = ("algorithm", "sequence", "run", "map", "source", "resolution",
                    "wall_angle", "wall_symmetry", "corners_canonical", "saver", "known",
                    "unknown", "flags")


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
        vals = [a for _, a in items]
        if angle_spread(vals, period) <= within:
            continue
        differ = True
        # the maps within [vals[i], vals[i] + within] modulo the period, for each i
        ahead = [[(b - a) % period <= within + 1e-9 for b in vals] for a in vals]
        sizes = [sum(row) for row in ahead]
        top = max(sizes)
        if 2 * top > len(items):
            kept = [any(ahead[i][j] for i in range(len(vals)) if sizes[i] == top)
                    for j in range(len(vals))]
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

    Parameters
    ----------
    records : pandas.DataFrame or list of dict
        The records (a column a record lacks is missing).

    Examples
    --------
    >>> recs = [{"sequence": "s", "map": "a.yaml", "wall_angle": 0.2},
    ...         {"sequence": "s", "map": "b.yaml", "wall_angle": 5.1}]
    >>> for w in comparability_warnings(recs):
    ...     print(w[:81])
    s: the maps are turned differently (wall angles modulo 90: a.yaml 0.2, b.yaml 5.1
    """
    from slamq.results.columns import GROUND_TRUTH_ALGORITHMS

    recs = _rows(records, _WARNING_COLUMNS)
    if "algorithm" in recs.columns:
        recs = recs.take(i for i, a in enumerate(recs.col("algorithm"))
                         if _missing(a) or str(a).lower() not in GROUND_TRUTH_ALGORITHMS)
    out = resolution_warnings(recs)
    seqs = recs.col("sequence") if "sequence" in recs.columns else ["all maps"] * len(recs)
    for seq, pos in _groups([_key(s) for s in seqs]):
        part = recs.take(pos)
        if "wall_angle" in part.columns:
            angles = [_number(a) for a in part.col("wall_angle")]
            syms = part.col("wall_symmetry") if "wall_symmetry" in part.columns else None
            o = orientation(_map_names(part), angles, syms)
            have = "corners_canonical" in part.columns and any(
                _number(v) == _number(v) for v in part.col("corners_canonical"))
            hint = ("compare their corners_canonical" if have else
                    "compare corners_canonical (canonical_resolution=0.07)")
            out.extend(f"{seq}: {msg}" for msg in orientation_sentence(o, hint))
        if "saver" in part.columns:
            savers = sorted({str(x) for x in part.col("saver") if isinstance(x, str) and x})
            if len(savers) > 1:
                out.append(f"{seq}: the maps were saved differently ({'; '.join(savers)}): "
                           "their occupied fractions and enclosed areas are not comparable")
        if {"unknown", "known"} <= set(part.columns):
            ratio = []
            for k, u in zip(part.col("known"), part.col("unknown"), strict=True):
                k, u = _number(k), _number(u)
                if k > 0 and u / k == u / k:
                    ratio.append(u / k)
            if len(ratio) > 1 and max(ratio) > 2 * max(min(ratio), 0.05):
                out.append(f"{seq}: the maps have different canvases (unknown cells per "
                           f"known cell {min(ratio):.2f} to {max(ratio):.2f}): their "
                           "proportions are not comparable")
        if "flags" in part.columns:
            files = next(([Path(str(v)).name for v in part.col(c)] for c in ("map", "source")
                          if c in part.columns), None) or _map_names(part)
            for name, flags in zip(files, part.col("flags"), strict=False):
                for flag in (str(flags).split(";") if isinstance(flags, str) else []):
                    if flag in FLAG_MEANING:
                        out.append(f"{seq}: {name} is {FLAG_MEANING[flag]}: "
                                   "its numbers are not comparable with the others'")
    return out


def _results_rows(results: Any) -> Any:
    """A path read with :func:`slamq.results.formats.read_records` (no pandas), else
    ``results`` as it is."""
    if isinstance(results, (str, os.PathLike)):
        from slamq.results.formats import read_records

        return read_records(Path(results))
    return results


def summary_rows(
    results: Any | str | os.PathLike[str] | Iterable[dict[str, Any]], *, ddof: int = 1,
    check_settings: bool = True,
) -> tuple[list[str], list[dict[str, Any]]]:
    """:func:`summarize` without pandas: its columns and its rows (one dict per row), the
    same numbers to the last bit (numpy's pairwise sums, computed in Python); what
    ``slamq summary`` prints, without importing pandas or numpy.

    Parameters and warnings are :func:`summarize`'s.

    Returns
    -------
    columns : list of str
        :func:`summarize`'s columns, in order.
    rows : list of dict
        One per (algorithm, sequence), sorted.

    Examples
    --------
    >>> recs = [{"algorithm": "a", "sequence": "s", "run": str(i), "corners": c,
    ...          "error": None} for i, c in enumerate([10, 12, 14])]
    >>> cols, rows = summary_rows(recs)
    >>> rows[0]["n"], rows[0]["corners_mean"], rows[0]["corners_std"]
    (3, 12.0, 2.0)
    """
    if ddof not in (0, 1):
        raise ParamError(f"ddof must be 0 or 1, got {ddof!r}")
    metric_names = [*SUMMARY_METRICS, *ATE_METRICS, *GT_METRICS, *REL_METRICS]
    recs = _rows(_results_rows(results),
                 {"error", "config", "ate_rmse", "gt_f1", "rel_n", *_WARNING_COLUMNS,
                  *metric_names})
    mixed = (settings_difference(recs.col("config"))
             if check_settings and "config" in recs.columns else None)
    if mixed:
        warnings.warn(
            f"the results were computed with different settings ({mixed}); their "
            "statistics mix them (evaluate every map again with one setting, or use another "
            "results file)", UserWarning,
            stacklevel=3,
        )
    if "algorithm" not in recs.columns:  # each map its own row, named by its file
        maps = recs.col("map") if "map" in recs.columns else [None] * len(recs)
        recs = recs.with_column(
            "algorithm", [Path(str(m)).stem if isinstance(m, str) else "" for m in maps])
    if "sequence" not in recs.columns:
        recs = recs.with_column("sequence", ["all maps"] * len(recs))
    failed = [not _missing(e) and e != "" for e in recs.col("error")]
    good = [i for i, f in enumerate(failed) if not f]
    if check_settings:
        for msg in comparability_warnings(recs.take(good)):
            warnings.warn(msg, UserWarning, stacklevel=3)

    def any_value(name: str) -> bool:
        return name in recs.columns and any(not _missing(recs.rows[i].get(name))
                                            for i in good)

    has_ate = any_value("ate_rmse")
    metrics = [m for m in SUMMARY_METRICS if m in recs.columns]
    if has_ate:
        metrics += [m for m in ATE_METRICS if m in recs.columns]
    if any_value("gt_f1"):
        metrics += [m for m in GT_METRICS if m in recs.columns]
    if any_value("rel_n"):
        metrics += [m for m in REL_METRICS if m in recs.columns]
    has_symmetry = "wall_symmetry" in recs.columns
    rows = []
    keys = [(_key(r.get("algorithm")), _key(r.get("sequence"))) for r in recs.rows]
    for (alg, seq), pos in _groups(keys):
        ok = [recs.rows[i] for i in pos if not failed[i]]
        row: dict[str, Any] = {
            "algorithm": alg, "sequence": seq, "n": len(ok), "failed": len(pos) - len(ok),
        }
        if has_ate:
            row["ate_runs"] = sum(not _missing(r.get("ate_rmse")) for r in ok)
        symmetry = _symmetry(ok, has_symmetry)
        if symmetry is not None:
            row["wall_symmetry"] = symmetry
        for m in metrics:
            vals = [v for v in (_number(r.get(m)) for r in ok) if v == v]
            if m == "wall_angle":
                vals = _unwrapped(vals, WALL_PERIODS.get(symmetry or "", 90.0))
            row[f"{m}_n"] = len(vals)
            mean, std = _mean_std(vals, ddof) if vals else (math.nan, math.nan)
            if m == "wall_angle" and symmetry is not None and math.isfinite(mean):
                # the mean of angles unwrapped about the first run, back into the period
                p = WALL_PERIODS.get(symmetry, 90.0)
                if not -p / 2 < mean <= p / 2:
                    mean = p / 2 - (p / 2 - mean) % p
            row[f"{m}_mean"] = mean
            row[f"{m}_std"] = std
        rows.append(row)
    cols = ["algorithm", "sequence", "n", "failed"] + (["ate_runs"] if has_ate else [])
    cols += [f"{m}_{s}" for m in metrics for s in ("mean", "std", "n")]
    if has_symmetry:
        cols.append("wall_symmetry")
    return cols, rows


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
        ``n`` runs. Records without an algorithm or a sequence value are left out.
        :func:`summary_rows` gives the same without pandas.

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
    import pandas as pd

    cols, rows = summary_rows(results, ddof=ddof, check_settings=check_settings)
    return pd.DataFrame(rows, columns=cols)


def _symmetry(runs: list[dict[str, Any]], has_column: bool) -> str | None:
    """The wall symmetry of an algorithm's runs (records): their common class, ``"mixed"``
    when they differ (no wall angle of theirs is then compared), None without the column
    (results written before it: read as rectilinear)."""
    if not has_column:
        return None
    found = sorted({s for s in (r.get("wall_symmetry") for r in runs)
                    if isinstance(s, str) and s})
    if not found:
        return None
    return found[0] if len(found) == 1 else "mixed"


def _unwrapped(angles: list[float], period: float) -> list[float]:
    """Wall angles of one algorithm's runs, as they are unless they straddle the ends of the
    period (one run at +44.9 degrees, another at -44.8 modulo 90): then each unwrapped to
    within half a period of the first, so that their mean and spread are the angles'."""
    if len(angles) < 2 or max(angles) - min(angles) <= period / 2:
        return angles
    half = period / 2
    return [angles[0] + ((a - angles[0] + half) % period - half) for a in angles]


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
    """A :class:`rich.table.Table` of a :func:`summarize` frame (or :func:`summary_rows`'
    rows): ``mean ± std`` cells of the columns shown at ``console``
    (:data:`slamq.columns.COLUMNS`)."""
    from rich.table import Table

    if hasattr(summary, "to_dict"):  # a DataFrame
        names, rows = list(summary.columns), summary.to_dict("records")
    else:
        rows = list(summary)
        names = list(rows[0]) if rows else []
    table = Table(title=title or None)
    table.add_column("sequence")
    table.add_column("algorithm")
    table.add_column("n", justify="right")
    cols = [c for c in shown("console") if f"{c.name}_mean" in names]
    for c in cols:
        table.add_column(c.heading, justify="right")
    if "failed" in names and sum(r["failed"] for r in rows):
        table.add_column("failed", justify="right")
    for row in sorted(rows, key=lambda r: (r["sequence"], r["algorithm"])):
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
