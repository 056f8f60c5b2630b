"""Ground-truth relations and the relations error of a trajectory (docs/spec.md section 6a).

:class:`Relations` holds the manually verified relative motions of Kümmerle et al. 2009
("On measuring the accuracy of SLAM algorithms"): for each row, two timestamps ``t1, t2``
and the planar motion ``(x, y, yaw)`` from the robot's pose at ``t1`` to its pose at
``t2``, in the frame of the pose at ``t1``. :class:`RelationsResult` is what
:func:`slamq.metrics.relations.relations` computes from them.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np

from slamq.errors import TrajectoryError

__all__ = ["Relations", "RelationsResult", "RELATIONS_STATS", "invert_motion"]

#: The statistics of a :class:`RelationsResult`, in output order: translational (m, m^2)
#: then rotational (deg, deg^2), absolute and squared, mean and std, and the maxima.
RELATIONS_STATS = (
    "trans_abs_mean", "trans_abs_std", "trans_sq_mean", "trans_sq_std", "trans_max",
    "rot_abs_mean", "rot_abs_std", "rot_sq_mean", "rot_sq_std", "rot_max",
)


def invert_motion(m: np.ndarray) -> np.ndarray:
    """The inverse SE(2) motions ``(N, 3)`` of ``x, y, yaw`` rows: ``(-R^T t, -yaw)``.

    Examples
    --------
    >>> import numpy as np
    >>> (invert_motion(np.array([[1.0, 0.0, np.pi / 2]])).round(12) + 0.0).tolist()
    [[0.0, 1.0, -1.570796326795]]
    """
    m = np.asarray(m, dtype=np.float64)
    c, s = np.cos(m[:, 2]), np.sin(m[:, 2])
    x, y = m[:, 0], m[:, 1]
    return np.column_stack([-(c * x + s * y), s * x - c * y, -m[:, 2]])


@dataclass(frozen=True, eq=False)
class Relations:
    """Relative motions between the poses at two timestamps (the ground truth).

    Parameters
    ----------
    t1, t2 : array (N,)
        Timestamps, seconds (any order; ``t2 < t1`` is allowed).
    motion : array (N, 3)
        ``x, y, yaw`` (metres, metres, radians) of the pose at ``t2`` in the frame of the
        pose at ``t1``.
    source : str
        The file (or ``"<array>"``) the relations came from; errors name it.

    Raises
    ------
    TrajectoryError
        No rows, wrong shapes, NaN or infinite values (the message names ``source`` and
        the first bad row, 1-based).

    Examples
    --------
    >>> r = Relations([0.0, 1.0], [1.0, 2.0], [[1.0, 0.0, 0.0], [1.0, 0.0, 0.5]])
    >>> len(r), r.motion[1].tolist()
    (2, [1.0, 0.0, 0.5])
    """

    t1: np.ndarray
    t2: np.ndarray
    motion: np.ndarray
    source: str = "<array>"

    def __post_init__(self) -> None:
        src = self.source
        t1 = np.array(self.t1, dtype=np.float64)
        t2 = np.array(self.t2, dtype=np.float64)
        m = np.array(self.motion, dtype=np.float64)
        if t1.ndim != 1 or t2.shape != t1.shape:
            raise TrajectoryError(f"{src}: t1 and t2 must be 1-D of one length, got shapes "
                                  f"{t1.shape} and {t2.shape}")
        n = t1.shape[0]
        if n == 0:
            raise TrajectoryError(f"{src}: no relations")
        if m.shape != (n, 3):
            raise TrajectoryError(f"{src}: motion must have shape ({n}, 3), got {m.shape}")
        bad = ~(np.isfinite(t1) & np.isfinite(t2) & np.isfinite(m).all(axis=1))
        if bad.any():
            row = int(np.flatnonzero(bad)[0])
            raise TrajectoryError(f"{src}: NaN or infinite value in relation {row + 1}")
        for arr in (t1, t2, m):
            arr.flags.writeable = False
        object.__setattr__(self, "t1", t1)
        object.__setattr__(self, "t2", t2)
        object.__setattr__(self, "motion", m)

    def __len__(self) -> int:
        return int(self.t1.shape[0])

    def __repr__(self) -> str:
        return f"Relations({len(self)} rows, source={self.source!r})"

    @functools.cached_property
    def forward(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(t1, t2, motion, reversed)``: every row stated forwards, a row with
        ``t2 < t1`` as ``(t2, t1, motion^-1)`` (docs/spec.md 6a), and which rows were.
        Computed once per Relations (a batch scores many trajectories against one file).

        Examples
        --------
        >>> r = Relations([0.0, 2.0], [1.0, 1.0], [[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
        >>> t1, t2, m, rev = r.forward
        >>> t1.tolist(), t2.tolist(), m[1].tolist(), rev.tolist()
        ([0.0, 1.0], [1.0, 2.0], [-1.0, 0.0, -0.0], [False, True])
        """
        rev = self.t2 < self.t1
        t1 = np.where(rev, self.t2, self.t1)
        t2 = np.where(rev, self.t1, self.t2)
        motion = self.motion
        if rev.any():
            motion = motion.copy()
            motion[rev] = invert_motion(motion[rev])
        for arr in (t1, t2, motion, rev):
            arr.flags.writeable = False
        return t1, t2, motion, rev

    @functools.cached_property
    def n_duplicates(self) -> int:
        """Rows whose forward ``(t1, t2)`` pair repeats an earlier row's.

        Examples
        --------
        >>> Relations([0.0, 1.0, 0.0], [1.0, 0.0, 1.0], [[0, 0, 0]] * 3).n_duplicates
        2
        """
        t1, t2, _, _ = self.forward
        z = np.sort(t1 + 1j * t2)  # lexicographic: t1, then t2
        return int((z[1:] == z[:-1]).sum())


@dataclass(frozen=True, eq=False)
class RelationsResult:
    """The relations error of one trajectory (Kümmerle et al. 2009; docs/spec.md 6a).

    Attributes
    ----------
    trans_abs_mean, trans_abs_std : float
        Mean and population standard deviation (ddof=0) of the translational errors, m.
    trans_sq_mean, trans_sq_std : float
        The same of the squared translational errors, m^2.
    trans_max : float
        Largest translational error, m.
    rot_abs_mean, rot_abs_std, rot_sq_mean, rot_sq_std, rot_max : float
        The same for the rotational errors, deg and deg^2.
    n : int
        Relations placed on the trajectory (the statistics are over these).
    n_relations : int
        Rows of the relations.
    n_unplaced : int
        Rows whose ``t1`` or ``t2`` could not be placed (``n_relations - n``).
    n_interpolated : int
        Placed rows for which at least one pose was interpolated.
    n_reversed : int
        Rows with ``t2 < t1``, inverted before use.
    n_duplicates : int
        Rows repeating an earlier row's ``(t1, t2)`` pair (each still counted).
    trans_errors, rot_errors : ndarray (n,)
        Per placed relation: translational error (m) and rotational error (deg).
    placed : ndarray (n,)
        Row indices (0-based) of the placed relations, in file order.
    est_source, relations_source : str
        The trajectory's and the relations' files (or ``"<array>"``).
    params : dict
        ``interpolate``, ``max_gap``, ``stamp_tol``.
    """

    trans_abs_mean: float
    trans_abs_std: float
    trans_sq_mean: float
    trans_sq_std: float
    trans_max: float
    rot_abs_mean: float
    rot_abs_std: float
    rot_sq_mean: float
    rot_sq_std: float
    rot_max: float
    n: int
    n_relations: int
    n_unplaced: int
    n_interpolated: int
    n_reversed: int
    n_duplicates: int
    trans_errors: np.ndarray
    rot_errors: np.ndarray
    placed: np.ndarray
    est_source: str = "<array>"
    relations_source: str = "<array>"
    params: dict = field(default_factory=dict)

    def stats(self) -> dict:
        """The statistics (:data:`RELATIONS_STATS`) and the counts as a dict."""
        out: dict = {k: float(getattr(self, k)) for k in RELATIONS_STATS}
        for k in ("n", "n_relations", "n_unplaced", "n_interpolated", "n_reversed",
                  "n_duplicates"):
            out[k] = int(getattr(self, k))
        return out

    def to_dict(self, errors: bool = False) -> dict:
        """A JSON-ready dict; the per-relation errors included when ``errors`` is true.

        Examples
        --------
        >>> import numpy as np
        >>> from slamq.models import Trajectory
        >>> from slamq.models.relations import Relations
        >>> from slamq.metrics.relations import relations
        >>> tr = Trajectory.from_xy_yaw([0.0, 1.0], [0.0, 1.0], [0.0, 0.0], [0.0, 0.0])
        >>> d = relations(tr, Relations([0.0], [1.0], [[1.0, 0.0, 0.0]])).to_dict()
        >>> d["trans_abs_mean"], d["n"]
        (0.0, 1)
        """
        d = {
            "metric": "relations",
            "estimate": self.est_source,
            "relations": self.relations_source,
            **self.stats(),
            **self.params,
        }
        if errors:
            d["trans_errors"] = self.trans_errors.tolist()
            d["rot_errors"] = self.rot_errors.tolist()
            d["rows"] = self.placed.tolist()
        return d

    def __str__(self) -> str:
        return (
            f"relations {self.est_source}: trans {self.trans_abs_mean:.4f} \u00b1 "
            f"{self.trans_abs_std:.4f} m (sq {self.trans_sq_mean:.4f} \u00b1 "
            f"{self.trans_sq_std:.4f} m^2, max {self.trans_max:.4f}), rot "
            f"{self.rot_abs_mean:.3f} \u00b1 {self.rot_abs_std:.3f} deg (sq "
            f"{self.rot_sq_mean:.3f} \u00b1 {self.rot_sq_std:.3f} deg^2, max "
            f"{self.rot_max:.3f}), n {self.n} of {self.n_relations}"
        )
