"""Shared test helpers: where the real-map corpus and the shipped fixtures are."""

from __future__ import annotations

import os
import signal
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
TEST_DATA = REPO / "tests" / "data"
#: ../shared/data beside the clone (CI puts it there); SLAMQ_SHARED_DATA overrides.
SHARED_DATA = Path(os.environ.get("SLAMQ_SHARED_DATA", REPO.parent / "shared" / "data"))


# Some tests send a Ctrl-C (SIGINT) to a `slamq run` they started. A shell starts a
# background job (`pytest ... &`, `nohup`) with SIGINT ignored, an ignored signal stays
# ignored in every child, and Python then never turns it into a KeyboardInterrupt: those
# tests timed out when the suite ran in the background. A handler (not SIG_IGN) here makes
# the children start with the default handling, as they do from a terminal or CI.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """The ../shared/data corpus, or skip when it is not beside the clone."""
    if not (SHARED_DATA / "maps").is_dir():
        pytest.skip(f"real-map corpus not found at {SHARED_DATA} (set SLAMQ_SHARED_DATA)")
    return SHARED_DATA


@pytest.fixture(scope="session")
def test_data() -> Path:
    """The small maps shipped in tests/data."""
    return TEST_DATA


def slamq_env(base: dict[str, str] | None = None) -> dict[str, str]:
    """An environment whose Python imports the same slamq as this test process (the source
    tree during development, site-packages in CI): for tests that start subprocesses."""
    import slamq

    root = str(Path(slamq.__file__).resolve().parent.parent)
    env = dict(os.environ if base is None else base)
    rest = [env["PYTHONPATH"]] if env.get("PYTHONPATH") else []
    env["PYTHONPATH"] = os.pathsep.join([root, *rest])
    return env


def comparison_tools_runs(shared: Path) -> list[tuple[str, str, Path, float]]:
    """The 15 runs of slam_comparison_tools in ../shared/data: ``(world, algorithm, map
    YAML, ATE RMSE)``, the ATE computed from the run's pose log (SLAM and ground-truth
    positions side by side, no alignment, as the repository reports it)."""
    import csv

    import numpy as np

    maps = shared / "maps" / "slam_comparison_tools" / "test_results"
    logs = shared / "trajectories" / "slam_comparison_tools"
    out = []
    for world in ("abstract", "office", "warehouse"):
        for y in sorted((maps / world).glob("*_map.yaml")):
            alg = y.name[: -len("_map.yaml")]
            with open(logs / world / f"{alg}_pose_log.csv") as fh:
                e = np.array([[float(r[k]) for k in ("slam_x", "slam_y", "gt_x", "gt_y")]
                              for r in csv.DictReader(fh)])
            ate = float(np.sqrt(np.mean(np.sum((e[:, :2] - e[:, 2:]) ** 2, axis=1))))
            out.append((world, alg, y, ate))
    return out
