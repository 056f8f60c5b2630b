"""Stage 1 of a run, planning: which runs a configuration asks for, where each goes, its key.

Takes a :class:`~slamq.runner.config.RunConfig`; gives the run list (:func:`plan`: one
:class:`RunSpec` per algorithm x parameter variant x sequence x iteration, iteration
outermost so parallel slots spread over algorithms), each run's folder
``<output>/<algorithm>/<variant>/<sequence>/<iteration>/``, the values its templates are
filled with (:func:`run_values`), its run key (:func:`run_key`: a hash of the algorithm,
the rendered command and config file, the parameters, the input's content and the
iteration) and which runs are still to do (:func:`pending`: a run whose ``run.json``
holds the same key is finished).

Next stage: :mod:`slamq.runner.rendering` fills the templates that the key hashes and
:mod:`slamq.runner.execution` starts the programs.
"""

from __future__ import annotations

import hashlib
import json
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from slamq.errors import ParamError
from slamq.runner.config import Algorithm, RunConfig, SequenceSpec, render
from slamq.runner.rendering import render_command, render_config_file

__all__ = ["RunSpec", "input_hash", "pending", "plan", "portable", "prepare_inputs", "run_key",
           "run_values", "slug"]


@dataclass
class RunSpec:
    """One planned run."""

    algorithm: Algorithm
    variant: str
    params: dict[str, Any]
    sequence: SequenceSpec
    iteration: int
    folder: Path

    @property
    def label(self) -> str:
        """The algorithm name used in results: ``name`` or ``name[variant]``."""
        return self.algorithm.name if self.variant == "default" else \
            f"{self.algorithm.name}[{self.variant}]"


_HASHES: dict[str, str] = {}


def input_hash(path: Path) -> str:
    """SHA-1 of a file's bytes or of a folder's files (relative names and bytes)."""
    key = str(path)
    if key in _HASHES:
        return _HASHES[key]
    h = hashlib.sha1(usedforsecurity=False)
    files = [path] if path.is_file() else sorted(p for p in path.rglob("*") if p.is_file())
    if not path.exists():
        raise ParamError(f"{path}: sequence input does not exist")
    for f in files:
        h.update(str(f.relative_to(path) if f != path else f.name).encode() + b"\0")
        with open(f, "rb") as fh:
            for chunk in iter(lambda fh=fh: fh.read(1 << 20), b""):
                h.update(chunk)
    _HASHES[key] = h.hexdigest()
    return _HASHES[key]


def slug(text: str) -> str:
    """``text`` as one safe path component (a run folder's or a step log's name).

    Examples
    --------
    >>> slug("gmapping fast/1"), slug("")
    ('gmapping_fast_1', '_')
    """
    return re.sub(r"[^A-Za-z0-9._=,+-]+", "_", text) or "_"


def prepare_inputs(config: RunConfig) -> None:
    """Make the inputs a configuration generates or converts that are not made yet, once:
    ``synth:`` sequences (:mod:`slamq.synth.benchmark`) and ``carmen:`` / ``bag:``
    sequences with the sidecars their runs' ``times:`` name (:mod:`slamq.runner.recorded`);
    under an exclusive lock on ``<output>/sequences/.lock``, so that two shards starting
    together do not both write one sequence's folder; the second finds it made. Every
    sequence's relations file is read first, so that a malformed one fails before any run.

    Raises
    ------
    slamq.ParamError
        A ``times:`` file in a converted sequence's folder that the conversion does not
        write.
    slamq.SequenceError, slamq.BagError, slamq.TrajectoryError
        A log that cannot be converted, a relations file that cannot be read (the messages
        name the file, and the line when there is one).
    """
    from slamq.sources.relations import read_relations

    for s in config.sequences:
        if s.relations is not None:
            read_relations(s.relations)
    todo = [s.generated for s in config.sequences if s.generated is not None]
    recorded = [(s.recorded, _sidecars(config, s)) for s in config.sequences
                if s.recorded is not None]

    def done(rec: Any, sidecars: dict[Path, tuple[float, float]]) -> bool:
        return rec.complete() and all(p.is_file() for p in sidecars)

    if all(g.complete() for g in todo) and all(done(r, n) for r, n in recorded):
        return
    import fcntl

    from slamq.synth.benchmark import generate_missing

    lock = config.output / "sequences" / ".lock"
    lock.parent.mkdir(parents=True, exist_ok=True)
    with open(lock, "a") as fh:
        fcntl.flock(fh, fcntl.LOCK_EX)
        try:
            if todo:
                generate_missing(todo, parallel=config.parallel)
            for rec, sidecars in recorded:
                if not rec.complete():
                    rec.convert()
                    _HASHES.pop(str(rec.input), None)
                for path, (metres, degrees) in sidecars.items():
                    if not path.is_file():
                        rec.write_nodes(path, metres, degrees)
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)


def _sidecars(config: RunConfig, seq: SequenceSpec) -> dict[Path, tuple[float, float]]:
    """The node sidecars of a converted sequence that its runs' ``times:`` name, with
    their node spacing (metres, degrees); a ``times:`` file in its folder that the
    conversion does not write is refused."""
    assert seq.recorded is not None
    out: dict[Path, tuple[float, float]] = {}
    for algo in config.algorithms:
        if algo.trajectory is None or algo.trajectory.times is None:
            continue
        for variant, params in algo.variants():
            spec = RunSpec(algo, variant, params, seq, 1, config.output / "_")
            where = f"algorithms.{algo.name}.outputs.trajectory.times"
            path = Path(render(algo.trajectory.times, run_values(spec, 0, config), where))
            what = seq.recorded.sidecar(path)
            if what is False:
                raise ParamError(
                    f"{config.source}: {where}: {path.name} is not a file that sequence "
                    f"{seq.name} (a {seq.recorded.kind}: log) is converted with; it writes "
                    f"{seq.input.name}.steps.txt, .nodes.txt, .nodes-<M>m.txt and "
                    ".nodes-<M>m-<D>deg.txt")
            if isinstance(what, tuple):
                out[path] = what
    return out


def plan(config: RunConfig) -> list[RunSpec]:
    """Every run of a configuration, in a stable order (iteration outermost, so parallel
    slots spread over algorithms)."""
    specs = []
    for it in range(1, config.iterations + 1):
        for algo in config.algorithms:
            for variant, params in algo.variants():
                for seq in config.sequences:
                    folder = (config.output / slug(algo.name) / slug(variant)
                              / slug(seq.name) / str(it))
                    specs.append(RunSpec(algo, variant, params, seq, it, folder))
    return specs


def run_values(spec: RunSpec, slot: int, config: RunConfig) -> dict[str, Any]:
    """The values a run's templates are filled with (``{input}``, ``{out}``,
    ``{param.NAME}``...); ``slot`` is the parallel slot running it (0 for its key)."""
    out = spec.folder / "out"
    v: dict[str, Any] = {
        "sequence": spec.sequence.name, "input": str(spec.sequence.input), "out": str(out),
        "iteration": spec.iteration, "seed": spec.iteration, "slot": slot,
        "config": str(spec.folder / ("config" + (spec.algorithm.config_template.suffix
                                                 if spec.algorithm.config_template else ""))),
        "ros_domain_id": config.ros_domain_base + slot,
        "ros_master_port": config.ros_master_base + slot,
    }
    v.update({f"param.{k}": val for k, val in spec.params.items()})
    return v


def _input_key(seq: SequenceSpec) -> str:
    """What a run key holds of its input: the file's hash; for a generated sequence not made
    yet or a log not converted yet (a dry run), its recipe's."""
    if seq.generated is not None and not seq.generated.complete():
        blob = json.dumps(seq.generated.recipe, sort_keys=True).encode()
        return "recipe:" + hashlib.sha1(blob, usedforsecurity=False).hexdigest()
    if seq.recorded is not None and not seq.input.exists():
        blob = json.dumps(seq.recorded.recipe(), sort_keys=True).encode()
        return "recipe:" + hashlib.sha1(blob, usedforsecurity=False).hexdigest()
    return input_hash(seq.input)


def portable(path: Any, config: RunConfig) -> str:
    """A path as a run key holds it: ``{output}/...`` under the output folder, ``{base}/...``
    under the config's folder, else as it is; so that a finished output folder moved or
    mounted elsewhere (with its config beside it) keeps its keys.

    Examples
    --------
    >>> from slamq.runner.config import load_config
    >>> cfg = load_config({"base_dir": "/data/exp", "output": "/scratch/runs",
    ...                    "sequences": {"s": "in.txt"}, "algorithms": {"a": {"command": ["x"]}}})
    >>> portable("/scratch/runs/a/1/out", cfg), portable("/data/exp/in.txt", cfg)
    ('{output}/a/1/out', '{base}/in.txt')
    >>> portable("/usr/share/mrpt/x.rawlog", cfg)
    '/usr/share/mrpt/x.rawlog'
    """
    p = Path(str(path))
    for root, token in ((config.output, "{output}"), (config.base_dir, "{base}")):
        if root is None:
            continue
        try:
            return f"{token}/{p.relative_to(root).as_posix()}"
        except ValueError:
            continue
    return str(path)


def run_key(spec: RunSpec, config: RunConfig) -> tuple[str, dict[str, Any]]:
    """The run key and the resolved pieces it hashes (slot-independent). Paths in the
    rendered command and config file are :func:`portable`: relative to the output folder
    or the config's folder."""
    values = run_values(spec, 0, config)
    for name in ("input", "out", "config"):
        values[name] = portable(values[name], config)
    algo = spec.algorithm
    cmd: Any = (render_command(algo.command, values, f"algorithms.{algo.name}.command")
                if algo.command is not None else
                [[s.name, render_command(s.command, values, s.name)] for s in algo.recipe])
    cfg = render_config_file(algo, values)
    pieces = {"algorithm": algo.name, "command": cmd, "config": cfg,
              "params": {k: str(v) for k, v in spec.params.items()},
              "input": _input_key(spec.sequence), "iteration": spec.iteration}
    blob = json.dumps(pieces, sort_keys=True, default=str).encode()
    return hashlib.sha256(blob).hexdigest()[:32], pieces


def pending(keyed: list[tuple[RunSpec, str, dict[str, Any]]], retry_failed: bool
            ) -> tuple[list[dict[str, Any] | None], list[int]]:
    """Which planned runs are finished and which are still to do.

    Parameters
    ----------
    keyed : list of (RunSpec, key, pieces)
        The planned runs with their :func:`run_key`.
    retry_failed : bool
        Whether a finished run whose outcome was not ``ok`` is to do again.

    Returns
    -------
    rows, todo
        ``rows[i]`` is the stored ``run.json`` of a finished run (with ``skipped: True``),
        None for a run to do; ``todo`` lists the indices of the runs to do.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from slamq.runner.config import load_config
    >>> d = pathlib.Path(tempfile.mkdtemp()); _ = (d / "in.txt").write_text("x")
    >>> cfg = load_config({"base_dir": str(d), "output": "o", "sequences": {"s": "in.txt"},
    ...                    "algorithms": {"echo": {"command": ["echo", "{input}"]}}})
    >>> keyed = [(s, *run_key(s, cfg)) for s in plan(cfg)]
    >>> pending(keyed, retry_failed=False)
    ([None], [0])
    """
    rows: list[dict[str, Any] | None] = [None] * len(keyed)
    todo = []
    for i, (spec, key, _pieces) in enumerate(keyed):
        done = spec.folder / "run.json"
        old = None
        if done.is_file():
            try:
                old = json.loads(done.read_text())
            except (OSError, ValueError):
                old = None
        if old and old.get("key") == key and (old.get("outcome") == "ok" or not retry_failed):
            rows[i] = {**old, "skipped": True}
        else:
            todo.append(i)
    return rows, todo
