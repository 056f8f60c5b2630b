"""Every column slamq writes, in one table: name, type, unit, better/worse, label, format,
and where it is shown.

A results record (``slamq eval --json/--csv``, ``slamq batch``) holds, in this order, the
``run`` columns (where the map belongs, how the record was made), the ``map`` columns (the
fields of :class:`slamq.MapQuality`), the ``param`` columns (``param_<name>`` of every
:class:`slamq.Params` field, generated from that schema), the ``ate`` columns (trajectory
error, docs/spec.md section 6), the ``gt`` columns (the map against its sequence's
ground-truth map, section 7) and the ``rel`` columns (the run's trajectory against its
sequence's relations, Kümmerle et al. 2009, section 6a). Rows of the ``verdict`` group
are figures the verdict computes per algorithm (never in a record).

Generated from the table: the record's keys and their order and the typed columns of
results files (:mod:`slamq.results.formats`); the statistics of :func:`slamq.summarize` and
its terminal table; the ``slamq eval`` table; the metrics :func:`slamq.validate` measures and
the ground-truth figures it measures them against; the report's ranked columns (labels,
units, better/worse, plot scale, the argument for the direction), its detail pages' numbers
and files, and the timeline's series; what :meth:`slamq.MapQuality.differences` compares.

Where a column is shown is its row's ``at``: place -> position (columns of a place are
shown in the order of their positions, see :data:`PLACES`).

Adding a map column is one row plus its computation: :func:`register_column` with a
``compute`` function of the :class:`~slamq.OccupancyMap` adds the column to every
:func:`slamq.evaluate` result (``MapQuality.extra``, ``to_dict()``), hence to results
files with its type, and to the places its ``at`` names (the summary, the report...).
A column that slamq itself computes is a row of :data:`COLUMNS` below and a field of
:class:`slamq.MapQuality` (tests/test_columns.py keeps the two equal).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, fields
from types import MappingProxyType
from typing import Any, TypeVar, overload

from slamq.errors import ParamError
from slamq.params import Params

__all__ = [
    "COLUMNS",
    "DTYPES",
    "GROUPS",
    "PLACES",
    "Column",
    "Names",
    "Shown",
    "column",
    "computed_columns",
    "group_names",
    "group_view",
    "record_columns",
    "register_column",
    "shown",
    "shown_names",
    "unregister_column",
]

#: A column's type: text, whole number, real number (NaN when undefined), list of counts.
DTYPES = ("str", "int", "float", "ints")
#: The groups of a record, in record order (``verdict``: computed per algorithm, no record).
GROUPS = ("run", "map", "param", "ate", "gt", "rel", "verdict")
#: Where a column can be shown (``at``):
#:
#: * ``summary``: :func:`slamq.summarize` gives its mean, std and count;
#: * ``console``: a column of the terminal summary table (``slamq batch``, ``slamq summary``);
#: * ``eval``: a column of the ``slamq eval`` table (after the map and its size);
#: * ``ranked``: ranked by the report (a table column and a plot);
#: * ``validity``: a no-reference metric whose agreement with ground truth is measured;
#: * ``truth``: a ground-truth figure it is measured against;
#: * ``detail``: a number on a map's detail page; ``files``: a file named there;
#: * ``timeline``: a series of the timeline plots;
#: * ``resources``: a quality figure on the run mode's resources page.
PLACES = ("summary", "console", "eval", "ranked", "validity", "truth", "detail", "files",
          "timeline", "resources")
#: The format of a number that is not whole (a mean over runs), by type.
_FORMATS = {"float": ".4f", "int": ".1f"}


@dataclass(frozen=True)
class Column:
    """One column of a results record (or a figure of the verdict).

    Attributes
    ----------
    name : str
        The key in a record, the column in a results file.
    dtype : str
        One of :data:`DTYPES`: ``"str"``, ``"int"``, ``"float"`` or ``"ints"`` (a list of
        counts, the enclosed-area curve). A missing value is null; a float column's null
        reads back as NaN.
    group : str
        One of :data:`GROUPS`.
    label : str
        Human name (default: the name with spaces).
    unit : str
        Unit of the number ("" for counts and ratios).
    better : str
        ``"lower"``, ``"higher"`` or "" (neither: a count, a setting, text).
    format : str
        Format spec of a value that is not whole (a mean; default ``.4f`` for floats, ``.1f``
        for integers).
    short : str
        Heading in the ``slamq eval`` table (default: the name).
    log : bool
        Plotted on a logarithmic axis (where the paper does).
    why : str
        The argument for the direction (the paper's, or the spec's section).
    at : mapping of str to int
        Place (:data:`PLACES`) -> position among the columns shown there.
    compute : callable, optional
        For a registered ``map`` column: its value for an :class:`~slamq.OccupancyMap`,
        computed with every evaluation (:func:`slamq.evaluate`, the reference too).

    Examples
    --------
    >>> c = COLUMNS["ate_rmse"]
    >>> c.heading, c.direction, c.dtype, c.format
    ('ATE RMSE (m)', 'lower is better', 'float', '.3f')
    """

    name: str
    dtype: str
    group: str
    label: str = ""
    unit: str = ""
    better: str = ""
    format: str = ""
    short: str = ""
    log: bool = False
    why: str = ""
    at: Mapping[str, int] = field(default_factory=dict, hash=False)
    compute: Callable[[Any], Any] | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        if self.dtype not in DTYPES:
            raise ParamError(f"column {self.name}: dtype must be one of {DTYPES}, "
                             f"got {self.dtype!r}")
        if self.group not in GROUPS:
            raise ParamError(f"column {self.name}: group must be one of {GROUPS}, "
                             f"got {self.group!r}")
        if self.better not in ("", "lower", "higher"):
            raise ParamError(f"column {self.name}: better must be 'lower', 'higher' or '', "
                             f"got {self.better!r}")
        unknown = sorted(set(self.at) - set(PLACES))
        if unknown:
            raise ParamError(f"column {self.name}: unknown place(s) {', '.join(unknown)}; "
                             f"known: {', '.join(PLACES)}")
        if self.compute is not None and self.group != "map":
            raise ParamError(f"column {self.name}: only a map column has a computation")
        if not self.label:
            object.__setattr__(self, "label", self.name.replace("_", " "))
        if not self.format:
            object.__setattr__(self, "format", _FORMATS.get(self.dtype, ""))
        if not self.short:
            object.__setattr__(self, "short", self.name)
        object.__setattr__(self, "at", dict(self.at))

    @property
    def key(self) -> str:
        """The name (what the report's ranking calls a metric's key)."""
        return self.name

    @property
    def higher(self) -> bool:
        """Higher is better."""
        return self.better == "higher"

    @property
    def direction(self) -> str:
        """``"higher is better"`` or ``"lower is better"``."""
        return "higher is better" if self.higher else "lower is better"

    @property
    def heading(self) -> str:
        """Label with unit, e.g. ``"ATE RMSE (m)"``."""
        return f"{self.label} ({self.unit})" if self.unit else self.label

    def format_number(self, x: float) -> str:
        """A number of this column: whole numbers without decimals, else :attr:`format`.

        Examples
        --------
        >>> COLUMNS["corners"].format_number(12.0), COLUMNS["corners"].format_number(12.25)
        ('12', '12.2')
        """
        if float(x).is_integer() and abs(x) < 1e15:
            return str(int(x))
        return format(x, self.format)


def _c(name: str, dtype: str, group: str, **kw: Any) -> Column:
    return Column(name, dtype, group, **kw)


_RUN = (
    _c("map", "str", "run", at={"files": 1}),
    _c("algorithm", "str", "run"),
    _c("sequence", "str", "run"),
    _c("run", "str", "run"),
    _c("trajectory", "str", "run", at={"files": 2}),
    _c("groundtruth", "str", "run", at={"files": 3}),
    _c("scans", "str", "run", at={"files": 8}),
    _c("hash", "str", "run", at={"files": 7}),
    _c("config", "str", "run"),
    _c("unknown_value", "int", "run"),
    _c("error", "str", "run"),
    _c("seconds", "float", "run", unit="s", at={"detail": 35}),
)
_MAP = (
    _c("source", "str", "map"),
    _c("height", "int", "map", unit="cells", at={"detail": 33}),
    _c("width", "int", "map", unit="cells", at={"detail": 34}),
    _c("total", "int", "map", unit="cells", at={"summary": 12, "detail": 32}),
    _c("known", "int", "map", unit="cells", at={"summary": 11, "eval": 1, "detail": 31}),
    _c("unknown", "int", "map", unit="cells", at={"summary": 10, "detail": 30}),
    _c("occupied", "int", "map", unit="cells", at={"summary": 8, "eval": 2, "detail": 28}),
    _c("free", "int", "map", unit="cells", at={"summary": 9, "detail": 29}),
    _c("occupied_fraction", "float", "map", better="lower",
       why="paper III.A: the higher the proportion of occupied cells, the less suitable the "
           "algorithm (blurred or doubled walls)",
       at={"summary": 1, "console": 2, "eval": 3, "ranked": 2, "validity": 3, "detail": 22,
           "timeline": 1}),
    _c("proportion", "float", "map", better="lower",
       at={"summary": 2, "console": 3, "eval": 4, "validity": 4, "detail": 26}),
    _c("threshold", "float", "map", at={"summary": 3, "detail": 27}),
    _c("corners", "int", "map", better="lower", log=True,
       why="paper III.B: the map with fewer corners is more likely consistent, with fewer "
           "artifacts (doubled walls, overlaps)",
       at={"summary": 4, "console": 4, "eval": 5, "ranked": 3, "validity": 1, "detail": 23,
           "timeline": 2}),
    _c("enclosed_areas", "int", "map", better="lower", log=True,
       why="paper III.C: the more enclosed areas (superposed rooms, failed loop closure), "
           "the lower the quality of the map",
       at={"summary": 6, "console": 5, "eval": 7, "ranked": 4, "validity": 5, "detail": 24,
           "timeline": 3}),
    _c("enclosed_unknown_value", "int", "map", short="peak_at_u",
       at={"summary": 7, "eval": 8, "detail": 25}),
    _c("resolution", "float", "map", unit="m", at={"summary": 15}),
    _c("known_area_m2", "float", "map", unit="m2", at={"summary": 13}),
    _c("corners_canonical", "int", "map", label="canonical corners", better="lower",
       log=True, short="canonical",
       why="docs/spec.md section 3a: the corners of the map turned to its walls' direction "
           "and resampled to one resolution, comparable between maps saved differently",
       at={"summary": 5, "eval": 6, "validity": 2}),
    _c("wall_angle", "float", "map", unit="deg", at={"summary": 16}),
    _c("wall_symmetry", "str", "map"),
    _c("saver", "str", "map"),
    _c("flags", "str", "map"),
    _c("known_box_m2", "float", "map", unit="m2", at={"summary": 14}),
    _c("curve", "ints", "map"),
)
#: ``param_<name>`` of every map parameter, with its type and unit (slamq.params).
_PARAMS = tuple(
    _c(f"param_{f.name}", "int" if f.type == "int" else "float", "param",
       unit=f.metadata["unit"])
    for f in fields(Params)
)
_ATE = (
    _c("ate_rmse", "float", "ate", label="ATE RMSE", unit="m", better="lower", log=True,
       format=".3f", why="paper IV: a lower RMSE means the algorithm gives better results",
       at={"summary": 1, "console": 1, "ranked": 1, "truth": 1, "detail": 1,
           "resources": 1}),
    *(_c(f"ate_{s}", "float", "ate", unit="m", better="lower", at={"summary": i, "detail": i})
      for i, s in enumerate(("mean", "median", "std", "min", "max"), 2)),
    _c("ate_n", "int", "ate", unit="poses", at={"summary": 7, "detail": 7}),
    _c("ate_error", "str", "ate", at={"files": 5}),
)
_SECTION7 = "docs/spec.md section 7"
_GT = (
    _c("gt_map", "str", "gt", at={"files": 4}),
    _c("gt_precision", "float", "gt", better="higher", at={"summary": 1, "detail": 8}),
    _c("gt_recall", "float", "gt", better="higher", at={"summary": 2, "detail": 9}),
    _c("gt_f1", "float", "gt", label="GT F1", better="higher",
       why=f"{_SECTION7}: the harmonic mean of the shares of estimated walls near a "
           "ground-truth wall and of ground-truth walls near an estimated one, after "
           "alignment",
       at={"summary": 3, "ranked": 5, "truth": 3, "detail": 10, "resources": 2}),
    _c("gt_iou", "float", "gt", better="higher", at={"summary": 4, "detail": 11}),
    _c("gt_ne", "float", "gt", unit="m", better="lower", at={"summary": 5, "detail": 12}),
    _c("gt_reverse", "float", "gt", unit="m", better="lower", at={"summary": 6, "detail": 13}),
    _c("gt_chamfer", "float", "gt", label="GT chamfer", unit="m", better="lower", log=True,
       why=f"{_SECTION7}: the mean distance from each map's walls to the other's (missing "
           "walls and ghost walls), after alignment",
       at={"summary": 7, "ranked": 6, "truth": 2, "detail": 14}),
    _c("gt_coverage", "float", "gt", better="higher", at={"summary": 8, "detail": 15}),
    _c("gt_dx", "float", "gt", unit="m", at={"detail": 16}),
    _c("gt_dy", "float", "gt", unit="m", at={"detail": 17}),
    _c("gt_dyaw", "float", "gt", unit="deg", at={"detail": 18}),
    _c("gt_icp_rms", "float", "gt", unit="m", at={"detail": 19}),
    _c("gt_truncated", "int", "gt", unit="cells", at={"detail": 20}),
    _c("gt_outside", "int", "gt", unit="cells", at={"detail": 21}),
    _c("gt_error", "str", "gt", at={"files": 6}),
)
_SECTION6A = "docs/spec.md section 6a (Kümmerle et al. 2009)"
_REL = (
    _c("relations", "str", "rel", at={"files": 8}),
    _c("rel_trans_abs_mean", "float", "rel", label="relations trans. error", unit="m",
       better="lower", log=True, format=".3f",
       why=f"{_SECTION6A}: the mean error of the estimate's motion between the stamps of "
           "each manually verified relation; the figure the 2D SLAM papers report",
       at={"summary": 1, "console": 6, "ranked": 7, "truth": 4, "detail": 36,
           "resources": 3}),
    _c("rel_trans_abs_std", "float", "rel", unit="m", better="lower",
       at={"summary": 2, "detail": 37}),
    _c("rel_trans_sq_mean", "float", "rel", unit="m2", better="lower",
       at={"summary": 3, "detail": 38}),
    _c("rel_trans_sq_std", "float", "rel", unit="m2", better="lower",
       at={"summary": 4, "detail": 39}),
    _c("rel_trans_max", "float", "rel", unit="m", better="lower",
       at={"summary": 5, "detail": 40}),
    _c("rel_rot_abs_mean", "float", "rel", label="relations rot. error", unit="deg",
       better="lower", format=".2f",
       why=f"{_SECTION6A}: the mean error of the estimate's turn between the stamps of "
           "each relation",
       at={"summary": 6, "console": 7, "truth": 5, "detail": 41}),
    _c("rel_rot_abs_std", "float", "rel", unit="deg", better="lower",
       at={"summary": 7, "detail": 42}),
    _c("rel_rot_sq_mean", "float", "rel", unit="deg2", better="lower",
       at={"summary": 8, "detail": 43}),
    _c("rel_rot_sq_std", "float", "rel", unit="deg2", better="lower",
       at={"summary": 9, "detail": 44}),
    _c("rel_rot_max", "float", "rel", unit="deg", better="lower",
       at={"summary": 10, "detail": 45}),
    _c("rel_n", "int", "rel", label="relations placed", unit="relations",
       at={"summary": 11, "detail": 46}),
    _c("rel_n_relations", "int", "rel", unit="relations", at={"detail": 47}),
    _c("rel_n_unplaced", "int", "rel", label="relations not placed", unit="relations",
       at={"summary": 12, "detail": 48}),
    _c("rel_n_interpolated", "int", "rel", unit="relations", at={"detail": 49}),
    _c("rel_n_reversed", "int", "rel", unit="relations"),
    _c("rel_n_duplicates", "int", "rel", unit="relations"),
    _c("rel_error", "str", "rel", at={"files": 9}),
)
_VERDICT = (
    _c("agreement", "float", "verdict", better="higher",
       why="docs/spec.md section 9: the median consistency of the map's walls with the other "
           "maps of the sequence, once laid over each other (no ground truth needed); a map "
           "under 0.9 of the best, or flagged by a defect detector, is never named best"),
    _c("scan_violation", "float", "verdict", label="violation share", better="lower",
       why="docs/spec.md section 7b: the share of the map's own laser beams, placed at its "
           "own trajectory, that pass through a wall of the map (no ground truth needed); "
           "grazes along a wall drawn thick count too, so the verdict weighs the crossing "
           "share"),
    _c("scan_crossing", "float", "verdict", label="crossing share", better="lower",
       why="docs/spec.md sections 7b and 9: the share of the map's own laser beams, placed "
           "at its own trajectory, that pass through a wall of the map and come out into "
           "free space beyond it (no ground truth needed); a map above max(0.02, 1.5x the "
           "lowest of the sequence) is inconsistent with its own data and never named best"),
    _c("scan_split", "float", "verdict", label="split crossing share", better="lower",
       why="docs/spec.md sections 7e and 9: the path against its own scans split in time - "
           "each half of the scans drawn as a map at the path's poses, the share of the other "
           "half's beams that cross its walls (the program's map is not read); a path above "
           "max(0.02, 1.5x the lowest of the sequence) is never named best"),
)


#: The table (the shipped columns, then the registered ones), by name, in record order.
_TABLE: dict[str, Column] = {}
#: Every column, by name: a read-only view of the table (:func:`register_column` adds one).
COLUMNS: Mapping[str, Column] = MappingProxyType(_TABLE)
#: What views derive from the table (cleared when it changes).
_CACHE: dict[Any, Any] = {}


def _rebuild(columns: Sequence[Column]) -> None:
    order = {g: i for i, g in enumerate(GROUPS)}
    ordered = sorted(columns, key=lambda c: order[c.group])  # stable: table order in a group
    _TABLE.clear()
    _TABLE.update((c.name, c) for c in ordered)
    _CACHE.clear()


_rebuild((*_RUN, *_MAP, *_PARAMS, *_ATE, *_GT, *_REL, *_VERDICT))
#: The columns slamq itself computes (never unregistered).
_SHIPPED = frozenset(_TABLE)


def column(name: str) -> Column:
    """The row of ``name``.

    Examples
    --------
    >>> column("gt_dyaw").unit
    'deg'
    """
    try:
        return COLUMNS[name]
    except KeyError:
        raise ParamError(f"no column {name!r} in slamq.columns.COLUMNS") from None


def register_column(col: Column) -> Column:
    """Add a column to the table (after the shipped columns of its group).

    A ``map`` column with a ``compute`` function is computed with every evaluation; any
    column then appears in records, results files (with its type) and every place its
    ``at`` names. :func:`unregister_column` takes it out again. Register before evaluating:
    a batch's threads share the table, other processes (a Dask cluster's workers) do not.

    Examples
    --------
    >>> import numpy as np, slamq
    >>> c = register_column(Column("walls", "int", "map", compute=lambda m: int(
    ...     (m.values[~m.unknown] < 50).sum()), at={"summary": 99}))
    >>> slamq.evaluate(np.zeros((2, 3), np.uint8)).to_dict()["walls"]
    6
    >>> "walls" in record_columns(), "walls" in shown("summary", "map").names()
    (True, True)
    >>> unregister_column("walls")
    """
    if not isinstance(col, Column):
        raise ParamError(f"register_column takes a Column, not {type(col).__name__}")
    if col.name in COLUMNS:
        raise ParamError(f"column {col.name!r} is already in the table")
    _rebuild((*COLUMNS.values(), col))
    return col


def unregister_column(name: str) -> None:
    """Remove a column :func:`register_column` added (a shipped column stays)."""
    if name in _SHIPPED:
        raise ParamError(f"column {name!r} is one of slamq's own; it cannot be removed")
    if name not in COLUMNS:
        raise ParamError(f"no registered column {name!r}")
    _rebuild([c for c in COLUMNS.values() if c.name != name])


def _cached(key: Any, make: Callable[[], Any]) -> Any:
    try:
        return _CACHE[key]
    except KeyError:
        value = _CACHE[key] = make()
        return value


def group_names(*groups: str) -> tuple[str, ...]:
    """The names of the columns of ``groups``, in record order.

    Examples
    --------
    >>> group_names("ate")
    ('ate_rmse', 'ate_mean', 'ate_median', 'ate_std', 'ate_min', 'ate_max', 'ate_n', 'ate_error')
    """
    return _cached(("group", groups), lambda: tuple(
        c.name for c in COLUMNS.values() if c.group in groups))


def record_columns(curve: bool = False) -> tuple[str, ...]:
    """The keys of a record, in order (``curve`` only when asked for).

    Examples
    --------
    >>> cols = record_columns()
    >>> cols[:3], "corners" in cols, "curve" in cols, "ate_rmse" in cols, "rel_n" in cols
    (('map', 'algorithm', 'sequence'), True, False, True, True)
    """
    names = group_names("run", "map", "param", "ate", "gt", "rel")
    return names if curve else tuple(n for n in names if n != "curve")


def computed_columns() -> tuple[Column, ...]:
    """The registered map columns that have a computation, in table order."""
    return _cached("computed", lambda: tuple(
        c for c in COLUMNS.values() if c.compute is not None))


def _shown(place: str, groups: tuple[str, ...]) -> tuple[Column, ...]:
    if place not in PLACES:
        raise ParamError(f"unknown place {place!r}; known: {', '.join(PLACES)}")
    cols = [c for c in COLUMNS.values() if place in c.at and (not groups or c.group in groups)]
    return tuple(sorted(cols, key=lambda c: c.at[place]))


T = TypeVar("T")


class _Live(Sequence[T]):
    """A sequence derived from the table each time it is read (cached until it changes)."""

    def __init__(self, make: Callable[[], tuple[T, ...]], what: str) -> None:
        self._make = make
        self._what = what

    @overload
    def __getitem__(self, i: int) -> T: ...
    @overload
    def __getitem__(self, i: slice) -> tuple[T, ...]: ...
    def __getitem__(self, i: int | slice) -> T | tuple[T, ...]:
        return self._make()[i]

    def __len__(self) -> int:
        return len(self._make())

    def __iter__(self) -> Iterator[T]:
        return iter(self._make())

    def __add__(self, other: Sequence[T]) -> tuple[T, ...]:
        return self._make() + tuple(other)

    def __radd__(self, other: Sequence[T]) -> tuple[T, ...]:
        return tuple(other) + self._make()

    def __eq__(self, other: object) -> bool:
        return self._make() == (tuple(other) if isinstance(other, (_Live, tuple)) else other)

    def __hash__(self) -> int:
        return hash(self._what)

    def __repr__(self) -> str:
        return f"<{self._what}: {', '.join(map(str, self._make()))}>"


class Shown(_Live[Column]):
    """The columns shown at one place, in order, as they are in the table now (a sequence
    derived again when the table changes)."""

    def __init__(self, place: str, groups: tuple[str, ...] = ()) -> None:
        _shown(place, groups)  # the place is checked once, here
        self.place = place
        self.groups = tuple(groups)
        where = f"columns shown at {place}" + (f" ({', '.join(groups)})" if groups else "")
        super().__init__(lambda: _cached(("shown", place, self.groups),
                                         lambda: _shown(place, self.groups)), where)

    def names(self) -> tuple[str, ...]:
        """The names of the columns, in order."""
        return tuple(c.name for c in self._make())

    def __repr__(self) -> str:
        return f"<{self._what}: {', '.join(self.names())}>"


class Names(_Live[str]):
    """Column names as they are in the table now: a live sequence (a module constant such as
    :data:`slamq.results.validity.METRICS` that follows :func:`register_column`).

    Examples
    --------
    >>> v = Names(lambda: group_names("ate"), "ate columns")
    >>> v[0], len(v), "ate_n" in v
    ('ate_rmse', 8, True)
    """


def shown(place: str, *groups: str) -> Shown:
    """The columns shown at ``place`` (of ``groups``, default all), in their order: a live
    view, which follows :func:`register_column`.

    Examples
    --------
    >>> shown("ranked").names()  # doctest: +NORMALIZE_WHITESPACE
    ('ate_rmse', 'occupied_fraction', 'corners', 'enclosed_areas', 'gt_f1', 'gt_chamfer',
     'rel_trans_abs_mean')
    >>> shown("validity").names()
    ('corners', 'corners_canonical', 'occupied_fraction', 'proportion', 'enclosed_areas')
    """
    return Shown(place, groups)


def shown_names(place: str, *groups: str) -> Names:
    """The names of :func:`shown`'s columns, as a live sequence.

    Examples
    --------
    >>> tuple(shown_names("truth"))
    ('ate_rmse', 'gt_chamfer', 'gt_f1', 'rel_trans_abs_mean', 'rel_rot_abs_mean')
    """
    view = shown(place, *groups)
    return Names(view.names, view._what)


def group_view(*groups: str) -> Names:
    """The names of the columns of ``groups`` (:func:`group_names`), as a live sequence."""
    return Names(lambda: group_names(*groups), f"{', '.join(groups)} columns")
