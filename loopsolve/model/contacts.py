"""``[slots]`` and ``[rolling]``: a pin in a slot of a moving link, a circle rolling without slipping.

::

    [slots]                 # a point of one link in a slot of another: straight or circular
    s1 = { point = "P", link = "coupler", line = "r3" }               # along r3, through its tail
    s2 = { point = "Q", link = "lever", arc = { center = "C", radius = "R" } }

    [rolling]               # a circle rolling without slipping on a line or on a circle
    wheel = { angle = "theta3", radius = "r", on = "x" }               # on the frame's line of travel x
    planet = { angle = "theta5", radius = "r", on = "frame", base = "R", arm = "theta3" }

A slot adds one equation: the point's distance from the slot's line (through the tail of ``line``, or
the point ``through``) or from the arc is zero. Its force is the reaction normal to the slot, between
the body carrying the point and ``link``.

Rolling adds one equation, the equality of the arc lengths rolled on the two bodies (relative to the
pose of the guesses, or ``phase``): on a line ``x − x₀ = ∓r (θ − θ₀)`` (the wheel on the ``side``
``"left"`` of the line of travel, the default, turns clockwise as x grows); on a circle of radius
``base`` turning with ``on`` (or the frame), the line of centres at the angle ``arm``:
``r (Δθ − Δψ) = ±R (Δψ − Δθ_b)`` (+ outside, − for ``internal = true``). Its forces are the normal
force and the tangential (no-slip) force at the contact point.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from . import expr as _expr
from .units import Kind

__all__ = ["Slot", "Rolling", "parse_slots", "parse_rolling", "kind_hints", "names_used"]

_SLOT_KEYS = {"point", "link", "line", "arc", "through"}
_ROLL_KEYS = {"angle", "radius", "on", "base", "arm", "internal", "side", "phase", "center"}


@dataclass(frozen=True, slots=True)
class Slot:
    """A pin (``point``) in a slot of ``link``: along the vector ``line`` (through its tail, or the point
    ``through``), or on the arc of centre ``center`` (a point) and ``radius`` (an expression)."""

    name: str
    key: str
    point: str
    link: str
    line: str | None
    through: str | None
    tail: tuple
    center: str | None
    radius: object
    text: str


@dataclass(frozen=True, slots=True)
class Rolling:
    """A wheel (angle ``angle``, radius ``radius``) rolling on a line (``on`` a length variable) or on a circle
    (``base`` its radius, ``on`` its angle or ``""`` for the frame, ``arm`` the line of centres' angle).
    ``ref`` holds the guesses (wheel, on, arm) when ``phase`` is not given; ``sign`` the sense."""

    name: str
    key: str
    angle: str
    radius: object
    on: str
    base: object
    arm: str
    sign: int
    phase: object
    ref: tuple
    center: str | None
    text: str

    @property
    def circle(self) -> bool:
        return self.base is not None


def _table(spec, name) -> Mapping:
    val = spec.get(name, {})
    return val if isinstance(val, Mapping) else {}


def kind_hints(spec):
    for name, d in _table(spec, "rolling").items():
        if not isinstance(d, Mapping):
            continue
        key = f"rolling.{name}"
        if isinstance(d.get("angle"), str):
            yield d["angle"], "angle", f"{key}.angle"
        if isinstance(d.get("on"), str):
            yield d["on"], ("angle" if "base" in d else "length"), f"{key}.on"
        if isinstance(d.get("arm"), str):
            yield d["arm"], "angle", f"{key}.arm"


def names_used(spec):
    for section in ("slots", "rolling"):
        for name, d in _table(spec, section).items():
            if not isinstance(d, Mapping):
                continue
            key = f"{section}.{name}"
            vals = [d.get(k) for k in ("angle", "on", "arm", "radius", "base", "phase")]
            if isinstance(d.get("arc"), Mapping):
                vals.append(d["arc"].get("radius"))
            for v in vals:
                if isinstance(v, str) and v not in ("frame", "ground"):
                    try:
                        yield from ((n, key) for n in _expr.names(_expr.parse(v)))
                    except Exception:
                        pass


def parse_slots(ctx) -> tuple[Slot, ...]:
    from .placement import placement

    out = []
    place = None
    for name, raw in ctx.table("slots").items():
        d = ctx.entry("slots", name, raw, _SLOT_KEYS, '{ point = "P", link = "coupler", line = "r3" }')
        if d is None:
            continue
        key = f"slots.{name}"
        p = ctx.problems
        if "point" not in d or "link" not in d or ("line" in d) == ("arc" in d):
            p.add(key, "a slot needs `point`, `link` and one of `line` (a vector) or `arc = { center, radius }`")
            continue
        point = ctx.point(d["point"], f"{key}.point")
        link = ctx.link(d["link"], f"{key}.link")
        if point is None or link is None:
            continue
        line = through = center = radius = None
        tail = ()
        if "line" in d:
            line = ctx.vector(d["line"], f"{key}.line")
            if line is None:
                continue
            if "through" in d:
                through = ctx.point(d["through"], f"{key}.through")
                if through is None:
                    continue
            else:
                if place is None:
                    place = placement(_Placeable(ctx))
                if line not in place.tail:
                    p.add(f"{key}.line", f"the vector {line!r} is in no loop or point, so where its line lies is "
                          "unknown: give the slot a point it passes through with `through`")
                    continue
                tail = place.tail[line]
            text = f"{point} in the slot of {link} along {line}"
        else:
            arc = d["arc"]
            if not isinstance(arc, Mapping) or set(arc) != {"center", "radius"}:
                p.add(f"{key}.arc", "expected { center = \"<point>\", radius = ... }")
                continue
            center = ctx.point(arc["center"], f"{key}.arc.center")
            radius = ctx.quantity(arc["radius"], f"{key}.arc.radius", Kind.LENGTH, positive=True, allow_zero=False)
            if center is None or radius is None:
                continue
            text = f"{point} in the arc slot of {link} about {center}"
        if "through" in d and line is None:
            p.add(f"{key}.through", "`through` belongs to a straight slot (`line`)")
            continue
        out.append(Slot(str(name), key, point, link, line, through, tail, center, radius, text))
    return tuple(out)


class _Placeable:
    """The parts of a mechanism :func:`loopsolve.model.placement.placement` reads, from a parse context."""

    def __init__(self, ctx):
        self.points = tuple(ctx.points.values())
        self.loops = tuple(ctx.loops)
        self.vectors = tuple(ctx.vectors.values())
        self.variables = tuple(ctx.variables.values())


def parse_rolling(ctx) -> tuple[Rolling, ...]:
    out = []
    for name, raw in ctx.table("rolling").items():
        d = ctx.entry("rolling", name, raw, _ROLL_KEYS, '{ angle = "theta3", radius = "r", on = "x" }')
        if d is None:
            continue
        key = f"rolling.{name}"
        p = ctx.problems
        n_before = len(p.items)
        for k in ("angle", "radius", "on"):
            if k not in d:
                p.add(key, f"missing key {k!r}; rolling is {{ angle = \"theta3\", radius = \"r\", on = \"x\" }}")
        if len(p.items) > n_before:
            continue
        circle = "base" in d
        angle = ctx.variable(d["angle"], f"{key}.angle", Kind.ANGLE)
        radius = ctx.quantity(d["radius"], f"{key}.radius", Kind.LENGTH, positive=True, allow_zero=False)
        if circle:
            on = ctx.variable(d["on"], f"{key}.on", Kind.ANGLE, frame=True)
            if "arm" not in d:
                p.add(key, "rolling on a circle needs `arm` (the angle of the line from its centre to the wheel's)")
                continue
            arm = ctx.variable(d["arm"], f"{key}.arm", Kind.ANGLE)
            base = ctx.quantity(d["base"], f"{key}.base", Kind.LENGTH, positive=True, allow_zero=False)
            internal = d.get("internal", False)
            if not isinstance(internal, bool):
                p.add(f"{key}.internal", f"expected true or false, got {internal!r}")
                continue
            sign = -1 if internal else 1
            if "side" in d:
                p.add(f"{key}.side", "`side` belongs to rolling on a line")
                continue
        else:
            on = ctx.variable(d["on"], f"{key}.on", Kind.LENGTH)
            arm, base = "", None
            for k in ("arm", "internal"):
                if k in d:
                    p.add(f"{key}.{k}", f"`{k}` belongs to rolling on a circle (give `base`, its radius)")
            side = d.get("side", "left")
            if side not in ("left", "right"):
                p.add(f"{key}.side", f"{side!r}: expected \"left\" or \"right\"")
            sign = 1 if side == "left" else -1
        if len(p.items) > n_before or angle is None or on is None or radius is None:
            continue
        if angle in (on, arm):
            p.add(key, f"the wheel's angle {angle!r} is also the {'base' if angle == on else 'arm'}")
            continue
        center = ctx.point(d["center"], f"{key}.center") if "center" in d else None
        phase, ref = None, ()
        if "phase" in d:
            phase = ctx.quantity(d["phase"], f"{key}.phase", Kind.LENGTH)
            if phase is None:
                continue
        else:
            missing = [v for v in (angle, on, arm) if v and ctx.variables[v].guess is None]
            if missing:
                p.add(key, f"no phase and no guess for {', '.join(missing)}: the arc lengths are measured from the "
                      "pose of the guesses; give guesses or `phase`")
                continue
            ref = tuple(ctx.variables[v].guess if v else 0.0 for v in (angle, on, arm))
        what = (f"circle of radius {d['base']} ({'inside' if sign < 0 else 'outside'})" if circle
                else f"the line of {on}")
        out.append(Rolling(str(name), key, angle, radius, on, base, arm, sign, phase, ref, center,
                           f"wheel {angle} rolling on {what}"))
    return tuple(out)
