"""``[constraints]``: scalar equations of the variables and parameters, solved with the loops.

Each entry is one equation in the safe expression language (:mod:`loopsolve.model.expr`), written
``"lhs = rhs"`` or as one expression equal to zero::

    [constraints]
    belt = "r5*theta5 = r2*theta2"      # a crossed belt would be "r5*theta5 = -r2*theta2"
    couple = "theta6 - 2*theta2 = 30"

Names are variables and parameters; angles are in the model's angle unit, as everywhere in a model
file (``theta6 - 2*theta2 = 30`` reads degrees in a degree model). The equation becomes one row of Φ
(``lhs − rhs``), so it counts in the mobility, enters the Jacobian, the rates, the assembly modes, the
tracker and the LaTeX like the loops' rows.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from . import expr as _expr
from .units import Kind, UnitError, unit_kind

__all__ = ["Constraint", "parse", "kind_hints", "names_used", "split_equation"]


@dataclass(frozen=True, slots=True)
class Constraint:
    """One scalar equation ``lhs = rhs`` (parsed expressions in model units)."""

    name: str
    key: str
    text: str
    lhs: _expr.Node
    rhs: _expr.Node


def split_equation(text: str) -> tuple[str, str] | None:
    """``("lhs", "rhs")`` of ``"lhs = rhs"`` (``rhs`` ``"0"`` without ``=``); None for two ``=``."""
    parts = text.split("=")
    if len(parts) > 2:
        return None
    return parts[0], (parts[1] if len(parts) == 2 else "0")


def _table(spec) -> Mapping:
    val = spec.get("constraints", {})
    return val if isinstance(val, Mapping) else {}


def _safe_sides(text: Any) -> list:
    """The parsed sides of an equation text, or [] when it does not parse (reported later)."""
    if not isinstance(text, str):
        return []
    sides = split_equation(text)
    if sides is None:
        return []
    out = []
    for side in sides:
        try:
            out.append(_expr.parse(side.strip() or "0"))
        except Exception:  # reported by parse()
            return []
    return out


def names_used(spec) -> list[tuple[str, str]]:
    out = []
    for name, text in _table(spec).items():
        for node in _safe_sides(text):
            out += [(n, f"constraints.{name}") for n in sorted(_expr.names(node))]
    return out


def _additive_terms(node) -> list:
    """The top-level terms of a sum (signs dropped)."""
    if isinstance(node, _expr.Binary) and node.op in ("+", "-"):
        return _additive_terms(node.left) + _additive_terms(node.right)
    if isinstance(node, _expr.Unary):
        return _additive_terms(node.operand)
    return [node]


def _term_kind(term, variables) -> tuple[str | None, str | None]:
    """``(name, None)`` for a term that is one variable times parameters and plain numbers, ``(None, kind)``
    for a literal with an angle or length unit, else ``(None, None)``."""
    if isinstance(term, _expr.Unary):
        return _term_kind(term.operand, variables)
    if isinstance(term, _expr.Num):
        if term.unit is None:
            return None, None
        try:
            k = unit_kind(term.unit)
        except UnitError:
            return None, None
        return None, ("angle" if k is Kind.ANGLE else "length" if k is Kind.LENGTH else None)
    factors = []

    def product(n) -> bool:
        if isinstance(n, _expr.Binary) and n.op in ("*", "/"):
            return product(n.left) and (product(n.right) if n.op == "*" else not (_expr.names(n.right) & variables))
        if isinstance(n, _expr.Name):
            factors.append(n.id)
            return True
        return isinstance(n, _expr.Num) and n.unit is None
    if not product(term):
        return None, None
    var = [f for f in factors if f in variables]
    return (var[0], None) if len(var) == 1 else (None, None)


def kind_hints(spec, seen: dict) -> None:
    """Kinds of the variables in additive terms of a constraint next to a variable (or literal) of known
    kind (a term is one variable times parameters and numbers: ``r5*theta5 = r2*theta2``)."""
    declared = spec.get("variables", {})
    declared = declared if isinstance(declared, Mapping) else {}
    variables = set(declared)
    kinds = {n: d["kind"] for n, d in declared.items()
             if isinstance(d, Mapping) and d.get("kind") in ("angle", "length")}
    groups = []
    for name, text in _table(spec).items():
        terms = [t for node in _safe_sides(text) for t in _additive_terms(node)]
        groups.append((f"constraints.{name}", [_term_kind(t, variables) for t in terms]))

    def known_kind(n):
        return [kinds[n]] if n in kinds else [c for c, _ in seen.get(n, ())]

    changed = True
    while changed:
        changed = False
        for key, terms in groups:
            known = {c for n, lit in terms for c in ([lit] if lit else known_kind(n) if n else [])}
            if len(known) != 1:
                continue
            ctx = next(iter(known))
            for n, _ in terms:
                if n is not None and not known_kind(n):
                    seen.setdefault(n, set()).add((ctx, key))
                    changed = True


def parse(ctx) -> tuple[Constraint, ...]:
    """The ``[constraints]`` of ``ctx.spec`` (problems collected in ``ctx.problems``)."""
    out = []
    table = ctx.table("constraints")
    declared = ctx.spec.get("variables", {})
    names = set(ctx.parameters) | set(ctx.variables) | (set(declared) if isinstance(declared, Mapping) else set())
    for name, text in table.items():
        key = f"constraints.{name}"
        if not ctx.check_name(name, key):
            continue
        if not isinstance(text, str):
            ctx.problems.add(key, f"expected an equation such as \"theta5 - theta2 = 0\", got {text!r}")
            continue
        sides = split_equation(text)
        if sides is None:
            ctx.problems.add(key, f"more than one '=' in {text!r}")
            continue
        nodes = []
        for side in sides:
            node = ctx.parse_expr(side.strip() or "0", key)
            if node is None:
                break
            ctx.check_literals(node, "any", key, text)
            nodes.append(node)
        if len(nodes) != 2:
            continue
        used = _expr.names(nodes[0]) | _expr.names(nodes[1])
        bad = sorted(used - names)
        for n in bad:
            ctx.problems.add(key, f"{text!r} names {n!r}, which is neither a parameter nor a variable; declared: "
                             + ", ".join(list(ctx.parameters) + list(ctx.variables)))
        if bad:
            continue
        if not used & (names - set(ctx.parameters)):
            ctx.problems.add(key, f"{text!r} names no variable: a constraint ties variables "
                             "(an equation of parameters alone is not a constraint)")
            continue
        out.append(Constraint(str(name), key, text, nodes[0], nodes[1]))
    return tuple(out)
