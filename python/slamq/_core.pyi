"""Type stubs of the Rust core (rust/src/python.rs). Use :func:`slamq.evaluate` instead:
it loads maps, checks parameters and turns these integers into a :class:`slamq.MapQuality`.
tests/test_stubs.py checks these names and signatures against the built module."""

import numpy as np
import numpy.typing as npt

from slamq.params import Params

__version__: str

class RawQuality:
    """The integers of one evaluation (SPEC sections 2-4)."""

    @property
    def known(self) -> int: ...
    @property
    def occupied(self) -> int: ...
    @property
    def sum_darkness(self) -> int: ...
    @property
    def corners(self) -> int: ...
    @property
    def curve(self) -> list[int]: ...

def evaluate(
    values: npt.NDArray[np.uint8],
    unknown: npt.NDArray[np.bool_],
    params: Params,
    threads: int = 0,
) -> RawQuality: ...
def evaluate_many(
    maps: list[tuple[npt.NDArray[np.uint8], npt.NDArray[np.bool_]]],
    params: Params,
    threads: int = 0,
) -> list[RawQuality]: ...
def otsu_table(
    values: npt.NDArray[np.uint8], unknown: npt.NDArray[np.bool_]
) -> list[int]: ...
def default_params() -> dict[str, float | int]: ...

#: Peak working memory of one evaluation, bytes per cell (reserved before it starts;
#: ``MemoryError`` when it cannot be).
WORK_BYTES_PER_CELL: int
