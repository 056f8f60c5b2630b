"""Writers: a :class:`~slamq.synth.Sequence` as the files real SLAM programs read."""

from __future__ import annotations

from slamq.synth.writers.rawlog import EPOCH, write_rawlog

__all__ = ["EPOCH", "write_rawlog"]
