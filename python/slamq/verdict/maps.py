"""The verdict on several maps of one place given as files, without a results table:
what ``slamq verdict`` runs (the report's verdict works from a batch's results instead).

Follow it: :func:`maps_verdict` -> :func:`slamq.evaluate` per map ->
:func:`slamq.verdict.evidence.sequence_evidence` (agreement, defect detectors) ->
:func:`slamq.verdict.rule.sequence_verdict` (docs/spec.md section 9).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import pandas as pd

from slamq.errors import SlamqError
from slamq.metrics.evaluate import evaluate
from slamq.sources import load_map
from slamq.verdict.evidence import sequence_evidence
from slamq.verdict.ranking import summarize
from slamq.verdict.rule import sequence_verdict

__all__ = ["maps_verdict"]


def maps_verdict(sources: Sequence[str | Path], *, names: Sequence[str] | None = None,
                 defects: bool = True, threads: int | None = None,
                 scans: str | Path | None = None,
                 trajectories: Sequence[str | Path] | None = None) -> dict[str, Any]:
    """The verdict on several maps of one place without ground truth (``slamq verdict``).

    Each map is scored (:func:`slamq.evaluate`), laid over the others and checked by the
    defect detectors (:func:`slamq.verdict.evidence.sequence_evidence`), and judged by the
    rule the report uses (:func:`slamq.verdict.rule.sequence_verdict`; docs/spec.md
    section 9). A map that cannot be read is left out and reported in ``errors``; the
    others are still judged.

    Parameters
    ----------
    sources : sequence of path
        Map files (YAML + image, or images).
    names : sequence of str, optional
        One name per source (default: the paths relative to their common folder).
    defects : bool, default True
        Run the defect detectors.
    threads : int, optional
        Cap on the Rust worker threads.
    scans : path, optional
        The recording every map was built from (:func:`slamq.load_scans`); with
        ``trajectories``, each map is also scored against its own scans (docs/spec.md
        section 9, "Against its own scans").
    trajectories : sequence of path, optional
        One per source, in order: the trajectory of the run that made the map (in the
        map's frame, on the recording's clock).

    Returns
    -------
    dict
        ``{"verdict": dict or None, "evidence": dict or None, "maps": {name: metrics},
        "errors": [(path, reason)]}``; ``verdict`` as
        :func:`~slamq.verdict.rule.sequence_verdict` (None when no map could be read; its
        sequence is the maps' common folder's name), ``maps`` the metrics of each map read.

    Examples
    --------
    >>> import numpy as np, tempfile, pathlib
    >>> from PIL import Image
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> img = np.full((80, 80), 254, np.uint8); img[10, 10:70] = 0; img[10:70, 10] = 0
    >>> img[69, 10:70] = 0; img[10:70, 69] = 0
    >>> for name in "abc": Image.fromarray(img).save(d / f"{name}.pgm")
    >>> r = maps_verdict(sorted(d.glob("*.pgm")), defects=False)
    >>> r["verdict"]["ranking"], r["errors"]
    (['a.pgm', 'b.pgm', 'c.pgm'], [])
    """
    paths = [Path(s) for s in sources]
    parents = [str(p.resolve().parent) for p in paths]
    root = os.path.commonpath(parents) if parents else ""
    if names is None:
        names = [os.path.relpath(p.resolve(), root) for p in paths]
    label = Path(root).name or "maps"
    if len(names) != len(paths):
        raise ValueError(f"{len(names)} names for {len(paths)} maps")
    if trajectories is not None and len(trajectories) != len(paths):
        raise ValueError(f"{len(trajectories)} trajectories for {len(paths)} maps")
    records, metrics, errors = [], {}, []
    loaded: dict[str, Any] = {}
    for i, (path, name) in enumerate(zip(paths, names)):
        try:
            loaded[str(path)] = grid = load_map(path)
            q = evaluate(grid, threads=threads)
        except SlamqError as exc:
            errors.append((str(path), str(exc)))
            continue
        row = q.to_dict()
        metrics[str(name)] = row
        records.append({**row, "map": str(path), "sequence": label, "algorithm": str(name),
                        "run": 1,
                        "scans": str(scans) if scans and trajectories is not None else None,
                        "trajectory": str(trajectories[i]) if trajectories else None})
    if not records:
        return {"verdict": None, "evidence": None, "maps": metrics, "errors": errors}
    ok = pd.DataFrame(records)
    evidence = sequence_evidence(ok, label, defects=defects, threads=threads, loaded=loaded)
    verdict = sequence_verdict(summarize(ok), label, evidence)
    return {"verdict": verdict, "evidence": evidence, "maps": metrics, "errors": errors}
