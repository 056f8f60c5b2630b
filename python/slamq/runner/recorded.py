"""Recorded sequences in ``slamq run`` configurations: a real robot's log, converted once.

A sequence may name a CARMEN log or a ROS bag instead of the file the programs read::

    sequences:
      mit-csail:
        carmen: data/mit-csail.clf         # a CARMEN log (.clf / .log, plain or gzip)
        relations: data/mit-csail.relations
        max_scans: 300                     # optional: only the log's first 300 scans
        laser: front                       # front | rear
        odometry: auto                     # auto | odom (slamq.sources.carmen)
        motion_model: {a1: 0.05}           # overrides of the rawlog's motion model
      intel-bag:
        bag: data/intel.orig.bag           # ROS 1 .bag, ROS 2 .db3 / .mcap or folder
        scan_topic: /scan                  # sensor_msgs/LaserScan
        odom_topic: /odom                  # nav_msgs/Odometry

Before the runs, each is written as an MRPT rawlog that keeps the log's own timestamps
(:func:`slamq.synth.writers.carmen_rawlog.write_scans_rawlog`; a CARMEN log in file
order, a bag in bag order) at ``<output>/sequences/<name>/<name>.rawlog``: the programs'
``{input}``. Beside it the sidecars that put index-timed pose logs on the log's clock:
``<name>.rawlog.steps.txt`` (one time per scan: ``icp-slam``), ``<name>.rawlog.nodes.txt``
(``graphslam-engine``'s nodes at 0.5 m / 30 deg), and every
``<name>.rawlog.nodes-<M>m.txt`` / ``<name>.rawlog.nodes-<M>m-<D>deg.txt`` that an
algorithm's ``outputs.trajectory.times`` names once its placeholders are filled (e.g.
``times: "{input}.nodes-{param.spacing}m.txt"`` with ``spacing: [0.5, 1.0]``): the times
of the nodes ``CFixedIntervalsNRD`` adds every M metres or D degrees (30 when not named).
A ``times:`` file under the sequence's folder that is none of these is refused.

Resumable: ``conversion.json`` keeps what the rawlog was written from (the log's SHA-1,
size and modification time, the options, the converter's code); a sequence whose log,
options and converter are unchanged is not converted again, only sidecars missing are
written (from ``scans.npz``, the scans' stamps and odometry).
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from slamq.errors import ParamError, SequenceError

__all__ = ["KINDS", "Recorded", "converter_digest", "node_sidecar", "parse_recorded"]

#: The keys each kind of recorded sequence may have (besides the ground-truth keys).
KINDS: dict[str, tuple[str, ...]] = {
    "carmen": ("carmen", "max_scans", "laser", "odometry", "motion_model"),
    "bag": ("bag", "max_scans", "scan_topic", "odom_topic", "motion_model"),
}
#: The registration angle of a ``.nodes-<M>m.txt`` sidecar that names none (degrees):
#: ``graphslam-engine``'s ``registration_max_angle`` in the shipped configurations.
DEFAULT_NODE_ANGLE = 30.0
_RECORD = "conversion.json"
_SCANS = "scans.npz"


@dataclass(frozen=True)
class Recorded:
    """One recorded sequence: its log, the folder it is converted into, and how.

    Attributes
    ----------
    name : str
        The sequence's name (and the rawlog's).
    kind : str
        ``"carmen"`` or ``"bag"``.
    source : pathlib.Path
        The log.
    folder : pathlib.Path
        ``<output>/sequences/<name>``.
    options : dict
        ``max_scans`` and, for a CARMEN log, ``laser``, ``odometry``; for a bag
        ``scan_topic``, ``odom_topic``; ``motion_model``.
    """

    name: str
    kind: str
    source: Path
    folder: Path
    options: dict[str, Any] = field(default_factory=dict, hash=False)

    @property
    def input(self) -> Path:
        """The rawlog the programs read (``{input}``)."""
        return self.folder / f"{self.name}.rawlog"

    def recipe(self) -> dict[str, Any]:
        """What the rawlog is made from, as ``conversion.json`` keeps it (less the log's
        digest)."""
        return {"kind": self.kind, "source": str(self.source), "options": self.options,
                "code": converter_digest()}

    def _stored(self) -> dict[str, Any] | None:
        try:
            doc = json.loads((self.folder / _RECORD).read_text())
        except (OSError, ValueError):
            return None
        return doc if isinstance(doc, dict) else None

    def complete(self) -> bool:
        """Whether the rawlog and its sidecars were written from this log (same bytes),
        these options and this converter: then it is not converted again."""
        old = self._stored()
        if old is None or old.get("recipe") != self.recipe():
            return False
        needed = (self.input, _steps(self.input), _nodes(self.input), self.folder / _SCANS)
        if not all(p.is_file() for p in needed):
            return False
        return _same_source(self.source, old.get("source_file"))

    def convert(self) -> dict[str, Any]:
        """Write the rawlog, its sidecars, ``scans.npz`` and ``conversion.json``.

        Returns
        -------
        dict
            ``scans``, ``first``, ``last`` (the first and last scan's Unix time),
            ``backwards`` (how often a scan's stamp is earlier than the one before it).

        Raises
        ------
        slamq.SequenceError
            The log cannot be read, has a malformed line, or holds no scan.
        slamq.BagError
            The bag cannot be read or lacks a topic.
        """
        import numpy as np

        from slamq.synth.writers.carmen_rawlog import write_scans_rawlog

        self.folder.mkdir(parents=True, exist_ok=True)
        (self.folder / _RECORD).unlink(missing_ok=True)  # incomplete until the end
        for old in self.folder.glob(f"{self.input.name}.nodes-*.txt"):
            old.unlink()
        stamps: list[float] = []
        odom: list[tuple[float, float, float]] = []
        o = self.options

        def tap(scans: Any) -> Any:
            for s in scans:
                stamps.append(s.stamp)
                odom.append(s.odom)
                yield s

        if self.kind == "carmen":
            from slamq.sources.carmen import CarmenLog

            log = CarmenLog(self.source)
            scans = log.scans(laser=o.get("laser", "front"),
                              odometry=o.get("odometry", "auto"),
                              max_scans=o.get("max_scans"))
        else:
            from slamq.sources.bag_scans import read_bag_scans

            scans = read_bag_scans(self.source, o.get("scan_topic", "/scan"),
                                   o.get("odom_topic", "/odom"), max_scans=o.get("max_scans"))
        info = write_scans_rawlog(tap(scans), self.input, motion_model=o.get("motion_model"))
        if not stamps:
            for p in (info["rawlog"], info["steps"], info["nodes"]):
                p.unlink(missing_ok=True)
            what = "laser scans" if self.kind == "carmen" else \
                f"scans on {o.get('scan_topic', '/scan')}"
            raise SequenceError(f"{self.source}: no {what} to convert")
        t = np.asarray(stamps, np.float64)
        tmp = self.folder / f".{_SCANS}.part.npz"
        np.savez(tmp, stamps=t, odom=np.asarray(odom, np.float64))
        os.replace(tmp, self.folder / _SCANS)
        summary = {"scans": len(stamps), "first": float(t[0]), "last": float(t[-1]),
                   "backwards": int((np.diff(t) < 0).sum())}
        doc = {"recipe": self.recipe(), "source_file": _signature(self.source, digest=True),
               **summary}
        tmp = self.folder / f".{_RECORD}.part"
        tmp.write_text(json.dumps(doc, indent=1) + "\n")
        os.replace(tmp, self.folder / _RECORD)
        return summary

    def write_nodes(self, path: Path, metres: float, degrees: float) -> Path:
        """Write a node sidecar: the times of the scans at which ``graphslam-engine`` adds
        a node every ``metres`` / ``degrees`` (:func:`slamq.synth.writers.rawlog.
        graphslam_nodes` on the scans' odometry), one per line."""
        import numpy as np

        from slamq.synth.writers.rawlog import graphslam_nodes

        with np.load(self.folder / _SCANS) as z:
            t, odom = z["stamps"], z["odom"]
        nodes = graphslam_nodes(odom, metres, math.radians(degrees))
        tmp = path.with_name(f".{path.name}.part")
        np.savetxt(tmp, t[nodes], fmt="%.6f")
        os.replace(tmp, path)
        return path

    def sidecar(self, path: Path) -> tuple[float, float] | None | bool:
        """What a ``times:`` file is to this sequence (:func:`node_sidecar`)."""
        return node_sidecar(self.input, path)

    def summary(self) -> dict[str, Any]:
        """What ``conversion.json`` says of the scans (empty before the conversion)."""
        old = self._stored() or {}
        return {k: old[k] for k in ("scans", "first", "last", "backwards") if k in old}


def _steps(rawlog: Path) -> Path:
    return rawlog.with_name(rawlog.name + ".steps.txt")


def _nodes(rawlog: Path) -> Path:
    return rawlog.with_name(rawlog.name + ".nodes.txt")


@functools.cache
def converter_digest() -> str:
    """SHA-1 of the code that turns a log into a rawlog (the CARMEN and bag readers, the
    rawlog writers): a sequence converted by other code is converted again."""
    root = Path(__file__).resolve().parents[1]
    h = hashlib.sha1(usedforsecurity=False)
    for rel in ("sources/carmen.py", "sources/bag_scans.py", "synth/writers/carmen_rawlog.py",
                "synth/writers/rawlog.py"):
        h.update(rel.encode() + b"\0" + (root / rel).read_bytes())
    return h.hexdigest()[:16]


def _files(path: Path) -> list[Path]:
    return [path] if path.is_file() else sorted(p for p in path.rglob("*") if p.is_file())


def _signature(path: Path, digest: bool) -> dict[str, Any]:
    """Size and modification time of a log's files, and their SHA-1 when ``digest``."""
    files = _files(path)
    sig: dict[str, Any] = {"size": [f.stat().st_size for f in files],
                           "mtime_ns": [f.stat().st_mtime_ns for f in files]}
    if digest:
        h = hashlib.sha1(usedforsecurity=False)
        for f in files:
            h.update(str(f.relative_to(path) if f != path else f.name).encode() + b"\0")
            with open(f, "rb") as fh:
                for chunk in iter(lambda fh=fh: fh.read(1 << 20), b""):
                    h.update(chunk)
        sig["sha1"] = h.hexdigest()
    return sig


def _same_source(path: Path, old: Any) -> bool:
    """Whether the log is the one converted: same sizes and times (no read), else the
    same SHA-1 (a copy, or a touched file)."""
    if not isinstance(old, dict):
        return False
    try:
        now = _signature(path, digest=False)
        if now["size"] == old.get("size") and now["mtime_ns"] == old.get("mtime_ns"):
            return True
        return bool(now["size"] == old.get("size")
                    and _signature(path, digest=True)["sha1"] == old.get("sha1"))
    except OSError:
        return False


_NODES = re.compile(r"\.nodes-(?P<m>\d+(?:\.\d+)?)m(?:-(?P<d>\d+(?:\.\d+)?)deg)?\.txt")


def node_sidecar(rawlog: Path, path: Path) -> tuple[float, float] | None | bool:
    """What a ``times:`` file is to a converted sequence whose rawlog is ``rawlog``:
    ``(metres, degrees)`` of a node sidecar to write, ``True`` for a sidecar the conversion
    writes anyway (``.steps.txt``, ``.nodes.txt``), ``None`` for a file elsewhere, and
    ``False`` for a file in the sequence's folder that it does not write.

    Examples
    --------
    >>> from pathlib import Path
    >>> r = Path("/o/sequences/aces/aces.rawlog")
    >>> node_sidecar(r, Path("/o/sequences/aces/aces.rawlog.nodes-1.0m.txt"))
    (1.0, 30.0)
    >>> node_sidecar(r, Path("/o/sequences/aces/aces.rawlog.nodes-0.5m-15deg.txt"))
    (0.5, 15.0)
    >>> node_sidecar(r, r.with_name("aces.rawlog.steps.txt")), node_sidecar(r, Path("/x.txt"))
    (True, None)
    >>> node_sidecar(r, r.with_name("aces.rawlog.nodes-fast.txt"))
    False
    """
    if path.parent != rawlog.parent:
        return None
    if path.name in (_steps(rawlog).name, _nodes(rawlog).name):
        return True
    if path.name.startswith(rawlog.name):
        m = _NODES.fullmatch(path.name[len(rawlog.name):])
        if m:
            return float(m["m"]), float(m["d"]) if m["d"] else DEFAULT_NODE_ANGLE
    return False


def _positive_int(value: Any, where: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise ParamError(f"{where} must be a whole number >= 1, got {value!r}")
    return value


def parse_recorded(name: str, doc: dict[str, Any], kind: str, source: Path, output: Path,
                   where: str) -> Recorded:
    """A recorded sequence from its config keys (``carmen:`` or ``bag:`` and its
    options; the caller refuses unknown keys, with the closest known name, and checks that
    ``source`` exists).

    Raises
    ------
    slamq.ParamError
        An option out of its range (the message names the key).

    Examples
    --------
    >>> from pathlib import Path
    >>> r = parse_recorded("csail", {"carmen": "c.clf", "max_scans": 300}, "carmen",
    ...                    Path("/d/c.clf"), Path("/o"), "sequences.csail")
    >>> str(r.input), r.options
    ('/o/sequences/csail/csail.rawlog', {'max_scans': 300})
    """
    options: dict[str, Any] = {}
    if doc.get("max_scans") is not None:
        options["max_scans"] = _positive_int(doc["max_scans"], f"{where}.max_scans")
    for key, choices in (("laser", ("front", "rear")), ("odometry", ("auto", "odom"))):
        if key in doc:
            if doc[key] not in choices:
                raise ParamError(f"{where}.{key} must be one of {', '.join(choices)}, "
                                 f"got {doc[key]!r}")
            options[key] = doc[key]
    for key in ("scan_topic", "odom_topic"):
        if key in doc:
            if not isinstance(doc[key], str) or not doc[key]:
                raise ParamError(f"{where}.{key} must be a topic name, got {doc[key]!r}")
            options[key] = doc[key]
    if doc.get("motion_model") is not None:
        from slamq.synth.writers.rawlog import MOTION_MODEL

        model = doc["motion_model"]
        if not isinstance(model, dict):
            raise ParamError(f"{where}.motion_model must be a mapping (keys: "
                             f"{', '.join(MOTION_MODEL)})")
        unknown = sorted(set(map(str, model)) - set(MOTION_MODEL))
        if unknown:  # (the config refuses them first, with the closest known name)
            raise ParamError(f"{where}.motion_model: unknown keys {', '.join(unknown)}; "
                             f"known: {', '.join(MOTION_MODEL)}")
        for k, v in model.items():
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) \
                    or v < 0:
                raise ParamError(f"{where}.motion_model.{k} must be a number >= 0, got {v!r}")
        options["motion_model"] = {str(k): float(v) for k, v in sorted(model.items())}
    return Recorded(name, kind, source, output / "sequences" / name, options)
