"""Every study runs as ``python studies/NAME.py`` (importing slamq as a library) and its
docstring examples print what they say; studies/README.md names every study."""

from __future__ import annotations

import doctest
import importlib
import subprocess
import sys
from pathlib import Path

import pytest

STUDIES = Path(__file__).resolve().parents[1]
SCRIPTS = sorted(p.stem for p in STUDIES.glob("*.py") if not p.name.startswith("_"))


def _env() -> dict[str, str]:
    import os

    import slamq

    env = dict(os.environ)
    root = str(Path(slamq.__file__).resolve().parent.parent)
    env["PYTHONPATH"] = os.pathsep.join([root, *filter(None, [env.get("PYTHONPATH")])])
    return env


def test_the_studies_are_the_ones_the_readme_lists() -> None:
    readme = (STUDIES / "README.md").read_text(encoding="utf-8")
    assert SCRIPTS == ["bag_carmen", "benchmark_study", "canonical_sweep", "confidence_study",
                       "corridor_travel_study", "damage_study", "defects_study",
                       "doubled_pairs_study",
                       "gmapping_run", "halves_study", "rbpf_path_study",
                       "real2d", "real2d_validity", "scans_study",
                       "shared_direction_study", "split_meet_study",
                       "split_scans", "support_grid_study",
                       "two_map_study", "uncomparable_study", "verdict_study",
                       "wall_symmetry"]
    assert all(f"python studies/{s}.py" in readme for s in SCRIPTS)


@pytest.mark.parametrize("name", SCRIPTS)
def test_each_study_runs_as_a_script(name: str) -> None:
    proc = subprocess.run([sys.executable, str(STUDIES / f"{name}.py"), "--help"],
                          capture_output=True, text=True, env=_env(), timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.startswith("usage:")


@pytest.mark.parametrize("name", ["_common", *SCRIPTS])
def test_docstring_examples(name: str, tmp_path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.failed == 0, f"{result.failed} of {result.attempted} examples failed in {name}"
