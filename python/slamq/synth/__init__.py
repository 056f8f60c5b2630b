"""``slamq.synth``: data with a known truth.

Two kinds of it:

- :mod:`slamq.synth.damage`: map series with a made, known severity of damage (drift, wall
  doubling, rotation, specks; and superposed copies, smears and kinks for the defect
  detectors) drawn from a floor plan. The studies that use them (how each no-reference
  metric follows the severity, the defect detectors' precision and recall) are in the
  repository's studies/ folder, outside the package.
- Ground truth on demand: generated worlds, a planned drive through them, simulated laser
  and odometry, and the sensor logs real SLAM programs read, beside the exact map and path
  (:mod:`slamq.synth.recording` holds the sequence every part of it passes along):
  :func:`world` / :func:`load_world` (:mod:`~slamq.synth.worldgen`), :func:`drive`
  (:mod:`~slamq.synth.planner`), the laser and odometry (:mod:`~slamq.synth.sensors`,
  :data:`NOISE`), :func:`simulate` (:mod:`~slamq.synth.simulation`), and the ground-truth
  files :func:`write_truth` (:mod:`~slamq.synth.truth`).

The functions ``world``, ``drive`` and ``simulate`` live in modules of other names
(``worldgen``, ``planner``, ``simulation``), so that no name of the package is both a
function and a module.
"""

from __future__ import annotations

from slamq.synth.damage import DEGRADATIONS, SEVERITIES, degrade, floor_plan, series
from slamq.synth.planner import Drive, drive
from slamq.synth.recording import LaserSpec, Recording
from slamq.synth.sensors import NOISE, OdometryNoise
from slamq.synth.simulation import simulate
from slamq.synth.truth import load_sequence, save_sequence, visible_map, write_truth
from slamq.synth.worldgen import KINDS, load_world, save_world, world, worlds

__all__ = ["DEGRADATIONS", "KINDS", "NOISE", "SEVERITIES", "Drive", "LaserSpec",
           "OdometryNoise", "Recording", "degrade", "drive", "floor_plan", "load_sequence",
           "load_world", "save_sequence", "save_world", "series", "simulate", "visible_map",
           "world", "worlds", "write_truth"]
