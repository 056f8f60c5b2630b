"""The :class:`Trajectory` container and the quaternion helpers every other part uses.

Quaternions are stored in ``w, x, y, z`` order (evo's ``orientations_quat_wxyz``), as
unit quaternions: the constructor normalises them, like evo does before it builds a
rotation matrix.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from slamq.errors import TrajectoryError

__all__ = [
    "Trajectory",
    "order_rows",
    "quat_to_matrix",
    "matrix_to_quat",
    "quat_multiply",
    "quat_rotate",
    "yaw_to_quat",
]


def yaw_to_quat(yaw: np.ndarray) -> np.ndarray:
    """Unit quaternions ``(N, 4)`` (w, x, y, z) of rotations by ``yaw`` radians about z.

    Examples
    --------
    >>> import numpy as np
    >>> (yaw_to_quat(np.array([0.0, np.pi])).round(6) + 0.0).tolist()
    [[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]]
    """
    half = 0.5 * np.asarray(yaw, dtype=np.float64)
    q = np.zeros((half.shape[0], 4))
    q[:, 0] = np.cos(half)
    q[:, 3] = np.sin(half)
    return q


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrices ``(N, 3, 3)`` of unit quaternions ``(N, 4)`` in w, x, y, z order.

    Examples
    --------
    >>> import numpy as np
    >>> quat_to_matrix(np.array([[1.0, 0, 0, 0]]))[0].tolist()
    [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    """
    q = np.asarray(q, dtype=np.float64)
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    r = np.empty((q.shape[0], 3, 3))
    xx, yy, zz = x * x, y * y, z * z
    xy, xz, yz = x * y, x * z, y * z
    wx, wy, wz = w * x, w * y, w * z
    r[:, 0, 0] = 1.0 - 2.0 * (yy + zz)
    r[:, 0, 1] = 2.0 * (xy - wz)
    r[:, 0, 2] = 2.0 * (xz + wy)
    r[:, 1, 0] = 2.0 * (xy + wz)
    r[:, 1, 1] = 1.0 - 2.0 * (xx + zz)
    r[:, 1, 2] = 2.0 * (yz - wx)
    r[:, 2, 0] = 2.0 * (xz - wy)
    r[:, 2, 1] = 2.0 * (yz + wx)
    r[:, 2, 2] = 1.0 - 2.0 * (xx + yy)
    return r


def matrix_to_quat(r: np.ndarray) -> np.ndarray:
    """Unit quaternions ``(N, 4)`` (w, x, y, z, with w >= 0) of rotation matrices ``(N, 3, 3)``.

    Uses the numerically stable branch (largest of w, x, y, z first) for every row.

    Examples
    --------
    >>> import numpy as np
    >>> matrix_to_quat(np.eye(3)[None]).tolist()
    [[1.0, 0.0, 0.0, 0.0]]
    """
    r = np.asarray(r, dtype=np.float64)
    n = r.shape[0]
    m00, m01, m02 = r[:, 0, 0], r[:, 0, 1], r[:, 0, 2]
    m10, m11, m12 = r[:, 1, 0], r[:, 1, 1], r[:, 1, 2]
    m20, m21, m22 = r[:, 2, 0], r[:, 2, 1], r[:, 2, 2]
    tr = m00 + m11 + m22
    cand = np.stack([tr, m00, m11, m22], axis=1)
    k = np.argmax(cand, axis=1)
    q = np.empty((n, 4))
    with np.errstate(invalid="ignore", divide="ignore"):
        # case w largest
        s = np.sqrt(np.maximum(tr + 1.0, 0.0)) * 2.0
        qw = np.stack([0.25 * s, (m21 - m12) / s, (m02 - m20) / s, (m10 - m01) / s], 1)
        s = np.sqrt(np.maximum(1.0 + m00 - m11 - m22, 0.0)) * 2.0
        qx = np.stack([(m21 - m12) / s, 0.25 * s, (m01 + m10) / s, (m02 + m20) / s], 1)
        s = np.sqrt(np.maximum(1.0 + m11 - m00 - m22, 0.0)) * 2.0
        qy = np.stack([(m02 - m20) / s, (m01 + m10) / s, 0.25 * s, (m12 + m21) / s], 1)
        s = np.sqrt(np.maximum(1.0 + m22 - m00 - m11, 0.0)) * 2.0
        qz = np.stack([(m10 - m01) / s, (m02 + m20) / s, (m12 + m21) / s, 0.25 * s], 1)
    for i, qq in enumerate((qw, qx, qy, qz)):
        sel = k == i
        q[sel] = qq[sel]
    q *= np.where(q[:, :1] < 0, -1.0, 1.0)
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    return q


def quat_multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton products ``a * b`` of quaternion arrays ``(N, 4)`` or ``(4,)`` (w, x, y, z).

    Examples
    --------
    >>> import numpy as np
    >>> quat_multiply(np.array([0.0, 0, 0, 1]), np.array([0.0, 0, 0, 1])).tolist()
    [-1.0, 0.0, 0.0, 0.0]
    """
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    aw, ax, ay, az = a[..., 0], a[..., 1], a[..., 2], a[..., 3]
    bw, bx, by, bz = b[..., 0], b[..., 1], b[..., 2], b[..., 3]
    return np.stack(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ],
        axis=-1,
    )


def quat_rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Vectors ``v`` (..., 3) rotated by unit quaternions ``q`` (..., 4) (w, x, y, z).

    Examples
    --------
    >>> import numpy as np
    >>> quat_rotate(yaw_to_quat(np.array([np.pi / 2])), np.array([[1.0, 0, 0]])).round(12) + 0.0
    array([[0., 1., 0.]])
    """
    w = q[..., :1]
    u = q[..., 1:]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def _first_bad_row(mask: np.ndarray) -> int:
    return int(np.flatnonzero(mask)[0])


#: Largest deviation of ``R^T R`` from the identity accepted in a pose matrix (files print
#: rotations with 6 to 9 digits; anything further off is not a rotation).
ROTATION_TOL = 1e-3


def _check_rotations(r: np.ndarray, source: str) -> None:
    """Raise when a ``(N, 3, 3)`` block is not a rotation (not orthonormal, or a mirror)."""
    off = np.abs(np.einsum("nji,njk->nik", r, r) - np.eye(3)).max(axis=(1, 2))
    bad = (off > ROTATION_TOL) | (np.linalg.det(r) <= 0)
    if bad.any():
        row = _first_bad_row(bad)
        raise TrajectoryError(
            f"{source}: pose {row + 1} is not a rigid transform (its 3x3 block is not a "
            f"rotation: R^T R differs from I by {off[row]:.3g}, det {np.linalg.det(r[row]):.3g})"
        )


@dataclass(frozen=True, eq=False)
class Trajectory:
    """Timestamped poses: ``N`` timestamps, positions and orientations.

    Parameters
    ----------
    timestamps : array (N,)
        Seconds, non-decreasing (equal neighbours are allowed, as in evo).
    positions : array (N, 3)
        x, y, z in metres (2-D trajectories have z = 0).
    orientations : array (N, 4), optional
        Quaternions in w, x, y, z order; normalised here. ``None`` means identity.
    source : str
        The file (or ``"<array>"``) the poses came from; errors name it.

    Raises
    ------
    TrajectoryError
        No poses, wrong shapes, NaN or infinite values, zero quaternions, or timestamps
        that go backwards; the message names ``source`` and the first bad row (1-based
        data rows).

    Examples
    --------
    >>> import numpy as np
    >>> from slamq.models import Trajectory
    >>> tr = Trajectory.from_xy_yaw([0.0, 1.0], [0.0, 1.0], [0.0, 0.0], [0.0, np.pi / 2])
    >>> len(tr), tr.positions[1].tolist(), round(float(tr.yaw[1]), 6)
    (2, [1.0, 0.0, 0.0], 1.570796)
    """

    timestamps: np.ndarray
    positions: np.ndarray
    orientations: np.ndarray | None = None
    source: str = "<array>"
    meta: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        src = self.source
        t = np.ascontiguousarray(self.timestamps, dtype=np.float64)
        p = np.ascontiguousarray(self.positions, dtype=np.float64)
        if t.ndim != 1:
            raise TrajectoryError(f"{src}: timestamps must be 1-D, got shape {t.shape}")
        n = t.shape[0]
        if n == 0:
            raise TrajectoryError(f"{src}: no poses (empty trajectory)")
        if p.shape != (n, 3):
            raise TrajectoryError(f"{src}: positions must have shape ({n}, 3), got {p.shape}")
        if self.orientations is None:
            q = np.zeros((n, 4))
            q[:, 0] = 1.0
        else:
            q = np.array(self.orientations, dtype=np.float64)
            if q.shape != (n, 4):
                raise TrajectoryError(
                    f"{src}: orientations must have shape ({n}, 4), got {q.shape}"
                )
        for name, arr in (("timestamp", t), ("position", p), ("orientation", q)):
            bad = ~np.isfinite(arr)
            if bad.any():
                row = _first_bad_row(bad.reshape(n, -1).any(axis=1))
                raise TrajectoryError(f"{src}: NaN or infinite {name} in pose {row + 1}")
        norm = np.sqrt(np.einsum("ij,ij->i", q, q))
        if (norm < 1e-12).any():
            row = _first_bad_row(norm < 1e-12)
            raise TrajectoryError(f"{src}: zero quaternion in pose {row + 1}")
        q /= norm[:, None]
        if n > 1:
            back = np.diff(t) < 0
            if back.any():
                i = _first_bad_row(back)
                raise TrajectoryError(
                    f"{src}: non-monotonic timestamps: pose {i + 2} ({float(t[i + 1])!r} s) is "
                    f"earlier than pose {i + 1} ({float(t[i])!r} s); read it in time order with "
                    f"unsorted='sort', or from its last restart with unsorted='last' (CLI: "
                    f"--unsorted sort|last; docs/spec.md 6c)"
                )
        for arr in (t, p, q):
            arr.flags.writeable = False
        object.__setattr__(self, "timestamps", t)
        object.__setattr__(self, "positions", p)
        object.__setattr__(self, "orientations", q)

    # ------------------------------------------------------------------ constructors
    @classmethod
    def _from_checked(
        cls,
        timestamps: np.ndarray,
        positions: np.ndarray,
        orientations: np.ndarray,
        *,
        source: str = "<array>",
        meta: dict | None = None,
    ) -> Trajectory:
        """A trajectory of arrays that already pass every check of the constructor.

        For readers that checked and normalised the poses themselves (``slamq._core.read_tum``):
        C-contiguous float64 arrays ``(N,)``, ``(N, 3)`` and ``(N, 4)`` (unit quaternions,
        w x y z, normalised as the constructor does), finite, non-decreasing timestamps,
        ``N >= 1``. The arrays are kept as they are (made read-only), not copied.
        """
        obj = object.__new__(cls)
        for name, arr in (("timestamps", timestamps), ("positions", positions),
                          ("orientations", orientations)):
            arr.flags.writeable = False
            object.__setattr__(obj, name, arr)
        object.__setattr__(obj, "source", source)
        object.__setattr__(obj, "meta", {} if meta is None else meta)
        return obj

    @classmethod
    def from_xy_yaw(
        cls,
        t: np.ndarray,
        x: np.ndarray,
        y: np.ndarray,
        yaw: np.ndarray | None = None,
        *,
        source: str = "<array>",
    ) -> Trajectory:
        """A planar trajectory from ``t, x, y`` and optionally ``yaw`` (radians).

        Examples
        --------
        >>> Trajectory.from_xy_yaw([0, 1], [0, 1], [0, 0]).positions.tolist()
        [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]
        """
        t = np.asarray(t, dtype=np.float64)
        pos = np.zeros((t.shape[0], 3))
        pos[:, 0] = np.asarray(x, dtype=np.float64)
        pos[:, 1] = np.asarray(y, dtype=np.float64)
        q = None if yaw is None else yaw_to_quat(np.asarray(yaw, dtype=np.float64))
        return cls(t, pos, q, source=source)

    @classmethod
    def from_matrices(
        cls,
        poses: np.ndarray,
        timestamps: np.ndarray | None = None,
        *,
        source: str = "<array>",
    ) -> Trajectory:
        """A trajectory from ``(N, 3, 4)`` or ``(N, 4, 4)`` pose matrices.

        Without ``timestamps`` the pose index is the timestamp (KITTI: matched by index).
        A 3x3 block that is not a rotation (``R^T R`` off the identity by more than
        ``ROTATION_TOL``, or a mirror) raises :class:`TrajectoryError`.

        Examples
        --------
        >>> import numpy as np
        >>> Trajectory.from_matrices(np.eye(4)[None]).orientations.tolist()
        [[1.0, 0.0, 0.0, 0.0]]
        """
        m = np.asarray(poses, dtype=np.float64)
        if m.ndim != 3 or m.shape[1:] not in ((3, 4), (4, 4)):
            raise TrajectoryError(f"{source}: pose matrices must be (N, 3, 4) or (N, 4, 4)")
        if timestamps is None:
            timestamps = np.arange(m.shape[0], dtype=np.float64)
        if not np.isfinite(m).all():
            row = _first_bad_row(~np.isfinite(m).reshape(m.shape[0], -1).all(axis=1))
            raise TrajectoryError(f"{source}: NaN or infinite value in pose {row + 1}")
        _check_rotations(m[:, :3, :3], source)
        return cls(timestamps, m[:, :3, 3], matrix_to_quat(m[:, :3, :3]), source=source)

    # ------------------------------------------------------------------ views
    def __len__(self) -> int:
        return int(self.timestamps.shape[0])

    def __repr__(self) -> str:
        return (
            f"Trajectory({len(self)} poses, {self.duration:.3f} s, "
            f"{self.path_length:.3f} m, source={self.source!r})"
        )

    @property
    def duration(self) -> float:
        """Last minus first timestamp, seconds."""
        return float(self.timestamps[-1] - self.timestamps[0])

    @property
    def path_length(self) -> float:
        """Sum of the distances between consecutive positions, metres."""
        return float(np.linalg.norm(np.diff(self.positions, axis=0), axis=1).sum())

    @property
    def rotations(self) -> np.ndarray:
        """Rotation matrices ``(N, 3, 3)``."""
        return quat_to_matrix(self.orientations)

    @property
    def yaw(self) -> np.ndarray:
        """Heading about z, radians (the z-y-x Euler yaw)."""
        w, x, y, z = self.orientations.T
        return np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))

    @property
    def is_planar(self) -> bool:
        """True when every z is 0 and every rotation is about z."""
        return bool(
            np.all(self.positions[:, 2] == 0.0)
            and np.all(self.orientations[:, 1:3] == 0.0)
        )

    def matrices(self) -> np.ndarray:
        """Homogeneous pose matrices ``(N, 4, 4)``."""
        m = np.zeros((len(self), 4, 4))
        m[:, :3, :3] = self.rotations
        m[:, :3, 3] = self.positions
        m[:, 3, 3] = 1.0
        return m

    def subset(self, index: np.ndarray) -> Trajectory:
        """The poses at ``index`` (an integer array or a boolean mask), in that order."""
        return Trajectory(
            self.timestamps[index],
            self.positions[index],
            self.orientations[index],
            source=self.source,
            meta=dict(self.meta),
        )

    def write_tum(self, path: str | Path) -> Path:
        """Write the trajectory as a TUM file (``t x y z qx qy qz qw``, full precision).

        Examples
        --------
        >>> import tempfile, pathlib
        >>> p = pathlib.Path(tempfile.mkdtemp()) / "t.txt"
        >>> _ = Trajectory.from_xy_yaw([0.5], [1.0], [2.0]).write_tum(p)
        >>> p.read_text().split()[:3]
        ['0.5', '1', '2']
        """
        path = Path(path)
        q = self.orientations
        data = np.column_stack([self.timestamps, self.positions, q[:, 1:], q[:, :1]])
        with open(path, "w") as f:
            np.savetxt(f, data, fmt="%.17g")
        return path


def order_rows(t: np.ndarray, unsorted: str) -> np.ndarray:
    """The rows of a trajectory whose timestamps are ``t`` to keep, in order, by the
    ``unsorted`` policy (docs/spec.md 6c): ``"error"`` keeps every row as it is (the
    :class:`~slamq.Trajectory` then refuses stamps that go backwards), ``"sort"`` sorts
    them by time (stable: equal stamps keep the file's order), ``"last"`` keeps the rows
    after the last stamp that goes backwards (a log that restarted).

    Examples
    --------
    >>> import numpy as np
    >>> t = np.array([0.0, 0.2, 0.1, 0.3])
    >>> order_rows(t, "sort").tolist(), order_rows(t, "last").tolist()
    ([0, 2, 1, 3], [2, 3])
    >>> order_rows(t, "error").tolist()
    [0, 1, 2, 3]
    """
    rows = np.arange(t.shape[0])
    if unsorted not in ("error", "last", "sort"):
        raise TrajectoryError(f"unsorted must be 'error', 'last' or 'sort', not {unsorted!r}")
    if unsorted == "error" or t.shape[0] < 2:
        return rows
    back = np.flatnonzero(np.diff(t) < 0)
    if back.size == 0:
        return rows
    if unsorted == "last":
        return rows[back[-1] + 1:]
    return rows[np.argsort(t, kind="stable")]
