"""The compiled-code cache can never hand a model another model's numbers.

Compiled modules are cached in memory and on disk under :func:`loopsolve.symbolic.compiled.structure_key`.
Every field of a model file that changes a number must change that key (parameter values are
passed to the compiled code at run time, so they must *not* need to); and two processes that share
one ``LOOPSOLVE_CACHE_DIR`` must each get their own model's answer. Every expected value here is a
closed-form four-bar position (two circles' intersection) written in this file.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.symbolic import compiled
from loopsolve.symbolic.compiled import structure_key

from support.probe import assert_is_a_closure, fourbar_positions, model, model_text, solve_rad, wrap_angle

# A four-bar with a tilted ground link: rAB + rBC = rAD + rDC, crank AB driven by theta2.


def fresh(mech):
    """Compile as a new process would (no in-memory module), reading the shared disk cache."""
    compiled._MEMO.clear()
    return mech.compile()


# ----------------------------------------------------------------------------- every field is in the key

# each variant: (changes to the base model, closed-form closures at theta2 = 40 (model units))
DEG = math.pi / 180
VARIANTS = {
    "angle unit": (dict(angle="rad"),  # the ground angle 10 and the input 40 are now radians
                   lambda t2: fourbar_positions(20, 66, 56, 80, 10.0, t2 / DEG)),
    "length unit (a literal with a unit)": (dict(length="cm", ab_len="20mm"),
                                            lambda t2: fourbar_positions(2, 66, 56, 80, 10 * DEG, t2)),
    "vector length": (dict(ab_len="AB + 3"), lambda t2: fourbar_positions(23, 66, 56, 80, 10 * DEG, t2)),
    "vector angle (fixed)": (dict(gnd_angle="25"), lambda t2: fourbar_positions(20, 66, 56, 80, 25 * DEG, t2)),
    "vector angle (expression)": (dict(ab_angle="theta2 + 30"),
                                  lambda t2: fourbar_positions(20, 66, 56, 80, 10 * DEG, t2 + 30 * DEG)),
    "vector offset": (dict(dc_offset=", offset = 180", guesses=(0, 60, -80)),
                      lambda t2: [(t3, wrap_angle(t4 - math.pi)) for t3, t4 in
                                  fourbar_positions(20, 66, 56, 80, 10 * DEG, t2)]),
    "vector components": (dict(bc_vec='{ x = "BC*cos(theta3)", y = "BC*sin(theta3)" }'),
                          lambda t2: fourbar_positions(20, 66, 56, 80, 10 * DEG, t2)),
    "vector components (scaled)": (dict(bc_vec='{ x = "BC*cos(theta3)", y = "BC*sin(theta3)/2" }'),
                                   None),
    "loop": (dict(loop="rAB + rBC + rDC = rAD", guesses=(0, 60, -80)),
             lambda t2: [(t3, wrap_angle(t4 - math.pi)) for t3, t4 in
                         fourbar_positions(20, 66, 56, 80, 10 * DEG, t2)]),
    "points": (dict(points='B = "rAB"\nC = "rAD + rDC"'),
               lambda t2: fourbar_positions(20, 66, 56, 80, 10 * DEG, t2)),
}


@pytest.mark.parametrize("name", list(VARIANTS))
def test_every_field_that_changes_a_number_changes_the_key(name):
    base, other = model(), model(**VARIANTS[name][0])
    assert structure_key(base, base.inputs) != structure_key(other, other.inputs)


def test_each_component_is_in_the_key():
    plain = model(**VARIANTS["vector components"][0])
    for vec in ('{ x = "BC*cos(theta3)", y = "BC*sin(theta3)/2" }', '{ x = "BC*cos(theta3)/2", y = "BC*sin(theta3)" }'):
        other = model(bc_vec=vec)
        assert structure_key(plain, plain.inputs) != structure_key(other, other.inputs)


@pytest.mark.parametrize("name", [n for n, (_, f) in VARIANTS.items() if f is not None])
def test_a_variant_compiled_after_the_base_gets_its_own_numbers(name, tmp_path, monkeypatch):
    """Base and variant share a disk cache; the variant's solution is its own closed form."""
    monkeypatch.setattr(compiled, "_MEMO", {})
    monkeypatch.setenv("LOOPSOLVE_CACHE_DIR", str(tmp_path))
    changes, closed = VARIANTS[name]
    base, other = model(), model(**changes)
    assert_is_a_closure(*solve_rad(fresh(base).mechanism, 40.0),
                        fourbar_positions(20, 66, 56, 80, 10 * DEG, 40 * DEG))
    fresh(other)
    assert_is_a_closure(*solve_rad(other, 40.0), closed(40 * DEG))  # 40 in the model's unit
    # and the other way round: the base compiled after the variant is still the base
    fresh(base)
    assert_is_a_closure(*solve_rad(base, 40.0), fourbar_positions(20, 66, 56, 80, 10 * DEG, 40 * DEG))


def test_points_variant_reports_its_own_points(tmp_path, monkeypatch):
    monkeypatch.setattr(compiled, "_MEMO", {})
    monkeypatch.setenv("LOOPSOLVE_CACHE_DIR", str(tmp_path))
    base, other = model(), model(points='B = "rAB"\nC = "rAD"')
    fresh(base)
    fresh(other)
    s = other.solve(40.0)
    assert (s["C_x"], s["C_y"]) == pytest.approx((80 * math.cos(10 * DEG), 80 * math.sin(10 * DEG)), abs=1e-12)


def test_the_input_choice_is_in_the_key(tmp_path, monkeypatch):
    """Driving theta4 instead of theta2: the same file, another compiled module."""
    monkeypatch.setattr(compiled, "_MEMO", {})
    monkeypatch.setenv("LOOPSOLVE_CACHE_DIR", str(tmp_path))
    mech = model()
    assert structure_key(mech, ("theta2",)) != structure_key(mech, ("theta4",))
    fresh(mech)
    compiled._MEMO.clear()
    ck = mech.compile("theta4")
    assert ck.inputs == ("theta4",) and ck.unknowns == ("theta2", "theta3")
    # theta4 given: the crank angles that close the loop with it, in closed form (inversion)
    t2 = math.radians(mech.solve(40.0)["theta4"])
    s = mech.solve(math.degrees(t2), input="theta4")
    assert math.radians(s["theta4"]) == pytest.approx(t2, abs=1e-12)
    assert _closes(math.radians(s["theta2"]), math.radians(s["theta3"]), t2)


def _closes(t2, t3, t4, a=20, b=66, c=56, d=80, gamma=10 * DEG):
    """The loop rAB + rBC = rAD + rDC closes to 1e-9 of the longest link."""
    ex = a * math.cos(t2) + b * math.cos(t3) - d * math.cos(gamma) - c * math.cos(t4)
    ey = a * math.sin(t2) + b * math.sin(t3) - d * math.sin(gamma) - c * math.sin(t4)
    return math.hypot(ex, ey) < 1e-9 * b


def test_parameter_values_are_not_baked_in(tmp_path, monkeypatch):
    """One compiled module serves every parameter value; each model solves with its own values."""
    monkeypatch.setattr(compiled, "_MEMO", {})
    monkeypatch.setenv("LOOPSOLVE_CACHE_DIR", str(tmp_path))
    base = model()
    cases = [(20, 66, 56, 80), (25, 66, 56, 80), (20, 70, 56, 80), (20, 66, 50, 80), (20, 66, 56, 75)]
    for a, b, c, d in cases:
        m = base.with_parameters(AB=a, BC=b, CD=c, AD=d)
        assert structure_key(m, m.inputs) == structure_key(base, base.inputs)
        ck = fresh(m)
        np.testing.assert_array_equal(ck.p, [d, a, b, c])  # declaration order AD, AB, BC, CD
        assert_is_a_closure(*solve_rad(m, 40.0), fourbar_positions(a, b, c, d, 10 * DEG, 40 * DEG))
    # one disk file serves them all: parameter values are really run-time inputs
    assert len(list(tmp_path.glob("m_*.py"))) == 1
    # a file edit of a parameter value alone gives the new number, not the cached one
    m = model(AB="27")
    fresh(m)
    assert_is_a_closure(*solve_rad(m, 40.0), fourbar_positions(27, 66, 56, 80, 10 * DEG, 40 * DEG))


# ----------------------------------------------------------------------------- two processes, one cache

_PROBE = """
    import math, sys
    import loopsolve as ls
    mech = ls.loads(sys.stdin.read(), source="probe.toml")
    print(repr(mech.solve({at!r})["theta4"]))
"""


def _theta4_in_process(text: str, at: float, cache) -> float:
    env = dict(os.environ, LOOPSOLVE_CACHE_DIR=str(cache))
    proc = subprocess.run([sys.executable, "-c", textwrap.dedent(_PROBE.format(at=at))], input=text,
                          capture_output=True, text=True, env=env)
    assert proc.returncode == 0, proc.stderr
    return float(proc.stdout)


def test_degree_model_after_an_identical_radian_model_in_another_process(tmp_path):
    """Same file but the angle unit: the ground angle 10 and the input 90 mean degrees or radians."""
    cache = tmp_path / "shared"
    rad_text = model_text(angle="rad", guesses=(1.57, 1.0, 1.5))
    deg_text = model_text()
    t4_rad = _theta4_in_process(rad_text, 90.0, cache)
    t4_deg = _theta4_in_process(deg_text, 90.0, cache)
    assert len(list(cache.glob("m_*.py"))) == 2
    expected_deg = [math.degrees(t4) for _, t4 in fourbar_positions(20, 66, 56, 80, 10 * DEG, 90 * DEG)]
    expected_rad = [t4 for _, t4 in fourbar_positions(20, 66, 56, 80, 10.0, 90.0)]
    assert min(abs(t4_deg - e) for e in expected_deg) < 1e-9
    assert min(abs(wrap_angle(t4_rad - e)) for e in expected_rad) < 1e-9
    # and again in the other order, with the files already on disk
    assert _theta4_in_process(deg_text, 90.0, cache) == t4_deg
    assert _theta4_in_process(rad_text, 90.0, cache) == t4_rad


def test_thesis_crank_rocker_in_degrees_after_radians(tmp_path):
    """The thesis four-bar (60, 25, 70, 45) at 90 deg: theta4 = 84.84 deg in the open mode, whatever
    was compiled before it into the same cache."""
    cache = tmp_path / "shared"
    text = (ls.models_dir() / "thesis_crank_rocker.toml").read_text()
    rad = text.replace('angle = "deg"', 'angle = "rad"').replace("guess = 90", "guess = 1.57") \
        .replace("guess = 20", "guess = 0.35").replace("guess = 80", "guess = 1.4")
    assert rad != text
    _theta4_in_process(rad, 1.5707963267948966, cache)
    t4 = _theta4_in_process(text, 90.0, cache)
    closures = [math.degrees(x) for _, x in fourbar_positions(25, 70, 45, 60, 0.0, 90 * DEG)]
    assert min(abs(t4 - e) for e in closures) < 1e-9


def test_the_length_unit_alone_is_in_the_key(tmp_path, monkeypatch):
    """``length = "20mm"`` is 20 in a mm model and 2 in a cm model: same text, other code."""
    monkeypatch.setattr(compiled, "_MEMO", {})
    monkeypatch.setenv("LOOPSOLVE_CACHE_DIR", str(tmp_path))
    mm, cm = model(ab_len="20mm"), model(ab_len="20mm", length="cm")
    assert structure_key(mm, mm.inputs) != structure_key(cm, cm.inputs)
    fresh(mm)
    assert_is_a_closure(*solve_rad(mm, 40.0), fourbar_positions(20, 66, 56, 80, 10 * DEG, 40 * DEG))
    fresh(cm)
    assert_is_a_closure(*solve_rad(cm, 40.0), fourbar_positions(2, 66, 56, 80, 10 * DEG, 40 * DEG))
