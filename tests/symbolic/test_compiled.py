"""Compiled kinematics: generated code equals the symbolic derivation; the disk cache skips sympy.

The cache tests run fresh Python processes that share one ``LOOPSOLVE_CACHE_DIR``: the first
compiles (sympy), the second must find the cached module and never import sympy.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest
import sympy as sp

import loopsolve as ls
from loopsolve.kinematics import classic
from loopsolve.symbolic.compiled import cache_dir, structure_key

from support.probe import assert_is_a_closure, fourbar_positions, model, solve_rad

MODELS = sorted(ls.models_dir().glob("*.toml"))
THESIS = ls.models_dir() / "thesis_crank_rocker.toml"


def _thesis_theta4(t2_deg: float) -> float:
    """theta4 [deg] of the thesis four-bar (60, 25, 70, 45), open mode, by the law of cosines."""
    t2 = math.radians(t2_deg)
    bx, by = 25 * math.cos(t2), 25 * math.sin(t2)
    d = math.hypot(60 - bx, by)  # B to O4
    beta = math.atan2(-by, 60 - bx)  # direction O4 -> ... seen from B
    gamma = math.acos((45 ** 2 + d ** 2 - 70 ** 2) / (2 * 45 * d))  # angle at O4 between O4->B and O4->C
    return math.degrees(beta + math.pi - gamma) % 360


def _example1_r1_with_extra_term() -> float:
    """The edited example-1 slider: r1 + 0.001*sqrt(r1 - 9) = 5 cos 45 + sqrt(64 - 12.5) (Newton here)."""
    target = 5 * math.cos(math.radians(45)) + math.sqrt(64 - (5 * math.sin(math.radians(45))) ** 2)
    r = target
    for _ in range(50):
        r -= (r + 0.001 * math.sqrt(r - 9) - target) / (1 + 0.0005 / math.sqrt(r - 9))
    return r


THESIS_THETA4_AT_90 = _thesis_theta4(90.0)


def _python(code: str, cache, *, check=True):
    env = dict(os.environ, LOOPSOLVE_CACHE_DIR=str(cache))
    proc = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True, env=env)
    if check:
        assert proc.returncode == 0, proc.stderr
    return proc


SOLVE_AND_REPORT = f"""
    import sys
    import loopsolve as ls
    mech = ls.load({str(THESIS)!r})
    s = mech.solve(90)
    print(repr(s["theta4"]), "sympy" in sys.modules)
"""


def test_second_process_does_not_import_sympy(tmp_path):
    cache = tmp_path / "cache"
    first = _python(SOLVE_AND_REPORT, cache).stdout.split()
    assert first[1] == "True"  # a cache miss derives with sympy
    files = list(cache.glob("m_*.py"))
    assert len(files) == 1
    second = _python(SOLVE_AND_REPORT, cache).stdout.split()
    assert second == [first[0], "False"]


def test_cli_on_a_warm_cache_does_not_import_sympy(tmp_path):
    cache = tmp_path / "cache"
    code = f"""
        import sys, io, contextlib
        from loopsolve.cli import main
        buf = io.StringIO()
        with contextlib.redirect_stdout(buf):
            status = main(["solve", {str(THESIS)!r}, "--format", "json"])
        print(status, "sympy" in sys.modules)
    """
    assert _python(code, cache).stdout.split() == ["0", "True"]
    assert _python(code, cache).stdout.split() == ["0", "False"]


def _fresh_compile(mech):
    """Compile as a new process would: without the in-process memo of compiled modules."""
    from loopsolve.symbolic import compiled

    compiled._MEMO.clear()
    return mech.compile()


def test_corrupt_cache_file_is_regenerated(tmp_path, monkeypatch):
    from loopsolve.symbolic import compiled

    monkeypatch.setattr(compiled, "_MEMO", {})
    monkeypatch.setenv("LOOPSOLVE_CACHE_DIR", str(tmp_path))
    mech = ls.load(THESIS)
    reference = _fresh_compile(mech).phi(np.array([1.0, 0.2, 1.3]))
    (path,) = tmp_path.glob("m_*.py")
    good = path.read_text()
    for garbage in ("this is not python (\n", "raise RuntimeError('boom')\n", "VARIABLES = ()\n", "",
                    good[: len(good) // 2], "VARIABLES = 5\nINPUTS = None\n"):
        path.write_text(garbage)
        ck = _fresh_compile(mech)
        np.testing.assert_array_equal(ck.phi(np.array([1.0, 0.2, 1.3])), reference)
        assert path.read_text() == good  # regenerated on disk as well
        assert mech.solve(90)["theta4"] == pytest.approx(THESIS_THETA4_AT_90, abs=1e-11)


def test_cache_can_be_disabled(tmp_path, monkeypatch):
    from loopsolve.symbolic import compiled

    monkeypatch.setattr(compiled, "_MEMO", {})
    monkeypatch.setenv("LOOPSOLVE_CACHE_DIR", "")
    assert cache_dir() is None
    monkeypatch.chdir(tmp_path)
    assert _fresh_compile(ls.load(THESIS)).unknowns == ("theta3", "theta4")
    assert not list(tmp_path.iterdir())


def test_unwritable_cache_still_solves(tmp_path, monkeypatch):
    from loopsolve.symbolic import compiled

    monkeypatch.setattr(compiled, "_MEMO", {})
    blocker = tmp_path / "file"
    blocker.write_text("not a directory")
    monkeypatch.setenv("LOOPSOLVE_CACHE_DIR", str(blocker / "cache"))
    mech = ls.load(THESIS)
    ck = _fresh_compile(mech)
    assert mech.solve(90, compiled=ck)["theta4"] == pytest.approx(THESIS_THETA4_AT_90, abs=1e-11)


def test_structure_key_ignores_parameter_values_but_not_structure():
    mech = ls.load(THESIS)
    longer = mech.with_parameters(r3=72)
    assert structure_key(mech, mech.inputs) == structure_key(longer, longer.inputs)
    assert structure_key(mech, ("theta2",)) != structure_key(mech, ("theta3",))
    assert longer.solve(90)["theta4"] != pytest.approx(mech.solve(90)["theta4"])
    # the same compiled module serves both, with each one's parameter values
    assert mech.compile().module is longer.compile().module
    t3, t4 = classic.fourbar_position(60, 25, 72, 45, np.radians(90))
    assert longer.solve(90)["theta4"] == pytest.approx(np.degrees(t4), abs=1e-10)


@pytest.mark.parametrize("path", MODELS, ids=lambda p: p.stem)
def test_compiled_functions_equal_the_symbolic_derivation(path):
    """phi, jac, rhs1-3 and the points of the generated module equal sympy's expressions."""
    mech = ls.load(path)
    kin, ck = mech.derive(), mech.compile()
    rng = np.random.default_rng(3)
    subs_p = dict(zip(kin.params, kin.param_values))
    args = [kin.z, kin.z1, kin.z2, kin.z3]
    f = {
        "phi": sp.lambdify([kin.z], kin.phi.subs(subs_p)),
        "jac": sp.lambdify([kin.z], kin.jac.subs(subs_p)),
        1: sp.lambdify(args[:2], kin.rhs[0].subs(subs_p)),
        2: sp.lambdify(args[:3], kin.rhs[1].subs(subs_p)),
        3: sp.lambdify(args, kin.rhs[2].subs(subs_p)),
    }
    n = len(kin.variables)
    for _ in range(5):
        zs = [rng.normal(size=n) * np.where(np.array(ck.kinds) == ls.units.Kind.LENGTH, ck.scale, 1.0)
              + (0 if k else np.abs(rng.normal(size=n)) * ck.scale * (np.array(ck.kinds) == ls.units.Kind.LENGTH))
              for k in range(4)]
        np.testing.assert_allclose(ck.phi(zs[0]), np.ravel(f["phi"](zs[0])), rtol=1e-12, atol=1e-12 * ck.scale)
        np.testing.assert_allclose(ck.jac(zs[0]), np.array(f["jac"](zs[0]), dtype=float), rtol=1e-12,
                                   atol=1e-12 * ck.scale)
        for k in (1, 2, 3):
            np.testing.assert_allclose(ck.rhs(k, *zs[: k + 1]), np.ravel(f[k](*zs[: k + 1])), rtol=1e-10,
                                       atol=1e-10 * ck.scale * (1 + np.max(np.abs(zs[1]))) ** k)
        # vectorized twins agree with the scalar functions
        Z = np.stack([zs[0], zs[0] + 0.1]).T
        np.testing.assert_allclose(ck.phi_v(Z)[:, 0], ck.phi(zs[0]), rtol=1e-13, atol=1e-13 * ck.scale)
        np.testing.assert_allclose(ck.jac_v(Z)[0], ck.jac(zs[0]), rtol=1e-13, atol=1e-13 * ck.scale)


def test_math_domain_errors_become_nan_not_exceptions():
    """A sqrt of a negative in generated scalar code gives NaN (Newton backs off), never a bare ValueError."""
    text = (ls.models_dir() / "example1_slider_crank.toml").read_text()
    text = text.replace('r1 = { length = "r1", angle = 0 }', 'r1 = { length = "r1 + 0.001*sqrt(r1 - 9)", angle = 0 }')
    text = text.replace("r1 = { guess = 10.7 }", 'r1 = { guess = 20, kind = "length" }')
    mech = ls.loads(text, source="sqrt.toml")
    ck = mech.compile()
    z = np.array([np.pi, 0.0, 3.0])  # r1 - 9 < 0
    assert np.all(np.isnan(ck.phi(z))) and np.all(np.isnan(ck.jac(z)))
    # the vector r1 is r1 + 0.001*sqrt(r1 - 9) long, and that length is 5 cos 45 + sqrt(64 - (5 sin 45)^2)
    assert mech.solve(45)["r1"] == pytest.approx(_example1_r1_with_extra_term(), abs=1e-12)
    with pytest.raises(ls.SolveError):  # at 180 deg the slider would sit at r1 = 3 < 9: no real solution
        mech.solve(180)


def test_a_warm_disk_cache_is_used_without_deriving(tmp_path, monkeypatch):
    """loopsolve.symbolic.compiled.x__fits__mutmut_17 rejected every good cache file (sympy on every call).
    In-process twin of test_compiled's subprocess test, which mutmut cannot see."""
    import loopsolve.symbolic.loop_equations
    from loopsolve.symbolic import compiled

    monkeypatch.setattr(compiled, "_MEMO", {})
    monkeypatch.setenv("LOOPSOLVE_CACHE_DIR", str(tmp_path))
    mech = ls.load(ls.models_dir() / "thesis_crank_rocker.toml")
    mech.compile()
    assert len(list(tmp_path.glob("m_*.py"))) == 1
    compiled._MEMO.clear()

    def no_sympy(*args, **kwargs):
        raise AssertionError("derived again although a valid cache file exists")

    monkeypatch.setattr(loopsolve.symbolic.loop_equations, "derive", no_sympy)
    ck = mech.compile()
    assert ck.points == ("B", "C") and ck.unknowns == ("theta3", "theta4")


def test_angle_literals_with_a_unit_in_expressions():
    """loopsolve.symbolic.loop_equations.x_to_sympy__mutmut_12 / x__angle_const__mutmut_1 (no test used a literal
    such as ``30deg`` inside an expression): in a radian model ``theta2 + 30deg`` is theta2 + pi/6,
    in a degree model ``theta2 + 0.5rad`` is theta2 + 28.6479 deg."""
    deg = math.pi / 180
    rad_model = model(angle="rad", ab_angle="theta2 + 30deg", guesses=(0.7, 1.0, 1.7))
    assert_is_a_closure(*solve_rad(rad_model, 0.7), fourbar_positions(20, 66, 56, 80, 10.0, 0.7 + math.pi / 6))
    deg_model = model(ab_angle="theta2 + 0.5rad")
    assert_is_a_closure(*solve_rad(deg_model, 40.0), fourbar_positions(20, 66, 56, 80, 10 * deg, 40 * deg + 0.5))
