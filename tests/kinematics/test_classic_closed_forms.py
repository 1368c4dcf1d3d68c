"""Tests of the closed-form reference kinematics in :mod:`loopsolve.kinematics.classic`."""

from __future__ import annotations

import math

import numpy as np
import pytest

from loopsolve.kinematics import classic as C
from loopsolve.errors import ModelError

TWO_PI = 2 * math.pi


def wrap(a):
    """Angle differences mapped onto [-pi, pi)."""
    return (np.asarray(a) + math.pi) % TWO_PI - math.pi


def e(a):
    return np.stack([np.cos(a), np.sin(a)], axis=-1)


def fourbar_closure(r1, r2, r3, r4, t2, t3, t4, t1=0.0):
    """Relative loop-closure residual of r2 e2 + r3 e3 - r1 e1 - r4 e4."""
    res = (
        r2[..., None] * e(t2)
        + r3[..., None] * e(t3)
        - r1[..., None] * e(t1)
        - r4[..., None] * e(t4)
    )
    return np.linalg.norm(res, axis=-1) / (r1 + r2 + r3 + r4)


def slider_closure(r1, r2, r3, r4, t2, t3, t1):
    res = (
        r2[..., None] * e(t2)
        + r3[..., None] * e(t3)
        - r1[..., None] * e(t1)
        - r4[..., None] * e(t1 + math.pi / 2)
    )
    return np.linalg.norm(res, axis=-1) / (np.abs(r1) + r2 + r3 + np.abs(r4))


def fd(fun, h):
    """Fourth-order central difference of fun(dt) at dt = 0 (tuple outputs allowed);
    angle-valued outputs must be unwrapped by the caller via ``fun``."""
    p1, m1, p2, m2 = fun(h), fun(-h), fun(2 * h), fun(-2 * h)
    return tuple((8 * (a - b) - (c - d)) / (12 * h) for a, b, c, d in zip(p1, m1, p2, m2))


def random_fourbars(seed, n=4000):
    rng = np.random.default_rng(seed)
    r = rng.uniform(0.5, 10.0, size=(4, n))
    t2 = rng.uniform(-math.pi, math.pi, n)
    t1 = rng.uniform(-math.pi, math.pi, n)
    return r, t2, t1


# ---------------------------------------------------------------- thesis values
THESIS_T2 = np.arange(0, 361, 30)
THESIS_T3 = [33.2, 19.08, 15.48, 16.1, 19.09, 24.3, 31.93, 41.71, 52.35, 61.34, 64.48, 55.19, 33.2]
THESIS_T4 = [58.41, 51.84, 63.67, 80.72, 98.11, 113.37, 124.65, 130.78, 131.37, 125.96, 112.67, 87.94, 58.41]


@pytest.mark.parametrize("i", range(len(THESIS_T2)))
def test_thesis_table(i):
    t3, t4 = C.fourbar_position(60, 25, 70, 45, math.radians(THESIS_T2[i]), mode=+1)
    assert abs(math.degrees(t3) - THESIS_T3[i]) <= 0.006
    assert abs(math.degrees(t4) - THESIS_T4[i]) <= 0.006


def test_thesis_table_vectorized():
    t3, t4 = C.fourbar_position(60, 25, 70, 45, np.radians(THESIS_T2))
    np.testing.assert_allclose(np.degrees(t3), THESIS_T3, atol=0.006)
    np.testing.assert_allclose(np.degrees(t4), THESIS_T4, atol=0.006)
    assert np.sin(t4 - t3).min() > 0


def test_thesis_crossed_mode_is_mirror_about_diagonal():
    t2 = np.radians(THESIS_T2)
    t3p, t4p = C.fourbar_position(60, 25, 70, 45, t2, mode=+1)
    t3m, t4m = C.fourbar_position(60, 25, 70, 45, t2, mode=-1)
    assert np.all(np.sin(t4m - t3m) < 0)
    # mirror about BD: the angle of BD bisects theta4(+) and theta4(-) (mod pi)
    bd_dir = np.arctan2(-25 * np.sin(t2), 60 - 25 * np.cos(t2))
    np.testing.assert_allclose(np.sin(t4p + t4m - 2 * bd_dir), 0, atol=1e-12)


# ------------------------------------------------------------ four-bar positions
@pytest.mark.parametrize("mode", [+1, -1])
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_fourbar_closure_and_mode(seed, mode):
    (r1, r2, r3, r4), t2, t1 = random_fourbars(seed)
    t3, t4 = C.fourbar_position(r1, r2, r3, r4, t2, mode=mode, theta1=t1)
    bd = np.hypot(r1 * np.cos(t1) - r2 * np.cos(t2), r1 * np.sin(t1) - r2 * np.sin(t2))
    inside = (bd < r3 + r4 - 1e-9) & (bd > abs(r3 - r4) + 1e-9)
    outside = (bd > r3 + r4 + 1e-9) | (bd < abs(r3 - r4) - 1e-9)
    assert inside.sum() > 1000 and outside.sum() > 100
    assert np.all(np.isfinite(t3[inside])) and np.all(np.isfinite(t4[inside]))
    assert np.all(np.isnan(t3[outside])) and np.all(np.isnan(t4[outside]))
    ok = np.isfinite(t4)
    assert np.all(np.isfinite(t3[ok]))
    assert fourbar_closure(r1[ok], r2[ok], r3[ok], r4[ok], t2[ok], t3[ok], t4[ok], t1[ok]).max() < 1e-12
    assert np.all(mode * np.sin(t4[inside] - t3[inside]) > 0)
    assert np.all((t3[ok] > -math.pi) & (t3[ok] <= math.pi))
    assert np.all((t4[ok] > -math.pi) & (t4[ok] <= math.pi))


@pytest.mark.parametrize("mode", [+1, -1])
def test_fourbar_theta4_equal_pi(mode):
    """A = C1 - A1 = 0 exactly when theta4 = pi: the root must still be exact."""
    rng = np.random.default_rng(7)
    n = 500
    r2, r3, r4 = rng.uniform(1, 3, n), rng.uniform(4, 8, n), rng.uniform(1, 6, n)
    t2 = rng.uniform(-math.pi, math.pi, n)
    t3_true = np.arcsin(-r2 * np.sin(t2) / r3)  # O4 on the x axis, theta4 = pi
    r1 = r2 * np.cos(t2) + r3 * np.cos(t3_true) + r4
    keep = r1 > 0.1
    r1, r2, r3, r4, t2, t3_true = (v[keep] for v in (r1, r2, r3, r4, t2, t3_true))
    want_mode = np.sign(np.sin(math.pi - t3_true))
    t3, t4 = C.fourbar_position(r1, r2, r3, r4, t2, mode=mode)
    assert np.all(np.isfinite(t4))
    assert fourbar_closure(r1, r2, r3, r4, t2, t3, t4).max() < 1e-12
    sel = want_mode == mode
    assert sel.sum() > 50
    np.testing.assert_allclose(wrap(t4[sel] - math.pi), 0, atol=1e-12)
    np.testing.assert_allclose(wrap(t3[sel] - t3_true[sel]), 0, atol=1e-12)


def test_fourbar_broadcasting_and_scalars():
    t3, t4 = C.fourbar_position(60, 25, 70, 45, np.linspace(0, 1, 5)[:, None], mode=np.array([1, -1]))
    assert t3.shape == t4.shape == (5, 2)
    np.testing.assert_allclose(t4[:, 0], C.fourbar_position(60, 25, 70, 45, np.linspace(0, 1, 5))[1])
    s3, s4 = C.fourbar_position(60, 25, 70, 45, 0.3)
    assert isinstance(s3, float) and isinstance(s4, float)


@pytest.mark.parametrize(
    "kwargs",
    [dict(mode=0), dict(mode=2), dict(mode=np.array([1, 0]))],
)
def test_fourbar_bad_mode(kwargs):
    with pytest.raises(ModelError):
        C.fourbar_position(60, 25, 70, 45, 0.3, **kwargs)


@pytest.mark.parametrize("bad", [(0, 25, 70, 45), (60, -25, 70, 45), (60, 25, np.array([70, 0]), 45)])
def test_fourbar_bad_lengths(bad):
    with pytest.raises(ModelError):
        C.fourbar_position(*bad, 0.3)


# ------------------------------------------------------------------- Freudenstein
@pytest.mark.parametrize("mode", [+1, -1])
def test_freudenstein_zero_at_solutions(mode):
    (r1, r2, r3, r4), t2, _ = random_fourbars(11)
    t3, t4 = C.fourbar_position(r1, r2, r3, r4, t2, mode=mode)
    ok = np.isfinite(t4)
    res = C.freudenstein_residual(r1, r2, r3, r4, t2, t4)[ok]
    scale = (r1 / r2 + r1 / r4 + (r1**2 + r2**2 + r3**2 + r4**2) / (r2 * r4))[ok]
    assert np.max(np.abs(res) / scale) < 1e-13
    # and it is not identically zero
    wrong = C.freudenstein_residual(r1, r2, r3, r4, t2, t4 + 0.1)[ok]
    assert np.median(np.abs(wrong)) > 1e-3


def test_freudenstein_thesis():
    t2 = np.radians(THESIS_T2)
    _, t4 = C.fourbar_position(60, 25, 70, 45, t2)
    np.testing.assert_allclose(C.freudenstein_residual(60, 25, 70, 45, t2, t4), 0, atol=1e-13)


# ------------------------------------------------- four-bar velocity/acceleration
def _well_conditioned_fourbars(seed, mode, n=1500):
    (r1, r2, r3, r4), t2, _ = random_fourbars(seed, n)
    t3, t4 = C.fourbar_position(r1, r2, r3, r4, t2, mode=mode)
    ok = np.isfinite(t4) & (np.abs(np.sin(t4 - t3)) > 0.2)
    for h in (-0.05, 0.05):  # keep well away from toggles (FD steps stay far inside)
        q3, q4 = C.fourbar_position(r1, r2, r3, r4, t2 + h, mode=mode)
        ok &= np.isfinite(q4) & (np.abs(np.sin(q4 - q3)) > 0.1)
    return r1[ok], r2[ok], r3[ok], r4[ok], t2[ok], t3[ok], t4[ok]


@pytest.mark.parametrize("mode", [+1, -1])
@pytest.mark.parametrize("seed", [21, 22])
def test_fourbar_velocity_vs_finite_difference(seed, mode):
    r1, r2, r3, r4, t2, t3, t4 = _well_conditioned_fourbars(seed, mode)
    assert t2.size > 200
    omega2 = np.random.default_rng(seed).uniform(-5, 5, t2.size)
    w3, w4 = C.fourbar_velocity(r2, r3, r4, t2, t3, t4, omega2)

    def pos(dt):  # angles unwrapped around the base position
        q3, q4 = C.fourbar_position(r1, r2, r3, r4, t2 + dt, mode=mode)
        return t3 + wrap(q3 - t3), t4 + wrap(q4 - t4)

    d3, d4 = fd(pos, 1e-4)
    fd3, fd4 = d3 * omega2, d4 * omega2
    np.testing.assert_allclose(w3, fd3, rtol=1e-6, atol=1e-6 * np.abs(omega2).max())
    np.testing.assert_allclose(w4, fd4, rtol=1e-6, atol=1e-6 * np.abs(omega2).max())


def test_fourbar_velocity_closes_the_velocity_loop_at_thesis_point():
    # the velocity loop r2 w2 e(t2 + 90) + r3 w3 e(t3 + 90) = r4 w4 e(t4 + 90) (time derivative of
    # r2 + r3 = r1 + r4), component by component, and w3 against a central difference of t3
    t2 = math.radians(30)
    t3, t4 = C.fourbar_position(60, 25, 70, 45, t2)
    w3, w4 = C.fourbar_velocity(25, 70, 45, t2, t3, t4, 2.0)
    for f in (lambda t: -math.sin(t), math.cos):
        lhs = 25 * 2.0 * f(t2) + 70 * w3 * f(t3)
        assert lhs == pytest.approx(45 * w4 * f(t4), abs=1e-12 * 25 * 2.0)
    h = 1e-6
    fd = (C.fourbar_position(60, 25, 70, 45, t2 + h)[0] - C.fourbar_position(60, 25, 70, 45, t2 - h)[0]) / (2 * h)
    assert w3 == pytest.approx(2.0 * fd, rel=1e-6)


@pytest.mark.parametrize("mode", [+1, -1])
@pytest.mark.parametrize("seed", [31, 32])
def test_fourbar_acceleration_vs_finite_difference(seed, mode):
    r1, r2, r3, r4, t2, t3, t4 = _well_conditioned_fourbars(seed, mode)
    rng = np.random.default_rng(seed)
    omega2 = rng.uniform(-3, 3, t2.size)
    alpha2 = rng.uniform(-10, 10, t2.size)
    w3, w4 = C.fourbar_velocity(r2, r3, r4, t2, t3, t4, omega2)
    a3, a4 = C.fourbar_acceleration(r2, r3, r4, t2, t3, t4, omega2, w3, w4, alpha2)

    def rates(dt):
        th2 = t2 + omega2 * dt + 0.5 * alpha2 * dt**2
        q3, q4 = C.fourbar_position(r1, r2, r3, r4, th2, mode=mode)
        return C.fourbar_velocity(r2, r3, r4, th2, q3, q4, omega2 + alpha2 * dt)

    fd3, fd4 = fd(rates, 1e-4)
    scale = np.abs(alpha2).max() + np.abs(omega2).max() ** 2
    np.testing.assert_allclose(a3, fd3, rtol=1e-6, atol=1e-6 * scale)
    np.testing.assert_allclose(a4, fd4, rtol=1e-6, atol=1e-6 * scale)


def test_fourbar_acceleration_satisfies_second_derivative_of_loop():
    t2 = np.radians(np.arange(0, 360, 7.0))
    t3, t4 = C.fourbar_position(60, 25, 70, 45, t2)
    w2, al2 = 1.3, -0.4
    w3, w4 = C.fourbar_velocity(25, 70, 45, t2, t3, t4, w2)
    a3, a4 = C.fourbar_acceleration(25, 70, 45, t2, t3, t4, w2, w3, w4, al2)

    def acc(r, t, w, a):  # second time derivative of r e(t)
        a, w = np.asarray(a)[..., None], np.asarray(w)[..., None]
        return r * (a * np.stack([-np.sin(t), np.cos(t)], -1) - w**2 * e(t))

    res = acc(25, t2, w2, al2) + acc(70, t3, w3, a3) - acc(45, t4, w4, a4)
    assert np.abs(res).max() < 1e-11


# -------------------------------------------------------------------- slider-crank
def test_slider_crank_notes_example_1():
    r2, r3, t2 = 5.0, 8.0, math.radians(45)
    r1, t3 = C.slider_crank_position(r2, r3, t2)
    assert 8 * math.sin(t3) == pytest.approx(-5 / math.sqrt(2), rel=1e-14)
    assert r1 == pytest.approx(5 / math.sqrt(2) + 8 * math.cos(t3), rel=1e-14)
    assert math.cos(t3) > 0
    r1m, t3m = C.slider_crank_position(r2, r3, t2, mode=-1)
    assert 8 * math.sin(t3m) == pytest.approx(-5 / math.sqrt(2), rel=1e-14)
    assert r1m == pytest.approx(5 / math.sqrt(2) + 8 * math.cos(t3m), rel=1e-14)
    assert r1m < r1
    # velocity: the notes' omega2 = 10 rad/s, alpha2 = 0
    v, w3 = C.slider_crank_velocity(r2, r3, t2, t3, 10.0)
    vp = -r2 * 10 * math.sin(t2) - r3 * w3 * math.sin(t3)  # x of the notes' v_P
    vy = r2 * 10 * math.cos(t2) + r3 * w3 * math.cos(t3)  # slider does not leave the line
    assert v == pytest.approx(vp, rel=1e-14)
    assert vy == pytest.approx(0, abs=1e-12)


def random_sliders(seed, n=4000):
    rng = np.random.default_rng(seed)
    r2 = rng.uniform(0.5, 5, n)
    r3 = rng.uniform(0.5, 10, n)
    r4 = rng.uniform(-6, 6, n)
    t2 = rng.uniform(-math.pi, math.pi, n)
    t1 = np.where(rng.uniform(size=n) < 0.3, 0.0, rng.uniform(-math.pi, math.pi, n))
    return r2, r3, r4, t2, t1


@pytest.mark.parametrize("seed", [41, 42])
def test_slider_crank_case_i_closure_and_modes(seed):
    r2, r3, r4, t2, t1 = random_sliders(seed)
    r1p, t3p = C.slider_crank_position(r2, r3, t2, offset=r4, mode=+1, theta1=t1)
    r1m, t3m = C.slider_crank_position(r2, r3, t2, offset=r4, mode=-1, theta1=t1)
    h = np.abs(r4 - r2 * np.sin(t2 - t1))
    assert np.all(np.isnan(r1p[h > r3 + 1e-9])) and np.all(np.isnan(t3m[h > r3 + 1e-9]))
    ok = h < r3 - 1e-9
    assert ok.sum() > 1000 and (~ok).sum() > 100
    assert np.all(np.isfinite(r1p[ok]) & np.isfinite(r1m[ok]))
    assert np.all(r1p[ok] > r1m[ok])
    for r1, t3 in ((r1p, t3p), (r1m, t3m)):
        good = np.isfinite(r1)
        assert slider_closure(r1[good], r2[good], r3[good], r4[good], t2[good], t3[good], t1[good]).max() < 1e-12


def test_slider_crank_in_line_extremes():
    # dead centres of an in-line slider-crank: r1 = r3 +- r2, unique (discriminant > 0 here)
    r1, t3 = C.slider_crank_position(2.0, 5.0, np.array([0.0, math.pi]))
    np.testing.assert_allclose(r1, [7.0, 3.0], rtol=1e-15)
    np.testing.assert_allclose(t3, [0.0, 0.0], atol=1e-15)


def _well_conditioned_sliders(seed, mode, n=1500):
    r2, r3, r4, t2, t1 = random_sliders(seed, n)
    r1, t3 = C.slider_crank_position(r2, r3, t2, offset=r4, mode=mode, theta1=t1)
    ok = np.isfinite(r1) & (np.abs(np.cos(t3 - t1)) > 0.2)
    for h in (-0.05, 0.05):  # keep well away from dead positions
        q1, q3 = C.slider_crank_position(r2, r3, t2 + h, offset=r4, mode=mode, theta1=t1)
        ok &= np.isfinite(q1) & (np.abs(np.cos(q3 - t1)) > 0.1)
    return r2[ok], r3[ok], r4[ok], t2[ok], t1[ok], r1[ok], t3[ok]


@pytest.mark.parametrize("mode", [+1, -1])
def test_slider_crank_velocity_and_acceleration_vs_fd(mode):
    r2, r3, r4, t2, t1, r1, t3 = _well_conditioned_sliders(51, mode)
    assert t2.size > 200
    rng = np.random.default_rng(52)
    omega2 = rng.uniform(-4, 4, t2.size)
    alpha2 = rng.uniform(-10, 10, t2.size)
    v, w3 = C.slider_crank_velocity(r2, r3, t2, t3, omega2, theta1=t1)
    acc, a3 = C.slider_crank_acceleration(r2, r3, t2, t3, omega2, w3, alpha2, theta1=t1)

    def pos(dt):
        q1, q3 = C.slider_crank_position(r2, r3, t2 + dt, offset=r4, mode=mode, theta1=t1)
        return q1, t3 + wrap(q3 - t3)

    d1, d3 = fd(pos, 1e-4)
    lscale = (r2 + r3) * np.abs(omega2)
    np.testing.assert_allclose(v, d1 * omega2, rtol=1e-6, atol=1e-6 * lscale.max())
    np.testing.assert_allclose(w3, d3 * omega2, rtol=1e-6, atol=1e-6 * np.abs(omega2).max())

    def rates(dt):
        th2 = t2 + omega2 * dt + 0.5 * alpha2 * dt**2
        q1, q3 = C.slider_crank_position(r2, r3, th2, offset=r4, mode=mode, theta1=t1)
        return C.slider_crank_velocity(r2, r3, th2, q3, omega2 + alpha2 * dt, theta1=t1)

    fdv, fdw = fd(rates, 1e-4)
    ascale = np.abs(alpha2).max() + np.abs(omega2).max() ** 2
    np.testing.assert_allclose(acc, fdv, rtol=1e-6, atol=1e-6 * ascale * (r2 + r3).max())
    np.testing.assert_allclose(a3, fdw, rtol=1e-6, atol=1e-6 * ascale)


# ------------------------------------------------------------- slider-crank case ii
@pytest.mark.parametrize("seed", [61, 62])
def test_case_ii_recovers_case_i(seed):
    r2, r3, r4, t2, t1 = random_sliders(seed)
    for mode_i in (+1, -1):
        r1, t3 = C.slider_crank_position(r2, r3, t2, offset=r4, mode=mode_i, theta1=t1)
        s = np.sin(t3 - t2)
        ok = np.isfinite(r1) & (np.abs(s) > 1e-3)
        mode_ii = np.where(s > 0, 1, -1)
        t2b, t3b = C.slider_crank_inversion_position(r1, r2, r3, offset=r4, mode=mode_ii, theta1=t1)
        np.testing.assert_allclose(wrap(t2b[ok] - t2[ok]), 0, atol=1e-9)
        np.testing.assert_allclose(wrap(t3b[ok] - t3[ok]), 0, atol=1e-9)


@pytest.mark.parametrize("mode", [+1, -1])
def test_case_ii_closure_and_mode(mode):
    rng = np.random.default_rng(71)
    n = 4000
    r1 = rng.uniform(-12, 12, n)
    r2, r3, r4 = rng.uniform(0.5, 5, n), rng.uniform(0.5, 10, n), rng.uniform(-6, 6, n)
    t1 = rng.uniform(-math.pi, math.pi, n)
    t2, t3 = C.slider_crank_inversion_position(r1, r2, r3, offset=r4, mode=mode, theta1=t1)
    p = np.hypot(r1, r4)
    inside = (p < r2 + r3 - 1e-9) & (p > np.abs(r2 - r3) + 1e-9)
    outside = (p > r2 + r3 + 1e-9) | (p < np.abs(r2 - r3) - 1e-9)
    assert inside.sum() > 500 and outside.sum() > 500
    assert np.all(np.isfinite(t2[inside]) & np.isfinite(t3[inside]))
    assert np.all(np.isnan(t2[outside]) & np.isnan(t3[outside]))
    assert np.all(mode * np.sin(t3[inside] - t2[inside]) > 0)
    ok = np.isfinite(t2)
    assert slider_closure(r1[ok], r2[ok], r3[ok], r4[ok], t2[ok], t3[ok], t1[ok]).max() < 1e-12


def test_case_ii_quadratic_leading_coefficient_zero():
    # A = C1 - A1 = 0 <=> theta2 = pi is a root: crank pin at (-r2, 0)
    r2, r3, r4 = 2.0, 5.0, 1.0
    r1 = -r2 + math.sqrt(r3**2 - r4**2)
    sols = [C.slider_crank_inversion_position(r1, r2, r3, offset=r4, mode=m) for m in (1, -1)]
    assert any(abs(wrap(t2 - math.pi)) < 1e-13 for t2, _ in sols)
    for t2, t3 in sols:
        assert slider_closure(np.array(r1), np.array(r2), np.array(r3), np.array(r4), t2, t3, 0.0) < 1e-14


# --------------------------------------------------------------------- Grashof
@pytest.mark.parametrize(
    "lengths, expected",
    [
        ((60, 25, 70, 45), C.GrashofClass.CRANK_ROCKER),  # thesis: 25 + 70 = 95 < 105
        ((2, 4, 5, 4.5), C.GrashofClass.DOUBLE_CRANK),
        ((4, 5, 2, 4.5), C.GrashofClass.DOUBLE_ROCKER),
        ((4, 5, 4.5, 2), C.GrashofClass.ROCKER_CRANK),  # r4 shortest: the output turns, the input rocks
        ((4, 2, 4, 2), C.GrashofClass.CHANGE_POINT),  # parallelogram
        ((3, 1, 3, 1 + 1e-12), C.GrashofClass.CHANGE_POINT),  # within 1e-9
        ((4, 3, 3.5, 5), C.GrashofClass.TRIPLE_ROCKER),
        ((10, 9, 8, 7), C.GrashofClass.CHANGE_POINT),  # 7 + 10 == 8 + 9
        ((10, 9, 8, 7.5), C.GrashofClass.TRIPLE_ROCKER),
    ],
)
def test_grashof(lengths, expected):
    assert C.grashof(*lengths) is expected
    assert C.is_grashof(*lengths) == (expected is not C.GrashofClass.TRIPLE_ROCKER)


def test_grashof_values_and_errors():
    assert [g.value for g in C.GrashofClass] == [
        "double crank",
        "crank-rocker",
        "rocker-crank",
        "double rocker",
        "change point",
        "triple rocker",
    ]
    with pytest.raises(ModelError):
        C.grashof(0, 1, 1, 1)
    with pytest.raises(ModelError):
        C.is_grashof(1, -1, 1, 1)


@pytest.mark.parametrize("seed", range(3))
def test_grashof_crank_rotates_iff_input_range_full(seed):
    rng = np.random.default_rng(seed)
    for r in rng.uniform(0.5, 10, size=(300, 4)):
        g = C.grashof(*r)
        full = C.fourbar_input_range(*r) == [(-math.pi, math.pi)]
        # the input r2 rotates fully exactly for a Grashof linkage whose shortest link
        # is the frame or the crank
        assert full == (g in (C.GrashofClass.DOUBLE_CRANK, C.GrashofClass.CRANK_ROCKER) and np.argmin(r) in (0, 1))


# ------------------------------------------------------ input range and toggles
def _in_intervals(theta, intervals, margin):
    theta = np.asarray(theta)
    res = np.zeros(theta.shape, bool)
    for s, t in intervals:
        d = (theta - s) % TWO_PI
        res |= (d >= margin) & (d <= t - s - margin)
    return res


def test_input_range_thesis():
    assert C.fourbar_input_range(60, 25, 70, 45) == [(-math.pi, math.pi)]
    assert C.fourbar_toggle_angles(60, 25, 70, 45).size == 0


def test_input_range_never_assembles():
    assert C.fourbar_input_range(20, 1, 2, 3) == []
    assert C.fourbar_toggle_angles(20, 1, 2, 3).size == 0
    assert np.all(np.isnan(C.transmission_angle_range(20, 1, 2, 3)))


@pytest.mark.parametrize("seed", [81, 82, 83])
def test_input_range_matches_positions(seed):
    rng = np.random.default_rng(seed)
    grid = np.linspace(-math.pi, math.pi, 721)
    shapes = set()
    for r in rng.uniform(0.5, 10, size=(200, 4)):
        intervals = C.fourbar_input_range(*r)
        shapes.add(len(intervals) if intervals != [(-math.pi, math.pi)] else "full")
        for s, t in intervals:
            assert t > s and -math.pi <= s and t <= math.pi + TWO_PI
        _, t4 = C.fourbar_position(*r, grid)
        inside = _in_intervals(grid, intervals, 1e-9)
        outside = ~_in_intervals(grid, intervals, -1e-9)
        assert np.all(np.isfinite(t4[inside]))
        assert np.all(np.isnan(t4[outside]))
        # the toggle angles are exactly the finite interval ends
        toggles = C.fourbar_toggle_angles(*r)
        assert np.all(np.diff(toggles) > 0)
        assert np.all((toggles > -math.pi) & (toggles <= math.pi))
        ends = {round(float(wrap(x + 1e-13)), 9) for iv in intervals for x in iv if iv != (-math.pi, math.pi)}
        assert {round(float(wrap(x + 1e-13)), 9) for x in toggles} == ends
    assert {"full", 0, 1, 2} <= shapes


@pytest.mark.parametrize("seed", [91, 92])
def test_toggle_angles_discriminant_and_neighbourhood(seed):
    rng = np.random.default_rng(seed)
    checked = 0
    for r in rng.uniform(0.5, 10, size=(300, 4)):
        if C.grashof(*r) is C.GrashofClass.CHANGE_POINT:
            continue
        for tau in C.fourbar_toggle_angles(*r):
            if abs(math.sin(tau)) < 1e-3:
                continue
            a, b, c = C._fourbar_coefficients(*r, tau)
            assert abs(b * b - 4 * a * c) <= 1e-10 * (b * b + 4 * abs(a * c))
            tp3, tp4 = C.fourbar_position(*r, tau, mode=+1)
            tm3, tm4 = C.fourbar_position(*r, tau, mode=-1)
            assert np.isfinite(tp4) and np.isfinite(tm4)
            assert abs(wrap(tp4 - tm4)) < 1e-6 and abs(wrap(tp3 - tm3)) < 1e-6
            assert abs(math.sin(tp4 - tp3)) < 1e-6  # coupler and output collinear
            # just outside on one side it cannot be assembled, just inside it can
            side = [np.isnan(C.fourbar_position(*r, tau + d)[1]) for d in (-1e-7, 1e-7)]
            assert sorted(side) == [False, True]
            checked += 1
    assert checked > 50


def test_toggle_angles_change_point():
    # parallelogram: change points at theta2 = 0 and pi
    np.testing.assert_allclose(C.fourbar_toggle_angles(4, 2, 4, 2), [0.0, math.pi])
    assert C.fourbar_input_range(4, 2, 4, 2) == [(-math.pi, math.pi)]


# ------------------------------------------------------------ transmission angle
def test_transmission_angle_fold():
    np.testing.assert_allclose(
        C.transmission_angle(np.radians([170, 10, 0, -90]), np.radians([-170, 350, 180, 0])),
        np.radians([20, 20, 180, 90]),
        atol=1e-14,
    )


@pytest.mark.parametrize("mode", [+1, -1])
def test_transmission_angle_law_of_cosines_and_range(mode):
    rng = np.random.default_rng(101)
    for r in rng.uniform(0.5, 10, size=(100, 4)):
        r1, r2, r3, r4 = r
        grid = np.linspace(-math.pi, math.pi, 20001)
        t3, t4 = C.fourbar_position(*r, grid, mode=mode)
        ok = np.isfinite(t4)
        lo, hi = C.transmission_angle_range(*r)
        if not ok.any():
            assert math.isnan(lo) and math.isnan(hi)
            continue
        mu = C.transmission_angle(t3[ok], t4[ok])
        bd2 = r1**2 + r2**2 - 2 * r1 * r2 * np.cos(grid[ok])
        np.testing.assert_allclose(np.cos(mu), (r3**2 + r4**2 - bd2) / (2 * r3 * r4), atol=1e-9)
        assert 0 <= lo <= hi <= math.pi
        assert mu.min() >= lo - 1e-9 and mu.max() <= hi + 1e-9
        # mu ~ sqrt(distance to a toggle), so compare cosines (smooth in theta2)
        tol = 2 * (grid[1] - grid[0]) * r1 * r2 / (r3 * r4)
        assert math.cos(mu.min()) == pytest.approx(math.cos(lo), abs=tol)
        assert math.cos(mu.max()) == pytest.approx(math.cos(hi), abs=tol)


def test_transmission_angle_range_thesis():
    lo, hi = C.transmission_angle_range(60, 25, 70, 45)
    assert math.cos(lo) == pytest.approx((70**2 + 45**2 - 35**2) / (2 * 70 * 45))
    assert math.cos(hi) == pytest.approx((70**2 + 45**2 - 85**2) / (2 * 70 * 45))


# ----------------------------------------------------------------------- Gruebler
@pytest.mark.parametrize(
    "args, mobility",
    [((4, 4), 1), ((4, 4, 0), 1), ((6, 7), 1), ((5, 5), 2), ((3, 2, 1), 1), ((5, 6), 0), ((1, 0), 0), ((2, 1), 1)],
)
def test_gruebler(args, mobility):
    assert C.gruebler(*args) == mobility
    assert isinstance(C.gruebler(*args), int)


@pytest.mark.parametrize("args", [(0, 0), (4, -1), (4, 4, -1), (4.5, 4), (4, "4")])
def test_gruebler_errors(args):
    with pytest.raises(ModelError):
        C.gruebler(*args)


# -------------------------------------------------------------------- quick return
def test_quick_return_values():
    ratio, adv, ret, rock = C.quick_return(1.0, 2.0)
    assert ratio == pytest.approx(2.0)
    assert adv == pytest.approx(math.radians(240))
    assert ret == pytest.approx(math.radians(120))
    assert rock == pytest.approx(math.radians(60))


@pytest.mark.parametrize("r2, d", [(1.0, 1.2), (1.0, 3.0), (2.5, 10.0)])
def test_quick_return_against_sampled_geometry(r2, d):
    ratio, adv, ret, rock = C.quick_return(r2, d)
    assert ratio > 1 and adv + ret == pytest.approx(TWO_PI) and rock == pytest.approx(math.pi - ret)
    # O4 at (-d, 0): slotted-link angle as the crank turns
    theta = np.linspace(-math.pi, math.pi, 400001)
    phi = np.arctan2(r2 * np.sin(theta), r2 * np.cos(theta) + d)
    assert phi.max() - phi.min() == pytest.approx(rock, abs=1e-8)
    th_hi, th_lo = theta[np.argmax(phi)], theta[np.argmin(phi)]
    # the crank arc between the limits through theta = pi (the O4 side) is the return
    assert TWO_PI - abs(th_hi - th_lo) == pytest.approx(ret, abs=1e-4)


def test_quick_return_vectorized_and_errors():
    ratio, *_ = C.quick_return(np.array([1.0, 2.0]), np.array([2.0, 4.0]))
    np.testing.assert_allclose(ratio, [2.0, 2.0])
    with pytest.raises(ModelError, match="Whitworth"):
        C.quick_return(2.0, 2.0)
    with pytest.raises(ModelError):
        C.quick_return(np.array([1.0, 3.0]), np.array([2.0, 2.0]))
    with pytest.raises(ModelError):
        C.quick_return(0.0, 1.0)
