"""The verdict: which algorithm is best on each sequence, on what basis, and how sure that
is. This module applies the rule of docs/spec.md section 9 ("The verdict"), which is where
the rule is written; its thresholds are the constants below, and :func:`rule_summary` says
it in one sentence from them. The report (``verdict.json``, its first box) and
``slamq verdict`` both call :func:`sequence_verdict`. How far the verdict without ground
truth can be trusted: docs/validity.md, "The verdict without ground truth".
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd

from slamq.models.quality import WALL_PERIODS
from slamq.params import SETTINGS
from slamq.results.columns import GROUND_TRUTH_ALGORITHMS
from slamq.results.summary import Orientation, distinct_resolutions, orientation
from slamq.verdict.calibration import with_calibration

__all__ = [
    "AGREEMENT_SHARE", "COMPLETE_SHARE", "CLEAR_MARGIN", "CORRIDOR_TRAVEL",
    "DEGENERATE_SHARE", "LOCAL_ANCHOR",
    "LOCAL_KEY", "LOCAL_RATIO", "SCANS_BREAK_TIES", "SCANS_ORDER_UNCOMPARABLE", "SCAN_FLOOR",
    "MILD_DEFECTS_DECIDE", "SCAN_KEY", "SCAN_SHARE", "SEVERE_DEFECTS", "SHARED_DIRECTION",
    "SHARED_DIRECTION_AGREE", "SHARED_DIRECTION_DEG",
    "SHARED_DIRECTION_DEG_NO_SCANS", "SHORTFALL",
    "SPLIT_HIT_KEY", "SPLIT_KEY", "SPLIT_MEET", "SPLIT_PRECISION",
    "SPLIT_PRECISION_FLAGS", "SPLIT_PRECISION_TRAVEL", "halves_apart", "halves_miss",
    "halves_misses", "travel_spared",
    "basis_name", "known_share", "needs_evidence", "one_direction_share", "rule_summary",
    "scan_limit", "shared_directions", "superposed_separations",
    "sequence_verdict", "verdict_sentence",
]

#: A map knowing less area than this share of the sequence's most complete map is partial:
#: never named best (the ranking tables flag it too).
COMPLETE_SHARE = 0.8

#: Corners: a runner-up within this relative margin of the best means no clear winner.
CLEAR_MARGIN = 0.25
#: Where corners leave no clear winner among the confirmed maps, the maps within
#: :data:`CLEAR_MARGIN` of the best count are ordered by their own scans' figure (the split
#: share where each has one, else the crossing share where each has one; lower first).
#: docs/validity.md, "No clear winner by corners: the scans decide".
SCANS_BREAK_TIES = True
#: Where corners cannot compare the confirmed maps (they differ in resolution or
#: orientation), their own scans order them with the figure of :data:`SCANS_BREAK_TIES`
#: (else their support does). docs/validity.md, "Maps corners cannot compare: the scans
#: order them".
SCANS_ORDER_UNCOMPARABLE = True
#: Without ground truth: a map whose support (median consistency with the other maps) is
#: below this share of the sequence's best support disagrees with the others and is never
#: named best; the maps at or above it are confirmed equally (corners order them, or their
#: own scans where corners cannot compare them).
AGREEMENT_SHARE = 0.9
#: Against its own scans (docs/spec.md 7b): a map whose crossing share (beams that pass
#: through a wall of the map and come out into free space beyond it) is above
#: ``max(SCAN_FLOOR, SCAN_SHARE x`` the lowest of the sequence's maps scored so``)`` is
#: inconsistent with its own data and never named best; where no other map confirms it (one
#: of two maps, maps that disagree), a map is named on its scans only when its crossing
#: share is at most ``SCAN_FLOOR``. Chosen on the tuning set of docs/validity.md ("Walls
#: crossed: set B under the frozen crossing rule; one amendment"); until then the violation
#: share with (0.10, 2).
SCAN_FLOOR = 0.02
SCAN_SHARE = 1.5
#: The evidence's field the scan rule reads (each algorithm's median crossing share).
SCAN_KEY = "scan_crossing"
#: Its path against its own scans split in time (docs/spec.md 7e): the evidence's field of
#: each algorithm's median split crossing share. A program whose split share is above
#: ``max(SCAN_FLOOR, SCAN_SHARE x`` the lowest of the sequence's``)`` is never named best,
#: as with the crossing share, and where its path was so scored, its split share is the
#: figure that confirms a map named on its scans (at most ``SCAN_FLOOR``). Frozen on the
#: sets of docs/validity.md ("C2 with 300 scans a half, on two more sets") before two new
#: sets were made, and met its criterion on them.
SPLIT_KEY = "scan_split"
#: Its path split within short stretches of itself (docs/spec.md 7f): the evidence's field
#: of each algorithm's median local share. With ``LOCAL_RATIO`` set, a split share confirms
#: a map named on its scans at most at ``max(SCAN_FLOOR, LOCAL_RATIO x`` the anchor's local
#: share``)``, for recordings of places that move (people, doors, glass) more than the
#: generated worlds ``SCAN_FLOOR`` was set on. **Off (None)**: measured as candidates C3
#: (``LOCAL_ANCHOR = "path"``, the program's own) and C3' (``"lowest"``, the lowest of the
#: sequence's programs) in docs/validity.md ("A fifth real log ..."), C3 named a broken
#: real map and C3' named no more sequences on five real logs; ``sequence_evidence``
#: measures the local shares only when it is set.
LOCAL_KEY = "scan_local"
LOCAL_RATIO: float | None = None
LOCAL_ANCHOR = "lowest"
#: Its path's halves against each other (docs/spec.md 7e): the evidence's field of each
#: algorithm's median split hit share (the mean of the two halves' hit shares: beams ending
#: on the walls the other half draws).
SPLIT_HIT_KEY = "split_hit"
#: With ``SPLIT_MEET``, a split share confirms a path (:meth:`_Shares.confirms`) only when
#: its program's split hit share is at least the highest of the sequence's programs so
#: scored divided by :data:`SCAN_SHARE`: halves that barely meet (a wrong loop that never
#: comes back over its start) test little, and their share is low for that (O1).
#: docs/validity.md, "A split share confirms a path only where its halves meet": adopted
#: (False: the rule before 2026-12-01).
SPLIT_MEET = True
#: Where the verdict would abstain because the maps disagree among themselves (or because
#: every map is flagged or partial), with at least three programs each with a split share
#: and a split hit share: the program whose halves cross each other's walls the least where
#: they meet them (:func:`halves_miss`) is named when its share is at most every other's
#: divided by :data:`SCAN_SHARE`, its maps are placed and carry no defect flag (but those
#: of :data:`SPLIT_PRECISION_FLAGS`), and its halves meet (:data:`SPLIT_MEET`'s
#: condition); "partial" and the split share's veto, which that share replaces there, are
#: not applied to it. Adopted 2026-12-02 with
#: :data:`SPLIT_PRECISION_TRAVEL` ``"any"`` (P1c of docs/validity.md, "Exempt from the
#: travel veto where the halves separate the paths: measured, adopted"); False: the rule
#: before.
SPLIT_PRECISION = True
#: Which named maps the travel veto (:func:`_short_path`) spares: ``None``, none (P1);
#: ``"halves"``, the map :data:`SPLIT_PRECISION` names (P1b: every path its shortfall
#: would be measured against crosses its own halves at least :data:`SCAN_SHARE` x as
#: often); ``"any"``, any named map whose halves separate it so from every other program's
#: path (P1c, :func:`halves_apart`; adopted). docs/validity.md, "The halves' precision
#: where the maps disagree" and "P1c: measured, adopted".
SPLIT_PRECISION_TRAVEL: str | None = "any"
#: The defect kinds the program :data:`SPLIT_PRECISION` names may carry all the same: the
#: flags that read from the map's image that the path drew a place twice (``doubled_walls``,
#: a parallel copy; ``superposed``, a turned one), which the halves test against the
#: path's own scans. P1d of docs/validity.md ("The halves against the flags of a place
#: drawn twice", adopted 2026-12-02 on eight generated sets); ``()``: every defect flag
#: stops the pick (P1c, the rule before).
SPLIT_PRECISION_FLAGS: tuple[str, ...] = ("doubled_walls", "superposed")
#: A sequence whose recording has at least this share of scans that see walls in one
#: direction only (docs/spec.md 7c: a corridor) gets a verdict of at most "low" without
#: ground truth: an error along those walls is invisible to the maps' agreement and to
#: their own scans. Read off the generated sets of docs/validity.md ("Scans that see one
#: direction only") and tested on a set generated after it was frozen.
DEGENERATE_SHARE = 0.02
#: In a sequence whose recording has at least :data:`DEGENERATE_SHARE` of its scans seeing
#: walls in one direction, the verdict abstains rather than name a program whose path is
#: this much shorter than another program's (``evidence["algorithms"][a]["shortfall"]``,
#: docs/spec.md 7d): a scan matcher that cannot see the motion along a corridor reports too
#: little of it, and its map still agrees with its own scans. Chosen on the pool of
#: docs/validity.md ("Paths shortened along a corridor").
SHORTFALL = 0.03
#: How the veto reads a program's shortfall along the recording's corridors beyond its
#: shortfall elsewhere (``evidence["algorithms"][a]["corridor_shortfall"]``,
#: :func:`slamq.metrics.travel.corridor_travel_ratio`), so that a difference of scale
#: between programs (one follows the odometry's scale error, another corrects it) is not
#: read as a corridor shortened: ``"both"`` (T2-and, the default) vetoes where it and the
#: whole path's are at least :data:`SHORTFALL`; ``"corridors"`` (T2, not adopted) reads it
#: alone; None the whole path's alone (the rule before 2026-11-30). docs/validity.md,
#: "Paths shortened along the corridors: measured, T2-and adopted".
CORRIDOR_TRAVEL: str | None = "both"

#: The defect kinds that the verdict of two maps takes as proof of a broken map (docs/spec.md
#: section 9, "Two maps, one broken beyond doubt"): none of them flagged a clean real map or
#: an unbroken benchmark map in docs/validity.md's defect study. ``doubled_walls`` is not
#: one: it fires on some sound maps (walls drawn as outlines, doubled graph-SLAM walls).
SEVERE_DEFECTS = ("superposed", "smeared", "fragmented")
#: Whether a defect flag of another kind (``doubled_walls``) on one of two placed maps names
#: the other without its own scans confirming it. False: candidate D1 of docs/validity.md
#: ("Doubled walls alone do not decide two maps").
MILD_DEFECTS_DECIDE = True
#: Whether a ``superposed`` flag is lifted from a map when another program's map of the
#: sequence carries one with the same second wall direction (separations within
#: :data:`SHARED_DIRECTION_DEG`, or :data:`SHARED_DIRECTION_DEG_NO_SCANS`): a direction two
#: programs draw at the same angle is the building's (a wing), not a scan-matching jump.
#: S1 of docs/validity.md ("A second generator the rule was not tuned on: wing worlds"),
#: adopted 2026-12-01; False is the rule before.
SHARED_DIRECTION = True
#: Degrees within which two maps' second wall directions are the same where both maps'
#: programs carry their own scans' crossing share (:data:`SCAN_KEY`): the superposed
#: detector's resolution (about 5 degrees). A lifted map is still judged by its scans.
#: S1a-5s of docs/validity.md ("S1a-5 only where both maps have their scans"); 3 is the
#: rule before.
SHARED_DIRECTION_DEG = 5.0
#: The same without the scans of both (maps alone): 3 degrees, as before. 5 named a broken
#: run there that 3 does not (docs/validity.md, "S1a-5 on the wing sets made once more").
SHARED_DIRECTION_DEG_NO_SCANS = 3.0
#: Whether the map that shares a second wall direction must also agree with the lifted map
#: (their consistency at least the evidence's ``min_support``) for :data:`SHARED_DIRECTION`
#: to lift the flag: two programs that draw the building draw the same walls. S1a of
#: docs/validity.md ("S1a: a second direction lifted only by a map that agrees"), adopted
#: 2026-12-01: without it, a broken map's artefact at the building's angle by chance
#: lifted flags on the real logs. False is S1 as first adopted.
SHARED_DIRECTION_AGREE = True

_BASES = (
    # (column, higher is better, tie-breaker column, tie-breaker higher, confidence)
    ("ate_rmse", False, "gt_f1", True,
     "high: ranked by trajectory error against the ground truth"),
    ("rel_trans_abs_mean", False, "rel_rot_abs_mean", False,
     "high: ranked by the relations error (Kümmerle et al. 2009) against the ground truth"),
    ("gt_f1", True, "gt_chamfer", False,
     "high: ranked by agreement with the ground-truth map"),
    ("corners", False, None, False,
     "low: corners separate broken maps from good ones; they do not order good maps"),
)


def known_share(block: pd.DataFrame) -> dict[str, float]:
    """Each algorithm's mean known area relative to the most complete map of the block
    (``known_area_m2_mean``, or ``known_mean`` when some map has no resolution); empty when
    fewer than two algorithms have it.

    Examples
    --------
    >>> import pandas as pd
    >>> known_share(pd.DataFrame({"known_area_m2_mean": [50.0, 100.0]}, index=["a", "b"]))
    {'a': 0.5, 'b': 1.0}
    """
    def col(name: str) -> pd.Series:
        return pd.to_numeric(block.get(name, pd.Series(dtype=float)), errors="coerce")

    area = col("known_area_m2_mean").dropna()
    known = area if len(area) == len(block) else col("known_mean").dropna()
    if len(known) < 2 or known.max() <= 0:
        return {}
    return {str(a): float(v / known.max()) for a, v in known.items()}


def _means(block: pd.DataFrame, key: str) -> pd.Series:
    col = f"{key}_mean"
    if col not in block:
        return pd.Series(dtype=float)
    values = pd.to_numeric(block[col], errors="coerce")
    return values[np.isfinite(values.to_numpy(dtype=float))]


def _algorithms(summary: pd.DataFrame, sequence: str) -> pd.DataFrame:
    """The summary rows of one sequence, reference maps (ground truths) left out."""
    block = summary.xs(sequence, level="sequence") if len(summary) else summary
    return block.drop(index=[a for a in block.index
                             if str(a).lower() in GROUND_TRUTH_ALGORITHMS])


def _ground_truth_decides(block: pd.DataFrame) -> bool:
    """At least two algorithms have an ATE, a relations error or a GT-map F1: the ground
    truth ranks them."""
    return any(len(_means(block, k)) >= 2 for k, *_ in _BASES[:3])


def _orientation(block: pd.DataFrame) -> Orientation:
    """How the wall angles of ``block``'s algorithms compare (each modulo the period of its
    walls' symmetry; irregular maps and maps of different classes are not compared):
    :func:`slamq.results.summary.orientation`."""
    return orientation([str(a) for a in block.index],
                       block.get("wall_angle_mean", pd.Series(math.nan, index=block.index)),
                       block.get("wall_symmetry"))


def _differences(block: pd.DataFrame) -> tuple[bool, bool]:
    """Whether the maps of ``block`` differ in resolution, and in orientation (two wall
    angles of one symmetry class more than ``ANGLE_TOLERANCE_DEG``, 1 degree, apart modulo
    its period, :func:`_orientation`): then plain corners do not compare."""
    return (len(distinct_resolutions(block.get("resolution_mean", []))) > 1,
            _orientation(block).differ)


def _turned_note(block: pd.DataFrame) -> str:
    """``"; X is turned against the others (wall angle A, the others B-C modulo P)"``
    when the orientation check singles out turned maps among ``block``'s, else ""."""
    o = _orientation(block)
    if not o.turned:
        return ""
    parts = []
    for cls, items in o.angles.items():
        mine = [(n, a) for n, a in items if n in o.turned]
        rest = [a for n, a in items if n not in o.turned]
        if not mine or not rest:
            continue
        shown = ", ".join(f"{n} at {a:.1f}" for n, a in mine)
        parts.append(f"{shown} deg, the others at {min(rest):.1f} to {max(rest):.1f} deg "
                     f"modulo {WALL_PERIODS[cls]:g}")
    verb = "is" if len(o.turned) == 1 else "are"
    return f"; {', '.join(o.turned)} {verb} turned against the others ({'; '.join(parts)})"


def _corner_key(block: pd.DataFrame, names: list[str]) -> tuple[str | None, pd.Series]:
    """The corner column that orders ``names``, the maps the agreement confirms equally:
    plain corners when they share one resolution and orientation (issue 25: "corners only
    break ties between unflagged maps of one resolution and frame"), else None (their
    own scans, else their support, order them); None too when a map has no corner count."""
    part = block.loc[[a for a in names if a in block.index]]
    if any(_differences(part)):
        return None, pd.Series(dtype=float)
    means = _means(part, "corners")
    if len(means) == len(part):
        return "corners", means
    return None, pd.Series(dtype=float)


def scan_limit(crossings: dict[str, float]) -> float:
    """The crossing share above which a map is inconsistent with its own scans:
    ``max(SCAN_FLOOR, SCAN_SHARE x`` the lowest of ``crossings``) (NaN: none).

    Examples
    --------
    >>> scan_limit({"a": 0.01, "b": 0.2}), scan_limit({"a": 0.04, "b": 0.3})
    (0.02, 0.06)
    """
    finite = [v for v in crossings.values() if math.isfinite(v)]
    return max(SCAN_FLOOR, SCAN_SHARE * min(finite)) if finite else math.nan


def _pct(v: float) -> str:
    return f"{100 * v:.1f}%"


class _Shares(dict[str, float]):
    """Each algorithm's figure against its own scans that confirms a map named on them: its
    split share (docs/spec.md 7e) for those in ``split``, else its map's crossing share
    (7b); ``local``: the local shares (7f) of those in ``split`` that have one."""

    def __init__(self, values: dict[str, float], split: set[str],
                 local: dict[str, float] | None = None,
                 hits: dict[str, float] | None = None) -> None:
        super().__init__(values)
        self.split = frozenset(split) & set(values)
        self.local = {a: v for a, v in (local or {}).items() if a in self.split}
        self.hits = {a: v for a, v in (hits or {}).items() if a in self.split}

    def floor(self, a: str) -> float:
        """The figure at most which ``a``'s scans confirm it: :data:`SCAN_FLOOR`, or, with
        :data:`LOCAL_RATIO` set, for a split share with a local share, ``max(SCAN_FLOOR,
        LOCAL_RATIO x`` the lowest local share (:data:`LOCAL_ANCHOR` ``"lowest"``) or its
        own (``"path"``)``)``.

        Examples
        --------
        >>> s = _Shares({"a": 0.01, "b": 0.03}, {"b"}, {"b": 0.025})
        >>> s.floor("b"), s.confirms("b"), s.confirms("a")  # LOCAL_RATIO off (None)
        (0.02, False, True)
        """
        if LOCAL_RATIO is None or a not in self.local:
            return SCAN_FLOOR
        return max(SCAN_FLOOR, LOCAL_RATIO * self._anchor(a))

    def _anchor(self, a: str) -> float:
        return self.local[a] if LOCAL_ANCHOR == "path" else min(self.local.values())

    def confirms(self, a: str) -> bool:
        """Whether ``a``'s own scans confirm it: its figure at most :meth:`floor` and, with
        :data:`SPLIT_MEET`, a split share's halves meeting (:meth:`unmet` empty)."""
        return self[a] <= self.floor(a) and not self.unmet(a)

    def unmet(self, a: str) -> str:
        """Why ``a``'s split share, at most :meth:`floor`, still cannot confirm it ("" when
        it can, or when the figure is above the floor anyway): with :data:`SPLIT_MEET`, its
        split hit share is under the highest of those scored so divided by
        :data:`SCAN_SHARE`.

        Examples
        --------
        >>> s = _Shares({"a": 0.035, "b": 0.011}, {"a", "b"}, hits={"a": 0.055, "b": 0.027})
        >>> print(s.unmet("b"))  # doctest: +NORMALIZE_WHITESPACE
        its halves barely meet: 2.7% of its beams end on the walls the other half draws,
        against 5.5% for a's path
        >>> s.confirms("b"), s.unmet("a")
        (False, '')
        """
        if (not SPLIT_MEET or a not in self.hits or len(self.hits) < 2
                or self[a] > self.floor(a)):
            return ""
        top = max(self.hits, key=lambda b: (self.hits[b], b))
        if self.hits[a] * SCAN_SHARE >= self.hits[top]:
            return ""
        return (f"its halves barely meet: {_pct(self.hits[a])} of its beams end on the "
                f"walls the other half draws, against {_pct(self.hits[top])} for {top}'s "
                "path")

    def not_confirming(self, a: str, whose: str = "its") -> str:
        """Why ``a``'s figure does not confirm it, as a sentence says it (``a`` not
        confirmed)."""
        if unmet := self.unmet(a):
            return f"{self.said(a, whose)}, but {unmet}"
        return f"{self.said(a, whose)}, more than {self.limit_said(a)}"

    def limit_said(self, a: str) -> str:
        """:meth:`floor` as a sentence says it.

        Examples
        --------
        >>> _Shares({"b": 0.05}, {"b"}, {"b": 0.025}).limit_said("b")  # LOCAL_RATIO off
        '2.0%'
        """
        floor = self.floor(a)
        if floor > SCAN_FLOOR:
            where = ("its path" if LOCAL_ANCHOR == "path" or self._anchor(a) == self.local[a]
                     else "the most consistent path")
            return (f"{_pct(floor)} ({LOCAL_RATIO:g}x what the scans cross within short "
                    f"stretches of {where}, {_pct(self._anchor(a))})")
        return _pct(SCAN_FLOOR)

    def said(self, a: str, whose: str = "its") -> str:
        """The figure of ``a`` as a sentence says it, naming which figure it is.

        Examples
        --------
        >>> s = _Shares({"a": 0.01, "b": 0.3}, {"b"})
        >>> s.said("a")
        '1.0% of its beams cross its walls'
        >>> s.said("b", "b's")
        "30.0% of b's beams cross the walls its scans draw in the other half of the run"
        """
        if a in self.split:
            return (f"{_pct(self[a])} of {whose} beams cross the walls its scans draw in "
                    "the other half of the run")
        return f"{_pct(self[a])} of {whose} beams cross its walls"

    def basis(self) -> list[str]:
        """The evidence fields the figures come from (none without scans)."""
        return ([SCAN_KEY] if self else []) + ([SPLIT_KEY] if self.split else [])


def _finite(info: dict[str, Any], key: str) -> dict[str, float]:
    """Each algorithm's evidence field ``key``, where it is a finite number."""
    values = {a: float(e.get(key, math.nan)) for a, e in info.items()}
    return {a: v for a, v in values.items() if math.isfinite(v)}


def _scan_flags(info: dict[str, Any]) -> tuple[_Shares, dict[str, str]]:
    """Each algorithm's figure against its own scans (:class:`_Shares`), and the reason of
    those above :func:`scan_limit` of the maps' crossing shares or of the paths' split
    shares (the first one found)."""
    crossing = _finite(info, SCAN_KEY)
    limit = scan_limit(crossing)
    lowest = min(crossing.values()) if crossing else math.nan
    flags = {a: (f"inconsistent with its own scans ({_pct(v)} of its beams cross its "
                 f"walls, the most consistent map's {_pct(lowest)})")
             for a, v in crossing.items() if v > limit}
    split = _finite(info, SPLIT_KEY)
    limit = scan_limit(split)
    for a, v in split.items():
        if v > limit:
            flags.setdefault(a, f"its path is inconsistent with its own scans split in time "
                                f"({_pct(v)} of its beams cross the walls its scans draw in "
                                f"the other half of the run, the lowest "
                                f"{_pct(min(split.values()))})")
    return _Shares({a: split.get(a, v) for a, v in crossing.items()},
                   {a for a in crossing if a in split}, _finite(info, LOCAL_KEY),
                   _finite(info, SPLIT_HIT_KEY)), flags


def one_direction_share(evidence: dict[str, Any]) -> float | None:
    """The sequence's degenerate share (``evidence["degenerate_share"]``, docs/spec.md 7c)
    when it is at least :data:`DEGENERATE_SHARE`, the condition under which the verdict
    caps its confidence and weighs the paths' shortfalls; None otherwise.

    Examples
    --------
    >>> one_direction_share({"degenerate_share": 0.05}), one_direction_share({})
    (0.05, None)
    """
    share = float(evidence.get("degenerate_share", math.nan))
    return share if math.isfinite(share) and share >= DEGENERATE_SHARE else None


def _shortened(info: dict[str, Any], evidence: dict[str, Any]) -> dict[str, str]:
    """The programs whose path is at least :data:`SHORTFALL` shorter than another's, with
    the reason, when the recording's scans see walls in one direction
    (:func:`one_direction_share`); none otherwise."""
    share = one_direction_share(evidence)
    if share is None:
        return {}
    out = {}
    for a, e in info.items():
        whole = float(e.get("shortfall", math.nan))
        said = f"its path is {_pct(whole)} shorter than {e.get('shortfall_against')}'s"
        if CORRIDOR_TRAVEL and "corridor_shortfall" in e:
            along = float(e["corridor_shortfall"])
            beyond = (f"{_pct(along)} shorter than {e.get('corridor_shortfall_against')}'s "
                      "along the corridors, beyond their difference elsewhere,")
            if not math.isfinite(along):
                pass  # no figure along the corridors: the whole path's
            elif CORRIDOR_TRAVEL == "both":
                whole, said = min(whole, along), f"{said}, and {beyond}"
            else:
                whole, said = along, f"its path is {beyond}"
        if math.isfinite(whole) and whole >= SHORTFALL:
            out[a] = (f"{said} where {_pct(share)} of the scans see walls in one direction "
                      "only: a corridor shortened by a scan matcher that could not see along "
                      "it")
    return out


def _separating(a: str, flagged: dict[str, str], scan_flags: dict[str, str],
                partial: set[str]) -> str | None:
    """What is wrong with map ``a`` on its own (a defect flag, its own scans, partial), which
    can tell two maps apart; None when nothing is."""
    reasons = [flagged[a]] if flagged.get(a, "").startswith("defects") else []
    reasons += [scan_flags[a]] if a in scan_flags else []
    reasons += ["a partial map"] if a in partial else []
    return "; ".join(reasons) or None


def superposed_separations(e: dict[str, Any]) -> list[float]:
    """The second-direction separations (degrees) of an algorithm's ``superposed`` flags
    (``e``: its evidence entry).

    Examples
    --------
    >>> superposed_separations({"defects": {"m": [{"kind": "superposed", "separation": 31.0},
    ...                                           {"kind": "smeared"}]}})
    [31.0]
    """
    return [v for _, v in _superposed_flags(e)]


def _superposed_flags(e: dict[str, Any]) -> list[tuple[str, float]]:
    """``(map path, separation)`` of each of an algorithm's ``superposed`` flags that
    carries a separation (``e``: its evidence entry)."""
    return [(str(p), float(d["separation"])) for p, ds in e.get("defects", {}).items()
            for d in ds if d.get("kind") == "superposed" and d.get("separation") is not None]


def shared_directions(info: dict[str, Any], evidence: dict[str, Any] | None = None
                      ) -> dict[str, dict[float, str]]:
    """Per algorithm (``info``: the evidence's ``algorithms``), the separations of its
    ``superposed`` flags that another algorithm's flag shares (within
    :data:`SHARED_DIRECTION_DEG` where both carry their own scans' crossing share, else
    :data:`SHARED_DIRECTION_DEG_NO_SCANS`), each with the first such algorithm (by name): the
    flags :data:`SHARED_DIRECTION` lifts (docs/spec.md section 9). Empty when it is False. With
    :data:`SHARED_DIRECTION_AGREE`, the sharing map must also agree with the flagged one
    (``evidence``'s ``consistency`` at least its ``min_support``; no evidence, no lift).

    Examples
    --------
    >>> flag = lambda m, s: {m: [{"kind": "superposed", "separation": s}]}
    >>> info = {"a": {"defects": flag("a.pgm", 31.0)}, "b": {"defects": flag("b.pgm", 32.5)},
    ...         "c": {"defects": flag("c.pgm", 12.0)}}
    >>> ev = {"min_support": 0.6, "consistency": {"a.pgm": {"b.pgm": 0.9}, "b.pgm": {"a.pgm": 0.9}}}
    >>> shared_directions(info, ev)
    {'a': {31.0: 'b'}, 'b': {32.5: 'a'}}
    >>> ev["consistency"] = {"a.pgm": {"b.pgm": 0.3}, "b.pgm": {"a.pgm": 0.3}}
    >>> shared_directions(info, ev)   # the same angle by chance on maps that disagree
    {}
    >>> ev["consistency"] = {"a.pgm": {"b.pgm": 0.9}, "b.pgm": {"a.pgm": 0.9}}
    >>> info["b"]["defects"] = flag("b.pgm", 35.5)          # 4.5 degrees apart
    >>> shared_directions(info, ev)                          # maps alone: within 3
    {}
    >>> for e in info.values():
    ...     e["scan_crossing"] = 0.01
    >>> shared_directions(info, ev)                          # both with their scans: within 5
    {'a': {31.0: 'b'}, 'b': {35.5: 'a'}}
    """
    if not SHARED_DIRECTION:
        return {}
    cons = (evidence or {}).get("consistency", {})
    floor = float((evidence or {}).get("min_support", SETTINGS.min_support.default))

    def agree(p: str, q: str) -> bool:
        if not SHARED_DIRECTION_AGREE:
            return True
        c = cons.get(p, {}).get(q)
        return c is not None and math.isfinite(float(c)) and float(c) >= floor

    scanned = _finite(info, SCAN_KEY)

    def margin(a: str, b: str) -> float:
        both = a in scanned and b in scanned
        return SHARED_DIRECTION_DEG if both else SHARED_DIRECTION_DEG_NO_SCANS

    seps = {a: _superposed_flags(e) for a, e in info.items()}
    out: dict[str, dict[float, str]] = {}
    for a, mine in seps.items():
        for p, v in mine:
            b = next((b for b in sorted(seps) if b != a and any(
                abs(v - w) <= margin(a, b) and agree(p, q) for q, w in seps[b])), None)
            if b is not None:
                out.setdefault(a, {})[v] = b
    return out


def _building_directions(info: dict[str, Any], warnings: list[str],
                         evidence: dict[str, Any] | None = None) -> dict[str, Any]:
    """``info`` with the ``superposed`` flags :func:`shared_directions` finds lifted, each
    entry's ``flagged_runs`` counted again; a warning says which and why."""
    out = dict(info)
    for a, lifted in shared_directions(info, evidence).items():
        e = info[a]
        defects = {path: [d for d in ds if not (d.get("kind") == "superposed"
                                                and d.get("separation") in lifted)]
                   for path, ds in e.get("defects", {}).items()}
        out[a] = dict(e, defects=defects,
                      flagged_runs=sum(1 for ds in defects.values() if ds))
        v, b = next(iter(lifted.items()))
        warnings.append(f"{a}'s second wall direction ({v:.0f} deg from the first) is drawn "
                        f"by {b}'s map too"
                        + (", which agrees with it" if SHARED_DIRECTION_AGREE else "")
                        + ": the building's, not held against it")
    return out


def _defects_held(e: dict[str, Any]) -> list[str]:
    """The defect kinds held against an algorithm (``e``: its evidence entry): every kind
    found on its runs when at least half of them carry a flag; none otherwise."""
    if not (e["flagged_runs"] and 2 * e["flagged_runs"] >= e["runs"]):
        return []
    return sorted({d["kind"] for ds in e["defects"].values() for d in ds})


def _severe(kinds: list[str]) -> bool:
    """Whether ``kinds`` (held against a map) hold a :data:`SEVERE_DEFECTS` kind."""
    return any(k in SEVERE_DEFECTS for k in kinds)


def _severe_kinds(e: dict[str, Any]) -> list[str]:
    """The :data:`SEVERE_DEFECTS` found on at least half of an algorithm's runs, sorted."""
    runs = max(int(e.get("runs", 1)), 1)
    per_run = [{d["kind"] for d in ds} for ds in e.get("defects", {}).values()]
    return sorted(k for k in SEVERE_DEFECTS if 2 * sum(k in ks for ks in per_run) >= runs)


def _one_broken(sequence: str, info: dict[str, Any], scans: _Shares,
                scan_flags: dict[str, str], warnings: list[str]) -> dict[str, Any] | None:
    """Of two maps, the verdict naming X when the other, Y, carries a severe defect
    (:data:`SEVERE_DEFECTS`) and X no defect at all and no veto of its own scans; placed or
    not, and whatever X's area against Y's (Y's copies count as area). None otherwise."""
    if len(info) != 2:
        return None
    severe = {a: _severe_kinds(e) for a, e in info.items()}
    broken = [a for a, k in severe.items() if k]
    if len(broken) != 1:
        return None
    y = broken[0]
    x = next(a for a in info if a != y)
    if _defects_held(info[x]) or x in scan_flags:
        return None
    why = ", ".join(severe[y])
    placed = info[x]["placed"] and info[y]["placed"]
    confidence = (f"low: two maps; {y} is broken on its own (defects: {why}, a kind the "
                  f"defect study found on no sound map) and {x} carries no defect flag"
                  + _own_scans(x, y, scans)
                  + ("" if placed else "; the two could not be laid over each other, "
                     "as a broken map does not register with a sound one"))
    out = list(warnings)
    out.append(f"{y} is never named best: defects: {', '.join(_defects_held(info[y]))}")
    return {"sequence": str(sequence), "best": x, "ranking": [x, y],
            "basis": ["defects"] + scans.basis(),
            "confidence": confidence, "warnings": out}


def _own_scans(x: str, y: str, scans: _Shares) -> str:
    """What ``x``'s own scans say of the map named of two (``y`` the other), to append to
    the confidence: "consistent" only when its figure (:class:`_Shares`) is at most
    :data:`SCAN_FLOOR` (:meth:`_Shares.floor`); above that, the two figures (``x`` is
    within the veto's limit, :func:`scan_limit`, but its scans do not confirm it); ""
    without scans.

    Examples
    --------
    >>> _own_scans("a", "b", _Shares({"a": 0.01, "b": 0.3}, set()))
    ', consistent with its own scans (1.0% of its beams cross its walls)'
    >>> print(_own_scans("a", "b", _Shares({"a": 0.01, "b": 0.3}, {"a", "b"})))
    ... # doctest: +NORMALIZE_WHITESPACE
    , its path consistent with its own scans split in time (1.0% of its beams cross the
    walls its scans draw in the other half of the run)
    >>> _own_scans("a", "b", _Shares({"a": 0.15, "b": 0.2}, set()))[:60]
    "; its own scans do not confirm it: 15.0% of a's beams cross "
    >>> _own_scans("a", "b", _Shares({}, set()))
    ''
    """
    if x not in scans:
        return ""
    if scans.confirms(x):
        if x in scans.split:
            return (", its path consistent with its own scans split in time "
                    f"({scans.said(x)})")
        return f", consistent with its own scans ({scans.said(x)})"
    # the other's figure only when it is the same figure
    same = y in scans and (y in scans.split) == (x in scans.split)
    theirs = f" ({y}'s {_pct(scans[y])})" if same else ""
    whose = f"{x}'s"
    if unmet := scans.unmet(x):  # within the floor, its halves barely meet
        return (f"; its own scans do not confirm it: {scans.said(x, whose)}{theirs}, but "
                f"{unmet}")
    return (f"; its own scans do not confirm it: {scans.said(x, whose)}{theirs}, more than "
            f"the {scans.limit_said(x)} that would")


def _undecided_pair(info: dict[str, Any], partial: set[str], scans: bool) -> str:
    """Why two maps without their scans were not told apart, and what would tell them
    apart ("; ..." to append to the verdict's reason)."""
    kinds = {a: _defects_held(e) for a, e in info.items()}
    flagged = sorted(a for a, k in kinds.items() if k)
    if len(flagged) == 2:
        out = "; both carry a defect flag (" + "; ".join(
            f"{a}: {', '.join(kinds[a])}" for a in flagged) + ")"
    elif flagged:
        a = flagged[0]
        b = next(x for x in info if x != a)
        held = ([] if info[a]["placed"] and info[b]["placed"] else ["the two are not placed"]
                ) + ([f"{b} is partial"] if b in partial else [])
        if not MILD_DEFECTS_DECIDE and not _severe(kinds[a]):
            out = (f"; {a} carries {', '.join(kinds[a])}, which is found on sound maps too: "
                   f"it names {b} of two only when {b}'s own scans confirm it")
        else:
            out = (f"; {a} carries {', '.join(kinds[a])}, which decides two maps only when "
                   "both are placed and the other is not partial"
                   + (f", and {' and '.join(held)}" if held else ""))
    else:
        out = "; neither carries a defect flag"
    if not scans:
        out += "; each map's own scans (its recording and trajectory) could tell them apart"
    return out


def _agreement_verdict(block: pd.DataFrame, sequence: str, evidence: dict[str, Any],
                       warnings: list[str]) -> dict[str, Any]:
    """The verdict without ground truth, from the maps' agreement, defect flags and their
    own scans."""
    info = {str(a): e for a, e in evidence["algorithms"].items() if a in block.index}
    warnings.extend(evidence.get("notes", []))
    info = _building_directions(info, warnings, evidence)
    flagged: dict[str, str] = {}
    for a, e in info.items():
        if not e["placed"]:
            flagged[a] = "could not be registered with the other maps"
        elif kinds := _defects_held(e):
            flagged[a] = f"defects: {', '.join(kinds)}"
    scans, scan_flags = _scan_flags(info)
    for a, why in scan_flags.items():
        flagged.setdefault(a, why)
    one_broken = _one_broken(sequence, info, scans, scan_flags, warnings)
    if one_broken is not None:  # two maps, one broken beyond doubt (spec section 9)
        return one_broken
    support = {a: e["support"] for a, e in info.items() if math.isfinite(e["support"])}
    complete = {a: e["completeness"] for a, e in info.items()
                if math.isfinite(e["completeness"])}
    # no majority agrees, but an agreeing group of two or more programs does: the maps
    # outside it confirm nothing, and the named map comes from the group (spec section 9)
    group = [a for a in evidence.get("group", []) if a in support]
    by_group = not evidence["majority"] and len(support) >= 3 and len(group) >= 2
    gsup = {a: info[a].get("group_support", math.nan) for a in group}
    if by_group:
        support_of = {a: v for a, v in gsup.items() if math.isfinite(v)}
        for a in support:
            if a not in flagged and a not in group:
                flagged[a] = "not in the group of maps that agree with each other"
    else:
        support_of = support
    top = max(support_of.values()) if support_of else math.nan
    for a, v in support_of.items():
        if a not in flagged and v < AGREEMENT_SHARE * top:
            flagged[a] = (f"its walls disagree with the other maps (support {v:.2f}, best "
                          f"{top:.2f})")
    most = max(complete.values()) if complete else math.nan
    partial: set[str] = set()
    for a, v in complete.items():
        if v < COMPLETE_SHARE * most:
            partial.add(a)
            warnings.append(f"{a}'s map knows {100 * v / most:.0f}% of the area the other "
                            "maps agree exists: a partial map, never named best")
    for a in sorted(flagged):
        warnings.append(f"{a} is never named best: {flagged[a]}")
    candidates = sorted((a for a in support_of if a not in flagged and a not in partial),
                        key=lambda a: (-support_of[a], a))
    key, corners = _corner_key(block, candidates)
    if key is not None and len(candidates) > 1:
        candidates.sort(key=lambda a: (float(corners[a]), a))
    # where corners leave no clear winner, the maps' own scans order the tied ones
    close = _within_margin(candidates, corners) if key is not None else []
    tied = _scan_tie_order(close, scans)
    if tied:
        candidates = tied + [a for a in candidates if a not in tied]
    # where corners cannot compare them, their own scans order them (support before)
    by_scans = (_scan_tie_order(candidates, scans)
                if SCANS_ORDER_UNCOMPARABLE and key is None else [])
    if by_scans:
        candidates = by_scans
    rest = sorted((a for a in support if a not in candidates),
                  key=lambda a: (a in flagged, -support[a], a))
    # maps that could not be placed (no support figure) are flagged: ranked last
    unplaced = sorted(a for a in info if a not in support and a in flagged)
    ranking = candidates + rest + unplaced
    unranked = sorted(str(a) for a in block.index
                      if str(a) not in support and str(a) not in unplaced)
    if unranked:
        warnings.append(f"not ranked, no agreement figure: {', '.join(unranked)}")
    basis = ["agreement"] + scans.basis() + (
        [key] if key and len(candidates) > 1 else [])
    alone = {a: _separating(a, flagged, scan_flags, partial) for a in info}
    why = None
    defect_decides = len(support) == 2 and len(candidates) == 1 and any(
        flagged.get(a, "").startswith("defects")
        and (MILD_DEFECTS_DECIDE or _severe(_defects_held(info[a]))) for a in support)
    if len(support) < 3 and len(info) == 2 and len(scans) == 2 and not defect_decides:
        # two maps, each scored against its own scans (item 5 of issue 41): one is named
        # when the other is wrong on its own (vetoed by its scans, or partial) and it is
        # not, and its own scans confirm it; a defect flag decides as without scans (below)
        named = [a for a in info if alone[a] is None]
        if len(named) == 1:
            x = named[0]
            y = next(a for a in info if a != x)
            # (at most the other's: two runs on one path have the same split share)
            if scans.confirms(x) and scans[x] <= scans[y]:
                return _two_maps(sequence, x, y, alone[y] or "", scans, basis, warnings)
            unmet = scans.unmet(x)
            why = (f"fewer than three maps take part: {y} is wrong on its own ({alone[y]}), "
                   f"but {x}'s own scans do not confirm it ({scans.said(x)}"
                   + (f", but {unmet}" if unmet else
                      f"; a map named of two needs at most {scans.limit_said(x)} and no "
                      "more than the other's") + ")")
        elif named:
            why = ("fewer than three maps take part: two maps that differ cannot tell which "
                   "of them is right, and neither is wrong on its own (a defect flag, a "
                   "partial map, or inconsistent with its own scans)")
        else:
            why = ("fewer than three maps take part, and both are wrong on their own: "
                   + "; ".join(f"{a}: {alone[a]}" for a in sorted(info)))
    elif len(support) < 3:
        why = ("fewer than three maps take part: two maps that differ cannot tell which "
               "of them is right") + (_undecided_pair(info, partial, bool(scans))
                                       if len(info) == 2 else "")
        if defect_decides:
            why = None  # one map is flagged on its own: the other is named
    elif not evidence["majority"] and not by_group:
        if len(scans) == len(info):
            return _by_scans(sequence, info, scans, scan_flags, alone, warnings, flagged)
        why = ("the maps disagree among themselves (most of them are not confirmed by the "
               "others, and no two programs' maps agree with each other): the evidence does "
               "not say which is right")
    if why is None and not candidates:
        why = "every map is flagged or partial"
        halves = _by_halves(sequence, info, flagged, warnings,
                            "no map is both confirmed and complete")
        if halves is not None:
            return halves
    if why is not None:
        return {"sequence": str(sequence), "best": None, "ranking": ranking,
                "basis": basis, "confidence": f"none: {why}", "warnings": warnings}
    if defect_decides:  # two maps, one flagged by a defect detector: low, as spec 9 says
        other = next(a for a in support if a != candidates[0])
        v = _two_maps(sequence, candidates[0], other, flagged[other], scans,
                      ["defects"] + scans.basis(), warnings)
        return {**v, "ranking": ranking}
    confidence = ("medium: no ground truth; the maps confirm each other, and the named map "
                  "is confirmed by them and has no defect flag")
    if by_group:
        others = sorted(a for a in support if a not in group)
        confidence = (f"low: no ground truth and no majority; {', '.join(group)} agree with "
                      f"each other (every pair's consistency at least "
                      f"{evidence.get('min_support', 0.6):g}) while "
                      f"{', '.join(others) or 'no other map'} do not agree with all of them; "
                      "the named map comes from that group and has no defect flag")
    if key is None and len(candidates) > 1:
        order = ("their own scans order them: " + ", ".join(
            scans.said(a, f"{a}'s") for a in by_scans[:2])) if by_scans else (
            "their support orders them")
        confidence += (f"; the {len(candidates)} maps they confirm equally differ in "
                       "resolution or orientation, so corners cannot compare them: "
                       + order
                       + _turned_note(block.loc[[a for a in candidates if a in block.index]]))
    if key is not None and len(candidates) > 1 and tied:
        first, second = (scans.said(a, f"{a}'s") for a in tied[:2])
        confidence += (f"; among the {len(candidates)} maps they confirm equally, {key} "
                       f"leave no clear winner ({', '.join(tied)} within "
                       f"{int(CLEAR_MARGIN * 100)}% of the fewest: "
                       f"{', '.join(f'{float(corners[a]):g}' for a in tied)}), so their own "
                       f"scans order them: {first}, {second}")
    elif key is not None and len(candidates) > 1:
        confidence += (f"; among the {len(candidates)} maps they confirm equally, {key} "
                       "decide")
        if len(close) > 1:
            first, second = float(corners[close[0]]), float(corners[close[1]])
            confidence += (f"; no clear winner: {close[0]} and {close[1]} are within "
                           f"{int(CLEAR_MARGIN * 100)}% ({first:g} and {second:g})")
    return {"sequence": str(sequence), "best": candidates[0], "ranking": ranking,
            "basis": basis, "confidence": confidence, "warnings": warnings}


def _within_margin(names: list[str], counts: pd.Series) -> list[str]:
    """Of ``names`` (fewest ``counts`` first), those within :data:`CLEAR_MARGIN` of the
    first's count: two or more mean no clear winner.

    Examples
    --------
    >>> _within_margin(["a", "b", "c"], pd.Series({"a": 100.0, "b": 110.0, "c": 200.0}))
    ['a', 'b']
    """
    if not names:
        return []
    fewest = float(counts[names[0]])
    return [a for a in names if float(counts[a]) <= fewest * (1 + CLEAR_MARGIN)]


def _scan_tie_order(close: list[str], scans: _Shares) -> list[str]:
    """The maps corners leave without a clear winner (``close``: :func:`_within_margin`
    of the candidates, in corners order; or every confirmed map, in support order, where
    corners cannot compare them) ordered by their figure against their own scans,
    lower first (ties keep the corners order), when there are two or more and each has the
    same kind of figure (all a split share, or all a crossing share); else ``[]``. Off
    (:data:`SCANS_BREAK_TIES` false): ``[]``.

    Examples
    --------
    >>> _scan_tie_order(["a", "b"], _Shares({"a": 0.02, "b": 0.01, "c": 0.0}, {"a", "b"}))
    ['b', 'a']
    >>> _scan_tie_order(["a", "b"], _Shares({"a": 0.02, "b": 0.01}, {"b"}))
    []
    """
    if not SCANS_BREAK_TIES or len(close) < 2:
        return []
    if not all(a in scans and math.isfinite(scans[a]) for a in close):
        return []
    if len({a in scans.split for a in close}) > 1:  # a split share against a crossing one
        return []
    return sorted(close, key=lambda a: scans[a])  # stable: ties keep the corners order


def _short_path(v: dict[str, Any], evidence: dict[str, Any]) -> dict[str, Any]:
    """``v`` as an abstention when the map it names has a path at least :data:`SHORTFALL`
    shorter than another program's (over the whole run and, as :data:`CORRIDOR_TRAVEL`
    says, along the corridors) in a recording whose scans see walls in one direction
    (:func:`_shortened`): which of the two paths is right, the scans cannot tell. Nothing
    else is named in its place."""
    best = v["best"]
    why = _shortened(evidence["algorithms"], evidence).get(str(best))
    if best is None or why is None:
        return v
    if (spared := travel_spared(evidence["algorithms"], str(best), v["basis"])) is not None:
        v["warnings"].append(
            f"{best} is named although {why.split(' where ')[0].rstrip(',')}: {spared}")
        return v
    return {**v, "best": None, "confidence": f"none: {best} would be named, but {why}"}


def _one_direction(v: dict[str, Any], evidence: dict[str, Any]) -> dict[str, Any]:
    """``v`` with its confidence at most "low" when the sequence's recording has at least
    :data:`DEGENERATE_SHARE` of its scans seeing walls in one direction only
    (``evidence["degenerate_share"]``): a "medium" becomes "low" with the reason; any
    other verdict gets the reason as a warning."""
    share = one_direction_share(evidence)
    if share is None:
        return v
    why = (f"{_pct(share)} of the recording's scans see walls in one direction only (a "
           "corridor): an error along them is invisible to the maps' agreement and to "
           "their own scans")
    if v["best"] is not None and v["confidence"].startswith("medium:"):
        v["confidence"] = "low:" + v["confidence"].removeprefix("medium:") + f"; {why}"
    else:
        v["warnings"].append(why)
    return v


def halves_miss(split: float, hit: float) -> float:
    """Of the beams with which a path's two halves meet each other's walls (ending on them,
    the split hit share ``hit``, or crossing them, the split share ``split``), the share
    that cross: ``split / (split + hit)`` (NaN when neither).

    Examples
    --------
    >>> round(halves_miss(0.05, 0.35), 3), halves_miss(0.0, 0.0)
    (0.125, nan)
    """
    total = split + hit
    return split / total if total > 0 else math.nan


def travel_spared(info: dict[str, Any], alg: str, basis: Sequence[str] = ()) -> str | None:
    """Why the travel veto does not hold ``alg``'s shorter path against it, as
    :data:`SPLIT_PRECISION_TRAVEL` says: ``"any"`` (P1c), its halves set it apart
    (:func:`halves_apart`); ``"halves"`` (P1b), the verdict naming it read the halves
    (:data:`SPLIT_HIT_KEY` in its ``basis``). Every other path is then torn and none is a
    reference for how far the robot went. None when the veto holds.

    Examples
    --------
    >>> info = {a: {"scan_split": s, "split_hit": h} for a, s, h in
    ...         [("a", 0.06, 0.35), ("b", 0.13, 0.14), ("c", 0.09, 0.03)]}
    >>> print(travel_spared(info, "a"))  # doctest: +NORMALIZE_WHITESPACE
    every other path's halves cross each other's walls at least 1.5x as often where they
    meet, so none of them says how far the robot went
    >>> print(travel_spared(info, "b"))
    None
    """
    if not ((SPLIT_PRECISION_TRAVEL == "any" and halves_apart(info) == alg)
            or (SPLIT_PRECISION_TRAVEL == "halves" and SPLIT_HIT_KEY in basis)):
        return None
    return (f"every other path's halves cross each other's walls at least {SCAN_SHARE:g}x "
            "as often where they meet, so none of them says how far the robot went")


def halves_apart(info: dict[str, Any]) -> str | None:
    """The program whose path's halves cross each other's walls the least where they meet
    (:func:`halves_miss` of its split share and split hit share), when that share is at
    most every other program's divided by :data:`SCAN_SHARE`; None when fewer than three
    programs take part, any lacks the figure, or none is so far apart.

    Examples
    --------
    >>> info = {a: {"scan_split": s, "split_hit": h} for a, s, h in
    ...         [("a", 0.06, 0.35), ("b", 0.13, 0.14), ("c", 0.09, 0.03)]}
    >>> halves_apart(info)
    'a'
    >>> info["b"]["split_hit"] = 0.6
    >>> print(halves_apart(info))
    None
    """
    miss = halves_misses(info)
    if len(miss) < 3 or not all(math.isfinite(v) for v in miss.values()):
        return None
    x, y = sorted(miss, key=lambda a: (miss[a], a))[:2]
    return x if miss[x] * SCAN_SHARE <= miss[y] else None


def halves_misses(info: dict[str, Any]) -> dict[str, float]:
    """Each program's :func:`halves_miss` from its evidence entry (NaN without the figures).

    Examples
    --------
    >>> halves_misses({"a": {"scan_split": 0.1, "split_hit": 0.3}, "b": {}})
    {'a': 0.25, 'b': nan}
    """
    return {a: halves_miss(float(e.get(SPLIT_KEY, math.nan)),
                           float(e.get(SPLIT_HIT_KEY, math.nan))) for a, e in info.items()}


def _by_halves(sequence: str, info: dict[str, Any], flagged: dict[str, str],
               warnings: list[str], why: str) -> dict[str, Any] | None:
    """With :data:`SPLIT_PRECISION`, the verdict that names the program the halves set
    apart (:func:`halves_apart`) when its maps are placed, carry no defect flag (but those
    of :data:`SPLIT_PRECISION_FLAGS`) and its halves meet (:data:`SPLIT_MEET`); None when
    it names none (``why``: what the verdict
    would abstain for, as its sentence begins)."""
    x = halves_apart(info) if SPLIT_PRECISION else None
    if x is None:
        return None
    hits = {a: float(e[SPLIT_HIT_KEY]) for a, e in info.items()}
    held = set(_defects_held(info[x])) if flagged.get(x, "").startswith("defects") else set()
    if (not info[x]["placed"] or held - set(SPLIT_PRECISION_FLAGS)
            or (SPLIT_MEET and hits[x] * SCAN_SHARE < max(hits.values()))):
        return None
    miss = halves_misses(info)
    order = sorted(info, key=lambda a: (miss[a], a))
    y = order[1]
    lifted = [w for w in warnings if w.startswith((f"{x}'s map knows", f"{x} is never named"))]
    out = [w for w in warnings if w not in lifted]
    if lifted:
        out.append(f"{x} is named on its halves all the same (" + "; ".join(lifted)
                   + "): where the maps disagree, the area they agree exists and the share "
                   "of beams crossing walls do not tell a right path from a torn one"
                   + ("; and a place its map seems to draw twice is not one its path "
                      "visited twice apart, as its halves agree where they meet"
                      if held else ""))
    confidence = (f"low: no ground truth and {why}; where each path's two halves meet each "
                  f"other's walls, {x}'s cross them the least ({_pct(miss[x])} of those "
                  f"beams cross rather than end on them; {hits[x]:.1%} end on them), "
                  f"at least {SCAN_SHARE:g}x fewer than any other path's (next {y}, "
                  f"{_pct(miss[y])})")
    return {"sequence": str(sequence), "best": x, "ranking": order,
            "basis": [SCAN_KEY, SPLIT_KEY, SPLIT_HIT_KEY], "confidence": confidence,
            "warnings": out}


def _two_maps(sequence: str, named: str, other: str, why: str, scans: _Shares,
              basis: list[str], warnings: list[str]) -> dict[str, Any]:
    """The verdict on two maps when one of them is wrong on its own and the other is not."""
    confidence = (f"low: two maps; {other} is wrong on its own ({why}) and {named} is not "
                  "(no defect flag, not partial)" + _own_scans(named, other, scans))
    return {"sequence": str(sequence), "best": named, "ranking": [named, other],
            "basis": basis, "confidence": confidence, "warnings": warnings}


def _by_scans(sequence: str, info: dict[str, Any], scans: _Shares,
              scan_flags: dict[str, str], alone: dict[str, str | None],
              warnings: list[str], flagged: dict[str, str]) -> dict[str, Any]:
    """Maps that disagree among themselves, each with its own scans: ordered by their
    figure (:class:`_Shares`); the first named when another map is inconsistent with its
    own scans, the first is not wrong on its own and its own scans confirm it (a figure of
    at most :data:`SCAN_FLOOR`); else, with :data:`SPLIT_PRECISION`, as
    :func:`_by_halves` says."""
    order = sorted(info, key=lambda a: (alone[a] is not None, scans[a], a))
    first = order[0]
    best = first if (scan_flags and alone[first] is None
                     and scans.confirms(first)) else None
    basis = scans.basis()
    if best is None and (halves := _by_halves(sequence, info, flagged, warnings,
                                              "the maps disagree among themselves")):
        return halves
    if best is None:
        why = ("the maps disagree among themselves and their own scans do not separate them "
               + ("(no map is inconsistent with its scans)" if not scan_flags else
                  "(every map is wrong on its own)" if alone[first] is not None else
                  f"(the most consistent of the maps not wrong on their own, {first}: "
                  f"{scans.not_confirming(first)})"))
        return {"sequence": str(sequence), "best": None, "ranking": order, "basis": basis,
                "confidence": f"none: {why}", "warnings": warnings}
    bad = sorted(scan_flags)
    confidence = (f"low: no ground truth and the maps disagree among themselves; {best} is "
                  f"the most consistent with its own scans ({scans.said(best)}) and has "
                  f"no defect flag, while "
                  f"{', '.join(bad)} {'is' if len(bad) == 1 else 'are'} inconsistent with "
                  "their own")
    return {"sequence": str(sequence), "best": best, "ranking": order, "basis": basis,
            "confidence": confidence, "warnings": warnings}


def sequence_verdict(summary: pd.DataFrame, sequence: str,
                     evidence: dict[str, Any] | None = None) -> dict[str, Any]:
    """The verdict on one sequence of a report summary.

    Parameters
    ----------
    summary : pandas.DataFrame
        :func:`slamq.verdict.ranking.summarize` output (index sequence, algorithm).
    sequence : str
    evidence : dict, optional
        :func:`slamq.verdict.evidence.sequence_evidence` of the sequence: without ground
        truth, the verdict then rests on the maps' agreement and defect flags. Without it,
        on corners alone (low confidence).

    Returns
    -------
    dict
        ``{"sequence", "best", "ranking", "basis", "confidence", "warnings",
        "confidence_calibration"}``: ``best`` is an algorithm or None, ``ranking`` the
        ranked algorithms best first, ``basis`` the columns used, ``warnings`` plain
        sentences. A map named without ground truth (with ``evidence``) at a level whose
        record was measured ("medium", "low") has that record right after the level in
        ``confidence`` and in ``confidence_calibration``
        (:func:`slamq.verdict.calibration.calibration`); else that is None.

    Examples
    --------
    >>> import pandas as pd
    >>> from slamq.verdict.ranking import summarize
    >>> df = pd.DataFrame({"sequence": "s", "algorithm": ["a", "b", "c"],
    ...                    "corners": [300, 40, 35], "ate_rmse": [0.05, 2.0, float("nan")],
    ...                    "known": [1000, 1000, 500]})
    >>> v = sequence_verdict(summarize(df), "s")
    >>> v["best"], v["ranking"], v["basis"]
    ('a', ['a', 'b'], ['ate_rmse'])
    >>> sequence_verdict(summarize(df.drop(columns="ate_rmse")), "s")["ranking"]
    ['b', 'a', 'c']
    >>> ev = {"majority": True, "notes": [], "algorithms": {
    ...     a: {"support": s, "completeness": 1.0, "placed": True, "runs": 1,
    ...         "flagged_runs": 0, "defects": {}} for a, s in zip("abc", [0.9, 0.5, 0.88])}}
    >>> v = sequence_verdict(summarize(df.drop(columns="ate_rmse")), "s", ev)
    >>> v["best"], v["ranking"], v["basis"]
    ('c', ['c', 'a', 'b'], ['agreement', 'corners'])
    >>> v["confidence"].startswith("medium: right in 436 of 452 labelled verdicts (96%")
    True
    >>> v["confidence_calibration"]
    {'right': 436, 'of': 452, 'share': 0.96, 'lower_bound': 0.94}
    """
    block = _algorithms(summary, sequence)
    warnings: list[str] = []
    if evidence is not None and not _ground_truth_decides(block):
        return with_calibration(_one_direction(_short_path(
            _agreement_verdict(block, sequence, evidence, warnings), evidence), evidence))
    share = known_share(block)  # by area: comparable across resolutions; else cells
    partial = {a for a, s in share.items() if s < COMPLETE_SHARE}
    for a in sorted(partial):
        warnings.append(f"{a}'s map knows {100 * share[a]:.0f}% of the area of the most "
                        "complete map: a partial map, never named best")
    res_differ, turned = _differences(block)
    differ = " and ".join(w for w, d in (("resolution", res_differ), ("orientation", turned))
                          if d)
    for key, higher, tie, tie_higher, confidence in _BASES:
        if key == "corners" and (res_differ or turned) and len(
                _means(block, "corners_canonical")):
            key = "corners_canonical"
            warnings.append(f"the maps differ in {differ}: ranked by corners_canonical (each "
                            "map turned to its walls and resampled to one resolution) instead "
                            "of corners" + _turned_note(block))
        means = _means(block, key)
        if len(means) < 2 and not (key.startswith("corners") and len(means) == 1):
            continue
        ties = _means(block, tie) if tie else pd.Series(dtype=float)

        def order_key(a: Any, means: pd.Series = means, ties: pd.Series = ties,
                      higher: bool = higher, tie_higher: bool = tie_higher) -> tuple:
            v = float(means[a])
            t = float(ties[a]) if a in ties.index else math.nan
            t = (-t if tie_higher else t) if math.isfinite(t) else math.inf
            return (str(a) in partial, -v if higher else v, t, str(a))

        ranking = [str(a) for a in sorted(means.index, key=order_key)]
        unranked = sorted(str(a) for a in block.index if a not in means.index)
        if unranked:
            warnings.append(f"not ranked, no {key}: {', '.join(unranked)}")
        best = ranking[0] if ranking and ranking[0] not in partial else None
        if key.startswith("corners"):
            warnings.append("no ground truth: occupied fraction, proportion and enclosed "
                            "areas do not decide (on slam_comparison_tools their rank "
                            "agreement with the trajectory error was at chance or inverted)")
            close = _within_margin([a for a in ranking if a not in partial], means)
            if len(close) > 1:
                first, second = float(means[close[0]]), float(means[close[1]])
                confidence += (f"; no clear winner: {close[0]} and {close[1]} are within "
                               f"{int(CLEAR_MARGIN * 100)}% ({first:g} and {second:g} "
                               "corners)")
            if key == "corners" and (res_differ or turned):
                warnings.append("the maps differ in resolution or orientation: corners are "
                                "not comparable (evaluate with canonical_resolution=0.07 "
                                "to rank them by corners_canonical)" + _turned_note(block))
                best, confidence = None, "none: the maps are not comparable"
        return {"sequence": str(sequence), "best": best, "ranking": ranking,
                "basis": [key] + ([tie] if tie and len(ties) else []),
                "confidence": confidence, "warnings": warnings,
                "confidence_calibration": None}
    return {"sequence": str(sequence), "best": None, "ranking": [], "basis": [],
            "confidence": "none: nothing to rank", "warnings": warnings,
            "confidence_calibration": None}


_BASIS_NAMES = {"ate_rmse": "ATE RMSE", "gt_f1": "GT F1", "corners": "corners",
                "rel_trans_abs_mean": "relations error",
                "agreement": "agreement with the other maps",
                "defects": "the other map's defect flags",
                "scan_violation": "consistency with its own scans",
                "scan_crossing": "consistency with its own scans",
                "scan_split": "its path against its own scans split in time",
                "split_hit": "its path's halves meeting each other's walls",
                "corners_canonical": "canonical corners"}


def basis_name(key: str | None) -> str:
    """How the page names a verdict's basis column.

    Examples
    --------
    >>> basis_name("ate_rmse"), basis_name("corners_canonical")
    ('ATE RMSE', 'canonical corners')
    """
    return _BASIS_NAMES.get(str(key), str(key))


def verdict_sentence(v: dict[str, Any]) -> str:
    """The verdict as the report's one sentence.

    Examples
    --------
    >>> verdict_sentence({"sequence": "s", "best": "a", "ranking": ["a", "b"],
    ...                   "basis": ["ate_rmse"], "confidence": "high: ...", "warnings": []})
    's: a is best by ATE RMSE (of 2; confidence high: ...).'
    """
    if v["best"] is None:
        # the reason the verdict abstains is its confidence's ("none: why"), unless it only
        # says there was nothing to rank: then the first warning says why
        why = v["confidence"].removeprefix("none: ")
        if why == "nothing to rank" and v["warnings"]:
            why = v["warnings"][0]
        return f"{v['sequence']}: no algorithm is named best ({why})."
    basis = basis_name(v["basis"][0])
    return (f"{v['sequence']}: {v['best']} is best by {basis} (of {len(v['ranking'])}; "
            f"confidence {v['confidence']}).")


def needs_evidence(summary: pd.DataFrame, sequence: str) -> bool:
    """Whether a sequence is judged without ground truth (no two algorithms with an ATE, a
    relations error or a GT-map F1) and has at least two algorithms: then the maps'
    agreement decides.

    Examples
    --------
    >>> import pandas as pd
    >>> from slamq.verdict.ranking import summarize
    >>> df = pd.DataFrame({"sequence": "s", "algorithm": ["a", "b"], "corners": [3, 4]})
    >>> needs_evidence(summarize(df), "s")
    True
    """
    block = _algorithms(summary, sequence)
    return len(block) >= 2 and not _ground_truth_decides(block)


def rule_summary() -> str:
    """The rule of docs/spec.md section 9 in one sentence, from this module's constants (the
    report prints it; the section is the full statement).

    Examples
    --------
    >>> print(rule_summary())  # doctest: +NORMALIZE_WHITESPACE
    by ATE RMSE when the sequence has ground truth, else by relations error, else by GT F1
    against its ground-truth map; else by how far the other maps confirm each map (a map
    they cannot place, whose support is under 90% of the best, that a defect detector
    flags (a second wall direction another program's map that agrees with it draws too is
    the building's),
    whose completeness is under 80% of the highest, whose own scans cross its walls
    more than max(2%, 1.5x the most consistent map's), or whose path's scans split in time
    cross each other's walls more than max(2%, 1.5x the lowest) is never named best;
    corners order the maps confirmed equally on one grid, and their own scans those
    within 25% of the fewest corners; of two maps, one is named when
    the other is superposed, smeared or fragmented and it carries no flag; of two maps, or
    of maps that disagree, one is also named when another is wrong on its own and its own
    scans confirm it (a path's split share only where its halves meet); where the maps
    disagree, the path whose halves cross each other's walls 1.5x less than any other where
    they meet names its program (whatever its doubled_walls or superposed flags); where 2%
    or more of the recording's scans see walls in one
    direction only, at most low confidence, and no verdict when the map it would name has a
    path 3% or more shorter than another's over the whole run and along the corridors beyond
    elsewhere, unless its halves set it apart so); with figures alone, by corners (no clear
    winner within 25%)
    """
    return (
        f"by {basis_name(_BASES[0][0])} when the sequence has ground truth, else by "
        f"{basis_name(_BASES[1][0])}, else by {basis_name(_BASES[2][0])} against its "
        "ground-truth map; else by how far the other "
        "maps confirm each map (a map they cannot place, whose support is under "
        f"{AGREEMENT_SHARE:.0%} of the best, that a defect detector flags"
        + ((" (a second wall direction another program's map"
            + (" that agrees with it" if SHARED_DIRECTION_AGREE else "")
            + " draws too is the building's)") if SHARED_DIRECTION else "") + ", whose "
        f"completeness is under {COMPLETE_SHARE:.0%} of the highest, whose own scans "
        f"cross its walls more than max({SCAN_FLOOR:.0%}, {SCAN_SHARE:g}x the most "
        "consistent map's), or whose path's scans split in time cross each other's walls "
        f"more than max({SCAN_FLOOR:.0%}, {SCAN_SHARE:g}x the lowest) is never named best; "
        "corners order the maps confirmed equally on one grid"
        + (f", and their own scans those within {CLEAR_MARGIN:.0%} of the fewest corners"
           if SCANS_BREAK_TIES else "")
        + "; of two maps, one is named when the other is "
        f"{', '.join(SEVERE_DEFECTS[:-1])} or {SEVERE_DEFECTS[-1]} and it carries no flag; "
        "of two maps, or of maps that disagree, one is also named when another is "
        "wrong on its own and its own scans confirm it"
        + (" (a path's split share only where its halves meet)" if SPLIT_MEET else "")
        + ((f"; where the maps disagree, the path whose halves cross each other's walls "
            f"{SCAN_SHARE:g}x less than any other where they meet names its program"
            + (f" (whatever its {' or '.join(SPLIT_PRECISION_FLAGS)} flags)"
               if SPLIT_PRECISION_FLAGS else ""))
           if SPLIT_PRECISION else "")
        + f"; where {DEGENERATE_SHARE:.0%} or "
        "more of the recording's scans see walls in one direction only, at most low "
        f"confidence, and no verdict when the map it would name has a path {SHORTFALL:.0%} or "
        "more shorter than another's"
        + {"both": " over the whole run and along the corridors beyond elsewhere",
           "corridors": " along the corridors beyond elsewhere"}.get(str(CORRIDOR_TRAVEL), "")
        + (", unless its halves set it apart so" if SPLIT_PRECISION_TRAVEL == "any" else "")
        + "); with figures alone, by corners (no "
        f"clear winner within {CLEAR_MARGIN:.0%})")
