"""slamq: score 2D SLAM results.

The three no-reference map metrics of Filatov et al. (arXiv 1708.02354) on occupancy
grids, pinned down by docs/spec.md, computed by a Rust core and checked against a plain
OpenCV reference (:mod:`slamq.metrics.reference`), plus trajectory error and batch
evaluation.

Data flows one way through the subpackages, and nothing imports upward (nor this
package): :mod:`slamq.native` (the one caller of the Rust core) -> :mod:`slamq.models`
(plain data) -> :mod:`slamq.sources` (readers) -> :mod:`slamq.metrics` (models in, numbers
out) -> :mod:`slamq.api` (paths in: ``slamq.evaluate`` and friends) -> :mod:`slamq.results`
-> :mod:`slamq.synth` -> :mod:`slamq.batch` -> :mod:`slamq.report` -> :mod:`slamq.runner`
-> :mod:`slamq.cli`.
Heavy parts (batch, bags, pbstream) are imported on first use.

>>> import numpy as np, slamq
>>> slamq.evaluate(np.full((8, 8), 254, np.uint8)).occupied
0
"""

from __future__ import annotations

import importlib
from typing import Any

from slamq.api import ate, ate_runs, compare, consensus, evaluate, rpe
from slamq.errors import (
    BagError,
    ConformanceError,
    MapError,
    MapWarning,
    OutOfMemoryError,
    ParamError,
    SlamqError,
    TrajectoryError,
)
from slamq.models import MapComparison, MapQuality, OccupancyMap, Trajectory
from slamq.params import Params
from slamq.sources import load_map, load_trajectory
from slamq.version import __version__ as __version__

#: Public names imported on first use: name -> module.
_LAZY = {
    "discover_runs": "slamq.batch.runs",
    "evaluate_many": "slamq.batch.engine",
    "run": "slamq.runner.runner",
    "read_results": "slamq.results.formats",
    "summarize": "slamq.results.summary",
    "synth": "slamq.synth",
    "validate": "slamq.results.validity",
    "read_bag_maps": "slamq.sources.bag_maps",
    "read_last_map": "slamq.sources.bag_maps",
    "read_bag_trajectory": "slamq.sources.bag_poses",
    "read_pbstream_trajectory": "slamq.sources.pbstream",
    "reference": "slamq.metrics.reference",
}


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'slamq' has no attribute {name!r}")
    mod = importlib.import_module(module)
    value = mod if module.endswith("." + name) else getattr(mod, name)
    globals()[name] = value
    return value


__all__ = [
    "BagError",
    "ConformanceError",
    "MapComparison",
    "MapError",
    "MapQuality",
    "MapWarning",
    "OccupancyMap",
    "OutOfMemoryError",
    "ParamError",
    "Params",
    "SlamqError",
    "Trajectory",
    "TrajectoryError",
    "ate",
    "ate_runs",
    "compare",
    "consensus",
    "discover_runs",
    "evaluate",
    "evaluate_many",
    "run",
    "load_map",
    "load_trajectory",
    "read_bag_maps",
    "read_bag_trajectory",
    "read_last_map",
    "read_pbstream_trajectory",
    "read_results",
    "rpe",
    "summarize",
    "synth",
    "validate",
]
