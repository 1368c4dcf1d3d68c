"""Mass-property and load quantities: a malformed value is a ModelError whose example is valid.

Mutation testing of the force code (issue 18): a survivor dropped one kind from the table of
examples, so a malformed mass (``mass = "heavy"``) ended in an internal KeyError instead of
the message. For every kind the message must name an example, and that example must parse
as that kind to the SI value written here.
"""

from __future__ import annotations

import pytest

import loopsolve as ls
from loopsolve.model.bodies import parse_mech_quantity
from loopsolve.errors import ModelError

# a value of each kind and its SI value, worked out by hand from the unit definitions
EXAMPLES = {"mass": ("0.3kg", 0.3), "inertia": ("2.5e-4kg*m^2", 2.5e-4), "force": ("-50N", -50.0),
            "torque": ("2N*m", 2.0), "stiffness": ("200N/m", 200.0), "damping": ("5N*s/m", 5.0),
            "torsional stiffness": ("2N*m/rad", 2.0), "torsional damping": ("0.1N*m*s/rad", 0.1),
            "acceleration": ("-9.81m/s^2", -9.81), "density": ("7850kg/m^3", 7850.0)}


@pytest.mark.parametrize("kind", sorted(EXAMPLES))
@pytest.mark.parametrize("bad", ["heavy", [1, 2], True])
def test_malformed_quantity_names_valid_example_units(kind, bad):
    """The message names the kind and example units; every example unit it names is one of that kind."""
    text, si = EXAMPLES[kind]
    with pytest.raises(ModelError) as info:
        parse_mech_quantity(bad, kind)
    msg = str(info.value)
    assert f"expected a{'n' if kind[0] in 'aeiou' else ''} {kind}" in msg
    units = msg.split("e.g. ", 1)[1].split(", ")
    assert len(units) >= 2
    for u in units:
        assert parse_mech_quantity(f"1 {u}", kind) > 0, u
    assert parse_mech_quantity(text, kind) == pytest.approx(si, rel=1e-15)


def test_malformed_mass_in_a_model_file_is_a_model_error():
    text = (ls.models_dir() / "engine_slider_crank.toml").read_text(encoding="utf-8")
    import re

    bad, n = re.subn(r'mass = "[^"]+"', 'mass = "heavy"', text, count=1)
    assert n == 1
    with pytest.raises(ModelError, match=r"^heavy\.toml: bodies\.crank\.mass: .*expected a mass.*e\.g\. kg"):
        ls.loads(bad, source="heavy.toml")


ENGINE = ls.models_dir() / "engine_slider_crank.toml"


def load_error(text: str) -> str:
    with pytest.raises(ModelError) as info:
        ls.loads(text, source="e.toml")
    return str(info.value)


def test_declaration_errors_name_the_key_and_what_to_write():
    """Each message names the exact key and the fix (mutation survivors of bodies.parse_dynamics
    changed only these messages: the SI unit of an expression, the key of a bar's density, the
    list of declared bodies)."""
    t = ENGINE.read_text(encoding="utf-8")
    msg = load_error(t.replace('force = ["-5.0265e-3*1e5', 'force = ["2 mm * -5.0265e-3*1e5'))
    assert msg.startswith("e.toml: loads[0].force[0]: ")
    assert "an expression is in SI (force in N); drop the unit 'mm'" in msg
    msg = load_error(t.replace('mass = "0.6kg", inertia = "1.6e-3kg*m^2"',
                               'bar = { length = 140, width = 20, thickness = 8, density = "heavy" }'))
    assert msg.startswith("e.toml: bodies.rod.bar.density: cannot read a number in 'heavy'; expected a density")
    msg = load_error(t.replace('body = "piston"', 'body = "nobody"', 1))
    assert msg == "e.toml: loads[0].body: 'nobody' is not a declared body (bodies: crank, piston, rod)"
    thesis = (ls.models_dir() / "thesis_crank_rocker_dynamics.toml").read_text(encoding="utf-8")
    msg = load_error(thesis.replace('torque = "-0.05N*m"', 'torque = "1 m * -0.05*cos(theta4)"'))
    assert "an expression is in SI (torque in N*m); drop the unit" in msg
