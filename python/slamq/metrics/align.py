"""Least-squares alignment of an estimated trajectory onto the ground truth (Umeyama).

``se3`` and ``sim3`` are evo's ``-a`` and ``-as`` (same Umeyama formulas and the same
degeneracy test), ``origin`` is evo's ``--align_origin`` (first poses made equal),
``se2`` is Umeyama in the x-y plane: a rotation about z and a translation in x and y
(z is left as it is), the natural alignment for 2-D SLAM. On planar data (z = 0) se2 and
se3 give the same alignment, except when the best 3-D fit turns the estimate upside down
(a half turn about an in-plane axis, i.e. a mirrored 2-D trajectory), which se2 excludes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from slamq import native
from slamq.errors import TrajectoryError
from slamq.models.trajectory import matrix_to_quat, quat_multiply, quat_to_matrix
from slamq.params import SETTINGS

__all__ = [
    "ALIGNMENTS", "Alignment", "umeyama", "umeyama_solve", "estimate_alignment",
    "estimate_alignment_pairs",
]

#: Alignment names accepted by :func:`slamq.ate` and ``rpe``.
ALIGNMENTS = SETTINGS.ate_align.choices


@dataclass(frozen=True)
class Alignment:
    """A similarity ``p -> scale * rotation @ p + translation`` applied to the estimate.

    Examples
    --------
    >>> import numpy as np
    >>> a = Alignment("none", np.eye(3), np.zeros(3), 1.0)
    >>> a.matrix().tolist()[3]
    [0.0, 0.0, 0.0, 1.0]
    """

    kind: str
    rotation: np.ndarray
    translation: np.ndarray
    scale: float = 1.0

    def matrix(self) -> np.ndarray:
        """The 4x4 Sim(3) matrix (evo's ``alignment_transformation_sim3``)."""
        m = np.eye(4)
        m[:3, :3] = self.scale * self.rotation
        m[:3, 3] = self.translation
        return m

    @property
    def yaw(self) -> float:
        """Rotation about z, radians (exact for se2, the z-y-x yaw otherwise)."""
        return float(np.arctan2(self.rotation[1, 0], self.rotation[0, 0]))

    def apply_positions(self, p: np.ndarray) -> np.ndarray:
        """``scale * R p + t`` for positions ``(N, 3)`` (scale first, as evo does)."""
        if self.kind == "none":
            return p
        r, t, s = self.rotation, self.translation, self.scale
        out = np.empty_like(p)
        x, y, z = p[:, 0], p[:, 1], p[:, 2]
        for k in range(3):  # column by column: no BLAS threads, no (N, 3) temporaries
            col = r[k, 0] * x
            col += r[k, 1] * y
            col += r[k, 2] * z
            if s != 1.0:
                col *= s
            col += t[k]
            out[:, k] = col
        return out

    def apply_orientations(self, q: np.ndarray) -> np.ndarray:
        """Left-multiply the orientations ``(N, 4)`` (w, x, y, z) by the rotation."""
        if self.kind == "none":
            return q
        qr = matrix_to_quat(self.rotation[None])[0]
        return quat_multiply(qr, q)


def umeyama(
    x: np.ndarray, y: np.ndarray, with_scale: bool = False
) -> tuple[np.ndarray, np.ndarray, float]:
    """Rotation ``r``, translation ``t`` and scale ``c`` minimising ``|y - (c r x + t)|``.

    ``x`` and ``y`` are ``(N, m)`` point arrays (rows are points). This is evo's
    ``geometry.umeyama_alignment`` (Umeyama 1991, eqs. 34-43) with the covariance as one
    matrix product.

    Raises
    ------
    TrajectoryError
        Fewer than ``m - 1`` singular values of the covariance exceed machine epsilon
        (evo's test): the points are (nearly) coincident or collinear.

    Examples
    --------
    >>> import numpy as np
    >>> x = np.array([[0.0, 0], [1, 0], [0, 1]])
    >>> r, t, c = umeyama(x, x @ np.array([[0.0, -1], [1, 0]]).T + [2, 3])
    >>> (np.round(r, 12) + 0.0).tolist(), (np.round(t, 12) + 0.0).tolist(), c
    ([[0.0, -1.0], [1.0, 0.0]], [2.0, 3.0], 1.0)
    """
    n, m = x.shape
    mean_x = x.mean(axis=0)
    mean_y = y.mean(axis=0)
    xc = x - mean_x
    yc = y - mean_y
    sigma_x = 1.0 / n * (np.linalg.norm(xc) ** 2)
    cov_xy = np.multiply(1.0 / n, yc.T @ xc)
    return umeyama_solve(mean_x, mean_y, sigma_x, cov_xy, with_scale)


def umeyama_solve(
    mean_x: np.ndarray,
    mean_y: np.ndarray,
    sigma_x: float,
    cov_xy: np.ndarray,
    with_scale: bool = False,
) -> tuple[np.ndarray, np.ndarray, float]:
    """:func:`umeyama` from its sums: the means ``(m,)``, ``sigma_x`` (mean squared
    distance of ``x`` from its mean) and ``cov_xy`` ``(m, m)`` (mean of ``yc xc^T``).

    The sums come from :func:`umeyama` (numpy) or from the Rust core
    (``slamq._core.ate_moments``); the SVD, the degeneracy test and the rest are evo's.

    Raises
    ------
    TrajectoryError
        As :func:`umeyama`.
    """
    m = cov_xy.shape[0]
    u, d, v = np.linalg.svd(cov_xy)
    if np.count_nonzero(d > np.finfo(d.dtype).eps) < m - 1:
        raise TrajectoryError(
            "degenerate alignment: the estimated and ground-truth positions span too few "
            f"dimensions (covariance rank < {m - 1}; coincident or collinear points)"
        )
    s = np.eye(m)
    if np.linalg.det(u) * np.linalg.det(v) < 0.0:
        s[m - 1, m - 1] = -1
    r = u.dot(s).dot(v)
    c = 1 / sigma_x * np.trace(np.diag(d).dot(s)) if with_scale else 1.0
    t = mean_y - np.multiply(c, r.dot(mean_x))
    return r, t, float(c)


def _distinct_at_least(p: np.ndarray, k: int) -> bool:
    """Whether the rows of ``p`` hold at least ``k`` (1, 2 or 3) distinct points."""
    if p.shape[0] < k:
        return False
    if k <= 1:
        return True
    if p.shape[0] > 4096 and _distinct_at_least(p[:4096], k):
        return True  # almost always decided by the first poses, without a pass over all
    d0 = (p != p[0]).any(axis=1)
    if not d0.any():
        return False
    if k == 2:
        return True
    p1 = p[int(np.argmax(d0))]
    return bool((d0 & (p != p1).any(axis=1)).any())


def estimate_alignment(
    kind: str,
    gt_pos: np.ndarray,
    est_pos: np.ndarray,
    gt_quat: np.ndarray,
    est_quat: np.ndarray,
    *,
    source: str = "<array>",
) -> Alignment:
    """The alignment of kind ``se2 | se3 | sim3 | origin | none`` of associated poses.

    Parameters
    ----------
    kind : str
    gt_pos, est_pos : (N, 3) arrays
        Associated positions (row i of both is one pair).
    gt_quat, est_quat : (N, 4) arrays
        Associated orientations (w, x, y, z); only ``origin`` uses them.
    source : str
        Named in the error messages (the estimate's file).

    Raises
    ------
    TrajectoryError
        Unknown kind, or too few distinct points: ``se2`` needs 2 distinct estimated
        x-y positions, ``se3``/``sim3`` need 3 distinct positions, not all collinear.

    Examples
    --------
    >>> import numpy as np
    >>> p = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0]])
    >>> q = np.tile([1.0, 0, 0, 0], (3, 1))
    >>> a = estimate_alignment("se2", p + [5, 0, 0], p, q, q)
    >>> (np.round(a.translation, 12) + 0.0).tolist()   # + 0.0: no signed zeros
    [5.0, 0.0, 0.0]
    """
    if kind not in ALIGNMENTS:
        raise TrajectoryError(f"unknown alignment {kind!r} (one of {', '.join(ALIGNMENTS)})")
    if kind == "none":
        return Alignment("none", np.eye(3), np.zeros(3), 1.0)
    if kind == "origin":
        rg = quat_to_matrix(gt_quat[:1])[0]
        re = quat_to_matrix(est_quat[:1])[0]
        r = rg @ re.T
        t = gt_pos[0] - r @ est_pos[0]
        return Alignment("origin", r, t, 1.0)
    if kind == "se2":
        if not _distinct_at_least(est_pos[:, :2], 2):
            raise TrajectoryError(
                f"{source}: degenerate alignment: se2 needs at least 2 distinct estimated "
                f"x-y positions among the {est_pos.shape[0]} associated poses"
            )
        try:
            r2, t2, _ = umeyama(est_pos[:, :2], gt_pos[:, :2], False)
        except TrajectoryError as exc:
            raise TrajectoryError(f"{source}: {exc}") from None
        r = np.eye(3)
        r[:2, :2] = r2
        return Alignment("se2", r, np.array([t2[0], t2[1], 0.0]), 1.0)
    if not _distinct_at_least(est_pos, 3):
        raise TrajectoryError(
            f"{source}: degenerate alignment: {kind} needs at least 3 distinct estimated "
            f"positions among the {est_pos.shape[0]} associated poses"
        )
    try:
        r, t, c = umeyama(est_pos, gt_pos, kind == "sim3")
    except TrajectoryError as exc:
        raise TrajectoryError(f"{source}: {exc}") from None
    return Alignment(kind, r, t, c)


def _distinct_pairs(est_pos: np.ndarray, ei: np.ndarray, dims: int, k: int) -> bool:
    """:func:`_distinct_at_least` of ``est_pos[ei][:, :dims]``, usually from the first
    4096 pairs only (without gathering every pair's position)."""
    if ei.shape[0] > 4096 and _distinct_at_least(est_pos[ei[:4096], :dims], k):
        return True
    return _distinct_at_least(est_pos[ei][:, :dims], k)


def estimate_alignment_pairs(
    kind: str,
    gt_pos: np.ndarray,
    est_pos: np.ndarray,
    gi: np.ndarray,
    ei: np.ndarray,
    *,
    source: str = "<array>",
) -> Alignment:
    """:func:`estimate_alignment` of the associated pairs ``gt_pos[gi]``, ``est_pos[ei]``
    for ``se2 | se3 | sim3 | none``, with the Umeyama sums taken by the Rust core
    (``slamq._core.ate_moments``: no gathered copies of the positions).

    Same alignment as :func:`estimate_alignment` (the sums differ from numpy's by rounding
    only), same errors for the same inputs.

    Parameters
    ----------
    kind : str
    gt_pos, est_pos : (N, 3) C-contiguous float64 arrays
        The trajectories' positions.
    gi, ei : (n,) int64 arrays
        The associated rows (``slamq.metrics.sync.associate``), ``n >= 1``.
    source : str
        Named in the error messages (the estimate's file).

    Raises
    ------
    TrajectoryError
        As :func:`estimate_alignment` (``origin`` is not handled here).

    Examples
    --------
    >>> import numpy as np
    >>> p = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0]])
    >>> i = np.arange(3)
    >>> a = estimate_alignment_pairs("se2", p + [5, 0, 0], p, i, i)
    >>> (np.round(a.translation, 12) + 0.0).tolist()
    [5.0, 0.0, 0.0]
    """
    if kind not in ALIGNMENTS or kind == "origin":
        raise TrajectoryError(f"unknown alignment {kind!r} (one of se2, se3, sim3, none)")
    if kind == "none":
        return Alignment("none", np.eye(3), np.zeros(3), 1.0)
    dims, need = (2, 2) if kind == "se2" else (3, 3)
    if not _distinct_pairs(est_pos, ei, dims, need):
        what = "x-y positions" if kind == "se2" else "positions"
        raise TrajectoryError(
            f"{source}: degenerate alignment: {kind} needs at least {need} distinct estimated "
            f"{what} among the {ei.shape[0]} associated poses"
        )
    mean_x, mean_y, sigma_x, cov = native.ate_moments(gt_pos, est_pos, gi, ei, dims)
    try:
        r, t, c = umeyama_solve(np.array(mean_x), np.array(mean_y), sigma_x, np.array(cov),
                                kind == "sim3")
    except TrajectoryError as exc:
        raise TrajectoryError(f"{source}: {exc}") from None
    if kind == "se2":
        r3 = np.eye(3)
        r3[:2, :2] = r
        return Alignment("se2", r3, np.array([t[0], t[1], 0.0]), 1.0)
    return Alignment(kind, r, t, c)
