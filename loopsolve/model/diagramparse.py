"""Reading a kinematic diagram (``[joints]``, ``[links]``, ``input``) into a checked
:class:`Diagram`: every problem reported at once, by key.

:mod:`loopsolve.model.diagram` turns the :class:`Diagram` into vectors and loops.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from .diagrambodies import parse_bodies
from ..errors import ModelError
from .spec import Problems, check_name, name_and_units
from .topology import Link, PrismaticJoint, RevoluteJoint, Topology
from .units import Kind, parse_quantity


_TOP_KEYS = {"name", "description", "units", "joints", "links", "input", "parameters", "modes",
             "schema", "version", "gravity", "bodies", "loads"}



_JOINT_KEYS = {"at", "type", "axis", "guide"}



_INPUT_KEYS = {"joint", "link", "speed", "accel", "jerk"}



_TYPES = {"r": "R", "revolute": "R", "pin": "R", "p": "P", "prismatic": "P", "slider": "P"}



@dataclass(frozen=True)
class Diagram:
    """A parsed kinematic diagram: validated topology, the driven joints/links and the rates.

    ``inputs`` lists ``("joint", name)`` or ``("link", name)`` in order (the first is the one
    a sweep varies); ``rates`` holds the raw ``speed``/``accel``/``jerk`` of the first input;
    ``overrides`` replaces generated length parameters by name.
    """

    name: str
    length_unit: str
    angle_unit: str
    topology: Topology
    inputs: tuple[tuple[str, str], ...]
    rates: Mapping[str, Any] = field(default_factory=dict)
    overrides: Mapping[str, Any] = field(default_factory=dict)
    description: str | None = None
    modes: Mapping[str, str] = field(default_factory=dict)
    source: str | None = None
    raw: Mapping[str, Any] = field(default_factory=dict, repr=False)
    #: points carried by one link only (``(name, (x, y), link)``, declaration order): tracer points
    points: tuple[tuple[str, tuple[float, float], str], ...] = ()
    #: bodies ``(link, mass properties, com point name)``; a com drawn with ``at`` is the tracer
    #: point ``G_<link>`` of :attr:`points`
    bodies: tuple[tuple[str, dict, str], ...] = ()



def _as_names(value, key: str, problems: Problems) -> list[str]:
    if isinstance(value, str):
        return [value]
    if isinstance(value, list) and value and all(isinstance(v, str) for v in value):
        return list(value)
    problems.add(key, f"expected a name or a list of names, got {value!r}")
    return []



def parse_diagram(data: Mapping[str, Any], *, source: str | None = None) -> Diagram:
    """Validate the kinematic-diagram layout of a model ``dict``.

    Format problems (a missing ``at``, a bad unit) are collected into one
    :class:`~loopsolve.errors.ModelFileError` (``ModelError`` without ``source``); structural
    ones (unknown joints, disconnected links...) raise :class:`~loopsolve.errors.TopologyError`.

    Examples
    --------
    >>> d = ls.diagram.parse_diagram({"joints": {"A": {"at": [0, 0]}, "B": {"at": [1, 0]},
    ...     "C": {"at": [0, 1]}}, "links": {"ground": ["A", "B"], "a": ["A", "C"], "b": ["B", "C"]}})
    >>> d.topology.mobility().gruebler
    0
    """
    problems = Problems(source)
    if not isinstance(data, Mapping):
        problems.add("", "a model is a table of keys (name, units, joints, links, input)")
        problems.raise_if_any()
    for k in data:
        if k in ("vectors", "loops", "variables", "points"):
            if data[k]:
                problems.add(str(k), f"a kinematic-diagram model generates its {k}; remove [{k}] (or write "
                             "a vector-loop model without [joints]/[links])")
        elif k not in _TOP_KEYS:
            problems.add(str(k), f"unknown key {k!r} in a kinematic-diagram model (expected one of: "
                         + ", ".join(sorted(_TOP_KEYS)) + ")")
    name, units = name_and_units(data, problems)
    length_unit, angle_unit = units.length, units.angle

    def length(v, key):
        try:
            return parse_quantity(v, Kind.LENGTH, angle_unit=angle_unit, length_unit=length_unit, where="")
        except (ModelError, ValueError, TypeError) as exc:
            problems.add(key, str(exc))
            return None

    joints: list[RevoluteJoint | PrismaticJoint] = []
    jspec = data.get("joints", {})
    if not isinstance(jspec, Mapping) or not jspec:
        problems.add("joints", "expected a table of joints: O2 = { at = [0, 0] }")
        jspec = {}
    for jname, jdef in jspec.items():
        key = f"joints.{jname}"
        if not check_name(jname, key, problems):
            continue
        if not isinstance(jdef, Mapping):
            problems.add(key, f"expected a table like {{ at = [0, 25] }}, got {jdef!r}")
            continue
        extra = set(jdef) - _JOINT_KEYS
        if extra:
            problems.add(key, f"unknown key(s) {sorted(extra)} (allowed: {', '.join(sorted(_JOINT_KEYS))})")
        at = jdef.get("at")
        if not isinstance(at, (list, tuple)) or len(at) != 2:
            problems.add(f"{key}.at", f"expected the drawn position [x, y], got {at!r}")
            continue
        xy = [length(c, f"{key}.at") for c in at]
        jtype = jdef.get("type", "R")
        kind = _TYPES.get(jtype.lower()) if isinstance(jtype, str) else None
        if kind is None:
            problems.add(f"{key}.type", f"{jtype!r}: expected \"R\" (revolute) or \"P\" (prismatic)")
            continue
        if None in xy:
            continue
        if kind == "R":
            for k in ("axis", "guide"):
                if k in jdef:
                    problems.add(f"{key}.{k}", f"`{k}` is for a prismatic joint; add type = \"P\" or remove it")
            joints.append(RevoluteJoint(jname, (xy[0], xy[1])))
            continue
        if "axis" not in jdef:
            problems.add(key, "a prismatic joint needs `axis`, the slide direction: [dx, dy] or an angle")
            continue
        axis = jdef["axis"]
        if isinstance(axis, (list, tuple)):
            if len(axis) != 2 or any(isinstance(c, bool) or not isinstance(c, (int, float)) for c in axis):
                problems.add(f"{key}.axis", f"expected a direction [dx, dy] or an angle, got {axis!r}")
                continue
            ax = (float(axis[0]), float(axis[1]))
        else:
            try:
                a = parse_quantity(axis, Kind.ANGLE, angle_unit=angle_unit, length_unit=length_unit, where="")
            except (ModelError, ValueError, TypeError) as exc:
                problems.add(f"{key}.axis", str(exc))
                continue
            ax = (math.cos(a), math.sin(a))
        guide = jdef.get("guide")
        if guide is not None and not isinstance(guide, str):
            problems.add(f"{key}.guide", f"expected a link name, got {guide!r}")
            continue
        try:
            joints.append(PrismaticJoint(jname, (xy[0], xy[1]), ax, guide))
        except ModelError as exc:
            problems.add(f"{key}.axis", str(exc))

    links: list[Link] = []
    lspec = data.get("links", {})
    if not isinstance(lspec, Mapping) or not lspec:
        problems.add("links", "expected a table of links: crank = [\"O2\", \"B\"] (and ground = [...])")
        lspec = {}
    for lname, ldef in lspec.items():
        key = f"links.{lname}"
        if not check_name(lname, key, problems):
            continue
        if not isinstance(ldef, list) or not all(isinstance(j, str) for j in ldef):
            problems.add(key, f"expected the list of joints the link carries, e.g. [\"B\", \"C\"], got {ldef!r}")
            continue
        links.append(Link(lname, tuple(ldef)))

    inputs: list[tuple[str, str]] = []
    rates: dict[str, Any] = {}
    ispec = data.get("input")
    if ispec is not None:
        if not isinstance(ispec, Mapping):
            problems.add("input", f"expected a table like {{ joint = \"O2\" }}, got {ispec!r}")
        else:
            extra = set(ispec) - _INPUT_KEYS
            if extra:
                problems.add("input", f"unknown key(s) {sorted(extra)} (allowed: {', '.join(sorted(_INPUT_KEYS))})")
            for k in ("joint", "link"):
                if k in ispec:
                    inputs.extend((k, n) for n in _as_names(ispec[k], f"input.{k}", problems))
            if not inputs and not extra:
                problems.add("input", "name the driven joint (joint = \"O2\") or link (link = \"crank\")")
            rates = {k: ispec[k] for k in ("speed", "accel", "jerk") if k in ispec}

    overrides = data.get("parameters", {})
    if not isinstance(overrides, Mapping):
        problems.add("parameters", f"expected a table of length overrides, got {overrides!r}")
        overrides = {}
    modes = data.get("modes", {})
    if not isinstance(modes, Mapping):
        problems.add("modes", "expected a table of alias = \"signature\"")
        modes = {}
    description = data.get("description")
    body_raw = parse_bodies(data.get("bodies"), links, joints, length, problems)
    problems.raise_if_any()
    links, joints, points = _split_points(links, joints, source)
    bodies = []
    for lname, props, com in body_raw:
        if isinstance(com, tuple):
            points = points + ((f"G_{lname}", com, lname),)
            com = f"G_{lname}"
        bodies.append((lname, props, com))
    top = Topology(tuple(links), tuple(joints), where=source or "")
    return Diagram(name.strip(), length_unit, angle_unit, top, tuple(inputs), rates, dict(overrides),
                   description, dict(modes), source, dict(data), points, tuple(bodies))



def _split_points(links: list[Link], joints: list, source: str | None):
    """Separate the points carried by one link only (tracer points) from the joints.

    A revolute joint that one link lists and no other link does joins nothing: it is a point
    of that link (a coupler point), moving with the link's pose. It is taken out of the link's
    joint list (so the link's reference joints are its first two real joints) and returned
    as ``(name, (x, y), link)``. A prismatic joint on one link stays an error (a slider
    joins two links), reported by the topology.
    """
    count: dict[str, list[str]] = {}
    for lk in links:
        for j in dict.fromkeys(lk.joints):
            count.setdefault(j, []).append(lk.name)
    pts = {j.name for j in joints if isinstance(j, RevoluteJoint) and len(count.get(j.name, ())) == 1}
    # a link left with fewer than two joints keeps its points as joints: the topology then
    # reports the joint named by one link only, which is the likelier mistake there
    for lk in links:
        if len({j for j in lk.joints if j not in pts}) < 2:
            pts -= set(lk.joints)
    if not pts:
        return links, joints, ()
    new_links = [Link(lk.name, tuple(j for j in lk.joints if j not in pts)) if set(lk.joints) & pts else lk
                 for lk in links]
    points = tuple((j.name, j.at, count[j.name][0]) for j in joints if j.name in pts)
    return new_links, [j for j in joints if j.name not in pts], points
