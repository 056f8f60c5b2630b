"""The report page in a real browser: headless Chromium (Debian's ``chromium``) via Playwright.

Checks: no console error and no failed request, every image decodes (non-zero natural
size), the ranking tables hold the results file's numbers, gallery links open the detail
pages, each layer of a detail page (the missing walls too) lies over the map and its
checkbox shows and hides it; screenshots are saved under test-artifacts/ (git-ignored).
"""

from __future__ import annotations

import json
import math
import os
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from slamq.report import build_report

REPO = Path(__file__).resolve().parents[2]
ARTIFACTS = REPO / "test-artifacts"


def _chromium() -> str:
    for name in (os.environ.get("SLAMQ_CHROMIUM", ""), "chromium", "chromium-browser",
                 "google-chrome"):
        if name and shutil.which(name):
            return shutil.which(name)
    pytest.skip("no chromium executable found (apt-get install chromium, or set "
                "SLAMQ_CHROMIUM): the report is not checked in a browser")


@pytest.fixture(scope="module")
def browser():
    sync_api = pytest.importorskip("playwright.sync_api",
                                   reason="playwright for Python is not installed")
    exe = _chromium()
    with sync_api.sync_playwright() as p:
        b = p.chromium.launch(executable_path=exe, args=["--no-sandbox"])
        yield b
        b.close()


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    from test_report import make_results

    root = tmp_path_factory.mktemp("browser")
    results = make_results(root)
    return results, build_report(results, root / "site")


def _open(browser, url: str):
    page = browser.new_page(viewport={"width": 1280, "height": 900})
    problems: list[str] = []
    page.on("console", lambda m: problems.append(f"console {m.type}: {m.text}")
            if m.type in ("error", "warning") else None)
    page.on("pageerror", lambda e: problems.append(f"page error: {e}"))
    page.on("requestfailed", lambda r: problems.append(f"failed request: {r.url}"))
    page.on("response", lambda r: problems.append(f"HTTP {r.status}: {r.url}")
            if r.status >= 400 else None)
    page.goto(url, wait_until="load")
    return page, problems


def _broken_images(page) -> list[str]:
    return page.evaluate(
        "() => Array.from(document.images).filter(i => !(i.complete && i.naturalWidth > 0 "
        "&& i.naturalHeight > 0)).map(i => i.getAttribute('src'))")


def test_index_loads_clean_and_matches_results(browser, report):
    results, index = report
    page, problems = _open(browser, index.as_uri())
    n_images = page.evaluate("() => document.images.length")
    assert n_images >= 12 + 4                       # gallery thumbnails + plots
    assert _broken_images(page) == []
    # every requested URL is a local file inside the site
    assert page.evaluate(
        "() => performance.getEntriesByType('resource').every(e => e.name.startsWith('file:'))")

    recs = [json.loads(x) for x in results.read_text().splitlines()]
    ok = [r for r in recs if r.get("error") is None]
    cells = page.evaluate(
        "() => Array.from(document.querySelectorAll('table.ranking td[data-metric]')).map("
        "td => ({seq: td.closest('table').dataset.sequence, "
        "alg: td.closest('tr').dataset.algorithm, metric: td.dataset.metric, "
        "mean: td.dataset.mean, std: td.dataset.std, n: td.dataset.n, text: td.innerText}))")
    # sequences x algorithms x (4 metrics + the agreement the verdict rests on)
    assert len(cells) == 2 * 3 * 5
    agreement = [c for c in cells if c["metric"] == "agreement"]
    assert len(agreement) == 6 and all(0 < float(c["mean"]) <= 1 for c in agreement)
    cells = [c for c in cells if c["metric"] != "agreement"]  # not a column of the results
    shares = page.evaluate(
        "() => Array.from(document.querySelectorAll('table.ranking td[data-known-share]'))"
        ".map(td => td.innerText)")
    assert len(shares) == 2 * 3 and all(t.endswith("%") for t in shares)
    for c in cells:
        vals = [float(r[c["metric"]]) for r in ok if r["sequence"] == c["seq"]
                and r["algorithm"] == c["alg"] and r.get(c["metric"]) is not None
                and math.isfinite(float(r[c["metric"]]))]
        assert int(c["n"]) == len(vals)
        if not vals:
            assert c["text"].strip() == "–"
            continue
        mean = float(np.mean(vals))
        assert float(c["mean"]) == pytest.approx(mean, rel=1e-12, abs=1e-15)
        if len(vals) > 1:
            assert float(c["std"]) == pytest.approx(float(np.std(vals, ddof=1)), rel=1e-12,
                                                    abs=1e-15)
        shown = re.findall(r"[-+]?\d*\.?\d+(?:e[-+]?\d+)?", c["text"])
        assert float(shown[0]) == pytest.approx(mean, rel=6e-3, abs=1e-12), c

    ARTIFACTS.mkdir(exist_ok=True)
    shot = ARTIFACTS / "report_index.png"
    page.screenshot(path=str(shot), full_page=True)
    print(f"\nreport screenshot: {shot}")
    assert shot.stat().st_size > 10_000
    assert problems == []
    page.close()


def test_gallery_links_open_detail_pages(browser, report):
    _, index = report
    page, problems = _open(browser, index.as_uri())
    links = page.evaluate(
        "() => Array.from(document.querySelectorAll('.gallery a.detail')).map(a => a.href)")
    assert len(links) == 12
    page.click(".gallery a.detail >> nth=0")
    page.wait_for_load_state("load")
    assert page.url == links[0]
    assert page.locator("h1").inner_text()
    assert page.locator("table.numbers").count() == 1
    assert _broken_images(page) == []
    for url in links[1:]:
        page.goto(url, wait_until="load")
        assert "run" in page.locator("h1").inner_text()
        assert _broken_images(page) == []
        assert page.locator("img").count() >= 2     # overlay + curve at least
    gif_page = next(u for u in links if u.endswith("-office-good-0.html"))
    page.goto(gif_page, wait_until="load")
    page.screenshot(path=str(ARTIFACTS / "report_detail.png"), full_page=True)
    page.click("text=back to the report")
    page.wait_for_load_state("load")
    assert page.url == index.as_uri()
    assert problems == []
    page.close()


@pytest.fixture(scope="module")
def office_report(tmp_path_factory):
    """The shipped slam_comparison_tools office world (five SLAM maps and a ground-truth
    map), with a hand-made defect on every map through the report's defects_for hook."""
    import slamq

    data = REPO / "tests" / "data" / "slam_comparison_tools"
    root = tmp_path_factory.mktemp("office")
    recs = list(slamq.evaluate_many(data, threads=2))

    def defects_for(grid):
        h, w = grid.shape
        return [{"kind": "test box", "bbox": [w // 4, h // 4, w // 2, h // 2],
                 "note": "hand-made"}]

    return build_report(recs, root / "site", gifs=False, trajectories=False,
                        defects_for=defects_for)


_LAYER_STATE = (
    "() => Object.fromEntries(Array.from(document.querySelectorAll('.stack .layer')).map("
    "e => [e.classList[1].replace('layer-', ''), getComputedStyle(e).display !== 'none']))")
_BOXES = (
    "() => { const b = document.querySelector('.stack img.base').getBoundingClientRect();"
    " return Array.from(document.querySelectorAll('.stack .layer')).filter("
    "e => getComputedStyle(e).display !== 'none').map(e => {"
    " const r = e.getBoundingClientRect(); return [r.left - b.left, r.top - b.top,"
    " r.width - b.width, r.height - b.height]; }); }")


def test_gallery_is_plain_maps_and_layers_toggle(browser, office_report):
    """Thumbnails are small plain maps; on a detail page each layer (enclosed areas,
    corners, ground truth, defects) lies exactly over the map and its checkbox shows and
    hides it, in a real browser without a server."""
    page, problems = _open(browser, office_report.as_uri())
    sizes = page.evaluate(
        "() => Array.from(document.querySelectorAll('.gallery img')).map("
        "i => [i.naturalWidth, i.naturalHeight])")
    assert len(sizes) == 6 and all(0 < max(s) <= 230 for s in sizes)
    assert page.locator(".gallery .thumb .badge").count() == 6       # "1 defect" each
    ARTIFACTS.mkdir(exist_ok=True)
    page.locator(".gallery").first.screenshot(path=str(ARTIFACTS / "report_gallery.png"))
    url = next(u for u in page.evaluate(
        "() => Array.from(document.querySelectorAll('.gallery a.detail')).map(a => a.href)")
        if "gmapping" in u)
    page.goto(url, wait_until="load")
    assert _broken_images(page) == []
    # the plain map at first: every layer off
    assert page.evaluate(_LAYER_STATE) == {"regions": False, "corners": False, "gt": False,
                                           "defects": False}
    assert page.evaluate(_BOXES) == []
    page.locator(".mapcol").screenshot(path=str(ARTIFACTS / "report_layers_default.png"))
    for key in ("regions", "corners", "defects"):
        page.check(f"#show-{key}")
    boxes = page.evaluate(_BOXES)                    # every layer covers the map exactly
    assert len(boxes) == 3 and all(abs(v) < 0.5 for box in boxes for v in box), boxes
    assert page.locator(".layer-defects text").text_content() == "1 test box"
    page.check("#show-gt")
    boxes = page.evaluate(_BOXES)
    assert len(boxes) == 4 and all(abs(v) < 0.5 for box in boxes for v in box), boxes
    for key in ("regions", "corners", "defects"):
        page.uncheck(f"#show-{key}")
    assert page.evaluate(_LAYER_STATE) == {"regions": False, "corners": False, "gt": True,
                                           "defects": False}
    page.locator(".mapcol").screenshot(path=str(ARTIFACTS / "report_layers_gt_only.png"))
    page.uncheck("#show-gt")
    assert not any(page.evaluate(_LAYER_STATE).values())
    page.click("label[for=show-corners]")            # the label toggles too
    assert page.evaluate(_LAYER_STATE)["corners"] is True
    assert problems == []
    page.close()


@pytest.fixture(scope="module")
def gap_report(tmp_path_factory):
    """A sequence without ground truth in which one map has a 2 m gap the two others close
    (test_report_pages.write_gap_sequence); the detail page of that map."""
    from test_report_pages import write_gap_sequence

    root = tmp_path_factory.mktemp("gap")
    recs, own, _ = write_gap_sequence(root / "maps")
    index = build_report(recs, root / "site", gifs=False, trajectories=False)
    (page,) = (index.parent / "maps").glob("*-gap-*.html")
    return page, own


def test_missing_walls_layer_toggles_over_the_gap(browser, gap_report):
    """The missing-walls layer is off at first; its checkbox (or its label) shows it, over
    the map like the other layers, with its box on the gap's cells as the browser draws
    them; unchecked it hides again."""
    url, own = gap_report
    page, problems = _open(browser, url.as_uri())
    assert _broken_images(page) == []
    assert page.evaluate(_LAYER_STATE) == {"regions": False, "corners": False,
                                           "missing": False}
    page.check("#show-regions")
    page.check("#show-corners")
    label = page.locator("label[for=show-missing]").inner_text()
    assert "informational" in label and "not used by the verdict" in label
    page.check("#show-missing")
    assert page.evaluate(_LAYER_STATE) == {"regions": True, "corners": True,
                                           "missing": True}
    boxes = page.evaluate(_BOXES)
    assert len(boxes) == 3 and all(abs(v) < 0.5 for box in boxes for v in box), boxes
    # the box on screen, in the map's cells: the base picture spans the viewBox
    x0, y0, w0, h0 = map(float, page.locator(".layer-missing").get_attribute(
        "viewBox").split())
    base = page.locator(".stack img.base").bounding_box()
    rect = page.locator(".layer-missing rect").bounding_box()
    sx, sy = w0 / base["width"], h0 / base["height"]
    cells = ((rect["x"] - base["x"]) * sx + x0, (rect["y"] - base["y"]) * sy + y0,
             rect["width"] * sx, rect["height"] * sy)
    r, c = np.nonzero(own)
    inside = (c + 0.5 >= cells[0]) & (c + 0.5 <= cells[0] + cells[2]) \
        & (r + 0.5 >= cells[1]) & (r + 0.5 <= cells[1] + cells[3])
    assert inside.mean() >= 0.8, cells
    assert "missing wall" in page.locator(".layer-missing text").text_content()
    ARTIFACTS.mkdir(exist_ok=True)
    page.locator(".mapcol").screenshot(path=str(ARTIFACTS / "report_layers_missing.png"))
    page.uncheck("#show-missing")
    assert page.evaluate(_LAYER_STATE)["missing"] is False
    page.click("label[for=show-missing]")             # the label toggles too
    assert page.evaluate(_LAYER_STATE)["missing"] is True
    assert problems == []
    page.close()


_OVERFLOW = "() => [document.documentElement.scrollWidth, window.innerWidth]"
_CHECKED = ("() => Array.from(document.querySelectorAll('input[type=checkbox]:checked'))"
            ".map(i => i.id)")


@pytest.mark.parametrize("width", [1400, 400])
def test_pages_fit_the_screen_and_open_on_the_plain_map(browser, office_report, width):
    """At 1400 and 400 px the index and a detail page never scroll sideways (wide tables
    scroll inside their own box, pictures shrink to the width), every picture keeps its
    aspect ratio, and no layer is drawn before its checkbox is ticked (issue 42, 6 and 8)."""
    site = office_report.parent
    detail = next((site / "maps").glob("*-gmapping-*.html"))
    for url in (office_report.as_uri(), detail.as_uri()):
        page = browser.new_page(viewport={"width": width, "height": 900})
        page.goto(url, wait_until="load")
        scroll_width, inner = page.evaluate(_OVERFLOW)
        assert scroll_width <= inner, (url, width, scroll_width)
        assert page.evaluate(_CHECKED) == []
        if "maps/" in url:
            assert page.evaluate(_LAYER_STATE) and not any(page.evaluate(_LAYER_STATE).values())
        # every picture within the page and undistorted (scaled, not cropped)
        bad = page.evaluate(
            "() => Array.from(document.images).filter(i => i.naturalWidth > 0).filter(i => {"
            " const r = i.getBoundingClientRect();"
            " return r.right > window.innerWidth + 0.5 || Math.abs(r.width / r.height -"
            " i.naturalWidth / i.naturalHeight) > 0.02 * i.naturalWidth / i.naturalHeight;"
            "}).map(i => i.getAttribute('src'))")
        assert bad == [], (url, width, bad)
        # a table wider than the screen scrolls inside its box
        tables = page.evaluate(
            "() => Array.from(document.querySelectorAll('table')).map(t => "
            "[t.parentElement.className, getComputedStyle(t.parentElement).overflowX])")
        assert all(c == "scroll" and o == "auto" for c, o in tables), tables
        ARTIFACTS.mkdir(exist_ok=True)
        name = "index" if url.endswith("index.html") else "detail"
        page.screenshot(path=str(ARTIFACTS / f"report_{name}_{width}.png"))
        page.close()
