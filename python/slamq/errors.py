"""Exception types of slamq.

Every error slamq raises on bad input is a :class:`SlamqError`, and names the file (when
there is one) and the reason. The CLI turns them into one line on stderr and exit code 2.
"""

from __future__ import annotations

__all__ = [
    "SlamqError",
    "MapError",
    "ParamError",
    "ConformanceError",
    "TrajectoryError",
    "BagError",
    "SequenceError",
    "OutOfMemoryError",
    "MapWarning",
]


class SlamqError(Exception):
    """Base class of every error slamq raises on purpose."""


class MapError(SlamqError, ValueError):
    """A map could not be loaded or is not a valid occupancy grid.

    The message names the file (or ``<array>``) and the reason.
    """


class ParamError(SlamqError, ValueError):
    """A metric parameter is out of its documented range."""


class ConformanceError(SlamqError, AssertionError):
    """The Rust core and :mod:`slamq.metrics.reference` disagree
    (``evaluate(..., verify=True)``)."""


class TrajectoryError(SlamqError, ValueError):
    """A trajectory could not be read, associated or aligned."""


class BagError(MapError):
    """A ROS bag could not be read, or lacks the requested topic."""


class SequenceError(SlamqError, ValueError):
    """A sensor log (e.g. a CARMEN log) could not be read or converted.

    The message names the file, the line number when there is one, and the reason.
    """


class OutOfMemoryError(SlamqError, MemoryError):
    """A map's evaluation needs more memory than the process may have (a memory limit such
    as ``ulimit -v``, or a map too large for the machine).

    The message names the map. The Rust core reserves an evaluation's peak working memory
    (:data:`slamq.metrics.evaluate.WORK_BYTES_PER_CELL` per cell) before it allocates
    anything, so the failure is this error instead of an abort; in a batch it is one failed
    row.
    """


class MapWarning(UserWarning):
    """A map loaded, but something about it deserves attention (named file and reason)."""
