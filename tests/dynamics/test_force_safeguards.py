"""Issue 17, force analysis and simulation: no silently wrong number from a declaration slip, every run bounded.

References written here: the issue's hand value of the engine's driving torque (−60.57 N·m at 30°,
3000 rpm); a load's contribution to the driving torque by virtual work with dP/dθ from central
differences of solved positions; a flywheel's energy fluctuation from the closed form of ∫T dθ;
positions of a simulation checked by solving the mechanism at them.
"""

from __future__ import annotations

import ast
import csv
import dataclasses
import io
import json
import math
import warnings
from pathlib import Path

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.cli import main
from loopsolve.dynamics.dynamics_model import compile_dynamics
from loopsolve.dynamics.kinetostatics import inverse_dynamics

MODELS = ls.models_dir()
ENGINE = MODELS / "engine_slider_crank.toml"
THESIS = MODELS / "thesis_crank_rocker_dynamics.toml"
#: the double rocker of the issue (dr_dyn.toml): the thesis dynamics model with r2 = 50, r3 = 20
DR_LIMIT = 71.790043135717  # theta2 at its limit position (located by the sweep, checked below)


def mutated(path: Path, change) -> ls.Mechanism:
    spec = ls.model.mechanism.deep_copy(ls.load(path).spec)
    change(spec)
    return ls.build_mechanism(spec)


def double_rocker() -> ls.Mechanism:
    def change(spec):
        spec["name"] = "Double rocker (dynamics)"
        spec["parameters"].update(r2=50, r3=20)
        spec["variables"]["theta2"].update(guess=60, speed="1rad/s")
        spec["variables"]["theta3"]["guess"] = -2.5
        spec["variables"]["theta4"]["guess"] = 109.5
        spec["bodies"]["crank"] = {"bar": {"length": 50, "width": 8, "thickness": 4}, "com": "0.5*r2",
                                   "angle": "theta2", "joints": ["O2", "B"]}
        spec["bodies"]["coupler"] = {"bar": {"length": 20, "width": 8, "thickness": 4}, "com": "r2 + 0.5*r3",
                                     "angle": "theta3", "joints": ["B", "C"]}

    return mutated(THESIS, change)


def run(capsys, *args):
    capsys.readouterr()
    code = main([str(a) for a in args])
    out = capsys.readouterr()
    return code, out.out, out.err


def write(tmp_path, mech: ls.Mechanism, name: str) -> Path:
    p = tmp_path / name
    p.write_text(ls.dumps(mech))
    return p


# ----------------------------------------------------------------------------- item 1
class TestJointLeftOut:
    def test_crank_leaving_out_b_names_both_bodies_and_the_joint(self, tmp_path, capsys):
        """Before: driving torque 0 N·m, exit 0 (B became a pin to the frame at a moving point)."""
        bad = mutated(ENGINE, lambda s: s["bodies"]["crank"].update(joints=["O2"]))
        with pytest.raises(ls.ModelError) as exc:
            ls.forces(bad, 30)
        msg = str(exc.value)
        assert "'B'" in msg and "'crank'" in msg and "'rod'" in msg and "bodies.crank.joints" in msg
        code, out, err = run(capsys, "forces", write(tmp_path, bad, "no_b.toml"), "--at", 30)
        assert code == 2 and out == "" and len(err.strip().splitlines()) == 1 and "'B'" in err

    def test_the_fixed_model_gives_the_published_torque(self):
        fs = ls.forces(ls.load(ENGINE), 30)  # 3000 rpm, the model's speed
        assert float(fs.drive) == pytest.approx(-60.57, abs=0.005)

    def test_rod_without_joints(self):
        bad = mutated(ENGINE, lambda s: s["bodies"]["rod"].pop("joints"))
        with pytest.raises(ls.ModelError) as exc:
            ls.forces(bad, 30)
        msg = str(exc.value)
        assert "'rod'" in msg and "'B'" in msg and "'C'" in msg and "bodies.rod.joints" in msg

    def test_a_pivot_no_body_lists(self):
        bad = mutated(THESIS, lambda s: s["bodies"]["rocker"].update(joints=["C"]))
        with pytest.raises(ls.ModelError, match=r"'rocker' turns about the fixed point 'O4'"):
            ls.forces(bad, 30)


# ----------------------------------------------------------------------------- item 2
def with_coupler_point(body: str) -> ls.Mechanism:
    def change(spec):
        spec["points"]["P"] = "r2 + 0.4*r3"
        spec["loads"].append({"at": "P", "body": body, "force": ["3N", "-5N"]})

    return mutated(THESIS, change)


class TestLoadOnTheRightBody:
    def test_a_coupler_point_load_on_the_rocker_is_refused(self):
        """Before: T = 0.0204 N·m instead of 0.15345 (the force applied to the rocker), exit 0."""
        with pytest.raises(ls.ModelError) as exc:
            ls.forces(with_coupler_point("rocker"), 60)
        msg = str(exc.value)
        assert "loads[1].body" in msg and "'rocker'" in msg and "'coupler'" in msg

    def test_on_the_coupler_it_adds_its_virtual_work(self):
        """T(with) − T(without) = −F · dP/dθ, dP/dθ by central differences of solved positions."""
        mech, base = with_coupler_point("coupler"), ls.load(THESIS)
        x, h = 60.0, 1e-4
        p = [np.array([mech.solve(x + d)["B_x"], mech.solve(x + d)["B_y"]]) * 0.6
             + np.array([mech.solve(x + d)["C_x"], mech.solve(x + d)["C_y"]]) * 0.4 for d in (-h, h)]
        dp = (p[1] - p[0]) / (2 * math.radians(h)) * 1e-3  # m/rad
        got = float(ls.forces(mech, x).drive) - float(ls.forces(base, x).drive)
        assert got == pytest.approx(-(3 * dp[0] - 5 * dp[1]), rel=1e-7)


# ----------------------------------------------------------------------------- item 3
class TestPowerBalanceCheck:
    def test_the_residual_names_the_pin_that_does_work(self):
        """Without the carrier check (check=False), the power balance alone catches the missing joint."""
        from loopsolve.dynamics.declcheck import check_power_balance

        bad = mutated(ENGINE, lambda s: s["bodies"]["crank"].update(joints=["O2"]))
        dm = compile_dynamics(bad)
        st = bad.solve(30)
        ix = st.compiled.input_idx[0]
        data = inverse_dynamics(dm, st.z[None], st.z1[ix], st.z2[ix], check=False)
        with pytest.raises(ls.PowerBalanceError) as exc:
            check_power_balance(dm, data, [30.0], spurious=data["spurious"])
        assert "the pin 'B' between 'rod' and the frame" in str(exc.value)
        assert exc.value.input_value == 30.0 and abs(exc.value.residual) > 1e3
        assert isinstance(exc.value, ls.ModelError) and exc.value.exit_code == 2

    def test_a_small_residual_with_no_spurious_work_is_a_warning(self):
        from loopsolve.dynamics.declcheck import check_power_balance

        dm = compile_dynamics(ls.load(THESIS))
        data = {"power_residual": np.array([0.0, 1e-6]), "power_scale": np.array([1.0, 1.0]),
                "kappa": np.array([10.0, 10.0])}
        with pytest.warns(ls.LoopsolveWarning, match="not smooth there"):
            check_power_balance(dm, data, [0.0, 5.0], spurious={"the pin 'B'": np.zeros(2)})
        data["power_residual"] = np.array([0.0, 1e-2])
        with pytest.raises(ls.PowerBalanceError, match=r"fails at theta2 = 5 \(1 of 2 rows\)"):
            check_power_balance(dm, data, [0.0, 5.0], spurious={"the pin 'B'": np.zeros(2)})
        data["power_residual"] = np.array([0.0, 1e-6])  # small, but a pin does the work: an error
        with pytest.raises(ls.PowerBalanceError, match="the likely fault: the pin 'B'"):
            check_power_balance(dm, data, [0.0, 5.0], spurious={"the pin 'B'": np.array([0.0, 1e-6])})

    def test_no_false_alarm_near_limits_or_with_non_smooth_loads(self):
        dr = double_rocker()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ls.LoopsolveWarning)
            for d in (1e-2, 1e-5, 1e-7, 5.7e-9 * 1.0000001):
                ls.forces(dr, DR_LIMIT - d)
            ls.forces(dr, 30, 80, 0.5, through_limits=True)
            ls.forces(ls.load(ENGINE), 180 - 1e-7, input="r1", speed="100mm/s")

            def kinked(spec):  # |ω| and a smoothed Coulomb friction: non-smooth, non-conservative
                spec["loads"].append({"body": "crank", "torque": "-0.01*sqrt(theta2_vel**2)"})
                spec["loads"].append({"body": "rocker", "torque": "-0.02*theta4_vel/sqrt(theta4_vel**2 + 1e-9)"})

            mech = mutated(THESIS, kinked)
            for speed, accel in ((0, 0), (2.0, 0), (-3.0, 5.0)):
                fs = ls.forces(mech, 0, 360, 3, speed=speed, accel=accel)
                assert np.all(np.abs(fs.power_residual) <= 1e-9 + 1e-9 * np.abs(fs.drive) * max(abs(speed), 1))


# ----------------------------------------------------------------------------- item 7
class TestDeadCentreWarning:
    def test_double_rocker_just_before_its_limit(self):
        """Before: 8.4e13 N·m printed with no warning."""
        dr = double_rocker()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ls.LoopsolveWarning)  # the sweep stops at the limit
            assert dr.sweep(30, 80, 0.5).events[0].input == pytest.approx(DR_LIMIT, abs=1e-9)
        with pytest.warns(ls.LoopsolveWarning, match=r"near a dead centre.*condition"):
            fs = ls.forces(dr, DR_LIMIT - 5.7e-9)
        assert fs.condition > 1e4

    def test_engine_driven_by_its_slider_near_tdc(self):
        with pytest.warns(ls.LoopsolveWarning, match=r"r1 = 179\.9999999 mm.*condition"):
            ls.forces(ls.load(ENGINE), 180 - 1e-7, input="r1", speed="100mm/s")

    def test_no_warning_on_ordinary_rows(self):
        with warnings.catch_warnings():
            warnings.simplefilter("error", ls.LoopsolveWarning)
            for path in (ENGINE, THESIS, MODELS / "shaper_dynamics.toml"):
                ls.forces(ls.load(path), 0, 360, 5)


# ----------------------------------------------------------------------------- item 9
class TestUnits:
    def test_simulation_positions_in_the_models_angle_unit(self):
        """Before: sim.x in radians, so mech.solve(sim.x[i]) solved at the wrong angle."""
        mech = ls.load(THESIS)
        sim = ls.simulate(mech, 0.2, step=0.1, speed0="60rpm", torque=0.05)
        assert sim.units()["x"] == "deg" and sim.units()["xd"] == "rad/s"
        st = mech.solve(float(sim.x[-1]))
        np.testing.assert_allclose(st.z, sim.z[-1], atol=1e-9)
        assert sim.x[0] == pytest.approx(90.0)

    def test_force_results_say_their_units(self):
        fs = ls.forces(ls.load(ENGINE), 0, 90, 45)
        u = fs.units()
        assert u["drive"] == "N*m" and u["joint_forces"] == "N" and u["theta2"] == "deg" and u["F_B_x"] == "N"

    def test_simulate_refuses_a_declaration_slip_before_integrating(self):
        bad = mutated(ENGINE, lambda s: s["bodies"]["crank"].update(joints=["O2"]))
        with pytest.raises(ls.ModelError, match="left out by 'crank'"):
            ls.simulate(bad, 10.0)

    def test_one_input_gives_scalars(self):
        """Before: one-element arrays (float(fs.drive) fails on numpy 2.4)."""
        fs = ls.forces(ls.load(ENGINE), 30)
        assert isinstance(float(fs.drive), float) and np.ndim(fs.drive) == 0
        assert np.shape(fs.joint_forces["F_B"]) == (2,) and np.shape(fs.shaking_force) == (2,)
        assert isinstance(fs["input_torque"], float) and fs["input_torque"] == float(fs.drive)


# ----------------------------------------------------------------------------- item 10
class TestThroughLimitsOutputs:
    @pytest.mark.parametrize("fmt", ["json", "csv"])
    def test_double_rocker(self, tmp_path, capsys, fmt):
        """Before: internal error: could not convert string to float: '-'."""
        path = write(tmp_path, double_rocker(), "dr.toml")
        code, out, err = run(capsys, "forces", path, "--from", 30, "--to", 80, "--step", 0.5, "--through-limits",
                             "--format", fmt)
        assert code == 0, err
        if fmt == "json":
            rows = json.loads(out)["rows"]
            assert {r["mode"] for r in rows} == {"-", "+"} and all(isinstance(r["input_torque"], (float, type(None)))
                                                                  for r in rows)
        else:
            rows = list(csv.DictReader(io.StringIO(out)))
            assert {r["mode"] for r in rows} == {"-", "+"}
            assert all(r["input_torque [N*m]"] == "" or math.isfinite(float(r["input_torque [N*m]"])) for r in rows)

    def test_thesis_rocker_input(self, capsys):
        code, out, err = run(capsys, "forces", THESIS, "--input", "theta4", "--from", 60, "--to", 40, "--step", 2,
                             "--through-limits", "--format", "json")
        assert code == 0, err
        assert len({r["mode"] for r in json.loads(out)["rows"]}) == 2


# ----------------------------------------------------------------------------- items 11 and 12
class TestSimulationStops:
    def test_start_next_to_a_limit_is_an_event(self, tmp_path, capsys):
        """Before: internal error: _Stop."""
        sim = ls.simulate(double_rocker(), 1.0, at=71.79)
        assert [e.kind for e in sim.events] == [ls.EventKind.LIMIT] and sim.events[0].input == 0.0
        assert len(sim.t) == 1
        code, out, err = run(capsys, "simulate", write(tmp_path, double_rocker(), "dr.toml"), "--at", 71.79,
                             "--duration", 1)
        assert code == 0 and "limit at t = 0 s" in out

    def test_nan_load_at_the_start_names_the_load_and_time(self, tmp_path, capsys):
        """Before: internal error: _Stop. The gas force (170.0001 − r1)^1.3 is NaN for r1 > 170.0001 mm."""
        bad = mutated(ENGINE, lambda s: s["loads"][0].update(force=["-1e5*(90/(170.0001 - r1))**1.3", 0]))
        with pytest.raises(ls.SolveError, match=r"the load 'gas' \(loads\[0\]\) is nan.*|t = 0 s"):
            ls.simulate(bad, 0.1)
        with pytest.raises(ls.SolveError) as exc:
            ls.simulate(bad, 0.1)
        assert "'gas'" in str(exc.value) and "t = 0 s" in str(exc.value)
        code, out, err = run(capsys, "simulate", write(tmp_path, bad, "gas.toml"), "--duration", 0.1)
        assert code == 3 and len(err.strip().splitlines()) == 1 and "'gas'" in err and "internal" not in err

    def test_nan_load_later_keeps_the_rows(self):
        """A force −10·sqrt(r1 − 150) is NaN once the piston passes 150 mm (θ ≈ 68°): the rows before are kept."""
        mech = mutated(ENGINE, lambda s: s["loads"][0].update(force=["-10*sqrt(r1 - 150)", 0]))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            with pytest.raises(ls.SolveError) as exc:
                ls.simulate(mech, 0.05, step=0.001, at=30, speed0="3000rpm")
        part = exc.value.result
        assert "'gas'" in str(exc.value) and part is not None and len(part.t) > 1
        assert np.all(np.isfinite(part.kinetic_energy))

    def test_unbounded_torque_stops_with_the_rows_so_far(self, tmp_path, capsys):
        """Before: `torque = tan(theta2)` on the rocker was still running after 300 s."""
        mech = mutated(THESIS, lambda s: s["loads"][0].update(torque="tan(theta2)"))
        with pytest.warns(ls.LoopsolveWarning, match="integration stopped"):
            sim = ls.simulate(mech, 0.05, step=0.01)
        assert sim.events[-1].kind is ls.EventKind.SINGULAR and len(sim.t) >= 1
        code, out, err = run(capsys, "simulate", write(tmp_path, mech, "tan.toml"), "--duration", 0.05,
                             "--step", 0.01)
        assert code == 0 and "integration stopped" in err

    def test_step_cap(self):
        mech = ls.load(THESIS)
        with pytest.warns(ls.LoopsolveWarning, match="3 integration steps"):
            sim = ls.simulate(mech, 2.0, step=0.01, speed0="60rpm", max_steps=3)
        assert 1 <= len(sim.t) < 201 and sim.events[-1].kind is ls.EventKind.SINGULAR


# ----------------------------------------------------------------------------- smaller items
def harmonic_crank():
    """A crank alone (rad model, no gravity, constant inertia) with a load torque a sin θ + b sin 2θ."""
    b = ls.MechanismBuilder("crank", length_unit="m", angle_unit="rad")
    b.parameter("e", 0.05).variable("theta", input=True, guess=0.3).variable("phi", guess=0.3)
    b.variable("L", guess=0.05).vector("r", length="e", angle="theta").vector("s", length="L", angle="phi")
    b.loop("r = s").point("O", "0")
    b.body("crank", mass=2.0, inertia=0.01, com="r", angle="theta", joints=["O"])
    return b.load(body="crank", torque="3*sin(theta) + sin(2*theta + 0.7)").build()


class TestFlywheel:
    def test_energy_fluctuation_from_the_continuous_curve(self):
        """T = −3 sin θ − sin(2θ + 0.7): E(θ) = 3 cos θ + cos(2θ + 0.7)/2, ΔE from a dense closed form.

        Before: the trapezoid work and the extrema at the rows (15°): relative error ~1e-2.
        """
        fw = ls.forces(harmonic_crank(), 0, 2 * math.pi, math.pi / 12, speed=4.0).flywheel(0.05)
        th = np.linspace(0, 2 * math.pi, 2_000_001)
        energy = 3 * np.cos(th) + 0.5 * np.cos(2 * th + 0.7)
        de = energy.max() - energy.min()
        assert fw.mean_torque == pytest.approx(0, abs=1e-9)
        assert fw.energy_fluctuation == pytest.approx(de, rel=2e-4)
        assert fw.at_max == pytest.approx(th[np.argmax(energy)], abs=2e-2)

    def test_cli_defaults_to_one_turn_and_allows_720(self, capsys):
        """Before: 'needs the driving torque at every point of a full cycle'."""
        code, out, err = run(capsys, "forces", THESIS, "--flywheel", 0.02)
        assert code == 0, err and "flywheel for C_s = 0.02" in out
        code, out, err = run(capsys, "forces", ENGINE, "--flywheel", 0.02, "--from", 0, "--to", 720, "--step", 4,
                             "--format", "json")
        assert code == 0, err
        assert json.loads(out)["flywheel"]["inertia"] > 0


class TestMessages:
    def test_unknown_load_key_is_named(self):
        with pytest.raises(ls.ModelError, match=r"loads\[0\]: unknown key\(s\) 'torqe' \(did you mean 'torque'\?\)"):
            mutated(THESIS, lambda s: s["loads"][0].update(torqe=s["loads"][0].pop("torque")))

    def test_missing_rocker_suggests_declaring_it(self):
        with pytest.raises(ls.ModelError) as exc:
            mutated(MODELS / "shaper_dynamics.toml", lambda s: s["bodies"].pop("lever"))
        msg = str(exc.value)
        assert "declare the body that carries the guide" in msg and "guide_body" not in msg

    def test_speed0_errors_are_attributed_to_speed0(self, capsys):
        # a unit of the wrong dimension is an error under --speed0, never under --speed
        code, out, err = run(capsys, "simulate", THESIS, "--duration", 0.02, "--speed0", "120 mm/s")
        assert code == 2 and "--speed0" in err and "--speed:" not in err
        # with units by dimension (issue 23) "120 rev/min" is a speed: 4*pi rad/s at t = 0
        code, out, err = run(capsys, "simulate", THESIS, "--duration", 0.02, "--speed0", "120 rev/min",
                             "--format", "json")
        assert code == 0, err
        assert json.loads(out)["rows"][0]["theta2_vel"] == pytest.approx(4 * math.pi, rel=1e-12)

    def test_torque_quantity_and_advice(self, capsys):
        code, out, err = run(capsys, "simulate", THESIS, "--duration", 0.02, "--torque", "0.05N*m", "--format", "json")
        assert code == 0, err
        want = ls.simulate(ls.load(THESIS), 0.02, torque=0.05)
        assert json.loads(out)["rows"][-1]["theta2"] == pytest.approx(float(want.x[-1]), rel=1e-12)
        code, out, err = run(capsys, "simulate", THESIS, "--duration", 0.02, "--torque", "0.05N*m + theta2")
        assert code == 2 and "0.05*N" not in err and "units are not allowed inside an expression" in err

    def test_simulation_table_prints_no_negative_zero(self):
        sim = ls.simulate(ls.load(THESIS), 0.02, step=0.01)
        neg = dataclasses.replace(sim, xd=np.full(len(sim.t), -0.0), potential_energy=np.full(len(sim.t), -0.0))
        body = neg.table().splitlines()[2:]
        assert not any(cell == "-0" for line in body for cell in line.split())

    def test_docs_document_the_bar_helper(self):
        text = (Path(__file__).parents[2] / "docs" / "explanation" / "forces.md").read_text()
        assert "I = m(L² + w²)/12" in text and "7850 kg/m³" in text

    def test_no_class_scoped_fixture_methods_in_test_forces(self):
        """pytest deprecates class-scoped fixtures defined as methods (they get a new ``self``)."""
        tree = ast.parse((Path(__file__).parent / "test_forces.py").read_text())
        for cls in (n for n in ast.walk(tree) if isinstance(n, ast.ClassDef)):
            for fn in (n for n in cls.body if isinstance(n, ast.FunctionDef)):
                for dec in fn.decorator_list:
                    assert "scope" not in ast.unparse(dec), f"{cls.name}.{fn.name}"
