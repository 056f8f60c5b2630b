"""The page cache of ``build_report(..., reuse=True)``: ``.pages.json`` in the output
folder keeps, per detail page, a stamp of everything the page is drawn from and the
pictures it made, so that an unchanged page is not drawn again."""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path
from typing import Any

from slamq.report.markup import MapPage
from slamq.verdict.exhibits import source_digests

__all__ = ["PAGE_CACHE", "page_digest", "read_page_cache", "write_page_cache"]

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


def write_page_cache(out: Path, pages: dict[str, dict[str, Any]]) -> None:
    """Write the cache (atomically), with how many pages were drawn and reused.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp())
    >>> write_page_cache(out, {"maps/a.html": {"digest": "d", "reused": False}})
    >>> read_page_cache(out)["maps/a.html"]["digest"]
    'd'
    """
    reused = sum(1 for p in pages.values() if p["reused"])
    data = {"drawn": len(pages) - reused, "reused": reused, "pages": pages}
    tmp = out / (PAGE_CACHE + ".tmp")
    tmp.write_text(json.dumps(data, indent=1, default=str))
    os.replace(tmp, out / PAGE_CACHE)


def page_digest(mp: MapPage, *, gifs: bool, trajectories: bool) -> str:
    """Stamp of everything a detail page is drawn from (see ``reuse`` of
    :func:`slamq.report.build_report`): the record, the page's name, the options, slamq's
    version, the missing walls and the content of the files it draws
    (:func:`slamq.verdict.exhibits.source_digests`).

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
         "standing": mp.standing,
         **source_digests(rec, gifs=gifs)},
        sort_keys=True, default=str)
    return hashlib.sha256(blob.encode()).hexdigest()[:32]
