"""How the report prints numbers: integers whole, else three significant digits, and
``mean ± std`` over runs with floating-point noise shown as 0."""

from __future__ import annotations

import math

__all__ = ["clean_std", "format_mean_std", "format_value"]


def format_value(x: float) -> str:
    """A number as the report prints it: integers whole, else 3 significant digits.

    Examples
    --------
    >>> format_value(12.0), format_value(0.23912), format_value(1234.5), format_value(float("nan"))
    ('12', '0.239', '1234.5', '–')
    """
    if x is None or not math.isfinite(x):
        return "–"
    if float(x).is_integer():
        return str(int(x))
    if abs(x) >= 100:
        return f"{x:.1f}"
    return f"{x:.3g}"


def format_mean_std(mean: float, std: float) -> str:
    """``"mean ± std"``, or the mean alone when there is no std (one run).

    Examples
    --------
    >>> format_mean_std(0.239, 0.011), format_mean_std(7.0, float("nan"))
    ('0.239 ± 0.011', '7')
    >>> format_mean_std(0.0241, 3.49e-18)   # rounding noise of equal runs is 0
    '0.0241 ± 0'
    """
    if std is None or not math.isfinite(std):
        return format_value(mean)
    return f"{format_value(mean)} ± {format_value(clean_std(mean, std))}"


def clean_std(mean: float, std: float) -> float:
    """``std``, or 0 when it is floating-point noise (below 1e-9 of the mean's size).

    Examples
    --------
    >>> clean_std(0.0241, 3.49e-18), clean_std(0.0241, 0.002)
    (0.0, 0.002)
    """
    scale = max(abs(mean), 1.0) if math.isfinite(mean) else 1.0
    return 0.0 if abs(std) <= 1e-9 * scale else std
