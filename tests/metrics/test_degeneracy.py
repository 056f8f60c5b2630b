"""Scans that see walls in one direction only (docs/spec.md 7c, slamq.scan_degeneracy): a
corridor's scans are degenerate and a room's are not, the Rust core gives its numpy twin's
ratios for any thread count, and bad input is refused with the recording's name."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import slamq
from slamq.errors import SequenceError
from slamq.metrics.degeneracy import (
    DEGENERATE_RATIO,
    MIN_LINE_POINTS,
    scan_degeneracy,
    scan_ratios,
    scan_ratios_reference,
)
from slamq.models import ScanDegeneracy, Scans
from slamq.synth import LaserSpec, simulate, world

_A = np.linspace(-np.pi, np.pi, 360, endpoint=False)


def _corridor(half_width: float = 1.0, turn: float = 0.0) -> np.ndarray:
    """Ranges from the middle of a straight corridor (walls at +-half_width), its axis at
    ``turn`` radians from the laser's heading (50 m where a beam runs along it)."""
    return np.minimum(half_width / np.abs(np.sin(_A - turn)).clip(1e-9), 50.0)


def _room(side: float = 4.0) -> np.ndarray:
    """Ranges from the centre of a square room."""
    h = side / 2
    return np.minimum(h / np.abs(np.cos(_A)).clip(1e-9), h / np.abs(np.sin(_A)).clip(1e-9))


def test_a_corridor_scan_is_degenerate_and_a_room_scan_is_not() -> None:
    s = Scans.from_layout(np.arange(3.0), -np.pi, 2 * np.pi / 360,
                          [_corridor(), _corridor(turn=0.7), _room()], 60.0)
    r = scan_ratios(s)
    assert r[0] < 1e-6 and r[1] < 1e-6  # whatever the corridor's direction
    assert r[2] > 0.9
    d = scan_degeneracy(s)
    assert isinstance(d, ScanDegeneracy)
    assert d.share == pytest.approx(2 / 3) and d.scored == 3
    assert d.to_dict() == {"degenerate_share": d.share, "scored": 3, "with_ratio": 3}
    assert slamq.scan_degeneracy is scan_degeneracy


def test_a_scan_with_too_few_straight_endpoints_has_no_ratio() -> None:
    # eight beams: no endpoint has six near neighbours
    s = Scans.from_layout([0.0], -np.pi, np.pi / 4, [np.full(8, 2.0)], 10.0)
    assert math.isnan(scan_ratios(s)[0])
    assert math.isnan(scan_degeneracy(s).share)
    # every beam without a return: no endpoint at all
    s = Scans.from_layout([0.0], -np.pi, 2 * np.pi / 360, [np.full(360, np.inf)], 10.0)
    assert math.isnan(scan_ratios(s)[0])


def test_max_scans_spreads_the_scored_scans_evenly() -> None:
    rows = [_corridor()] * 10 + [_room()] * 10
    s = Scans.from_layout(np.arange(20.0), -np.pi, 2 * np.pi / 360, rows, 60.0)
    full, part = scan_degeneracy(s), scan_degeneracy(s, max_scans=4)
    assert full.share == 0.5 and full.scored == 20
    assert part.scored == 4 and part.share == 0.5  # scans 0, 6, 13, 19


@pytest.mark.parametrize("kind, degenerate", [("corridor", True), ("office", False),
                                               ("hall", False)])
def test_simulated_worlds_separate_at_the_verdict_threshold(kind: str, degenerate: bool
                                                           ) -> None:
    # the benchmark's laser (1081 beams over 270 degrees): a corridor world's recording has
    # at least 2% of its scans degenerate, an office's or a hall's fewer
    from slamq.verdict.rule import DEGENERATE_SHARE

    seq = simulate(world(3, kind=kind), seed=1, noise="none", laser=LaserSpec(), length=60.0)
    share = scan_degeneracy(Scans.from_sequence(seq)).share
    assert (share >= DEGENERATE_SHARE) is degenerate, share


@st.composite
def scans(draw: st.DrawFn) -> Scans:
    """A few scans of a few straight walls (each a stretch of beams at a range that
    follows one line), with gaps and noise."""
    beams = draw(st.integers(20, 120))
    angles = np.sort(np.asarray(draw(st.lists(
        st.floats(-3.1, 3.1, allow_nan=False), min_size=beams, max_size=beams, unique=True))))
    rows = []
    for _ in range(draw(st.integers(1, 4))):
        r = np.empty(beams)
        start = 0
        while start < beams:
            n = draw(st.integers(1, beams - start))
            d = draw(st.floats(0.3, 8.0))
            phi = draw(st.floats(-3.1, 3.1))
            with np.errstate(divide="ignore"):
                seg = d / np.cos(angles[start:start + n] - phi)
            r[start:start + n] = np.where(seg > 0, seg, np.inf)
            start += n
        noise = draw(st.floats(0.0, 0.05))
        r = r + noise * np.sin(np.arange(beams) * 12.9898)
        r[np.asarray(draw(st.lists(st.integers(0, beams - 1), max_size=5)), dtype=int)] = np.nan
        rows.append(r)
    return Scans(np.arange(float(len(rows))), angles, np.asarray(rows), 30.0,
                 min_range=draw(st.sampled_from([0.0, 0.5])))


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(scans())
def test_rust_equals_the_numpy_twin(s: Scans) -> None:
    rust, ref = scan_ratios(s), scan_ratios_reference(s)
    assert np.array_equal(np.isnan(rust), np.isnan(ref))
    both = ~np.isnan(rust)
    assert np.allclose(rust[both], ref[both], rtol=0, atol=1e-9)
    far = both & (np.abs(ref - DEGENERATE_RATIO) > 1e-9)
    assert np.array_equal(rust[far] < DEGENERATE_RATIO, ref[far] < DEGENERATE_RATIO)


def test_walls_facing_every_way_give_the_twin_s_ratio_to_the_last_bits() -> None:
    """The case hypothesis found on 2026-12-01 (a wall bent round the laser, endpoints a
    few 1e-8 m apart where the beams' angles are subnormal): the scan's two eigenvalues
    nearly equal, where ``sqrt(h^2 - (ab - c^2))`` turned the sums' last bits into 2e-9 of
    the ratio. ``h +- hypot((a - b) / 2, c)`` does not cancel there (docs/spec.md 7c)."""
    angles = np.array([-3.0, -2.0, -1.96875, -1.9375, -1.875, -1.75, -1.5, -1.25, -1.0, 0.0,
                       2.2250738585072034e-309, 1.1125369292536007e-308,
                       2.2250738585072014e-308, 1.4492268043533640e-291,
                       8.4121902048873266e-277, 3.0840633207843707e-275,
                       1.0128204395817511e-203, 7.0739202478738254e-088,
                       1.4012984643248171e-045, 0.125, 0.25, 0.5, 0.75, 1.0, 1.25, 1.5,
                       1.75, 2.0, 3.0])
    ranges = np.array([[np.inf] * 6 + [
        14.136832936675198, 3.1713577042995613, 1.8508157031747337, 0.999999963020381,
        0.9999999470786485, 0.9999999404843926, 0.999999944402354, 0.9999999581405046,
        0.9999999792722807, 1.0000000040651853, 1.0000000281400578, 1.0000000472445636,
        1.0000000580042816, 1.0078637463990452, 1.03208507268142, 1.139493957598553,
        1.366701131175915, 1.8508156992655553, 3.1713576536883736,
        14.136832848301433] + [np.inf] * 3])
    s = Scans(np.array([0.0]), angles, ranges, 30.0)
    rust, ref = scan_ratios(s), scan_ratios_reference(s)
    assert rust[0] > 0.99  # walls facing every way
    assert abs(rust[0] - ref[0]) < 1e-12, (rust, ref)


def test_the_twin_and_thread_counts_agree_on_a_simulated_drive() -> None:
    seq = simulate(world(5, kind="corridor"), seed=2, noise="low", laser=LaserSpec(beams=361),
                   length=30.0)
    s = Scans.from_sequence(seq)
    one = scan_ratios(s, threads=1)
    assert np.array_equal(one, scan_ratios(s, threads=2), equal_nan=True)
    ref = scan_ratios_reference(s)
    assert np.allclose(one, ref, rtol=0, atol=1e-9, equal_nan=True)
    assert np.isfinite(one).sum() > 0.5 * len(s)
    assert MIN_LINE_POINTS == 10


def test_bad_input_is_refused_with_its_name() -> None:
    s = Scans.from_layout([0.0], -np.pi, 2 * np.pi / 360, [_room()], 60.0, source="lab.bag")
    with pytest.raises(SequenceError, match="lab.bag.*max_scans"):
        scan_degeneracy(s, max_scans=0)
    with pytest.raises(slamq.ParamError):
        scan_ratios(s, threads=-1)
    # a layout without beams: no scan has a ratio, in the core as in the twin
    empty = Scans(np.arange(2.0), np.zeros(0), np.zeros((2, 0)), 10.0, source="empty.log")
    assert np.isnan(scan_ratios(empty)).all() and len(scan_ratios(empty)) == 2
    assert np.isnan(scan_ratios_reference(empty)).all()
    assert math.isnan(scan_degeneracy(empty).share)
