"""The metric parameters of the spec (docs/spec.md sections 3 and 4): the one table.

Every parameter is declared once, below, as a field of :class:`Params` with its default,
range, unit and help text. Everything else is generated from this table: the keyword
checks of :func:`slamq.evaluate` and :func:`slamq.metrics.reference.evaluate`, the
``--log-threshold``-style options of every CLI command, the parameter list in
:class:`Params`' docstring, the ``param_*`` columns of results files, and what the Rust
core receives (it reads these attributes, rust/src/bindings/maps.rs). Adding a parameter means a
field here, a field of the Rust struct in rust/src/params.rs, and its use in the metric
(Rust and the reference function).
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
    "Params",
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
        0.07, 0.0, None, "m",
        "corners_canonical: the map is turned to its dominant wall direction and resampled "
        "to this resolution before its corners are counted; 0 skips corners_canonical",
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
