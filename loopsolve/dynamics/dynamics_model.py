"""Dynamics of a one-degree-of-freedom mechanism: derivation (sympy) and compiled numeric model.

From the kinematic derivation (:func:`loopsolve.symbolic.loop_equations.derive`) and the mass properties and loads
(:mod:`loopsolve.model.bodies`), this module derives with sympy, once per mechanism, the position,
velocity and acceleration of every centre of mass and load point, every body's angle and its
rates, the guide directions and the load expressions, and compiles them into one vectorized numpy
function of ``(z, ż, z̈, p)``. sympy never runs when the function is evaluated.

With the kinematic coefficients ``z' = dz/dx`` and ``z'' = d²z/dx²`` (rates at unit input speed and
zero input acceleration), the same function gives ``dr_G/dx`` and ``d²r_G/dx²``, hence the
generalized inertia and the generalized force of the one-degree-of-freedom equation of motion

    M(x) ẍ + ½ M′(x) ẋ² = Q(x, ẋ, t) + T,
    M = Σ m |dr_G/dx|² + I (dθ/dx)²,   M′ = dM/dx,   Q = Σ (virtual work of the loads) / δx.

Internally x is the SI generalized coordinate: radians for an angle input, metres for a length
input (positions in the model's length unit are scaled by ``length_factor``).

References: Uicker, Pennock and Shigley, *Theory of Machines and Mechanisms*, ch. 13–16
(kinematic coefficients, the equation of motion of a single-degree-of-freedom machine).
"""

from __future__ import annotations

import re
import threading
from dataclasses import dataclass, field

import numpy as np
import sympy as sp

from ..model.bodies import FRAME, Body, Dynamics
from ..symbolic.compiled import CompiledKinematics, structure_key
from ..errors import ModelError
from ..model.mechanism import Mechanism
from ..symbolic.loop_equations import Kinematics, derive, to_sympy
from ..model.units import Kind, length_factor, parse_quantity

__all__ = ["DynamicsModel", "compile_dynamics", "kinematic_coefficients", "mass_matrix_terms", "mass_terms_from",
           "compile_drive"]

_LOCK = threading.Lock()
_MEMO: dict = {}


@dataclass(frozen=True, eq=False)
class DynamicsModel:
    """The compiled dynamics of one mechanism for one input (built by :func:`compile_dynamics`).

    ``evaluate(z, z1, z2)`` takes ``(nvar, N)`` arrays and returns a dict of arrays (model length
    units for positions, radians for angles): ``G`` ``(B, 2, N)`` and ``vG``, ``aG``; ``th``,
    ``om``, ``al`` ``(B, N)`` (zeros for bodies without an angle); ``P``, ``vP`` ``(K, 2, N)`` for
    the points in ``point_names`` (and ``aP``); ``phi`` ``(V, N)`` guide directions for ``guide_vectors``;
    ``load`` ``(L, N)`` the load values in ``load_slots`` order.
    """

    ck: CompiledKinematics
    dynamics: Dynamics
    bodies: tuple[Body, ...]
    point_names: tuple[str, ...]
    guide_vectors: tuple[str, ...]
    load_slots: tuple[tuple[int, int], ...]  # (load index, component)
    input_body: str
    input_kind: Kind
    input_guide: str | None
    length_factor: float
    gravity: np.ndarray
    loads_use_rates: bool
    _fn: object = field(repr=False)
    _fn_scalar: object = field(repr=False)

    @property
    def coord_factor(self) -> float:
        """SI units of the generalized coordinate per internal input unit (1 for radians)."""
        return 1.0 if self.input_kind is Kind.ANGLE else self.length_factor

    def evaluate(self, z, z1, z2) -> dict:
        z, z1, z2 = (np.asarray(a, dtype=float) for a in (z, z1, z2))
        if z.ndim == 1:  # one pose: the scalar (math) code, no array overhead
            try:
                flat = np.array(self._fn_scalar(z, z1, z2, self.ck.p), dtype=float)[:, None]
            except (ArithmeticError, ValueError):  # outside a load's domain: numpy gives NaN there
                with np.errstate(all="ignore"):
                    raw = self._fn(z[:, None], z1[:, None], z2[:, None], self.ck.p)
                flat = np.empty((len(raw), 1))
                for i, r in enumerate(raw):  # constants come back as scalars, the rest as (1,) arrays
                    flat[i] = r
            return self._split(flat, 1)
        n = z.shape[1]
        raw = self._fn(z, z1, z2, self.ck.p)
        flat = np.empty((len(raw), n))
        for i, r in enumerate(raw):
            flat[i] = r
        return self._split(flat, n)

    def _split(self, flat, n) -> dict:
        nb, nk, ng, nl = len(self.bodies), len(self.point_names), len(self.guide_vectors), len(self.load_slots)
        out, pos = {}, 0
        for name, size, shape in (("G", nb * 2, (nb, 2)), ("vG", nb * 2, (nb, 2)), ("aG", nb * 2, (nb, 2)),
                                  ("th", nb, (nb,)), ("om", nb, (nb,)), ("al", nb, (nb,)),
                                  ("P", nk * 2, (nk, 2)), ("vP", nk * 2, (nk, 2)), ("aP", nk * 2, (nk, 2)),
                                  ("phi", ng, (ng,)),
                                  ("load", nl, (nl,))):
            out[name] = flat[pos:pos + size].reshape(shape + (n,))
            pos += size
        return out


def metres_per_unit(mech: Mechanism) -> float:
    """Metres per length unit of ``mech`` (a model error when the unit is not a physical length)."""
    try:
        return length_factor(mech.units.length, "m")
    except ModelError:
        raise ModelError(f"{mech.source or mech.name}: units.length = {mech.units.length!r} is not a physical "
                         "length unit: force analysis needs mm, cm, m, in or ft") from None


def _sym_value(v, conv):
    return sp.Float(v) if isinstance(v, (int, float)) else conv(v)


def point_expr(kin: Kinematics, pt, conv) -> sp.Matrix:
    """The position ``(2, 1)`` of point ``pt`` in symbols of ``kin`` (factors converted by ``conv``)."""
    pos = sp.zeros(2, 1)
    for i, (sign, vn) in enumerate(pt.terms):
        f = pt.factor(i)
        pos += sign * (conv(f) if f is not None else 1) * kin.vector_xy[vn]
    return pos


def sympy_converter(mech: Mechanism, kin: Kinematics):
    """``(conv, k)``: model expressions to sympy in the symbols of ``kin``, and the angle factor ``k``."""
    k = sp.pi / 180 if mech.units.angle == "deg" else sp.Integer(1)
    symbols = dict(zip(kin.param_names, kin.params))
    symbols.update(dict(zip(kin.variables, kin.z)))
    symbols.update({n + "_vel": s for n, s in zip(kin.variables, kin.z1)})
    angle_names = frozenset([n for n, kd in zip(kin.variables, kin.kinds) if kd is Kind.ANGLE]
                            + [n for n, kd in zip(kin.param_names, kin.param_kinds) if kd is Kind.ANGLE])

    def conv(node):
        return to_sympy(node, symbols, k=k, angle_names=angle_names, length_unit=mech.units.length)

    return conv, k


def _resolve_input(mech: Mechanism, dyn: Dynamics, ck: CompiledKinematics) -> tuple[str, Kind, str | None]:
    """The body the driver acts on (and, for a length input, the guide it pushes along)."""
    if len(ck.inputs) != 1:
        raise ModelError(f"{mech.source or mech.name}: force analysis needs one input, not {len(ck.inputs)} "
                         f"({', '.join(ck.inputs)})")
    name = ck.inputs[0]
    kind = ck.kinds[ck.index(name)]
    if kind is Kind.ANGLE:
        for b in dyn.bodies:
            if b.angle_text == name:
                return b.name, kind, None
        raise ModelError(f"{mech.source or mech.name}: bodies: no body turns with the input {name!r}: the driving "
                         f"torque acts on the body whose angle is {name!r} (add angle = \"{name}\" to it)")
    for b in dyn.bodies:
        if b.guide is not None and b.guide_body == FRAME:
            v = mech.vector(b.guide)
            from ..model.expr import names as expr_names

            if v.length is not None and name in expr_names(v.length):
                return b.name, kind, b.guide
    raise ModelError(f"{mech.source or mech.name}: bodies: no body slides on the frame along a vector of length "
                     f"{name!r}: the driving force acts on that body (give it guide = \"<vector>\")")


def compile_dynamics(mech: Mechanism, input=None, *, compiled: CompiledKinematics | None = None) -> DynamicsModel:
    """Derive (sympy, once per structure in a process) and compile the dynamics of ``mech``.

    Raises :class:`ModelError` when the model declares no bodies or the input has no body.

    Examples
    --------
    >>> mech = ls.load(ls.models_dir() / "thesis_crank_rocker_dynamics.toml")
    >>> from loopsolve.dynamics.dynamics_model import compile_dynamics
    >>> dm = compile_dynamics(mech)
    >>> dm.input_body, [b.name for b in dm.bodies]
    ('crank', ['crank', 'coupler', 'rocker'])
    """
    dyn = mech.dynamics
    if dyn is None or not dyn.bodies:
        raise ModelError(f"{mech.source or mech.name}: no [bodies] declared: force analysis needs the mass, "
                         "inertia and centre of mass of every moving link (see the model-file contract)")
    ck = compiled if compiled is not None else mech.compile(input)
    inputs = tuple(ck.inputs)
    input_body, input_kind, input_guide = _resolve_input(mech, dyn, ck)
    points: list[str] = []
    for b in dyn.bodies:
        points += [j for j in b.joints if j not in points]
    for ld in dyn.loads:
        for p in ((ld.at,) if ld.at else ()) + tuple(ld.ends):
            if p not in points:
                points.append(p)
    for pt in mech.points:  # every other point too: the declaration checks look for joints left out
        if pt.name not in points:
            points.append(pt.name)
    guides = []
    for b in dyn.bodies:
        if b.guide is not None and b.guide not in guides:
            guides.append(b.guide)
    slots = []
    for i, ld in enumerate(dyn.loads):
        for c in range(len(ld.values)):
            slots.append((i, c))
    key = (structure_key(mech, inputs), repr((dyn.bodies, dyn.loads)), tuple(points), tuple(guides))
    with _LOCK:
        fns = _MEMO.get(key)
    if fns is None:
        fns = _derive_function(mech, inputs, dyn, points, guides, slots)
        with _LOCK:
            _MEMO[key] = fns
    return DynamicsModel(ck=ck, dynamics=dyn, bodies=dyn.bodies, point_names=tuple(points),
                         guide_vectors=tuple(guides), load_slots=tuple(slots), input_body=input_body,
                         input_kind=input_kind, input_guide=input_guide,
                         length_factor=metres_per_unit(mech), gravity=np.array(dyn.gravity, dtype=float),
                         loads_use_rates=fns[2], _fn=fns[0], _fn_scalar=fns[1])


def _derive_function(mech, inputs, dyn, points, guides, slots):
    kin = derive(mech, input=inputs)
    conv, k = sympy_converter(mech, kin)
    D = kin.time_derivative
    by_point = {p.name: p for p in mech.points}
    exprs: list = []
    G, vG, aG, th, om, al = [], [], [], [], [], []
    for b in dyn.bodies:
        g = point_expr(kin, b.com, conv)
        v = g.applyfunc(D)
        a = v.applyfunc(D)
        G += list(g)
        vG += list(v)
        aG += list(a)
        if b.angle is not None:
            t = sp.expand(k * conv(b.angle))
            w = D(t)
            th.append(t)
            om.append(w)
            al.append(D(w))
        else:
            th += [sp.Integer(0)]
            om += [sp.Integer(0)]
            al += [sp.Integer(0)]
    P, vP, aP = [], [], []
    for name in points:
        pe = point_expr(kin, by_point[name], conv)
        ve = pe.applyfunc(D)
        P += list(pe)
        vP += list(ve)
        aP += list(ve.applyfunc(D))
    phi = []
    for vn in guides:
        length, angle = kin.vectors[vn]
        if angle is None:
            xy = kin.vector_xy[vn]
            angle = sp.atan2(xy[1], xy[0])
        phi.append(angle)
    loads = [_sym_value(dyn.loads[i].values[c], conv) for i, c in slots]
    exprs = G + vG + aG + th + om + al + P + vP + aP + phi + loads
    args = [sp.Matrix(kin.z), sp.Matrix(kin.z1), sp.Matrix(kin.z2), sp.Matrix(kin.params) if kin.params else []]
    vector = sp.lambdify(args, exprs, modules="numpy", cse=True)
    scalar = sp.lambdify(args, exprs, modules="math", cse=True)
    rates = set(kin.z1)
    uses_rates = any(sp.sympify(e).free_symbols & rates for e in loads)
    return vector, scalar, uses_rates


def kinematic_coefficients(ck: CompiledKinematics, z) -> tuple[np.ndarray, np.ndarray]:
    """``(z', z'')``: first and second derivatives of every variable with respect to the input.

    ``z`` is ``(N, nvar)`` (internal units); returns two ``(N, nvar)`` arrays (the input's own
    entries are 1 and 0). Solves Φ_q q' = b₁ at unit input speed, then Φ_q q'' = b₂ at zero input
    acceleration, vectorized; NaN where Φ_q is singular.

    Examples
    --------
    >>> mech = ls.load(ls.models_dir() / "thesis_crank_rocker.toml")
    >>> ck = mech.compile()
    >>> s = mech.solve(90)
    >>> from loopsolve.dynamics.dynamics_model import kinematic_coefficients
    >>> d1, d2 = kinematic_coefficients(ck, s.z[None, :])
    >>> round(float(d1[0, ck.index("theta4")]), 4)
    0.5908
    """
    z = np.atleast_2d(np.asarray(z, dtype=float))
    n, nv = z.shape
    ix, iq = ck.input_idx[0], ck.unknown_idx
    d1 = np.zeros((n, nv))
    d1[:, ix] = 1.0
    d2 = np.zeros((n, nv))
    J = ck.jac_v(z.T)
    if J.shape[0] != n:
        J = np.broadcast_to(J, (n,) + J.shape[1:])
    ok = np.abs(np.linalg.det(J)) > 0
    Js = np.where(ok[:, None, None], J, np.eye(J.shape[1]))
    b1 = np.broadcast_to(ck.rhs_v(1, z.T, d1.T), (len(iq), n)).T
    d1[:, iq] = np.linalg.solve(Js, b1[..., None])[..., 0]
    b2 = np.broadcast_to(ck.rhs_v(2, z.T, d1.T, d2.T), (len(iq), n)).T
    d2[:, iq] = np.linalg.solve(Js, b2[..., None])[..., 0]
    d1[~ok] = np.nan
    d2[~ok] = np.nan
    return d1, d2


def mass_matrix_terms(dm: DynamicsModel, z, d1, d2) -> tuple[np.ndarray, np.ndarray]:
    """Generalized inertia M(x) and its derivative M′(x) (SI: kg·m² for an angle input, kg for a length).

    ``z``, ``d1``, ``d2`` are ``(N, nvar)``: positions and kinematic coefficients.
    """
    return mass_terms_from(dm, dm.evaluate(z.T, d1.T, d2.T))


def mass_terms_from(dm: DynamicsModel, e: dict) -> tuple[np.ndarray, np.ndarray]:
    """M and M′ from an evaluation ``e`` at the kinematic coefficients (see :func:`mass_matrix_terms`)."""
    lf, s = dm.length_factor, dm.coord_factor
    m = np.array([b.mass for b in dm.bodies])[:, None]
    inertia = np.array([b.inertia for b in dm.bodies])[:, None]
    vg, ag = e["vG"] * lf / s, e["aG"] * lf / s**2
    om, al = e["om"] / s, e["al"] / s**2
    M = np.sum(m * np.sum(vg**2, axis=1) + inertia * om**2, axis=0)
    dM = np.sum(2 * m * np.sum(vg * ag, axis=1) + 2 * inertia * om * al, axis=0)
    return M, dM


#: a number with a unit (not an expression): ``0.05N*m``, ``0.4 in*lbf``
_QUANTITY_RE = re.compile(r"\s*[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?\s*[A-Za-z°µμ][A-Za-z0-9*/^·²³ ]*\Z")


def compile_drive(mech: Mechanism, text, inputs) -> object:
    """A driving torque (force) given as a number or an expression of the input (model units),
    ``<input>_vel`` and ``t``, parameters allowed, compiled to ``f(x, xd, t) -> float`` (SI result).

    ``x`` and ``xd`` are internal (radians, rad/s). Raises :class:`ModelError` naming the text.
    """
    from ..model import expr as _expr

    (name,) = inputs
    kind = Kind.TORQUE if mech.variable(name).kind is Kind.ANGLE else Kind.FORCE
    if isinstance(text, str) and _QUANTITY_RE.match(text):  # "0.05N*m", "0.4 in*lbf", "20N": a constant
        value = parse_quantity(text, kind, length_unit="m", where="--torque")
        return lambda x, xd, t: value
    label = "torque" if kind is Kind.TORQUE else "force"
    si, example = ("N*m", "0.05N*m") if kind is Kind.TORQUE else ("N", "20N")
    try:
        node = _expr.parse(text) if not isinstance(text, _expr.Name) else text
        if any(isinstance(n, _expr.Num) and n.unit for n in _expr.walk(node)):
            raise _expr.ExpressionError("unknown unit inside the expression")
    except _expr.ExpressionError as exc:
        why = "units are not allowed inside an expression" if "unit" in str(exc) else str(exc)
        raise ModelError(f"--torque {text!r}: {why}; the driving {label} is a number in SI ({si}), a quantity "
                         f"such as \"{example}\", or an expression of {name!r}, {name + '_vel'!r} and 't' whose "
                         "value is in SI (no units inside)") from None
    allowed = {name, name + "_vel", "t"} | {p.name for p in mech.parameters}
    bad = sorted(_expr.names(node) - allowed)
    if bad:
        raise ModelError(f"--torque {text!r}: unknown name(s) {', '.join(map(repr, bad))}; an expression may use "
                         f"{name!r} (model units), {name + '_vel'!r}, 't' and the parameters")
    kin_like = sp.Symbol(name, real=True), sp.Symbol(name + "__d1", real=True), sp.Symbol("t", real=True)
    params = [sp.Symbol(p.name, real=True) for p in mech.parameters]
    symbols = {name: kin_like[0], name + "_vel": kin_like[1], "t": kin_like[2], **dict(zip((p.name for p in mech.parameters), params))}
    k = sp.pi / 180 if mech.units.angle == "deg" else sp.Integer(1)
    var = mech.variable(name)
    angle_names = frozenset(([name] if var.kind is Kind.ANGLE else [])
                            + [p.name for p in mech.parameters if p.kind is Kind.ANGLE])
    e = to_sympy(node, symbols, k=k, angle_names=angle_names, length_unit=mech.units.length)
    fn = sp.lambdify([kin_like[0], kin_like[1], kin_like[2], params], e, modules="math")
    pvals = [p.value for p in mech.parameters]

    def drive(x, xd, t):
        try:
            return float(fn(x, xd, t, pvals))
        except (ArithmeticError, ValueError) as exc:
            raise ModelError(f"--torque {text!r} cannot be evaluated at {name} = {x:g}, t = {t:g}: {exc}") from None

    return drive
