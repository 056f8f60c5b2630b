"""The terminal table of :class:`slamq.MapQuality` results (``slamq eval``).

Files are written and read by :mod:`slamq.results.files`.
"""

from __future__ import annotations

import math
import os
import sys
from collections.abc import Sequence
from typing import IO

from slamq.models import MapQuality

__all__ = ["format_table", "print_table"]

_COLUMNS = (
    ("map", "source", "<"),
    ("H x W", None, ">"),
    ("known", "known", ">"),
    ("occupied", "occupied", ">"),
    ("occ. fraction", "occupied_fraction", ">"),
    ("proportion", "proportion", ">"),
    ("corners", "corners", ">"),
    ("enclosed", "enclosed_areas", ">"),
    ("at u", "enclosed_unknown_value", ">"),
)


def _cell(q: MapQuality, key: str | None) -> str:
    if key is None:
        return f"{q.height} x {q.width}"
    value = getattr(q, key)
    if isinstance(value, float):
        return "nan" if math.isnan(value) else f"{value:.4f}"
    if key == "source":
        return _short(str(value))
    return str(value)


def _short(path: str) -> str:
    try:
        rel = os.path.relpath(path)
    except ValueError:
        return path
    return rel if len(rel) <= len(path) else path


def format_table(results: Sequence[MapQuality]) -> str:
    """One aligned text row per map.

    Examples
    --------
    >>> import numpy as np, slamq
    >>> print(format_table([slamq.evaluate(np.full((4, 4), 254, np.uint8))]).splitlines()[0])
    map      H x W  known  occupied  occ. fraction  proportion  corners  enclosed  at u
    """
    rows = [[h for h, _, _ in _COLUMNS]]
    rows += [[_cell(q, key) for _, key, _ in _COLUMNS] for q in results]
    widths = [max(len(r[i]) for r in rows) for i in range(len(_COLUMNS))]
    lines = []
    for r in rows:
        parts = [
            (c.ljust(w) if align == "<" else c.rjust(w))
            for c, w, (_, _, align) in zip(r, widths, _COLUMNS)
        ]
        lines.append("  ".join(parts).rstrip())
    return "\n".join(lines)


def print_table(
    results: Sequence[MapQuality], *, curve: bool = False, file: IO[str] | None = None
) -> None:
    """Print :func:`format_table` (and each map's enclosed-area curve when ``curve``)."""
    out = file or sys.stdout
    print(format_table(results), file=out)
    if curve:
        for q in results:
            if q.curve is not None:
                values = q.params.sweep_values
                pairs = " ".join(f"{u}:{c}" for u, c in zip(values, q.curve))
                print(f"{_short(q.source)} curve u:count_u {pairs}", file=out)
