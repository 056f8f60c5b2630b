"""What one map's detail page shows, computed for the report to draw: the map loaded and
scored with the parameters of its record, the corners and enclosed areas that were counted,
its defects, its comparison with the sequence's ground-truth map, where it contradicts its
own scans (docs/spec.md section 7b: a density of the beams that cross its walls),
its trajectory errors and the stages of its building. Anything that cannot be computed
becomes a note (the page says why a part is missing), never an exception.

Defects are boxes ``{"kind": str, "bbox": [col0, row0, col1, row1], "note": str}`` in the
map's cells (row 0 at the top, as the map's image; ``col1`` and ``row1`` exclusive, as
``values[row0:row1, col0:col1]``), taken from the record's ``defects`` field (a JSON list,
or a list) and from ``defects_for(map)``; by default that runs
:func:`slamq.metrics.defects.detect_defects`, the detectors the verdict reads.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from slamq.errors import SlamqError
from slamq.models import MapComparison, MapQuality, OccupancyMap
from slamq.params import Params
from slamq.verdict.building import Timeline
from slamq.verdict.records import evaluate_map, params_of, usable
from slamq.verdict.trajectory import TrajectoryEvidence

__all__ = ["MapExhibit", "Marks", "ScanExhibit", "counted_marks", "detected_defects",
           "map_exhibit", "source_digests", "violation_density"]

#: What draws the defects layer: ``defects_for(map)`` -> list of defect dicts.
DefectsFor = Callable[[Any], list[dict]]


@dataclass
class Marks:
    """What was counted on a map, as its overlay draws it.

    Attributes
    ----------
    corners : numpy.ndarray
        ``(K, 2)`` float (row, col) centroids of the counted corners, in map cells.
    labels : numpy.ndarray
        ``(H, W)`` int32: 0 = not counted, 1..n = the counted enclosed regions.
    unknown_value : int
        The unknown value ``u`` the regions were taken at.
    """

    corners: np.ndarray
    labels: np.ndarray
    unknown_value: int

    @property
    def n_corners(self) -> int:
        """Number of counted corners."""
        return int(len(self.corners))

    @property
    def n_regions(self) -> int:
        """Number of counted enclosed regions."""
        return int(self.labels.max()) if self.labels.size else 0


def counted_marks(grid: OccupancyMap, unknown_value: int, params: Params | None = None
                  ) -> Marks:
    """The corners and enclosed regions the metrics count on ``grid`` (docs/spec.md
    sections 3 and 4), the regions at the unknown value ``unknown_value``.

    Examples
    --------
    >>> import numpy as np, slamq
    >>> img = np.full((40, 40), 205, np.uint8)
    >>> img[5:35, 5:35] = 0
    >>> img[8:32, 8:32] = 254
    >>> m = counted_marks(slamq.OccupancyMap(img, img == 205), 0)
    >>> m.n_regions, m.n_corners
    (1, 4)
    """
    from slamq.metrics import reference

    params = params or Params()
    labels = np.asarray(reference.enclosed_labels(grid, int(unknown_value), params), np.int32)
    corners = np.asarray(reference.corner_points(grid, params), float).reshape(-1, 2)
    return Marks(corners=corners, labels=labels, unknown_value=int(unknown_value))


@dataclass
class ScanExhibit:
    """Where a map contradicts its own scans (docs/spec.md 7b), as its page draws it.

    Attributes
    ----------
    figures : dict
        :meth:`slamq.models.ScanConsistency.to_dict` (``violation_share``, ``hit_share``,
        ``scans``, ``beams``...).
    density : numpy.ndarray
        ``(H, W)`` float32 on the map's cells, in [0, 1]: :func:`violation_density` of the
        beams that crossed a wall through each occupied cell (0: none; a beam that only
        grazes a wall is not drawn).
    recording : str
        The recording's file name.
    split : dict or None
        The record's path against the same scans split in time, as the verdict weighs it
        (:func:`slamq.verdict.scans.record_split`, docs/spec.md 7e:
        :meth:`slamq.models.ScanSplit.to_dict`); None when it could not be scored.
    """

    figures: dict[str, Any]
    density: np.ndarray
    recording: str
    split: dict[str, Any] | None = None


def violation_density(counts: np.ndarray, *, block: int | None = None) -> np.ndarray:
    """How densely a map's walls are crossed by its own beams, per block of cells, for a
    heat map: the violations of each ``block x block`` square of cells summed, divided by
    the 99th percentile of the blocks that have any (at least 1) and clipped to 1, on the
    map's cells again.

    Parameters
    ----------
    counts : numpy.ndarray
        ``(H, W)``: :attr:`slamq.models.ScanConsistency.crossing_grid` (or its
        ``violation_grid``).
    block : int, optional
        Cells per side of a block (default: about 1/300 of the map's longer side, at least
        1, so that the spots stay visible in a picture of the whole map).

    Returns
    -------
    numpy.ndarray
        ``(H, W)`` float32 in [0, 1].

    Examples
    --------
    >>> c = np.zeros((4, 6), np.uint32); c[0, 0] = 5; c[3, 5] = 1
    >>> violation_density(c, block=2)[:, :2].tolist()
    [[1.0, 1.0], [1.0, 1.0], [0.0, 0.0], [0.0, 0.0]]
    """
    counts = np.asarray(counts, dtype=np.float64)
    h, w = counts.shape
    b = int(block) if block else max(1, -(-max(h, w) // 300))
    hp, wp = -(-h // b) * b, -(-w // b) * b
    padded = np.zeros((hp, wp))
    padded[:h, :w] = counts
    sums = padded.reshape(hp // b, b, wp // b, b).sum(axis=(1, 3))
    nonzero = sums[sums > 0]
    if nonzero.size == 0:
        return np.zeros((h, w), np.float32)
    top = max(1.0, float(np.percentile(nonzero, 99)))
    dens = np.clip(sums / top, 0.0, 1.0)
    return np.repeat(np.repeat(dens, b, axis=0), b, axis=1)[:h, :w].astype(np.float32)


@dataclass
class MapExhibit:
    """Everything one detail page draws of its map.

    Attributes
    ----------
    grid : OccupancyMap or None
        The map (None: it could not be loaded; ``notes`` says why).
    params : Params
        The metric parameters of the record.
    quality : MapQuality or None
        The map evaluated now, with its enclosed-area curve.
    marks : Marks or None
        The counted corners and enclosed regions (at the record's unknown value).
    notes : list of str
        What the page should warn about, in order.
    defects : list of dict
        The well-formed defects (record's first, then ``defects_for``'s).
    ground_truth : (MapComparison, OccupancyMap) or None
        The comparison with the sequence's ground-truth map and that map.
    trajectory : TrajectoryEvidence, Exception or None
        The run's trajectory errors, the reason they could not be computed, or None (no
        trajectory, or not asked for).
    building : (str, Timeline or None), Exception or None
        What the map's building stages are and their timeline (None when there are fewer
        than two), the reason they could not be read, or None (not asked for).
    scans : ScanExhibit, Exception or None
        Where the map contradicts its own scans (the record names its ``scans`` and its
        ``trajectory``), the reason it could not be computed, or None.
    """

    grid: OccupancyMap | None
    params: Params
    quality: MapQuality | None = None
    marks: Marks | None = None
    notes: list[str] = field(default_factory=list)
    defects: list[dict] = field(default_factory=list)
    ground_truth: tuple[MapComparison, OccupancyMap] | None = None
    trajectory: TrajectoryEvidence | Exception | None = None
    building: tuple[str, Timeline | None] | Exception | None = None
    scans: ScanExhibit | Exception | None = None


def detected_defects(grid: Any) -> list[dict]:
    """The defect detectors' flags on a map (:func:`slamq.metrics.defects.detect_defects`),
    as the detail page draws them.

    Examples
    --------
    >>> import numpy as np, slamq
    >>> detected_defects(slamq.OccupancyMap(np.full((9, 9), 254, np.uint8), np.zeros((9, 9), bool)))
    []
    """
    from slamq.metrics.defects import detect_defects  # on first use

    return [d.to_dict() for d in detect_defects(grid)]


def map_exhibit(record: dict, *, gifs: bool = True, trajectories: bool = True,
                defects_for: DefectsFor | None = detected_defects) -> MapExhibit:
    """Load, score and examine a record's map for its detail page.

    Parameters
    ----------
    record : dict
        A successful results record (``map`` and the metric columns; ``param_*``,
        ``enclosed_unknown_value``, ``defects``, ``gt_map``, ``config``, ``trajectory``,
        ``groundtruth`` when present).
    gifs : bool, default True
        Also read and score the stages of the map's building.
    trajectories : bool, default True
        Also score the run's trajectory.
    defects_for : callable, optional
        ``defects_for(map)`` returns more defects (default: :func:`detected_defects`).

    Returns
    -------
    MapExhibit

    Examples
    --------
    >>> import numpy as np, tempfile, pathlib
    >>> from PIL import Image
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> img = np.full((30, 30), 254, np.uint8); img[8:22, 8:22] = 0
    >>> Image.fromarray(img).save(d / "a.pgm")
    >>> ex = map_exhibit({"map": str(d / "a.pgm"), "corners": 3}, gifs=False)
    >>> ex.marks.n_corners, ex.notes[0][:32]
    (8, 'the results file says corners = ')
    >>> map_exhibit({"map": str(d / "none.pgm")}).notes[0][:15]
    'map not drawn: '
    """
    from slamq.sources import load_map

    rec = record
    params = params_of(rec)
    ex = MapExhibit(grid=None, params=params)
    try:
        grid = load_map(rec["map"])
        quality = evaluate_map(grid, params, curve=True)
    except (SlamqError, OSError, ValueError) as exc:
        ex.notes.append(f"map not drawn: {exc}")
        return ex
    ex.grid, ex.quality = grid, quality
    u = int(rec["enclosed_unknown_value"]) if usable(rec.get("enclosed_unknown_value")) \
        else int(quality.enclosed_unknown_value)
    ex.marks = counted_marks(grid, u, params)
    for key, drawn in (("corners", ex.marks.n_corners), ("enclosed_areas", ex.marks.n_regions)):
        if usable(rec.get(key)) and int(rec[key]) != drawn:
            ex.notes.append(
                f"the results file says {key} = {int(rec[key])}, the map as loaded now "
                f"gives {drawn} (file changed, or other parameters?)")
    ex.defects = _defects(rec, grid, defects_for, ex.notes)
    ex.ground_truth = _compare_gt(rec, grid, ex.notes)
    ex.scans = _scans(rec, grid)
    if trajectories and usable(rec.get("trajectory")):
        from slamq.verdict.trajectory import trajectory_evidence

        try:
            ex.trajectory = trajectory_evidence(rec)
        except Exception as exc:  # noqa: BLE001 - a bad trajectory is a note, never a crash
            ex.trajectory = exc
    if gifs:
        ex.building = _building(rec, params)
    return ex


def _scans(rec: dict, grid: Any) -> ScanExhibit | Exception | None:
    """Where the record's map contradicts its own scans, or why that is not known."""
    from slamq.verdict.scans import has_scans, record_consistency, record_split

    if not has_scans(rec):
        return None
    try:
        c = record_consistency(rec, grid)
    except (SlamqError, OSError, ValueError) as exc:
        return exc
    try:
        split: dict[str, Any] | None = record_split(rec).to_dict()
    except (SlamqError, OSError, ValueError):
        split = None  # the map's figures stand; the page says the split is not known
    cells = c.crossing_grid if c.crossing_grid is not None else c.violation_grid
    return ScanExhibit(c.to_dict(), violation_density(cells),
                       Path(str(rec["scans"])).name, split)


def _compare_gt(rec: dict, grid: Any, notes: list[str]
                ) -> tuple[MapComparison, OccupancyMap] | None:
    """``(comparison, ground-truth map)`` of the record's map against its sequence's
    ground-truth map with the batch's settings (docs/spec.md section 7), else None."""
    if not usable(rec.get("gt_map")) or usable(rec.get("gt_error")):
        return None
    from slamq.api import compare
    from slamq.sources import load_map

    cfg = _gt_config(rec.get("config"))
    try:
        gt = load_map(rec["gt_map"])
        c = compare(grid, gt, align=cfg[0], tolerance=cfg[1], max_distance=cfg[2],
                    cells=True)
    except (SlamqError, OSError, ValueError) as exc:
        notes.append(f"ground-truth overlay not drawn: {exc}")
        return None
    return c, gt


def _gt_config(config: Any) -> tuple[str, float | None, float | None]:
    """``(align, tolerance, max_distance)`` of the record's comparison settings."""
    try:
        gt = json.loads(config)["gt"]
        return str(gt[0]), gt[1], gt[2]
    except (TypeError, ValueError, KeyError, IndexError):
        from slamq.params import SETTINGS

        return SETTINGS.compare_align.default, None, None


def _defects(rec: dict, grid: Any, defects_for: DefectsFor | None,
             notes: list[str]) -> list[dict]:
    """The map's defects: the record's ``defects`` field (a JSON string or a list), then
    ``defects_for(grid)``; a malformed entry becomes a note on the page."""
    found: list[Any] = []
    raw = rec.get("defects")
    if isinstance(raw, str) and raw.strip():
        try:
            raw = json.loads(raw)
        except ValueError as exc:
            notes.append(f"defects field is not JSON: {exc}")
            raw = None
    if isinstance(raw, (list, tuple, np.ndarray)):
        found.extend(raw)
    elif usable(raw) and not isinstance(raw, str):
        notes.append(f"defects field is not a list: {str(raw)[:80]}")
    if defects_for is not None:
        try:
            found.extend(defects_for(grid) or [])
        except Exception as exc:  # noqa: BLE001 - a failing detector is a note, never a crash
            notes.append(f"defects_for failed: {type(exc).__name__}: {exc}")
    good = []
    for i, d in enumerate(found):
        try:
            bbox = [float(v) for v in d["bbox"]]
            if len(bbox) != 4 or not all(map(math.isfinite, bbox)):
                raise ValueError("bbox needs 4 finite numbers")
            kept = {"kind": str(d.get("kind", "defect")), "bbox": bbox,
                    "note": str(d.get("note", ""))}
            sep = d.get("separation")  # a superposed flag's: read by the verdict's S1
            if isinstance(sep, (int, float)) and math.isfinite(sep):
                kept["separation"] = float(sep)
            good.append(kept)
        except (TypeError, KeyError, ValueError, AttributeError) as exc:
            notes.append(f"defect {i} ignored ({exc}): {str(d)[:80]}")
    return good


def _building(rec: dict, params: Params) -> tuple[str, Timeline | None] | Exception:
    """``(what, timeline)`` of the map's building stages (timeline None: fewer than two),
    or the error that stopped reading them."""
    from slamq.verdict.building import build_timeline, building_maps

    try:
        sources, what = building_maps(rec["map"])
        if len(sources) < 2:
            return what, None
        return what, build_timeline(sources, params)
    except (SlamqError, OSError, ValueError) as exc:
        return exc


def source_digests(record: dict, *, gifs: bool) -> dict[str, Any]:
    """Content stamps of the files a record's detail page is drawn from: its map, ground-truth
    map, trajectory, ground-truth trajectory, recording (``scans``: its size and time) and
    (with ``gifs``) the map's snapshots; None for a file that is absent or unreadable.

    Examples
    --------
    >>> source_digests({"map": None}, gifs=True)["map"] is None
    True
    """
    from slamq.batch.records import content_hash
    from slamq.sources.snapshots import find_snapshots

    def map_digest(p: Any) -> str | None:
        try:
            return content_hash(p) if usable(p) else None
        except (OSError, SlamqError):
            return None

    def file_digest(p: Any) -> str | None:
        if not usable(p):
            return None
        try:
            return hashlib.sha1(Path(p).read_bytes(), usedforsecurity=False).hexdigest()
        except OSError:
            return None

    def stat_digest(p: Any) -> str | None:
        # a recording may be large: its size and time stand for its content
        try:
            st = Path(p).stat() if usable(p) else None
        except OSError:
            return None
        return None if st is None else f"{st.st_size}:{st.st_mtime_ns}"

    snaps: list[Any] = []
    if gifs and usable(record.get("map")):
        snaps = [[q.name, map_digest(q)] for q in find_snapshots(Path(record["map"]).parent)]
    return {"map": map_digest(record.get("map")), "gt_map": map_digest(record.get("gt_map")),
            "trajectory": file_digest(record.get("trajectory")),
            "groundtruth": file_digest(record.get("groundtruth")), "snapshots": snaps,
            "scans": stat_digest(record.get("scans"))}
