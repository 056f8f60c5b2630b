"""Hostile inputs, built by each test itself (no committed bombs): the loader and the CLI
answer with one clear error naming the file, in bounded time and memory, never a hang."""

from __future__ import annotations

import os
import resource
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import slamq_env

import slamq
from slamq.errors import MapError, ParamError, TrajectoryError

#: The address-space limit of the subprocess tests: enough for Python, numpy and OpenCV,
#: far below what the hostile files would make a naive reader allocate.
LIMIT_BYTES = 2 << 30


def _limited() -> None:  # runs in the child before exec
    resource.setrlimit(resource.RLIMIT_AS, (LIMIT_BYTES, LIMIT_BYTES))


def _slamq(*args: str, timeout: float = 60, limit: bool = True) -> subprocess.CompletedProcess:
    """The real CLI under an address-space limit (unless ``limit`` is False: pyarrow's
    allocator reserves more address space than the limit) and a timeout."""
    return subprocess.run([sys.executable, "-m", "slamq", *args], capture_output=True,
                          text=True, env=slamq_env(), timeout=timeout,
                          preexec_fn=_limited if limit else None)


def _run_limited(script: str) -> list[str]:
    """A Python ``script`` in a child under the address-space limit and a timeout; the
    lines it printed, the last of which is its peak RSS (KiB): ``VmHWM`` of its own address
    space (``ru_maxrss`` would keep the high-water mark of the pytest process it was
    forked from, across exec)."""
    proc = subprocess.run([sys.executable, "-c", script + "\nprint([line.split()[1] for line in "
                           "open('/proc/self/status') if line.startswith('VmHWM:')][0])\n"],
                          capture_output=True, text=True, env=slamq_env(), timeout=120,
                          preexec_fn=_limited)
    assert proc.returncode == 0, proc.stderr
    return proc.stdout.splitlines()


def _load_limited(path: Path, error: str) -> tuple[str, int]:
    """``slamq.load_map(path)`` in a child under the address-space limit: the message of
    the ``slamq.<error>`` it raised, and the child's peak RSS in KiB."""
    msg, peak_kb = _run_limited("import slamq\n"
                                "try:\n"
                                f"    slamq.load_map({str(path)!r})\n"
                                f"except slamq.{error} as exc:\n"
                                "    print(exc)\n")
    return msg, int(peak_kb)


def _billion_laughs(levels: int = 12, width: int = 10) -> str:
    lines = ['a0: &a0 ["lol"]']
    for i in range(1, levels):
        lines.append(f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * width) + "]")
    return "\n".join(lines) + f"\nimage: m.pgm\nresolution: *a{levels - 1}\n"


def test_a_yaml_alias_bomb_is_refused_at_once(tmp_path: Path) -> None:
    bomb = tmp_path / "bomb.yaml"
    bomb.write_text(_billion_laughs())  # ~600 bytes; 10^11 strings when expanded
    assert bomb.stat().st_size < 1000
    (tmp_path / "m.pgm").write_bytes(b"P5 1 1 255 " + bytes([254]))
    with pytest.raises(MapError, match=r"bomb.yaml: YAML aliases \(\*a0\) are not allowed"):
        slamq.load_map(bomb)
    proc = _slamq("eval", str(bomb), timeout=30)
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2 and len(lines) == 1 and "bomb.yaml" in lines[0]
    # found in a folder, it is a map whose loading says why; the good map is still scored
    good = tmp_path / "good.pgm"
    good.write_bytes(b"P5 2 2 255\n" + bytes([0, 254, 254, 254]))
    proc = _slamq("eval", str(tmp_path), "--json", str(tmp_path / "r.json"), timeout=30)
    assert proc.returncode == 2 and "bomb.yaml: YAML aliases" in proc.stderr
    assert "good.pgm" in (tmp_path / "r.json").read_text()


def test_a_rejected_value_is_never_printed_whole(tmp_path: Path) -> None:
    (tmp_path / "m.pgm").write_bytes(b"P5 1 1 255 " + bytes([254]))
    y = tmp_path / "long.yaml"
    y.write_text("image: m.pgm\nmode: " + "x" * 200_000 + "\n")
    with pytest.raises(MapError) as err:
        slamq.load_map(y)
    assert len(str(err.value)) < 300 and "200002 chars" in str(err.value)


def test_special_files_as_trajectories_never_block(tmp_path: Path) -> None:
    fifo = tmp_path / "traj.txt"
    os.mkfifo(fifo)  # opening it for reading would block until a writer comes
    with pytest.raises(TrajectoryError, match="traj.txt: not a regular file"):
        slamq.load_trajectory(fifo)
    with pytest.raises(TrajectoryError, match="/dev/zero: not a regular file"):
        slamq.load_trajectory("/dev/zero")
    gt = tmp_path / "gt.txt"
    gt.write_text("0 0 0 0 0 0 0 1\n1 1 0 0 0 0 0 1\n")
    proc = _slamq("ate", str(gt), str(fifo), timeout=30)
    assert proc.returncode == 2 and "not a regular file" in proc.stderr


def test_a_bool_mask_whose_bytes_are_not_0_or_1_is_normalised() -> None:
    values = np.full((4, 4), 254, np.uint8)
    raw = np.zeros((4, 4), np.uint8)
    raw[0, :2] = 255  # uint8.view(bool) holding 255: undefined behaviour in a &[bool]
    grid = slamq.OccupancyMap(values, raw.view(bool))
    assert grid.unknown.view(np.uint8).max() == 1
    q = slamq.evaluate(grid)
    assert (q.known, q.unknown) == (14, 2)


@pytest.mark.parametrize("kwargs, reason", [
    ({"resolution": float("inf")}, "resolution must be finite"),
    ({"resolution": "x"}, "resolution must be a number"),
    ({"origin": "garbage"}, "origin must be"),
    ({"origin": (0.0, float("nan"), 0.0)}, "origin must be finite"),
])
def test_occupancy_map_metadata_is_checked(kwargs: dict, reason: str) -> None:
    with pytest.raises(MapError, match=reason):
        slamq.OccupancyMap(np.zeros((2, 2), np.uint8), np.zeros((2, 2), bool), **kwargs)


def test_a_nul_byte_in_a_path_is_a_map_error() -> None:
    with pytest.raises(MapError, match="cannot read"):
        slamq.load_map("map\0.yaml")


@pytest.mark.parametrize("threads", [2**63, 2**64, 10**6])
def test_absurd_thread_counts_are_parameter_errors(threads: int) -> None:
    with pytest.raises(ParamError, match="threads must be at most"):
        slamq.evaluate(np.zeros((3, 3), np.uint8), threads=threads)


def test_a_huge_parameter_is_a_parameter_error() -> None:
    with pytest.raises(ParamError, match="log_threshold must be finite"):
        slamq.evaluate(np.zeros((3, 3), np.uint8), log_threshold=10**400)


def _maps(folder: Path, n: int) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(0)
    for i in range(n):
        img = np.full((120, 120), 254, np.uint8)
        img[rng.random((120, 120)) < 0.05] = 0
        (folder / f"map{i}x.pgm").write_bytes(b"P5 120 120 255\n" + img.tobytes())
    return folder


@pytest.mark.parametrize("suffix", [".jsonl", ".parquet"])
def test_a_second_writer_of_a_results_file_is_refused_naming_the_first(
        tmp_path: Path, suffix: str) -> None:
    from slamq.results import ResultsFile, read_results

    maps = _maps(tmp_path / "maps", 12)
    out = tmp_path / f"r{suffix}"
    with ResultsFile(out):  # this process writes the file ...
        proc = _slamq("batch", str(maps), "--out", str(out), "-q", limit=False)  # ... not this
        assert proc.returncode == 2, proc.stderr
        assert f"pid {os.getpid()}" in proc.stderr and "another slamq process" in proc.stderr
    proc = _slamq("batch", str(maps), "--out", str(out), "-q", limit=False)
    assert proc.returncode == 0, proc.stderr
    assert len(read_results(out)) == 12


def test_two_batches_racing_on_one_file_lose_no_row(tmp_path: Path) -> None:
    from slamq.results import read_results

    maps = _maps(tmp_path / "maps", 60)
    out = tmp_path / "r.parquet"
    cmd = [sys.executable, "-m", "slamq", "batch", str(maps), "--out", str(out), "-q",
           "--threads", "1"]
    procs = [subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                              env=slamq_env()) for _ in range(2)]
    codes = sorted(p.wait(timeout=120) for p in procs)
    errs = [p.stderr.read() for p in procs]
    assert codes in ([0, 0], [0, 2]), errs  # the second waits its turn or is refused
    if codes == [0, 2]:
        assert any("another slamq process" in e for e in errs)
    df = read_results(out)
    assert len(df) == 60 and df["error"].isna().all()


def test_a_tampered_results_file_is_named_with_the_bad_column(tmp_path: Path) -> None:
    bad = tmp_path / "r.jsonl"
    bad.write_text('{"map": "a.pgm", "algorithm": "x", "sequence": "s", "run": "0", '
                   '"corners": "abc", "error": null}\n')
    proc = _slamq("summary", str(bad), limit=False)
    assert proc.returncode == 2
    assert "r.jsonl: not a slamq results file: column 'corners'" in proc.stderr


def test_summary_csv_cells_never_run_as_spreadsheet_formulas(tmp_path: Path) -> None:
    folder = tmp_path / "=cmd|' -C calc'!A0"  # a folder name anyone can choose
    folder.mkdir()
    (folder / "m.pgm").write_bytes(b"P5 2 2 255\n" + bytes([0, 254, 254, 254]))
    q = slamq.evaluate(folder / "m.pgm")
    rec = {"map": str(folder / "m.pgm"), "algorithm": "@SUM(1)", "sequence": folder.name,
           "run": "0", "corners": q.corners, "error": None}
    import json

    (tmp_path / "r.json").write_text(json.dumps([rec]))
    out = tmp_path / "s.csv"
    proc = _slamq("summary", str(tmp_path / "r.json"), "--csv", str(out), limit=False)
    assert proc.returncode == 0, proc.stderr
    text = out.read_text()
    assert "'@SUM(1)" in text and "'=cmd" in text
    assert not any(line.startswith(("=", "@", "+", "-")) for line in text.splitlines())


def _tiff_header(w: int, h: int) -> bytes:
    import struct

    entries = [(256, 4, 1, w), (257, 4, 1, h), (258, 3, 1, 8), (259, 3, 1, 8)]
    ifd = struct.pack("<H", len(entries)) + b"".join(
        struct.pack("<HHII", *e) for e in entries) + struct.pack("<I", 0)
    return b"II*\x00" + struct.pack("<I", 8) + ifd + bytes(64)


@pytest.mark.parametrize("name, data", [
    ("bomb.webp", b"RIFF" + (28).to_bytes(4, "little") + b"WEBPVP8X" + bytes(8)
     + (16383).to_bytes(3, "little") + (16383).to_bytes(3, "little") + bytes(6)),
    ("bomb.gif", b"GIF89a" + (16384).to_bytes(2, "little") + (16384).to_bytes(2, "little")
     + bytes(30)),
    ("bomb.bmp", b"BM" + bytes(16) + (20000).to_bytes(4, "little", signed=True)
     + (-20000).to_bytes(4, "little", signed=True) + bytes(40)),
    ("bomb.tiff", _tiff_header(20000, 20000)),
])
def test_image_headers_claiming_huge_maps_are_refused_before_decoding(
        tmp_path: Path, name: str, data: bytes) -> None:
    p = tmp_path / name
    p.write_bytes(data)
    assert p.stat().st_size < 200
    with pytest.raises(MapError, match=rf"{name}: corrupt \w+ or a decompression bomb"):
        slamq.load_map(p)
    if p.suffix != ".gif":  # slamq eval takes no .gif (report animations are GIFs)
        proc = _slamq("eval", str(p), timeout=30)  # under the address-space limit
        assert proc.returncode == 2 and "decompression bomb" in proc.stderr


@pytest.mark.parametrize("ext", [".webp", ".bmp", ".tiff", ".png"])
def test_real_images_of_those_formats_still_load(tmp_path: Path, ext: str) -> None:
    import cv2

    img = np.full((37, 53), 254, np.uint8)
    img[5:30, 10] = 0
    params = [cv2.IMWRITE_WEBP_QUALITY, 101] if ext == ".webp" else []  # 101: lossless
    ok, buf = cv2.imencode(ext, img, params)
    assert ok
    p = tmp_path / f"m{ext}"
    p.write_bytes(buf.tobytes())
    from slamq.sources.images import header_size

    size = header_size(p.read_bytes())
    assert size is None or size[1:] == (53, 37)
    assert np.array_equal(slamq.load_map(p).values, img)


@pytest.mark.parametrize(("shape", "trajectory_error", "map_error"), [
    ("zeros", "corrupt pbstream (field number 0)", "corrupt pbstream (field number 0)"),
    ("skipped", "a pbstream record inflates past 268435456 bytes",
     "a pbstream record inflates past 268435456 bytes"),
    ("declared", "corrupt pbstream (a field of 1073741824 bytes at byte 6 of its record runs "
     "past the record budget", "corrupt pbstream (a field of 1073741824 bytes at byte 6"),
    ("trajectories", "trajectory 0 has no nodes", "runs past the record budget of 268435456"),
])
def test_a_pbstream_record_that_inflates_to_1_gib_is_refused_in_bounded_memory(
        tmp_path: Path, shape: str, trajectory_error: str, map_error: str) -> None:
    # Records are inflated and parsed as a stream: only the fields a reader needs are kept
    # (nodes, poses, a grid's cells), so a bomb costs a few MiB of memory, never the 256 MiB
    # budget (542 MB when the record was inflated whole, then copied).
    from _pbencode import pbstream_bomb

    p = tmp_path / "bomb.pbstream"
    p.write_bytes(pbstream_bomb(shape))
    assert p.stat().st_size < 1100 * 1024
    out = _run_limited(
        "import slamq\n"
        "for load, error in ((slamq.load_trajectory, slamq.TrajectoryError),\n"
        "                    (slamq.load_map, slamq.MapError)):\n"
        "    try:\n"
        f"        load({str(p)!r})\n"
        "    except error as exc:\n"
        "        print(type(exc).__name__, exc)\n")
    (traj_msg, map_msg, peak_kb) = out
    assert traj_msg.startswith(f"TrajectoryError {p}: ") and trajectory_error in traj_msg
    assert map_msg.startswith(f"MapError {p}: ") and map_error in map_msg
    assert int(peak_kb) < 150 * 1024, f"peak RSS {int(peak_kb) // 1024} MiB"


@pytest.mark.parametrize("fmt", ["ros1", "sqlite3", "mcap"])
def test_a_bad_first_map_does_not_hide_a_good_last_one(tmp_path: Path, fmt: str) -> None:
    from _bagdata import BagWriter, bag_path, room_grid

    from slamq.errors import BagError
    from slamq.sources.bag_maps import read_bag_maps, read_last_map

    grid_type = "nav_msgs/msg/OccupancyGrid"
    bag = bag_path(tmp_path, fmt)
    with BagWriter(bag, fmt) as w:
        bad = w.grid(1.0, room_grid(size=10))
        bad.info.width = 999  # width*height no longer matches the data
        w.write("/map", grid_type, bad)
        w.write("/map", grid_type, w.grid(2.0, room_grid(size=20)))
    assert read_last_map(bag).shape == (28, 28)
    with pytest.raises(BagError, match=r"/map message 0: .*holds \d+ cells"):
        list(read_bag_maps(bag))


# ---------------------------------------------------------------------------------------
# Class 5: a map's hash and its numbers come from the same bytes
# ---------------------------------------------------------------------------------------


def _pgm(corner_squares: int) -> bytes:
    img = np.full((60, 60), 254, np.uint8)
    for k in range(corner_squares):
        img[5 + 12 * (k // 4): 9 + 12 * (k // 4), 5 + 12 * (k % 4): 9 + 12 * (k % 4)] = 0
    return b"P5 60 60 255\n" + img.tobytes()


def test_a_map_replaced_while_a_batch_reads_it_never_pairs_one_hash_with_other_numbers(
        tmp_path: Path) -> None:
    import hashlib
    import threading

    from slamq.batch.records import EvalOptions, evaluate_run
    from slamq.batch.runs import Run

    a, b = _pgm(1), _pgm(12)
    yml = (b"image: m.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: 0\n"
           b"occupied_thresh: 0.65\nfree_thresh: 0.196\n")
    expected = {}
    for data in (a, b):
        h = hashlib.sha1(len(yml).to_bytes(8, "little") + yml
                         + len(data).to_bytes(8, "little") + data, usedforsecurity=False)
        expected[h.hexdigest()] = slamq.evaluate(np.frombuffer(data[13:], np.uint8)
                                                 .reshape(60, 60)).corners
    assert len(set(expected.values())) == 2
    (tmp_path / "m.yaml").write_bytes(yml)
    target = tmp_path / "m.pgm"
    target.write_bytes(a)
    stop = threading.Event()

    def swap() -> None:  # replaces the image atomically, back and forth, as fast as it can
        i = 0
        while not stop.is_set():
            tmp = tmp_path / f"tmp{i % 2}.pgm"
            tmp.write_bytes(b if i % 2 else a)
            os.replace(tmp, target)
            i += 1

    writer = threading.Thread(target=swap)
    writer.start()
    try:
        recs = [evaluate_run(Run(tmp_path / "m.yaml", "x", "s"), EvalOptions())
                for _ in range(300)]
    finally:
        stop.set()
        writer.join()
    scored = [r for r in recs if r["error"] is None]
    assert len(scored) > 100, [r["error"] for r in recs[:5]]
    for r in scored:  # the numbers of the bytes that were hashed, every time
        assert expected[r["hash"]] == r["corners"], r
    assert {r["corners"] for r in scored} == set(expected.values())  # both were seen
    for r in recs:
        assert r["error"] is None or "m." in r["error"], r["error"]


def test_a_huge_image_is_refused_before_it_is_hashed(tmp_path: Path) -> None:
    import time

    big = tmp_path / "big.pgm"
    with big.open("wb") as fh:  # 12 GiB, sparse: nothing is written but the header
        fh.write(b"P5 100000 100000 255\n")
        fh.truncate(12 << 30)
    (tmp_path / "big.yaml").write_text("image: big.pgm\nresolution: 0.05\n")
    t0 = time.perf_counter()
    proc = _slamq("batch", str(tmp_path / "big.yaml"), "--out", str(tmp_path / "r.jsonl"),
                  "-q", limit=False)
    elapsed = time.perf_counter() - t0
    assert elapsed < 20, elapsed  # hashing 12 GiB took 32 s
    from slamq.results import read_results

    rec = read_results(tmp_path / "r.jsonl").iloc[0]
    assert "big.pgm" in rec["error"] and "too large for an image" in rec["error"]
    assert proc.returncode != 0 or rec["error"]


# ---------------------------------------------------------------------------------------
# Class 3: the core's working memory cannot be had -> one error, never an abort
# ---------------------------------------------------------------------------------------


def test_a_map_too_large_for_the_memory_limit_is_one_failed_row_not_an_abort(
        tmp_path: Path) -> None:
    import cv2

    from slamq.results import read_results

    maps = tmp_path / "maps"
    maps.mkdir()
    big = np.full((11000, 11000), 254, np.uint8)  # 121 Mcells: loads in the limit, but the
    big[100:200] = 0                                # core's 1.9 GB working set does not fit
    cv2.imwrite(str(maps / "big.png"), big)
    del big
    for i in range(3):
        cv2.imwrite(str(maps / f"good{i}.png"), np.pad(np.zeros((20, 20), np.uint8), 40,
                                                       constant_values=254))
    out = tmp_path / "r.jsonl"
    proc = _slamq("batch", str(maps), "--out", str(out), "-q", "--threads", "2")
    assert proc.returncode in (0, 2) and proc.returncode >= 0, proc.stderr  # no SIGABRT
    df = read_results(out).set_index("algorithm")
    assert len(df) == 4
    assert df.loc[["good0", "good1", "good2"], "error"].isna().all()
    assert df.loc[["good0", "good1", "good2"], "corners"].tolist() == [8, 8, 8]
    err = df.loc["big", "error"]
    assert "big.png" in err and "cannot reserve" in err and "11000 x 11000" in err, err


def test_an_evaluation_beyond_the_memory_limit_raises_out_of_memory_error() -> None:
    code = (
        "import numpy as np, slamq\n"
        "img = np.full((11000, 11000), 254, np.uint8)\n"
        "try:\n"
        "    slamq.evaluate(img)\n"
        "except slamq.OutOfMemoryError as exc:\n"
        "    assert isinstance(exc, MemoryError) and isinstance(exc, slamq.SlamqError)\n"
        "    print('caught:', exc)\n"
        "print(slamq.evaluate(img[:100, :100]).known)\n"  # the process goes on
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=slamq_env(), timeout=120, preexec_fn=_limited)
    assert proc.returncode == 0, proc.stderr
    assert "caught: <array>: cannot reserve 1847 MiB" in proc.stdout
    assert proc.stdout.splitlines()[-1] == "10000"
    import slamq._core as core
    from slamq.metrics.evaluate import WORK_BYTES_PER_CELL

    assert core.WORK_BYTES_PER_CELL == WORK_BYTES_PER_CELL


# ---------------------------------------------------------------------------------------
# Class 1: ASCII PNM samples are checked before numbers are made
# ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("size_kb", [100, 300])
def test_an_ascii_pgm_of_long_tokens_is_refused_in_bounded_memory(
        tmp_path: Path, size_kb: int) -> None:
    # one 50 KB sample among short ones: an array of fixed-width byte strings of every
    # sample made the 100 KB file allocate > 1 GB, the 300 KB one raised numpy MemoryError
    n = size_kb * 1024 // 4
    body = b"1 " * (n - 1) + b"9" * (size_kb * 1024 // 2)
    bomb = tmp_path / "bomb.pgm"
    bomb.write_bytes(f"P2\n{n} 1\n255\n".encode() + body + b"\n")
    msg, peak_kb = _load_limited(bomb, "MapError")
    assert msg == f"{bomb}: bad ASCII PGM: a sample is not a decimal number in 0..maxval"
    assert int(peak_kb) < 400 * 1024  # the interpreter, numpy and OpenCV take ~150 MB


def test_an_ascii_pgm_still_loads(tmp_path: Path) -> None:
    p = tmp_path / "a.pgm"
    p.write_bytes(b"P2\n# CREATOR: map_saver.cpp 0.050 m/pix\n3 2\n255\n0 205 254\n"
                  b"254\t254 # a comment\n\n0\n")
    m = slamq.load_map(p)
    assert m.values.tolist() == [[0, 205, 254], [254, 254, 0]]
    assert m.resolution == 0.05
    with pytest.raises(MapError, match="only 5 samples"):
        p.write_bytes(b"P2 3 2 255 0 205 254 254 254")
        slamq.load_map(p)
    with pytest.raises(MapError, match="not a decimal number"):
        p.write_bytes(b"P2 3 2 255 0 205 254 254 254 -1")
        slamq.load_map(p)


# ---------------------------------------------------------------------------------------
# Class 1: compressed bag chunks are inflated as a bounded stream first
# ---------------------------------------------------------------------------------------


def _bomb_bag(folder: Path, fmt: str, inflated: int) -> Path:
    """A real bag (rosbags' writer) with one map, whose compressed chunk has ``inflated``
    bytes of zeros appended as further bz2 streams / zstd frames, which bz2 and zstd inflate
    as part of the chunk: a few KB on disk."""
    import bz2

    from _bagdata import BagWriter, bag_path, room_grid
    from rosbags.rosbag2.storage_mcap import zstd

    bag = bag_path(folder, fmt)
    with BagWriter(bag, fmt, compressed=True) as w:
        if fmt == "ros1":
            owner, extra = w.writer, bz2.compress(bytes(1 << 20), 9) * (inflated >> 20)
        else:
            owner, extra = w.writer.storage, zstd.compress(bytes(1 << 20)) * (inflated >> 20)
        real = owner.compressor
        owner.compressor = lambda data: real(data) + extra
        w.write("/map", "nav_msgs/msg/OccupancyGrid", w.grid(1.0, room_grid(size=20)))
    return bag


@pytest.mark.parametrize("fmt", ["ros1", "mcap"])
def test_a_compressed_bag_chunk_bomb_is_refused_in_bounded_memory(
        tmp_path: Path, fmt: str) -> None:
    bomb = _bomb_bag(tmp_path, fmt, 3000 << 20)  # 3 GB of zeros in a 150 KB file
    size = sum(f.stat().st_size for f in ([bomb] if bomb.is_file() else bomb.rglob("*")))
    assert size < 300_000
    msg, peak_kb = _load_limited(bomb, "BagError")
    kind = "ROS1" if fmt == "ros1" else "MCAP"
    assert f": {kind} chunk at byte " in msg and "inflates to more than" in msg, msg
    assert "(corrupt, or a decompression bomb)" in msg and str(bomb) in msg
    assert int(peak_kb) < 400 * 1024


def test_a_chunk_declaring_more_than_the_budget_is_refused_before_inflating(
        tmp_path: Path) -> None:
    import struct

    from slamq.errors import BagError
    from slamq.sources.bagchunks import MAX_CHUNK_BYTES

    def field(k: bytes, v: bytes) -> bytes:
        return struct.pack("<I", len(k) + 1 + len(v)) + k + b"=" + v

    hdr = (field(b"op", b"\x05") + field(b"compression", b"bz2")
           + field(b"size", struct.pack("<I", 4_000_000_000)))
    bag = tmp_path / "claims.bag"
    bag.write_bytes(b"#ROSBAG V2.0\n" + struct.pack("<I", len(hdr)) + hdr
                    + struct.pack("<I", 4) + b"BZh9")
    with pytest.raises(BagError, match=f"declares 4000000000 bytes, more than the limit of "
                                       f"{MAX_CHUNK_BYTES}"):
        slamq.load_map(bag)


def _zstd_rosbag2(folder: Path, mode: str) -> Path:
    """A real ROS 2 sqlite3 bag (rosbags' writer) with one 20 x 20 map, compressed by
    rosbag2's ``message`` or ``file`` zstd mode."""
    from _bagdata import BagWriter, bag_path, room_grid
    from rosbags.rosbag2 import CompressionFormat, CompressionMode

    bag = bag_path(folder, "sqlite3")
    w = BagWriter(bag, "sqlite3")
    w.writer.set_compression(CompressionMode[mode.upper()], CompressionFormat.ZSTD)
    with w:
        w.write("/map", "nav_msgs/msg/OccupancyGrid", w.grid(1.0, room_grid(size=20)))
    return bag


def test_a_zstd_rosbag2_message_bomb_is_refused_in_bounded_memory(tmp_path: Path) -> None:
    import sqlite3

    from rosbags.rosbag2.storage_mcap import zstd

    bag = _zstd_rosbag2(tmp_path, "message")
    assert "compression_mode: message" in (bag / "metadata.yaml").read_text()
    (db,) = bag.glob("*.db3")
    extra = zstd.compress(bytes(1 << 20)) * 1100  # 1.1 GiB of zeros as further frames
    con = sqlite3.connect(db)
    with con:
        ((row_id, data),) = con.execute("SELECT id, data FROM messages").fetchall()
        con.execute("UPDATE messages SET data = ? WHERE id = ?", (data + extra, row_id))
    con.close()
    assert sum(f.stat().st_size for f in bag.iterdir()) < 300_000
    msg, peak_kb = _load_limited(bag, "BagError")
    assert msg.startswith(f"{db}: message 1 (zstd) inflates to more than "), msg
    assert "(corrupt, or a decompression bomb)" in msg
    assert int(peak_kb) < 400 * 1024


@pytest.mark.parametrize("mode", ["message", "file"])
def test_zstd_rosbag2_bags_still_load(tmp_path: Path, mode: str) -> None:
    bag = _zstd_rosbag2(tmp_path, mode)
    assert f"compression_mode: {mode}" in (bag / "metadata.yaml").read_text()
    assert slamq.load_map(bag).shape == (28, 28)


@pytest.mark.parametrize("fmt", ["ros1", "mcap"])
def test_compressed_bags_still_load(tmp_path: Path, fmt: str) -> None:
    from _bagdata import BagWriter, bag_path, room_grid

    bag = bag_path(tmp_path, fmt)
    with BagWriter(bag, fmt, compressed=True) as w:
        for t in range(3):
            w.write("/map", "nav_msgs/msg/OccupancyGrid", w.grid(1.0 + t, room_grid(size=60)))
    assert slamq.load_map(bag).shape == (68, 68)


# ---------------------------------------------------------------------------------------
# Class 10: a results file that cannot be written is named
# ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("suffix", [".jsonl", ".parquet"])
def test_a_full_disk_names_the_results_file(tmp_path: Path, suffix: str) -> None:
    import signal

    maps = _maps(tmp_path / "maps", 40)
    out = tmp_path / f"r{suffix}"

    def small_files() -> None:  # writes past 16 KB fail with EFBIG, as ENOSPC would
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (16 << 10, 16 << 10))

    proc = subprocess.run([sys.executable, "-m", "slamq", "batch", str(maps), "--out",
                           str(out), "-q", "--chunk-size", "4"], capture_output=True,
                          text=True, env=slamq_env(), timeout=120, preexec_fn=small_files)
    assert proc.returncode == 2, proc.stderr
    line = proc.stderr.strip().splitlines()[-1]  # (Parquet: the journal, or the compaction)
    named = [p for p in (out, Path(f"{out}.journal.jsonl"))
             if f"{p}: cannot write results:" in line and "File too large" in line]
    assert named, proc.stderr
    assert "Traceback" not in proc.stderr
    from slamq.results import read_results

    if suffix == ".jsonl":  # the rows written before the failure are kept
        assert 0 < len(read_results(out)) < 40


def test_pbstream_submaps_far_apart_are_painted_in_bounded_memory(tmp_path: Path) -> None:
    # two 6 x 5-cell submaps 1 km apart span 10^8 cells at 0.1 m: the map itself needs about
    # 4 bytes per cell; painting each submap over the whole span needed 40
    from _pbencode import FREE, graph, grid2d, submap, write

    cells = np.full((6, 5), FREE, np.int64)
    p = write(tmp_path, graph({0: (0, 0, 0), 1: (1000, 1000, 0)}),
              submap(0, 0, (0, 0, 0), grid2d(cells, (2.0, 1.0), (0, 0, 4, 5))),
              submap(0, 1, (0, 0, 0), grid2d(cells, (2.0, 1.0), (0, 0, 4, 5))))
    shape, peak_kb = _run_limited(f"import slamq\nm = slamq.load_map({str(p)!r})\n"
                                  "print(m.shape, m.known_count)")
    assert shape == "(10015, 10016) 60"  # 1000.5 x 1000.6 m, 5 cells of padding each side
    assert int(peak_kb) < 1536 * 1024
