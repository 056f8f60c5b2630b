"""What a rerun of ``slamq run`` may skip: stamps of the inputs of each scoring stage.

After the runs, :func:`slamq.runner.scoring.score` scores the maps, draws each run's
``building.gif`` and writes the report. Each of these keeps, in
``OUTPUT/.slamq-cache.json``, a stamp of the inputs it was made from; a rerun redoes a piece
of work only when its stamp differs (or its output is gone):

- a run's scores: the content of its map (YAML and image), trajectory, ground-truth
  trajectory and ground-truth map, its place in the results (algorithm, sequence,
  iteration, paths), the ``evaluate`` settings and slamq's version;
- a run's ``building.gif``: the names and content of its snapshots, the frame size and
  slamq's version;
- the report: the bytes of ``results.jsonl`` and ``scores.csv``, every run's score and
  snapshot stamps, the title and slamq's version (and that ``report/index.html`` is the
  file written then).

Every stage appends one line to ``OUTPUT/stages.jsonl`` saying what it did, what it skipped
and why (``{"stage": "score", "done": 1, "skipped": 8, "why": {...}}``), and the same
sentence is printed by ``slamq run``.
"""

from __future__ import annotations

import hashlib
import json
import os
import time
from pathlib import Path
from typing import Any

__all__ = ["CACHE_NAME", "LOG_NAME", "Stamps", "changes", "file_digest", "log_stage",
           "map_digest", "snapshots_digest", "stamp"]

#: The stamps file, in the output folder.
CACHE_NAME = ".slamq-cache.json"
#: One JSON line per stage and invocation: what was done, what skipped, why.
LOG_NAME = "stages.jsonl"


def stamp(obj: Any) -> str:
    """SHA-256 (hex, 32 characters) of an object's canonical JSON.

    Examples
    --------
    >>> stamp({"b": 1, "a": [2]}) == stamp({"a": [2], "b": 1})
    True
    """
    blob = json.dumps(obj, sort_keys=True, default=str, separators=(",", ":")).encode()
    return hashlib.sha256(blob).hexdigest()[:32]


def file_digest(path: Any) -> str | None:
    """SHA-1 of a regular file's bytes, ``None`` for no path or a file that cannot be read.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "t.txt"; _ = p.write_text("x")
    >>> file_digest(p)
    '11f6ad8ec52a2984abaafd7c3b516503785c2072'
    >>> file_digest(None) is None, file_digest(p.parent / "missing") is None
    (True, True)
    """
    if path is None:
        return None
    h = hashlib.sha1(usedforsecurity=False)
    try:
        with open(path, "rb") as f:
            for chunk in iter(lambda: f.read(1 << 20), b""):
                h.update(chunk)
    except OSError:
        return None
    return h.hexdigest()


def map_digest(path: Any) -> str | None:
    """The batch engine's content hash of a map (YAML and image), ``None`` when unreadable.

    Examples
    --------
    >>> map_digest("no/such/map.yaml") is None
    True
    """
    if path is None:
        return None
    from slamq.batch.records import content_hash
    from slamq.errors import SlamqError

    try:
        return content_hash(path)
    except (OSError, SlamqError):
        return None


def snapshots_digest(folder: Path) -> str | None:
    """Stamp of a run folder's snapshots (names and content), ``None`` without snapshots.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> snapshots_digest(pathlib.Path(tempfile.mkdtemp())) is None
    True
    """
    from slamq.sources.snapshots import find_snapshots

    snaps = find_snapshots(Path(folder))
    if not snaps:
        return None
    return stamp([[p.name, map_digest(p)] for p in snaps])


def changes(old: dict[str, Any] | None, new: dict[str, Any]) -> list[str]:
    """The names of the inputs that differ between two stamps (``["new"]`` without an old
    one; ``[]`` when they are equal).

    Examples
    --------
    >>> changes({"map": "a", "version": "1"}, {"map": "b", "version": "1"})
    ['map']
    >>> changes(None, {"map": "a"})
    ['new']
    """
    if not isinstance(old, dict):
        return ["new"]
    return sorted(k for k in set(old) | set(new) if old.get(k) != new.get(k))


class Stamps:
    """The stamps of an output folder (``OUTPUT/.slamq-cache.json``), per stage and item.

    A missing or unreadable file is an empty cache (everything is redone). :meth:`save`
    writes the file atomically.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> s = Stamps(d); s.put("gif", "run/1", {"snapshots": "ab"}); s.save()
    >>> Stamps(d).get("gif", "run/1")
    {'snapshots': 'ab'}
    """

    def __init__(self, output: Path) -> None:
        self.path = Path(output) / CACHE_NAME
        try:
            data = json.loads(self.path.read_text())
        except (OSError, ValueError):
            data = {}
        self.data: dict[str, dict[str, Any]] = data if isinstance(data, dict) else {}

    def get(self, stage: str, item: str) -> Any:
        """The stamp stored for ``item`` of ``stage``, or None."""
        table = self.data.get(stage)
        return table.get(item) if isinstance(table, dict) else None

    def put(self, stage: str, item: str, value: Any) -> None:
        """Set a stamp (kept in memory until :meth:`save`)."""
        table = self.data.get(stage)
        if not isinstance(table, dict):
            table = self.data[stage] = {}
        table[item] = value

    def drop(self, stage: str, item: str) -> None:
        """Forget a stamp (its work is redone next time)."""
        table = self.data.get(stage)
        if isinstance(table, dict):
            table.pop(item, None)

    def save(self) -> None:
        """Write the stamps atomically."""
        self.path.parent.mkdir(parents=True, exist_ok=True)
        tmp = self.path.with_name(self.path.name + ".tmp")
        tmp.write_text(json.dumps(self.data, indent=1, sort_keys=True, default=str))
        os.replace(tmp, self.path)


def log_stage(output: Path, stage: str, done: int, skipped: int, message: str,
              **extra: Any) -> dict[str, Any]:
    """Append one stage's line to ``OUTPUT/stages.jsonl`` and return it.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> log_stage(d, "gifs", 0, 2, "GIFs: 2 skipped")["skipped"]
    2
    >>> len((d / "stages.jsonl").read_text().splitlines())
    1
    """
    line = {"at": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "stage": stage, "done": done,
            "skipped": skipped, "message": message, **extra}
    with open(Path(output) / LOG_NAME, "a", encoding="utf-8") as f:
        f.write(json.dumps(line, default=str) + "\n")
    return line
