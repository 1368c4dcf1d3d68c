"""The batched fast path: same results as the tracked path, verified point by point."""

from __future__ import annotations

import math

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.kinematics import batch
from loopsolve.kinematics import classic as C
from loopsolve.kinematics.sweep import AUTO_BATCH

from support.models import watt_sixbar

THESIS = ls.load(ls.models_dir() / "thesis_crank_rocker.toml")


def wrap(a):
    return (np.asarray(a) + math.pi) % (2 * math.pi) - math.pi


def assert_same(a, b, tol=1e-12):
    assert len(a) == len(b)
    assert a.modes == b.modes
    assert [e.kind for e in a.events] == [e.kind for e in b.events]
    for name in ("z", "z1", "z2", "z3"):
        x, y = getattr(a, name), getattr(b, name)
        assert np.max(np.abs(x - y) / (1 + np.abs(y))) <= tol, name
    assert np.max(np.abs(a.points - b.points) / (1 + np.abs(b.points))) <= tol


class TestAgreement:
    def test_thesis_fourbar_1e4_points_agree_to_1e_12(self):
        step = 360 / 10_000
        tr = THESIS.sweep(0, 360, step, method="tracked")
        bt = THESIS.sweep(0, 360, step, method="batched")
        assert len(tr) == 10_001 and tr.method == "tracked" and bt.method == "batched"
        assert_same(bt, tr)
        # and both equal the closed form
        x = np.radians(bt["theta2"])
        t3, t4 = C.fourbar_position(60, 25, 70, 45, x, 1)
        w3, w4 = C.fourbar_velocity(25, 70, 45, x, t3, t4, bt.z1[:, 0])
        a3, a4 = C.fourbar_acceleration(25, 70, 45, x, t3, t4, bt.z1[:, 0], w3, w4, 0.0)
        assert np.max(np.abs(wrap(bt.z[:, 1] - t3))) < 1e-12
        assert np.max(np.abs(wrap(bt.z[:, 2] - t4))) < 1e-12
        assert np.max(np.abs(bt.z1[:, 2] - w4)) < 1e-12
        assert np.max(np.abs(bt.z2[:, 1] - a3)) < 1e-11

    def test_through_limits_batched_equals_tracked(self):
        mech = ls.fourbar(4, 3, 3.5, 5, theta2=200)
        tr = mech.sweep(200, 560, 0.5, through_limits=True, method="tracked")
        bt = mech.sweep(200, 560, 0.5, through_limits=True, method="batched")
        assert [e.kind.value for e in bt.events] == ["limit", "mode-change", "limit", "mode-change"]
        assert [e.input for e in bt.events] == pytest.approx([e.input for e in tr.events], abs=1e-10)
        assert_same(bt, tr, tol=1e-10)

    @pytest.mark.parametrize("model,step", [("prob2_offset_slider_crank.toml", 0.25),
                                            ("quick_return.toml", 0.25),
                                            ("example1_slider_crank.toml", 0.3)])
    def test_models_agree(self, model, step):
        mech = ls.load(ls.models_dir() / model)
        # rates of lengths in mm at 20 rad/s reach 1e5 mm/s^2: round-off of the positions, amplified
        assert_same(mech.sweep(0, 360, step, method="batched"), mech.sweep(0, 360, step, method="tracked"),
                    tol=1e-11)

    def test_sixbar_blocks(self):
        mech = watt_sixbar()
        assert_same(mech.sweep(60, 420, 0.5, method="batched"), mech.sweep(60, 420, 0.5, method="tracked"),
                    tol=1e-11)


class TestVerification:
    def test_corrupted_vectorized_points_are_caught_and_redone(self, monkeypatch):
        """Points the vectorized Newton gets wrong (here: sent to the other mode) are redone by tracking."""
        real = batch._newton_v

        def sabotaged(ck, Z):
            out = real(ck, Z)
            # every 7th point: replace by the crossed solution (a valid root with a tiny residual
            # and correction, only its mode is wrong: the signature check must catch it)
            idx = np.arange(0, Z.shape[1], 7)
            t3, t4 = C.fourbar_position(60, 25, 70, 45, Z[0, idx], -1)
            Z[1, idx], Z[2, idx] = t3, t4
            return out

        monkeypatch.setattr(batch, "_newton_v", sabotaged)
        bt = THESIS.sweep(0, 360, 0.25, method="batched")
        monkeypatch.undo()
        tr = THESIS.sweep(0, 360, 0.25, method="tracked")
        assert set(bt.modes) == {"-"}
        assert_same(bt, tr)

    def test_auto_picks_batched_for_dense_grids(self):
        assert THESIS.sweep(0, 360, 360 / (AUTO_BATCH + 10)).method == "batched"
        assert THESIS.sweep(0, 360, 10).method == "tracked"


class TestRates:
    def test_rates_v_equals_the_single_point_solve(self):
        ck = THESIS.compile()
        states = [THESIS.solve(t, speed=2.0, accel=0.5, jerk=0.1) for t in (0, 33, 90, 200, 301)]
        Z = np.array([s.z for s in states]).T
        Z1, Z2, Z3, cond = batch.rates_v(ck, Z, (2.0, 0.5, 0.1))
        for i, s in enumerate(states):
            assert np.allclose(Z1[:, i], s.z1, rtol=1e-13, atol=1e-13)
            assert np.allclose(Z2[:, i], s.z2, rtol=1e-13, atol=1e-13)
            assert np.allclose(Z3[:, i], s.z3, rtol=1e-12, atol=1e-12)
            assert cond[i] == pytest.approx(s.cond, rel=1e-9)

    def test_block_solve_general_blocks(self):
        ck = watt_sixbar().compile()
        s = watt_sixbar().solve(60)
        rng = np.random.default_rng(3)
        Z = s.z[:, None] + 0.01 * rng.standard_normal((len(s.z), 50))
        J = ck.module.jac_v(Z, ck.p)
        B = rng.standard_normal((4, 50))
        X = batch.block_solve_v(ck, J, B)
        for i in range(50):
            assert np.allclose(ck.jac(Z[:, i]) @ X[:, i], B[:, i], atol=1e-10)
        dets, reg = batch.block_dets_v(ck, J)
        assert dets.shape == (2, 50) and np.all(reg > 0)

    def test_singular_rows_get_nan_rates(self):
        ck = ls.fourbar(4, 2, 4, 2).compile()
        Z = np.array([[0.0, math.pi / 2], [0.0, 0.0], [0.0, math.pi / 2]])  # change point, regular
        Z1, _, _, cond = batch.rates_v(ck, Z, (1.0, 0.0, 0.0))
        assert np.isnan(Z1[1, 0]) and np.isinf(cond[0])
        assert np.all(np.isfinite(Z1[:, 1]))


def test_derivatives_option_skips_the_higher_rates():
    full = THESIS.sweep(0, 360, 0.5, method="batched")
    acc = THESIS.sweep(0, 360, 0.5, method="batched", derivatives=2)
    assert np.array_equal(acc.z2, full.z2) and np.array_equal(acc.z1, full.z1)
    assert np.all(np.isnan(acc["theta3_jerk"])) and np.all(acc["theta2_jerk"] == 0)
    assert acc.rows[0]["theta4_jerk"] is None
    vel = THESIS.sweep(0, 360, 30, method="tracked", derivatives=1)
    assert np.all(np.isnan(vel["theta4_acc"])) and np.all(np.isfinite(vel["theta4_vel"]))
    with pytest.raises(ls.ModelError):
        THESIS.sweep(0, 360, 30, derivatives=4)
