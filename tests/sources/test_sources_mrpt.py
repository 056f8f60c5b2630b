"""MRPT output readers on files written here (no MRPT needed)."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

import slamq
from slamq.errors import MapError, TrajectoryError
from slamq.sources.mrpt import load_mrpt_grid, read_limits, read_mrpt_path, write_mrpt_yaml


def _grid(d: Path, limits: str = "% Grid limits\n-2.0 2.0 -1.0 1.0\n") -> Path:
    img = np.full((20, 40), 128, np.uint8)  # unknown
    img[:10, :] = 255  # top half free
    img[0, :] = 0  # top row occupied (y_max side)
    png = d / "finalMap_mrpt__maps__COccupancyGridMap2D_00.png"
    cv2.imwrite(str(png), img)
    (d / "finalMap_mrpt__maps__COccupancyGridMap2D_00_limits.txt").write_text(limits)
    return png


def test_grid_geometry_and_cells(tmp_path: Path) -> None:
    m = load_mrpt_grid(_grid(tmp_path))
    assert m.shape == (20, 40)
    assert m.resolution == pytest.approx(0.1)
    assert m.origin == pytest.approx((-2.0, -1.0, 0.0))
    assert int(m.unknown.sum()) == 400
    assert int((m.values[0] == 0).sum()) == 40  # the occupied row stays the top row
    # the YAML written for the batch reads back to the same cells
    y = slamq.load_map(write_mrpt_yaml(_grid(tmp_path), tmp_path / "run" / "map.yaml"))
    assert np.array_equal(y.values, m.values) and np.array_equal(y.unknown, m.unknown)
    assert y.origin == pytest.approx(m.origin)


@pytest.mark.parametrize("limits, reason", [
    ("1 2 3\n", "4 numbers"), ("0 -1 0 1\n", "empty"), ("a b c d\n", "not a number"),
    ("0 4 0 1\n", "m/cell"),  # 0.1 m/cell across, 0.05 down
])
def test_bad_limits_name_the_file(tmp_path: Path, limits: str, reason: str) -> None:
    with pytest.raises(MapError, match=reason) as info:
        load_mrpt_grid(_grid(tmp_path, limits))
    assert "_limits.txt" in str(info.value) or ".png" in str(info.value)


def test_missing_limits(tmp_path: Path) -> None:
    png = _grid(tmp_path)
    png.with_name(png.stem + "_limits.txt").unlink()
    with pytest.raises(MapError, match="limits"):
        read_limits(png.with_name(png.stem + "_limits.txt"))
    with pytest.raises(MapError, match="_limits.txt"):
        load_mrpt_grid(png)


def test_rbpf_and_icp_pose_logs(tmp_path: Path) -> None:
    p = tmp_path / "log_estimated_path.txt"
    p.write_text("0 0 0 0 0 -0 0 100.0\n1 1 2 0 0.5 -0 0 100.2\n2 1.5 2 0 0.6 0 0 0.000000\n")
    t = read_mrpt_path(p)
    assert t.timestamps.tolist() == [100.0, 100.2]  # the final t=0 row is MRPT's invalid time
    assert t.positions[1, :2].tolist() == [1.0, 2.0]
    p.write_text("0 0 0 0\n1 0.5 0.1 0.2\n2 1 0.2 0.3\n")
    t = read_mrpt_path(p)
    assert t.timestamps.tolist() == [0.0, 1.0, 2.0] and t.positions[2, 0] == 1.0


@pytest.mark.parametrize("text, reason", [
    ("", "no timestamped poses"), ("0 1 2\n", "columns"), ("0 0 0 0\n1 0 0 0 0 0 0 1\n", "columns"),
    ("0 x 0 0\n", "not a number"), ("0 nan 0 0 0 0 0 1\n", "non-finite"),
])
def test_bad_pose_logs(tmp_path: Path, text: str, reason: str) -> None:
    p = tmp_path / "log_estimated_path.txt"
    p.write_text(text)
    with pytest.raises(TrajectoryError, match=reason) as info:
        read_mrpt_path(p)
    assert str(p) in str(info.value)


def test_graphslam_graph_is_a_trajectory_by_node_id(tmp_path: Path) -> None:
    from slamq.sources.mrpt import read_mrpt_graph

    p = tmp_path / "output_graph.graph"
    p.write_text("VERTEX_SE2 0 0 0 0\nFIX 0\nVERTEX_SE2 2 1.0 0.1 0.2\nVERTEX_SE2 1 0.5 0 0.1\n"
                 "EDGE_SE2 0 1 0.5 0 0.1 1 0 0 1 0 1\n")
    for t in (read_mrpt_graph(p), read_mrpt_path(p)):  # the mrpt format reads graphs too
        assert t.timestamps.tolist() == [0.0, 1.0, 2.0]
        assert t.positions[:, 0].tolist() == [0.0, 0.5, 1.0]
        assert t.yaw[2] == pytest.approx(0.2)
    p.write_text("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 0 1 0 0\n")
    with pytest.raises(TrajectoryError, match="repeated node ids"):
        read_mrpt_path(p)
    p.write_text("VERTEX_SE2 0 0 0\n")
    with pytest.raises(TrajectoryError, match=r"output_graph.graph:1: VERTEX_SE2 needs"):
        read_mrpt_path(p)


def test_step_times_put_an_index_log_on_a_clock(tmp_path: Path) -> None:
    from slamq.sources.mrpt import apply_step_times

    (tmp_path / "log.txt").write_text("0 0 0 0\n1 0.5 0 0\n3 1.0 0 0\n")
    (tmp_path / "steps.txt").write_text("# times\n10.0\n10.1\n10.2\n10.3\n")
    t = apply_step_times(read_mrpt_path(tmp_path / "log.txt"), tmp_path / "steps.txt")
    assert t.timestamps.tolist() == [10.0, 10.1, 10.3]
    (tmp_path / "steps.txt").write_text("10.0\n10.1\n")
    with pytest.raises(TrajectoryError, match=r"indexed 0\.\.3 do not fit the 2 step times"):
        apply_step_times(read_mrpt_path(tmp_path / "log.txt"), tmp_path / "steps.txt")
    with pytest.raises(TrajectoryError, match="cannot read step times"):
        apply_step_times(read_mrpt_path(tmp_path / "log.txt"), tmp_path / "none.txt")


def _rbpf_out(d: Path, *, poses: int = 3) -> Path:
    """An rbpf-slam output folder: 4 steps, steps 0 and 2 inserted, the mean path timed."""
    rows = ["0 0 0", "0 0 0", "1.0 0.5 0.1", "2.0 1.0 0.2"][:poses]
    (d / "most_likely_path.txt").write_text("\n".join(rows) + "\n")
    (d / "log_times.txt").write_text("% step ms frames inserted\n"
                                     "0 5.0 1 1\n1 0.1 1 0\n2 4.0 2 1\n3 0.1 2 0\n")
    (d / "log_estimated_path.txt").write_text(
        "0 0 0 0 0 0 0 70.0\n1 0.4 0 0 0 0 0 70.1\n2 0.9 0.4 0 0.1 0 0 70.2\n"
        "3 1.2 0.5 0 0.1 0 0 70.3\n3 0 0 0 0 0 0 0\n")
    return d / "most_likely_path.txt"


def test_rbpf_most_likely_path_is_timed_by_its_inserted_steps(tmp_path: Path) -> None:
    from slamq.sources import load_trajectory

    p = _rbpf_out(tmp_path)
    t = load_trajectory(p, format="mrpt")
    assert t.timestamps.tolist() == [70.0, 70.2]
    assert t.positions[:, 0].tolist() == [0.0, 1.0]
    assert np.degrees(2 * np.arctan2(t.orientations[1, 3], t.orientations[1, 0])) == \
        pytest.approx(np.degrees(0.1))
    # without the mean path, the step index stands for the time
    (tmp_path / "log_estimated_path.txt").unlink()
    assert load_trajectory(p, format="mrpt").timestamps.tolist() == [0.0, 2.0]


def test_rbpf_most_likely_path_that_does_not_fit_its_steps_is_refused(tmp_path: Path) -> None:
    from slamq.sources.mrpt import read_mrpt_most_likely

    p = _rbpf_out(tmp_path, poses=4)
    with pytest.raises(TrajectoryError, match=r"4 poses do not fit the 2 inserted steps"):
        read_mrpt_most_likely(p)
    p = _rbpf_out(tmp_path)
    (tmp_path / "log_times.txt").unlink()
    with pytest.raises(TrajectoryError, match=r"log_times.txt: cannot read"):
        read_mrpt_most_likely(p)
