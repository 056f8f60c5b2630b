"""The :class:`Run` record: one map of a batch, with where it belongs and its trajectories.

Every way of finding runs gives these (:mod:`slamq.batch.layouts` for folders,
:mod:`slamq.batch.manifest` for manifest CSV files, :mod:`slamq.batch.runs` for the whole
discovery); :mod:`slamq.batch.records` evaluates one and :mod:`slamq.batch.engine` many.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

__all__ = ["Run"]


@dataclass(frozen=True)
class Run:
    """One map of a batch, with where it belongs and its trajectory files.

    Attributes
    ----------
    map : pathlib.Path
        The map file (YAML or image).
    algorithm, sequence, run : str
        The SLAM algorithm, the data set it ran on, and which repetition.
    trajectory, groundtruth : pathlib.Path or None
        The estimated trajectory and the sequence's ground truth, when known (the same
        file for a paired pose log).
    gt_map : pathlib.Path or None
        The sequence's ground-truth map, when known (not part of the key).
    relations : pathlib.Path or None
        The sequence's relations file (Kümmerle et al. 2009; the ``rel_*`` columns), when
        known (not part of the key).
    scans : pathlib.Path or None
        The recording the map was built from, when known (a CARMEN log, an MRPT rawlog or
        a bag with laser scans, :func:`slamq.load_scans`): the verdict scores the map
        against its own scans at ``trajectory`` (docs/spec.md sections 7b and 9). Not part
        of the key.

    Examples
    --------
    >>> from slamq.batch import Run
    >>> Run("gmapping/office/1/map.yaml", "gmapping", "office", "1").key
    ('gmapping', 'office', '1', 'gmapping/office/1/map.yaml')
    """

    map: Path
    algorithm: str
    sequence: str
    run: str = "0"
    trajectory: Path | None = None
    groundtruth: Path | None = None
    #: How the run was found: "runs" (``<algorithm>/<sequence>/<run>/`` folders), "flat",
    #: "manifest", "file" (named directly), or "" (built by hand). Not part of the key.
    layout: str = field(default="", compare=False)
    gt_map: Path | None = field(default=None, compare=False)
    relations: Path | None = field(default=None, compare=False)
    scans: Path | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "map", Path(self.map))
        for name in ("trajectory", "groundtruth", "gt_map", "relations", "scans"):
            value = getattr(self, name)
            if value is not None and not isinstance(value, Path):
                object.__setattr__(self, name, Path(value))
        for name in ("algorithm", "sequence", "run"):
            object.__setattr__(self, name, str(getattr(self, name)))

    @property
    def key(self) -> tuple[str, str, str, str]:
        """``(algorithm, sequence, run, map)``: a run's identity in a results file."""
        return (self.algorithm, self.sequence, self.run, str(self.map))


