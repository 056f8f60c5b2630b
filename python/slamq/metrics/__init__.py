"""The metrics: map quality (the Rust core, and its OpenCV reference) and trajectory error.

Metrics take models (:class:`~slamq.OccupancyMap`, :class:`~slamq.Trajectory`) and never
read a file; :mod:`slamq.api` (``slamq.evaluate``, ``slamq.compare``, ...) turns paths and
arrays into models and calls them. They reach the Rust core through :mod:`slamq.native`.

- :func:`evaluate` (:mod:`slamq.metrics.evaluate`): the three map metrics of
  docs/spec.md sections 2-4, computed by the Rust core.
- :func:`compare` (:mod:`slamq.metrics.compare`): a map against a ground-truth map,
  docs/spec.md section 7, computed by the Rust core.
- :func:`consensus` (:mod:`slamq.metrics.consensus`, experimental): several maps of one
  place scored against the consensus of the others, without ground truth.
- :func:`~slamq.metrics.defects.detect_defects` (:mod:`slamq.metrics.defects`): named defects
  of one map (superposed copies, doubled walls, smears, fragments) with their places.
- :mod:`slamq.metrics.reference`: the same numbers, literally, with OpenCV (the definition).
- :func:`ate`, :func:`rpe`, :func:`ate_runs` (:mod:`slamq.metrics.ate`): trajectory error
  (docs/spec.md section 6) on :class:`~slamq.models.Trajectory` objects, with association
  (:mod:`~slamq.metrics.sync`) and alignment (:mod:`~slamq.metrics.align`).
"""

