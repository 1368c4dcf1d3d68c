"""The numba engine's cheaper sweep (issue 21 row 1): the same rows, computed with less work per call.

* the rows' rates computed inside the compiled step loop (``node_rates``, fused with the
  corrector's last Φ) equal :func:`loopsolve.kinematics.batch.rates_v` at the same positions and the
  four-bar closed forms of :mod:`loopsolve.kinematics.classic`;
* what the front end reuses per compiled model (the kernel, the start's guess pose) never goes
  stale: a model with other parameters (``with_parameters``), a ``ck.p`` changed in place, another
  start value give the rows of the closed form, and the rows of a fresh sweep;
* plain-number bounds and rates skip the unit parser with the parser's own values;
* the generated tuple helpers put the unknowns and the input where the model has them.
"""

from __future__ import annotations

import importlib.util
import math

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.kinematics import batch
from loopsolve.kinematics.numba_engine import jit, steps
from loopsolve.kinematics import classic as C
from loopsolve.kinematics.scalar_solver import kernel_of
from loopsolve.kinematics.solve import plain_value
from loopsolve.model.units import Kind, parse_quantity

#: the tests that sweep with the compiled engine (the others hold without numba)
needs_numba = pytest.mark.skipif(importlib.util.find_spec("numba") is None, reason="numba is not installed")

MODEL = ls.models_dir() / "thesis_crank_rocker.toml"


def _wrap(d):
    return (d + math.pi) % (2 * math.pi) - math.pi


def _same(a, b, tol):
    """Equal NaN patterns, and |a - b| <= tol (1 + max|b|) elsewhere."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    assert a.shape == b.shape
    assert np.array_equal(np.isnan(a), np.isnan(b))
    ok = ~np.isnan(b)
    if not ok.any():
        return
    assert np.max(np.abs(a[ok] - b[ok])) <= tol * (1 + np.max(np.abs(b[ok])))


@pytest.fixture
def fused(monkeypatch):
    """Counts the sweeps whose rates came from the step loop (whole_rates) and from a rates pass."""
    calls = {"fused": 0, "pass": 0}
    whole, rates = steps.FastLane.whole_rates, steps.FastLane.rates

    def whole_rates(self, *a):
        calls["fused"] += 1
        return whole(self, *a)

    def rates_pass(self, *a):
        calls["pass"] += 1
        return rates(self, *a)

    monkeypatch.setattr(steps.FastLane, "whole_rates", whole_rates)
    monkeypatch.setattr(steps.FastLane, "rates", rates_pass)
    return calls


def _closed_form(sw, r, mode_sign, om, al):
    """theta3, theta4 and their rates from the notes' closed forms at the sweep's inputs."""
    r1, r2, r3, r4 = r
    t2 = np.radians(sw["theta2"])
    t3, t4 = C.fourbar_position(r1, r2, r3, r4, t2, mode_sign)
    w3, w4 = C.fourbar_velocity(r2, r3, r4, t2, t3, t4, om)
    a3, a4 = C.fourbar_acceleration(r2, r3, r4, t2, t3, t4, om, w3, w4, al)
    return t3, t4, w3, w4, a3, a4


def _check_closed_form(sw, r, mode_sign, om, al, tol=1e-12):
    ck = sw.compiled
    i3, i4 = ck.index("theta3"), ck.index("theta4")
    t3, t4, w3, w4, a3, a4 = _closed_form(sw, r, mode_sign, om, al)
    assert np.max(np.abs(_wrap(sw.z[:, i3] - t3))) < 1e-10
    assert np.max(np.abs(_wrap(sw.z[:, i4] - t4))) < 1e-10
    for got, ref in ((sw.z1[:, i3], w3), (sw.z1[:, i4], w4), (sw.z2[:, i3], a3), (sw.z2[:, i4], a4)):
        # the closed form at the closed-form positions: the positions differ by ~1e-15 rad
        assert np.max(np.abs(got - ref)) <= tol * (1 + np.max(np.abs(ref)))


@needs_numba
@pytest.mark.parametrize("mode,derivatives", [("open", 2), ("crossed", 3), ("open", 1)])
def test_rates_from_the_step_loop_equal_rates_v_and_the_closed_form(mode, derivatives, fused):
    om, al, jk = 3.0, -2.0, 0.7
    mech = ls.fourbar(60, 25, 70, 45, mode=mode)
    sw = mech.sweep(0, 359, 1, method="tracked", engine="numba", progress=False, speed=om, accel=al, jerk=jk,
                    derivatives=derivatives)
    assert len(sw) == 360 and sw.events == ()
    assert fused == {"fused": 1, "pass": 0}  # traced whole: the rates came from the step loop
    ck = sw.compiled
    z1, z2, z3, cond = batch.rates_v(ck, np.ascontiguousarray(sw.z.T), (om, al, jk), derivatives=derivatives)
    _same(sw.z1, z1.T, 1e-12)
    _same(sw.z2, z2.T, 1e-12)
    _same(sw.z3, z3.T, 1e-12)
    _same(sw.cond, cond, 1e-12)
    i3 = ck.index("theta3")
    assert np.isnan(sw.z2[:, i3]).all() == (derivatives < 2)
    assert np.isnan(sw.z3[:, i3]).all() == (derivatives < 3)
    if derivatives >= 2:
        _check_closed_form(sw, (60, 25, 70, 45), 1 if mode == "open" else -1, om, al)
    # the pure-Python tracer's rows, to 1e-12
    py = mech.sweep(0, 359, 1, method="tracked", engine="python", progress=False, speed=om, accel=al, jerk=jk,
                    derivatives=derivatives)
    for q in ("z", "z1", "z2", "z3"):
        _same(getattr(sw, q), getattr(py, q), 1e-12)


@needs_numba
def test_a_path_with_a_limit_takes_the_rates_pass_and_agrees_with_python(fused):
    mech = ls.fourbar(4, 3, 3.5, 5)  # a limit at 341.43 deg
    nb = mech.sweep(300, 360, 1, engine="numba", progress=False, derivatives=3, speed=2.0, accel=1.0,
                    through_limits=True)
    py = mech.sweep(300, 360, 1, engine="python", progress=False, derivatives=3, speed=2.0, accel=1.0,
                    through_limits=True)
    assert fused["fused"] == 0 and fused["pass"] == 1  # handed back to Python at the fold
    assert [e.kind for e in nb.events] == [e.kind for e in py.events] and len(nb) == len(py)
    for q in ("z", "z1", "z2", "z3"):
        _same(getattr(nb, q), getattr(py, q), 1e-12)


@needs_numba
def test_with_parameters_and_a_changed_p_never_reuse_a_stale_front_end():
    mech = ls.load(MODEL)
    om = math.radians(60.0)  # 10 rpm in rad/s, the model's speed
    first = mech.sweep(0, 359, 1, method="tracked", engine="numba", progress=False)
    _check_closed_form(first, (60, 25, 70, 45), 1, om, 0.0)
    other = mech.with_parameters(r2=20, r3=72)
    sw = other.sweep(0, 359, 1, method="tracked", engine="numba", progress=False)
    _check_closed_form(sw, (60, 20, 72, 45), 1, om, 0.0)
    fresh = other.sweep(0, 359, 1, method="tracked", engine="python", progress=False)
    for q in ("z", "z1", "z2"):
        _same(getattr(sw, q), getattr(fresh, q), 1e-12)
    again = mech.sweep(0, 359, 1, method="tracked", engine="numba", progress=False)
    for q in ("z", "z1", "z2", "cond"):
        assert np.array_equal(getattr(again, q), getattr(first, q))
    # a compiled model whose parameter array is changed in place gets a new kernel
    ck = mech.compile()
    kern = kernel_of(ck)
    assert kernel_of(ck) is kern
    ck.p[[p.name for p in ck.mechanism.parameters].index("r2")] = 20.0
    assert kernel_of(ck) is not kern and kernel_of(ck).p == ck.p.tolist()
    sw = mech.sweep(0, 359, 1, method="tracked", engine="numba", progress=False, compiled=ck)
    _check_closed_form(sw, (60, 20, 70, 45), 1, om, 0.0)


@needs_numba
@pytest.mark.parametrize("start", [0.0, 90, 200.5])
def test_the_start_follows_the_start_value(start):
    """The start's guess pose is kept per model; the start itself is solved at each call's value."""
    for mech, sign in ((ls.load(MODEL), 1), (ls.fourbar(60, 25, 70, 45, mode="crossed"), -1)):
        ck = mech.compile()
        for _ in range(2):
            sw = mech.sweep(start, start + 20, 5, method="tracked", engine="numba", progress=False, compiled=ck)
            assert sw["theta2"][0] == pytest.approx(start, abs=1e-12)
            t3, t4 = C.fourbar_position(60, 25, 70, 45, np.radians(sw["theta2"]), sign)
            assert np.max(np.abs(_wrap(sw.z[:, ck.index("theta4")] - t4))) < 1e-10


@pytest.mark.parametrize("kind", [Kind.ANGLE, Kind.LENGTH, Kind.ANGULAR_RATE, Kind.ANGULAR_ACCEL,
                                  Kind.ANGULAR_JERK, Kind.LENGTH_RATE, Kind.LENGTH_ACCEL, Kind.LENGTH_JERK])
@pytest.mark.parametrize("units", [("deg", "mm"), ("rad", "in")])
def test_plain_numbers_skip_the_parser_with_its_values(kind, units):
    mech = ls.fourbar(60, 25, 70, 45)
    spec = {**mech.spec, "units": {"angle": units[0], "length": units[1]}}
    from loopsolve.model.spec import build_mechanism

    ck = build_mechanism(spec).compile()
    for v in (0, 1, -7, 359, 0.1, -2.5e-7, 1e17, 3.0e99, 10**30):
        x = plain_value(ck, v, kind)
        assert x is not None
        assert x == parse_quantity(v, kind, angle_unit=units[0], length_unit=units[1], reduce=False)
    for v in ("90", "1rad", True, np.float64(2.0), math.inf, math.nan, 10**400, None, [1.0]):
        assert plain_value(ck, v, kind) is None  # the parser decides (its value, or its error)
    if kind is not Kind.ANGLE:
        assert plain_value(ck, 1e101, kind) is None  # beyond MAX_MAGNITUDE: the parser's error


@needs_numba
def test_plain_and_unit_bounds_give_the_same_sweep():
    mech = ls.load(MODEL)
    a = mech.sweep(10, 100, 2, engine="numba", progress=False, speed=2.0, accel=0.5)
    b = mech.sweep("10deg", "100deg", "2deg", engine="numba", progress=False, speed="2rad/s", accel="0.5rad/s^2")
    for q in ("z", "z1", "z2", "z3"):
        assert np.array_equal(getattr(a, q), getattr(b, q), equal_nan=True)


def test_the_tuple_helpers_put_each_value_where_the_model_has_it():
    ns: dict = {}
    exec(jit._tuple_helpers(5, 3, 1, 4), ns)  # unknowns at 3 and 1, input at 4
    z = [10.0, 11.0, 12.0, 13.0, 14.0]
    assert ns["ztuple"](z) == (10.0, 11.0, 12.0, 13.0, 14.0)
    assert ns["zset"](z, -1.0, -2.0) == (10.0, -2.0, 12.0, -1.0, 14.0)
    assert ns["rvec"](7.0, -1.0, -2.0) == (0.0, -2.0, 0.0, -1.0, 7.0)


@needs_numba
def test_engines_agree_when_the_input_is_not_the_first_variable():
    """Driving the rocker (input theta4, unknowns theta2 and theta3): other compile-time indices."""
    mech = ls.fourbar(60, 25, 70, 45)
    ck = mech.compile("theta4")
    assert int(ck.input_idx[0]) != 0
    kw = dict(input="theta4", compiled=ck, method="tracked", progress=False, speed=1.5, accel=0.3, derivatives=3)
    nb = mech.sweep(60, 90, 0.5, engine="numba", **kw)
    py = mech.sweep(60, 90, 0.5, engine="python", **kw)
    assert len(nb) == len(py) == 61
    for q in ("z", "z1", "z2", "z3"):
        _same(getattr(nb, q), getattr(py, q), 1e-12)


def test_the_structure_key_is_kept_per_live_mechanism_and_per_inputs():
    """compile() hashes the declaration once per mechanism and choice of inputs (every mech.sweep calls it)."""
    import gc
    import pickle

    from loopsolve.symbolic import compiled

    mech = ls.fourbar(60, 25, 70, 45)
    k2 = compiled.structure_key(mech, ("theta2",))
    assert k2 == compiled._structure_key(mech, ("theta2",))
    assert compiled.structure_key(mech, ("theta2",)) == k2
    k4 = compiled.structure_key(mech, ("theta4",))
    assert k4 != k2 and k4 == compiled._structure_key(mech, ("theta4",))
    other = mech.with_parameters(r2=20)  # the same structure: the same generated code
    assert compiled.structure_key(other, ("theta2",)) == k2
    assert mech.compile().module is other.compile().module and other.compile().p[1] == 20.0
    slider = ls.load(ls.models_dir() / "prob2_offset_slider_crank.toml")
    assert compiled.structure_key(slider, slider.inputs) != k2
    copy = pickle.loads(pickle.dumps(mech))  # the memo is not part of the object
    assert "_structure_keys" not in vars(copy) and compiled.structure_key(copy, ("theta2",)) == k2
    n, m = len(compiled._KEYS), len(compiled._COMPILED)
    del other, copy
    gc.collect()
    assert len(compiled._KEYS) <= n - 2 and len(compiled._COMPILED) <= m - 1  # dead mechanisms leave the memos
    import weakref

    ck = mech.compile()  # compiled once per mechanism and inputs; each call its own parameter array
    ck.p[1] = 1.0
    assert mech.compile().p[1] == 25.0 and mech.compile().mechanism is mech
    dead = ls.fourbar(60, 25, 70, 40)
    dead.compile()
    dead.compile()
    ref = weakref.ref(dead)
    del dead
    gc.collect()
    assert ref() is None  # the compile memo does not keep its mechanism alive


@needs_numba
def test_kernels_are_reused_per_mechanism_and_do_not_keep_a_study_alive():
    import gc
    import weakref

    from loopsolve.kinematics import scalar_solver

    mech = ls.fourbar(60, 25, 70, 45)
    a, b = mech.compile(), mech.compile()  # equal compiled models of one mechanism
    assert a is not b and kernel_of(a) is kernel_of(b)
    assert kernel_of(mech.with_parameters(r2=20).compile()) is not kernel_of(a)
    refs = []
    for r2 in np.linspace(20, 26, scalar_solver._KERNELS_MAX + 4):
        m = mech.with_parameters(r2=float(r2))
        refs.append(weakref.ref(m))
        sw = m.sweep(0, 40, 10, engine="numba", progress=False)
        t3, t4 = C.fourbar_position(60, float(r2), 70, 45, np.radians(sw["theta2"]), 1)
        assert np.max(np.abs(_wrap(sw.z[:, sw.compiled.index("theta4")] - t4))) < 1e-10
    del m, sw
    gc.collect()
    assert len(scalar_solver._KERNELS) <= scalar_solver._KERNELS_MAX
    assert sum(r() is not None for r in refs) <= scalar_solver._KERNELS_MAX  # the others were freed


@needs_numba
@pytest.mark.parametrize("step", [30, 7.5])
def test_rates_of_rows_between_nodes_without_a_grid_value(step, fused):
    """A coarse output grid: the step loop takes nodes between rows; the rows' rates are those of
    their own nodes (not of the nodes in between), as rates_v and the closed form have them."""
    om, al = 2.0, 0.3
    mech = ls.fourbar(60, 25, 70, 45)
    sw = mech.sweep(0, 360, step, method="tracked", engine="numba", progress=False, speed=om, accel=al,
                    derivatives=3, jerk=0.1)
    assert fused == {"fused": 1, "pass": 0} and len(sw) == round(360 / step) + 1
    np.testing.assert_allclose(sw["theta2"], np.arange(len(sw)) * step, rtol=0, atol=1e-12)
    z1, z2, z3, _ = batch.rates_v(sw.compiled, np.ascontiguousarray(sw.z.T), (om, al, 0.1), derivatives=3)
    _same(sw.z1, z1.T, 1e-12)
    _same(sw.z2, z2.T, 1e-12)
    _same(sw.z3, z3.T, 1e-12)
    _check_closed_form(sw, (60, 25, 70, 45), 1, om, al)
