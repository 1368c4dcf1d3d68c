"""Limit positions located inside the lockstep chunk for slider-cranks and six-bars (issue 21, item 2).

A design whose sweep stops at a limit position used to be handed to the single-design sweep
unless the model was one dyad (a four-bar). Here seeded mixed boxes of an offset slider-crank
(blocks: one angle, one length) and a Stephenson III six-bar (two dyads): every design's status,
stop, nearest assemblable inputs, events, mode and rows equal its own single sweep, the limit
designs are never swept alone, and the slider-crank's limits and gaps are the closed form.

Offset slider-crank (the lecture notes' Prob 2: r2 + r3 = r1 + r4, r1 along the line of
sliding, r4 the offset e at 90°): the y component r2 sin θ2 + r3 sin θ3 = e has a root θ3 while
|e − r2 sin θ2| <= r3; the limit positions are where |r2 sin θ2 − e| = r3 (the rod perpendicular
to the line of sliding).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import loopsolve as ls

pytest.importorskip("xarray", reason="the study extra (xarray) is not installed")

SLIDER = ls.models_dir() / "prob2_offset_slider_crank.toml"
SIXBAR = ls.models_dir() / "stephenson3_sixbar.toml"
STEP = 5.0


def _study_and_alone(mech, d, monkeypatch):
    """The study of ``d`` over 0..360 by 5°, and the designs it swept alone."""
    from loopsolve.design import lockstep

    alone = []
    single = lockstep._single
    monkeypatch.setattr(lockstep, "_single", lambda *a: (alone.append(int(a[-2])), single(*a)))
    ds = ls.study(mech, d, 0, 360, STEP, derivatives=1, chunk_size=len(d), progress=False)  # one chunk
    monkeypatch.undo()
    return ds, set(alone)


def _equals_single_sweep(ds, j, m, columns):
    """Design j of the study against ``m``'s own sweep: status, stop, nearest, events, mode and rows."""
    status = ds.status.values[j]
    if status == "not-assemblable":
        with pytest.raises(ls.AssemblyError) as exc:
            m.sweep(0, 360, STEP, derivatives=1, progress=False)
        near = [float(s) for s in str(ds.nearest.values[j]).split(",") if s.strip()]
        # the single sweep's tracer locates the fold to 1e-9 in the input (5.7e-8 deg)
        assert near == pytest.approx(list(exc.value.nearest), abs=6e-8)
        assert ds.events.values[j] == str(exc.value).splitlines()[0].split(": ", 1)[1]
        assert float(ds.stop.values[j]) == 0.0
        return exc.value.nearest
    sw = m.sweep(0, 360, STEP, derivatives=1, progress=False)
    lim = [e.input for e in sw.events if e.kind is ls.EventKind.LIMIT]
    assert ds.mode.values[j] == sw.mode
    rows = {float(x): i for i, x in enumerate(sw.columns[sw.input])}
    for x, i in rows.items():
        k = int(round(x / STEP))
        for name in columns:
            assert ds[name].values[j, k] == pytest.approx(sw.columns[name][i], rel=1e-12, abs=1e-9), (j, name, x)
    if status == "ok":
        assert not lim and ds.events.values[j] == "" and len(rows) == 73
        return None
    assert status == "limit" and lim
    assert float(ds.stop.values[j]) == pytest.approx(lim[0], abs=6e-8)  # the tracker: 1e-9 rad
    assert ds.events.values[j] == f"limit@{float(ds.stop.values[j]):.10g}" and ds.nearest.values[j] == ""
    last = max(rows.values())
    assert np.isnan(ds[columns[0]].values[j, last + 1:]).all()  # no row after the limit
    return lim[0]


def _slider_box(seed=21):
    """Ordinary offset slider-cranks (crank shorter than the rod), cranks longer than the rod (a limit
    on the way up, and with a large offset on the way down), and offsets longer than the rod (not
    assemblable anywhere near θ2 = 0): 570 designs of (r2, r3, e) in mm."""
    rng = np.random.default_rng(seed)

    def box(n, r2, r3, e):
        return np.column_stack([rng.uniform(*r2, n), rng.uniform(*r3, n), rng.uniform(*e, n)])

    return np.vstack([box(500, (400, 560), (1400, 1700), (-200, 200)),
                      box(40, (1100, 1400), (500, 900), (-100, 100)),  # r2 sin θ2 = e + r3 before 90°
                      box(20, (900, 1000), (850, 900), (150, 250)),  # e + r3 > r2: after 180°
                      box(10, (400, 560), (400, 550), (600, 800))])  # e > r3: not at θ2 = 0


def _slider_limit(r2, r3, e):
    """The first θ2 (degrees) from 0 up where |r2 sin θ2 − e| = r3, or None."""
    if (e + r3) / r2 < 1:
        return math.degrees(math.asin((e + r3) / r2))
    if (r3 - e) / r2 < 1:
        return 180.0 + math.degrees(math.asin((r3 - e) / r2))
    return None


@pytest.mark.filterwarnings("ignore:.*limit position")
def test_slider_crank_limits_equal_their_single_sweep_and_the_closed_form(monkeypatch):
    from loopsolve.design.designs import Designs

    mech = ls.load(SLIDER)
    v = _slider_box()
    d = Designs(("r2", "r3", "e"), {"r2": v[:, 0], "r3": v[:, 1], "e": v[:, 2]})
    ds, alone = _study_and_alone(mech, d, monkeypatch)
    status = ds.status.values
    r2, r3, e = v.T
    closed = np.array([_slider_limit(*row) for row in v], dtype=object)
    closed_na = np.abs(e) > r3
    assert np.array_equal(status == "not-assemblable", closed_na)
    assert np.array_equal(status == "limit", ~closed_na & (closed != None))  # noqa: E711
    assert (status == "limit").sum() == 60 and closed_na.sum() == 10
    assert not alone  # the limits and gaps are located in the chunk: no design swept alone
    assert ds.lockstep.values[status == "limit"].all()
    check = np.flatnonzero(status != "ok").tolist() + list(range(0, 500, 50))
    for j in check:
        m = mech.with_parameters(r2=float(r2[j]), r3=float(r3[j]), e=float(e[j]))
        got = _equals_single_sweep(ds, j, m, ("theta3", "x", "theta3_vel", "x_vel", "B_x"))
        if status[j] == "limit":
            assert float(ds.stop.values[j]) == pytest.approx(closed[j], abs=1e-8)
        elif status[j] == "not-assemblable":  # assemblable where r2 sin θ2 >= e − r3: [asin s, 180° − asin s]
            s = math.degrees(math.asin((e[j] - r3[j]) / r2[j]))
            assert list(got) == pytest.approx([-180.0 - s, s], abs=1e-8)


def _sixbar_box(seed=22):
    """Stephenson III designs (r_crank, r_coupler, r_rocker, r_link5, r_link6): ordinary ones, output
    dyads too short to reach C all the way round (a limit of the second dyad), triple-rocker
    four-bars (a limit of the first), and output dyads that cannot reach C anywhere."""
    rng = np.random.default_rng(seed)

    def box(n, *ranges):
        return np.column_stack([rng.uniform(*r, n) for r in ranges])

    four = ((24, 26), (68, 72), (44, 46))
    return np.vstack([box(500, *four, (55, 65), (65, 75)),
                      box(30, *four, (40, 46), (40, 46)),  # r5 + r6 < max |C O6| = 97.5
                      box(12, (35, 42), (40, 50), (40, 50), (55, 65), (65, 75)),
                      box(8, *four, (20, 25), (20, 25))])  # r5 + r6 < min |C O6| = 56.3: never


@pytest.mark.filterwarnings("ignore:.*limit position")
def test_sixbar_limits_equal_their_single_sweep(monkeypatch):
    from loopsolve.design.designs import Designs

    names = ("r_crank", "r_coupler", "r_rocker", "r_link5", "r_link6")
    mech = ls.load(SIXBAR)
    v = _sixbar_box()
    d = Designs(names, {n: v[:, i] for i, n in enumerate(names)})
    ds, alone = _study_and_alone(mech, d, monkeypatch)
    status = ds.status.values
    lim = np.flatnonzero(status == "limit")
    assert (status[500:530] == "limit").all() and (status[530:542] == "limit").sum() >= 10
    assert (status[542:] == "not-assemblable").all()
    assert not alone & set(lim.tolist())  # located in the chunk
    assert ds.lockstep.values[lim].all()
    for j in np.flatnonzero(status != "ok").tolist() + list(range(0, 500, 100)):
        m = mech.with_parameters(**{n: float(v[j, i]) for i, n in enumerate(names)})
        _equals_single_sweep(ds, j, m, ("theta_coupler", "theta_rocker", "theta_link5", "theta_link6",
                                        "theta_link6_vel", "D_x"))


@pytest.mark.filterwarnings("ignore:.*limit position")
def test_designs_with_a_limit_between_the_guesses_and_the_start_start_in_the_chunk(monkeypatch):
    """The engine slider-crank's guesses are at θ2 = 30°; a crank more than twice the rod cannot be
    assembled there (r2 sin 30° > r3), so the lockstep path from the guesses never reaches the start
    θ2 = 0. Such designs start in the chunk as their single sweep starts (the root in the mode the
    guesses name, at the start) and stop at the closed-form limit r2 sin θ2 = r3."""
    from loopsolve.design.designs import Designs

    mech = ls.load(ls.models_dir() / "engine_slider_crank.toml")
    rng = np.random.default_rng(23)
    r2 = np.concatenate([rng.uniform(300, 400, 40), rng.uniform(30, 50, 20)])
    r3 = np.concatenate([rng.uniform(100, 140, 40), rng.uniform(120, 160, 20)])
    ds, alone = _study_and_alone(mech, Designs(("r2", "r3"), {"r2": r2, "r3": r3}), monkeypatch)
    assert ds.status.values.tolist() == ["limit"] * 40 + ["ok"] * 20
    assert not alone and ds.lockstep.values.all()
    for j in list(range(40)) + [40, 50]:
        m = mech.with_parameters(r2=float(r2[j]), r3=float(r3[j]))
        _equals_single_sweep(ds, j, m, ("theta3", "r1", "theta3_vel", "r1_vel", "C_x"))
        if j < 40:
            assert float(ds.stop.values[j]) == pytest.approx(math.degrees(math.asin(r3[j] / r2[j])), abs=1e-8)


@pytest.mark.filterwarnings("ignore:.*limit position")
def test_watt_sixbar_designs_are_all_decided_in_the_chunk(monkeypatch):
    """Watt I six-bars (guesses drawn at θ2 = 60°, studied from 0°): designs with a limit between the
    guesses and the start, designs the lockstep path dropped for a steep slope late in the cycle (no
    limit: completed to the end), limits of either dyad — none is swept alone, and every design
    equals its own sweep."""
    from loopsolve.design.designs import Designs

    names = ("r_crank", "r_link5", "r_link6")
    mech = ls.load(ls.models_dir() / "watt1_sixbar.toml")
    rng = np.random.default_rng(5)
    v = np.column_stack([rng.uniform(20, 40, 150), rng.uniform(40, 90, 150), rng.uniform(30, 80, 150)])
    ds, alone = _study_and_alone(mech, Designs(names, {n: v[:, i] for i, n in enumerate(names)}), monkeypatch)
    status = ds.status.values
    assert not alone
    assert (status == "limit").sum() >= 40 and (status == "ok").sum() >= 50
    assert ds.lockstep.values[status != "not-assemblable"].all()
    for j in np.flatnonzero(status != "not-assemblable"):
        m = mech.with_parameters(**{n: float(v[j, i]) for i, n in enumerate(names)})
        _equals_single_sweep(ds, j, m, ("theta_coupler", "theta_rocker", "theta_link5", "theta_link6",
                                        "theta_link5_vel", "G_x"))


@pytest.mark.filterwarnings("ignore:.*limit position")
@pytest.mark.filterwarnings("ignore:.*singular")
def test_slider_cranks_near_a_change_point_equal_their_single_sweep():
    """r2 = r3 + e + δ: for δ > 0 a gap around θ2 = 90° of half-width ≈ √(2δ/r2) rad, for δ < 0 a
    neck. Within about 1e-10 of the change point (δ = 1e-9 here, 1.3e-12 of r2) the tracer passes the
    gap with a singular event; wider gaps stop the sweep at the limit asin((r3 + e)/r2). A gap
    narrower than 1e-3 rad is left to the single sweep, so the study equals it for every δ."""
    from loopsolve.design.designs import Designs

    mech = ls.load(SLIDER)
    deltas = [1e-1, 1e-3, 1e-6, 1e-9, -1e-9, -1e-6, -1e-3, -1e-1]
    r3, e = 700.0, 50.0
    r2 = np.array([r3 + e + dd for dd in deltas])
    d = Designs(("r2", "r3", "e"), {"r2": r2, "r3": np.full(len(r2), r3), "e": np.full(len(r2), e)})
    ds = ls.study(mech, d, 0, 360, STEP, derivatives=1, progress=False)
    for j, dd in enumerate(deltas):
        m = mech.with_parameters(r2=float(r2[j]), r3=r3, e=e)
        sw = m.sweep(0, 360, STEP, derivatives=1, progress=False)
        events = "; ".join(f"{ev.kind.value}@{ev.input:.10g}" for ev in sw.events)
        if dd == 1e-9:  # passed as a change point
            assert ds.status.values[j] == "ok" and events.startswith("singular@")
        if ds.status.values[j] == "limit":
            assert float(ds.stop.values[j]) == pytest.approx(sw.events[0].input, abs=6e-8)
            first = math.degrees(math.asin((r3 + e) / r2[j])) if dd > 0 else 180 + math.degrees(
                math.asin((r3 - e) / r2[j]))
            assert float(ds.stop.values[j]) == pytest.approx(first, abs=1e-6)
        else:
            assert ds.events.values[j] == events
        assert ds.status.values[j] == ("ok" if dd == 1e-9 else "limit")
        rows = {float(x): i for i, x in enumerate(sw.columns[sw.input])}
        for x, i in rows.items():
            assert ds.theta3.values[j, int(round(x / STEP))] == pytest.approx(sw.columns["theta3"][i], rel=1e-12)
