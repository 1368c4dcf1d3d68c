"""The equation of motion in symbols (:mod:`loopsolve.dynamics.eom`) and its LaTeX section (:mod:`loopsolve.output.latex_dynamics`).

Independent references written here: the numeric M, M′ and Q of :mod:`loopsolve.dynamics.dynamics_model` and
:mod:`loopsolve.dynamics.kinetostatics` (the code the force analysis and the simulations run, itself checked
against Newton–Euler and Kane's method in test_forces.py) on every shipped model with bodies, with
springs, dampers and rate-dependent loads added, and for a length input; the four-bar's M from the
kinetic energy of three rigid bodies built with sympy.physics.mechanics (M = 2T/θ̇₂²), its M′ by the
chain rule and its Q from the potential energy of gravity and the virtual work of the torque; the
driving torque printed with ``--at`` against the Newton–Euler torque of ``ls.forces``; and the PDF
read back with pdftotext.
"""

from __future__ import annotations

import re

import numpy as np
import pytest
import sympy as sp

import loopsolve as ls
from loopsolve.dynamics.dynamics_model import compile_dynamics, kinematic_coefficients, mass_matrix_terms
from loopsolve.dynamics.kinetostatics import generalized_force
from loopsolve.output.latex import to_latex, write_pdf

from support.latex import pdf_text, require
from support.models import with_extra_loads

MODELS = [p for p in sorted(ls.models_dir().glob("*.toml")) if ls.load(p).dynamics is not None]
THESIS = ls.models_dir() / "thesis_crank_rocker_dynamics.toml"


def test_every_shipped_dynamics_model_is_covered():
    names = {p.name for p in MODELS}
    assert {"thesis_crank_rocker_dynamics.toml", "engine_slider_crank.toml", "shaper_dynamics.toml",
            "thesis_crank_rocker_dynamics_diagram.toml"} <= names


# ------------------------------------------------------------------ symbolic = numeric
def _cases():
    for p in MODELS:
        yield pytest.param(p, False, None, id=p.stem)
        yield pytest.param(p, True, None, id=p.stem + "+springs")
    yield pytest.param(ls.models_dir() / "engine_slider_crank.toml", True, "r1", id="engine-length-input")


@pytest.mark.parametrize("path, extra, inp", list(_cases()))
def test_symbolic_equals_numeric(path, extra, inp):
    """M, M′ and Q with the substitution dict applied = the compiled numbers, at 50 random inputs."""
    mech = ls.load(path)
    if extra:
        mech = with_extra_loads(mech)
    d = mech.derive_dynamics(inp)
    ck = mech.compile(inp)
    dm = compile_dynamics(mech, compiled=ck)
    kin = d.kinematics
    assert tuple(kin.unknowns) == tuple(ck.unknowns)
    iq = [ck.index(n) for n in kin.unknowns]
    args = list(kin.z) + list(d.first) + list(d.second) + [d.xdot]
    exprs = [d.subs(d.M), d.subs(d.dM), d.subs(d.Q)]
    for e in exprs:  # nothing left but the pose, the coefficients and the input speed
        assert e.free_symbols <= set(args)
    fn = sp.lambdify(args, exprs, modules="numpy")
    # the size of every term of every sum, to judge a sum that nearly cancels (Q, M′)
    terms = [[d.subs((sp.Mul(*g.factor) * t.coef * t.kin).xreplace(d.coefficients)) for g in d.groups[key]
              for t in g.terms] for key in ("M", "dM", "Q")]
    sizes = [sp.lambdify(args, ts, modules="numpy") for ts in terms]
    rng = np.random.default_rng(2026)
    xs = rng.uniform(110, 170, 50) if inp == "r1" else rng.uniform(0, 360, 50)
    for x in xs:
        s = mech.solve(float(x), input=inp, compiled=ck)
        z = s.z[None, :]
        d1, d2 = kinematic_coefficients(ck, z)
        M, dM = mass_matrix_terms(dm, z, d1, d2)
        xd = float(rng.uniform(-20, 20))
        Q = generalized_force(dm, z, xd, d1)
        point = (*z[0], *d1[0, iq], *d2[0, iq], xd)
        got = fn(*point)
        for name, g, want, size in zip(("M", "M'", "Q"), got, (M[0], dM[0], Q[0]), sizes):
            scale = float(np.sum(np.abs(size(*point))))
            assert abs(g - want) <= 1e-12 * max(scale, abs(want)), (name, x, g, want, scale)


def test_named_symbols_and_values():
    d = ls.derive_dynamics(ls.load(THESIS))
    byname = {str(s): s for s in d.values}
    for body in ("crank", "coupler", "rocker"):
        assert byname[f"m_{body}"] in d.M.free_symbols and byname[f"I_{body}"] in d.M.free_symbols
        assert byname[f"m_{body}"] in d.Q.free_symbols  # gravity
    assert d.values[byname["lambda"]] == pytest.approx(1e-3)
    assert d.values[byname["g"]] == pytest.approx(9.81)
    assert d.values[byname["T_rocker"]] == pytest.approx(-0.05)
    assert d.values[byname["m_crank"]] == pytest.approx(7850 * 0.025 * 0.008 * 0.004)
    assert d.values[byname["r2"]] == 25.0
    # the unit conversion is one factor, never folded: every mass term carries lambda², and no
    # number of the model's mass properties appears in M
    lam = byname["lambda"]
    for term in sp.Add.make_args(sp.expand(d.M)):
        if any(m in term.free_symbols for m in d.mass.values()):
            assert term.as_powers_dict()[lam] == 2
        else:
            assert lam not in term.free_symbols
    assert not [f for f in sp.expand(d.M).atoms(sp.Float) if f not in (0.25, 0.5, 1.0)]  # the com factors 0.5
    # the kinematic coefficients are the documented symbols
    assert [str(s) for s in d.first] == ["theta3__p1", "theta4__p1"]
    assert [str(s) for s in d.second] == ["theta3__p2", "theta4__p2"]


def test_metre_model_has_no_length_factor():
    b = ls.MechanismBuilder("pendulum crank", length_unit="m", angle_unit="rad")
    b.parameter("e", 0.2).parameter("d", 0.5)
    b.variable("theta", input=True, guess=0.3).variable("phi", guess=0.3).variable("L", guess=0.4)
    b.vector("r", length="e", angle="theta").vector("s", length="L", angle="phi").vector("a", length="d", angle=0)
    b.loop("r = s + a").point("O", "0")
    b.body("crank", mass=2.0, inertia=0.01, com="r", angle="theta", joints=["O"])
    d = b.gravity(0, -9.81).build().derive_dynamics()
    names = {str(s) for s in d.M.free_symbols | d.Q.free_symbols}
    assert "lambda" not in names
    th, e, m, ii, g = (sp.Symbol(n, real=True) for n in ("theta", "e", "m_crank", "I_crank", "g"))
    assert sp.simplify(d.M - (m * e**2 + ii)) == 0
    assert sp.simplify(d.Q - (-m * g * e * sp.cos(th))) == 0


def test_without_bodies_is_a_model_error():
    with pytest.raises(ls.ModelError, match=r"no \[bodies\]"):
        ls.load(ls.models_dir() / "thesis_crank_rocker.toml").derive_dynamics()


# ------------------------------------------------------------------ sympy.physics.mechanics
@pytest.fixture(scope="module")
def thesis_reference():
    """M, M′ and Q of the thesis four-bar from sympy.physics.mechanics (rigid bodies, kinetic energy)."""
    me = pytest.importorskip("sympy.physics.mechanics")
    real = {"real": True}
    lam, g, r1, r2, r3, r4 = (sp.Symbol(n, **real) for n in ("lambda", "g", "r1", "r2", "r3", "r4"))
    th = [sp.Symbol(f"theta{i}", **real) for i in (2, 3, 4)]
    p1 = [sp.Integer(1)] + [sp.Symbol(f"theta{i}__p1", **real) for i in (3, 4)]
    p2 = [sp.Integer(0)] + [sp.Symbol(f"theta{i}__p2", **real) for i in (3, 4)]
    m = {b: sp.Symbol(f"m_{b}", **real) for b in ("crank", "coupler", "rocker")}
    ii = {b: sp.Symbol(f"I_{b}", **real) for b in ("crank", "coupler", "rocker")}
    t_rocker = sp.Symbol("T_rocker", **real)
    q = me.dynamicsymbols("q2 q3 q4")
    N = me.ReferenceFrame("N")
    A = [N.orientnew(f"A{i}", "Axis", [qi, N.z]) for i, qi in zip((2, 3, 4), q)]
    O2 = me.Point("O2")
    O2.set_vel(N, 0)
    O4 = O2.locatenew("O4", lam * r1 * N.x)
    O4.set_vel(N, 0)
    B = O2.locatenew("B", lam * r2 * A[0].x)
    B.v2pt_theory(O2, N, A[0])
    G = [O2.locatenew("G2", lam * r2 / 2 * A[0].x), B.locatenew("G3", lam * r3 / 2 * A[1].x),
         O4.locatenew("G4", lam * r4 / 2 * A[2].x)]
    for Gp, base, frame in zip(G, (O2, B, O4), A):
        Gp.v2pt_theory(base, N, frame)
    bodies = [me.RigidBody(b, Gp, frame, m[b], (me.inertia(frame, 0, 0, ii[b]), Gp))
              for b, Gp, frame in zip(("crank", "coupler", "rocker"), G, A)]
    w = sp.Symbol("w", positive=True)  # θ̇₂; θ̇ⱼ = θ′ⱼ θ̇₂
    t = me.dynamicsymbols._t
    at_pose = {**{qi.diff(t): pj * w for qi, pj in zip(q, p1)}}
    kinetic = sum(b.kinetic_energy(N) for b in bodies).subs(at_pose).subs(dict(zip(q, th)))
    M = sp.expand(sp.simplify(2 * kinetic / w**2))
    potential = sum(m[b] * g * Gp.pos_from(O2).dot(N.y) for b, Gp in zip(("crank", "coupler", "rocker"), G))
    potential = potential.subs(dict(zip(q, th)))

    def d_dx(e):  # total derivative along the motion: θⱼ′ and θⱼ″ are functions of θ₂ too
        return (sum(sp.diff(e, a) * b for a, b in zip(th, p1))
                + sum(sp.diff(e, a) * b for a, b in zip(p1[1:], p2[1:])))

    Q = -d_dx(potential) + t_rocker * p1[2]
    return {"M": M, "dM": d_dx(M), "Q": Q, "masses": list(m.values()) + list(ii.values())}


def _same(a, b) -> bool:
    return sp.simplify(sp.expand_trig(sp.expand(sp.nsimplify(a, rational=True) - b))) == 0


class TestAgainstMechanics:
    def test_mass_matrix_term_by_term(self, thesis_reference):
        d = ls.load(THESIS).derive_dynamics()
        ref = thesis_reference
        assert {str(s) for s in ref["masses"]} == {str(s) for s in list(d.mass.values()) + list(d.inertia.values())}
        for s in ref["masses"]:  # the coefficient of every mass and every inertia
            assert _same(sp.expand(d.M).coeff(s), ref["M"].coeff(s)), s
        assert _same(d.M, ref["M"])

    def test_derivative_and_generalized_force(self, thesis_reference):
        d = ls.load(THESIS).derive_dynamics()
        for s in thesis_reference["masses"]:
            assert _same(sp.expand(d.dM).coeff(s), sp.expand(thesis_reference["dM"]).coeff(s)), s
        assert _same(d.Q, thesis_reference["Q"])


# ------------------------------------------------------------------ the LaTeX section
def _eom_section(tex: str) -> str:
    start = tex.index(r"\section*{Equation of motion}")
    end = tex.find(r"\section*", start + 10)
    return tex[start:] if end < 0 else tex[start:end]


class TestLatexSection:
    def test_thesis_symbols_then_numbers(self):
        tex = to_latex(ls.load(THESIS))
        sec = _eom_section(tex)
        for body in ("crank", "coupler", "rocker"):
            assert r"m_{\mathrm{%s}} = " % body in sec and r"I_{\mathrm{%s}} = " % body in sec
        assert r"\lambda = 0.001\,\mathrm{m/mm}" in sec and r"g = 9.81\,\mathrm{m/s^{2}}" in sec
        # the sentence over that table names its three kinds of rows (the model has gravity, a torque, mm)
        assert "Gravity, the loads and the unit of length:" in sec
        assert r"T_{\mathrm{rocker}} = -0.05\,\mathrm{N\,m}" in sec
        # the symbolic sums, then the same with numbers: textbook signs, lambda a factor
        assert r"Q(\theta_{2}) &= - \lambda g\Bigl[m_{\mathrm{crank}}\,y'_{G_{\mathrm{crank}}}" in sec
        assert r"+ T_{\mathrm{rocker}}\,\theta'_{4}" in sec
        assert r"Q(\theta_{2}) &= - 9.81 \lambda\Bigl[0.00628\,y'_{G_{\mathrm{crank}}}" in sec
        assert r"- 0.05\,\theta'_{4}" in sec
        assert r"M(\theta_{2}) &= \lambda^{2}\Bigl[m_{\mathrm{crank}}" in sec
        assert not re.search(r"\de-\d", sec) and r"+ \left(-" not in sec and "+ -" not in sec
        assert r"6.28 \times 10^{-9}" not in sec  # m λ² folded into one number (the old output)

    def test_springs_and_dampers_are_named(self):
        sec = _eom_section(to_latex(with_extra_loads(ls.load(THESIS))))
        for sym in (r"k_{\mathrm{B,O4}} = 300\,\mathrm{N/m}", r"c_{\mathrm{B,O4}} = 2\,\mathrm{N\,s/m}",
                    r"k_{\mathrm{rocker}} = 0.4\,\mathrm{N\,m/rad}", r"\theta_{0,\mathrm{rocker}} = 10^{\circ}",
                    r"g_{x} = 0.7", r"g_{y} = -9.81", r"L_{\mathrm{B,O4}} &= \sqrt{"):
            assert sym in sec, sym
        assert r"Q(\theta_{2}, \dot{\theta}_{2})" in sec  # dampers: Q depends on the speed
        # the numbers inside the kinematic parts, with their signs
        for num in (r"\left(0.7\,x'_{G_{\mathrm{crank}}} - 9.81\,y'_{G_{\mathrm{crank}}}\right)",
                    r"\left(L_{\mathrm{B,O4}} - 10\right) L'_{\mathrm{B,O4}}", r"\left(\theta_{4} - 10^{\circ}\right)"):
            assert num in sec, num
        assert "+ -" not in sec and r"+ \left(-" not in sec

    def test_at_gives_the_driving_torque_of_newton_euler(self):
        mech = ls.load(THESIS)
        tex = to_latex(mech, at=60)
        sec = tex[tex.index(r"\section*{Equation of motion at the given input}"):]
        value = float(re.search(r"- Q &= (-?[0-9.]+(?: \\times 10\^\{-?\d+\})?)", sec).group(1)
                      .replace(r" \times 10^{", "e").replace("}", ""))
        want = float(ls.forces(mech, 60)["input_torque"])  # Newton–Euler, at the model's 10 rpm
        assert value == pytest.approx(want, rel=1e-5)
        for head in ("M &= ", "M' &= ", "Q &= "):
            assert head in sec
        assert r"\mathrm{kg\,m^{2}}" in sec and r"\mathrm{N\,m}" in sec

    def test_length_input_is_per_metre(self):
        """Driven by the piston (x = r1 in mm): M in kg, the inertias divided by λ², M′ per metre."""
        sec = _eom_section(to_latex(ls.load(ls.models_dir() / "engine_slider_crank.toml"), input="r1"))
        assert r"M(r_{1}) &= m_{\mathrm{crank}}" in sec
        assert r"\frac{1}{\lambda^{2}}\Bigl[I_{\mathrm{crank}}" in sec and r"M'(r_{1}) &= \frac{2}{\lambda}\Bigl[" in sec
        assert r"Q(r_{1}) &= - g\,m_{\mathrm{rod}}\,y'_{G_{\mathrm{rod}}} + F_{\mathrm{gas},x}\,x'_{C}" in sec

    @pytest.mark.parametrize("path", MODELS, ids=[p.stem for p in MODELS])
    def test_pdf_compiles_and_reads_like_the_notes(self, path, tmp_path):
        require("pdflatex", "pdftotext")
        mech = ls.load(path)
        pdf = write_pdf(to_latex(mech, at=mech.variable(mech.inputs[0]).guess), tmp_path / "eom.pdf")
        text = pdf_text(pdf)
        sec = text[text.index("Equation of motion"):text.index("Numeric solution")]
        flat = sec.replace(" ", "")
        for body in mech.dynamics.bodies:
            assert "m" + body.name + "=" in flat, body.name  # m_crank = 0.00628 kg
        for bad in ("+ (−", "+ −", "+ -", "+ (-"):
            assert bad not in sec, bad
        assert "λ" in sec and "Equation of motion at the given input" in text
