"""The SLAM runner: run algorithms x sequences x iterations x parameters, then score them.

A run goes through these modules, in order (each module's docstring says what it takes and
gives):

* :mod:`slamq.runner.config`: the YAML configuration (:func:`load_config`).
* :mod:`slamq.runner.planning`: the run list, each run's folder and run key, resume.
* :mod:`slamq.runner.rendering`: each run's command, config file and environment.
* :mod:`slamq.runner.execution`: the programs started on parallel slots, timeouts, ROS
  recipes, ``run.json``; :mod:`slamq.runner.process` runs each in its own session
  (SIGINT, SIGTERM, SIGKILL to the group; wall/CPU time and peak RSS).
* :mod:`slamq.runner.collection`: each run's map, trajectory and snapshots; its outcome.
* :mod:`slamq.runner.scoring`: scores through :func:`slamq.evaluate_many`,
  :func:`slamq.summarize`, GIFs and :func:`slamq.report.build_report`, skipping what did
  not change (:mod:`slamq.runner.cache`); :mod:`slamq.runner.resources` puts wall/CPU
  time, peak RSS and parameter values beside the scores (``scores.csv``, ``summary.csv``).
* :mod:`slamq.runner.runner`: the orchestrator, :func:`run` = :func:`execute` (plan,
  render, execute, collect) then :func:`~slamq.runner.scoring.score`.
* :mod:`slamq.runner.distributed`: each run as a task on a Dask cluster (``--scheduler``).
* :mod:`slamq.runner.shards`: array jobs without Dask (``--shard I/N``, ``--merge``).

``slamq.run(config)`` is :func:`slamq.runner.runner.run`; a *run* is one execution of one
algorithm on one sequence (its folder, its row in ``runs.csv``).
"""

from __future__ import annotations

from slamq.runner.config import RunConfig, load_config
from slamq.runner.runner import execute, plan, run

__all__ = ["RunConfig", "execute", "load_config", "plan", "run"]

