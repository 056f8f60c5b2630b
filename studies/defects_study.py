"""How well the defect detectors of :mod:`slamq.metrics.defects` work: precision and recall
on three labelled sets, none of which the thresholds were tuned on.

- **synthetic** (held out): :func:`slamq.synth.damage.floor_plan` seeds 700.. and
  :func:`slamq.synth.worldgen.worlds` from seed 700, clean and damaged by
  :func:`slamq.synth.damage.degrade` (damage seeds 700..); the thresholds were tuned on
  plan seeds 100-105 and worlds from seed 100 (seeds 300.. and 500.. were held-out sets of
  earlier versions, used up: docs/validity.md says how). :data:`EXPECTED` is what docs/validity.md
  wrote down before any detector ran: per damage, which detector must fire (``"fires"``),
  must stay silent (``"silent"``) or may do either (not counted).
- **benchmark**: the 360 maps of ``examples/benchmark.yaml`` (real MRPT SLAM programs on
  generated worlds), labelled broken when the run's ATE RMSE is over 3x the sequence's best
  and over 0.2 m (studies/benchmark_study.py, :func:`load_benchmark`).
- **real**: maps of the real-map corpus (../shared/data beside the clone, or
  ``SLAMQ_SHARED_DATA``; :data:`_common.SHARED_MAPS`) labelled by eye (its MANIFEST.md):
  :data:`REAL_DEFECTIVE` with the detectors expected on each, and :data:`REAL_CLEAN`, paths
  relative to the maps folder ``--real`` names.

``python studies/defects_study.py --benchmark DIR --real [DIR] --markdown
docs/validity.md`` regenerates the tables of docs/validity.md ("Defect detectors");
``--real`` alone reads the corpus at :data:`_common.SHARED_MAPS`. ``--scale F`` resamples
every synthetic and real map F times finer (nearest cell: 2.5 turns a 0.05 m map into a
0.02 m one with the same walls in metres) before the detectors see it, so that the same
maps are measured at two resolutions.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pandas as pd
from _common import SHARED_MAPS, print_or_write_section

from slamq.metrics.defects import DETECTORS
from slamq.models import OccupancyMap
from slamq.sources import load_map
from slamq.synth.damage import degrade, floor_plan
from slamq.synth.worldgen import worlds

__all__ = ["EXPECTED", "REAL_CLEAN", "REAL_DEFECTIVE", "benchmark_table", "flags",
           "real_table", "synthetic_table"]

_F, _S = "fires", "silent"
_ALL_SILENT = {d: _S for d in DETECTORS}
#: (damage, severity) -> {detector: "fires" / "silent"}; a detector left out may do either.
EXPECTED: dict[tuple[str, float], dict[str, str]] = {
    ("clean", 0.0): _ALL_SILENT,
    ("rotation", 3.0): _ALL_SILENT,
    ("rotation", 20.0): _ALL_SILENT,
    ("specks", 0.002): _ALL_SILENT,
    ("specks", 0.005): _ALL_SILENT,
    ("drift", 0.5): _ALL_SILENT,
    ("drift", 1.0): _ALL_SILENT,
    ("superposed", 5.0): {"superposed": _F, "fragmented": _S},
    ("superposed", 10.0): {"superposed": _F, "fragmented": _S},
    ("superposed", 20.0): {"superposed": _F, "fragmented": _S},
    ("doubling", 0.2): {"doubled_walls": _F, "smeared": _S, "fragmented": _S},
    ("doubling", 0.3): {"doubled_walls": _F, "smeared": _S, "fragmented": _S},
    ("doubling", 0.4): {"doubled_walls": _F, "smeared": _S, "fragmented": _S},
    ("doubling", 1.0): {"superposed": _F, "smeared": _S, "fragmented": _S},
    ("doubling", 30.0): {"doubled_walls": _S, "smeared": _S, "fragmented": _F},
    ("smear", 10.0): {"smeared": _F, "fragmented": _S},
    ("smear", 20.0): {"smeared": _F, "fragmented": _S},
    # added with v2 (after the first measurement on real maps): parts turned against each
    # other, as scan matching that jumped leaves them
    ("kinks", 10.0): {"superposed": _F, "fragmented": _S},
    ("kinks", 20.0): {"superposed": _F, "fragmented": _S},
}

#: Real maps with a defect seen by eye (MANIFEST.md), relative to the corpus's maps folder
#: (:data:`_common.SHARED_MAPS` unless ``--real`` names another), and the detectors
#: expected to fire on each (at least one of them finds the map).
REAL_DEFECTIVE: dict[str, tuple[str, ...]] = {
    "awabot_trajectoire4_4/trajectoire4_4_hector_odom.yaml": ("superposed",),
    "tfm_turtlebot4/maps/cartographer/default.yaml": ("superposed", "smeared"),
    "slam_comparison_tools/test_results/warehouse/cartographer_map.yaml":
        ("superposed", "smeared"),
    "slam_comparison_tools/test_results/abstract/cartographer_map.yaml":
        ("superposed", "doubled_walls"),
    "slam_comparison_tools/test_results/abstract/lidar_rtabmap_map.yaml":
        ("superposed", "doubled_walls"),
    "camel_robot_office/cartographer_map.yaml": ("doubled_walls", "superposed"),
    "base_model_mu_building/mu.yaml": ("superposed", "smeared"),
    "base_model_mu_building/mu_gm.yaml": ("doubled_walls",),
}
#: Real maps labelled clean (relative to the same folder): no detector may fire.
REAL_CLEAN: tuple[str, ...] = (
    *(f"slam_comparison_tools/test_results/{w}/{a}_map.yaml"
      for w in ("abstract", "office", "warehouse") for a in ("gmapping", "slam_toolbox")),
    "slam_comparison_tools/test_results/office/lidar_rtabmap_map.yaml",
    "slam_comparison_tools/test_results/warehouse/lidar_rtabmap_map.yaml",
    "tfm_turtlebot4/maps/gmapping/default.yaml",
    "tfm_turtlebot4/maps/slam_toolbox/default.yaml",
    "tfm_turtlebot4/maps/slam_toolbox/HuberLoss.yaml",
    "tfm_turtlebot4/maps/hector/hector.yaml",
    "awabot_trajectoire4_4/trajectoire4_4_gmapping.yaml",
    "awabot_trajectoire4_4/trajectoire4_4_cartographer_1.yaml",
    *(f"tb3_aws_house_carto_rtab/{v}/map.yaml" for v in (
        "cart_lidar0-9res", "cart_lidar2-5res", "rtab_lidar0-9res", "rtab_lidar2-5res")),
    "lfz1994_robot_navigation/cartographer.yaml",
    "lfz1994_robot_navigation/gmapping.yaml",
    "lfz1994_robot_navigation/karto.yaml",
    "ros2_car_2/cartographer_map.yaml",
    "ros2_car_2/gmapping_map.yaml",
    "atividade3_gmapping_hector/map_gmapping.yaml",
    "atividade3_gmapping_hector/map_hector.yaml",
    "yogik10_slam_maps_eval/map_fastslam.pgm",
    "utexas_gdc_large/2/2.yaml",
    "utexas_gdc_large/3/3.yaml",
    "utexas_gdc_large/intel_lab/intel.yaml",
    "base_model_mu_building/mu4.yaml",
    "nanobot/new_maps/karto.yaml",
)


def finer(m: OccupancyMap, scale: float) -> OccupancyMap:
    """``m`` resampled ``scale`` times finer (nearest cell; a map without a resolution is
    taken at 0.05 m): the same walls in metres on a finer grid. ``scale`` 1 returns ``m``.

    Examples
    --------
    >>> from slamq.synth import floor_plan
    >>> f = finer(floor_plan(0), 2.5)
    >>> f.resolution, f.shape[0] == round(floor_plan(0).shape[0] * 2.5)
    (0.02, True)
    """
    if scale == 1:
        return m
    h, w = m.shape
    size = (int(round(w * scale)), int(round(h * scale)))
    values = cv2.resize(m.values, size, interpolation=cv2.INTER_NEAREST)
    unknown = cv2.resize(m.unknown.view(np.uint8), size,
                         interpolation=cv2.INTER_NEAREST).astype(bool)
    res = round((m.resolution or 0.05) / scale, 9)
    return OccupancyMap(values, unknown, resolution=res, origin=m.origin, source=m.source)


def flags(m: OccupancyMap, timing: dict[str, float] | None = None) -> dict[str, Any]:
    """Every detector's verdict on one map: ``{detector: score or None}``, plus
    ``{detector}_bbox`` and ``{detector}_note``; ``timing`` (optional) accumulates CPU
    seconds per detector.

    Examples
    --------
    >>> from slamq.synth import floor_plan
    >>> flags(floor_plan(0))["superposed"] is None
    True
    """
    out: dict[str, Any] = {}
    for name, fn in DETECTORS.items():
        t = time.process_time()
        found = fn(m)
        if timing is not None:
            timing[name] = timing.get(name, 0.0) + time.process_time() - t
        out[name] = found[0].score if found else None
        out[f"{name}_bbox"] = list(found[0].bbox) if found else None
        out[f"{name}_note"] = found[0].note if found else ""
    return out


def synthetic_records(plans: int = 10, seed: int = 700, n_worlds: int = 12,
                      scale: float = 1.0, resolution: float = 0.05) -> pd.DataFrame:
    """One row per held-out synthetic map: ``base`` (plan or world, drawn at ``resolution``
    metres per cell), ``seed``, ``damage``, ``severity`` and :func:`flags`; every base gets
    every damage of :data:`EXPECTED`, then is resampled ``scale`` times finer
    (:func:`finer`).

    Examples
    --------
    >>> df = synthetic_records(plans=1, n_worlds=0)
    >>> len(df) == len(EXPECTED), bool(df.loc[df["damage"] == "clean", "superposed"].isna().all())
    (True, True)
    """
    bases = [floor_plan(seed + k, resolution=resolution) for k in range(plans)] + worlds(
        n_worlds, seed=seed, resolution=resolution)
    rows = []
    for k, base in enumerate(bases):
        for damage, sev in EXPECTED:
            m = base if damage == "clean" else degrade(base, damage, sev, seed=seed + k)
            rows.append({"base": base.source, "seed": seed, "damage": damage,
                         "severity": sev, **flags(finer(m, scale))})
    return pd.DataFrame(rows)


def synthetic_table(df: pd.DataFrame) -> pd.DataFrame:
    """Per detector and damage row: how often it fired, and against :data:`EXPECTED`.

    Examples
    --------
    >>> df = pd.DataFrame({"damage": ["clean", "doubling"], "severity": [0.0, 0.3],
    ...                    **{d: [None, None] for d in DETECTORS}})
    >>> df.loc[1, "doubled_walls"] = 12.5
    >>> t = synthetic_table(df)
    >>> t[t["detector"] == "doubled_walls"][["expected", "fired"]].values.tolist()
    [['silent', 0], ['fires', 1]]
    """
    rows = []
    for (damage, sev), part in df.groupby(["damage", "severity"], sort=False):
        exp = EXPECTED.get((damage, sev), {})
        for det in DETECTORS:
            fired = int(part[det].notna().sum())
            rows.append({"damage": damage, "severity": sev, "detector": det,
                         "expected": exp.get(det, "may"), "fired": fired, "n": len(part)})
    return pd.DataFrame(rows)


def _pr(tp: int, fp: int, fn: int) -> tuple[float, float]:
    prec = tp / (tp + fp) if tp + fp else float("nan")
    rec = tp / (tp + fn) if tp + fn else float("nan")
    return prec, rec


def synthetic_summary(table: pd.DataFrame) -> pd.DataFrame:
    """Per detector: precision and recall over the rows where :data:`EXPECTED` says fires
    or silent.

    Examples
    --------
    >>> df = pd.DataFrame({"damage": ["clean", "doubling"], "severity": [0.0, 0.3],
    ...                    **{d: [None, None] for d in DETECTORS}})
    >>> df.loc[1, "doubled_walls"] = 12.5
    >>> s = synthetic_summary(synthetic_table(df)).set_index("detector")
    >>> float(s.loc["doubled_walls", "precision"]), float(s.loc["doubled_walls", "recall"])
    (1.0, 1.0)
    """
    out = []
    for det, t in table.groupby("detector", sort=False):
        pos, neg = t[t["expected"] == _F], t[t["expected"] == _S]
        tp, fn = int(pos["fired"].sum()), int((pos["n"] - pos["fired"]).sum())
        fp = int(neg["fired"].sum())
        prec, rec = _pr(tp, fp, fn)
        out.append({"detector": det, "precision": prec, "recall": rec, "tp": tp, "fp": fp,
                    "fn": fn, "negatives": int(neg["n"].sum())})
    return pd.DataFrame(out)


def benchmark_records(output: Path) -> pd.DataFrame:
    """:func:`flags` of every map of a benchmark run folder (:func:`benchmark_study.
    load_benchmark`), with ``broken``, ``kind`` and ``ate_rmse``; runs without a map are
    left out. Reads every map: minutes for the 360-map benchmark."""
    from benchmark_study import load_benchmark

    df = load_benchmark(Path(output))
    rows = []
    for r in df.itertuples():
        if not isinstance(r.map, str):
            continue
        rows.append({"algorithm": r.algorithm, "sequence": r.sequence, "map": r.map,
                     "broken": bool(r.broken), "kind": r.kind, "ate_rmse": r.ate_rmse,
                     **flags(load_map(r.map))})
    return pd.DataFrame(rows)


def benchmark_table(df: pd.DataFrame) -> pd.DataFrame:
    """Per detector (and any of them): maps flagged, precision (flagged maps that are
    broken), recall (broken maps flagged), flags on unbroken maps, and flags on the map
    with the lowest ATE of its sequence (what would keep the verdict from naming it).

    Examples
    --------
    >>> df = pd.DataFrame({"sequence": ["a", "a"], "ate_rmse": [0.05, 0.9],
    ...                    "broken": [False, True], **{d: [None, 3.0] for d in DETECTORS}})
    >>> t = benchmark_table(df).set_index("detector")
    >>> float(t.loc["any", "precision"]), int(t.loc["any", "best_flagged"])
    (1.0, 0)
    """
    out = []
    best = df.loc[df.groupby("sequence")["ate_rmse"].idxmin()]
    def fired_in(d: pd.DataFrame, det: str) -> pd.Series:
        return d[list(DETECTORS)].notna().any(axis=1) if det == "any" else d[det].notna()
    for det in [*DETECTORS, "any"]:
        fired = fired_in(df, det)
        tp = int((fired & df["broken"]).sum())
        fp = int((fired & ~df["broken"]).sum())
        fn = int((~fired & df["broken"]).sum())
        prec, rec = _pr(tp, fp, fn)
        out.append({"detector": det, "flagged": tp + fp, "precision": prec, "recall": rec,
                    "flags_on_unbroken": fp, "unbroken": int((~df["broken"]).sum()),
                    "broken": int(df["broken"].sum()),
                    "best_flagged": int(fired_in(best, det).sum()), "sequences": len(best)})
    return pd.DataFrame(out)


def real_records(root: Path, timing: dict[str, float] | None = None,
                 scale: float = 1.0) -> pd.DataFrame:
    """:func:`flags` of the labelled real maps under ``root`` (the corpus's maps folder,
    :data:`_common.SHARED_MAPS`), each resampled ``scale`` times finer (:func:`finer`);
    maps that are absent are left out (a folder without them gives an empty table).

    Examples
    --------
    >>> import tempfile
    >>> len(real_records(tempfile.mkdtemp()))
    0
    """
    rows = []
    items = [(p, "defective", exp) for p, exp in REAL_DEFECTIVE.items()] + [
        (p, "clean", ()) for p in REAL_CLEAN]
    for rel, label, exp in items:
        path = Path(root) / rel
        if not path.exists():
            continue
        m = finer(load_map(path), scale)
        rows.append({"map": rel, "label": label, "expected": ",".join(exp),
                     "mcells": m.values.size / 1e6, **flags(m, timing)})
    return pd.DataFrame(rows)


def real_table(df: pd.DataFrame) -> pd.DataFrame:
    """Per detector (and any): precision (flags on defective maps / all flags), recall (of
    the defective maps where the detector is expected, those it flags), flags on clean
    maps.

    Examples
    --------
    >>> df = pd.DataFrame({"label": ["defective", "clean"], "expected": ["superposed", ""],
    ...                    **{d: [None, None] for d in DETECTORS}})
    >>> df.loc[0, "superposed"] = 0.6
    >>> t = real_table(df).set_index("detector")
    >>> float(t.loc["superposed", "recall"]), int(t.loc["any", "flags_on_clean"])
    (1.0, 0)
    """
    out = []
    clean = df["label"] == "clean"
    for det in [*DETECTORS, "any"]:
        fired = df[list(DETECTORS)].notna().any(axis=1) if det == "any" else df[det].notna()
        expected = (~clean) if det == "any" else df["expected"].str.split(",").apply(
            lambda e, d=det: d in e)
        tp_all = int((fired & ~clean).sum())
        fp = int((fired & clean).sum())
        prec = tp_all / (tp_all + fp) if tp_all + fp else float("nan")
        rec = float((fired & expected).sum() / expected.sum()) if expected.sum() else \
            float("nan")
        out.append({"detector": det, "flagged": tp_all + fp, "precision": prec,
                    "recall": rec, "expected_on": int(expected.sum()),
                    "flags_on_clean": fp, "clean": int(clean.sum())})
    return pd.DataFrame(out)


def _f(x: float) -> str:
    return "n/a" if x != x else f"{x:.2f}"


def markdown(syn: pd.DataFrame | None, bench: pd.DataFrame | None,
             real: pd.DataFrame | None, timing: dict[str, float] | None, mcells: float,
             command: str) -> str:
    """The tables of docs/validity.md's "Defect detectors" section (each part left out when
    its frame is None).

    Examples
    --------
    >>> print(markdown(None, None, None, None, 0.0, "cmd").splitlines()[0])
    Regenerate with `cmd`.
    """
    lines = [f"Regenerate with `{command}`.", ""]
    if syn is not None:
        table = synthetic_table(syn)
        summary = synthetic_summary(table).set_index("detector")
        seed = int(syn["seed"].iloc[0]) if "seed" in syn and len(syn) else 0
        lines += [f"**Synthetic, held out** (plan seeds {seed}.., worlds from seed {seed}, "
                  f"damage seeds {seed}..; "
                  f"{syn['base'].nunique()} bases). Per damage, maps flagged / maps, "
                  "**bold** where the pre-registration says the detector fires (the kinks rows "
                  "were added with v2), plain where it must stay silent, *italic* where "
                  "either is allowed:", "",
                  "| damage | " + " | ".join(DETECTORS) + " |",
                  "|---|" + "---|" * len(DETECTORS)]
        for (damage, sev), part in table.groupby(["damage", "severity"], sort=False):
            cells = []
            for r in part.itertuples():
                c = f"{r.fired}/{r.n}"
                cells.append(f"**{c}**" if r.expected == _F else c if r.expected == _S
                             else f"*{c}*")
            lines.append(f"| {damage} {sev:g} | " + " | ".join(cells) + " |")
        lines += ["", "| detector | precision | recall | false flags (on maps where it must "
                  "stay silent) |", "|---|---|---|---|"]
        for det, r in summary.iterrows():
            lines.append(f"| {det} | {_f(r.precision)} | {_f(r.recall)} ({int(r.tp)}/"
                         f"{int(r.tp + r.fn)}) | {int(r.fp)}/{int(r.negatives)} |")
        lines.append("")
    if bench is not None:
        seed = bench["sequence"].str.extract(r"-s(\d+)$")[0]
        parts = [("all", bench)] if seed.isna().all() else [
            ("simulation seed 0 (v2 was adjusted on these)", bench[seed == "0"]),
            ("simulation seeds 1-2 (held out)", bench[seed != "0"])]
        lines += [f"**Benchmark** ({len(bench)} MRPT maps, {int(bench['broken'].sum())} "
                  "broken by ATE): precision = flagged maps that are broken, recall = broken "
                  "maps flagged; the last column counts the sequences whose lowest-ATE map is "
                  "flagged (the verdict would pass it over).", ""]
        for title, part in parts:
            if not len(part):
                continue
            t = benchmark_table(part)
            lines += [f"{title}:", "",
                      "| detector | flagged | precision | recall | flags on unbroken maps | "
                      "lowest-ATE map flagged |", "|---|---|---|---|---|---|"]
            for r in t.itertuples():
                lines.append(f"| {r.detector} | {r.flagged} | {_f(r.precision)} | "
                             f"{_f(r.recall)} | {r.flags_on_unbroken}/{r.unbroken} | "
                             f"{r.best_flagged}/{r.sequences} |")
            lines.append("")
        by = bench.assign(any=bench[list(DETECTORS)].notna().any(axis=1)).groupby(
            ["algorithm", "broken"])["any"].agg(["sum", "count"])
        lines += ["", "Flagged by any detector, per program: " + "; ".join(
            f"{a} {'broken' if b else 'unbroken'} {int(r['sum'])}/{int(r['count'])}"
            for (a, b), r in by.iterrows()) + ".", ""]
    if real is not None:
        t = real_table(real)
        lines += [f"**Real maps** (../shared/data, labelled by eye: "
                  f"{int((real['label'] != 'clean').sum())} defective, "
                  f"{int((real['label'] == 'clean').sum())} clean): precision = flags on "
                  "defective maps / all flags; recall = of the defective maps where the "
                  "detector was expected, those it flags.", "",
                  "| detector | flagged | precision | recall | flags on clean maps |",
                  "|---|---|---|---|---|"]
        for r in t.itertuples():
            lines.append(f"| {r.detector} | {r.flagged} | {_f(r.precision)} | "
                         f"{_f(r.recall)} (of {r.expected_on}) | {r.flags_on_clean}/"
                         f"{r.clean} |")
        lines += ["", "| map | label | expected | flagged |", "|---|---|---|---|"]
        for r in real.itertuples():
            got = [d for d in DETECTORS if getattr(r, d) == getattr(r, d)
                   and getattr(r, d) is not None]
            lines.append(f"| `{r.map}` | {r.label} | {r.expected or '-'} | "
                         f"{', '.join(got) or '-'} |")
        lines.append("")
    if timing:
        lines += [f"CPU time per million cells (one thread, over the {mcells:.1f} Mcells of "
                  "the real maps): " + ", ".join(
                      f"{d} {1000 * s / mcells:.0f} ms" for d, s in timing.items()) + ".", ""]
    return "\n".join(lines)


BEGIN, END = "<!-- defects:begin -->", "<!-- defects:end -->"


def main(argv: Sequence[str] | None = None) -> int:
    """``python studies/defects_study.py``: the detectors' precision and recall on the
    held-out synthetic maps, a benchmark run folder and the labelled real maps."""
    ap = argparse.ArgumentParser(prog="python studies/defects_study.py",
                                 description=main.__doc__)
    ap.add_argument("--plans", type=int, default=10, help="held-out floor plans")
    ap.add_argument("--worlds", type=int, default=12, help="held-out generated worlds")
    ap.add_argument("--seed", type=int, default=700,
                    help="first seed of the held-out plans, worlds and damage")
    ap.add_argument("--no-synthetic", action="store_true")
    ap.add_argument("--benchmark", type=Path, help="a `slamq run` output folder")
    ap.add_argument("--real", type=Path, nargs="?", const=SHARED_MAPS, metavar="DIR",
                    help=f"the labelled maps folder (alone: {SHARED_MAPS})")
    ap.add_argument("--resolution", type=float, default=0.05,
                    help="draw the synthetic plans and worlds at this many metres per cell")
    ap.add_argument("--scale", type=float, default=1.0,
                    help="resample every map this many times finer (nearest cell) first")
    ap.add_argument("--csv", type=Path, help="write every map's flags to this folder")
    ap.add_argument("--markdown", type=Path, help="file whose marked section to replace")
    args = ap.parse_args(argv)
    syn = None if args.no_synthetic else synthetic_records(args.plans, args.seed, args.worlds,
                                                           args.scale, args.resolution)
    bench = benchmark_records(args.benchmark) if args.benchmark else None
    timing: dict[str, float] = {}
    real = real_records(args.real, timing, args.scale) if args.real else None
    if args.csv:
        args.csv.mkdir(parents=True, exist_ok=True)
        for name, df in (("synthetic", syn), ("benchmark", bench), ("real", real)):
            if df is not None:
                df.to_csv(args.csv / f"defects_{name}.csv", index=False)
    command = "python studies/defects_study.py" + (
        f" --plans {args.plans} --worlds {args.worlds} --seed {args.seed}" if syn is not None else
        " --no-synthetic") + (f" --benchmark {args.benchmark}" if bench is not None else "") \
        + (f" --real {args.real}" if real is not None else "") + (
        f" --scale {args.scale:g}" if args.scale != 1 else "") + (
        f" --resolution {args.resolution:g}" if args.resolution != 0.05 else "") + (
        f" --markdown {args.markdown}" if args.markdown else "")
    mcells = float(real["mcells"].sum()) if real is not None and len(real) else 0.0
    text = markdown(syn, bench, real, timing if mcells else None, mcells, command)
    return print_or_write_section(text, args.markdown, BEGIN, END)


if __name__ == "__main__":
    sys.exit(main())
