"""Bodies of kinematic-diagram models: ``[bodies]`` named after links, centres of mass drawn.

:func:`parse_bodies` validates the ``[bodies]`` of a diagram (problems collected, each naming
its key); :func:`body_specs` turns them into the vector-loop ``[bodies]`` that
:mod:`loopsolve.model.bodies` reads, with the angle, joints and guide taken from the diagram's links.
:mod:`loopsolve.model.diagram` adds a centre of mass drawn with ``at = [x, y]`` as the tracer point
``G_<link>`` carried by the link.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, Callable

from ..errors import TopologyError
from .spec import Problems
from .topology import GROUND, Link, PrismaticJoint, Topology

__all__ = ["parse_bodies", "body_specs"]

#: keys of a body in a diagram model (``angle``, ``joints`` and ``guide`` come from the diagram)
BODY_KEYS = {"mass", "inertia", "bar", "com", "at"}


def parse_bodies(bspec, links: list[Link], joints: list, length: Callable, problems: Problems) -> list:
    """The ``[bodies]`` of a diagram: ``(link, mass properties, com)`` with ``com`` a drawn
    position ``(x, y)`` or the name of a point of the link; problems collected.

    A body is named after the link it is (``crank = { mass = ..., inertia = ...,
    com = { at = [x, y] } }``); its angle, joints and guide come from the diagram.

    Parameters
    ----------
    bspec : mapping or None
        The ``[bodies]`` table of the model file.
    links, joints : list
        The parsed links and joints of the diagram.
    length : callable
        ``length(value, key)``: a drawn coordinate in the model's length unit (``None`` and a
        problem recorded when it cannot be read).
    problems : Problems
        Collects every problem with its key.

    Returns
    -------
    list of (str, dict, tuple or str)

    Examples
    --------
    >>> from loopsolve.model.spec import Problems
    >>> from loopsolve.model.topology import Link
    >>> links = [Link("ground", ("O2", "O4")), Link("crank", ("O2", "B"))]
    >>> ls.model.diagrambodies.parse_bodies({"crank": {"mass": 1, "at": [0, 5]}}, links, [],
    ...                               lambda v, key: float(v), Problems(None))
    [('crank', {'mass': 1}, (0.0, 5.0))]
    """
    if bspec is None:
        return []
    if not isinstance(bspec, Mapping):
        problems.add("bodies", f"expected a table of bodies named after links: crank = {{ mass = \"0.3kg\", "
                     f"inertia = ..., at = [x, y] }}, got {bspec!r}")
        return []
    lmap = {lk.name: lk for lk in links}
    jnames = {j.name for j in joints}
    taken = jnames | set(lmap)
    out = []
    for bname, bdef in bspec.items():
        key = f"bodies.{bname}"
        if bname == GROUND:
            problems.add(key, "the ground is the fixed link: list only moving links")
            continue
        if bname not in lmap:
            problems.add(key, f"{bname!r} is not a link of [links]: a body of a diagram model is named after "
                         f"its link (the moving links are {', '.join(n for n in lmap if n != GROUND) or 'none'})")
            continue
        if not isinstance(bdef, Mapping):
            problems.add(key, f"expected a table like {{ mass = \"0.3kg\", inertia = ..., at = [x, y] }}, got {bdef!r}")
            continue
        extra = set(bdef) - BODY_KEYS
        if extra:
            hint = ("; a diagram gives the angle, joints and guide of a link's body" if
                    extra & {"angle", "joints", "guide", "guide_body"} else "")
            problems.add(key, f"unknown key(s) {sorted(extra)} (allowed: {', '.join(sorted(BODY_KEYS))}){hint}")
            continue
        if "com" in bdef and "at" in bdef:
            problems.add(key, "give the centre of mass once: `at = [x, y]` or `com = { at = [x, y] }`")
            continue
        craw = bdef.get("com", bdef.get("at"))
        ckey = f"{key}.com" if "com" in bdef else f"{key}.at"
        if "com" in bdef and isinstance(craw, Mapping):
            if set(craw) != {"at"}:
                problems.add(ckey, f"expected {{ at = [x, y] }} (the centre of mass at the drawn pose), got {craw!r}")
                continue
            craw, ckey = craw["at"], f"{ckey}.at"
        if craw is None:
            problems.add(key, "missing the centre of mass: `at = [x, y]` at the drawn pose (or the name of a "
                         "joint of the link, com = \"B\")")
            continue
        if isinstance(craw, str) and "com" in bdef:
            if craw not in lmap[bname].joints:
                problems.add(ckey, f"{craw!r} is not a joint of link {bname!r} ({', '.join(lmap[bname].joints)}); "
                             "give the drawn position com = { at = [x, y] }")
                continue
            com: Any = craw
        else:
            if (not isinstance(craw, (list, tuple)) or len(craw) != 2
                    or any(isinstance(c, bool) for c in craw)):
                problems.add(ckey, f"expected the centre of mass at the drawn pose as a pair of numbers [x, y], "
                             f"got {craw!r}")
                continue
            xy = [length(c, ckey) for c in craw]
            if None in xy:
                continue
            if f"G_{bname}" in taken:
                problems.add(key, f"the centre-of-mass point G_{bname} would collide with a joint or link of "
                             "that name; rename it")
                continue
            com = (float(xy[0]), float(xy[1]))
        props = {k: bdef[k] for k in ("mass", "inertia", "bar") if k in bdef}
        out.append((bname, props, com))
    return out


def body_specs(bodies, top: Topology, theta_of, where: str) -> dict[str, dict[str, Any]]:
    """The vector-model ``[bodies]`` of a diagram's bodies: angle, joints and guide from the links.

    A body's joints are the revolute joints its link lists; a prismatic joint on which the
    link slides (the other link being the guide) makes it a guided body (``guide = "r_<joint>"``,
    on the guide's body or the frame); one the link guides adds nothing (the slider's body
    carries the contact).

    Parameters
    ----------
    bodies : sequence of (str, dict, str)
        ``(link, mass properties, com point name)`` in declaration order.
    top : Topology
        The diagram's topology.
    theta_of : callable
        The angle variable of a link (``None`` for the ground and links translating on it).
    where : str
        Prefix of error messages (the file).

    Examples
    --------
    >>> top = ls.diagram.topology_of(ls.load(ls.models_dir() / "thesis_crank_rocker_diagram.toml"))
    >>> ls.model.diagrambodies.body_specs([("rocker", {"mass": 1, "inertia": 0}, "C")], top,
    ...                             lambda link: None if link == "ground" else f"theta_{link}", "")
    {'rocker': {'mass': 1, 'inertia': 0, 'com': 'C', 'angle': 'theta_rocker', 'joints': ['C', 'O4']}}
    """
    jmap, lmap = top.joint_map, top.link_map
    out: dict[str, dict[str, Any]] = {}
    for lname, props, com in bodies:
        entry: dict[str, Any] = dict(props)
        entry["com"] = com
        th = theta_of(lname)
        if th is not None:
            entry["angle"] = th
        joints, guides = [], []
        for j in lmap[lname].joints:
            if isinstance(jmap[j], PrismaticJoint):
                g = top.guide(j)
                if g != lname:
                    guides.append((j, g))
            else:
                joints.append(j)
        entry["joints"] = joints
        if len(guides) > 1:
            raise TopologyError(f"{where}bodies.{lname}: the link slides on {len(guides)} guides "
                                f"({', '.join(j for j, _ in guides)}); a body slides on one guide at most")
        if guides:
            j, g = guides[0]
            entry["guide"] = f"r_{j}"
            entry["guide_body"] = "frame" if g == GROUND else g
        out[lname] = entry
    return out
