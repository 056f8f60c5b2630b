"""Stage 4 of a run, collecting: a finished run's map, trajectory and snapshots, checked.

Takes a run whose program has ended (its :class:`~slamq.runner.planning.RunSpec`, its
``out/`` folder as the program left it); finds the files the algorithm's ``outputs``
name (:func:`output_files`, glob patterns under ``out/``), turns each into what slamq
scores (a map in its own format, or as a map_server ``map.yaml``;
``snapshots/map_NNNN.yaml``; the trajectory as ``trajectory.tum``, in time order when the
sequence says ``unsorted: sort``) and gives the run's
outcome (:func:`collect`): ``ok``, ``no_output`` (a configured output missing or
unreadable) or ``degenerate`` (no occupied cell, or fewer than ``min_poses`` poses), with
the collected files.

Before: :mod:`slamq.runner.execution` ran the program. Next: :mod:`slamq.runner.scoring`
scores the collected maps and trajectories.
"""

from __future__ import annotations

import dataclasses
import glob
import hashlib
import json
from pathlib import Path
from typing import Any

from slamq.errors import SlamqError
from slamq.runner.config import Output, RunConfig, render
from slamq.runner.planning import RunSpec, run_values

__all__ = ["collect", "output_files", "outputs_stamp"]


def output_files(out: Path, pattern: str) -> list[Path]:
    """The files under ``out`` matching a glob ``pattern`` (``**`` recursive), sorted,
    without MRPT's ``*_limits.txt`` side files.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp())
    >>> for name in ("map_2.yaml", "map_1.yaml", "map_limits.txt"):
    ...     _ = (out / name).write_text("")
    >>> [p.name for p in output_files(out, "map_*")]
    ['map_1.yaml', 'map_2.yaml']
    """
    return sorted(Path(p) for p in glob.glob(str(out / pattern), recursive=True)
                  if Path(p).is_file() and not p.endswith("_limits.txt"))


def outputs_stamp(spec: RunSpec) -> str:
    """A digest of what the algorithm's ``outputs`` say (paths, formats, topics, times):
    a finished run whose outputs changed since it was collected is collected again from
    the files its program left, without running it again.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from slamq.runner.config import load_config
    >>> from slamq.runner.planning import plan
    >>> d = pathlib.Path(tempfile.mkdtemp()); _ = (d / "in.txt").write_text("x")
    >>> def first(traj):
    ...     return plan(load_config({"base_dir": str(d), "output": "o",
    ...         "sequences": {"s": "in.txt"}, "algorithms": {"echo": {
    ...         "command": ["echo"], "outputs": {"trajectory": traj}}}}))[0]
    >>> outputs_stamp(first("a.txt")) == outputs_stamp(first("b.txt"))
    False
    """
    algo = spec.algorithm
    parts = {name: (dataclasses.asdict(o) if o is not None else None)
             for name, o in (("map", algo.map), ("trajectory", algo.trajectory),
                             ("snapshots", algo.snapshots))}
    blob = json.dumps(parts, sort_keys=True, default=str).encode()
    return hashlib.sha1(blob, usedforsecurity=False).hexdigest()[:16]


def _collect_map(o: Output, src: Path, dest_yaml: Path) -> Path:
    """Make ``dest_yaml`` (map_server YAML) for an output file; returns the map to score.
    The output's format is asked of the map-format registry (slamq.sources.formats)."""
    from slamq.sources.formats import collect_map

    return collect_map(src, dest_yaml, format=o.format, topic=o.topic)


def collect(spec: RunSpec, config: RunConfig) -> tuple[str, str, dict[str, Any]]:
    """Collect a finished run's outputs; ``(outcome, reason, files)``."""
    from slamq.sources.maps import load_map

    algo, folder = spec.algorithm, spec.folder
    out = folder / "out"
    files: dict[str, Any] = {}
    if algo.map is not None:
        found = output_files(out, algo.map.path)
        if not found:
            return "no_output", f"no map matching {algo.map.path}", files
        try:
            m = _collect_map(algo.map, found[-1], folder / "map.yaml")
            grid = load_map(m)
        except (SlamqError, OSError) as exc:
            return "no_output", f"map unreadable: {exc}", files
        files["map"] = str(m)
        known = ~grid.unknown
        if not known.any():
            return "degenerate", "the map has no known cell", files
        if not (grid.values[known] < 128).any():
            return "degenerate", "the map has no dark (occupied) cell", files
    if algo.trajectory is not None:
        found = output_files(out, algo.trajectory.path)
        if not found:
            return "no_output", f"no trajectory matching {algo.trajectory.path}", files
        unsorted = spec.sequence.unsorted
        try:
            if algo.trajectory.format == "mrpt":
                from slamq.sources.mrpt import read_mrpt_path

                traj = read_mrpt_path(found[-1], unsorted=unsorted)
            else:
                from slamq.sources.trajectories import load_trajectory

                fmt = None if algo.trajectory.format == "auto" else algo.trajectory.format
                traj = load_trajectory(found[-1], format=fmt, topic=algo.trajectory.topic,
                                       unsorted=unsorted)
            if algo.trajectory.times is not None:
                from slamq.sources.mrpt import apply_step_times

                times = Path(render(algo.trajectory.times, run_values(spec, 0, config),
                                    f"algorithms.{algo.name}.outputs.trajectory.times"))
                traj = apply_step_times(traj, times if times.is_absolute() else out / times,
                                        unsorted=unsorted)
            traj.write_tum(folder / "trajectory.tum")
        except (SlamqError, OSError) as exc:
            reason = f"trajectory unreadable: {exc}"
            if "non-monotonic" in str(exc):
                reason += (f" [sequences.{spec.sequence.name}.unsorted: sort reads it in "
                           "time order]")
            return "no_output", reason, files
        files["trajectory"] = str(folder / "trajectory.tum")
        if len(traj) < config.min_poses:
            return "degenerate", f"{len(traj)} poses (< {config.min_poses})", files
    if algo.snapshots is not None:
        snaps = []
        for i, src in enumerate(output_files(out, algo.snapshots.path), 1):
            try:
                snaps.append(str(_collect_map(algo.snapshots, src,
                                              folder / "snapshots" / f"map_{i:04d}.yaml")))
            except (SlamqError, OSError):
                continue
        files["snapshots"] = len(snaps)
    return "ok", "", files


