"""An expression as a linear combination of named vectors: the terms of a point or loop equation.

``linear_in_vectors`` splits an expression tree of :mod:`loopsolve.model.expr` into
``(vector name, scalar factor)`` pairs, refusing anything that is not a sum of vectors with
scalar factors (:class:`NotLinear`).
"""

from __future__ import annotations

from . import expr as _expr

__all__ = ["NotLinear", "linear_in_vectors"]


class NotLinear(Exception):
    """The expression is not a sum of vectors with scalar factors (the message says which term)."""


def _mul(a, b):
    if a is None:
        return b
    if b is None:
        return a
    return _expr.Binary("*", a, b)


def _neg(a):
    return _expr.Unary("-", _expr.Num(1.0) if a is None else a)


def linear_in_vectors(node, vecs: frozenset) -> list:
    """``[(vector, factor node or None), ...]`` for an expression linear in the vector names ``vecs``.

    Raises :class:`NotLinear` for a term without a vector, a product or quotient of vectors, or
    any other operation on one.

    Examples
    --------
    >>> from loopsolve.model import expr
    >>> [(v, None if f is None else expr.to_text(f))
    ...  for v, f in linear_in_vectors(expr.parse("r0 + r2 - rcx*u3"), frozenset({"r0", "r2", "u3"}))]
    [('r0', None), ('r2', None), ('u3', '-rcx')]
    """

    def has_vec(n) -> bool:
        return bool(_expr.names(n) & vecs)

    def go(n) -> list:
        if isinstance(n, _expr.Name) and n.id in vecs:
            return [(n.id, None)]
        if not has_vec(n):
            raise NotLinear(f"the term {_expr.to_text(n)!r} has no vector")
        if isinstance(n, _expr.Unary):
            inner = go(n.operand)
            return inner if n.op == "+" else [(v, _neg(f)) for v, f in inner]
        if isinstance(n, _expr.Binary):
            if n.op in ("+", "-"):
                right = go(n.right)
                if n.op == "-":
                    right = [(v, _neg(f)) for v, f in right]
                return go(n.left) + right
            if n.op == "*":
                lv, rv = has_vec(n.left), has_vec(n.right)
                if lv and rv:
                    raise NotLinear(f"{_expr.to_text(n)!r} multiplies two vectors")
                vec_side, scalar = (n.left, n.right) if lv else (n.right, n.left)
                return [(v, _mul(scalar, f) if f is not None else scalar) for v, f in go(vec_side)]
            if n.op == "/":
                if has_vec(n.right):
                    raise NotLinear(f"{_expr.to_text(n)!r} divides by a vector")
                inv = _expr.Binary("/", _expr.Num(1.0), n.right)
                return [(v, _mul(f, inv) if f is not None else inv) for v, f in go(n.left)]
        raise NotLinear(f"{_expr.to_text(n)!r} is not a sum of vectors with scalar factors")

    return go(node)
