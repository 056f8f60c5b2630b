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
from collections.abc import Sequence as Seq
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from slamq.errors import ParamError

__all__ = ["Generated", "expand", "generate", "generate_missing"]

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
        if f.name not in ("benchmark.py", "damage.py", "__main__.py"):
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
    from slamq.synth.world import KINDS

    worlds = doc.get("worlds", 1)
    kinds = _list(doc.get("kinds", list(KINDS)), f"{where}.kinds")
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


def _world_label(w: dict[str, Any]) -> str:
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
    from slamq.synth.drive import drive
    from slamq.synth.sequence import LaserSpec

    laser = _keywords(doc.get("laser", {}), LaserSpec.__dataclass_fields__, f"{where}.laser")
    options = _keywords(doc.get("drive", {}),
                        [p for p in inspect.signature(drive).parameters
                         if p not in ("world", "seed")], f"{where}.drive")
    out = []
    for w in worlds:
        for noise in noises:
            for seed in seeds:
                label = f"{name}-{_world_label(w)}-{noise}-s{seed}"
                recipe = {"world": w, "noise": noise, "seed": seed, "input": fmt,
                          "formats": formats, "groundtruth_map": gt_map,
                          "laser": laser, "drive": options}
                out.append(Generated(label, output / "sequences" / label, recipe))
    return out


def generate(g: Generated) -> Generated:
    """Make one generated sequence's files (the world, the drive, the sensors, the writers'
    outputs and the ground truth), then its ``recipe.json`` last."""
    from slamq.synth import writers
    from slamq.synth.sequence import LaserSpec
    from slamq.synth.simulate import simulate
    from slamq.synth.truth import write_truth
    from slamq.synth.world import load_world, world

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



# --------------------------------------------------------------------------------------
# The study of a benchmark run: how each no-reference metric agrees with the exact truth.

#: A run is *broken* (decided before the benchmark was run, from the ground truth alone):
#: its ATE RMSE is more than ``BROKEN_ATE_FACTOR`` times the best of its sequence and more
#: than ``BROKEN_ATE_FLOOR`` metres (so three good runs 2 cm apart are not "broken").
BROKEN_ATE_FACTOR = 3.0
BROKEN_ATE_FLOOR = 0.2


def load_benchmark(output: Path) -> pd.DataFrame:
    """The scored runs of a ``slamq run`` output folder, one row per map, with the generated
    sequences' recipe (``world``, ``kind``, ``noise``, ``sim_seed``) and ``broken``.

    Runs that produced no map are rows too (``outcome`` not ``ok``, metrics missing).
    """
    from slamq.results.formats import read_results

    output = Path(output)
    results = output / "results.jsonl"
    if not results.is_file():
        raise ParamError(f"{results}: no results (run `slamq run` on the config first)")
    df = read_results(results)
    if "error" in df:
        df = df[df["error"].isna() | (df["error"].astype(str) == "")]
    runs = pd.read_csv(output / "runs.csv")
    runs = runs[["algorithm", "sequence", "iteration", "outcome", "wall_time", "cpu_time"]
                if "cpu_time" in runs else ["algorithm", "sequence", "iteration", "outcome"]]
    runs = runs.assign(run=runs["iteration"].astype(str)).drop(columns="iteration")
    df = runs.merge(df.assign(run=df["run"].astype(str)), on=["algorithm", "sequence", "run"],
                    how="left")
    info = {}
    for seq in df["sequence"].unique():
        try:
            r = json.loads((output / "sequences" / seq / "recipe.json").read_text())
        except (OSError, ValueError):
            continue
        w = r["world"]
        info[seq] = {"world": _world_label(w), "kind": w.get("kind", "map"),
                     "noise": r["noise"], "sim_seed": r["seed"]}
    extra = pd.DataFrame.from_dict(info, orient="index")
    df = df.merge(extra, left_on="sequence", right_index=True, how="left")
    best = df.groupby("sequence")["ate_rmse"].transform("min")
    df["broken"] = (df["ate_rmse"] > BROKEN_ATE_FACTOR * best) & \
        (df["ate_rmse"] > BROKEN_ATE_FLOOR)
    return df


def _pooled_rows(df: pd.DataFrame, permutations: int, seed: int) -> pd.DataFrame:
    from slamq.results.validity import validate

    t = validate(df, truths=("ate_rmse", "gt_f1"), permutations=permutations, seed=seed)
    return t[t["sequence"] == "(pooled)"]


def study_benchmark(df: pd.DataFrame, *, permutations: int = 1000,
                    seed: int = 0) -> dict[str, pd.DataFrame]:
    """The tables of docs/validity.md's benchmark section, from :func:`load_benchmark`.

    ``runs``: per algorithm and noise, runs, ok, ATE and GT-map F1 (mean, std);
    ``pooled``: each metric's agreement with ATE and with F1 over every sequence;
    ``by_kind`` / ``by_world`` / ``by_noise``: the pooled concordance within each;
    ``failures``: per metric, over the sequences with a broken and an unbroken map, the
    share where the metric's worst map is broken (it sees the failure) and where its best
    map is broken (it would pick the broken one).
    """
    from slamq.results.validity import METRICS

    ok = df[df["outcome"] == "ok"]
    g = df.groupby(["algorithm", "noise"], dropna=False)
    runs = pd.DataFrame({
        "runs": g.size(), "ok": g["outcome"].apply(lambda s: int((s == "ok").sum())),
        "ate_mean": g["ate_rmse"].mean(), "ate_std": g["ate_rmse"].std(),
        "ate_median": g["ate_rmse"].median(),
        "f1_mean": g["gt_f1"].mean(), "f1_std": g["gt_f1"].std(),
        "broken": g["broken"].sum(),
    }).reset_index()
    best = ok.loc[ok.groupby("sequence")["ate_rmse"].idxmin().dropna(), "algorithm"]
    runs["best_ate_share"] = [float((best == a).mean()) if len(best) else float("nan")
                              for a in runs["algorithm"]]
    broken = df.pivot_table(index="kind", columns="noise", values="broken", aggfunc="sum",
                            fill_value=0)
    tables = {"runs": runs, "broken": broken, "pooled": _pooled_rows(ok, permutations, seed)}
    for by in ("kind", "noise", "world"):
        parts = []
        for value, part in ok.groupby(by):
            rows = _pooled_rows(part, 0, seed).assign(**{by: value})
            parts.append(rows)
        tables[f"by_{by}"] = pd.concat(parts, ignore_index=True) if parts else pd.DataFrame()
    fails = []
    for metric in METRICS:
        if metric not in ok:
            continue
        seen = picked = n = 0
        for _, part in ok.groupby("sequence"):
            part = part[np.isfinite(pd.to_numeric(part[metric], errors="coerce"))]
            if len(part) < 2 or not part["broken"].any() or part["broken"].all():
                continue
            n += 1
            order = part.sort_values(metric, kind="stable")
            seen += bool(order["broken"].iloc[-1])
            picked += bool(order["broken"].iloc[0])
        fails.append({"metric": metric, "sequences": n,
                      "worst_is_broken": seen / n if n else float("nan"),
                      "best_is_broken": picked / n if n else float("nan")})
    tables["failures"] = pd.DataFrame(fails)
    return tables


def _fmt(x: Any, spec: str = ".2f") -> str:
    try:
        return "-" if x is None or not np.isfinite(float(x)) else format(float(x), spec)
    except (TypeError, ValueError):
        return str(x)


def markdown_benchmark(tables: dict[str, pd.DataFrame], command: str) -> str:
    """The benchmark section of docs/validity.md (between ``<!-- benchmark:begin -->`` and
    ``<!-- benchmark:end -->``)."""
    lines = [f"Regenerate with `{command}`.", "",
             "### Runs", "",
             "ATE RMSE and GT-map F1: mean ± std over the runs; median ATE; best ATE: the share "
             "of all sequences on which the algorithm had the lowest ATE.", "",
             "| algorithm | odometry noise | runs | ok | broken | ATE RMSE (m) | median ATE (m) "
             "| GT-map F1 | best ATE |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in tables["runs"].itertuples():
        lines.append(f"| {r.algorithm} | {r.noise} | {r.runs} | {r.ok} | {int(r.broken)} | "
                     f"{_fmt(r.ate_mean, '.3f')} ± {_fmt(r.ate_std, '.3f')} | "
                     f"{_fmt(r.ate_median, '.3f')} | {_fmt(r.f1_mean)} ± {_fmt(r.f1_std)} | "
                     f"{_fmt(r.best_ate_share)} |")
    b = tables["broken"]
    if not b.empty:
        lines += ["", "Broken runs by world kind and odometry noise (3 programs x 3 seeds x "
                  "the worlds of the kind):", "",
                  "| world kind | " + " | ".join(str(c) for c in b.columns) + " |",
                  "|---|" + "---|" * len(b.columns)]
        for kind, row in b.iterrows():
            lines.append(f"| {kind} | " + " | ".join(str(int(v)) for v in row) + " |")
    lines += ["", "### Each metric against the truth, pooled over every sequence", "",
              "Spearman agreement (+1: the metric orders a sequence's maps as the truth does) "
              "/ pairwise concordance (0.5 = chance) / permutation p.", "",
              "| metric | vs ATE RMSE | vs GT-map F1 |", "|---|---|---|"]
    pooled = tables["pooled"]
    for metric, part in pooled.groupby("metric", sort=False):
        cells = []
        for truth in ("ate_rmse", "gt_f1"):
            row = part[part["truth"] == truth]
            if row.empty:
                cells.append("-")
                continue
            r = row.iloc[0]
            cells.append(f"{r['agreement']:+.2f} / {_fmt(r['concordance'])} / "
                         f"{_fmt(r['p_value'], '.3f')} (n={int(r['n'])})")
        lines.append(f"| {metric} | " + " | ".join(cells) + " |")
    for by, title in (("kind", "world kind"), ("noise", "odometry noise")):
        t = tables[f"by_{by}"]
        if t.empty:
            continue
        values = list(dict.fromkeys(t[by]))
        lines += ["", f"### Concordance by {title} (vs ATE RMSE / vs GT-map F1)", "",
                  "| metric | " + " | ".join(str(v) for v in values) + " |",
                  "|---|" + "---|" * len(values)]
        for metric, part in t.groupby("metric", sort=False):
            cells = []
            for v in values:
                sub = part[part[by] == v]
                c = [_fmt(sub.loc[sub["truth"] == tr, "concordance"].iloc[0])
                     if (sub["truth"] == tr).any() else "-" for tr in ("ate_rmse", "gt_f1")]
                cells.append(" / ".join(c))
            lines.append(f"| {metric} | " + " | ".join(cells) + " |")
    f = tables["failures"]
    lines += ["", "### Failures each metric sees", "",
              f"A map is broken when its ATE RMSE is over {BROKEN_ATE_FACTOR:g}x the best of "
              f"its sequence and over {BROKEN_ATE_FLOOR:g} m (decided before the run). Over "
              "the sequences with a broken and an unbroken map: how often the metric's worst "
              "map is a broken one (it sees the failure), and how often its best is (it would "
              "name a broken map best).", "",
              "| metric | sequences | worst is broken | best is broken |", "|---|---|---|---|"]
    for r in f.itertuples():
        lines.append(f"| {r.metric} | {r.sequences} | {_fmt(r.worst_is_broken)} | "
                     f"{_fmt(r.best_is_broken)} |")
    return "\n".join(lines) + "\n"


BEGIN, END = "<!-- benchmark:begin -->", "<!-- benchmark:end -->"


def main(argv: Seq[str] | None = None) -> int:
    """``python -m slamq.synth.benchmark OUTPUT``: the study of a benchmark run, printed or
    written into a Markdown file between the ``<!-- benchmark:begin/end -->`` markers."""
    import argparse

    from slamq.synth.damage import print_or_write_section

    ap = argparse.ArgumentParser(prog="python -m slamq.synth.benchmark",
                                 description=main.__doc__)
    ap.add_argument("output", type=Path, help="the `slamq run` output folder")
    ap.add_argument("--permutations", type=int, default=1000)
    ap.add_argument("--markdown", type=Path, help="file whose marked section to replace")
    args = ap.parse_args(argv)
    tables = study_benchmark(load_benchmark(args.output), permutations=args.permutations)
    command = f"python -m slamq.synth.benchmark {args.output} --permutations " \
        f"{args.permutations}" + (f" --markdown {args.markdown}" if args.markdown else "")
    return print_or_write_section(markdown_benchmark(tables, command), args.markdown, BEGIN,
                                  END)


if __name__ == "__main__":
    raise SystemExit(main())
