"""The studies' tests: the studies import each other and _common by name (as when run as
``python studies/NAME.py``), so studies/ goes first on ``sys.path``."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

STUDIES = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(STUDIES))

from _common import REPO, SHARED_DATA  # noqa: E402


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """The real-map corpus (:data:`_common.SHARED_DATA`), or skip when it is absent."""
    if not (SHARED_DATA / "maps").is_dir():
        pytest.skip(f"real-map corpus not found at {SHARED_DATA} (set SLAMQ_SHARED_DATA)")
    return SHARED_DATA


@pytest.fixture(scope="session")
def test_data() -> Path:
    """The small maps shipped in tests/data."""
    return REPO / "tests" / "data"
