"""A fan of many four-bar loops on one crank: info and sweeps finish and match the closed forms.

The reachable range of the crank is found block by block (not over the 2^N combinations of
assembly modes), and Newton evaluates only the structural non-zeros of Φ_q, so a 40-loop fan
runs in seconds. Every value is compared with the law of cosines written here (support/models.py).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import loopsolve as ls

from support.models import crank_range, fan_lengths, fan_model


N = 40


@pytest.fixture(scope="module")
def fan():
    return ls.loads(fan_model(N), source="fan40.toml")


def _wrap(a):
    return (np.asarray(a) + math.pi) % (2 * math.pi) - math.pi


def _pose(g, c, o, t2):
    """θ3, θ4 of one loop at crank angle t2, the branch with θ4 = φ + γ (independent of support/models.py)."""
    B = np.exp(1j * t2)
    D = g + 0j
    d = abs(B - D)
    phi = np.angle(B - D)
    gam = np.arccos((o * o + d * d - c * c) / (2 * o * d))
    t4 = phi + gam
    C = D + o * np.exp(1j * t4)
    return np.angle(C - B), t4


def test_fan_closed_form_helper_matches_law_of_cosines():
    g, c, o = 4.04, 1.62, 2.04  # a triple rocker: the crank rocks while the diagonal <= c + o
    lo, hi = crank_range(g, c, o)
    assert abs(1 + g * g - 2 * g * math.cos(hi) - (c + o) ** 2) < 1e-12 and lo == -hi


def test_info_fan_per_loop_ranges(fan):
    d = fan.info()
    L = fan_lengths(N)
    assert len(d["blocks"]) == N and all(len(b) == 2 for b in d["blocks"])
    assert len(d["fourbars"]) == N
    lo_all, hi_all = -math.pi, math.pi
    for k, fb in enumerate(d["fourbars"]):
        assert fb["loop"] == f"L{k}"
        cr = crank_range(*L[k])
        if cr is None:
            assert fb["input_motion"] != "rocks"
            continue
        (a, b), = fb["input_range"]
        assert a == pytest.approx(math.degrees(cr[0]), abs=1e-7)
        assert b == pytest.approx(math.degrees(cr[1]), abs=1e-7)
        lo_all, hi_all = max(lo_all, cr[0]), min(hi_all, cr[1])
    (a, b), = d["reachable_input_ranges"]
    assert a == pytest.approx(math.degrees(lo_all), abs=1e-7)
    assert b == pytest.approx(math.degrees(hi_all), abs=1e-7)


def test_sweep_fan_rows_and_limit(fan):
    L = fan_lengths(N)
    hi = min(cr[1] for cr in map(lambda l: crank_range(*l), L) if cr is not None)
    with pytest.warns(ls.LoopsolveWarning):  # the sweep stops at the limit and says so
        sw = fan.sweep(0, 90, 10)
    assert sw.events[-1].kind.value == "limit"
    assert sw.events[-1].input == pytest.approx(math.degrees(hi), abs=1e-6)
    t2 = np.radians(sw["theta2"])
    assert np.all(t2 <= hi + 1e-12) and len(t2) == 1 + int(math.degrees(hi) // 10)
    for k, (g, c, o) in enumerate(L):
        t3, t4 = _pose(g, c, o, t2)
        assert np.max(np.abs(_wrap(np.radians(sw[f"t3_{k}"]) - t3))) < 1e-6
        assert np.max(np.abs(_wrap(np.radians(sw[f"t4_{k}"]) - t4))) < 1e-6


def test_solve_fan_matches_closed_form(fan):
    # at the guessed input value (a solve elsewhere selects the guessed mode by enumerating
    # every mode, still 2^N: see the closing note of the perf branch)
    L = fan_lengths(N)
    r = fan.solve(0)
    for k, (g, c, o) in enumerate(L):
        t3, t4 = _pose(g, c, o, 0.0)
        assert abs(_wrap(math.radians(r[f"t3_{k}"]) - t3)) < 1e-10
        assert abs(_wrap(math.radians(r[f"t4_{k}"]) - t4)) < 1e-10
