"""Peak memory of refusing a ~1 MB ``.pbstream`` whose record inflates to 1 GiB.

Target (issue 27): refused at <= 150 MB peak RSS (was 542 MB). Four bombs (as in
``tests/hostile/test_hostile_inputs.py``): ``zeros`` (1 GiB of zero bytes), ``skipped``
(1,024 fields of 1 MiB that no reader keeps), ``declared`` (a pose graph declaring 1 GiB),
``trajectories`` (a 200 MiB pose graph of trajectories holding only unknown fields, then
824 MiB more). Each is read as a trajectory (``load_trajectory``) and as a map
(``load_map``) in a fresh child process, by this slamq and by the pbstream readers of
``--baseline REV`` (default ``3e957b6``, before issue 27; its two modules from ``git
show``, run with this build); the child's ``VmHWM`` (peak RSS) and CPU time are printed,
and ``none``: the child importing slamq and numpy only.

    PYTHONPATH=python python benches/bench_pbstream_bomb.py
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "tests"))

CHILD = """
import sys, time
kind, impl, path = sys.argv[1:4]
sys.path.insert(0, sys.argv[4])
import numpy, slamq
t = time.process_time()
try:
    if kind == 'trajectory':
        if impl == 'baseline':
            import base_pbstream
            base_pbstream.read_pbstream_trajectory(path)
        else:
            slamq.load_trajectory(path)
    elif kind == 'map':
        if impl == 'baseline':
            import base_pbstream_map
            base_pbstream_map.read_pbstream_map(path)
        else:
            slamq.load_map(path)
    print('loaded')
except Exception as exc:
    print(type(exc).__name__ + ': ' + str(exc).replace(path, 'FILE'))
print(time.process_time() - t)
print([x.split()[1] for x in open('/proc/self/status') if x.startswith('VmHWM:')][0])
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--baseline", default="3e957b6", help="git revision to compare with")
    args = ap.parse_args()
    from _pbencode import BOMB_SHAPES, pbstream_bomb

    work = Path(tempfile.mkdtemp(prefix="slamq-pbbomb-"))
    for name, rename in (("pbstream", "base_pbstream"), ("pbstream_map", "base_pbstream_map")):
        text = subprocess.run(["git", "-C", str(REPO), "show",
                               f"{args.baseline}:python/slamq/sources/{name}.py"],
                              check=True, capture_output=True, text=True).stdout
        text = text.replace("from slamq.sources.pbstream import", "from base_pbstream import")
        (work / f"{rename}.py").write_text(text)
    print(f"load {os.getloadavg()[0]:.1f}\n")
    print("| bomb | file | read as | slamq | peak RSS MiB | CPU s | answer |")
    print("|---|---|---|---|---|---|---|")
    for shape in BOMB_SHAPES:
        path = work / f"{shape}.pbstream"
        path.write_bytes(pbstream_bomb(shape))
        size = f"{path.stat().st_size / 1e6:.2f} MB"
        for kind in ("none", "trajectory", "map"):
            for impl in (("this",) if kind == "none" else (args.baseline, "this")):
                proc = subprocess.run([sys.executable, "-c", CHILD, kind,
                                       "baseline" if impl != "this" else impl, str(path),
                                       str(work)], capture_output=True, text=True)
                answer, cpu, peak = proc.stdout.splitlines()[-3:]
                print(f"| {shape} | {size} | {kind} | {impl} | {int(peak) / 1024:.1f} | "
                      f"{float(cpu):.2f} | {answer[:90]} |")
        path.unlink()


if __name__ == "__main__":
    main()
