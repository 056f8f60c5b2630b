"""Pictures of maps: RGB renders, frames aligned in world coordinates, animated GIFs.

Shared by ``slamq timeline`` and the report. Known cells are drawn by value (0 = black =
occupied, 255 = white = free), unknown cells mid grey (128), north up as every map is held.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Union

import numpy as np
from PIL import Image

from slamq.models import OccupancyMap

PathLike = Union[str, "os.PathLike[str]"]

__all__ = ["UNKNOWN_RGB", "render_map", "render_frames", "write_gif"]


#: Colour of unknown cells.
UNKNOWN_RGB = (128, 128, 128)


def _shrink(rgb: np.ndarray, scale: float) -> np.ndarray:
    """Resize an RGB array by ``scale`` <= 1 (box filter: thin walls fade, never vanish)."""
    if scale >= 1.0:
        return rgb
    h, w = rgb.shape[:2]
    size = (max(1, round(w * scale)), max(1, round(h * scale)))
    img = Image.fromarray(rgb).resize(size, Image.Resampling.BOX)
    return np.asarray(img)


def render_map(map: OccupancyMap, *, max_size: int | None = None) -> np.ndarray:
    """The map as an RGB image: grey by value, unknown cells mid grey, north up.

    Parameters
    ----------
    map : OccupancyMap
    max_size : int, optional
        Shrink (box filter, aspect kept) so that neither side exceeds this many pixels.
        Never enlarges.

    Returns
    -------
    numpy.ndarray
        ``(H, W, 3)`` uint8 (the map's shape unless shrunk).

    Examples
    --------
    >>> import numpy as np, slamq
    >>> from slamq.report.animation import render_map
    >>> m = slamq.OccupancyMap(np.array([[0, 254]], np.uint8), np.array([[False, True]]))
    >>> render_map(m).tolist()
    [[[0, 0, 0], [128, 128, 128]]]
    >>> render_map(slamq.OccupancyMap(np.zeros((40, 80), np.uint8),
    ...                               np.zeros((40, 80), bool)), max_size=20).shape
    (10, 20, 3)
    """
    if len(set(UNKNOWN_RGB)) == 1:  # grey: one channel set, then copied to three
        grey = np.repeat(np.where(map.unknown, np.uint8(UNKNOWN_RGB[0]),
                                  map.values)[:, :, None], 3, axis=2)
    else:
        grey = np.repeat(map.values[:, :, None], 3, axis=2)
        grey[map.unknown] = UNKNOWN_RGB
    if max_size is not None:
        if int(max_size) < 1:
            raise ValueError(f"max_size must be >= 1, got {max_size}")
        h, w = map.shape
        grey = _shrink(grey, min(1.0, int(max_size) / max(h, w)))
    return np.ascontiguousarray(grey, dtype=np.uint8)


def _aligned(maps: Sequence[OccupancyMap]) -> bool:
    """True when the maps share a resolution and have no yaw (world alignment is a shift)."""
    res = [m.resolution for m in maps]
    if any(r is None for r in res):
        return False
    r0 = float(res[0])  # type: ignore[arg-type]
    return all(abs(float(r) - r0) <= 1e-9 * r0 for r in res) and all(  # type: ignore[arg-type]
        abs(float(m.origin[2])) < 1e-9 for m in maps
    )


def render_frames(
    maps: Sequence[OccupancyMap],
    *,
    max_size: int | None = 512,
    renders: Sequence[np.ndarray] | None = None,
) -> list[np.ndarray]:
    """Equal-sized RGB frames of a sequence of maps (a map being built), one per map.

    When the maps share a resolution and have no yaw, each is placed at its world
    position on a canvas covering all of them (a growing gmapping/Cartographer map stays
    put); otherwise each is centred. Outside a map the canvas is unknown grey.

    Parameters
    ----------
    maps : sequence of OccupancyMap
        Only the geometry is used when ``renders`` is given: then anything with ``shape``,
        ``resolution`` and ``origin`` attributes will do.
    max_size : int, optional
        Longest canvas side in pixels (frames are shrunk to fit; never enlarged).
    renders : sequence of numpy.ndarray, optional
        Pre-rendered maps (``render_map(m, max_size=...)``, any scale <= 1); lets a caller
        keep only small renders of a long sequence in memory.

    Examples
    --------
    >>> import numpy as np, slamq
    >>> from slamq.report.animation import render_frames
    >>> small = slamq.OccupancyMap(np.zeros((2, 2), np.uint8), np.zeros((2, 2), bool), 1.0)
    >>> big = slamq.OccupancyMap(np.full((4, 6), 255, np.uint8), np.zeros((4, 6), bool), 1.0,
    ...                          (-2.0, 0.0, 0.0))
    >>> a, b = render_frames([small, big])
    >>> a.shape == b.shape == (4, 6, 3), a[3, 2].tolist(), a[0, 0].tolist()
    (True, [0, 0, 0], [128, 128, 128])
    """
    if not maps:
        return []
    if renders is not None and len(renders) != len(maps):
        raise ValueError(f"{len(renders)} renders for {len(maps)} maps")
    aligned = _aligned(maps)
    if aligned:
        res = float(maps[0].resolution)  # type: ignore[arg-type]
        # cell coordinates of each map's lower-left corner on a common grid
        xs = [m.origin[0] / res for m in maps]
        ys = [m.origin[1] / res for m in maps]
        x0 = min(xs)
        top = max(y + m.shape[0] for y, m in zip(ys, maps))
        width = max(x + m.shape[1] for x, m in zip(xs, maps)) - x0
        height = top - min(ys)
        cols = [x - x0 for x in xs]
        rows = [top - (y + m.shape[0]) for y, m in zip(ys, maps)]  # from the canvas top
    else:
        width = max(m.shape[1] for m in maps)
        height = max(m.shape[0] for m in maps)
        cols = [(width - m.shape[1]) / 2 for m in maps]
        rows = [(height - m.shape[0]) / 2 for m in maps]
    scale = 1.0 if max_size is None else min(1.0, int(max_size) / max(width, height))
    cw, ch = max(1, math.ceil(width * scale - 1e-9)), max(1, math.ceil(height * scale - 1e-9))
    frames = []
    for i, m in enumerate(maps):
        canvas = np.empty((ch, cw, 3), np.uint8)
        canvas[:] = UNKNOWN_RGB
        h, w = m.shape
        size = (max(1, round(w * scale)), max(1, round(h * scale)))
        rgb = renders[i] if renders is not None else render_map(m)
        if rgb.shape[1] != size[0] or rgb.shape[0] != size[1]:
            filt = Image.Resampling.BOX if rgb.shape[1] >= size[0] else Image.Resampling.NEAREST
            rgb = np.asarray(Image.fromarray(rgb).resize(size, filt))
        r0, c0 = int(round(rows[i] * scale)), int(round(cols[i] * scale))
        r0, c0 = min(max(r0, 0), ch - 1), min(max(c0, 0), cw - 1)
        hh, ww = min(rgb.shape[0], ch - r0), min(rgb.shape[1], cw - c0)
        canvas[r0 : r0 + hh, c0 : c0 + ww] = rgb[:hh, :ww]
        frames.append(canvas)
    return frames


def write_gif(
    frames: Sequence[np.ndarray], path: PathLike, *, duration_ms: int = 200, loop: int = 0
) -> Path:
    """Write RGB (or grey) frames as an animated GIF (pillow); returns the path.

    Frames of different sizes are padded (white, bottom/right) to the largest. As pillow
    does, consecutive identical frames are merged into one longer frame.

    Parameters
    ----------
    frames : sequence of numpy.ndarray
        ``(H, W, 3)`` or ``(H, W)`` uint8.
    path : path
        The ``.gif`` to write (parent folders are created).
    duration_ms : int, default 200
        Display time of each frame.
    loop : int, default 0
        0 loops forever.

    Examples
    --------
    >>> import numpy as np, tempfile, pathlib
    >>> from PIL import Image
    >>> from slamq.report.animation import write_gif
    >>> frames = [np.full((4, 4, 3), v, np.uint8) for v in (0, 128, 255)]
    >>> p = write_gif(frames, pathlib.Path(tempfile.mkdtemp()) / "a.gif")
    >>> Image.open(p).n_frames
    3
    """
    if not frames:
        raise ValueError("write_gif needs at least one frame")
    arrays = []
    for f in frames:
        a = np.asarray(f)
        if a.dtype != np.uint8 or a.ndim not in (2, 3) or (a.ndim == 3 and a.shape[2] != 3):
            raise ValueError(f"frames must be (H, W) or (H, W, 3) uint8, got {a.shape} {a.dtype}")
        arrays.append(np.repeat(a[:, :, None], 3, axis=2) if a.ndim == 2 else a)
    h = max(a.shape[0] for a in arrays)
    w = max(a.shape[1] for a in arrays)
    images = []
    for a in arrays:
        if a.shape[:2] != (h, w):
            pad = np.full((h, w, 3), 255, np.uint8)
            pad[: a.shape[0], : a.shape[1]] = a
            a = pad
        # fast octree quantisation rather than the adaptive (median cut) palette: map frames
        # have a few hundred colours, and it is much cheaper (benches/RESULTS.md)
        images.append(Image.fromarray(a).quantize(colors=256, method=Image.Quantize.FASTOCTREE))
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    images[0].save(
        out,
        save_all=True,
        append_images=images[1:],
        duration=int(duration_ms),
        loop=int(loop),
        optimize=False,
        disposal=1,
    )
    return out
