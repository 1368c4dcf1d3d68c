"""Sweeps with branch tracking: modes kept, limits located, through-limits, change points, errors."""

from __future__ import annotations

import json
import math
import warnings

import numpy as np
import pytest
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st

import loopsolve as ls
from loopsolve.kinematics import classic as C
from loopsolve.cli import main
from loopsolve.kinematics.solve import solve_position
from loopsolve.kinematics.sweep import StepControl, _progress
from loopsolve.kinematics.reach import default_range, nearest_assemblable, reachable_ranges
from loopsolve.kinematics.grid import grid

from support.models import watt_sixbar

#: every test here runs with the pure-Python tracer and with the compiled fast lane (conftest.py)
pytestmark = pytest.mark.usefixtures("both_engines")

TWO_PI = 2 * math.pi
RAD = math.radians


def wrap(a):
    return (np.asarray(a) + math.pi) % TWO_PI - math.pi


def closure(sw):
    """Largest loop-closure residual of a sweep's rows, relative to the model's length scale."""
    ck = sw.compiled
    return max((float(np.max(np.abs(ck.phi(z)))) for z in sw.z), default=0.0) / ck.scale


def kinds(sw):
    return [e.kind.value for e in sw.events]


# ----------------------------------------------------------------------------- strategies


@st.composite
def crank_rockers(draw):
    """Grashof crank-rockers (crank r2 shortest), many close to the change point S + L = P + Q."""
    s = draw(st.floats(0.5, 1.5))
    big = draw(st.floats(3.0, 5.0))
    p = draw(st.floats(s + 0.3, big - 0.2))
    eps = 10 ** draw(st.floats(-5, -0.5))
    q = s + big - p + eps
    perm = draw(st.permutations([big, p, q]))
    r1, r3, r4 = perm
    assume(C.grashof(r1, s, r3, r4) is C.GrashofClass.CRANK_ROCKER and s == min(r1, s, r3, r4))
    return r1, s, r3, r4


@st.composite
def triple_rockers(draw):
    """Non-Grashof four-bars whose crank rocks between two toggle positions."""
    r = [draw(st.floats(1.0, 5.0)) for _ in range(4)]
    assume(C.grashof(*r) is C.GrashofClass.TRIPLE_ROCKER)
    rng = C.fourbar_input_range(*r)
    assume(len(rng) == 1 and 0.1 < rng[0][1] - rng[0][0] < TWO_PI - 0.1)
    return tuple(r)


def fd_check(mech, x0, mode, *, h=1e-3):
    """Velocities and accelerations at x0 against 5-point finite differences of positions (unit speed)."""
    sw = mech.sweep(x0 - 2 * h, x0 + 2 * h, h, mode=mode, method="tracked")
    assert len(sw) == 5
    hr = RAD(h)
    iu = sw.compiled.unknown_idx
    z = np.unwrap(sw.z[:, iu], axis=0)
    d1 = (z[0] - 8 * z[1] + 8 * z[3] - z[4]) / (12 * hr)
    d2 = (-z[0] + 16 * z[1] - 30 * z[2] + 16 * z[3] - z[4]) / (12 * hr * hr)
    # the differences also carry the positions' round-off, eps·cond(Φ_q)·|q| each, which near a
    # change point (cond ~ 300 at 1e-5 from one) is what bounds them, not the truncation:
    # 18/12 and 64/12 of it over h and h² (the sums of the stencils' weights)
    noise = np.finfo(float).eps * float(np.max(sw.cond)) * (1 + np.max(np.abs(sw.z[:, iu])))
    scale = 1 + np.max(np.abs(sw.z1[2, iu]))
    assert np.max(np.abs(d1 - sw.z1[2, iu])) < 1e-7 * scale + 4 * 18 * noise / (12 * hr)
    assert np.max(np.abs(d2 - sw.z2[2, iu])) < 1e-4 * (1 + np.max(np.abs(sw.z2[2, iu]))) + 4 * 64 * noise / (12 * hr * hr)


# ----------------------------------------------------------------------------- Grashof linkages


class TestGrashofFullCycles:
    @settings(max_examples=25, deadline=None)
    @given(r=crank_rockers(), mode=st.sampled_from(["open", "crossed"]), t0=st.floats(0, 360))
    # 1e-5 from the change point: the finite differences' round-off exceeded a fixed tolerance
    # (the solver's accelerations equal the closed form's there to 1e-12)
    @example(r=(1.0, 0.5, 4.0, 3.50001), mode="open", t0=258.0)
    def test_crank_rocker_cycle_keeps_its_mode(self, r, mode, t0):
        mech = ls.fourbar(*r, theta2=t0, mode=mode)
        sig = "-" if mode == "open" else "+"
        coarse = mech.sweep(t0, t0 + 360, 45, method="tracked")
        fine = mech.sweep(t0, t0 + 360, 1, method="tracked")
        for sw, n in ((coarse, 9), (fine, 361)):
            assert len(sw) == n and sw.events == ()
            assert set(sw.modes) == {sig} and sw.mode == sig
            assert closure(sw) <= 1e-10
            t3, t4 = C.fourbar_position(*r, np.radians(sw["theta2"]), 1 if mode == "open" else -1)
            assert np.max(np.abs(wrap(np.radians(sw["theta3"]) - t3))) < 1e-9
            assert np.max(np.abs(wrap(np.radians(sw["theta4"]) - t4))) < 1e-9
        # the coarse grid lands on the same branch as the fine one
        assert np.max(np.abs(coarse.z - fine.z[::45])) < 1e-9
        fd_check(mech, t0 + 100, sig)

    @settings(max_examples=25, deadline=None)
    @given(r2=st.floats(0.5, 2.0), extra=st.floats(0.1, 5.0), e=st.floats(-1.0, 1.0),
           mode=st.sampled_from(["right", "left"]), t0=st.floats(0, 360))
    def test_slider_crank_cycle_keeps_its_mode(self, r2, extra, e, mode, t0):
        r3 = r2 + abs(e) + extra
        mech = ls.slider_crank(r2, r3, offset=e, theta2=t0, mode=mode)
        coarse = mech.sweep(t0, t0 + 360, 45, method="tracked")
        fine = mech.sweep(t0, t0 + 360, 1.5, method="tracked")
        sig = coarse.mode
        for sw, n in ((coarse, 9), (fine, 241)):
            assert len(sw) == n and sw.events == ()
            assert set(sw.modes) == {sig}
            assert closure(sw) <= 1e-10
            x, t3 = C.slider_crank_position(r2, r3, np.radians(sw["theta2"]), e, 1 if mode == "right" else -1)
            assert np.max(np.abs(sw["x"] - x)) < 1e-9 * (1 + r3)
            assert np.max(np.abs(wrap(np.radians(sw["theta3"]) - t3))) < 1e-9
        assert np.max(np.abs(coarse.z - fine.z[::30])) < 1e-9
        fd_check(mech, t0 + 200, sig)

    @pytest.mark.parametrize("r", [(2, 1, 3, 2.001), (3, 2, 5, 4.01)])
    def test_near_change_point_where_warm_started_newton_flips(self, r):
        mech = ls.fourbar(*r, theta2=0)
        ck = mech.compile()
        # the naive sweep: each point's Newton starts from the previous solution
        z = mech.solve(0, compiled=ck).z
        naive = []
        for t in range(45, 361, 45):
            z0 = z.copy()
            z0[0] = RAD(t)
            z, _, _ = solve_position(ck, z0)
            naive.append(ck.signature(z))
        assert "+" in naive  # it jumps to the crossed mode somewhere
        sw = mech.sweep(0, 360, 45)
        assert set(sw.modes) == {"-"} and sw.events == ()
        t3, t4 = C.fourbar_position(*r, np.radians(sw["theta2"]), 1)
        assert np.max(np.abs(wrap(np.radians(sw["theta4"]) - t4))) < 1e-9

    def test_thesis_reference_cycle(self):
        sw = ls.load(ls.models_dir() / "thesis_crank_rocker.toml").sweep(0, 360, 30)
        assert len(sw) == 13 and set(sw.modes) == {"-"}
        assert sw["theta4"][3] == pytest.approx(80.7225, abs=1e-4)
        assert sw["theta2"][-1] == 360

    def test_sweep_backwards_and_with_units(self):
        mech = ls.fourbar(60, 25, 70, 45)
        fwd = mech.sweep(0, 90, 10)
        back = mech.sweep("90deg", "0deg", "10deg")
        assert np.allclose(back["theta4"][::-1], fwd["theta4"], atol=1e-12)
        assert np.allclose(back["theta4_vel"][::-1], fwd["theta4_vel"], atol=1e-12)


# ----------------------------------------------------------------------------- limits


class TestLimits:
    @settings(max_examples=25, deadline=None)
    @given(r=triple_rockers(), frac=st.floats(0.2, 0.8))
    def test_limits_equal_the_toggle_angles_and_the_circuit_closes(self, r, frac):
        (lo, hi), = C.fourbar_input_range(*r)
        t0 = math.degrees(lo + frac * (hi - lo))
        mech = ls.fourbar(*r, theta2=t0)
        toggles = C.fourbar_toggle_angles(*r)

        def near_toggle(x):
            return np.min(np.abs(wrap(RAD(x) - toggles)))

        stop = mech.sweep(t0, t0 + 360, 5)
        assert kinds(stop) == ["limit"]
        assert near_toggle(stop.events[0].input) < 1e-8
        assert RAD(stop.events[0].input) == pytest.approx(hi, abs=1e-8)
        assert np.all(np.diff(stop["theta2"]) > 0) and set(stop.modes) == {"-"}

        sw = mech.sweep(t0, t0 + 360, 5, through_limits=True)
        assert kinds(sw) == ["limit", "mode-change", "limit", "mode-change"]
        assert all(near_toggle(e.input) < 1e-8 for e in sw.events)
        # the circuit closes: back at the start in the start mode
        assert sw["theta2"][-1] == pytest.approx(t0, abs=1e-9) and sw.modes[-1] == "-"
        assert np.allclose(sw.z[-1], sw.z[0], atol=1e-9)
        modes = np.array([1 if s == "-" else -1 for s in sw.modes])
        assert set(modes) == {1, -1}
        t3, t4 = C.fourbar_position(*r, np.radians(sw["theta2"]), modes)
        assert np.max(np.abs(wrap(np.radians(sw["theta3"]) - t3))) < 1e-9
        assert np.max(np.abs(wrap(np.radians(sw["theta4"]) - t4))) < 1e-9
        assert closure(sw) <= 1e-10
        # the input turns back on the same grid: rows at start + k * 5
        k = (sw["theta2"] - t0) / 5
        assert np.allclose(k, np.round(k), atol=1e-9)
        # every grid value inside the range is visited once per mode, plus the closing row
        vals = np.radians(t0 + 5 * np.arange(-72, 73))
        assert len(sw) == 1 + 2 * int(np.sum((vals > lo) & (vals < hi)))

    def test_through_limits_within_a_partial_range_stops_at_its_end(self):
        mech = ls.fourbar(4, 3, 3.5, 5, theta2=300)
        sw = mech.sweep(300, 350, 10, through_limits=True)
        assert kinds(sw) == ["limit", "mode-change"]
        assert list(sw["theta2"]) == [300, 310, 320, 330, 340, 340, 330, 320, 310, 300]
        assert sw.modes == ("-",) * 5 + ("+",) * 5

    def test_slider_as_input_stops_at_the_dead_centre(self):
        mech = ls.load(ls.models_dir() / "example1_slider_crank.toml")
        sw = mech.sweep(5, 14, 1, input="r1")
        assert kinds(sw) == ["limit"] and sw.events[0].input == pytest.approx(13.0, abs=1e-9)
        assert list(sw["r1"]) == [5, 6, 7, 8, 9, 10, 11, 12]

    def test_cli_limit_exits_zero_with_rows_and_event(self, tmp_path, capsys):
        path = tmp_path / "tr.toml"
        path.write_text(ls.dumps(ls.fourbar(4, 3, 3.5, 5, theta2=300)))
        assert main(["sweep", str(path), "--from", "300", "--to", "400", "--step", "10", "--format", "json"]) == 0
        doc = json.loads(capsys.readouterr().out)
        assert [r["theta2"] for r in doc["rows"]] == [300, 310, 320, 330, 340]
        assert doc["events"][0]["kind"] == "limit"
        assert doc["events"][0]["input"] == pytest.approx(341.42665028, abs=1e-7)
        assert main(["sweep", str(path), "--from", "300", "--to", "660", "--step", "10", "--through-limits",
                     "--format", "json", "--method", "tracked"]) == 0
        doc = json.loads(capsys.readouterr().out)
        assert [e["kind"] for e in doc["events"]] == ["limit", "mode-change", "limit", "mode-change"]
        assert doc["rows"][-1]["theta2"] == 300


class TestChangePoints:
    @pytest.mark.parametrize("method", ["tracked", "batched"])
    def test_change_point_is_a_singular_event_and_the_only_mode_change(self, method):
        # S + L = P + Q: 2 + 5 = 4 + 3; the branches touch at theta2 = 180
        mech = ls.fourbar(5, 2, 4, 3, theta2=10)
        sw = mech.sweep(10, 370, 10, method=method)
        assert kinds(sw) == ["singular"]
        assert sw.events[0].input == pytest.approx(180, abs=2e-8)
        assert "change point" in sw.events[0].message
        x = sw["theta2"]
        assert set(np.array(sw.modes)[x < 180]) == {"-"} and set(np.array(sw.modes)[x > 180]) == {"+"}
        assert 180 not in list(x) and len(sw) == 36  # the row at the change point has no defined rates
        assert closure(sw) <= 1e-10

    def test_parallelogram(self):
        sw = ls.fourbar(4, 2, 4, 2, theta2=10).sweep(10, 370, 10)
        assert kinds(sw) == ["singular", "singular"]
        assert [e.input for e in sw.events] == pytest.approx([180, 360], abs=2e-8)


# ----------------------------------------------------------------------------- errors and start


class TestOutsideTheRange:
    def test_assembly_error_names_the_nearest_inputs(self):
        mech = ls.fourbar(4, 3, 3.5, 5, theta2=90)
        with pytest.raises(ls.AssemblyError) as exc:
            mech.sweep(0, 90, 10)
        tog = math.degrees(C.fourbar_toggle_angles(4, 3, 3.5, 5)[1])
        assert exc.value.nearest == pytest.approx((-tog, tog), abs=1e-8)
        assert exc.value.input_value == 0
        assert f"{tog:.10g}" in str(exc.value)

    def test_slider_input_nearest(self):
        mech = ls.load(ls.models_dir() / "example1_slider_crank.toml")
        with pytest.raises(ls.AssemblyError) as exc:
            mech.sweep(14, 20, 1, input="r1")
        assert exc.value.nearest == pytest.approx((13.0,), abs=1e-9)

    def test_cli_exit_3_one_line(self, tmp_path, capsys):
        path = tmp_path / "tr.toml"
        path.write_text(ls.dumps(ls.fourbar(4, 3, 3.5, 5, theta2=90)))
        assert main(["sweep", str(path), "--from", "0", "--to", "90", "--step", "10"]) == 3
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and err.startswith("loopsolve: AssemblyError:")
        assert "18.57334972" in err

    def test_bad_guesses_are_not_reported_as_unassemblable(self):
        # with r5 = 40 the second loop of this six-bar only closes on the first loop's crossed mode;
        # the guesses name the open one: no solution has their mode, and the error names those that exist
        mech = watt_sixbar().with_parameters(r5=40)
        with pytest.raises(ls.ModeError, match=r"named by the guesses.*assembles there only in mode\(s\) "
                                               r"\+\+, \+-.*--mode"):
            mech.solve(60)
        assert mech.solve(60, mode="+-").mode == "+-"

    @pytest.mark.parametrize("mode", ["open", "crossed"])
    @pytest.mark.parametrize("x", [341.4266, 341.4, 341.0, 340.0, 335.0])
    def test_one_row_sweep_reports_nothing_beyond_its_input(self, x, mode):
        # a one-row sweep (start = stop) near a limit: the tracer's first arclength step (steep
        # tangent) left the one-point range and went on to the limit, reported at 341.42665 although
        # the sweep covers x only. The limit (law of cosines) lies beyond x: no event, one row.
        tog = fold_angles(4, 3, 3.5, 5)[0]
        assert 360 - tog == pytest.approx(341.42665028, abs=1e-8) and x < 360 - tog
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # no "the sweep stops at a limit" warning either
            sw = ls.fourbar(4, 3, 3.5, 5).sweep(x, x, 1, mode=mode)
        assert kinds(sw) == [] and list(sw["theta2"]) == [x]
        assert closure(sw) < 1e-12

    def test_start_on_a_singular_position(self):
        with pytest.raises(ls.SingularPositionError):
            ls.fourbar(4, 2, 4, 2, theta2=10).sweep(0, 90, 10)

    def test_bad_method_and_step(self):
        mech = ls.fourbar(60, 25, 70, 45)
        with pytest.raises(ls.ModelError):
            mech.sweep(0, 10, 1, method="fast")
        with pytest.raises(ls.ModelError):
            mech.sweep(0, 10, 0)


class TestRanges:
    def test_reachable_ranges(self):
        ck = ls.fourbar(4, 3, 3.5, 5).compile()
        (lo, hi), = reachable_ranges(ck)
        (a, b), = C.fourbar_input_range(4, 3, 3.5, 5)
        assert (lo, hi) == pytest.approx((a, b), abs=1e-9)
        assert reachable_ranges(ls.fourbar(60, 25, 70, 45).compile()) == [(-math.pi, math.pi)]

    def test_double_rocker_ranges_both_arcs(self):
        r = (2.0, 3.0, 1.0, 3.5)  # Grashof, coupler shortest: double rocker
        assert C.grashof(*r) is C.GrashofClass.DOUBLE_ROCKER
        ck = ls.fourbar(*r, theta2=math.degrees(np.mean(C.fourbar_input_range(*r)[0]))).compile()
        ours = reachable_ranges(ck)
        ref = C.fourbar_input_range(*r)
        assert len(ours) == len(ref)
        for (p, q), (a, b) in zip(sorted(ours), sorted((wrap(a), wrap(a) + (b - a)) for a, b in ref)):
            assert (p, q) == pytest.approx((a, b), abs=1e-9)

    def test_info_prints_the_reachable_range(self):
        d = ls.fourbar(4, 3, 3.5, 5).info()
        assert d["reachable_input_ranges"] == [pytest.approx([18.57334972, 341.4266503], abs=1e-7)]
        from loopsolve.kinematics.info import format_info

        assert "reachable range(s) of theta2" in format_info(d)

    def test_nearest_for_a_fully_rotating_input_is_the_input_itself(self):
        ck = ls.fourbar(60, 25, 70, 45).compile()
        assert nearest_assemblable(ck, 0.3) == pytest.approx((math.degrees(0.3),))


# ----------------------------------------------------------------------------- multi-loop, results


def test_sixbar_cycle_keeps_both_block_signs():
    mech = watt_sixbar()
    for sig in ("--", "+-", "-+", "++"):  # this Watt II six-bar turns fully in all four modes
        coarse = mech.sweep(60, 420, 45, mode=sig)
        sw = mech.sweep(60, 420, 5, mode=sig)
        assert len(sw) == 73 and sw.events == () and set(sw.modes) == {sig}
        assert closure(sw) <= 1e-10
        assert np.max(np.abs(coarse.z - sw.z[::9])) < 1e-9
        assert np.max(np.abs(wrap(sw.z[-1, 1:] - sw.z[0, 1:]))) < 1e-9  # one turn later: same pose


def test_sweep_result_is_immutable_and_consistent():
    sw = ls.fourbar(60, 25, 70, 45).sweep(0, 90, 30)
    with pytest.raises(AttributeError):
        sw.mode = "+"
    with pytest.raises(ValueError):
        sw.z[0, 0] = 1.0
    assert [s.row() for s in sw.states] == sw.rows
    assert sw.states[1]["theta4"] == pytest.approx(sw["theta4"][1])
    doc = json.loads(sw.to_json())
    assert doc["mode"] == "-" and len(doc["rows"]) == 4 and doc["events"] == []
    assert sw.to_csv().splitlines()[0].startswith("theta2 [deg]")
    rebuilt = ls.Sweep(sw.compiled, sw.states, sw.events, sw.mode)
    assert np.array_equal(rebuilt["C_x_acc"], sw["C_x_acc"])


def test_grid_and_progress():
    assert grid(0, 360, 45).tolist() == [0, 45, 90, 135, 180, 225, 270, 315, 360]
    assert grid(0, 100, 30).tolist() == [0, 30, 60, 90]
    assert _progress(1000, None) is None  # not a terminal under pytest
    bar = _progress(1000, True)
    assert bar is not None
    bar.close()


def test_step_control_bounds_the_internal_step():
    mech = ls.fourbar(60, 25, 70, 45)
    a = mech.sweep(0, 360, 90, control=StepControl(max_step=RAD(0.5)), method="tracked")
    b = mech.sweep(0, 360, 90, method="tracked")
    assert np.allclose(a.z, b.z, atol=1e-12)


# ----------------------------------------------------------------------------- issue 9 reproducers

GAP = (4.810642113, 3.574599603, 7.945621763, 9.18169356)  # S + L - P - Q = 2.9e-5: a 0.235° gap at 0
FAR = (1.7602295198117748, 3.762080090646547, 1.5153328493542173, 4.006972653043114)


def fold_angles(r1, r2, r3, r4):
    """Input angles (deg) where coupler and rocker are collinear (law of cosines)."""
    out = []
    for d in (r3 + r4, abs(r3 - r4)):
        c = (r1 * r1 + r2 * r2 - d * d) / (2 * r1 * r2)
        if abs(c) <= 1:
            out.append(math.degrees(math.acos(c)))
    return out


def gap_model(tmp_path):
    path = tmp_path / "gap.toml"
    path.write_text(ls.dumps(ls.fourbar(*GAP, theta2=40, mode="crossed")))
    return path


class TestNarrowGaps:
    def test_gap_is_a_limit_not_a_change_point(self, tmp_path, capsys):
        edge = min(fold_angles(*GAP))
        assert edge == pytest.approx(0.1176, abs=1e-4)
        for method in ("tracked", "batched"):
            assert main(["sweep", str(gap_model(tmp_path)), "--from", "40", "--to", "-320", "--step", "40",
                         "--mode", "crossed", "--format", "json", "--method", method]) == 0
            out, err = capsys.readouterr()
            # the command line prints the stop as one warning line on stderr
            assert err.count("\n") == 1 and err.startswith("loopsolve: warning:") and "limit position" in err
            doc = json.loads(out)
            assert [r["theta2"] for r in doc["rows"]] == [40]
            assert [e["kind"] for e in doc["events"]] == ["limit"]
            assert doc["events"][0]["input"] == pytest.approx(edge, abs=1e-9)

    def test_solve_in_the_gap_names_the_located_folds(self, tmp_path, capsys):
        edge = min(fold_angles(*GAP))
        assert main(["solve", str(gap_model(tmp_path)), "--at", "0", "--mode", "crossed"]) == 3
        err = capsys.readouterr().err
        assert "AssemblyError" in err and f"{edge:.10g}" in err and f"-{edge:.10g}" in err
        ck = ls.fourbar(*GAP).compile()
        assert nearest_assemblable(ck, 0.0) == pytest.approx((-edge, edge), abs=1e-9)
        (lo, hi), = reachable_ranges(ck)
        assert (math.degrees(lo), math.degrees(hi)) == pytest.approx((edge, 360 - edge), abs=1e-9)

    @pytest.mark.parametrize("method", ["tracked", "batched"])
    @pytest.mark.parametrize("mode", ["open", "crossed"])
    def test_limit_far_from_the_start(self, method, mode):
        # true limit: -179.850025 deg (coupler and rocker stretched out)
        lim = -max(fold_angles(*FAR))
        assert lim == pytest.approx(-179.850025, abs=1e-6)
        mech = ls.fourbar(*FAR, theta2=-123.9110129647841, mode=mode)
        with pytest.warns(ls.LoopsolveWarning, match="limit position"):
            sw = mech.sweep(-123.9110129647841, -483.91, 44.851226743352335, mode=mode, method=method)
        assert kinds(sw) == ["limit"] and sw.events[0].input == pytest.approx(lim, abs=1e-9)
        assert np.all(sw["theta2"] > lim) and len(sw) == 2

    def test_limit_between_the_last_row_and_the_end(self):
        with pytest.warns(ls.LoopsolveWarning):
            sw = ls.fourbar(4, 3, 3.5, 5, theta2=300).sweep(300, 345, 10)
        assert list(sw["theta2"]) == [300, 310, 320, 330, 340]
        assert kinds(sw) == ["limit"] and sw.events[0].input == pytest.approx(max(fold_angles(4, 3, 3.5, 5)) * -1 + 360,
                                                                               abs=1e-9)


class TestStartAtALimit:
    def test_start_on_a_limit_and_just_beyond(self):
        lo = min(fold_angles(4, 3, 3.5, 5))
        mech = ls.fourbar(4, 3, 3.5, 5, theta2=180)
        for d in (0.0, -1e-9, 1e-9):
            sw = mech.sweep(lo + d, 90, 10)
            assert kinds(sw) == ["limit"] and sw.events[0].input == pytest.approx(lo, abs=1e-9)
            assert sw["theta2"][0] == pytest.approx(lo + d + 10)
        with pytest.raises(ls.AssemblyError):
            mech.sweep(lo - 1e-7, 90, 10)


class TestGridStart:
    @pytest.mark.parametrize("start", [27.4, 25.7, 27.1, 28.5, 67.9])
    def test_decimal_starts_keep_every_row(self, start, capsys):
        path = str(ls.models_dir() / "double_rocker.toml")
        assert main(["sweep", path, "--from", str(start), "--to", "70", "--step", "5", "--format", "json"]) == 0
        doc = json.loads(capsys.readouterr().out)
        n = int(math.floor((70 - start) / 5 + 1e-9)) + 1
        assert [r["theta2"] for r in doc["rows"]] == pytest.approx([start + 5 * k for k in range(n)], abs=1e-12)
        assert doc["events"] == []

    def test_string_and_float_arguments_agree(self):
        mech = ls.load(ls.models_dir() / "double_rocker.toml")
        a = mech.sweep("27.4", "70", "5")
        b = mech.sweep(27.4, 70, 5)
        c = mech.sweep("27.4deg", "70deg", "5deg")
        assert len(a) == len(b) == len(c) == 9
        assert np.max(np.abs(a.z - b.z)) < 1e-12 and np.max(np.abs(c.z - b.z)) < 1e-12


class TestStopAnnounced:
    def test_python_warning_names_the_input_once(self):
        with pytest.warns(ls.LoopsolveWarning) as rec:
            sw = ls.load(ls.models_dir() / "double_rocker.toml").sweep(60, 180, 10)
        lim = sw.events[0].input
        assert len(rec) == 1 and "\n" not in str(rec[0].message) and f"{lim:.10g}" in str(rec[0].message)
        assert f"{lim:.10g}" not in sw.events[0].message  # the table prints the input next to it

    @pytest.mark.parametrize("fmt", ["table", "csv", "json"])
    def test_cli_warns_on_stderr_in_every_format(self, tmp_path, tmp_path_factory, fmt):
        import os
        import subprocess
        import sys

        out = tmp_path / f"out.{fmt}"
        # one cache for the three formats: with the numba engine the model is compiled once
        env = {**os.environ, "LOOPSOLVE_CACHE_DIR": str(tmp_path_factory.getbasetemp() / "cli_warns_cache")}
        r = subprocess.run([sys.executable, "-m", "loopsolve.cli", "sweep", str(ls.models_dir() / "double_rocker.toml"),
                            "--from", "60", "--to", "180", "--step", "10", "--format", fmt, "-o", str(out)],
                           capture_output=True, text=True, env=env)
        assert r.returncode == 0
        assert "LoopsolveWarning" in r.stderr or "warning" in r.stderr
        assert "71.79004314" in r.stderr

    def test_table_states_the_limit_once(self, capsys):
        assert main(["sweep", str(ls.models_dir() / "double_rocker.toml"), "--from", "60", "--to", "180",
                     "--step", "10"]) == 0
        out, err = capsys.readouterr()
        assert err.startswith("loopsolve: warning:") and "71.79" in err
        line = [ln for ln in out.splitlines() if ln.startswith("limit")][0]
        assert line.count("71.79") == 1


class TestGridSemantics:
    def test_negative_step_is_refused(self):
        with pytest.raises(ls.ModelError, match="positive"):
            ls.fourbar(60, 25, 70, 45).sweep(0, 90, -10)

    def test_to_is_the_end_of_the_range(self):
        sw = ls.load(ls.models_dir() / "thesis_crank_rocker.toml").sweep(0, 360, "0.5rad")
        assert len(sw) == 13 and sw["theta2"][-1] == pytest.approx(6 * math.degrees(1.0), abs=1e-9)

    @pytest.mark.parametrize("args", [("--to", "60", "--step", "1e-9"), ("--to", "60", "--step", "1e-300"),
                                      ("--to", "1e7", "--step", "1")])
    def test_enormous_grids_are_refused_quickly(self, args, capsys):
        assert main(["sweep", str(ls.models_dir() / "double_rocker.toml"), "--from", "30", *args]) == 2
        err = capsys.readouterr().err
        assert "ModelError" in err and "--max-rows" in err and len(err.strip().splitlines()) == 1

    def test_bounds_beyond_a_turn_limit_are_refused_not_reduced(self, capsys):
        # --at reduces 1e17 exactly modulo a turn; a sweep bound must never be moved that way
        assert main(["sweep", str(ls.models_dir() / "double_rocker.toml"), "--from", "30", "--to", "1e18",
                     "--step", "1"]) == 2
        err = capsys.readouterr().err
        assert "ModelError" in err and "65536 turns" in err and len(err.strip().splitlines()) == 1

    def test_max_rows(self, capsys):
        mech = ls.fourbar(60, 25, 70, 45)
        with pytest.raises(ls.ModelError, match="max_rows"):
            mech.sweep(0, 360, 1, max_rows=100)
        assert len(mech.sweep(0, 360, 1, max_rows=361)) == 361
        path = str(ls.models_dir() / "thesis_crank_rocker.toml")
        assert main(["sweep", path, "--from", "0", "--to", "360", "--step", "1", "--max-rows", "10"]) == 2
        assert main(["sweep", path, "--from", "0", "--to", "360", "--step", "1", "--max-rows", "400",
                     "--format", "csv"]) == 0


class TestDefaultRange:
    def test_double_rocker_starts_on_its_limit(self):
        ck = ls.load(ls.models_dir() / "double_rocker.toml").compile()
        lo, hi = sorted(fold_angles(60, 50, 20, 45))
        start, stop, through = default_range(ck, 4)
        assert start == pytest.approx(lo, abs=1e-9) and through and stop > hi
        sw = ck.mechanism.sweep(start, stop, 4, through_limits=True)
        assert kinds(sw) == ["limit", "limit", "mode-change"]
        assert [e.input for e in sw.events] == pytest.approx([lo, hi, hi], abs=1e-9)
        assert sw["theta2"][0] == pytest.approx(start + 4)


class TestLimitRows:
    @pytest.mark.parametrize("method", ["tracked", "batched"])
    def test_a_row_at_each_limit_position(self, method):
        mech = ls.load(ls.models_dir() / "double_rocker.toml")
        lo, hi = sorted(fold_angles(60, 50, 20, 45))
        with pytest.warns(ls.LoopsolveWarning):
            sw = mech.sweep(60, 180, 10, limit_rows=True, method=method)
        assert list(sw["theta2"][:2]) == [60, 70] and sw["theta2"][2] == pytest.approx(hi, abs=1e-9) and len(sw) == 3
        assert abs(math.sin(math.radians(sw["theta4"][2] - sw["theta3"][2]))) < 1e-9  # coupler, rocker aligned
        assert np.isnan(sw["theta3_vel"][2]) and np.isfinite(sw["theta3_vel"][1])
        full = mech.sweep(lo + 1e-10, hi + 4, 4, through_limits=True, limit_rows=True, method=method)
        x = full["theta2"]
        assert x[0] == pytest.approx(lo, abs=1e-9) and x[-1] == pytest.approx(lo, abs=1e-9)
        assert np.sum(np.abs(x - hi) < 1e-9) == 1 and len(full) == 2 * 12 + 1


# A sweep that starts just before a limit position: the tracker's first arclength step goes round the
# limit and comes back out of the range. It used to stop there silently (one row, no event, no warning:
# found by the in-chunk limit tests, design r2 = 1010.47, r3 = 636.12, e = -130.80 of prob2 swept from 30°);
# the limit must be reported where the closed form puts it, |e - r2 sin θ2| = r3.
_NEAR_LIMIT = dict(r2=1010.4744132940376, r3=636.1194251148528, e=-130.79819087070194)


@pytest.mark.parametrize("step", [0.001, 0.5, 3.0, 10.0])
@pytest.mark.parametrize("gap", [1e-7, 1e-5, 1e-3, 5.5e-3, 0.1, 2.0])
@pytest.mark.parametrize("side", ["up", "down"])
def test_a_limit_just_after_the_start_is_reported_not_a_silent_stop(side, gap, step):
    r2, r3, e = _NEAR_LIMIT["r2"], _NEAR_LIMIT["r3"], _NEAR_LIMIT["e"]
    lim = math.degrees(math.asin((e + r3) / r2))  # ≈ 30.0055°: reachable below it
    mech = ls.load(ls.models_dir() / "prob2_offset_slider_crank.toml").with_parameters(**_NEAR_LIMIT)
    if side == "down":  # the mirror limit ≈ 149.9945°, reachable above it, swept downwards
        lim = 180.0 - lim
        start, stop = lim + gap, lim + gap - 6.0
    else:
        start, stop = lim - gap, lim - gap + 6.0
    with pytest.warns(ls.LoopsolveWarning, match="limit position"):
        sw = mech.sweep(start, stop, step, method="tracked")
    limits = [ev for ev in sw.events if ev.kind.value == "limit"]
    assert len(limits) == 1 and limits[0].input == pytest.approx(lim, abs=1e-7)
    x = np.degrees(sw.z[:, 0])
    assert np.all((x - lim) * (1 if side == "up" else -1) <= 1e-9)  # no row beyond the limit
