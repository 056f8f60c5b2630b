"""Type stubs of the Rust core (rust/src/python.rs). Use :func:`slamq.evaluate` instead:
it loads maps, checks parameters and turns these integers into a :class:`slamq.MapQuality`."""

from typing import TypedDict

import numpy as np
import numpy.typing as npt

__version__: str

class RawQuality(TypedDict):
    known: int
    occupied: int
    sum_darkness: int
    corners: int
    curve: list[int]

def evaluate(
    values: npt.NDArray[np.uint8],
    unknown: npt.NDArray[np.bool_],
    log_threshold: float = 0.1,
    min_dot_area: int = 5,
    harris_k: float = 0.04,
    harris_quality: float = 0.01,
    sweep_step: int = 1,
    min_area: int = 1,
    threads: int = 0,
) -> RawQuality: ...
def evaluate_many(
    maps: list[tuple[npt.NDArray[np.uint8], npt.NDArray[np.bool_]]],
    log_threshold: float = 0.1,
    min_dot_area: int = 5,
    harris_k: float = 0.04,
    harris_quality: float = 0.01,
    sweep_step: int = 1,
    min_area: int = 1,
    threads: int = 0,
) -> list[RawQuality]: ...
def otsu_table(
    values: npt.NDArray[np.uint8], unknown: npt.NDArray[np.bool_]
) -> list[int]: ...
