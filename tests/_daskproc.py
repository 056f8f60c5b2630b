"""A real Dask cluster for tests: ``dask scheduler`` and ``dask worker`` processes on
127.0.0.1, each in its own session so that stopping one stops its whole process group."""

from __future__ import annotations

import json
import os
import shlex
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

from conftest import slamq_env

DASK = str(Path(sys.executable).with_name("dask"))


def available() -> bool:
    """Whether the ``dask`` command and dask.distributed are installed."""
    try:
        import distributed  # noqa: F401
    except ImportError:
        return False
    return Path(DASK).exists() or shutil.which("dask") is not None


def _start(args: list[str], log: Path, env: dict[str, str] | None = None,
           hide: Path | None = None) -> subprocess.Popen:
    cmd = [DASK, *args]
    if hide is not None:  # a private mount namespace where ``hide`` is an empty tmpfs
        cmd = ["unshare", "--mount", "--propagation", "private", "sh", "-c",
               f"mount -t tmpfs slamq-hidden {shlex.quote(str(hide))} && exec {shlex.join(cmd)}"]
    return subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=open(log, "w"),
                            stdin=subprocess.DEVNULL, start_new_session=True,
                            env=slamq_env(env))


def can_hide(folder: Path) -> bool:
    """Whether a process can be given its own mount namespace hiding ``folder`` (root)."""
    if not shutil.which("unshare"):
        return False
    p = subprocess.run(["unshare", "--mount", "--propagation", "private", "sh", "-c",
                        f"mount -t tmpfs slamq-hidden {shlex.quote(str(folder))}"],
                       capture_output=True, timeout=10)
    return p.returncode == 0


def stop(proc: subprocess.Popen, grace: float = 5.0) -> None:
    """SIGTERM the process group, SIGKILL it after ``grace`` seconds; reap the leader."""
    for sig, wait in ((signal.SIGTERM, grace), (signal.SIGKILL, 5.0)):
        try:
            os.killpg(proc.pid, sig)
        except ProcessLookupError:
            break
        end = time.monotonic() + wait
        while time.monotonic() < end:
            proc.poll()
            try:
                os.killpg(proc.pid, 0)
            except ProcessLookupError:
                break
            time.sleep(0.05)
        else:
            continue
        break
    try:
        proc.wait(timeout=5)
    except subprocess.TimeoutExpired:
        pass


class Cluster:
    """A scheduler and its workers; :meth:`close` stops every process group."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        folder.mkdir(parents=True, exist_ok=True)
        self.procs: list[subprocess.Popen] = []
        file = folder / "scheduler.json"
        self.scheduler = _start(["scheduler", "--host", "127.0.0.1", "--port", "0",
                                 "--no-dashboard", "--scheduler-file", str(file)],
                                folder / "scheduler.log")
        self.procs.append(self.scheduler)
        end = time.monotonic() + 60
        while not file.exists() or not file.read_text().strip():
            if time.monotonic() > end or self.scheduler.poll() is not None:
                self.close()
                raise RuntimeError((folder / "scheduler.log").read_text())
            time.sleep(0.05)
        self.address = json.loads(file.read_text())["address"]

    def add_worker(self, name: str, env: dict[str, str] | None = None,
                   resources: str | None = None, nthreads: int = 1,
                   hide: Path | None = None) -> subprocess.Popen:
        """Start a ``dask worker`` (one process; not seeing ``hide``); wait until the
        scheduler knows it."""
        args = ["worker", self.address, "--nworkers", "1", "--nthreads", str(nthreads),
                "--no-dashboard", "--host", "127.0.0.1", "--name", name]
        if resources:
            args += ["--resources", resources]
        env = dict(os.environ, **(env or {}))
        proc = _start(args, self.folder / f"{name}.log", env, hide)
        self.procs.append(proc)
        self.wait_workers(name)
        return proc

    def wait_workers(self, *names: str, timeout: float = 60) -> None:
        from distributed import Client

        with Client(self.address, timeout=30) as c:
            end = time.monotonic() + timeout
            while True:
                known = {w["name"] for w in c.scheduler_info(n_workers=-1)["workers"].values()}
                if set(names) <= {str(k) for k in known}:
                    return
                if time.monotonic() > end:
                    raise RuntimeError(f"workers {names} never joined (known: {known})")
                time.sleep(0.1)

    def close(self) -> None:
        for p in reversed(self.procs):
            stop(p)
