"""Absolute and relative trajectory error (docs/spec.md section 6), and statistics over runs.

The numbers equal evo's (``evo_ape`` / ``evo_rpe``, translation part, metres) for the
alignments evo has: association by :func:`slamq.metrics.sync.associate`, alignment by
:func:`slamq.metrics.align.estimate_alignment`, statistics as evo's ``get_statistic``
(``std`` is the population standard deviation of the per-pose errors).

:func:`ate` runs its passes over the poses in the Rust core (``rust/src/ate.rs``: the
association, the Umeyama sums, the per-pose errors and their statistics; the 3x3 SVD stays
in numpy); :func:`ate_numpy` is the same computation in numpy, its numpy twin, which it is
tested against (equal to about 1e-13: the sums are taken in another order).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from slamq import native
from slamq.errors import TrajectoryError
from slamq.metrics.align import (
    ALIGNMENTS,
    Alignment,
    estimate_alignment,
    estimate_alignment_pairs,
)
from slamq.metrics.sync import (
    MAX_GAP,
    associate,
    associate_interpolated,
    matching_indices_numpy,
)
from slamq.models.trajectory import Trajectory, quat_multiply, quat_rotate
from slamq.params import SETTINGS

__all__ = [
    "ErrorResult", "RunsResult", "ate", "ate_numpy", "rpe", "ate_runs", "find_offset",
    "STAT_NAMES", "MAX_OFFSET",
]

#: Default bound of the time-offset search (``offset="auto"``), seconds either way.
MAX_OFFSET = 1.0
#: The offset search stops refining when its grid spacing is at most this, seconds.
OFFSET_RESOLUTION = 1e-4

#: The statistics of an :class:`ErrorResult`, in output order.
STAT_NAMES = ("rmse", "mean", "median", "std", "min", "max", "sse")


@dataclass(frozen=True, eq=False)
class ErrorResult:
    """Per-pose errors of one estimate against the ground truth, and their statistics.

    Attributes
    ----------
    rmse, mean, median, std, min, max, sse : float
        Statistics of ``errors`` (metres, or degrees/radians for rotation RPE); ``std``
        is the population standard deviation (ddof=0), ``sse`` the sum of squares.
    n : int
        Number of errors (associated poses for ATE, pose pairs for RPE).
    errors : ndarray (n,)
        The per-pose (ATE) or per-pair (RPE) errors.
    timestamps : ndarray (n,)
        Estimate timestamps of the compared poses (RPE: the second pose of each pair).
    metric : str
        ``"ate"`` or ``"rpe"``.
    align : str
        The alignment used.
    alignment : Alignment
        The fitted transformation (``alignment.matrix()`` is evo's Sim(3) matrix).
    gt_source, est_source : str
        The files (or ``"<array>"``).
    params : dict
        ``max_dt``, ``offset`` and, for RPE, ``delta``, ``unit``, ``relation``.
    """

    rmse: float
    mean: float
    median: float
    std: float
    min: float
    max: float
    sse: float
    n: int
    errors: np.ndarray
    timestamps: np.ndarray
    metric: str
    align: str
    alignment: Alignment
    gt_source: str = "<array>"
    est_source: str = "<array>"
    params: dict = field(default_factory=dict)

    @property
    def scale(self) -> float:
        """The fitted scale (1 unless ``align="sim3"``)."""
        return float(self.alignment.scale)

    def stats(self) -> dict:
        """The statistics as a dict (``rmse`` ... ``sse``, ``n``)."""
        out = {k: float(getattr(self, k)) for k in STAT_NAMES}
        out["n"] = int(self.n)
        return out

    def to_dict(self, errors: bool = False) -> dict:
        """A JSON-ready dict; per-pose errors included when ``errors`` is true.

        Examples
        --------
        >>> import numpy as np
        >>> from slamq.models import Trajectory
        >>> from slamq.metrics.ate import ate
        >>> gt = Trajectory.from_xy_yaw([0, 1, 2], [0, 1, 2], [0, 0, 1])
        >>> ate(gt, gt, align="none").to_dict()["rmse"]
        0.0
        """
        d = {
            "metric": self.metric,
            "groundtruth": self.gt_source,
            "estimate": self.est_source,
            "align": self.align,
            **self.stats(),
            "scale": self.scale,
            "alignment": self.alignment.matrix().tolist(),
            **self.params,
        }
        if errors:
            d["errors"] = self.errors.tolist()
            d["timestamps"] = self.timestamps.tolist()
        return d

    def __str__(self) -> str:
        unit = "m" if self.params.get("relation", "trans") == "trans" else (
            "deg" if self.params.get("relation") == "angle_deg" else "rad")
        return (
            f"{self.metric.upper()} {self.est_source}: rmse {self.rmse:.6g} {unit} "
            f"(mean {self.mean:.6g}, median {self.median:.6g}, std {self.std:.6g}, "
            f"min {self.min:.6g}, max {self.max:.6g}, n {self.n}, align {self.align})"
        )


@dataclass(frozen=True, eq=False)
class RunsResult:
    """ATE over repeated runs of one (algorithm, sequence): the paper's "mean +- std".

    Both standard deviations are kept; the printed "mean +- std" (``str()``, ``slamq ate``
    with several estimates) uses the sample one, as ``slamq summary`` and the report do by
    default.

    Attributes
    ----------
    rmse : ndarray (runs,)
        Per-run ATE RMSE.
    mean : float
        Mean of ``rmse``.
    std : float
        Population standard deviation of ``rmse`` (``ddof=0``, numpy's default).
    std_sample : float
        Sample standard deviation (``ddof=1``, Bessel-corrected); NaN for one run.
    results : list of ErrorResult
        The per-run results.
    """

    rmse: np.ndarray
    mean: float
    std: float
    std_sample: float
    results: list

    @property
    def n_runs(self) -> int:
        """Number of runs."""
        return int(self.rmse.shape[0])

    def to_dict(self) -> dict:
        """A JSON-ready dict: per-run RMSE and the summary."""
        return {
            "runs": self.n_runs,
            "rmse": self.rmse.tolist(),
            "rmse_mean": self.mean,
            "rmse_std": self.std,
            "rmse_std_sample": None if math.isnan(self.std_sample) else self.std_sample,
            "estimates": [r.est_source for r in self.results],
        }

    def __str__(self) -> str:
        if self.n_runs == 1:
            return f"{self.mean:.3f} m (1 run)"
        return f"{self.mean:.3f} \u00b1 {self.std_sample:.3f} m ({self.n_runs} runs, sample std)"


def _as_traj(x: Trajectory, what: str) -> Trajectory:
    if isinstance(x, Trajectory):
        return x
    raise TrajectoryError(f"{what} must be a Trajectory, not {type(x).__name__} (read files "
                          "with slamq.load_trajectory; slamq.ate still takes paths)")


def _stats(errors: np.ndarray) -> dict:
    """evo's ``PE.get_statistic`` for every statistic."""
    sq = np.power(errors, 2)
    return {
        "rmse": math.sqrt(np.mean(sq)),
        "mean": float(np.mean(errors)),
        "median": float(np.median(errors)),
        "std": float(np.std(errors)),
        "min": float(np.min(errors)),
        "max": float(np.max(errors)),
        "sse": float(np.sum(sq)),
    }


def _check_align(align: str) -> None:
    if align not in ALIGNMENTS:
        raise TrajectoryError(f"unknown alignment {align!r} (one of {', '.join(ALIGNMENTS)})")


def ate(
    gt: Trajectory,
    est: Trajectory,
    *,
    align: str = SETTINGS.ate_align.default,
    max_dt: float = SETTINGS.max_dt.default,
    offset: float | str = SETTINGS.offset.default,
    interpolate: bool = False,
    max_gap: float = MAX_GAP,
    max_offset: float = MAX_OFFSET,
) -> ErrorResult:
    """Absolute trajectory error: position differences after association and alignment.

    Parameters
    ----------
    gt, est : Trajectory
        Ground truth and estimate (:func:`slamq.load_trajectory` reads them;
        :func:`slamq.ate` still takes file paths, deprecated).
    align : {"se2", "se3", "sim3", "origin", "none"}
        ``se2`` (default): rotation about z + x-y translation, for 2-D SLAM; ``se3`` and
        ``sim3``: evo's ``-a`` and ``-as``; ``origin``: first associated poses made
        equal (evo's ``--align_origin``); ``none``: as is.
    max_dt : float
        Largest time difference of associated poses, seconds (evo's ``--t_max_diff``).
    offset : float or "auto"
        Seconds added to the estimate's timestamps (evo's ``--t_offset``); ``"auto"``:
        the offset within ``max_offset`` that minimises the aligned ATE RMSE
        (:func:`find_offset`), reported as ``params["offset"]``.
    interpolate : bool
        Pair every ground-truth pose with the estimate interpolated at its time
        (:func:`slamq.metrics.sync.associate_interpolated`) instead of the nearest
        estimate pose within ``max_dt`` (docs/spec.md 6b).
    max_gap : float
        With ``interpolate``: largest time between the two estimate poses interpolated
        between, seconds.
    max_offset : float
        With ``offset="auto"``: the search's bound, seconds either way.

    Returns
    -------
    ErrorResult
        ``rmse, mean, median, std, min, max, sse, n`` and the per-pose ``errors``
        (3-D distance between aligned estimate and ground truth, metres). Equal to
        ``evo_ape tum GT EST [-a|-as|--align_origin]`` to 1e-9.

    Raises
    ------
    TrajectoryError
        No associated poses, unknown alignment, degenerate alignment (se2: fewer than 2
        distinct positions, se3/sim3: fewer than 3 or collinear).

    Examples
    --------
    >>> import numpy as np
    >>> from slamq.models import Trajectory
    >>> from slamq.metrics.ate import ate
    >>> t = np.arange(50) * 0.1
    >>> gt = Trajectory.from_xy_yaw(t, np.cos(t), np.sin(2 * t))
    >>> c, s = np.cos(0.3), np.sin(0.3)          # the estimate: gt rotated and shifted
    >>> est = Trajectory.from_xy_yaw(t, c * np.cos(t) - s * np.sin(2 * t) + 4,
    ...                              s * np.cos(t) + c * np.sin(2 * t) - 1)
    >>> round(ate(gt, est).rmse, 9), ate(gt, est, align="none").rmse > 1
    (0.0, True)
    """
    _check_align(align)
    gt = _as_traj(gt, "gt")
    est = _as_traj(est, "est")
    extra: dict = {}
    if isinstance(offset, str):
        offset, extra = _auto_offset(gt, est, offset, align, max_dt, interpolate, max_gap,
                                     max_offset)
    gi, ei, est = _pairs(gt, est, max_dt, offset, interpolate, max_gap)
    if interpolate:
        extra = {"interpolate": True, "max_gap": float(max_gap), **extra}
    r = _ate_core(gt, est, gi, ei, align, max_dt, offset)
    if extra:
        r.params.update(extra)
    return r


def _pairs(gt: Trajectory, est: Trajectory, max_dt: float, offset: float,
           interpolate: bool, max_gap: float) -> tuple[np.ndarray, np.ndarray, Trajectory]:
    """The associated pairs ``(gt_index, est_index, est)``: nearest stamps (evo's rule), or
    with ``interpolate`` the estimate interpolated at the ground-truth stamps (then ``est``
    is that interpolated trajectory)."""
    if not interpolate:
        gi, ei = associate(gt, est, max_dt=max_dt, offset=offset)
        return gi, ei, est
    gi, est_at = associate_interpolated(gt, est, offset=offset, max_gap=max_gap)
    return gi, np.arange(gi.shape[0]), est_at


def _auto_offset(gt: Trajectory, est: Trajectory, offset: str, align: str, max_dt: float,
                 interpolate: bool, max_gap: float, max_offset: float) -> tuple[float, dict]:
    if offset != "auto":
        raise TrajectoryError(f"offset must be a number of seconds or 'auto', not {offset!r}")
    found, rmse, evaluations = find_offset(gt, est, align=align, max_dt=max_dt,
                                           interpolate=interpolate, max_gap=max_gap,
                                           max_offset=max_offset)
    return found, {"offset_search": {"auto": True, "max_offset": float(max_offset),
                                     "resolution": OFFSET_RESOLUTION,
                                     "criterion_rmse": rmse, "evaluations": evaluations}}


def find_offset(
    gt: Trajectory,
    est: Trajectory,
    *,
    align: str = SETTINGS.ate_align.default,
    max_dt: float = SETTINGS.max_dt.default,
    interpolate: bool = False,
    max_gap: float = MAX_GAP,
    max_offset: float = MAX_OFFSET,
) -> tuple[float, float, int]:
    """The time offset (seconds added to the estimate's stamps) minimising the ATE RMSE.

    The criterion is the ATE RMSE after alignment ``align`` (``none`` and ``origin``
    are replaced by ``se2``: an offset search without a fitted alignment would trade time
    for position). The search is bounded to ``[-max_offset, max_offset]`` and coarse to
    fine: 41 offsets evenly spaced over the bounds, then 21 offsets spaced a tenth as wide
    around the best so far, repeated until the spacing is at most ``OFFSET_RESOLUTION``
    (0.1 ms). Offsets that associate fewer than half the poses of the best-covered coarse
    offset are not candidates (a sliver of overlap fits trivially well); ties go to the
    offset nearer 0. Without ``interpolate`` the RMSE is a step function of the offset
    (poses pair or not within ``max_dt``), so the search is meant for ``interpolate=True``.

    Returns
    -------
    offset, rmse, evaluations : float, float, int
        The offset found, its criterion RMSE, and how many ATEs the search computed.

    Raises
    ------
    TrajectoryError
        ``max_offset`` not a finite number >= 0, or no offset within the bounds
        associates any pose.

    Examples
    --------
    >>> import numpy as np
    >>> from slamq.models import Trajectory
    >>> t = np.arange(0.0, 20.0, 0.1)
    >>> gt = Trajectory.from_xy_yaw(t, np.cos(t), np.sin(0.5 * t))
    >>> est = Trajectory.from_xy_yaw(t - 0.237, np.cos(t), np.sin(0.5 * t))  # its clock lags
    >>> off, rmse, _ = find_offset(gt, est, interpolate=True)
    >>> round(off, 3), rmse < 1e-3
    (0.237, True)
    """
    if not (math.isfinite(max_offset) and max_offset >= 0):
        raise TrajectoryError(f"max_offset must be a finite number >= 0, not {max_offset!r}")
    crit = align if align in ("se2", "se3", "sim3") else "se2"
    seen: dict[float, tuple[float, int]] = {}

    def score(off: float) -> tuple[float, int]:
        if off not in seen:
            try:
                gi, ei, e = _pairs(gt, est, max_dt, off, interpolate, max_gap)
                seen[off] = (_ate_core(gt, e, gi, ei, crit, max_dt, off).rmse, int(gi.shape[0]))
            except TrajectoryError:
                seen[off] = (math.inf, 0)
        return seen[off]

    coarse = np.linspace(-max_offset, max_offset, 41) if max_offset > 0 else np.zeros(1)
    counts = [score(float(o))[1] for o in coarse]
    need = 0.5 * max(counts)
    if max(counts) == 0:
        raise TrajectoryError(
            f"{est.source}: no offset within +-{max_offset} s associates a pose of "
            f"{gt.source}; widen max_offset")

    def best(offsets: np.ndarray) -> float:
        cands = [(score(float(o))[0], abs(float(o)), float(o)) for o in offsets
                 if score(float(o))[1] >= need]
        return min(cands)[2] if cands else math.nan

    found = best(coarse)
    spacing = (coarse[1] - coarse[0]) if coarse.shape[0] > 1 else 0.0
    while spacing > OFFSET_RESOLUTION and math.isfinite(found):
        spacing /= 10.0
        grid = np.clip(found + spacing * np.arange(-10, 11), -max_offset, max_offset)
        found = best(np.concatenate([grid, [found]]))
    if not math.isfinite(found):
        raise TrajectoryError(f"{est.source}: no offset within +-{max_offset} s gives an ATE "
                              f"against {gt.source}")
    return found, float(seen[found][0]), len(seen)


def _ate_core(gt: Trajectory, est: Trajectory, gi: np.ndarray, ei: np.ndarray, align: str,
              max_dt: float, offset: float) -> ErrorResult:
    """The alignment, errors and statistics of associated pairs (the Rust passes)."""
    if align == "origin":
        a = estimate_alignment(align, gt.positions[gi[:1]], est.positions[ei[:1]],
                               gt.orientations[gi[:1]], est.orientations[ei[:1]],
                               source=est.source)
    else:
        a = estimate_alignment_pairs(align, gt.positions, est.positions, gi, ei,
                                     source=est.source)
    # the per-pose errors and their statistics in one pass of the Rust core, without
    # gathered copies of the positions (its numpy twin: ate_numpy)
    rotation = None if a.kind == "none" else a.rotation.tolist()
    errors, (total, sse, ssd, lo, hi, median) = native.ate_errors(
        gt.positions, est.positions, gi, ei, rotation, a.translation.tolist(),
        float(a.scale))
    n = int(errors.shape[0])
    stats = {
        "rmse": math.sqrt(sse / n),
        "mean": total / n,
        "median": median,
        "std": math.sqrt(ssd / n),
        "min": lo,
        "max": hi,
        "sse": sse,
    }
    return _ate_result(stats, errors, est.timestamps[ei], align, a, gt, est, max_dt, offset)


def _ate_result(
    stats: dict,
    errors: np.ndarray,
    timestamps: np.ndarray,
    align: str,
    a: Alignment,
    gt: Trajectory,
    est: Trajectory,
    max_dt: float,
    offset: float,
) -> ErrorResult:
    return ErrorResult(
        **stats,
        n=int(errors.shape[0]),
        errors=errors,
        timestamps=timestamps,
        metric="ate",
        align=align,
        alignment=a,
        gt_source=gt.source,
        est_source=est.source,
        params={"max_dt": float(max_dt), "offset": float(offset)},
    )


def ate_numpy(
    gt: Trajectory,
    est: Trajectory,
    *,
    align: str = SETTINGS.ate_align.default,
    max_dt: float = SETTINGS.max_dt.default,
    offset: float = SETTINGS.offset.default,
) -> ErrorResult:
    """:func:`ate` in numpy (association, Umeyama, errors, statistics): the numpy twin the
    Rust passes of :func:`ate` are tested against. Same arguments (but a numeric
    ``offset`` and no interpolation), result and errors.

    Examples
    --------
    >>> import numpy as np
    >>> from slamq.models import Trajectory
    >>> t = np.arange(20.0)
    >>> gt = Trajectory.from_xy_yaw(t, t, np.sin(t))
    >>> est = Trajectory.from_xy_yaw(t, t + 1, np.sin(t))
    >>> ate_numpy(gt, est, align="none").rmse == ate(gt, est, align="none").rmse == 1.0
    True
    """
    _check_align(align)
    gt = _as_traj(gt, "gt")
    est = _as_traj(est, "est")
    gi, ei = associate(gt, est, max_dt=max_dt, offset=offset, matcher=matching_indices_numpy)
    gp = gt.positions[gi]
    ep = est.positions[ei]
    if align == "origin":
        a = estimate_alignment(align, gp[:1], ep[:1], gt.orientations[gi[:1]],
                               est.orientations[ei[:1]], source=est.source)
    else:
        a = estimate_alignment(align, gp, ep, gp, ep, source=est.source)
    ep = a.apply_positions(ep)
    diff = ep - gp
    errors = np.sqrt(np.einsum("ij,ij->i", diff, diff))
    return _ate_result(_stats(errors), errors, est.timestamps[ei], align, a, gt, est,
                       max_dt, offset)


def _pairs_by_frames(n: int, delta: int) -> tuple[np.ndarray, np.ndarray]:
    ids = np.arange(0, n, delta)
    return ids[:-1], ids[1:]


def _pairs_by_path(p: np.ndarray, delta: float) -> tuple[np.ndarray, np.ndarray]:
    """evo's consecutive ``filter_pairs_by_path``: a new id whenever the path travelled
    since the last id (summed step by step from 0) reaches ``delta``."""
    ids = [0]
    travelled = 0.0
    # one sequential float sum, as evo's loop (a plain loop: ~0.3 s per million poses)
    for k, step in enumerate(np.linalg.norm(np.diff(p, axis=0), axis=1).tolist(), 1):
        travelled += step
        if travelled >= delta:
            ids.append(k)
            travelled = 0.0
    arr = np.asarray(ids)
    return arr[:-1], arr[1:]


def rpe(
    gt: Trajectory,
    est: Trajectory,
    *,
    delta: float = 1,
    unit: str = "frames",
    relation: str = "trans",
    align: str = SETTINGS.rpe_align.default,
    max_dt: float = SETTINGS.max_dt.default,
    offset: float | str = SETTINGS.offset.default,
    pairs_from: str = "est",
    interpolate: bool = False,
    max_gap: float = MAX_GAP,
    max_offset: float = MAX_OFFSET,
) -> ErrorResult:
    """Relative pose error between pose pairs ``delta`` apart (evo's ``evo_rpe``).

    Parameters
    ----------
    gt, est : Trajectory
    delta : float
        Distance between the poses of a pair: frames (an integer >= 1) or metres of
        travelled path.
    unit : {"frames", "m"}
        ``frames``: pairs ``(0, d), (d, 2d), ...`` of associated poses; ``m``: a new
        pair ends when the path travelled since the previous end reaches ``delta``
        (evo's consecutive pairs).
    relation : {"trans", "angle_deg", "angle_rad"}
        Norm of the translation of the relative error pose (metres, evo's default), or
        its rotation angle.
    align : {"none", "se2", "se3", "sim3", "origin"}
        Applied before the RPE (rigid alignments do not change it; ``sim3`` scales).
    max_dt, offset : float
        Association, as in :func:`ate`.
    pairs_from : {"est", "gt"}
        Whose path length chooses the pairs for ``unit="m"`` (evo: the estimate, or the
        reference with ``--pairs_from_reference``).
    interpolate, max_gap, max_offset
        As in :func:`ate`; ``offset="auto"`` searches the offset by the ATE RMSE
        (:func:`find_offset`), then computes the RPE with it.

    Returns
    -------
    ErrorResult
        One error per pair; equal to ``evo_rpe`` to 1e-9.

    Examples
    --------
    >>> import numpy as np
    >>> from slamq.models import Trajectory
    >>> from slamq.metrics.ate import rpe
    >>> t = np.arange(10.0)
    >>> gt = Trajectory.from_xy_yaw(t, t, 0 * t)
    >>> est = Trajectory.from_xy_yaw(t, 1.1 * t, 0 * t)   # 10 % too long steps
    >>> r = rpe(gt, est, delta=2)
    >>> r.n, round(r.rmse, 12)
    (4, 0.2)
    """
    _check_align(align)
    if unit not in ("frames", "m"):
        raise TrajectoryError(f"unit must be 'frames' or 'm', not {unit!r}")
    if relation not in ("trans", "angle_deg", "angle_rad"):
        raise TrajectoryError(
            f"relation must be 'trans', 'angle_deg' or 'angle_rad', not {relation!r}"
        )
    if pairs_from not in ("est", "gt"):
        raise TrajectoryError(f"pairs_from must be 'est' or 'gt', not {pairs_from!r}")
    if unit == "frames":
        if not math.isfinite(delta) or float(delta) != int(delta) or int(delta) < 1:
            raise TrajectoryError(f"delta must be an integer >= 1 for unit 'frames', not {delta}")
        delta = int(delta)
    elif not (math.isfinite(delta) and delta > 0):
        raise TrajectoryError(f"delta must be a number > 0 for unit 'm', not {delta}")
    gt = _as_traj(gt, "gt")
    est = _as_traj(est, "est")
    if relation != "trans":
        for name, tr in (("gt", gt), ("est", est)):
            if tr.meta.get("orientation") is False:
                raise TrajectoryError(
                    f"{tr.source}: has no orientation column, so the {relation} error of "
                    f"{name} would be zero by construction; use relation='trans'")
    extra: dict = {}
    if isinstance(offset, str):
        offset, extra = _auto_offset(gt, est, offset, "se2", max_dt, interpolate, max_gap,
                                     max_offset)
    if interpolate:
        extra = {"interpolate": True, "max_gap": float(max_gap), **extra}
    gi, ei, est = _pairs(gt, est, max_dt, offset, interpolate, max_gap)
    gp, gq = gt.positions[gi], gt.orientations[gi]
    ep, eq = est.positions[ei], est.orientations[ei]
    if align == "origin":
        a = estimate_alignment(align, gp[:1], ep[:1], gq[:1], eq[:1], source=est.source)
    else:
        a = estimate_alignment(align, gp, ep, gq, eq, source=est.source)
    ep = a.apply_positions(ep)
    eq = a.apply_orientations(eq)
    if unit == "frames":
        i, j = _pairs_by_frames(gp.shape[0], delta)
    else:
        i, j = _pairs_by_path(ep if pairs_from == "est" else gp, float(delta))
    if i.shape[0] == 0:
        raise TrajectoryError(
            f"{est.source}: delta = {delta} ({unit}) leaves no pose pair among the "
            f"{gp.shape[0]} associated poses; try a smaller delta"
        )
    conj = np.array([1.0, -1.0, -1.0, -1.0])
    if relation == "trans":
        # |t(E)| with E = (Q_i^-1 Q_j)^-1 (P_i^-1 P_j) is |R_Pi^T dP - R_Qi^T dQ|
        tq = quat_rotate(gq[i] * conj, gp[j] - gp[i])
        tp = quat_rotate(eq[i] * conj, ep[j] - ep[i])
        d = tp - tq
        errors = np.sqrt(np.einsum("ij,ij->i", d, d))
    else:
        rq = quat_multiply(gq[i] * conj, gq[j])
        rp = quat_multiply(eq[i] * conj, eq[j])
        e = quat_multiply(rq * conj, rp)
        errors = 2.0 * np.arctan2(np.linalg.norm(e[:, 1:], axis=1), np.abs(e[:, 0]))
        if relation == "angle_deg":
            errors = np.rad2deg(errors)
    return ErrorResult(
        **_stats(errors),
        n=int(errors.shape[0]),
        errors=errors,
        timestamps=est.timestamps[ei][j],
        metric="rpe",
        align=align,
        alignment=a,
        gt_source=gt.source,
        est_source=est.source,
        params={"max_dt": float(max_dt), "offset": float(offset), "delta": delta,
                "unit": unit, "relation": relation, **extra},
    )


def ate_runs(
    gt: Trajectory,
    ests: Sequence[Trajectory],
    *,
    align: str = SETTINGS.ate_align.default,
    max_dt: float = SETTINGS.max_dt.default,
    offset: float = SETTINGS.offset.default,
) -> RunsResult:
    """ATE of repeated runs against one ground truth: per-run RMSE, mean and std.

    ``std`` is the population standard deviation of the per-run RMSE (``ddof=0``),
    ``std_sample`` the sample standard deviation (``ddof=1``, NaN for a single run; the
    one ``str(result)``, ``slamq ate`` and ``slamq summary`` print). The paper's Table I
    reports "mean +- std" of the per-run RMSE without saying which.

    Examples
    --------
    >>> import numpy as np
    >>> from slamq.models import Trajectory
    >>> from slamq.metrics.ate import ate_runs
    >>> t = np.arange(20.0)
    >>> gt = Trajectory.from_xy_yaw(t, t, np.sin(t))
    >>> ests = [Trajectory.from_xy_yaw(t, t, np.sin(t) + e) for e in (0.1, 0.3)]
    >>> r = ate_runs(gt, ests, align="none")
    >>> np.round(r.rmse, 12).tolist(), round(r.mean, 12), round(r.std, 12)
    ([0.1, 0.3], 0.2, 0.1)
    """
    if len(ests) == 0:
        raise TrajectoryError("ate_runs needs at least one estimate")
    gt = _as_traj(gt, "gt")
    results = [ate(gt, e, align=align, max_dt=max_dt, offset=offset) for e in ests]
    rmse = np.array([r.rmse for r in results])
    std_sample = float(np.std(rmse, ddof=1)) if rmse.shape[0] > 1 else float("nan")
    return RunsResult(
        rmse=rmse,
        mean=float(np.mean(rmse)),
        std=float(np.std(rmse)),
        std_sample=std_sample,
        results=results,
    )

