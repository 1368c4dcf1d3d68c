"""The Python builder and the TOML model file are two front doors to the same declaration.

Hand-written builder declarations of shipped models, and a replay of every model file through
the builder's methods, must give the same Mechanism, the same symbolic derivation (Φ, Φ_q,
b1..b3, points: ``simplify(a - b) == 0``) and the same solved numbers.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

import loopsolve as ls
from loopsolve.symbolic.compiled import structure_key

MODELS = sorted(ls.models_dir().glob("*.toml"))


def thesis_builder():
    b = ls.MechanismBuilder("Crank-rocker four-bar", length_unit="mm", angle_unit="deg")
    for n, v in (("r1", 60), ("r2", 25), ("r3", 70), ("r4", 45)):
        b.parameter(n, v)
    b.variable("theta2", input=True, guess=90, speed="10rpm")
    b.variable("theta3", guess=20).variable("theta4", guess=80)
    b.vector("r1", length="r1", angle=0).vector("r2", length="r2", angle="theta2")
    b.vector("r3", length="r3", angle="theta3").vector("r4", length="r4", angle="theta4")
    b.loop("r2 + r3 = r1 + r4").point("B", "r2").point("C", "r2 + r3")
    return b.mode("open", "-").mode("crossed", "+").build()


def example1_builder():
    b = ls.MechanismBuilder("Example 1 slider-crank", length_unit="in", angle_unit="deg")
    b.parameter("r2", 5).parameter("r3", 8)
    b.variable("theta2", input=True, guess=45, speed="10rad/s", accel=0)
    b.variable("theta3", guess=-26).variable("r1", guess=10.7)
    b.vector("r1", length="r1", angle=0).vector("r2", length="r2", angle="theta2")
    b.vector("r3", length="r3", angle="theta3")
    return b.loop("r2 + r3 = r1").point("B", "r2").point("C", "r1").build()


def quick_return_builder():
    b = ls.MechanismBuilder("Crank and slotted lever quick-return", length_unit="mm", angle_unit="deg")
    b.parameter("r2", 100).parameter("d", 200)
    b.variable("theta2", input=True, guess=0, speed="60rpm")
    b.variable("theta4", guess=63.4).variable("s", guess=223.6)
    b.vector("r1", length="d", angle=90).vector("r2", length="r2", angle="theta2")
    b.vector("r4", length="s", angle="theta4")
    return b.loop("r1 + r2 = r4").point("O2", "r1").point("A", "r1 + r2").build()


HAND = {
    "thesis_crank_rocker": thesis_builder,
    "example1_slider_crank": example1_builder,
    "quick_return": quick_return_builder,
}


def replay(mech: ls.Mechanism) -> ls.Mechanism:
    """Rebuild a loaded model by calling the builder's methods on its declaration."""
    spec = mech.spec
    units = spec.get("units", {})
    b = ls.MechanismBuilder(spec.get("name", "mechanism"), length_unit=units.get("length", "mm"),
                            angle_unit=units.get("angle", "deg"))
    for n, v in spec.get("parameters", {}).items():
        b.parameter(n, v)
    for n, v in spec.get("variables", {}).items():
        b.variable(n, **v)
    for n, v in spec.get("vectors", {}).items():
        b.vector(n, **{k: x for k, x in v.items() if k != "link"})
    for lp in spec.get("loops", []):
        b.loop(lp["equation"], name=lp.get("name"))
    for n, v in spec.get("points", {}).items():
        b.point(n, v)
    for n, v in spec.get("modes", {}).items():
        b.mode(n, v)
    for n, v in spec.get("constraints", {}).items():
        b.constraint(n, v)
    for section, method in (("gears", b.gear), ("cams", b.cam), ("slots", b.slot), ("rolling", b.rolling)):
        for n, v in spec.get(section, {}).items():
            method(n, **v)
    return b.build()


def _same_derivation(m1, m2, input=None):
    k1, k2 = m1.derive(input), m2.derive(input)
    assert k1.variables == k2.variables and k1.unknowns == k2.unknowns and k1.inputs == k2.inputs
    assert k1.param_names == k2.param_names and k1.param_values == k2.param_values
    pairs = [(k1.phi, k2.phi), (k1.jac, k2.jac), (k1.jac_inputs, k2.jac_inputs)] + list(zip(k1.rhs, k2.rhs))
    for name in k1.points:
        pairs += list(zip(k1.points[name], k2.points[name]))
    for a, b in pairs:
        assert a.shape == b.shape
        assert sp.simplify(a - b) == sp.zeros(*a.shape)
    return k1, k2


def _declaration(m):
    return (m.name, m.units, m.parameters, m.variables, m.vectors, m.loops, m.points, dict(m.mode_aliases),
            m.n_equations, m.equation_names)


@pytest.mark.parametrize("stem", HAND)
def test_hand_written_builder_equals_model_file(stem):
    from_file = ls.load(ls.models_dir() / f"{stem}.toml")
    built = HAND[stem]()
    assert _declaration(built) == _declaration(from_file)
    _same_derivation(built, from_file)
    ck_b, ck_f = built.compile(), from_file.compile()
    assert structure_key(built, built.inputs) == structure_key(from_file, from_file.inputs)
    for at in np.linspace(0, 350, 8):
        s_b, s_f = built.solve(float(at), compiled=ck_b), from_file.solve(float(at), compiled=ck_f)
        assert s_b.row() == pytest.approx(s_f.row(), rel=1e-14, abs=1e-12)


@pytest.mark.parametrize("path", MODELS, ids=lambda p: p.stem)
def test_builder_replay_of_every_model_file(path):
    from_file = ls.load(path)
    built = replay(from_file)
    assert built.source is None and from_file.source == str(path)
    assert _declaration(built) == _declaration(from_file)
    s_b, s_f = built.solve(), from_file.solve()
    assert s_b.row() == pytest.approx(s_f.row(), rel=1e-14, abs=1e-12)


def test_builder_and_file_derivations_for_another_input():
    """The identity also holds for the inversion (slider position as input)."""
    built, from_file = example1_builder(), ls.load(ls.models_dir() / "example1_slider_crank.toml")
    k1, _ = _same_derivation(built, from_file, input="r1")
    assert k1.unknowns == ("theta2", "theta3")


def _thesis_variant(r3_angle, r4_angle, loop, point_c, guess3, guess4):
    b = ls.MechanismBuilder("Crank-rocker four-bar", length_unit="mm", angle_unit="deg")
    for n, v in (("r1", 60), ("r2", 25), ("r3", 70), ("r4", 45)):
        b.parameter(n, v)
    b.variable("theta2", input=True, guess=90, speed="10rpm").variable("theta3", guess=guess3)
    b.variable("theta4", guess=guess4)
    b.vector("r1", length="r1", angle=0).vector("r2", length="r2", angle="theta2")
    b.vector("r3", length="r3", angle=r3_angle).vector("r4", length="r4", angle=r4_angle)
    b.loop(loop).point("B", "r2").point("C", point_c)
    return b.mode("open", "-").mode("crossed", "+").build()


def test_equivalent_declarations_have_the_same_derivation():
    """−r3 e(θ3 + 180°) is r3 e(θ3): sympy proves the two declarations derive the same equations."""
    variant = _thesis_variant("theta3 + 180", "theta4", "r2 - r3 = r1 + r4", "r2 - r3", 20, 80)
    _same_derivation(variant, thesis_builder())


def test_derivation_comparison_detects_a_difference():
    """The symbolic comparison is not vacuous: the rocker drawn from the other pivot is caught."""
    variant = _thesis_variant("theta3", "theta4", "r2 + r3 = r1 - r4", "r2 + r3", 20, 260)
    with pytest.raises(AssertionError):
        _same_derivation(variant, thesis_builder())
    # ... although it is the same linkage: θ4 differs by 180°
    s = variant.solve(90)
    assert (s["theta4"] - thesis_builder().solve(90)["theta4"]) % 360 == pytest.approx(180, abs=1e-9)


def test_builder_rejects_like_the_file():
    b = ls.MechanismBuilder("bad").parameter("r1", 60).variable("theta2", input=True, guess=0)
    b.vector("r1", length="r1", angle="theta2").vector("r2", length="r2", angle=0).loop("r1 = r2")
    with pytest.raises(ls.ModelError, match=r"vectors\.r2\.length: unknown name 'r2'"):
        b.build()


def test_builder_declares_higher_pairs_and_friction_as_the_file_does():
    """A wheel on a journal with a constraint and friction, declared from Python, is the file's model: the same
    equations, and the same driving torque against the friction (r sin(atan mu) m g)."""
    from pathlib import Path

    import math

    from_file = ls.load(Path(__file__).parents[1] / "data" / "journal_wheel.toml")
    b = ls.MechanismBuilder("wheel on a journal bearing", length_unit="mm", angle_unit="deg")
    b.variable("theta", input=True, guess=0).variable("phi", guess=0, kind="angle")
    b.vector("spoke", length=50, angle="theta").point("O", "0").point("A", "spoke")
    b.constraint("mark", "phi = theta").gravity(0, "-9.81m/s^2")
    b.body("wheel", mass="2kg", inertia="0.01kg*m^2", com="O", angle="theta", joints=["O"])
    built = b.friction("O", mu=0.2, radius="20mm").build()
    assert built.equation_names == from_file.equation_names
    torque = ls.forces(built, at=30)["input_torque"]
    assert torque == pytest.approx(ls.forces(from_file, at=30)["input_torque"], rel=1e-12)
    assert torque == pytest.approx(0.020 * 0.2 / math.sqrt(1 + 0.2**2) * 2 * 9.81, rel=1e-9)
    with pytest.raises(ls.ModelError, match="friction.O"):
        b.friction("O", mu=0.1, radius="5mm")
