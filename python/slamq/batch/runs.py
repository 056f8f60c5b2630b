"""Finding the runs of a batch: folder layouts and manifest CSV files.

A *run* is one map built by one SLAM algorithm on one sequence (a recorded data set),
optionally with the trajectory the algorithm estimated and the sequence's ground truth.

Rules (:func:`discover_runs` applies them)
------------------------------------------
The maps of a folder are found by the one folder walk, :mod:`slamq.sources.walk` (the
same rules as ``slamq eval DIR``): map YAMLs, images no YAML names, numbered snapshots
left out beside a real map, hidden entries and bag folders skipped, symbolic links
followed once.

* **Run layout** ``<algorithm>/<sequence>/<run>/``: a folder at least three levels below
  the root that holds exactly one map. algorithm, sequence and run are the names of the
  grandparent, parent and folder itself.
* **Flat layout** (everything else), e.g. ``test_results/<world>/<algo>_map.yaml``:
  sequence = the folder's name, algorithm = the file stem with its ``_map`` token removed
  (``gmapping_map`` -> ``gmapping``, ``gmapping_map_cropped`` -> ``gmapping_cropped``;
  ``gmapping_map_3`` -> algorithm ``gmapping``, run ``3``), run = ``"0"`` otherwise.
  A ground-truth map ``<sequence>_ground_truth`` (or ``_gt``, e.g. slam_comparison_tools'
  ``ground_truths/office_ground_truth.yaml``) becomes algorithm ``ground_truth`` of that
  sequence, wherever it lies, so it sits beside the SLAM maps in the summary.
* **Trajectories** (``.txt .csv .tum .kitti``): in a run folder, the one trajectory file
  (names holding ``traj``, ``pose``, ``odom`` or ``est`` first, then by name). In the flat
  layout, a file whose stem is the algorithm or starts with ``<algorithm>_`` or
  ``<algorithm>.`` (the longest algorithm name wins), in the map's folder or in
  ``trajectories/<group>/.../<sequence>/`` beside the map's group folder
  (``data/maps/<group>/...`` or ``data/<group>/...``: the ../shared/data and tests/data
  convention).
* **Ground truth**: a trajectory file named ``groundtruth*``, ``ground_truth*``, ``gt``,
  ``gt_*``/``gt-*`` or ``<sequence>_groundtruth*``/``<sequence>_ground_truth*``/
  ``<sequence>_gt*``, searched in the run folder, then the sequence folder, then the root.
  A CSV trajectory whose header has both ``gt_x`` and an estimate column (``slam_x``,
  ``est_x``) is its own ground truth (a paired pose log).
* **Ground-truth map** of a sequence (docs/spec.md section 7): the map of its ground-truth
  run, i.e. a map whose algorithm is one of :data:`GROUND_TRUTH_ALGORITHMS` (a
  ``<sequence>_ground_truth`` map anywhere under the root, or a ``ground_truth*.yaml`` /
  ``gt_map.yaml`` in the sequence folder, which the flat layout names ``ground_truth`` /
  ``gt``). Every other run of the sequence gets it as ``gt_map`` (the first by path when
  there are several); the reference run itself gets none and is never ranked.
* **Relations** (Kümmerle et al. 2009; docs/spec.md 6a) of a sequence: a file
  ``<sequence>.relations`` (or ``.relations.gz``) in the run folder, the sequence folder
  or the root, or the one ``*.relations`` file of the run or sequence folder. A run with
  a trajectory and relations gets the ``rel_*`` columns. (``slamq batch --relations
  [SEQUENCE=]FILE`` and the ``relations=`` of :func:`slamq.evaluate_many` name it
  instead.)
* **Manifest** (``.csv``): columns ``algorithm, sequence, run, map, trajectory,
  groundtruth, gt_map, relations, scans`` (only ``map`` required; others may be blank),
  paths relative to the manifest's folder, ``#`` lines are comments, spaces after commas
  are ignored. A
  ``gt_map`` cell sets that run's ground-truth map (it wins over a reference run). A
  ``trajectory`` cell naming a paired pose log with a blank ``groundtruth`` is paired
  with itself.

Where the rules live
--------------------
This module drives a discovery (:func:`discover_runs`, :class:`Discovery`): each source
goes to :mod:`slamq.batch.layouts` (a folder, a map file named directly) or
:mod:`slamq.batch.manifest` (a ``.csv``); :mod:`slamq.batch.pairing` finds each map's
trajectory and ground truth and, once every run is found, gives each sequence's
ground-truth map to its other runs. Every one of them gives :class:`~slamq.batch.run.Run`
records.
"""

from __future__ import annotations

import hashlib
import os
import pickle
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import IO, Any

from slamq.batch.layouts import LayoutSummary, describe_layout, discover_folder, single_map
from slamq.batch.manifest import read_manifest
from slamq.batch.pairing import (
    TRAJECTORY_SUFFIXES,
    add_ground_truth,
    clear_caches,
    is_ground_truth,
    with_ground_truth_map,
)
from slamq.batch.run import Run
from slamq.errors import MapError
from slamq.results.columns import GROUND_TRUTH_ALGORITHMS
from slamq.sources.files import PathLike

__all__ = [
    "GROUND_TRUTH_ALGORITHMS",
    "Discovery",
    "Run",
    "describe_layout",
    "discover_runs",
    "is_ground_truth",
    "read_manifest",
    "TRAJECTORY_SUFFIXES",
]


def discover_runs(sources: PathLike | Run | Iterable[PathLike | Run]) -> list[Run]:
    """Find the runs in folders, manifest CSV files and map files.

    Parameters
    ----------
    sources : path, Run, or an iterable of them
        A folder (searched recursively with the layout rules of :mod:`slamq.batch.runs`),
        a manifest ``.csv``, a map file (YAML, image, or a ROS bag file or ROS 2 bag folder,
        whose last ``/map`` is evaluated; sequence = the folder's name), or a ready
        :class:`Run`.

    Returns
    -------
    list of Run
        Folder contents sorted by path; the order of ``sources`` and of manifest rows is
        kept. A run listed twice (same algorithm, sequence, run and map) is kept once.
        Paths are absolute (not resolved: symbolic links keep their names), except those
        of a ready :class:`Run`. (:class:`Discovery` gives the same runs without holding
        them all in memory.)

    Raises
    ------
    slamq.MapError
        A source that does not exist, or a malformed manifest (naming file and line).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> root = pathlib.Path(tempfile.mkdtemp())
    >>> run = root / "gmapping" / "office" / "run 1"
    >>> run.mkdir(parents=True)
    >>> _ = (run / "map.pgm").write_bytes(b"P5 1 1 255 \\xfe")
    >>> _ = (run / "trajectory.txt").write_text("0 0 0 0 0 0 0 1\\n")
    >>> [(r.algorithm, r.sequence, r.run, r.trajectory.name) for r in discover_runs(root)]
    [('gmapping', 'office', 'run 1', 'trajectory.txt')]
    """
    runs = list(_iter_runs(_source_list(sources)))
    refs: dict[str, Path] = {}
    for r in runs:
        add_ground_truth(refs, r)
    return [with_ground_truth_map(r, refs) for r in runs]


class Discovery:
    """The runs of a batch, found lazily: what :func:`discover_runs` finds, in the same
    order, without a list of every run in memory.

    Making it walks the sources once (raising for a missing source or a bad manifest, as
    :func:`discover_runs` does) and keeps a summary in memory: the number of runs, the
    layout counts, the algorithm and sequence names and each sequence's ground-truth map,
    i.e. memory in the number of algorithms and sequences, not of maps. The runs it found
    go to an anonymous temporary file (about 0.2 KB per run, on disk, not in memory), and
    each iteration reads them back one chunk at a time: the same runs in the same order
    as the walk, so ``len()`` is always their count, and iterating costs about a tenth of
    walking the folders again (a batch iterates while its workers evaluate maps, and the
    walk's Python held the GIL they need). A map added after the walk is found by the
    next Discovery (or batch). When no temporary file can be made, each iteration walks
    the sources again. A manifest's rows are read whole; when several sources are given,
    a run found twice is recognised by a 16-byte digest of its key (about 0.1 KB per run
    while walking).

    Parameters
    ----------
    sources : path, Run, or an iterable of them
        As for :func:`discover_runs` (a one-shot iterator is read into a list first).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> root = pathlib.Path(tempfile.mkdtemp()) / "office"
    >>> root.mkdir()
    >>> for name in ("gmapping_map", "hector_map", "office_ground_truth"):
    ...     _ = (root / f"{name}.pgm").write_bytes(b"P5 1 1 255 \\xfe")
    >>> found = Discovery(root)
    >>> len(found), [(r.algorithm, r.gt_map and r.gt_map.name) for r in found]
    (3, [('gmapping', 'office_ground_truth.pgm'), ('hector', 'office_ground_truth.pgm'), \
('ground_truth', None)])
    >>> found.layout_lines()
    ['3 runs: 3 algorithm(s) x 1 sequence(s); layout: 3 in flat <sequence>/<algorithm>_map files']
    """

    #: Runs per pickled chunk of the temporary file.
    CHUNK = 512

    def __init__(self, sources: PathLike | Run | Iterable[PathLike | Run]) -> None:
        self._sources = _source_list(sources)
        self._summary = LayoutSummary()
        self._refs: dict[str, Path] = {}
        self._spill = _RunSpill.open()
        try:
            for run in _iter_runs(self._sources):
                self._summary.add(run)
                add_ground_truth(self._refs, run)
                self._keep(run)
            self._keep(None)
        except BaseException:
            self.close()
            raise

    def _keep(self, run: Run | None) -> None:
        """Add ``run`` to the temporary file (None: flush it). When writing fails (a full
        disk), the file is dropped and iterating walks the sources again."""
        if self._spill is None:
            return
        try:
            if run is None:
                self._spill.finish()
            else:
                self._spill.add(run)
        except OSError:
            self.close()

    def __len__(self) -> int:
        return self._summary.n

    def __iter__(self) -> Iterator[Run]:
        found = _iter_runs(self._sources) if self._spill is None else self._spill.runs()
        for run in found:
            yield with_ground_truth_map(run, self._refs)

    def close(self) -> None:
        """Delete the temporary file now (it also goes when the Discovery is garbage
        collected or the process ends); iterating afterwards walks the sources again."""
        spill, self._spill = self._spill, None
        if spill is not None:
            spill.close()

    def __getstate__(self) -> dict[str, Any]:  # a file handle does not pickle: walk again
        return {**self.__dict__, "_spill": None}

    def layout_lines(self) -> list[str]:
        """What :func:`describe_layout` says of these runs."""
        return self._summary.lines()


def _source_list(sources: PathLike | Run | Iterable[PathLike | Run]) -> list[PathLike | Run]:
    if isinstance(sources, (str, os.PathLike, Run)):
        return [sources]
    return list(sources)


class _RunSpill:
    """The runs of a walk, pickled in chunks of :attr:`Discovery.CHUNK` to an anonymous
    temporary file (deleted when closed or collected), read back one chunk at a time."""

    def __init__(self, fh: IO[bytes]) -> None:
        self._fh = fh
        self._rows: list[tuple[Any, ...]] = []
        self._ends: list[int] = []  # the end offset of each chunk

    @classmethod
    def open(cls) -> _RunSpill | None:
        try:
            return cls(tempfile.TemporaryFile(prefix="slamq-runs-"))
        except OSError:
            return None

    def add(self, run: Run) -> None:
        self._rows.append((
            os.fspath(run.map), run.algorithm, run.sequence, run.run,
            None if run.trajectory is None else os.fspath(run.trajectory),
            None if run.groundtruth is None else os.fspath(run.groundtruth),
            run.layout, None if run.gt_map is None else os.fspath(run.gt_map),
            None if run.relations is None else os.fspath(run.relations),
            None if run.scans is None else os.fspath(run.scans),
        ))
        if len(self._rows) >= Discovery.CHUNK:
            self._flush()

    def _flush(self) -> None:
        if self._rows:
            pickle.dump(self._rows, self._fh, protocol=pickle.HIGHEST_PROTOCOL)
            self._rows = []
            self._fh.flush()
            self._ends.append(self._fh.tell())

    def finish(self) -> None:
        self._flush()
        self._fh.flush()

    def runs(self) -> Iterator[Run]:
        """The runs in the order they were added (several iterations may interleave)."""
        start = 0
        fd = self._fh.fileno()
        for end in self._ends:
            rows = pickle.loads(_pread_all(fd, end - start, start))
            start = end
            for m, a, s, r, t, g, layout, gm, rel, sc in rows:
                yield Run(Path(m), a, s, r, None if t is None else Path(t),
                          None if g is None else Path(g), layout,
                          None if gm is None else Path(gm),
                          None if rel is None else Path(rel),
                          None if sc is None else Path(sc))

    def close(self) -> None:
        self._fh.close()


def _pread_all(fd: int, n: int, offset: int) -> bytes:
    """``n`` bytes at ``offset`` (no shared file position: iterations may interleave)."""
    parts = []
    while n > 0:
        b = os.pread(fd, n, offset)
        if not b:
            raise OSError(f"the temporary file of a discovery ended {n} bytes early")
        parts.append(b)
        n -= len(b)
        offset += len(b)
    return b"".join(parts)


def _iter_runs(sources: list[PathLike | Run]) -> Iterator[Run]:
    """The runs of ``sources`` in order, each key once, without ground-truth maps."""
    clear_caches()  # the caches live for one pass only
    # One folder, manifest or file never gives a key twice (each folder is walked once,
    # read_manifest refuses a repeated row); across sources, a compact digest per key.
    seen: set[bytes] | None = set() if len(sources) > 1 else None
    try:
        for src in sources:
            for run in _source_runs(src):
                if seen is not None:
                    d = hashlib.blake2b("\0".join(run.key).encode("utf-8", "surrogatepass"),
                                        digest_size=16).digest()
                    if d in seen:
                        continue
                    seen.add(d)
                yield run
    finally:
        clear_caches()


def _source_runs(src: PathLike | Run) -> Iterable[Run]:
    if isinstance(src, Run):
        return [src]
    # absolute: the results file must not depend on where the batch was started
    # (resume from another folder, a report built elsewhere)
    path = Path(os.path.abspath(os.path.expanduser(os.fspath(src))))
    if path.is_dir() and (path / "metadata.yaml").is_file():
        return [single_map(path)]  # a ROS 2 bag: its last /map
    if path.is_dir():
        return discover_folder(path)
    if path.is_file() and path.suffix.lower() == ".csv":
        return read_manifest(path)
    if path.is_file():
        return [single_map(path)]
    if not path.exists():
        raise MapError(f"{path}: no such file or folder")
    raise MapError(f"{path}: not a file or folder")


