"""Kinematic diagrams: joints drawn at one assembly pose and links as the joints they carry.

:func:`diagram_to_spec` turns the kinematic-diagram layout of a model file (``[joints]``,
``[links]``, ``[input]``; see the design notes) into the vector-loop layout that
:func:`loopsolve.model.spec.build_mechanism` validates, so a diagram model goes down exactly the same
pipeline as a hand-written one, and :func:`loopsolve.dumps` writes the generated model back as a
vector-loop file (the round trip).

Generated names (one documented rule)
-------------------------------------
* ``theta_<link>``: the angle of a moving link, measured CCW from +x, equal to the direction
  from the link's first listed joint to its second one (links joined by a slider turn together
  and share the variable of the one with the most joints).
* ``s_<joint>``: the slide of a prismatic joint along its axis, measured from the foot of the
  perpendicular dropped from its guide's reference point (the origin for the ground, else the
  guide's first joint) onto the line of sliding.
* ``r_<link>``: the vector from a moving link's first joint to its second; ``r_<link>_<joint>``
  from its first joint to a further joint (angle ``theta_<link>`` plus a constant offset), and
  from the origin to a ground joint. Every fixed length is a parameter with the vector's name.
* ``r_<joint>``: the sliding vector of a prismatic joint (length ``s_<joint>``).
* every joint is a point with its own name (columns ``B_x``, ``B_y``, ...).
* ``G_<link>``: the centre of mass of a body drawn with ``at = [x, y]`` (``[bodies]`` entries
  are named after their links), a tracer point carried by the link. The generated body has
  ``angle = "theta_<link>"`` (none for a link that only translates), ``joints`` the revolute
  joints the link lists, and ``guide = "r_<joint>"`` for the prismatic joint it slides on
  (``guide_body`` the guide link, or ``"frame"``). ``gravity`` and ``[[loads]]`` pass through.

The loops are a minimum cycle basis of the link–joint graph (the shortest independent loops,
which give the smallest solve blocks) and the guesses are the drawn pose, so the drawing fixes
the assembly mode.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .diagramparse import Diagram, parse_diagram
from .diagrambodies import body_specs
from ..errors import ModelError, TopologyError
from .mechanism import Mechanism
from .spec import build_mechanism
from .topology import GROUND, Link, PrismaticJoint, RevoluteJoint, Topology, check_inputs, jacobian_rank
from .units import Kind, angle_factor

__all__ = ["Diagram", "parse_diagram", "diagram_to_spec", "diagram_data", "from_declarations",
           "topology_of", "to_vector_model"]


# =============================================================================
# generation
# =============================================================================


@dataclass(frozen=True, slots=True)
class _Vec:
    """A generated vector: fixed or variable length, fixed or link-relative angle."""

    name: str
    angle: float  # absolute angle at the drawn pose (radians)
    length: float | None = None  # fixed length, or None when ``slide`` gives it
    slide: str | None = None  # variable-length name (s_<joint>)
    theta: str | None = None  # angle variable (None: fixed angle)
    ref: float = 0.0  # value of ``theta`` at the drawn pose (radians)


def _num(x: float) -> float | int:
    """A number as written to a model file: 12 significant digits, integers without ``.0``."""
    r = float(f"{x:.12g}")
    if r == 0.0:
        return 0
    if abs(r) < 1e15 and r == round(r):
        return int(round(r))
    return r


def _wrap(a: float) -> float:
    """Angle mapped onto (-pi, pi]."""
    w = math.remainder(a, 2 * math.pi)
    return math.pi if w == -math.pi else w


def _terms_text(terms: Mapping[str, int]) -> tuple[str, str]:
    """Signed vector sum → (positive part, negative part) as text."""
    pos, neg = [], []
    for name, c in terms.items():
        (pos if c > 0 else neg).extend([name] * abs(c))
    return " + ".join(pos), " + ".join(neg)


def _add(acc: dict[str, int], terms: Mapping[str, int], sign: int = 1) -> dict[str, int]:
    out = dict(acc)
    for k, c in terms.items():
        out[k] = out.get(k, 0) + sign * c
        if out[k] == 0:
            del out[k]
    return out


def _generate(d: Diagram) -> dict[str, Any]:
    top = d.topology
    where = f"{d.source}: " if d.source else ""
    jmap, lmap = top.joint_map, top.link_map
    rep = top.rotation_groups
    af = angle_factor(d.angle_unit)
    coords = np.array([j.at for j in top.joints], dtype=float)
    scale = float(max(np.abs(coords).max(initial=0.0), np.ptp(coords, axis=0).max(initial=0.0), 1e-300))
    tol = 1e-9 * scale
    problems: list[str] = []

    def at(j: str) -> np.ndarray:
        return np.array(jmap[j].at, dtype=float)

    guides = {j.name: top.guide(j.name) for j in top.joints if isinstance(j, PrismaticJoint)}

    # two revolute joints of one link drawn at the same point are one joint declared twice
    for lk in top.links:
        rs = [j for j in lk.joints if isinstance(jmap[j], RevoluteJoint)]
        xy = np.array([jmap[j].at for j in rs], dtype=float).reshape(-1, 2)
        close = np.hypot(*(xy[:, None, :] - xy[None, :, :]).transpose(2, 0, 1)) <= tol
        for i, k in zip(*np.nonzero(np.triu(close, 1))):
            a, b = rs[i], rs[k]
            problems.append(f"joints {a!r} and {b!r} of link {lk.name!r} are drawn at the same point: "
                            "when links meet at one pin declare one joint carried by all of them")

    # reference angle of every rotation group (the variable theta_<rep>)
    ref: dict[str, float] = {GROUND: 0.0}
    for lk in top.links:
        r = rep[lk.name]
        if r in ref:
            continue
        rl = lmap[r]
        ang = None
        j0 = at(rl.joints[0])
        for j in rl.joints[1:]:
            dv = at(j) - j0
            if np.linalg.norm(dv) > tol:
                ang = math.atan2(dv[1], dv[0])
                break
        if ang is None:
            members = [m for m in top.link_map if rep[m] == r]
            for j in top.joints:
                if isinstance(j, PrismaticJoint) and set(top.carriers[j.name]) & set(members):
                    ang = math.atan2(j.axis[1], j.axis[0])
                    break
        if ang is None:
            problems.append(f"link {r!r}: all its joints are drawn at one point, so its angle is undefined; "
                            "draw its joints apart")
            ang = 0.0
        ref[r] = ang
    if problems:
        raise TopologyError(where + "; ".join(problems), problems=[where + p for p in problems])

    def theta_of(link: str) -> str | None:
        r = rep[link]
        return None if r == GROUND else f"theta_{r}"

    # star vectors of every link: v[link][joint] = {vector name: coefficient}
    vecs: dict[str, _Vec] = {}
    slide_guess: dict[str, float] = {}
    star: dict[str, dict[str, dict[str, int]]] = {}
    for lk in top.links:
        th = theta_of(lk.name)
        rref = ref[rep[lk.name]]
        center = np.zeros(2) if lk.name == GROUND else at(lk.joints[0])
        star[lk.name] = {}
        for i, j in enumerate(lk.joints):
            terms: dict[str, int] = {}
            guided = guides.get(j) == lk.name
            if guided:
                u = np.array(jmap[j].axis)
                foot = at(j) + u * float(np.dot(center - at(j), u))
                part = foot - center
                slide_guess[f"s_{j}"] = float(np.dot(at(j) - foot, u))
            else:
                part = at(j) - center
            if np.linalg.norm(part) > tol:
                if lk.name != GROUND and i == 1:
                    vname = f"r_{lk.name}"
                else:
                    vname = f"r_{lk.name}_{j}"
                vecs[vname] = _Vec(vname, math.atan2(part[1], part[0]), length=float(np.linalg.norm(part)),
                                   theta=th, ref=rref)
                terms[vname] = 1
            if guided:
                u = jmap[j].axis
                vname = f"r_{j}"
                vecs[vname] = _Vec(vname, math.atan2(u[1], u[0]), slide=f"s_{j}", theta=th, ref=rref)
                terms[vname] = 1
            star[lk.name][j] = terms

    # tracer points: a vector from the carrying link's reference point, turning with the link
    for pname, xy, lname in d.points:
        lk = lmap[lname]
        center = np.zeros(2) if lname == GROUND else at(lk.joints[0])
        part = np.asarray(xy, dtype=float) - center
        star[lname][pname] = {}
        if np.linalg.norm(part) > tol:
            vname = f"r_{lname}_{pname}"
            vecs[vname] = _Vec(vname, math.atan2(part[1], part[0]), length=float(np.linalg.norm(part)),
                               theta=theta_of(lname), ref=ref[rep[lname]])
            star[lname][pname] = {vname: 1}

    # generated names must not collide (a link called ``a_b`` next to link ``a`` with joint ``b``)
    counts: dict[str, int] = {}
    for lname, by_joint in star.items():
        for terms in by_joint.values():
            for vname in terms:
                counts[vname] = counts.get(vname, 0) + 1
    dup = sorted(n for n, c in counts.items() if c > 1)
    if dup:
        raise TopologyError(f"{where}the generated vector name(s) {', '.join(dup)} collide; rename the links or "
                            "joints so that no link name is another link's name plus _joint")

    # variables: one angle per rotation group (declaration order), one slide per prismatic joint
    variables: dict[str, dict[str, Any]] = {}
    var_kind: dict[str, Kind] = {}
    for lk in top.links:
        th = theta_of(lk.name)
        if th is not None and th not in variables:
            variables[th] = {"guess": _num(ref[rep[lk.name]] / af)}
            var_kind[th] = Kind.ANGLE
    for j in top.joints:
        if isinstance(j, PrismaticJoint):
            variables[f"s_{j.name}"] = {"guess": _num(slide_guess[f"s_{j.name}"])}
            var_kind[f"s_{j.name}"] = Kind.LENGTH

    # inputs
    in_vars: list[str] = []
    for kind, nm in d.inputs:
        var = _input_variable(top, kind, nm, where, theta_of)
        if var in in_vars:
            raise TopologyError(f"{where}the inputs {', '.join(n for _, n in d.inputs)} drive the same "
                                f"variable {var} twice; name each driven joint or link once")
        in_vars.append(var)

    # loops (minimum cycle basis): their vector sums and the same vectors in walking order
    loop_terms: list[dict[str, int]] = []
    loop_walks: list[list[tuple[int, str]]] = []
    for steps in top.loops():
        acc: dict[str, int] = {}
        walk: list[tuple[int, str]] = []
        for link, j_in, j_out in steps:
            acc = _add(acc, star[link][j_out], +1)
            acc = _add(acc, star[link][j_in], -1)
            # across the link from j_in back to its reference point, then out to j_out
            walk += [(-c, v) for v, c in reversed(list(star[link][j_in].items()))]
            walk += [(c, v) for v, c in star[link][j_out].items()]
        loop_terms.append(acc)
        loop_walks.append(_cancel(walk))

    # mobility: Gruebler and the Jacobian rank at the drawn pose
    names = list(variables)
    jac = np.zeros((2 * len(loop_terms), len(names)))
    for li, terms in enumerate(loop_terms):
        for vname, c in terms.items():
            v = vecs[vname]
            e = np.array([math.cos(v.angle), math.sin(v.angle)])
            if v.slide is not None:
                jac[2 * li:2 * li + 2, names.index(v.slide)] += c * e
                length = slide_guess[v.slide]
            else:
                length = v.length
            if v.theta is not None:
                jac[2 * li:2 * li + 2, names.index(v.theta)] += c * length * np.array([-e[1], e[0]])
    mob = top.mobility(rank=jacobian_rank(jac), n_variables=len(names))
    if not in_vars and mob.gruebler > 0 and not mob.special:
        raise TopologyError(f"{where}no [input]: the mobility is {mob.gruebler} ({mob.formula()}); name the "
                            f"driven joint(s) in [input], e.g. joint = \"{top.links[0].joints[0]}\"")
    try:
        check_inputs(mob, len(in_vars), where=d.source or d.name, inputs=[n for _, n in d.inputs])
    except TopologyError as exc:
        if not d.points:
            raise
        note = (f"; note: {', '.join(p for p, _, _ in d.points)} named by one link only "
                f"{'is a point' if len(d.points) == 1 else 'are points'} (tracer points), not joints: "
                "list a joint on every link it connects")
        raise TopologyError(str(exc) + note, problems=[p + note for p in exc.problems] if exc.problems
                            else None) from None
    if mob.gruebler == 0:
        raise TopologyError(f"{where}mobility 0 ({mob.formula()}): a structure has no motion to solve")
    if len(names) - 2 * len(loop_terms) != mob.gruebler:  # pragma: no cover - guarded by _check_p_groups
        raise TopologyError(f"{where}{len(names)} joint variables and {len(loop_terms)} loops do not match the "
                            f"mobility {mob.gruebler}")
    for k, v in enumerate(in_vars):
        variables[v] = {"input": True, **variables[v]}
    if d.rates and in_vars:
        variables[in_vars[0]].update(d.rates)

    # points: every joint, reached from the origin through the links (breadth first from the ground)
    center_terms: dict[str, dict[str, int]] = {GROUND: {}}
    pos: dict[str, dict[str, int]] = {}
    queue = [GROUND]
    while queue:
        lname = queue.pop(0)
        for j in lmap[lname].joints:
            if j not in pos:
                pos[j] = _add(center_terms[lname], star[lname][j])
            for other in top.carriers[j]:
                if other not in center_terms:
                    center_terms[other] = _add(pos[j], star[other][j], -1)
                    queue.append(other)

    for pname, _, lname in d.points:
        pos[pname] = _add(center_terms[lname], star[lname][pname])

    # the spec
    used = set()
    for terms in loop_terms:
        used |= set(terms)
    for terms in pos.values():
        used |= set(terms)
    parameters: dict[str, Any] = {}
    vectors: dict[str, dict[str, Any]] = {}
    for vname, v in vecs.items():
        if vname not in used:
            continue
        entry: dict[str, Any] = {}
        if v.slide is not None:
            entry["length"] = v.slide
        else:
            parameters[vname] = _num(v.length)
            entry["length"] = vname
        if v.theta is None:
            entry["angle"] = _num(_wrap(v.angle) / af)
        else:
            entry["angle"] = v.theta
            off = _wrap(v.angle - v.ref)
            if abs(off) > 1e-12:
                entry["offset"] = _num(off / af)
        vectors[vname] = entry
    for pname, value in d.overrides.items():
        if pname not in parameters:
            raise TopologyError(f"{where}parameters.{pname}: not a generated length; a kinematic-diagram model "
                                "may override these: " + ", ".join(parameters))
        parameters[pname] = value
    loops = []
    for i, walk in enumerate(loop_walks):
        if not walk:
            raise TopologyError(f"{where}loop {i + 1} ({_loop_text(top.loops()[i])}) has no vector of nonzero "
                                "length: its joints are drawn at one point")
        loops.append({"name": f"loop{i + 1}", "equation": _walk_text(walk)})
    declared = list(d.raw.get("joints", {})) if isinstance(d.raw.get("joints"), Mapping) else []
    order = {n: i for i, n in enumerate(declared)}
    names = [j.name for j in top.joints] + [p for p, _, _ in d.points]
    points = {}
    for name in sorted(names, key=lambda n: order.get(n, len(order))):
        plus, minus = _terms_text(pos[name])
        text = plus + (" - " + " - ".join(minus.split(" + ")) if minus else "")
        if not plus and minus:
            text = "- " + " - ".join(minus.split(" + "))
        points[name] = text or "0"

    spec: dict[str, Any] = {"name": d.name}
    if d.description is not None:
        spec["description"] = d.description
    spec["units"] = {"length": d.length_unit, "angle": d.angle_unit}
    spec["parameters"] = parameters
    spec["variables"] = variables
    spec["vectors"] = vectors
    spec["loops"] = loops
    spec["points"] = points
    if d.modes:
        spec["modes"] = dict(d.modes)
    if "gravity" in d.raw:
        spec["gravity"] = d.raw["gravity"]
    if d.bodies:
        spec["bodies"] = body_specs(d.bodies, top, theta_of, where)
    if "loads" in d.raw:
        spec["loads"] = d.raw["loads"]
    for key in ("joints", "links", "input"):
        if key in d.raw:
            spec[key] = d.raw[key]
    return spec


def _cancel(walk: list[tuple[int, str]]) -> list[tuple[int, str]]:
    """A closed walk of signed vectors with every ``v, -v`` pair (also around the end) removed."""
    out: list[tuple[int, str]] = []
    for sign, v in walk:
        if out and out[-1] == (-sign, v):
            out.pop()
        else:
            out.append((sign, v))
    while len(out) >= 2 and out[0] == (-out[-1][0], out[-1][1]):
        out = out[1:-1]
    return out


def _walk_text(walk: list[tuple[int, str]]) -> str:
    """The loop equation of a closed walk, written so that reading it gives the walk back.

    The walk is turned to start after its last backward vector: ``a + b + c - d - e = 0`` is
    written ``a + b + c = e + d`` (the left side forward, the right side backward, the
    textbook form that draws the vectors tip to tail). A walk that changes direction more
    than twice keeps every vector on the left: ``a - b + c - d = 0``.
    """
    n = len(walk)
    starts = [k for k in range(n) if walk[k][0] > 0 and walk[k - 1][0] < 0]
    if not starts:  # every vector points one way round
        k0 = 0 if walk[0][0] > 0 else None
        if k0 is None:
            walk = [(-s, v) for s, v in reversed(walk)]
        return " + ".join(v for _, v in walk) + " = 0"
    rot = walk[starts[0]:] + walk[:starts[0]]
    runs = sum(1 for k in range(n) if rot[k][0] != rot[k - 1][0])
    if runs == 2:
        m = next(k for k in range(n) if rot[k][0] < 0)
        lhs = " + ".join(v for _, v in rot[:m])
        rhs = " + ".join(v for _, v in reversed(rot[m:]))
        return f"{lhs} = {rhs}"
    text = rot[0][1]
    for sign, v in rot[1:]:
        text += f" {'+' if sign > 0 else '-'} {v}"
    return text + " = 0"


def _loop_text(steps) -> str:
    return " - ".join(j for _, j, _ in steps)


def _input_variable(top: Topology, kind: str, name: str, where: str, theta_of) -> str:
    if kind == "link":
        if name not in top.link_map:
            raise TopologyError(f"{where}input.link: the input names the unknown link {name!r}; the links are "
                                + ", ".join(top.link_map))
        th = theta_of(name)
        if th is None:
            raise TopologyError(f"{where}input.link: link {name!r} does not turn (it is the ground or slides on "
                                "it); drive its prismatic joint instead (joint = \"...\")")
        return th
    if name not in top.joint_map:
        raise TopologyError(f"{where}input.joint: the input names the unknown joint {name!r}; the joints are "
                            + ", ".join(top.joint_map))
    j = top.joint_map[name]
    if isinstance(j, PrismaticJoint):
        return f"s_{name}"
    car = top.carriers[name]
    grounded = [c for c in car if theta_of(c) is None]
    moving = sorted({theta_of(c) for c in car if theta_of(c) is not None})
    if not grounded:
        raise TopologyError(f"{where}input.joint: the driven joint {name!r} joins the moving links "
                            f"{', '.join(car)}; loopsolve drives a joint on the ground or a link's absolute "
                            f"angle: give link = \"{car[0]}\" instead")
    if len(moving) != 1:
        raise TopologyError(f"{where}input.joint: the driven joint {name!r} turns the links "
                            f"{', '.join(c for c in car if c not in grounded)} independently; name the driven "
                            "link instead (link = \"...\")")
    return moving[0]


def diagram_to_spec(data: Mapping[str, Any], *, source: str | None = None) -> dict[str, Any]:
    """The vector-loop model ``dict`` of a kinematic diagram (see the module notes).

    Parameters
    ----------
    data : mapping
        The TOML layout: ``name``, ``units``, ``[joints]`` (``at``, ``type`` R/P, ``axis``,
        ``guide``), ``[links]`` (lists of joints; the fixed link is ``ground``), ``[input]``
        (``joint`` or ``link``, a name or a list of names, optional ``speed``/``accel``/
        ``jerk`` of the first), optional ``[parameters]`` overriding generated lengths,
        optional ``gravity``, ``[bodies]`` (named after links: ``mass``, ``inertia`` or
        ``bar``, and ``at = [x, y]``, ``com = { at = [x, y] }`` or ``com = "<joint>"``) and
        ``[[loads]]``.
    source : str, optional
        The file, named in error messages.

    Returns
    -------
    dict
        Ready for :func:`loopsolve.model.spec.build_mechanism`; it keeps the diagram under
        ``joints``/``links``/``input`` (ignored by the vector-loop layout).

    Raises
    ------
    ModelFileError, ModelError
        Format problems, all at once.
    TopologyError
        Structure problems; the declared inputs disagree with the mobility (naming both counts);
        an over-constrained special geometry.

    Examples
    --------
    >>> spec = ls.diagram.diagram_to_spec({
    ...     "joints": {"O2": {"at": [0, 0]}, "B": {"at": [0, 25]}, "C": {"at": [67.255, 44.411]},
    ...                "O4": {"at": [60, 0]}},
    ...     "links": {"ground": ["O2", "O4"], "crank": ["O2", "B"], "coupler": ["B", "C"],
    ...               "rocker": ["C", "O4"]},
    ...     "input": {"joint": "O2"}})
    >>> spec["loops"][0]["equation"]
    'r_crank + r_coupler + r_rocker = r_ground_O4'
    >>> spec["variables"]["theta_crank"]
    {'input': True, 'guess': 90}
    """
    return _generate(parse_diagram(data, source=source))


# =============================================================================
# Python front door, round trip, topology of a mechanism
# =============================================================================


def diagram_data(joints: Sequence[RevoluteJoint | PrismaticJoint], links: Sequence[Link], *,
                 input: str | Sequence[str] | None = None, input_link: str | Sequence[str] | None = None,
                 name: str = "mechanism", length_unit: str = "mm", angle_unit: str = "deg",
                 speed=None, accel=None, jerk=None, parameters: Mapping[str, Any] | None = None) -> dict:
    """The model-file ``dict`` of Python joint/link declarations (the TOML layout).

    Examples
    --------
    >>> T = ls.topology
    >>> data = ls.diagram.diagram_data([T.RevoluteJoint("O2", (0, 0)), T.PrismaticJoint("S", (5, 0), (1, 0))],
    ...                                [T.Link("ground", ["O2", "S"])], input="S")
    >>> data["joints"]["S"], data["input"]
    ({'at': [5.0, 0.0], 'type': 'P', 'axis': [1.0, 0.0]}, {'joint': 'S'})
    """
    jd: dict[str, Any] = {}
    for j in joints:
        if not isinstance(j, (RevoluteJoint, PrismaticJoint)):
            raise ModelError(f"expected RevoluteJoint or PrismaticJoint, got {j!r}")
        entry: dict[str, Any] = {"at": [j.at[0], j.at[1]]}
        if isinstance(j, PrismaticJoint):
            entry["type"] = "P"
            entry["axis"] = [j.axis[0], j.axis[1]]
            if j.guide is not None:
                entry["guide"] = j.guide
        if j.name in jd:
            raise TopologyError(f"the joint {j.name!r} is declared twice")
        jd[j.name] = entry
    ld: dict[str, Any] = {}
    for lk in links:
        if not isinstance(lk, Link):
            raise ModelError(f"expected a Link, got {lk!r}")
        if lk.name in ld:
            raise TopologyError(f"the link {lk.name!r} is declared twice")
        ld[lk.name] = list(lk.joints)
    data: dict[str, Any] = {"name": name, "units": {"length": length_unit, "angle": angle_unit},
                            "joints": jd, "links": ld}
    inp: dict[str, Any] = {}
    for key, val in (("joint", input), ("link", input_link)):
        if val is not None:
            inp[key] = val if isinstance(val, str) else list(val)
    for key, val in (("speed", speed), ("accel", accel), ("jerk", jerk)):
        if val is not None:
            inp[key] = val
    if inp:
        data["input"] = inp
    if parameters:
        data["parameters"] = dict(parameters)
    return data


def from_declarations(joints: Sequence[RevoluteJoint | PrismaticJoint], links: Sequence[Link], **kwargs) -> Mechanism:
    """Build a :class:`~loopsolve.model.mechanism.Mechanism` from Python joint and link declarations.

    Takes the arguments of :func:`diagram_data`; the result equals loading the same diagram
    from a model file.

    Examples
    --------
    >>> T = ls.topology
    >>> J = [T.RevoluteJoint("O2", (0, 0)), T.RevoluteJoint("B", (0, 25)),
    ...      T.RevoluteJoint("C", (67.255, 44.411)), T.RevoluteJoint("O4", (60, 0))]
    >>> L = [T.Link("ground", ["O2", "O4"]), T.Link("crank", ["O2", "B"]),
    ...      T.Link("coupler", ["B", "C"]), T.Link("rocker", ["O4", "C"])]
    >>> mech = ls.diagram.from_declarations(J, L, input="O2", name="four-bar")
    >>> round(mech.solve(90)["theta_rocker"], 2)
    80.72
    """
    data = diagram_data(joints, links, **kwargs)
    return build_mechanism(diagram_to_spec(data, source=None), source=None)


def topology_of(mech: Mechanism) -> Topology | None:
    """The :class:`~loopsolve.model.topology.Topology` of a mechanism built from a diagram, else ``None``.

    Examples
    --------
    >>> mech = ls.load(ls.models_dir() / "thesis_crank_rocker_diagram.toml")
    >>> ls.diagram.topology_of(mech).mobility().gruebler
    1
    >>> ls.diagram.topology_of(ls.fourbar(60, 25, 70, 45)) is None
    True
    """
    spec = mech.spec
    if not isinstance(spec, Mapping) or "joints" not in spec or "links" not in spec:
        return None
    data = {k: spec[k] for k in ("name", "units", "joints", "links") if k in spec}
    return parse_diagram(data, source=mech.source).topology


def to_vector_model(model: str | os.PathLike | Mapping[str, Any] | Mechanism) -> str:
    """The vector-loop model file (TOML text) generated from a kinematic diagram.

    ``model`` is a diagram model file, its ``dict``, or a mechanism built from one. Loading
    the text gives the same derivation and the same results.

    Examples
    --------
    >>> text = ls.diagram.to_vector_model(ls.models_dir() / "thesis_crank_rocker_diagram.toml")
    >>> print(text.split("[[loops]]")[1].strip().splitlines()[1])
    equation = "r_crank + r_coupler + r_rocker = r_ground_O4"
    """
    from .modelfile import dumps, load  # lazily: modelfile imports this module (to read diagrams)

    if isinstance(model, Mechanism):
        mech = model
    elif isinstance(model, Mapping):
        mech = build_mechanism(diagram_to_spec(model), source=None)
    else:
        mech = load(Path(model))
    spec = {k: v for k, v in mech.spec.items() if k not in ("joints", "links", "input")}
    head = ""
    if "joints" in mech.spec:
        head = (f"# Generated by loopsolve from the kinematic diagram {mech.source or mech.name!r}:\n"
                "# theta_<link> is the direction from a link's first listed joint to its second, s_<joint>\n"
                "# the slide of a prismatic joint; guesses are the drawn pose.\n")
    return head + dumps(spec)
