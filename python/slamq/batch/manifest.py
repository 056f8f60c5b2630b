"""Batch discovery, manifest: the runs a manifest CSV file lists.

Takes a ``.csv`` file (columns :data:`MANIFEST_COLUMNS`, only ``map`` required; the rules
under *Manifest* in :mod:`slamq.batch.runs`); gives its :class:`~slamq.batch.run.Run`
objects in row order (:func:`read_manifest`), paths relative to the manifest's folder,
blank names filled as the flat layout would (:func:`slamq.batch.layouts.flat_names`), a
paired pose log its own ground truth (:func:`slamq.batch.pairing.is_paired_log`).
"""

from __future__ import annotations

import csv
import os
from pathlib import Path

from slamq.batch.layouts import flat_names
from slamq.batch.pairing import is_paired_log
from slamq.batch.run import Run
from slamq.errors import MapError
from slamq.sources.files import PathLike

__all__ = ["MANIFEST_COLUMNS", "read_manifest"]

MANIFEST_COLUMNS = ("algorithm", "sequence", "run", "map", "trajectory", "groundtruth",
                    "gt_map", "relations", "scans")


def read_manifest(path: PathLike) -> list[Run]:
    """Read a manifest CSV: one run per row, paths relative to the manifest's folder.

    Columns (header row required, any order, case-insensitive): ``map`` (required),
    ``algorithm``, ``sequence``, ``run``, ``trajectory``, ``groundtruth``, ``gt_map`` (the
    sequence's ground-truth map), ``relations`` (the sequence's relations file), ``scans``
    (the recording the map was built from, :func:`slamq.load_scans`). Blank
    algorithm defaults to the flat-layout name of the map, blank sequence to the map's
    folder name, blank run to ``"0"``; blank trajectory/groundtruth mean none, except that
    a trajectory that is a paired pose log (a CSV whose header names ``gt_x`` and
    ``slam_x``/``est_x``, as slam_comparison_tools writes) with a blank groundtruth is its
    own ground truth, as in ``slamq ate LOG.csv``. Lines
    starting with ``#`` are comments. A map file that does not exist is kept: the batch
    reports it as a failed row.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> text = "algorithm, sequence, run, map\\nhector, lab, 2, a b.yaml\\n"
    >>> _ = (d / "runs.csv").write_text(text)
    >>> r = read_manifest(d / "runs.csv")[0]
    >>> r.algorithm, r.run, r.map.name
    ('hector', '2', 'a b.yaml')
    """
    path = Path(path)
    base = Path(os.path.abspath(path)).parent
    try:
        with open(path, newline="", encoding="utf-8-sig") as fh:
            lines = [(i + 1, line) for i, line in enumerate(fh)]
    except (OSError, UnicodeDecodeError) as exc:
        raise MapError(f"{path}: cannot read manifest: {exc}") from exc
    lines = [(n, line) for n, line in lines if line.strip() and not line.lstrip().startswith("#")]
    if not lines:
        raise MapError(f"{path}: empty manifest (expected a header with a 'map' column)")
    rows = csv.reader([line for _, line in lines], skipinitialspace=True)
    header = [h.strip().lower() for h in next(rows)]
    if "map" not in header:
        raise MapError(
            f"{path}: line {lines[0][0]}: manifest header has no 'map' column "
            f"(columns: {', '.join(MANIFEST_COLUMNS)})"
        )
    if len(set(header)) != len(header):
        raise MapError(f"{path}: line {lines[0][0]}: duplicate column names in the header")
    runs: list[Run] = []
    seen: dict[tuple[str, str, str, str], int] = {}
    for (lineno, _), row in zip(lines[1:], rows):
        if len(row) > len(header):
            raise MapError(
                f"{path}: line {lineno}: {len(row)} fields but the header has {len(header)}"
            )
        cells = {h: (row[i].strip() if i < len(row) else "") for i, h in enumerate(header)}
        if not cells["map"]:
            raise MapError(f"{path}: line {lineno}: empty 'map' cell")
        map_path = _resolve(base, cells["map"])
        algorithm = cells.get("algorithm") or flat_names(map_path.stem)[0]
        sequence = cells.get("sequence") or map_path.resolve().parent.name
        run_id = cells.get("run") or "0"
        traj = _resolve(base, cells["trajectory"]) if cells.get("trajectory") else None
        gt = _resolve(base, cells["groundtruth"]) if cells.get("groundtruth") else None
        if gt is None and traj is not None and is_paired_log(traj):
            gt = traj  # a paired pose log is its own ground truth, as in `slamq ate LOG`
        gt_map = _resolve(base, cells["gt_map"]) if cells.get("gt_map") else None
        rel = _resolve(base, cells["relations"]) if cells.get("relations") else None
        scans = _resolve(base, cells["scans"]) if cells.get("scans") else None
        run = Run(map_path, algorithm, sequence, run_id, traj, gt, layout="manifest",
                  gt_map=gt_map, relations=rel, scans=scans)
        if run.key in seen:
            raise MapError(
                f"{path}: line {lineno}: run {algorithm}/{sequence}/{run_id} with map "
                f"{cells['map']!r} is already listed on line {seen[run.key]}"
            )
        seen[run.key] = lineno
        runs.append(run)
    return runs


def _resolve(base: Path, cell: str) -> Path:
    p = Path(os.path.expanduser(cell))
    return p if p.is_absolute() else base / p


