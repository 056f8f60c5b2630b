"""The Rust core's thread pools: adopted threads, every core, and forked children."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest
from conftest import slamq_env

pytestmark = pytest.mark.skipif(not hasattr(os, "fork"), reason="os.fork (POSIX)")


def _run(script: str) -> list[str]:
    proc = subprocess.run([sys.executable, "-W", "ignore", "-c", script], env=slamq_env(),
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return proc.stdout.split()


@pytest.mark.parametrize("adopted", [False, True])
def test_a_forked_child_evaluates_after_its_parent_did(adopted: bool) -> None:
    """A child forked after its parent evaluated maps (``multiprocessing``'s default start
    method on Linux) has none of the parent's pool threads: its calls with every core and
    with one thread make new pools instead of waiting for ever (they did), on a plain and on
    an adopted thread, and give the parent's numbers."""
    script = (
        "import os, numpy as np, slamq\n"
        "from slamq import _core\n"
        f"adopted = {adopted}\n"
        "if adopted:\n"
        "    assert _core.adopt_thread()\n"
        "img = np.full((60, 60), 254, np.uint8); img[10:40, 12:50] = 0; img[45:50, :] = 205\n"
        "want = [slamq.evaluate(img), slamq.evaluate(img, threads=1),\n"
        "        slamq.evaluate(img, threads=2)]\n"
        "pid = os.fork()\n"
        "if pid == 0:\n"
        "    got = [slamq.evaluate(img), slamq.evaluate(img, threads=1),\n"
        "           slamq.evaluate(img, threads=2)]\n"
        "    os._exit(0 if got == want else 3)\n"
        "_, status = os.waitpid(pid, 0)\n"
        "print(os.waitstatus_to_exitcode(status), want[0].corners)\n"
    )
    code, corners = _run(script)[-2:]
    assert code == "0" and int(corners) > 0
