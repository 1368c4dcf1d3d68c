"""The equation of motion in symbols: M(x), M′(x) and Q(x) as sums over the bodies and the loads.

:func:`derive_dynamics` writes the generalized inertia, its derivative and the generalized force
of a one-degree-of-freedom mechanism in the textbook's form (Uicker, Pennock and Shigley,
*Theory of Machines and Mechanisms*, ch. 16),

    M(x)  = λ² Σ m_i (x′_Gi² + y′_Gi²) + Σ I_i θ′_i²,
    M′(x) = 2λ² Σ m_i (x′_Gi x″_Gi + y′_Gi y″_Gi) + 2 Σ I_i θ′_i θ″_i,
    Q(x)  = −λ g Σ m_i y′_Gi + λ Σ (F_x x′_P + F_y y′_P) + Σ T θ′
            − λ² k (L − L₀) L′ − λ² c L′² ẋ − …,
    M ẍ + ½ M′ ẋ² = Q + T_drive,

with symbols named after the model — ``m_crank``, ``I_crank``, ``g``, the loads' names
(``F_C_x``, ``T_rocker``; ``k`` and ``c`` for springs and dampers) — and the kinematic
coefficients of the unknowns (``theta3__p1`` = θ′₃ = dθ₃/dx, ``theta3__p2`` = θ″₃) kept as
symbols, as the notes write them. λ is the model's length unit in metres (10⁻³ for mm): the
positions and their coefficients stay in the model's unit and the conversion is one factor,
never folded into a coefficient. The values of all these symbols travel beside the expressions
in :attr:`DynamicsDerivation.values`.

These are the same quantities that :func:`loopsolve.dynamics.dynamics_model.mass_terms_from` and
:func:`loopsolve.dynamics.kinetostatics.generalized_from` compute numerically (the tests check it on every
shipped model); the LaTeX export (:mod:`loopsolve.output.latex_dynamics`) prints this object. sympy runs
only here, once per call, never when the equation of motion is evaluated.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import sympy as sp

from ..model.bodies import FRAME, LoadKind
from .dynamics_model import metres_per_unit, point_expr, sympy_converter
from ..errors import ModelError
from ..model.mechanism import Mechanism
from ..symbolic.loop_equations import Kinematics, derive
from ..symbolic.texprint import escape, join_terms, symbol_latex
from ..model.units import Kind

__all__ = ["DynamicsDerivation", "EomTerm", "EomGroup", "derive_dynamics"]


@dataclass(frozen=True, eq=False)
class EomTerm:
    """One term of a group: a constant (a product of named symbols) times a kinematic part.

    ``tex(fmt)`` prints the kinematic part, ``fmt(symbol)`` giving ``(negative, text)`` for a named
    constant inside it (its symbol, or its value).
    """

    coef: sp.Expr
    kin: sp.Expr
    tex: Callable[[Callable[[sp.Symbol], str]], str]


@dataclass(frozen=True, eq=False)
class EomGroup:
    """``sign · factor · Σ coef·kin``: terms that share a factor (λ², λg, 2, ẋ …)."""

    sign: int
    factor: tuple[sp.Expr, ...]
    terms: tuple[EomTerm, ...]

    def expr(self) -> sp.Expr:
        return self.sign * sp.Mul(*self.factor) * sp.Add(*[t.coef * t.kin for t in self.terms])


@dataclass(frozen=True, eq=False)
class DynamicsDerivation:
    """The symbolic equation of motion of a one-degree-of-freedom mechanism (:func:`derive_dynamics`).

    Users receive a derivation from :func:`loopsolve.derive_dynamics`; they need not construct one.

    Parameters
    ----------
    mechanism, kinematics, input, input_kind, x, xdot, first, second
        What was derived, and its symbols (see Attributes).
    M, dM, Q, compact, coefficients, values, units, meaning, latex_names, groups
        The equation of motion and how it is printed.
    mass, inertia, length_scale, point_coefficients, spring_lengths
        The named constants and coefficients.

    Attributes
    ----------
    M, dM, Q : sympy.Expr
        M(x), M′(x) = dM/dx and Q(x, ẋ) in SI (kg·m², kg·m², N·m for an angle input; kg, kg/m, N
        for a length input), in the positions ``kinematics.z``, the kinematic coefficients
        ``first``/``second`` (q′, q″ of the unknowns; the input's own are 1 and 0), the input speed
        ``xdot`` (dampers, rate-dependent loads), the parameters and the named constants.
    compact : dict
        ``"M"``, ``"dM"``, ``"Q"`` in the named coefficients (x′_G, y′_G, x″_G, …, L, L′) as printed;
        ``coefficients`` maps each named coefficient to its expansion.
    values : dict
        symbol → value: the named constants (SI; free lengths in the model's length unit, free
        angles in radians, λ in m per model length unit) and the parameters (internal units). A
        load given as an expression maps to a sympy expression of the positions, the
        coefficients and ``xdot``. :meth:`subs` applies them.
    units, meaning : dict
        symbol → unit (LaTeX) and a few words, for the named constants.
    latex_names : dict
        symbol → LaTeX for the named constants and coefficients.
    groups : dict
        ``"M"``, ``"dM"``, ``"Q"`` → the :class:`~loopsolve.dynamics.eom.EomGroup` sums the compact forms are made of.
    mass, inertia : dict
        body name → its mass symbol (``m_crank``) and inertia symbol (``I_crank``; bodies without
        an angle or with zero inertia have none).
    x, xdot, input, input_kind
        The input's position symbol, its speed symbol (``theta2__d1``), name and kind.
    length_scale : sympy.Expr
        λ, the symbol of the model's length unit in metres (the number 1 in a metre model).
    point_coefficients, spring_lengths : dict
        point name → its named coefficients (x′, y′, x″, y″); spring/damper ends → (L, L′).
    mechanism : Mechanism
        The mechanism derived.
    kinematics : Kinematics
        Its kinematic derivation (the positions ``kinematics.z`` the expressions use).
    first, second : tuple of sympy.Symbol
        The kinematic coefficients q′ and q″ of the unknowns.

    Examples
    --------
    >>> import loopsolve as ls
    >>> dyn = ls.derive_dynamics(ls.load(ls.models_dir() / "thesis_crank_rocker_dynamics.toml"))
    >>> dyn.input, sorted(dyn.mass)
    ('theta2', ['coupler', 'crank', 'rocker'])
    >>> dyn.M.has(dyn.xdot), sorted(dyn.compact)  # M(x) depends on the position only
    (False, ['M', 'Q', 'dM'])
    """

    mechanism: Mechanism
    kinematics: Kinematics
    input: str
    input_kind: Kind
    x: sp.Symbol
    xdot: sp.Symbol
    first: tuple[sp.Symbol, ...]
    second: tuple[sp.Symbol, ...]
    M: sp.Expr
    dM: sp.Expr
    Q: sp.Expr
    compact: Mapping[str, sp.Expr]
    coefficients: Mapping[sp.Symbol, sp.Expr]
    values: Mapping[sp.Symbol, object]
    units: Mapping[sp.Symbol, str]
    meaning: Mapping[sp.Symbol, str]
    latex_names: Mapping[sp.Symbol, str]
    groups: Mapping[str, tuple[EomGroup, ...]]
    mass: Mapping[str, sp.Symbol]
    inertia: Mapping[str, sp.Symbol]
    length_scale: sp.Expr  # λ (1 in a metre model)
    point_coefficients: Mapping[str, tuple[sp.Symbol, ...]]  # point -> x', y', x'', y'' named symbols
    spring_lengths: Mapping[tuple[str, str], tuple[sp.Symbol, sp.Symbol]]  # ends -> (L, L')

    def subs(self, expr):
        """``expr`` with every named constant and parameter replaced by its value (the loads given
        as expressions first, then the numbers): a function of the pose, the coefficients and ẋ.

        Examples
        --------
        >>> d = ls.load(ls.models_dir() / "thesis_crank_rocker_dynamics.toml").derive_dynamics()
        >>> sorted(str(s) for s in d.subs(d.M).free_symbols)
        ['theta2', 'theta3', 'theta3__p1', 'theta4', 'theta4__p1']
        """
        expr = sp.sympify(expr)
        exprs = {s: v for s, v in self.values.items() if isinstance(v, sp.Basic)}
        numbers = {s: sp.Float(v) for s, v in self.values.items() if not isinstance(v, sp.Basic)}
        return expr.xreplace(exprs).xreplace(numbers)


def _label(name: str) -> str:
    return r"\mathrm{%s}" % escape(name)


def derive_dynamics(mech: Mechanism, input=None) -> DynamicsDerivation:
    """The equation of motion of ``mech`` in symbols: M(x), M′(x), Q(x) and the values of the symbols.

    Parameters
    ----------
    mech : Mechanism
        A model with ``[bodies]`` (and optionally ``gravity`` and ``[[loads]]``) and one input.
    input : str, optional
        Derive for this input variable instead of the declared one.

    Returns
    -------
    DynamicsDerivation

    Raises
    ------
    ModelError
        No bodies, more than one input, or a length unit that is not physical.

    Examples
    --------
    >>> mech = ls.load(ls.models_dir() / "thesis_crank_rocker_dynamics.toml")
    >>> d = mech.derive_dynamics()
    >>> d.compact["Q"]
    T_rocker*theta4__p1 - g*lambda*(m_coupler*y'_G_coupler + m_crank*y'_G_crank + m_rocker*y'_G_rocker)
    >>> {str(s): round(float(v), 6) for s, v in d.values.items() if str(s) in ("g", "lambda", "T_rocker")}
    {'lambda': 0.001, 'g': 9.81, 'T_rocker': -0.05}
    """
    dyn = mech.dynamics
    where = mech.source or mech.name
    if dyn is None or not dyn.bodies:
        raise ModelError(f"{where}: no [bodies] declared: the equation of motion needs the mass, inertia and "
                         "centre of mass of every moving link (see the model-file contract)")
    kin = derive(mech, input)
    if len(kin.inputs) != 1:
        raise ModelError(f"{where}: the equation of motion needs one input, not {len(kin.inputs)} "
                         f"({', '.join(kin.inputs)})")
    x = kin.inputs[0]
    ix = kin.variables.index(x)
    kind = kin.kinds[ix]
    conv, k = sympy_converter(mech, kin)
    lf = metres_per_unit(mech)
    D = kin.time_derivative
    names: dict = {}  # symbol -> LaTeX
    values: dict = {}
    units: dict = {}
    meaning: dict = {}
    taken = set(kin.variables) | set(kin.param_names) | {str(s) for s in kin.z1 + kin.z2}

    def new(name: str, tex: str, value=None, unit: str = "", what: str = "") -> sp.Symbol:
        while name in taken:
            name += "_"
        taken.add(name)
        s = sp.Symbol(name, real=True)
        names[s] = tex
        if value is not None:
            values[s] = value
            units[s] = unit
            meaning[s] = what
        return s

    # kinematic coefficients: rates at unit input speed and zero input acceleration
    first = tuple(sp.Symbol(n + "__p1", real=True) for n in kin.unknowns)
    second = tuple(sp.Symbol(n + "__p2", real=True) for n in kin.unknowns)
    prime = {kin.z1[ix]: sp.Integer(1), kin.z2[ix]: sp.Integer(0)}
    for n, p1, p2 in zip(kin.unknowns, first, second):
        j = kin.variables.index(n)
        prime[kin.z1[j]], prime[kin.z2[j]] = p1, p2
    xdot = kin.z1[ix]
    # load expressions may use the rates <var>_vel = q′ ẋ
    rate_of = {kin.z1[j]: (xdot if j == ix else prime[kin.z1[j]] * xdot) for j in range(len(kin.variables))}

    def coef1(e):
        return sp.expand(D(e).xreplace(prime))

    def coef2(e):
        return sp.expand(D(D(e)).xreplace(prime))

    lam = new("lambda", r"\lambda", lf, r"\mathrm{m/%s}" % escape(mech.units.length),
              "model length unit in metres") if lf != 1 else sp.Integer(1)
    s = sp.Integer(1) if kind is Kind.ANGLE else lam  # SI generalized coordinate per model unit
    coefficients: dict = {}
    point_coefs: dict = {}

    def point_coefficients(pname: str, pos: sp.Matrix, label: str) -> tuple:
        if pname in point_coefs:
            return point_coefs[pname]
        syms = []
        for order, (f, marks) in enumerate(((coef1, "'"), (coef2, "''"))):
            for c, axis in enumerate("xy"):
                sym = new(f"{axis}{marks}_{pname}", "%s%s_{%s}" % (axis, marks, label))
                coefficients[sym] = f(pos[c])
                syms.append(sym)
        point_coefs[pname] = tuple(syms)
        return point_coefs[pname]

    deg = mech.units.angle == "deg"

    def _tex(e) -> str:
        from ..symbolic.texprint import LatexPrinter

        return LatexPrinter({"degrees": deg, "symbol_names": dict(names)}).doprint(e)

    def _power(w, n: int = 2) -> str:
        """θ′ (or θ′²) of a body's angle: ``1`` when the body turns with the input."""
        if w == 1:
            return "1"
        t = _tex(w)
        if n == 1:
            return t
        return "{%s}^{2}" % t if w.is_Symbol else r"\left(%s\right)^{2}" % t

    def _product(w, a) -> str:
        return _tex(a) if w == 1 else r"%s\,%s" % (_tex(w), _tex(a))

    def tx(sym) -> str:
        return names[sym]

    def minus(f, a_tex: str, sym) -> str:  # (a − value of sym), the value's sign kept
        neg, t = f(sym)
        return r"\left(%s\right)" % join_terms([(False, a_tex), (not neg, t)])

    def times(f, sym, b_tex: str) -> tuple[bool, str]:
        neg, t = f(sym)
        return neg, t + r"\," + b_tex

    def sq(sym) -> str:
        return "{%s}^{2}" % names[sym]

    by_point = {p.name: p for p in mech.points}
    mass, inertia, angles = {}, {}, {}
    m_terms, i_terms, dm_terms, di_terms = [], [], [], []
    grav_terms = []
    gx, gy = dyn.gravity
    if gx and gy:
        gsym = (new("g_x", "g_{x}", gx, r"\mathrm{m/s^{2}}", "gravity, x component"),
                new("g_y", "g_{y}", gy, r"\mathrm{m/s^{2}}", "gravity, y component"))
        gsign, gfactor = 1, ()
    elif gx or gy:
        gsym = (new("g", "g", abs(gx or gy), r"\mathrm{m/s^{2}}", "gravitational acceleration"),)
        gsign, gfactor = (1 if (gx or gy) > 0 else -1), gsym
    else:
        gsym, gsign, gfactor = (), 1, ()
    for b in dyn.bodies:
        lab = _label(b.name)
        m = new(f"m_{b.name}", r"m_{%s}" % lab, b.mass, r"\mathrm{kg}", f"mass of {b.name}")
        mass[b.name] = m
        xp, yp, xpp, ypp = point_coefficients(f"G_{b.name}", point_expr(kin, b.com, conv), r"G_{%s}" % lab)
        m_terms.append(EomTerm(m, xp**2 + yp**2, lambda f, a=xp, c=yp: r"\left(%s + %s\right)" % (sq(a), sq(c))))
        dm_terms.append(EomTerm(m, xp * xpp + yp * ypp, lambda f, a=xp, c=yp, a2=xpp, c2=ypp:
                                r"\left(%s\,%s + %s\,%s\right)" % (tx(a), tx(a2), tx(c), tx(c2))))
        if gx and gy:
            grav_terms.append(EomTerm(m, gsym[0] * xp + gsym[1] * yp, lambda f, a=xp, c=yp:
                                      r"\left(%s\right)" % join_terms([times(f, gsym[0], tx(a)),
                                                                           times(f, gsym[1], tx(c))])))
        elif (gx or gy) and coefficients[xp if gx else yp] != 0:  # (a term m·0 is left out)
            cp = xp if gx else yp
            grav_terms.append(EomTerm(m, cp, lambda f, a=cp: tx(a)))
        if b.angle is not None:
            th = sp.expand(k * conv(b.angle))
            angles[b.name] = (th, coef1(th), coef2(th))
            if b.inertia:
                ii = new(f"I_{b.name}", r"I_{%s}" % lab, b.inertia, r"\mathrm{kg\,m^{2}}",
                         f"inertia of {b.name} about its centre of mass")
                inertia[b.name] = ii
                w, a = angles[b.name][1], angles[b.name][2]
                i_terms.append(EomTerm(ii, w**2, lambda f, w=w: _power(w)))
                di_terms.append(EomTerm(ii, w * a, lambda f, w=w, a=a: _product(w, a)))

    # ---- loads
    def load_label(ld, default: str) -> str:
        explicit = ld.name and ld.name not in (f"load{ld.index + 1}", f"load{ld.index + 1}_damping")
        return ld.name.removesuffix("_damping") if explicit else default

    def ends_label(ld) -> str:
        a, b = ld.ends
        return a + b if len(a) == 1 and len(b) == 1 else f"{a},{b}"

    bases = [("k" if ld.kind in (LoadKind.SPRING, LoadKind.TORSION_SPRING) else "c")
             for ld in dyn.loads if ld.kind not in (LoadKind.FORCE, LoadKind.TORQUE)]
    force_terms, torque_terms, spring_terms, damper_terms, tspring_terms, tdamper_terms = ([] for _ in range(6))
    springs: dict = {}

    def load_value(v):
        if isinstance(v, (int, float)):
            return float(v)
        return sp.expand(conv(v).xreplace(rate_of)) if conv(v).free_symbols & set(rate_of) else conv(v)

    def spring_geometry(ld):
        if tuple(ld.ends) in springs:
            return springs[tuple(ld.ends)]
        a, b = (point_expr(kin, by_point[e], conv) for e in ld.ends)
        d = a - b
        length = sp.sqrt(d[0] ** 2 + d[1] ** 2)
        lab = _label(ends_label(ld))
        L = new(f"L_{'_'.join(ld.ends)}", r"L_{%s}" % lab)
        Lp = new(f"L'_{'_'.join(ld.ends)}", r"L'_{%s}" % lab)
        coefficients[L] = length
        coefficients[Lp] = sp.expand(D(d[0]).xreplace(prime) * d[0] + D(d[1]).xreplace(prime) * d[1]) / length
        for e in ld.ends:
            point_coefficients(e, point_expr(kin, by_point[e], conv), symbol_latex(e))
        springs[tuple(ld.ends)] = (L, Lp)
        return L, Lp

    for ld in dyn.loads:
        if ld.kind is LoadKind.FORCE:
            if ld.body == FRAME:
                continue
            lab = load_label(ld, ld.at)
            xp, yp = point_coefficients(ld.at, point_expr(kin, by_point[ld.at], conv), symbol_latex(ld.at))[:2]
            for c, (axis, cp) in enumerate((("x", xp), ("y", yp))):
                v = ld.values[c]
                if isinstance(v, (int, float)) and v == 0:
                    continue
                F = new(f"F_{lab}_{axis}", r"F_{%s,%s}" % (_label(lab), axis), load_value(v), r"\mathrm{N}",
                        f"force at {ld.at} on {ld.body}, {axis} component")
                if coefficients[cp] != 0:  # no virtual work along a direction the point cannot move
                    force_terms.append(EomTerm(F, cp, lambda f, cp=cp: tx(cp)))
        elif ld.kind is LoadKind.TORQUE:
            if ld.body == FRAME:
                continue
            lab = load_label(ld, ld.body)
            T = new(f"T_{lab}", r"T_{%s}" % _label(lab), load_value(ld.values[0]), r"\mathrm{N\,m}",
                    f"torque on {ld.body}")
            w = angles[ld.body][1]
            torque_terms.append(EomTerm(T, w, lambda f, w=w: _power(w, 1)))
        elif ld.kind in (LoadKind.SPRING, LoadKind.DAMPER):
            L, Lp = spring_geometry(ld)
            base = "k" if ld.kind is LoadKind.SPRING else "c"
            lab = load_label(ld, ends_label(ld)) if bases.count(base) > 1 else ""
            sub = "_{%s}" % _label(lab) if lab else ""
            if ld.kind is LoadKind.SPRING:
                kk = new("k" + ("_" + lab if lab else ""), "k" + sub, ld.stiffness, r"\mathrm{N/m}",
                         f"stiffness of the spring {ld.ends[0]}-{ld.ends[1]}")
                L0 = new("L_0" + ("_" + lab if lab else ""), r"L_{0%s}" % ("," + _label(lab) if lab else ""),
                         ld.free, r"\mathrm{%s}" % escape(mech.units.length),
                         f"free length of the spring {ld.ends[0]}-{ld.ends[1]}")
                spring_terms.append(EomTerm(kk, (L - L0) * Lp, lambda f, L=L, Lp=Lp, L0=L0:
                                            r"%s %s" % (minus(f, tx(L), L0), tx(Lp))))
            else:
                cc = new("c" + ("_" + lab if lab else ""), "c" + sub, ld.damping, r"\mathrm{N\,s/m}",
                         f"damping of the damper {ld.ends[0]}-{ld.ends[1]}")
                damper_terms.append(EomTerm(cc, Lp**2, lambda f, Lp=Lp: sq(Lp)))
        else:
            base = "k" if ld.kind is LoadKind.TORSION_SPRING else "c"
            lab = load_label(ld, ld.body) if bases.count(base) > 1 else ""
            sub = "_{%s}" % _label(lab) if lab else ""
            th, w, _ = angles[ld.body]
            if ld.kind is LoadKind.TORSION_SPRING:
                kk = new("k" + ("_" + lab if lab else ""), "k" + sub, ld.stiffness, r"\mathrm{N\,m/rad}",
                         f"stiffness of the torsional spring on {ld.body}")
                t0 = new("theta_0" + ("_" + lab if lab else ""),
                         r"\theta_{0%s}" % ("," + _label(lab) if lab else ""), ld.free, r"\mathrm{rad}",
                         f"free angle of the torsional spring on {ld.body}")
                tspring_terms.append(EomTerm(kk, (th - t0) * w, lambda f, th=th, w=w, t0=t0:
                                             r"%s %s" % (minus(f, _tex(th), t0), _power(w, 1))))
            else:
                cc = new("c" + ("_" + lab if lab else ""), "c" + sub, ld.damping, r"\mathrm{N\,m\,s/rad}",
                         f"damping of the torsional damper on {ld.body}")
                tdamper_terms.append(EomTerm(cc, w**2, lambda f, w=w: _power(w)))

    two = sp.Integer(2)

    def group(sign, factor, terms):
        fac = tuple(f for f in factor if f != 1)
        terms = tuple(t for t in terms if t.kin != 0)
        return (EomGroup(sign, fac, terms),) if terms else ()

    inv_s = (1 / s,) if s != 1 else ()
    groups = {
        "M": group(1, (lam**2 / s**2,), m_terms) + group(1, (1 / s**2,), i_terms),
        "dM": group(1, (two, lam**2 / s**3), dm_terms) + group(1, (two, 1 / s**3), di_terms),
        "Q": (group(gsign, (lam / s,) + gfactor, grav_terms) + group(1, (lam / s,), force_terms)
              + group(1, inv_s, torque_terms) + group(-1, (lam**2 / s,), spring_terms)
              + group(-1, (lam**2 / s, xdot), damper_terms) + group(-1, inv_s, tspring_terms)
              + group(-1, (xdot,) + inv_s, tdamper_terms)),
    }
    compact = {key: sp.Add(*[g.expr() for g in gs]) for key, gs in groups.items()}
    full = {key: e.xreplace(coefficients) for key, e in compact.items()}
    for sym, val in zip(kin.params, kin.param_values):
        values[sym] = float(val)
    for v, p1, p2 in zip(kin.unknowns, first, second):
        names[p1], names[p2] = symbol_latex(v + "__p1"), symbol_latex(v + "__p2")
    return DynamicsDerivation(
        mechanism=mech, kinematics=kin, input=x, input_kind=kind, x=kin.z[ix], xdot=xdot, first=first,
        second=second, M=full["M"], dM=full["dM"], Q=full["Q"], compact=compact, coefficients=coefficients,
        values=values, units=units, meaning=meaning, latex_names=names, groups=groups, mass=mass,
        inertia=inertia, length_scale=lam, point_coefficients=point_coefs, spring_lengths=springs)


