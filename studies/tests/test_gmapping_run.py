"""The GMapping runner's own part (studies/gmapping_run.py): its best particle's CARMEN
log read back, and the map drawn from it, on a log written here (GMapping itself is not
installed by CI)."""

from __future__ import annotations

import math
from pathlib import Path

import gmapping_run as g
import numpy as np

from slamq.models.trajectory import yaw_to_quat
from slamq.sources import load_map, load_trajectory

HALF = 2.0  # a 4 m x 4 m room centred on the origin


def _ranges(x: float, y: float, a: float, angles: np.ndarray) -> np.ndarray:
    """Ranges from (x, y) to the room's walls along a + angles."""
    out = []
    for b in a + angles:
        c, s = math.cos(b), math.sin(b)
        ts = [t for t in ((HALF - x) / c if c > 1e-9 else math.inf,
                          (-HALF - x) / c if c < -1e-9 else math.inf,
                          (HALF - y) / s if s > 1e-9 else math.inf,
                          (-HALF - y) / s if s < -1e-9 else math.inf)]
        out.append(min(ts))
    return np.array(out)


def _write_log(path: Path, poses: list[tuple[float, float, float]]) -> None:
    angles = -math.pi / 2 + math.radians(1) * np.arange(181)
    with path.open("w") as f:
        f.write("ODOM 0.0 0.0 0.0 0 0 0 100.0 pippo 100.0\n")
        for i, (x, y, a) in enumerate(poses):
            r = _ranges(x, y, a, angles)
            r[90] = 81.83  # no return, as the logs write it
            f.write("ROBOTLASER1 0 -1.570796 3.141593 0.017453 81.9 0.01 0 181 "
                    + " ".join(f"{v:.3f}" for v in r)
                    + f" 0 {x} {y} {a} {x} {y} {a} 0 0 0.55 0.375 1000000.0 "
                    f"{100.5 + i} localhost {100.5 + i}\n")


def test_the_best_path_and_its_map(tmp_path: Path) -> None:
    poses = [(-1.0, -1.0, 0.0), (0.0, -1.0, math.pi / 2), (1.0, 0.0, math.pi),
             (0.0, 1.0, -math.pi / 2), (-1.0, 0.5, 0.3)]
    log = tmp_path / "best-path.clf"
    _write_log(log, poses)
    stamps, ranges, read, geometry = g.read_robotlaser(log)
    assert stamps.tolist() == [100.5, 101.5, 102.5, 103.5, 104.5]
    assert np.allclose(read, poses) and len(ranges[0]) == 181
    assert geometry == (-1.570796, 0.017453, 81.9)

    g.write_tum(tmp_path / "trajectory.tum", stamps, read)
    traj = load_trajectory(tmp_path / "trajectory.tum")
    assert np.allclose(traj.positions[:, :2], np.array(poses)[:, :2])
    assert np.allclose(traj.orientations, yaw_to_quat(np.array([p[2] for p in poses])))

    img, corner = g.draw_map(ranges, read, geometry, resolution=0.05)
    g.write_map(tmp_path, img, corner, 0.05)
    grid = load_map(tmp_path / "map.yaml")

    def value(x: float, y: float) -> int:
        col = int((x - corner[0]) / 0.05)
        row = img.shape[0] - 1 - int((y - corner[1]) / 0.05)
        return int(grid.values[row, col])

    # the walls are occupied (within a cell of where they are), the room's inside free,
    # outside the walls nothing is known
    for x, y in ((2.0, 0.3), (-2.0, -0.7), (0.4, 2.0), (-0.6, -2.0)):
        near = [value(x + dx, y + dy) for dx in (-0.05, 0, 0.05) for dy in (-0.05, 0, 0.05)]
        assert 0 in near, (x, y)
    for x, y in ((0.0, 0.0), (1.5, 1.5), (-1.5, 1.2), (0.7, -1.6)):
        assert value(x, y) == 254, (x, y)
    assert img.shape == (85, 85) and corner == (-2.1, -2.1)  # the walls, and a cell more
    assert img[0, 0] == img[-1, -1] == img[0, -1] == img[-1, 0] == 205
    # no wall inside the room: the beams without a return (81.83 m) drew nothing
    inside = img[img.shape[0] - int((1.8 - corner[1]) / 0.05):
                 img.shape[0] - int((-1.8 - corner[1]) / 0.05),
                 int((-1.8 - corner[0]) / 0.05):int((1.8 - corner[0]) / 0.05)]
    assert (inside == 0).sum() == 0 and (inside == 254).mean() > 0.99
