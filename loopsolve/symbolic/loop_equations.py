"""Symbolic derivation with sympy: Φ, Φ_q and the velocity, acceleration and jerk right-hand sides.

For the chosen inputs x and unknowns q (together the joint variables z), each loop
``Σ ±r_k e(θ_k) = 0`` gives two scalar equations Φ(z) = 0. Differentiating in time with the
total-derivative operator D (``D f = Σ ∂f/∂z_i ż_i + ∂f/∂ż_i z̈_i + ...``) gives
``DᵏΦ = Φ_q q⁽ᵏ⁾ − b_k``, so the rate equations are ``Φ_q q⁽ᵏ⁾ = b_k`` with
``b_k = −DᵏΦ |_{q⁽ᵏ⁾ = 0}``. Parameters stay symbols; their values travel separately.

The products are public sympy objects (:class:`Kinematics`): the same expressions are compiled
for the solver (:mod:`loopsolve.symbolic.compiled`) and printed by :mod:`loopsolve.output.latex`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import sympy as sp

from ..model import expr as _expr
from ..errors import ModelError
from ..model.mechanism import Mechanism
from ..model.units import Kind, angle_factor, parse_quantity, unit_info, unit_kind

__all__ = ["Kinematics", "derive", "to_sympy"]

_TRIG = {"sin": sp.sin, "cos": sp.cos, "tan": sp.tan}
_INVERSE = {"asin": sp.asin, "acos": sp.acos, "atan": sp.atan}


@dataclass(frozen=True)
class Kinematics:
    """Everything derived for one choice of inputs.

    Users receive a derivation from :func:`loopsolve.derive` (``mech.derive()``); they need
    not construct one.

    Parameters
    ----------
    name, units, variables, kinds, inputs, unknowns, z, z1, z2, z3
        The mechanism's name, units and joint variables (see Attributes).
    params, param_names, param_values, param_kinds
        Its parameters.
    loop_names, loop_vectors, phi, jac, jac_inputs, rhs, points, vectors, vector_xy, equation_names
        The derived expressions.

    Attributes
    ----------
    variables, inputs, unknowns : tuple of str
        Names (declaration order; ``unknowns`` is the order of Φ_q's columns).
    z, z1, z2, z3 : tuple of sympy.Symbol
        Joint variables and their first three time derivatives (declaration order).
    params : tuple of sympy.Symbol
        Parameter symbols; ``param_values`` their values (internal units).
    phi : sympy.Matrix
        Loop-closure equations, two rows per loop (x then y), then one row per higher pair
        (constraint, gear pair, cam, slot, rolling contact; see :mod:`loopsolve.symbolic.pairs`).
    jac : sympy.Matrix
        Φ_q, the coefficient matrix (rows of ``phi`` × ``unknowns``).
    rhs : tuple of sympy.Matrix
        ``(b1, b2, b3)``: right-hand sides of Φ_q q̇ = b1, Φ_q q̈ = b2, Φ_q q⃛ = b3.
    points : dict
        name → tuple of 2×1 matrices: position, velocity, acceleration, jerk.
    vectors : dict
        name → (length, angle [rad]) expressions (angle ``None`` for Cartesian vectors).
    name : str
        The mechanism's name.
    units : Units
        The model's units (length, angle).
    kinds : tuple of Kind
        Angle or length, per variable.
    param_names, param_kinds : tuple
        The parameters' names and kinds (same order as ``params``).
    loop_names : tuple of str
        The loops' names; ``loop_vectors`` the vectors (2×1 matrices) each loop sums.
    jac_inputs : sympy.Matrix
        Φ_x, the derivative of ``phi`` with respect to the inputs.
    vector_xy : dict
        name → the vector's (x, y) components as a 2×1 matrix.
    equation_names : tuple of str
        One name per row of ``phi`` (``loop1_x``...).

    Examples
    --------
    >>> import loopsolve as ls
    >>> k = ls.derive(ls.load(ls.models_dir() / "thesis_crank_rocker.toml"))
    >>> k.unknowns, k.phi.shape
    (('theta3', 'theta4'), (2, 1))
    >>> k.jac
    Matrix([
    [-r3*sin(theta3),  r4*sin(theta4)],
    [ r3*cos(theta3), -r4*cos(theta4)]])
    """

    name: str
    units: object
    variables: tuple[str, ...]
    kinds: tuple[Kind, ...]
    inputs: tuple[str, ...]
    unknowns: tuple[str, ...]
    z: tuple[sp.Symbol, ...]
    z1: tuple[sp.Symbol, ...]
    z2: tuple[sp.Symbol, ...]
    z3: tuple[sp.Symbol, ...]
    params: tuple[sp.Symbol, ...]
    param_names: tuple[str, ...]
    param_values: tuple[float, ...]
    param_kinds: tuple[Kind, ...]
    loop_names: tuple[str, ...]
    loop_vectors: tuple[tuple[sp.Matrix, ...], ...]
    phi: sp.Matrix
    jac: sp.Matrix
    jac_inputs: sp.Matrix
    rhs: tuple[sp.Matrix, sp.Matrix, sp.Matrix]
    points: Mapping[str, tuple[sp.Matrix, sp.Matrix, sp.Matrix, sp.Matrix]]
    vectors: Mapping[str, tuple[sp.Expr, sp.Expr | None]]
    vector_xy: Mapping[str, sp.Matrix]
    #: the name of every row of Φ: ``<loop>.x``, ``<loop>.y``, then ``<section>.<name>`` of each higher pair
    equation_names: tuple[str, ...] = ()

    @property
    def unknown_symbols(self) -> tuple[sp.Symbol, ...]:
        return tuple(self.z[self.variables.index(n)] for n in self.unknowns)

    @property
    def input_symbols(self) -> tuple[sp.Symbol, ...]:
        return tuple(self.z[self.variables.index(n)] for n in self.inputs)

    def time_derivative(self, e):
        """Total time derivative D(e) along the motion (see module docstring)."""
        return _Deriv(self.z, self.z1, self.z2, self.z3).D(e)


def to_sympy(node: _expr.Node, symbols: Mapping[str, sp.Expr], *, k: sp.Expr, angle_names: frozenset,
             length_unit: str = "mm") -> sp.Expr:
    """Convert an expression tree, written in model units, to a sympy expression in model units.

    Angle symbols are internal radians, so in model units they appear as ``θ/k`` where ``k`` is
    the size of the model's angle unit in radians; trig functions take their argument in model
    units (``sin(k·a)``); inverse trig results are converted back (``asin(v)/k``).
    """

    def go(n):
        if isinstance(n, _expr.Num):
            if n.unit is None:
                return sp.nsimplify(n.value) if float(n.value).is_integer() else sp.Float(n.value)
            if unit_kind(n.unit) is Kind.ANGLE:
                return _angle_const(n, k)
            # a length literal such as 25mm: converted to the model's length unit
            return sp.Float(parse_quantity(f"{n.value}{n.unit}", Kind.LENGTH, angle_unit="rad",
                                           length_unit=length_unit))
        if isinstance(n, _expr.Const):
            return sp.pi
        if isinstance(n, _expr.Name):
            s = symbols[n.id]
            return s / k if n.id in angle_names else s
        if isinstance(n, _expr.Unary):
            v = go(n.operand)
            return -v if n.op == "-" else v
        if isinstance(n, _expr.Binary):
            a, b = go(n.left), go(n.right)
            return {"+": lambda: a + b, "-": lambda: a - b, "*": lambda: a * b,
                    "/": lambda: a / b, "**": lambda: a ** b}[n.op]()
        if isinstance(n, _expr.Call):
            args = [go(a) for a in n.args]
            if n.func in _TRIG:
                return _TRIG[n.func](k * args[0])
            if n.func in _INVERSE:
                return _INVERSE[n.func](args[0]) / k
            if n.func == "atan2":
                return sp.atan2(args[0], args[1]) / k
            if n.func == "sqrt":
                return sp.sqrt(args[0])
            if n.func == "abs":
                return sp.Abs(args[0])
        raise ModelError(f"cannot convert expression node {n!r}")

    return go(node)


def _angle_const(n: _expr.Num, k: sp.Expr) -> sp.Expr:
    """An angle literal with a unit (``30deg``, ``0.5rad``) expressed in model units (exactly)."""
    val = sp.nsimplify(n.value) if float(n.value).is_integer() else sp.Float(n.value)
    info = unit_info(n.unit)  # radians per unit, exactly: a rational times π^pi_power
    return val * sp.Rational(info.ratio.numerator, info.ratio.denominator) * sp.pi**info.pi_power / k


def derive(mech: Mechanism, input: str | Sequence[str] | None = None) -> Kinematics:
    """Derive Φ, Φ_q and the rate right-hand sides of ``mech`` for the given input(s).

    Parameters
    ----------
    mech : Mechanism
    input : str or sequence of str, optional
        The driven variable(s); default: the declared input.

    Returns
    -------
    Kinematics

    Examples
    --------
    >>> kin = ls.fourbar(r1=60, r2=25, r3=70, r4=45).derive()
    >>> kin.jac
    Matrix([
    [-r3*sin(theta3),  r4*sin(theta4)],
    [ r3*cos(theta3), -r4*cos(theta4)]])
    """
    inputs = mech.resolve_inputs(input)
    unknowns = tuple(v.name for v in mech.variables if v.name not in inputs)
    k = sp.pi / 180 if mech.units.angle == "deg" else sp.Integer(1)
    if abs(float(k) - angle_factor(mech.units.angle)) > 1e-15:
        raise ModelError(f"unsupported angle unit {mech.units.angle!r}")

    names = tuple(v.name for v in mech.variables)
    kinds = tuple(v.kind for v in mech.variables)
    z = tuple(sp.Symbol(n, real=True) for n in names)
    z1 = tuple(sp.Symbol(n + "__d1", real=True) for n in names)
    z2 = tuple(sp.Symbol(n + "__d2", real=True) for n in names)
    z3 = tuple(sp.Symbol(n + "__d3", real=True) for n in names)
    params = tuple(sp.Symbol(p.name, real=True) for p in mech.parameters)
    symbols = {p.name: s for p, s in zip(mech.parameters, params)}
    symbols.update(dict(zip(names, z)))
    angle_names = frozenset(
        [v.name for v in mech.variables if v.kind is Kind.ANGLE]
        + [p.name for p in mech.parameters if p.kind is Kind.ANGLE]
    )

    def conv(node):
        return to_sympy(node, symbols, k=k, angle_names=angle_names, length_unit=mech.units.length)

    where = mech.source or mech.name

    def field(v, name):
        """One vector field in sympy, refused when it is not a finite real expression."""
        e = conv(getattr(v, name))
        if _not_finite_real(e):
            raise ModelError(f"{where}: vectors.{v.name}.{name}: {_expr.to_text(getattr(v, name))!r} is not a "
                             f"finite real expression (it simplifies to {_short(e)}): check divisions by zero, "
                             "tan at 90 degrees and the domains of sqrt, asin and acos")
        return e

    vectors: dict[str, tuple] = {}
    vector_xy: dict[str, sp.Matrix] = {}
    for v in mech.vectors:
        if v.cartesian:
            x, y = field(v, "x"), field(v, "y")
            vectors[v.name] = (sp.sqrt(x**2 + y**2), None)
            vector_xy[v.name] = sp.Matrix([x, y])
        else:
            length = field(v, "length")
            ang_model = field(v, "angle") + (field(v, "offset") if v.offset is not None else 0)
            angle = sp.expand(k * ang_model)
            vectors[v.name] = (length, angle)
            vector_xy[v.name] = sp.Matrix([length * sp.cos(angle), length * sp.sin(angle)])

    rows = []
    loop_vectors = []
    for loop in mech.loops:
        total = sp.zeros(2, 1)
        for sign, vn in loop.terms:
            total += sign * vector_xy[vn]
        rows.extend([total[0], total[1]])
        loop_vectors.append(tuple(vector_xy[vn] for _, vn in loop.terms))
    if mech.pairs is not None:
        from .pairs import PairSymbols, pair_rows

        def point(name):
            p = next(pt for pt in mech.points if pt.name == name)
            pos = sp.zeros(2, 1)
            for i, (sign, vn) in enumerate(p.terms):
                f = p.factor(i)
                pos += sign * (conv(f) if f is not None else 1) * vector_xy[vn]
            return pos

        for name, e in pair_rows(PairSymbols(conv, dict(zip(names, z)), k, vector_xy, vectors, point, mech)):
            if _not_finite_real(e):
                raise ModelError(f"{where}: {name}: the equation is not a finite real expression (it simplifies to "
                                 f"{_short(e)}): check divisions by zero and the domains of sqrt, asin and acos")
            rows.append(e)
    phi = sp.Matrix(rows) if rows else sp.zeros(0, 1)

    kin_tmp = _Deriv(z, z1, z2, z3)
    q_idx = [names.index(n) for n in unknowns]
    x_idx = [names.index(n) for n in inputs]
    jac = phi.jacobian([z[i] for i in q_idx])
    jac_inputs = phi.jacobian([z[i] for i in x_idx])

    # b_k = -(D^k Φ with q^(k) = 0)
    d1 = phi.applyfunc(kin_tmp.D)
    d2 = d1.applyfunc(kin_tmp.D)
    _check_size(mech, d2, MAX_NODES // 2, "second")
    d3 = d2.applyfunc(kin_tmp.D)
    zero1 = {z1[i]: 0 for i in q_idx}
    zero2 = {z2[i]: 0 for i in q_idx}
    zero3 = {z3[i]: 0 for i in q_idx}
    b1 = (-d1.xreplace(zero1)).applyfunc(_tidy)
    b2 = (-d2.xreplace(zero2)).applyfunc(_tidy)
    b3 = (-d3.xreplace(zero3)).applyfunc(_tidy)

    _check_size(mech, b3, MAX_NODES, "third")

    points: dict[str, tuple] = {}
    for p in mech.points:
        pos = sp.zeros(2, 1)
        for i, (sign, vn) in enumerate(p.terms):
            f = p.factor(i)
            pos += sign * (conv(f) if f is not None else 1) * vector_xy[vn]
        vel = pos.applyfunc(kin_tmp.D)
        acc = vel.applyfunc(kin_tmp.D)
        jerk = acc.applyfunc(kin_tmp.D)
        points[p.name] = (pos, vel.applyfunc(_tidy), acc.applyfunc(_tidy), jerk.applyfunc(_tidy))

    _check_jacobian_structure(mech, jac, unknowns)
    _check_inputs_structure(mech, jac_inputs, inputs)
    if inputs == mech.inputs and mech.mode_aliases:
        _check_mode_aliases(mech, jac, unknowns)
    return Kinematics(
        name=mech.name,
        units=mech.units,
        variables=names,
        kinds=kinds,
        inputs=inputs,
        unknowns=unknowns,
        z=z,
        z1=z1,
        z2=z2,
        z3=z3,
        params=params,
        param_names=tuple(p.name for p in mech.parameters),
        param_values=tuple(p.value for p in mech.parameters),
        param_kinds=tuple(p.kind for p in mech.parameters),
        loop_names=tuple(lp.name for lp in mech.loops),
        loop_vectors=tuple(loop_vectors),
        phi=phi,
        jac=jac,
        jac_inputs=jac_inputs,
        rhs=(b1, b2, b3),
        points=points,
        vectors=vectors,
        vector_xy=vector_xy,
        equation_names=mech.equation_names,
    )


#: most operations one entry of the third time derivative of Φ may have; beyond it the
#: compilation (common subexpressions, code generation) would take minutes. The models in
#: ``models/`` stay below 300.
MAX_NODES = 8000


def _size_exceeds(e, limit: int) -> bool:
    for i, _ in enumerate(sp.preorder_traversal(e)):
        if i >= limit:
            return True
    return False


def _check_size(mech: Mechanism, m: sp.Matrix, limit: int, order: str) -> None:
    """Refuse a derivation whose entries grow past ``limit`` operations, naming the loop."""
    for i in range(m.rows):
        if _size_exceeds(m[i], limit) and i >= 2 * len(mech.loops):
            raise ModelError(
                f"{mech.source or mech.name}: {mech.equation_names[i]}: the {order} time derivative of its "
                f"equation has more than {limit} operations, too large to derive and compile in reasonable "
                "time; simplify its expressions")
        if _size_exceeds(m[i], limit):
            loop = mech.loops[i // 2]
            raise ModelError(
                f"{mech.source or mech.name}: loops[{i // 2}] ({loop.name}: {loop.text!r}): the {order} time "
                f"derivative of its closure equations has more than {limit} operations, too large to "
                "derive and compile in reasonable time; simplify the expressions of its vectors "
                f"({', '.join(sorted({n for _, n in loop.terms}))})")


def _not_finite_real(e) -> bool:
    """True for an expression holding an infinity, NaN, an imaginary unit or an interval."""
    if e.has(sp.zoo, sp.oo, -sp.oo, sp.nan, sp.I) or e.has(sp.AccumBounds):
        return True
    return bool(e.is_number and e.is_real is False)


def _short(e, limit: int = 60) -> str:
    text = str(e)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _tidy(e):
    """Light clean-up: group by the rates so the right-hand sides read like the textbook."""
    return sp.expand(e)


class _Deriv:
    def __init__(self, z, z1, z2, z3):
        self.pairs = list(zip(z, z1)) + list(zip(z1, z2)) + list(zip(z2, z3))

    def D(self, e):
        out = sp.Integer(0)
        free = e.free_symbols
        for s, ds in self.pairs:
            if s in free:
                out += sp.diff(e, s) * ds
        if out.has(sp.DiracDelta):  # d/dt of sign(x) (from abs(), or a Cartesian vector's length):
            out = out.replace(sp.DiracDelta, lambda *args: sp.Integer(0))  # 0 wherever it is defined
        return out


def _check_inputs_structure(mech: Mechanism, jac_inputs: sp.Matrix, inputs: tuple[str, ...]) -> None:
    """An input that appears in no loop equation drives nothing (every rate would be 0): say which."""
    for j, name in enumerate(inputs):
        if all(jac_inputs[i, j] == 0 for i in range(jac_inputs.rows)):
            raise ModelError(
                f"{mech.source or mech.name}: the input {name!r} does not appear in any loop equation, so it "
                "drives nothing (every rate would be 0); add a vector that depends on it to a loop or drive "
                "another variable")


def _check_mode_aliases(mech: Mechanism, jac: sp.Matrix, unknowns: tuple[str, ...]) -> None:
    """Every declared mode name must have one sign per diagonal block of Φ_q (the signature length)."""
    from ..model.topology import solve_order

    m, n = jac.shape
    try:
        blocks = solve_order([[jac[i, j] != 0 for j in range(n)] for i in range(m)], unknown_names=unknowns)
    except ModelError:
        return  # reported elsewhere (no perfect matching)
    bad = [f"modes.{a} = {sig!r}" for a, sig in mech.mode_aliases.items() if len(sig) != len(blocks)]
    if bad:
        raise ModelError(f"{mech.source or mech.name}: {'; '.join(bad)}: a mode signature of this model has "
                         f"{len(blocks)} sign(s), one per diagonal block of the Jacobian")


def _check_jacobian_structure(mech: Mechanism, jac: sp.Matrix, unknowns: tuple[str, ...]) -> None:
    """An unknown that appears in no equation can never be solved: say which."""
    for j, name in enumerate(unknowns):
        if all(jac[i, j] == 0 for i in range(jac.rows)):
            raise ModelError(
                f"{mech.source or mech.name}: variable {name!r} does not appear in any loop equation "
                "(no loop uses a vector that depends on it); add it to a loop or make it the input"
            )
