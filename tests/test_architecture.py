"""The package's shape: data flows one way (no import cycle, nothing imports upward, the top
package included, imports by name strings included), one module talks to the Rust core,
metrics never read files, one table of parameters, and typed stubs that match the built
Rust module."""

from __future__ import annotations

import ast
import importlib
import inspect
import os
import pkgutil
from pathlib import Path

import pytest

import slamq
from slamq import _core

PACKAGE = Path(slamq.__file__).parent

#: The layers, bottom first; a module may import its own layer and the layers below it.
#: The top package (``slamq/__init__.py``) is above them all; no module imports it.
LAYERS = ("version", "lazy", "errors", "params", "columns", "native", "models", "sources",
          "synth", "metrics", "api", "results", "batch", "verdict", "report", "runner", "cli")
TOP = len(LAYERS)


def _modules() -> list[str]:
    names = ["slamq"]
    for info in pkgutil.walk_packages([str(PACKAGE)], prefix="slamq."):
        names.append(info.name)
    return sorted(n for n in names if n not in ("slamq.__main__", "slamq._core"))


MODULES = frozenset(_modules())


def _layer(module: str) -> int:
    if module == "slamq":
        return TOP
    parts = module.split(".")
    assert parts[1] in LAYERS, f"{module}: in no layer; add it to LAYERS"
    return LAYERS.index(parts[1])


def _tree(module: str) -> ast.Module:
    mod = importlib.import_module(module)
    return ast.parse(Path(inspect.getfile(mod)).read_text(encoding="utf-8"))


def _imports(module: str) -> set[str]:
    """Every slamq module ``module`` imports: named in an ``import`` statement (any depth:
    also the imports inside functions, which run later), or by a string that is a module's
    whole name (``importlib.import_module(name)``, the lazy-attribute tables)."""
    found: set[str] = set()
    for node in ast.walk(_tree(module)):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names if a.name.startswith("slamq"))
        elif isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("slamq"):
            # "from slamq.metrics import reference" imports the module slamq.metrics.reference
            # (and its package); "from slamq import native" imports slamq.native only
            names = {f"{node.module}.{a.name}" for a in node.names}
            found.update(names & MODULES)
            if node.module != "slamq" or not names <= MODULES:
                found.add(node.module)
        elif isinstance(node, ast.Constant) and isinstance(node.value, str):
            # a submodule's dotted name ("slamq" alone is the program's and the logger's)
            if "." in node.value and (node.value in MODULES or node.value == "slamq._core"):
                found.add(node.value)
    return found


def test_every_module_is_in_a_layer() -> None:
    for module in _modules():
        _layer(module)


def test_no_module_of_the_package_imports_the_top_package() -> None:
    assert [m for m in _modules() if "slamq" in _imports(m)] == []


def test_exactly_one_module_talks_to_the_rust_core() -> None:
    assert [m for m in _modules() if "slamq._core" in _imports(m)] == ["slamq.native"]


def test_metrics_take_models_and_never_read_files() -> None:
    """A metric works on OccupancyMap / Trajectory objects: no metric module imports a
    reader (slamq.api turns paths into models and calls the metric)."""
    reads = [(m, t) for m in _modules() if m.startswith("slamq.metrics")
             for t in _imports(m) if t.startswith("slamq.sources")]
    assert reads == []


def _reachable(module: str) -> set[str]:
    """Every slamq module ``module`` imports, directly or through other slamq modules."""
    seen: set[str] = set()
    todo = [module]
    while todo:
        m = todo.pop()
        for target in _imports(m):
            if target in MODULES and target not in seen:
                seen.add(target)
                todo.append(target)
    return seen


def test_slamq_verdict_does_not_import_the_report() -> None:
    """``slamq verdict`` judges with the verdict layer alone: nothing it imports, at any
    depth, is part of slamq.report."""
    reached = _reachable("slamq.cli.verdict")
    assert "slamq.verdict.maps" in reached  # the walk follows the command's imports
    assert sorted(m for m in reached if m == "slamq.report" or m.startswith("slamq.report.")
                  ) == []


def test_the_report_draws_and_never_reads_or_measures() -> None:
    """slamq.report draws what the verdict layer hands it: no report module imports a
    reader (slamq.sources) or a metric (slamq.metrics)."""
    found = [(m, t) for m in _modules() if m == "slamq.report" or m.startswith("slamq.report.")
             for t in _imports(m) if t.startswith(("slamq.sources", "slamq.metrics"))]
    assert found == []


def test_no_study_ships_in_the_package() -> None:
    """Studies, benchmark sets and retired rules live in studies/ (outside the wheel): no
    module of the package is a study, and none names a file of the real-map corpus."""
    import re

    assert [m for m in _modules() if re.search(r"stud(y|ies)", m)] == []
    corpus = re.compile(r"\.\./shared|shared/data|test_results/|SLAMQ_SHARED_DATA")
    found = []
    for module in _modules():
        tree = _tree(module)
        docstrings = {id(n.body[0].value) for n in ast.walk(tree)
                      if isinstance(n, (ast.Module, ast.FunctionDef, ast.ClassDef))
                      and n.body and isinstance(n.body[0], ast.Expr)
                      and isinstance(n.body[0].value, ast.Constant)}
        for node in ast.walk(tree):
            if isinstance(node, ast.Constant) and isinstance(node.value, str) and \
                    id(node) not in docstrings and corpus.search(node.value):
                found.append(f"{module}: {node.value[:60]!r}")
            elif isinstance(node, ast.BinOp) and isinstance(node.op, ast.Div) and \
                    re.search(r"'shared'\s*/\s*'data'", ast.unparse(node)):
                found.append(f"{module}: {ast.unparse(node)[:60]}")
    assert found == []


def test_no_study_name_or_retired_rule_in_the_sources() -> None:
    """What only a study used is gone from the package and the core (the previous
    registration search, ``legacy_search``, included)."""
    import re

    root = Path(__file__).resolve().parents[1]
    pattern = re.compile(r"verdict_study|defects_study|canonical_across_grids|legacy_search")
    hits = [str(f.relative_to(root))
            for folder, suffixes in ((root / "python" / "slamq", (".py", ".pyi")),
                                     (root / "rust" / "src", (".rs",)))
            for f in sorted(folder.rglob("*")) if f.suffix in suffixes
            and pattern.search(f.read_text(encoding="utf-8"))]
    assert hits == []


def test_the_version_is_written_once_and_agrees_with_the_packaging() -> None:
    import re

    root = Path(__file__).resolve().parents[1]
    pyproject = re.search(r'^version = "([^"]+)"', (root / "pyproject.toml").read_text(),
                          re.MULTILINE)
    cargo = re.search(r'^version = "([^"]+)"', (root / "Cargo.toml").read_text(), re.MULTILINE)
    assert pyproject and cargo
    assert slamq.__version__ == pyproject.group(1) == cargo.group(1) == _core.__version__


def test_nothing_imports_upward() -> None:
    upward = []
    for module in _modules():
        mine = _layer(module)
        for target in _imports(module):
            if target in MODULES and _layer(target) > mine:
                upward.append(f"{module} -> {target}")
    assert upward == []


def test_no_import_cycle() -> None:
    graph = {m: {t for t in _imports(m) if t in set(_modules())} for m in _modules()}
    # a package's __init__ re-exporting its own modules is not a cycle between layers
    for m, targets in graph.items():
        graph[m] = {t for t in targets if not t.startswith(m + ".")}
    state: dict[str, int] = {}
    cycles: list[list[str]] = []

    def visit(node: str, path: list[str]) -> None:
        state[node] = 1
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                cycles.append(path[path.index(nxt):] + [nxt] if nxt in path else [node, nxt])
            elif nxt not in state:
                visit(nxt, path + [nxt])
        state[node] = 2

    for m in sorted(graph):
        if m not in state:
            visit(m, [m])
    assert cycles == []


def test_no_import_error_guard_on_slamq_modules() -> None:
    guarded = []
    for module in _modules():
        mod = importlib.import_module(module)
        tree = ast.parse(Path(inspect.getfile(mod)).read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if not isinstance(node, ast.Try):
                continue
            catches = {ast.unparse(h.type) for h in node.handlers if h.type is not None}
            if not catches & {"ImportError", "ModuleNotFoundError"}:
                continue
            body = ast.unparse(ast.Module(body=node.body, type_ignores=[]))
            if "import slamq" in body or "from slamq" in body:
                guarded.append(module)
    assert guarded == []


#: Run in one fresh interpreter: it loads the heavy third-party packages (most of an
#: import's time), then forks a child per slamq module, which imports that module first and
#: alone. No slamq module is loaded before the fork, so each child sees slamq as a fresh
#: interpreter would; third-party modules are shared and cannot hide a cycle inside slamq.
_FORK_IMPORTS = """
import importlib, json, os, sys, traceback
for name in ("numpy", "pandas", "pyarrow", "pyarrow.parquet", "matplotlib", "yaml"):
    try:
        importlib.import_module(name)
    except ImportError:
        pass
assert not [m for m in sys.modules if m == "slamq" or m.startswith("slamq.")]
failed = []
for module in sys.argv[1:]:
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:
        os.close(r)
        try:
            importlib.import_module(module)
            code = 0
        except BaseException:
            os.write(w, traceback.format_exc()[-500:].encode())
            code = 1
        os._exit(code)
    os.close(w)
    with os.fdopen(r, "rb") as f:
        err = f.read().decode()
    if os.waitpid(pid, 0)[1] != 0:
        failed.append([module, err])
print(json.dumps(failed))
"""


@pytest.mark.skipif(not hasattr(os, "fork"), reason="the children are forked (POSIX)")
def test_every_module_imports_first_in_a_fresh_interpreter() -> None:
    """Each module imported first, alone: an import cycle would fail for some order."""
    import json
    import subprocess
    import sys

    from conftest import slamq_env

    modules = _modules()
    proc = subprocess.run([sys.executable, "-c", _FORK_IMPORTS, *modules], capture_output=True,
                          text=True, env=slamq_env(), timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert json.loads(proc.stdout) == []
    assert len(modules) > 80  # every module was tried, not an empty walk


def _stub_signatures() -> dict[str, ast.FunctionDef]:
    tree = ast.parse((PACKAGE / "_core.pyi").read_text(encoding="utf-8"))
    return {n.name: n for n in tree.body if isinstance(n, ast.FunctionDef)}


def test_stubs_name_exactly_the_functions_of_the_core() -> None:
    runtime = {n for n, v in vars(_core).items() if callable(v) and not isinstance(v, type)}
    assert set(_stub_signatures()) == runtime
    tree = ast.parse((PACKAGE / "_core.pyi").read_text(encoding="utf-8"))
    classes = {n.name for n in tree.body if isinstance(n, ast.ClassDef) and
               not n.name.startswith("_")}
    assert classes == {n for n, v in vars(_core).items() if isinstance(v, type)}


@pytest.mark.parametrize("name", sorted(_stub_signatures()))
def test_stub_parameters_match_the_core(name: str) -> None:
    stub = _stub_signatures()[name]
    args = stub.args.args
    defaults = [None] * (len(args) - len(stub.args.defaults)) + [
        ast.literal_eval(d) for d in stub.args.defaults]
    expected = [(a.arg, d) for a, d in zip(args, defaults)]
    sig = inspect.signature(getattr(_core, name))
    actual = [(p.name, None if p.default is inspect.Parameter.empty else p.default)
              for p in sig.parameters.values() if p.name != "py"]
    assert actual == expected


def test_raw_quality_fields_match_the_stub() -> None:
    tree = ast.parse((PACKAGE / "_core.pyi").read_text(encoding="utf-8"))
    cls = next(n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == "RawQuality")
    stub_fields = {n.name for n in cls.body if isinstance(n, ast.FunctionDef)}
    import numpy as np

    raw = _core.evaluate(np.zeros((3, 3), np.uint8), np.zeros((3, 3), bool), slamq.Params())
    assert stub_fields == {n for n in dir(raw) if not n.startswith("_")}


def test_every_cli_option_of_a_parameter_comes_from_the_table() -> None:
    from slamq.cli import build_parser
    from slamq.params import PARAM_NAMES

    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    for command in ("eval", "batch", "timeline"):
        options = {a.dest: a for a in sub.choices[command]._actions}
        for name in PARAM_NAMES:
            assert options[name].default == getattr(slamq.Params(), name)
            assert options[name].help.startswith(
                slamq.Params.__dataclass_fields__[name].metadata["help"][:20])


_TRACE = """
import importlib.util, os, sys, threading
root = os.path.dirname(importlib.util.find_spec("slamq").origin)
ran = {}
def hook(frame, event, arg):
    name = frame.f_code.co_filename
    if event == "call" and name.startswith(root + os.sep):
        ran.setdefault(os.path.relpath(name, root), None)
sys.setprofile(hook)
threading.setprofile(hook)
from slamq.cli import main
code = main(["eval", sys.argv[1]])
sys.setprofile(None)
assert code == 0, code
print("\\n".join(ran))
"""


def test_the_files_slamq_eval_runs_are_the_ones_the_readme_lists(test_data: Path) -> None:
    """A profiler hook records every Python file of slamq whose code runs (module bodies
    and functions) for ``slamq eval map.yaml``; the README's "What `slamq eval map.yaml`
    runs" names exactly these."""
    import re
    import subprocess
    import sys

    from conftest import slamq_env

    yaml = test_data / "slam_comparison_tools" / "test_results" / "office" / "gmapping_map.yaml"
    proc = subprocess.run([sys.executable, "-c", _TRACE, str(yaml)], capture_output=True,
                          text=True, env=slamq_env(), timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    ran = [line for line in proc.stdout.splitlines() if line.endswith(".py")]
    readme = (Path(__file__).resolve().parents[1] / "README.md").read_text(encoding="utf-8")
    section = readme.split("### What `slamq eval map.yaml` runs", 1)[1].split("In Rust", 1)[0]
    listed = {name.removeprefix("python/slamq/")
              for name in re.findall(r"`([\w/]+\.py)`", section) if not name.startswith("tests/")}
    assert sorted(ran) == sorted(listed)
    assert len(ran) == len(set(ran))
