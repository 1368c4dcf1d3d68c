"""Joint forces and driving torques by Newton–Euler against hand computations (written for the
surviving mutants of loopsolve/dynamics/kinetostatics.py, issue 13).

Every expected value is computed here, independently of the Newton–Euler code under test:
closed-form positions of an inclined slider-crank (law of cosines) with derivatives by complex step,
the driving force by virtual work, the shaking force and moment from Σ m (g − a_G) and Σ I α,
a crank alone with a spring to the frame by hand formulas, and hand-written tables of the unknowns.
"""

from __future__ import annotations

import cmath
import math

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.dynamics.dynamics_model import compile_dynamics
from loopsolve.errors import ModelError
from loopsolve.dynamics.kinetostatics import inverse_dynamics, layout, solve_batched

G = 9.81

# ------------------------------------------------------------------ inclined slider-crank, driven by the slider
ALPHA = math.radians(30.0)  # guide direction
R2, R3 = 0.05, 0.15  # crank, rod (m)
MASS = (0.3, 0.5, 0.4)  # crank, rod, piston (kg)
INERTIA = (2e-4, 9e-4)  # crank, rod about G (kg m^2)
TAU = -0.7  # torque on the crank (N m)


def inclined_slider(torque: bool = False) -> ls.Mechanism:
    """Crank O2-B, rod B-C, piston C sliding along r1 at 30° on the frame; the input is the piston position x."""
    b = ls.MechanismBuilder("inclined slider", length_unit="m", angle_unit="rad")
    b.parameter("r2", R2).parameter("r3", R3).parameter("alpha", ALPHA)
    b.variable("x", input=True, guess=0.17).variable("theta2", guess=1.2).variable("theta3", guess=0.0)
    b.vector("r1", length="x", angle="alpha").vector("r2", length="r2", angle="theta2")
    b.vector("r3", length="r3", angle="theta3").loop("r2 + r3 = r1")
    b.point("O2", "0").point("B", "r2").point("C", "r1")
    b.body("crank", mass=MASS[0], inertia=INERTIA[0], com="0.5*r2", angle="theta2", joints=["O2", "B"])
    b.body("rod", mass=MASS[1], inertia=INERTIA[1], com="r2 + 0.5*r3", angle="theta3", joints=["B", "C"])
    b.body("piston", mass=MASS[2], com="r1", joints=["C"], guide="r1")
    if torque:
        b.load(body="crank", torque=TAU)
    return b.gravity(0, -G).build()


def slider_pose(x):
    """Rows: G_crank, G_rod, G_piston (x, y) and (theta2, theta3); analytic in x (complex step works)."""
    beta = cmath.acos((x * x + R2 * R2 - R3 * R3) / (2 * x * R2))  # crank angle from the guide (law of cosines)
    t2 = ALPHA + beta
    t3 = ALPHA + cmath.asin(-R2 * cmath.sin(beta) / R3)
    bx, by = R2 * cmath.cos(t2), R2 * cmath.sin(t2)
    return np.array([[0.5 * bx, 0.5 * by],
                     [bx + 0.5 * R3 * cmath.cos(t3), by + 0.5 * R3 * cmath.sin(t3)],
                     [x * math.cos(ALPHA), x * math.sin(ALPHA)],
                     [t2, t3]])


def slider_d1(x, hc=1e-30):
    return slider_pose(x + 1j * hc).imag / hc


def slider_d2(x, h=2e-5):
    """Fourth-order central difference of the complex-step first derivative."""
    return (8 * (slider_d1(x + h) - slider_d1(x - h)) - (slider_d1(x + 2 * h) - slider_d1(x - 2 * h))) / (12 * h)


def _cross(p, q):
    return p[0] * q[1] - p[1] * q[0]


def slider_reference(x, v, a, tau=0.0):
    """Driving force by virtual work, shaking force/moment, energies' rates — all from the closed form."""
    pos, d1, d2 = slider_pose(x).real, slider_d1(x), slider_d2(x)
    acc = d2 * v * v + d1 * a
    vel = d1 * v
    g = np.array([0.0, -G])
    # virtual work with x as the coordinate: F = Σ m (a_G − g)·∂G/∂x + Σ I α ∂θ/∂x − τ ∂θ2/∂x
    force = (sum(MASS[k] * np.dot(acc[k] - g, d1[k]) for k in range(3))
             + sum(INERTIA[k] * acc[3][k] * d1[3][k] for k in range(2)) - tau * d1[3][0])
    shaking = sum(MASS[k] * (g - acc[k]) for k in range(3))
    moment = (sum(_cross(pos[k], MASS[k] * (g - acc[k])) for k in range(3))
              - sum(INERTIA[k] * acc[3][k] for k in range(2)))
    dke = sum(MASS[k] * np.dot(vel[k], acc[k]) for k in range(3)) + sum(INERTIA[k] * vel[3][k] * acc[3][k]
                                                                         for k in range(2))
    dv = -sum(MASS[k] * np.dot(g, vel[k]) for k in range(3))
    return dict(force=force, shaking=shaking, moment=moment, dke=dke, dv=dv, p_loads=tau * vel[3][0],
                d1=d1[3], d2=d2[3])


@pytest.fixture(scope="module")
def slider():
    return inclined_slider()


class TestInclinedSliderDrivenByItsPosition:
    @pytest.mark.parametrize("x, v, a", [(0.17, 0.3, 2.0), (0.12, -0.8, 0.0), (0.19, 0.0, -5.0)])
    def test_force_and_shaking_against_closed_form(self, slider, x, v, a):
        """Input force, shaking force and shaking moment of a slider-crank driven along a 30° guide.

        Kills x_inverse_dynamics__mutmut_216 (the driver's y component in the wrong equation),
        x_inverse_dynamics__mutmut_436 (the driver's moment replaces the shaking moment instead of
        adding to it) and x_inverse_dynamics__mutmut_446 (moment arm of the driver from the wrong
        coordinate).
        """
        ref = slider_reference(x, v, a)
        f = ls.forces(slider, x, speed=v, accel=a)
        assert f.drive_name == "input_force"
        assert float(f.sweep["theta2"][0]) == pytest.approx(slider_pose(x)[3][0].real, abs=1e-10)
        scale = abs(ref["force"]) + 1.0
        assert float(f.drive) == pytest.approx(ref["force"], rel=1e-6, abs=1e-7 * scale)
        np.testing.assert_allclose(f.shaking_force, ref["shaking"], rtol=1e-6, atol=1e-7 * scale)
        assert float(f.shaking_moment) == pytest.approx(ref["moment"], rel=1e-6, abs=1e-8 * scale)

    def test_static_slider_holds_the_weight(self, slider):
        """At rest the frame carries the weight: shaking force Σ m g, moment Σ r_G × m g (about O2).

        Kills x_inverse_dynamics__mutmut_436 and x_inverse_dynamics__mutmut_446.
        """
        x = 0.16
        pos = slider_pose(x).real
        f = ls.forces(slider, x, speed=0, accel=0)
        weight = -G * sum(MASS)
        np.testing.assert_allclose(f.shaking_force, [0.0, weight], atol=1e-10)
        want = sum(_cross(pos[k], (0.0, -G * MASS[k])) for k in range(3))
        assert float(f.shaking_moment) == pytest.approx(want, rel=1e-9)

    def test_inverse_dynamics_power_terms_and_coefficients(self):
        """``power_scale`` = |F ẋ| + |dE_k/dt| + |dV/dt| + |P_loads|; ``d1``/``d2`` are ∂q/∂x, ∂²q/∂x².

        With a torque on the crank, P_loads ≠ 0. Kills x_inverse_dynamics__mutmut_496 (P_loads
        subtracted from the scale) and x_inverse_dynamics__mutmut_536 (``d2`` lost).
        """
        mech = inclined_slider(torque=True)
        ck = mech.compile()
        dm = compile_dynamics(mech, compiled=ck)
        assert list(ck.variables) == ["x", "theta2", "theta3"]
        x, v, a = 0.15, 0.6, 3.0
        ref = slider_reference(x, v, a, tau=TAU)
        z = np.array([[x, *slider_pose(x)[3].real]])
        out = inverse_dynamics(dm, z, v, a)
        assert float(out["drive"][0]) == pytest.approx(ref["force"], rel=1e-6)
        want = abs(ref["force"] * v) + abs(ref["dke"]) + abs(ref["dv"]) + abs(ref["p_loads"])
        assert abs(ref["p_loads"]) > 0.1 * want
        assert float(out["power_scale"][0]) == pytest.approx(want, rel=1e-6)
        assert abs(float(out["power_residual"][0])) <= 1e-9 * want
        np.testing.assert_allclose(out["d1"][0], [1.0, *ref["d1"]], rtol=1e-9)
        np.testing.assert_allclose(out["d2"][0], [0.0, *ref["d2"]], rtol=1e-6)

    def test_non_finite_pose_is_singular_with_zero_ratio(self, slider):
        """A pose that is not finite gives NaN forces, ``singular`` and the Hadamard ratio 0 (documented: 0 = singular).

        Kills x_inverse_dynamics__mutmut_306 (ratio NaN there).
        """
        dm = compile_dynamics(slider)
        x = 0.17
        good = [x, *slider_pose(x)[3].real]
        with np.errstate(invalid="ignore"):
            out = inverse_dynamics(dm, np.array([good, [np.nan] * 3]), 0.0, 0.0)
        assert out["singular"].tolist() == [False, True]
        assert np.isnan(out["drive"][1]) and np.isfinite(out["drive"][0])
        assert 0.0 < out["cond"][0] <= 1.0
        assert out["cond"][1] == 0.0


def test_layout_names_pins_carriers_and_frame():
    """The unknowns: one pin per joint, on the first body carrying it from the other, −1 for the frame.

    Hand table for the thesis crank-rocker (crank, coupler, rocker) and the inclined slider-crank.
    Kills x_layout__mutmut_14 (a frame pin's other body −2 instead of the documented −1).
    """
    dm = compile_dynamics(ls.load(ls.models_dir() / "thesis_crank_rocker_dynamics.toml"))
    lay = layout(dm)
    assert [(p[0], p[2], p[3]) for p in lay.pins] == [("F_O2", 0, -1), ("F_B", 0, 1), ("F_C", 1, 2),
                                                      ("F_O4", 2, -1)]
    assert [dm.point_names[p[1]] for p in lay.pins] == ["O2", "B", "C", "O4"]
    assert lay.guides == () and lay.driver == 0 and (lay.n_unknowns, lay.n_equations) == (9, 9)
    lay = layout(compile_dynamics(inclined_slider()))
    assert [(p[0], p[2], p[3]) for p in lay.pins] == [("F_O2", 0, -1), ("F_B", 0, 1), ("F_C", 1, 2)]
    assert [g[:3] for g in lay.guides] == [("piston_guide", 2, -1)]
    assert lay.driver == 2 and (lay.n_unknowns, lay.n_equations) == (9, 9)


# ------------------------------------------------------------------ a crank alone
M_C, I_C, E_C = 0.7, 2e-3, 0.04  # mass, inertia about G, O-to-G distance (m)


def crank(spring: bool = False, torque: str | None = None) -> ls.Mechanism:
    """One crank about O (a dummy loop r = s ties two more variables to it), com at its tip P."""
    b = ls.MechanismBuilder("crank", length_unit="m", angle_unit="rad")
    b.parameter("e", E_C).parameter("d", 0.1)
    b.variable("theta", input=True, guess=0.3).variable("phi", guess=0.3).variable("L", guess=E_C)
    b.vector("r", length="e", angle="theta").vector("s", length="L", angle="phi").vector("a", length="d", angle=0)
    b.loop("r = s")
    b.point("O", "0").point("P", "r").point("A", "a")
    b.body("crank", mass=M_C, inertia=I_C, com="r", angle="theta", joints=["O"])
    if spring:
        b.load(spring=["P", "A"], stiffness="250N/m", free_length=0.03, bodies=["crank", "frame"])
    if torque:
        b.load(body="crank", torque=torque)
    return b.gravity(0, -G).build()


def test_spring_to_the_frame_energy_and_torque():
    """Crank with a spring P–A (A = (0.1, 0) on the frame): V = m g e sin θ + ½ k (L − L0)², T by hand.

    Kills x__external__mutmut_178 (½ / k instead of ½ k in the spring's potential energy).
    """
    mech = crank(spring=True)
    k, free, d = 250.0, 0.03, 0.1
    for th, w, al in ((0.4, 0.0, 0.0), (2.2, 3.0, -4.0), (4.0, -1.5, 6.0)):
        px, py = E_C * math.cos(th), E_C * math.sin(th)
        length = math.hypot(px - d, py)
        dl = ((px - d) * -py + py * px) / length  # dL/dθ = (P − A)·∂P/∂θ / L
        f = ls.forces(mech, th, speed=w, accel=al)
        v_pot = M_C * G * py + 0.5 * k * (length - free) ** 2
        assert float(f.potential_energy) == pytest.approx(v_pot, rel=1e-12)
        assert float(f.kinetic_energy) == pytest.approx(0.5 * (I_C + M_C * E_C**2) * w**2, rel=1e-12, abs=1e-15)
        want = (I_C + M_C * E_C**2) * al + M_C * G * px + k * (length - free) * dl
        assert float(f.drive) == pytest.approx(want, rel=1e-11, abs=1e-13)


def test_nan_load_rows_are_flagged():
    """A torque load sqrt(θ − 1) is NaN for θ < 1: those rows have NaN forces, are ``singular`` and get an event.

    The other rows follow T = (I + m e²) α + m g e cos θ − τ. Kills x_inverse_dynamics__mutmut_276
    (a NaN right-hand side with a finite matrix no longer flagged).
    """
    mech = crank(torque="sqrt(theta - 1)")
    w, al = 2.0, 1.5
    with np.errstate(invalid="ignore"):
        f = ls.forces(mech, 0, 3, 0.5, speed=w, accel=al)
    th = np.asarray(f.sweep["theta"], dtype=float)
    np.testing.assert_allclose(th, np.arange(0, 3.01, 0.5), atol=1e-12)
    bad = th < 1
    assert np.all(np.isnan(f.drive[bad])) and f.singular.tolist() == bad.tolist()
    marked = sorted(ev.input for ev in f.events if ev.kind.value == "singular")
    np.testing.assert_allclose(marked, th[bad])
    want = (I_C + M_C * E_C**2) * al + M_C * G * E_C * np.cos(th[~bad]) - np.sqrt(th[~bad] - 1)
    np.testing.assert_allclose(f.drive[~bad], want, rtol=1e-11)


def test_force_series_of_the_page():
    """``view.force_series`` (the interactive page's torque curve) analyses the sweep itself: T = m g e cos θ at rest.

    Kills x_force_analysis__mutmut_8 (the dynamics compiled without the mechanism).
    """
    from loopsolve.output.view import force_series

    sw = crank().sweep(0, 3, 1.0, speed=0, accel=0)
    series = force_series(sw)
    assert list(series) == ["input_torque [N*m]"]
    np.testing.assert_allclose(series["input_torque [N*m]"], M_C * G * E_C * np.cos([0.0, 1.0, 2.0, 3.0]),
                               rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("args", [(0, 3), (None, 3, 0.5)], ids=["no step", "no start"])
def test_force_sweep_needs_start_stop_and_step(args):
    """``forces(mech, start, stop)`` without a step (or without a start) is a ModelError naming the three.

    Kills x_forces__mutmut_35 (``or`` → ``and``).
    """
    with pytest.raises(ModelError, match="start, stop and step"):
        ls.forces(crank(), *args)


def test_solve_batched_ratio_is_scale_free():
    """The Hadamard ratio |det A| / Π‖row‖ is 1 for orthogonal rows whatever their scale (docstring).

    Kills x__solve_stacked__mutmut_167 (row norms ≤ 1 not divided out).
    """
    a = np.array([[[0.1, 0.0], [0.0, 0.5]], [[0.0, 0.2], [0.3, 0.0]], [[3.0, 4.0], [-0.4, 0.3]],
                  [[0.5, 0.5], [0.5, 0.5]]])
    b = np.array([[1.0, 2.0], [1.0, 3.0], [5.0, 0.5], [1.0, 1.0]])
    x, ratio = solve_batched(a, b)
    np.testing.assert_allclose(x[0], [10.0, 4.0], rtol=1e-14)
    np.testing.assert_allclose(x[1], [10.0, 5.0], rtol=1e-14)
    np.testing.assert_allclose(np.array(a[2]) @ x[2], b[2], rtol=1e-14)
    np.testing.assert_allclose(ratio[:3], [1.0, 1.0, 1.0], rtol=1e-14)
    assert ratio[3] == 0.0
