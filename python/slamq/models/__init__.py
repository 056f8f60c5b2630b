"""Plain data, no I/O: what the readers produce and the metrics consume.

- :class:`OccupancyMap`: an occupancy grid held image-style (SPEC section 1).
- :class:`Trajectory`: timestamped poses (SPEC section 6).
- :class:`MapQuality`: the three map metrics of one map (SPEC sections 2-4).
- :class:`MapComparison`: a map scored against a ground-truth map (SPEC section 7).
- :class:`Registration`: one map registered onto another of the same place (SPEC 7a).
- :class:`Relations`, :class:`RelationsResult`: ground-truth relations and the relations
  error of a trajectory (SPEC 6a).
- :class:`Scans`, :class:`ScanConsistency`, :class:`ScanDegeneracy`, :class:`ScanSplit`:
  laser scans, a map scored against them (SPEC 7b), how many see walls in one direction
  only (7c), and a trajectory scored against them split in time (7e).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from slamq.lazy import exports

if TYPE_CHECKING:
    from slamq.models.comparison import MapComparison
    from slamq.models.occupancy import OccupancyMap
    from slamq.models.quality import MapQuality
    from slamq.models.registration import Registration
    from slamq.models.relations import Relations, RelationsResult
    from slamq.models.scans import ScanConsistency, ScanDegeneracy, Scans, ScanSplit
    from slamq.models.trajectory import Trajectory

#: Public names, imported on first use: name -> module.
_WHERE = {
    "MapComparison": "slamq.models.comparison",
    "MapQuality": "slamq.models.quality",
    "OccupancyMap": "slamq.models.occupancy",
    "Registration": "slamq.models.registration",
    "Relations": "slamq.models.relations",
    "RelationsResult": "slamq.models.relations",
    "ScanConsistency": "slamq.models.scans",
    "ScanDegeneracy": "slamq.models.scans",
    "ScanSplit": "slamq.models.scans",
    "Scans": "slamq.models.scans",
    "Trajectory": "slamq.models.trajectory",
}

__getattr__, __dir__ = exports(globals(), _WHERE)

__all__ = ["MapComparison", "MapQuality", "OccupancyMap", "Registration", "Relations",
           "RelationsResult", "ScanConsistency", "ScanDegeneracy", "ScanSplit",
           "Scans",
           "Trajectory"]
