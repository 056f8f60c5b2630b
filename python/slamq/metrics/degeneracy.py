"""Scans that see walls in one direction only (docs/spec.md section 7c).

A scan whose straight wall stretches all face about one way (a corridor's two sides)
constrains a pose across them and not along them: a scan matcher can slide along a
corridor and every map built from such scans, and the scans themselves, agree with the
slide. :func:`scan_degeneracy` measures how many of a recording's scans are like that,
from the scans alone (no map, no trajectory); the verdict caps its confidence where the
share is high (docs/spec.md section 9).

The per-scan figure is computed in Rust (``rust/src/degeneracy.rs``, in parallel without
the GIL); :func:`scan_ratios_reference` is its numpy twin, which the tests hold it to.
"""

from __future__ import annotations

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from slamq import native
from slamq.errors import SequenceError
from slamq.metrics.sync import evenly_spread
from slamq.models.scans import ScanDegeneracy, Scans
from slamq.params import check_threads

__all__ = ["DEGENERATE_RATIO", "LINE_SPREAD", "MAX_SCANS", "MIN_LINE_POINTS", "NEIGHBOURS",
           "NEAR_M", "scan_degeneracy", "scan_ratios", "scan_ratios_reference"]

#: Beams on each side of an endpoint whose endpoints may share its wall stretch.
NEIGHBOURS = 3
#: Metres: a neighbour's endpoint farther than this from the endpoint is not on its stretch.
NEAR_M = 0.9
#: A stretch is straight when the variance across it is under this share of the variance
#: along it.
LINE_SPREAD = 0.05
#: Endpoints on straight stretches a scan needs for a figure.
MIN_LINE_POINTS = 10
#: A scan is degenerate when the smaller eigenvalue of its normals' sum n n^T is under this
#: share of the larger.
DEGENERATE_RATIO = 0.1
#: Scans scored per recording at most, evenly spread.
MAX_SCANS = 2000
_CHUNK = 256


def _eig(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The larger and smaller eigenvalues of the symmetric 2 x 2 matrices [[a, c], [c, b]]:
    ``h +- hypot((a - b) / 2, c)``, which does not cancel when the two are nearly equal."""
    half = (a + b) / 2
    disc = np.hypot((a - b) / 2, c)
    return half + disc, half - disc


def scan_ratios(scans: Scans, index: np.ndarray | None = None, *,
                threads: int | None = None) -> np.ndarray:
    """For each scan (or each of ``index``), the smaller over the larger eigenvalue of the
    sum of n n^T over its endpoints on straight wall stretches (n the stretch's unit
    normal): 0 when every stretch faces one way, 1 when they face every way equally; NaN
    with fewer than :data:`MIN_LINE_POINTS` such endpoints.

    Parameters
    ----------
    scans : Scans
    index : numpy.ndarray, optional
        The scans to score (default: all).
    threads : int, optional
        Worker threads (None: every core); the result does not depend on it.

    Returns
    -------
    numpy.ndarray
        ``(len(index),)`` float64.

    Raises
    ------
    slamq.SequenceError
        The scans' layout cannot be scored (the recording is named).

    Examples
    --------
    A laser in a corridor between walls at y = -1 and y = +1 m, and in a 4 m square room:

    >>> import numpy as np
    >>> from slamq.models.scans import Scans
    >>> a = np.linspace(-np.pi, np.pi, 360, endpoint=False)
    >>> corridor = np.minimum(1 / np.abs(np.sin(a)).clip(1e-9), 50.0)
    >>> room = np.minimum(2 / np.abs(np.cos(a)).clip(1e-9), 2 / np.abs(np.sin(a)).clip(1e-9))
    >>> s = Scans.from_layout([0.0, 0.1], -np.pi, 2 * np.pi / 360, [corridor, room], 60.0)
    >>> [round(float(v), 2) for v in scan_ratios(s)]
    [0.0, 0.98]
    """
    rows = scans.ranges if index is None else scans.ranges[np.asarray(index, dtype=np.int64)]
    n_threads = 0 if threads is None else check_threads(threads)
    try:
        return native.scan_ratios(scans.angles, np.ascontiguousarray(rows),
                                  float(scans.min_range), float(scans.max_range), n_threads)
    except ValueError as exc:
        raise SequenceError(f"{scans.source}: {exc}") from None


def scan_ratios_reference(scans: Scans, index: np.ndarray | None = None) -> np.ndarray:
    """:func:`scan_ratios` in numpy (docs/spec.md 7c, the same operations), the reference
    the Rust core is tested against; the parameters and the result are :func:`scan_ratios`'s.

    Examples
    --------
    >>> import numpy as np
    >>> from slamq.models.scans import Scans
    >>> s = Scans.from_layout([0.0], -np.pi, 2 * np.pi / 360, [np.full(360, 3.0)], 60.0)
    >>> ratio = scan_ratios_reference(s)  # a round room: walls facing every way
    >>> bool(ratio[0] > 0.9 and np.allclose(ratio, scan_ratios(s)))
    True
    """
    order = np.argsort(scans.angles, kind="stable")
    ang = scans.angles[order]
    idx = np.arange(len(scans)) if index is None else np.asarray(index, dtype=np.int64)
    out = np.full(idx.size, np.nan)
    if ang.size == 0:
        return out  # no beam, no endpoint
    w = 2 * NEIGHBOURS + 1
    cos, sin = np.cos(ang), np.sin(ang)
    for start in range(0, idx.size, _CHUNK):
        rows = idx[start:start + _CHUNK]
        r = scans.ranges[rows][:, order]
        with np.errstate(invalid="ignore"):
            ok = np.isfinite(r) & (r > scans.min_range) & (r < 0.99 * scans.max_range)
            x = np.where(ok, r * cos, np.nan)
            y = np.where(ok, r * sin, np.nan)
        pad = ((0, 0), (NEIGHBOURS, NEIGHBOURS))
        wx = sliding_window_view(np.pad(x, pad, constant_values=np.nan), w, axis=1)
        wy = sliding_window_view(np.pad(y, pad, constant_values=np.nan), w, axis=1)
        with np.errstate(invalid="ignore"):
            near = np.hypot(wx - x[..., None], wy - y[..., None]) < NEAR_M
        count = near.sum(-1)
        mx = np.where(near, wx, 0.0).sum(-1) / np.maximum(count, 1)
        my = np.where(near, wy, 0.0).sum(-1) / np.maximum(count, 1)
        dx = np.where(near, wx - mx[..., None], 0.0)
        dy = np.where(near, wy - my[..., None], 0.0)
        sxx, syy, sxy = (dx * dx).sum(-1), (dy * dy).sum(-1), (dx * dy).sum(-1)
        along, across = _eig(sxx, syy, sxy)
        line = ok & (count >= w - 1) & (across < LINE_SPREAD * np.maximum(along, 1e-12))
        normal = 0.5 * np.arctan2(2 * sxy, sxx - syy) + np.pi / 2
        nc, ns = np.cos(normal), np.sin(normal)
        jxx = np.where(line, nc * nc, 0.0).sum(1)
        jyy = np.where(line, ns * ns, 0.0).sum(1)
        jxy = np.where(line, nc * ns, 0.0).sum(1)
        big, small = _eig(jxx, jyy, jxy)
        enough = line.sum(1) >= MIN_LINE_POINTS
        out[start:start + rows.size] = np.where(enough, small / np.maximum(big, 1e-12), np.nan)
    return out


def scan_degeneracy(scans: Scans, *, max_scans: int = MAX_SCANS,
                    threads: int | None = None) -> ScanDegeneracy:
    """How many of a recording's scans see walls in one direction only.

    Parameters
    ----------
    scans : Scans
        The recording (:func:`slamq.load_scans`).
    max_scans : int, default :data:`MAX_SCANS`
        Score at most this many scans, evenly spread over the recording.
    threads : int, optional
        Worker threads (None: every core); the result does not depend on it.

    Returns
    -------
    ScanDegeneracy
        ``ratios`` per scored scan (:func:`scan_ratios`) and ``stamps`` (their times),
        ``share`` of the scans with a ratio that are under :data:`DEGENERATE_RATIO` (NaN
        when none has a ratio).

    Raises
    ------
    slamq.SequenceError
        ``max_scans`` is below 1.

    Examples
    --------
    >>> import numpy as np
    >>> from slamq.models.scans import Scans
    >>> a = np.linspace(-np.pi, np.pi, 360, endpoint=False)
    >>> corridor = np.minimum(1 / np.abs(np.sin(a)).clip(1e-9), 50.0)
    >>> room = np.minimum(2 / np.abs(np.cos(a)).clip(1e-9), 2 / np.abs(np.sin(a)).clip(1e-9))
    >>> s = Scans.from_layout(np.arange(4.0), -np.pi, 2 * np.pi / 360,
    ...                       [corridor, room, room, room], 60.0)
    >>> d = scan_degeneracy(s)
    >>> d.share, d.scored
    (0.25, 4)
    """
    if max_scans < 1:
        raise SequenceError(f"{scans.source}: max_scans must be at least 1, got {max_scans}")
    index = evenly_spread(len(scans), max_scans)
    ratios = scan_ratios(scans, index, threads=threads)
    has = np.isfinite(ratios)
    share = float((ratios[has] < DEGENERATE_RATIO).mean()) if has.any() else float("nan")
    return ScanDegeneracy(ratios=ratios, share=share, scored=int(index.size),
                          source=scans.source, stamps=scans.stamps[index].copy())
