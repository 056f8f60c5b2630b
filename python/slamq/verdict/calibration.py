"""How often the verdict without ground truth was right at each confidence level, as the
verdict says it (issue 41, item 6).

The counts are measured, not chosen: ``studies/confidence_study.py`` ran the verdict with
the ground truth hidden on every labelled set there is and counted, per level, how often
the named map was right; its table is in docs/validity.md, "Calibrated confidence"
(between the ``confidence-study`` markers). ``tests/report/test_verdict_calibration.py`` keeps
:data:`CONFIDENCE_CALIBRATION` equal to that table's "all" rows. "high" is used only when
ground truth decides (right by definition) and "none" names nothing: neither has a count.
"""

from __future__ import annotations

import math
from typing import Any

__all__ = ["CONFIDENCE_CALIBRATION", "TWO_MAPS", "calibration", "calibration_note",
           "level_of", "wilson_lower", "with_calibration"]

#: The record a verdict of two maps quotes ("low: two maps; ..."): measured apart, on
#: every labelled pair, as a choice between two maps is another question than a choice
#: among three or more.
TWO_MAPS = "low (two maps)"

#: Level -> (verdicts right, labelled verdicts) of the verdict without ground truth, over
#: every labelled set (the "all" rows of docs/validity.md, "Calibrated confidence", written
#: by studies/confidence_study.py). Regenerate the table there, then copy its counts here.
#: The generated sets are counted with each program read at the path its map is drawn at
#: (rbpf-slam's most likely particle, ``--most-likely``), as a user's program reports it.
#: Counted on 2026-12-03 with the rule as shipped (the travel veto on the corridors, the
#: halves' meeting and precision, P1d, G1) on 29 generated sets made again that day, the
#: real folders ranked by eye and the real logs (docs/validity.md, "The confidence record
#: counted again under the rule as shipped: measured"); the record before it, counted on
#: 2026-11-30 under an older rule, was 335 of 341, 89 of 91 and 788 of 846.
CONFIDENCE_CALIBRATION: dict[str, tuple[int, int]] = {
    "medium": (436, 452),
    "low": (275, 280),
    TWO_MAPS: (1278, 1357),
}


def level_of(confidence: str) -> str:
    """The level whose record a verdict's ``confidence`` quotes: its first word, or
    :data:`TWO_MAPS` for a verdict of two maps ("low: two maps; ...").

    Examples
    --------
    >>> level_of("medium: no ground truth"), level_of("low: two maps; b is wrong")
    ('medium', 'low (two maps)')
    >>> level_of("low: right in 3 of 4 labelled verdicts (...); two maps; b is wrong")
    'low (two maps)'
    """
    word, _, rest = str(confidence).partition(":")
    word = word.strip().lower()
    # "low: two maps; ...", or with the record quoted first: "low: right in ...; two maps;"
    two = rest.lstrip().startswith("two maps;") or "; two maps;" in rest
    return TWO_MAPS if word == "low" and two else word


def wilson_lower(right: int, n: int, z: float = 1.96) -> float:
    """Lower end of the Wilson score interval of ``right`` successes in ``n`` trials (95%
    by default); NaN when ``n`` is 0.

    Examples
    --------
    >>> round(wilson_lower(19, 20), 3), round(wilson_lower(100, 100), 3)
    (0.764, 0.963)
    >>> round(wilson_lower(121, 127), 2), round(wilson_lower(3, 3), 2)
    (0.9, 0.44)
    """
    if n <= 0:
        return math.nan
    p = right / n
    centre = p + z * z / (2 * n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    return (centre - half) / (1 + z * z / n)


def calibration(level: str) -> dict[str, Any] | None:
    """The measured record of a confidence level: ``{"right", "of", "share",
    "lower_bound"}`` (the share and its 95% Wilson lower bound, to two decimals), or None
    when the level has none (``"high"``, ``"none"``).

    Examples
    --------
    >>> calibration("medium")
    {'right': 436, 'of': 452, 'share': 0.96, 'lower_bound': 0.94}
    >>> calibration("high") is None
    True
    """
    if level not in CONFIDENCE_CALIBRATION:
        return None
    right, n = CONFIDENCE_CALIBRATION[level]
    return {"right": right, "of": n, "share": round(right / n, 2),
            "lower_bound": round(wilson_lower(right, n), 2)}


def calibration_note(level: str) -> str:
    """What the verdict's confidence says of its level's record ("" when it has none).

    Examples
    --------
    >>> print(calibration_note("medium"))  # doctest: +NORMALIZE_WHITESPACE
    right in 436 of 452 labelled verdicts (96%, lower bound 94% at 95% confidence,
    docs/validity.md)
    >>> calibration_note("none")
    ''
    """
    c = calibration(level)
    if c is None:
        return ""
    return (f"right in {c['right']} of {c['of']} labelled verdicts ({c['share']:.0%}, lower "
            f"bound {c['lower_bound']:.0%} at 95% confidence, docs/validity.md)")


def with_calibration(verdict: dict[str, Any]) -> dict[str, Any]:
    """A verdict without ground truth with its level's record: the note right after the
    level in ``confidence`` (``"medium: right in ...; no ground truth; ..."``) and
    ``confidence_calibration`` (:func:`calibration`: None when the level has none, or
    the verdict names nothing).

    Examples
    --------
    >>> v = with_calibration({"best": "a", "confidence": "low: two maps; b is wrong"})
    >>> print(v["confidence"])  # doctest: +NORMALIZE_WHITESPACE
    low: right in 1278 of 1357 labelled verdicts (94%, lower bound 93% at 95% confidence,
    docs/validity.md); two maps; b is wrong
    >>> v["confidence_calibration"]["lower_bound"]
    0.93
    """
    text = str(verdict.get("confidence", ""))
    level, _, rest = text.partition(":")
    key = level_of(text)
    c = calibration(key) if verdict.get("best") is not None else None
    if c is not None:
        verdict["confidence"] = f"{level}: {calibration_note(key)};{rest}"
    verdict["confidence_calibration"] = c
    return verdict
