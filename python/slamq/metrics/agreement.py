"""``slamq.agreement``: several maps of one place as evidence about each other, without
ground truth (docs/spec.md section 9).

Every ordered pair of maps is compared once (:func:`slamq.compare` with its per-cell
flags, after the maps have been placed in one frame): map *i* is laid on map *j*'s grid.
Only where the *other* map looked counts, so that a map is not blamed for walls the other
never saw:

- ``support(i, j)``: the share of *i*'s walls lying in *j*'s known area (grown by the
  tolerance) that have a wall of *j* within the tolerance;
- ``recall(i, j)``: the share of *j*'s walls lying in *i*'s known area (grown likewise)
  that have a wall of *i* within the tolerance;
- ``consistency(i, j)``: their harmonic mean, averaged over the two directions of the pair
  (so it is symmetric);
- ``covers(i, j)``: the share of *j*'s known cells that *i* knows.

Per map: ``support`` is the median of its consistencies with the other maps, and
``completeness`` the median of ``covers(i, j)`` (area the other maps agree exists that this
map knows; cells a map knows outside every other map, such as a superposed copy, do not
count). A map whose walls the others do not confirm has a low support; a map that saw less
has a low completeness, not a low support.

A map can only be judged by maps that agree with each other: ``majority`` says whether more
than half of the maps have a support of at least ``min_support``. When it is False the
maps disagree among themselves (most of them broken, or not of one place) and the numbers
do not say which map is right.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from concurrent.futures import Executor, ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from slamq.errors import ParamError
from slamq.metrics.compare import compare
from slamq.metrics.several import named_maps
from slamq.models import OccupancyMap
from slamq.params import SETTINGS, check_threads

__all__ = ["GROUP_MIN_OVERLAP", "MISSING_MIN_LENGTH", "Agreement", "agreeing_group",
           "agreement", "missing_walls", "place_all"]

_E, _G, _EM, _GM, _EK, _GF = 1, 2, 4, 8, 16, 32


@dataclass(frozen=True)
class Agreement:
    """Several maps of one place scored by each other.

    Attributes
    ----------
    names : list of str
        The maps, in the order given.
    support : dict of str to float
        Per map, the median consistency with the other maps, in [0, 1] (NaN when no
        other map overlaps it).
    completeness : dict of str to float
        Per map, the median share of another map's known area that it knows, in [0, 1].
    consistency : numpy.ndarray
        ``consistency[i, j]``, symmetric, NaN on the diagonal and where two maps do not
        overlap.
    placed : dict of str to bool
        Whether each map could be placed in the common frame (a map that could not has
        NaN figures).
    majority : bool
        More than half of the maps have a support of at least ``min_support``.
    group : list of str
        The agreeing group (docs/spec.md section 9): of the sets of maps whose every pair
        has a consistency of at least ``min_support``, each map of a pair knowing at least
        :data:`GROUP_MIN_OVERLAP` of the other's known area, the one with the most programs
        (``owners``; every map its own program without them), then the most maps, then the
        highest mean consistency, in the order given; empty when no two programs' maps
        agree. A map in it is confirmed by another program's even when most maps are
        broken; a map that agrees with nobody, or only with reruns of its own program, is
        evidence of nothing.
    min_support : float
        The support a map needs to count as confirmed.
    notes : list of str
        Plain sentences on what went wrong (maps not placed, no majority).
    missing : dict of str to numpy.ndarray
        Per placed map, on its own grid (its image's cells): where more than half of the
        other maps have a wall that none of its walls matches and it sees free space
        (missing walls, leaks); :func:`missing_walls` makes flags of them.

    Examples
    --------
    >>> import numpy as np
    >>> from slamq import agreement
    >>> img = np.full((40, 40), 254, np.uint8); img[5, 5:35] = 0; img[5:35, 5] = 0
    >>> bad = img.copy(); bad[20, 10:35] = 0; bad[5:35, 5] = 254    # ghost in, wall out
    >>> a = agreement({"a": img, "b": img, "c": bad}, align="origin")
    >>> a.support["a"] > a.support["c"], a.majority
    (True, True)
    """

    names: list[str]
    support: dict[str, float]
    completeness: dict[str, float]
    consistency: np.ndarray
    placed: dict[str, bool]
    majority: bool
    min_support: float
    notes: list[str] = field(default_factory=list)
    missing: dict[str, np.ndarray] = field(default_factory=dict)
    group: list[str] = field(default_factory=list)

    def table(self) -> list[dict[str, Any]]:
        """One dict per map: ``name``, ``support``, ``completeness``, ``placed``.

        Examples
        --------
        >>> import numpy as np
        >>> from slamq import agreement
        >>> img = np.full((20, 20), 254, np.uint8); img[5, 2:18] = 0; img[5:15, 2] = 0
        >>> [r["support"] for r in agreement([img, img, img], align="origin").table()]
        [1.0, 1.0, 1.0]
        """
        return [{"name": n, "support": self.support[n],
                 "completeness": self.completeness[n], "placed": self.placed[n]}
                for n in self.names]


#: A stretch of missing wall is flagged from this length on, metres (chosen on the synthetic
#: "gap" damage of slamq.synth.damage; docs/validity.md).
MISSING_MIN_LENGTH = 0.5


def missing_walls(agree: Agreement, maps: Mapping[str, OccupancyMap], *,
                  min_length: float = MISSING_MIN_LENGTH) -> dict[str, list[Any]]:
    """Flags of missing walls and leaks: per map, the largest stretch of walls that most of
    the other maps have where this map sees free space, when it runs at least
    ``min_length`` metres (the longer side of the stretch's bounding box).

    Parameters
    ----------
    agree : Agreement
        :func:`agreement` of ``maps``.
    maps : mapping of name to OccupancyMap
        The same maps.
    min_length : float, default 0.5
        Metres of missing wall (one 8-connected stretch) from which a map is flagged.

    Returns
    -------
    dict of str to list of Defect
        ``kind="missing_walls"`` (:class:`slamq.metrics.defects.Defect`), at most one per map.

    Examples
    --------
    >>> import numpy as np
    >>> from slamq.models import OccupancyMap
    >>> img = np.full((60, 60), 254, np.uint8); img[10, 5:55] = 0; img[50, 5:55] = 0
    >>> img[10:51, 5] = 0; img[10:51, 54] = 0; img[10:51, 30] = 0
    >>> gap = img.copy(); gap[15:45, 30] = 254                 # an inner wall not there
    >>> none = np.zeros(img.shape, bool)
    >>> maps = {k: OccupancyMap(v, none, 0.05) for k, v in
    ...         {"a": img, "b": img, "gap": gap}.items()}
    >>> flags = missing_walls(agreement(maps, align="origin"), maps)
    >>> [d.kind for d in flags["gap"]], flags["a"]
    (['missing_walls'], [])
    """
    import cv2

    from slamq.metrics.defects import Defect

    out: dict[str, list[Any]] = {n: [] for n in agree.names}
    for name, mask in agree.missing.items():
        m = maps[name]
        res = m.resolution or 0.05
        if not mask.any():
            continue
        n, labels, stats, _ = cv2.connectedComponentsWithStats(mask.astype(np.uint8), 8)
        if n <= 1:
            continue
        extent = np.maximum(stats[1:, cv2.CC_STAT_WIDTH], stats[1:, cv2.CC_STAT_HEIGHT])
        k = 1 + int(np.argmax(extent))
        length = float(extent[k - 1]) * res
        if length < min_length:
            continue
        x, y, w, h = (int(v) for v in stats[k, :4])
        rows = m.shape[0]
        cx, cy = x + w / 2, y + h / 2
        ox, oy, yaw = m.origin
        u, v = cx * res, (rows - cy) * res
        where = (ox + math.cos(yaw) * u - math.sin(yaw) * v,
                 oy + math.sin(yaw) * u + math.cos(yaw) * v)
        out[name].append(Defect(
            "missing_walls", length, (x, y, x + w, y + h), where,
            f"{length:.1f} m of wall that most of the other maps have, where this map sees "
            "free space (a missing wall or a leak)"))
    return out


def _grow(mask: np.ndarray, cells: int) -> np.ndarray:
    if cells <= 0 or not mask.any():
        return mask
    import cv2  # on first use: importing OpenCV takes a while

    k = np.ones((2 * cells + 1, 2 * cells + 1), np.uint8)
    return cv2.dilate(mask.astype(np.uint8), k) != 0


def finite_median(values: Any) -> float:
    """The median of the finite values, NaN when there is none.

    Examples
    --------
    >>> finite_median([1.0, float("nan"), 3.0]), finite_median([])
    (2.0, nan)
    """
    row = np.asarray(values, dtype=float)
    row = row[np.isfinite(row)]
    return float(np.median(row)) if len(row) else math.nan


def _share(num: int, den: int) -> float:
    return num / den if den else math.nan


class _Laid:
    """One ordered pair laid over each other: ``est`` on ``ref``'s grid (:func:`_lay`).

    ``support`` and ``recall`` at once; ``covers`` and ``missing`` (the cells of ``ref``'s
    grid where ``est`` has a wall that no wall of ``ref`` matches and ``ref`` sees free
    space) when asked (:meth:`rest`): of two placements of a pair only the better one's
    are needed. Everything is read within ``box``, the box of ``ref``'s known cells grown
    by the tolerance: outside it no cell counts."""

    def __init__(self, f: np.ndarray, shape: tuple[int, ...], box: tuple[slice, slice],
                 support: float, recall: float, est_known: np.ndarray, ref_cells: np.ndarray,
                 ref_count: int) -> None:
        self.f, self.shape, self.box = f, shape, box
        self.support, self.recall = support, recall
        self._est_known, self._ref_cells, self._ref_count = est_known, ref_cells, ref_count

    def rest(self) -> _Figures:
        """The pair's figures, with the missing walls within :attr:`box`."""
        covers = _share(int(np.count_nonzero(self._ref_cells & self._est_known)),
                        self._ref_count)
        missing = (self.f & (_E | _EM | _GF)) == (_E | _GF)
        return _Figures(self.support, self.recall, covers, self.shape, self.box, missing)


@dataclass(frozen=True)
class _Figures:
    """What the agreement keeps of one ordered pair: ``missing`` is the part within
    ``box`` of a mask of the ``shape`` of the grid the pair was laid on."""

    support: float
    recall: float
    covers: float
    shape: tuple[int, ...]
    box: tuple[slice, slice]
    missing: np.ndarray

    def vote(self, votes: np.ndarray | None) -> np.ndarray:
        """``votes`` (int16 counts on that grid; zeros when None) with ``missing`` added."""
        if votes is None:
            votes = np.zeros(self.shape, np.int16)
        votes[self.box] += self.missing
        return votes


def _known_box(ref: OccupancyMap, grow: int) -> tuple[slice, slice]:
    """The box of ``ref``'s known cells (on its grid: the flags ``_G | _GF`` of every map
    laid on it), grown by ``grow`` cells."""
    known = ~ref.unknown
    rows = np.flatnonzero(known.any(axis=1))
    cols = np.flatnonzero(known.any(axis=0))
    if not len(rows):
        return (slice(0, 0), slice(0, 0))
    return (slice(max(0, int(rows[0]) - grow), int(rows[-1]) + grow + 1),
            slice(max(0, int(cols[0]) - grow), int(cols[-1]) + grow + 1))


def _lay(est: OccupancyMap, ref: OccupancyMap, align: str, tolerance: float | None,
         threads: int | None, known: dict[Any, Any] | None = None) -> _Laid:
    """``est`` laid on ``ref``'s grid (:func:`slamq.compare` with its cells), read within the
    box of ``ref``'s known cells grown by the tolerance: walls of ``est`` outside it are
    away from ``ref``'s known cells, and ``ref``'s walls and free cells lie inside it with
    their tolerance, so no count reads past it. ``known`` keeps the box, and ``ref``'s
    known cells in it and those grown, between the pairs laid on one grid."""
    from slamq.metrics.compare import DEFAULT_TOLERANCE_CELLS, _number

    res = ref.resolution or est.resolution or 1.0  # as compare: the ground truth's cells
    tol = DEFAULT_TOLERANCE_CELLS * res if tolerance is None else _number("tolerance",
                                                                          tolerance)
    grow = max(1, int(math.ceil(tol / res)))
    key = (id(ref.values), id(ref.unknown), grow)
    cached = None if known is None else known.get(key)
    box = cached[1] if cached is not None and cached[0] is ref else _known_box(ref, grow)
    # min_fit_precision 0: a poor fit is kept as it is (compare would also run the global
    # registration, only to say in its note whether it fits better)
    c = compare(est, ref, align=align, tolerance=tolerance, cells=True, threads=threads,
                min_fit_precision=0.0, cells_box=(box[0].start, box[0].stop, box[1].start,
                                                  box[1].stop))
    f = c.cells
    assert f is not None
    if grow != max(1, int(math.ceil(c.tolerance / c.resolution))):
        raise AssertionError(f"agreement: tolerance {c.tolerance} m at {c.resolution} m, "
                             f"not the {grow} cells its box was grown by")
    if cached is None or cached[0] is not ref:
        ref_cells = (f & (_G | _GF)) != 0
        cached = (ref, box, ref_cells, _grow(ref_cells, grow),
                  int(np.count_nonzero(ref_cells)))
        if known is not None:
            known[key] = cached
    _, box, ref_cells, ref_known, ref_count = cached
    e = (f & _E) != 0
    est_known = (f & (_EK | _E)) != 0
    e_in = e & ref_known
    g_in = ((f & _G) != 0) & _grow(est_known, grow)
    support = _share(int(np.count_nonzero(e_in & ((f & _EM) != 0))),
                     int(np.count_nonzero(e_in)))
    recall = _share(int(np.count_nonzero(g_in & ((f & _GM) != 0))),
                    int(np.count_nonzero(g_in)))
    return _Laid(f, ref.shape, box, support, recall, est_known, ref_cells, ref_count)


def _pair(est: OccupancyMap, ref: OccupancyMap, align: str, tolerance: float | None,
          threads: int | None, known: dict[Any, Any] | None = None) -> _Figures:
    """The figures of ``est`` laid on ``ref``'s grid; ``missing``: the cells of ``ref``'s
    grid where ``est`` has a wall that no wall of ``ref`` matches and ``ref`` sees free
    space."""
    return _lay(est, ref, align, tolerance, threads, known).rest()


def _resolved(maps: Mapping[str, OccupancyMap]) -> dict[str, OccupancyMap]:
    """The maps, those without a resolution given the first one the others have (else 1 m),
    so that every pair is measured in one unit."""
    res = next((m.resolution for m in maps.values() if m.resolution), 1.0)
    return {n: m if m.resolution else OccupancyMap(m.values, m.unknown, res, m.origin,
                                                    source=m.source)
            for n, m in maps.items()}


def _moved(m: OccupancyMap, r: Any) -> OccupancyMap:
    """``m`` with its origin taken by the registration ``r`` into the fixed map's frame."""
    ((x, y),) = r.apply([m.origin[:2]])
    return OccupancyMap(m.values, m.unknown, m.resolution,
                        (float(x), float(y), m.origin[2] + r.theta), source=m.source)


def place_all(maps: Mapping[str, OccupancyMap], *, threads: int | None = None
              ) -> tuple[dict[str, OccupancyMap], dict[str, bool], list[str]]:
    """Put several maps of one place in one frame by :func:`slamq.register_many`.

    The base is the map with the most trusted registrations (ties: the highest summed
    confidence, then :func:`slamq.metrics.register.canonical_order`, which depends on the
    maps alone, not their names or order); every other map is moved into the base's frame by its
    own registration onto the base, or, when that one is refused, through one other map
    that both registrations trust. Maps without a resolution take the first resolution
    given (else 1 m).

    Parameters
    ----------
    maps : mapping of name to OccupancyMap
    threads : int, optional

    Returns
    -------
    (dict, dict, list of str)
        The maps with their origins moved; per map whether it was placed; sentences about
        the maps that were not.

    Examples
    --------
    >>> import numpy as np
    >>> from slamq.models import OccupancyMap
    >>> img = np.full((80, 100), 254, np.uint8)
    >>> img[10, 10:90] = img[70, 10:90] = img[10:71, 10] = img[10:71, 90] = 0
    >>> img[10:40, 50] = img[40, 30:51] = 0
    >>> none = np.zeros(img.shape, bool)
    >>> maps = {"a": OccupancyMap(img, none, 0.05), "b": OccupancyMap(img, none, 0.05,
    ...                                                                (3.0, -1.0, 0.7))}
    >>> moved, placed, notes = place_all(maps)
    >>> placed, [round(v, 3) + 0.0 for v in moved["b"].origin]
    ({'a': True, 'b': True}, [0.0, 0.0, 0.0])
    """
    from slamq.metrics.register import canonical_order, register_many

    names = list(maps)
    maps = _resolved(maps)
    regs = register_many(maps, threads=threads)
    rank = {n: k for k, n in enumerate(canonical_order(maps))}

    def trusted(n: str) -> tuple[int, float, int]:
        ok = [regs[m, n] for m in names if m != n and regs[m, n].ok]
        return (len(ok), math.fsum(r.confidence for r in ok), -rank[n])

    base = max(names, key=trusted)
    moved = {base: maps[base]}
    placed = dict.fromkeys(names, False)
    placed[base] = True
    notes = []
    for n in names:
        if n == base:
            continue
        r = regs[n, base]
        if r.ok:
            moved[n] = _moved(maps[n], r)
            placed[n] = True
            continue
        for k in names:
            if k in (n, base) or not (regs[n, k].ok and regs[k, base].ok):
                continue
            moved[n] = _moved(_moved(maps[n], regs[n, k]), regs[k, base])  # through k
            placed[n] = True
            break
        else:
            moved[n] = maps[n]
            notes.append(f"{n} could not be registered with the other maps ({r.reason})")
    return moved, placed, notes


#: Pairs laid at once when ``threads`` is not given: every core, up to this many (each pair
#: holds a few bytes per cell of its grid while it is laid).
MAX_DEFAULT_WORKERS = 8


def _workers(threads: int | None) -> int:
    """How many pairs are laid at once: ``threads``, or every core up to
    :data:`MAX_DEFAULT_WORKERS`."""
    n = check_threads(threads)  # a ParamError for a bad count, as the core gives
    if n:
        return n
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return max(1, min(MAX_DEFAULT_WORKERS, cores or 1))


def _in_order(pool: Executor | None, threads: int | None, tasks: Sequence[Any]) -> list[Any]:
    """The results of ``tasks`` (callables of no argument), in their order: on ``pool``,
    else on a pool of :func:`_workers` threads (in this thread when that is one)."""
    if pool is None and _workers(threads) > 1 and len(tasks) > 1:
        with ThreadPoolExecutor(max_workers=_workers(threads),
                                thread_name_prefix="slamq-agreement") as own:
            return [f.result() for f in [own.submit(t) for t in tasks]]
    if pool is None:
        return [t() for t in tasks]
    return [f.result() for f in [pool.submit(t) for t in tasks]]


def _auto(maps: dict[str, OccupancyMap], names: list[str], sup: np.ndarray, rec: np.ndarray,
          cov: np.ndarray, placed: dict[str, bool], notes: list[str], votes: dict,
          tolerance: float | None, threads: int | None, pool: Executor | None) -> None:
    """``align="auto"``: each ordered pair placed by the files' frames refined by ICP or by
    the pair's global registration, whichever fits better (fills the arrays in place).
    The pairs are laid side by side, each on one Rust thread (their figures do not depend
    on it)."""
    from slamq.errors import MapError
    from slamq.metrics.register import register_many

    maps = _resolved(maps)
    try:
        regs = register_many(maps, threads=threads)
    except MapError as exc:
        regs = {}
        notes.append(f"no global registration ({exc}): the files' frames only")
    bar = SETTINGS.min_inliers.default
    known: dict[Any, Any] = {}
    one = 1 if _workers(threads) > 1 or pool is not None else threads

    def lay(a: str, b: str) -> tuple[bool, _Figures]:
        best = _lay(maps[a], maps[b], "icp", tolerance, one, known)
        fits = min(best.support, best.recall) >= bar
        r = regs.get((a, b))
        if r is not None and r.ok:
            fits = True
            moved = _lay(_moved(maps[a], r), maps[b], "icp", tolerance, one, known)
            if _f(moved.support, moved.recall) > _f(best.support, best.recall):
                best = moved
        return fits, best.rest()

    pairs = [(i, j) for i in range(len(names)) for j in range(len(names)) if i != j]
    done = _in_order(pool, threads, [lambda a=names[i], b=names[j]: lay(a, b)
                                     for i, j in pairs])
    fits = dict.fromkeys(names, False)
    for (i, j), (fit, best) in zip(pairs, done):
        a, b = names[i], names[j]
        fits[a] |= fit
        sup[i, j], rec[i, j], cov[i, j] = best.support, best.recall, best.covers
        votes[b] = best.vote(votes.get(b))
    for a in names:
        if not fits[a]:
            placed[a] = False
            notes.append(f"{a} could not be placed with the other maps (neither its frame nor "
                         "a trusted registration fits any of them)")


def _f(p: float, r: float) -> float:
    if not (math.isfinite(p) and math.isfinite(r)):
        return math.nan
    return 0.0 if p + r == 0 else 2 * p * r / (p + r)


def agreement(maps: Mapping[str, OccupancyMap] | Sequence[OccupancyMap], *,
              align: str = SETTINGS.agreement_align.default,
              min_support: float = SETTINGS.min_support.default,
              tolerance: float | None = None, threads: int | None = None,
              pool: Executor | None = None,
              owners: Mapping[str, str] | None = None) -> Agreement:
    """Score each of several maps of one place by how far the others confirm it.

    Parameters
    ----------
    maps : mapping of name to map, or sequence of maps
        At least 2 maps (:func:`slamq.agreement` takes paths and image arrays too); a
        sequence is named ``"0"``, ``"1"``...
    align : {"auto", "register", "icp", "origin", "search"}, default "auto"
        How each pair of maps is laid over each other: ``auto``, by the files' frames
        refined by ICP or by :func:`slamq.register_many`'s registration, whichever fits
        better (maps of one recording share its first pose; maps saved in unrelated frames
        need the registration); ``register``, all maps moved into one base map's frame by
        the registration (a map it cannot place gets NaN figures); the others as in
        :func:`slamq.compare`.
    min_support : float, default 0.6
        The support a map needs to count as confirmed by the others (``majority``).
    tolerance : float, optional
        Matching distance, metres (default: :func:`slamq.compare`'s, 2 cells).
    threads : int, optional
        Cap on the worker threads (default: every core, up to 8): that many pairs are laid
        over each other at once, each on one thread. The figures do not depend on it.
    pool : concurrent.futures.Executor, optional
        Lay the pairs on this executor's workers instead (one Rust thread each), e.g. one
        shared with other work.
    owners : mapping of name to str, optional
        The program (or setting) that made each map, by name: the agreeing group counts
        programs before maps, so runs of one program that agree with each other (a
        deterministic program run three times draws one map three times) are no group.
        Default: every map its own program.

    Returns
    -------
    Agreement

    Raises
    ------
    slamq.ParamError
        Fewer than 2 maps, or a parameter out of range.

    Examples
    --------
    >>> import numpy as np
    >>> from slamq import agreement
    >>> img = np.full((30, 30), 254, np.uint8); img[5, 5:25] = 0; img[5:25, 5] = 0
    >>> img[24, 5:25] = 0
    >>> shifted = np.roll(img, 6, axis=1); shifted[:, :6] = 254   # a displaced copy...
    >>> doubled = np.minimum(img, shifted)                         # ...superposed
    >>> a = agreement([img, img, doubled], align="origin")
    >>> a.support["0"] > a.support["2"]
    True
    """
    if align not in SETTINGS.agreement_align.choices:
        raise ParamError(f"align must be one of {', '.join(SETTINGS.agreement_align.choices)}"
                         f", got {align!r}")
    if not (isinstance(min_support, (int, float)) and 0 <= min_support <= 1):
        raise ParamError(f"min_support must be in [0, 1], got {min_support!r}")
    loaded = named_maps(maps, "agreement", 2)
    names = list(loaded)
    notes: list[str] = []
    placed = dict.fromkeys(names, True)
    pair_align = align
    if align == "register":
        loaded, placed, why = place_all(loaded, threads=threads)
        notes.extend(why)
        pair_align = "icp"
    n = len(names)
    sup = np.full((n, n), math.nan)
    rec = np.full((n, n), math.nan)
    cov = np.full((n, n), math.nan)
    votes: dict[str, np.ndarray] = {}
    if align == "auto":
        _auto(loaded, names, sup, rec, cov, placed, notes, votes, tolerance, threads, pool)
    else:
        known: dict[Any, Any] = {}
        one = 1 if _workers(threads) > 1 or pool is not None else threads
        pairs = [(i, j) for i, a in enumerate(names) for j, b in enumerate(names)
                 if i != j and placed[a] and placed[b]]
        done = _in_order(pool, threads, [
            lambda a=names[i], b=names[j]: _pair(loaded[a], loaded[b], pair_align, tolerance,
                                                 one, known) for i, j in pairs])
        for (i, j), figs in zip(pairs, done):
            sup[i, j], rec[i, j], cov[i, j] = figs.support, figs.recall, figs.covers
            votes[names[j]] = figs.vote(votes.get(names[j]))
    voters = max(1, sum(placed.values()) - 1)
    missing = {b: v * 2 > voters for b, v in votes.items() if placed[b]}
    cons = np.full((n, n), math.nan)
    for i in range(n):
        for j in range(n):
            if i != j:
                one, two = _f(sup[i, j], rec[i, j]), _f(sup[j, i], rec[j, i])
                vals = [v for v in (one, two) if math.isfinite(v)]
                cons[i, j] = float(np.mean(vals)) if vals else math.nan

    support = {a: finite_median(cons[i]) for i, a in enumerate(names)}
    completeness = {a: finite_median(cov[i]) for i, a in enumerate(names)}
    confirmed = sum(1 for a in names if support[a] >= min_support)
    majority = confirmed * 2 > n
    if not majority:
        notes.append(f"only {confirmed} of {n} maps agree with the others (support >= "
                     f"{min_support:g}): the maps disagree among themselves")
    mine = owners or {}
    group = [names[i] for i in agreeing_group(_overlapping(cons, cov), min_support,
                                              [str(mine.get(a, a)) for a in names])]
    return Agreement(names=names, support=support, completeness=completeness,
                     consistency=cons, placed=placed, majority=majority,
                     min_support=float(min_support), notes=notes, missing=missing,
                     group=group)


#: Above this many maps the agreeing group is grown greedily instead of searched exactly.
EXACT_GROUP_MAPS = 16
#: Two maps count as agreeing (for the group) only when each knows at least this share of
#: the other's known area: a map of one scan agrees with any map of the place where it
#: overlaps it, and would confirm a broken one (docs/validity.md, "A minimum overlap").
GROUP_MIN_OVERLAP = 0.05


def _overlapping(consistency: np.ndarray, covers: np.ndarray,
                 least: float = GROUP_MIN_OVERLAP) -> np.ndarray:
    """``consistency`` with NaN where either map of a pair knows less than ``least`` of
    the other's known area (``covers[i, j]``: the share of j's known cells that i knows).

    Examples
    --------
    >>> import numpy as np
    >>> c = np.array([[np.nan, 0.9], [0.9, np.nan]])
    >>> float(_overlapping(c, np.array([[np.nan, 0.001], [1.0, np.nan]]))[0, 1])
    nan
    >>> float(_overlapping(c, np.array([[np.nan, 0.5], [1.0, np.nan]]))[0, 1])
    0.9
    """
    c = np.array(consistency, dtype=float)
    cov = np.asarray(covers, dtype=float)
    tiny = (cov < least) | (cov.T < least)  # NaN compares False: not known, not tiny
    c[tiny] = math.nan
    return c


def agreeing_group(consistency: np.ndarray, min_consistency: float,
                   owners: Sequence[str] | None = None) -> list[int]:
    """The indices of the set of maps whose every pair has a consistency of at least
    ``min_consistency`` (a clique) with the most distinct ``owners`` (the program of each
    map; default: every map its own), at least two; of those the largest, then the one
    with the highest mean consistency, then the first in index order. Empty when no two
    owners' maps agree. Exact up to :data:`EXACT_GROUP_MAPS` maps, greedy beyond (from
    each pair of two owners in order of consistency, add the map that keeps the set
    agreeing with the most owners, then the highest mean consistency).

    Examples
    --------
    >>> import numpy as np
    >>> c = np.array([[np.nan, 0.99, 0.2, 0.6],
    ...               [0.99, np.nan, 0.1, 0.7],
    ...               [0.2, 0.1, np.nan, 0.3],
    ...               [0.6, 0.7, 0.3, np.nan]])
    >>> agreeing_group(c, 0.6)
    [0, 1, 3]
    >>> agreeing_group(c, 0.8), agreeing_group(c, 0.995)
    ([0, 1], [])
    >>> agreeing_group(c, 0.6, ["a", "a", "b", "a"])  # one program's runs: no group
    []
    >>> agreeing_group(c, 0.6, ["a", "b", "c", "b"])
    [0, 1, 3]
    """
    c = np.asarray(consistency, dtype=float)
    n = c.shape[0]
    who = list(owners) if owners is not None else list(range(n))
    ok = np.nan_to_num(c, nan=-1.0) >= min_consistency
    np.fill_diagonal(ok, False)

    def mean(members: tuple[int, ...]) -> float:
        return float(np.mean([c[i, j] for i in members for j in members if i < j]))

    def score(members: tuple[int, ...]) -> tuple[int, int, float]:
        return (len({who[i] for i in members}), len(members), mean(members))

    best: tuple[int, ...] = ()
    best_score: tuple[int, int, float] = (0, 0, -math.inf)
    if n <= EXACT_GROUP_MAPS:
        def grow(members: tuple[int, ...], rest: list[int]) -> None:
            nonlocal best, best_score
            mine = {who[i] for i in members}
            if len(mine) >= 2 and (sc := score(members)) > best_score:
                best, best_score = members, sc  # two owners at least
            for k, j in enumerate(rest):
                reach = mine.union(who[i] for i in rest[k:])
                if (len(reach), len(members) + len(rest) - k) < best_score[:2]:
                    return  # cannot beat the best owners and size any more
                if all(ok[i, j] for i in members):
                    grow(members + (j,), rest[k + 1:])

        grow((), list(range(n)))
        return list(best)
    pairs = sorted(((c[i, j], i, j) for i in range(n) for j in range(i + 1, n)
                    if ok[i, j] and who[i] != who[j]), key=lambda t: (-t[0], t[1], t[2]))
    for _, i, j in pairs:
        members = (i, j)
        while True:
            add = [k for k in range(n) if k not in members and all(ok[m, k] for m in members)]
            if not add:
                break
            members = tuple(sorted(members + (max(add, key=lambda k: (
                score(tuple(sorted(members + (k,)))), -k)),)))
        if (sc := score(members)) > best_score:
            best, best_score = members, sc
    return list(best)
