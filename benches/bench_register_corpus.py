"""Benchmark: ``slamq.register`` on every pair of every folder of ../shared/data/maps that
holds at least two maps of one place (issue 41 item 3): how many pairs are placed, how many
refused, and the CPU time per pair (one thread).

A folder's maps are its map_server YAMLs, or its images where a folder has no YAML for
them (the corpus's MANIFEST.md says which maps of a group show one place; the folders below
follow it, one place each where the MANIFEST says so). Every unordered pair is registered
once (the second map onto the first); per pair it prints ok, the rotation, inliers,
overlap, margin and the CPU seconds; per folder the pairs placed. ``--json FILE`` writes
every pair's figures, so that two builds can be compared pair by pair
(``--compare OLD.json``).

Usage::

    PYTHONPATH=python python benches/bench_register_corpus.py [--json out.json]
        [--compare before.json] [--folders base_model_mu_building,...] [--repeat 1]
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import itertools  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import platform  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import slamq  # noqa: E402

ROOT = Path(os.environ.get("SLAMQ_SHARED_DATA",
                           Path(__file__).resolve().parents[2] / "shared" / "data")) / "maps"

#: folder -> its maps (relative to the folder), one place each unless said.
FOLDERS: dict[str, list[str]] = {
    "slam_comparison_tools/test_results/abstract": [
        "cartographer_map.yaml", "gmapping_map.yaml", "lidar_rtabmap_map.yaml",
        "rgbd_rtabmap_map.yaml", "slam_toolbox_map.yaml"],
    "slam_comparison_tools/test_results/office": [
        "cartographer_map.yaml", "gmapping_map.yaml", "lidar_rtabmap_map.yaml",
        "rgbd_rtabmap_map.yaml", "slam_toolbox_map.yaml"],
    "slam_comparison_tools/test_results/warehouse": [
        "cartographer_map.yaml", "gmapping_map.yaml", "lidar_rtabmap_map.yaml",
        "rgbd_rtabmap_map.yaml", "slam_toolbox_map.yaml"],
    "tfm_turtlebot4/maps": [
        "cartographer/default.yaml", "cartographer/no_imu.yaml", "gmapping/default.yaml",
        "hector/hector.yaml", "slam_toolbox/HuberLoss.yaml", "slam_toolbox/default.yaml"],
    "awabot_trajectoire4_4": [
        "trajectoire4_4_cartographer_1.yaml", "trajectoire4_4_gmapping.yaml",
        "trajectoire4_4_hector_odom.yaml", "trajectoire4_4_rtabmap.yaml"],
    "nanobot/new_maps": [
        "crsm_processed.pgm", "gmapping_processed.pgm", "hector_processed.pgm", "karto.yaml"],
    "nanobot/maps": [
        "adnn.yaml", "gmap.yaml", "gmapping.yaml", "gmapping_ros.yaml", "karto.yaml",
        "map.yaml", "test_gmapping.yaml"],
    # map.yaml is another place (MANIFEST): its pairs are expected refused
    "lfz1994_robot_navigation": ["cartographer.yaml", "gmapping.yaml", "karto.yaml",
                                 "map.yaml"],
    "camel_robot_office": [
        "02_06_2022_office.yaml", "07_04_office.yaml", "4_07_2022.yaml",
        "cartographer2_map.yaml", "cartographer_map.yaml", "office_29_03.yaml",
        "slam_toolbox_map.yaml", "slam_toolbox_map1.yaml", "slam_toolbox_sync_map.yaml",
        "unfinished_map.yaml"],
    "base_model_mu_building": ["mu.yaml", "mu4.yaml", "mu_gm.yaml"],
    "tb3_aws_house_carto_rtab": [
        "cart_lidar0-9res/map.yaml", "cart_lidar2-5res/map.yaml",
        "rtab_lidar0-9res/map.yaml", "rtab_lidar2-5res/map.yaml"],
    "ros2_car_2": ["cartographer_map.yaml", "gmapping_map.yaml", "my_map.yaml"],
    "ros_whill_arc": ["cartographer.yaml", "gmapping.yaml"],
    "atividade3_gmapping_hector": ["map_gmapping.yaml", "map_hector.yaml"],
    # the raw and the hand-cleaned map of one floor
    "utexas_gdc_large/2": ["2.yaml", "2_original.pgm"],
    # RViz screenshots without a resolution, at different zooms (MANIFEST): one room
    "dakitec_pioneer_rviz_screenshots:a207": [
        "cartographer_a207.png", "gmapping_a207.png", "hector_mapping_a207.png"],
}


def _folder_dir(key: str) -> Path:
    return ROOT / key.split(":")[0]


def run(keys: list[str], repeat: int) -> list[dict]:
    rows = []
    for key in keys:
        files = FOLDERS[key]
        maps = {f: slamq.load_map(_folder_dir(key) / f) for f in files}
        for a, b in itertools.combinations(files, 2):
            best, r = math.inf, None
            for _ in range(repeat):
                t = time.process_time()
                r = slamq.register(maps[b], maps[a], threads=1)
                best = min(best, time.process_time() - t)
            assert r is not None
            rows.append(dict(folder=key, moving=b, fixed=a, ok=r.ok, reason=r.reason,
                             theta=math.degrees(r.theta), tx=r.tx, ty=r.ty,
                             inliers=r.inliers, overlap=r.overlap, margin=r.margin,
                             confidence=r.confidence, seconds=best,
                             res=(maps[b].resolution, maps[a].resolution)))
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--folders", default=",".join(FOLDERS))
    ap.add_argument("--json", help="write every pair's figures here")
    ap.add_argument("--compare", help="a --json file of another build, compared pair by pair")
    args = ap.parse_args()
    keys = args.folders.split(",")
    print(f"# slamq {slamq.__version__}, {platform.processor() or platform.machine()}, "
          f"load {os.getloadavg()[0]:.1f}; CPU seconds per pair, one thread, best of "
          f"{args.repeat}")
    rows = run(keys, args.repeat)
    old = {}
    if args.compare:
        old = {(r["folder"], r["moving"], r["fixed"]): r
               for r in json.loads(Path(args.compare).read_text())}
    print(f"\n{'pair':70s} {'ok':>5s} {'deg':>7s} {'inl':>5s} {'ovl':>5s} {'marg':>5s} "
          f"{'s':>6s}" + ("  before: ok, deg, move m" if old else ""))
    for r in rows:
        line = (f"{r['folder'].split('/')[0][:18] + ': ' + r['moving'] + ' -> ' + r['fixed']:70s}"
                f" {r['ok']!s:>5s} {r['theta']:7.1f} {r['inliers']:5.2f} {r['overlap']:5.2f}"
                f" {r['margin']:5.2f} {r['seconds']:6.2f}")
        o = old.get((r["folder"], r["moving"], r["fixed"]))
        if o is not None:
            moved = math.hypot(o["tx"] - r["tx"], o["ty"] - r["ty"])
            line += f"  {o['ok']!s:>5s} {o['theta']:7.1f} {moved:6.2f}"
        print(line)
    print(f"\n{'folder':46s} {'pairs':>5s} {'placed':>6s}" + (" before" if old else "")
          + f" {'s/pair':>7s} {'max s':>6s}")
    total = placed = before = 0
    for key in keys:
        fr = [r for r in rows if r["folder"] == key]
        n_ok = sum(r["ok"] for r in fr)
        n_old = sum(old[(r["folder"], r["moving"], r["fixed"])]["ok"] for r in fr
                    if (r["folder"], r["moving"], r["fixed"]) in old)
        total, placed, before = total + len(fr), placed + n_ok, before + n_old
        secs = [r["seconds"] for r in fr]
        print(f"{key:46s} {len(fr):5d} {n_ok:6d}" + (f" {n_old:6d}" if old else "")
              + f" {sum(secs) / len(secs):7.2f} {max(secs):6.2f}")
    secs = [r["seconds"] for r in rows]
    print(f"{'all':46s} {total:5d} {placed:6d}" + (f" {before:6d}" if old else "")
          + f" {sum(secs) / len(secs):7.2f} {max(secs):6.2f}")
    print(f"# load {os.getloadavg()[0]:.1f} at the end")
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
