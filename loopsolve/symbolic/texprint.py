"""LaTeX in the notation of the textbook notes: names, the sympy printer, line layout and document blocks.

:class:`LatexPrinter` prints sympy expressions as the notes write them: ``theta2`` → θ₂,
``r_AB`` → r_{AB}, rate symbols ``theta3__d1``/``__d2``/``__d3`` → θ̇₃, θ̈₃, θ⃛₃, ``\\sin\\theta_2``
without parentheses around a single symbol, and in a degree model the angle constants inside
sin/cos as degrees (``\\cos(\\theta_4 + 30^\\circ)`` rather than ``\\cos(\\theta_4 + \\pi/6)``).
sympy folds ``cos(θ − 20°)`` into ``sin(θ + 70°)``; the printer writes such terms back in terms
of the declared vector angles. The layout helpers estimate the printed width of LaTeX text and
break long sums over lines (continuation lines keep their sign). :mod:`loopsolve.output.latex` and
:mod:`loopsolve.output.latex_dynamics` build the document from these pieces: the blocks :class:`Section`,
:class:`Text`, :class:`Eqs` and :class:`Table`, text escaped by :func:`escape`, numbers and units
typeset by :func:`tex_number` and :func:`tex_unit`.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass

import sympy as sp
from sympy.printing.latex import LatexPrinter as _SympyLatexPrinter


__all__ = ["LatexPrinter", "symbol_latex", "vector_latex"]


# ============================================================================ names

_GREEK = frozenset(
    "alpha beta gamma delta epsilon varepsilon zeta eta theta vartheta iota kappa mu nu xi pi "
    "varpi rho varrho sigma varsigma tau upsilon phi varphi chi psi omega".split()
)
_GREEK_UPPER = frozenset("Gamma Delta Theta Xi Pi Sigma Upsilon Phi Psi Omega".split())
# amsmath's \dddot sets the subscript far from its base; three dots over the letter look right
ACCENT = {1: r"\dot", 2: r"\ddot", 3: r"\overset{\ldots}"}
_RATE_RE = re.compile(r"^(?P<base>.+)__d(?P<order>[123])$")
# kinematic coefficients of loopsolve.dynamics.eom: name__p1 = dq/dx (q'), name__p2 = d²q/dx² (q'')
_PRIME_RE = re.compile(r"^(?P<base>.+)__p(?P<order>[12])$")


def _word(text: str) -> str:
    """One piece of a name: Greek letters by name, words upright, letters/digits as they are."""
    if text in _GREEK or text in _GREEK_UPPER:
        return "\\" + text
    if re.fullmatch(r"[a-z]{2,}[0-9]*", text):  # a word (crank, link5): upright
        return r"\mathrm{%s}" % text
    return text


def _split_name(name: str) -> tuple[str, str | None]:
    """``theta2`` → (``\\theta``, ``2``); ``r_AB`` → (``r``, ``AB``); ``rAB`` → (``r``, ``AB``)."""
    parts = [p for p in name.split("_") if p]
    head, subs = parts[0], parts[1:]
    if head[0].islower():
        m = re.match(r"[a-z]+", head)
    else:
        m = re.match(r"[A-Za-z]+", head)
        if m and m.end() > 1 and m.group(0) not in _GREEK_UPPER and head[1:m.end()].islower():
            m = re.match(r"[A-Z]", head)  # "Rab" -> R_{ab}
    base = m.group(0)
    tail = head[m.end():]
    pieces = ([tail] if tail else []) + subs
    sub = ",".join(_word(p) for p in pieces) if pieces else None
    return _word(base), sub


def symbol_latex(name: str) -> str:
    """LaTeX for a variable or parameter name, in textbook notation.

    A leading lower-case word is the base (Greek by name, other words upright); what follows
    it — digits, capitals, or parts after underscores — is the subscript. Rate symbols of
    :mod:`loopsolve.symbolic.loop_equations` (``name__d1``, ``__d2``, ``__d3``) get one, two or three dots.

    Examples
    --------
    >>> from loopsolve.output.latex import symbol_latex
    >>> symbol_latex("theta2"), symbol_latex("r_AB"), symbol_latex("phi")
    ('\\\\theta_{2}', 'r_{AB}', '\\\\phi')
    >>> symbol_latex("theta3__d2"), symbol_latex("s_1__d1")
    ('\\\\ddot{\\\\theta}_{3}', '\\\\dot{s}_{1}')
    >>> symbol_latex("theta3__p1"), symbol_latex("theta3__p2")  # kinematic coefficients dθ₃/dx, d²θ₃/dx²
    ("\\\\theta'_{3}", "\\\\theta''_{3}")
    >>> symbol_latex("theta_in"), symbol_latex("AB")
    ('\\\\theta_{\\\\mathrm{in}}', 'AB')
    """
    m = _RATE_RE.match(name)
    order = 0
    if m:
        name, order = m.group("base"), int(m.group("order"))
    p = _PRIME_RE.match(name)
    if p:
        base, sub = _split_name(p.group("base"))
        base += "'" * int(p.group("order"))
        return base if sub is None else "%s_{%s}" % (base, sub)
    base, sub = _split_name(name)
    if order:
        base = "%s{%s}" % (ACCENT[order], base)
    return base if sub is None else "%s_{%s}" % (base, sub)


def vector_latex(name: str) -> str:
    """LaTeX for a vector name: an arrow over the base letter (``r2`` → ``\\vec{r}_{2}``).

    Examples
    --------
    >>> from loopsolve.output.latex import vector_latex
    >>> vector_latex("r2"), vector_latex("rAB"), vector_latex("AB")
    ('\\\\vec{r}_{2}', '\\\\vec{r}_{AB}', '\\\\overrightarrow{AB}')
    """
    base, sub = _split_name(name)
    single = len(base) == 1 or (base.startswith("\\") and not base.startswith(r"\mathrm"))
    arrow = r"\vec{%s}" % base if single else r"\overrightarrow{%s}" % base
    return arrow if sub is None else "%s_{%s}" % (arrow, sub)


# ============================================================================ printer


class DegreeConstant(sp.Symbol):
    """A constant angle printed in degrees (``30^\\circ``); only ever used for printing."""


def _degree_text(value: float) -> str:
    """Degrees to 6 significant digits (``30``, ``12.5``, ``5.31978 \\times 10^{-6}``)."""
    v = round(value, 9)
    if float(v).is_integer():
        return str(int(v))
    text = "%.6g" % v
    if "e" in text:
        mant, exp = text.split("e")
        return r"%s \times 10^{%d}" % (mant, int(exp))
    return text


def _to_degrees(arg: sp.Expr) -> sp.Expr:
    """Replace the rational/float multiples of π in a sum by :class:`DegreeConstant` terms."""
    out = []
    for t in sp.Add.make_args(arg):
        c = t / sp.pi
        if t.has(sp.pi) and c.is_number and c.is_real:
            deg = float(c) * 180.0
            sym = DegreeConstant(_degree_text(abs(deg)))
            out.append(-sym if deg < 0 else sym)
        else:
            out.append(t)
    return sp.Add(*out, evaluate=False) if len(out) > 1 else out[0]


_TRIG = (sp.sin, sp.cos, sp.tan)


class LatexPrinter(_SympyLatexPrinter):
    """sympy's LaTeX printer with the notation of the kinematics notes.

    Settings (besides sympy's): ``degrees`` — print the π-multiples inside sin/cos/tan as
    degrees (for degree models); ``angles`` — the declared vector angles (radians): sympy writes
    cos(θ − 20°) as sin(θ + 70°), the printer writes it back in terms of the declared angle.
    Matrices print as ``bmatrix``.

    Examples
    --------
    >>> import sympy as sp
    >>> from loopsolve.output.latex import LatexPrinter
    >>> t3, w3, r3 = sp.symbols("theta3 theta3__d1 r3")
    >>> LatexPrinter().doprint(-r3 * w3**2 * sp.cos(t3))
    '- r_{3} \\\\dot{\\\\theta}_{3}^{2} \\\\cos\\\\theta_{3}'
    >>> LatexPrinter({"degrees": True}).doprint(sp.sin(t3 + sp.pi / 6))
    '\\\\sin(\\\\theta_{3} + 30^{\\\\circ})'
    >>> sp.cos(t3 - sp.pi / 9)
    sin(theta3 + 7*pi/18)
    >>> LatexPrinter({"degrees": True, "angles": (t3 - sp.pi / 9,)}).doprint(sp.cos(t3 - sp.pi / 9))
    '\\\\cos(\\\\theta_{3} - 20^{\\\\circ})'
    """

    _default_settings = {
        **_SympyLatexPrinter._default_settings,
        "degrees": False,
        "angles": (),
        "mat_str": "bmatrix",
        "mat_delim": "",
    }

    def doprint(self, expr):
        return super().doprint(self.prepare(expr))

    def prepare(self, expr):
        """The expression as it will be printed: trig arguments restored to the declared angles
        (``angles`` setting) and degree constants substituted (``degrees`` setting)."""
        if isinstance(expr, sp.MatrixBase):
            return expr.applyfunc(self.prepare)
        if not isinstance(expr, sp.Basic):
            return expr
        if self._settings["angles"]:
            expr = expr.replace(lambda e: isinstance(e, (sp.sin, sp.cos)), self._declared_angle)
        if self._settings["degrees"]:
            expr = expr.replace(lambda e: isinstance(e, _TRIG),
                                lambda e: e.func(_to_degrees(e.args[0]), evaluate=False))
        return expr

    def _declared_angle(self, f):
        """sympy folds cos(θ − 20°) into sin(θ + 70°): write it back in terms of a declared angle.

        When the argument differs from a declared angle p by n·π/2, sin/cos of it is ±sin p or
        ±cos p (kept unevaluated)."""
        arg = f.args[0]
        if arg.is_Symbol or any(arg == p for p in self._settings["angles"]):
            return f  # a plain variable or a declared angle as it is (another may differ by a quarter turn)
        for p in self._settings["angles"]:
            d = arg - p
            if d == 0 or not d.is_number:
                continue
            n = float(d / (sp.pi / 2))
            if abs(n - round(n)) > 1e-12:  # sympy's fold is exact up to float round-off
                continue
            n = int(round(n)) % 4
            # sin(p + nπ/2), cos(p + nπ/2) for n = 0..3
            table = {0: (1, sp.sin, 1, sp.cos), 1: (1, sp.cos, -1, sp.sin),
                     2: (-1, sp.sin, -1, sp.cos), 3: (-1, sp.cos, 1, sp.sin)}[n]
            sign, func = (table[0], table[1]) if isinstance(f, sp.sin) else (table[2], table[3])
            return sign * func(p, evaluate=False)
        return f

    def angle(self, expr) -> str:
        """Print an angle expression (a whole angle, not a trig argument): degrees when asked."""
        if self._settings["degrees"]:
            expr = _to_degrees(sp.sympify(expr))
        return self.doprint(expr)

    def parenthesize_super(self, s):
        """Braces around a base that carries a superscript or a prime (``{\\theta'_{3}}^{2}``)."""
        return "{%s}" % s if ("^" in s or "'" in s) else s

    # ---- symbols
    def _print_Symbol(self, expr, style="plain"):
        name = self._settings["symbol_names"].get(expr)
        if name is not None:
            return name
        return symbol_latex(expr.name)

    def _print_DegreeConstant(self, expr, style="plain"):
        if "times" in expr.name:
            return "(%s)^{\\circ}" % expr.name
        return "%s^{\\circ}" % expr.name

    # ---- trigonometric functions: \sin\theta_2, \sin^{2}\theta_2, \sin\left(\theta_2 - \theta_3\right)
    def _trig(self, name, expr, exp=None):
        arg = expr.args[0]
        head = "\\" + name + ("^{%s}" % exp if exp is not None else "")
        inner = self._print(arg)
        if arg.is_Symbol and not isinstance(arg, DegreeConstant):
            return head + inner if inner.startswith("\\") else head + " " + inner
        if isinstance(arg, sp.Add):
            terms = self.signed_terms(arg, prepared=True)
            first = next((i for i, (neg, _) in enumerate(terms) if not neg), 0)
            inner = join_terms(terms[first:first + 1] + terms[:first] + terms[first + 1:])
        return r"%s(%s)" % (head, inner)

    def _print_sin(self, expr, exp=None):
        return self._trig("sin", expr, exp)

    def _print_cos(self, expr, exp=None):
        return self._trig("cos", expr, exp)

    def _print_tan(self, expr, exp=None):
        return self._trig("tan", expr, exp)

    # ---- products: number, lengths/parameters, rates, then sin/cos (r_2 \dot\theta_2 \sin\theta_2)
    @staticmethod
    def _factor_key(f):
        base = f.base if isinstance(f, sp.Pow) else f
        if f.is_Number:
            return (0, 0, "")
        if isinstance(base, sp.Symbol):
            m = _RATE_RE.match(base.name) or _PRIME_RE.match(base.name)
            if m:
                return (2, int(m.group("order")), m.group("base"))
            return (1, 0, base.name)
        if isinstance(base, _TRIG):
            return (4, 0, str(base))
        return (3, 0, str(f))

    def _print_Mul(self, expr):
        args = expr.args
        if args[0] is sp.S.One or any(isinstance(a, sp.Number) for a in args[1:]):
            return super()._print_Mul(expr)  # unevaluated Mul: printed as given
        tex = ""
        if expr.could_extract_minus_sign():
            expr = -expr
            if expr.is_Add:
                return "- (%s)" % self._print(expr)
            tex = "- "
        numer, denom = sp.fraction(expr, exact=True)
        if denom is sp.S.One:
            return tex + self._product(expr)
        return tex + r"\frac{%s}{%s}" % (self._product(numer), self._product(denom))

    def _product(self, expr) -> str:
        if not expr.is_Mul:
            return self._print(expr)
        args = sorted(expr.args, key=self._factor_key)
        out, last = "", ""
        for i, term in enumerate(args):
            t = self._print(term)
            if self._needs_mul_brackets(term, first=(i == 0), last=(i == len(args) - 1)):
                t = r"\left(%s\right)" % t
            if out:
                out += r" \cdot " if (re.search(r"[0-9][}]*\s*$", last) and re.match(r"\s*[{]*[0-9-]", t)) else " "
            out += t
            last = t
        return out

    # ---- sums: degree constants last (theta_4 + 30°); terms available for line breaking
    def ordered_terms(self, expr) -> list:
        terms = list(self._as_ordered_terms(expr)) if isinstance(expr, sp.Add) else [expr]
        deg = [t for t in terms if t.atoms(DegreeConstant) and not (t.free_symbols - t.atoms(DegreeConstant))]
        return [t for t in terms if t not in deg] + deg

    def _print_Add(self, expr, order=None):
        return join_terms(self.signed_terms(expr, prepared=True))

    def signed_terms(self, expr, *, prepared: bool = False) -> list[tuple[bool, str]]:
        """``expr`` as a list of ``(negative, tex)`` terms, in printing order."""
        if not prepared:
            expr = self.prepare(sp.sympify(expr))
        out = []
        for term in self.ordered_terms(expr):
            neg = term.could_extract_minus_sign()
            if neg:
                term = -term
            tex = self._print(term)
            if self._needs_add_brackets(term):
                tex = r"\left(%s\right)" % tex
            out.append((neg, tex))
        return out


def join_terms(terms: Sequence[tuple[bool, str]]) -> str:
    """Signed terms ``(negative, tex)`` written as one sum (``0`` when there are none)."""
    if not terms:
        return "0"
    text = ""
    for i, (neg, tex) in enumerate(terms):
        if i == 0:
            text = ("- " if neg else "") + tex
        else:
            text += (" - " if neg else " + ") + tex
    return text


# ============================================================================ layout helpers

#: width of a display line, in the units of :func:`tex_width` (one unit ≈ 0.19 cm, an italic
#: letter at 11 pt; the text is 16.6 cm wide on A4 with 2.2 cm margins)
BUDGET = 80.0
#: an empty line in a list of equation lines: a wider gap in the rendered block
GAP = ""


def _group_end(s: str, start: int) -> int:
    """Index just past the brace group that opens at ``s[start] == "{"``."""
    depth = 0
    for i in range(start, len(s)):
        depth += {"{": 1, "}": -1}.get(s[i], 0)
        if depth == 0:
            return i + 1
    return len(s)


def tex_width(tex: str) -> float:
    """Rough printed width of a math string (a letter ≈ 1, sub/superscripts ≈ 0.7, operators ≈ 2;
    a fraction is as wide as the wider of its numerator and denominator)."""
    i = tex.find("\\frac{")
    if i >= 0:
        a_end = _group_end(tex, i + 5)
        b_end = _group_end(tex, a_end)
        frac = max(tex_width(tex[i + 6:a_end - 1]), tex_width(tex[a_end + 1:b_end - 1])) + 1.0
        return tex_width(tex[:i]) + frac + tex_width(tex[b_end:])
    s = re.sub(r"\\(left|right)\b", "", tex)
    s = re.sub(r"\\begin\{[a-z]+\}|\\end\{[a-z]+\}", "", s)
    s = re.sub(r"\\(mathrm|mathbf|vec|dot|ddot|overset|ldots|hat|overrightarrow|boldsymbol|text)\b", "", s)
    s = re.sub(r"\\(sin|cos|tan)", "sin", s)
    s = re.sub(r"\\(quad|qquad)", "xx", s)
    s = re.sub(r"\\[,;!]", "", s)
    s = re.sub(r"\\[A-Za-z]+", "x", s)
    width, depth, stack = 0.0, 0, []
    i = 0
    while i < len(s):
        ch = s[i]
        if ch in "_^" and i + 1 < len(s) and s[i + 1] == "{":
            stack.append(True)
            depth += 1
            i += 2
            continue
        if ch == "{":
            stack.append(False)
        elif ch == "}":
            if stack and stack.pop():
                depth -= 1
        elif ch in "+-=" and depth == 0:
            width += 2.0
        elif ch == "&":
            pass
        elif not ch.isspace():
            width += 0.7 if depth else 1.0
        i += 1
    return width


def matrix_width(cells: list[list[str]]) -> float:
    """Rough printed width of a matrix of math cells (see :func:`tex_width`)."""
    if not cells:
        return 0.0
    cols = len(cells[0])
    return sum(max(tex_width(row[j]) for row in cells) for j in range(cols)) + 2.5 * cols + 1.5


def break_terms(terms: Sequence[tuple[bool, str]], budget: float) -> list[str]:
    """Pack signed terms greedily into lines no wider than ``budget`` (continuation lines start
    with their sign)."""
    lines: list[str] = []
    cur = ""
    for neg, tex in terms:
        if not cur:
            cur = (("- " if neg else "") if not lines else ("{}- " if neg else "{}+ ")) + tex
            continue
        piece = (" - " if neg else " + ") + tex
        if tex_width(cur + piece) > budget:
            lines.append(cur)
            cur = ("{}- " if neg else "{}+ ") + tex
        else:
            cur += piece
    if cur or not lines:
        lines.append(cur or "0")
    return lines


def eq_lines(lhs: str, rhs_terms: Sequence[tuple[bool, str]], budget: float = BUDGET) -> list[str]:
    """``lhs &= rhs`` as align lines, the right side broken over lines when too wide."""
    room = max(budget - tex_width(lhs) - 3.0, 0.45 * budget)
    parts = break_terms(rhs_terms, room)
    return ["%s &= %s" % (lhs, parts[0])] + [r"&\quad %s" % p for p in parts[1:]]


def balance_block(pairs, budget: float = BUDGET) -> list[str]:
    """Align lines for equations ``lhs = rhs`` whose sides are both sums (the loop equations).

    When they all fit, they align on ``=``. Otherwise every equation of the block is set as
    its left side on one line (or more) and ``= right side`` below, all flush on one column,
    so that no line is pushed past the margin by the alignment."""
    texts = [(join_terms(lt), join_terms(rt)) for lt, rt in pairs]
    widest_lhs = max(tex_width(lhs) for lhs, _ in texts)
    if all(widest_lhs + tex_width(rhs) + 3 <= budget for _, rhs in texts):
        return ["%s &= %s" % (lhs, rhs) for lhs, rhs in texts]
    lines: list[str] = []
    for lt, rt in pairs:
        if lines:
            lines.append(GAP)
        left = break_terms(lt, budget - 4)
        right = break_terms(rt, budget - 6)
        lines += ["& " + left[0]] + [r"&\quad %s" % p for p in left[1:]]
        lines += ["&= " + right[0]] + [r"&\quad %s" % p for p in right[1:]]
    return lines


_TEX_SPECIAL = {"\\": r"\textbackslash{}", "&": r"\&", "%": r"\%", "$": r"\$", "#": r"\#", "_": r"\_",
                "{": r"\{", "}": r"\}", "~": r"\textasciitilde{}", "^": r"\textasciicircum{}"}


def escape(text: str) -> str:
    """Plain text for LaTeX text mode (special characters escaped, non-ASCII dropped to '?')."""
    out = "".join(_TEX_SPECIAL.get(c, c) for c in str(text))
    return out.encode("ascii", "replace").decode("ascii")


def tex_number(v) -> str:
    """A value for a table, in math mode (6 significant digits, powers of ten written out)."""
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return r"\text{--}"
    v = float(v)
    if v == 0:
        return "0"
    s = "%.6g" % v
    if "e" in s:
        mant, exp = s.split("e")
        return r"%s \times 10^{%d}" % (mant, int(exp))
    return s


def tex_unit(label: str) -> str:
    """A unit label (``deg``, ``rad/s^2``, ``mm/s``) in math mode, with its leading space."""
    if not label:
        return ""
    if label == "deg":
        return r"^{\circ}"
    label = re.sub(r"\^(\d)", r"^{\1}", label)
    return r"\,\mathrm{%s}" % label


# ============================================================================ the document model
# (built by latex.py and latex_dynamics.py, rendered by latex.py)


@dataclass(frozen=True)
class Section:
    """A section heading of a document."""
    title: str


@dataclass(frozen=True)
class Text:
    """A paragraph of a document."""
    text: str  # LaTeX text mode (inline math with $...$)


@dataclass(frozen=True)
class Eqs:
    """A block of aligned equations of a document."""
    lines: tuple[str, ...]  # align lines (with &)


@dataclass(frozen=True)
class Table:
    """A table of a document: text-mode header, math-mode rows."""
    header: tuple[str, ...]  # text mode
    rows: tuple[tuple[str, ...], ...]  # math mode cells
    align: str
    equation: bool = False  # kept in snippets (the numeric table asked for with `at`)
