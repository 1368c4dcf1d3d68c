"""The symbolic derivation as LaTeX (and PDF), in the notation of the textbook notes.

:func:`to_latex` prints the expressions of :func:`loopsolve.symbolic.loop_equations.derive` — the very sympy
objects the solver compiles, so the document and the numbers cannot disagree — as

* the vector loops, in vector form (``\\vec r_2 + \\vec r_3 = \\vec r_1 + \\vec r_4``) and in
  complex-exponential form (``r_2 e^{j\\theta_2} + ...``);
* the scalar x and y loop-closure (position) equations;
* the velocity, acceleration and jerk equations in matrix form, Φ_q q⁽ᵏ⁾ = b_k, with the
  coefficient matrix Φ_q written out, and for a 2×2 system the velocity solution by Cramer's rule;
* the position, velocity and acceleration of the declared points;
* optionally a table of the numeric solution at one input value.

:mod:`loopsolve.symbolic.texprint` prints the expressions in the notes' notation (θ₂, θ̇₃, degrees inside
sin/cos of a degree model) and breaks long sums over lines: a right-hand side too wide for the
matrix equation is listed entry by entry, and a coefficient matrix too wide for the page is
listed by its non-zero entries.

:func:`write_pdf` compiles a document with ``pdflatex`` (or ``latexmk``). Only packages of
Debian's ``texlive-latex-base`` are used (amsmath, geometry).
"""

from __future__ import annotations

import math
import os
import re
import shutil
import subprocess
import tempfile
from collections.abc import Sequence
from pathlib import Path

import sympy as sp

from ..errors import LoopsolveError, MissingDependencyError
from ..model.mechanism import Mechanism
from ..symbolic.texprint import (ACCENT, BUDGET, GAP, Eqs, LatexPrinter, Section, Table, Text, balance_block, eq_lines,
                                 escape, join_terms, matrix_width, symbol_latex, tex_number, tex_unit, tex_width,
                                 vector_latex)
from ..model.units import Kind

__all__ = ["LatexPrinter", "symbol_latex", "vector_latex", "velocity_solution", "to_latex", "write_pdf"]

def velocity_solution(kin) -> dict[str, sp.Expr] | None:
    """The unknown rates of a 2×2 velocity equation by Cramer's rule, simplified.

    ``None`` when Φ_q is not 2×2 or the result does not simplify to a compact form. These are
    the formulas the document prints under the velocity equation.

    Examples
    --------
    >>> from loopsolve.output.latex import velocity_solution
    >>> sol = velocity_solution(ls.fourbar(r1=60, r2=25, r3=70, r4=45).derive())
    >>> sol["theta4"]
    -r2*theta2__d1*sin(theta2 - theta3)/(r4*sin(theta3 - theta4))
    """
    jac, b1 = kin.jac, kin.rhs[0]
    if jac.shape != (2, 2):
        return None
    det = sp.factor(sp.trigsimp(jac.det()))
    if det == 0:
        return None
    out = {}
    for i, name in enumerate(kin.unknowns):
        ji = jac.copy()
        ji[:, i] = b1
        value = sp.factor(sp.trigsimp(ji.det())) / det
        if sp.count_ops(value) > 40:
            return None
        out[name] = value
    return out


class _Builder:
    """Collects the parts of the derivation for one mechanism and one input choice."""

    def __init__(self, mech: Mechanism, input, at):
        self.mech = mech
        self.kin = mech.derive(input)
        self.deg = mech.units.angle == "deg"
        declared = tuple(a for _, a in self.kin.vectors.values()
                         if a is not None and not a.is_Symbol and a.free_symbols)
        self.p = LatexPrinter({"degrees": self.deg, "angles": declared})
        self.items: list = []
        self.input = input
        self.at = at

    # ---- helpers
    def tex(self, expr) -> str:
        return self.p.doprint(expr)

    def terms(self, expr):
        return self.p.signed_terms(expr)

    def sym(self, name: str, order: int = 0) -> str:
        return symbol_latex(name + ("__d%d" % order if order else ""))

    def column(self, names: Sequence[str], order: int) -> str:
        return r"\begin{bmatrix} %s \end{bmatrix}" % r" \\ ".join(self.sym(n, order) for n in names)

    def matrix_cells(self, m: sp.Matrix) -> list[list[str]]:
        return [[self.tex(m[i, j]) for j in range(m.cols)] for i in range(m.rows)]

    @staticmethod
    def bmatrix(cells: list[list[str]]) -> str:
        return r"\begin{bmatrix} %s \end{bmatrix}" % r" \\ ".join(" & ".join(r) for r in cells)

    # ---- parts
    def header(self):
        mech, kin = self.mech, self.kin
        units = mech.units
        self.items.append(Section("Mechanism"))
        src = r" (model file \texttt{%s})" % escape(Path(mech.source).name) if mech.source else ""
        self.items.append(Text(r"\emph{%s}%s. Lengths in %s, angles in %s; angular rates in rad/s, "
                                r"rad/s$^2$, rad/s$^3$. Angles are measured counter-clockwise from the "
                                r"$x$ axis." % (escape(mech.name), src, escape(units.length),
                                                "degrees" if self.deg else "radians")))
        if mech.parameters:
            rows = []
            for prm in mech.parameters:
                if prm.kind is Kind.ANGLE:
                    value = prm.value / (math.pi / 180) if self.deg else prm.value
                    cell = tex_number(value) + tex_unit(units.angle if self.deg else "rad")
                elif prm.kind is Kind.LENGTH:
                    cell = tex_number(prm.value) + tex_unit(units.length)
                else:
                    cell = tex_number(prm.value)
                rows.append((self.sym(prm.name), cell))
            self.items.append(Text("Parameters (they stay symbols in the equations):"))
            self.items.append(Table(("Parameter", "Value"), tuple(rows), "lr"))
        vrows = []
        for v in mech.vectors:
            length, angle = kin.vectors[v.name]
            if angle is None:
                xy = kin.vector_xy[v.name]
                vrows.append((vector_latex(v.name), r"x = %s,\ y = %s" % (self.tex(xy[0]), self.tex(xy[1])),
                               r"\text{--}"))
            else:
                vrows.append((vector_latex(v.name), self.tex(length), self.p.angle(angle)))
        if vrows:
            self.items.append(Text("Vectors (length and angle of each):"))
            self.items.append(Table(("Vector", "Length", "Angle"), tuple(vrows), "lll"))
        ins = ", ".join("$%s$" % self.sym(n) for n in kin.inputs)
        q = r",\ ".join(self.sym(n) for n in kin.unknowns)
        self.items.append(Text(r"Input: %s. Unknowns: $\mathbf{q} = [%s]^{T}$ (%d scalar equations, "
                                r"%d unknowns)." % (ins, q, kin.jac.rows, len(kin.unknowns))))

    def loops(self):
        mech, kin = self.mech, self.kin
        if not mech.loops:
            return
        self.items.append(Section("Vector loops and position equations"))
        self.items.append(Text(r"Each loop closes: in vector form, in complex-exponential form "
                                r"($\vec{r} = r\,\mathrm{e}^{\mathrm{j}\theta}$, "
                                r"$\mathrm{j}^2 = -1$), and by its $x$ and $y$ components, which are the "
                                r"position equations $\boldsymbol{\Phi}(\mathbf{q}) = \mathbf{0}$."))
        for idx, loop in enumerate(mech.loops):
            lhs, rhs = (loop.lhs, loop.rhs) if (loop.lhs or loop.rhs) else (loop.terms, ())
            vec = lambda side: [(s < 0, vector_latex(n)) for s, n in side] or [(False, r"\vec{0}")]  # noqa: E731
            cplx = lambda side: [self.complex_term(s, n) for s, n in side] or [(False, "0")]  # noqa: E731
            pairs = [(vec(lhs), vec(rhs)), (cplx(lhs), cplx(rhs))]
            for c in (0, 1):  # the x and y components, term by term in the loop's order
                side = lambda vs: [t for s, n in vs if kin.vector_xy[n][c] != 0  # noqa: E731
                                   for t in self.terms(s * kin.vector_xy[n][c])] or [(False, "0")]
                pairs.append((side(lhs), side(rhs)))
            lines = balance_block(pairs)
            if len(mech.loops) > 1:
                label = "" if loop.name == "loop%d" % (idx + 1) else " (%s)" % escape(loop.name)
                self.items.append(Text("Loop %d%s:" % (idx + 1, label)))
            self.items.append(Eqs(tuple(lines)))

    def complex_term(self, sign: int, name: str) -> tuple[bool, str]:
        length, angle = self.kin.vectors[name]
        if angle is None:
            x, y = self.kin.vector_xy[name]
            parts = []
            if x != 0:
                neg = x.could_extract_minus_sign()
                parts.append((neg, self.tex(-x if neg else x)))
            if y != 0:
                neg = y.could_extract_minus_sign()
                yt = self.tex(-y if neg else y)
                if isinstance(y, sp.Add):
                    yt = r"\left(%s\right)" % yt
                parts.append((neg, r"\mathrm{j}\,%s" % yt))
            return sign < 0, r"\left(%s\right)" % join_terms(parts)
        lt = self.tex(length)
        if isinstance(length, sp.Add) or length.could_extract_minus_sign():
            lt = r"\left(%s\right)" % lt
        if angle == 0:
            return sign < 0, lt
        at = self.p.angle(angle)
        if not (angle.is_Symbol or (self.deg and (angle / sp.pi).is_number)):
            at = r"\left(%s\right)" % at
        return sign < 0, r"%s\,\mathrm{e}^{\mathrm{j}%s}" % (lt, at)

    def rates(self):
        kin = self.kin
        names = kin.unknowns
        jac_cells = self.matrix_cells(kin.jac)
        jac_w = matrix_width(jac_cells)
        jac_tex = self.bmatrix(jac_cells)
        jac_inline = jac_w <= 0.55 * BUDGET
        titles = ("Velocity", "Acceleration", "Jerk")
        what = ("velocity", "acceleration", "jerk")
        rate_words = ("first", "second", "third")
        for k in (1, 2, 3):
            b = kin.rhs[k - 1]
            self.items.append(Section("%s equation" % titles[k - 1]))
            if k == 1:
                self.items.append(Text(
                    r"Differentiating the position equations with respect to time gives the velocity equation, "
                    r"linear in the unknown rates: $\boldsymbol{\Phi}_{\mathbf{q}}\,\dot{\mathbf{q}} = "
                    r"\mathbf{b}_1$. The coefficient matrix $\boldsymbol{\Phi}_{\mathbf{q}} = "
                    r"\partial\boldsymbol{\Phi}/\partial\mathbf{q}$ is the same in the acceleration and jerk "
                    r"equations."))
                if not jac_inline:
                    self.items.append(Eqs(tuple(self.jacobian_lines(jac_cells, jac_w))))
            else:
                self.items.append(Text(
                    r"Differentiating %s gives the %s equation "
                    r"$\boldsymbol{\Phi}_{\mathbf{q}}\,%s = \mathbf{b}_%d$ (%s time derivatives)."
                    % ("once more" if k == 2 else "again", what[k - 1],
                       {2: r"\ddot{\mathbf{q}}", 3: r"\overset{\ldots}{\mathbf{q}}"}[k], k, rate_words[k - 1])))
            lhs = (jac_tex if jac_inline else r"\boldsymbol{\Phi}_{\mathbf{q}}") + " " + self.column(names, k)
            lhs_w = (jac_w if jac_inline else 3.0) + matrix_width([[self.sym(n, k)] for n in names])
            b_cells = self.matrix_cells(b)
            if lhs_w + matrix_width(b_cells) + 3 <= BUDGET:
                self.items.append(Eqs((r"%s &= %s" % (lhs, self.bmatrix(b_cells)),)))
            else:
                self.items.append(Eqs((r"%s &= \mathbf{b}_{%d}" % (lhs, k),)))
                self.items.append(Text(r"where the entries of $\mathbf{b}_{%d}$ are" % k))
                lines = []
                for i in range(b.rows):
                    lines += eq_lines("b_{%d,%d}" % (k, i + 1), self.terms(b[i]))
                self.items.append(Eqs(tuple(lines)))
            if k == 1:
                self.cramer()

    def jacobian_lines(self, cells, width) -> list[str]:
        if width <= BUDGET:
            return [r"\boldsymbol{\Phi}_{\mathbf{q}} &= %s" % self.bmatrix(cells)]
        lines = []
        for i, row in enumerate(cells):
            for j, c in enumerate(row):
                if c != "0":
                    lines.append(r"\left(\boldsymbol{\Phi}_{\mathbf{q}}\right)_{%d,%d} &= %s" % (i + 1, j + 1, c))
        lines.append(r"&\text{(the other entries are zero)}")
        return lines

    def cramer(self):
        kin = self.kin
        sol = velocity_solution(kin)
        if not sol:
            return
        lines = []
        x_rates = [kin.z1[kin.variables.index(n)] for n in kin.inputs]
        for name, value in sol.items():
            lhs = self.sym(name, 1)
            rate = x_rates[0] if len(x_rates) == 1 else None
            coeff = sp.cancel(value / rate) if rate is not None and value.has(rate) else None
            if coeff is not None and not coeff.has(rate):
                lines.append(r"%s &= %s\,%s" % (lhs, self.fraction(coeff), self.tex(rate)))
            else:
                lines.append(r"%s &= %s" % (lhs, self.fraction(value)))
        if any(tex_width(line) > BUDGET for line in lines):
            return  # too long to be worth reading (e.g. two inputs): the matrix form says it all
        self.items.append(Text(r"Solved by Cramer's rule:"))
        self.items.append(Eqs(tuple(lines)))

    def fraction(self, value: sp.Expr) -> str:
        """Print a quotient; a leading minus sign is absorbed into a sine of a difference when
        there is one (−a/sin(θ₃−θ₄) → a/sin(θ₄−θ₃), as the notes write it)."""
        num, den = sp.fraction(sp.factor(value))
        if (num / den).could_extract_minus_sign():
            for part, other in ((den, num), (num, den)):
                for f in sp.Mul.make_args(part):
                    if isinstance(f, sp.sin) and isinstance(f.args[0], sp.Add):
                        # sin(-a) = -sin(a): flipping one sine flips the sign of the quotient
                        flipped = part.xreplace({f: sp.sin(-f.args[0], evaluate=False)})
                        if part is den:
                            return self._quotient(-num, flipped)
                        return self._quotient(-flipped, den)
        return self._quotient(num, den)

    def _quotient(self, num, den) -> str:
        sign = ""
        if num.could_extract_minus_sign():
            sign, num = "-", -num
        if den == 1:
            return sign + self.tex(num)
        return r"%s\frac{%s}{%s}" % (sign, self.tex(num), self.tex(den))

    def points(self):
        kin, mech = self.kin, self.mech
        if not mech.points:
            return
        self.items.append(Section("Points"))
        self.items.append(Text("Position, velocity and acceleration of each point (components along $x$ and $y$)."))
        lines: list[str] = []
        for pt in mech.points:
            ptex = symbol_latex(pt.name)
            vec = join_terms(self.point_terms(pt)) if pt.terms else r"\vec{0}"
            if lines:
                lines.append(GAP)
            lines.append(r"\vec{r}_{%s} &= %s" % (ptex, vec))
            pos, vel, acc, _ = kin.points[pt.name]
            for order, m in enumerate((pos, vel, acc)):
                for c, axis in ((0, "x"), (1, "y")):
                    sym = "%s_{%s}" % (ACCENT[order] + "{%s}" % axis if order else axis, ptex)
                    lines += eq_lines(sym, self.terms(m[c]))
        self.items.append(Eqs(tuple(lines)))

    def point_terms(self, pt) -> list[tuple[bool, str]]:
        """Signed LaTeX terms of a point expression, scalar factors in front of their vectors."""
        from ..symbolic.loop_equations import to_sympy

        symbols = dict(zip(self.kin.param_names, self.kin.params))
        k = sp.pi / 180 if self.deg else sp.Integer(1)
        out = []
        for i, (sign, n) in enumerate(pt.terms):
            f = pt.factor(i)
            if f is None:
                out.append((sign < 0, vector_latex(n)))
                continue
            fs = sp.nsimplify(to_sympy(f, symbols, k=k, angle_names=frozenset(),
                                       length_unit=self.mech.units.length), rational=True) * sign
            neg = fs.could_extract_minus_sign()
            ftex = self.tex(-fs if neg else fs)
            if isinstance(-fs if neg else fs, sp.Add):
                ftex = r"\left(%s\right)" % ftex
            out.append((neg, ftex + r"\," + vector_latex(n)))
        return out

    def dynamics(self):
        """The equation of motion (models with ``[bodies]``): :mod:`loopsolve.output.latex_dynamics`."""
        from .latex_dynamics import equation_of_motion

        self.items += equation_of_motion(self)

    def dynamics_at(self):
        """M, M′, Q and the driving torque at the input ``at`` (models with ``[bodies]``)."""
        from .latex_dynamics import equation_of_motion_at

        self.items += equation_of_motion_at(self)

    def numeric(self):
        if self.at is None:
            return
        from ..kinematics.results import column_units

        state = self.mech.solve(self.at, input=self.input)
        row = state.row()
        units = column_units(state.compiled)
        kin = self.kin
        inp = kin.inputs[0]
        self.items.append(Section("Numeric solution"))
        rates = ", ".join(
            "$%s = %s%s$" % (self.sym(inp, k), tex_number(row[inp + suf]), tex_unit(units[inp + suf]))
            for k, suf in enumerate(("", "_vel", "_acc")))
        resid = "%.1e" % state.residual
        mant, exp = resid.split("e")
        self.items.append(Text(r"At %s. Assembly mode %s; loop-closure residual $%s \times 10^{%d}$."
                                % (rates, "$%s$" % state.mode if state.mode else "--", mant, int(exp))))
        scale = float(getattr(state.compiled, "scale", 1.0) or 1.0)

        def cells(key):
            values = [row[key + s] for s in ("", "_vel", "_acc", "_jerk")]
            # round-off (1e-15 of the row's size) is shown as 0
            size = max([abs(v) for v in values if v is not None] + [scale])
            return tuple(tex_number(0.0 if v is not None and abs(v) < 1e-11 * size else v) + tex_unit(units[key + s])
                         for v, s in zip(values, ("", "_vel", "_acc", "_jerk")))

        rows = [(self.sym(name),) + cells(name) for name in list(kin.inputs) + list(kin.unknowns)]
        for pt in self.mech.points:
            for axis in ("x", "y"):
                rows.append(("%s_{%s}" % (axis, symbol_latex(pt.name)),) + cells("%s_%s" % (pt.name, axis)))
        self.items.append(Table(("", "Position", "Velocity", "Acceleration", "Jerk"), tuple(rows),
                                 "lrrrr", equation=True))

    def pairs(self):
        """The equations of the constraints, gear pairs, cams, slots and rolling contacts (rows of Φ after the loops)."""
        mech, kin = self.mech, self.kin
        if mech.pairs is None or not mech.pairs.n_rows:
            return
        self.items.append(Section("Constraints and higher pairs"))
        self.items.append(Text(r"Each adds one position equation to $\boldsymbol{\Phi}(\mathbf{q}) = \mathbf{0}$, "
                                r"differentiated and solved with the loops (angles in radians):"))
        lines = []
        first = 2 * len(mech.loops)
        for i, elem in enumerate(mech.pairs.rows):
            e = kin.phi[first + i]
            lines.append(r"&\text{%s:} & %s &= 0" % (escape(elem.key), self.tex(e)))
        self.items.append(Eqs(tuple(lines)))

    def build(self):
        self.header()
        self.loops()
        self.pairs()
        self.rates()
        self.points()
        self.dynamics()
        self.numeric()
        self.dynamics_at()
        return self.items


# ============================================================================ rendering


def _render_table(t: Table) -> str:
    head = " & ".join(r"\textbf{%s}" % h if h else "" for h in t.header)
    body = "\n".join(" & ".join("$%s$" % c for c in row) + r" \\" for row in t.rows)
    return ("\\begin{center}\n\\begin{tabular}{%s}\n\\hline\n%s \\\\\n\\hline\n%s\n\\hline\n"
            "\\end{tabular}\n\\end{center}" % (t.align, head, body))


#: a line of an ``Eqs`` block that only adds vertical space before the next line


def _join_lines(lines: Sequence[str]) -> str:
    out = ""
    for i, line in enumerate(lines):
        if line == GAP:
            continue
        if out:
            out += " \\\\[2.5ex]\n" if lines[i - 1] == GAP else " \\\\\n"
        out += line
    return out


def _render_align(lines: Sequence[str]) -> str:
    return "\\begin{align*}\n" + _join_lines(lines) + "\n\\end{align*}"


def _equations_only(items) -> list:
    """Drop the text and the equation-free sections (for snippets)."""
    kept: list = []
    for it in items:
        if isinstance(it, Text) or (isinstance(it, Table) and not it.equation):
            continue
        if isinstance(it, Section) and kept and isinstance(kept[-1], Section):
            kept.pop()
        kept.append(it)
    if kept and isinstance(kept[-1], Section):
        kept.pop()
    return kept


def _render_body(items, *, snippet: bool) -> str:
    if snippet:
        items = _equations_only(items)
    out = []
    for it in items:
        if isinstance(it, Section):
            out.append(("%% %s" % it.title) if snippet else "\\section*{%s}" % escape(it.title))
        elif isinstance(it, Text):
            if not snippet:
                out.append(it.text)
        elif isinstance(it, Eqs):
            out.append(_render_align(it.lines))
        elif isinstance(it, Table):
            if not snippet or it.equation:
                out.append(_render_table(it))
    return "\n\n".join(out) + "\n"


def _render_inline(items) -> str:
    """One ``aligned`` environment (for ``$\\displaystyle ...$`` in Jupyter / MathJax)."""
    lines: list[str] = []
    for it in _equations_only(items):
        if isinstance(it, Section):
            lines.append(r"&\textbf{%s}" % escape(it.title))
        elif isinstance(it, Eqs):
            lines.extend(ln for ln in it.lines if ln != GAP)
        elif isinstance(it, Table) and it.equation:
            head = " & ".join(r"\text{%s}" % h for h in it.header)
            body = r" \\ ".join(" & ".join(row) for row in it.rows)
            lines.append(r"&\begin{array}{%s} %s \\ \hline %s \end{array}" % (it.align, head, body))
    return "\\begin{aligned}\n" + " \\\\\n".join(lines) + "\n\\end{aligned}"


_PREAMBLE = r"""\documentclass[11pt,a4paper]{article}
\usepackage[margin=2.2cm]{geometry}
\usepackage{amsmath}
\allowdisplaybreaks
\pdfgentounicode=1
\setlength{\parindent}{0pt}
\setlength{\parskip}{0.6ex}
"""


def _document(title: str, body: str) -> str:
    return (_PREAMBLE + "\\title{%s}\n\\author{Kinematic derivation by loopsolve}\n\\date{}\n"
            "\\begin{document}\n\\maketitle\n\n%s\n\\end{document}\n" % (escape(title), body))


def to_latex(mech: Mechanism, *, input: str | Sequence[str] | None = None, at=None,
             snippet: bool = False, inline: bool = False) -> str:
    """The symbolic derivation of ``mech`` as LaTeX.

    Parameters
    ----------
    mech : Mechanism
    input : str or sequence of str, optional
        Derive for this input variable instead of the declared one.
    at : float or str, optional
        Also tabulate the numeric solution (positions and rates) at this input value (model
        units, or with a unit such as ``"1.2rad"``), solved with the model's speed/accel.
    snippet : bool
        Equations only (``align*`` environments, and the numeric table when ``at`` is given),
        to paste into a document that loads ``amsmath``; default: a standalone ``article``.
    inline : bool
        With ``snippet``: one ``aligned`` environment to place inside ``$...$`` (Jupyter).

    Returns
    -------
    str

    Raises
    ------
    ModelError
        For an unknown input name.
    SolveError
        When ``at`` is given and the mechanism cannot be solved there.

    Examples
    --------
    >>> mech = ls.load(ls.models_dir() / "thesis_crank_rocker.toml")
    >>> tex = mech.to_latex()
    >>> tex.startswith("\\\\documentclass") and r"\\vec{r}_{2} + \\vec{r}_{3} &= \\vec{r}_{1} + \\vec{r}_{4}" in tex
    True
    >>> snippet = ls.output.latex.to_latex(mech, snippet=True)
    >>> print(next(line for line in snippet.splitlines() if "cos" in line))
    r_{2} \\cos\\theta_{2} + r_{3} \\cos\\theta_{3} &= r_{1} + r_{4} \\cos\\theta_{4} \\\\
    """
    items = _Builder(mech, input, at).build()
    if inline:
        return _render_inline(items)
    if snippet:
        name = "".join(" " if ord(c) < 0x20 or 0x7F <= ord(c) < 0xA0 else c for c in mech.name)
        return "%% loopsolve: %s\n" % name + _render_body(items, snippet=True)
    return _document(mech.name, _render_body(items, snippet=False))


# ============================================================================ PDF


def _find_program(program: str | None) -> tuple[str, str]:
    names = (program,) if program else ("pdflatex", "latexmk")
    for name in names:
        path = shutil.which(name)
        if path:
            return name, path
    raise MissingDependencyError(
        "%s not found on PATH: install TeX Live (Debian/Ubuntu: apt-get install texlive-latex-base), "
        "or write the .tex file without --pdf" % (" or ".join(names)))


def _log_excerpt(log: str, limit: int = 12) -> str:
    """The error lines of a TeX log: each ``!`` message with the ``l.N`` line that follows."""
    lines = log.splitlines()
    keep: list[str] = []
    for i, line in enumerate(lines):
        if line.startswith("!"):
            keep.append(line)
            for follow in lines[i + 1:i + 8]:
                if re.match(r"l\.\d+", follow):
                    keep.append(follow)
                    break
    if not keep:
        keep = [ln for ln in lines if "Error" in ln or "not found" in ln] or lines[-limit:]
    return "\n".join(keep[:limit])


def write_pdf(tex: str, output: str | os.PathLike, *, program: str | None = None,
              timeout: float = 300.0) -> Path:
    """Compile a LaTeX document (or a snippet, wrapped in one) to ``output`` as PDF.

    Runs ``pdflatex`` (or ``latexmk -pdf`` when pdflatex is absent) in a temporary directory,
    non-interactively and without shell escape.

    Parameters
    ----------
    tex : str
        A document from :func:`to_latex` (a snippet without ``\\documentclass`` is wrapped).
    output : path
        The PDF file to write (its folder must exist).
    program : {"pdflatex", "latexmk"}, optional
        Force one program.
    timeout : float
        Seconds before the compilation is abandoned.

    Returns
    -------
    pathlib.Path
        ``output``.

    Raises
    ------
    MissingDependencyError
        Neither program is installed (the message names them).
    LoopsolveError
        Compilation failed (the message quotes the error lines of the TeX log), or
        ``output`` cannot be written.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from loopsolve.output.latex import write_pdf
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "fourbar.pdf"
    >>> try:
    ...     out = write_pdf(ls.fourbar(r1=60, r2=25, r3=70, r4=45).to_latex(), path)
    ... except ls.MissingDependencyError:   # no TeX installed here
    ...     out = None
    >>> out is None or out.read_bytes()[:5] == b"%PDF-"
    True
    """
    if "\\documentclass" not in tex:
        tex = _document("Kinematic derivation", tex)
    name, exe = _find_program(program)
    output = Path(output)
    with tempfile.TemporaryDirectory(prefix="loopsolve-tex-") as tmp:
        src = Path(tmp) / "derivation.tex"
        src.write_text(tex, encoding="utf-8")
        if name == "latexmk":
            cmd = [exe, "-pdf", "-interaction=nonstopmode", "-halt-on-error", "-no-shell-escape", src.name]
        else:
            cmd = [exe, "-interaction=nonstopmode", "-halt-on-error", "-no-shell-escape", src.name]
        try:
            proc = subprocess.run(cmd, cwd=tmp, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                  stderr=subprocess.STDOUT, timeout=timeout, check=False)
        except subprocess.TimeoutExpired:
            raise LoopsolveError(f"{name} did not finish within {timeout:g} s; the document was not compiled")
        pdf = Path(tmp) / "derivation.pdf"
        if proc.returncode != 0 or not pdf.exists():
            log_file = Path(tmp) / "derivation.log"
            log = (log_file.read_text(encoding="utf-8", errors="replace") if log_file.exists()
                   else proc.stdout.decode("utf-8", errors="replace"))
            raise LoopsolveError(f"{name} failed (exit status {proc.returncode}) compiling the LaTeX "
                                 f"document:\n{_log_excerpt(log)}")
        try:
            shutil.copyfile(pdf, output)
        except OSError as exc:
            raise LoopsolveError(f"cannot write the PDF to {str(output)!r}: {exc.strerror or exc}") from None
    return output
