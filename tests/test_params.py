"""One parameter schema for every family (python/slamq/params.py): every default, choice
and range that slamq writes elsewhere (function signatures, option objects, CLI options,
the Rust core and its stubs) is the schema's."""

from __future__ import annotations

import argparse
import importlib
import inspect
import math
import pkgutil
from dataclasses import fields
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

import slamq
from slamq import _core
from slamq.params import SETTINGS, Params

#: Keyword names that are a schema row under another name, by the function's module (a
#: keyword ``align`` is the ATE, RPE or map comparison alignment depending on where it is).
ALIASES = {
    "ate_max_dt": "max_dt",
    "offset_2": "offset",
    "ate_align": "ate_align",
    "ate_unsorted": "unsorted",
    "gt_align": "compare_align",
    "gt_tolerance": "tolerance",
    "gt_max_distance": "max_distance",
}
#: Besides those, CLI options named otherwise than their row.
CLI_ALIASES = {**ALIASES, "format": "trajectory_format"}


#: Keywords named like a row that mean something else there: (module, keyword).
NOT_THE_ROW = {
    ("slamq.synth.writers.rawlog", "max_distance"),  # graph-SLAM node spacing, metres
}


def _row_of(func: Any, name: str) -> str | None:
    if (func.__module__, name) in NOT_THE_ROW:
        return None
    if name in ALIASES:
        return ALIASES[name]
    if name == "align":
        mod, qual = func.__module__, func.__qualname__
        if mod.endswith(("compare", "consensus")) or qual in ("compare", "consensus"):
            return "compare_align"
        if mod.endswith("agreement") or qual == "agreement":
            return "agreement_align"
        if qual.startswith("rpe"):
            return "rpe_align"
        if qual.startswith(("ate", "ate_runs")):
            return "ate_align"
        return None
    if name == "offset" and func.__module__ not in ("slamq.api", "slamq.metrics.ate",
                                                     "slamq.metrics.sync"):
        return None  # a pixel offset elsewhere (overlays)
    if name in SETTINGS and SETTINGS[name].family != "runtime":
        return name
    return None


def _functions() -> list[Any]:
    found = []
    names = ["slamq"] + [m.name for m in pkgutil.walk_packages(slamq.__path__, "slamq.")
                         if m.name not in ("slamq._core", "slamq.__main__")]
    for name in names:
        mod = importlib.import_module(name)
        for obj in vars(mod).values():
            if inspect.isclass(obj) and obj.__module__ == name:
                found.extend(v for v in vars(obj).values() if inspect.isfunction(v))
            elif inspect.isfunction(obj) and obj.__module__ == name:
                found.append(obj)
    return found


def test_every_keyword_of_the_schema_has_its_default() -> None:
    wrong, seen = [], set()
    for func in _functions():
        for p in inspect.signature(func).parameters.values():
            row = _row_of(func, p.name)
            if row is None or p.default is inspect.Parameter.empty:
                continue
            seen.add(row)
            if p.default != SETTINGS[row].default:
                wrong.append(f"{func.__module__}.{func.__qualname__}({p.name}={p.default!r})")
    assert wrong == []
    # the scan does find the keywords (the test would pass vacuously otherwise)
    assert {"max_dt", "offset", "ate_align", "rpe_align", "unsorted", "compare_align",
            "occupied_threshold", "quorum", "radius", "agreement_align", "min_support"} <= seen


def test_every_cli_option_of_the_schema_has_its_default_and_choices() -> None:
    from slamq.cli import build_parser

    sub = next(a for a in build_parser()._actions if a.dest == "command")
    checked = 0
    for command, parser in sub.choices.items():
        for action in parser._actions:
            row = {"align": {"ate": "ate_align", "rpe": "rpe_align", "batch": "ate_align",
                             "compare": "compare_align"}.get(command)}.get(action.dest)
            row = row or CLI_ALIASES.get(action.dest) or (
                action.dest if action.dest in SETTINGS else None)
            if row is None:
                continue
            s = SETTINGS[row]
            assert action.default == s.default, (command, action.dest)
            assert (tuple(action.choices) if action.choices else None) == s.choices
            assert action.help.startswith(s.help[:20].replace("%", "%%")), (command, action.dest)
            checked += 1
    assert checked >= 20


def test_the_core_compare_defaults_are_the_schema() -> None:
    """``_core.compare``'s keywords (and so _core.pyi, which test_architecture keeps equal
    to the core) default to the schema's rows."""
    sig = inspect.signature(_core.compare).parameters
    assert sig["tolerance"].default == SETTINGS.tolerance_cells.default
    assert sig["occupied_threshold"].default == SETTINGS.occupied_threshold.default
    assert sig["align"].default == SETTINGS.compare_align.default


def test_the_core_working_memory_is_the_one_python_reports() -> None:
    from slamq.metrics.evaluate import WORK_BYTES_PER_CELL

    assert WORK_BYTES_PER_CELL == _core.WORK_BYTES_PER_CELL


def _edges(f: Any) -> list[tuple[Any, bool]]:
    """Values at and just past the edges of a map parameter's range: (value, in range)."""
    low, high = f.metadata["low"], f.metadata["high"]
    out = []
    if f.type == "int":
        out += [(low, True), (low - 1, False), (high, True), (high + 1, False)]
    else:
        out += [(math.inf, False), (math.nan, False)]
        if low is not None:
            out += [(low, True), (math.nextafter(low, -math.inf), False)]
        if high is not None:
            out += [(high, True), (math.nextafter(high, math.inf), False)]
    return out


@pytest.mark.parametrize("name", [f.name for f in fields(Params)])
def test_the_core_takes_exactly_the_schema_range_of_each_map_parameter(name: str) -> None:
    f = Params.__dataclass_fields__[name]
    grid = (np.full((2, 2), 254, np.uint8), np.zeros((2, 2), bool))
    for value, ok in _edges(f):
        try:
            Params(**{name: value})
            python_ok = True
        except slamq.ParamError:
            python_ok = False
        raw = SimpleNamespace(**{**Params().to_dict(), name: value})
        try:
            _core.evaluate(*grid, raw, 1)
            core_ok = True
        except (ValueError, OverflowError, TypeError):
            core_ok = False
        assert (python_ok, core_ok) == (ok, ok), (name, value)


def test_a_cli_option_added_from_a_row_reads_its_type() -> None:
    p = argparse.ArgumentParser()
    SETTINGS.max_dt.add_option(p)
    SETTINGS.ate_align.add_option(p, "--align", dest="align")
    args = p.parse_args(["--max-dt", "0.5", "--align", "se3"])
    assert (args.max_dt, args.align) == (0.5, "se3")
    assert p.parse_args([]).max_dt == SETTINGS.max_dt.default


def test_the_simulator_presets_are_the_schema_choices() -> None:
    from slamq.synth import KINDS, NOISE

    assert tuple(KINDS) == SETTINGS.world_kind.choices
    assert tuple(NOISE) == SETTINGS.noise.choices
