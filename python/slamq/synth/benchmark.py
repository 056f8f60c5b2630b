"""Generated sequences in ``slamq run`` configurations: the ground-truth benchmark.

A sequence of a run configuration may name a *recipe* instead of a recording::

    sequences:
      gen:
        synth:
          worlds: 20                 # world seeds 0..19 (kinds cycle), or a list of
                                     # {kind: K, seed: S, size: [W, H]} / map_server YAMLs
          kinds: [office, loop]      # the kinds an integer ``worlds`` cycles through
          noise: [low, high]         # odometry noise presets (slamq.synth NOISE)
          seeds: [0, 1, 2]           # simulation seeds: drive, laser and odometry noise
          input: rawlog              # the writer whose file the programs read ({input})
          formats: [rawlog]          # every writer to run (bags, CARMEN, ...)
          groundtruth_map: visible   # the ground-truth map the runs are scored against
          laser: {beams: 1081}       # LaserSpec fields
          drive: {}                  # keywords of the simulator's drive

It expands to one sequence per world x noise x seed, named
``gen-w03-hall-low-s1``, whose files are generated once under
``<output>/sequences/<name>/`` (the recipe is kept beside them as ``recipe.json``, and a
folder whose recipe and files are complete is not generated again). Every run of such a
sequence is scored against its exact path (``gt.tum``) and map (``visible_map.yaml``,
only the walls the laser hit, or ``gt_map.yaml``), so every ok run has ``ate_*`` and
``gt_*``.
"""

from __future__ import annotations

import functools
import hashlib
import inspect
import json
import os
from collections.abc import Iterable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from slamq.errors import ParamError

__all__ = ["Generated", "expand", "generate", "generate_missing", "world_label"]

#: Files every generated sequence has (besides the writers' outputs).
TRUTH_FILES = ("gt_map.yaml", "visible_map.yaml", "gt_map_start.yaml", "visible_map_start.yaml",
               "gt.tum", "odom.tum", "sequence.json")
#: The keys a ``synth:`` recipe may have.
KEYS = {"worlds", "kinds", "noise", "seeds", "input", "formats", "groundtruth_map", "laser",
        "drive"}


@dataclass(frozen=True)
class Generated:
    """One generated sequence: its name, folder and the recipe that makes it."""

    name: str
    folder: Path
    recipe: dict[str, Any]

    @property
    def input(self) -> Path:
        """The file the SLAM programs read (the ``input`` writer's output)."""
        return self.folder / (self.name + _INPUT_SUFFIX[self.recipe["input"]])

    @property
    def groundtruth(self) -> Path:
        return self.folder / "gt.tum"

    @property
    def groundtruth_map(self) -> Path:
        """The ground-truth map in the frame the SLAM programs map in: an MRPT rawlog or a
        CARMEN log gives odometry increments, so their maps start at the robot's first pose
        (``*_map_start.yaml``: the same image, its origin moved into that frame, exact);
        a bag's odometry is in the world frame (``*_map.yaml``)."""
        start = "_start" if self.recipe["input"] in ("rawlog", "carmen") else ""
        return self.folder / f"{self.recipe['groundtruth_map']}_map{start}.yaml"

    def complete(self) -> bool:
        """Whether the folder holds this recipe's files, made by this version of the
        generator's code (then it is not generated again)."""
        try:
            old = json.loads((self.folder / "recipe.json").read_text())
        except (OSError, ValueError):
            return False
        return old == {**self.recipe, "code": generator_digest()} and self.input.exists() \
            and all((self.folder / f).exists() for f in TRUTH_FILES)


#: What each writer appends to the sequence's name (slamq.synth.writers.FORMATS).
_INPUT_SUFFIX = {"rawlog": ".rawlog", "carmen": ".log", "rosbag1": ".bag", "rosbag2": "_ros2",
                 "mcap": "_mcap"}


@functools.cache
def generator_digest() -> str:
    """SHA-1 of the source of every module that makes a generated sequence's files (the
    worlds, the drive, the sensors, the truth, the writers): a folder made by other code is
    generated again."""
    here = Path(__file__).parent
    h = hashlib.sha1(usedforsecurity=False)
    for f in sorted([*here.glob("*.py"), *here.glob("writers/*.py")]):
        if f.name not in ("benchmark.py", "damage.py"):
            h.update(f.name.encode() + b"\0" + f.read_bytes())
    return h.hexdigest()[:16]


def _keywords(value: Any, known: Iterable[str], where: str) -> dict[str, Any]:
    if not isinstance(value, dict):
        raise ParamError(f"{where} must be a mapping")
    unknown = set(value) - set(known)
    if unknown:
        raise ParamError(f"{where}: unknown keys {', '.join(sorted(unknown))} "
                         f"(known: {', '.join(sorted(known))})")
    return dict(value)


def _list(value: Any, where: str) -> list[Any]:
    values = value if isinstance(value, list) else [value]
    if not values:
        raise ParamError(f"{where} is an empty list")
    return values


def _worlds(doc: dict[str, Any], base: Path, where: str) -> list[dict[str, Any]]:
    from slamq.synth.worldgen import DEFAULT_KINDS, KINDS

    worlds = doc.get("worlds", 1)
    kinds = _list(doc.get("kinds", list(DEFAULT_KINDS)), f"{where}.kinds")
    for k in kinds:
        if k not in KINDS:
            raise ParamError(f"{where}.kinds: unknown world kind {k!r} "
                             f"(known: {', '.join(KINDS)})")
    if isinstance(worlds, int) and not isinstance(worlds, bool):
        if worlds < 1:
            raise ParamError(f"{where}.worlds must be >= 1, got {worlds}")
        return [{"kind": kinds[i % len(kinds)], "seed": i} for i in range(worlds)]
    out = []
    for i, w in enumerate(_list(worlds, f"{where}.worlds")):
        if isinstance(w, (str, os.PathLike)):
            p = Path(os.path.expanduser(str(w)))
            out.append({"map": str(p if p.is_absolute() else (base / p).resolve())})
        elif isinstance(w, dict) and set(w) <= {"kind", "seed", "size"} and \
                w.get("kind", kinds[0]) in KINDS:
            spec = {"kind": w.get("kind", kinds[0]), "seed": int(w.get("seed", i))}
            if "size" in w:
                spec["size"] = [float(v) for v in w["size"]]
            out.append(spec)
        else:
            raise ParamError(f"{where}.worlds[{i}] must be a map_server YAML path or "
                             f"{{kind: K, seed: S, size: [W, H]}} with K one of "
                             f"{', '.join(KINDS)}")
    return out


def world_label(w: dict[str, Any]) -> str:
    """The part of a generated sequence's name that names its world (a recipe's ``world``).

    Examples
    --------
    >>> world_label({"kind": "office", "seed": 3}), world_label({"map": "/maps/lab.yaml"})
    ('w03-office', 'w-lab')
    """
    if "map" in w:
        return "w-" + Path(w["map"]).stem
    return f"w{w['seed']:02d}-{w['kind']}"


def expand(name: str, doc: Any, output: Path, base: Path, where: str) -> list[Generated]:
    """The sequences a ``synth:`` recipe stands for (nothing is generated here).

    Examples
    --------
    >>> from pathlib import Path
    >>> g = expand("gen", {"worlds": 2, "kinds": ["office"], "noise": ["low", "high"]},
    ...            Path("/tmp/out"), Path("."), "sequences.gen.synth")
    >>> [s.name for s in g][:3]
    ['gen-w00-office-low-s0', 'gen-w00-office-high-s0', 'gen-w01-office-low-s0']
    >>> str(g[0].folder)
    '/tmp/out/sequences/gen-w00-office-low-s0'
    >>> g[0].input.name, g[0].groundtruth_map.name
    ('gen-w00-office-low-s0.rawlog', 'visible_map_start.yaml')
    """
    from slamq.synth.sensors import NOISE

    if not isinstance(doc, dict):
        raise ParamError(f"{where} must be a mapping (worlds, noise, seeds, ...)")
    unknown = set(doc) - KEYS
    if unknown:
        raise ParamError(f"{where}: unknown keys {', '.join(sorted(unknown))} "
                         f"(known: {', '.join(sorted(KEYS))})")
    worlds = _worlds(doc, base, where)
    noises = [str(n) for n in _list(doc.get("noise", "low"), f"{where}.noise")]
    for n in noises:
        if n not in NOISE:
            raise ParamError(f"{where}.noise: unknown preset {n!r} (known: {', '.join(NOISE)})")
    seeds = [int(s) for s in _list(doc.get("seeds", [0]), f"{where}.seeds")]
    fmt = str(doc.get("input", "rawlog"))
    if fmt not in _INPUT_SUFFIX:
        raise ParamError(f"{where}.input must be one of {', '.join(_INPUT_SUFFIX)}, got {fmt!r}")
    formats = sorted({fmt, *(str(f) for f in _list(doc.get("formats", [fmt]),
                                                   f"{where}.formats"))})
    gt_map = str(doc.get("groundtruth_map", "visible"))
    if gt_map not in ("visible", "gt"):
        raise ParamError(f"{where}.groundtruth_map must be visible or gt, got {gt_map!r}")
    from slamq.synth.planner import drive
    from slamq.synth.recording import LaserSpec

    laser = _keywords(doc.get("laser", {}), LaserSpec.__dataclass_fields__, f"{where}.laser")
    options = _keywords(doc.get("drive", {}),
                        [p for p in inspect.signature(drive).parameters
                         if p not in ("world", "seed")], f"{where}.drive")
    out = []
    for w in worlds:
        for noise in noises:
            for seed in seeds:
                label = f"{name}-{world_label(w)}-{noise}-s{seed}"
                recipe = {"world": w, "noise": noise, "seed": seed, "input": fmt,
                          "formats": formats, "groundtruth_map": gt_map,
                          "laser": laser, "drive": options}
                out.append(Generated(label, output / "sequences" / label, recipe))
    return out


def generate(g: Generated) -> Generated:
    """Make one generated sequence's files (the world, the drive, the sensors, the writers'
    outputs and the ground truth), then its ``recipe.json`` last."""
    from slamq.synth import writers
    from slamq.synth.recording import LaserSpec
    from slamq.synth.simulation import simulate
    from slamq.synth.truth import write_truth
    from slamq.synth.worldgen import load_world, world

    r = g.recipe
    w = r["world"]
    grid = load_world(w["map"]) if "map" in w else world(
        w["seed"], kind=w["kind"], size=tuple(w["size"]) if "size" in w else None)
    laser = LaserSpec(**r["laser"])
    seq = simulate(grid, seed=r["seed"], noise=r["noise"], laser=laser, name=g.name,
                   **r["drive"])
    g.folder.mkdir(parents=True, exist_ok=True)
    (g.folder / "recipe.json").unlink(missing_ok=True)
    write_truth(seq, g.folder)
    writers.write(seq, g.folder, r["formats"])
    (g.folder / "recipe.json").write_text(json.dumps({**r, "code": generator_digest()},
                                                     indent=1, sort_keys=True))
    return g


def generate_missing(sequences: Iterable[Generated], *, parallel: int = 1,
                     progress: Any = None) -> list[Generated]:
    """Generate the sequences whose folders are not complete; returns those made."""
    todo = [g for g in sequences if not g.complete()]
    if not todo:
        return []
    made = []
    with ThreadPoolExecutor(max_workers=max(1, parallel)) as pool:
        for g in pool.map(generate, todo):
            made.append(g)
            if progress is not None:
                progress(g)
    return made
