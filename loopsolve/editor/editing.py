"""Edits of a kinematic-diagram model ``dict`` (the ``[joints]``/``[links]`` layout of a model file).

Every edit takes the current model ``dict`` and returns a new one (the input is never changed),
so the document can keep the old ones for undo. Two kinds:

* **Geometric edits** (move a joint, type a dimension) keep the structure. They are applied at
  the pose the page shows: the mechanism is solved at the current input value in its assembly
  mode, the edit is made there, and the result is written back as the diagram's drawn pose
  (:func:`repose`): joint positions, slide axes of prismatic joints on moving guides, centres
  of mass drawn with ``at``. The generated lengths and offsets then follow from the pose, so a
  saved file is always a consistent drawing (no stale ``[parameters]`` overrides).
* **Structural edits** (add or delete links, joints, sliders, points; change the input; masses
  and loads) change the ``dict`` only; the analysis says whether the result is a mechanism.

Names of new elements follow one rule: the first free name of ``link1, link2, ...``,
``J1, J2, ...``, ``S1, ...`` (sliders), ``P1, ...`` (points), ``block1, ...``.
"""

from __future__ import annotations

import copy
import math
import re
from collections.abc import Mapping
from typing import Any

from ..errors import ModelError, ModeError
from ..model.topology import GROUND

__all__ = ["template", "is_diagram", "repose", "move_joint", "set_dimension", "set_coordinates",
           "add_link", "add_point", "add_slider", "delete", "set_input", "set_body", "set_loads",
           "set_gravity", "set_units", "diagram_from_positions", "MAX_ELEMENTS"]

#: most joints (or links) a model edited on the page may have (bounded work per request)
MAX_ELEMENTS = 60

_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]{0,39}")


def template() -> dict:
    """The model the editor starts from without a model file: a crank-rocker four-bar.

    Ground 60, crank 25, coupler 70, rocker 45 mm, drawn at a crank angle of 90° (open mode).

    Examples
    --------
    >>> from loopsolve.editor.editing import template
    >>> from loopsolve.model.modelfile import dumps, loads
    >>> mech = loads(dumps(template()))
    >>> round(mech.solve(90)["theta_rocker"], 3), ls.guessed_mode(mech)
    (-99.278, '-')
    """
    b = (0.0, 25.0)
    # C: |C - B| = 70, |C - O4| = 45 (the open assembly), from the circle intersection
    o4 = (60.0, 0.0)
    d = math.dist(b, o4)
    a = (70.0 ** 2 - 45.0 ** 2 + d * d) / (2 * d)
    h = math.sqrt(70.0 ** 2 - a * a)
    ux, uy = (o4[0] - b[0]) / d, (o4[1] - b[1]) / d
    c = (b[0] + a * ux - h * uy, b[1] + a * uy + h * ux)
    return {
        "name": "Four-bar",
        "units": {"length": "mm", "angle": "deg"},
        "joints": {"O2": {"at": [0, 0]}, "B": {"at": [0, 25]}, "C": {"at": [_r(c[0]), _r(c[1])]},
                   "O4": {"at": [60, 0]}},
        "links": {"ground": ["O2", "O4"], "crank": ["O2", "B"], "coupler": ["B", "C"], "rocker": ["C", "O4"]},
        "input": {"joint": "O2"},
    }


def _r(v: float) -> float | int:
    """A coordinate as written: the float itself (full precision), an integer without ``.0``."""
    v = float(v)
    if v == 0:
        return 0
    if v == round(v) and abs(v) < 1e15:
        return int(v)
    return v


def is_diagram(data: Mapping) -> bool:
    """Whether a model ``dict`` is a kinematic diagram (``[joints]``/``[links]``, no vectors)."""
    return isinstance(data, Mapping) and ("joints" in data or "links" in data) and "vectors" not in data


def _need_diagram(data: Mapping, what: str) -> None:
    if not is_diagram(data):
        raise ModelError(f"{what} needs a kinematic-diagram model ([joints] and [links]); this model is "
                         "declared with vectors and loops: edit its parameters by value instead")


def _check_name(name: Any, what: str) -> str:
    if not isinstance(name, str) or not _NAME.fullmatch(name):
        raise ModelError(f"{what} {name!r}: a name is a letter or _ followed by letters, digits or _ "
                         "(at most 40 characters)")
    return name


def _point(xy: Any, what: str) -> list:
    if (not isinstance(xy, (list, tuple)) or len(xy) != 2
            or not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in xy)):
        raise ModelError(f"{what}: expected a position [x, y] of two finite numbers, got {xy!r}")
    if max(abs(float(v)) for v in xy) > 1e12:
        raise ModelError(f"{what}: {xy!r} is too far out (coordinates up to 1e12 model units)")
    return [_r(xy[0]), _r(xy[1])]


def _free(existing, prefix: str) -> str:
    k = 1
    while f"{prefix}{k}" in existing:
        k += 1
    return f"{prefix}{k}"


def _names(data: Mapping) -> set:
    return set(data.get("joints", {})) | set(data.get("links", {}))


def _count_check(data: Mapping) -> None:
    if len(data.get("joints", {})) > MAX_ELEMENTS or len(data.get("links", {})) > MAX_ELEMENTS:
        raise ModelError(f"the editor handles models of at most {MAX_ELEMENTS} joints and {MAX_ELEMENTS} links")


# ------------------------------------------------------------------------------ re-posing
def repose(data: Mapping, mech, state, *, moved: Mapping[str, list] | None = None) -> dict:
    """The diagram ``data`` drawn at the pose ``state`` of its mechanism ``mech`` (joints in ``moved`` put there).

    Joint positions come from the state's point columns (every joint is a point), slide axes
    of prismatic joints on a moving guide turn with the guide, centres of mass drawn with
    ``at`` move with their link, and ``[parameters]`` overrides that the new pose now
    generates are dropped.
    """
    from ..model.diagram import diagram_to_spec
    from ..model.diagramparse import parse_diagram

    new = copy.deepcopy(dict(data))
    joints = new["joints"]
    moved = dict(moved or {})
    top = parse_diagram(data, source=None).topology
    groups = top.rotation_groups
    deg = mech.units.angle == "deg"
    variables = mech.spec.get("variables", {})

    def turn(link: str) -> float:
        """Rotation (radians) of a link from the drawn pose to the state."""
        rep = groups.get(link, GROUND)
        if rep == GROUND:
            return 0.0
        var = f"theta_{rep}"
        guess = variables.get(var, {}).get("guess")
        if guess is None:
            return 0.0
        d = float(state[var]) - float(guess)
        return math.radians(d) if deg else d

    on_ground = {j for j in new.get("links", {}).get(GROUND, [])
                 if isinstance(joints.get(j), dict) and not _prismatic(joints[j])}
    for name, entry in joints.items():
        if not isinstance(entry, dict):
            continue
        if name in moved:
            entry["at"] = _point(moved[name], f"joints.{name}.at")
        elif name not in on_ground:  # a ground joint stays where it is drawn (no round-off creeps in)
            try:
                x, y = float(state[f"{name}_x"]), float(state[f"{name}_y"])
            except (KeyError, ModelError):
                continue
            entry["at"] = [_r(x), _r(y)]
        if _prismatic(entry):
            try:
                guide = top.guide(name)
            except Exception:  # noqa: BLE001 — a joint the topology does not know keeps its axis
                continue
            a = turn(guide)
            if a:
                ax = _axis_vector(entry.get("axis"), mech.units.angle)
                c, s = math.cos(a), math.sin(a)
                entry["axis"] = [_r(c * ax[0] - s * ax[1]), _r(s * ax[0] + c * ax[1])]
    for link, body in (new.get("bodies") or {}).items():
        if not isinstance(body, dict):
            continue
        g = f"G_{link}"
        holder = body if "at" in body else body.get("com") if isinstance(body.get("com"), dict) else None
        if holder is not None and "at" in holder:
            try:
                holder["at"] = [_r(float(state[f"{g}_x"])), _r(float(state[f"{g}_y"]))]
            except (KeyError, ModelError):
                pass
    overrides = new.get("parameters")
    if overrides:
        spec = diagram_to_spec({k: v for k, v in new.items() if k != "parameters"})
        keep = {}
        for k, v in overrides.items():
            gen = spec["parameters"].get(k)
            if not (isinstance(v, (int, float)) and gen is not None
                    and abs(float(gen) - float(v)) <= 1e-9 * max(1.0, abs(float(v)))):
                keep[k] = v
        if keep:
            new["parameters"] = keep
        else:
            new.pop("parameters")
    return new


def _prismatic(entry) -> bool:
    return isinstance(entry, Mapping) and str(entry.get("type", "R")).upper() in ("P", "PRISMATIC", "SLIDER")


def _axis_vector(axis, angle_unit: str) -> tuple[float, float]:
    if isinstance(axis, (list, tuple)) and len(axis) == 2:
        n = math.hypot(float(axis[0]), float(axis[1]))
        return (float(axis[0]) / n, float(axis[1]) / n) if n > 0 else (1.0, 0.0)
    from ..model.units import Kind, parse_quantity

    a = parse_quantity(axis, Kind.ANGLE, angle_unit=angle_unit, length_unit="m", where="axis")
    return (math.cos(a), math.sin(a))


def _coincident(data: Mapping, name: str, state, scale: float) -> list[str]:
    """Joints drawn at the same place as ``name`` in ``state`` (a pin and its slider): they move together."""
    try:
        x, y = float(state[f"{name}_x"]), float(state[f"{name}_y"])
    except (KeyError, ModelError):
        return [name]
    out = [name]
    for other in data.get("joints", {}):
        if other == name:
            continue
        try:
            ox, oy = float(state[f"{other}_x"]), float(state[f"{other}_y"])
        except (KeyError, ModelError):
            continue
        if math.hypot(ox - x, oy - y) <= 1e-9 * scale:
            out.append(other)
    return out


def move_joint(data: Mapping, mech, state, joint: str, to) -> dict:
    """Move ``joint`` (and the joints drawn on it) to ``to`` at the pose ``state``; the rest stays put.

    The links that carry the joint change length (or offset); a ground joint moves the frame
    placement. The caller checks that the assembly mode did not change.
    """
    _need_diagram(data, "dragging a joint")
    if joint not in data.get("joints", {}):
        raise ModelError(f"no joint {joint!r} (joints: {', '.join(data.get('joints', {}))})")
    to = _point(to, f"joints.{joint}")
    scale = float(mech.compile().scale)
    return repose(data, mech, state, moved={j: to for j in _coincident(data, joint, state, scale)})


def set_coordinates(data: Mapping, mech, state, joint: str, x, y) -> dict:
    """Typed coordinates of a joint (model length unit, or with a unit: ``"12.5mm"``)."""
    from ..model.units import Kind, parse_quantity

    units = mech.units
    vals = [parse_quantity(v, Kind.LENGTH, angle_unit=units.angle, length_unit=units.length,
                           where=f"joints.{joint}.at") for v in (x, y)]
    return move_joint(data, mech, state, joint, vals)


def set_dimension(data: Mapping, name: str, value) -> dict:
    """A typed value of a generated length parameter (``r_crank = 30``; units allowed: ``"1.2in"``).

    Returns the diagram with the value as a ``[parameters]`` override; the caller solves it at
    the current input in the kept mode and re-poses it (:func:`repose`), which drops the override.
    """
    from ..model.modelfile import loads, dumps
    from ..model.units import Kind, parse_quantity

    _need_diagram(data, "a typed dimension")
    mech = loads(dumps(data), source="<editor>")
    params = mech.spec.get("parameters", {})
    if name not in params:
        raise ModelError(f"no dimension {name!r}; the dimensions are {', '.join(params)}")
    v = parse_quantity(value, Kind.LENGTH, angle_unit=mech.units.angle, length_unit=mech.units.length,
                       where=f"parameters.{name}")
    if not math.isfinite(v) or v <= 0:
        raise ModelError(f"{name} = {value!r}: a length must be a positive number")
    new = copy.deepcopy(dict(data))
    new.setdefault("parameters", {})[name] = _r(v)
    return new


# ------------------------------------------------------------------------------ structure
def add_link(data: Mapping, joints, new_joints: Mapping[str, Any] | None = None, *, name: str | None = None) -> dict:
    """A new link carrying ``joints`` (existing names, or names of ``new_joints``: ``{name: [x, y]}``)."""
    _need_diagram(data, "adding a link")
    new = copy.deepcopy(dict(data))
    new.setdefault("joints", {})
    new.setdefault("links", {})
    new_joints = dict(new_joints or {})
    for j, xy in new_joints.items():
        _check_name(j, "joint")
        if j in _names(new):
            raise ModelError(f"the name {j!r} is taken")
        new["joints"][j] = {"at": _point(xy, f"joints.{j}.at")}
    joints = list(joints)
    if len(joints) < 2 or len(set(joints)) != len(joints):
        raise ModelError("a link carries at least two different joints")
    for j in joints:
        if j not in new["joints"]:
            raise ModelError(f"no joint {j!r} to put on the new link")
    lname = _check_name(name, "link") if name else _free(_names(new), "link")
    if lname in new["links"] or (name and name in new["joints"]):
        raise ModelError(f"the name {lname!r} is taken")
    new["links"][lname] = joints
    _count_check(new)
    return new


def add_point(data: Mapping, link: str, at, *, name: str | None = None) -> dict:
    """A point of interest (tracer point) carried by ``link`` at ``at`` in the drawn pose.

    The drawn pose is the one the caller re-posed the diagram to (the current row); a point on
    the ground is fixed.
    """
    _need_diagram(data, "adding a point")
    if link not in data.get("links", {}):
        raise ModelError(f"no link {link!r} to carry the point")
    new = copy.deepcopy(dict(data))
    pname = _check_name(name, "point") if name else _free(_names(new), "P")
    if pname in _names(new):
        raise ModelError(f"the name {pname!r} is taken")
    new["joints"][pname] = {"at": _point(at, f"joints.{pname}.at")}
    new["links"][link] = list(new["links"][link]) + [pname]
    _count_check(new)
    return new


def add_slider(data: Mapping, joint: str, guide: str = GROUND, axis=(1.0, 0.0)) -> dict:
    """Put ``joint`` on a block that slides along ``guide`` (a link, default the ground).

    A prismatic joint ``S<k>`` is drawn at the joint with slide direction ``axis``; a new
    link ``block<k>`` carries the joint and the slider, and the guide link carries the slider.
    """
    _need_diagram(data, "adding a slider")
    joints = data.get("joints", {})
    if joint not in joints:
        raise ModelError(f"no joint {joint!r} to put on a slider")
    if guide not in data.get("links", {}):
        raise ModelError(f"no link {guide!r} to guide the slider (links: {', '.join(data.get('links', {}))})")
    ax = _point(axis, "axis")
    if math.hypot(float(ax[0]), float(ax[1])) == 0:
        raise ModelError("the slide direction [dx, dy] must not be zero")
    new = copy.deepcopy(dict(data))
    sname = _free(_names(new), "S")
    bname = _free(_names(new) | {sname}, "block")
    new["joints"][sname] = {"at": list(new["joints"][joint]["at"]), "type": "P", "axis": ax}
    new["links"][bname] = [joint, sname]
    new["links"][guide] = list(new["links"][guide]) + [sname]
    _count_check(new)
    return new


def delete(data: Mapping, *, joint: str | None = None, link: str | None = None) -> dict:
    """Delete a joint (from every link) or a link; what is left carrying nothing goes too.

    Links left with fewer than two joints are deleted, joints no link carries are deleted, and
    bodies, loads and the input that named a deleted element are dropped.
    """
    _need_diagram(data, "deleting")
    new = copy.deepcopy(dict(data))
    joints, links = new.get("joints", {}), new.get("links", {})
    if joint is not None:
        if joint not in joints:
            raise ModelError(f"no joint {joint!r} to delete")
        del joints[joint]
        for k in list(links):
            links[k] = [j for j in links[k] if j != joint]
    if link is not None:
        if link not in links:
            raise ModelError(f"no link {link!r} to delete")
        if link == GROUND:
            raise ModelError("the ground cannot be deleted (delete its joints instead)")
        del links[link]
    for k in list(links):
        if len(links[k]) < 2 and k != GROUND:
            del links[k]
    used = {j for js in links.values() for j in js}
    for j in list(joints):
        if j not in used:
            del joints[j]
    inp = new.get("input")
    if isinstance(inp, dict):
        for key, pool in (("joint", joints), ("link", links)):
            val = inp.get(key)
            names = [val] if isinstance(val, str) else list(val or [])
            kept = [n for n in names if n in pool]
            if key in inp and kept != names:
                if kept:
                    inp[key] = kept[0] if isinstance(val, str) else kept
                else:
                    del inp[key]
        if "joint" not in inp and "link" not in inp:
            del new["input"]
    bodies = new.get("bodies")
    if isinstance(bodies, dict):
        for b in list(bodies):
            if b not in links:
                del bodies[b]
        if not bodies:
            del new["bodies"]
    loads_ = new.get("loads")
    if isinstance(loads_, list):
        keep = [ld for ld in loads_ if isinstance(ld, dict)
                and (ld.get("body") is None or ld.get("body") in links)
                and (not isinstance(ld.get("at"), str) or ld.get("at") in joints)]
        if keep:
            new["loads"] = keep
        else:
            del new["loads"]
    return new


def set_input(data: Mapping, *, joint: str | None = None, link: str | None = None) -> dict:
    """Drive ``joint`` (a ground pivot or a slider) or ``link`` (its absolute angle)."""
    _need_diagram(data, "choosing the input")
    if (joint is None) == (link is None):
        raise ModelError("name the driven joint or the driven link (one of them)")
    if joint is not None and joint not in data.get("joints", {}):
        raise ModelError(f"no joint {joint!r} to drive")
    if link is not None and link not in data.get("links", {}):
        raise ModelError(f"no link {link!r} to drive")
    new = copy.deepcopy(dict(data))
    rates = {k: v for k, v in (new.get("input") or {}).items() if k in ("speed", "accel", "jerk")}
    new["input"] = {("joint" if joint is not None else "link"): joint if joint is not None else link, **rates}
    return new


# ------------------------------------------------------------------------------ masses and loads
_BODY_KEYS = {"mass", "inertia", "bar", "at", "com"}


def set_body(data: Mapping, link: str, props: Mapping[str, Any] | None) -> dict:
    """Mass properties of ``link`` (``None``: remove them). Values are checked by the model parser."""
    _need_diagram(data, "editing masses")
    if link not in data.get("links", {}) or link == GROUND:
        raise ModelError(f"no moving link {link!r} to give mass properties")
    new = copy.deepcopy(dict(data))
    bodies = dict(new.get("bodies") or {})
    if props is None:
        bodies.pop(link, None)
    else:
        if not isinstance(props, Mapping) or set(props) - _BODY_KEYS:
            raise ModelError(f"bodies.{link}: expected some of {', '.join(sorted(_BODY_KEYS))}")
        bodies[link] = copy.deepcopy(dict(props))
    if bodies:
        new["bodies"] = bodies
    else:
        new.pop("bodies", None)
    return new


def set_loads(data: Mapping, loads_) -> dict:
    """The ``[[loads]]`` list (forces at points, torques on bodies), replaced as a whole."""
    if not isinstance(loads_, list) or not all(isinstance(x, Mapping) for x in loads_):
        raise ModelError("loads: expected a list of tables such as { body = \"rocker\", torque = \"-2N*m\" }")
    if len(loads_) > MAX_ELEMENTS:
        raise ModelError(f"at most {MAX_ELEMENTS} loads")
    new = copy.deepcopy(dict(data))
    if loads_:
        new["loads"] = [dict(x) for x in loads_]
    else:
        new.pop("loads", None)
    return new


def set_gravity(data: Mapping, gravity) -> dict:
    """``gravity = [gx, gy]`` (numbers in m/s² or quantities with units), or ``None`` for none."""
    new = copy.deepcopy(dict(data))
    if gravity is None:
        new.pop("gravity", None)
    else:
        if not isinstance(gravity, (list, tuple)) or len(gravity) != 2:
            raise ModelError(f"gravity: expected [gx, gy], got {gravity!r}")
        new["gravity"] = list(gravity)
    return new


def set_units(data: Mapping, length: str | None = None, angle: str | None = None) -> dict:
    """The model's length and angle units (names as in model files: ``mm``, ``in``, ``deg``, ``rad``)."""
    new = copy.deepcopy(dict(data))
    units = dict(new.get("units") or {})
    if length is not None:
        units["length"] = str(length)
    if angle is not None:
        units["angle"] = str(angle)
    new["units"] = units
    return new


# ------------------------------------------------------------------------------ from a solved design
def diagram_from_positions(name: str, units: Mapping[str, str], positions: Mapping[str, tuple[float, float]],
                           links: Mapping[str, list], input_joint: str, *, description: str | None = None) -> dict:
    """A diagram ``dict`` from joint positions of a solved pose (a synthesized design becomes editable)."""
    data: dict[str, Any] = {"name": name}
    if description:
        data["description"] = description
    data["units"] = dict(units)
    data["joints"] = {j: {"at": [_r(float(x)), _r(float(y))]} for j, (x, y) in positions.items()}
    data["links"] = {k: list(v) for k, v in links.items()}
    data["input"] = {"joint": input_joint}
    return data


def mode_check(old_mode: str | None, new_mode: str | None, what: str, labels: Mapping[str, str] | None = None) -> None:
    """Raise :class:`ModeError` when an edit would change the assembly mode."""
    if old_mode is None or new_mode == old_mode:
        return
    labels = dict(labels or {})
    name = {v: k for k, v in labels.items()}
    show = lambda m: f"{m} ({name[m]})" if m in name else str(m)  # noqa: E731
    if new_mode is None or "0" in str(new_mode):
        raise ModeError(f"{what} puts the linkage on a dead-centre (singular) position, where its assembly mode "
                        f"{show(old_mode)} is not defined; move it less far", mode=old_mode)
    raise ModeError(f"{what} would change the assembly mode from {show(old_mode)} to {show(new_mode)}: the "
                    "linkage keeps its mode, so the edit is not made (drag less far, or build the other mode "
                    "on purpose)", mode=old_mode, modes=(new_mode,))
