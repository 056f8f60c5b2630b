"""Writing :class:`slamq.MapQuality` results: a terminal table, JSON and CSV files.

The JSON and CSV files hold ``MapQuality.to_dict()`` per map, so they can be reloaded with
:func:`read_results` (or pandas) and compared.
"""

from __future__ import annotations

import csv
import json
import math
import os
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import IO, Any, Union

from slamq.quality import MapQuality

__all__ = ["format_table", "print_table", "write_json", "write_csv", "read_results"]

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


PathLike = Union[str, "os.PathLike[str]"]


def _records(results: Sequence[MapQuality]) -> list[dict[str, Any]]:
    return [q.to_dict() for q in results]


def _json_safe(value: Any) -> Any:
    if isinstance(value, float) and math.isnan(value):
        return None
    return value


def write_json(path: PathLike, results: Sequence[MapQuality]) -> Path:
    """Write the results as a JSON list of ``MapQuality.to_dict()`` (NaN as null).

    Examples
    --------
    >>> import numpy as np, slamq, tempfile, os
    >>> q = slamq.evaluate(np.full((4, 4), 254, np.uint8))
    >>> p = write_json(os.path.join(tempfile.mkdtemp(), "r.json"), [q])
    >>> read_results(p)[0]["known"]
    16
    """
    path = Path(path)
    records = [{k: _json_safe(v) for k, v in r.items()} for r in _records(results)]
    path.write_text(json.dumps(records, indent=2) + "\n")
    return path


def _csv_header() -> list[str]:
    """The columns of ``MapQuality.to_dict()``, for a file with no result."""
    from slamq.params import Params

    names = [k for k in MapQuality.__dataclass_fields__ if k != "params"]
    return names + [f"param_{k}" for k in Params.__dataclass_fields__]


def write_csv(path: PathLike, results: Sequence[MapQuality]) -> Path:
    """Write one CSV row per map (the curve, when present, as ``;``-joined counts)."""
    path = Path(path)
    records = _records(results)
    fields = list(records[0].keys()) if records else _csv_header()
    with path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=fields)
        writer.writeheader()
        for r in records:
            if r.get("curve") is not None:
                r["curve"] = ";".join(str(c) for c in r["curve"])
            writer.writerow(r)
    return path


#: The float fields that are NaN when a map has no known cell (null in JSON).
_RATIOS = ("occupied_fraction", "proportion", "threshold")


def read_results(path: PathLike) -> list[dict[str, Any]]:
    """Reload a file written by :func:`write_json` (or ``slamq eval --json``).

    The ratios written as null (a map with no known cell) come back as NaN, so a record
    equals the ``MapQuality.to_dict()`` it was written from (NaN compared as NaN).

    Examples
    --------
    >>> import json, tempfile, os
    >>> p = os.path.join(tempfile.mkdtemp(), "r.json")
    >>> _ = open(p, "w").write(json.dumps([{"corners": 3, "proportion": None}]))
    >>> read_results(p)
    [{'corners': 3, 'proportion': nan}]
    """
    records = list(json.loads(Path(path).read_text()))
    for r in records:
        for k in _RATIOS:
            if k in r and r[k] is None:
                r[k] = math.nan
    return records
