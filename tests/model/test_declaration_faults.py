"""The declaration-fault corpus of issue 17: one slip in [bodies] or [[loads]] never gives a silently different number.

For every shipped model with bodies: every single joint deleted from a body's ``joints``, and every
load moved to each other body. Each mutant either raises a :class:`LoopsolveError` whose message
names what was changed (the joint and the body, or the load's key ``loads[i]``), or gives a result
that is right for what it declares: its driving torque equals the one of the equation of motion
``T = M ẍ + ½ M′ ẋ² − Q`` (:func:`virtual_work_drive`: virtual work, no joint forces, so a different
computation from Newton–Euler) and its power balance, recomputed here with the energy rate by
finite differences of the kinetic and potential energy along the motion, holds.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.dynamics.dynamics_model import compile_dynamics
from loopsolve.dynamics.kinetostatics import virtual_work_drive

MODELS = [p for p in sorted(ls.models_dir().glob("*.toml")) if ls.load(p).dynamics is not None]
AT = (37.0, 151.0)  # two generic inputs (degrees) of every shipped dynamics model (all crank-driven)
SPEED = 12.0  # rad/s


def _mutants():
    for path in MODELS:
        spec = ls.load(path).spec
        bodies = spec.get("bodies", {})
        for bname, bdef in bodies.items():
            for j in bdef.get("joints", []):
                yield pytest.param(path.name, "joint", (bname, j), id=f"{path.stem}-{bname}-drops-{j}")
        for i, ld in enumerate(spec.get("loads", [])):
            if "body" not in ld:
                continue
            for other in bodies:
                if other != ld["body"]:
                    yield pytest.param(path.name, "load", (i, other), id=f"{path.stem}-loads{i}-on-{other}")


def _mutate(name: str, kind: str, what) -> ls.Mechanism:
    spec = ls.model.mechanism.deep_copy(ls.load(ls.models_dir() / name).spec)
    if kind == "joint":
        bname, j = what
        spec["bodies"][bname]["joints"] = [x for x in spec["bodies"][bname]["joints"] if x != j]
    else:
        i, other = what
        spec["loads"][i]["body"] = other
    return ls.build_mechanism(spec)


def _independent_power_residual(mech, x0: float) -> float:
    """T ẋ − (dE/dt − P_loads) with dE/dt by central differences of E(θ) at constant speed (relative)."""
    h = 1e-4  # degrees
    fs = ls.forces(mech, x0 - h, x0 + h * 1.5, h, speed=SPEED)
    e = np.asarray(fs.kinetic_energy) + np.asarray(fs.potential_energy)
    dedt = (e[2] - e[0]) / (2 * math.radians(h)) * SPEED
    # the loads' power: what is left of the energy balance in the result itself is not used; the loads
    # here are a torque on a body (T_l ω_body) or a force at a point (F · v_P), from the sweep's rates
    mid = fs.sweep.states[1]
    p_loads = 0.0
    dm = compile_dynamics(mech, compiled=fs.sweep.compiled)
    ev = dm.evaluate(mid.z, mid.z1, mid.z2)
    names = [b.name for b in dm.bodies]
    lf = dm.length_factor
    slot = 0
    for ld in dm.dynamics.loads:
        vals = ev["load"][slot:slot + len(ld.values)][:, 0]
        slot += len(ld.values)
        if ld.kind.value == "torque":
            p_loads += vals[0] * ev["om"][names.index(ld.body), 0]
        elif ld.kind.value == "force":
            p_loads += float(np.dot(vals, ev["vP"][dm.point_names.index(ld.at), :, 0] * lf))
        else:
            raise AssertionError(f"the corpus models have force and torque loads only, not {ld.kind}")
    t = float(fs.drive[1])
    return (t * SPEED - (dedt - p_loads)) / max(abs(t * SPEED), abs(dedt), abs(p_loads))


@pytest.mark.parametrize("name, kind, what", list(_mutants()))
def test_declaration_fault_is_refused_or_consistent(name, kind, what):
    mech = _mutate(name, kind, what)
    try:
        results = [ls.forces(mech, x, speed=SPEED) for x in AT]
    except ls.LoopsolveError as exc:
        msg = str(exc)
        if kind == "joint":
            bname, j = what
            assert repr(j) in msg and repr(bname) in msg, msg
        else:
            assert f"loads[{what[0]}]" in msg, msg
        return
    # accepted: then the result must be right for what is declared
    assert kind == "load", f"a joint left out of a body was accepted: {what}"
    dm = compile_dynamics(mech)
    for x, fs in zip(AT, results):
        st = fs.sweep.states[0]
        want = virtual_work_drive(dm, st.z[None, :], SPEED, 0.0)[0]
        assert float(fs.drive) == pytest.approx(want, rel=1e-9, abs=1e-12), (x, fs.drive, want)
        assert abs(_independent_power_residual(mech, x)) < 1e-5


def test_the_corpus_covers_every_shipped_dynamics_model():
    names = {m.values[0] for m in _mutants()}
    assert {"engine_slider_crank.toml", "shaper_dynamics.toml", "thesis_crank_rocker_dynamics.toml",
            "thesis_crank_rocker_dynamics_diagram.toml"} <= names
    assert len(list(_mutants())) >= 25
