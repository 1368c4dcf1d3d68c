"""Force and torque analysis, the equation of motion, simulation and flywheel sizing.

Independent references written here: Newton–Euler residuals recomputed per body from the reported
joint forces and the point accelerations; statics against finite differences of a potential energy
computed from the com positions; the four-bar's equation of motion from sympy.physics.mechanics
(KanesMethod with the loop-closure constraint); a crank alone and an in-line slider-crank against
exact closed forms (derivatives by complex step); simulate against energy conservation and
against the inverse-dynamics torque fed back.
"""

from __future__ import annotations

import cmath
import json
import math
import subprocess
import sys

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.dynamics.dynamics_model import compile_dynamics, kinematic_coefficients, mass_matrix_terms
from loopsolve.dynamics.kinetostatics import generalized_force, inverse_dynamics, virtual_work_drive

from support.models import with_extra_loads

MODELS = [p for p in sorted(ls.models_dir().glob("*.toml")) if ls.load(p).dynamics is not None]
G = 9.81


def sweep_rows(mech, speed, accel, n=12):
    ck = mech.compile()
    sw = mech.sweep(0, 360, 360 / n, speed=speed, accel=accel)
    return ck, sw


class TestPowerBalance:
    """Newton–Euler driving torque = virtual-work torque M ẍ + ½M′ẋ² − Q on every model with masses."""

    @pytest.mark.parametrize("extra", [False, True], ids=["as shipped", "springs+dampers"])
    @pytest.mark.parametrize("path", MODELS, ids=[p.stem for p in MODELS])
    def test_newton_euler_equals_virtual_work(self, path, extra):
        mech = ls.load(path)
        if extra:
            mech = with_extra_loads(mech)
        ck = mech.compile()
        sw = mech.sweep(0, 360, 15, speed=7.0, accel=-3.0)
        dm = compile_dynamics(mech, compiled=ck)
        ix = ck.input_idx[0]
        ne = inverse_dynamics(dm, sw.z, sw.z1[:, ix], sw.z2[:, ix])
        vw = virtual_work_drive(dm, sw.z, sw.z1[:, ix], sw.z2[:, ix])
        scale = np.max(np.abs(vw))
        assert scale > 0
        np.testing.assert_allclose(ne["drive"], vw, rtol=0, atol=1e-9 * scale)
        # the built-in power balance closes too
        assert np.max(np.abs(ne["power_residual"])) <= 1e-9 * np.max(ne["power_scale"])

    @pytest.mark.parametrize("path", MODELS, ids=[p.stem for p in MODELS])
    def test_energy_rate_by_finite_differences(self, path):
        """Without non-conservative loads, T ẋ = d(E_k + V)/dt at constant speed (central differences in x)."""
        mech = ls.load(path)
        spec = ls.model.mechanism.deep_copy(mech.spec)
        spec.pop("loads", None)
        spec["gravity"] = ["0.5m/s^2", "-9.81m/s^2"]
        mech = ls.build_mechanism(spec)
        w, h = 3.0, 1e-4  # rad/s; step in degrees
        for at in (20.0, 145.0, 260.0):
            f = [ls.forces(mech, at + d, speed=w) for d in (-h, 0.0, h)]
            e = [float(r.kinetic_energy + r.potential_energy) for r in f]
            dedx = (e[2] - e[0]) / (2 * math.radians(h))
            t = float(f[1].drive)
            assert t * w == pytest.approx(dedx * w, rel=1e-6, abs=1e-9 * abs(w * t) + 1e-12)


class TestStatics:
    def test_gravity_torque_is_dv_dx(self):
        """At zero speed with gravity only, T = dV/dθ2, V from the com positions (mid-links) computed here."""
        mech = ls.load(ls.models_dir() / "thesis_crank_rocker_dynamics.toml")
        spec = ls.model.mechanism.deep_copy(mech.spec)
        spec.pop("loads")
        mech = ls.build_mechanism(spec)
        m = {b.name: b.mass for b in mech.dynamics.bodies}

        def potential(at):
            s = mech.solve(at)
            t2, t3, t4 = (math.radians(s[n]) for n in ("theta2", "theta3", "theta4"))
            y2 = 0.5 * 25 * math.sin(t2)
            y3 = 25 * math.sin(t2) + 0.5 * 70 * math.sin(t3)
            y4 = 0.5 * 45 * math.sin(t4)
            return G * 1e-3 * (m["crank"] * y2 + m["coupler"] * y3 + m["rocker"] * y4)

        h = 1e-3
        for at in (0.0, 70.0, 180.0, 290.0):
            dv = (potential(at + h) - potential(at - h)) / (2 * math.radians(h))
            t = float(ls.forces(mech, at, speed=0, accel=0).drive)
            assert t == pytest.approx(dv, rel=1e-7)


# ------------------------------------------------------------------ sympy.physics.mechanics
R1, R2, R3, R4 = 60.0, 25.0, 70.0, 45.0
MASS = (0.1, 0.2, 0.15)
INERTIA = (1e-4, 3e-4, 2e-4)
TAU4 = -0.05


def fourbar_dynamics() -> ls.Mechanism:
    b = ls.MechanismBuilder("four-bar dynamics")
    for n, v in dict(r1=R1, r2=R2, r3=R3, r4=R4).items():
        b.parameter(n, v)
    b.variable("theta2", input=True, guess=90).variable("theta3", guess=20).variable("theta4", guess=80)
    b.vector("r1", length="r1", angle=0).vector("r2", length="r2", angle="theta2")
    b.vector("r3", length="r3", angle="theta3").vector("r4", length="r4", angle="theta4")
    b.loop("r2 + r3 = r1 + r4")
    b.point("O2", "0").point("B", "r2").point("C", "r2 + r3").point("O4", "r1")
    b.body("crank", mass=MASS[0], inertia=f"{INERTIA[0]}kg*m^2", com="0.5*r2", angle="theta2", joints=["O2", "B"])
    b.body("coupler", mass=MASS[1], inertia=f"{INERTIA[1]}kg*m^2", com="r2 + 0.5*r3", angle="theta3", joints=["B", "C"])
    b.body("rocker", mass=MASS[2], inertia=f"{INERTIA[2]}kg*m^2", com="r1 + 0.5*r4", angle="theta4", joints=["C", "O4"])
    b.load(body="rocker", torque=f"{TAU4}N*m")  # the model is in mm: SI plain numbers would be ambiguous
    return b.gravity(0, f"{-G}m/s^2").build()


@pytest.fixture(scope="module")
def kane_fourbar():
    sp = pytest.importorskip("sympy")
    me = pytest.importorskip("sympy.physics.mechanics")
    q2, q3, q4 = me.dynamicsymbols("q2 q3 q4")
    u2, u3, u4 = me.dynamicsymbols("u2 u3 u4")
    L1, L2, L3, L4 = (v / 1000 for v in (R1, R2, R3, R4))
    N = me.ReferenceFrame("N")
    frames = [N.orientnew(f"A{i}", "Axis", [q, N.z]) for i, q in ((2, q2), (3, q3), (4, q4))]
    for F, u in zip(frames, (u2, u3, u4)):
        F.set_ang_vel(N, u * N.z)
    A2, A3, A4 = frames
    O2 = me.Point("O2")
    O2.set_vel(N, 0)
    B = O2.locatenew("B", L2 * A2.x)
    B.v2pt_theory(O2, N, A2)
    G2 = O2.locatenew("G2", L2 / 2 * A2.x)
    G2.v2pt_theory(O2, N, A2)
    G3 = B.locatenew("G3", L3 / 2 * A3.x)
    G3.v2pt_theory(B, N, A3)
    C = B.locatenew("C", L3 * A3.x)
    C.v2pt_theory(B, N, A3)
    O4 = O2.locatenew("O4", L1 * N.x)
    O4.set_vel(N, 0)
    G4 = O4.locatenew("G4", L4 / 2 * A4.x)
    G4.v2pt_theory(O4, N, A4)
    C4 = O4.locatenew("C4", L4 * A4.x)
    bodies = [me.RigidBody(n, Gp, F, mm, (me.inertia(F, 0, 0, ii), Gp)) for n, Gp, F, mm, ii in
              zip(("crank", "coupler", "rocker"), (G2, G3, G4), frames, MASS, INERTIA)]
    T = sp.Symbol("T")  # a driving torque on the crank: the equation is linear in it, dẍ/dT = 1/M
    loads = [(Gp, -mm * G * N.y) for Gp, mm in zip((G2, G3, G4), MASS)] + [(A4, TAU4 * N.z), (A2, T * N.z)]
    loop = C.pos_from(O2) - C4.pos_from(O2)
    conf = [loop.dot(N.x), loop.dot(N.y)]
    t = me.dynamicsymbols._t
    rates = {q2.diff(t): u2, q3.diff(t): u3, q4.diff(t): u4}
    vel = [sp.diff(c, t).subs(rates) for c in conf]
    kane = me.KanesMethod(N, q_ind=[q2], u_ind=[u2], q_dependent=[q3, q4], u_dependent=[u3, u4],
                          configuration_constraints=conf, velocity_constraints=vel,
                          kd_eqs=[q2.diff(t) - u2, q3.diff(t) - u3, q4.diff(t) - u4])
    kane.kanes_equations(bodies, loads)
    # mass_matrix (3x3: the dynamic equation and the two differentiated constraints) times (u2', u3', u4')
    # equals forcing; solving it gives the input's acceleration of the constrained system
    mass = sp.lambdify([q2, q3, q4], kane.mass_matrix)
    forcing = sp.lambdify([q2, q3, q4, u2, u3, u4, T], kane.forcing)

    def accel(t2, t3, t4, w2, w3, w4, torque):
        return float(np.linalg.solve(np.array(mass(t2, t3, t4), dtype=float),
                                     np.array(forcing(t2, t3, t4, w2, w3, w4, torque), dtype=float))[0, 0])

    return accel


def fourbar_pose(t2: float, near):
    """Open-mode pose by intersecting the circles (B, r3) and (O4, r4); the solution nearest ``near``."""
    bx, by = R2 * math.cos(t2), R2 * math.sin(t2)
    dx, dy = R1 - bx, -by
    d = math.hypot(dx, dy)
    a = (R3**2 - R4**2 + d**2) / (2 * d)
    hgt = math.sqrt(R3**2 - a**2)
    best = None
    for s in (1, -1):
        cx = bx + a * dx / d - s * hgt * dy / d
        cy = by + a * dy / d + s * hgt * dx / d
        t3, t4 = math.atan2(cy - by, cx - bx), math.atan2(cy, cx - R1)
        err = abs(math.remainder(t3 - near[0], 2 * math.pi)) + abs(math.remainder(t4 - near[1], 2 * math.pi))
        if best is None or err < best[0]:
            best = (err, t3, t4)
    return best[1], best[2]


class TestIndependentEquationOfMotion:
    def test_fourbar_against_kanes_method(self, kane_fourbar):
        accel = kane_fourbar
        mech = fourbar_dynamics()
        ck = mech.compile()
        dm = compile_dynamics(mech, compiled=ck)
        for at in np.arange(0.0, 360.0, 30.0):
            s = mech.solve(at)
            t2 = math.radians(at)
            t3, t4 = fourbar_pose(t2, (s.z[1], s.z[2]))
            # kinematic coefficients of the four-bar, closed form
            h3 = R2 * math.sin(t4 - t2) / (R3 * math.sin(t3 - t4))
            h4 = R2 * math.sin(t3 - t2) / (R4 * math.sin(t3 - t4))
            # M ẍ + ½ M′ ẋ² = Q + T: M from dẍ/dT, Q at rest, M′ from the speed-dependent part
            mk = 1.0 / (accel(t2, t3, t4, 0, 0, 0, 1.0) - accel(t2, t3, t4, 0, 0, 0, 0.0))
            q_k = mk * accel(t2, t3, t4, 0, 0, 0, 0.0)
            dm_k = 2 * (q_k - mk * accel(t2, t3, t4, 1.0, h3, h4, 0.0))
            z = np.array([[t2, t3, t4]])
            d1, d2 = kinematic_coefficients(ck, z)
            M, dM = mass_matrix_terms(dm, z, d1, d2)
            Q = generalized_force(dm, z, 0.0, d1)
            assert M[0] == pytest.approx(mk, rel=1e-9)
            assert dM[0] == pytest.approx(dm_k, rel=1e-9, abs=1e-9 * abs(mk))
            assert Q[0] == pytest.approx(q_k, rel=1e-9, abs=1e-12)


class TestClosedForms:
    def test_crank_alone(self):
        """One crank about O2 (a dummy loop r = s ties two more variables to it): T = (I + m e²) α + m g e cos θ."""
        m, i_g, e = 0.7, 2e-3, 0.04
        b = ls.MechanismBuilder("crank", length_unit="m", angle_unit="rad")
        b.parameter("e", e).variable("theta", input=True, guess=0.3).variable("phi", guess=0.3)
        b.variable("L", guess=e).vector("r", length="e", angle="theta").vector("s", length="L", angle="phi")
        b.loop("r = s")
        b.point("O", "0").point("P", "r")
        b.body("crank", mass=m, inertia=i_g, com="r", angle="theta", joints=["O"])
        mech = b.gravity(0, -G).build()
        for th in (0.0, 0.8, 2.5, 4.0):
            for w, a in ((0.0, 0.0), (5.0, 0.0), (3.0, 7.0)):
                f = ls.forces(mech, th, speed=w, accel=a)
                want = (i_g + m * e**2) * a + m * G * e * math.cos(th)
                assert float(f.drive) == pytest.approx(want, rel=1e-12, abs=1e-14)
                # the pin carries the weight and the centripetal and tangential forces
                fx = m * (-e * w**2 * math.cos(th) - e * a * math.sin(th))
                fy = m * (-e * w**2 * math.sin(th) + e * a * math.cos(th)) + m * G
                np.testing.assert_allclose(f.joint_forces["F_O"], [fx, fy], rtol=1e-12, atol=1e-12)

    def test_slider_crank_exact(self):
        """In-line slider-crank with masses: T = M(θ) α + ½ M′(θ) ω² − Q(θ), exact kinematics, M′ by complex step."""
        r, l, a, b_ = 0.05, 0.18, 0.02, 0.06  # crank, rod, crank com from O2, rod com from B (m)
        m2, m3, m4, i2, i3 = 0.9, 0.5, 0.35, 1.1e-3, 1.6e-3
        bld = ls.MechanismBuilder("slider-crank", length_unit="m", angle_unit="deg")
        bld.parameter("r2", r).parameter("r3", l).parameter("ka", a / r).parameter("kb", b_ / l)
        bld.variable("theta2", input=True, guess=40).variable("theta3", guess=-10).variable("x", guess=0.2)
        bld.vector("r1", length="x", angle=0).vector("r2", length="r2", angle="theta2")
        bld.vector("r3", length="r3", angle="theta3").loop("r2 + r3 = r1")
        bld.point("O2", "0").point("B", "r2").point("C", "r1")
        bld.body("crank", mass=m2, inertia=i2, com="ka*r2", angle="theta2", joints=["O2", "B"])
        bld.body("rod", mass=m3, inertia=i3, com="r2 + kb*r3", angle="theta3", joints=["B", "C"])
        bld.body("piston", mass=m4, com="r1", joints=["C"], guide="r1")
        mech = bld.gravity(0, -G).build()

        def inertia_and_potential(th):
            s3 = -r * cmath.sin(th) / l
            t3 = cmath.asin(s3)
            h3 = -r * cmath.cos(th) / (l * cmath.cos(t3))
            vg3 = (-r * cmath.sin(th) - b_ * h3 * cmath.sin(t3), r * cmath.cos(th) + b_ * h3 * cmath.cos(t3))
            vx = -r * cmath.sin(th) - l * h3 * cmath.sin(t3)
            M = m2 * a**2 + i2 + m3 * (vg3[0] ** 2 + vg3[1] ** 2) + i3 * h3**2 + m4 * vx**2
            V = G * (m2 * a * cmath.sin(th) + m3 * (r * cmath.sin(th) + b_ * cmath.sin(t3)))
            return M, V

        hc = 1e-20
        for deg in (10.0, 75.0, 160.0, 230.0, 300.0):
            th = math.radians(deg)
            M = inertia_and_potential(th)[0].real
            dM = inertia_and_potential(th + 1j * hc)[0].imag / hc
            Q = -inertia_and_potential(th + 1j * hc)[1].imag / hc
            for w, al in ((0.0, 0.0), (40.0, 0.0), (25.0, -300.0)):
                want = M * al + 0.5 * dM * w**2 - Q
                got = float(ls.forces(mech, deg, speed=w, accel=al).drive)
                assert got == pytest.approx(want, rel=1e-10, abs=1e-12 * (abs(M * al) + abs(dM * w**2) + abs(Q)))


class TestJointForces:
    @pytest.mark.parametrize("at", [0.0, 100.0, 215.0, 330.0])
    def test_newton_euler_residual_per_body(self, at):
        """ΣF = m a_G and ΣM_G = I α for each link, recomputed from the reported forces and the point kinematics."""
        mech = fourbar_dynamics()
        f = ls.forces(mech, at, speed=9.0, accel=4.0)
        row = f.rows[0]
        mm = 1e-3
        P = {p: np.array([row[f"{p}_x"], row[f"{p}_y"]]) * mm for p in ("O2", "B", "C", "O4")}
        A = {p: np.array([row[f"{p}_x_acc"], row[f"{p}_y_acc"]]) * mm for p in ("O2", "B", "C", "O4")}
        F = {j: np.array([row[f"F_{j}_x"], row[f"F_{j}_y"]]) for j in ("O2", "B", "C", "O4")}
        alpha = {n: row[f"{n}_acc"] for n in ("theta2", "theta3", "theta4")}
        g = np.array([0.0, -G])
        cross = lambda r, v: r[0] * v[1] - r[1] * v[0]  # noqa: E731
        # (body, com, com acceleration, [(point, force on the body)], angular acceleration, extra torque)
        links = [
            (0, 0.5 * (P["O2"] + P["B"]), 0.5 * (A["O2"] + A["B"]), [("O2", F["O2"]), ("B", F["B"])], "theta2",
             float(f.drive)),
            (1, 0.5 * (P["B"] + P["C"]), 0.5 * (A["B"] + A["C"]), [("B", -F["B"]), ("C", F["C"])], "theta3", 0.0),
            (2, 0.5 * (P["C"] + P["O4"]), 0.5 * (A["C"] + A["O4"]), [("C", -F["C"]), ("O4", F["O4"])], "theta4",
             TAU4),
        ]
        scale = max(np.abs(list(F.values())).max(), abs(float(f.drive)) / 0.01)
        for k, gpos, acc, forces_, ang, tq in links:
            res_f = sum(fv for _, fv in forces_) + MASS[k] * g - MASS[k] * acc
            res_m = sum(cross(P[p] - gpos, fv) for p, fv in forces_) + tq - INERTIA[k] * alpha[ang]
            assert np.max(np.abs(res_f)) <= 1e-9 * scale
            assert abs(res_m) <= 1e-9 * scale * 0.1
        # the frame reactions (pins O2, O4; the driver is a couple) are minus the shaking force,
        # which is Σ m a_G − Σ m g (no external forces on this model)
        reactions = F["O2"] + F["O4"]
        np.testing.assert_allclose(reactions, -np.array([row["shaking_force_x"], row["shaking_force_y"]]),
                                   rtol=1e-12, atol=1e-12 * scale)
        inertial = sum(MASS[k] * (acc - g) for k, _, acc, *_ in links)
        np.testing.assert_allclose(reactions, inertial, rtol=1e-9, atol=1e-9 * scale)

    @pytest.mark.parametrize("path", MODELS, ids=[p.stem for p in MODELS])
    def test_sum_of_frame_reactions_is_minus_shaking(self, path):
        """Σ (m a_G − m g) − external loads = frame pins + guides + driver = −shaking force."""
        mech = ls.load(path)
        f = ls.forces(mech, 0, 360, 45)
        data = inverse_dynamics(compile_dynamics(mech), f.sweep.z, f.sweep.z1[:, f.sweep.compiled.input_idx[0]],
                                f.sweep.z2[:, f.sweep.compiled.input_idx[0]])
        assert np.max(np.abs(data["residual"])) <= 1e-9 * np.max(data["force_scale"])
        assert np.all(np.isfinite(f.shaking_force))


@pytest.fixture(scope="module")
def free_fourbar():
    """The four-bar without loads (a module-level fixture: pytest deprecates class-scoped fixture methods)."""
    spec = ls.model.mechanism.deep_copy(fourbar_dynamics().spec)
    spec.pop("loads")
    return ls.build_mechanism(spec)


class TestSimulate:
    def test_free_motion_conserves_energy(self, free_fourbar):
        sim = ls.simulate(free_fourbar, 2.0, step=0.1, at=60, speed0=2.0)
        e = sim.total_energy
        assert len(sim.t) == 21 and not sim.events
        assert np.ptp(e) <= 1e-8 * np.max(np.abs(e))
        assert set(sim.modes) == {sim.modes[0]}

    def test_limit_position_is_an_event(self):
        """Driving the engine by its piston: the piston's dead centre stops the integration, reported."""
        spec = ls.model.mechanism.deep_copy(ls.load(ls.models_dir() / "engine_slider_crank.toml").spec)
        spec.pop("loads")
        sim = ls.simulate(ls.build_mechanism(spec), 0.3, step=0.05, input="r1", at=150, speed0="500mm/s")
        assert [e.kind for e in sim.events] == [ls.EventKind.LIMIT]
        assert 0.05 < sim.events[0].input < 0.1 and len(sim.t) == 2
        assert np.ptp(sim.total_energy) <= 1e-8 * np.max(np.abs(sim.total_energy))

    def test_inverse_dynamics_torque_keeps_speed_constant(self):
        mech = fourbar_dynamics()
        w = 2 * math.pi  # 60 rpm
        ck = mech.compile()
        dm = compile_dynamics(mech, compiled=ck)
        state = {"z": mech.solve(30).z}

        def torque(t, x, xd):
            z = state["z"].copy()
            z[0] = x
            s = mech.solve(math.degrees(x), guess={"theta3": z[1], "theta4": z[2]}, compiled=ck)
            state["z"] = s.z
            return float(inverse_dynamics(dm, s.z[None, :], w, 0.0)["drive"][0])

        sim = ls.simulate(mech, 0.5, step=0.05, at=30, speed0=w, torque=torque)
        np.testing.assert_allclose(sim.xd, w, rtol=1e-8)
        np.testing.assert_allclose(sim.x, 30 + math.degrees(w) * sim.t, rtol=1e-8)  # degrees, as the CLI


class TestFlywheel:
    def test_flywheel_of_a_pure_harmonic_torque(self):
        """Crank alone, gravity: T = m g e cos θ at constant speed; ΔE = 2 m g e exactly."""
        m, e = 0.7, 0.04
        b = ls.MechanismBuilder("crank", length_unit="m", angle_unit="deg")
        b.parameter("e", e).variable("theta", input=True, guess=0).variable("phi", guess=0)
        b.variable("L", guess=e).vector("r", length="e", angle="theta").vector("s", length="L", angle="phi")
        b.loop("r = s")
        b.point("O", "0")
        b.body("crank", mass=m, inertia=1e-3, com="r", angle="theta", joints=["O"])
        mech = b.gravity(0, -G).build()
        fw = ls.forces(mech, 0, 360, 0.5, speed=10.0).flywheel(0.05)
        de = 2 * m * G * e
        assert fw.mean_torque == pytest.approx(0, abs=1e-12)
        assert fw.energy_fluctuation == pytest.approx(de, rel=1e-5)
        assert fw.inertia == pytest.approx(de / (0.05 * 100), rel=1e-5)
        assert fw.at_max == pytest.approx(90) and fw.at_min == pytest.approx(270)

    def test_flywheel_needs_a_full_cycle(self):
        mech = ls.load(ls.models_dir() / "thesis_crank_rocker_dynamics.toml")
        with pytest.raises(ls.ModelError, match="full cycle"):
            ls.forces(mech, 0, 180, 10).flywheel(0.02)


BAD = """
name = "bad"
units = {{ length = "mm", angle = "deg" }}
[parameters]
r1 = 60
r2 = 25
r3 = 70
r4 = 45
[variables]
theta2 = {{ input = true, guess = 90 }}
theta3 = {{ guess = 20 }}
theta4 = {{ guess = 80 }}
[vectors]
r1 = {{ length = "r1", angle = 0 }}
r2 = {{ length = "r2", angle = "theta2" }}
r3 = {{ length = "r3", angle = "theta3" }}
r4 = {{ length = "r4", angle = "theta4" }}
[[loops]]
equation = "r2 + r3 = r1 + r4"
[points]
B = "r2"
C = "r2 + r3"
[bodies]
{bodies}
[[loads]]
body = "{load_body}"
torque = "-2N*m"
"""


class TestBadDeclarations:
    def test_all_problems_at_once(self, tmp_path):
        bodies = "\n".join([
            'crank = { mass = "0.3kg", inertia = "1e-4kg*m^2", com = "0.5*r2", angle = "theta9", joints = ["B"] }',
            'coupler = { mass = "0.8kg", inertia = "1e-3kg*m^2", com = "r2 + 0.5*r8", angle = "theta3", joints = ["B", "Q"] }',
            'rocker = { mass = "-1kg", inertia = "-3kg*m^2", com = "r1 + 0.5*r4", angle = "theta4", joints = ["C"] }',
        ])
        path = tmp_path / "bad.toml"
        path.write_text(BAD.format(bodies=bodies, load_body="wheel"))
        with pytest.raises(ls.ModelFileError) as exc:
            ls.load(path)
        msg = str(exc.value)
        for key, words in (("bodies.crank.angle", "theta9"), ("bodies.coupler.com", "r8"),
                           ("bodies.coupler.joints", "'Q' is not a point"), ("bodies.rocker.mass", "positive"),
                           ("bodies.rocker.inertia", "negative"), ("loads[0].body", "'wheel'")):
            line = next((ln for ln in msg.splitlines() if key in ln), "")
            assert words in line, (key, msg)
        assert "bad.toml" in msg

    def test_cli_exits_2_with_one_line(self, tmp_path):
        path = tmp_path / "bad.toml"
        path.write_text(BAD.format(bodies='crank = { mass = 0, com = "r9", joints = ["Z"] }', load_body="crank"))
        r = subprocess.run([sys.executable, "-m", "loopsolve.cli", "forces", str(path), "--at", "30"],
                           capture_output=True, text=True)
        assert r.returncode == 2
        assert len(r.stderr.strip().splitlines()) == 1
        assert "bodies.crank" in r.stderr and "bad.toml" in r.stderr

    def test_model_without_bodies(self):
        with pytest.raises(ls.ModelError, match=r"no \[bodies\]"):
            ls.forces(ls.load(ls.models_dir() / "thesis_crank_rocker.toml"), 30)

    def test_units_of_mass_properties(self):
        q = ls.bodies.parse_mech_quantity
        assert q("2lb", "mass") == pytest.approx(0.90718474)
        assert q("1.2lbf", "force") == pytest.approx(5.33786594)
        assert q("3e5g*mm^2", "inertia") == pytest.approx(3e-4)
        with pytest.raises(ls.ModelError, match="unit 'furlong' is a length unit, not a mass"):
            q("3 furlong", "mass")


class _Run:
    def __init__(self, returncode, stdout, stderr):
        self.returncode, self.stdout, self.stderr = returncode, stdout, stderr


class TestCommandLine:
    @pytest.fixture(autouse=True)
    def _capsys(self, capsys):
        self.capsys = capsys

    def run(self, *args):
        """The CLI in this process (the derivation memo is shared; one subprocess test is in TestBadDeclarations)."""
        from loopsolve.cli import main

        self.capsys.readouterr()
        code = main([str(a) for a in args])
        out = self.capsys.readouterr()
        return _Run(code, out.out, out.err)

    def test_forces_json_sweep(self):
        model = ls.models_dir() / "engine_slider_crank.toml"
        r = self.run("forces", model, "--from", 0, "--to", 360, "--step", 90, "--format", "json", "--flywheel", 0.02)
        assert r.returncode == 0, r.stderr
        doc = json.loads(r.stdout)
        row = doc["rows"][1]
        for key in ("theta2", "r1", "input_torque", "F_O2_x", "F_B_y", "F_C_x", "shaking_force_x",
                    "shaking_force_y", "shaking_moment", "kinetic_energy", "potential_energy"):
            assert key in row
        assert doc["units"]["input_torque"] == "N*m" and doc["units"]["F_C_x"] == "N"
        assert doc["flywheel"]["inertia"] > 0
        assert len(doc["rows"]) == 5

    def test_forces_csv_and_table(self):
        model = ls.models_dir() / "shaper_dynamics.toml"
        r = self.run("forces", model, "--at", 45, "--format", "csv")
        assert r.returncode == 0, r.stderr
        header = r.stdout.splitlines()[0]
        assert "input_torque [N*m]" in header and "F_E_x [N]" in header and "kinetic_energy [J]" in header
        r = self.run("forces", model, "--at", 45)
        assert r.returncode == 0 and "driving torque" in r.stdout

    def test_length_input_gives_input_force(self):
        model = ls.models_dir() / "engine_slider_crank.toml"
        r = self.run("forces", model, "--input", "r1", "--at", 150, "--speed", "100mm/s", "--format", "json")
        assert r.returncode == 0, r.stderr
        row = json.loads(r.stdout)["rows"][0]
        assert "input_force" in row and "input_torque" not in row

    def test_simulate_cli(self):
        model = ls.models_dir() / "thesis_crank_rocker_dynamics.toml"
        r = self.run("simulate", model, "--duration", 0.04, "--step", 0.02, "--torque", "0.05 - 0.001*theta2_vel",
                     "--format", "json")
        assert r.returncode == 0, r.stderr
        doc = json.loads(r.stdout)
        assert [row["t"] for row in doc["rows"]] == [0.0, 0.02, 0.04]
        assert {"theta2", "theta2_vel", "theta2_acc", "kinetic_energy", "potential_energy"} <= set(doc["rows"][0])
        r = self.run("simulate", model, "--duration", 1, "--torque", "import os")
        assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1


class TestPlots:
    def test_force_plots(self, tmp_path):
        pytest.importorskip("matplotlib")
        mech = ls.load(ls.models_dir() / "engine_slider_crank.toml")
        fs = ls.forces(mech, 0, 360, 10)
        assert fs.plot_torque().axes[0].get_ylabel() == "input_torque [N*m]"
        assert len(fs.plot_joint_forces(joints=["B", "C"]).axes) == 2
        fs.plot_shaking(output=tmp_path / "s.svg")
        assert (tmp_path / "s.svg").stat().st_size > 0
        from loopsolve.cli import main

        assert main(["forces", str(mech.source), "--from", "0", "--to", "360", "--step", "30", "--plot",
                     str(tmp_path / "f.png"), "-o", str(tmp_path / "f.txt")]) == 0
        assert (tmp_path / "f.png").stat().st_size > 0
        with pytest.raises(ls.ModelError, match="needs a sweep"):
            ls.forces(mech, 30).plot_torque()


class TestLatex:
    def test_equation_of_motion_section(self):
        tex = ls.load(ls.models_dir() / "engine_slider_crank.toml").to_latex()
        assert r"\section*{Equation of motion}" in tex
        assert r"M(\theta_{2})\,\ddot{\theta}_{2} + \tfrac{1}{2} M'(\theta_{2})\,\dot{\theta}_{2}^2 &= Q + T" in tex
        assert r"\theta'_{3}" in tex  # kinematic coefficients, not rates
        assert "Equation of motion" not in ls.load(ls.models_dir() / "thesis_crank_rocker.toml").to_latex()


def test_a_load_outside_its_domain_is_named_not_called_a_dead_centre():
    """A torque sqrt(θ − 1) is NaN for θ < 1 rad: those rows are flagged with an event that blames the load.

    The crank (mass 2 kg at e = 0.05 m, no inertia of its own) is nowhere near a dead centre, so the
    event must not say so; elsewhere T = m e² α + m g e cos θ − sqrt(θ − 1).
    """
    b = ls.MechanismBuilder("crank", length_unit="m", angle_unit="rad")
    b.parameter("e", 0.05).parameter("d", 0.1)
    b.variable("theta", input=True, guess=0.3).variable("phi", guess=0.3).variable("L", guess=0.05)
    b.vector("r", length="e", angle="theta").vector("s", length="L", angle="phi").vector("a", length="d", angle=0)
    b.loop("r = s").point("O", "0")
    b.body("crank", mass=2.0, inertia=0.0, com="r", angle="theta", joints=["O"])
    mech = b.load(body="crank", torque="sqrt(theta - 1)").gravity(0, -9.81).build()
    with np.errstate(invalid="ignore"):
        f = ls.forces(mech, 0, 2, 0.5, speed=2.0, accel=1.5)
    th = np.asarray(f.sweep["theta"], dtype=float)
    events = {round(ev.input, 9): ev.message for ev in f.events if ev.kind.value == "singular"}
    assert sorted(events) == [0.0, 0.5]
    assert all("not a finite number" in m and "loads" in m and "dead centre" not in m for m in events.values())
    ok = th >= 1
    want = 2.0 * 0.05**2 * 1.5 + 2.0 * 9.81 * 0.05 * np.cos(th[ok]) - np.sqrt(th[ok] - 1)
    np.testing.assert_allclose(f.drive[ok], want, rtol=1e-11)
