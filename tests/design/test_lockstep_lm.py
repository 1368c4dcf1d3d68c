"""Lockstep Levenberg–Marquardt, periodic angles and the de-duplication of basins (issue 19).

References are written here: the four-bar coupler point by circle intersection (``fourbar_point``
of test_synthesis), planted designs, hand-built duplicate sets.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.design.synthesis.problem import define, periodic
from loopsolve.design.synthesis.lockstep_lm import batch_lm, distinct, sample
from loopsolve.design.synthesis.run import _polish_floor

from support.models import fourbar_point, PLANT_INPUTS, PLANTED, VARY6
from support.synthesis import FOURBAR


VARY_TURN = dict(VARY6, theta0=(0, 360), phi=(0, 360))


@pytest.fixture(scope="module")
def fourbar():
    return ls.load(FOURBAR)


def closed_form_objective(p, targets, sign):
    return sum(float(np.sum((fourbar_point(p, x, sign) - t) ** 2)) for x, t in zip(PLANT_INPUTS, targets))


def planted_problem(fourbar, p, sign=-1):
    t = np.array([fourbar_point(p, x, sign) for x in PLANT_INPUTS])
    return define(fourbar, path="P", targets={"x": t[:, 0], "y": t[:, 1]}, inputs=PLANT_INPUTS, vary=VARY_TURN), t


def test_batch_lm_crosses_the_periodic_bound_and_recovers_the_planted_design(fourbar):
    """θ0 = 358.5°, φ = 1.5° planted; starts on the other side of 0°/360° reach it, wrapped into [0°, 360°)."""
    p = dict(PLANTED, theta0=358.5, phi=1.5)
    pr, t = planted_problem(fourbar, p)
    exact = np.array([p[n] for n in pr.names])
    starts = np.repeat(exact[None] * 1.004, 3, axis=0)
    i0, i1 = pr.names.index("theta0"), pr.names.index("phi")
    starts[0, i0], starts[0, i1] = 1.0, 358.0  # both angles across the bound
    starts[1, i0], starts[1, i1] = 357.0, 3.0
    starts[2, i0], starts[2, i1] = 2.0, 2.0
    V, X, f = batch_lm(pr, starts, -np.ones((1, 3)), iters=60)
    for v, fv in zip(V, f):
        q = dict(zip(pr.names, v))
        assert fv <= 1e-20
        assert q["theta0"] == pytest.approx(358.5, abs=1e-7) and q["phi"] == pytest.approx(1.5, abs=1e-7)
        assert np.allclose(v, exact, rtol=1e-8, atol=1e-8)
        assert closed_form_objective(q, t, -1) <= 1e-20


def test_batch_lm_polishes_both_modes_in_one_batch(fourbar):
    """One batch holds a design of each assembly mode; each column keeps its mode and reaches its planted optimum."""
    p = dict(PLANTED, theta0=10.0, phi=20.0)
    objs = []
    for sign in (-1, 1):
        pr, t = planted_problem(fourbar, p, sign)
        exact = np.array([p[n] for n in pr.names])
        starts = np.vstack([exact * 1.003, exact * 0.997])
        # column 0 in the planted mode, column 1 in the other: that one cannot reach f = 0
        signs = np.array([[float(sign), float(-sign)]])
        V, X, f = batch_lm(pr, starts, signs, iters=60)
        assert f[0] <= 1e-20 and np.allclose(V[0], exact, rtol=1e-8, atol=1e-8)
        q1 = dict(zip(pr.names, V[1]))
        if np.isfinite(f[1]):  # the other mode's column: its objective is the closed form in that mode
            assert f[1] == pytest.approx(closed_form_objective(q1, t, -sign), rel=1e-9)
            assert f[1] > 1e-12
        objs.append(f[0])
    assert max(objs) <= 1e-20


def test_distinct_drops_duplicates_but_keeps_every_other_basin():
    """Hand-built: a near copy and a copy across 0°/360° are duplicates; the same f elsewhere is another basin."""
    lo, hi = np.array([0.0, 0.0]), np.array([10.0, 360.0])
    V = np.array([[1.0, 0.2],       # 0: best
                  [1.0 + 1e-6, 0.2],  # 1: same basin bottom (duplicate of 0)
                  [1.0, 359.9],     # 2: across the periodic bound: 0.3° from 0 -> duplicate of 0
                  [6.0, 180.0],     # 3: same objective, another place: another basin
                  [1.0, 0.2],       # 4: same place, another objective (a saddle/other level): kept
                  [3.0, 90.0]])     # 5: infinite objective: never
    f = np.array([1.0, 1.0 + 1e-9, 1.0 + 2e-9, 1.0 + 3e-9, 2.0, np.inf])
    per, period = np.array([False, True]), np.array([np.inf, 360.0])
    assert distinct(V, f, lo, hi, k=10, periodic_mask=per, period=period) == [0, 3, 4]
    # without the periodic mask 359.9° is far from 0.2°: kept as its own basin
    assert distinct(V, f, lo, hi, k=10) == [0, 2, 3, 4]
    assert distinct(V, f, lo, hi, k=2, periodic_mask=per, period=period) == [0, 3]


def test_sample_is_inside_the_bounds_log_scaled_and_seeded(fourbar):
    pr, _ = planted_problem(fourbar, dict(PLANTED, theta0=0.0, phi=0.0))
    pr = define(fourbar, path="P", targets={"x": [0, 1, 2], "y": [0, 1, 0]}, inputs=[0, 30, 60],
                vary={"r2": (0.2, 50), "rcx": (-3, 3), "theta0": (0, 360)})
    V = sample(pr, 2000, 7)
    assert np.all(V >= pr.lo) and np.all(V <= pr.hi)
    assert np.array_equal(V, sample(pr, 2000, 7))
    r2 = V[:, pr.names.index("r2")]
    # log scale: half the designs below the geometric mean sqrt(0.2 * 50) = 3.16, not below 25
    assert np.mean(r2 < math.sqrt(0.2 * 50)) == pytest.approx(0.5, abs=0.02)
    per, period = periodic(pr)
    assert list(per) == [False, False, True] and period[2] == pytest.approx(360.0)


def test_synthesize_recovers_a_planted_design_at_the_periodic_bound(fourbar):
    """End to end: θ0 = 359.2°, φ = 0.6° planted (both at the 0°/360° bound) recovered to round-off, certified."""
    p = dict(PLANTED, theta0=359.2, phi=0.6)
    pr, t = planted_problem(fourbar, p)
    res = ls.synthesize(fourbar, path="P", targets={"x": t[:, 0], "y": t[:, 1]}, inputs=PLANT_INPUTS,
                        vary=VARY_TURN, seed=1, popsize=8, maxiter=20, progress=False)
    q = res.report["parameters"]
    assert res.objective <= 1e-20 and res.report["certificate"]["defects"] == []
    assert q["theta0"] == pytest.approx(359.2, abs=1e-6) and q["phi"] == pytest.approx(0.6, abs=1e-6)
    assert closed_form_objective(q, t, -1 if res.report["mode"] == "-" else 1) == pytest.approx(
        res.objective, abs=1e-20)


def test_searches_of_both_modes_in_one_lockstep_batch_equal_the_searches_alone(fourbar):
    """search_many(problems=...) evaluates the generations of a '+' and a '-' search as one batch: same courses."""
    import dataclasses

    from loopsolve.design.synthesis.problem import search, search_many

    t = planted_targets_default()
    pr = define(fourbar, path="P", targets=t, inputs=PLANT_INPUTS, vary=VARY6, mode="any")
    subs = [dataclasses.replace(pr, mode=m) for m in ("+", "-")]
    kw = {"popsize": 6, "maxiter": 10}
    together = search_many(pr, [3, 4], problems=subs, **kw)
    for sub, s, got in zip(subs, [3, 4], together):
        alone = search(sub, seed=s, **kw)
        assert np.allclose(got[0], alone[0], rtol=1e-12, atol=0) and np.allclose(got[1], alone[1], rtol=1e-9)
        assert got[5:7] == alone[5:7]
        # each search's best objective against the circle intersection in its own mode
        q = dict(zip(pr.names, got[0][0]))
        sign = 1 if sub.mode == "+" else -1
        pts = [fourbar_point(q, x, sign) for x in PLANT_INPUTS]
        if all(p is not None for p in pts) and got[1][0] < 1e3:
            ref = sum(float(np.sum((p - np.array([tx, ty])) ** 2)) for p, tx, ty in zip(pts, t["x"], t["y"]))
            assert got[1][0] == pytest.approx(ref, rel=1e-9)


def planted_targets_default():
    pts = np.array([fourbar_point(PLANTED, x, -1) for x in PLANT_INPUTS])
    return {"x": pts[:, 0], "y": pts[:, 1]}


def _counting(monkeypatch):
    """Count the batch evaluations (one per LM iteration, plus the first) of :func:`batch_lm`."""
    from loopsolve.design.synthesis import lockstep_lm

    calls = []
    orig = lockstep_lm.residuals_and_jacobian

    def counted(*a, **k):
        calls.append(a[1].shape[0])
        return orig(*a, **k)

    monkeypatch.setattr(lockstep_lm, "residuals_and_jacobian", counted)
    return calls


def test_batch_lm_exact_fit_stop_keeps_the_planted_optimum(fourbar, monkeypatch):
    """Three starts confirm the planted exact fit: the batch stops early, at the planted design.

    Against the closed form: the three agreeing columns are at the planted design with f ≤ 2e-12 ×
    the floor (the exact polish of synthesize takes them to f ≤ 1e-20, see the next test); a far start
    that would still be crawling is returned as it stands, with the closed-form objective of where
    it stands (not a made-up value).
    """
    p = dict(PLANTED, theta0=10.0, phi=20.0)
    pr, t = planted_problem(fourbar, p)
    exact = np.array([p[n] for n in pr.names])
    far = exact.copy()
    far[pr.names.index("rcx")] = -2.5
    starts = np.vstack([exact * 1.002, exact * 0.998, exact * (1 + 0.001 * np.arange(len(exact))), far])
    signs = -np.ones((1, 4))
    calls = _counting(monkeypatch)
    V0, _, f0 = batch_lm(pr, starts, signs, iters=60)  # no floor: every column to convergence or the cap
    n_plain = len(calls)
    calls.clear()
    floor = _polish_floor(pr)  # the floor synthesize passes
    V, X, f = batch_lm(pr, starts, signs, iters=60, floor=floor)
    assert len(calls) < n_plain  # stopped once three columns agreed on the exact fit
    assert np.min(f0) <= 1e-20
    for j in range(3):  # the three agreeing columns: all at the planted design (the exact polish follows)
        qj = dict(zip(pr.names, V[j]))
        assert closed_form_objective(qj, t, -1) <= 2e-12 * floor
        assert np.allclose(V[j], exact, rtol=1e-6, atol=1e-6)
    if np.isfinite(f[3]):
        q3 = dict(zip(pr.names, V[3]))
        assert f[3] == pytest.approx(closed_form_objective(q3, t, -1), rel=1e-9)


def test_synthesize_with_the_lm_stops_recovers_a_planted_design(fourbar, monkeypatch):
    """End to end with the defaults: the lockstep LM stops early (exact fit confirmed), the exact polish
    stops after a second start lands on it, and the planted design is still found to f ≤ 1e-20
    against the closed form, certified."""
    p = dict(PLANTED, theta0=10.0, phi=20.0)
    pr, t = planted_problem(fourbar, p)
    from loopsolve.design.synthesis import run as synthesis_run

    calls = _counting(monkeypatch)
    polished = []
    orig = synthesis_run.polish

    def counted_polish(*a, **k):
        polished.append(1)
        return orig(*a, **k)

    monkeypatch.setattr(synthesis_run, "polish", counted_polish)
    res = ls.synthesize(fourbar, path="P", targets={"x": t[:, 0], "y": t[:, 1]}, inputs=PLANT_INPUTS,
                        vary=VARY_TURN, seed=3, popsize=8, maxiter=20, progress=False)
    q = res.report["parameters"]
    assert res.objective <= 1e-20
    assert closed_form_objective(q, t, -1 if res.report["mode"] == "-" else 1) <= 1e-20
    assert not res.report["certificate"]["defects"]
    assert len(calls) < 61  # the LM batch stopped before its cap of 60 iterations
    assert len(polished) <= 2  # a second start polished onto the certified exact fit ends the polishing


def test_reassemble_from_a_nearby_position_matches_the_closed_form(fourbar):
    """Newton from a neighbour design's positions gives the coupler point of the circle intersection;
    a NaN start falls back to the multistart assembly; the mode is the one asked for."""
    p = dict(PLANTED, theta0=10.0, phi=20.0)
    pr, t = planted_problem(fourbar, p)
    b = pr.batch
    v = np.array([p[n] for n in pr.names])
    V = np.vstack([v, v * 1.01])
    P = b.params(V)
    x = np.full(2, math.radians(PLANT_INPUTS[0]))
    signs = -np.ones((1, 2))
    Z, ok = b.assemble(b.params(V * 0.99), x, signs)  # positions of nearby designs
    assert ok.all()
    Z[:, 1] = np.nan  # column 1: no start, the multistart assembly must step in
    Zr, okr = b.reassemble(Z, P, x, signs)
    assert okr.all()
    pts = b.points(Zr, P)
    ip = pr.ck.points.index("P")
    for j in range(2):
        q = dict(zip(pr.names, V[j]))
        ref = fourbar_point(q, PLANT_INPUTS[0], -1)
        assert np.allclose(pts[ip, :, j], ref, atol=1e-10)


def test_trust_polish_recovers_a_moved_turned_scaled_design_with_free_timing(fourbar, monkeypatch):
    """Shape synthesis' polish (``trust=True`` with warm poses): twelve points of a planted crank-rocker, moved, turned
    and scaled, met at free inputs; four starts 3 % off in every dimension and ~3° off at every input. Every start
    reaches the planted design — the closed-form objective at its inputs is an exact fit — in no more evaluations
    than the plain damping needs, and the poses it returns are those of the closed form."""
    p = {k: v * 6.5 for k, v in PLANTED.items()} | {"x0": 12.0, "y0": -30.0, "theta0": 35.0}
    inputs = np.arange(0.0, 360.0, 30.0)
    t = np.array([fourbar_point(p, x, -1) for x in inputs])
    vary = {"r1": (1, 100), "r2": (0.5, 50), "r3": (1, 100), "r4": (1, 100), "rcx": (-50, 50), "rcy": (-50, 50),
            "x0": (-100, 100), "y0": (-100, 100), "theta0": (-180, 180)}
    pr = define(fourbar, path="P", targets={"x": t[:, 0], "y": t[:, 1]}, vary=vary)
    exact = np.array([p[n] for n in pr.names])
    rng = np.random.default_rng(3)
    starts = exact[None] * (1 + 0.03 * rng.standard_normal((4, len(exact))))
    X0 = np.radians(inputs)[:, None] + 0.05 * rng.standard_normal((len(inputs), 4))
    signs = -np.ones((1, 4))
    calls = _counting(monkeypatch)
    evals = {}
    for trust in (False, True):
        calls.clear()
        V, X, f, Z = batch_lm(pr, starts, signs, X0, iters=120, warm=True, poses=True, trust=trust)
        evals[trust] = len(calls)
    assert evals[True] <= evals[False]
    for j in range(4):
        q = dict(zip(pr.names, V[j]))
        assert np.allclose(V[j], exact, rtol=1e-8, atol=1e-8)
        got = np.array([fourbar_point(q, x, -1) for x in np.degrees(X[:, j])])  # X: theta2 at each target (rad)
        assert np.sum((got - t) ** 2) <= 1e-20
        ip = pr.ck.points.index("P")
        pts = pr.batch.points(Z[:, :, j], np.repeat(pr.batch.params(V[j][None]), len(inputs), axis=1))[ip].T
        assert np.allclose(pts, got, atol=1e-9)


def _free_timing_problem(fourbar, p, inputs, vary):
    t = np.array([fourbar_point(p, x, -1) for x in inputs])
    return define(fourbar, path="P", targets={"x": t[:, 0], "y": t[:, 1]}, vary=vary), t


def _free_opts(pr):
    from loopsolve.design.synthesis.run import _FREE_INPUT_STEP, _STALL, _STALL_DROP

    return dict(trust=True, pin=True, free_step=_FREE_INPUT_STEP, stall=(_STALL, _STALL_DROP), floor=_polish_floor(pr))


VARY_FREE = dict(VARY6, theta0=(0, 360))  # (no φ: with free timing it is a shift of every input)


def test_free_timing_lockstep_polish_recovers_a_planted_coupler_curve(fourbar):
    """The polish synthesize runs with free timing (MINPACK scaling, active set, stall stop, capped input steps, the
    free-timing floor): ten points of a planted crank-rocker met at unknown inputs; starts 1 % off in every
    dimension and ~2° off at every input end at the planted design, an exact fit against the closed form."""
    p = dict(PLANTED, theta0=25.0)
    inputs = np.arange(5.0, 360.0, 36.0)
    pr, t = _free_timing_problem(fourbar, p, inputs, VARY_FREE)
    exact = np.array([p[n] for n in pr.names])
    rng = np.random.default_rng(7)
    starts = exact[None] * (1 + 0.01 * rng.standard_normal((3, len(exact))))
    X0 = np.radians(inputs)[:, None] + 0.03 * rng.standard_normal((len(inputs), 3))
    V, X, f = batch_lm(pr, starts, -np.ones((1, 3)), X0, iters=60, **_free_opts(pr))
    j = int(np.argmin(f))
    assert f[j] < 1e-20
    q = dict(zip(pr.names, V[j]))
    got = np.array([fourbar_point(q, x, -1) for x in np.degrees(X[:, j])])
    assert np.sum((got - t) ** 2) < 1e-20  # the closed form at the returned inputs, not the solver's own value
    assert np.allclose(V[j], exact, rtol=1e-7, atol=1e-7)


def test_free_timing_floor_is_far_below_a_real_optimum(fourbar):
    """The exact-fit floor of free timing is a round-off level (1e-12 of the spread), not the prescribed timing's
    1e-6 that was about twice the published ellipse's optimum and stopped its polish early."""
    phi = np.radians(np.arange(0, 361, 40))
    t = np.stack([10 + 10 * np.cos(phi), 10 + 8 * np.sin(phi)], axis=1)
    pr = define(fourbar, path="P", targets={"x": t[:, 0], "y": t[:, 1]}, vary=VARY_FREE)
    prescribed = define(fourbar, path="P", targets={"x": t[:, 0], "y": t[:, 1]}, vary=VARY_FREE,
                        inputs=list(np.degrees(phi) * 0.99))
    assert _polish_floor(pr) < 1e-5 * 4.02e-4  # (8.3e-10)
    assert _polish_floor(prescribed) == pytest.approx(1e6 * _polish_floor(pr))


def test_active_set_holds_a_length_on_its_bound_at_the_bounded_minimum(fourbar):
    """Ten points of a planted crank-rocker with r4 = 3.2, but r4 bounded to [2, 3]: the bounded free-timing minimum
    has r4 on its bound. The lockstep polish (active set on) reaches it: same objective and design as an
    independent reference — scipy's bounded ``least_squares`` on the closed-form coupler point, written here."""
    from scipy.optimize import least_squares

    p = dict(PLANTED, theta0=25.0)
    inputs = np.arange(5.0, 360.0, 36.0)
    vary = dict(VARY_FREE, r4=(2.0, 3.0))
    pr, t = _free_timing_problem(fourbar, p, inputs, vary)
    names, k = pr.names, len(pr.names)
    v0 = np.array([p[n] for n in names])
    v0[names.index("r4")] = 3.0
    u0 = np.concatenate([v0, inputs])

    def res(u):
        q = dict(zip(names, u[:k]))
        pts = [fourbar_point(q, x, -1) for x in u[k:]]
        if any(pt is None for pt in pts):
            return np.full(2 * len(inputs), 1e3)
        return (np.array(pts) - t).ravel()

    lo = np.concatenate([pr.lo, np.full(len(inputs), -np.inf)])
    hi = np.concatenate([pr.hi, np.full(len(inputs), np.inf)])
    ref = least_squares(res, u0, bounds=(lo, hi), method="trf", x_scale="jac", xtol=1e-15, ftol=1e-15, gtol=1e-15)
    f_ref = float(np.sum(res(ref.x) ** 2))
    assert ref.x[names.index("r4")] == pytest.approx(3.0, abs=1e-9)  # the reference's minimum is on the bound
    assert f_ref > 1e-6  # and not an exact fit: the bound matters

    V, X, f = batch_lm(pr, v0[None], -np.ones((1, 1)), np.radians(inputs)[:, None], iters=60, **_free_opts(pr))
    q = dict(zip(names, V[0]))
    assert q["r4"] == 3.0  # held on its bound, exactly
    got = np.array([fourbar_point(q, x, -1) for x in np.degrees(X[:, 0])])
    assert np.sum((got - t) ** 2) == pytest.approx(f[0], rel=1e-9)
    assert f[0] == pytest.approx(f_ref, rel=1e-6)
    assert np.allclose(V[0], ref.x[:k], rtol=1e-5, atol=1e-5)
