"""The units registry as loopsolve builds it (:mod:`loopsolve.model.unitlib`), on whatever pint is installed.

CI runs this file on the newest pint the newest Python gets and on the oldest pint the declared bounds
allow (``.ci/run``): every engineering spelling must mean the same there. The expected sizes are written
from the definitions (the international pound 0.45359237 kg, standard gravity 9.80665 m/s², the inch
0.0254 m), not from pint.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import warnings
from fractions import Fraction
from pathlib import Path

import pytest

from loopsolve.errors import LoopsolveWarning
from loopsolve.model import unitlib

MODELS = Path(__file__).resolve().parents[2] / "models"
LB = Fraction("0.45359237")  # kg, the international pound
G0 = Fraction("9.80665")  # m/s², standard gravity (the pound-force is LB * G0 newtons)
INCH = Fraction("0.0254")  # m
TORQUE = (("length", 2), ("mass", 1), ("time", -2))

#: spelling -> (dimension, exact size in kg, m, s, rad; a factor of π written as ("pi", n))
EXPECTED = {
    "N*m": (TORQUE, Fraction(1)),
    "Nm": (TORQUE, Fraction(1)),
    "N·m": (TORQUE, Fraction(1)),
    "Nmm": (TORQUE, Fraction(1, 1000)),
    "N*mm": (TORQUE, Fraction(1, 1000)),
    "kNm": (TORQUE, Fraction(1000)),
    "lbf*in": (TORQUE, LB * G0 * INCH),
    "in*lbf": (TORQUE, LB * G0 * INCH),
    "Ns": ((("length", 1), ("mass", 1), ("time", -1)), Fraction(1)),
    "Nms": ((("length", 2), ("mass", 1), ("time", -1)), Fraction(1)),
    "lbm": ((("mass", 1),), LB),
    "lb": ((("mass", 1),), LB),
    "rev": ((("angle", 1),), ("pi", Fraction(2))),
    "turn": ((("angle", 1),), ("pi", Fraction(2))),
    "°": ((("angle", 1),), ("pi", Fraction(1, 180))),
    "deg": ((("angle", 1),), ("pi", Fraction(1, 180))),
    "rad": ((("angle", 1),), Fraction(1)),
    "rpm": ((("angle", 1), ("time", -1)), ("pi", Fraction(1, 30))),
    "rev/min": ((("angle", 1), ("time", -1)), ("pi", Fraction(1, 30))),
    "°/s": ((("angle", 1), ("time", -1)), ("pi", Fraction(1, 180))),
    "Hz": ((("time", -1),), Fraction(1)),  # a frequency, not an angular rate: the radian is a dimension
    "N*m/rad": ((("angle", -1),) + TORQUE, Fraction(1)),
}


def _dims(info):
    return tuple((d, int(p)) for d, p in info.dims)


def _size(expected):
    return float(expected) if isinstance(expected, Fraction) else math.pi * float(expected[1])


@pytest.fixture(scope="module")
def fresh_registry():
    """A registry built the way loopsolve builds it, with any warning an error."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return unitlib._build_registry()


@pytest.mark.parametrize("spelling", sorted(EXPECTED))
def test_engineering_spelling_from_a_fresh_registry(fresh_registry, spelling):
    dims, size = EXPECTED[spelling]
    text = spelling.replace("·", "*")
    q = fresh_registry.Quantity(Fraction(1), text)
    assert tuple(sorted((d.strip("[]"), int(p)) for d, p in q.dimensionality.items())) == tuple(sorted(dims))
    target = "*".join(f"{unitlib._SI[d]}**({p})" for d, p in dims)
    got = Fraction(q.to(target).magnitude)
    if isinstance(size, Fraction):
        assert got == size  # exact: pint computes with fractions
    else:
        assert float(got) == pytest.approx(_size(size), rel=1e-15)


@pytest.mark.parametrize("spelling", sorted(EXPECTED))
def test_engineering_spelling_through_lookup(spelling, monkeypatch):
    monkeypatch.setenv("LOOPSOLVE_CACHE_DIR", "")  # no memo: pint answers
    monkeypatch.setattr(unitlib, "_MEMO", {})
    dims, size = EXPECTED[spelling]
    info = unitlib.lookup(spelling)
    assert info is not None and _dims(info) == tuple(sorted(dims))
    if isinstance(size, Fraction):
        assert info.ratio == size and info.pi_power == 0
    else:
        assert info.pi_power == 1 and info.ratio == size[1]  # a rational multiple of π, exactly
    assert info.si_factor == pytest.approx(_size(size), rel=1e-15)


def test_building_the_registry_warns_nothing_on_the_installed_pint():
    import pint

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        unitlib._build_registry()
    assert [str(w.message) for w in caught] == [], pint.__version__


def test_a_spelling_pint_defines_otherwise_is_replaced_with_one_warning(monkeypatch):
    """pint's ``mil`` is an angle (a 6400th of a turn); a definition of ours that means otherwise wins,
    and says so once, naming it — never an internal error."""
    monkeypatch.setattr(unitlib, "ENGINEERING_UNITS", unitlib.ENGINEERING_UNITS + (("mil", "0.001 * inch"),))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        reg = unitlib._build_registry()
    messages = [str(w.message) for w in caught if issubclass(w.category, LoopsolveWarning)]
    assert len(messages) == 1 and "'mil'" in messages[0] and "0.001 * inch" in messages[0]
    assert Fraction(reg.Quantity(Fraction(1), "mil").to("meter").magnitude) == INCH / 1000


def test_a_spelling_pint_defines_alike_is_left_to_pint(monkeypatch):
    monkeypatch.setattr(unitlib, "ENGINEERING_UNITS", unitlib.ENGINEERING_UNITS + (("ft", "12 * inch"),))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        reg = unitlib._build_registry()
    assert Fraction(reg.Quantity(Fraction(1), "ft").to("meter").magnitude) == 12 * INCH


# ---------------------------------------------------------------- bounded work, sizes in range

@pytest.mark.parametrize("unit, why", [
    ("rad**4**4**4/s", "power of a power"),
    ("mrad**4**4/rad**4**4*rad/s", "power of a power"),
    ("mm**-4**4", "power of a power"),
    ("rad^4^4/s", "power of a power"),
    ("((rad**4)**4)**2/s", "power of 32"),
    ("(ym**4)**4", "too small for floating point"),
    ("(Ym**4)**4", "infinite"),
])
def test_hostile_unit_is_refused_with_the_reason(unit, why, monkeypatch):
    monkeypatch.setenv("LOOPSOLVE_CACHE_DIR", "")
    assert unitlib.lookup(unit) is None
    assert why in unitlib.refusal(unit)


@pytest.mark.parametrize("speed, why", [
    ("10 rad**4**4**4/s", "power of a power"),
    ("10 mrad**4**4/rad**4**4*rad/s", "power of a power"),
    ("1 mm**-4**4", "power of a power"),
    ("1e-300 nrad/s", "underflows"),
])
def test_cli_refuses_a_hostile_speed_in_one_line(speed, why, tmp_path):
    """The fuzzer's cases (issue 29): a power tower hung the CLI, an underflowing factor became a speed of 0."""
    env = dict(os.environ, LOOPSOLVE_CACHE_DIR=str(tmp_path / "cache"))
    r = subprocess.run([sys.executable, "-m", "loopsolve", "solve", str(MODELS / "thesis_crank_rocker.toml"),
                        "--at", "30", "--speed", speed], capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 2 and r.stdout == ""
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "--speed" in lines[0] and why in lines[0], r.stderr


def test_model_file_with_a_power_tower_names_the_key(tmp_path):
    text = (MODELS / "thesis_crank_rocker.toml").read_text(encoding="utf-8")
    assert 'speed = "10rpm"' in text
    model = tmp_path / "tower.toml"
    model.write_text(text.replace('speed = "10rpm"', 'speed = "10 rad**4**4**4/s"'), encoding="utf-8")
    r = subprocess.run([sys.executable, "-m", "loopsolve", "solve", str(model), "--at", "30"],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 2 and "variables.theta2.speed" in r.stderr and "power of a power" in r.stderr


# ---------------------------------------------------------------- the memo

_CODE = ("import sys; from loopsolve.model.units import *; "
         "print(parse_quantity('1 in', Kind.LENGTH), 'pint' in sys.modules)")


def _run(cache: Path) -> list[str]:
    env = dict(os.environ, LOOPSOLVE_CACHE_DIR=str(cache), PYTHONPATH=os.pathsep.join(sys.path))
    r = subprocess.run([sys.executable, "-c", _CODE], capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 0, r.stderr
    return r.stdout.split()


def _memo(cache: Path) -> Path:
    (memo,) = [p for p in cache.iterdir() if p.name.startswith("units-")]
    return memo


def _planted(kind: str, original: bytes) -> bytes:
    head, _, body = original.partition(b"\n")
    if kind == "nested":  # json.loads recursion: once made every command fail, blaming the model
        return b"[" * 200_000 + b"]" * 200_000
    if kind == "nested-with-header":  # a header that does not match what follows
        return head + b"\n" + b"[" * 200_000 + b"]" * 200_000
    if kind == "truncated":
        return original[: len(original) // 2]
    if kind == "forged":  # a changed factor under the old header: 1 in = 1 m
        return head + b"\n" + body.replace(b'"127/5000"', b'"1/1"')
    if kind == "zero-size":  # layout right, hash right, an answer of size 0
        data = json.loads(body)
        for entry in data.values():
            if entry:
                entry[1] = "0"
        new = json.dumps(data, sort_keys=True).encode()
        import hashlib

        return head.split(b" sha256=")[0] + b" sha256=" + hashlib.sha256(new).hexdigest().encode() + b"\n" + new
    if kind == "not-json":
        return b"\x00\xff garbage"
    raise AssertionError(kind)


@pytest.mark.parametrize("kind", ["nested", "nested-with-header", "truncated", "forged", "zero-size", "not-json"])
def test_an_unreadable_memo_is_absent_and_rewritten(kind, tmp_path):
    cache = tmp_path / "cache"
    cache.mkdir(mode=0o700)
    assert _run(cache) == ["25.4", "True"]
    memo = _memo(cache)
    good = memo.read_bytes()
    memo.write_bytes(_planted(kind, good))
    assert _run(cache) == ["25.4", "True"]  # pint answered again, the right answer
    assert _memo(cache).read_bytes() == good  # and the memo was written anew
    assert _run(cache) == ["25.4", "False"]  # which the next run trusts
