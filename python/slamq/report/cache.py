"""The page cache of ``build_report(..., reuse=True)``: ``.pages.json`` in the output
folder keeps, per detail page, a stamp of everything the page is drawn from and the
pictures it made, and per figure of the index a stamp of its inputs, so that an unchanged
page or figure is not drawn again."""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path
from typing import Any

from slamq.report.markup import MapPage
from slamq.verdict.exhibits import source_digests

__all__ = ["PAGE_CACHE", "figure_digest", "page_digest", "read_figure_cache", "read_page_cache",
           "write_page_cache"]

PAGE_CACHE = ".pages.json"


def read_page_cache(out: Path) -> dict[str, dict[str, Any]]:
    """The pages kept in ``out``'s cache (empty when there is none or it is unreadable).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> read_page_cache(pathlib.Path(tempfile.mkdtemp()))
    {}
    """
    try:
        data = json.loads((out / PAGE_CACHE).read_text())
        pages = data["pages"]
    except (OSError, ValueError, KeyError, TypeError):
        return {}
    return pages if isinstance(pages, dict) else {}


def read_figure_cache(out: Path) -> dict[str, str]:
    """The index figures kept in ``out``'s cache: ``{PNG path: stamp}``.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> read_figure_cache(pathlib.Path(tempfile.mkdtemp()))
    {}
    """
    try:
        figures = json.loads((out / PAGE_CACHE).read_text())["figures"]
    except (OSError, ValueError, KeyError, TypeError):
        return {}
    return figures if isinstance(figures, dict) else {}


def write_page_cache(out: Path, pages: dict[str, dict[str, Any]],
                     figures: dict[str, str] | None = None) -> None:
    """Write the cache (atomically), with how many pages were drawn and reused, and the
    stamps of the index's figures.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp())
    >>> write_page_cache(out, {"maps/a.html": {"digest": "d", "reused": False}})
    >>> read_page_cache(out)["maps/a.html"]["digest"]
    'd'
    """
    reused = sum(1 for p in pages.values() if p["reused"])
    data = {"drawn": len(pages) - reused, "reused": reused, "pages": pages,
            "figures": figures or {}}
    tmp = out / (PAGE_CACHE + ".tmp")
    tmp.write_text(json.dumps(data, indent=1, default=str))
    os.replace(tmp, out / PAGE_CACHE)


def page_digest(mp: MapPage, *, gifs: bool, trajectories: bool) -> str:
    """Stamp of everything a detail page is drawn from (see ``reuse`` of
    :func:`slamq.report.build_report`): the record, the page's name, the options, slamq's
    version, the missing walls, the map's standing and agreeing group and the content of
    the files it draws (:func:`slamq.verdict.exhibits.source_digests`).

    Examples
    --------
    >>> mp = MapPage(0, {"map": None, "run": 0}, "a", page="maps/a.html")
    >>> len(page_digest(mp, gifs=False, trajectories=False))
    32
    """
    from slamq.version import __version__

    rec = mp.record
    blob = json.dumps(
        {"record": rec, "slug": mp.slug, "page": mp.page, "gifs": gifs,
         "trajectories": trajectories, "version": __version__, "missing": mp.missing,
         "standing": mp.standing, "group": mp.group, "path": mp.path,
         "building": mp.building,
         **source_digests(rec, gifs=gifs)},
        sort_keys=True, default=str)
    return hashlib.sha256(blob.encode()).hexdigest()[:32]


def figure_digest(ok: Any, metric: Any, sequences: list[str], colours: dict[str, str]) -> str:
    """Stamp of everything an index figure of ``metric`` is drawn from: each run's sequence,
    algorithm and value, the panel order, the colours, the metric's description and
    slamq's version.

    Examples
    --------
    >>> import pandas as pd
    >>> from slamq.verdict.ranking import METRICS
    >>> ok = pd.DataFrame({"sequence": "s", "algorithm": ["a", "b"], "corners": [3, 5]})
    >>> a = figure_digest(ok, METRICS[2], ["s"], {"a": "#1f77b4"})
    >>> a == figure_digest(ok.assign(corners=[3, 6]), METRICS[2], ["s"], {"a": "#1f77b4"})
    False
    """
    import pandas as pd

    from slamq.version import __version__

    cols = [c for c in ("sequence", "algorithm", metric.key) if c in ok.columns]
    part = ok[cols].astype(str)
    h = hashlib.sha256(pd.util.hash_pandas_object(part, index=False).to_numpy().tobytes())
    h.update(json.dumps([repr(metric), sequences, colours, __version__], default=str).encode())
    return h.hexdigest()[:32]
