"""Every reader: occupancy grids and trajectories from files, arrays and bags.

- :func:`load_map`: every map file format of the registry :mod:`slamq.sources.formats`
  (map_server YAML + image, bare images, MRPT grids, Cartographer ``.pbstream``, ROS bags,
  and what :func:`register_format` adds: one module each, one ``interpret`` step), uint8
  images and OccupancyGrid arrays (:mod:`slamq.sources.maps`, :mod:`~slamq.sources.grids`).
- :func:`load_trajectory`: TUM, KITTI, EuRoC, CSV, ROS bags, Cartographer ``.pbstream``
  (:mod:`slamq.sources.trajectories`, :mod:`~slamq.sources.bag_poses`,
  :mod:`~slamq.sources.pbstream`).
- :func:`load_scans`: a planar laser's scans from CARMEN logs, MRPT rawlogs and ROS bags
  (:mod:`slamq.sources.scans`), what a map is scored against (docs/spec.md section 7b).
- :func:`discover_maps`: the one folder walk (:mod:`slamq.sources.walk`), shared by
  ``slamq eval`` and ``slamq batch``; it asks the format registry which files are maps.
- :mod:`slamq.sources.files`: the size budgets and the regular-file rule every reader obeys.

Bag readers need the ``bags`` extra (``pip install 'slamq[bags]'``); they are imported when
a bag is read.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from slamq.lazy import exports

if TYPE_CHECKING:
    from slamq.sources.files import is_bag
    from slamq.sources.formats import register_format, unregister_format
    from slamq.sources.grids import from_occupancy_grid
    from slamq.sources.maps import load_map
    from slamq.sources.pbstream import read_pbstream_trajectory
    from slamq.sources.scans import load_scans
    from slamq.sources.trajectories import FORMATS, load_trajectory, parse_columns
    from slamq.sources.walk import discover_maps

#: Public names, imported on first use: name -> module.
_WHERE = {
    "FORMATS": "slamq.sources.trajectories",
    "discover_maps": "slamq.sources.walk",
    "from_occupancy_grid": "slamq.sources.grids",
    "is_bag": "slamq.sources.files",
    "load_map": "slamq.sources.maps",
    "load_scans": "slamq.sources.scans",
    "load_trajectory": "slamq.sources.trajectories",
    "parse_columns": "slamq.sources.trajectories",
    "read_pbstream_trajectory": "slamq.sources.pbstream",
    "register_format": "slamq.sources.formats",
    "unregister_format": "slamq.sources.formats",
}

__getattr__, __dir__ = exports(globals(), _WHERE)

__all__ = [
    "FORMATS",
    "discover_maps",
    "from_occupancy_grid",
    "is_bag",
    "load_map",
    "load_scans",
    "load_trajectory",
    "parse_columns",
    "read_pbstream_trajectory",
    "register_format",
    "unregister_format",
]
