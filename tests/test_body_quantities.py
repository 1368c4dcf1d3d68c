"""Mass-property and load quantities: a malformed value is a ModelError whose example is valid.

Mutation testing of the force code (issue 18): a survivor dropped one kind from the table of
examples, so a malformed mass (``mass = "heavy"``) ended in an internal KeyError instead of
the message. For every kind the message must name an example, and that example must parse
as that kind to the SI value written here.
"""

from __future__ import annotations

import pytest

import loopsolve as ls
from loopsolve.bodies import MECH_UNITS, parse_mech_quantity
from loopsolve.errors import ModelError

# the example each message shows and its SI value, worked out by hand
EXAMPLES = {"mass": ("0.3kg", 0.3), "inertia": ("2.5e-4kg*m^2", 2.5e-4), "force": ("-50N", -50.0),
            "torque": ("2N*m", 2.0), "stiffness": ("200N/m", 200.0), "damping": ("5N*s/m", 5.0),
            "torsional stiffness": ("2N*m/rad", 2.0), "torsional damping": ("0.1N*m*s/rad", 0.1),
            "acceleration": ("-9.81m/s^2", -9.81), "density": ("7850kg/m^3", 7850.0)}


def test_every_kind_has_an_example():
    assert set(EXAMPLES) == set(MECH_UNITS)


@pytest.mark.parametrize("kind", sorted(EXAMPLES))
@pytest.mark.parametrize("bad", ["heavy", [1, 2], True])
def test_malformed_quantity_names_a_valid_example(kind, bad):
    text, si = EXAMPLES[kind]
    with pytest.raises(ModelError) as info:
        parse_mech_quantity(bad, kind)
    assert f'"{text}"' in str(info.value)
    assert parse_mech_quantity(text, kind) == pytest.approx(si, rel=1e-15)


def test_malformed_mass_in_a_model_file_is_a_model_error():
    text = (ls.models_dir() / "engine_slider_crank.toml").read_text(encoding="utf-8")
    import re

    bad, n = re.subn(r'mass = "[^"]+"', 'mass = "heavy"', text, count=1)
    assert n == 1
    with pytest.raises(ModelError, match=r'"0\.3kg"'):
        ls.loads(bad, source="heavy.toml")
