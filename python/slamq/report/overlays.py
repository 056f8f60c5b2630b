"""Maps drawn for people: north up, corners ringed, counted enclosed areas coloured; also
as separate layers (the plain map, the regions) for the report's detail pages.

The corners and regions are the ones the metrics count
(:func:`slamq.verdict.exhibits.counted_marks`), so the picture shows exactly what the numbers
counted: one ring per counted corner (SPEC section 3) and one colour per enclosed free
region counted at the unknown value ``enclosed_unknown_value`` (SPEC section 4).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from PIL import Image, ImageDraw

from slamq.models import OccupancyMap
from slamq.verdict.exhibits import Marks

__all__ = ["CORNER_RGB", "REGION_PALETTE", "Overlay", "compact_image", "draw_overlay",
           "palette_image", "render_base"]

#: Ring colour of a marked corner (pure red; nothing else in an overlay uses it).
CORNER_RGB = (255, 0, 0)
#: Fill colours of enclosed regions (cycled); none is grey, red or white.
REGION_PALETTE: tuple[tuple[int, int, int], ...] = (
    (31, 119, 180), (44, 160, 44), (255, 127, 14), (148, 103, 189), (23, 190, 207),
    (188, 189, 34), (227, 119, 194), (140, 86, 75), (0, 90, 50), (90, 0, 160),
    (0, 160, 120), (200, 150, 0),
)
#: Unknown cells in the base image (mid grey), as slamq.report.animation.render_map draws them.
UNKNOWN_GREY = 128


@dataclass
class Overlay:
    """An annotated map image and what was drawn on it.

    Attributes
    ----------
    image : numpy.ndarray or None
        ``(h*scale, w*scale, 3)`` uint8 RGB, north up: the map cropped to its known cells
        (and a margin of :data:`CROP_MARGIN` cells), starting at cell ``offset``, with the
        rings and colours drawn on it (None when only the layers were drawn:
        ``draw_overlay(..., composite=False)``).
    scale : int
        Pixels per map cell.
    corners : numpy.ndarray
        ``(K, 2)`` float (row, col) centroids of the marked corners, in map cells.
    labels : numpy.ndarray
        ``(H, W)`` int32: 0 = not counted, 1..n = the coloured enclosed regions.
    unknown_value : int
        The unknown value ``u`` the regions were taken at.
    offset : tuple of int
        ``(row, col)`` of the map cell at the image's top-left corner.
    grey : numpy.ndarray
        ``(h*scale, w*scale)`` uint8: the same crop and scale without anything drawn on
        it, the map itself (grey: :attr:`plain` is it in RGB).
    region_index : numpy.ndarray
        ``(h*scale, w*scale)`` uint8: 0 outside the enclosed regions, else ``1 +`` the
        :data:`REGION_PALETTE` entry of the region's colour (:attr:`regions` in RGBA).
    alpha : float
        Opacity of the region colours.
    """

    image: np.ndarray | None
    scale: int
    corners: np.ndarray
    labels: np.ndarray
    unknown_value: int
    offset: tuple[int, int]
    grey: np.ndarray
    region_index: np.ndarray
    alpha: float = 0.65

    @property
    def cells(self) -> tuple[int, int]:
        """``(rows, cols)`` of map cells the image shows."""
        return self.grey.shape[0] // self.scale, self.grey.shape[1] // self.scale

    @property
    def n_corners(self) -> int:
        """Number of corner rings drawn."""
        return int(len(self.corners))

    @property
    def n_regions(self) -> int:
        """Number of enclosed regions coloured."""
        return int(self.labels.max()) if self.labels.size else 0

    @property
    def plain(self) -> np.ndarray:
        """``(h*scale, w*scale, 3)`` uint8 RGB: :attr:`grey`, the map itself."""
        return np.repeat(self.grey[:, :, None], 3, axis=2)

    @property
    def region_colours(self) -> list[tuple[int, int, int, int]]:
        """RGBA of each value of :attr:`region_index` (0: transparent)."""
        a = int(round(255 * self.alpha))
        return [(0, 0, 0, 0), *((r, g, b, a) for r, g, b in REGION_PALETTE)]

    @property
    def regions(self) -> np.ndarray:
        """``(h*scale, w*scale, 4)`` uint8 RGBA: the enclosed regions' colours, transparent
        elsewhere (a layer to put over :attr:`plain`)."""
        return np.asarray(self.region_colours, np.uint8)[self.region_index]

    def save(self, path: str, *, max_size: int | None = None, which: str = "image") -> None:
        """Write the image (or ``which="plain"`` / ``"regions"``) as PNG, shrunk to at
        most ``max_size`` pixels a side; the plain map as a grey PNG, the regions as a
        palette PNG (the same pixels, a fraction of the bytes and the time)."""
        if which == "plain":
            img = Image.fromarray(self.grey)
        elif which == "regions":
            img = palette_image(self.region_index, self.region_colours)
        else:
            if self.image is None:
                raise ValueError("no composite image: draw_overlay(..., composite=True)")
            img = compact_image(self.image)
        if max_size and max(img.size) > max_size:
            img.thumbnail((max_size, max_size), Image.Resampling.LANCZOS)
        img.save(path, optimize=False)


def palette_image(index: np.ndarray, colours: list[tuple[int, ...]]) -> Image.Image:
    """A palette image (``P``) of a ``(H, W)`` uint8 array of indices into ``colours``
    (RGB, or RGBA: each entry's opacity is kept, as a PNG's ``tRNS`` chunk).

    Examples
    --------
    >>> import numpy as np
    >>> img = palette_image(np.array([[0, 1]], np.uint8), [(0, 0, 0, 0), (9, 8, 7, 166)])
    >>> img.mode, np.asarray(img.convert("RGBA")).tolist()
    ('P', [[[0, 0, 0, 0], [9, 8, 7, 166]]])
    """
    index = np.ascontiguousarray(index, dtype=np.uint8)
    out = Image.frombytes("P", (index.shape[1], index.shape[0]), index.tobytes())
    out.putpalette([int(v) for c in colours for v in c[:3]])
    if colours and len(colours[0]) == 4:
        out.info["transparency"] = bytes(int(c[3]) for c in colours)
    return out


def compact_image(array: np.ndarray) -> Image.Image:
    """``array`` (uint8 grey, RGB or RGBA) as the PNG image of the fewest bytes per pixel
    that holds the same pixels: grey (``L``) when every pixel is grey, a palette (``P``,
    with each entry's opacity) when it has at most 256 colours, else as it is. A map and
    its layers, mostly a few colours, encode several times faster so (and smaller); a
    browser shows the same pixels.

    Examples
    --------
    >>> import numpy as np
    >>> rgba = np.zeros((2, 3, 4), np.uint8); rgba[0, 1] = (31, 119, 180, 166)
    >>> img = compact_image(rgba)
    >>> img.mode, np.array_equal(np.asarray(img.convert("RGBA")), rgba)
    ('P', True)
    >>> compact_image(np.full((2, 2, 3), 128, np.uint8)).mode
    'L'
    """
    a = np.ascontiguousarray(array, dtype=np.uint8)
    if a.ndim != 3 or a.shape[2] not in (3, 4):
        return Image.fromarray(a)
    if a.shape[2] == 3 and (a[:, :, 0] == a[:, :, 1]).all() and (
            a[:, :, 1] == a[:, :, 2]).all():
        return Image.fromarray(np.ascontiguousarray(a[:, :, 0]))
    img = Image.fromarray(a)
    colours = img.getcolors(256)
    if colours is None:
        return img
    # each pixel's colour packed into one integer, then its place in the sorted palette
    table = sorted(_pack(c) for _, c in colours)
    if a.shape[2] == 4:
        keys = a.view("<u4")[:, :, 0]
    else:
        keys = (a[:, :, 0].astype(np.uint32) | (a[:, :, 1].astype(np.uint32) << 8)
                | (a[:, :, 2].astype(np.uint32) << 16))
    index = np.searchsorted(np.asarray(table, np.uint32), keys).astype(np.uint8)
    return palette_image(index, [tuple((k >> (8 * i)) & 255 for i in range(a.shape[2]))
                                 for k in table])


def _pack(colour: tuple[int, ...]) -> int:
    """An RGB(A) colour as one integer, red in the lowest byte (a little-endian RGBA
    pixel read as uint32)."""
    return sum(int(v) << (8 * i) for i, v in enumerate(colour))


def render_base(grid: OccupancyMap) -> np.ndarray:
    """The map as RGB: known cells by value (0 black = occupied), unknown mid grey.

    Uses :func:`slamq.report.animation.render_map` when that module is present, so that the
    report and the animations look alike.

    Examples
    --------
    >>> import numpy as np, slamq
    >>> m = slamq.OccupancyMap(np.array([[0, 254]], np.uint8), np.array([[False, True]]))
    >>> render_base(m).tolist()
    [[[0, 0, 0], [128, 128, 128]]]
    """
    from slamq.report.animation import render_map

    return np.ascontiguousarray(render_map(grid), dtype=np.uint8)


#: Cells of unknown canvas kept around the known area when a map is drawn.
CROP_MARGIN = 4


def known_box(grid: OccupancyMap, margin: int = CROP_MARGIN) -> tuple[int, int, int, int]:
    """``(r0, r1, c0, c1)``: the rows and columns holding known cells, widened by
    ``margin`` (the whole map when nothing is known).

    Examples
    --------
    >>> import numpy as np, slamq
    >>> img = np.full((20, 30), 205, np.uint8)
    >>> img[5:8, 10:12] = 254
    >>> known_box(slamq.OccupancyMap(img, img == 205), margin=2)
    (3, 10, 8, 14)
    """
    known = ~grid.unknown
    rows, cols = np.flatnonzero(known.any(axis=1)), np.flatnonzero(known.any(axis=0))
    h, w = grid.shape
    if not len(rows):
        return 0, h, 0, w
    return (max(0, int(rows[0]) - margin), min(h, int(rows[-1]) + 1 + margin),
            max(0, int(cols[0]) - margin), min(w, int(cols[-1]) + 1 + margin))


def _scale_for(shape: tuple[int, int], target: int) -> int:
    return max(1, min(16, int(math.ceil(target / max(shape)))))


def draw_overlay(
    grid: OccupancyMap,
    marks: Marks,
    *,
    target_size: int = 900,
    alpha: float = 0.65,
    composite: bool = True,
) -> Overlay:
    """Draw the map with its counted corners ringed and counted enclosed areas coloured.

    Parameters
    ----------
    grid : OccupancyMap
        The map (held north up, as every loaded map is).
    marks : Marks
        What was counted on it (:func:`slamq.verdict.exhibits.counted_marks`: the corners
        and the enclosed regions at the result's ``enclosed_unknown_value``).
    target_size : int, default 900
        Small maps are enlarged by a whole factor (at most 16) towards this many pixels
        on the longer side, so that rings and regions stay visible.
    alpha : float, default 0.65
        Opacity of the region colours over the map.
    composite : bool, default True
        Draw ``image``, the map with the rings and colours on it. False: only the layers
        (``grey``/``plain`` and ``region_index``/``regions``; ``image`` is None), as a
        detail page shows them, in a fraction of the time.

    Returns
    -------
    Overlay

    Examples
    --------
    >>> import numpy as np, slamq
    >>> from slamq.verdict.exhibits import counted_marks
    >>> img = np.full((40, 40), 205, np.uint8)
    >>> img[5:35, 5:35] = 0
    >>> img[8:32, 8:32] = 254
    >>> grid = slamq.OccupancyMap(img, img == 205)
    >>> ov = draw_overlay(grid, counted_marks(grid, 0))
    >>> ov.n_regions, ov.image.shape[2]
    (1, 3)
    """
    labels, corners = marks.labels, marks.corners
    n = int(labels.max()) if labels.size else 0
    r0, r1, c0, c1 = known_box(grid)
    grey = np.where(grid.unknown[r0:r1, c0:c1], np.uint8(UNKNOWN_GREY),
                    grid.values[r0:r1, c0:c1]).astype(np.uint8)
    crop = labels[r0:r1, c0:c1]
    # 1 + the palette entry of each counted cell's region (regions cycle through it)
    index = np.where(crop > 0, (crop - 1) % len(REGION_PALETTE) + 1, 0).astype(np.uint8)
    scale = _scale_for(grey.shape, target_size)
    image = None
    if composite:
        base = render_base(grid).astype(np.float32)
        if n:
            lut = np.zeros((n + 1, 3), np.float32)
            lut[1:] = np.array(REGION_PALETTE, np.float32)[np.arange(n) % len(REGION_PALETTE)]
            mask = labels > 0
            base[mask] = (1 - alpha) * base[mask] + alpha * lut[labels[mask]]
        rgb = np.clip(np.rint(base[r0:r1, c0:c1]), 0, 255).astype(np.uint8)
        # keep exact pure red for the rings only
        red = (rgb[:, :, 0] == 255) & (rgb[:, :, 1] == 0) & (rgb[:, :, 2] == 0)
        rgb[red] = (254, 0, 0)
        if scale > 1:
            rgb = np.repeat(np.repeat(rgb, scale, axis=0), scale, axis=1)
        img = Image.fromarray(rgb)
        draw = ImageDraw.Draw(img)
        size = max(img.size)
        radius = max(3.0, size / 110.0)
        width = max(1, int(round(radius / 3)))
        for row, col in corners:
            x, y = (col - c0 + 0.5) * scale, (row - r0 + 0.5) * scale
            draw.ellipse((x - radius, y - radius, x + radius, y + radius),
                         outline=CORNER_RGB, width=width)
        image = np.asarray(img)
    if scale > 1:  # one byte a pixel: the layers are enlarged before they are coloured
        grey, index = (np.repeat(np.repeat(a, scale, axis=0), scale, axis=1)
                       for a in (grey, index))
    return Overlay(image=image, scale=scale, corners=corners, labels=labels,
                   unknown_value=int(marks.unknown_value), offset=(r0, c0), grey=grey,
                   region_index=index, alpha=alpha)
