"""The SLAM runner: run algorithms x sequences x iterations x parameters, then score them.

* :mod:`slamq.run.config`: the YAML configuration (:func:`load_config`).
* :mod:`slamq.run.process`: each run in its own session; SIGINT, SIGTERM, SIGKILL to the
  group; wall/CPU time and peak RSS.
* :mod:`slamq.run.runner`: run folders, outcomes, resume, parallel slots, ROS recipes,
  then scoring through :func:`slamq.evaluate_many`, :func:`slamq.summarize`, GIFs and
  :func:`slamq.report.build_report`.
* :mod:`slamq.run.distributed`: each run as a task on a Dask cluster (``--scheduler``).
* :mod:`slamq.run.shards`: array jobs without Dask (``--shard I/N``, ``--merge``).
* :mod:`slamq.run.resources`: wall/CPU time, peak RSS and parameter values beside the
  scores (``scores.csv``, ``summary.csv``).

The module itself is callable: ``slamq.run(config)`` is :func:`slamq.run.runner.run`.
"""

from __future__ import annotations

import sys
import types
from typing import Any

from slamq.run.config import RunConfig, load_config
from slamq.run.runner import execute, plan, run

__all__ = ["RunConfig", "execute", "load_config", "plan", "run"]


class _CallableModule(types.ModuleType):
    def __call__(self, config: Any, **kwargs: Any) -> dict[str, Any]:
        return run(config, **kwargs)


sys.modules[__name__].__class__ = _CallableModule
