"""What a model is made of: variables, loops, mobility, solve order and classic properties.

``info(mech)`` is the data behind ``loopsolve info``; ``format_info`` prints it for people.
"""

from __future__ import annotations

import math

from .model import Mechanism
from .units import Kind

__all__ = ["info", "format_info"]


def _fourbar_loops(mech: Mechanism):
    """Loops made of four fixed-length vectors, one of them fixed in angle (ground): four-bars."""
    params = {p.name: p for p in mech.parameters}
    var_names = {v.name for v in mech.variables}
    from . import expr as _expr

    out = []
    for loop in mech.loops:
        if len(loop.terms) != 4:
            continue
        vecs = [mech.vector(n) for _, n in loop.terms]
        if any(v.cartesian for v in vecs):
            continue
        lengths, ground, moving = {}, [], []
        ok = True
        for v in vecs:
            lnames = _expr.names(v.length)
            if lnames & var_names or not isinstance(v.length, (_expr.Num, _expr.Name)):
                ok = False
                break
            if isinstance(v.length, _expr.Num):
                lengths[v.name] = float(v.length.value)
            else:
                lengths[v.name] = params[v.length.id].value
            angle_vars = _expr.names(v.angle) & var_names
            (moving if angle_vars else ground).append(v.name)
        if ok and len(ground) == 1 and len(moving) == 3:
            out.append((loop, lengths, ground[0], moving))
    return out


def info(mech: Mechanism, *, input=None) -> dict:
    """Structure summary of ``mech`` as a JSON-ready dict.

    Keys: ``name``, ``source``, ``units``, ``mobility``, ``inputs``, ``unknowns``, ``variables``,
    ``parameters``, ``loops``, ``blocks`` (solve order: lists of unknown names), ``points``,
    ``fourbars`` (Grashof class, input range, transmission-angle range of four-bar loops).

    Examples
    --------
    >>> d = ls.fourbar(60, 25, 70, 45).info()
    >>> d["mobility"], d["blocks"], d["fourbars"][0]["grashof"]
    (1, [['theta3', 'theta4']], 'crank-rocker')
    """
    ck = mech.compile(input)
    u = mech.units
    conv = (lambda r: math.degrees(r)) if u.angle == "deg" else (lambda r: r)
    data = {
        "name": mech.name,
        "source": mech.source,
        "units": {"length": u.length, "angle": u.angle},
        "mobility": len(mech.variables) - 2 * len(mech.loops),
        "inputs": list(ck.inputs),
        "unknowns": list(ck.unknowns),
        "variables": [{"name": v.name, "kind": "angle" if v.kind is Kind.ANGLE else "length",
                       "input": v.name in ck.inputs} for v in mech.variables],
        "parameters": {p.name: (conv(p.value) if p.kind is Kind.ANGLE else p.value) for p in mech.parameters},
        "loops": [{"name": lp.name, "equation": lp.text} for lp in mech.loops],
        "blocks": [[ck.unknowns[j] for j in b.unknowns] for b in ck.blocks],
        "points": [p.name for p in mech.points],
        "modes": dict(mech.mode_aliases),
        "fourbars": [],
    }
    try:
        from . import classic
    except ImportError:  # pragma: no cover
        classic = None
    if classic is not None:
        for loop, lengths, ground, moving in _fourbar_loops(mech):
            # order the moving links along the loop: input crank first when it is in this loop
            r1 = lengths[ground]
            crank = next((n for n in moving if _expr_uses(mech, n, ck.inputs[0])), moving[0])
            others = [n for n in moving if n != crank]
            # the coupler is the one not touching the ground: in r2 + r3 = r1 + r4 the side with the crank
            sign = {n: s for s, n in loop.terms}
            coupler = next((n for n in others if sign[n] == sign[crank]), others[0])
            rocker = next(n for n in others if n != coupler)
            r2, r3, r4 = lengths[crank], lengths[coupler], lengths[rocker]
            g = classic.grashof(r1, r2, r3, r4)
            ranges = classic.fourbar_input_range(r1, r2, r3, r4)
            mu = classic.transmission_angle_range(r1, r2, r3, r4)
            data["fourbars"].append({
                "loop": loop.name,
                "links": {"ground": ground, "crank": crank, "coupler": coupler, "rocker": rocker},
                "lengths": {"ground": r1, "crank": r2, "coupler": r3, "rocker": r4},
                "grashof": g.value,
                "input_range": [[conv(a), conv(b)] for a, b in ranges],
                "transmission_angle_range": [conv(mu[0]), conv(mu[1])],
            })
    return data


def _expr_uses(mech: Mechanism, vector: str, var: str) -> bool:
    from . import expr as _expr

    v = mech.vector(vector)
    return var in _expr.names(v.angle) if v.angle is not None else False


def format_info(data: dict) -> str:
    """Human-readable text of :func:`info`."""
    u = data["units"]
    lines = [f"{data['name']}" + (f"  ({data['source']})" if data.get("source") else ""),
             f"  units: length {u['length']}, angle {u['angle']}",
             f"  mobility: {data['mobility']}",
             f"  input(s): {', '.join(data['inputs'])}",
             f"  unknowns: {', '.join(data['unknowns'])}",
             "  loops: " + "; ".join(f"{lp['name']}: {lp['equation']}" for lp in data["loops"]),
             "  solve order (blocks): " + " -> ".join("(" + ", ".join(b) + ")" for b in data["blocks"])]
    if data.get("points"):
        lines.append(f"  points: {', '.join(data['points'])}")
    if data.get("modes"):
        lines.append("  mode names: " + ", ".join(f"{k} = {v}" for k, v in data["modes"].items()))
    for fb in data.get("fourbars", []):
        ln = fb["links"]
        lines.append(f"  four-bar loop {fb['loop']}: ground {ln['ground']}, crank {ln['crank']}, coupler "
                     f"{ln['coupler']}, rocker {ln['rocker']}: {fb['grashof']}")
        rng = ", ".join(f"[{a:.6g}, {b:.6g}]" for a, b in fb["input_range"])
        lines.append(f"    input range ({u['angle']}): {rng}")
        mu = fb["transmission_angle_range"]
        lines.append(f"    transmission angle ({u['angle']}): {mu[0]:.6g} to {mu[1]:.6g}")
    for k, v in data.items():
        if k.endswith("_text"):
            lines.append(v)
    return "\n".join(lines) + "\n"
