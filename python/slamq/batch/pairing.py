"""Batch discovery, pairing: which trajectory, ground truth and ground-truth map go with a map.

Takes a map that a layout (:mod:`slamq.batch.layouts`) or a manifest
(:mod:`slamq.batch.manifest`) found, with its algorithm and sequence; gives its estimated
trajectory and the sequence's ground truth (the rules under *Trajectories* and *Ground
truth* in :mod:`slamq.batch.runs`): :func:`pick_trajectory` for a run folder,
:func:`flat_trajectories` for a flat folder (the map's folder and the mirrored
``trajectories/<group>/.../<sequence>/`` folders), :func:`find_groundtruth` and
:func:`groundtruth_among` for ground-truth files, :func:`is_paired_log` for a pose log
that holds both. After the walk, :func:`add_ground_truth` notes each sequence's
ground-truth map and :func:`with_ground_truth_map` gives it to the sequence's other runs
(*Ground-truth map*).

Folder listings are cached for one pass of a discovery (:func:`clear_caches`).
"""

from __future__ import annotations

import dataclasses
import functools
import os
import re
from collections.abc import Iterable
from pathlib import Path

from slamq.batch.run import Run
from slamq.results.columns import GROUND_TRUTH_ALGORITHMS
from slamq.sources.trajectories import paired_columns

__all__ = ["TRAJECTORY_SUFFIXES", "add_ground_truth", "clear_caches", "find_groundtruth",
           "find_relations", "flat_trajectories", "groundtruth_among", "is_ground_truth",
           "is_paired_log", "pick_trajectory", "trajectory_files", "with_ground_truth_map"]

#: The suffixes of trajectory files.
TRAJECTORY_SUFFIXES = frozenset({".txt", ".csv", ".tum", ".kitti"})


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


def trajectory_files(files: Iterable[Path]) -> list[Path]:
    """The trajectory files among ``files`` (by suffix, :data:`TRAJECTORY_SUFFIXES`)."""
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


def pick_trajectory(candidates: list[Path], sequence: str = "") -> Path | None:
    """The estimated trajectory among ``candidates``: no ground-truth name, names holding
    ``traj``, ``pose``, ``odom`` or ``est`` first, then the first by name.

    Examples
    --------
    >>> from pathlib import Path
    >>> pick_trajectory([Path("a.txt"), Path("gt.txt"), Path("poses.txt")]).name
    'poses.txt'
    """
    cands = [p for p in candidates if not _is_gt_name(p, sequence)]
    if not cands:
        return None
    hinted = [p for p in cands if _TRAJ_HINT.search(p.stem)]
    return sorted(hinted or cands)[0]


def find_groundtruth(
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


def groundtruth_among(files: Iterable[Path], sequence: str) -> Path | None:
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


def is_paired_log(path: Path) -> bool:
    """Whether ``path`` is a paired pose log (a CSV holding estimate and ground truth)."""
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


def flat_trajectories(
    folder: Path, algorithm: str, algos: frozenset[str], sequence: str, root: Path
) -> tuple[Path | None, Path | None]:
    """``(trajectory, groundtruth)`` of a flat-layout map of ``algorithm`` in ``folder``
    (``algos``: every algorithm with a map there), searched in ``folder``, then its
    mirrored ``trajectories/`` folders, the ground truth also in ``root``."""
    traj: Path | None = None
    gt: Path | None = None
    search = [folder, *_mirror_folders(folder, sequence)]
    for where in search:
        mine = _owned_trajectories(where, algos).get(algorithm, [])
        pick = pick_trajectory(mine, sequence)
        if traj is None and pick is not None:
            traj = pick
        if gt is None:
            gt = find_groundtruth([where], sequence)
        if traj is not None and gt is not None:
            break
    if gt is None and root != folder:
        gt = find_groundtruth([], sequence, root)
    if gt is None and traj is not None and is_paired_log(traj):
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


#: The suffixes of relations files (Kümmerle et al. 2009).
RELATIONS_SUFFIXES = (".relations", ".relations.gz")


@functools.lru_cache(maxsize=256)
def _folder_relations(folder: Path) -> tuple[Path, ...]:
    """The relations files directly in ``folder``, sorted (none when it cannot be listed)."""
    try:
        with os.scandir(folder) as it:
            names = [e.name for e in it if e.name.lower().endswith(RELATIONS_SUFFIXES)
                     and not e.name.startswith(".") and e.is_file()]
    except OSError:
        return ()
    return tuple(sorted(folder / n for n in names))


def find_relations(folders: list[Path], sequence: str, root: Path | None = None
                   ) -> Path | None:
    """The relations file of ``sequence``: in each of ``folders`` (the run's, the
    sequence's), ``<sequence>.relations`` (or ``.relations.gz``) or the folder's only
    relations file; then ``<sequence>.relations`` in ``root``.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (d / "intel.relations").write_text("0 1 0 0 0 0 0 0\\n")
    >>> find_relations([d / "x"], "intel", d).name, find_relations([], "aces", d)
    ('intel.relations', None)
    >>> find_relations([d], "aces").name  # the only one in a folder of the sequence
    'intel.relations'
    """
    names = {f"{sequence}{suffix}".lower() for suffix in RELATIONS_SUFFIXES}
    for folder in folders:
        found = _folder_relations(folder)
        named = [p for p in found if p.name.lower() in names]
        if named:
            return named[0]
        if len(found) == 1:
            return found[0]
    if root is not None:
        named = [p for p in _folder_relations(root) if p.name.lower() in names]
        if named:
            return named[0]
    return None


_CACHES = (
    _folder_trajectories, _groundtruth_in, _owned_trajectories, _mirror_folders,
    _mirror_cached, _folder_relations,
)


def clear_caches() -> None:
    """Forget the folder listings cached while one pass of a discovery runs."""
    for cache in _CACHES:
        cache.cache_clear()


def add_ground_truth(refs: dict[str, Path], run: Run) -> None:
    """Note ``run`` if it is the first (by path) ground-truth run of its sequence."""
    if is_ground_truth(run.algorithm):
        have = refs.get(run.sequence)
        if have is None or str(run.map) < str(have):
            refs[run.sequence] = run.map


def with_ground_truth_map(run: Run, refs: dict[str, Path]) -> Run:
    """A run that is not a ground truth and has no ``gt_map`` gets its sequence's ground-truth
    map."""
    if run.gt_map is not None or is_ground_truth(run.algorithm) or run.sequence not in refs:
        return run
    return dataclasses.replace(run, gt_map=refs[run.sequence])


