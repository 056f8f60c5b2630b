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
* **Manifest** (``.csv``): columns ``algorithm, sequence, run, map, trajectory,
  groundtruth, gt_map`` (only ``map`` required; others may be blank), paths relative to
  the manifest's folder, ``#`` lines are comments, spaces after commas are ignored. A
  ``gt_map`` cell sets that run's ground-truth map (it wins over a reference run). A
  ``trajectory`` cell naming a paired pose log with a blank ``groundtruth`` is paired
  with itself.
"""

from __future__ import annotations

import csv
import dataclasses
import functools
import hashlib
import os
import pickle
import re
import tempfile
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

from slamq.errors import MapError
from slamq.results.columns import GROUND_TRUTH_ALGORITHMS
from slamq.sources.files import PathLike
from slamq.sources.trajectories import paired_columns
from slamq.sources.walk import walk_folders

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

TRAJECTORY_SUFFIXES = frozenset({".txt", ".csv", ".tum", ".kitti"})
#: The algorithm name given to ground-truth maps found in a flat layout.
GROUND_TRUTH = "ground_truth"
MANIFEST_COLUMNS = ("algorithm", "sequence", "run", "map", "trajectory", "groundtruth",
                    "gt_map")

def is_ground_truth(algorithm: str) -> bool:
    """Whether runs of ``algorithm`` are ground-truth maps.

    Examples
    --------
    >>> is_ground_truth("Ground_Truth"), is_ground_truth("gmapping")
    (True, False)
    """
    return str(algorithm).lower() in GROUND_TRUTH_ALGORITHMS

_GT_NAME = re.compile(r"^(ground[_-]?truth|gt)([_\-.].*)?$", re.IGNORECASE)
_TRAJ_HINT = re.compile(r"traj|pose|odom|est", re.IGNORECASE)
#: A map file that is the ground truth of the sequence folder holding it.
_SEQUENCE_GT_MAP = re.compile(r"^(ground[_-]?truth.*|gt_map|gt)$", re.IGNORECASE)



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

    def __post_init__(self) -> None:
        object.__setattr__(self, "map", Path(self.map))
        for name in ("trajectory", "groundtruth", "gt_map"):
            value = getattr(self, name)
            if value is not None and not isinstance(value, Path):
                object.__setattr__(self, name, Path(value))
        for name in ("algorithm", "sequence", "run"):
            object.__setattr__(self, name, str(getattr(self, name)))

    @property
    def key(self) -> tuple[str, str, str, str]:
        """``(algorithm, sequence, run, map)``: a run's identity in a results file."""
        return (self.algorithm, self.sequence, self.run, str(self.map))


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
        _add_ground_truth(refs, r)
    return [_with_ground_truth_map(r, refs) for r in runs]


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
        self._summary = _LayoutSummary()
        self._refs: dict[str, Path] = {}
        self._spill = _RunSpill.open()
        try:
            for run in _iter_runs(self._sources):
                self._summary.add(run)
                _add_ground_truth(self._refs, run)
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
            yield _with_ground_truth_map(run, self._refs)

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
            for m, a, s, r, t, g, layout, gm in rows:
                yield Run(Path(m), a, s, r, None if t is None else Path(t),
                          None if g is None else Path(g), layout,
                          None if gm is None else Path(gm))

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
    for cache in _CACHES:  # the caches live for one pass only
        cache.cache_clear()
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
        for cache in _CACHES:
            cache.cache_clear()


def _source_runs(src: PathLike | Run) -> Iterable[Run]:
    if isinstance(src, Run):
        return [src]
    # absolute: the results file must not depend on where the batch was started
    # (resume from another folder, a report built elsewhere)
    path = Path(os.path.abspath(os.path.expanduser(os.fspath(src))))
    if path.is_dir() and (path / "metadata.yaml").is_file():
        return [_single_map(path)]  # a ROS 2 bag: its last /map
    if path.is_dir():
        return _discover_folder(path)
    if path.is_file() and path.suffix.lower() == ".csv":
        return read_manifest(path)
    if path.is_file():
        return [_single_map(path)]
    if not path.exists():
        raise MapError(f"{path}: no such file or folder")
    raise MapError(f"{path}: not a file or folder")


def _add_ground_truth(refs: dict[str, Path], run: Run) -> None:
    """Note ``run`` if it is the first (by path) ground-truth run of its sequence."""
    if is_ground_truth(run.algorithm):
        have = refs.get(run.sequence)
        if have is None or str(run.map) < str(have):
            refs[run.sequence] = run.map


def _with_ground_truth_map(run: Run, refs: dict[str, Path]) -> Run:
    """A run that is not a ground truth and has no ``gt_map`` gets its sequence's ground-truth
    map."""
    if run.gt_map is not None or is_ground_truth(run.algorithm) or run.sequence not in refs:
        return run
    return dataclasses.replace(run, gt_map=refs[run.sequence])


# --------------------------------------------------------------------------- manifest


def read_manifest(path: PathLike) -> list[Run]:
    """Read a manifest CSV: one run per row, paths relative to the manifest's folder.

    Columns (header row required, any order, case-insensitive): ``map`` (required),
    ``algorithm``, ``sequence``, ``run``, ``trajectory``, ``groundtruth``, ``gt_map`` (the
    sequence's ground-truth map). Blank
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
        algorithm = cells.get("algorithm") or _flat_names(map_path.stem)[0]
        sequence = cells.get("sequence") or map_path.resolve().parent.name
        run_id = cells.get("run") or "0"
        traj = _resolve(base, cells["trajectory"]) if cells.get("trajectory") else None
        gt = _resolve(base, cells["groundtruth"]) if cells.get("groundtruth") else None
        if gt is None and traj is not None and _is_paired_log(traj):
            gt = traj  # a paired pose log is its own ground truth, as in `slamq ate LOG`
        gt_map = _resolve(base, cells["gt_map"]) if cells.get("gt_map") else None
        run = Run(map_path, algorithm, sequence, run_id, traj, gt, layout="manifest",
                  gt_map=gt_map)
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


# --------------------------------------------------------------------------- folders


def _single_map(path: Path) -> Run:
    algorithm, run_id = _flat_names(path.stem)
    seq = path.resolve().parent.name
    gt_seq = _ground_truth_map(path.stem)
    if gt_seq is not None:
        return Run(path, GROUND_TRUTH, gt_seq, "0", layout="file")
    traj, gt = _flat_trajectories(path.parent, algorithm, frozenset([algorithm]), seq,
                                  path.parent)
    return Run(path, algorithm, seq, run_id, traj, gt, layout="file")


def _ground_truth_map(stem: str) -> str | None:
    """The sequence of a ground-truth map named ``<sequence>_ground_truth`` (or ``_gt``)."""
    m = re.match(r"^(.+?)[_-](ground[_-]?truth|gt)(_map)?$", stem, re.IGNORECASE)
    return m.group(1) if m else None


def _flat_names(stem: str) -> tuple[str, str]:
    """``(algorithm, run)`` from a flat-layout map name."""
    m = re.match(r"^(.+?)_map_(\d+)$", stem)
    if m:
        return m.group(1), m.group(2)
    if stem.endswith("_map") and len(stem) > 4:
        return stem[:-4], "0"
    m = re.match(r"^(.+?)_map_(.+)$", stem)
    if m:
        return f"{m.group(1)}_{m.group(2)}", "0"
    return stem, "0"


def _discover_folder(root: Path) -> Iterator[Run]:
    root_name = root.resolve().name
    for here, files, maps in walk_folders(root):
        if not maps:
            continue
        rel = here.relative_to(root).parts
        if len(rel) >= 3 and len(maps) == 1:
            algorithm, sequence, run_id = rel[-3], rel[-2], rel[-1]
            traj = _pick_trajectory(_trajectory_files(files), sequence)
            # the run folder's files are listed already: only its parent is scanned
            gt = _groundtruth_among(files, sequence) or _find_groundtruth(
                [here.parent], sequence, root)
            if gt is None and traj is not None and _is_paired_log(traj):
                gt = traj
            yield Run(maps[0], algorithm, sequence, run_id, traj, gt, layout="runs")
            continue
        folder_seq = here.name if rel else root_name
        names_here = [_flat_names(m.stem) for m in maps]
        algos = frozenset(a for a, _ in names_here)  # one object: its hash is cached
        for m, (algorithm, run_id) in zip(maps, names_here):
            gt_seq = _ground_truth_map(m.stem)
            if gt_seq is not None:
                yield Run(m, GROUND_TRUTH, gt_seq, "0", layout="flat")
                continue
            if _SEQUENCE_GT_MAP.match(m.stem):  # ground_truth*.yaml, gt_map.yaml
                yield Run(m, GROUND_TRUTH, folder_seq, "0", layout="flat")
                continue
            traj, gt = _flat_trajectories(here, algorithm, algos, folder_seq, root)
            yield Run(m, algorithm, folder_seq, run_id, traj, gt, layout="flat")


def _trajectory_files(files: Iterable[Path]) -> list[Path]:
    return [p for p in files if p.suffix.lower() in TRAJECTORY_SUFFIXES]


def _is_gt_name(path: Path, sequence: str) -> bool:
    stem = path.stem
    if _GT_NAME.match(stem):
        return True
    low, seq = stem.lower(), sequence.lower()
    if seq and low.startswith(seq):
        rest = low[len(seq):].lstrip("_-")
        return bool(_GT_NAME.match(rest))
    return False


def _pick_trajectory(candidates: list[Path], sequence: str = "") -> Path | None:
    cands = [p for p in candidates if not _is_gt_name(p, sequence)]
    if not cands:
        return None
    hinted = [p for p in cands if _TRAJ_HINT.search(p.stem)]
    return sorted(hinted or cands)[0]


def _find_groundtruth(
    folders: list[Path], sequence: str, root: Path | None = None
) -> Path | None:
    """The first ground-truth file in ``folders``; in ``root`` (searched last, it holds the
    ground truths of many sequences) its name must start with the sequence's name."""
    search = [(f, False) for f in folders] + ([(root, True)] if root is not None else [])
    for folder, need_prefix in search:
        gt = _groundtruth_in(folder, sequence, need_prefix)
        if gt is not None:
            return gt
    return None


def _groundtruth_among(files: Iterable[Path], sequence: str) -> Path | None:
    """What :func:`_groundtruth_in` finds in a folder whose files are ``files`` (its
    non-hidden entries; a hidden name is never a ground-truth name)."""
    gts = [p for p in files if p.suffix.lower() in TRAJECTORY_SUFFIXES
           and _is_gt_name(p, sequence) and p.is_file()]
    return min(gts) if gts else None


@functools.lru_cache(maxsize=256)
def _folder_trajectories(folder: Path) -> list[Path]:
    """The trajectory files directly in ``folder``, sorted ([] when it cannot be listed).

    Cached while one pass of a discovery runs (the maps of a flat folder all look at the
    same folders), for the 256 folders used last: only trajectory names are kept, not the
    folder's listing (a folder of 10,000 maps would otherwise stay in memory)."""
    try:
        with os.scandir(folder) as it:
            names = [e.name for e in it
                     if os.path.splitext(e.name)[1].lower() in TRAJECTORY_SUFFIXES
                     and e.is_file()]
    except OSError:
        return []
    return sorted(folder / n for n in names)


@functools.lru_cache(maxsize=256)
def _groundtruth_in(folder: Path, sequence: str, need_prefix: bool) -> Path | None:
    gts = [p for p in _folder_trajectories(folder) if _is_gt_name(p, sequence)]
    if need_prefix:
        gts = [p for p in gts if p.stem.lower().startswith(sequence.lower())]
    return min(gts) if gts else None


def _is_paired_log(path: Path) -> bool:
    cols = paired_columns(path)
    return cols is not None


@functools.lru_cache(maxsize=256)
def _mirror_folders(folder: Path, sequence: str) -> tuple[Path, ...]:
    """``trajectories/<group>/.../<sequence>`` folders of a map folder ``.../<group>/...``.

    The group's trajectories live in a ``trajectories`` folder beside the group
    (``data/<group>`` -> ``data/trajectories/<group>``) or beside the ``maps`` folder
    holding it (``data/maps/<group>`` -> ``data/trajectories/<group>``); the nearest one
    wins.
    """
    return tuple(Path(p) for p in _mirror_cached(str(folder.resolve()), sequence))


@functools.lru_cache(maxsize=256)
def _mirror_cached(folder: str, sequence: str) -> tuple[str, ...]:
    parts = Path(folder).parts
    for i in range(len(parts) - 1, 0, -1):
        bases = [Path(*parts[:i])]
        if parts[i - 1] == "maps" and i >= 2:
            bases.append(Path(*parts[: i - 1]))
        for base in bases:
            group_root = base / "trajectories" / parts[i]
            if parts[i] == "trajectories" or not group_root.is_dir():
                continue
            found = []
            for sub, dirs, _ in os.walk(group_root):
                dirs[:] = sorted(d for d in dirs if not d.startswith("."))
                if Path(sub).name == sequence:
                    found.append(sub)
            return tuple(found)
    return ()


def _flat_trajectories(
    folder: Path, algorithm: str, algos: frozenset[str], sequence: str, root: Path
) -> tuple[Path | None, Path | None]:
    traj: Path | None = None
    gt: Path | None = None
    search = [folder, *_mirror_folders(folder, sequence)]
    for where in search:
        mine = _owned_trajectories(where, algos).get(algorithm, [])
        pick = _pick_trajectory(mine, sequence)
        if traj is None and pick is not None:
            traj = pick
        if gt is None:
            gt = _find_groundtruth([where], sequence)
        if traj is not None and gt is not None:
            break
    if gt is None and root != folder:
        gt = _find_groundtruth([], sequence, root)
    if gt is None and traj is not None and _is_paired_log(traj):
        gt = traj
    return traj, gt


@functools.lru_cache(maxsize=256)
def _owned_trajectories(folder: Path, algos: frozenset[str]) -> dict[str, list[Path]]:
    """The trajectory files of ``folder`` by the algorithm they belong to (one pass over
    the folder for all its maps, so discovery stays linear in the number of maps)."""
    owned: dict[str, list[Path]] = {}
    for p in _folder_trajectories(folder):
        owner = _owner(p.stem, algos)
        if owner is not None:
            owned.setdefault(owner, []).append(p)
    return owned


def _owner(stem: str, algos: frozenset[str]) -> str | None:
    """The algorithm a trajectory named ``stem`` belongs to: the longest ``a`` in ``algos``
    with ``stem == a`` or ``stem`` starting with ``a_`` or ``a.``.

    >>> _owner("karto_slam_traj", frozenset({"karto", "karto_slam"}))
    'karto_slam'
    >>> _owner("kartoslam", frozenset({"karto"})) is None
    True
    """
    if stem in algos:
        return stem
    for i in range(len(stem) - 1, 0, -1):
        if stem[i] in "_." and stem[:i] in algos:
            return stem[:i]
    return None


_CACHES = (
    _folder_trajectories, _groundtruth_in, _owned_trajectories, _mirror_folders,
    _mirror_cached,
)


def describe_layout(runs: Iterable[Run]) -> list[str]:
    """Lines saying how a batch's runs were found, and warnings for layouts that look
    guessed wrongly: an (algorithm, sequence) of run folders whose maps have different file
    names is probably algorithms mistaken for runs.

    ``runs`` is read once and not kept (memory in the number of algorithms and sequences).

    Examples
    --------
    >>> runs = [Run("r/maps/gmapping/default.yaml", "r", "maps", "gmapping", layout="runs"),
    ...         Run("r/maps/hector/hector.yaml", "r", "maps", "hector", layout="runs")]
    >>> print("\\n".join(describe_layout(runs)))  # doctest: +NORMALIZE_WHITESPACE
    2 runs: 1 algorithm(s) x 1 sequence(s); layout: 2 in <algorithm>/<sequence>/<run>/ folders
    warning: algorithm 'r', sequence 'maps': its runs ('gmapping', 'hector') hold maps named
    differently (default.yaml, hector.yaml); are they algorithms rather than runs? Check
    with --dry-run, or use a manifest CSV
    """
    summary = _LayoutSummary()
    for r in runs:
        summary.add(r)
    return summary.lines()


class _LayoutSummary:
    """What :func:`describe_layout` says, gathered one run at a time: counts, names, and
    per (algorithm, sequence) of run folders its first 4 run ids and 5 smallest map names."""

    NAMES = {"runs": "in <algorithm>/<sequence>/<run>/ folders",
             "flat": "in flat <sequence>/<algorithm>_map files", "manifest": "from manifests",
             "file": "named directly", "": "given as Run objects"}

    def __init__(self) -> None:
        from collections import Counter

        self.n = 0
        self.layouts: Counter[str] = Counter()
        self.algos: set[str] = set()
        self.seqs: set[str] = set()
        self.groups: dict[tuple[str, str], tuple[list[str], list[str]]] = {}

    def add(self, r: Run) -> None:
        self.n += 1
        self.layouts[r.layout] += 1
        self.algos.add(r.algorithm)
        self.seqs.add(r.sequence)
        if r.layout != "runs":
            return
        ids, names = self.groups.setdefault((r.algorithm, r.sequence), ([], []))
        if len(ids) < 4:
            ids.append(r.run)
        name = r.map.name
        if name not in names and (len(names) < 5 or name < names[-1]):
            names.append(name)
            names.sort()
            del names[5:]

    def lines(self) -> list[str]:
        layout = ", ".join(f"{n} {self.NAMES.get(k, k)}" for k, n in self.layouts.most_common())
        lines = [f"{self.n} runs: {len(self.algos)} algorithm(s) x {len(self.seqs)} "
                 f"sequence(s); layout: {layout}"]
        for (alg, seq), (ids, names) in sorted(self.groups.items()):
            if len(names) > 1:
                lines.append(
                    f"warning: algorithm {alg!r}, sequence {seq!r}: its runs "
                    f"({', '.join(map(repr, ids))}) hold maps named differently "
                    f"({', '.join(names[:4])}); are they algorithms rather than runs? Check "
                    "with --dry-run, or use a manifest CSV")
        return lines
