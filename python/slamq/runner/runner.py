"""Run SLAM programs over sequences x iterations x parameter variants, then score them.

This module is the orchestrator: :func:`run` = :func:`execute` then :func:`score`. Follow
one run from the configuration to its score through the stages, each in its module:

1. :mod:`slamq.runner.config`: the YAML configuration, checked (:func:`load_config`).
2. :mod:`slamq.runner.planning`: the run list and each run's folder and key (:func:`plan`,
   :func:`run_key`), and which runs are finished already.
3. :mod:`slamq.runner.rendering`: each run's command, config file and environment.
4. :mod:`slamq.runner.execution`: the programs started, waited for and stopped
   (:mod:`slamq.runner.process`), each run's ``run.json``; on local slots, or on Dask
   (:mod:`slamq.runner.distributed`) or one shard of an array job
   (:mod:`slamq.runner.shards`).
5. :mod:`slamq.runner.collection`: each run's map, trajectory and snapshots found and
   checked; the run's outcome.
6. :mod:`slamq.runner.scoring`: the maps scored, the summary, GIFs and the report
   (:func:`score`), skipping what did not change (:mod:`slamq.runner.cache`).

Each run gets ``<output>/<algorithm>/<variant>/<sequence>/<iteration>/`` holding
``command.txt``, ``env.json``, ``stdout.log``, ``stderr.log``, the program's own folder
``out/``, the collected ``map.yaml`` (+ image), ``trajectory.tum``, ``snapshots/map_NNNN.yaml``
and ``building.gif``, and ``run.json`` (outcome, exit status, timings, peak RSS, run key),
written atomically last. Outcomes: ``ok``, ``timeout``, ``crash`` (non-zero exit or killed),
``no_output`` (a configured map/trajectory missing or unreadable), ``degenerate`` (no
occupied cell, or fewer than ``min_poses`` poses), ``infrastructure`` (could not start /
a ROS step never became ready, after ``retries``).

Resume: a run whose ``run.json`` holds the same run key (hash of algorithm, resolved
command, rendered config file, params, input content hash, iteration) is not run again;
``retry_failed=True`` reruns the ones that did not end ``ok``.

ROS recipes start their steps in order, each in its own session, waiting for each step's
readiness (a file under ``out/``, a topic listed by ``topic_command``, or a delay); the run
ends when the ``wait`` step ends, then after ``quiet_period`` seconds the other steps are
stopped (SIGINT, SIGTERM, SIGKILL), last started first. Each parallel slot has its own
``ROS_DOMAIN_ID`` (``ros_domain_base + slot``) and ``ROS_MASTER_URI`` port.
"""

from __future__ import annotations

from typing import Any

from slamq.runner.config import load_config
from slamq.runner.execution import OUTCOMES, recollect, run_local, run_row
from slamq.runner.planning import RunSpec, input_hash, pending, plan, prepare_inputs, run_key
from slamq.runner.rendering import render_config_file
from slamq.runner.scoring import need_report_extra, score

__all__ = ["OUTCOMES", "RunSpec", "execute", "input_hash", "plan", "render_config_file", "run",
           "run_key", "score"]


def execute(config: Any, *, retry_failed: bool = False, dry_run: bool = False,
            progress: Any = None, select: Any = None, backend: Any = None
            ) -> list[dict[str, Any]]:
    """Run (or skip, when finished before) every planned run; returns one row per run.

    Ctrl-C (KeyboardInterrupt in the calling thread) stops every running group (SIGINT,
    SIGTERM, SIGKILL) and is raised again; interrupted runs leave no ``run.json``.
    ``select`` (indices into :func:`plan`) keeps only those runs (a shard); ``backend``
    (``backend(config, keyed, rows, todo, progress)``, e.g. Dask) runs ``todo`` instead of
    the local slots (:func:`slamq.runner.execution.run_local`).
    """
    config = load_config(config)
    if not dry_run:
        prepare_inputs(config)
    specs = plan(config)
    if select is not None:
        specs = [specs[i] for i in select]
    keyed = [(s, *run_key(s, config)) for s in specs]
    rows, todo = pending(keyed, retry_failed)
    if dry_run:
        return [{**run_row(s, k, {"outcome": "planned"}, 0), "command": p["command"]}
                if rows[i] is None else rows[i]
                for i, (s, k, p) in enumerate(keyed)]
    for i, (spec, _key, _pieces) in enumerate(keyed):
        if rows[i] is not None:  # finished before: collected again if its outputs changed
            rows[i] = recollect(spec, rows[i], config)
    (backend or run_local)(config, keyed, rows, todo, progress)
    return [r for r in rows if r is not None]


def run(config: Any, *, retry_failed: bool = False, dry_run: bool = False,
        progress: Any = None, backend: Any = None) -> dict[str, Any]:
    """Run a configuration end to end: the runs, the scores, the summary, GIFs, the report.

    Parameters
    ----------
    config : path, dict or RunConfig
        See :mod:`slamq.runner.config`.
    retry_failed : bool
        Run again the finished runs whose outcome was not ``ok``.
    dry_run : bool
        Only plan: the rows say ``planned`` (or the stored outcome) with their commands.
    backend : callable, optional
        Where the runs go instead of the local slots (see :func:`execute`;
        :func:`slamq.runner.distributed.dask_backend`).

    Returns
    -------
    dict
        ``rows`` (one per run), ``results`` (the batch results file), ``summary``
        (DataFrame: mean ± std per algorithm[variant] and sequence, plus ``runs``, ``ok``,
        ``failure_rate``), ``gifs``, ``report`` (index.html or None), ``records`` (maps
        scored now), ``stages`` (per stage: ``done``, ``skipped``, ``message`` saying why;
        see :func:`score`).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp()); _ = (d / "in.txt").write_text("x")
    >>> r = run({"base_dir": str(d), "output": "o", "sequences": {"s": "in.txt"},
    ...          "algorithms": {"echo": {"command": ["echo", "{input}"]}}}, dry_run=True)
    >>> [row["outcome"] for row in r["rows"]]
    ['planned']
    """
    cfg = load_config(config)
    if cfg.report and not dry_run:
        need_report_extra(cfg)  # before the runs, not after hours of them
    rows = execute(cfg, retry_failed=retry_failed, dry_run=dry_run, progress=progress,
                   backend=backend)
    if dry_run:
        return {"rows": rows, "results": None, "summary": None, "gifs": [], "report": None}
    cfg.output.mkdir(parents=True, exist_ok=True)
    return {"rows": rows, **score(cfg, rows)}


