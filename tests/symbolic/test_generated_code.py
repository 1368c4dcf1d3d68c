"""The generated code and the derivation give the right numbers: rates, polar splits, the cache
(written for surviving mutants of loopsolve.symbolic.compiled and loopsolve.symbolic.loop_equations, issue 13).

Every expected value is computed here: slider-crank closed forms and their derivatives by hand,
the polar split of a tip acceleration from its definition, the four-bar by law of cosines.
Each test names the mutants it kills (``mutmut show NAME``); the rest are triaged in
tools/mutation_triage/compiled.txt and symbolic.txt.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import stat
import warnings

import pytest

import loopsolve as ls
from loopsolve.symbolic import compiled
from loopsolve.kinematics import export
from loopsolve.symbolic.compiled import cache_dir
from loopsolve.errors import ModelError

THESIS = ls.models_dir() / "thesis_crank_rocker.toml"
PROB2 = ls.models_dir() / "prob2_offset_slider_crank.toml"


def fourbar_theta4(r1, r2, r3, r4, theta2_deg):
    """Rocker angle [deg] of the open four-bar (law of cosines in triangles O2-B-O4 and B-C-O4)."""
    t2 = math.radians(theta2_deg)
    bx, by = r2 * math.cos(t2), r2 * math.sin(t2)
    d = math.hypot(r1 - bx, by)  # diagonal B-O4
    beta = math.atan2(by, r1 - bx)  # angle of the diagonal at O4, measured from -x
    psi = math.acos((r4 * r4 + d * d - r3 * r3) / (2 * r4 * d))  # angle C-O4-B
    return math.degrees(math.pi - beta - psi)


THESIS_THETA4_AT_90 = fourbar_theta4(60, 25, 70, 45, 90)


def slider(r2, r3, e, theta2_deg, omega, alpha):
    """Offset slider-crank r2 e(θ2) + r3 e(θ3) = (s, e), open mode (cos θ3 > 0).

    Returns θ3 [deg], s, ṡ, s̈ for crank rate ω [rad/s] and acceleration α [rad/s²]:
    s(θ) = r2 cos θ + w, w = sqrt(r3² − g²), g = e − r2 sin θ, differentiated by hand.
    """
    t = math.radians(theta2_deg)
    g, g1, g2 = e - r2 * math.sin(t), -r2 * math.cos(t), r2 * math.sin(t)
    w = math.sqrt(r3 * r3 - g * g)
    w1 = -g * g1 / w
    w2 = -(g1 * g1 + g * g2) / w - (g * g1) ** 2 / w**3
    s, s_t, s_tt = r2 * math.cos(t) + w, -r2 * math.sin(t) + w1, -r2 * math.cos(t) + w2
    return math.degrees(math.asin(g / r3)), s, s_t * omega, s_tt * omega**2 + s_t * alpha


@pytest.fixture
def fresh(monkeypatch, tmp_path):
    """No module compiled earlier in this process; a private cache directory."""
    monkeypatch.setattr(compiled, "_MEMO", {})
    monkeypatch.setenv("LOOPSOLVE_CACHE_DIR", str(tmp_path / "cache"))
    return tmp_path / "cache"


CARTESIAN_SLIDER = """
name = "slider by components"
units = { length = "mm", angle = "deg" }
[parameters]
r2 = 40
r3 = 100
e = 20
[variables]
theta2 = { input = true, guess = 50, speed = "10rad/s", accel = "50rad/s^2" }
theta3 = { guess = -5 }
s = { guess = 130, kind = "length" }
[vectors]
r2 = { length = "r2", angle = "theta2" }
r3 = { length = "r3", angle = "theta3" }
r1 = { x = "abs(s)", y = "e" }
[[loops]]
equation = "r2 + r3 = r1"
"""


def test_block_given_by_components_sliding_split(fresh):
    """The slider's position vector r1 = (|s|, e) turns and stretches as s moves: the state's JSON
    carries its acceleration split under its name, equal to the definition evaluated here.

    Kills loopsolve.symbolic.compiled.x_generate_source__mutmut_85 (SLIDING held None, not the name),
    _185/_195/_205 (vectors0/1/2 lost the unpacking of z, z1, z2: NameError),
    loopsolve.symbolic.loop_equations.x_derive__mutmut_135 (length of a vector by components sqrt(x² + 2y)) and
    loopsolve.symbolic.loop_equations.xǁ_DerivǁD__mutmut_21 (d/dt sign(s) = DiracDelta(s) taken as 1, not 0: a
    spurious 2ṡ² in the slider's acceleration).
    """
    omega, alpha = 10.0, 50.0
    th3, s, s1, s2 = slider(40, 100, 20, 50, omega, alpha)
    state = ls.loads(CARTESIAN_SLIDER).solve(50)
    assert state["theta3"] == pytest.approx(th3, abs=1e-9)
    assert state["s"] == pytest.approx(s, abs=1e-9)
    assert state["s_vel"] == pytest.approx(s1, rel=1e-9)
    assert state["s_acc"] == pytest.approx(s2, rel=1e-9)

    # tip P = (s, e): r = |P|, θ = atan2(e, s), with their rates from ṡ, s̈ (e is constant)
    e = 20.0
    r = math.hypot(s, e)
    r1 = s * s1 / r
    r2 = (s1 * s1 + s * s2 - r1 * r1) / r
    t1 = -e * s1 / r**2
    t2 = -e * s2 / r**2 + 2 * e * s1 * r1 / r**3
    er, et = (s / r, e / r), (-e / r, s / r)
    expected = {
        "tangential": [r * t2 * c for c in et],
        "normal": [-r * t1 * t1 * c for c in er],
        "slip": [r2 * c for c in er],
        "coriolis": [2 * r1 * t1 * c for c in et],
        "total": [s2, 0.0],
    }
    doc = json.loads(export.to_json(state))
    assert list(doc["acceleration_components"]) == ["r1"]
    got = doc["acceleration_components"]["r1"]
    assert set(got) == set(expected)
    for part, xy in expected.items():
        assert got[part] == pytest.approx(xy, rel=1e-7, abs=1e-7 * abs(s2)), part


def test_unary_minus_and_atan2_in_a_vector_angle(fresh):
    """The offset of prob 2 written as r4 at -atan2(e, 0) + 180 = 90 degrees.

    Kills loopsolve.symbolic.loop_equations.x_to_sympy__mutmut_37 (unary minus dropped: r4 at 270, offset
    reversed) and x_to_sympy__mutmut_67 (atan2 refused as an unknown expression node).
    """
    text = PROB2.read_text(encoding="utf-8").replace('r4 = { length = "e", angle = 90 }',
                                                     'r4 = { length = "e", angle = "-atan2(e, 0) + 180" }')
    assert "atan2" in text
    # prob 2: crank 480 mm at 20 rad/s (no angular acceleration), rod 1600 mm, offset 100 mm
    th3, x, x1, x2 = slider(480, 1600, 100, 40, 20.0, 0.0)
    state = ls.loads(text).solve(40)
    assert state["theta3"] == pytest.approx(th3, abs=1e-9)
    assert state["x"] == pytest.approx(x, abs=1e-8)
    assert state["x_vel"] == pytest.approx(x1, rel=1e-9)
    assert state["x_acc"] == pytest.approx(x2, rel=1e-9)


FOURBAR = """
name = "fb"
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
r3 = {{ length = {l3}, angle = "theta3" }}
r4 = {{ length = {l4}, angle = "theta4" }}
[[loops]]
equation = "r2 + r3 = r1 + r4"
"""


def test_minus_infinity_in_an_expression_is_refused_naming_the_key(fresh):
    """``r4 ** -abs(tan(90))`` holds -oo (abs of the pole of tan is +oo): refused as a model error
    that names the key, like +oo and zoo. Kills loopsolve.symbolic.loop_equations.x__not_finite_real__mutmut_9."""
    text = FOURBAR.format(l3='"r3"', l4='"r4 ** -abs(tan(90))"')
    with pytest.raises(ModelError) as info:
        ls.loads(text).solve(90)
    msg = str(info.value)
    assert "vectors.r4.length" in msg and "not a finite real expression" in msg


def _nest(var: str, depth: int) -> str:
    return "sin(" + f"{var} + sin(" * (depth - 1) + var + ")" * depth


def test_too_large_derivation_names_the_loop_and_its_vectors(fresh):
    """Two links whose lengths are nested sines of their angles: the third derivative of the loop
    is too large; the error names the loop and its vectors.

    Kills loopsolve.symbolic.loop_equations.x__check_size__mutmut_6 (AttributeError instead of the ModelError) and
    x__check_size__mutmut_16 (the vector names run together with 'XX')."""
    text = FOURBAR.format(l3=f'"r3 + {_nest("theta3", 4)}"', l4=f'"r4 + {_nest("theta4", 4)}"')
    with pytest.raises(ModelError) as info:
        ls.loads(text).compile()
    msg = str(info.value)
    assert "loops[0] (loop1: 'r2 + r3 = r1 + r4')" in msg
    assert "too large" in msg
    assert msg.endswith("(r1, r2, r3, r4)")


def test_long_loop_of_simple_vectors_is_accepted():
    """A crank of 25 mm drawn as 270 collinear pieces of 25/270 mm: each piece adds about 10
    operations to the second derivative of the loop and 20 to the third, so the loop stays under
    the third-derivative limit (8000) while its second derivative passes 8000/3. It is derived,
    and its Jacobian is the four-bar's. Kills loopsolve.symbolic.loop_equations.x_derive__mutmut_225 (the
    second-derivative early refusal at MAX_NODES // 3 instead of // 2)."""
    n = 270
    params = "\n".join(f"c{i} = {25 / n!r}" for i in range(n))
    vecs = "\n".join(f'c{i} = {{ length = "c{i}", angle = "theta2" }}' for i in range(n))
    eq = " + ".join(f"c{i}" for i in range(n)) + " + r3 = r1 + r4"
    text = FOURBAR.format(l3='"r3"', l4='"r4"').replace("r2 = 25\n", params + "\n")
    text = text.replace('r2 = { length = "r2", angle = "theta2" }', vecs).replace('"r2 + r3 = r1 + r4"', f'"{eq}"')
    kin = ls.loads(text).derive()
    assert kin.unknowns == ("theta3", "theta4")
    assert len(kin.phi) == 2
    # Φ_q of the four-bar: [[-r3 sin θ3, r4 sin θ4], [r3 cos θ3, -r4 cos θ4]] (θ in radians inside)
    t3, t4 = kin.z[1], kin.z[2]
    at = {t3: 0.3, t4: 1.1}
    at.update({p: v for p, v in zip(kin.params, kin.param_values)})
    got = [float(kin.jac[i, j].subs(at)) for i in range(2) for j in range(2)]
    assert got == pytest.approx([-70 * math.sin(0.3), 45 * math.sin(1.1), 70 * math.cos(0.3), -45 * math.cos(1.1)],
                                rel=1e-12)


# ----------------------------------------------------------------------------- the disk cache


def test_default_cache_directory_is_created_under_the_home(tmp_path, monkeypatch):
    """Without LOOPSOLVE_CACHE_DIR the cache is $XDG_CACHE_HOME/loopsolve, else ~/.cache/loopsolve;
    a home whose .cache does not exist yet gets it (private), and nothing lands in the working
    directory.

    Kills loopsolve.symbolic.compiled.x_cache_dir__mutmut_9 (base None), x_cache_dir__mutmut_19 (the home
    not expanded: a relative 'XX~XX/.cache') and x_ensure_dir__mutmut_2 (missing parents of the
    cache directory not created, so nothing was cached)."""
    monkeypatch.setattr(compiled, "_MEMO", {})
    monkeypatch.delenv("LOOPSOLVE_CACHE_DIR", raising=False)
    cwd = tmp_path / "cwd"
    cwd.mkdir()
    monkeypatch.chdir(cwd)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache_dir() == tmp_path / "xdg" / "loopsolve"
    home = tmp_path / "home"  # does not exist yet
    monkeypatch.setenv("HOME", str(home))
    monkeypatch.setenv("XDG_CACHE_HOME", "")  # empty: as if unset
    assert cache_dir() == home / ".cache" / "loopsolve"
    monkeypatch.delenv("XDG_CACHE_HOME")
    assert cache_dir() == home / ".cache" / "loopsolve"
    assert ls.load(THESIS).solve(90)["theta4"] == pytest.approx(THESIS_THETA4_AT_90, abs=1e-9)
    directory = home / ".cache" / "loopsolve"
    assert len(list(directory.glob("m_*.py"))) == 1
    assert stat.S_IMODE(directory.stat().st_mode) == 0o700
    assert list(cwd.iterdir()) == []


def test_entry_with_a_valid_header_but_another_models_layout_is_not_used(fresh):
    """A well-formed entry (right key and hash in its header) that holds another model's module
    (here the slider-crank of prob 2 under the four-bar's key) is regenerated, never used.

    Kills loopsolve.symbolic.compiled.x__fits__mutmut_2 (`and` -> `or`: any module with all the functions fit)."""
    assert ls.load(THESIS).solve(90)["theta4"] == pytest.approx(THESIS_THETA4_AT_90, abs=1e-9)
    (mine,) = fresh.glob("m_*.py")
    compiled._MEMO.clear()
    ls.load(PROB2).solve(40)
    (other,) = [p for p in fresh.glob("m_*.py") if p != mine]
    body = other.read_bytes().partition(b"\n")[2]
    key = mine.name[2:-3]
    mine.write_bytes(f"# loopsolve-cache key={key} sha256={hashlib.sha256(body).hexdigest()}\n".encode() + body)
    compiled._MEMO.clear()
    state = ls.load(THESIS).solve(90)
    assert state["theta4"] == pytest.approx(THESIS_THETA4_AT_90, abs=1e-9)
    assert b"theta4" in mine.read_bytes()  # rewritten with the four-bar's module


def test_entry_replaced_by_a_fifo_after_the_first_check_is_named_in_the_warning(fresh, tmp_path, monkeypatch):
    """Another process swaps the entry for a FIFO between the lstat and the open: the open
    descriptor's check refuses it and the warning names the entry.

    Kills loopsolve.symbolic.compiled.x_read_entry__mutmut_49 (the warning said 'None')."""
    ls.load(THESIS).compile()
    (entry,) = fresh.glob("m_*.py")
    entry.unlink()
    os.mkfifo(entry)
    decoy = tmp_path / "decoy.py"
    decoy.write_text("# a regular file\n", encoding="utf-8")
    real_lstat = os.lstat

    def lstat_before_the_swap(path, *args, **kwargs):  # what lstat saw just before the swap
        if os.fspath(path) == os.fspath(entry):
            return real_lstat(decoy)
        return real_lstat(path, *args, **kwargs)

    monkeypatch.setattr(os, "lstat", lstat_before_the_swap)
    compiled._MEMO.clear()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        value = ls.load(THESIS).solve(90)["theta4"]
    assert value == pytest.approx(THESIS_THETA4_AT_90, abs=1e-9)
    msgs = [str(w.message) for w in caught if issubclass(w.category, ls.LoopsolveWarning)]
    assert len(msgs) == 1, msgs
    assert f"the cache entry {entry} is not a regular file" in msgs[0]
    assert stat.S_ISFIFO(real_lstat(entry).st_mode)  # left alone


def test_vectorized_point_positions_have_the_documented_shape(fresh):
    """``CompiledKinematics.point_values_v`` returns a (P, 2, N) array for N configurations.

    Kills loopsolve.symbolic.compiled.xǁCompiledKinematicsǁpoint_values_v__mutmut_23 (a (P·N, 2) array)."""
    ck = ls.load(PROB2).compile()
    assert ck.variables == ("theta2", "theta3", "x") and ck.points == ("A", "B")
    cranks = [10.0, 40.0, 200.0]
    sols = [slider(480, 1600, 100, c, 0.0, 0.0) for c in cranks]
    z = [[math.radians(c) for c in cranks], [math.radians(s[0]) for s in sols], [s[1] for s in sols]]
    pts = ck.point_values_v(0, z)
    assert pts.shape == (2, 2, 3)
    for n, (c, s) in enumerate(zip(cranks, sols)):
        t = math.radians(c)
        assert list(pts[0, :, n]) == pytest.approx([480 * math.cos(t), 480 * math.sin(t)], abs=1e-9)  # A
        assert list(pts[1, :, n]) == pytest.approx([s[1], 100.0], abs=1e-9)  # B = r1 + r4


def test_vectorized_vector_lengths_and_angles(fresh):
    """``CompiledKinematics.vector_values_v``: (V, 2, N) lengths and angles for N configurations,
    (V, 2) for one. Kills loopsolve.symbolic.compiled.xǁCompiledKinematicsǁvector_values_v__mutmut_4
    (parameters not passed), _14 (reshaped to (2, N)) and _24 (one configuration not reshaped)."""
    ck = ls.load(PROB2).compile()
    assert ck.vectors == ("r1", "r2", "r3", "r4")
    cranks = [10.0, 40.0, 200.0]
    sols = [slider(480, 1600, 100, c, 0.0, 0.0) for c in cranks]
    z = [[math.radians(c) for c in cranks], [math.radians(s[0]) for s in sols], [s[1] for s in sols]]
    vv = ck.vector_values_v(0, z)
    assert vv.shape == (4, 2, 3)
    for n, (c, s) in enumerate(zip(cranks, sols)):
        expected = [[s[1], 0.0], [480, math.radians(c)], [1600, math.radians(s[0])], [100, math.pi / 2]]
        assert [list(vv[k, :, n]) for k in range(4)] == [pytest.approx(e, abs=1e-9) for e in expected]
    one = ck.vector_values_v(0, [col[1] for col in z])
    assert one.shape == (4, 2)
    assert list(one[0]) == pytest.approx([sols[1][1], 0.0], abs=1e-9)
    assert list(one[2]) == pytest.approx([1600, math.radians(sols[1][0])], abs=1e-9)


def test_mode_at_an_exact_dead_centre_has_a_zero_sign():
    """Driven by its slider at x = r2 + r3 = 13, the slider-crank has one configuration (crank and
    rod along the line of sliding), where det Φ_q = r2 r3 sin(θ3 − θ2) is exactly 0: its mode
    signature is '0'. Kills loopsolve.symbolic.compiled.xǁCompiledKinematicsǁsignature__mutmut_21 ('XX0XX')."""
    (mode,) = ls.slider_crank(5, 8, theta2=-30).modes(13.0, input="x")
    assert mode.signature == "0"
    assert [mode.positions[n] for n in ("theta2", "theta3", "x")] == pytest.approx([0.0, 0.0, 13.0], abs=1e-9)
