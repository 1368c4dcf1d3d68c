"""What a model is made of: variables, loops, mobility, solve order and classic properties.

``info(mech)`` is the data behind ``loopsolve info``; ``format_info`` prints it for people.
"""

from __future__ import annotations

import math

import numpy as np

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

    ``mobility`` is the Gruebler–Kutzbach count for a kinematic-diagram model (whose
    ``topology`` gives links, joints and the formula), else joint variables minus twice the
    loops; ``mobility_rank`` is the second opinion: joint variables minus the rank of Φ_q at
    the solved start pose (``None`` when it does not assemble). For a diagram, four-bar loops
    are found in the link–joint graph (also inside six-bars) and their ``input_range`` is in
    the loop's driving variable (``input``). ``quick_return`` lists inverted slider-crank
    loops (fixed frame, input crank, sliding lever): type ``crank-slotted-lever`` (classic
    time ratio and lever swing from :func:`loopsolve.classic.quick_return`) or ``whitworth``;
    ``rams`` gives the stroke and time ratio of every later slider over a full crank turn,
    and ``stroke`` the output stroke (the first ram, else the lever swing).

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
        "mobility_rank": None,
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
    top = _topology(mech)
    z0 = _start_pose(ck)
    if top is not None:
        mob = top.mobility()
        data["mobility"] = mob.gruebler
        data["topology"] = {"links": mob.n_links, "joints": len(top.joints), "j1": mob.j1, "j2": mob.j2,
                            "gruebler": mob.gruebler, "formula": mob.formula(),
                            "independent_loops": mob.loops,
                            "prismatic": [j.name for j in top.joints if j.kind == "P"]}
    if z0 is not None:
        data["mobility_rank"] = _rank_mobility(ck, z0)
    if classic is not None and top is not None:
        data["fourbars"] = _diagram_fourbars(mech, ck, top, z0, conv, classic)
    if classic is not None:
        data["quick_return"] = _quick_returns(mech, ck, z0, conv, classic)
    if classic is not None and top is None:
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
    data["reachable_input_ranges"] = _reachable_ranges(ck)
    return data


def _reachable_ranges(ck) -> list[list[float]]:
    """Assemblable intervals of the driving input found by the tracker (display units)."""
    from .solve import display_value
    from .sweep import reachable_ranges

    return [[display_value(ck, a), display_value(ck, b)] for a, b in reachable_ranges(ck)]


def _expr_uses(mech: Mechanism, vector: str, var: str) -> bool:
    from . import expr as _expr

    v = mech.vector(vector)
    return var in _expr.names(v.angle) if v.angle is not None else False


def _topology(mech: Mechanism):
    """The link–joint topology of a diagram model, else None."""
    from .diagram import topology_of

    return topology_of(mech)


def _start_pose(ck):
    """All variables solved at the declared guesses (the drawn pose of a diagram), or None."""
    from .errors import LoopsolveError
    from .solve import initial_z, solve_position

    try:
        z, _, _ = solve_position(ck, initial_z(ck, warn=False))
    except LoopsolveError:
        return None
    return z


def _rank_mobility(ck, z) -> int:
    """Joint variables minus the rank of Φ_q (all variables, central differences) at ``z``."""
    import numpy as np

    from .topology import jacobian_rank

    n = len(ck.variables)
    jac = np.zeros((len(ck.phi(z)), n))
    for i, kind in enumerate(ck.kinds):
        h = 1e-6 * (ck.scale if kind is Kind.LENGTH else 1.0)
        zp, zm = z.copy(), z.copy()
        zp[i] += h
        zm[i] -= h
        jac[:, i] = (ck.phi(zp) - ck.phi(zm)) / (2 * h)
    return n - jacobian_rank(jac, rtol=1e-7)


def _diagram_fourbars(mech: Mechanism, ck, top, z, conv, classic) -> list:
    """Four-bar loops of a diagram (four links incl. the ground, four pins): Grashof and ranges.

    Lengths come from the solved start pose (the drawing, or overridden lengths). The loop's
    crank is the side link driven by an input, else the one solved in an earlier block; its
    input range is given in that link's angle variable.
    """
    from .topology import GROUND

    if z is None:
        return []
    pts = {name: xy for name, xy in zip(ck.points, ck.point_values(0, z))}
    rep = top.rotation_groups

    def var(link):
        return None if rep[link] == GROUND else f"theta_{rep[link]}"

    def order(v):
        if v in ck.inputs:
            return -1
        j = ck.unknowns.index(v)
        return next(i for i, b in enumerate(ck.blocks) if j in b.unknowns)

    out = []
    for i, steps in enumerate(top.loops()):
        links = [s[0] for s in steps]
        joints = [s[1] for s in steps]
        if len(steps) != 4 or links[0] != GROUND or any(top.joint_map[j].kind != "R" for j in joints):
            continue
        if any(var(lk) is None for lk in links[1:]) or len({var(lk) for lk in links[1:]}) != 3:
            continue
        (_, jd, ja), (l1, _, jb), (l2, _, jc), (l3, _, _) = steps
        if order(var(l3)) < order(var(l1)):  # the crank is the link solved first
            l1, l3, ja, jd, jb, jc = l3, l1, jd, ja, jc, jb
        p2, pin, rpin, p4 = (np.asarray(pts[j], dtype=float) for j in (ja, jb, jc, jd))
        r1, r2, r3, r4 = (float(np.linalg.norm(b - a)) for a, b in ((p2, p4), (p2, pin), (pin, rpin), (rpin, p4)))
        crank_var = var(l1)
        g_dir = math.atan2(*(p4 - p2)[::-1])
        shift = g_dir + (z[ck.index(crank_var)] - math.atan2(*(pin - p2)[::-1]))
        ranges = classic.fourbar_input_range(r1, r2, r3, r4)
        if ranges == [(-math.pi, math.pi)]:
            shown = [[conv(-math.pi), conv(math.pi)]]
        else:
            shown = []
            for a, b in ranges:
                a2 = math.remainder(a + shift, 2 * math.pi)
                shown.append([conv(a2), conv(a2 + (b - a))])
        mu = classic.transmission_angle_range(r1, r2, r3, r4)
        out.append({
            "loop": f"loop{i + 1}",
            "links": {"ground": GROUND, "crank": l1, "coupler": l2, "rocker": l3},
            "joints": {"crank_pivot": ja, "crank_pin": jb, "rocker_pin": jc, "rocker_pivot": jd},
            "lengths": {"ground": r1, "crank": r2, "coupler": r3, "rocker": r4},
            "input": crank_var,
            "grashof": classic.grashof(r1, r2, r3, r4).value,
            "input_range": shown,
            "transmission_angle_range": [conv(mu[0]), conv(mu[1])],
        })
    return out


def _quick_returns(mech: Mechanism, ck, z, conv, classic) -> list:
    """Inverted slider-crank loops (fixed frame + input crank = sliding lever): quick returns.

    The crank-and-slotted-lever type (frame ``d`` > crank ``r2``) gets the classic time ratio
    and lever swing (:func:`loopsolve.classic.quick_return`); the Whitworth type (``d < r2``,
    the lever turns fully) its time ratio from the ram. Strokes and time ratios of the rams
    (length unknowns solved after the loop) come from a full crank turn.
    """
    from . import expr as _expr

    if z is None or not ck.inputs or ck.kinds[ck.index(ck.inputs[0])] is not Kind.ANGLE:
        return []
    inp = ck.inputs[0]
    var_names = set(ck.variables)
    vals = {name: lv for name, lv in zip(ck.vectors, ck.vector_values(0, z))}
    out = []
    samples = None
    for loop in mech.loops:
        fixed, crank, slide = [], [], []
        ok = True
        for sign, name in loop.terms:
            v = mech.vector(name)
            if v.cartesian:
                if (_expr.names(v.x) | _expr.names(v.y)) & var_names:
                    ok = False
                else:
                    fixed.append((sign, name))
                continue
            lv = _expr.names(v.length) & var_names
            av = (_expr.names(v.angle) | (_expr.names(v.offset) if v.offset is not None else set())) & var_names
            if not lv and not av:
                fixed.append((sign, name))
            elif not lv and av == {inp}:
                crank.append((sign, name))
            elif isinstance(v.length, _expr.Name) and lv == {v.length.id} and len(av) == 1 and inp not in av:
                slide.append((sign, name, v.length.id, next(iter(av))))
            else:
                ok = False
        if not ok or len(crank) != 1 or len(slide) != 1 or not fixed:
            continue
        d_vec = sum(s * vals[n][0] * np.array([math.cos(vals[n][1]), math.sin(vals[n][1])]) for s, n in fixed)
        d = float(np.linalg.norm(d_vec))
        r2 = float(vals[crank[0][1]][0])
        if d <= 0 or abs(d - r2) <= 1e-9 * max(d, r2):
            continue
        _, _, s_var, lever = slide[0]
        entry = {"loop": loop.name, "crank": crank[0][1], "lever": lever, "slider": s_var,
                 "r2": r2, "d": d, "type": "crank-slotted-lever" if d > r2 else "whitworth",
                 "time_ratio": None, "advance_angle": None, "return_angle": None, "rocking_angle": None,
                 "stroke": None, "rams": []}
        if d > r2:
            ratio, adv, ret, rock = classic.quick_return(r2, d)
            entry.update(time_ratio=float(ratio), advance_angle=conv(float(adv)), return_angle=conv(float(ret)),
                         rocking_angle=conv(float(rock)))
            entry["stroke"] = {"variable": lever, "value": conv(float(rock)), "unit": mech.units.angle}
        if samples is None:
            samples = _cycle_samples(ck, z)
        if samples is not None:
            x, zs = samples
            for name, kind in zip(ck.variables, ck.kinds):
                if kind is not Kind.LENGTH or name in ck.inputs or name == s_var:
                    continue
                ram = _stroke(ck, x, zs, ck.index(name))
                ram["variable"] = name
                entry["rams"].append(ram)
            if entry["rams"]:
                ram = entry["rams"][0]
                entry["stroke"] = {"variable": ram["variable"], "value": ram["stroke"], "unit": mech.units.length}
                if d < r2:
                    entry.update(time_ratio=ram["time_ratio"], advance_angle=conv(ram["advance_angle"]),
                                 return_angle=conv(ram["return_angle"]))
            for ram in entry["rams"]:
                ram["advance_angle"], ram["return_angle"] = conv(ram["advance_angle"]), conv(ram["return_angle"])
        out.append(entry)
    return out


def _cycle_samples(ck, z0, n: int = 720):
    """Positions over one full turn of the input from ``z0`` (continuation), or None."""
    from .errors import LoopsolveError
    from .solve import solve_position

    i = ck.input_idx[0]
    x = z0[i] + np.linspace(0.0, 2 * math.pi, n + 1)
    z = z0.copy()
    zs = []
    try:
        for xv in x:
            z = z.copy()
            z[i] = xv
            z, _, _ = solve_position(ck, z)
            zs.append(z)
    except LoopsolveError:
        return None
    return x, np.array(zs)


def _stroke(ck, x, zs, k: int) -> dict:
    """Stroke of variable ``k`` over one turn and the time ratio of its two strokes.

    The extremes are where the kinematic coefficient dq/dx vanishes, found by Brent's
    method between the samples around the sampled extremes.
    """
    from scipy.optimize import brentq

    from .errors import LoopsolveError
    from .solve import solve_position, solve_rates

    y = zs[:-1, k]
    n = len(y)
    i_in = ck.input_idx[0]

    def state(xv, j):
        z = zs[j].copy()
        z[i_in] = xv
        z, _, _ = solve_position(ck, z)
        return z

    def coeff(xv, j):
        z = state(xv, j)
        return solve_rates(ck, z, (1.0, 0.0, 0.0))[0][k]

    def extreme(j):
        a, b = (j - 1) % n, (j + 1) % n
        xa, xb = x[j] - (x[1] - x[0]), x[j] + (x[1] - x[0])
        try:
            ga, gb = coeff(xa, a), coeff(xb, b)
            if ga * gb < 0:
                xr = brentq(lambda xv: coeff(xv, j), xa, xb, xtol=1e-13, rtol=1e-15)
                return xr, float(state(xr, j)[k])
        except (LoopsolveError, ValueError):
            pass
        return float(x[j]), float(y[j])

    x_max, y_max = extreme(int(np.argmax(y)))
    x_min, y_min = extreme(int(np.argmin(y)))
    forward = (x_max - x_min) % (2 * math.pi)  # min -> max as the input turns positively
    slow, fast = max(forward, 2 * math.pi - forward), min(forward, 2 * math.pi - forward)
    return {"min": y_min, "max": y_max, "stroke": y_max - y_min,
            "time_ratio": float(slow / fast) if fast > 0 else None,
            "advance_angle": float(slow), "return_angle": float(fast)}


def format_info(data: dict) -> str:
    """Human-readable text of :func:`info`."""
    u = data["units"]
    lines = [f"{data['name']}" + (f"  ({data['source']})" if data.get("source") else ""),
             f"  units: length {u['length']}, angle {u['angle']}",
             f"  mobility: {data['mobility']}"
             + (f" ({data['topology']['formula']})" if data.get("topology") else "")
             + (f"; Jacobian rank at the start pose leaves {data['mobility_rank']}"
                if data.get("mobility_rank") is not None else ""),
             f"  input(s): {', '.join(data['inputs'])}",
             f"  unknowns: {', '.join(data['unknowns'])}",
             "  loops: " + "; ".join(f"{lp['name']}: {lp['equation']}" for lp in data["loops"]),
             "  solve order (blocks): " + " -> ".join("(" + ", ".join(b) + ")" for b in data["blocks"])]
    if data.get("points"):
        lines.append(f"  points: {', '.join(data['points'])}")
    if data.get("modes"):
        lines.append("  mode names: " + ", ".join(f"{k} = {v}" for k, v in data["modes"].items()))
    if "reachable_input_ranges" in data:
        rr = data["reachable_input_ranges"]
        lines.append(f"  reachable range(s) of {data['inputs'][0]} (tracked to the limit positions): "
                     + (", ".join(f"[{a:.10g}, {b:.10g}]" for a, b in rr) if rr else "none found"))
    for fb in data.get("fourbars", []):
        ln = fb["links"]
        lines.append(f"  four-bar loop {fb['loop']}: ground {ln['ground']}, crank {ln['crank']}, coupler "
                     f"{ln['coupler']}, rocker {ln['rocker']}: {fb['grashof']}")
        rng = ", ".join(f"[{a:.6g}, {b:.6g}]" for a, b in fb["input_range"])
        lines.append(f"    input range ({u['angle']}): {rng}")
        mu = fb["transmission_angle_range"]
        lines.append(f"    transmission angle ({u['angle']}): {mu[0]:.6g} to {mu[1]:.6g}")
    for qr in data.get("quick_return", []):
        lines.append(f"  quick return ({qr['type']}) in {qr['loop']}: crank {qr['crank']} = {qr['r2']:.6g}, "
                     f"frame d = {qr['d']:.6g}, lever {qr['lever']}, slide {qr['slider']}")
        if qr.get("time_ratio") is not None:
            lines.append(f"    time ratio {qr['time_ratio']:.6g} (advance {qr['advance_angle']:.6g}, return "
                         f"{qr['return_angle']:.6g} {u['angle']})")
        if qr.get("rocking_angle") is not None:
            lines.append(f"    lever swing {qr['rocking_angle']:.6g} {u['angle']}")
        for ram in qr.get("rams", []):
            tr = f", time ratio {ram['time_ratio']:.6g}" if ram.get("time_ratio") is not None else ""
            lines.append(f"    stroke of {ram['variable']}: {ram['stroke']:.6g} {u['length']} "
                         f"({ram['min']:.6g} to {ram['max']:.6g}){tr}")
    for k, v in data.items():
        if k.endswith("_text"):
            lines.append(v)
    return "\n".join(lines) + "\n"
