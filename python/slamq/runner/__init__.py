"""The SLAM runner: run algorithms x sequences x iterations x parameters, then score them.

* :mod:`slamq.runner.config`: the YAML configuration (:func:`load_config`).
* :mod:`slamq.runner.process`: each run in its own session; SIGINT, SIGTERM, SIGKILL to the
  group; wall/CPU time and peak RSS.
* :mod:`slamq.runner.runner`: run folders, outcomes, resume, parallel slots, ROS recipes,
  then scoring through :func:`slamq.evaluate_many`, :func:`slamq.summarize`, GIFs and
  :func:`slamq.report.build_report`.
* :mod:`slamq.runner.distributed`: each run as a task on a Dask cluster (``--scheduler``).
* :mod:`slamq.runner.shards`: array jobs without Dask (``--shard I/N``, ``--merge``).
* :mod:`slamq.runner.resources`: wall/CPU time, peak RSS and parameter values beside the
  scores (``scores.csv``, ``summary.csv``).

``slamq.run(config)`` is :func:`slamq.runner.runner.run`; a *run* is one execution of one
algorithm on one sequence (its folder, its row in ``runs.csv``).
"""

from __future__ import annotations

from slamq.runner.config import RunConfig, load_config
from slamq.runner.runner import execute, plan, run

__all__ = ["RunConfig", "execute", "load_config", "plan", "run"]

