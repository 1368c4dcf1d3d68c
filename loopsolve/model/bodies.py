"""Mass properties and loads: the declarations of the ``gravity``, ``[bodies]`` and ``[[loads]]`` keys.

A model may add, to its kinematics, the moving rigid bodies (mass, inertia about the centre of
mass, centre of mass as a point expression, orientation, the joints they carry, the guide they
slide on) and the loads on them (forces at points, torques on bodies, linear springs and viscous
dampers between two points, torsional springs and dampers on a body). This module parses and
validates them into frozen declarations; :mod:`loopsolve.dynamics.dynamics_model` derives the equation of motion
and :mod:`loopsolve.dynamics.kinetostatics` the joint forces.

Values are SI (kg, kg·m², N, N·m, N/m, N·s/m, m/s²) when plain numbers — except that, in a model
whose length unit is not the metre, a plain number whose SI unit involves the metre (inertia,
torque, stiffness, damping, gravity, density) is refused as ambiguous; a string may carry any unit
of the right dimension (``"0.3kg"``, ``"2.5e-4kg*m^2"``, ``"0.5 slug*ft^2"``, ``"12 in*lbf"``,
``"-9.81m/s^2"``), read by :func:`loopsolve.model.units.parse_quantity` like every other quantity. A
force or torque may also be an expression (SI result) of the parameters, the variables (in the
model's units: a piston position in mm, an angle in degrees) and the rates ``<variable>_vel``
(rad/s or length unit/s). Free lengths are in the model's length unit, free angles in its angle
unit, unless they carry a unit.

This module does not import :mod:`loopsolve.model.mechanism`: the builder passes its point parser in.
"""

from __future__ import annotations

import enum
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from . import expr as _expr
from ..errors import ModelError
from .units import Kind, length_factor, parse_quantity, unit_label

__all__ = ["Body", "Load", "LoadKind", "Dynamics", "parse_mech_quantity", "parse_dynamics",
           "uniform_bar"]

FRAME = "frame"

_QTY_RE = re.compile(r"^\s*([+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?)\s*([A-Za-z°µμ][A-Za-z0-9*/^·²³ ]*)?\s*$")
_VEL = "_vel"


def parse_mech_quantity(value: Any, kind: str | Kind, *, length_unit: str = "m", where: str = "") -> float:
    """A plain number or a quantity string of a mechanical ``kind`` (``"mass"``, ``"inertia"``, ...,
    a :class:`~loopsolve.model.units.Kind` value), in SI.

    Any unit of the kind's dimension is accepted (:func:`loopsolve.model.units.parse_quantity`). A plain
    number is SI; where the SI unit involves the metre (inertia, torque, stiffness, damping,
    acceleration, density) it is refused unless ``length_unit`` is the metre (or it is 0). Raises
    :class:`~loopsolve.model.units.UnitError` (a :class:`ModelError`) naming the kind and examples.

    Examples
    --------
    >>> ls.bodies.parse_mech_quantity("2.5e-4kg*m^2", "inertia")
    0.00025
    >>> round(ls.bodies.parse_mech_quantity("1lbf", "force"), 4)
    4.4482
    >>> round(ls.bodies.parse_mech_quantity("12 in*lbf", "torque", length_unit="mm"), 6)
    1.355818
    """
    k = kind if isinstance(kind, Kind) else Kind(kind)
    return parse_quantity(value, k, angle_unit="deg", length_unit=length_unit, where=where)


def uniform_bar(length: float, width: float, thickness: float, density: float = 7850.0) -> tuple[float, float]:
    """Mass (kg) and inertia about the centre (kg·m²) of a uniform rectangular bar (SI inputs).

    ``m = ρ L w t``, ``I = m (L² + w²) / 12`` (rotation in the plane of ``L`` and ``w``).

    Examples
    --------
    >>> m, i = ls.bodies.uniform_bar(0.1, 0.01, 0.005, 7850)
    >>> round(m, 5), round(i * 1e6, 4)
    (0.03925, 33.0354)
    """
    m = density * length * width * thickness
    return m, m * (length**2 + width**2) / 12.0


class LoadKind(enum.Enum):
    """The kinds of ``[[loads]]`` entries."""

    FORCE = "force"
    TORQUE = "torque"
    SPRING = "spring"
    DAMPER = "damper"
    TORSION_SPRING = "torsional spring"
    TORSION_DAMPER = "torsional damper"


@dataclass(frozen=True, slots=True)
class Body:
    """A moving rigid body. SI mass and inertia; ``com`` a point (from the origin, model units).

    ``angle`` is an expression of the variables and parameters (model angle units), ``None`` for a
    body that only translates; ``joints`` name points; ``guide`` names the vector it slides along,
    on ``guide_body`` (``"frame"`` or a body).
    """

    name: str
    mass: float
    inertia: float
    com: Any  # a model.Point
    angle: Any = None
    joints: tuple[str, ...] = ()
    guide: str | None = None
    guide_body: str | None = None
    angle_text: str = ""


@dataclass(frozen=True, slots=True)
class Load:
    """One ``[[loads]]`` entry (index ``index`` in the file).

    ``values`` holds floats (SI) or expression trees (SI result): ``(fx, fy)`` for a force,
    ``(torque,)`` for a torque. Springs and dampers join ``ends`` (two point names) on
    ``bodies`` (two body names or ``"frame"``); ``stiffness``/``damping`` SI; ``free`` is the free
    length (model length unit) or free angle (radians).
    """

    kind: LoadKind
    index: int
    body: str | None = None
    at: str | None = None
    values: tuple = ()
    ends: tuple[str, ...] = ()
    bodies: tuple[str, ...] = ()
    stiffness: float = 0.0
    damping: float = 0.0
    free: float = 0.0
    name: str = ""


@dataclass(frozen=True, slots=True)
class Dynamics:
    """Gravity (m/s², x and y), bodies and loads of a mechanism."""

    gravity: tuple[float, float]
    bodies: tuple[Body, ...]
    loads: tuple[Load, ...]

    def body(self, name: str) -> Body:
        for b in self.bodies:
            if b.name == name:
                return b
        raise ModelError(f"unknown body {name!r}; the bodies are {', '.join(b.name for b in self.bodies)}")


_BODY_KEYS = {"mass", "inertia", "com", "angle", "joints", "guide", "guide_body", "bar"}
_BAR_KEYS = {"length", "width", "thickness", "density"}


def parse_dynamics(spec: Mapping[str, Any], *, problems, parse_point: Callable, parse_expr: Callable,
                   vec_names, point_names, param_names, var_names, fixed_points, vector_angle_text,
                   length_unit: str, angle_unit: str) -> Dynamics | None:
    """Parse ``gravity``, ``[bodies]`` and ``[[loads]]`` of a model ``dict`` (``None`` when absent).

    ``problems.add(key, message)`` collects every problem; ``parse_point(name, text, key)``
    parses a point expression; ``parse_expr(value, key)`` an expression; ``fixed_points`` are the
    points that do not move; ``vector_angle_text`` maps a vector to the text of its angle (``None``
    for a fixed direction).
    """
    if not any(k in spec for k in ("gravity", "bodies", "loads")):
        return None
    try:
        lf = length_factor(length_unit, "m")
        physical = True
    except ModelError:
        lf = 1.0
        physical = False
        if "bodies" in spec:
            problems.add("units.length", f"{length_unit!r} is not a physical length unit: a model with "
                         "bodies needs mm, cm, m, in or ft")
    names_ok = set(param_names) | set(var_names) | {v + _VEL for v in var_names}

    def value(raw, kind: str, key: str, *, expression: bool = False):
        if expression and isinstance(raw, str) and not _QTY_RE.match(raw):
            node = parse_expr(raw, key)
            if node is None:
                return None
            bad = sorted(_expr.names(node) - names_ok)
            for nm in bad:
                problems.add(key, f"{raw!r} names {nm!r}, which is not a parameter, a variable or a rate "
                             f"<variable>_vel; declared: {', '.join(sorted(names_ok))}")
            for n in _expr.walk(node):
                if isinstance(n, _expr.Num) and n.unit is not None:
                    problems.add(key, f"{raw!r}: an expression is in SI ({kind} in "
                                 f"{unit_label(Kind(kind))}); drop the unit {n.unit!r}")
                    return None
            return None if bad else node
        try:
            return parse_mech_quantity(raw, kind, length_unit=length_unit if physical else "m")
        except ModelError as exc:
            problems.add(key, str(exc))
            return None

    # ---- gravity
    gravity = (0.0, 0.0)
    graw = spec.get("gravity")
    if graw is not None:
        if not isinstance(graw, list) or len(graw) != 2:
            problems.add("gravity", f"expected the two components of g, e.g. [0, \"-9.81m/s^2\"], got {graw!r}")
        else:
            g = [value(c, "acceleration", f"gravity[{i}]") for i, c in enumerate(graw)]
            if None not in g:
                gravity = (g[0], g[1])

    # ---- bodies
    bspec = spec.get("bodies", {})
    if not isinstance(bspec, Mapping):
        problems.add("bodies", f"expected a table of bodies: crank = {{ mass = \"0.3kg\", ... }}, got {bspec!r}")
        bspec = {}
    bodies: list[Body] = []
    for bname, bdef in bspec.items():
        key = f"bodies.{bname}"
        if bname in (FRAME, "ground"):
            problems.add(key, f"{bname!r} is the fixed link: list only moving bodies")
            continue
        if not isinstance(bdef, Mapping):
            problems.add(key, f"expected a table like {{ mass = \"0.3kg\", inertia = ..., com = \"0.5*r2\" }}, "
                         f"got {bdef!r}")
            continue
        extra = set(bdef) - _BODY_KEYS
        if extra:
            problems.add(key, f"unknown key(s) {sorted(extra)} (allowed: {', '.join(sorted(_BODY_KEYS))})")
        mass = inertia = None
        if "bar" in bdef:
            bar = bdef["bar"]
            if not isinstance(bar, Mapping) or set(bar) - _BAR_KEYS or not {"length", "width", "thickness"} <= set(bar):
                problems.add(f"{key}.bar", "expected { length = ..., width = ..., thickness = ..., "
                             "density = \"7850kg/m^3\" } (lengths in the model's unit unless given)")
            else:
                dims = []
                for d in ("length", "width", "thickness"):
                    try:
                        dims.append(parse_quantity(bar[d], Kind.LENGTH, angle_unit=angle_unit,
                                                   length_unit=length_unit) * lf)
                    except (ModelError, ValueError, TypeError) as exc:
                        problems.add(f"{key}.bar.{d}", str(exc))
                rho = value(bar.get("density", "7850kg/m^3"), "density", f"{key}.bar.density")
                if len(dims) == 3 and rho is not None:
                    if min(dims) <= 0 or rho <= 0:
                        problems.add(f"{key}.bar", "the bar's dimensions and density must be positive")
                    else:
                        mass, inertia = uniform_bar(*dims, rho)
            if "mass" in bdef or "inertia" in bdef:
                problems.add(key, "give either `bar` or `mass` and `inertia`, not both")
        else:
            if "mass" not in bdef:
                problems.add(key, "missing `mass` (e.g. mass = \"0.3kg\"), or describe a uniform bar with "
                             "bar = { length, width, thickness, density }")
            else:
                mass = value(bdef["mass"], "mass", f"{key}.mass")
                if mass is not None and not mass > 0:
                    problems.add(f"{key}.mass", f"the mass must be positive, got {bdef['mass']!r}")
                    mass = None
            if "inertia" in bdef:
                inertia = value(bdef["inertia"], "inertia", f"{key}.inertia")
                if inertia is not None and inertia < 0:
                    problems.add(f"{key}.inertia", f"the inertia must not be negative, got {bdef['inertia']!r}")
                    inertia = None
            elif "angle" in bdef:
                problems.add(key, "a rotating body needs `inertia` about its centre of mass "
                             "(e.g. inertia = \"2.5e-4kg*m^2\"; 0 for a point mass)")
            else:
                inertia = 0.0
        com = None
        if "com" not in bdef:
            problems.add(key, "missing `com`: the centre of mass as a point expression (e.g. \"r2 + 0.5*r3\")")
        else:
            craw = bdef["com"]
            if isinstance(craw, str) and craw.strip() in point_names and craw.strip() not in vec_names:
                com = point_names[craw.strip()]
            else:
                com = parse_point(f"G_{bname}", craw, f"{key}.com")
        angle = None
        angle_text = ""
        if "angle" in bdef:
            angle = parse_expr(bdef["angle"], f"{key}.angle")
            if angle is not None:
                angle_text = _expr.to_text(angle)
                bad = sorted(_expr.names(angle) - set(param_names) - set(var_names))
                for nm in bad:
                    problems.add(f"{key}.angle", f"{bdef['angle']!r} names {nm!r}, which is not a declared variable "
                                 f"or parameter; declared variables: {', '.join(var_names)}")
                if bad:
                    angle = None
                elif not (_expr.names(angle) & set(var_names)):
                    problems.add(f"{key}.angle", f"{bdef['angle']!r} is constant: a body that does not rotate "
                                 "has no `angle`")
                    angle = None
        joints: list[str] = []
        jraw = bdef.get("joints", [])
        if not isinstance(jraw, list) or not all(isinstance(j, str) for j in jraw):
            problems.add(f"{key}.joints", f"expected a list of point names such as [\"O2\", \"B\"], got {jraw!r}")
        else:
            for j in jraw:
                if j not in point_names:
                    problems.add(f"{key}.joints", f"{j!r} is not a point: declare it in [points] (e.g. {j} = \"r2\"); "
                                 f"the points are {', '.join(point_names) or 'none'}")
                elif j in joints:
                    problems.add(f"{key}.joints", f"{j!r} is listed twice")
                else:
                    joints.append(j)
        guide = bdef.get("guide")
        guide_body = bdef.get("guide_body")
        if guide is not None and (not isinstance(guide, str) or guide not in vec_names):
            problems.add(f"{key}.guide", f"{guide!r} is not a declared vector (the guide is the vector the body "
                         "slides along)")
            guide = None
        if guide_body is not None and guide is None:
            problems.add(f"{key}.guide_body", "`guide_body` is given without `guide`")
        if mass is None or inertia is None or com is None:
            continue
        bodies.append(Body(str(bname), float(mass), float(inertia), com, angle, tuple(joints),
                           guide, guide_body, angle_text))

    body_names = {b.name for b in bodies} | {str(n) for n in bspec}
    # guides: on the frame when the vector's direction is fixed, else on the body turning with it
    resolved: list[Body] = []
    for b in bodies:
        if b.guide is None:
            resolved.append(b)
            continue
        key = f"bodies.{b.name}.guide"
        gb = b.guide_body
        if gb is not None:
            if gb not in body_names and gb != FRAME:
                problems.add(f"bodies.{b.name}.guide_body", f"{gb!r} is not a body (nor \"frame\")")
                continue
        else:
            text = vector_angle_text(b.guide)
            if text is None:
                gb = FRAME
            else:
                cands = [o.name for o in bodies if o.name != b.name and o.angle_text == text]
                if not cands:
                    problems.add(key, f"the guide {b.guide!r} turns (angle {text!r}) but no other declared body "
                                 f"turns with it: declare the body that carries the guide in [bodies] (e.g. the "
                                 f"rocker: {{ mass = ..., inertia = ..., com = ..., angle = \"{text}\", joints = "
                                 "[...] })")
                    continue
                if len(cands) > 1:
                    problems.add(key, f"the guide {b.guide!r} (angle {text!r}) turns with {', '.join(cands)}: name "
                                 "the one that carries it with guide_body = \"...\"")
                    continue
                gb = cands[0]
        resolved.append(Body(b.name, b.mass, b.inertia, b.com, b.angle, b.joints, b.guide, gb, b.angle_text))
    bodies = resolved

    def carrier(point: str, key: str, given) -> str | None:
        if given is not None:
            if given != FRAME and given not in body_names:
                problems.add(key, f"{given!r} is not a declared body (bodies: {', '.join(sorted(body_names))}; "
                             "or \"frame\")")
                return None
            return given
        cands = [b.name for b in bodies if point in b.joints]
        if len(cands) == 1:
            return cands[0]
        if len(cands) > 1:
            problems.add(key, f"{point!r} is carried by {', '.join(cands)}: name the body the load acts on "
                         "with body = \"...\"")
            return None
        if point in fixed_points:
            return FRAME
        problems.add(key, f"no body carries the point {point!r}: name the body with body = \"...\"")
        return None

    # ---- loads
    lspec = spec.get("loads", [])
    if not isinstance(lspec, list):
        problems.add("loads", "expected an array of tables: [[loads]] at = \"C\", force = [\"-50N\", 0]")
        lspec = []
    loads: list[Load] = []
    for i, ldef in enumerate(lspec):
        key = f"loads[{i}]"
        if not isinstance(ldef, Mapping):
            problems.add(key, f"expected a table, got {ldef!r}")
            continue
        lname = str(ldef.get("name", f"load{i + 1}"))
        body = ldef.get("body")
        if body is not None and (not isinstance(body, str) or (body not in body_names and body != FRAME)):
            problems.add(f"{key}.body", f"{body!r} is not a declared body (bodies: "
                         f"{', '.join(sorted(body_names)) or 'none'})")
            continue
        kinds = [k for k in ("force", "torque", "spring", "damper") if k in ldef]
        if not kinds and body is not None and ("stiffness" in ldef or "damping" in ldef):
            kinds = ["torsion"]
        all_keys = {"at", "body", "force", "torque", "spring", "damper", "stiffness", "damping", "free_length",
                    "free_angle", "bodies", "name"}
        unknown = sorted(str(k) for k in set(ldef) - all_keys)
        if unknown:
            import difflib

            hints = [f"{k!r}" + (f" (did you mean {m[0]!r}?)" if (m := difflib.get_close_matches(k, all_keys, 1)) else "")
                     for k in unknown]
            problems.add(key, f"unknown key(s) {', '.join(hints)}; a load's keys are {', '.join(sorted(all_keys))}")
            continue
        if len(kinds) != 1:
            problems.add(key, "a load is one of: a force (at, force = [fx, fy]), a torque (body, torque), a spring "
                         "(spring = [\"A\", \"B\"], stiffness, free_length), a damper (damper = [\"A\", \"B\"], "
                         "damping), or a torsional spring/damper (body, stiffness, free_angle / damping)")
            continue
        kind = kinds[0]
        allowed = {"force": {"at", "body", "force"}, "torque": {"body", "torque"},
                   "spring": {"spring", "stiffness", "free_length", "bodies"},
                   "damper": {"damper", "damping", "bodies"},
                   "torsion": {"body", "stiffness", "free_angle", "damping"}}[kind] | {"name"}
        extra = set(ldef) - allowed
        if extra:
            problems.add(key, f"unknown key(s) {sorted(extra)} for a {kind} (allowed: {', '.join(sorted(allowed))})")
            continue
        if kind == "force":
            at = ldef.get("at")
            f = ldef.get("force")
            if not isinstance(at, str) or at not in point_names:
                problems.add(f"{key}.at", f"{at!r} is not a declared point")
                continue
            if not isinstance(f, list) or len(f) != 2:
                problems.add(f"{key}.force", f"expected the two components [fx, fy], got {f!r}")
                continue
            vals = tuple(value(c, "force", f"{key}.force[{j}]", expression=True) for j, c in enumerate(f))
            on = carrier(at, f"{key}.body", body)
            if None in vals or on is None:
                continue
            loads.append(Load(LoadKind.FORCE, i, body=on, at=at, values=vals, name=lname))
        elif kind == "torque":
            if body is None:
                problems.add(key, "a torque needs the body it acts on: body = \"...\"")
                continue
            t = value(ldef["torque"], "torque", f"{key}.torque", expression=True)
            if t is not None:
                loads.append(Load(LoadKind.TORQUE, i, body=body, values=(t,), name=lname))
        elif kind in ("spring", "damper"):
            ends = ldef[kind]
            if not isinstance(ends, list) or len(ends) != 2 or not all(isinstance(e, str) for e in ends):
                problems.add(f"{key}.{kind}", f"expected two point names such as [\"B\", \"O4\"], got {ends!r}")
                continue
            bad = [e for e in ends if e not in point_names]
            for e in bad:
                problems.add(f"{key}.{kind}", f"{e!r} is not a declared point")
            given = ldef.get("bodies", [None, None])
            if not isinstance(given, list) or len(given) != 2:
                problems.add(f"{key}.bodies", f"expected two body names (or \"frame\"), got {given!r}")
                continue
            if bad:
                continue
            on = tuple(carrier(e, f"{key}.bodies", g) for e, g in zip(ends, given))
            if None in on:
                continue
            if kind == "spring":
                k = value(ldef.get("stiffness"), "stiffness", f"{key}.stiffness") if "stiffness" in ldef else None
                if "stiffness" not in ldef:
                    problems.add(key, "a spring needs `stiffness` (e.g. \"200N/m\")")
                if "free_length" not in ldef:
                    problems.add(key, "a spring needs `free_length` (in the model's length unit or with a unit)")
                    continue
                try:
                    free = parse_quantity(ldef["free_length"], Kind.LENGTH, angle_unit=angle_unit,
                                          length_unit=length_unit)
                except (ModelError, ValueError, TypeError) as exc:
                    problems.add(f"{key}.free_length", str(exc))
                    continue
                if k is None:
                    continue
                loads.append(Load(LoadKind.SPRING, i, ends=tuple(ends), bodies=on, stiffness=k, free=free, name=lname))
            else:
                if "damping" not in ldef:
                    problems.add(key, "a damper needs `damping` (e.g. \"5N*s/m\")")
                    continue
                c = value(ldef["damping"], "damping", f"{key}.damping")
                if c is not None:
                    loads.append(Load(LoadKind.DAMPER, i, ends=tuple(ends), bodies=on, damping=c, name=lname))
        else:  # torsional spring and/or damper on a body (relative to the frame)
            if "stiffness" in ldef:
                k = value(ldef["stiffness"], "torsional stiffness", f"{key}.stiffness")
                if "free_angle" not in ldef:
                    problems.add(key, "a torsional spring needs `free_angle` (in the model's angle unit)")
                    continue
                try:
                    free = parse_quantity(ldef["free_angle"], Kind.ANGLE, angle_unit=angle_unit,
                                          length_unit=length_unit)
                except (ModelError, ValueError, TypeError) as exc:
                    problems.add(f"{key}.free_angle", str(exc))
                    continue
                if k is not None:
                    loads.append(Load(LoadKind.TORSION_SPRING, i, body=body, stiffness=k, free=free, name=lname))
            if "damping" in ldef:
                c = value(ldef["damping"], "torsional damping", f"{key}.damping")
                if c is not None:
                    loads.append(Load(LoadKind.TORSION_DAMPER, i, body=body, damping=c, name=lname + "_damping"))
    # bodies that rotate are needed for torsional loads
    by = {b.name: b for b in bodies}
    for ld in loads:
        if ld.kind in (LoadKind.TORSION_SPRING, LoadKind.TORSION_DAMPER) and ld.body in by \
                and by[ld.body].angle is None:
            problems.add(f"loads[{ld.index}]", f"a torsional load on {ld.body!r}, which has no `angle`")
    return Dynamics(gravity, tuple(bodies), tuple(loads))
