"""Every parameter slamq takes, in one schema: the map metrics' and every other family's.

* **map** (docs/spec.md sections 3 and 4): the fields of :class:`Params`, each with its
  default, range, unit and help. Generated from them: the keyword checks of
  :func:`slamq.evaluate` and :func:`slamq.metrics.reference.evaluate`, the
  ``--log-threshold``-style options of every CLI command, the parameter list in
  :class:`Params`' docstring, the ``param_*`` columns of results files (names and types),
  and what the Rust core receives (it reads these attributes, rust/src/bindings/maps.rs).
* **load**, **runtime**, **trajectory**, **compare**, **consensus**, **synth**,
  **defects**: the rows of :data:`SETTINGS` (``unknown_value``; ``threads``; ``max_dt``,
  ``offset``, the ATE / RPE alignments, ``unsorted``; the ground-truth comparison's
  alignment, tolerance, occupied threshold and distance cap; the consensus' quorum and
  radius; the generated worlds' kinds and odometry noise presets; the thresholds of the
  defect detectors, :mod:`slamq.metrics.defects`). Function signatures,
* **load**, **runtime**, **trajectory**, **compare**, **register**, **consensus**,
  **synth**: the rows of
  :data:`SETTINGS` (``unknown_value``; ``threads``; ``max_dt``, ``offset``, the ATE / RPE
  alignments, ``unsorted``; the ground-truth comparison's alignment, tolerance, occupied
  threshold and distance cap; the registration's refusal thresholds ``min_inliers``,
  ``min_overlap``, ``min_margin``; the consensus' quorum and radius; the generated worlds' kinds
  and odometry noise presets). Function signatures,
  option objects (:class:`slamq.batch.records.EvalOptions`) and CLI options
  (:meth:`Setting.add_option`) take their defaults and choices from these rows.

tests/test_params.py holds everything else to the schema: every function signature and
every CLI option of the package that has a parameter of the schema has its default (and
choices); the Rust core's defaults (``default_params()``, ``compare``'s keywords, hence
``_core.pyi``, which tests/test_architecture.py keeps equal to the core) and its ranges
(each map parameter just inside and just outside its range) are the schema's.

Adding a parameter is one row here plus its use: for a map parameter, its field in the
Rust ``Params`` (rust/src/params.rs, with the same default) and its read and range check
in rust/src/bindings/maps.rs, then the metric (Rust and the reference function); for any
other family, the keyword of the function that uses it (its default from the row) and, for
a command, one ``add_option`` call.
"""

from __future__ import annotations

import argparse
import math
import numbers
import os
from dataclasses import asdict, dataclass, field, fields
from typing import Any

from slamq.errors import ParamError

__all__ = [
    "MAX_THREADS",
    "PARAM_NAMES",
    "SETTINGS",
    "Params",
    "Setting",
    "add_param_options",
    "check_threads",
    "param_help",
    "params_doc",
    "params_from_args",
]

#: The largest ``threads`` any slamq call accepts: four per CPU of this machine.
MAX_THREADS = 4 * (os.cpu_count() or 1)


def _param(default: float, low: float | None, high: float | None, unit: str, help: str) -> Any:
    """A :class:`Params` field: its default and, as metadata, range, unit and help."""
    return field(default=default, metadata={"low": low, "high": high, "unit": unit, "help": help})


@dataclass(frozen=True)
class Params:
    """Parameters of the three map metrics (docs/spec.md sections 2-4).

    Parameters
    ----------
    {params}

    Examples
    --------
    >>> from slamq import Params
    >>> Params(min_area=4).min_area
    4
    >>> Params(sweep_step=0)
    Traceback (most recent call last):
    ...
    slamq.errors.ParamError: sweep_step must be an integer in 1..256, got 0
    """

    # --- corners (spec section 3)
    log_threshold: float = _param(
        0.1, None, None, "fraction of 255*256",
        "corner structure mask: Laplacian-of-Gaussian response above "
        "log_threshold * 255 * 256 (a fraction of the largest possible step)",
    )
    min_dot_area: int = _param(
        5, 0, 2**31 - 1, "cells",
        "corner structure mask: components smaller than this are dropped as noise",
    )
    harris_k: float = _param(0.04, None, None, "", "Harris detector free parameter k")
    harris_quality: float = _param(
        0.01, 0.0, 1.0, "fraction of max R",
        "corner mask: Harris response above harris_quality * max R",
    )
    canonical_resolution: float = _param(
        0.0, 0.0, None, "m",
        "corners_canonical: the map is turned to its dominant wall direction and resampled "
        "to this resolution before its corners are counted (0.07 is the reference the spec "
        "validates); 0, the default, skips corners_canonical (the wall angle is computed "
        "either way)",
    )
    # --- enclosed areas (spec section 4)
    sweep_step: int = _param(
        1, 1, 256, "grey levels",
        "enclosed areas: the unknown value u runs over range(0, 256, sweep_step)",
    )
    min_area: int = _param(
        1, 0, 2**31 - 1, "cells",
        "enclosed areas: free components smaller than this are not counted",
    )

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            low, high = f.metadata["low"], f.metadata["high"]
            if f.type == "int":
                if (isinstance(value, bool) or not isinstance(value, numbers.Integral)
                        or not low <= value <= high):
                    raise ParamError(
                        f"{f.name} must be an integer in {low}..{high}, got {value!r}")
                object.__setattr__(self, f.name, int(value))  # numpy integers become int
                continue
            if isinstance(value, bool) or not isinstance(value, numbers.Real):
                raise ParamError(f"{f.name} must be a number, got {value!r}")
            try:
                number = float(value)
            except OverflowError:
                number = math.inf
            if not math.isfinite(number):
                raise ParamError(f"{f.name} must be finite, got {value!r}")
            if (low is not None and number < low) or (high is not None and number > high):
                raise ParamError(f"{f.name} must be in [{low}, {high}], got {number}")
            object.__setattr__(self, f.name, number)

    @classmethod
    def from_kwargs(cls, **kwargs: Any) -> Params:
        """Build parameters from keyword arguments, rejecting unknown names.

        Examples
        --------
        >>> Params.from_kwargs(harris_k=0.05).harris_k
        0.05
        """
        unknown = sorted(set(kwargs) - set(PARAM_NAMES))
        if unknown:
            raise ParamError(
                f"unknown parameter(s) {', '.join(unknown)}; known: {', '.join(PARAM_NAMES)}"
            )
        return cls(**kwargs)

    @classmethod
    def resolve(cls, params: Params | None, kwargs: dict[str, Any]) -> Params:
        """``params``, or parameters built from keywords; not both.

        Examples
        --------
        >>> Params.resolve(None, {"min_area": 3}).min_area
        3
        """
        if params is None:
            return cls.from_kwargs(**kwargs)
        if not isinstance(params, Params):
            raise ParamError(f"params must be a slamq.Params, got {type(params).__name__}")
        if kwargs:
            raise ParamError(f"give params= or parameter keywords, not both "
                             f"(got {', '.join(sorted(kwargs))})")
        return params

    @property
    def sweep_values(self) -> range:
        """The unknown values ``u`` the enclosed-area sweep visits."""
        return range(0, 256, self.sweep_step)

    def to_dict(self) -> dict[str, Any]:
        """The parameters as a plain dict."""
        return asdict(self)


#: The parameter names, in table order.
PARAM_NAMES: tuple[str, ...] = tuple(f.name for f in fields(Params))


@dataclass(frozen=True)
class Setting:
    """One row of the schema outside the map metrics: a parameter of one family.

    Attributes
    ----------
    family : str
        ``"load"``, ``"runtime"``, ``"trajectory"``, ``"compare"``, ``"register"``,
        ``"consensus"``, ``"agreement"``, ``"synth"`` or ``"defects"``.
    name : str
        The row's name (also the keyword or option it is, unless noted in ``help``).
    default : Any
        The default every function, option object and CLI option uses.
    help : str
        One line for ``--help`` and docstrings.
    unit : str
        Unit of a number ("" for none).
    type : type
        ``float``, ``int`` or ``str``.
    low, high : float or None
        The range of a number (inclusive; None: unbounded).
    high_open : bool
        ``high`` itself is out of range (``[low, high)``).
    choices : tuple of str or None
        The values a ``str`` setting takes.

    Examples
    --------
    >>> SETTINGS.max_dt.default, SETTINGS.ate_align.choices
    (0.01, ('se2', 'se3', 'sim3', 'origin', 'none'))
    """

    family: str
    name: str
    default: Any
    help: str
    unit: str = ""
    type: type = float
    low: float | None = None
    high: float | None = None
    choices: tuple[str, ...] | None = None
    high_open: bool = False

    def help_line(self) -> str:
        """The help text with the unit and default (``%`` escaped for argparse).

        Examples
        --------
        >>> SETTINGS.offset.help_line()
        'seconds added to the estimate timestamps (s; default 0.0)'
        """
        unit = f"{self.unit}; " if self.unit else ""
        return f"{self.help} ({unit}default {self.default})".replace("%", "%%")

    def add_option(self, parser: Any, *flags: str, dest: str | None = None,
                   metavar: str | None = None, note: str = "") -> None:
        """Add this setting to an argparse parser as ``--name`` (or ``flags``), with the
        schema's type, default, choices and help (``note``: what the command adds)."""
        flags = flags or ("--" + self.name.replace("_", "-"),)
        text = self.help_line() + (f"; {note}" if note else "")
        kwargs: dict[str, Any] = {"default": self.default, "help": text}
        if dest is not None:
            kwargs["dest"] = dest
        if self.choices is not None:
            kwargs["choices"] = self.choices
        else:
            kwargs["type"] = self.type
            if metavar is not None:
                kwargs["metavar"] = metavar
        parser.add_argument(*flags, **kwargs)


class _Rows(dict):
    """The schema's rows by name, also as attributes (``SETTINGS.max_dt``)."""

    def __getattr__(self, name: str) -> Setting:
        try:
            return self[name]
        except KeyError:
            raise AttributeError(name) from None


_TRAJECTORY_ALIGNMENTS = ("se2", "se3", "sim3", "origin", "none")
_MAP_ALIGNMENTS = ("origin", "icp", "search")

#: Every parameter outside the map metrics, by name (the map metrics': :class:`Params`).
SETTINGS = _Rows((s.name, s) for s in (
    Setting("load", "unknown_value", None,
            "treat pixels equal to this value as unknown, and nothing else", "", int, 0, 255),
    Setting("runtime", "threads", None, "cap on worker threads (default: every core)", "",
            int, 1, MAX_THREADS),
    Setting("trajectory", "max_dt", 0.01, "largest time difference of associated poses",
            "s", float, 0.0, None),
    Setting("trajectory", "offset", 0.0, "seconds added to the estimate timestamps", "s"),
    Setting("trajectory", "ate_align", "se2",
            "alignment of each estimate onto the ground truth for ATE: se2 = rotation about "
            "z + planar translation; se3/sim3/origin as evo -a/-as/--align_origin; none",
            type=str, choices=_TRAJECTORY_ALIGNMENTS),
    Setting("trajectory", "rpe_align", "none",
            "alignment of each estimate onto the ground truth for RPE (as ate_align)",
            type=str, choices=_TRAJECTORY_ALIGNMENTS),
    Setting("trajectory", "trajectory_format", None,
            "file format of a trajectory (default: guessed from the file)", type=str,
            choices=("tum", "kitti", "euroc", "csv", "mrpt", "bag", "pbstream")),
    Setting("trajectory", "unsorted", "error",
            "timestamps going backwards (a restarted log): fail, keep the last run of the "
            "log, or sort", type=str, choices=("error", "last", "sort")),
    Setting("compare", "compare_align", "icp",
            "alignment with the ground-truth map: icp, the files' frames refined by trimmed "
            "ICP; origin, the frames only; search, from the global registration (any "
            "rotation), for maps saved in an arbitrary frame; auto, icp and, when its fit is "
            "poor (precision under min_fit_precision), also search, keeping the better; icp "
            "and origin say what search gives when they fit poorly",
            type=str, choices=("auto",) + _MAP_ALIGNMENTS),
    Setting("compare", "min_fit_precision", 0.5,
            "an alignment whose precision (share of the estimate's walls within tolerance of "
            "a ground-truth wall) is under this fits poorly: search is tried too, and auto "
            "keeps it when it fits better", "", float, 0.0, 1.0),
    Setting("compare", "tolerance", None,
            "matching distance for precision/recall (default: tolerance_cells cells of the "
            "ground truth)", "m", float, 0.0, None),
    Setting("compare", "tolerance_cells", 2.0,
            "the default matching distance, in cells of the ground truth's grid", "cells",
            float, 0.0, None),
    Setting("compare", "occupied_threshold", 0.5,
            "a known cell is occupied when (255 - v) / 255 is above this", "", float, 0.0,
            1.0, high_open=True),
    Setting("compare", "max_distance", None,
            "distances to the ground truth above this count as this (bounds NE for partial "
            "maps)", "m", float, 0.0, None),
    Setting("register", "min_inliers", 0.6,
            "registration refused when the maps' walls agree less than this where they "
            "overlap (the worse direction)", "", float, 0.0, 1.0),
    Setting("register", "min_overlap", 0.1,
            "registration refused when less than this share of either map's walls lands on "
            "the other's known cells", "", float, 0.0, 1.0),
    Setting("register", "min_margin", 0.05,
            "registration refused when a distinct alignment scores within this share of the "
            "best (an ambiguous, symmetric place)", "", float, 0.0, 1.0),
    Setting("synth", "world_kind", "office",
            "kind of generated building (slamq.synth.KINDS says what each is)", type=str,
            choices=("office", "loop", "corridor", "hall", "symmetric", "mixed",
                     "hexagonal", "wing", "warehouse", "house")),
    Setting("synth", "noise", "low", "odometry noise preset (slamq.synth.NOISE)", type=str,
            choices=("none", "low", "high")),
    Setting("consensus", "quorum", 0.5,
            "a consensus cell is occupied when more than this share of the voters has a wall "
            "near it", "", float, 0.0, 1.0, high_open=True),
    Setting("consensus", "radius", 1, "cells of slack between the maps' walls once aligned",
            "cells", int, 0, None),
    Setting("agreement", "agreement_align", "auto",
            "how maps of one place are laid over each other for slamq.agreement: auto (the "
            "files' frames refined by ICP or the global registration, whichever fits better), "
            "register (all into one base map's frame), or as compare's align", type=str,
            choices=("auto", "register") + _MAP_ALIGNMENTS),
    Setting("agreement", "min_support", 0.6,
            "the support (median consistency with the other maps) a map needs to count as "
            "confirmed", "", float, 0.0, 1.0),
    Setting("defects", "superposed_min_separation", 5.0,
            "superposed: the second wall direction is at least this far from the first "
            "(modulo 90 degrees)", "deg", float, 0.0, 45.0),
    Setting("defects", "superposed_min_share", 0.1,
            "superposed: the second direction's peak holds at least this share of the "
            "first's (above the histogram's median)", "", float, 0.0, 1.0),
    Setting("defects", "superposed_min_length", 8.0,
            "superposed: a copy laid over the original holds at least this much wall in "
            "the second direction", "m",
            float, 0.0, None),
    Setting("defects", "superposed_min_mixed", 0.15,
            "superposed: at least this share of the second direction's walls lies in 2 m "
            "tiles that hold main-direction walls too", "", float, 0.0, 1.0),
    Setting("defects", "superposed_min_square", 0.2,
            "superposed: the second direction has walls both ways (the lesser of it and its "
            "perpendicular at least this share of the greater; a lone diagonal wall has "
            "one way)", "", float, 0.0, 1.0),
    Setting("defects", "superposed_split_share", 0.2,
            "superposed: a second direction this strong (share of the first peak) flags the "
            "map wherever its walls lie (parts turned against each other)", "", float, 0.0,
            1.0),
    Setting("defects", "superposed_split_length", 4.0,
            "superposed: a second direction strong enough to flag the map wherever it lies "
            "holds at least this much wall", "m", float, 0.0, None),
    Setting("defects", "doubled_min_gap", 0.1,
            "doubled_walls: smallest free gap between two parallel walls", "m", float,
            0.0, None),
    Setting("defects", "doubled_max_gap", 0.5,
            "doubled_walls: largest free gap between two parallel walls", "m", float, 0.0,
            None),
    Setting("defects", "doubled_min_run", 1.0,
            "doubled_walls: a stretch of parallel pairs counts when it runs this long", "m",
            float, 0.0, None),
    Setting("defects", "doubled_min_length", 4.0,
            "doubled_walls: the map is flagged when the stretches add up to this", "m",
            float, 0.0, None),
    Setting("defects", "doubled_min_share", 0.0,
            "doubled_walls: the stretches must also add up to this share of the map's "
            "wall length (occupied cells times the cell size; 0: no share; 0.01 measured, "
            "not the default: docs/validity.md)", "", float, 0.0, 1.0),
    Setting("defects", "smeared_min_thickness", 0.4,
            "smeared: occupied blobs thicker than this (distance transform) are smears "
            "unless solid rectangles or discs", "m", float, 0.0, None),
    Setting("defects", "smeared_min_area", 2.0,
            "smeared: the map is flagged when the thick cores cover this much", "m2",
            float, 0.0, None),
    Setting("defects", "fragment_min_area", 4.0,
            "fragmented: a disconnected piece of the known area counts from this size",
            "m2", float, 0.0, None),
    Setting("defects", "fragment_min_share", 0.05,
            "fragmented: ... and from this share of the known area", "", float, 0.0, 1.0),
))


def param_help(name: str) -> str:
    """One line: the help text, unit and default of parameter ``name``.

    Examples
    --------
    >>> param_help("min_area")
    'enclosed areas: free components smaller than this are not counted (cells; default 1)'
    """
    f = Params.__dataclass_fields__[name]
    unit = f.metadata["unit"]
    return f"{f.metadata['help']} ({unit + '; ' if unit else ''}default {f.default})"


def check_threads(threads: Any, name: str = "threads") -> int:
    """``threads`` as the core takes it: 0 for "every core", else 1..:data:`MAX_THREADS`.

    Examples
    --------
    >>> check_threads(None), check_threads(2)
    (0, 2)
    >>> check_threads(0)
    Traceback (most recent call last):
    ...
    slamq.errors.ParamError: threads must be a positive integer, got 0
    """
    if threads is None:
        return 0
    if isinstance(threads, bool) or not isinstance(threads, numbers.Integral) or threads < 1:
        raise ParamError(f"{name} must be a positive integer, got {threads!r}")
    if threads > MAX_THREADS:
        raise ParamError(f"{name} must be at most {MAX_THREADS} (4 per CPU), got {threads}")
    return int(threads)


def add_param_options(parser: argparse.ArgumentParser) -> None:
    """Add every parameter of the table as a CLI option (``--log-threshold`` ...)."""
    group = parser.add_argument_group("metric parameters (docs/spec.md sections 3-4)")
    for f in fields(Params):
        group.add_argument(
            "--" + f.name.replace("_", "-"), dest=f.name, default=f.default,
            type=int if f.type == "int" else float,
            help=param_help(f.name).replace("%", "%%"),
        )


def params_from_args(args: argparse.Namespace) -> Params:
    """The :class:`Params` of parsed options added by :func:`add_param_options`."""
    return Params(**{name: getattr(args, name) for name in PARAM_NAMES})


def params_doc(doc: str | None) -> str:
    """``doc`` with its ``{params}`` line replaced by the table's numpydoc parameter list."""
    return (doc or "").replace("{params}", _numpydoc_list())


def _numpydoc_list() -> str:
    lines = []
    for f in fields(Params):
        lines.append(f"{f.name} : {f.type}, default {f.default}")
        lines.append(f"        {param_help(f.name)}.")
    return "\n    ".join(lines)


Params.__doc__ = params_doc(Params.__doc__)
