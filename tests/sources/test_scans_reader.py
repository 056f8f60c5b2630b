"""Laser scans from recordings (slamq.load_scans): the rawlogs, CARMEN logs and bags slamq
writes read back exactly, the real logs of ../shared/data/datasets2d and MRPT's own
datasets (when present), and bad input refused with the file and the place named."""

from __future__ import annotations

import gzip
import math
from pathlib import Path

import numpy as np
import pytest
from conftest import SHARED_DATA

import slamq
from slamq.errors import SequenceError
from slamq.models import Scans
from slamq.sources.scans import load_scans, read_rawlog_scans
from slamq.synth import LaserSpec, simulate, world
from slamq.synth.recording import EPOCH
from slamq.synth.writers.carmen import write_carmen
from slamq.synth.writers.carmen_rawlog import carmen_to_rawlog
from slamq.synth.writers.rawlog import write_rawlog

DATASETS = SHARED_DATA / "datasets2d"
CSAIL = DATASETS / "mit-csail" / "mit-csail.clf"
MRPT_DATA = Path("/usr/share/mrpt/datasets")
SENA = MRPT_DATA / "2006-01ENE-21-SENA_Telecom Faculty_one_loop_only.rawlog"


@pytest.fixture(scope="module")
def drive():
    """A short drive with a laser mounted off the robot's centre, turned."""
    w = world(2, kind="office", size=(8.0, 6.0))
    laser = LaserSpec(beams=61, offset=(0.2, -0.05, 0.1))
    return simulate(w, seed=3, noise="low", laser=laser, length=6.0)


def _same(a: Scans, b: Scans, *, atol: float = 0.0, angles: float = 1e-6) -> None:
    assert a.ranges.shape == b.ranges.shape
    assert np.array_equal(np.isfinite(a.ranges), np.isfinite(b.ranges))
    fin = np.isfinite(a.ranges)
    assert np.abs(a.ranges[fin] - b.ranges[fin]).max() <= atol
    assert np.abs(a.angles - b.angles).max() < angles


def test_the_rawlog_slamq_writes_reads_back(drive, tmp_path: Path) -> None:
    path = write_rawlog(drive, tmp_path / "d.rawlog")
    s = slamq.load_scans(path)
    ref = Scans.from_sequence(drive)
    # float32 ranges on disk; the stamps on the sequence's clock (EPOCH + stamps)
    _same(s, ref, atol=1e-5)
    assert np.abs(s.stamps - (EPOCH + drive.stamps)).max() < 1e-6
    assert np.allclose(s.offset, drive.laser.offset, atol=1e-9)
    assert s.max_range == pytest.approx(drive.laser.max_range)
    assert s.meta == {"format": "rawlog", "reordered": 0}
    # gzip too, and a cut of the head
    gz = tmp_path / "d.rawlog.gz"
    gz.write_bytes(gzip.compress(path.read_bytes()))
    _same(load_scans(gz), s)
    assert len(read_rawlog_scans(path, max_scans=5)) == 5


def test_a_carmen_log_and_its_rawlog_give_the_same_scans(drive, tmp_path: Path) -> None:
    log = write_carmen(drive, tmp_path / "d.log")
    s = load_scans(log)
    assert s.meta["format"] == "carmen"
    # millimetres and microradians in the log
    _same(s, Scans.from_sequence(drive), atol=6e-4, angles=2e-5)
    assert np.allclose(s.offset, drive.laser.offset, atol=1e-5)
    raw = carmen_to_rawlog(log, tmp_path / "d.rawlog")["rawlog"]
    r = load_scans(raw)
    _same(r, s, atol=1e-5, angles=2e-5)  # the aperture is a float32 in the rawlog
    assert np.abs(r.stamps - s.stamps).max() < 1e-6
    # the rawlog's first beam is put at the log's angle_min by turning the sensor pose:
    # the beams in the robot's frame are the same
    assert np.abs((r.angles + r.offset[2]) - (s.angles + s.offset[2])).max() < 2e-5


def test_a_bag_with_laser_scans(drive, tmp_path: Path) -> None:
    pytest.importorskip("rosbags")
    from slamq.synth.writers.ros import write_rosbag1

    bag = write_rosbag1(drive, tmp_path / "d.bag")
    s = load_scans(bag)
    assert s.meta["format"] == "bag"
    _same(s, Scans.from_sequence(drive), atol=1e-5)
    assert np.abs(s.stamps - (EPOCH + drive.stamps)).max() < 1e-6
    # the laser's offset from /tf_static (base_link -> laser)
    assert np.allclose(s.offset, drive.laser.offset, atol=1e-6)


def test_backwards_stamps_are_put_in_time_order(tmp_path: Path) -> None:
    p = tmp_path / "back.clf"
    p.write_text("FLASER 2 1.0 2.0 0 0 0 0 0 0 10.0 h 0\n"
                 "FLASER 2 3.0 4.0 0 0 0 0 0 0 9.5 h 0\n"
                 "FLASER 2 5.0 6.0 0 0 0 0 0 0 11.0 h 0\n")
    s = load_scans(p)
    assert s.stamps.tolist() == [9.5, 10.0, 11.0]
    assert s.ranges[:, 0].tolist() == [3.0, 1.0, 5.0]
    assert s.meta["reordered"] == 1


@pytest.mark.skipif(not CSAIL.exists(), reason="../shared/data/datasets2d absent")
def test_the_mit_csail_log_and_its_bag() -> None:
    s = load_scans(CSAIL)
    assert len(s) == 1988 and s.angles.shape == (361,)
    assert s.angles[0] == pytest.approx(-math.pi / 2) and s.angles[-1] == pytest.approx(
        math.pi / 2)
    assert 0.5 < np.isfinite(s.ranges).mean() < 1.0
    bag = CSAIL.with_name("mit-csail.orig.bag")
    if bag.exists():
        pytest.importorskip("rosbags")
        b = load_scans(bag)
        # the same scans: the log was written from the bag (stamps to the microsecond,
        # ranges to the centimetre)
        assert np.abs(b.stamps - s.stamps).max() < 1e-5
        _same(b, s, atol=0.006)


@pytest.mark.skipif(not SENA.exists(), reason="MRPT's datasets (mrpt-apps) absent")
def test_mrpt_real_and_demo_rawlogs() -> None:
    # a real one (Malaga, 2006): old serialization (CPose3D as a 4x4 matrix, version 6
    # scans, observations before actions)
    s = load_scans(SENA)
    assert len(s) == 225 and s.angles.shape == (361,)
    assert s.offset == pytest.approx((0.78, 0.0, 0.0), abs=1e-6)
    assert np.all(np.diff(s.stamps) > 0) and 50 < s.stamps[-1] - s.stamps[0] < 70
    demo = load_scans(MRPT_DATA / "localization_demo.rawlog")
    assert len(demo) == 37 and demo.angles[0] == pytest.approx(-math.pi / 2, abs=1e-6)
    # rawlogs of other sensors are refused, naming the class and the byte
    with pytest.raises(SequenceError, match=r"kf-slam_demo.rawlog: byte \d+: "
                                            r"CObservationBearingRange is not read"):
        load_scans(MRPT_DATA / "kf-slam_demo.rawlog")


def test_bad_input_names_the_file_and_the_place(drive, tmp_path: Path) -> None:
    path = write_rawlog(drive, tmp_path / "d.rawlog")
    cut = tmp_path / "cut.rawlog"
    cut.write_bytes(path.read_bytes()[:3000])
    with pytest.raises(SequenceError, match=r"cut.rawlog: byte \d+: the file ends inside "):
        load_scans(cut)
    junk = tmp_path / "junk.rawlog"
    junk.write_bytes(b"hello world")
    with pytest.raises(SequenceError, match=r"junk.rawlog: byte 1: not an MRPT object"):
        load_scans(junk)
    empty = tmp_path / "empty.rawlog"
    empty.write_bytes(b"")
    with pytest.raises(SequenceError, match="empty.rawlog: no 2D laser scans"):
        load_scans(empty)
    with pytest.raises(SequenceError, match="no.rawlog: cannot read"):
        load_scans(tmp_path / "no.rawlog")
    with pytest.raises(SequenceError, match="map.pgm: not a recording with laser scans"):
        load_scans(tmp_path / "map.pgm")
    two = tmp_path / "two.clf"
    two.write_text("FLASER 2 1.0 2.0 0 0 0 0 0 0 10.0 h 0\n"
                   "FLASER 3 1.0 2.0 3.0 0 0 0 0 0 0 10.5 h 0\n")
    with pytest.raises(SequenceError, match=r"two.clf:2: the scans change their number of "
                                            "beams"):
        load_scans(two)
    none = tmp_path / "none.clf"
    none.write_text("ODOM 0 0 0 0 0 0 1.0 h 1.0\n")
    with pytest.raises(SequenceError, match="none.clf: no front laser scans"):
        load_scans(none)
    for bad in (-1, 0):  # 0 would read nothing: a clear refusal, not "no scans"
        with pytest.raises(SequenceError, match="max_scans must be an integer >= 1"):
            load_scans(two, max_scans=bad)
