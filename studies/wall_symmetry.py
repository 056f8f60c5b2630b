"""The wall-symmetry classes (docs/spec.md 3a.2) of every map of the real-map corpus and of
generated and drawn maps: ``R4`` and ``R6`` (the shares of the gradient weight that agree
on one direction modulo 90 and 60 degrees), the class and the wall angle.

``python studies/wall_symmetry.py [--real DIR] [--markdown docs/validity.md]`` prints (or
writes between the ``wall-symmetry`` markers) one table per set: the real maps (every PGM
and PNG under the corpus's maps folder, through its YAML when one names it), generated
worlds of every kind upright and turned 20 degrees, damaged floor plans, and regular
polygons drawn with OpenCV (tests/metrics/test_walls.py draws the same).
"""

from __future__ import annotations

import argparse
import math
import sys
import warnings
from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np
import pandas as pd
from _common import SHARED_MAPS, print_or_write_section

from slamq import native
from slamq.models import OccupancyMap
from slamq.models.quality import wall_symmetry
from slamq.sources import load_map
from slamq.synth import degrade, floor_plan, world
from slamq.synth.worldgen import KINDS

__all__ = ["classify", "polygon", "real_rows", "synthetic_rows"]

BEGIN, END = "<!-- wall-symmetry:begin -->", "<!-- wall-symmetry:end -->"


def classify(m: OccupancyMap) -> dict[str, object]:
    """``R4``, ``R6``, class and wall angle of one map (what :func:`slamq.evaluate` gives
    as ``wall_symmetry`` and ``wall_angle``).

    Examples
    --------
    >>> classify(floor_plan(0))["class"]
    'rectilinear'
    """
    h = native.wall_harmonics(np.ascontiguousarray(m.values), np.ascontiguousarray(m.unknown))
    re4, im4, re6, im6, weight = h
    theta = math.atan2(im4, re4) / 4.0 if (re4 or im4) else 0.0
    cls, angle = wall_symmetry(h, theta)
    w = max(weight, 1)
    return {"R4": math.hypot(re4, im4) / w, "R6": math.hypot(re6, im6) / w, "class": cls,
            "angle": angle}


def polygon(sides: int, turn: float, radius: float = 6.0, res: float = 0.05) -> OccupancyMap:
    """A regular polygon of free floor in 0.1 m walls, turned ``turn`` degrees, with three
    partitions parallel to its sides.

    Examples
    --------
    >>> classify(polygon(6, 10.0))["class"]
    'hexagonal'
    """
    size = int(2 * radius / res) + 40
    img = np.full((size, size), 205, np.uint8)
    c, r, sh = size / 2.0, radius / res, 4

    def at(a: float, d: float) -> tuple[float, float]:
        return c + d * math.cos(math.radians(a)), c - d * math.sin(math.radians(a))

    pts = [np.round(np.array([at(turn + 360.0 * k / sides, r) for k in range(sides)])
                    * (1 << sh)).astype(np.int32)]
    cv2.fillPoly(img, pts, 254, cv2.LINE_8, sh)
    t = max(1, round(0.1 / res))
    cv2.polylines(img, pts, True, 0, t, cv2.LINE_8, sh)
    for k in range(3):
        d = turn + 90.0 + 180.0 / sides + k * 360.0 / sides
        mid, step = np.array(at(d - 90.0, 0.35 * r)), np.array(at(d, 0.3 * r)) - c
        p, q = (np.round((mid + s * step) * (1 << sh)).astype(int) for s in (-1, 1))
        cv2.line(img, tuple(int(v) for v in p), tuple(int(v) for v in q), 0, t, cv2.LINE_8, sh)
    return OccupancyMap(img, img == 205, resolution=res, source=f"{sides}-gon turned {turn:g}")


def real_rows(root: Path) -> pd.DataFrame:
    """:func:`classify` of every PGM/PNG under ``root``, loaded through the YAML that names
    it when there is one.

    Examples
    --------
    >>> import tempfile
    >>> len(real_rows(Path(tempfile.mkdtemp())))
    0
    """
    yamls: dict[Path, Path] = {}
    for y in root.rglob("*.yaml"):
        for line in y.read_text(errors="ignore").splitlines():
            if line.strip().startswith("image:"):
                name = Path(line.split(":", 1)[1].strip().strip("'\"")).name
                yamls[(y.parent / name).resolve()] = y
    rows = []
    for p in sorted(q for q in root.rglob("*") if q.suffix.lower() in (".pgm", ".png")):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            m = load_map(yamls.get(p.resolve(), p))
        rows.append({"map": str(p.relative_to(root)), "resolution": m.resolution,
                     **classify(m)})
    return pd.DataFrame(rows)


def synthetic_rows() -> pd.DataFrame:
    """:func:`classify` of generated worlds (every kind of :data:`slamq.synth.worldgen.KINDS`,
    the hexagonal one included, seeds 0-2, upright and turned 20 degrees), floor plans 0-1
    clean and damaged, and drawn polygons.

    Examples
    --------
    >>> df = synthetic_rows()
    >>> worlds = df[df["set"] == "worlds"]
    >>> hexagonal = worlds["map"].str.startswith("hexagonal")
    >>> sorted(set(worlds.loc[hexagonal, "class"])), sorted(set(worlds.loc[~hexagonal, "class"]))
    (['hexagonal'], ['rectilinear'])
    """
    rows = []
    for kind in KINDS:
        for s in range(3):
            w = world(s, kind=kind)
            for turn in (0.0, 20.0):
                m = w if not turn else degrade(w, "rotation", turn)
                rows.append({"set": "worlds", "map": f"{kind} {s} turned {turn:g}",
                             **classify(m)})
    for s in range(2):
        p = floor_plan(s)
        for damage, sev in (("clean", 0), ("superposed", 10), ("superposed", 45),
                            ("kinks", 20), ("smear", 20), ("drift", 8), ("specks", 0.02),
                            ("doubling", 0.3)):
            m = p if damage == "clean" else degrade(p, damage, sev, seed=s)
            rows.append({"set": "plans", "map": f"plan {s} {damage} {sev:g}", **classify(m)})
    for sides in (3, 4, 5, 6, 8, 48):
        for turn in (0.0, 15.0, 30.0):
            rows.append({"set": "polygons", "map": f"{sides}-gon turned {turn:g}",
                         **classify(polygon(sides, turn))})
    return pd.DataFrame(rows)


def _table(df: pd.DataFrame, first: str) -> str:
    lines = [f"| {first} | R4 | R6 | class | wall angle |", "|---|---|---|---|---|"]
    for r in df.to_dict("records"):
        name = f"`{r['map']}`" if "set" not in r else f"{r['set']}: {r['map']}"
        lines.append(f"| {name} | {r['R4']:.3f} | {r['R6']:.3f} | {r['class']} | "
                     f"{r['angle']:+.1f} |")
    return "\n".join(lines) + "\n"


def main(argv: Sequence[str] | None = None) -> int:
    """``python studies/wall_symmetry.py``: the wall-symmetry class of every real map and of
    generated and drawn maps."""
    ap = argparse.ArgumentParser(prog="python studies/wall_symmetry.py",
                                 description=main.__doc__)
    ap.add_argument("--real", type=Path, default=SHARED_MAPS, metavar="DIR",
                    help=f"the corpus's maps folder (default {SHARED_MAPS})")
    ap.add_argument("--markdown", type=Path, help="file whose marked section to replace")
    args = ap.parse_args(argv)
    real = real_rows(args.real)
    syn = synthetic_rows()
    counts = real["class"].value_counts()
    by_group = real.assign(group=real["map"].str.split("/").str[0]).groupby(
        ["group", "class"]).size().unstack(fill_value=0)
    text = [f"Regenerate: `python studies/wall_symmetry.py --markdown docs/validity.md` "
            f"({len(real)} real maps).\n\n",
            "**Real maps, per class:** " + ", ".join(
                f"{k} {int(counts.get(k, 0))}" for k in ("rectilinear", "hexagonal",
                                                          "irregular")) + ".\n\n",
            "| folder | " + " | ".join(by_group.columns) + " |\n",
            "|---|" + "---|" * len(by_group.columns) + "\n"]
    text += [f"| {g} | " + " | ".join(str(int(v)) for v in row) + " |\n"
             for g, row in by_group.iterrows()]
    text += ["\n", _table(real, "map"), "\n", "**Generated and drawn maps:**\n\n",
             _table(syn, "map")]
    return print_or_write_section("".join(text), args.markdown, BEGIN, END)


if __name__ == "__main__":
    sys.exit(main())
