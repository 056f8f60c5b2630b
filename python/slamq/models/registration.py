"""``Registration``: one map registered onto another map of the same place (SPEC section
7a), built from what the Rust core returns."""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np

__all__ = ["Registration"]


@dataclass(frozen=True)
class Registration:
    """The rigid motion taking one map's world frame onto another's, and how far to trust
    it (docs/spec.md section 7a).

    A point ``p`` (metres, in the moving map's world frame: the frame its YAML origin is
    given in) is ``R(theta) p + (tx, ty)`` in the fixed map's world frame.

    Attributes
    ----------
    moving, fixed : str
        Where the two maps came from (or their names in :func:`slamq.register_many`).
    ok : bool
        The transform is to be trusted; when False, ``reason`` says why (the transform is
        still the best candidate found, or the identity when none was).
    reason : str
        Empty when ``ok``.
    theta : float
        Rotation, radians in (-pi, pi].
    tx, ty : float
        Translation, metres.
    inliers : float
        Consistency where the maps overlap, in [0, 1]: of the moving map's walls that land
        on the fixed map's known cells (or near its walls), the share within ``tolerance``
        of a fixed wall (``inliers_moving``); the same the other way round
        (``inliers_fixed``); ``inliers`` is the smaller of the two.
    inliers_moving, inliers_fixed : float
    overlap : float
        The larger of ``overlap_moving`` (share of the moving walls landing on the fixed
        map's known cells) and ``overlap_fixed`` (the other way round).
    overlap_moving, overlap_fixed : float
    score, runner_up_score : float
        At the best candidate and at the best one that places the map elsewhere (NaN:
        none), each after a short ICP, on subsamples: the share of the moving walls within
        ``tolerance`` of a fixed wall times the consistency of the fixed walls landing on
        the moving map (docs/spec.md 7a).
    runner_up : tuple of float or None
        That runner-up's ``(theta, tx, ty)``.
    margin : float
        ``1 - runner_up_score / score`` (1 without a distinct runner-up): near 0 for an
        ambiguous (symmetric, repetitive) place.
    confidence : float
        In [0, 1]: ``inliers * min(1, margin / 0.5)`` when ``ok``, 0 when refused.
    icp_rms : float
        The final ICP's inlier RMS, metres.
    icp_iterations, rotations, candidates : int
        Final ICP iterations; rotations tried; candidates refined.
    tolerance : float
        The matching distance of the inlier count, metres.

    Examples
    --------
    >>> import numpy as np, slamq
    >>> img = np.full((80, 100), 254, np.uint8)
    >>> img[10, 10:90] = img[70, 10:90] = img[10:71, 10] = img[10:71, 90] = 0
    >>> img[10:40, 50] = img[40, 30:51] = 0                       # an inner corner
    >>> r = slamq.register(np.rot90(img), img)
    >>> r.ok, round(abs(np.degrees(r.theta))), r.inliers > 0.9
    (True, 90, True)
    """

    moving: str
    fixed: str
    ok: bool
    reason: str
    theta: float
    tx: float
    ty: float
    inliers: float
    inliers_moving: float
    inliers_fixed: float
    overlap: float
    overlap_moving: float
    overlap_fixed: float
    score: float
    runner_up_score: float
    runner_up: tuple[float, float, float] | None
    margin: float
    confidence: float
    icp_rms: float
    icp_iterations: int
    rotations: int
    candidates: int
    tolerance: float

    @classmethod
    def from_raw(cls, raw: Any, *, moving: str, fixed: str) -> Registration:
        """The model of a ``slamq._core.RawRegistration``."""
        ru = raw.runner_up
        return cls(
            moving=moving, fixed=fixed, ok=bool(raw.ok), reason=str(raw.reason),
            theta=float(raw.theta), tx=float(raw.tx), ty=float(raw.ty),
            inliers=float(raw.inliers), inliers_moving=float(raw.inliers_moving),
            inliers_fixed=float(raw.inliers_fixed), overlap=float(raw.overlap),
            overlap_moving=float(raw.overlap_moving), overlap_fixed=float(raw.overlap_fixed),
            score=float(raw.score), runner_up_score=float(raw.runner_up_score),
            runner_up=None if ru is None else (float(ru[0]), float(ru[1]), float(ru[2])),
            margin=float(raw.margin), confidence=float(raw.confidence),
            icp_rms=float(raw.icp_rms), icp_iterations=int(raw.icp_iterations),
            rotations=int(raw.rotations), candidates=int(raw.candidates),
            tolerance=float(raw.tolerance),
        )

    @property
    def transform(self) -> tuple[float, float, float]:
        """``(theta, tx, ty)``: radians, metres, metres."""
        return (self.theta, self.tx, self.ty)

    def matrix(self) -> np.ndarray:
        """The transform as a 3x3 homogeneous matrix (moving world -> fixed world).

        Examples
        --------
        >>> import numpy as np, slamq
        >>> img = np.full((60, 60), 254, np.uint8)
        >>> img[10, 10:50] = img[50, 10:50] = img[10:51, 10] = img[10:30, 50] = 0
        >>> slamq.register(img, img).matrix().round(6).tolist()[2]
        [0.0, 0.0, 1.0]
        """
        c, s = math.cos(self.theta), math.sin(self.theta)
        return np.array([[c, -s, self.tx], [s, c, self.ty], [0.0, 0.0, 1.0]])

    def apply(self, points: Any) -> np.ndarray:
        """Points ``(n, 2)`` (metres, moving world) in the fixed map's world frame.

        Examples
        --------
        >>> import numpy as np, slamq
        >>> img = np.full((60, 60), 254, np.uint8)
        >>> img[10, 10:50] = img[50, 10:50] = img[10:51, 10] = img[10:30, 50] = 0
        >>> r = slamq.register(img, img)
        >>> bool(np.allclose(r.apply([[1.0, 2.0]]), [[1.0, 2.0]], atol=0.01))
        True
        """
        p = np.asarray(points, dtype=float).reshape(-1, 2)
        c, s = math.cos(self.theta), math.sin(self.theta)
        return np.column_stack([c * p[:, 0] - s * p[:, 1] + self.tx,
                                s * p[:, 0] + c * p[:, 1] + self.ty])

    def inverse(self) -> Registration:
        """The same registration read the other way (fixed onto moving): the inverse
        transform, the directional figures swapped; score, margin and confidence kept.

        Examples
        --------
        >>> import numpy as np, slamq
        >>> img = np.full((60, 60), 254, np.uint8)
        >>> img[10, 10:50] = img[50, 10:50] = img[10:51, 10] = img[10:30, 50] = 0
        >>> r = slamq.register(img, img)
        >>> r.inverse().moving == r.fixed, r.inverse().inverse() == r
        (True, True)
        """
        c, s = math.cos(self.theta), math.sin(self.theta)
        ru = self.runner_up
        if ru is not None:
            cr, sr = math.cos(ru[0]), math.sin(ru[0])
            ru = (-ru[0], -(cr * ru[1] + sr * ru[2]), -(-sr * ru[1] + cr * ru[2]))
        return replace(
            self, moving=self.fixed, fixed=self.moving, theta=-self.theta,
            tx=-(c * self.tx + s * self.ty), ty=-(-s * self.tx + c * self.ty),
            inliers_moving=self.inliers_fixed, inliers_fixed=self.inliers_moving,
            overlap_moving=self.overlap_fixed, overlap_fixed=self.overlap_moving,
            runner_up=ru,
        )

    def to_dict(self) -> dict[str, Any]:
        """The figures as a plain dict (``dyaw`` in degrees added for reading).

        Examples
        --------
        >>> import numpy as np, slamq
        >>> img = np.full((60, 60), 254, np.uint8)
        >>> img[10, 10:50] = img[50, 10:50] = img[10:51, 10] = img[10:30, 50] = 0
        >>> d = slamq.register(img, img).to_dict()
        >>> d["ok"], round(d["dyaw"], 3), sorted(d)[:3]
        (True, 0.0, ['candidates', 'confidence', 'dyaw'])
        """
        d = {f.name: getattr(self, f.name) for f in fields(self)}
        d["dyaw"] = math.degrees(self.theta)
        return d
