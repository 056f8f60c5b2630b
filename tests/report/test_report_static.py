"""The report's stylesheet is a file of the package (shipped in the wheel: maturin packs
every file under python/slamq) and every page inlines it."""

from __future__ import annotations

import shutil
import subprocess
from importlib import resources
from pathlib import Path

import pytest

from slamq.report.markup import page, stylesheet

REPO = Path(__file__).resolve().parents[2]


def test_the_stylesheet_is_package_data_and_inlined_in_every_page() -> None:
    css = resources.files("slamq.report").joinpath("static/report.css").read_text("utf-8")
    assert "main{" in css and ".layers" in css
    assert stylesheet() == css
    html = page("t", "<p>x</p>")
    assert f"<style>\n{css}</style>" in html


@pytest.mark.skipif(shutil.which("git") is None or not (REPO / ".git").exists(),
                    reason="needs the git checkout")
def test_the_stylesheet_is_tracked_so_the_wheel_ships_it() -> None:
    files = subprocess.run(["git", "ls-files", "python/slamq/report/static"], cwd=REPO,
                           capture_output=True, text=True, check=True).stdout.split()
    assert "python/slamq/report/static/report.css" in files
