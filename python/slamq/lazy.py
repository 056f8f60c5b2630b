"""Package attributes imported on first use (PEP 562), so that importing a package runs
only the modules a caller needs: ``slamq eval map.yaml`` executes the loader, the metric
and the table, not every reader and metric (tests/test_architecture.py lists the files).

>>> import types
>>> pkg = types.ModuleType("pkg")
>>> pkg.__getattr__, pkg.__dir__ = exports(pkg, {"sqrt": "math", "path": "os"})
>>> pkg.__getattr__("sqrt")(4.0)
2.0
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from typing import Any


def exports(package: Any, where: Mapping[str, str]
            ) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """The ``__getattr__`` and ``__dir__`` of a package whose public names live in the
    modules ``where[name]``. A name its module does not define (``"reference":
    "slamq.metrics.reference"``) is the module itself."""
    namespace = package if isinstance(package, dict) else vars(package)

    def __getattr__(name: str) -> Any:
        module = where.get(name)
        if module is None:
            raise AttributeError(f"module {namespace['__name__']!r} has no attribute {name!r}")
        mod = importlib.import_module(module)
        value = getattr(mod, name, mod)
        namespace[name] = value
        return value

    def __dir__() -> list[str]:
        return sorted(set(namespace) | set(where))

    return __getattr__, __dir__
