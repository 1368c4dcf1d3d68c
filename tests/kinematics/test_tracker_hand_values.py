"""The tracker (kernel, continuation, sweep, batch) against values worked out by hand
(written for its surviving mutants, issue 13).

Every expected value is written here independently: four-bar and slider-crank positions by the
law of cosines / the sine rule, block determinants of the loop Jacobians by hand, link lengths
from the drawn joint coordinates of a model file. The triage of every survivor (killed here or
harmless, with the reason) is in tools/mutation_triage/{kernel,continuation,sweep,batch}.txt.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.kinematics import batch
from loopsolve.kinematics.grid import grid

from support.models import watt_sixbar

MODELS = ls.models_dir()


def fourbar_pose(r1, r2, r3, r4, t2, sign):
    """(theta3, theta4) [rad] of the four-bar O2 A B O4 (O4 = (r1, 0)) by the law of cosines."""
    ax, ay = r2 * math.cos(t2), r2 * math.sin(t2)
    d = math.hypot(r1 - ax, ay)
    phi = math.atan2(-ay, r1 - ax)  # direction A -> O4
    beta = math.acos((r3 * r3 + d * d - r4 * r4) / (2 * r3 * d))  # angle at A between AO4 and AB
    t3 = phi + sign * beta
    bx, by = ax + r3 * math.cos(t3), ay + r3 * math.sin(t3)
    return t3, math.atan2(by, bx - r1)


# ----------------------------------------------------------------------------- batch.block_dets_v


def test_block_dets_of_a_fourbar_by_hand():
    """|det Φ_q| = r3·r4·|sin(θ3 − θ4)| and regularity 2·r3·r4·|sin(θ3 − θ4)| / (r3² + r4²), for both
    modes at once (the modes have opposite signs), and the stacked call equals the one-point calls.

    Kills loopsolve.kinematics.batch.x_block_dets_v__mutmut_5 (angle columns scaled by 2) and
    loopsolve.kinematics.batch.x_block_dets_v__mutmut_45 (the 2x2 determinant with a division).
    """
    r1, r2, r3, r4 = 60.0, 25.0, 70.0, 45.0
    ck = ls.fourbar(r1, r2, r3, r4).compile()
    cols, want_d, want_h = [], [], []
    for t2 in (0.3, 1.2, 2.5, 4.0):
        for sign in (1, -1):
            t3, t4 = fourbar_pose(r1, r2, r3, r4, t2, sign)
            cols.append([t2, t3, t4])
            s = abs(math.sin(t3 - t4))
            want_d.append(r3 * r4 * s)
            want_h.append(2 * r3 * r4 * s / (r3 * r3 + r4 * r4))
    Z = np.array(cols).T
    dets, reg = batch.block_dets_v(ck, ck.module.jac_v(Z, ck.p))
    assert dets.shape == (1, len(cols))
    assert np.allclose(np.abs(dets[0]), want_d, rtol=1e-12)
    assert np.allclose(reg[0], want_h, rtol=1e-12)
    assert np.all(np.sign(dets[0, ::2]) == -np.sign(dets[0, 1::2]))  # the two modes
    for i in range(len(cols)):
        d1, h1 = batch.block_dets_v(ck, ck.module.jac_v(Z[:, i:i + 1], ck.p))
        assert d1[0, 0] == pytest.approx(dets[0, i], rel=1e-14) and h1[0, 0] == pytest.approx(reg[0, i], rel=1e-14)


def test_block_dets_of_a_slider_crank_by_hand():
    """Example 1 (r2 = 5, r3 = 8, no offset): two 1x1 blocks, θ3 from the y equation (det r3·cos θ3,
    regularity r3·|cos θ3| / scale) and r1 from the x equation (det 1 x the length scale, regularity 1).

    Kills loopsolve.kinematics.batch.x_block_dets_v__mutmut_35 (1x1 regularity: np.minimum with one argument)
    and loopsolve.kinematics.batch.x_block_dets_v__mutmut_5 too.
    """
    mech = ls.load(MODELS / "example1_slider_crank.toml")
    ck = mech.compile()
    r2, r3 = 5.0, 8.0
    scale = float(ck.scale)
    cols, c3 = [], []
    for t2 in (0.2, 0.785, 2.0, 3.5, 5.5):
        t3 = math.asin(-r2 * math.sin(t2) / r3)  # the rod on the slider's side (cos θ3 > 0)
        cols.append([t2, t3, r2 * math.cos(t2) + r3 * math.cos(t3)])
        c3.append(r3 * math.cos(t3))
    order = [ck.index(v) for v in ("theta2", "theta3", "r1")]
    Z = np.zeros((3, len(cols)))
    Z[order] = np.array(cols).T
    dets, reg = batch.block_dets_v(ck, ck.module.jac_v(Z, ck.p))
    blocks = [tuple(ck.unknowns[c] for c in b.unknowns) for b in ck.blocks]
    i3, i1 = blocks.index(("theta3",)), blocks.index(("r1",))
    assert np.allclose(np.abs(dets[i3]), c3, rtol=1e-12)
    assert np.allclose(reg[i3], np.minimum(np.array(c3) / scale, 1.0), rtol=1e-12)
    assert np.allclose(np.abs(dets[i1]), scale, rtol=1e-14)
    assert np.allclose(reg[i1], 1.0, rtol=1e-14)


# ----------------------------------------------------------------------------- a 4x4 block (batched path)

STEPHENSON = MODELS / "stephenson3_sixbar.toml"


def stephenson_lengths():
    """Pairs of joints on one link and their distance, from the drawn joint coordinates of the file."""
    import tomllib

    doc = tomllib.loads(STEPHENSON.read_text())
    at = {k: v["at"] for k, v in doc["joints"].items()}
    pairs = [(a, b) for link, js in doc["links"].items() if link != "ground"
             for i, a in enumerate(js) for b in js[i + 1:]]
    return [(a, b, math.dist(at[a], at[b])) for a, b in pairs]


def test_batched_sweep_of_a_coupled_4x4_block():
    """The Stephenson III driven by link 6 couples both loops into one 4x4 block: the batched sweep
    runs its block-sign check on it, keeps every link its drawn length and equals the tracked sweep.

    Its rates (the stacked block solve of a 4x4 block) match central differences of the positions.

    Kills loopsolve.kinematics.batch.x__sign_dets_v__mutmut_27 (no 3x3+ matrix), loopsolve.kinematics.batch.x__sign_dets_v__mutmut_37
    (float index into the Jacobian), loopsolve.kinematics.batch.x_block_solve_v__mutmut_67, _77 and _87 (the 3x3+
    block solve broken).
    """
    mech = ls.load(STEPHENSON)
    assert [len(b.unknowns) for b in mech.compile("theta_link6").blocks] == [4]
    bt = mech.sweep(-128, -120, 0.02, input="theta_link6", method="batched", progress=False)
    tr = mech.sweep(-128, -120, 0.02, input="theta_link6", method="tracked", progress=False)
    assert bt.method == "batched" and len(bt) == len(tr) == 401 and not bt.events
    assert np.allclose(bt["theta_link6"], -128 + 0.02 * np.arange(401), atol=1e-9)
    assert bt.modes == tr.modes and len(set(bt.modes)) == 1
    for a, b, ell in stephenson_lengths():
        d = np.hypot(bt[f"{a}_x"] - bt[f"{b}_x"], bt[f"{a}_y"] - bt[f"{b}_y"])
        assert np.allclose(d, ell, rtol=0, atol=1e-5), (a, b)  # the file's coordinates have 6 decimals
    assert np.max(np.abs(bt.z - tr.z)) < 1e-12
    # velocities (unit input speed: dq/dx) against central differences of the positions (0.02° apart)
    h = math.radians(0.02)
    for name in ("theta_crank", "theta_coupler", "theta_rocker", "theta_link5"):
        q = np.unwrap(np.radians(bt[name]))
        fd = (q[2:] - q[:-2]) / (2 * h)
        v = bt[f"{name}_vel"][1:-1] / bt["theta_link6_vel"][1:-1]
        assert np.all(np.isfinite(v)) and np.allclose(v, fd, rtol=1e-4, atol=1e-6), name


def test_block_dets_of_a_4x4_block_are_per_point():
    """Stacked regularities equal the single-point ones (each point's own Hadamard ratio
    |det M| / (‖M‖²_F / k)^(k/2), 0 < h ≤ 1), whatever the other points.

    Kills loopsolve.kinematics.batch.x_block_dets_v__mutmut_75 (Frobenius norm summed over all points).
    """
    mech = ls.load(STEPHENSON)
    ck = mech.compile("theta_link6")
    sw = mech.sweep(-128, -120, 4, input="theta_link6", method="tracked", progress=False)
    Z = np.ascontiguousarray(sw.z.T)
    dets, reg = batch.block_dets_v(ck, ck.module.jac_v(Z, ck.p))
    assert dets.shape == reg.shape == (1, 3)
    for i in range(3):
        M = np.asarray(ck.jac(Z[:, i]), dtype=float)  # all angles: no column scaling
        want = abs(np.linalg.det(M)) / (np.sum(M * M) / 4) ** 2
        assert abs(dets[0, i]) == pytest.approx(abs(np.linalg.det(M)), rel=1e-10)
        assert 0 < reg[0, i] <= 1 and reg[0, i] == pytest.approx(want, rel=1e-10)


# ----------------------------------------------------------------------------- starting on a limit


def toggle_angles(r1, r2, r3, r4):
    """Crank angles [deg] in (0, 180) where B is r3 + r4 or |r3 - r4| from O4 (law of cosines)."""
    out = []
    for d in (r3 + r4, abs(r3 - r4)):
        c = (r1 * r1 + r2 * r2 - d * d) / (2 * r1 * r2)
        if -1 < c < 1:
            out.append(math.degrees(math.acos(c)))
    return sorted(out)


@pytest.mark.parametrize("method", ["tracked", "batched"])
def test_a_sweep_from_a_limit_warns_nothing_and_turns_at_the_far_one(method):
    """Double rocker (60, 50, 20, 45): toggles at acos(0.9125) = 24.15° and acos(0.3125) = 71.79°.
    Starting on the first, the sweep (batched or tracked) issues no numpy warning: the start node's
    tangent is normal to the input axis, and its slope dq/dx is infinite by design.

    Kills loopsolve.kinematics.batch.x_solve_rows__mutmut_109 (divide-by-zero warning at the start fold).
    """
    import warnings

    lo, hi = toggle_angles(60, 50, 20, 45)
    assert lo == pytest.approx(math.degrees(math.acos(0.9125)), abs=1e-12)
    start = math.ceil(lo * 1e9) / 1e9
    mech = ls.load(MODELS / "double_rocker.toml")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sw = mech.sweep(start, 75, 0.5, through_limits=True, method=method, progress=False)
    assert sw.method == method
    assert [e.kind.value for e in sw.events] == ["limit", "limit", "mode-change"]
    assert [e.input for e in sw.events] == pytest.approx([lo, hi, hi], abs=1e-9)
    assert sw["theta2"][0] == pytest.approx(start + 0.5, abs=1e-12)


# ----------------------------------------------------------------------------- wrong-mode detection


def test_batched_points_sent_to_the_other_mode_are_caught(monkeypatch):
    """The thesis four-bar in metres (0.06, 0.025, 0.07, 0.045): every 5th vectorized point is
    replaced by the other mode's pose at the same input (a valid root, law of cosines); the block
    sign check must reject it, so every row is the tracked mode's pose by the law of cosines.

    Kills loopsolve.kinematics.batch.x__sign_dets_v__mutmut_17 (2x2 determinant sign with a division, which
    accepts many crossed poses when the link lengths are below 1).
    """
    r = (0.06, 0.025, 0.07, 0.045)
    mech = ls.fourbar(*r)
    real = batch._newton_v

    def other_mode(t2, t3):
        poses = [fourbar_pose(*r, t2, s) for s in (1, -1)]
        return max(poses, key=lambda p: abs(math.remainder(p[0] - t3, 2 * math.pi)))

    def sabotaged(ck, Z):
        out = real(ck, Z)
        for i in range(0, Z.shape[1], 5):
            Z[1, i], Z[2, i] = other_mode(Z[0, i], Z[1, i])
        return out

    monkeypatch.setattr(batch, "_newton_v", sabotaged)
    sw = mech.sweep(0, 360, 0.5, method="batched", progress=False)
    assert sw.method == "batched" and len(sw) == 721 and set(sw.modes) == {sw.mode}
    t2 = np.radians(sw["theta2"])
    z = np.radians(np.column_stack([sw["theta3"], sw["theta4"]]))
    err = {s: np.array([np.abs(np.remainder(np.array(fourbar_pose(*r, x, s)) - q + math.pi, 2 * math.pi) - math.pi)
                        .max() for x, q in zip(t2, z)]) for s in (1, -1)}
    assert min(err[1].max(), err[-1].max()) < 1e-10


def test_batched_slider_crank_points_sent_to_the_other_mode_are_caught(monkeypatch):
    """Slider-crank r2 = 5, r3 = 8 declared with r1 before theta3 (so the θ3 block is the second
    unknown's): every 5th vectorized point is replaced by the mirrored rod θ3' = π − θ3,
    r1' = r2·cos θ2 − r3·cos θ3 (a valid root of the other mode); every row must still be the start
    mode's pose by the sine rule: sin θ3 = −r2·sin θ2 / r3 with cos θ3 > 0, r1 = r2·cos θ2 + r3·cos θ3.

    Kills loopsolve.kinematics.batch.x__sign_dets_v__mutmut_7 (1x1 block sign read from the wrong Jacobian entry).
    """
    r2, r3 = 5.0, 8.0
    b = ls.MechanismBuilder("slider-crank, r1 first")
    b.parameter("r2", r2).parameter("r3", r3)
    b.variable("theta2", input=True, guess=45)
    b.variable("r1", guess=10.7).variable("theta3", guess=-26)
    b.vector("r1", length="r1", angle=0).vector("r2", length="r2", angle="theta2")
    b.vector("r3", length="r3", angle="theta3")
    b.loop("r2 + r3 = r1")
    mech = b.build()
    ck = mech.compile()
    i2, i1, i3 = (ck.index(v) for v in ("theta2", "r1", "theta3"))
    real = batch._newton_v

    def sabotaged(ck_, Z):
        out = real(ck_, Z)
        idx = np.arange(0, Z.shape[1], 5)
        t3 = Z[i3, idx]
        Z[i3, idx] = math.pi - t3
        Z[i1, idx] = r2 * np.cos(Z[i2, idx]) - r3 * np.cos(t3)
        return out

    monkeypatch.setattr(batch, "_newton_v", sabotaged)
    sw = mech.sweep(0, 360, 0.5, method="batched", progress=False)
    assert sw.method == "batched" and len(sw) == 721 and set(sw.modes) == {sw.mode}
    t2 = np.radians(sw["theta2"])
    t3 = np.arcsin(-r2 * np.sin(t2) / r3)
    assert np.max(np.abs(np.remainder(np.radians(sw["theta3"]) - t3 + math.pi, 2 * math.pi) - math.pi)) < 1e-10
    assert np.max(np.abs(sw["r1"] - (r2 * np.cos(t2) + r3 * np.cos(t3)))) < 1e-9


# ----------------------------------------------------------------------------- sweep: grid, errors, ranges


@pytest.mark.parametrize("step", [0, 0.0, math.inf, -math.inf, math.nan])
def test_grid_refuses_a_zero_or_non_finite_step(step):
    """``grid`` (public) raises the ModelError naming --step, not a ZeroDivisionError or a NaN grid.

    Kills loopsolve.kinematics.grid.x_grid__mutmut_1 (``or`` -> ``and``: nothing is refused).
    """
    with pytest.raises(ls.ModelError, match="--step must be a nonzero number"):
        grid(0.0, 10.0, step)
    assert grid(10.0, 0.0, -4.0).tolist() == [10.0, 6.0, 2.0]  # the sign of the step is the range's


def test_stalled_newton_error_keeps_the_partial_solution():
    """Watt II six-bar with r5 = 40: the second loop only closes on the first loop's crossed mode, the
    guesses pick the open one. Newton from them stalls; the error (since issue 17 a ModeError: the
    guesses name a mode no solution has, and the modes there are listed) carries ``result``, the
    partial solution: the input at 60°, the first loop closed in the open mode (law of cosines), the
    second loop open. ``assembly_failure`` turns that stall into a ConvergenceError keeping it too.

    Kills loopsolve.kinematics.reach.x_assembly_failure__mutmut_22 and loopsolve.kinematics.reach.x_assembly_failure__mutmut_32
    (``result`` dropped).
    """
    from loopsolve.kinematics.solve import initial_z, solve_position
    from loopsolve.kinematics.reach import assembly_failure

    mech = watt_sixbar().with_parameters(r5=40)
    with pytest.raises(ls.ModeError) as exc:
        mech.solve(60)
    ck = mech.compile()
    z0 = initial_z(ck)
    z0[ck.index("theta2")] = math.radians(60)
    with pytest.raises(ls.AssemblyError) as stall:
        solve_position(ck, z0)
    failure = assembly_failure(ck, math.radians(60), stall.value)
    assert isinstance(failure, ls.ConvergenceError)
    for err in (exc.value, failure):
        assert err.input_value == pytest.approx(60, abs=1e-12)
        _check_partial_watt(ck, np.asarray(err.result, dtype=float))


def _check_partial_watt(ck, z):
    """The input at 60°, the first loop closed in a mode of the law of cosines, the second loop open."""
    assert z.shape == (len(ck.variables),)
    assert z[ck.index("theta2")] == pytest.approx(math.radians(60), abs=1e-15)
    poses = [fourbar_pose(60, 25, 70, 45, math.radians(60), s) for s in (1, -1)]
    got = (z[ck.index("theta3")], z[ck.index("theta4")])
    assert min(max(abs(math.remainder(g - p, 2 * math.pi)) for g, p in zip(got, pose)) for pose in poses) < 1e-9
    # the second loop r4c + r5 = r7 + r6 (r7 = (50, 55)) does not close at the partial solution
    t4, t5, t6 = (z[ck.index(v)] for v in ("theta4", "theta5", "theta6"))
    gap = (25 * np.exp(1j * (t4 + math.radians(160))) + 40 * np.exp(1j * t5)) - (50 + 55j + 55 * np.exp(1j * t6))
    assert abs(gap) > 1e-3


def test_reachable_ranges_of_a_slider_far_from_its_guess():
    """Slider-crank r2 = 2, r3 = 3 whose slider is measured from a point 40 to the right of the crank
    pivot (C = 40 + s), guessed at s = -10 (length scale 10). |C| lies in [r3 - r2, r3 + r2], so
    s ∈ [-45, -41] ∪ [-39, -35]: both within 4 length scales of the guess, both found.

    Kills loopsolve.kinematics.reach.x_reachable_ranges__mutmut_10 (samples centred on 0 instead of the guess).
    """
    from loopsolve.kinematics.reach import nearest_assemblable, reachable_ranges

    b = ls.MechanismBuilder("far slider")
    b.parameter("r2", 2).parameter("r3", 3)
    b.variable("s", input=True, guess=-10)
    b.variable("theta2", guess=30).variable("theta3", guess=-20)
    b.vector("r2", length="r2", angle="theta2").vector("r3", length="r3", angle="theta3")
    b.vector("d", x=40, y=0).vector("s", length="s", angle=0)
    b.loop("r2 + r3 = d + s")
    mech = b.build()
    ck = mech.compile()
    assert ck.scale == 10
    want = [(-45.0, -41.0), (-39.0, -35.0)]
    got = reachable_ranges(ck)
    assert len(got) == 2 and all(p == pytest.approx(q, abs=1e-9) for p, q in zip(got, want))
    assert nearest_assemblable(ck, -40.0) == pytest.approx((-41.0, -39.0), abs=1e-9)


def test_batched_rows_report_one_newton_iteration():
    """The batched path solves a row by one vectorized Newton step from its warm start, and says so
    (``n_iter`` 1), also when every row takes that path at once (a sweep from the double rocker's
    limit at acos(0.9125) = 24.15° up to 70°, short of the far limit at 71.79°, no row on a node).

    Kills loopsolve.kinematics.batch.x_solve_rows__mutmut_289 (n_iter 2 when all rows are vectorized).
    """
    lo, hi = toggle_angles(60, 50, 20, 45)
    start = math.ceil(lo * 1e9) / 1e9
    sw = ls.load(MODELS / "double_rocker.toml").sweep(start, 70, 4, method="batched", progress=False)
    assert len(sw) == 11 and sw["theta2"][-1] == pytest.approx(start + 44, abs=1e-12) and start + 44 < hi
    assert sw.n_iter.tolist() == [1] * 11 and [s.n_iter for s in sw.states] == [1] * 11


# ----------------------------------------------------------------------------- rows next to a change point


def test_tracked_rows_next_to_a_change_point():
    """Four-bar (4, 2, 3, 3): r1 + r2 = r3 + r4, so at θ2 = 180° every pivot is in line (a change
    point). Every output row of a fine grid through it is solved, tracked as batched (only the row
    on the change point itself is left out, its rates being undefined); every row is one of the
    two law-of-cosines poses, and the change point is located at 180° to 1e-8.

    Regression test: next to the change point the corrector's Newton steps stall at round-off
    times the condition number, and the tracked path used to drop rows such as 179.94° and 180.06°
    ("no converged solution ... row left out") that the batched path solved.
    """
    r = (4.0, 2.0, 3.0, 3.0)
    for method in ("tracked", "batched"):
        sw = ls.fourbar(*r, theta2=179).sweep(179, 181, 0.01, method=method, progress=False)
        assert [e.kind.value for e in sw.events] == ["singular"] and "change point" in sw.events[0].message
        assert sw.events[0].input == pytest.approx(180, abs=5e-8)
        want = [v for v in np.round(179 + 0.01 * np.arange(201), 2) if v != 180]
        assert np.allclose(sw["theta2"], want, atol=1e-9)
        t2 = np.radians(sw["theta2"])
        z = np.radians(np.column_stack([sw["theta3"], sw["theta4"]]))
        for x, q in zip(t2, z):
            off = min(np.abs(np.remainder(np.array(fourbar_pose(*r, x, s)) - q + math.pi, 2 * math.pi) - math.pi).max()
                      for s in (1, -1))
            assert off < 1e-9


def test_corrector_subdivides_a_segment_whose_guess_is_poor():
    """The tracker's row corrector on a long segment (nodes at 20° and 90° on the crossed branch of
    the non-Grashof four-bar 4, 3, 3.5, 5): the cubic guess at 37.5° is poor, Newton leaves the mode,
    and the segment is subdivided until the crossed pose (law of cosines) is found.

    Kills loopsolve.kinematics.continuation.xǁTracerǁsolve_at__mutmut_135 (subdivision crashes: tangent
    without its orientation row).
    """
    from loopsolve.kinematics.continuation import Kernel, StepControl, Tracer, first_node
    from loopsolve.kinematics.grid import Grid

    r = (4.0, 3.0, 3.5, 5.0)
    mech = ls.fourbar(*r)
    ck = mech.compile()
    kern = Kernel(ck)
    za, zb = (mech.solve(x, mode="crossed").z for x in (20, 90))
    a, b = first_node(kern, za, 1.0), first_node(kern, zb, 1.0)
    side = [s for s in (1, -1)
            if max(abs(math.remainder(p - q, 2 * math.pi)) for p, q in zip(fourbar_pose(*r, za[0], s), za[1:])) < 1e-9]
    assert len(side) == 1
    x0, x1 = math.radians(20), math.radians(90)
    tr = Tracer(kern, Grid(x0, x1 - x0, 0, 1, x0, x1), StepControl(), land=False, through_limits=False, x_start=x0)
    got = tr.solve_at(a, b, math.radians(37.5), a.sig)
    assert got is not None
    z, res, _ = got
    want = fourbar_pose(*r, math.radians(37.5), side[0])
    assert max(abs(math.remainder(p - q, 2 * math.pi)) for p, q in zip(want, z[1:])) < 1e-12
    assert res < 1e-12


# ----------------------------------------------------------------------------- dense batched grids


@pytest.mark.parametrize("stop", [0.5, 3.0])  # one segment (two chunks of rows), several
def test_dense_batched_rows_are_each_their_own_pose(stop):
    """A batched grid of 0.01° over a short range: the coarse pass's ~1° segments each cross far
    more than 32 output values (the vectorized enumeration); every row is present, in order, and is
    the four-bar pose at its own input by the law of cosines.

    Kills loopsolve.kinematics.sweep.x__enumerate_rows__mutmut_137 (no segment index), loopsolve.kinematics.sweep.
    x__enumerate_rows__mutmut_167 (rows within ~1 of the node copy the node) and loopsolve.kinematics.sweep.
    x__enumerate_rows__mutmut_197 (the rows of a second chunk dropped).
    """
    r = (60.0, 25.0, 70.0, 45.0)
    sw = ls.fourbar(*r, theta2=0).sweep(0, stop, 0.01, method="batched", progress=False)
    n = int(round(stop / 0.01)) + 1
    assert sw.method == "batched" and len(sw) == n and not sw.events
    assert np.allclose(sw["theta2"], 0.01 * np.arange(n), atol=1e-12)
    t2 = np.radians(sw["theta2"])
    z = np.radians(np.column_stack([sw["theta3"], sw["theta4"]]))
    off = {s: max(np.abs(np.remainder(np.array(fourbar_pose(*r, x, s)) - q + math.pi, 2 * math.pi) - math.pi).max()
                  for x, q in zip(t2, z)) for s in (1, -1)}
    assert min(off.values()) < 1e-10


def test_progress_bar_on_a_terminal(monkeypatch):
    """Long sweeps show a progress bar on stderr when it is a terminal (progress=None), not otherwise.

    Kills loopsolve.kinematics.sweep.x__progress__mutmut_2 (the terminal test replaced by None).
    """
    import io
    import sys

    from loopsolve.kinematics.sweep import _progress

    pytest.importorskip("tqdm")

    class Terminal(io.StringIO):
        def isatty(self):
            return True

    monkeypatch.setattr(sys, "stderr", Terminal())
    bar = _progress(5000, None)
    assert bar is not None
    bar.close()
    assert _progress(100, None) is None  # a short sweep ends before the bar's delay: no bar to set up
    monkeypatch.setattr(sys, "stderr", io.StringIO())
    assert _progress(5000, None) is None


# ----------------------------------------------------------------------------- a start on a limit, heading out


def test_a_sweep_from_a_limit_out_of_the_assemblable_range_stops_there():
    """Non-Grashof four-bar (4, 3, 3.5, 5): the crank rocks between ±acos((4² + 3² − 1.5²)/(2·4·3))
    = ±18.5733°. A sweep that starts on a limit and heads away from the assemblable range has no
    row; it reports that limit and warns about it, instead of wandering outside its range to a
    singular position there (322.96° / 37.04° before). A zero-width range on the double rocker's
    limit acos(0.9125) gives its limit only (no far limit at 71.79°, no warning).

    Regression test for the tracer leaving a range whose start is a limit position on its end.
    """
    import warnings

    t = math.degrees(math.acos((16 + 9 - 1.5 ** 2) / 24))
    mech = ls.fourbar(4, 3, 3.5, 5, theta2=180)
    for start, stop in ((360 - t, 350), (t, 0)):
        with pytest.warns(ls.LoopsolveWarning, match=f"limit position .* {start:.10g}"):
            sw = mech.sweep(start, stop, 10, progress=False)
        assert len(sw) == 0 and {e.kind.value for e in sw.events} == {"limit"}
        assert [e.input for e in sw.events] == pytest.approx([start] * len(sw.events), abs=1e-9)
    lo = math.degrees(math.acos(0.9125))
    dr = ls.load(MODELS / "double_rocker.toml")
    for through in (False, True):
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            sw = dr.sweep(lo, lo, 1, through_limits=through, progress=False)
        assert len(sw) == 0 and [e.kind.value for e in sw.events] == ["limit"]
        assert sw.events[0].input == pytest.approx(lo, abs=1e-9)


def test_rates_at_a_singular_row_warn_nothing():
    """Four-bar (4, 2, 4, 2) at θ2 = θ3 = θ4 = 0 (all pivots in line): Φ_q = [[0, 0], [4, -2]] is
    singular. rates_v gives an infinite condition number and NaN rates for it, silently; the regular
    row beside it (90°, 0°, 90°: a parallelogram) gets finite rates.

    Kills loopsolve.kinematics.batch.x__cond_v__mutmut_59 (divide-by-zero warning at a singular row).
    """
    import warnings

    ck = ls.fourbar(4, 2, 4, 2).compile()
    Z = np.array([[0.0, math.pi / 2], [0.0, 0.0], [0.0, math.pi / 2]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        Z1, _, _, cond = batch.rates_v(ck, Z, (1.0, 0.0, 0.0))
    assert np.isinf(cond[0]) and np.isnan(Z1[1, 0]) and np.isfinite(cond[1]) and np.all(np.isfinite(Z1[:, 1]))
    assert Z1[2, 1] == pytest.approx(1.0, abs=1e-12)  # a parallelogram: the rocker turns with the crank


def test_max_rows_counts_a_full_turn_through_limits_once_more():
    """A full turn by 1° with --through-limits may visit every grid angle on both modes: 360 + 360 + 1
    = 721 rows counted up front. max_rows=721 is accepted, 720 refused naming 721 rows.

    Kills loopsolve.kinematics.sweep.x__make_grid__mutmut_31 (one and a half turns counted).
    """
    mech = ls.fourbar(60, 25, 70, 45)
    sw = mech.sweep(0, 360, 1, through_limits=True, max_rows=721, progress=False)
    assert len(sw) == 361
    with pytest.raises(ls.ModelError, match=r"would have 721 rows .* limit of 720"):
        mech.sweep(0, 360, 1, through_limits=True, max_rows=720, progress=False)


def test_an_empty_sweep_has_empty_columns():
    """A sweep without rows (from the limit at 341.43° of the 4, 3, 3.5, 5 four-bar outwards) still
    has every column, each of length 0.

    Kills loopsolve.kinematics.batch.x_rates_v__mutmut_10 (no (nvar, 0) arrays for zero rows).
    """
    import warnings

    t = math.degrees(math.acos((16 + 9 - 1.5 ** 2) / 24))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ls.LoopsolveWarning)
        sw = ls.fourbar(4, 3, 3.5, 5, theta2=180).sweep(360 - t, 350, 10, method="batched", progress=False)
    assert len(sw) == 0
    for name in ("theta2", "theta3_vel", "theta4_acc", "theta4_jerk"):
        assert np.asarray(sw[name]).shape == (0,)
    assert sw.z.shape == (0, 3) and sw.z1.shape == (0, 3)


def test_auto_method_counts_the_full_turn_grid_points():
    """With --through-limits a full turn by h visits the grid angles k·h for |k| <= floor(360/h) on
    both sides of the start: 2·floor(360/h) + 1 output points. 'auto' batches from 720 points on:
    h = 1.001 gives 2·359 + 1 = 719 (tracked), h = 1 gives 721 (batched).

    Kills loopsolve.kinematics.sweep.x__make_grid__mutmut_121 (one grid point too many below the start).
    """
    mech = ls.fourbar(60, 25, 70, 45)
    assert mech.sweep(0, 360, 1.001, through_limits=True, progress=False).method == "tracked"
    assert mech.sweep(0, 360, 1, through_limits=True, progress=False).method == "batched"


@pytest.mark.parametrize("method", ["tracked", "batched"])
def test_limit_rows_sit_where_the_input_turns(method):
    """Double rocker through its limits from acos(0.9125) = 24.15°: with limit rows (as the plot
    command draws them), the far limit acos(0.3125) = 71.79° is a row with NaN rates placed exactly
    where the input turns back: the rows before it increase, the rows after it decrease.

    Kills loopsolve.kinematics.sweep.x_sweep__mutmut_238 (limit rows placed one path segment late).
    """
    lo, hi = toggle_angles(60, 50, 20, 45)
    start = math.ceil(lo * 1e9) / 1e9
    sw = ls.load(MODELS / "double_rocker.toml").sweep(start, 75, 0.5, through_limits=True, method=method,
                                                       limit_rows=True, progress=False)
    x = np.asarray(sw["theta2"])
    i = int(np.argmax(x))
    assert x[i] == pytest.approx(hi, abs=1e-9) and np.isnan(sw["theta4_vel"][i])
    assert np.all(np.diff(x[:i + 1]) > 0) and np.all(np.diff(x[i:]) < 0)
    # a dense grid next to the far limit: rows also on the last internal step before it
    sw = ls.load(MODELS / "double_rocker.toml").sweep(71.7, 72, 0.0001, through_limits=True, method=method,
                                                       limit_rows=True, progress=False)
    x = np.asarray(sw["theta2"])
    i = int(np.argmax(x))
    assert x[i] == pytest.approx(hi, abs=1e-9) and np.isnan(sw["theta4_vel"][i])
    assert np.all(np.diff(x[:i + 1]) > 0) and np.all(np.diff(x[i:]) < 0)


def test_reachable_ranges_ending_exactly_at_half_a_turn():
    """Slider-crank r2 = 5, r3 = 2, offset e = 2: the rod reaches the crank pin only where
    |r2·sin θ2 − e| <= r3, i.e. 0 <= sin θ2 <= 0.8: θ2 in [0°, asin 0.8] and [180° − asin 0.8, 180°].
    The second range ends on a limit exactly at 180°, where the samples wrap, but it does not go
    through ±180°: the two ranges stay apart.

    Kills loopsolve.kinematics.reach.x_reachable_ranges__mutmut_170 (ranges merged across ±π).
    """
    from loopsolve.kinematics.reach import reachable_ranges

    mech = ls.slider_crank(5, 2, offset=2, theta2=20)
    got = [tuple(math.degrees(v) for v in r) for r in reachable_ranges(mech.compile())]
    a = math.degrees(math.asin(0.8))
    assert len(got) == 2
    assert got[0] == pytest.approx((0.0, a), abs=1e-9) and got[1] == pytest.approx((180 - a, 180.0), abs=1e-9)


def test_limit_row_of_a_two_input_sweep_that_cannot_leave_its_start():
    """Five-bar with arms of 25 (cranks 20, ground 40) and crank b held at 90°: crank a assembles
    where 1600·cos θa + 800·sin θa >= −100 (|AB| <= 50), up to atan(1/2) + acos(−100/√(1600² + 800²))
    = 119.77°. Started there towards 130° (as the plot command does, with limit rows) the sweep has
    only its limit row: crank a at the limit, crank b still at its held 90°, NaN rates.

    Regression test for a start on a limit heading out of the range (the path is the limit alone).
    """
    mech = ls.load(MODELS / "fivebar_two_inputs.toml").with_parameters(r_arm_a=25, r_arm_b=25)
    hi = math.degrees(math.atan2(800, 1600) + math.acos(-100 / math.hypot(1600, 800)))
    with pytest.warns(ls.LoopsolveWarning, match="limit position"):
        sw = mech.sweep(hi, 130, 1, limit_rows=True, progress=False)
    assert len(sw) == 1
    assert sw["theta_crank_a"][0] == pytest.approx(hi, abs=1e-9) and sw["theta_crank_b"][0] == 90
    assert np.isnan(sw["theta_arm_a_vel"][0])
    assert {e.kind.value for e in sw.events} == {"limit"}


def test_a_sweep_that_cannot_take_a_step_returns_its_start():
    """With a step control no step can satisfy (tangent turn limited to 1e-6 rad, steps not below
    1e-3), the four-bar sweep from 30° keeps its start row (the law-of-cosines pose), reports where
    tracking stopped and warns, instead of failing.

    Kills loopsolve.kinematics.continuation.xǁTracerǁtrace__mutmut_144 (no path returned after the failure).
    """
    from loopsolve.kinematics.sweep import StepControl

    r = (60.0, 25.0, 70.0, 45.0)
    with pytest.warns(ls.LoopsolveWarning, match="stops at a singular position at theta2 = 30"):
        sw = ls.fourbar(*r, theta2=30).sweep(30, 90, 10, control=StepControl(max_turn=1e-6, min_step=1e-3),
                                             method="tracked", progress=False)
    assert len(sw) == 1 and sw["theta2"][0] == 30
    assert [e.kind.value for e in sw.events] == ["singular"] and "the rows stop here" in sw.events[0].message
    assert sw.events[0].input == pytest.approx(30, abs=1e-12)
    q = np.radians([sw["theta3"][0], sw["theta4"][0]])
    assert min(np.abs(np.remainder(np.array(fourbar_pose(*r, math.radians(30), s)) - q + math.pi, 2 * math.pi)
                      - math.pi).max() for s in (1, -1)) < 1e-10

