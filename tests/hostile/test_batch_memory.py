"""Many maps: a batch's peak memory does not grow with the number of maps (issue 11).

The real CLI runs in a subprocess (under the address-space limit of the hostile tests when
it writes JSON Lines; pyarrow's allocator reserves more address space than that limit)
over two generated folders of tiny maps, and reports its own peak RSS. Before streaming
discovery, compact resume keys and a streamed Parquet compaction, the larger batch peaked
0.9 KB per extra map higher (JSON Lines) and 6 KB (Parquet); resuming 2 - 4 KB.
"""

from __future__ import annotations

import resource
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import slamq_env

pytestmark = pytest.mark.skipif(not Path("/proc/self/status").exists(),
                                reason="peak RSS read from /proc/self/status (Linux)")

#: Maps of the small and the large batch. The small batch is past the fixed-size buffers
#: (1,024-row Arrow batches and Parquet row groups, 1,024 unmerged key digests, the maps in
#: flight, allocator pools), which fill by 1,000 - 3,000 maps.
SMALL, LARGE = 1500, 4500
#: The growth allowed per extra map. JSON Lines measured 0.1 - 0.3 KB/map over this range
#: (a list of the runs alone was 1 KB/map, the resume records 2 KB/map). A Parquet batch's
#: peak (pyarrow and pandas loaded) varies by +-3 MiB from run to run, so its bound only
#: catches gross growth such as the 6 KB/map of the in-memory compaction; discovery and
#: resume keys are the same code for both formats and are held to the JSON Lines bound.
MAX_KB_PER_MAP = {"jsonl": 0.5, "parquet": 2.5}
LIMIT_BYTES = 2 << 30


def _limited() -> None:  # runs in the child before exec
    resource.setrlimit(resource.RLIMIT_AS, (LIMIT_BYTES, LIMIT_BYTES))


def _tiny_maps(root: Path, n: int) -> Path:
    """``n`` 20 x 20 PGM maps in a flat layout, 500 per sequence folder, named
    ``<algorithm>_map_<run>`` with runs below 100 (not numbered snapshots)."""
    for i in range(n):
        seq = root / f"seq{i // 500:02d}"
        seq.mkdir(parents=True, exist_ok=True)
        j = i % 500
        img = np.full((20, 20), 254, np.uint8)
        img[2 + i % 8 : 12 + i % 8, 5:15] = 0
        (seq / f"algo{j // 100}_map_{j % 100}.pgm").write_bytes(
            b"P5 20 20 255\n" + img.tobytes())
    return root


def _batch_peak_kb(src: Path, out: Path, limit: bool) -> int:
    """Run ``slamq batch SRC --out OUT`` in a fresh Python; its peak RSS in KiB.

    The child reads ``VmHWM`` of its own address space: ``getrusage``'s ``ru_maxrss`` keeps
    the high-water mark across fork and exec, so a child of a large pytest process would
    report the parent's size."""
    script = (
        "from slamq.cli import main\n"
        f"code = main(['batch', {str(src)!r}, '--out', {str(out)!r}, '-q', '--no-progress',"
        " '--threads', '2'])\n"
        "hwm = [l for l in open('/proc/self/status') if l.startswith('VmHWM:')]\n"
        "print(code, hwm[0].split()[1])\n"
    )
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          env=slamq_env(), timeout=120, preexec_fn=_limited if limit else None)
    assert proc.returncode == 0, proc.stderr[-2000:]
    code, peak = proc.stdout.split()[-2:]
    assert code == "0", proc.stderr[-2000:]
    return int(peak)


@pytest.mark.parametrize("fmt", ["jsonl", "parquet"])
def test_a_batch_peak_rss_is_flat_in_the_number_of_maps(tmp_path: Path, fmt: str) -> None:
    sizes = {"small": SMALL, "large": LARGE}
    limit = fmt == "jsonl"
    peaks: dict[tuple[str, str], int] = {}
    for name, n in sizes.items():
        src = _tiny_maps(tmp_path / name, n)
        out = tmp_path / f"{name}.{fmt}"
        peaks[("fresh", name)] = _batch_peak_kb(src, out, limit)
        # every map has its row: nothing was lost to save memory
        if fmt == "jsonl":
            assert len(out.read_text().splitlines()) == n
        else:
            import pyarrow.parquet as pq

            assert pq.read_metadata(out).num_rows == n
        # resuming (every map already in the file) reads the file's keys back; quick, so
        # for Parquet the lower of two runs (a single one varies by up to 5 MiB)
        peaks[("resume", name)] = min(_batch_peak_kb(src, out, limit)
                                      for _ in range(1 if fmt == "jsonl" else 2))
    for phase in ("fresh", "resume"):
        small, large = peaks[(phase, "small")], peaks[(phase, "large")]
        per_map = (large - small) * 1.024 / (LARGE - SMALL)  # KiB -> KB
        assert per_map < MAX_KB_PER_MAP[fmt], (
            f"{phase} {fmt} batch: peak RSS {small / 1024:.1f} MiB at {SMALL} maps, "
            f"{large / 1024:.1f} MiB at {LARGE}: {per_map:.2f} KB per map")
