"""Reader of ground-truth relations files (Kümmerle et al. 2009, the Freiburg format).

One relation per line, whitespace separated: ``t1 t2 x y z roll pitch yaw`` -- the motion
from the robot's pose at ``t1`` to its pose at ``t2`` in the frame of ``t1`` (metres,
radians). The format is planar: ``z``, ``roll`` and ``pitch`` must be 0 (within
:data:`PLANAR_TOL`). Blank lines and lines starting with ``#`` are skipped; a ``.gz`` file
is read through gzip.
"""

from __future__ import annotations

import gzip
import math
import os
from pathlib import Path

import numpy as np

from slamq.errors import TrajectoryError
from slamq.models.relations import Relations

__all__ = ["read_relations", "load_relations", "PLANAR_TOL"]

#: Largest ``|z|``, ``|roll|``, ``|pitch|`` accepted in a planar relation.
PLANAR_TOL = 1e-6


def read_relations(path: str | os.PathLike) -> Relations:
    """Read a relations file (``t1 t2 x y z roll pitch yaw`` per line).

    Raises
    ------
    TrajectoryError
        The file cannot be read, is empty, a line has another number of fields or a value
        that is not a finite number, or a relation is not planar; the message names the
        file and the line (1-based).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "r.relations"
    >>> _ = p.write_text("# t1 t2 x y z roll pitch yaw\\n1.5 2.5 0.3 0.01 0 0 0 0.1\\n")
    >>> r = read_relations(p)
    >>> len(r), r.t1.tolist(), r.motion.tolist()
    (1, [1.5], [[0.3, 0.01, 0.1]])
    """
    path = Path(path)
    src = str(path)
    try:
        if path.suffix == ".gz":
            with gzip.open(path, "rt", encoding="utf-8", errors="replace") as f:
                text = f.read()
        else:
            text = path.read_text(encoding="utf-8", errors="replace")
    except (OSError, EOFError) as exc:
        raise TrajectoryError(f"{src}: cannot read the relations file ({exc})") from None
    rows: list[list[float]] = []
    for lineno, line in enumerate(text.splitlines(), 1):
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        fields = s.split()
        if len(fields) != 8:
            raise TrajectoryError(
                f"{src}: line {lineno}: {len(fields)} fields, a relation has 8 "
                f"(t1 t2 x y z roll pitch yaw)")
        try:
            vals = [float(v) for v in fields]
        except ValueError:
            bad = next(v for v in fields if not _is_float(v))
            raise TrajectoryError(f"{src}: line {lineno}: {bad!r} is not a number") from None
        if not all(math.isfinite(v) for v in vals):
            raise TrajectoryError(f"{src}: line {lineno}: NaN or infinite value")
        if max(abs(vals[4]), abs(vals[5]), abs(vals[6])) > PLANAR_TOL:
            raise TrajectoryError(
                f"{src}: line {lineno}: not a planar relation (z, roll, pitch = "
                f"{vals[4]}, {vals[5]}, {vals[6]}; slamq's relations are SE(2))")
        rows.append(vals)
    if not rows:
        raise TrajectoryError(f"{src}: no relations in the file")
    a = np.asarray(rows)
    return Relations(a[:, 0], a[:, 1], a[:, [2, 3, 7]], source=src)


#: :func:`read_relations` under the name of the package's other loaders.
load_relations = read_relations


def _is_float(v: str) -> bool:
    try:
        float(v)
    except ValueError:
        return False
    return True
