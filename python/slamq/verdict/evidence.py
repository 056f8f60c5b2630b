"""The evidence the no-ground-truth verdict weighs: what the maps of one sequence say about
each other (:func:`slamq.agreement`) and what is wrong with each of them on its own
(:func:`slamq.metrics.defects.detect_defects`).

:func:`sequence_evidence` loads the maps of one sequence (at most ``runs_per_algorithm``
runs of each algorithm, the first by run number: the pairwise comparison grows with the
square of the maps), scores them against each other and runs the defect detectors, and
sums that up per algorithm for :func:`slamq.verdict.rule.sequence_verdict`. A record that
names the recording its map was built from (``scans``) and its ``trajectory`` is also
scored against its own scans (:func:`slamq.verdict.scans.record_consistency`, docs/spec.md
section 7b), its path against its own scans split in time
(:func:`slamq.verdict.scans.record_split`, section 7e), both of which the rule weighs
(section 9), and its recording by how many of its
scans see walls in one direction only (:func:`slamq.scan_degeneracy`, section 7c), which
caps the verdict's confidence. Beside it,
for the detail pages only, the missing walls of each map against the others
(:func:`slamq.metrics.agreement.missing_walls`, read off the same agreement): the verdict does
not read them (docs/validity.md, "Missing walls against the other maps").
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any

import pandas as pd

from slamq.errors import SlamqError
from slamq.metrics.agreement import (
    MISSING_MIN_LENGTH,
    _workers,
    agreement,
    finite_median,
    missing_walls,
)
from slamq.params import SETTINGS
from slamq.results.columns import GROUND_TRUTH_ALGORITHMS
from slamq.sources import load_map
from slamq.verdict.travel import path_shortfalls

__all__ = ["MISSING_MIN_LENGTH", "ONE_WITNESS_A_PROGRAM", "RUNS_PER_ALGORITHM",
           "program_support", "sequence_evidence", "split_hit"]

#: At most this many runs of each algorithm take part in the agreement of a sequence.
RUNS_PER_ALGORITHM = 3
#: Where three or more programs take part, a map's support counts each other program once
#: and its own program's reruns never (:func:`program_support`; docs/validity.md, "One
#: witness a program"); False: the median over every other map, reruns included (the rule
#: before 2026-11-30).
ONE_WITNESS_A_PROGRAM = True


def program_support(consistency: Mapping[str, Mapping[str, float]],
                    owner: Mapping[str, str]) -> dict[str, float] | None:
    """Each map's support with one witness a program: the median, over the other
    programs, of its consistency with that program's maps (their median).

    A program whose reruns draw the same map would otherwise vouch for its own walls
    (docs/validity.md, "One witness a program"). With one map a program this is the
    median over the other maps, :func:`slamq.agreement`'s support.

    Parameters
    ----------
    consistency : mapping
        ``{map: {other map: consistency}}`` (symmetric; NaN where a pair was not compared).
    owner : mapping
        Each map's program.

    Returns
    -------
    dict or None
        ``{map: support}`` (NaN without a finite consistency); None when fewer than three
        programs take part (of two, each map would have one witness, and the two supports
        of a pair of programs would be the two directions of one consistency).

    Examples
    --------
    >>> c = {"a1": {"a2": 1.0, "b": 0.5, "c": 0.6}, "a2": {"a1": 1.0, "b": 0.5, "c": 0.6},
    ...      "b": {"a1": 0.5, "a2": 0.5, "c": 0.9}, "c": {"a1": 0.6, "a2": 0.6, "b": 0.9}}
    >>> owner = {"a1": "a", "a2": "a", "b": "b", "c": "c"}
    >>> s = program_support(c, owner)
    >>> round(s["a1"], 2), round(s["b"], 2)  # a's rerun is no witness of a
    (0.55, 0.7)
    >>> program_support({"a": {"b": 0.5}, "b": {"a": 0.5}}, {"a": "a", "b": "b"}) is None
    True
    """
    if len(set(owner.values())) < 3:
        return None
    out = {}
    for m, row in consistency.items():
        by_program: dict[str, list[float]] = {}
        for o, v in row.items():
            if owner[o] != owner[m]:
                by_program.setdefault(owner[o], []).append(v)
        out[m] = finite_median([finite_median(v) for v in by_program.values()])
    return out


def sequence_evidence(ok: pd.DataFrame, sequence: str, *,
                      align: str = SETTINGS.agreement_align.default,
                      runs_per_algorithm: int = RUNS_PER_ALGORITHM,
                      defects: bool = True, scans: bool = True, threads: int | None = None,
                      loaded: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """Cross-map agreement and defect flags of the maps of one sequence, per algorithm.

    Parameters
    ----------
    ok : pandas.DataFrame
        Successful result rows (``map``, ``algorithm``, ``sequence``, ``run``).
    sequence : str
    align : str, default "auto"
        How the maps are put in one frame (:func:`slamq.agreement`'s ``align``).
    runs_per_algorithm : int, default 3
        At most this many runs of each algorithm take part.
    defects : bool, default True
        Run the defect detectors.
    scans : bool, default True
        Score each map against its own scans, where its record names them (``scans``) and
        its ``trajectory``.
    threads : int, optional
        Cap on the worker threads (default: every core, up to 8): that many of the maps'
        scans and defect detectors and of the agreement's pairs run at once, each on one
        thread. No figure depends on it.
    loaded : mapping, optional
        Maps already in memory, by the ``map`` value of their row (read again otherwise).

    Returns
    -------
    dict
        ``{"algorithms": {alg: {"support", "completeness", "placed", "runs", "flagged_runs",
        "defects", "in_group", "group_support", "scan_violation", "scan_crossing", "scan_hit",
        "scan_runs", "scan_split", "split_runs", "split_hit", "scan_local", "shortfall",
        "shortfall_against"}},
        "majority": bool, "group": [alg], "group_maps": [dict],
        "consistency": {path: {path: float}}, "maps": int, "notes": [str],
        "missing_walls": {path: [dict]}, "scans": {path: dict}, "splits": {path: dict},
        "degeneracy": {path: dict}, "degenerate_share": float, "min_support": float}``.
        ``group_maps`` is the agreeing group of docs/spec.md section 9, map by map
        (``{"map": path, "algorithm", "run"}``, empty when no two maps agree);
        ``consistency`` maps the path of each map that took part to its consistency with
        each other one (NaN where they do not overlap; empty with a single map): what a
        map's detail page says of its place in the group. ``defects`` maps a
        run's map path to its defects (dicts of
        :meth:`Defect.to_dict`); an algorithm's support and completeness are the medians
        over its runs. ``missing_walls`` maps the path of each map placed with the others
        (none when fewer than two maps) to its
        :func:`~slamq.metrics.agreement.missing_walls` flags (``kind="missing_walls"``,
        ``bbox`` in the map's own cells), for the report's pages: the verdict does not
        read them. ``scan_violation``, ``scan_crossing`` and ``scan_hit`` are the medians
        over an algorithm's runs of their maps' violation, crossing and hit shares against
        their own scans (NaN, and ``scan_runs`` 0, when none has them; the verdict weighs
        the crossing share); ``scans`` maps the path of each map scored so
        to its :meth:`~slamq.models.ScanConsistency.to_dict`. ``scan_split`` is the median
        over an algorithm's runs of their paths' split crossing share (docs/spec.md 7e; NaN,
        and ``split_runs`` 0, when none has scans), ``split_hit`` the median of their
        :func:`split_hit` (how much the halves meet), and ``splits`` maps the path of each
        map whose record was scored so to its :meth:`~slamq.models.ScanSplit.to_dict`, with
        ``local_crossing`` and ``windows`` (:func:`slamq.verdict.scans.record_local`,
        section 7f) when the rule reads them (``slamq.verdict.rule.LOCAL_RATIO`` set; off
        by default) and any path's split share is above its ``SCAN_FLOOR``;
        ``scan_local`` is their median over the runs (NaN where none).
        ``degeneracy`` maps each
        recording named by a record with scans to its
        :meth:`~slamq.models.ScanDegeneracy.to_dict` (docs/spec.md 7c), and
        ``degenerate_share`` is the highest of their shares (NaN: none). ``shortfall`` is
        how much shorter the program's path is than another program's at most, and
        ``shortfall_against`` that program (:func:`slamq.verdict.travel.path_shortfalls`; NaN
        and None without trajectories); ``corridor_shortfall`` and
        ``corridor_shortfall_against`` the same along the recording's corridors beyond
        elsewhere (its ``directions``; the whole path's where no recording was measured).

    Examples
    --------
    >>> import numpy as np, pandas as pd, tempfile, pathlib
    >>> from PIL import Image
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> img = np.full((60, 60), 254, np.uint8); img[10, 10:50] = 0; img[10:50, 10] = 0
    >>> img[49, 10:50] = 0; img[10:50, 49] = 0
    >>> for name in "abc": Image.fromarray(img).save(d / f"{name}.pgm")
    >>> ok = pd.DataFrame({"map": [str(d / f"{n}.pgm") for n in "abc"], "sequence": "s",
    ...                    "algorithm": list("abc"), "run": 1})
    >>> e = sequence_evidence(ok, "s", align="origin", defects=False)
    >>> e["majority"], e["algorithms"]["a"]["support"], e["missing_walls"][str(d / "a.pgm")]
    (True, 1.0, [])
    >>> a, b = str(d / "a.pgm"), str(d / "b.pgm")
    >>> [m["algorithm"] for m in e["group_maps"]], e["consistency"][a][b]
    (['a', 'b', 'c'], 1.0)
    """
    sub = ok[(ok["sequence"] == sequence)
             & ~ok["algorithm"].astype(str).str.lower().isin(GROUND_TRUTH_ALGORITHMS)]
    sub = sub.sort_values(["algorithm", "run"], kind="stable")
    picked = sub.groupby("algorithm", sort=True).head(runs_per_algorithm)
    maps: dict[str, Any] = {}
    owner: dict[str, str] = {}
    paths: dict[str, str] = {}
    runs: dict[str, Any] = {}
    gaps: dict[str, list[dict[str, Any]]] = {}
    notes: list[str] = []
    for rec in picked.itertuples():
        key = f"{rec.algorithm}#{rec.run}"
        try:
            maps[key] = loaded[rec.map] if loaded and rec.map in loaded else load_map(rec.map)
        except SlamqError as exc:
            notes.append(f"{rec.map}: not used as evidence ({exc})")
            continue
        owner[key] = str(rec.algorithm)
        paths[key] = str(rec.map)
        runs[key] = rec.run.item() if hasattr(rec.run, "item") else rec.run
    with ThreadPoolExecutor(max_workers=_workers(threads),
                            thread_name_prefix="slamq-evidence") as pool:
        # the scans and the detectors of every map, and the pairs of the agreement, side by
        # side on the pool's workers (one Rust thread each: no figure depends on it)
        one = 1 if _workers(threads) > 1 else threads
        scored: list[tuple[str, str, Future[Any]]] = []
        split: list[tuple[str, str, Future[Any]]] = []
        records: dict[str, dict[str, Any]] = {}
        # and each recording itself: how many of its scans see walls in one direction only
        # (docs/spec.md 7c), which caps the verdict's confidence (section 9)
        degenerate: dict[str, Future[Any]] = {}
        if scans:
            from slamq.metrics.degeneracy import scan_degeneracy
            from slamq.verdict.scans import (
                has_scans,
                record_consistency,
                recording,
            )

            for rec in picked.itertuples():
                if not has_scans(rec._asdict()):
                    continue
                path = str(rec.scans)
                try:
                    # read once, here, for all the maps that share it
                    recorded = recording(rec.scans)
                except SlamqError:
                    recorded = None  # record_consistency says why, in its turn
                if recorded is not None and path not in degenerate:
                    degenerate[path] = pool.submit(scan_degeneracy, recorded, threads=one)
                key = f"{rec.algorithm}#{rec.run}"
                if key in maps:
                    scored.append((key, str(rec.map), pool.submit(
                        record_consistency, rec._asdict(), maps[key], threads=one)))
                    # the path against its own scans split in time (7e): the map not read
                    split.append((key, str(rec.map), pool.submit(
                        _split_figures, rec._asdict(), one)))
                    records[key] = rec._asdict()
        flagged: dict[str, Future[Any]] = {}
        if defects:
            from slamq.metrics.defects import detect_defects  # on first use

            flagged = {key: pool.submit(detect_defects, m) for key, m in maps.items()}
        # the group counts programs first: one program's reruns agreeing is no group
        agree = agreement(maps, align=align, threads=threads, pool=pool, owners=owner) \
            if len(maps) >= 2 else None
        checked = _figures(scored, "not scored against its scans", notes)
        halves = _figures(split, "its path not scored against its scans split in time", notes)
        # and within short stretches of itself (7f), where the rule reads it (its
        # LOCAL_RATIO set) and it can change the confirmation: a split share at most
        # SCAN_FLOOR is confirmed whatever the local shares, so they are computed (for
        # every path: the rule may read the lowest) only when one is above
        from slamq.verdict import rule
        from slamq.verdict.scans import record_local

        wanted = rule.LOCAL_RATIO is not None and any(
            h["split_crossing"] > rule.SCAN_FLOOR for h in halves.values())
        stretches = _figures(
            [(key, str(records[key]["map"]), pool.submit(record_local, records[key],
                                                          threads=one))
             for key in (halves if wanted else ())],
            "its path not scored against its scans within short stretches", notes)
        for key, local in stretches.items():
            halves[key] = {**halves[key], **local}
        found = {key: [d.to_dict() for d in job.result()] for key, job in flagged.items()}
        seen = _figures([(path, path, job) for path, job in degenerate.items()],
                        "its scans' directions not measured", notes)
        # the scored scans themselves, for the shortfall along the corridors (7d)
        directions = {path: job.result() for path, job in degenerate.items()
                      if path in seen}
    if agree is not None:
        support, complete, placed = agree.support, agree.completeness, agree.placed
        majority = agree.majority
        in_group = set(agree.group)
        index = {k: i for i, k in enumerate(agree.names)}
        group_support = {
            k: finite_median([agree.consistency[index[k], index[o]] for o in agree.group
                              if o != k]) if k in in_group else math.nan for k in maps}
        notes.extend(agree.notes)
        missing = missing_walls(agree, maps)
        gaps = {paths[k]: [d.to_dict() for d in missing[k]] for k in maps if placed[k]}
        group_maps = [{"map": paths[k], "algorithm": owner[k], "run": runs[k]}
                      for k in agree.group]
        rows = {k: {o: float(agree.consistency[index[k], index[o]]) for o in maps if o != k}
                for k in maps}
        pairs = {paths[k]: {paths[o]: v for o, v in row.items()} for k, row in rows.items()}
        if ONE_WITNESS_A_PROGRAM and (by_key := program_support(rows, owner)) is not None:
            support = by_key
    else:
        support = complete = dict.fromkeys(maps, math.nan)
        placed = dict.fromkeys(maps, False)
        majority = False
        in_group = set()
        group_support = dict.fromkeys(maps, math.nan)
        group_maps = []
        pairs = {paths[k]: {} for k in maps}
    # each program's path against the others' (docs/spec.md 7d): weighed only where the
    # recording's scans see walls in one direction (section 9)
    compared = [r._asdict() for r in picked.itertuples() if f"{r.algorithm}#{r.run}" in maps]
    short, along = path_shortfalls(compared, notes, directions)
    algorithms: dict[str, dict[str, Any]] = {}
    for alg in sorted(set(owner.values())):
        keys = [k for k in maps if owner[k] == alg]
        shortfall, against = short.get(alg, (math.nan, None))
        corridor, corridor_against = along.get(alg, (math.nan, None))
        algorithms[alg] = {
            "support": finite_median([support[k] for k in keys]),
            "completeness": finite_median([complete[k] for k in keys]),
            "placed": all(placed[k] for k in keys),
            "runs": len(keys),
            "flagged_runs": sum(1 for k in keys if found.get(k)),
            "defects": {str(maps[k].source): found.get(k, []) for k in keys},
            "in_group": sum(k in in_group for k in keys) / len(keys) if keys else 0.0,
            "group_support": finite_median([group_support[k] for k in keys]),
            "scan_violation": finite_median([checked[k]["violation_share"] for k in keys
                                             if k in checked]),
            "scan_crossing": finite_median([checked[k].get("crossing_share", math.nan)
                                            for k in keys if k in checked]),
            "scan_hit": finite_median([checked[k]["hit_share"] for k in keys
                                       if k in checked]),
            "scan_runs": sum(1 for k in keys if k in checked),
            "scan_split": finite_median([halves[k]["split_crossing"] for k in keys
                                         if k in halves]),
            "split_runs": sum(1 for k in keys if k in halves),
            "split_hit": finite_median([split_hit(halves[k]) for k in keys
                                        if k in halves]),
            "scan_local": finite_median([halves[k].get("local_crossing", math.nan)
                                         for k in keys if k in halves]),
            "shortfall": shortfall,
            "shortfall_against": against,
            "corridor_shortfall": corridor,
            "corridor_shortfall_against": corridor_against,
        }
    # the agreeing group, by program: those whose runs are mostly in it
    group = sorted(a for a, e in algorithms.items() if e["in_group"] > 0.5)
    return {"algorithms": algorithms, "majority": bool(majority), "maps": len(maps),
            "notes": notes, "missing_walls": gaps, "group": group,
            "group_maps": group_maps, "consistency": pairs,
            "scans": {paths[k]: v for k, v in checked.items()},
            "splits": {paths[k]: v for k, v in halves.items()},
            "degeneracy": seen, "degenerate_share": _highest(
                [d["degenerate_share"] for d in seen.values()]),
            "min_support": SETTINGS.min_support.default}


def split_hit(figures: Mapping[str, Any]) -> float:
    """How much a path's two halves meet: the mean of their hit shares (beams ending on the
    walls the other half draws; :meth:`slamq.models.ScanSplit.to_dict`'s ``hit_1`` and
    ``hit_2``), NaN without them.

    Examples
    --------
    >>> split_hit({"hit_1": 0.2, "hit_2": 0.4}), split_hit({})
    (0.30000000000000004, nan)
    """
    try:
        return (float(figures["hit_1"]) + float(figures["hit_2"])) / 2
    except (KeyError, TypeError, ValueError):
        return math.nan


def _split_figures(record: dict[str, Any], threads: int | None) -> dict[str, Any]:
    """:func:`slamq.verdict.scans.record_split`'s figures, without its drawn maps (two of
    up to 2^26 cells a path: a job's result is held until every job is read)."""
    from slamq.verdict.scans import record_split

    return record_split(record, threads=threads).to_dict()


def _figures(jobs: list[tuple[str, str, Future[Any]]], failed: str, notes: list[str]
             ) -> dict[str, dict[str, Any]]:
    """``{key: job.result().to_dict()}`` of ``jobs`` (``(key, path, job)``; a result that
    is a dict as it is); a job that raises :class:`SlamqError` is left out and noted as
    ``"{path}: {failed} ({error})"``."""
    out: dict[str, dict[str, Any]] = {}
    for key, path, job in jobs:
        try:
            result = job.result()
            out[key] = result if isinstance(result, dict) else result.to_dict()
        except SlamqError as exc:
            notes.append(f"{path}: {failed} ({exc})")
    return out


def _highest(values: list[float]) -> float:
    """The largest finite value (NaN when there is none).

    Examples
    --------
    >>> _highest([0.01, float("nan"), 0.03]), _highest([])
    (0.03, nan)
    """
    finite = [v for v in values if math.isfinite(v)]
    return max(finite) if finite else math.nan
