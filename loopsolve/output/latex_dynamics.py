"""The "Equation of motion" section of the LaTeX document: symbols first, then numbers.

For a model with ``[bodies]``, :func:`equation_of_motion` prints the derivation of
:func:`loopsolve.dynamics.eom.derive_dynamics` as the textbook writes it:

* the mass properties (``m_crank = 0.00628 kg``, ``I_crank = …``) and the other constants —
  λ (the model's length unit in metres), g, the loads by their names (``F_C,x``, ``T_rocker``,
  ``k``, ``c``) — each with its value and unit;
* the kinematic coefficients of the centres of mass and of the load points
  (x′_G = dx_G/dx, x″_G, in the model's length unit), in the kinematic coefficients q′, q″ of the
  unknowns;
* M(x), M′(x) and Q(x) as sums over the bodies and the loads in those symbols, then the same
  sums with the numbers put in (λ stays a factor, a negative value is a minus sign: ``− 0.05 θ′₄``),
  and the equation of motion M ẍ + ½ M′ ẋ² = Q + T (− Q_f with ``[friction]``: the friction's
  generalized force, given by its lost power and solved with the joint forces, see :func:`_friction_items`);
* with ``at``: the kinematic coefficients, M, M′, Q and the driving torque T at that input (with
  friction: T, the lost power and Q_f from the exact force analysis).

:mod:`loopsolve.output.latex` calls it with its builder (the printer, the mechanism, the input choice).
"""

from __future__ import annotations

import math

import numpy as np
import sympy as sp

from ..symbolic.texprint import (BUDGET, GAP, Eqs, LatexPrinter, Section, Table, Text, break_terms, eq_lines, escape,
                                 join_terms, symbol_latex, tex_number, tex_width)
from ..model.units import Kind

__all__ = ["equation_of_motion"]


class _Writer:
    def __init__(self, builder, d):
        self.b, self.d = builder, d
        settings = dict(builder.p._settings)
        self.p = LatexPrinter({"degrees": settings["degrees"], "angles": settings["angles"],
                               "symbol_names": dict(d.latex_names)})
        self.deg = builder.deg
        self.lam = d.length_scale

    def tex(self, e) -> str:
        return self.p.doprint(e)

    # ---- a named constant as its symbol, or as its value
    def symbolic(self, sym) -> tuple[bool, str]:
        return False, self.d.latex_names[sym]

    def numeric(self, sym) -> tuple[bool, str]:
        v = self.d.values.get(sym)
        if v is None or isinstance(v, sp.Basic) or sym == self.lam:
            return False, self.d.latex_names[sym]
        if self.d.units.get(sym) == r"\mathrm{rad}" and self.deg:
            return v < 0, tex_number(abs(math.degrees(v))) + r"^{\circ}"
        return v < 0, tex_number(abs(v))

    def factor(self, factor, fmt) -> tuple[bool, str]:
        """The common factor of a group (2λ², gλ, ẋ …) with the named constants as ``fmt`` gives them."""
        neg, parts, below = False, [], []
        for f in factor:
            for base, exp in sp.Mul(f).as_powers_dict().items():
                if exp < 0:  # a length input: 1/λ (M′ is per metre of the SI coordinate)
                    below.append(self.tex(base**-exp))
                elif base in self.d.latex_names and base != self.lam:
                    n, t = fmt(base)
                    neg ^= n and exp % 2 == 1
                    parts.append(t if exp == 1 else "{%s}^{%s}" % (t, self.tex(exp)))
                else:
                    parts.append(self.tex(base**exp))
        nums = [p for p in parts if p[:1].isdigit()]
        top = " ".join(nums + [p for p in parts if p not in nums])
        return neg, (r"\frac{%s}{%s}" % (top or "1", " ".join(below)) if below else top)

    def chunks(self, groups, fmt) -> list[list[tuple[bool, str]]]:
        """The signed terms of a sum of groups, each group bracketed behind its factor (one list per
        group that should stay on one line if it can)."""
        out: list[list[tuple[bool, str]]] = []
        for g in groups:
            terms = []
            for t in g.terms:
                neg, ctex = fmt(t.coef)
                ktex = t.tex(fmt)
                terms.append((neg, ctex if ktex == "1" else r"%s\,%s" % (ctex, ktex)))
            fneg, ftex = self.factor(g.factor, fmt)
            sign = (g.sign < 0) != fneg
            if not ftex:
                out += [[(neg != sign, t)] for neg, t in terms]
            elif len(terms) == 1:  # 2 · 0.0016 θ′₃ θ″₃, 9.81λ · 0.6 y′_G
                join = r" \cdot " if terms[0][1][:1].isdigit() else r"\,"
                out.append([(terms[0][0] != sign, ftex + join + terms[0][1])])
            else:
                first = r"%s\Bigl[%s%s" % (ftex, "- " if terms[0][0] else "", terms[0][1])
                rest = terms[1:]
                rest[-1] = (rest[-1][0], rest[-1][1] + r"\Bigr]")
                out.append([(sign, first)] + rest)
        return out or [[(False, "0")]]

    # ---- parts
    def tables(self, items):
        d, mech = self.d, self.d.mechanism
        rows = []
        for body in mech.dynamics.bodies:
            m = d.mass[body.name]
            ii = d.inertia.get(body.name)
            rows.append((r"\mathrm{%s}" % escape(body.name), self.constant(m),
                         self.constant(ii) if ii is not None else r"\text{--}",
                         join_terms(self.b.point_terms(body.com)) if body.com.terms else r"\vec{0}",
                         self.b.p.angle(sp.expand(self.angle_of(body))) if body.angle is not None else r"\text{--}"))
        items.append(Text("Mass properties of the moving bodies (the inertia is about the centre of mass $G$):"))
        items.append(Table(("Body", "Mass", "Inertia", "$\\vec{r}_G$", "$\\theta$"), tuple(rows), "lllll"))
        skip = set(d.mass.values()) | set(d.inertia.values())
        consts = [s for s in d.units if s not in skip]
        numbers = [s for s in consts if not isinstance(d.values[s], sp.Basic)]
        if numbers:
            what = [w for w, present in (
                ("gravity", any(d.meaning[n].startswith("grav") for n in numbers)),
                ("the loads", any(not d.meaning[n].startswith(("grav", "model length")) for n in numbers)),
                ("the unit of length", self.lam in numbers)) if present]
            text = ", ".join(what[:-1]) + (" and " if len(what) > 1 else "") + what[-1]
            items.append(Text(text[:1].upper() + text[1:] + ":"))
            items.append(Table(("Quantity", "Value"), tuple(
                (r"\text{%s}" % escape(d.meaning[s][:1].upper() + d.meaning[s][1:]), self.constant(s))
                for s in numbers), "ll"))
        exprs = [s for s in consts if isinstance(d.values[s], sp.Basic)]
        if exprs:
            items.append(Text("Loads given as functions of the motion (SI):"))
            lines = []
            for s in exprs:  # six significant digits, as the tables
                e = d.values[s]
                e = e.xreplace({f: sp.Float(f, 6) for f in e.atoms(sp.Float)})
                lines += eq_lines(d.latex_names[s], self.p.signed_terms(e))
            items.append(Eqs(tuple(lines)))

    def angle_of(self, body):
        from ..dynamics.dynamics_model import sympy_converter

        conv, k = sympy_converter(self.d.mechanism, self.d.kinematics)
        return k * conv(body.angle)

    def constant(self, sym) -> str:
        neg, t = (False, tex_number(self.d.values[sym])) if sym == self.lam else self.numeric(sym)
        unit = self.d.units.get(sym, "")
        if unit == r"\mathrm{rad}" and self.deg:
            unit = ""
        return r"%s = %s%s%s" % (self.d.latex_names[sym], "-" if neg else "", t, r"\," + unit if unit else "")

    def coefficients(self, items):
        d = self.d
        x = d.input
        xt = symbol_latex(x)
        unit = escape(d.mechanism.units.length)
        per = "rad" if d.input_kind is Kind.ANGLE else unit
        items.append(Text(
            r"With the input moving at $%s = 1$ and $%s = 0$ the rates are the kinematic coefficients "
            r"$q' = \mathrm{d}q/\mathrm{d}%s$ and $q'' = \mathrm{d}^2q/\mathrm{d}%s^2$ (the solutions of the velocity "
            r"and acceleration equations). Those of the centres of mass and of the points the loads act on, in "
            r"%s/%s and %s/%s$^2$:" % (symbol_latex(x + "__d1"), symbol_latex(x + "__d2"), xt, xt, unit, per,
                                         unit, per)))
        lines: list[str] = []
        for name, syms in d.point_coefficients.items():
            if lines:
                lines.append(GAP)
            for sym in syms:
                lines += eq_lines(d.latex_names[sym], self.p.signed_terms(d.coefficients[sym]))
        for (a, b), (L, Lp) in d.spring_lengths.items():
            ta, tb = symbol_latex(a), symbol_latex(b)
            dx, dy = r"\left(x_{%s} - x_{%s}\right)" % (ta, tb), r"\left(y_{%s} - y_{%s}\right)" % (ta, tb)
            lines += [GAP, r"%s &= \sqrt{%s^2 + %s^2}" % (d.latex_names[L], dx, dy),
                      r"%s &= \frac{%s\left(x'_{%s} - x'_{%s}\right) + %s\left(y'_{%s} - y'_{%s}\right)}{%s}"
                      % (d.latex_names[Lp], dx, ta, tb, dy, ta, tb, d.latex_names[L])]
        items.append(Eqs(tuple(lines)))

    def equations(self, items):
        d = self.d
        xt = symbol_latex(d.input)
        xd, xdd = symbol_latex(d.input + "__d1"), symbol_latex(d.input + "__d2")
        q_args = xt + (r", %s" % xd if d.subs(d.Q).has(d.xdot) else "")
        force = "torque" if d.input_kind is Kind.ANGLE else "force"
        lam = (r" The factor $\lambda$ converts the model's lengths to metres." if self.lam != 1 else "")
        items.append(Text(
            r"The generalized inertia $M$, its derivative $M' = \mathrm{d}M/\mathrm{d}%s$ and the generalized force "
            r"$Q$ (the virtual work of gravity and the loads per unit $\delta %s$), as sums over the bodies and the "
            r"loads (SI).%s The equation of motion of the one-degree-of-freedom mechanism follows, where $T$ is the "
            r"driving %s on the input:" % (xt, xt, lam, force)))
        heads = (r"M(%s)" % xt, r"M'(%s)" % xt, r"Q(%s)" % q_args)
        eom = r"M(%s)\,%s + \tfrac{1}{2} M'(%s)\,%s^2 &= Q + T%s" % (
            xt, xdd, xt, xd, r" - Q_\mathrm{f}" if _frictions(d.mechanism) else "")
        for fmt in (self.symbolic, self.numeric):
            lines = []
            for head, key in zip(heads, ("M", "dM", "Q")):
                lines += _bracket_lines(head, self.chunks(d.groups[key], fmt))
            if fmt == self.symbolic:
                lines.append(eom)
            items.append(Eqs(tuple(lines)))
            if fmt == self.symbolic:
                items.append(Text("With the values of the tables:"))

def _at(builder, items):
    from ..dynamics.dynamics_model import compile_dynamics, kinematic_coefficients, mass_matrix_terms
    from ..dynamics.kinetostatics import generalized_force, virtual_work_drive

    mech = builder.mech
    name = builder.kin.inputs[0]
    state = mech.solve(builder.at, input=builder.input)
    ck = state.compiled
    dm = compile_dynamics(mech, compiled=ck)
    ix = ck.index(name)
    z = state.z[None, :]
    d1, d2 = kinematic_coefficients(ck, z)
    M, dM = mass_matrix_terms(dm, z, d1, d2)
    s = dm.coord_factor
    xd, xdd = float(state.z1[ix]), float(state.z2[ix])
    Q = generalized_force(dm, z, xd, d1)
    T = virtual_work_drive(dm, z, xd, xdd)
    angle = ck.kinds[ix] is Kind.ANGLE
    xt = symbol_latex(name)
    length = escape(mech.units.length)
    shown = math.degrees(state.z[ix]) if angle and builder.deg else state.z[ix]
    where = r"%s = %s%s" % (xt, tex_number(shown), r"^{\circ}" if angle and builder.deg else
                            (r"\,\mathrm{rad}" if angle else r"\,\mathrm{%s}" % length))
    rate = r"\mathrm{rad/s}" if angle else r"\mathrm{m/s}"
    items.append(Section("Equation of motion at the given input"))
    items.append(Text(r"At $%s$, with $%s = %s\,%s$ and $%s = %s\,%s^{2}$ (SI):" % (
        where, symbol_latex(name + "__d1"), tex_number(xd * s), rate, symbol_latex(name + "__d2"),
        tex_number(xdd * s), rate)))
    rows = []
    for unknown in ck.unknowns:
        k = ck.index(unknown)
        uq = "rad" if ck.kinds[k] is Kind.ANGLE else length
        ux = "rad" if angle else length
        unit = "" if uq == ux else r"\,\mathrm{%s/%s}" % (uq, ux)
        unit2 = "" if uq == ux else r"\,\mathrm{%s/%s^{2}}" % (uq, ux)
        rows.append((symbol_latex(unknown), tex_number(d1[0, k]) + unit, tex_number(d2[0, k]) + unit2))
    items.append(Table(("", "$q'$", "$q''$"), tuple(rows), "lrr", equation=True))
    mu = r"\mathrm{kg\,m^{2}}" if angle else r"\mathrm{kg}"
    fu = r"\mathrm{N\,m}" if angle else r"\mathrm{N}"
    head = r"T = M\,%s + \tfrac{1}{2} M'\,%s^2 - Q" % (symbol_latex(name + "__d2"), symbol_latex(name + "__d1"))
    lines = [r"M &= %s\,%s" % (tex_number(M[0]), mu),
             r"M' &= %s\,%s" % (tex_number(dM[0]), mu if angle else r"\mathrm{kg/m}"),
             r"Q &= %s\,%s" % (tex_number(Q[0]), fu)]
    if not _frictions(mech):
        items.append(Eqs(tuple(lines + [r"%s &= %s\,%s" % (head, tex_number(T[0]), fu)])))
        return
    # with friction T is the exact solution of the force analysis (its Q_f = P_lost / input rate)
    from ..dynamics.kinetostatics import forces

    fs = forces(mech, at=builder.at, input=builder.input)
    drive = float(np.asarray(fs.drive, dtype=float).reshape(-1)[0])
    lost = float(np.asarray(fs["power_lost"], dtype=float).reshape(-1)[0])
    if not math.isfinite(drive):
        items.append(Eqs(tuple(lines)))
        items.append(Text(r"With its friction the mechanism self-locks here: no driving %s moves it "
                           r"(\texttt{loopsolve forces} reports the event)." % ("torque" if angle else "force")))
        return
    lines.append(r"P_\mathrm{lost} &= %s\,\mathrm{W}" % tex_number(lost))
    if xd != 0.0:
        lines.append(r"Q_\mathrm{f} = P_\mathrm{lost} / %s &= %s\,%s" % (
            symbol_latex(name + "__d1"), tex_number(lost / (xd * s)), fu))
    lines.append(r"%s%s &= %s\,%s" % (head, r" + Q_\mathrm{f}" if xd != 0.0 else "", tex_number(drive), fu))
    items.append(Eqs(tuple(lines)))


def _bracket_lines(lhs: str, groups, budget: float = 0.8 * BUDGET) -> list[str]:
    """``lhs &= …`` broken over lines; a bracketed group starts a new line when it then fits on it
    (it is broken inside its ``\\Bigl[`` … ``\\Bigr]`` only when it is wider than a line). The budget is
    smaller than the kinematics' because :func:`~loopsolve.symbolic.texprint.tex_width` underestimates the
    nested subscripts and the thin spaces of these sums (measured on the shaper's PDF)."""
    room = max(budget - tex_width(lhs) - 3.0, 0.45 * budget)
    lines: list[list[tuple[bool, str]]] = [[]]
    for group in groups:
        cur = lines[-1]
        if cur and tex_width(join_terms(cur + group)) > room and tex_width(join_terms(group)) <= room:
            lines.append([])
        lines[-1] += group
    parts: list[str] = []
    for terms in lines:
        broken = break_terms(terms, room)
        if parts:  # a continuation line keeps its sign
            broken[0] = ("{}" if terms[0][0] else "{}+ ") + broken[0]
        parts += broken
    return ["%s &= %s" % (lhs, parts[0])] + [r"&\quad %s" % p for p in parts[1:]]


def equation_of_motion(builder) -> list:
    """The items of the "Equation of motion" section for ``builder`` (a :class:`loopsolve.output.latex._Builder`)."""
    mech, kin = builder.mech, builder.kin
    dyn = mech.dynamics
    if dyn is None or not dyn.bodies or len(kin.inputs) != 1:
        return []
    from ..dynamics.eom import derive_dynamics

    d = derive_dynamics(mech, builder.input)
    w = _Writer(builder, d)
    items: list = [Section("Equation of motion")]
    w.tables(items)
    w.coefficients(items)
    w.equations(items)
    xd = symbol_latex(d.input + "__d1")
    if _frictions(mech):
        _friction_items(builder, items, xd, "torque" if d.input_kind is Kind.ANGLE else "force")
        return items
    items.append(Text(
        r"Newton--Euler for each moving body, $\sum \vec{F} = m\,\vec{a}_G$ and $\sum M_G = I_G\,\alpha$, is a "
        r"linear system in the joint forces, the guide reactions and $T$ (\texttt{loopsolve forces}); its $T$ "
        r"equals the one above, and the power balance $T%s = \dot{E}_k + \dot{V} - P_\mathrm{loads}$ "
        r"is checked at every point." % xd))
    return items


def _frictions(mech) -> tuple:
    """The model's ``[friction]`` entries (:mod:`loopsolve.model.friction`), or ``()``."""
    pairs = mech.pairs
    return tuple(getattr(pairs, "friction", ()) or ()) if pairs is not None else ()


_FRICTION_KIND = {"pin": "revolute (journal)", "guide": "prismatic guide", "slot": "pin in a slot",
                  "cam": "cam contact"}


def _friction_items(builder, items, xd: str, drive: str) -> None:
    """The friction part of the equation of motion: the joints' coefficients and the term Q_f.

    Coulomb friction is not a function of the motion alone: each joint's friction is proportional
    to that joint's force, which the Newton--Euler system gives with T and the accelerations (and
    its direction is the relative velocity's). So Q_f is written by its power, and its value is the
    exact solution of ``loopsolve forces`` (:mod:`loopsolve.dynamics.friction`), not a sum of the
    symbols above.
    """
    from ..model.pairs import evaluator

    mech = builder.mech
    values = evaluator(mech)
    length = escape(mech.units.length)
    rows = []
    for fr in _frictions(mech):
        mu = tex_number(fr.mu)
        if fr.kind == "pin":
            r = values(fr.radius, Kind.LENGTH)
            circle = r * fr.mu / math.sqrt(1.0 + fr.mu ** 2)
            law = (r"c = r \sin\varphi = %s\,\mathrm{%s}\text{, torque } c\,|\vec{F}|"
                   % (tex_number(circle), length))
            radius = r"%s\,\mathrm{%s}" % (tex_number(r), length)
        else:
            law, radius = r"\text{force } \mu\,|N|", r"\text{--}"
        rows.append((r"\mathrm{%s}" % escape(fr.name), r"\text{%s}" % _FRICTION_KIND.get(fr.kind, fr.kind),
                     mu, radius, law))
    items.append(Text(
        r"Coulomb friction (\texttt{[friction]}): at a revolute joint of journal radius $r$ the friction circle "
        r"$c = r \sin\varphi$ with $\tan\varphi = \mu$ gives the torque $c\,|\vec{F}|$ against the relative "
        r"rotation, $\vec{F}$ the joint's force; at a sliding contact the force $\mu\,|N|$ against the "
        r"relative sliding, $N$ its normal force:"))
    items.append(Table(("Joint", "Kind", r"$\mu$", "$r$", "Friction"), tuple(rows), "lllll"))
    items.append(Text(
        r"$Q_\mathrm{f}$ is the friction's generalized force, given by the power it takes, "
        r"$Q_\mathrm{f}\,%s = P_\mathrm{lost} = \sum_k c_k\,|\vec{F}_k|\,|\omega_k| + \sum_k \mu_k\,|N_k|\,|v_k| "
        r"\ge 0$ ($\omega_k$, $v_k$ the relative rates at joint $k$). The joint forces $\vec{F}_k$, $N_k$ depend on "
        r"$T$ and the accelerations, so the equation above is piecewise linear in them and is not a sum of the "
        r"symbols above: Newton--Euler for each moving body with these friction forces (\texttt{loopsolve forces}) "
        r"is solved exactly for the joint forces and $T$, and the power balance $T%s = \dot{E}_k + \dot{V} - "
        r"P_\mathrm{loads} + P_\mathrm{lost}$ is checked at every point. Where no driving %s can move the "
        r"mechanism it self-locks (an event of \texttt{loopsolve forces}, not a solution)." % (
            xd, xd, drive)))


def equation_of_motion_at(builder) -> list:
    """The items of the section "Equation of motion at one input" (``builder.at``; models with bodies)."""
    mech, kin = builder.mech, builder.kin
    dyn = mech.dynamics
    if builder.at is None or dyn is None or not dyn.bodies or len(kin.inputs) != 1:
        return []
    items: list = []
    _at(builder, items)
    return items
