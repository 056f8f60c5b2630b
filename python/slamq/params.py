"""The metric parameters of SPEC.md sections 3 and 4, with their defaults and checks."""

from __future__ import annotations

import math
import numbers
from dataclasses import asdict, dataclass, fields
from typing import Any

from slamq.errors import ParamError

__all__ = ["Params"]


@dataclass(frozen=True)
class Params:
    """Parameters of the three map metrics (SPEC.md sections 2-4).

    Parameters
    ----------
    log_threshold : float, default 0.1
        Corner structure mask: Laplacian-of-Gaussian response above
        ``log_threshold * 255 * 256`` (a fraction of the largest possible step).
    min_dot_area : int, default 5
        Structure-mask components smaller than this many cells are dropped as noise.
    harris_k : float, default 0.04
        Harris detector free parameter ``k``.
    harris_quality : float, default 0.01
        Corner mask: Harris response above ``harris_quality * max R``; in [0, 1].
    sweep_step : int, default 1
        Enclosed areas: the unknown value ``u`` runs over ``range(0, 256, sweep_step)``.
    min_area : int, default 1
        Enclosed areas: free components smaller than this many cells are not counted.

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

    log_threshold: float = 0.1
    min_dot_area: int = 5
    harris_k: float = 0.04
    harris_quality: float = 0.01
    sweep_step: int = 1
    min_area: int = 1

    def __post_init__(self) -> None:
        for name in ("log_threshold", "harris_k", "harris_quality"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, numbers.Real):
                raise ParamError(f"{name} must be a number, got {value!r}")
            if not math.isfinite(float(value)):
                raise ParamError(f"{name} must be finite, got {value!r}")
            object.__setattr__(self, name, float(value))
        if not 0.0 <= self.harris_quality <= 1.0:
            raise ParamError(f"harris_quality must be in [0, 1], got {self.harris_quality}")
        for name, lo, hi in (
            ("min_dot_area", 0, 2**31 - 1),
            ("sweep_step", 1, 256),
            ("min_area", 0, 2**31 - 1),
        ):
            value = getattr(self, name)
            if (isinstance(value, bool) or not isinstance(value, numbers.Integral)
                    or not lo <= value <= hi):
                raise ParamError(f"{name} must be an integer in {lo}..{hi}, got {value!r}")
            object.__setattr__(self, name, int(value))  # numpy integers become int

    @classmethod
    def from_kwargs(cls, **kwargs: Any) -> Params:
        """Build parameters from keyword arguments, rejecting unknown names.

        Examples
        --------
        >>> Params.from_kwargs(harris_k=0.05).harris_k
        0.05
        """
        names = {f.name for f in fields(cls)}
        unknown = sorted(set(kwargs) - names)
        if unknown:
            raise ParamError(
                f"unknown parameter(s) {', '.join(unknown)}; known: {', '.join(sorted(names))}"
            )
        return cls(**kwargs)

    @property
    def sweep_values(self) -> range:
        """The unknown values ``u`` the enclosed-area sweep visits."""
        return range(0, 256, self.sweep_step)

    def to_dict(self) -> dict[str, Any]:
        """The parameters as a plain dict."""
        return asdict(self)
