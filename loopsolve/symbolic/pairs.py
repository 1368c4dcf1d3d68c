"""The equations of the higher pairs in sympy: one row of Φ for each constraint, gear pair, cam, slot
and rolling contact (:mod:`loopsolve.model.pairs`).

:func:`pair_rows` is called by :func:`loopsolve.symbolic.loop_equations.derive` after the loops' rows,
so the higher pairs are differentiated (Φ_q, b₁–b₃), compiled and solved with the loops: one Φ,
one Jacobian, one tracker. The rows are:

* a constraint ``lhs = rhs``: ``lhs − rhs`` (model units, as written);
* a gear pair: ``(θ_m − θ_c) + s·ρ·(θ_g − θ_c) − phase`` in radians (``ρ`` the ratio
  N_g/N_m or r_g/r_m, ``s`` = +1 external, −1 internal); a rack ``x − R·(θ_g − θ_c) − phase``
  (model length unit);
* a cam: ``s − S(θ)`` (translating; model length unit) or ``ψ − ψ₀ − σ·Ψ(θ)`` (oscillating;
  radians), ``S``/``Ψ`` the law, periodic in the cam angle;
* a pin in a slot: the distance of the point from the slot's line (or arc), model length unit;
* rolling: the difference of the arc lengths rolled on the two bodies, model length unit.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from fractions import Fraction

import sympy as sp

__all__ = ["PairSymbols", "pair_rows", "TurnAngle", "cam_law", "gear_row", "gear_ratio"]


@dataclass(frozen=True)
class PairSymbols:
    """What the rows are built from: ``conv`` turns a model expression (model units) into sympy,
    ``var`` maps a variable name to its symbol (internal units: radians, model length), ``k`` is the
    model's angle unit in radians, ``vector_xy``/``vector_polar`` the loops' vectors, ``point`` the
    position of a declared point."""

    conv: Callable
    var: Mapping[str, sp.Symbol]
    k: sp.Expr
    vector_xy: Mapping[str, sp.Matrix]
    vector_polar: Mapping[str, tuple]
    point: Callable
    mech: object


def pair_rows(ps: PairSymbols) -> list[tuple[str, sp.Expr]]:
    """``[(row name, expression), ...]`` of every higher pair of ``ps.mech``, in row order."""
    pairs = ps.mech.pairs
    if pairs is None:
        return []
    rows = []
    for c in pairs.constraints:
        e = ps.conv(c.lhs) - ps.conv(c.rhs)
        if _angle_valued(ps.mech, (c.lhs, c.rhs)):
            e = sp.expand(e * ps.k)  # in radians, as the textbooks write r5 θ5 = r2 θ2
        rows.append((c.key, e))
    for g in pairs.gears:
        rows.append((g.key, gear_row(ps, g)))
    for c in pairs.cams:
        rows.append((c.key, ps.var[c.follower] - cam_law(ps, c)))
    for sl in pairs.slots:
        rows.append((sl.key, slot_row(ps, sl)))
    for r in pairs.rolling:
        rows.append((r.key, rolling_row(ps, r)))
    return rows


def slot_row(ps: PairSymbols, sl) -> sp.Expr:
    """The pin's distance from the slot's line (signed, model length unit) or from its arc."""
    P = ps.point(sl.point)
    if sl.line is not None:
        A = (ps.point(sl.through) if sl.through
             else sum((sign * ps.vector_xy[v] for sign, v in sl.tail), sp.zeros(2, 1)))
        length, angle = ps.vector_polar[sl.line]
        if angle is None:
            xy = ps.vector_xy[sl.line]
            e = xy / sp.sqrt(xy[0] ** 2 + xy[1] ** 2)
        else:
            e = sp.Matrix([sp.cos(angle), sp.sin(angle)])
        d = P - A
        return d[0] * e[1] - d[1] * e[0]
    C = ps.point(sl.center)
    R = ps.conv(sl.radius)
    d = P - C
    return (d[0] ** 2 + d[1] ** 2 - R**2) / (2 * R)


def rolling_row(ps: PairSymbols, r) -> sp.Expr:
    """Equal arc lengths rolled on the two bodies (model length unit)."""
    def ang(name, ref):
        if not name:
            return sp.Integer(0)
        return ps.var[name] - (sp.Float(ref) if r.phase is None else 0)

    rad = ps.conv(r.radius)
    ref = r.ref if r.phase is None else (0.0, 0.0, 0.0)
    phase = ps.conv(r.phase) if r.phase is not None else 0
    tw = ang(r.angle, ref[0])
    if not r.circle:  # x − x₀ = −sign · r (θ − θ₀)
        return ang(r.on, ref[1]) + r.sign * rad * tw - phase
    tb, tp = ang(r.on, ref[1]), ang(r.arm, ref[2])
    return rad * (tw - tp) - r.sign * ps.conv(r.base) * (tp - tb) - phase

class TurnAngle(sp.Function):
    """An angle reduced to one turn, [0, 2π): the argument of a cam law. Its derivative is 1 (the
    reduction jumps only by whole turns), so the law differentiates as a function of the cam angle."""

    nargs = 1

    def fdiff(self, argindex=1):
        return sp.Integer(1)

    def _pythoncode(self, printer):
        return "((%s) %% (2*math.pi))" % printer._print(self.args[0])

    def _numpycode(self, printer):
        return "numpy.mod(%s, 2*numpy.pi)" % printer._print(self.args[0])

    def _latex(self, printer, exp=None):
        tex = r"\left(%s\right)_{\bmod 2\pi}" % printer._print(self.args[0])
        return tex if exp is None else r"%s^{%s}" % (tex, exp)


class _SympyOps:
    sin = staticmethod(sp.sin)
    cos = staticmethod(sp.cos)
    pi = sp.pi


def cam_law(ps: PairSymbols, c) -> sp.Expr:
    """The cam's law as a function of its angle: a Piecewise over the segments of one turn (the follower's
    displacement: model length unit, or radians for an oscillating follower)."""
    from ..model.camlaws import pieces

    if c.profile is not None:
        return profile_function(c.profile, c.name)(TurnAngle(ps.var[c.cam]))
    to_rad = lambda node: ps.conv(node) * ps.k  # noqa: E731  (angles of the model file in radians)
    lift = (lambda node: ps.conv(node)) if c.kind == "translating" else to_rad
    start = to_rad(c.start) if c.start is not None else sp.Integer(0)
    w = TurnAngle(ps.var[c.cam] - start) + start
    branches = []
    lo, level = start, sp.Integer(0)
    for seg in c.segments:
        end = to_rad(seg.end)
        if seg.rise is None:
            value = level
            h = 0
        else:
            h = seg.sign * lift(seg.rise)
            u = (w - lo) / (end - lo)
            parts = pieces(seg.curve, u, _SympyOps)
            S = parts[0][1][0] if len(parts) == 1 else sp.Piecewise(
                *[(vals[0], u < bound) for bound, vals in parts[:-1]], (parts[-1][1][0], True))
            value = level + h * S
        branches.append((value, w < end))
        lo, level = end, level + h
    branches[-1] = (branches[-1][0], True)
    return sp.Piecewise(*branches)


class _ProfileFunction(sp.Function):
    """The displacement of a cam declared by its pitch curve (or a derivative of it), a function of the cam
    angle reduced to one turn: a periodic piecewise quintic (:class:`~loopsolve.model.campitch.ProfileLaw`).
    Printed to code as a binary tree of comparisons over its pieces (plain ``math``, ``numpy.where``)."""

    nargs = 1
    table = None
    order = 0
    label = ""

    def fdiff(self, argindex=1):
        if self.order >= 5:  # quintic pieces
            return sp.Integer(0)
        return profile_function(self.table, self.label, self.order + 1)(self.args[0])

    def _code(self, printer, vectorized):
        w = "(%s)" % printer._print(self.args[0])
        c = self.table.derivative_coeffs(self.order)
        x = self.table.breaks

        def leaf(i):
            u = "(%s - %r)" % (w, x[i])
            out = repr(float(c[i, -1]))
            for a in c[i, -2::-1]:
                out = "(%s*%s + %r)" % (out, u, float(a))
            return out

        def tree(lo, hi):
            if hi - lo == 1:
                return leaf(lo)
            mid = (lo + hi) // 2
            if vectorized:
                return "numpy.where(%s < %r, %s, %s)" % (w, x[mid], tree(lo, mid), tree(mid, hi))
            return "(%s if %s < %r else %s)" % (tree(lo, mid), w, x[mid], tree(mid, hi))

        return tree(0, len(x) - 1)

    def _pythoncode(self, printer):
        return self._code(printer, False)

    def _numpycode(self, printer):
        return self._code(printer, True)

    def _latex(self, printer, exp=None):
        d = "" if self.order == 0 else "^{(%d)}" % self.order
        tex = r"s_{\mathrm{%s}}%s\left(%s\right)" % (self.label.replace("_", r"\_"), d,
                                                      printer._print(self.args[0]))
        return tex if exp is None else r"\left(%s\right)^{%s}" % (tex, exp)


_PROFILE_FUNCTIONS: dict = {}


def profile_function(table, label: str, order: int = 0):
    """The sympy function of a profile cam's displacement (``order``: its derivative in the cam angle)."""
    key = (table.digest, label, order)
    fn = _PROFILE_FUNCTIONS.get(key)
    if fn is None:
        fn = type(f"camprofile_{label}_{table.digest}_{order}", (_ProfileFunction,),
                  {"table": table, "order": order, "label": label})
        _PROFILE_FUNCTIONS[key] = fn
    return fn


def gear_ratio(ps: PairSymbols, g) -> sp.Expr:
    """N_gear/N_mate (or r_gear/r_mate) of a gear pair; the pinion's pitch radius of a rack."""
    if g.rack:
        if g.radii is not None:
            return ps.conv(g.radii[0])
        return ps.conv(g.module) * ps.conv(g.teeth[0]) / 2
    if g.teeth is not None:
        return ps.conv(g.teeth[0]) / ps.conv(g.teeth[1])
    return ps.conv(g.radii[0]) / ps.conv(g.radii[1])


def gear_row(ps: PairSymbols, g) -> sp.Expr:
    """Willis' formula of a gear pair as a residual: radians (model length for a rack)."""
    def ang(name, ref=None):
        if not name:
            return sp.Integer(0)
        return ps.var[name] if ref is None else ps.var[name] - _angle_constant(ref)

    rho = gear_ratio(ps, g)
    if g.phase is None:  # the guesses mesh: each angle measured from its guess
        rg, rm, rc = g.ref
        tg, tm, tc = ang(g.gear, rg if g.gear else None), ang(g.mate, rm if g.mate else None), \
            ang(g.carrier, rc if g.carrier else None)
        phase = 0
    else:
        tg, tm, tc = ang(g.gear), ang(g.mate), ang(g.carrier)
        phase = ps.conv(g.phase) * (1 if g.rack else ps.k)
    if g.rack:
        return tm - rho * (tg - tc) - phase
    s = -1 if g.internal else 1
    return (tm - tc) + s * rho * (tg - tc) - phase


def _angle_constant(value: float) -> sp.Expr:
    """An angle in radians as the derivation prints it: a multiple of π when it is one (a guess of 90°
    is π/2, not 1.5707963267949), else the float."""
    frac = Fraction(value / math.pi).limit_denominator(3600)
    if abs(float(frac) * math.pi - value) <= 1e-12 * max(1.0, abs(value)):
        return sp.Rational(frac.numerator, frac.denominator) * sp.pi
    return sp.Float(value)


def _angle_valued(mech, nodes) -> bool:
    """Whether every variable of a constraint outside sin/cos/tan is an angle (the equation is then
    written in radians, whatever the model's angle unit)."""
    from ..model import expr as _expr
    from ..model.units import Kind

    kinds = {v.name: v.kind for v in mech.variables}
    found = []

    def go(n, in_trig=False):
        if isinstance(n, _expr.Name) and n.id in kinds and not in_trig:
            found.append(kinds[n.id])
        elif isinstance(n, _expr.Unary):
            go(n.operand, in_trig)
        elif isinstance(n, _expr.Binary):
            go(n.left, in_trig)
            go(n.right, in_trig)
        elif isinstance(n, _expr.Call):
            for a in n.args:
                go(a, in_trig or n.func in ("sin", "cos", "tan"))

    for node in nodes:
        go(node)
    return bool(found) and all(k is Kind.ANGLE for k in found)
