"""A Freiburg log kept as a ROS 1 bag (INESCTEC/ricoslam's ``*.orig.bag``) written back as a
CARMEN log of one beam layout, for a study (docs/validity.md, "A fifth real log").

``slamq`` reads one beam layout per recording. The Freiburg clinic log (``fr-clinic``) was
recorded with the SICK's interlaced mode: four layouts in turn, 181 beams from -90 degrees
and three of 180 beams shifted by 0.25, 0.5 and 0.75 degrees. This keeps the scans of one
layout (by default the one that starts at ``--start`` degrees, -90) exactly as recorded and
every odometry message, so a program sees one scan every fourth step with the odometry
between them. The laser's offset on the robot (``/tf_static``, base to laser) becomes
``PARAM robot_frontlaser_offset``; each ``FLASER`` carries the odometry pose at its stamp
(the bag publishes both at one stamp), and ``PARAM laser_beams 181`` tells GMapping
the layout, as the other logs of ../shared were rebuilt.

``python studies/bag_carmen.py BAG OUT.clf [--start -90]``
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path


def _yaw(q: object) -> float:
    return 2.0 * math.atan2(q.z, q.w)  # type: ignore[attr-defined]


def convert(bag: Path, out: Path, start_deg: float = -90.0) -> dict[str, int]:
    """Write ``out`` from ``bag``; return the counts of what was kept and dropped."""
    from rosbags.highlevel import AnyReader

    kept = dropped = odoms = 0
    with AnyReader([bag]) as reader, out.open("w") as f:
        f.write(f"# CARMEN log written from {bag.name} by studies/bag_carmen.py: one beam "
                f"layout ({start_deg:g} deg start), every ODOM; hostname nohost.\n")
        conns = {c.topic: c for c in reader.connections}
        for _, _, raw in reader.messages(connections=[conns["/tf_static"]]):
            tf = reader.deserialize(raw, conns["/tf_static"].msgtype).transforms[0]
            t = tf.transform
            f.write(f"PARAM robot_frontlaser_offset {t.translation.x:.6f} 0 nohost 0\n")
            f.write(f"PARAM robot_frontlaser_side_offset {t.translation.y:.6f} 0 nohost 0\n")
            f.write(f"PARAM robot_frontlaser_angular_offset {_yaw(t.rotation):.6f} "
                    "0 nohost 0\n")
        # GMapping reads the beam count of FLASER lines from these (180 without them)
        f.write("PARAM robot_use_laser on 0 nohost 0\nPARAM laser_beams 181 0 nohost 0\n")
        poses: dict[int, tuple[float, float, float]] = {}
        for _, _, raw in reader.messages(connections=[conns["/odom"]]):
            msg = reader.deserialize(raw, conns["/odom"].msgtype)
            p = msg.pose.pose
            poses[msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec] = (
                p.position.x, p.position.y, _yaw(p.orientation))
        odom = (0.0, 0.0, 0.0)
        for conn, _, raw in reader.messages(connections=[conns["/odom"], conns["/scan"]]):
            msg = reader.deserialize(raw, conn.msgtype)
            ns = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
            stamp = ns * 1e-9
            odom = poses.get(ns, odom)
            if conn.topic == "/odom":
                odoms += 1
                f.write(f"ODOM {odom[0]:.6f} {odom[1]:.6f} {odom[2]:.6f} 0 0 0 "
                        f"{stamp:.6f} nohost {stamp:.6f}\n")
                continue
            if abs(math.degrees(msg.angle_min) - start_deg) > 0.01 or len(msg.ranges) != 181:
                dropped += 1
                continue
            kept += 1
            ranges = " ".join(f"{r:.2f}" for r in msg.ranges)
            pose = " ".join(f"{v:.6f}" for v in odom)
            f.write(f"FLASER {len(msg.ranges)} {ranges} {pose} {pose} "
                    f"{stamp:.6f} nohost {stamp:.6f}\n")
    return {"scans_kept": kept, "scans_dropped": dropped, "odometry": odoms}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    ap.add_argument("bag", type=Path)
    ap.add_argument("out", type=Path)
    ap.add_argument("--start", type=float, default=-90.0, help="the kept layout's first beam, deg")
    a = ap.parse_args(argv if argv is not None else sys.argv[1:])
    print(convert(a.bag, a.out, a.start))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
