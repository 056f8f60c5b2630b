"""The one module that talks to the Rust core, ``slamq._core`` (rust/src/bindings/).

Every other module calls the core through these names, so that one file shows everything
Python asks of Rust (the typed signatures are in ``_core.pyi``):

* the map metrics (rust/src/bindings/maps.rs): :func:`evaluate`, :func:`evaluate_many`,
  :func:`otsu_table`, :func:`wall_harmonics`, :func:`default_params`,
  :data:`WORK_BYTES_PER_CELL`, :class:`RawQuality`;
* the loaders' fast paths (bindings/loading.rs): :func:`map_saver_shades`,
  :func:`read_table`, :func:`read_tum`;
* the trajectory passes (bindings/trajectory.rs): :func:`match_stamps`,
  :func:`ate_moments`, :func:`ate_errors`;
* the ground-truth comparison (bindings/comparison.rs): :func:`compare`,
  :class:`RawComparison`;
* the registration of maps of one place (bindings/registration.rs): :func:`register`,
  :func:`register_many`, :class:`RawRegistration`;
* the simulator's laser (bindings/synth.rs): :func:`raycast`;
* a map against its own scans, and scans that see walls in one direction only
  (bindings/scans.rs): :func:`scan_consistency`, :func:`scan_ratios`, and a trajectory
  against its own scans split in time: :func:`scan_split`;
* the runtime (bindings/runtime.rs): :func:`adopt_thread`.

It sits just above :mod:`slamq.errors` and :mod:`slamq.params`: importing it loads the
extension and nothing else of slamq.

>>> from slamq import native
>>> native.WORK_BYTES_PER_CELL
16
"""

from __future__ import annotations

from slamq._core import (
    WORK_BYTES_PER_CELL,
    RawComparison,
    RawQuality,
    RawRegistration,
    adopt_thread,
    ate_errors,
    ate_moments,
    compare,
    default_params,
    evaluate,
    evaluate_many,
    map_saver_shades,
    match_stamps,
    otsu_table,
    raycast,
    read_table,
    read_tum,
    register,
    register_many,
    scan_consistency,
    scan_ratios,
    scan_split,
    wall_harmonics,
)

__all__ = [
    "WORK_BYTES_PER_CELL",
    "RawComparison",
    "RawQuality",
    "RawRegistration",
    "adopt_thread",
    "ate_errors",
    "ate_moments",
    "compare",
    "default_params",
    "evaluate",
    "evaluate_many",
    "map_saver_shades",
    "match_stamps",
    "otsu_table",
    "raycast",
    "read_table",
    "read_tum",
    "register",
    "register_many",
    "scan_consistency",
    "scan_ratios",
    "scan_split",
    "wall_harmonics",
]
