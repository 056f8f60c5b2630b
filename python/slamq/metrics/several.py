"""Several maps of one place as a function's input (:func:`slamq.consensus`,
:func:`slamq.agreement`, :func:`slamq.register_many`): named, checked, in the order given."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from slamq.errors import ParamError
from slamq.models import OccupancyMap

__all__ = ["named_maps"]


def named_maps(maps: Mapping[str, OccupancyMap] | Sequence[OccupancyMap], what: str,
               least: int) -> dict[str, OccupancyMap]:
    """The maps by name (a sequence is named ``"0"``, ``"1"``...), checked.

    Parameters
    ----------
    maps : mapping of name to OccupancyMap, or sequence of OccupancyMap
    what : str
        The function's name, for the errors.
    least : int
        How many maps it needs at least.

    Returns
    -------
    dict of str to OccupancyMap

    Raises
    ------
    slamq.ParamError
        Fewer than ``least`` maps, or something that is not an OccupancyMap.

    Examples
    --------
    >>> import numpy as np
    >>> from slamq.models import OccupancyMap
    >>> m = OccupancyMap(np.full((3, 3), 254, np.uint8), np.zeros((3, 3), bool))
    >>> list(named_maps([m, m], "agreement", 2))
    ['0', '1']
    """
    named = (dict(maps) if isinstance(maps, Mapping)
             else {str(i): m for i, m in enumerate(maps)})
    if len(named) < least:
        raise ParamError(f"{what} needs at least {least} maps, got {len(named)}")
    loaded = {str(k): v for k, v in named.items()}
    for k, v in loaded.items():
        if not isinstance(v, OccupancyMap):
            raise ParamError(f"{what} takes OccupancyMaps, not {type(v).__name__} as {k!r}; "
                             f"slamq.{what} reads files and arrays")
    return loaded
