"""map_server names other modules import: :func:`write_raw_map` and :func:`reapply`. The
map_server format itself (YAML parsing, reading, writing) is
:mod:`slamq.sources.formats.map_server`; the step from pixels to cells is
:mod:`slamq.sources.formats.raw`."""

from __future__ import annotations

from slamq.sources.formats.map_server import write_raw_map
from slamq.sources.formats.raw import reapply

__all__ = ["reapply", "write_raw_map"]
