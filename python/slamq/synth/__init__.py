"""``slamq.synth``: data with a known truth.

Two kinds of it:

- :mod:`slamq.synth.damage`: map series with a made, known severity of damage (drift, wall
  doubling, rotation, specks) drawn from a floor plan, and the study of how each
  no-reference metric follows the severity (``python -m slamq.synth``).
- Ground truth on demand: generated worlds, a planned drive through them, simulated laser
  and odometry, and the sensor logs real SLAM programs read, beside the exact map and path
  (:mod:`slamq.synth.sequence` holds the sequence every part of it passes along).
"""

from __future__ import annotations

from slamq.synth.damage import (
    DEGRADATIONS,
    SEVERITIES,
    degrade,
    floor_plan,
    records,
    series,
    study,
)
from slamq.synth.sequence import LaserSpec, Sequence

__all__ = ["DEGRADATIONS", "SEVERITIES", "LaserSpec", "Sequence", "degrade", "floor_plan",
           "records", "series", "study"]
