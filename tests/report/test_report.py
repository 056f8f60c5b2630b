"""slamq.report: ranking, plots, overlays, animations and the site, on hand-made maps.

The browser checks of the built page are in test_report_browser.py; ``make_results`` here
writes the small results set both use.
"""

from __future__ import annotations

import json
import math
import re
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pandas as pd
import pytest
from conftest import slamq_env
from PIL import Image

from slamq import OccupancyMap, Params
from slamq.errors import SlamqError
from slamq.metrics import reference
from slamq.report import build_report
from slamq.report.formatting import format_mean_std, format_value
from slamq.report.overlays import CORNER_RGB, compact_image, draw_overlay
from slamq.report.plots import metric_figure
from slamq.report.timeline import write_timeline_gif
from slamq.sources.snapshots import find_snapshots
from slamq.verdict.building import build_timeline
from slamq.verdict.exhibits import counted_marks
from slamq.verdict.ranking import METRICS, rank_sequence, summarize
from slamq.verdict.records import evaluate_map, load_results

FREE, WALL, UNKNOWN = 254, 0, 205


# ----------------------------------------------------------------------------- map makers


def rooms_image(n_rooms: int, *, extra_boxes: int = 0, split: bool = False,
                seed: int = 0) -> np.ndarray:
    """``n_rooms`` closed rooms (walls 2 cells thick) side by side on an unknown canvas."""
    rng = np.random.default_rng(seed)
    img = np.full((50, 30 * n_rooms + 10), UNKNOWN, np.uint8)
    for k in range(n_rooms):
        c0 = 5 + 30 * k
        img[5:45, c0:c0 + 26] = WALL
        img[7:43, c0 + 2:c0 + 24] = FREE
        if split and k == 0:
            img[24:26, c0 + 2:c0 + 24] = WALL          # a wall across: one more room
        for _ in range(extra_boxes):                     # clutter: more corners
            r, c = rng.integers(10, 36), rng.integers(c0 + 5, c0 + 18)
            img[r:r + 3, c:c + 3] = WALL
    return img


def write_map(folder: Path, img: np.ndarray, name: str = "map") -> Path:
    """PGM + map_server YAML; returns the YAML path."""
    folder.mkdir(parents=True, exist_ok=True)
    Image.fromarray(img).save(folder / f"{name}.pgm")
    yaml = folder / f"{name}.yaml"
    yaml.write_text(f"image: {name}.pgm\nresolution: 0.05\norigin: [-1.0, -1.0, 0.0]\n"
                    "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n")
    return yaml


def _trajectory_files(folder: Path, noise: float, seed: int) -> tuple[Path, Path]:
    """A TUM ground truth inside room 1 and an estimate with noise (metres)."""
    rng = np.random.default_rng(seed)
    t = np.arange(40) * 0.5
    x = -1.0 + 0.05 * (12 + 6 * np.cos(t / 3))
    y = -1.0 + 0.05 * (25 + 12 * np.sin(t / 3))
    gt, est = folder / "groundtruth.txt", folder / "trajectory.txt"
    ex, ey = x + rng.normal(0, noise, t.size), y + rng.normal(0, noise, t.size)
    for path, (xs, ys) in ((gt, (x, y)), (est, (ex, ey))):
        path.write_text("".join(f"{a:.3f} {b:.6f} {c:.6f} 0 0 0 0 1\n"
                                for a, b, c in zip(t, xs, ys)))
    return est, gt


def make_results(root: Path) -> Path:
    """A small batch: 2 sequences x 3 algorithms x 3 runs, one failed map, ATE for "good",
    snapshots in one run folder. Returns the .jsonl results path."""
    params = Params()
    records = []
    plans = {"good": {}, "cluttered": {"extra_boxes": 3}, "split": {"split": True,
                                                                      "extra_boxes": 1}}
    for seq, n_rooms in (("office", 2), ("lab", 3)):
        for alg, kw in plans.items():
            for run in range(3):
                folder = root / seq / alg / f"run{run}"
                img = rooms_image(n_rooms, seed=run + 10 * n_rooms, **kw)
                yaml = write_map(folder, img)
                q = evaluate_map(str(yaml), params, curve=False)
                rec = q.to_dict()
                rec.pop("curve", None)
                rec.update(map=str(yaml), algorithm=alg, sequence=seq, run=run,
                           trajectory=None, groundtruth=None, error=None, seconds=0.01,
                           hash="0" * 16)
                if alg == "good":
                    est, gt = _trajectory_files(folder, 0.02 * (run + 1), run)
                    rec.update(trajectory=str(est), groundtruth=str(gt))
                    rec["ate_rmse"] = 0.02 * (run + 1)          # as if computed by batch
                records.append(rec)
    snap = root / "office" / "good" / "run0"
    for k, n in enumerate((1, 1, 2), start=1):
        img = rooms_image(n)
        full = np.full((50, 70), UNKNOWN, np.uint8)
        full[:, :img.shape[1]] = img
        if k == 2:
            full[7:43, 20:31] = UNKNOWN                    # half of the first room unknown
        Image.fromarray(full).save(snap / f"map_{k:04d}.pgm")
    records.append({"map": str(root / "lab" / "missing.yaml"), "algorithm": "good",
                    "sequence": "lab", "run": 9, "error": "missing.yaml: no such file"})
    path = root / "results.jsonl"
    path.write_text("".join(json.dumps(r) + "\n" for r in records))
    return path


# ----------------------------------------------------------------------------- metrics


def test_summarize_uses_sample_std_and_skips_nan():
    df = pd.DataFrame({"sequence": "s", "algorithm": ["a", "a", "a", "b"],
                       "corners": [10, 14, 12, 3], "ate_rmse": [0.1, np.nan, 0.3, np.nan]})
    s = summarize(df)
    assert s.loc[("s", "a"), "n"] == 3
    assert s.loc[("s", "a"), "corners_mean"] == 12.0
    assert s.loc[("s", "a"), "corners_std"] == pytest.approx(2.0)       # ddof=1
    assert s.loc[("s", "a"), "ate_rmse_n"] == 2
    assert s.loc[("s", "a"), "ate_rmse_mean"] == pytest.approx(0.2)
    assert math.isnan(s.loc[("s", "b"), "ate_rmse_mean"])
    assert math.isnan(s.loc[("s", "b"), "corners_std"])                 # one run: no std


def test_every_metric_is_lower_is_better_and_log_where_the_paper_uses_it():
    paper = [m for m in METRICS if not m.key.startswith(("gt_", "rel_"))]
    assert {m.key: m.log for m in paper} == {
        "ate_rmse": True, "occupied_fraction": False, "corners": True, "enclosed_areas": True}
    assert all("paper" in m.why and not m.higher for m in paper)
    # the ground-truth comparison (docs/spec.md section 7): F1 is the one higher-is-better
    gt = {m.key: (m.higher, m.log) for m in METRICS if m.key.startswith("gt_")}
    assert gt == {"gt_f1": (True, False), "gt_chamfer": (False, True)}
    assert all("section 7" in m.why for m in METRICS if m.key.startswith("gt_"))
    # the relations error (docs/spec.md section 6a): lower is better, log as ATE
    rel = {m.key: (m.higher, m.log) for m in METRICS if m.key.startswith("rel_")}
    assert rel == {"rel_trans_abs_mean": (False, True)}
    assert all("section 6a" in m.why for m in METRICS if m.key.startswith("rel_"))


def test_gt_f1_ranks_the_highest_first_and_the_reference_is_not_ranked():
    df = pd.DataFrame({"sequence": "s", "algorithm": ["a", "b", "ground_truth"],
                       "gt_f1": [0.9, 0.99, np.nan], "gt_chamfer": [0.05, 0.01, np.nan]})
    r = rank_sequence(summarize(df), "s")
    assert r.order == ["b", "a"] and r.ground_truths == ["ground_truth"]
    assert r.best["gt_f1"] == ["b"] and r.best["gt_chamfer"] == ["b"]
    assert r.ranks["gt_f1"] == {"a": 2.0, "b": 1.0}


def test_ranking_and_disagreement():
    df = pd.DataFrame({
        "sequence": "s", "algorithm": ["a", "b", "c"],
        "ate_rmse": [0.1, 0.5, np.nan], "occupied_fraction": [0.05, 0.04, 0.09],
        "corners": [100, 300, 200], "enclosed_areas": [2, 9, 2]})
    r = rank_sequence(summarize(df), "s")
    # the verdict's order (ATE RMSE decides), then c, which has no ATE, unranked
    assert r.order == ["a", "b", "c"] and r.ranked == ["a", "b"] and r.winner == "a"
    assert r.best["enclosed_areas"] == ["a", "c"]                       # a tie: both best
    assert [m.key for m in r.disagree] == ["occupied_fraction"]
    assert r.ranks["ate_rmse"] == {"a": 1.0, "b": 2.0}
    assert not hasattr(r, "score")                    # no mean rank over metrics
    sentence = r.sentence()
    assert sentence.startswith("s: a is best by ATE RMSE (the verdict")
    assert "lowest occupied fraction: b" in sentence and "mean rank" not in sentence
    # the mean rank over the four metrics would have named b here; the verdict names a
    df.loc[0, "ate_rmse"], df.loc[1, "ate_rmse"] = 0.5, 0.1
    r = rank_sequence(summarize(df), "s")
    assert r.winner == "b" and r.order == ["b", "a", "c"]
    assert r.sentence().startswith("s: b is best by ATE RMSE")


def test_ranking_flags_partial_maps_and_single_algorithm():
    df = pd.DataFrame({"sequence": "s", "algorithm": ["a", "b", "c"], "corners": [5, 6, 1],
                       "known": [1000, 900, 100]})
    assert rank_sequence(summarize(df), "s").partial == ["c"]
    one = rank_sequence(summarize(df[df.algorithm == "a"]), "s")
    assert "nothing to compare" in one.sentence()


def test_formatting():
    assert format_value(3.0) == "3"
    assert format_value(0.23912) == "0.239"
    assert format_value(float("nan")) == "–"
    assert format_mean_std(0.239, 0.0114) == "0.239 ± 0.0114"
    assert format_mean_std(7.0, float("nan")) == "7"


# ----------------------------------------------------------------------------- overlays


def _red_components(image: np.ndarray) -> int:
    red = np.all(image == np.array(CORNER_RGB, np.uint8), axis=2).astype(np.uint8)
    n, _ = cv2.connectedComponents(red, connectivity=8)
    return n - 1


def test_overlay_rings_every_counted_corner():
    img = np.full((60, 100), FREE, np.uint8)
    for c0 in (10, 45, 75):                                  # three separate square blocks
        img[20:32, c0:c0 + 12] = WALL
    grid = OccupancyMap(img, np.zeros_like(img, bool))
    q = evaluate_map(grid, Params(), curve=False)
    assert q.corners == 24                        # per block: 4 outer + 4 inner LoG corners
    ov = draw_overlay(grid, counted_marks(grid, q.enclosed_unknown_value))
    assert ov.n_corners == 24
    assert _red_components(ov.image) == 24                   # 24 separate rings on the image
    assert ov.scale == 9 and ov.image.shape == (540, 900, 3)


def test_overlay_colours_every_counted_enclosed_area():
    img = rooms_image(3)
    grid = OccupancyMap(img, img == UNKNOWN)
    q = evaluate_map(grid, Params(), curve=False)
    assert q.enclosed_areas == 3
    ov = draw_overlay(grid, counted_marks(grid, q.enclosed_unknown_value),
                      target_size=0)
    assert ov.scale == 1 and ov.n_regions == 3
    assert ov.n_regions == reference.enclosed_count(grid, q.enclosed_unknown_value)
    rgb = ov.image.astype(int)
    coloured = (rgb[:, :, 0] != rgb[:, :, 1]) | (rgb[:, :, 1] != rgb[:, :, 2])
    red = np.all(ov.image == np.array(CORNER_RGB, np.uint8), axis=2)
    # the image is the map cropped to its known cells (offset: its top-left cell)
    (r0, c0), (h, w) = ov.offset, ov.image.shape[:2]
    inside = ov.labels[r0:r0 + h, c0:c0 + w] > 0
    assert inside.sum() == (ov.labels > 0).sum()  # no counted cell is cropped away
    # every counted cell is coloured, nothing else is (but the rings)
    assert coloured[inside].all()
    assert not (coloured & ~inside & ~red).any()
    region_colours = {tuple(c) for c in ov.image[inside & ~red]}
    assert len(region_colours) == 3                           # one colour per region


def test_overlay_of_a_map_without_structure():
    grid = OccupancyMap(np.full((10, 10), FREE, np.uint8), np.zeros((10, 10), bool))
    ov = draw_overlay(grid, counted_marks(grid, 0))
    assert ov.n_corners == 0 and ov.n_regions == 0
    assert (ov.image == FREE).all()


def test_layers_alone_are_the_layers_of_the_composite_and_compact_pngs_keep_pixels(
        tmp_path: Path) -> None:
    """A detail page draws only the layers (composite=False): the same plain map and
    regions as the full overlay; written compactly (grey, palette), the PNGs read back as
    the same RGB(A) pixels."""
    img = rooms_image(3)
    grid = OccupancyMap(img, img == UNKNOWN)
    q = evaluate_map(grid, Params(), curve=False)
    marks = counted_marks(grid, q.enclosed_unknown_value)
    full, layers = draw_overlay(grid, marks), draw_overlay(grid, marks, composite=False)
    assert layers.scale == full.scale > 1 and layers.offset == full.offset
    assert layers.image is None and full.image.shape == full.plain.shape
    assert np.array_equal(layers.plain, full.plain)
    assert np.array_equal(layers.regions, full.regions)
    assert layers.cells == full.cells and layers.n_regions == full.n_regions == 3
    rgb = full.image.copy()
    rgb[: rgb.shape[0] // 2, :, 0] = np.arange(rgb.shape[1]) % 256  # > 256 colours: kept RGB
    for array, mode in ((full.plain, "L"), (full.regions, "P"), (full.image, "P"),
                        (rgb, "RGB")):
        out = tmp_path / f"{mode}.png"
        made = compact_image(array)
        made.save(out)
        with Image.open(out) as back:
            assert back.mode == made.mode == mode
            pixels = np.asarray(back.convert("RGBA" if array.shape[2] == 4 else "RGB"))
        assert np.array_equal(pixels, array), mode


# ----------------------------------------------------------------------------- plots


def test_metric_figure_draws_every_finite_run(tmp_path):
    df = pd.DataFrame({"sequence": ["s1"] * 5 + ["s2"] * 2,
                       "algorithm": ["a", "a", "b", "b", "b", "a", "b"],
                       "corners": [3, 4, 0, 9, np.nan, 5, 6]})
    out = tmp_path / "corners.png"
    counts = metric_figure(df, METRICS[2], out)
    assert counts == {"s1": 4, "s2": 2}
    with Image.open(out) as im:
        assert im.size[0] > 600 and im.size[1] > 200


# ----------------------------------------------------------------------------- animation


def test_snapshots_become_a_gif_with_metrics(tmp_path):
    folder = tmp_path / "run"
    folder.mkdir()
    for k, n in enumerate((1, 2, 3), start=1):
        Image.fromarray(rooms_image(n)).save(folder / f"map_{k:04d}.pgm")
    (folder / "map.pgm").write_bytes(b"")                     # not a snapshot
    snaps = find_snapshots(folder)
    assert [p.name for p in snaps] == ["map_0001.pgm", "map_0002.pgm", "map_0003.pgm"]
    tl = build_timeline(snaps)
    assert tl.enclosed_areas == [1, 2, 3]
    gif = write_timeline_gif(tl, tmp_path / "t.gif")
    with Image.open(gif) as im:
        assert im.n_frames == 3
        assert im.size[0] > im.size[1]                        # map beside the plots


# ----------------------------------------------------------------------------- results, site


def test_load_results_rejects_bad_files(tmp_path):
    with pytest.raises(SlamqError, match="not found"):
        load_results(tmp_path / "nope.jsonl")
    bad = tmp_path / "bad.jsonl"
    bad.write_text('{"corners": 3}\n')
    with pytest.raises(SlamqError, match="no 'map' column"):
        load_results(bad)
    broken = tmp_path / "broken.jsonl"
    broken.write_text("{not json\n")
    with pytest.raises(SlamqError, match="broken.jsonl"):
        load_results(broken)


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    root = tmp_path_factory.mktemp("report")
    results = make_results(root)
    index = build_report(results, root / "site")
    return results, index


def test_site_has_tables_gallery_plots_and_details(site):
    results, index = site
    html = index.read_text(encoding="utf-8")
    out = index.parent
    recs = [json.loads(x) for x in results.read_text().splitlines()]
    ok = [r for r in recs if r.get("error") is None]
    assert len(list((out / "maps").glob("*.html"))) == len(ok)           # one per map
    for key in ("occupied_fraction", "corners", "enclosed_areas", "ate_rmse"):
        assert (out / "img" / f"plot_{key}.svg").is_file()
    assert html.count('class="ranking"') == 2
    # each algorithm's known area relative to the most complete map of its sequence
    # which numbers to trust: the shipped validity table, whatever the results
    assert 'class="validity shipped"' in html and "<td>corners</td><td>0.73</td>" in html
    ranking = "".join(re.findall(r'<table class="ranking".*?</table>', html, re.S))
    shares = re.findall(r'data-known-share="([^"]*)">(\d+)%</td>', ranking)
    assert len(shares) == 6 and ">known area</th>" in html
    assert all(round(100 * float(v)) == int(t) for v, t in shares)
    assert max(float(v) for v, _ in shares) == 1.0
    # gallery: best and worst of each of 3 algorithms x 2 sequences
    assert len(re.findall(r'<a class="detail" href="maps/[^"]+\.html">', html)) == 12
    assert "missing.yaml: no such file" in html                          # failed map listed
    # the verdict names the winner of each sequence (only one algorithm has trajectories:
    # no ground truth to rank by, so the maps' agreement decides and corners order the
    # maps it confirms equally), and verdict.json says the same
    verdicts = {v["sequence"]: v for v in json.loads((out / "verdict.json").read_text())}
    for seq in ("office", "lab"):
        assert re.search(rf'#seq-{seq}">{seq}</a>: <b>good</b> is best by agreement with the '
                         'other maps', html)
        assert verdicts[seq]["best"] == "good"
        assert verdicts[seq]["basis"] == ["agreement", "corners"]
        assert verdicts[seq]["confidence"].startswith("medium: right in ")
        assert set(verdicts[seq]) == {"sequence", "best", "ranking", "basis", "confidence",
                                      "warnings", "confidence_calibration"}
        assert verdicts[seq]["confidence_calibration"]["of"] >= 100
    # the first-listed table cell equals the results file
    m = re.search(r'data-sequence="lab".*?data-metric="corners" data-mean="([^"]+)"', html)
    lab_good = [r["corners"] for r in ok if r["sequence"] == "lab" and r["algorithm"] == "good"]
    assert float(m.group(1)) == pytest.approx(np.mean(lab_good), rel=1e-12)


def test_detail_page_has_overlay_curve_trajectory_and_gif(site):
    _, index = site
    out = index.parent
    page = next((out / "maps").glob("*-office-good-0.html")).read_text(encoding="utf-8")
    srcs = re.findall(r'<img src="\.\./(img/[^"]+)"', page)
    kinds = {Path(s).stem.rsplit("_", 1)[-1] for s in srcs}
    assert {"curve", "build"} <= kinds
    for s in srcs:
        assert (out / s).stat().st_size > 0
    assert "traj" in kinds and "time" in kinds, page  # the map overlay and ATE over time


def test_cli_report(tmp_path, site):
    results, _ = site
    env_py = slamq_env()["PYTHONPATH"]
    run = subprocess.run(
        [sys.executable, "-m", "slamq", "report", str(results), "--out",
         str(tmp_path / "s"), "--details", "gallery", "--no-gifs"],
        capture_output=True, text=True, env={"PYTHONPATH": env_py, "PATH": "/usr/bin:/bin"},
        timeout=300)
    assert run.returncode == 0, run.stderr
    assert (tmp_path / "s" / "index.html").is_file()
    assert len(list((tmp_path / "s" / "maps").glob("*.html"))) == 12
    bad = subprocess.run(
        [sys.executable, "-m", "slamq", "report", str(tmp_path / "none.jsonl"), "--out",
         str(tmp_path / "t")], capture_output=True, text=True,
        env={"PYTHONPATH": env_py, "PATH": "/usr/bin:/bin"}, timeout=120)
    assert bad.returncode == 2
    assert bad.stderr.strip().count("\n") == 0 and "none.jsonl" in bad.stderr


def test_reference_maps_are_shown_but_not_ranked() -> None:
    from slamq.verdict.ranking import rank_sequence
    from slamq.verdict.ranking import summarize as report_summary

    df = pd.DataFrame({
        "sequence": "s",
        "algorithm": ["ground_truth", "a", "b"],
        "corners": [1, 5, 9],
        "occupied_fraction": [0.01, 0.1, 0.2],
        "enclosed_areas": [0, 1, 3],
    })
    r = rank_sequence(report_summary(df), "s")
    assert r.order == ["a", "b"]
    assert r.ground_truths == ["ground_truth"]
    assert "ground_truth" not in r.ranked and r.winner == "a"


def test_user_strings_are_escaped_and_never_read_as_mathtext(tmp_path) -> None:
    """Algorithm, sequence and file names go into HTML escaped, and into the plots as plain
    text (matplotlib would parse ``$\\nope$`` as mathtext and fail)."""
    img = rooms_image(1)
    names = ["<script>alert(1)</script>", "a$\\nope$", "x\"y'z & ü"]
    recs = []
    for k, alg in enumerate(names):
        yaml = write_map(tmp_path / f"maps {k}", img, name=f"m<{k}>")
        for run in range(2):
            recs.append({"map": str(yaml), "algorithm": alg, "sequence": "s <i>$\\x$</i>",
                         "run": run, "occupied_fraction": 0.1 + 0.01 * k + 0.001 * run,
                         "corners": 4 + k, "enclosed_areas": 1, "enclosed_unknown_value": 0,
                         "error": None})
    recs.append({"map": str(tmp_path / "<img src=x onerror=alert(1)>.pgm"), "algorithm": "b",
                 "sequence": "t", "run": 0, "error": "boom <b>"})
    index = build_report(recs, tmp_path / "site", gifs=False)
    pages = [index, *sorted((tmp_path / "site" / "maps").glob("*.html"))]
    assert len(pages) == 1 + 6
    for page in pages:
        text = page.read_text(encoding="utf-8")
        for raw in ("<script>", "<i>$", "<img src=x", "<b>\"", "m<0>", "boom <b>"):
            assert raw not in text, (page.name, raw)
    html = index.read_text(encoding="utf-8")
    assert "&lt;script&gt;alert(1)&lt;/script&gt;" in html
    assert "x&quot;y&#x27;z &amp; ü" in html and "boom &lt;b&gt;" in html
    svg = (tmp_path / "site" / "img" / "plot_corners.svg").read_text(encoding="utf-8")
    assert "&lt;script&gt;" in svg and "<script>" not in svg and "a$\\nope$" in svg


def test_tables_are_exported_as_markdown_and_latex(site):
    _, index = site
    md = (index.parent / "tables.md").read_text(encoding="utf-8").splitlines()
    assert md[0].startswith("| sequence | algorithm | runs |")
    assert len(md) > 2 and all(line.startswith("|") for line in md)
    tex = (index.parent / "tables.tex").read_text(encoding="utf-8")
    assert tex.startswith("\\begin{tabular}") and tex.rstrip().endswith("\\end{tabular}")
    assert "$\\pm$" in tex and "±" not in tex
    page = index.read_text(encoding="utf-8")
    assert 'href="tables.md"' in page and "The maps as they are" in page


def test_ground_truth_columns_ranked_and_overlay_on_detail_pages(tmp_path):
    """A batch with a ground-truth map: GT F1 and GT chamfer in the ranked table (the
    reference shown as "ref."), the aligned overlay on every compared map's detail page."""
    import slamq

    data = Path(__file__).resolve().parent.parent / "data" / "slam_comparison_tools"
    recs = list(slamq.evaluate_many(data, threads=2))
    index = build_report(recs, tmp_path / "site", gifs=False)
    html = index.read_text()
    assert "GT F1" in html and "GT chamfer (m)" in html and ">ref.<" in html
    table = (tmp_path / "site" / "tables.md").read_text()
    assert "GT F1" in table
    pages = sorted((tmp_path / "site" / "maps").glob("*.html"))
    with_overlay = [p for p in pages if "_gt.png" in p.read_text()]
    assert len(with_overlay) == 5 and not any("ground_truth" in p.name for p in with_overlay)
    img = cv2.imread(str(tmp_path / "site" / "img" / (with_overlay[0].stem + "_gt.png")))
    assert img is not None and img.shape[2] == 3
