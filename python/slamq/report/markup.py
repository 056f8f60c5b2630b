"""What every page of the report shares: HTML escaping, file-name slugs, the page frame
with the report's stylesheet (``static/report.css``, shipped with the package and inlined
into each page, so the site needs no other file to look right) and :class:`MapPage`, one
map's detail page as the index links it."""

from __future__ import annotations

import html
import re
from dataclasses import dataclass, field
from functools import lru_cache
from importlib import resources
from typing import Any

__all__ = ["MapPage", "esc", "metric_title", "page", "slug", "stylesheet"]

_SLUG = re.compile(r"[^A-Za-z0-9_.-]+")


@lru_cache(maxsize=1)
def stylesheet() -> str:
    """The report's CSS (``slamq/report/static/report.css``).

    Examples
    --------
    >>> "main{" in stylesheet()
    True
    """
    return resources.files("slamq.report").joinpath("static/report.css").read_text(
        encoding="utf-8")


def esc(x: Any) -> str:
    """``x`` as HTML text or attribute value.

    Examples
    --------
    >>> esc('a<b & "c"')
    'a&lt;b &amp; &quot;c&quot;'
    """
    return html.escape(str(x), quote=True)


def slug(x: Any) -> str:
    """``x`` as a short file-name part.

    Examples
    --------
    >>> slug("slam toolbox / run 1")
    'slam-toolbox-run-1'
    """
    return _SLUG.sub("-", str(x)).strip("-")[:60] or "x"


def page(title: str, body: str, *, root: str = "") -> str:
    """A whole HTML page: ``body`` in the report's frame, with its stylesheet inlined.

    Examples
    --------
    >>> page("t", "<p>x</p>").startswith("<!DOCTYPE html>")
    True
    """
    return (
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
        "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">"
        "<link rel=\"icon\" href=\"data:,\">"
        f"<title>{esc(title)}</title><style>\n{stylesheet()}</style></head>"
        f"<body><main>{body}</main></body></html>\n"
    )


def metric_title(metric: Any) -> str:
    """The title of a metric's figure (:func:`slamq.report.plots.metric_figure`; also the
    PNG's ``Title`` and the caption under it on the page): the metric and its own
    direction.

    Examples
    --------
    >>> from slamq.verdict.ranking import METRICS
    >>> metric_title(METRICS[0])
    'ATE RMSE (m) per run — lower is better'
    """
    return f"{metric.heading} per run — {metric.direction}"


@dataclass
class MapPage:
    """One map's detail page and its pictures (paths relative to the site root)."""

    index: int
    record: dict
    slug: str
    page: str = ""
    thumb: str = ""
    full: str = ""
    gif: str = ""
    notes: list[str] = field(default_factory=list)
    defects: list[dict] = field(default_factory=list)
    #: Missing walls against the other maps of the sequence (None: the map took no part in
    #: an agreement, e.g. its sequence has ground truth).
    missing: list[dict] | None = None
    #: Where the map stands in its sequence's verdict (:func:`slamq.report.detail.standing`):
    #: sentences the detail page prints under its title (None: not known).
    standing: dict[str, str] | None = None
    #: The map's place in its sequence's agreeing group (:func:`slamq.report.detail.
    #: agreeing_group`; None: the sequence was not judged by the maps' agreement).
    group: dict[str, Any] | None = None
    #: How far the map's program's path travels against the other programs' (:func:`slamq.
    #: report.detail.path_sentence`; None: no figure).
    path: str | None = None
    #: The map's ``superposed`` flags the verdict lifts (:func:`slamq.report.detail.
    #: building_directions`): separation in degrees -> the program whose map shares it.
    building: dict[float, str] = field(default_factory=dict)

    def lifted_by(self, defect: dict) -> str | None:
        """The program whose map draws ``defect``'s second wall direction too, when the
        verdict lifts it (a ``superposed`` flag in :attr:`building`); None otherwise.

        Examples
        --------
        >>> mp = MapPage(0, {}, "a", building={31.0: "b"})
        >>> mp.lifted_by({"kind": "superposed", "separation": 31.0})
        'b'
        >>> mp.lifted_by({"kind": "superposed", "separation": 12.0}) is None
        True
        """
        sep = defect.get("separation")
        if defect.get("kind") != "superposed" or sep is None:
            return None
        return self.building.get(round(float(sep), 2))

