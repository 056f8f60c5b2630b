"""Shared test helpers: where the real-map corpus and the shipped fixtures are."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
TEST_DATA = REPO / "tests" / "data"
#: ../shared/data beside the clone (CI puts it there); SLAMQ_SHARED_DATA overrides.
SHARED_DATA = Path(os.environ.get("SLAMQ_SHARED_DATA", REPO.parent / "shared" / "data"))


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
