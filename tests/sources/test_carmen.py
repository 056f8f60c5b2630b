"""CARMEN logs: the streaming reader (every record type, gzip, malformed lines, unknown
records, bounded memory), the rawlog written from them with the log's own timestamps, the
real datasets of ../shared/data/datasets2d when present, and MRPT's icp-slam on a cut."""

from __future__ import annotations

import gzip
import math
import re
import shutil
import struct
import subprocess
import time
import tracemalloc
from pathlib import Path

import numpy as np
import pytest
from conftest import SHARED_DATA

from slamq.errors import SequenceError, SlamqError
from slamq.sources.carmen import CarmenLog, Laser, Odom, Param, is_carmen
from slamq.sources.mrpt import apply_step_times, load_mrpt_grid, read_mrpt_path
from slamq.synth.writers.carmen_rawlog import carmen_to_rawlog, ticks, write_scans_rawlog
from slamq.synth.writers.rawlog import _END, _FRAME, _SCAN, MOTION_MODEL, _action, _pose3d

DATASETS = SHARED_DATA / "datasets2d"
CSAIL = DATASETS / "mit-csail" / "mit-csail.clf"
MRPT_CONFIGS = Path("/usr/share/mrpt/config_files")
ICP_INI = MRPT_CONFIGS / "icp-slam" / "icp-slam_demo_classic_gridmatch.ini"
RBPF_INI = MRPT_CONFIGS / "rbpf-slam" / "gridmapping_optimal_sampling.ini"

# one line of each record type (ranges 1, no return (>= max range), 2.5)
PARAM = "PARAM robot_front_laser_max 4.0 100.0 host 0.5"
ODOM = "ODOM 1.0 2.0 0.5 0.3 0.1 0.0 100.25 host 0.75"
FLASER = "FLASER 3 1.0 4.0 2.5 9 9 9 1.0 2.0 0.5 100.5 host 1.0"
RLASER = "RLASER 2 1.0 1.0 0 0 0 1.0 2.0 0.5 100.5 host 1.0"
RAWLASER = "RAWLASER1 0 -1.5 3.0 1.5 8.0 0.02 0 3 1.0 8.0 2.0 0 101.0 host 1.5"
ROBOTLASER = ("ROBOTLASER1 0 -0.5 1.0 0.5 8.0 0.03 0 3 1.0 2.0 9.0 2 7 7 "
              "1.1 2.0 0.0 1.0 2.0 0.0 0 0 0 0 0 101.5 host 2.0")


def _write(path: Path, lines: list[str], *, gz: bool = False) -> Path:
    text = "\n".join(lines) + "\n"
    if gz:
        with gzip.open(path, "wt") as f:
            f.write(text)
    else:
        path.write_text(text)
    return path


# ---------------------------------------------------------------------------------------
# the reader
# ---------------------------------------------------------------------------------------


def test_every_record_type_is_read_with_its_fields(tmp_path: Path) -> None:
    p = _write(tmp_path / "a.log", ["# comment", "", PARAM, ODOM, FLASER, RLASER, RAWLASER,
                                    ROBOTLASER])
    log = CarmenLog(p)
    recs = list(log.records())
    assert [type(r).__name__ for r in recs] == ["Param", "Odom"] + ["Laser"] * 4
    param, odom, flaser, rlaser, raw, robot = recs
    assert isinstance(param, Param) and (param.name, param.value, param.stamp, param.line) == (
        "robot_front_laser_max", "4.0", 100.0, 3)
    assert isinstance(odom, Odom)
    assert (odom.x, odom.y, odom.theta, odom.tv, odom.rv, odom.accel) == (1, 2, 0.5, 0.3, 0.1, 0)
    assert (odom.stamp, odom.logger_stamp, odom.host, odom.line) == (100.25, 0.75, "host", 4)
    assert isinstance(flaser, Laser) and flaser.kind == "FLASER"
    assert flaser.ranges.tolist() == [1.0, 4.0, 2.5]
    assert flaser.laser_pose == (9, 9, 9) and flaser.robot_pose == (1, 2, 0.5)
    assert (flaser.stamp, flaser.logger_stamp, flaser.line) == (100.5, 1.0, 5)
    assert math.isnan(flaser.fov) and math.isnan(flaser.max_range)
    assert rlaser.kind == "RLASER" and rlaser.ranges.tolist() == [1.0, 1.0]
    assert (raw.kind, raw.start_angle, raw.fov, raw.angular_resolution, raw.max_range,
            raw.accuracy) == ("RAWLASER1", -1.5, 3.0, 1.5, 8.0, pytest.approx(0.02))
    assert raw.robot_pose is None and raw.stamp == 101.0 and raw.logger_stamp == 1.5
    assert robot.kind == "ROBOTLASER1" and robot.ranges.tolist() == [1.0, 2.0, 9.0]
    assert robot.laser_pose == (1.1, 2.0, 0.0) and robot.robot_pose == (1.0, 2.0, 0.0)
    assert robot.stamp == 101.5 and robot.logger_stamp == 2.0
    assert log.counts == {"PARAM": 1, "ODOM": 1, "FLASER": 1, "RLASER": 1, "RAWLASER1": 1,
                          "ROBOTLASER1": 1}
    assert not log.skipped


def test_scans_take_geometry_odometry_and_offset(tmp_path: Path) -> None:
    p = _write(tmp_path / "a.clf", [PARAM, "ODOM 0 0 0 0 0 0 100.0 host 0",
                                    FLASER, RAWLASER, ROBOTLASER,
                                    "ODOM 2 0 1.0 0 0 0 102.0 host 0"])
    flaser, raw, robot = CarmenLog(p).scans()
    # FLASER: 180 degrees end to end, max range from PARAM (4.0: the 4.0 reading is none)
    assert flaser.ranges.tolist() == [1.0, math.inf, 2.5]
    assert flaser.angle_min == pytest.approx(-math.pi / 2)
    assert flaser.angle_increment == pytest.approx(math.pi / 2)
    assert flaser.max_range == 4.0 and flaser.odom == (1.0, 2.0, 0.5)
    assert flaser.offset == (0.0, 0.0, 0.0)  # the line's own laser pose is not an offset
    # RAWLASER: no pose on the line: interpolated between the ODOM records at 100 and 102 s
    assert raw.odom == pytest.approx((1.0, 0.0, 0.5))
    assert raw.ranges.tolist() == [1.0, math.inf, 2.0]
    assert (raw.angle_min, raw.angle_increment, raw.max_range) == (-1.5, 1.5, 8.0)
    assert raw.range_noise == pytest.approx(0.02)
    # ROBOTLASER: offset = laser pose in the robot's frame
    assert robot.offset == pytest.approx((0.1, 0.0, 0.0))
    assert robot.odom == (1.0, 2.0, 0.0)
    # in file order, with the line each came from
    assert [s.kind for s in (flaser, raw, robot)] == ["FLASER", "RAWLASER1", "ROBOTLASER1"]
    assert [s.line for s in (flaser, raw, robot)] == [3, 4, 5]
    # odometry="odom": every scan's pose from the ODOM records
    odom = np.array([s.odom for s in CarmenLog(p).scans(odometry="odom")])
    assert odom == pytest.approx(np.array([(0.5, 0.0, 0.25), (1.0, 0.0, 0.5),
                                           (1.5, 0.0, 0.75)]))


def test_interpolation_turns_the_short_way_and_clamps_at_the_ends(tmp_path: Path) -> None:
    raw = "RAWLASER1 0 -1.5 3.0 1.5 8.0 0.02 0 1 1.0 0 {t} host 0"
    p = _write(tmp_path / "a.log", [raw.format(t=99), "ODOM 0 0 3.0 0 0 0 100 h 0",
                                    raw.format(t=101), "ODOM 0 0 -3.0 0 0 0 102 h 0",
                                    raw.format(t=103)])
    a, b, c = (s.odom for s in CarmenLog(p).scans())
    assert a == (0, 0, 3.0)  # before the first ODOM: the first
    assert b[2] == pytest.approx(math.pi) or b[2] == pytest.approx(-math.pi)  # not 0
    assert c == (0, 0, -3.0)  # after the last: the last


def test_rear_laser_and_parameters(tmp_path: Path) -> None:
    p = _write(tmp_path / "a.log", ["PARAM robot_rearlaser_offset -0.2 0 h 0",
                                    "PARAM laser_rear_laser_fov 90 0 h 0", FLASER, RLASER])
    (rear,) = CarmenLog(p).scans(laser="rear")
    assert rear.kind == "RLASER" and rear.offset == pytest.approx((-0.2, 0.0, math.pi))
    assert rear.angle_min == pytest.approx(-math.pi / 4)
    assert rear.max_range == 80.0
    bad = _write(tmp_path / "b.log", ["PARAM robot_front_laser_max far 0 h 0", FLASER])
    with pytest.raises(SequenceError, match=r"b.log: PARAM robot_front_laser_max"):
        list(CarmenLog(bad).scans())


def test_gzip_reads_the_same(tmp_path: Path) -> None:
    lines = [PARAM, ODOM, FLASER, RAWLASER, ROBOTLASER]
    plain = CarmenLog(_write(tmp_path / "a.clf", lines))
    packed = CarmenLog(_write(tmp_path / "a.clf.gz", lines, gz=True))
    a, b = list(plain.scans()), list(packed.scans())
    assert len(a) == len(b) == 3
    for x, y in zip(a, b):
        assert (x.stamp, x.odom, x.line) == (y.stamp, y.odom, y.line)
        assert x.ranges.tolist() == y.ranges.tolist()
    # recognised by content, not by the name
    assert len(list(CarmenLog(_write(tmp_path / "z.log", lines, gz=True)).records())) == 5
    assert is_carmen("a.clf.gz") and not is_carmen("a.bag")


@pytest.mark.parametrize("line, reason", [
    ("ODOM 1 2 3 0 0 0 100.0 host", "10"),                       # a field short
    ("ODOM 1 2 x 0 0 0 100.0 host 0", "could not convert"),       # not a number
    ("FLASER 3 1.0 2.0 0 0 0 0 0 0 100.0 host 0", "13"),          # a range short
    ("FLASER -1 0 0 0 0 0 0 100.0 host 0", "negative"),
    ("FLASER", "num_readings"),
    ("RAWLASER1 0 -1.5 3.0 1.5 8.0 0.02 0 3 1.0 8.0 2.0 0 101.0 host", "fields"),
    ("ROBOTLASER1 0 -0.5 1.0 0.5 8.0 0.03 0 3 1.0 2.0 9.0 5 7 101.5 host 2.0", "fields"),
    ("PARAM lonely", "value"),
    ("ODOM 1 nan 3 0 0 0 100.0 host 0", "not finite"),
    ("FLASER 1 1.0 0 0 0 0 0 0 inf host 0", "timestamp is not finite"),
])
def test_a_malformed_line_names_the_file_and_line(tmp_path: Path, line: str,
                                                  reason: str) -> None:
    p = _write(tmp_path / "bad.clf", [PARAM, ODOM, line, FLASER])
    kind = line.split()[0]
    with pytest.raises(SequenceError, match=rf"bad\.clf:3: malformed {kind} line .*{reason}"):
        list(CarmenLog(p).records())
    with pytest.raises(SlamqError):  # also through scans and the converter
        carmen_to_rawlog(p, tmp_path / "bad.rawlog")
    assert sorted(f.name for f in tmp_path.iterdir()) == ["bad.clf"]  # no half-written files


def test_a_truncated_gzip_log_names_the_file(tmp_path: Path) -> None:
    p = _write(tmp_path / "t.clf.gz", [FLASER] * 2000, gz=True)
    p.write_bytes(p.read_bytes()[:200])
    with pytest.raises(SequenceError, match=r"t\.clf\.gz:\d+: cannot read"):
        list(CarmenLog(p).records())


def test_an_endless_line_is_an_error_not_a_memory_hog(tmp_path: Path) -> None:
    p = tmp_path / "junk.log"
    p.write_bytes(b"FLASER 3 " + b"1.0 " * 400_000)  # 1.6 MB, no newline
    with pytest.raises(SequenceError, match=r"junk\.log:1: a line longer than"):
        list(CarmenLog(p).records())


def test_missing_or_not_a_file(tmp_path: Path) -> None:
    with pytest.raises(SequenceError, match=r"nope\.clf: cannot read"):
        CarmenLog(tmp_path / "nope.clf")
    with pytest.raises(SequenceError, match="is a directory"):
        CarmenLog(tmp_path)
    p = _write(tmp_path / "a.clf", [FLASER])
    with pytest.raises(SequenceError, match="laser must be"):
        CarmenLog(p).scans(laser="top").__next__()
    with pytest.raises(SequenceError, match="odometry must be"):
        CarmenLog(p).scans(odometry="gps").__next__()


def test_raw_scans_without_any_odom_record_are_an_error(tmp_path: Path) -> None:
    p = _write(tmp_path / "a.log", [RAWLASER])
    with pytest.raises(SequenceError, match=r"a\.log:1: a RAWLASER1 scan needs odometry"):
        list(CarmenLog(p).scans())


def test_unknown_records_are_skipped_and_counted(tmp_path: Path) -> None:
    p = _write(tmp_path / "a.log", ["SYNC 1 h 1", "TRUEPOS 0 0 0 0 0 0 1 h 1", FLASER,
                                    "SYNC 2 h 2", "NMEA-GGA whatever"])
    log = CarmenLog(p)
    assert len(list(log.records())) == 1
    assert log.skipped == {"SYNC": 2, "TRUEPOS": 1, "NMEA-GGA": 1}
    assert log.counts == {"FLASER": 1}


def test_no_scan_of_the_laser_is_an_error(tmp_path: Path) -> None:
    p = _write(tmp_path / "a.log", [PARAM, ODOM])
    with pytest.raises(SequenceError, match=r"a\.log: no front laser scans"):
        carmen_to_rawlog(p, tmp_path / "a.rawlog")
    assert sorted(f.name for f in tmp_path.iterdir()) == ["a.log"]


def _peak_bytes(log: CarmenLog) -> tuple[int, int]:
    """Scans read and the peak of memory allocated while reading them."""
    tracemalloc.start()
    n = sum(1 for _ in log.scans())
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return n, peak


def test_scans_stream_in_bounded_memory(tmp_path: Path) -> None:
    """Reading four times as many scans takes no more memory: the scans are handed out one
    at a time and none is kept (a list of the 1,600 scans would hold 1.2 MB of ranges)."""
    beams = " ".join(["1.5"] * 181)
    line = f"FLASER 181 {beams} 0 0 0 0 0 0 {{t:.6f}} h 0\nODOM 0 0 0 0 0 0 {{t:.6f}} h 0\n"
    peaks = []
    for n in (400, 1_600):
        p = tmp_path / f"big{n}.clf"
        with open(p, "w") as f:
            for i in range(n):
                f.write(line.format(t=1000 + i * 0.1))
        log = CarmenLog(p)
        assert next(log.scans()).stamp == 1000.0  # a stream: a scan before the file is read
        got, peak = _peak_bytes(log)
        assert got == n
        peaks.append(peak)
    assert peaks[1] < 1.2 * peaks[0] + 10_000, peaks
    assert peaks[1] < 500_000, peaks


def test_max_scans_cuts_the_head(tmp_path: Path) -> None:
    lines = [f"FLASER 1 1.0 0 0 0 {i} 0 0 {100 + i}.0 h 0" for i in range(10)]
    p = _write(tmp_path / "a.log", lines)
    assert [s.odom[0] for s in CarmenLog(p).scans(max_scans=3)] == [0, 1, 2]
    assert list(CarmenLog(p).scans(max_scans=0)) == []
    info = carmen_to_rawlog(p, tmp_path / "cut.rawlog", max_scans=4)
    assert (info["scans"], info["first"], info["last"]) == (4, 100.0, 103.0)


# ---------------------------------------------------------------------------------------
# the rawlog
# ---------------------------------------------------------------------------------------


def _read_rawlog(path: Path, label: str = "LASER") -> list[dict]:
    """Parse the rawlog this writer writes (fixed layout) back: per entry the action's and
    the scan's timestamps, the odometry increment, aperture, max range, sensor yaw, ranges
    and valid flags."""
    data = path.read_bytes()
    action_len = len(_action(np.zeros(3), 0, MOTION_MODEL))
    pose_len = len(_pose3d(0, 0, 0))
    inc_at = len(b"\x9cmrpt::obs::CActionCollection\x00") + 4 + len(
        b"\xa1mrpt::obs::CActionRobotMovement2D\x07") + 4 + len(b"\x94mrpt::poses::CPose2D\x01")
    out, i = [], 0
    while i < len(data):
        a = data[i:i + action_len]
        inc = struct.unpack_from("<3d", a, inc_at)
        t_action = struct.unpack_from("<Q", a, action_len - 10)[0]
        i += action_len
        j = i + len(_FRAME) + 4 + len(_SCAN)
        assert data[i:j] == _FRAME + struct.pack("<I", 1) + _SCAN
        aperture, right_to_left, max_range = struct.unpack_from("<f?f", data, j)
        j += 9
        rot = struct.unpack_from("<12d", data, j + pose_len - 1 - 96)
        yaw = math.atan2(rot[6], rot[3])
        j += pose_len
        (n,) = struct.unpack_from("<I", data, j)
        j += 4
        ranges = np.frombuffer(data, "<f4", n, j)
        valid = np.frombuffer(data, np.int8, n, j + 4 * n)
        j += 5 * n + 4
        (t_scan,) = struct.unpack_from("<Q", data, j)
        j += 8 + 4
        (k,) = struct.unpack_from("<I", data, j)
        assert data[j + 4:j + 4 + k] == label.encode()
        j += 4 + k + 9
        assert data[j:j + 2] == _END + _END
        i = j + 2
        out.append({"t_action": t_action, "t_scan": t_scan, "inc": inc, "aperture": aperture,
                    "right_to_left": right_to_left, "max_range": max_range, "yaw": yaw,
                    "ranges": ranges.copy(), "valid": valid.astype(bool)})
    return out


def test_rawlog_keeps_the_log_timestamps_and_odometry(tmp_path: Path) -> None:
    stamps = [976052857.337530, 976052857.348896, 976052857.342000, 976052858.0]  # 1 back
    lines = [PARAM]
    for k, t in enumerate(stamps):
        lines.append(f"FLASER 3 1.0 4.0 2.5 0 0 0 {0.5 * k} 0 {0.1 * k} {t:.6f} h 0.0")
    p = _write(tmp_path / "a.clf", lines)
    info = carmen_to_rawlog(p, tmp_path / "out" / "a.rawlog")
    entries = _read_rawlog(info["rawlog"])
    assert len(entries) == info["scans"] == 4
    want = [(round(t * 1e6) + 11_644_473_600_000_000) * 10 for t in stamps]
    assert [e["t_scan"] for e in entries] == [e["t_action"] for e in entries] == want
    assert [ticks(t) for t in stamps] == want
    # the file order is kept, the backward stamp too
    assert info["steps"].read_text().split() == [f"{t:.6f}" for t in stamps]
    # graphslam-engine's nodes: the first scan, then past 0.5 m of odometry (scan 2)
    assert info["nodes"].read_text().split() == ["976052857.337530", "976052857.342000"]
    # odometry increments in the earlier pose's frame
    assert entries[0]["inc"] == (0, 0, 0)
    dx, dy, dth = entries[1]["inc"]
    assert dth == pytest.approx(0.1)
    assert (dx, dy) == pytest.approx((0.5 * math.cos(0.0), 0.0))
    dx, dy, _ = entries[2]["inc"]
    assert (dx, dy) == pytest.approx((0.5 * math.cos(0.1), -0.5 * math.sin(0.1)))
    # the scan: 180 degrees counter-clockwise, no return as max_range with a zero flag
    e = entries[0]
    assert e["aperture"] == pytest.approx(math.pi) and e["right_to_left"]
    assert e["max_range"] == 4.0 and e["yaw"] == pytest.approx(0.0)
    assert e["ranges"].tolist() == [1.0, 4.0, 2.5]
    assert e["valid"].tolist() == [True, False, True]


def test_an_asymmetric_scan_turns_the_sensor_pose(tmp_path: Path) -> None:
    line = ("ROBOTLASER1 0 0.0 1.0 0.5 8.0 0.03 0 3 1.0 2.0 3.0 0 "
            "0 0 0.25 0 0 0 0 0 0 0 0 5.0 h 0")
    info = carmen_to_rawlog(_write(tmp_path / "a.log", [line]), tmp_path / "a.rawlog")
    (e,) = _read_rawlog(info["rawlog"])
    # beams at 0, 0.5, 1.0 rad; MRPT spreads them over [-0.5, 0.5]: the sensor turns by 0.5
    assert e["aperture"] == pytest.approx(1.0)
    assert e["yaw"] == pytest.approx(0.25 + 0.5)


def test_write_scans_rawlog_rejects_unknown_motion_keys(tmp_path: Path) -> None:
    with pytest.raises(SlamqError, match="unknown keys"):
        write_scans_rawlog([], tmp_path / "a.rawlog", motion_model={"b1": 1.0})


@pytest.mark.skipif(not shutil.which("rawlog-edit"), reason="rawlog-edit absent "
                                                             "(apt-get install mrpt-apps)")
def test_mrpt_reads_the_rawlog_with_the_log_timestamps(tmp_path: Path) -> None:
    lines = [f"FLASER 3 1.0 2.0 2.5 0 0 0 {0.1 * k} 0 0 {1134864629.895182 + 0.2 * k:.6f} h 0"
             for k in range(20)]
    info = carmen_to_rawlog(_write(tmp_path / "a.clf", lines), tmp_path / "a.rawlog")
    res = subprocess.run(["rawlog-edit", "--info", "-i", str(info["rawlog"])], check=True,
                         capture_output=True, text=True, stdin=subprocess.DEVNULL, timeout=60)
    assert re.search(r"Actions/SensoryFrame format\s*:\s*Yes", res.stdout)
    assert re.search(r"Earliest timestamp\s*:\s*1134864629\.895182", res.stdout)
    assert re.search(r"Latest timestamp\s*:\s*1134864633\.695182", res.stdout)
    listed = tmp_path / "ts.txt"
    subprocess.run(["rawlog-edit", "--list-timestamps", "-i", str(info["rawlog"]),
                    "--text-file-output", str(listed)], check=True, capture_output=True,
                   stdin=subprocess.DEVNULL, timeout=60)
    got = [row.split()[0] for row in listed.read_text().splitlines()]
    assert got == info["steps"].read_text().split()


# ---------------------------------------------------------------------------------------
# the real datasets (../shared/data/datasets2d)
# ---------------------------------------------------------------------------------------

needs_csail = pytest.mark.skipif(not CSAIL.exists(), reason=f"{CSAIL} absent (the datasets of "
                                 "../shared/data/datasets2d; set SLAMQ_SHARED_DATA)")


#: dataset -> (log, ODOM records, FLASER records, relation rows as the README says; the
#: first and last FLASER timestamps in file order)
REAL = {
    "intel": ("intel.from-rosbag.clf", 26_915, 13_631, 2_984,
              "976052857.337530", "976055548.624744"),
    "aces": ("aces.from-rosbag.clf", 7_375, 7_374, 1_279, "70.289900", "1435.809999"),
    "fr079": ("fr079.from-rosbag.clf", 8_951, 4_934, 1_685, "1211.520329", "2272.970282"),
}


@pytest.mark.parametrize("name", sorted(REAL))
def test_rebuilt_logs_counts_times_and_relations_on_laser_timestamps(name: str) -> None:
    """Record counts, first and last times, and every relation timestamp of the rebuilt
    logs is a laser timestamp, exactly."""
    log_name, n_odom, n_laser, n_rel, first, last = REAL[name]
    path = DATASETS / name / log_name
    if not path.exists():
        pytest.skip(f"{path} absent (the datasets of ../shared/data/datasets2d; "
                    "set SLAMQ_SHARED_DATA)")
    log = CarmenLog(path)
    stamps = np.array([r.stamp for r in log.records() if isinstance(r, Laser)])
    assert log.counts == {"ODOM": n_odom, "FLASER": n_laser}
    assert not log.skipped
    assert (f"{stamps[0]:.6f}", f"{stamps[-1]:.6f}") == (first, last)
    rel = np.loadtxt(path.parent / f"{name}.relations", usecols=(0, 1))
    assert len(rel) == n_rel
    assert np.isin(rel, stamps).all()


@needs_csail
def test_csail_relations_use_the_ipc_timestamp_not_the_logger_one() -> None:
    """The original CARMEN log: its logger timestamps count from the logger's start, and
    the relation stamps (5 decimals) fall on the ``timestamp`` column within 5 us."""
    ipc, logger = [], []
    log = CarmenLog(CSAIL)
    for r in log.records():
        assert isinstance(r, Laser)
        ipc.append(r.stamp)
        logger.append(r.logger_stamp)
    assert log.counts == {"FLASER": 1988}
    assert f"{ipc[0]:.6f}" == "1134864629.895182" and f"{ipc[-1]:.6f}" == "1134865053.892206"
    rel = np.unique(np.loadtxt(CSAIL.parent / "mit-csail.relations", usecols=(0, 1)))

    def nearest(stamps: list[float]) -> np.ndarray:
        s = np.sort(stamps)
        i = np.clip(np.searchsorted(s, rel), 1, len(s) - 1)
        return np.minimum(abs(s[i] - rel), abs(s[i - 1] - rel))

    assert nearest(ipc).max() <= 5e-6 + 1e-7  # 5 us and float64's rounding at 1.1e9 s
    assert nearest(logger).min() > 1e8


@needs_csail
def test_csail_rawlog_round_trip_keeps_every_timestamp(tmp_path: Path) -> None:
    info = carmen_to_rawlog(CSAIL, tmp_path / "csail.rawlog")
    entries = _read_rawlog(info["rawlog"])
    scans = list(CarmenLog(CSAIL).scans())
    assert len(entries) == len(scans) == 1988
    assert [e["t_scan"] for e in entries] == [ticks(s.stamp) for s in scans]
    assert info["steps"].read_text().split() == [f"{s.stamp:.6f}" for s in scans]
    assert entries[5]["ranges"].shape == (361,)
    assert entries[5]["aperture"] == pytest.approx(math.pi)


def _mrpt_config(template: Path, path: Path, overrides: dict[str, str]) -> Path:
    """An MRPT .ini from ``template`` with the ``key = value`` lines of ``overrides``
    replaced (each key is in the template once)."""
    ini = template.read_text()
    for key, value in overrides.items():
        ini, n = re.subn(rf"(?m)^(\s*{key}\s*=).*$", rf"\g<1>{value}", ini)
        assert n == 1, key
    path.write_text(ini)
    return path


def _run_mrpt(command: list[str], cwd: Path) -> None:
    start = time.monotonic()
    res = subprocess.run(command, capture_output=True, text=True, stdin=subprocess.DEVNULL,
                         timeout=120, cwd=cwd)
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
    assert time.monotonic() - start < 60


@pytest.mark.slow
@needs_csail
@pytest.mark.skipif(not shutil.which("icp-slam") or not ICP_INI.exists(),
                    reason="icp-slam absent (apt-get install mrpt-apps)")
def test_icp_slam_maps_a_cut_of_a_real_log(tmp_path: Path) -> None:
    """MRPT's icp-slam on the first 200 scans of MIT CSAIL (about 16 m of driving and a full
    turn): it reads the rawlog, builds a map and logs one pose per scan, which the steps
    sidecar puts back on the log's clock."""
    info = carmen_to_rawlog(CSAIL, tmp_path / "cut.rawlog", max_scans=200)
    assert info["scans"] == 200
    out = tmp_path / "out"
    ini = _mrpt_config(ICP_INI, tmp_path / "icp.ini", {
        "logOutput_dir": str(out), "SHOW_PROGRESS_3D_REAL_TIME": "0", "SAVE_3D_SCENE": "0",
        "CAMERA_3DSCENE_FOLLOWS_ROBOT": "0"})
    _run_mrpt(["icp-slam", str(ini), str(info["rawlog"])], tmp_path)
    grid = load_mrpt_grid(next(out.glob("_finalmaps_*COccupancyGridMap2D_00.png")))
    occupied = int(((grid.values < 100) & ~grid.unknown).sum())
    assert occupied > 500
    path = read_mrpt_path(out / "log_estimated_path.txt")
    assert len(path) == 200
    timed = apply_step_times(path, info["steps"])
    assert timed.timestamps[0] == pytest.approx(info["first"], abs=1e-6)
    assert timed.timestamps[-1] == pytest.approx(info["last"], abs=1e-6)
    xy = np.asarray(timed.positions)[:, :2]
    assert np.abs(np.diff(xy, axis=0)).sum() > 5  # it followed the robot


@pytest.mark.slow
@needs_csail
@pytest.mark.skipif(not shutil.which("rbpf-slam") or not RBPF_INI.exists(),
                    reason="rbpf-slam absent (apt-get install mrpt-apps)")
def test_rbpf_slam_logs_the_log_timestamps(tmp_path: Path) -> None:
    """rbpf-slam (5 particles) on the same cut: it needs the action + sensory-frame form,
    and the times in its pose log are the CARMEN log's own."""
    info = carmen_to_rawlog(CSAIL, tmp_path / "cut.rawlog", max_scans=200)
    out = tmp_path / "out"
    ini = _mrpt_config(RBPF_INI, tmp_path / "rbpf.ini", {
        "logOutput_dir": str(out), "sampleSize": "5", "SHOW_PROGRESS_IN_WINDOW": "0",
        "SAVE_3D_SCENE": "0", "LOG_FREQUENCY": "50"})
    _run_mrpt(["rbpf-slam", str(ini), str(info["rawlog"])], tmp_path)
    assert next(out.glob("finalMap_*COccupancyGridMap2D_00.png")).stat().st_size > 0
    logged = np.loadtxt(out / "log_estimated_path.txt", usecols=7)
    assert len(logged) == 200
    assert [f"{t:.6f}" for t in logged] == info["steps"].read_text().split()
