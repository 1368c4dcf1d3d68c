"""Shape synthesis: planted designs (a four-bar and a Stephenson III six-bar, moved, turned and scaled) recovered to
their dimensions; every reported four-bar candidate re-checked against the circle-intersection closed form
written here (one circuit, a full turn for a closed curve, the distances of the targets, the transmission
angle); open curves; the placement written into the model."""

from __future__ import annotations

import math

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.design.atlas.build import build_atlas
from loopsolve.design.synthesis.shape.run import synthesize_shape

pytest.importorskip("zarr", reason="atlases need zarr (the study extra)")

FOURBAR = ls.models_dir() / "fourbar_path_synthesis.toml"
STEPH = ls.models_dir() / "stephenson3_sixbar_path.toml"
VARY = {"r2": (0.4, 4.0), "r3": (1.6, 16.0), "r4": (1.6, 16.0), "rcx": (-8.0, 16.0), "rcy": (-12.0, 12.0)}
STEPH_VARY = {"r2": (10, 40), "r3": (30, 120), "r4": (25, 100), "rc": (10, 100), "gamma": (0, 360),
              "r5": (30, 150), "r6": (30, 150), "r7": (30, 200), "beta": (0, 360), "pcx": (-60, 120),
              "pcy": (-80, 80)}


@pytest.fixture(scope="module")
def fourbar():
    return ls.load(FOURBAR)


@pytest.fixture(scope="module")
def atlas(fourbar, tmp_path_factory):
    path = tmp_path_factory.mktemp("shape") / "fb.zarr"
    return build_atlas(fourbar, point="P", vary=VARY, size=2048, chunk=1024, out=path, step_deg=4.0, progress=False)


def similarity(xy, angle_deg, scale, shift):
    a = math.radians(angle_deg)
    R = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    return xy @ R.T * scale + np.asarray(shift)


def traced(mech, point, step=5.0):
    sw = mech.sweep(0, 360, step, progress=False)
    return np.stack([sw.columns[f"{point}_x"], sw.columns[f"{point}_y"]], axis=1)[:-1]


# ----------------------------------------------------------------------------- the closed form


def coupler_curve(p, t_deg, sign):
    """P of the four-bar of models/fourbar_path_synthesis.toml by circle intersection: ``(P, ok)`` at crank angles
    ``t_deg`` (theta2), in the assembly mode whose dyad determinant r3 r4 sin(theta3 − theta4) has ``sign``."""
    O2 = p["x0"] + 1j * p["y0"]
    g = np.exp(1j * math.radians(p["theta0"]))
    O4 = O2 + p["r1"] * g
    A = O2 + p["r2"] * g * np.exp(1j * np.radians(np.asarray(t_deg) + p["phi"]))
    dvec = O4 - A
    dd = np.abs(dvec)
    along = (p["r3"] ** 2 - p["r4"] ** 2 + dd ** 2) / (2 * dd)
    h2 = p["r3"] ** 2 - along ** 2
    ok = h2 >= 0
    hgt = np.sqrt(np.where(ok, h2, 0.0))
    out = np.full(np.shape(A), np.nan + 0j)
    mu = np.full(np.shape(A), np.nan)
    for sg in (1, -1):
        B = A + dvec / dd * (along + 1j * sg * hgt)
        good = ok & (np.sign(np.sin(np.angle(B - A) - np.angle(B - O4))) == sign)
        u = (B - A) / p["r3"]
        out = np.where(good, A + p["rcx"] * u + p["rcy"] * 1j * u, out)
        mu = np.where(good, np.degrees(np.abs(np.angle((B - A) / (B - O4)))), mu)
    return out, ok, mu


def distance_to(q, curve):
    """Distance of the points ``q`` (complex) to the polyline ``curve`` (complex)."""
    a, b = curve[:-1], curve[1:]
    d = b - a
    t = np.clip(np.real((q[:, None] - a[None]) * np.conj(d[None])) / np.abs(d[None]) ** 2, 0, 1)
    return np.min(np.abs(q[:, None] - (a[None] + t * d[None])), axis=1)


def check_against_closed_form(report, targets, closed):
    """Every candidate: one circuit (its dyad assembles in its mode at every input of the motion), a full turn for a
    closed curve, the targets' distances and the transmission range as the closed form gives them."""
    q = targets[:, 0] + 1j * targets[:, 1]
    size = float(np.max(np.ptp(targets, axis=0)))
    assert report["candidates"], "no candidate"
    for c in report["candidates"]:
        p = c["parameters"]
        sign = 1.0 if c["mode"] == "+" else -1.0
        cert = c["certificate"]
        assert cert["defects"] == [] and cert["one_circuit"] and cert["assembles"]
        if closed:
            t = np.arange(0, 360, 0.01)
            curve, ok, mu = coupler_curve(p, t, sign)
            assert ok.all(), "the crank does not turn fully"  # the dyad closes at every crank angle
            assert np.all(np.isfinite(curve)), "the mode changes along the turn"
            assert cert["crank"] is True
            curve = np.append(curve, curve[0])
        else:
            xs = [tg["input"] for tg in report["targets"]] if c is report["candidates"][0] else None
            t = np.arange(-720, 720, 0.01)
            curve, ok, mu = coupler_curve(p, t, sign)
            if xs is not None:  # the stretch of the motion between the first and last target
                lo, hi = min(xs[0], xs[-1]), max(xs[0], xs[-1])
                keep = (t >= lo - 0.01) & (t <= hi + 0.01)
                curve, mu = curve[keep], mu[keep]
                assert np.all(np.isfinite(curve)), "the stretch leaves the mode"
            else:
                curve = curve[np.isfinite(curve)]
        d = distance_to(q, curve)
        # the polyline at 0.01° is off the curve by its sagitta (< 1e-6 of the size here)
        tol = 1e-6 * size + 1e-9
        assert c["shape_error"]["max"] == pytest.approx(float(d.max()), abs=tol)
        assert c["shape_error"]["rms"] == pytest.approx(float(np.sqrt(np.mean(d * d))), abs=tol)
        if c is report["candidates"][0]:
            errs = np.array([tg["error"] for tg in report["targets"]])
            assert np.allclose(errs, d, atol=tol)
        if closed:
            assert c["transmission"][0] == pytest.approx(np.nanmin(mu), abs=0.05)
            assert c["transmission"][1] == pytest.approx(np.nanmax(mu), abs=0.05)


# ----------------------------------------------------------------------------- planted designs


def _near_entry(atlas, crank=True, k=5):
    ok = np.flatnonzero(atlas.traced & (atlas.crank if crank else ~atlas.crank))
    return int(ok[k])


def test_a_planted_fourbar_is_recovered_to_its_dimensions(fourbar, atlas):
    """A design 3 % away from an atlas entry (not itself in the atlas), its curve moved, turned and scaled: the
    polish gives back its dimensions and the placement."""
    i = _near_entry(atlas)
    vals = atlas.values(i)
    rng = np.random.default_rng(7)
    planted = {n: vals[n] * (1 + 0.03 * rng.standard_normal()) for n in ("r2", "r3", "r4", "rcx", "rcy")}
    design = fourbar.with_parameters(**planted)
    xy = similarity(traced(design, "P"), 35.0, 6.5, (12.0, -30.0))
    res = synthesize_shape(fourbar, shape="P", targets=xy, atlas=atlas, top=3, progress=False)
    want = {n: v * 6.5 for n, v in planted.items()} | {"r1": 4.0 * 6.5, "x0": 12.0, "y0": -30.0, "theta0": 35.0}
    best = None
    for c in res.report["candidates"]:
        p = c["parameters"]
        err = max(abs(p[n] - v) / (1 if n == "theta0" else 6.5) for n, v in want.items())
        best = err if best is None else min(best, err)
    assert best < 1e-6, res.report["candidates"]
    top = res.report["candidates"][0]
    assert top["shape_error"]["rms"] < 1e-8 * 6.5
    assert top["placement"]["scale"] == pytest.approx(6.5, rel=1e-6)
    assert top["placement"]["angle"] == pytest.approx(35.0, abs=1e-6)
    check_against_closed_form(res.report, xy, closed=True)
    # the written model is placed in the target's coordinates: its curve goes through the targets
    m = res.mechanism
    sw = m.sweep(0, 360, 0.25, progress=False)
    curve = np.asarray(sw.columns["P_x"]) + 1j * np.asarray(sw.columns["P_y"])
    assert np.max(distance_to(xy[:, 0] + 1j * xy[:, 1], curve)) < 1e-4 * 6.5


def test_a_planted_stephenson_sixbar_is_recovered_to_its_dimensions(tmp_path):
    """A six-bar of the atlas, its curve sampled at other points than the atlas', moved, turned and scaled: the
    polish gives back its fifteen dimensions and the placement.

    (The planted six-bar is an atlas entry, not a design between entries as for the four-bar: a Stephenson III
    curve pins its fifteen dimensions only loosely — designs 1 % away from an entry were fitted to 2e-6 of the
    curve's size by designs 0.25 away — and the Watt II point of the second coupler not at all: its curve is
    the second four-bar's coupler curve over the first one's swing, whatever the first four-bar that swings it.)
    """
    steph = ls.load(STEPH)
    atlas = build_atlas(steph, point="P", vary=STEPH_VARY, size=1024, chunk=512, out=tmp_path / "s.zarr",
                        step_deg=4.0, progress=False)
    i = _near_entry(atlas, k=8)
    planted = {n: atlas.values(i)[n] for n in STEPH_VARY}
    xy = similarity(traced(steph.with_parameters(**planted), "P", step=3.0), -120.0, 0.25, (3.0, 4.0))
    res = synthesize_shape(steph, shape="P", targets=xy, atlas=atlas, top=3, progress=False)
    lengths = ("r1", "r2", "r3", "r4", "rc", "r5", "r6", "r7", "pcx", "pcy")
    want = {n: planted.get(n, 60.0) * 0.25 for n in lengths}
    p = res.report["candidates"][0]["parameters"]
    assert max(abs(p[n] - v) for n, v in want.items()) < 1e-6 * 60
    for n in ("gamma", "beta"):
        assert abs(math.remainder(p[n] - planted[n], 360)) < 1e-6
    assert abs(math.remainder(p["theta0"] + 120.0, 360)) < 1e-6
    assert abs(p["x0"] - 3.0) < 1e-6 and abs(p["y0"] - 4.0) < 1e-6
    assert res.report["candidates"][0]["shape_error"]["max"] < 1e-8


# ----------------------------------------------------------------------------- curves no design traces exactly


def test_a_noisy_drawn_closed_curve_gives_certified_distinct_designs_as_the_closed_form_says(fourbar, atlas):
    t = np.radians(np.arange(0, 360, 7.5))
    rng = np.random.default_rng(11)
    # a kidney: an ellipse with a dent, drawn by hand (noise 1 % of its size)
    xy = np.stack([40 + 20 * np.cos(t) - 4 * np.cos(2 * t), 15 + 11 * np.sin(t) + 2 * np.sin(2 * t)], axis=1)
    xy += rng.normal(0, 0.4, xy.shape)
    res = synthesize_shape(fourbar, shape="P", targets=xy, atlas=atlas, top=4, progress=False)
    rep = res.report
    assert rep["task"] == "shape" and rep["closed"] is True
    check_against_closed_form(rep, xy, closed=True)
    rms = [c["shape_error"]["rms"] for c in rep["candidates"]]
    assert rms == sorted(rms) and rms[0] < 1.0  # the noise is 0.4
    # distinct: no two candidates share their dimensions to 1 % of the curve's size
    P = np.array([[c["parameters"][n] for n in ("r1", "r2", "r3", "r4", "rcx", "rcy", "x0", "y0")]
                  for c in rep["candidates"]])
    for a_ in range(len(P)):
        for b_ in range(a_ + 1, len(P)):
            assert np.max(np.abs(P[a_] - P[b_])) > 0.01 * 40 or rep["candidates"][a_]["mode"] != \
                rep["candidates"][b_]["mode"]
    assert rep["objective"] == pytest.approx(np.sum(np.array([tg["error"] for tg in rep["targets"]]) ** 2))


def test_an_open_stretch_with_noise_is_matched_and_certified(fourbar, atlas):
    """The straight-ish lower stretch of a crank-rocker's curve (a walking machine's foot path), with noise."""
    design = fourbar.with_parameters(r1=4, r2=1.0, r3=4.0, r4=4.0, rcx=8.0, rcy=0.0)  # a Chebyshev-like linkage
    sw = design.sweep(0, 360, 2, progress=False)
    xy = np.stack([sw.columns["P_x"], sw.columns["P_y"]], axis=1)
    low = xy[:, 1] < np.quantile(xy[:, 1], 0.3)
    stretch = xy[low]
    order = np.argsort(stretch[:, 0])
    stretch = similarity(stretch[order], 10.0, 3.0, (100.0, 50.0))
    stretch += np.random.default_rng(5).normal(0, 0.01, stretch.shape)
    res = synthesize_shape(fourbar, shape="P", targets=stretch, closed=False, atlas=atlas, top=3, progress=False)
    rep = res.report
    assert rep["closed"] is False
    check_against_closed_form(rep, stretch, closed=False)
    assert rep["candidates"][0]["shape_error"]["rms"] < 0.1


def test_fixed_placement_parameters_are_kept(fourbar, atlas):
    i = _near_entry(atlas, k=9)
    vals = atlas.values(i)
    design = fourbar.with_parameters(**{n: vals[n] for n in VARY})
    xy = traced(design, "P")  # in the model's own frame: x0 = y0 = 0, theta0 = 0
    res = synthesize_shape(fourbar, shape="P", targets=xy, atlas=atlas, top=2, progress=False,
                           vary={"x0": (0, 0), "y0": (0, 0), "r1": (1, 30)})
    for c in res.report["candidates"]:
        assert c["parameters"]["x0"] == 0 and c["parameters"]["y0"] == 0
        assert 1 <= c["parameters"]["r1"] <= 30
    assert res.report["candidates"][0]["shape_error"]["rms"] < 1e-6


def test_a_diagram_model_without_placement_parameters_is_placed_through_added_ones(tmp_path):
    """models/fourbar_coupler_curve.toml has its ground pivots as numbers: its vector form gets frame_x, frame_y and
    frame_angle, and the written design traces the target in the target's coordinates."""
    m = ls.load(ls.models_dir() / "fourbar_coupler_curve.toml")
    atlas = build_atlas(m, point="P", vary={"r_crank": (15, 35), "r_coupler": (50, 90), "r_rocker": (35, 60),
                                            "r_coupler_P": (20, 80)}, size=512, chunk=512, out=tmp_path / "d.zarr",
                        step_deg=4.0, progress=False)
    xy = similarity(traced(m, "P"), 80.0, 0.1, (-7.0, 2.0))
    res = synthesize_shape(m, shape="P", targets=xy, atlas=atlas, top=1, progress=False)
    c = res.report["candidates"][0]
    assert c["shape_error"]["max"] < 1e-6
    assert {"frame_x", "frame_y", "frame_angle"} <= set(c["parameters"])
    assert c["placement"]["scale"] == pytest.approx(0.1, rel=1e-6)
    sw = res.mechanism.sweep(0, 360, 0.5, progress=False)
    curve = np.asarray(sw.columns["P_x"]) + 1j * np.asarray(sw.columns["P_y"])
    assert np.max(distance_to(xy[:, 0] + 1j * xy[:, 1], curve)) < 1e-3


def _kidney():
    t = np.radians(np.arange(0, 360, 10))
    return np.stack([4 + 3 * np.cos(t) * (1 + 0.3 * np.cos(2 * t)), 1.8 * np.sin(t) + 0.6 * np.sin(2 * t)], axis=1)


def _count_evaluations(monkeypatch):
    """The designs of every batch evaluation of the polish (one per lockstep iteration, plus the first)."""
    import loopsolve.design.synthesis.lockstep_lm as synthlm

    real = synthlm.residuals_and_jacobian
    calls = []

    def counted(problem, V, *a, **k):
        calls.append(V.shape[0])
        return real(problem, V, *a, **k)

    monkeypatch.setattr(synthlm, "residuals_and_jacobian", counted)
    return calls


def test_a_stalled_polish_ends_early_with_its_best_design(fourbar, atlas, monkeypatch):
    """A curve no four-bar traces exactly (a kidney of 36 points): a start of the polish stops once its objective
    no longer falls (shape._STALL), keeping its best design. The polish evaluates far fewer designs than when
    no start ever stalls, and its designs are as good to a fraction of a per cent."""
    import loopsolve.design.synthesis.shape.run as shape

    xy = _kidney()
    calls = _count_evaluations(monkeypatch)
    got, default = {}, shape._STALL_DROP
    for drop in (default, -1.0):  # -1: an objective never falls that little, so a start never stalls
        monkeypatch.setattr(shape, "_STALL_DROP", drop)
        calls.clear()
        res = synthesize_shape(fourbar, shape="P", targets=xy, atlas=atlas, top=3, progress=False)
        got[drop] = (sum(calls), [c["shape_error"]["rms"] for c in res.report["candidates"]])
    (n_stall, rms_stall), (n_full, rms_full) = got[default], got[-1.0]
    assert n_stall < 0.8 * n_full
    assert rms_stall[0] <= 1.01 * rms_full[0]


def test_a_shape_query_does_a_bounded_amount_of_work(fourbar, atlas, monkeypatch):
    """One query's work, counted (not timed): the polish is one lockstep batch per iteration for every start at
    once (at most ``LM_ITERS`` + 1 evaluations, no design polished on its own), its poses are checked by a few
    traces, and every reported design costs one certificate whose sweeps also give its shape error (no other
    sweep of its motion)."""
    import loopsolve.design.synthesis.certificate as certificate
    import loopsolve.design.synthesis.lockstep_lm as synthlm
    import loopsolve.design.synthesis.shape.run as shape
    from loopsolve.design.synthesis.problem import Problem
    from loopsolve.model.mechanism import Mechanism

    calls = _count_evaluations(monkeypatch)
    counts = {"trace": 0, "certify": 0, "sweep": 0, "validate": 0}

    def counting(obj, name, key):
        real = getattr(obj, name)

        def wrapped(*a, **k):
            counts[key] += 1
            return real(*a, **k)

        monkeypatch.setattr(obj, name, wrapped)

    counting(Problem, "trace", "trace")
    counting(certificate, "certify", "certify")
    counting(Mechanism, "sweep", "sweep")
    counting(synthlm, "_validate", "validate")
    top = 3
    for closed, xy in ((True, _kidney()), (False, _kidney()[:14])):
        calls.clear()
        for k in counts:
            counts[k] = 0
        res = synthesize_shape(fourbar, shape="P", targets=xy, closed=closed, atlas=atlas, top=top, progress=False)
        n_starts = res.report["statistics"]["retrieval"]["starts"]
        # (a second pass, from their starts, only for starts that ended failing the crank requirement)
        assert 1 < len(calls) <= 2 * (shape.LM_ITERS + 1)
        assert calls[0] == n_starts > 1 and max(calls) <= n_starts
        # the first trace through the targets, the checks at 16 and 64 iterations and at the end, and the
        # requirements' check of a closed curve (a full turn) — redone only for starts that failed it
        assert counts["validate"] <= len(synthlm._TRUST_VALIDATE) + 2
        assert counts["trace"] <= 2 * (len(synthlm._TRUST_VALIDATE) + 3)
        n_cert = counts["certify"]
        assert len(res.report["candidates"]) <= n_cert <= 2 * top + len(res.report["statistics"]["rejected"])
        # a certificate sweeps at most the stretches between its 8 checkpoints and a full turn; the shape error
        # reuses them (a design whose certificate has a defect is swept once more for the error it reports)
        assert counts["sweep"] <= n_cert * (shape._CERT_POINTS - 1 + 1) + len(res.report["statistics"]["rejected"])
        check_against_closed_form(res.report, xy, closed=closed)


def test_the_lockstep_polish_returns_the_positions_its_last_trace_found(fourbar):
    """batch_lm(..., poses=True) gives, for every design it returns, the positions at every target that a fresh
    trace through the targets in its mode finds (so shape synthesis need not trace them again)."""
    from loopsolve.design.synthesis.problem import define
    from loopsolve.design.synthesis.lockstep_lm import batch_lm, sample

    sw = fourbar.sweep(0, 360, 30, progress=False)
    targets = {"x": sw.columns["P_x"][:-1] + 0.05, "y": sw.columns["P_y"][:-1]}
    pb = define(fourbar, path="P", targets=targets, vary=VARY, mode="any")
    V = sample(pb, 6, 1)
    S = np.repeat(pb.modes(pb.batch.params(V))[0][:, :1], len(V), axis=1)
    X = np.repeat(np.radians(np.arange(0.0, 360.0, 30.0))[:, None], len(V), axis=1)  # free timing: its starts
    V, X, f, Z = batch_lm(pb, V, S, X, iters=6, warm=True, poses=True)
    done = np.isfinite(f)
    assert done.any()
    for i in np.flatnonzero(done):
        Zt, reached = pb.trace(pb.batch.params(V[i][None]), X[:, i][:, None], S[:, i][:, None], hmax=math.radians(5),
                               singular_stop=False)
        assert reached[0] >= pb.T
        assert np.allclose(Z[:, :, i], Zt[:, :pb.T, 0], atol=1e-9)
    assert np.all(np.isnan(Z[:, :, ~done]))
