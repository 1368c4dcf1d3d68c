"""Higher pairs: the elements a model adds to its vector loops, and the one door that parses them.

A model file may add to its loops scalar constraints (``[constraints]``), spur gear pairs
(``[gears]``), disk cams (``[cams.NAME]``), pins in slots (``[slots]``), rolling contacts
(``[rolling]``) and Coulomb friction (``[friction]``). Each of the first five contributes one
scalar equation to Φ, derived, differentiated and solved with the loops
(:mod:`loopsolve.symbolic.pairs`); friction adds no equation, only forces
(:mod:`loopsolve.dynamics.friction`). This module holds the container :class:`HigherPairs`, the
context the parsers share (:class:`PairContext`) and :func:`parse_pairs`, called by
:func:`loopsolve.model.spec.build_mechanism` with the rest of the declaration; each element's
declaration and checks live in its own module (:mod:`~loopsolve.model.constraints`,
:mod:`~loopsolve.model.gears`, :mod:`~loopsolve.model.cams`, :mod:`~loopsolve.model.contacts`,
:mod:`~loopsolve.model.friction`).

A variable that appears only in higher pairs gets its kind from them: a gear's angles are
angles, a rack's travel and a translating follower's displacement are lengths, and in a
``[constraints]`` equation a bare name added to (or subtracted from) a name of known kind has that
kind. Anything still unknown asks for ``kind = "angle"`` or ``kind = "length"`` in ``[variables]``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from . import expr as _expr
from .units import Kind, UnitError, parse_quantity, unit_kind

__all__ = ["SECTIONS", "ROW_SECTIONS", "HigherPairs", "PairContext", "parse_pairs", "infer_kinds",
           "pair_variables", "evaluator", "declared_rows", "declared_row_keys", "declared_links"]

#: the model-file sections of higher pairs
SECTIONS = ("constraints", "gears", "cams", "slots", "rolling", "friction")
#: the sections whose entries add one equation each to Φ, in the order of Φ's rows
ROW_SECTIONS = ("constraints", "gears", "cams", "slots", "rolling")

_ANGLE, _LENGTH = "angle", "length"


@dataclass(frozen=True)
class HigherPairs:
    """The higher pairs of a mechanism (each a tuple of frozen declarations, in file order)."""

    constraints: tuple = ()
    gears: tuple = ()
    cams: tuple = ()
    slots: tuple = ()
    rolling: tuple = ()
    friction: tuple = ()

    @property
    def rows(self) -> tuple:
        """The elements that add an equation to Φ, in row order (constraints, gears, cams, slots, rolling)."""
        return self.constraints + self.gears + self.cams + self.slots + self.rolling

    @property
    def row_names(self) -> tuple[str, ...]:
        """``section.name`` of every row (the names Φ's rows carry after the loops' x and y)."""
        return tuple(e.key for e in self.rows)

    @property
    def n_rows(self) -> int:
        return len(self.rows)

    def element(self, key: str):
        """The element whose key (``gears.sun_planet``) is ``key``."""
        for e in self.rows + self.friction:
            if e.key == key:
                return e
        raise KeyError(key)

    def __bool__(self) -> bool:
        return any((self.constraints, self.gears, self.cams, self.slots, self.rolling, self.friction))


@dataclass
class PairContext:
    """What the higher-pair parsers need from the rest of the declaration (built by ``build_mechanism``).

    ``problems.add(key, message)`` collects problems; ``parse_expr(value, key)`` parses an
    expression (``None`` on failure, the problem recorded); ``check_literals(node, ctx, key, text)``
    checks the units of its literals; ``check_name(name, key)`` an entry's name.
    ``parameters``/``variables`` map names to the parsed
    declarations (values and guesses in internal units), ``vectors`` names to parsed vectors,
    ``points`` names to parsed points; ``bodies`` the body names (``()`` without ``[bodies]``),
    ``links`` every link name the model declares (bodies, vectors' ``link`` keys, diagram links).
    """

    problems: Any
    parse_expr: Callable
    check_literals: Callable
    check_name: Callable
    parameters: Mapping[str, Any]
    variables: Mapping[str, Any]
    vectors: Mapping[str, Any]
    points: Mapping[str, Any]
    bodies: tuple[str, ...]
    links: frozenset
    angle_unit: str
    length_unit: str
    dynamics: Any = None
    spec: Mapping[str, Any] = field(default_factory=dict)
    loops: tuple = ()

    # ---------------------------------------------------------------- shared helpers
    @property
    def angle_factor(self) -> float:
        """Radians per model angle unit."""
        return math.pi / 180.0 if self.angle_unit == "deg" else 1.0

    def table(self, section: str) -> Mapping[str, Any]:
        """The section's table (``{}`` when absent; a problem when it is not a table)."""
        val = self.spec.get(section, {})
        if not isinstance(val, Mapping):
            self.problems.add(section, f"expected a table, got {type(val).__name__} {_short(val)}")
            return {}
        return val

    def entry(self, section: str, name: Any, value: Any, allowed: set, example: str) -> Mapping | None:
        """One entry of a section, checked to be a table of known keys with a valid name."""
        key = f"{section}.{name}"
        if not self.check_name(name, key):
            return None
        if not isinstance(value, Mapping):
            self.problems.add(key, f"expected a table like {example}, got {_short(value)}")
            return None
        extra = sorted(set(value) - allowed)
        if extra:
            self.problems.add(key, f"unknown key(s) {extra} (allowed: {', '.join(sorted(allowed))})")
            return None
        return value

    def variable(self, value: Any, key: str, kind: Kind | None = None, *, frame: bool = False) -> str | None:
        """A variable name (``"frame"`` gives ``""`` where ``frame`` is allowed), of ``kind``; else a problem."""
        if frame and value in ("frame", "ground", 0):
            return ""
        if not isinstance(value, str) or value not in self.variables:
            declared = ", ".join(self.variables) or "none"
            extra = ' or "frame"' if frame else ""
            self.problems.add(key, f"{_short(value)} is not a declared variable (declared: {declared}){extra}")
            return None
        var = self.variables[value]
        if kind is not None and var.kind is not kind:
            self.problems.add(key, f"{value!r} is {_a(var.kind.value)} but this key needs {_a(kind.value)}")
            return None
        return value

    def point(self, value: Any, key: str) -> str | None:
        if not isinstance(value, str) or value not in self.points:
            declared = ", ".join(self.points) or "none"
            self.problems.add(key, f"{_short(value)} is not a declared point (points: {declared})")
            return None
        return value

    def vector(self, value: Any, key: str) -> str | None:
        if not isinstance(value, str) or value not in self.vectors:
            declared = ", ".join(self.vectors) or "none"
            self.problems.add(key, f"{_short(value)} is not a declared vector (vectors: {declared})")
            return None
        return value

    def link(self, value: Any, key: str) -> str | None:
        """A link name: ``frame``/``ground``, a body, a vector's ``link`` or a diagram link.

        A model that declares no links at all (no bodies, no ``link`` keys) accepts any valid name:
        then it only labels the element."""
        if value in ("frame", "ground"):
            return "frame"
        if not isinstance(value, str) or not value:
            self.problems.add(key, f"expected a link name, got {_short(value)}")
            return None
        if self.links and value not in self.links:
            self.problems.add(key, f"unknown link {value!r} (links: frame, {', '.join(sorted(self.links))})")
            return None
        return value

    def quantity(self, value: Any, key: str, kind: Kind, *, positive: bool = False,
                 allow_zero: bool = True) -> _expr.Node | None:
        """A number, quantity (``"25mm"``), parameter or expression of parameters of ``kind`` (angle or
        length), parsed; its value is checked (``positive``) with the parameters' values."""
        if isinstance(value, bool) or not isinstance(value, (int, float, str)):
            self.problems.add(key, f"expected a number, a quantity such as \"25mm\" or a parameter, got "
                              f"{_short(value)}")
            return None
        node = self.parse_expr(value, key)
        if node is None:
            return None
        bad = sorted(_expr.names(node) - set(self.parameters))
        if bad:
            where = [n for n in bad if n in self.variables]
            what = "a variable" if where else "not a parameter"
            self.problems.add(key, f"{_short(value)} names {bad[0]!r}, {what}: this value is a number, a quantity "
                              f"or an expression of parameters ({', '.join(self.parameters) or 'none declared'})")
            return None
        if kind is Kind.DIMENSIONLESS:
            if any(isinstance(n, _expr.Num) and n.unit is not None for n in _expr.walk(node)):
                self.problems.add(key, f"{_short(value)}: a plain number here, without a unit")
                return None
        else:
            self.check_literals(node, _ANGLE if kind is Kind.ANGLE else _LENGTH, key, _short(value))
        v = self.value(node, kind)
        if v is None:
            self.problems.add(key, f"{_short(value)} cannot be evaluated to a finite number")
            return None
        if positive and (v < 0 or (v == 0 and not allow_zero)):
            self.problems.add(key, f"{_short(value)} = {v:g} must be positive")
            return None
        return node

    def value(self, node: _expr.Node, kind: Kind = Kind.DIMENSIONLESS) -> float | None:
        """The value of a parsed expression of parameters in internal units (radians, model length)."""
        env = {}
        for name, p in self.parameters.items():
            env[name] = p.value / self.angle_factor if p.kind is Kind.ANGLE else p.value
        try:
            v = _expr.evaluate(_lengths_converted(node, self.length_unit), env,
                               angle_unit_factor=self.angle_factor)
        except Exception:  # ExpressionError, a unit of another kind: reported by check_literals
            return None
        return v * self.angle_factor if kind is Kind.ANGLE else v

    def angle(self, value: Any, key: str) -> float | None:
        """A plain angle (number in the model's unit or with a unit) in radians."""
        try:
            return parse_quantity(value, Kind.ANGLE, angle_unit=self.angle_unit, length_unit=self.length_unit)
        except (UnitError, ValueError, TypeError, Exception) as exc:  # noqa: B014 - every refusal is a problem
            self.problems.add(key, str(exc))
            return None


def evaluator(mech) -> Callable:
    """``values(node, kind)``: a parsed expression of ``mech``'s parameters in internal units (radians for
    ``Kind.ANGLE``, else as written in the model's units: lengths in its length unit)."""
    k = math.pi / 180.0 if mech.units.angle == "deg" else 1.0
    env = {p.name: (p.value / k if p.kind is Kind.ANGLE else p.value) for p in mech.parameters}
    length_unit = mech.units.length

    def values(node, kind=Kind.DIMENSIONLESS):
        v = _expr.evaluate(_lengths_converted(node, length_unit), env, angle_unit_factor=k)
        return v * k if kind is Kind.ANGLE else v

    return values


def _lengths_converted(node: _expr.Node, length_unit: str) -> _expr.Node:
    """``node`` with every length literal (``25mm``) converted to a plain number in the model's unit."""
    if isinstance(node, _expr.Num):
        if node.unit is None:
            return node
        try:
            kind = unit_kind(node.unit)
        except UnitError:
            return node
        if kind is Kind.LENGTH:
            return _expr.Num(parse_quantity(f"{node.value}{node.unit}", Kind.LENGTH, angle_unit="rad",
                                            length_unit=length_unit))
        return node
    if isinstance(node, _expr.Unary):
        return _expr.Unary(node.op, _lengths_converted(node.operand, length_unit))
    if isinstance(node, _expr.Binary):
        return _expr.Binary(node.op, _lengths_converted(node.left, length_unit),
                            _lengths_converted(node.right, length_unit))
    if isinstance(node, _expr.Call):
        return _expr.Call(node.func, tuple(_lengths_converted(a, length_unit) for a in node.args))
    return node


def _short(value: Any, limit: int = 60) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _a(noun: str) -> str:
    return ("an " if noun[:1] in "aeiou" else "a ") + noun


# ------------------------------------------------------------------------- kinds of variables
def infer_kinds(spec: Mapping[str, Any], seen: dict) -> None:
    """Add to ``seen`` (name → set of ``(context, key)``) the kinds the higher pairs give names.

    Runs before the variables are parsed, on the raw tables (malformed entries are skipped here
    and reported by :func:`parse_pairs`).
    """
    for module in _element_modules()[1:]:
        for name, ctx, key in module.kind_hints(spec):
            if isinstance(name, str) and name not in ("frame", "ground"):
                seen.setdefault(name, set()).add((ctx, key))
    from .constraints import kind_hints as constraint_hints

    constraint_hints(spec, seen)


def pair_variables(spec: Mapping[str, Any]) -> dict[str, str]:
    """Every name the higher pairs of a raw spec use as a variable or parameter → the first key using it."""
    out: dict[str, str] = {}
    for module in _element_modules():
        for name, key in module.names_used(spec):
            if isinstance(name, str):
                out.setdefault(name, key)
    return out


def declared_row_keys(spec: Mapping[str, Any]) -> list[str]:
    """``section.name`` of every entry of the raw spec that adds an equation (counted as declared)."""
    out = []
    for section in ROW_SECTIONS:
        table = spec.get(section)
        if isinstance(table, Mapping):
            out += [f"{section}.{name}" for name in table]
    return out


def slot_vectors(spec: Mapping[str, Any], points: Mapping[str, Any]) -> set[str]:
    """The vectors the slots of a raw spec put in Φ: those of their pins, lines and centres."""
    out = set()
    table = spec.get("slots")
    if not isinstance(table, Mapping):
        return out
    for d in table.values():
        if not isinstance(d, Mapping):
            continue
        names = [d.get("point"), d.get("through")]
        if isinstance(d.get("arc"), Mapping):
            names.append(d["arc"].get("center"))
        for n in names:
            if isinstance(n, str) and n in points:
                out |= {v for _, v in points[n].terms}
        if isinstance(d.get("line"), str):
            out.add(d["line"])
    return out


def declared_rows(spec: Mapping[str, Any]) -> int:
    """How many equations the higher pairs of a raw spec add to Φ (one per entry)."""
    return len(declared_row_keys(spec))


def declared_links(spec: Mapping[str, Any], dynamics) -> frozenset:
    """The link names a model declares: its bodies, its vectors' ``link`` keys, a diagram's links."""
    out = set()
    if dynamics is not None:
        out |= {b.name for b in dynamics.bodies}
    vecs = spec.get("vectors")
    if isinstance(vecs, Mapping):
        out |= {v["link"] for v in vecs.values() if isinstance(v, Mapping) and isinstance(v.get("link"), str)}
    links = spec.get("links")
    if isinstance(links, Mapping):
        out |= {str(k) for k in links if k not in ("ground", "frame")}
    return frozenset(out)


def _element_modules() -> tuple:
    """The modules of the elements that add equations (constraints first)."""
    from . import cams, constraints, contacts, gears

    return (constraints, gears, cams, contacts)


# ------------------------------------------------------------------------- the door
def parse_pairs(ctx: PairContext) -> HigherPairs | None:
    """Parse every higher-pair section of ``ctx.spec`` (``None`` when the model has none)."""
    if not any(s in ctx.spec for s in SECTIONS):
        return None
    from . import cams, constraints, contacts, friction, gears

    pairs = HigherPairs(constraints=constraints.parse(ctx), gears=gears.parse(ctx), cams=cams.parse(ctx),
                        slots=contacts.parse_slots(ctx), rolling=contacts.parse_rolling(ctx))
    return HigherPairs(pairs.constraints, pairs.gears, pairs.cams, pairs.slots, pairs.rolling,
                       friction.parse(ctx, pairs))
