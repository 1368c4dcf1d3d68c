"""Checks of parsed expressions before the symbolic derivation sees them.

Every model expression is a small tree (:mod:`loopsolve.model.expr`); before sympy differentiates it
three times and expands the result, these checks refuse what would hang the derivation, what
cannot be compiled, or what would be read in the wrong unit:

* :func:`constant_size` -- constant subexpressions: division by zero, ``sqrt(-1)``, ``acos(2)``,
  overflow, constant exponents beyond :data:`MAX_EXPONENT`;
* :func:`degree_bound` -- nested powers multiply (``((t**64)**64)**64``), bounded by :data:`MAX_DEGREE`;
* :func:`nesting_depth` -- functions nested deeper than :data:`MAX_CALL_NESTING` (``sin(sin(...))``);
* :func:`check_terms` -- the number of terms of the expanded expression and its first three time
  derivatives (Leibniz, Faà di Bruno, multinomial counts), bounded by :data:`MAX_TERMS`;
* :func:`check_literals` -- a number with a unit must be of the kind its place expects
  (``angle = "30 m"`` is not 30000 degrees), and plain numbers stay within
  :data:`~loopsolve.model.units.MAX_MAGNITUDE`.

The model builder (:mod:`loopsolve.model.mechanism`) calls them and collects their problems by key.
"""

from __future__ import annotations

import math

from . import expr as _expr
from .units import MAX_MAGNITUDE, Kind, UnitError, parse_quantity, unit_kind

__all__ = ["MAX_EXPONENT", "MAX_DEGREE", "MAX_CALL_NESTING", "MAX_TERMS"]

#: expression contexts (which kind a place expects)
_ANGLE, _LENGTH, _ANY = "angle", "length", "any"
_EXPONENT = "exponent"


#: largest |exponent| accepted when the exponent is a constant (x**2, sqrt via **0.5, ...)
MAX_EXPONENT = 64
#: largest polynomial degree of an expression in its names (nested powers multiply:
#: ``(x**8)**8`` has degree 64); the derivation differentiates three times and expands
MAX_DEGREE = 256

_LIMITS = (f"constants must stay finite and real, and constant exponents within ±{MAX_EXPONENT} "
           "(the symbolic derivation would otherwise try to expand them)")


class ExpressionTooLarge(Exception):
    """An expression the derivation could not handle (too large a constant, degree, nesting or expansion)."""


def _call_value(func: str, args: list[float]) -> float:
    """Value of an allowed function at constant arguments (radians); ValueError outside its domain."""
    fn = {"sin": math.sin, "cos": math.cos, "tan": math.tan, "asin": math.asin, "acos": math.acos,
          "atan": math.atan, "atan2": math.atan2, "sqrt": math.sqrt, "abs": abs}[func]
    if func == "atan2" and args[0] == 0 and args[1] == 0:
        raise ValueError("atan2(0, 0) is undefined")
    return float(fn(*args))


def constant_size(node) -> float | None:
    """Float value of a name-free subtree (``None`` if it has names).

    Raises :class:`ExpressionTooLarge` for a constant exponent beyond ``MAX_EXPONENT``, a constant that
    overflows, a division by zero or a function outside its domain (``sqrt(-1)``, ``acos(2)``):
    sympy evaluates integer powers such as ``10**10**10`` exactly (and expands
    ``(a + b)**1000000``), which would hang the derivation, and a complex or infinite constant
    cannot be compiled. Literals with units count by their number (their kind is checked by
    :func:`check_literals`); function values are computed in radians, a sufficient test of
    the domain of the inverse functions and sqrt.
    """
    if isinstance(node, _expr.Num):
        return float(node.value)
    if isinstance(node, _expr.Const):
        return math.pi
    if isinstance(node, _expr.Unary):
        v = constant_size(node.operand)
        return None if v is None else (-v if node.op == "-" else v)
    if isinstance(node, _expr.Call):
        vals = [constant_size(a) for a in node.args]
        if any(v is None for v in vals):
            return None
        try:
            v = _call_value(node.func, vals)
        except (ValueError, OverflowError):
            raise ExpressionTooLarge(f"{_expr.to_text(node)} is not a real number (math domain error)") from None
        if not math.isfinite(v):
            raise ExpressionTooLarge(f"the constant {_expr.to_text(node)} overflows")
        return v
    if isinstance(node, _expr.Binary):
        a, b = constant_size(node.left), constant_size(node.right)
        if node.op == "**" and b is not None and abs(b) > MAX_EXPONENT:
            raise ExpressionTooLarge(f"exponent {b:g} is too large: {_LIMITS}")
        if node.op == "/" and b == 0:
            raise ExpressionTooLarge(f"division by zero in {_expr.to_text(node)}")
        if a is None or b is None:
            return None
        try:
            v = {"+": lambda: a + b, "-": lambda: a - b, "*": lambda: a * b,
                 "/": lambda: a / b, "**": lambda: math.pow(a, b)}[node.op]()
        except ZeroDivisionError:
            raise ExpressionTooLarge(f"{_expr.to_text(node)} divides by zero") from None
        except OverflowError:
            raise ExpressionTooLarge(f"the constant {_expr.to_text(node)} overflows: {_LIMITS}") from None
        except ValueError:
            raise ExpressionTooLarge(f"the constant {_expr.to_text(node)} is not a real number") from None
        if math.isinf(v):
            raise ExpressionTooLarge(f"the constant {_expr.to_text(node)} overflows: {_LIMITS}")
        return None if math.isnan(v) else v
    return None


def degree_bound(node) -> float:
    """Bound on the polynomial degree of an expression in its names (0 for a constant).

    Nested constant powers multiply (``((t**64)**64)**64`` has degree 262144, which sympy
    would collect into one power and whose derivatives overflow every float): refused past
    :data:`MAX_DEGREE`.
    """
    if isinstance(node, (_expr.Num, _expr.Const)):
        return 0
    if isinstance(node, _expr.Name):
        return 1
    if isinstance(node, _expr.Unary):
        return degree_bound(node.operand)
    if isinstance(node, _expr.Call):
        return 1 if any(degree_bound(a) for a in node.args) else 0
    if isinstance(node, _expr.Binary):
        a, b = degree_bound(node.left), degree_bound(node.right)
        if node.op in "+-":
            d = max(a, b)
        elif node.op in "*/":
            d = a + b
        else:
            e = constant_size(node.right)
            d = a * abs(e) if e is not None else a + b
        if d > MAX_DEGREE:
            raise ExpressionTooLarge(f"{_expr.to_text(node)[:60]} has degree {d:g} in its names (limit {MAX_DEGREE}); "
                            "the derivation differentiates it three times: write a simpler expression")
        return d
    return 0


#: deepest nesting of function calls (and powers with a variable exponent) on one path of an
#: expression: the third time derivative of ``sin(sin(...(t)))`` nested n deep has ~n³ terms
MAX_CALL_NESTING = 10


def nesting_depth(node) -> int:
    """Deepest nesting of calls and variable powers; refused past :data:`MAX_CALL_NESTING`."""
    best = 0
    stack = [(node, 0)]
    while stack:
        n, d = stack.pop()
        if isinstance(n, _expr.Call) or (isinstance(n, _expr.Binary) and n.op == "**"
                                         and constant_size(n.right) is None):
            d += 1
            if d > MAX_CALL_NESTING:
                raise ExpressionTooLarge(f"functions are nested more than {MAX_CALL_NESTING} deep (the derivation "
                                "differentiates three times and the terms grow with the cube of the "
                                "nesting): write a simpler expression")
        best = max(best, d)
        stack.extend((c, d) for c in _expr._children(n))
    return best


#: most terms an expression may have, expanded, in itself or in any of its first three time
#: derivatives (the derivation expands them): ``(a + b + c + d)**40`` or a product of a hundred
#: factors would take sympy minutes
MAX_TERMS = 2000
_CAP = 1e12


def _terms(node, vars_: frozenset | None) -> tuple[float, float, float, float]:
    """Upper bounds on the number of terms of an expression and of its 1st..3rd time derivatives.

    Counts after expansion: sums add, products follow Leibniz's rule, a function of ``u``
    follows Faà di Bruno's (``D³g(u)`` has the terms of ``(Du)³``, ``Du·D²u`` and ``D³u``),
    an integer power expands as a product. ``vars_`` are the names that move (``None``: all).
    """
    if isinstance(node, (_expr.Num, _expr.Const)):
        return (1.0, 0.0, 0.0, 0.0)
    if isinstance(node, _expr.Name):
        return (1.0, 1.0, 1.0, 1.0) if vars_ is None or node.id in vars_ else (1.0, 0.0, 0.0, 0.0)
    if isinstance(node, _expr.Unary):
        return _terms(node.operand, vars_)
    if isinstance(node, _expr.Binary):
        a = _terms(node.left, vars_)
        if node.op in "+-":
            b = _terms(node.right, vars_)
            return tuple(min(x + y, _CAP) for x, y in zip(a, b))
        if node.op == "**":
            e = constant_size(node.right)
            if e is not None and float(e).is_integer() and 1 <= abs(e) <= MAX_EXPONENT:
                return _power(a, int(abs(e)))
            b = _terms(node.right, vars_)
            return _chain(_leibniz(a, b))
        b = _terms(node.right, vars_)
        if node.op == "/":
            b = _chain(b)
        return _leibniz(a, b)
    if isinstance(node, _expr.Call):
        out = (1.0, 0.0, 0.0, 0.0)
        for arg in node.args:
            out = _leibniz(out, _terms(arg, vars_))
        return _chain(out)
    return (1.0, 0.0, 0.0, 0.0)


def _leibniz(a, b):
    c = (1, 1, 1, 1), (1, 2, 1), (1, 3, 3, 1)
    out = [a[0] * b[0]]
    for k in (1, 2, 3):
        out.append(sum(c[k - 1][j] * a[j] * b[k - j] for j in range(k + 1)))
    return tuple(min(x, _CAP) for x in out)


def _power(a, p: int):
    """Terms of u**p expanded (multinomial count) and of its derivatives (p·u^(p-1)·Du, ...)."""
    def m(q: int) -> float:  # monomials of degree q in a[0] terms
        return float(math.comb(int(min(a[0], 1e6)) + q - 1, q)) if q >= 0 else 0.0
    a1, a2, a3 = a[1], a[2], a[3]
    out = (m(p), m(p - 1) * a1, m(p - 2) * a1 * a1 + m(p - 1) * a2,
           m(p - 3) * a1 ** 3 + 3 * m(p - 2) * a1 * a2 + m(p - 1) * a3)
    return tuple(min(x, _CAP) for x in out)


def _chain(u):
    """Terms of g(u) and its derivatives (g' etc. count one term each)."""
    f1, f2, f3 = u[1], u[2], u[3]
    return (1.0, min(f1, _CAP), min(f1 * f1 + f2, _CAP), min(f1 ** 3 + 3 * f1 * f2 + f3, _CAP))


def check_terms(node, moving: frozenset | None = None) -> None:
    """Raise :class:`ExpressionTooLarge` when the time derivatives of ``node`` would expand too far."""
    worst = max(_terms(node, moving))
    if worst > MAX_TERMS:
        raise ExpressionTooLarge(f"the expression would expand to about {worst:.3g} terms in its time derivatives "
                        f"(limit {MAX_TERMS}; the derivation differentiates three times and expands): "
                        "write a simpler expression")


def check_literals(node, ctx: str, key: str, problems, angle_unit: str, length_unit: str,
                    text: str) -> None:
    """Every number with a unit must be of the kind its place expects.

    An ``angle``/``offset`` field and the argument of ``sin``/``cos``/``tan`` expect an angle; a
    ``length``, ``x`` or ``y`` field (outside trig functions) a length; an exponent a plain
    number. Elsewhere (``sqrt``, inverse trig, ``atan2``) a length or an angle is accepted.
    A unit of another kind is reported naming ``key``: ``angle = "30 m"`` would otherwise be
    read as 30000 (≡ 120°).
    """
    if isinstance(node, _expr.Num):
        if node.unit is None:
            if abs(node.value) > MAX_MAGNITUDE:
                problems.add(key, f"the number {node.value:.3g} in {text!r} is beyond ±{MAX_MAGNITUDE:g}: lengths "
                             "that large overflow the squares and products the solver forms (use a larger unit)")
            return
        literal = _expr.to_text(node)
        try:
            got = unit_kind(node.unit)
        except UnitError:
            got = None
        if ctx == _ANGLE:
            want = Kind.ANGLE
        elif ctx == _LENGTH:
            want = Kind.LENGTH
        elif ctx == _EXPONENT:
            problems.add(key, f"unit {node.unit!r} in an exponent in {text!r}: an exponent is a plain number")
            return
        elif got in (Kind.ANGLE, Kind.LENGTH):
            want = got
        else:
            problems.add(key, f"unit {node.unit!r} of {literal!r} in {text!r} is "
                         f"{'an unknown' if got is None else 'an ' + got.value if got.value[0] in 'aeiou' else 'a ' + got.value} "
                         "unit; only angle and length units may appear in an expression")
            return
        try:
            parse_quantity(literal, want, angle_unit=angle_unit, length_unit=length_unit)
        except UnitError as exc:
            same = text.replace(" ", "") == literal.replace(" ", "") or f"{literal!r}" == f"{text!r}"
            problems.add(key, str(exc) if same else f"{exc} (in {text!r})")
        return
    if isinstance(node, _expr.Unary):
        check_literals(node.operand, ctx, key, problems, angle_unit, length_unit, text)
    elif isinstance(node, _expr.Binary):
        check_literals(node.left, ctx, key, problems, angle_unit, length_unit, text)
        check_literals(node.right, _EXPONENT if node.op == "**" else ctx, key, problems, angle_unit,
                        length_unit, text)
    elif isinstance(node, _expr.Call):
        sub = {"sin": _ANGLE, "cos": _ANGLE, "tan": _ANGLE, "abs": ctx}.get(node.func, _ANY)
        for a in node.args:
            check_literals(a, sub, key, problems, angle_unit, length_unit, text)
