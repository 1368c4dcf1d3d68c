"""What a model is made of: variables, loops, mobility, solve order and classic properties.

``info(mech)`` is the data behind ``loopsolve info``; ``format_info`` prints it for people.
"""

from __future__ import annotations

import math

import numpy as np

from ..model.mechanism import Mechanism
from ..model.units import Kind

__all__ = ["info", "format_info"]


def info(mech: Mechanism, *, input=None, reach: bool = True) -> dict:
    """Structure summary of ``mech`` as a JSON-ready dict.

    Keys: ``name``, ``source``, ``units``, ``mobility``, ``inputs``, ``unknowns``, ``variables``,
    ``parameters``, ``loops``, ``blocks`` (solve order: lists of unknown names), ``points``,
    ``fourbars`` (Grashof class, input range, transmission-angle range of four-bar loops).

    ``mobility`` is the Gruebler–Kutzbach count for a kinematic-diagram model (whose
    ``topology`` gives links, joints and the formula), else joint variables minus twice the
    loops, minus one for each higher pair (``pairs``: constraints, gear pairs, cams, slots,
    rolling contacts, each with its ``name`` and ``equation``); ``mobility_rank`` is the second opinion: joint variables minus the rank of Φ_q at
    the solved start pose (``None`` when it does not assemble). Four-bar loops (found in the
    link–joint graph of a diagram, also inside six-bars, or as four constant-length vectors of
    a vector loop) name their ``ground``, ``input`` (the side that drives the loop: the
    mechanism's input or a link solved earlier), ``coupler`` and ``output`` links with their
    lengths, the Grashof class seen from the input, ``input_motion`` and ``input_range`` in
    the loop's driving variable (``input``; see :func:`_fourbars`). ``quick_return`` lists inverted slider-crank
    loops (fixed frame, input crank, sliding lever): type ``crank-slotted-lever`` (classic
    time ratio and lever swing from :func:`loopsolve.kinematics.classic.quick_return`) or ``whitworth``;
    ``rams`` gives the stroke and time ratio of every later slider over a full crank turn,
    and ``stroke`` the output stroke (the first ram, else the lever swing).
    ``reachable_input_ranges`` (the input's reachable intervals, by assembly tests along a full
    range) is left out with ``reach=False`` (the costly part, for callers that need the structure).

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
        "mobility": len(mech.variables) - mech.n_equations,
        "mobility_rank": None,
        "inputs": list(ck.inputs),
        "unknowns": list(ck.unknowns),
        "variables": [{"name": v.name, "kind": "angle" if v.kind is Kind.ANGLE else "length",
                       "input": v.name in ck.inputs} for v in mech.variables],
        "parameters": {p.name: (conv(p.value) if p.kind is Kind.ANGLE else p.value) for p in mech.parameters},
        "loops": [{"name": lp.name, "equation": lp.text} for lp in mech.loops],
        "pairs": ([{"name": e.key, "equation": e.text} for e in mech.pairs.rows] if mech.pairs is not None else []),
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
    if z0 is not None and mech.pairs is not None and mech.pairs.gears:
        from .pairchecks import check_gears

        check_gears(ck, z0[:, None])  # gears whose centres drift are a model error, at the start pose too
    if top is not None:
        mob = top.mobility()
        data["mobility"] = mob.gruebler - (mech.pairs.n_rows if mech.pairs is not None else 0)
        data["topology"] = {"links": mob.n_links, "joints": len(top.joints), "j1": mob.j1, "j2": mob.j2,
                            "gruebler": mob.gruebler, "formula": mob.formula(),
                            "independent_loops": mob.loops,
                            "prismatic": [j.name for j in top.joints if j.kind == "P"]}
    if z0 is not None:
        data["mobility_rank"] = _rank_mobility(ck, z0)
    if classic is not None:
        data["fourbars"] = _fourbars(mech, ck, top, z0, conv, classic)
        data["quick_return"] = _quick_returns(mech, ck, z0, conv, classic)
    if reach:
        data["reachable_input_ranges"] = _reachable_ranges(ck)
    return data


def _reachable_ranges(ck) -> list[list[float]]:
    """Assemblable intervals of the driving input found by the tracker (display units)."""
    from .solve import display_value
    from .reach import reachable_ranges

    return [[display_value(ck, a), display_value(ck, b)] for a, b in reachable_ranges(ck)]


def _topology(mech: Mechanism):
    """The link–joint topology of a diagram model, else None."""
    from ..model.diagram import topology_of

    return topology_of(mech)


def _start_pose(ck):
    """All variables solved at the input's guess in the mode the guesses name (the drawn pose of a
    diagram), or None."""
    import warnings

    from ..errors import LoopsolveError
    from .solve import initial_z, start_position

    x = float(initial_z(ck, warn=False)[ck.input_idx[0]])
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # info reports; the solve commands warn about guesses
            z, _, _ = start_position(ck, x)
    except LoopsolveError:
        return None
    return z


def _rank_mobility(ck, z) -> int:
    """Joint variables minus the rank of Φ_q (all variables) at ``z``.

    The columns of the unknowns are the compiled Jacobian; only the input columns come from
    central differences (two evaluations of Φ per input, not per variable).
    """
    import numpy as np

    from ..model.topology import jacobian_rank

    n = len(ck.variables)
    jq = ck.jac(z)
    # Φ_q is block triangular in the solve order: when every diagonal block has full rank, so
    # has Φ_q, and [Φ_q | Φ_x] has rank len(unknowns) without a decomposition of the whole
    if jq.size and all(jacobian_rank(jq[np.ix_(b.eqs, b.unknowns)], rtol=1e-7) == len(b.unknowns)
                       for b in ck.blocks):
        return n - jq.shape[0]
    jac = np.zeros((len(ck.phi(z)), n))
    jac[:, ck.unknown_idx] = jq
    for i in ck.input_idx:
        h = 1e-6 * (ck.scale if ck.kinds[i] is Kind.LENGTH else 1.0)
        zp, zm = z.copy(), z.copy()
        zp[i] += h
        zm[i] -= h
        jac[:, i] = (ck.phi(zp) - ck.phi(zm)) / (2 * h)
    return n - jacobian_rank(jac, rtol=1e-7)


_TWO_PI = 2 * math.pi


def _angle(v) -> float:
    return math.atan2(float(v[1]), float(v[0]))


def _full(ranges) -> bool:
    return any(hi - lo >= _TWO_PI - 1e-12 for lo, hi in ranges)


def _intersect(a: list, b: list) -> list:
    """Intersection of two sets of angle intervals on the circle (each ``(lo, hi)``, ``hi - lo <= 2π``)."""
    if _full(a):
        return list(b)
    if _full(b):
        return list(a)
    out = []
    for lo, hi in a:
        for blo, bhi in b:
            k = math.floor((lo - bhi) / _TWO_PI)  # shift b to overlap a where it can
            for m in range(k, k + 3):
                l2, h2 = max(lo, blo + m * _TWO_PI), min(hi, bhi + m * _TWO_PI)
                if h2 > l2 + 1e-15:
                    out.append((l2, h2))
    return out


def _shown(ranges: list) -> list:
    """Intervals as shown: each moved by whole turns so that it starts in [−π, π); sorted."""
    if _full(ranges):
        return [(-math.pi, math.pi)]
    out = []
    for lo, hi in ranges:
        shift = -_TWO_PI * math.floor((lo + math.pi) / _TWO_PI)
        out.append((lo + shift, hi + shift))
    return sorted(out)


def _transmission(g, a, b, c, phis: list) -> tuple[float, float]:
    """Extreme transmission angles while the input angle ``φ`` (at its pivot, from the frame) stays in ``phis``.

    The diagonal from the input pin to the output pivot, ``BD² = g² + a² − 2 g a cos φ``, sets
    ``cos μ = (b² + c² − BD²) / (2 b c)``: μ grows with BD, BD with ``|φ|``.
    """
    if not phis:
        return (math.nan, math.nan)
    cmax, cmin = -1.0, 1.0
    for lo, hi in phis:
        if hi - lo >= _TWO_PI - 1e-12:
            cmax, cmin = 1.0, -1.0
            break
        has0 = math.floor(hi / _TWO_PI) >= math.ceil(lo / _TWO_PI)
        haspi = math.floor((hi - math.pi) / _TWO_PI) >= math.ceil((lo - math.pi) / _TWO_PI)
        ends = (math.cos(lo), math.cos(hi))
        cmax = max(cmax, 1.0 if has0 else max(ends))
        cmin = min(cmin, -1.0 if haspi else min(ends))

    def mu(cos_phi):
        bd2 = g * g + a * a - 2 * g * a * cos_phi
        # at a limit of the input the diagonal is exactly b + c or |b - c|: mu is exactly 180 deg or 0
        # ((b² + c² − (b ± c)²) / (2 b c) need not round to ∓1)
        for ell, at_limit in ((b + c, math.pi), (b - c, 0.0)):
            if abs(bd2 - ell * ell) <= 1e-9 * (b + c) ** 2:
                return at_limit
        return math.acos(min(1.0, max(-1.0, (b * b + c * c - bd2) / (2 * b * c))))

    return (mu(cmax), mu(cmin))


def loop_walk(loop) -> list:
    """The closed walk of a loop: the left side forward, the right side backward."""
    if loop.rhs:
        return list(loop.lhs) + [(-s, n) for s, n in reversed(loop.rhs)]
    return list(loop.terms)


def _vector_candidates(mech: Mechanism, ck, z) -> list:
    """Four-bar loops of a vector-loop model: four constant-length vectors, one fixed (the frame).

    The walk (left side forward, right side backward) places the four sides as a polygon at
    the start pose, so the coupler is the side opposite the frame whatever the vectors' names.
    """
    from ..model import expr as _expr

    var_names = set(ck.variables)
    vals = {name: lv for name, lv in zip(ck.vectors, ck.vector_values(0, z))}
    # does a vector turn with its variable or against it? every variable nudged at once: a
    # side of a four-bar depends on one variable only
    nudged = {name: lv for name, lv in zip(ck.vectors, ck.vector_values(0, z + 1e-6))}
    out = []
    for loop in mech.loops:
        walk = loop_walk(loop)
        if len(walk) != 4 or len({n for _, n in walk}) != 4:
            continue
        sides, ok = [], True
        for sign, name in walk:
            v = mech.vector(name)
            if v.cartesian or _expr.names(v.length) & var_names:
                ok = False
                break
            av = (_expr.names(v.angle) | (_expr.names(v.offset) if v.offset is not None else set())) & var_names
            if len(av) > 1:
                ok = False
                break
            length, ang = vals[name]
            d = sign * length * np.array([math.cos(ang), math.sin(ang)])
            sides.append((name, next(iter(av)) if av else None, d))
        if not ok or sum(v is None for _, v, _ in sides) != 1 or len({v for _, v, _ in sides if v}) != 3:
            continue
        k = next(i for i, (_, v, _) in enumerate(sides) if v is None)
        sides = sides[k:] + sides[:k]  # the frame first: frame, side 1, coupler, side 3
        corners = [np.zeros(2)]
        for _, _, d in sides[:3]:
            corners.append(corners[-1] + d)
        # corners: 0 = start of the frame side, 1 = its end (pivot of side 1), 2 = pin of side 1,
        # 3 = pin of side 3 (whose pivot is corner 0)
        ends = {sides[1][0]: (corners[1], corners[2]), sides[3][0]: (corners[0], corners[3])}
        sense = {}
        for name, v, _ in (sides[1], sides[3]):
            turn = math.remainder(float(nudged[name][1]) - float(vals[name][1]), _TWO_PI)
            sense[name] = 1.0 if turn >= 0 else -1.0
        out.append({"loop": loop.name, "frame": sides[0][0], "sides": (sides[1][0], sides[3][0]),
                    "coupler": sides[2][0], "var": {sides[1][0]: sides[1][1], sides[3][0]: sides[3][1]},
                    "ends": ends, "sense": sense, "joints": None,
                    "len": {name: float(vals[name][0]) for name, _, _ in sides}})
    return out


def _diagram_candidates(ck, top, z) -> list:
    """Four-bar loops of a diagram (four links incl. the ground, four pins), from the drawn joints."""
    from ..model.topology import GROUND

    pts = {name: np.asarray(xy, dtype=float) for name, xy in zip(ck.points, ck.point_values(0, z))}
    rep = top.rotation_groups

    def var(link):
        return None if rep[link] == GROUND else f"theta_{rep[link]}"

    out = []
    for i, steps in enumerate(top.loops()):
        links = [s[0] for s in steps]
        joints = [s[1] for s in steps]
        if len(steps) != 4 or links[0] != GROUND or any(top.joint_map[j].kind != "R" for j in joints):
            continue
        if any(var(lk) is None for lk in links[1:]) or len({var(lk) for lk in links[1:]}) != 3:
            continue
        (_, jd, ja), (l1, _, jb), (l2, _, jc), (l3, _, _) = steps
        out.append({"loop": f"loop{i + 1}", "frame": GROUND, "sides": (l1, l3), "coupler": l2,
                    "var": {l1: var(l1), l3: var(l3)},
                    "ends": {l1: (pts[ja], pts[jb]), l3: (pts[jd], pts[jc])}, "sense": {l1: 1.0, l3: 1.0},
                    "joints": {l1: (ja, jb), l3: (jd, jc)}})
    return out


def _fourbars(mech: Mechanism, ck, top, z, conv, classic) -> list:
    """Four-bar loops: which side drives, Grashof class, range of the driving variable, transmission.

    A loop's input is the side link whose angle is the mechanism's input or is solved in an
    earlier block (a rocker of an earlier loop driving a second four-bar); the coupler is the
    side opposite the frame, the output the other side. Lengths come from the solved start
    pose. The Grashof class is read from the input's point of view (:func:`classic.grashof`
    with the input as ``r2``). ``input_range`` lists the intervals of the input variable where
    the loop is driven: where it assembles (law of cosines on the diagonal from the input pin
    to the output pivot) and, for an input driven by an earlier four-bar's output, within the
    swing that output reaches. ``input_motion`` says whether the input turns fully or rocks.
    """
    if z is None:
        return []
    cands = _diagram_candidates(ck, top, z) if top is not None else _vector_candidates(mech, ck, z)
    if not cands:
        return []

    def order(v):
        if v in ck.inputs:
            return -1
        j = ck.unknowns.index(v)
        return next(i for i, b in enumerate(ck.blocks) if j in b.unknowns)

    reach: dict[str, list] = {}  # variable -> intervals it reaches (from earlier loops' outputs)
    rows = []
    for cand in cands:
        s1, s3 = cand["sides"]
        v1, v3 = cand["var"][s1], cand["var"][s3]
        o1, o3 = order(v1), order(v3)
        vc = cand["var"].get(cand["coupler"])
        if o1 == o3 or (vc is not None and order(vc) < min(o1, o3)):
            continue  # no side drives the loop (the coupler is driven, or both sides are)
        inp, out = (s1, s3) if o1 < o3 else (s3, s1)
        rows.append((min(o1, o3), cand, inp, out))
    rows.sort(key=lambda r: r[0])
    result = []
    for _, cand, inp, out in rows:
        x, y = cand["var"][inp], cand["var"][out]
        piv_in, pin_in = cand["ends"][inp]
        piv_out, pin_out = cand["ends"][out]
        g = float(np.linalg.norm(piv_out - piv_in))
        a = float(np.linalg.norm(pin_in - piv_in))
        b = float(np.linalg.norm(pin_out - pin_in))
        c = float(np.linalg.norm(pin_out - piv_out))
        if cand.get("len"):  # the declared lengths, not their round trip through the pose
            g, a, b, c = (cand["len"][n] for n in (cand["frame"], inp, cand["coupler"], out))
        if min(g, a, b, c) <= 0.0:
            continue
        # the input angle at its pivot measured from the frame: phi = phi0 + (x - x0); its range
        # (symmetric about phi = 0) in x is x0 - phi0 + range(phi); likewise the output's
        phi0 = _angle(pin_in - piv_in) - _angle(piv_out - piv_in)
        psi0 = _angle(pin_out - piv_out) - _angle(piv_in - piv_out)
        x0, y0 = float(z[ck.index(x)]), float(z[ck.index(y)])
        sx, sy = cand["sense"][inp], cand["sense"][out]
        own = [(x0 - sx * phi0 + lo, x0 - sx * phi0 + hi) for lo, hi in classic.fourbar_input_range(g, a, b, c)]
        driven_by = "input" if x in ck.inputs else None
        rng = own
        if x not in ck.inputs and x in reach:
            rng = _intersect(own, reach[x][1])
            driven_by = reach[x][0]
        out_rng = [(y0 - sy * psi0 + lo, y0 - sy * psi0 + hi) for lo, hi in classic.fourbar_input_range(g, c, b, a)]
        # the output moves continuously: it stays in the interval that holds its start value
        here = [(lo, hi) for lo, hi in out_rng if _full([(lo, hi)]) or (y0 - lo) % _TWO_PI <= hi - lo + 1e-12]
        reach.setdefault(y, (cand["loop"], [(lo + _TWO_PI * math.floor((y0 - lo) / _TWO_PI),
                                             hi + _TWO_PI * math.floor((y0 - lo) / _TWO_PI)) for lo, hi in here]))
        # phi = phi0 + sx (x - x0): an input turning against its vector (sx = -1) reverses the interval
        phis = [tuple(sorted((sx * (lo - x0) + phi0, sx * (hi - x0) + phi0))) for lo, hi in rng]
        mu = _transmission(g, a, b, c, phis)
        shown = _shown(rng)
        entry = {
            "loop": cand["loop"],
            "links": {"ground": cand["frame"], "input": inp, "coupler": cand["coupler"], "output": out},
            "lengths": {"ground": g, "input": a, "coupler": b, "output": c},
            "input": x,
            "output": y,
            "driven_by": driven_by,
            "grashof": classic.grashof(g, a, b, c).value,
            "input_motion": "turns fully" if _full(rng) else ("rocks" if rng else "cannot move"),
            "input_range": [[conv(lo), conv(hi)] for lo, hi in shown],
            "transmission_angle_range": [conv(mu[0]), conv(mu[1])],
        }
        if cand["joints"] is not None:
            (ja, jb), (jd, jc) = cand["joints"][inp], cand["joints"][out]
            entry["joints"] = {"input_pivot": ja, "input_pin": jb, "output_pin": jc, "output_pivot": jd}
        result.append(entry)
    return result


def _quick_returns(mech: Mechanism, ck, z, conv, classic) -> list:
    """Inverted slider-crank loops (fixed frame + input crank = sliding lever): quick returns.

    The crank-and-slotted-lever type (frame ``d`` > crank ``r2``) gets the classic time ratio
    and lever swing (:func:`loopsolve.kinematics.classic.quick_return`); the Whitworth type (``d < r2``,
    the lever turns fully) its time ratio from the ram. Strokes and time ratios of the rams
    (length unknowns solved after the loop) come from a full crank turn.
    """
    from ..model import expr as _expr

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


def _cycle_samples(ck, z0, n: int = 180):
    """Positions over one full turn of the input from ``z0`` (continuation), or None."""
    from ..errors import LoopsolveError
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


def _illinois(f, a: float, b: float, fa: float, fb: float, *, xtol: float = 1e-13, max_iter: int = 100) -> float:
    """A root of ``f`` in ``[a, b]`` where ``fa``, ``fb`` differ in sign (Illinois regula falsi).

    Examples
    --------
    >>> round(_illinois(lambda x: x * x - 2.0, 1.0, 2.0, -1.0, 2.0), 12)
    1.414213562373
    """
    side = 0
    c = a
    for _ in range(max_iter):
        c = (a * fb - b * fa) / (fb - fa)
        fc = f(c)
        if fc == 0.0 or abs(b - a) <= xtol:
            return c
        if fc * fb < 0:
            a, fa = b, fb
            side_new = -1
        else:
            fa = fa / 2 if side == +1 else fa
            side_new = +1
        b, fb = c, fc
        side = side_new
    return c


def _stroke(ck, x, zs, k: int) -> dict:
    """Stroke of variable ``k`` over one turn and the time ratio of its two strokes.

    The extremes are where the kinematic coefficient dq/dx vanishes, found by the Illinois
    variant of regula falsi between the samples around the sampled extremes (no scipy import:
    it took a third of the time of ``loopsolve info``).
    """
    from ..errors import LoopsolveError
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
                xr = _illinois(lambda xv: coeff(xv, j), xa, xb, ga, gb)
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
             *(["  higher pairs: " + "; ".join(f"{e['name']}: {e['equation']}" for e in data["pairs"])]
               if data.get("pairs") else []),
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
        ln, lg = fb["links"], fb["lengths"]
        lines.append(f"  four-bar loop {fb['loop']}: {fb['grashof']} (input {ln['input']} {lg['input']:.6g}, coupler "
                     f"{ln['coupler']} {lg['coupler']:.6g}, output {ln['output']} {lg['output']:.6g}, ground "
                     f"{ln['ground']} {lg['ground']:.6g})")
        rng = ", ".join(f"[{a:.6g}, {b:.6g}]" for a, b in fb["input_range"]) or "none"
        by = "" if fb.get("driven_by") in (None, "input") else f", driven by {fb['driven_by']}"
        lines.append(f"    input {fb['input']} {fb['input_motion']}{by}: range ({u['angle']}) {rng}")
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
