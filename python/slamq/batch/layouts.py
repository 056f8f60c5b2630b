"""Batch discovery, layouts: the runs of a folder, and of a map file named directly.

Takes a folder (:func:`discover_folder`) or a map file (:func:`single_map`); gives a
:class:`~slamq.batch.run.Run` per map, named by the folder layout it lies in (the rules
under *Run layout* and *Flat layout* in :mod:`slamq.batch.runs`): ``runs`` for
``<algorithm>/<sequence>/<run>/`` folders, ``flat`` for ``<sequence>/<algorithm>_map``
files (:func:`flat_names`), ``file`` for a map named directly; ground-truth maps become
algorithm :data:`GROUND_TRUTH`. The maps come from the one folder walk
(:func:`slamq.sources.walk.walk_folders`); their trajectories and ground truth from
:mod:`slamq.batch.pairing`. :func:`describe_layout` says how a batch's runs were found.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Iterator
from pathlib import Path

from slamq.batch.pairing import (
    find_groundtruth,
    find_relations,
    flat_trajectories,
    groundtruth_among,
    is_paired_log,
    pick_trajectory,
    trajectory_files,
)
from slamq.batch.run import Run
from slamq.sources.walk import walk_folders

__all__ = ["GROUND_TRUTH", "LayoutSummary", "describe_layout", "discover_folder",
           "flat_names", "single_map"]

#: The algorithm name given to ground-truth maps found in a flat layout.
GROUND_TRUTH = "ground_truth"
#: A map file that is the ground truth of the sequence folder holding it.
_SEQUENCE_GT_MAP = re.compile(r"^(ground[_-]?truth.*|gt_map|gt)$", re.IGNORECASE)


def single_map(path: Path) -> Run:
    """The run of a map file named directly (layout ``file``): named as in a flat folder.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> d = pathlib.Path(tempfile.mkdtemp()) / "office"
    >>> d.mkdir()
    >>> _ = (d / "hector_map_2.pgm").write_bytes(b"P5 1 1 255 \\xfe")
    >>> r = single_map(d / "hector_map_2.pgm")
    >>> r.algorithm, r.sequence, r.run, r.layout
    ('hector', 'office', '2', 'file')
    """
    algorithm, run_id = flat_names(path.stem)
    seq = path.resolve().parent.name
    gt_seq = _ground_truth_map(path.stem)
    if gt_seq is not None:
        return Run(path, GROUND_TRUTH, gt_seq, "0", layout="file")
    traj, gt = flat_trajectories(path.parent, algorithm, frozenset([algorithm]), seq,
                                  path.parent)
    return Run(path, algorithm, seq, run_id, traj, gt, layout="file")


def _ground_truth_map(stem: str) -> str | None:
    """The sequence of a ground-truth map named ``<sequence>_ground_truth`` (or ``_gt``)."""
    m = re.match(r"^(.+?)[_-](ground[_-]?truth|gt)(_map)?$", stem, re.IGNORECASE)
    return m.group(1) if m else None


def flat_names(stem: str) -> tuple[str, str]:
    """``(algorithm, run)`` from a flat-layout map name.

    Examples
    --------
    >>> flat_names("gmapping_map"), flat_names("gmapping_map_3"), flat_names("gmapping_map_cropped")
    (('gmapping', '0'), ('gmapping', '3'), ('gmapping_cropped', '0'))
    """
    m = re.match(r"^(.+?)_map_(\d+)$", stem)
    if m:
        return m.group(1), m.group(2)
    if stem.endswith("_map") and len(stem) > 4:
        return stem[:-4], "0"
    m = re.match(r"^(.+?)_map_(.+)$", stem)
    if m:
        return f"{m.group(1)}_{m.group(2)}", "0"
    return stem, "0"


def discover_folder(root: Path) -> Iterator[Run]:
    """The runs of the maps under ``root`` in walk order, each named by its layout (``runs``
    or ``flat``), with its trajectory and ground truth, without ground-truth maps."""
    root_name = root.resolve().name
    for here, files, maps in walk_folders(root):
        if not maps:
            continue
        rel = here.relative_to(root).parts
        if len(rel) >= 3 and len(maps) == 1:
            algorithm, sequence, run_id = rel[-3], rel[-2], rel[-1]
            traj = pick_trajectory(trajectory_files(files), sequence)
            # the run folder's files are listed already: only its parent is scanned
            gt = groundtruth_among(files, sequence) or find_groundtruth(
                [here.parent], sequence, root)
            if gt is None and traj is not None and is_paired_log(traj):
                gt = traj
            rel = find_relations([here, here.parent], sequence, root) if traj else None
            yield Run(maps[0], algorithm, sequence, run_id, traj, gt, layout="runs",
                      relations=rel)
            continue
        folder_seq = here.name if rel else root_name
        names_here = [flat_names(m.stem) for m in maps]
        algos = frozenset(a for a, _ in names_here)  # one object: its hash is cached
        for m, (algorithm, run_id) in zip(maps, names_here):
            gt_seq = _ground_truth_map(m.stem)
            if gt_seq is not None:
                yield Run(m, GROUND_TRUTH, gt_seq, "0", layout="flat")
                continue
            if _SEQUENCE_GT_MAP.match(m.stem):  # ground_truth*.yaml, gt_map.yaml
                yield Run(m, GROUND_TRUTH, folder_seq, "0", layout="flat")
                continue
            traj, gt = flat_trajectories(here, algorithm, algos, folder_seq, root)
            rel = find_relations([here], folder_seq, root) if traj else None
            yield Run(m, algorithm, folder_seq, run_id, traj, gt, layout="flat",
                      relations=rel)


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
    summary = LayoutSummary()
    for r in runs:
        summary.add(r)
    return summary.lines()


class LayoutSummary:
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


