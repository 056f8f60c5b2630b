"""Benchmark: reading ROS bags, slamq vs evo (poses) and every map vs every N-th (maps).

Writes, in a temporary folder, one bag per format (ROS1, ROS2 sqlite3, MCAP) holding
``--poses`` PoseStamped messages and ``--maps`` growing 1000 x 1000 OccupancyGrids, then
times, in the same run:

- poses: ``read_bag_trajectory`` vs evo's ``file_interface.read_bag_trajectory``
  (both on rosbags), asserting identical stamps and positions;
- maps: ``read_bag_maps`` (every map), ``read_bag_maps(every=10)`` and ``read_last_map``.

Usage::

    PYTHONPATH=python python benches/bench_bags.py [--poses 100000] [--maps 60]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

from _bagdata import BagWriter, bag_path  # noqa: E402

from slamq.sources.bag_maps import read_bag_maps, read_last_map
from slamq.sources.bag_poses import read_bag_trajectory  # noqa: E402


def best(fn, repeat: int) -> tuple[float, object]:
    times, out = [], None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return min(times), out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--poses", type=int, default=100_000)
    ap.add_argument("--maps", type=int, default=60)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    from evo.tools import file_interface
    from rosbags.rosbag1 import Reader as Reader1
    from rosbags.rosbag2 import Reader as Reader2

    rng = np.random.default_rng(0)
    tmp = Path(tempfile.mkdtemp())
    print(f"{args.poses} PoseStamped, {args.maps} maps of 1000 x 1000, best of {args.repeat}")
    print(f"{'format':8} {'slamq poses':>12} {'evo poses':>10} {'evo/slamq':>9} "
          f"{'all maps':>9} {'every=10':>9} {'last map':>9} {'all/last':>8}")
    for fmt in ("ros1", "sqlite3", "mcap"):
        bag = bag_path(tmp, fmt)
        with BagWriter(bag, fmt) as w:
            pose_t = w.T["geometry_msgs/msg/PoseStamped"]
            for i in range(args.poses):
                xyz = (0.01 * i, np.sin(0.001 * i), 0.0)
                w.write("/pose", "geometry_msgs/msg/PoseStamped",
                        pose_t(header=w.header(1.0 + 0.01 * i), pose=w.pose(xyz, (1, 0, 0, 0))))
            g = np.full((1000, 1000), -1, np.int8)
            for i in range(args.maps):
                rows = (i + 1) * (1000 // args.maps)
                g[:rows] = rng.choice(np.array([0, 100, -1], np.int8), size=(rows, 1000),
                                      p=[0.8, 0.1, 0.1])
                w.write("/map", "nav_msgs/msg/OccupancyGrid", w.grid(1.0 + i, g))
        ts, mine = best(lambda b=bag: read_bag_trajectory(b, "/pose"), args.repeat)

        def evo(b=bag, fmt=fmt):
            with (Reader1 if fmt == "ros1" else Reader2)(b) as reader:
                return file_interface.read_bag_trajectory(reader, "/pose")

        te, ref = best(evo, args.repeat)
        assert np.array_equal(mine.timestamps, ref.timestamps)
        assert np.array_equal(mine.positions, ref.positions_xyz)
        ta, n = best(lambda b=bag: sum(1 for _ in read_bag_maps(b, "/map")), args.repeat)
        t10, _ = best(lambda b=bag: sum(1 for _ in read_bag_maps(b, "/map", every=10)),
                      args.repeat)
        tl, _ = best(lambda b=bag: read_last_map(b), args.repeat)
        assert n == args.maps
        print(f"{fmt:8} {ts:11.3f}s {te:9.3f}s {te / ts:9.2f} {ta:8.3f}s {t10:8.3f}s "
              f"{tl:8.3f}s {ta / tl:8.1f}")


if __name__ == "__main__":
    main()
