"""``slamq synth world`` and ``slamq synth sequence``: ground truth on demand.

``world`` draws a seeded procedural building (:func:`slamq.synth.world`) and saves it as a
map_server map; ``sequence`` drives a simulated robot through a world (any map_server map)
and writes its ground truth (:func:`slamq.synth.write_truth`) and, with ``--formats``, the
sensor logs SLAM programs read (:mod:`slamq.synth.writers`, imported only when such a format
is asked for: every command's parser imports this module).
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from slamq.cli.common import EXIT_OK
from slamq.errors import SlamqError

#: Formats this module writes itself; the others come from ``slamq.synth.writers.FORMATS``.
OWN_FORMATS = ("truth", "npz")
#: The sensor-log formats of ``slamq.synth.writers.FORMATS``, named here for ``--help`` so
#: that building the parser does not import the writers (tests/synth: equal).
WRITER_FORMATS = ("rawlog", "carmen", "rosbag1", "rosbag2", "mcap")


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    """Register ``slamq synth``."""
    from slamq.params import SETTINGS  # not slamq.synth: every command's parser runs this

    s = subparsers.add_parser(
        "synth", help="generate worlds and simulated drives with exact ground truth",
        description="Ground truth on demand: procedural worlds whose exact map is known, and "
        "simulated drives through them (exact path, noisy odometry, laser scans).",
    )
    sub = s.add_subparsers(dest="synth_command", required=True)
    w = sub.add_parser("world", help="draw a seeded procedural world (map_server YAML + PGM)",
                       description="Draw a seeded procedural building and save it as "
                       "DIR/NAME.yaml + .pgm (0 wall, 254 free, 205 unknown), NAME.json "
                       "(its rooms and features) and NAME_transparent.png (glass walls). "
                       "Kinds: " + ", ".join(SETTINGS.world_kind.choices)
                       + " (slamq.synth.KINDS describes them).")
    w.add_argument("--seed", type=int, default=0, help="seed (default 0)")
    w.add_argument("--kind", choices=[*sorted(SETTINGS.world_kind.choices), "all"],
                   default=SETTINGS.world_kind.default,
                   help=SETTINGS.world_kind.help_line() + "; all: the kinds in turn")
    w.add_argument("--count", type=int, default=1,
                   help="this many worlds, seeds SEED, SEED+1, ... (default 1)")
    w.add_argument("--size", type=float, nargs=2, metavar=("W", "H"), default=None,
                   help="building size in metres (default 20 15; corridor 30 9)")
    w.add_argument("--resolution", type=float, default=0.05, help="metres per cell")
    w.add_argument("--name", default=None, help="file name of a single world "
                   "(default KIND_SEED)")
    w.add_argument("--out", required=True, metavar="DIR", help="output folder")
    w.set_defaults(func=handle_world)

    q = sub.add_parser("sequence", help="simulate a drive through a world and write its "
                       "ground truth and sensor logs",
                       description="Drive a simulated robot through WORLD (a map_server "
                       "YAML, e.g. from `slamq synth world`): a collision-free tour of its "
                       "rooms that returns to its start, laser scans by exact ray casting, "
                       "odometry with seeded noise. Writes DIR/gt_map, visible_map, gt.tum, "
                       "odom.tum, sequence.json (format truth) and the other --formats.")
    q.add_argument("world", help="the world: a map_server YAML")
    q.add_argument("--seed", type=int, default=0, help="seed of the drive and the noise")
    SETTINGS.noise.add_option(q)
    q.add_argument("--out", required=True, metavar="DIR", help="output folder")
    q.add_argument("--formats", default="truth",
                   help="comma-separated: truth, npz (the whole sequence), and the sensor "
                   f"logs {', '.join(WRITER_FORMATS)} (default truth)")
    q.add_argument("--beams", type=int, default=1081, help="laser beams (default 1081)")
    q.add_argument("--fov", type=float, default=270.0, help="laser field of view, degrees")
    q.add_argument("--max-range", type=float, default=20.0, help="laser range, metres")
    q.add_argument("--range-noise", type=float, default=0.01,
                   help="laser range noise (standard deviation), metres")
    q.add_argument("--speed", type=float, default=0.5, help="metres per second")
    q.add_argument("--rate", type=float, default=10.0, help="scans per second")
    q.add_argument("--length", type=float, default=None,
                   help="visit only the rooms that keep the closed tour within this many "
                   "metres")
    q.add_argument("--laps", type=int, default=1, help="drive the tour this many times")
    q.add_argument("--pauses", type=int, default=0, help="pauses at waypoints")
    q.add_argument("--kidnaps", type=int, default=0,
                   help="times the robot is carried to the next waypoint unseen")
    q.add_argument("--clearance", type=float, default=0.35,
                   help="least distance from the walls, metres")
    q.add_argument("--threads", type=int, default=None, help="ray casting threads")
    q.set_defaults(func=handle_sequence)


def handle_world(args: argparse.Namespace) -> int:
    """``slamq synth world``."""
    from slamq.synth import KINDS, save_world, world

    if args.count < 1:
        raise SlamqError(f"--count must be >= 1, got {args.count}")
    if args.name and args.count > 1:
        raise SlamqError("--name names a single world: leave it out with --count")
    kinds = list(KINDS) if args.kind == "all" else [args.kind]
    out = _folder(args.out)
    for i in range(args.count):
        kind, seed = kinds[i % len(kinds)], args.seed + i
        w = world(seed, kind=kind, size=tuple(args.size) if args.size else None,
                  resolution=args.resolution)
        path = save_world(w, out / f"{args.name or f'{kind}_{seed}'}.yaml")
        print(f"{path}  ({kind}, seed {seed}, {w.shape[1]} x {w.shape[0]} cells, "
              f"{len(w.meta['rooms'])} rooms: {', '.join(w.meta['features'])})")
    return EXIT_OK


def _folder(out: str) -> Path:
    p = Path(out)
    if p.exists() and not p.is_dir():
        raise SlamqError(f"{p}: not a folder")
    try:
        p.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise SlamqError(f"{p}: cannot create the folder: {exc.strerror or exc}") from None
    return p


def parse_formats(text: str) -> list[str]:
    """The asked formats, checked: a :class:`~slamq.errors.SlamqError` names an unknown
    one. The writers module is imported only when a format other than ``truth`` and
    ``npz`` is asked for; its ``FORMATS`` says which it writes."""
    names = list(dict.fromkeys(f.strip().lower() for f in text.split(",") if f.strip()))
    if not names:
        raise SlamqError("--formats: no format given")
    logs = [n for n in names if n not in OWN_FORMATS]
    if not logs:
        return names
    from slamq.synth import writers

    known = tuple(writers.FORMATS)
    for n in logs:
        if n not in known:
            raise SlamqError(f"--formats: unknown format {n!r}: one of "
                             f"{', '.join(OWN_FORMATS + known)}")
    return names


def handle_sequence(args: argparse.Namespace) -> int:
    """``slamq synth sequence``."""
    from slamq.synth import LaserSpec, load_world, save_sequence, simulate, write_truth

    formats = parse_formats(args.formats)
    if not (args.beams >= 1 and 0 <= args.fov <= 360 and args.max_range > 0):
        raise SlamqError("laser: --beams must be >= 1, --fov within 0..360, --max-range > 0")
    world = load_world(args.world)
    laser = LaserSpec(beams=args.beams, fov=math.radians(args.fov), max_range=args.max_range,
                      range_noise=args.range_noise)
    try:
        seq = simulate(world, seed=args.seed, noise=args.noise, laser=laser, speed=args.speed,
                       rate=args.rate, length=args.length, laps=args.laps,
                       pauses=args.pauses, kidnaps=args.kidnaps, clearance_m=args.clearance,
                       threads=args.threads)
    except SlamqError as exc:
        raise SlamqError(f"{args.world}: {exc}") from None
    out = _folder(args.out)
    files: dict[str, Path] = {}
    if "truth" in formats:
        files.update(write_truth(seq, out, threads=args.threads))
    if "npz" in formats:
        files["npz"] = save_sequence(seq, out / "sequence.npz")
    logs = [f for f in formats if f not in OWN_FORMATS]
    if logs:
        from slamq.synth import writers

        files.update(writers.write(seq, out, logs))
    print(f"{seq.name}: {len(seq)} scans x {seq.laser.beams} beams, "
          f"{seq.meta['drive']['length']:.1f} m in {seq.stamps[-1]:.1f} s -> {out}")
    for key, path in files.items():
        print(f"  {key}: {path}")
    return EXIT_OK
