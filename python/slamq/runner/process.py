"""Child processes of the runner: each in its own session, stopped as a whole group.

:func:`start` launches a command in a new session (so its process group id is its pid and
the terminal's Ctrl-C does not reach it directly); :func:`stop_group` sends SIGINT, then
SIGTERM, then SIGKILL to the whole group, each after a grace period, until no process of
the group is left; :func:`wait` waits for the leader with a deadline and an optional stop
event, then stops the group, so no orphan of a run survives it. Wall time comes from a
monotonic clock; CPU time and peak RSS from ``os.wait4`` (the leader and the descendants
it waited for), taken by a small meter process that starts the command (see :data:`METER`).
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

__all__ = ["Child", "Exit", "Interrupts", "adopt_orphans", "group_alive", "interrupts_caught",
           "start", "stop_group", "wait"]

#: Poll interval while waiting (seconds).
POLL = 0.02

#: The meter: the group leader of every command. Linux keeps the high-water RSS of the
#: memory a process had before ``exec`` (a fork of this big Python process) in the
#: ``ru_maxrss`` of its ``wait4``, so a command started from here straight away would
#: report at least this process's RSS as its peak. The meter (a bare interpreter, about
#: 10 MB) spawns the command with default signal handling, ignores SIGINT/SIGTERM itself
#: (the command in its group gets them), waits for it and writes its rusage (user s,
#: system s, peak RSS kB) to the file it is given, then ends as the command ended.
METER = r"""
import os, signal, sys
out, argv = sys.argv[1], sys.argv[2:]
sigs = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP, signal.SIGQUIT, signal.SIGPIPE,
        signal.SIGXFSZ)
for s in sigs[:4]:
    signal.signal(s, signal.SIG_IGN)
try:
    pid = os.posix_spawnp(argv[0], argv, os.environ, setsigdef=sigs)
except OSError as e:
    sys.stderr.write("slamq: cannot start %s: %s\n" % (argv[0], e.strerror or e))
    sys.exit(127)
while True:
    try:
        _, status, ru = os.wait4(pid, 0)
        break
    except InterruptedError:
        continue
with open(out + ".tmp", "w") as f:
    f.write("%r %r %d\n" % (ru.ru_utime, ru.ru_stime, ru.ru_maxrss))
os.replace(out + ".tmp", out)
if os.WIFSIGNALED(status):
    sig = os.WTERMSIG(status)
    if sig in sigs:
        signal.signal(sig, signal.SIG_DFL)
    os.kill(os.getpid(), sig)
    sys.exit(128 + sig)
sys.exit(os.WEXITSTATUS(status))
"""


@dataclass
class Exit:
    """How a child ended.

    Attributes
    ----------
    returncode : int or None
        Exit status; ``-N`` when killed by signal N (like :mod:`subprocess`).
    timed_out, interrupted : bool
        Stopped by the runner because of the deadline, or of Ctrl-C / a stop request.
    wall, user_cpu, sys_cpu : float
        Seconds.
    max_rss_kb : int
        Peak resident set size (kB) of the leader or the largest descendant it waited for.
    stopped_with : str or None
        The last signal the runner needed (``"SIGINT"``, ``"SIGTERM"``, ``"SIGKILL"``).
    """

    returncode: int | None
    timed_out: bool = False
    interrupted: bool = False
    wall: float = 0.0
    user_cpu: float = 0.0
    sys_cpu: float = 0.0
    max_rss_kb: int = 0
    stopped_with: str | None = None


@dataclass
class Child:
    """A started command: its Popen, start time and rusage once reaped."""

    popen: subprocess.Popen
    started: float
    rusage: Any = None
    status: int | None = None
    meter: str | None = None

    @property
    def pid(self) -> int:
        return self.popen.pid

    def poll(self) -> int | None:
        """Reap the leader if it has ended (keeps its rusage); its return code or None."""
        if self.status is not None:
            return self.status
        try:
            pid, status, ru = os.wait4(self.pid, os.WNOHANG)
        except ChildProcessError:
            self.status = self.popen.returncode if self.popen.returncode is not None else -1
            return self.status
        if pid == 0:
            return None
        self.rusage = ru
        self.status = os.waitstatus_to_exitcode(status)
        self.popen.returncode = self.status
        return self.status


def start(
    argv: list[str] | str,
    *,
    cwd: Path,
    env: dict[str, str],
    stdout: IO[bytes] | int,
    stderr: IO[bytes] | int,
    shell: bool = False,
) -> Child:
    """Start a command in a new session (its own process group), stdin from /dev/null.

    Raises
    ------
    OSError
        The program cannot be started (not found, not executable, no resources).

    Examples
    --------
    >>> import pathlib, os, subprocess
    >>> c = start(["true"], cwd=pathlib.Path("."), env=dict(os.environ),
    ...           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    >>> wait(c, timeout=10).returncode
    0
    """
    args = ["/bin/sh", "-c", argv] if shell else [str(a) for a in argv]
    if isinstance(argv, str) and not shell:
        args = [argv]
    prog = args[0]
    found = (os.access(os.path.join(str(cwd), prog), os.X_OK) if "/" in prog
             else shutil.which(prog, path=env.get("PATH", os.defpath)) is not None)
    if not found:
        raise FileNotFoundError(2, "No such file or directory", prog)
    fd, meter = tempfile.mkstemp(prefix="slamq-rusage-")
    os.close(fd)
    os.unlink(meter)
    popen = subprocess.Popen(
        [sys.executable, "-S", "-E", "-c", METER, meter, *args], cwd=str(cwd), env=env,
        stdin=subprocess.DEVNULL, stdout=stdout, stderr=stderr, start_new_session=True,
    )
    return Child(popen, time.monotonic(), meter=meter)


def _metered(child: Child) -> tuple[float, float, int] | None:
    """The command's own rusage as the meter wrote it (None if the meter was killed)."""
    if child.meter is None:
        return None
    try:
        with open(child.meter) as f:
            u, s, rss = f.read().split()
        return float(u), float(s), int(rss)
    except (OSError, ValueError):
        return None
    finally:
        for p in (child.meter, child.meter + ".tmp"):
            try:
                os.unlink(p)
            except OSError:
                pass


#: ``prctl`` option (Linux >= 3.4): orphaned descendants are reparented to this process.
_PR_SET_CHILD_SUBREAPER = 36


def adopt_orphans() -> bool:
    """Make this process the reaper of its orphaned descendants (Linux); True if it took.

    A run's program may leave children behind (``sleep 60 &``, a ROS launch's nodes): when
    their parent ends they are reparented to init, and a stopped group's last members stay
    zombies until init reaps them. In a container, init may be slow to (this machine's
    took 1-2 s) or never do it (``slamq run`` itself as PID 1, as in a Kubernetes job):
    :func:`stop_group` then waited its whole SIGKILL grace for every stopped run, and the
    zombies piled up. As their reaper, this process reaps them itself as they end (see
    :func:`stop_group`). Called by the ``slamq run`` command for its own process; a program
    that calls the runner as a library keeps its own behaviour unless it calls this.

    Examples
    --------
    >>> adopt_orphans() in (True, False)
    True
    """
    if not sys.platform.startswith("linux"):
        return False
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        return int(libc.prctl(_PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0)) == 0
    except (OSError, AttributeError):
        return False


def _reap_group(pgid: int) -> None:
    """Reap the ended members of group ``pgid`` that are this process's children: the
    orphans it adopted (:func:`adopt_orphans`, or as PID 1). Never a Child's leader before
    :meth:`Child.poll` took its status (the caller's rule)."""
    while True:
        try:
            if os.waitid(os.P_PGID, pgid, os.WEXITED | os.WNOHANG) is None:
                return  # members left, none ended
        except (ChildProcessError, OSError):
            return  # no child of ours in the group


def group_alive(pgid: int) -> bool:
    """Whether any process (zombies included) is left in process group ``pgid``."""
    try:
        os.killpg(pgid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _signal_group(pgid: int, sig: int) -> None:
    try:
        os.killpg(pgid, sig)
    except (ProcessLookupError, PermissionError):
        pass


class Interrupts(threading.Event):
    """A stop request that a SIGINT or SIGTERM sets (:func:`interrupts_caught`).

    ``signals`` lists the signals that came; :meth:`is_set` is true once one came (or
    :meth:`set` was called). The handler only appends to ``signals``: it takes no lock (an
    ``Event.set`` there deadlocked when a second signal came while the first handler held
    the event's lock), and whoever reads :meth:`is_set`, in any thread, sees the signal at
    once: a run whose program died of the same signal (a batch scheduler signals every
    process of a job) must see the stop before it sees its program's end, or it is recorded
    as a crash and never run again."""

    def __init__(self) -> None:
        super().__init__()
        self.signals: list[int] = []

    def is_set(self) -> bool:
        return bool(self.signals) or super().is_set()


@contextmanager
def interrupts_caught() -> Iterator[Interrupts]:
    """While inside, a SIGINT or SIGTERM sets the :class:`Interrupts` yielded instead of
    raising.

    A Ctrl-C used to be a ``KeyboardInterrupt`` raised wherever the main thread was: in the
    middle of the thread pool starting a worker (that worker, untracked, was never waited
    for), or in the handler before it ignored the next one (the runs' own stopping then
    ended half-way). Noted, it is seen where the caller looks for it; the caller raises
    ``KeyboardInterrupt`` itself once its runs are stopped. Only handlers set in Python are
    replaced (a signal ignored, or left to its default, stays so); outside the main thread,
    where Python cannot set a handler, nothing changes.

    Examples
    --------
    >>> import os, signal
    >>> with interrupts_caught() as caught:
    ...     os.kill(os.getpid(), signal.SIGINT)
    ...     os.kill(os.getpid(), signal.SIGINT)
    >>> caught.signals, caught.is_set()
    ([2, 2], True)
    """
    caught = Interrupts()
    if threading.current_thread() is not threading.main_thread():
        yield caught
        return

    def handler(signum: int, frame: object) -> None:
        caught.signals.append(signum)

    old = {}
    for s in (signal.SIGINT, signal.SIGTERM):
        if callable(signal.getsignal(s)):
            old[s] = signal.signal(s, handler)
    try:
        yield caught
    finally:
        for s, previous in old.items():
            signal.signal(s, previous)


def stop_group(child: Child | int, grace: tuple[float, float] = (5.0, 5.0)) -> str | None:
    """Stop a whole process group: SIGINT, SIGTERM after ``grace[0]`` s, SIGKILL after
    ``grace[1]`` s more. Returns the last signal sent (None if the group was gone).

    ``child`` is a :class:`Child` (its leader is reaped here) or a bare process group id
    (a group this process did not start: only signalled). Members reparented elsewhere are
    waited for until they are gone (a zombie no one reaps is given up on after the SIGKILL
    grace).
    """
    pgid = child if isinstance(child, int) else child.pid

    def reap() -> None:
        if isinstance(child, int) or child.poll() is not None:
            _reap_group(pgid)  # adopted orphans: their zombies would keep the group alive

    last = None
    for sig, wait_s in ((signal.SIGINT, grace[0]), (signal.SIGTERM, grace[1]),
                        (signal.SIGKILL, max(grace[1], 2.0))):
        reap()
        if not group_alive(pgid):
            return last
        _signal_group(pgid, sig)
        last = signal.Signals(sig).name
        end = time.monotonic() + wait_s
        while time.monotonic() < end:
            reap()
            if not group_alive(pgid):
                return last
            time.sleep(POLL)
    reap()
    return last


def wait(
    child: Child,
    *,
    timeout: float | None,
    stop: threading.Event | None = None,
    grace: tuple[float, float] = (5.0, 5.0),
) -> Exit:
    """Wait for the leader until ``timeout`` seconds after its start or ``stop`` is set,
    then stop the rest of its group (always: a finished leader may leave children)."""
    deadline = None if timeout is None else child.started + timeout
    timed_out = interrupted = False
    stopped_with = None
    while child.poll() is None:
        if stop is not None and stop.is_set():
            interrupted = True
        elif deadline is not None and time.monotonic() >= deadline:
            timed_out = True
        if timed_out or interrupted:
            stopped_with = stop_group(child, grace)
            break
        time.sleep(POLL)
    wall = time.monotonic() - child.started
    leftover = stop_group(child, grace)  # orphans of a finished leader
    stopped_with = stopped_with or leftover
    if child.status is None:  # should not happen: stop_group reaps the leader
        child.popen.wait()
        child.status = child.popen.returncode
    ru = child.rusage
    own = _metered(child)  # else the meter's wait4 (its own peak RSS included)
    return Exit(
        returncode=child.status,
        timed_out=timed_out,
        interrupted=interrupted,
        wall=wall,
        user_cpu=own[0] if own else float(ru.ru_utime) if ru else 0.0,
        sys_cpu=own[1] if own else float(ru.ru_stime) if ru else 0.0,
        max_rss_kb=own[2] if own else int(ru.ru_maxrss) if ru else 0,
        stopped_with=stopped_with,
    )
