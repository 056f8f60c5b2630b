"""The terminal table of :class:`slamq.MapQuality` results (``slamq eval``).

Files are written and read by :mod:`slamq.results.formats`.
"""

from __future__ import annotations

import math
import os
import sys
import textwrap
from collections.abc import Sequence
from typing import IO

from slamq.columns import COLUMNS, shown
from slamq.models import MapQuality

__all__ = ["format_table", "print_table"]

#: The first two columns (heading, key, alignment): the map (its short name) and its size;
#: then the columns of the table shown at ``eval`` (:data:`slamq.columns.COLUMNS`).
_LEAD = (("map", "source", "<"), ("cells", None, ">"))


#: Printed under the table: what the columns mean.
LEGEND = (
    "lower is better for occupied_fraction, corners and enclosed_areas (paper III); "
    "peak_at_u: the unknown value at which enclosed_areas peaks; proportion = occupied / "
    "(free + unknown) depends on the canvas"
)
#: Added to :data:`LEGEND` when the table has the canonical column.
CANONICAL_LEGEND = (
    "; canonical: corners of the map turned to its walls' direction and resampled to "
    "canonical_resolution (compare maps of different orientation or resolution on it)"
)


def _has_canonical(results: Sequence[MapQuality]) -> bool:
    """Whether a map has corners_canonical (off by default): then the table shows its
    column and the legend explains it."""
    return any(q.corners_canonical is not None for q in results)


def _optional(name: str) -> bool:
    """A column that is None unless asked for (corners_canonical, a registered column)."""
    f = MapQuality.__dataclass_fields__.get(name)
    return f is None or f.default is None


def _columns(results: Sequence[MapQuality]) -> list[tuple[str, str | None, str]]:
    """(heading, key, alignment) of the table's columns: :data:`_LEAD`, then those shown
    at ``eval``; an optional column only when some map has it."""
    return [*_LEAD, *((c.short, c.name, "<" if c.dtype == "str" else ">")
                      for c in shown("eval") if not _optional(c.name)
                      or any(q.value(c.name) is not None for q in results))]


def _cell(q: MapQuality, key: str | None, names: dict[str, str]) -> str:
    if key is None:
        return f"{q.height}x{q.width}"
    value = q.value(key)
    if value is None:
        return "-"
    if isinstance(value, float):
        return "nan" if math.isnan(value) else format(value, COLUMNS[key].format)
    if key == "source":
        return names.get(str(value), str(value))
    return str(value)


def short_names(paths: Sequence[str]) -> dict[str, str]:
    """Each path without the folder all of them share (and relative to the current folder
    when that is shorter): ``/data/runs/office/a.yaml`` -> ``office/a.yaml``.

    Examples
    --------
    >>> short_names(["/d/runs/office/a.yaml", "/d/runs/lab/b.yaml"])
    {'/d/runs/office/a.yaml': 'office/a.yaml', '/d/runs/lab/b.yaml': 'lab/b.yaml'}
    """
    files = [p.partition(":/")[0] for p in paths if not p.startswith("<")]  # bag:/topic[i]
    if len(files) > 1:
        common = os.path.commonpath([os.path.dirname(os.path.abspath(p)) for p in files])
    else:
        common = os.path.dirname(os.path.abspath(files[0])) if files else ""
    out = {}
    for p in paths:
        if p.startswith("<"):
            out[p] = p
            continue
        path, sep, topic = p.partition(":/")
        short = os.path.relpath(os.path.abspath(path), common) if common else path
        try:
            rel = os.path.relpath(path)
        except ValueError:
            rel = path
        out[p] = min((short, rel, path), key=len) + sep + topic
    return out


def format_table(results: Sequence[MapQuality]) -> str:
    """One aligned text row per map.

    Examples
    --------
    >>> import numpy as np, slamq
    >>> header, row = format_table([slamq.evaluate(np.full((4, 4), 254, np.uint8))]).splitlines()
    >>> header.split()[:5]
    ['map', 'cells', 'known', 'occupied', 'occupied_fraction']
    >>> row.split()[:5]
    ['<array>', '4x4', '16', '0', '0.0000']
    """
    names = short_names([q.source for q in results])
    columns = _columns(results)
    rows = [[h for h, _, _ in columns]]
    rows += [[_cell(q, key, names) for _, key, _ in columns] for q in results]
    widths = [max(len(r[i]) for r in rows) for i in range(len(columns))]
    lines = []
    for r in rows:
        parts = [
            (c.ljust(w) if align == "<" else c.rjust(w))
            for c, w, (_, _, align) in zip(r, widths, columns)
        ]
        lines.append("  ".join(parts).rstrip())
    return "\n".join(lines)


def print_table(
    results: Sequence[MapQuality], *, curve: bool = False, file: IO[str] | None = None
) -> None:
    """Print :func:`format_table` (and each map's enclosed-area curve when ``curve``)."""
    out = file or sys.stdout
    print(format_table(results), file=out)
    legend = LEGEND + (CANONICAL_LEGEND if _has_canonical(results) else "")
    print(textwrap.fill(legend, width=100), file=out)
    if curve:
        names = short_names([q.source for q in results])
        for q in results:
            if q.curve is not None:
                values = q.params.sweep_values
                pairs = " ".join(f"{u}:{c}" for u, c in zip(values, q.curve))
                print(f"{names[q.source]} curve u:count_u {pairs}", file=out)
