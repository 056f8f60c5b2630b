"""slamq: score 2D SLAM results.

The three no-reference map metrics of Filatov et al. (arXiv 1708.02354) on occupancy
grids, pinned down by docs/spec.md, computed by a Rust core and checked against a plain
OpenCV reference (:mod:`slamq.metrics.reference`), plus trajectory error and batch
evaluation.

Data flows one way through the subpackages, and nothing imports upward (nor this
package): :mod:`slamq.native` (the one caller of the Rust core) -> :mod:`slamq.models`
(plain data) -> :mod:`slamq.sources` (readers) -> :mod:`slamq.synth` (data with a known
truth) -> :mod:`slamq.metrics` (models in, numbers out) -> :mod:`slamq.api` (paths in:
``slamq.evaluate`` and friends) -> :mod:`slamq.results` -> :mod:`slamq.batch` ->
:mod:`slamq.verdict` -> :mod:`slamq.report` -> :mod:`slamq.runner` -> :mod:`slamq.cli`.
Every public name but the errors is imported on first use (:mod:`slamq.lazy`).

>>> import numpy as np, slamq
>>> slamq.evaluate(np.full((8, 8), 254, np.uint8)).occupied
0
"""

from __future__ import annotations

from typing import TYPE_CHECKING

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
from slamq.lazy import exports

if TYPE_CHECKING:  # what the names below are, for type checkers (imported on first use)
    from slamq import api, synth  # noqa: F401
    from slamq.api import (
        agreement,
        ate,
        ate_runs,
        compare,
        consensus,
        evaluate,
        register,
        register_many,
        rpe,
    )
    from slamq.batch.engine import evaluate_many
    from slamq.batch.runs import discover_runs
    from slamq.metrics import reference  # noqa: F401
    from slamq.metrics.degeneracy import scan_degeneracy
    from slamq.metrics.scans import scan_consistency
    from slamq.metrics.split import scan_split
    from slamq.metrics.travel import travel_ratio
    from slamq.models import MapComparison, MapQuality, OccupancyMap, Registration, Trajectory
    from slamq.models.scans import Scans
    from slamq.params import Params
    from slamq.results.formats import read_results
    from slamq.results.summary import summarize
    from slamq.results.validity import validate
    from slamq.runner.runner import run
    from slamq.sources.bag_maps import read_bag_maps, read_last_map
    from slamq.sources.bag_poses import read_bag_trajectory
    from slamq.sources.maps import load_map
    from slamq.sources.pbstream import read_pbstream_trajectory
    from slamq.sources.scans import load_scans
    from slamq.sources.trajectories import load_trajectory
    from slamq.version import __version__ as __version__

#: Public names imported on first use (so that ``slamq eval`` runs only what it needs):
#: name -> module.
_LAZY = {
    "__version__": "slamq.version",
    "api": "slamq.api",
    "evaluate": "slamq.api",
    "compare": "slamq.api",
    "consensus": "slamq.api",
    "agreement": "slamq.api",
    "register": "slamq.api",
    "register_many": "slamq.api",
    "ate": "slamq.api",
    "rpe": "slamq.api",
    "ate_runs": "slamq.api",
    "relations": "slamq.metrics.relations", "load_relations": "slamq.sources.relations",
    "load_scans": "slamq.sources.scans", "scan_consistency": "slamq.metrics.scans",
    "scan_degeneracy": "slamq.metrics.degeneracy", "scan_split": "slamq.metrics.split",
    "travel_ratio": "slamq.metrics.travel",
    "Scans": "slamq.models.scans",
    "MapComparison": "slamq.models.comparison",
    "MapQuality": "slamq.models.quality",
    "OccupancyMap": "slamq.models.occupancy",
    "Registration": "slamq.models.registration",
    "Trajectory": "slamq.models.trajectory",
    "Params": "slamq.params",
    "load_map": "slamq.sources.maps",
    "load_trajectory": "slamq.sources.trajectories",
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

__getattr__, __dir__ = exports(globals(), _LAZY)

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
    "Registration",
    "SlamqError",
    "Trajectory",
    "TrajectoryError",
    "agreement",
    "ate",
    "ate_runs",
    "compare",
    "consensus",
    "discover_runs",
    "evaluate",
    "evaluate_many",
    "register",
    "register_many",
    "run",
    "load_map",
    "load_trajectory",
    "read_bag_maps",
    "read_bag_trajectory",
    "read_last_map",
    "read_pbstream_trajectory",
    "read_results",
    "relations", "load_relations",
    "load_scans", "scan_consistency", "scan_degeneracy", "scan_split", "Scans",
    "rpe",
    "travel_ratio",
    "summarize",
    "synth",
    "validate",
]
