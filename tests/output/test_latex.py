"""Tests of the LaTeX/PDF export (:mod:`loopsolve.output.latex`).

The exported matrices are checked against an independent derivation written by hand from the
lecture notes (../shared/seeds/000_9c80aae809135345.txt): the component form of each vector's
position, velocity, acceleration and jerk, summed over the loop. Documents of every model in
``models/`` are compiled with pdflatex and read back with poppler's pdftotext/pdftoppm.
"""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest
import sympy as sp

import loopsolve as ls
from loopsolve import cli
from loopsolve.errors import LoopsolveError, MissingDependencyError
from loopsolve.output.latex import LatexPrinter, symbol_latex, to_latex, vector_latex, velocity_solution, write_pdf

from support.latex import pdf_text, require

MODELS = sorted(ls.models_dir().glob("*.toml"))


def read_pgm(path: Path) -> tuple[int, int, bytes]:
    """Width, height and pixels of a binary (P5) greyscale PGM with maxval < 256."""
    data = path.read_bytes()
    fields, pos = [], 0
    while len(fields) < 4:
        while data[pos:pos + 1].isspace():
            pos += 1
        if data[pos:pos + 1] == b"#":
            pos = data.index(b"\n", pos) + 1
            continue
        end = pos
        while not data[end:end + 1].isspace():
            end += 1
        fields.append(data[pos:end])
        pos = end
    magic, w, h, maxval = fields[0], int(fields[1]), int(fields[2]), int(fields[3])
    assert magic == b"P5" and maxval < 256
    pixels = data[pos + 1:pos + 1 + w * h]
    assert len(pixels) == w * h
    return w, h, pixels


def first_page_pixels(pdf: Path, tmp: Path) -> bytes:
    subprocess.run(["pdftoppm", "-gray", "-r", "40", "-f", "1", "-l", "1", str(pdf), str(tmp / "page")],
                   check=True, capture_output=True)
    (pgm,) = tmp.glob("page*.pgm")
    return read_pgm(pgm)[2]


# ----------------------------------------------------------------------------- every model


@pytest.fixture(scope="module", params=MODELS, ids=lambda p: p.stem)
def document(request):
    """(mechanism, LaTeX document with the numeric table at the declared input): once per model."""
    mech = ls.load(request.param)
    return mech, to_latex(mech, at=mech.solve().input_value)


@pytest.fixture(scope="module")
def exported(document, tmp_path_factory):
    """(mechanism, LaTeX, compiled PDF): each model compiled once."""
    require("pdflatex")
    mech, tex = document
    return mech, tex, write_pdf(tex, tmp_path_factory.mktemp("pdf") / "derivation.pdf")


_TEXT_GREEK = {"theta": "θ", "phi": "ϕ", "beta": "β", "alpha": "α", "gamma": "γ", "psi": "ψ"}


def text_of(name: str) -> str:
    """How pdftotext shows a symbol: Greek letter by name, subscript parts run on and separated
    by commas (theta2 -> θ2, r_lever_D -> rlever,D)."""
    head, *parts = name.split("_")
    m = re.match(r"([a-z]+|[A-Za-z]+)(.*)", head)
    base, tail = m.group(1), m.group(2)
    return _TEXT_GREEK.get(base, base) + ",".join(([tail] if tail else []) + parts)


class TestEveryModel:
    def test_compiles_to_pdf(self, exported):
        _, tex, pdf = exported
        assert tex.startswith("\\documentclass")
        assert pdf.read_bytes()[:5] == b"%PDF-"

    def test_pdftotext_shows_the_loop_equation_terms(self, exported):
        require("pdftotext")
        mech, _, pdf = exported
        text = pdf_text(pdf)
        for heading in ("Vector loops and position equations", "Velocity equation", "Acceleration equation",
                        "Jerk equation", "Numeric solution", mech.name):
            assert heading in text
        checked = 0
        for loop in mech.loops:
            for _, vname in loop.terms:
                spec = mech.spec["vectors"][vname]
                length, angle = str(spec.get("length", "")), str(spec.get("angle", ""))
                if (re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", length) and angle in {v.name for v in mech.variables}
                        and not spec.get("offset")):
                    # the x and y terms of the scalar loop equations: r2 cos θ2, r2 sin θ2
                    for fn in ("cos", "sin"):
                        assert f"{text_of(length)} {fn} {text_of(angle)}" in text, (vname, fn)
                    checked += 1
        # a link of named length turning with its own variable: two in a four-bar; one where the other
        # bars of the loop turn with a cam's lift (a rocker at gamma0 - psi) or slide
        assert checked >= 1
        for v in mech.variables:
            assert text_of(v.name) in text
        if mech.pairs is not None:  # each higher pair is a row of Φ, named by its key
            assert "Constraints and higher pairs" in text
            for pair in (*mech.pairs.constraints, *mech.pairs.gears, *mech.pairs.cams):
                # (TeX draws the underscore of \_ as a rule: pdftotext reads it as a space)
                assert f"{pair.key.replace('_', ' ')}:" in text, pair.key

    def test_cam_law_joins_are_printed(self, document):
        """A cam's row is its law piecewise over one turn: each segment's end (its join with the next)
        appears as a bound of the cam angle, a multiple of π written here from the declared ``to``."""
        import sympy as sp

        mech, tex = document
        cams = mech.pairs.cams if mech.pairs is not None else ()
        for cam in cams:
            for seg in cam.segments[:-1]:  # the last piece is the 'otherwise' of the cases
                to = float(mech.spec["cams"][cam.name]["law"][cam.segments.index(seg)]["to"])
                bound = sp.nsimplify(to / 180) * sp.pi if mech.units.angle == "deg" else sp.nsimplify(to)
                assert sp.latex(bound) in tex, (cam.key, to)

    def test_first_page_is_not_blank(self, exported, tmp_path):
        require("pdftoppm")
        pixels = first_page_pixels(exported[2], tmp_path)
        dark = sum(1 for p in pixels if p < 128)
        assert len(set(pixels)) > 8  # anti-aliased glyphs, not a flat page
        assert 0.002 < dark / len(pixels) < 0.5

    def test_no_sympy_artefacts(self, document):
        _, tex = document
        for bad in ("Derivative", "(t)", "__d", "\\sin\\left(", "\\cos{", "\\sin{", "\\dddot", "e-0", "e+0"):
            assert bad not in tex, bad
        assert not re.search(r"(?<!\\)theta", tex)  # every theta is \theta, none a raw name


# ----------------------------------------------------------------------------- hand derivation

t2, t3, t4, x = sp.symbols("theta2 theta3 theta4 x", real=True)
w2, w3, w4, xd = sp.symbols("theta2__d1 theta3__d1 theta4__d1 x__d1", real=True)
a2, a3, a4, xdd = sp.symbols("theta2__d2 theta3__d2 theta4__d2 x__d2", real=True)
j2, j3, j4, xddd = sp.symbols("theta2__d3 theta3__d3 theta4__d3 x__d3", real=True)
r1, r2, r3, r4, e = sp.symbols("r1 r2 r3 r4 e", real=True)


def rotating(r, th, w, a, j):
    """Position, velocity, acceleration, jerk (x, y) of r·e^{jθ} with r constant (the notes' forms)."""
    c, s = sp.cos(th), sp.sin(th)
    return (
        (r * c, r * s),
        (-r * w * s, r * w * c),
        (-r * a * s - r * w**2 * c, r * a * c - r * w**2 * s),
        (-r * j * s - 3 * r * w * a * c + r * w**3 * s, r * j * c - 3 * r * w * a * s - r * w**3 * c),
    )


def sliding_x(u, ud, udd, uddd):
    """A vector of variable length u along +x (the slider's r1)."""
    return ((u, 0), (ud, 0), (udd, 0), (uddd, 0))


def rhs_by_hand(loop, unknown_rates):
    """b_k = −(k-th derivative of the loop) with the unknowns' k-th rates set to zero."""
    out = []
    for k in (1, 2, 3):
        zero = {s: 0 for s in unknown_rates[k - 1]}
        out.append(sp.Matrix([-sp.expand(sum(sign * v[k][c] for sign, v in loop)).xreplace(zero)
                              for c in (0, 1)]))
    return out


class TestAgainstHandDerivation:
    """Φ_q and b_1, b_2, b_3 equal the notes' forms, and the document prints them."""

    def fourbar(self):
        mech = ls.load(ls.models_dir() / "thesis_crank_rocker.toml")
        jac = sp.Matrix([[-r3 * sp.sin(t3), r4 * sp.sin(t4)], [r3 * sp.cos(t3), -r4 * sp.cos(t4)]])
        loop = [(1, rotating(r2, t2, w2, a2, j2)), (1, rotating(r3, t3, w3, a3, j3)),
                (-1, rotating(r4, t4, w4, a4, j4)), (-1, ((r1, 0), (0, 0), (0, 0), (0, 0)))]
        rhs = rhs_by_hand(loop, [(w3, w4), (a3, a4), (j3, j4)])
        return mech, jac, rhs

    def slider_crank(self):
        """Prob 2 of the notes: r2 + r3 = r1 + r4 with r1 = x along the slide, r4 = e at 90°."""
        mech = ls.load(ls.models_dir() / "prob2_offset_slider_crank.toml")
        jac = sp.Matrix([[-r3 * sp.sin(t3), -1], [r3 * sp.cos(t3), 0]])
        loop = [(1, rotating(r2, t2, w2, a2, j2)), (1, rotating(r3, t3, w3, a3, j3)),
                (-1, sliding_x(x, xd, xdd, xddd)), (-1, ((0, e), (0, 0), (0, 0), (0, 0)))]
        rhs = rhs_by_hand(loop, [(w3, xd), (a3, xdd), (j3, xddd)])
        return mech, jac, rhs

    def test_notes_acceleration_rhs_is_what_the_hand_helpers_give(self):
        """The helpers reproduce the notes' printed acceleration equation of the four-bar."""
        _, _, (_, b2, _) = self.fourbar()
        notes_x = r2 * a2 * sp.sin(t2) + r2 * w2**2 * sp.cos(t2) + r3 * w3**2 * sp.cos(t3) - r4 * w4**2 * sp.cos(t4)
        assert sp.simplify(b2[0] - notes_x) == 0

    @pytest.mark.parametrize("case", ["fourbar", "slider_crank"])
    def test_matrices_equal_the_hand_derivation(self, case):
        mech, jac, rhs = getattr(self, case)()
        kin = mech.derive()
        assert sp.simplify(kin.jac - jac) == sp.zeros(2, 2)
        for k in range(3):
            assert sp.simplify(kin.rhs[k] - rhs[k]) == sp.zeros(2, 1), f"b{k + 1}"

    @pytest.mark.parametrize("case", ["fourbar", "slider_crank"])
    def test_document_prints_the_hand_matrices(self, case):
        mech, jac, rhs = getattr(self, case)()
        tex = to_latex(mech)
        p = LatexPrinter({"degrees": True})
        for i in range(2):
            assert " & ".join(p.doprint(jac[i, j]) for j in range(2)) in tex
            assert p.doprint(sp.expand(rhs[0][i])) in tex
            for k in (1, 2):
                for _, term in p.signed_terms(sp.expand(rhs[k][i])):
                    assert term in tex

    def test_fourbar_velocity_solution_is_the_notes_closed_form(self):
        mech, jac, rhs = self.fourbar()
        theta4_dot = r2 * sp.sin(t2 - t3) / (r4 * sp.sin(t4 - t3)) * w2
        theta3_dot = r2 * sp.sin(t2 - t4) / (r3 * sp.sin(t4 - t3)) * w2
        solved = jac.LUsolve(rhs[0])  # from the matrices the document prints
        assert sp.simplify(solved[1] - theta4_dot) == 0
        assert sp.simplify(solved[0] - theta3_dot) == 0
        sol = velocity_solution(mech.derive())
        assert sp.simplify(sol["theta4"] - theta4_dot) == 0
        assert sp.simplify(sol["theta3"] - theta3_dot) == 0
        # ... and the document writes it as the notes do
        tex = to_latex(mech)
        assert (r"\dot{\theta}_{4} &= \frac{r_{2} \sin(\theta_{2} - \theta_{3})}{r_{4} \sin(\theta_{4} - \theta_{3})}"
                r"\,\dot{\theta}_{2}") in tex
        assert (r"\dot{\theta}_{3} &= \frac{r_{2} \sin(\theta_{2} - \theta_{4})}{r_{3} \sin(\theta_{4} - \theta_{3})}"
                r"\,\dot{\theta}_{2}") in tex

    def test_slider_crank_velocity_solution(self):
        mech, _, _ = self.slider_crank()
        sol = velocity_solution(mech.derive())
        theta3_dot = -r2 * sp.cos(t2) / (r3 * sp.cos(t3)) * w2  # y component: r2 θ̇2 c2 + r3 θ̇3 c3 = 0
        assert sp.simplify(sol["theta3"] - theta3_dot) == 0
        assert sp.simplify(sol["x"] - (-r2 * w2 * sp.sin(t2) - r3 * theta3_dot * sp.sin(t3))) == 0

    def test_velocity_solution_only_for_two_unknowns(self, sixbar):
        assert velocity_solution(sixbar.derive()) is None


# ----------------------------------------------------------------------------- notation


class TestNames:
    @pytest.mark.parametrize("name, tex", [
        ("theta2", r"\theta_{2}"), ("theta_2", r"\theta_{2}"), ("r_AB", "r_{AB}"), ("rAB", "r_{AB}"),
        ("phi", r"\phi"), ("beta", r"\beta"), ("alpha_off", r"\alpha_{\mathrm{off}}"), ("s", "s"),
        ("x_1", "x_{1}"), ("L1", "L_{1}"), ("AB", "AB"), ("r4d", "r_{4d}"), ("theta_in", r"\theta_{\mathrm{in}}"),
        ("crank", r"\mathrm{crank}"), ("Phi2", r"\Phi_{2}"), ("theta2_3", r"\theta_{2,3}"),
        ("r_lever_D", r"r_{\mathrm{lever},D}"), ("theta_link5", r"\theta_{\mathrm{link5}}"),
        ("theta3__d1", r"\dot{\theta}_{3}"), ("theta3__d2", r"\ddot{\theta}_{3}"),
        ("theta3__d3", r"\overset{\ldots}{\theta}_{3}"), ("s_1__d1", r"\dot{s}_{1}"), ("r_AB__d2", r"\ddot{r}_{AB}"),
    ])
    def test_symbol_latex(self, name, tex):
        assert symbol_latex(name) == tex

    @pytest.mark.parametrize("name, tex", [
        ("r2", r"\vec{r}_{2}"), ("r_AB", r"\vec{r}_{AB}"), ("AB", r"\overrightarrow{AB}"),
        ("crank", r"\overrightarrow{\mathrm{crank}}"), ("r4d", r"\vec{r}_{4d}"),
    ])
    def test_vector_latex(self, name, tex):
        assert vector_latex(name) == tex

    def test_printer_textbook_forms(self):
        p = LatexPrinter()
        rab, phi, phid, th3, th3d = sp.symbols("r_AB phi phi__d1 theta3 theta3__d2")
        assert p.doprint(phid * rab * sp.sin(phi)) == r"r_{AB} \dot{\phi} \sin\phi"
        assert p.doprint(-2 * th3d * rab * sp.cos(th3) ** 2) == r"- 2 r_{AB} \ddot{\theta}_{3} \cos^{2}\theta_{3}"
        assert p.doprint(sp.sin(phi - th3)) == r"\sin(\phi - \theta_{3})"
        assert p.doprint(sp.Matrix([[rab, 0], [0, phi]])) == r"\begin{bmatrix}r_{AB} & 0\\0 & \phi\end{bmatrix}"

    def test_degree_constants(self):
        th = sp.Symbol("theta4")
        deg, rad = LatexPrinter({"degrees": True}), LatexPrinter()
        assert deg.doprint(sp.cos(th + sp.pi / 6)) == r"\cos(\theta_{4} + 30^{\circ})"
        assert deg.doprint(sp.cos(th - sp.pi / 9)) == r"\sin(\theta_{4} + 70^{\circ})"  # sympy's fold
        assert deg.doprint(sp.sin(th + sp.Float(12.5) * sp.pi / 180)) == r"\sin(\theta_{4} + 12.5^{\circ})"
        assert deg.angle(sp.pi / 2) == r"90^{\circ}"
        declared = LatexPrinter({"degrees": True, "angles": (th - sp.pi / 9, th + 2 * sp.pi / 3)})
        assert declared.doprint(sp.cos(th - sp.pi / 9)) == r"\cos(\theta_{4} - 20^{\circ})"
        assert declared.doprint(sp.diff(sp.cos(th - sp.pi / 9), th)) == r"- \sin(\theta_{4} - 20^{\circ})"
        assert declared.doprint(sp.sin(th + 2 * sp.pi / 3)) == r"\sin(\theta_{4} + 120^{\circ})"
        assert declared.doprint(sp.cos(th + 2 * sp.pi / 3)) == r"\cos(\theta_{4} + 120^{\circ})"
        assert rad.doprint(sp.cos(th + sp.pi / 6)) == r"\cos(\theta_{4} + \frac{\pi}{6})"


@pytest.fixture(scope="module")
def greek():
    """An inverted slider-crank with Greek, underscored and digit names and a variable-length vector."""
    b = ls.MechanismBuilder("Greek & underscore names #1", length_unit="mm", angle_unit="deg")
    b = b.parameter("r_AB", 100).parameter("d_0", 200).parameter("alpha_off", "15deg")
    b = b.variable("phi", input=True, guess=0).variable("beta", guess=63.4).variable("s_1", guess=223.6)
    b = b.vector("r_g", length="d_0", angle=90).vector("r_AB", length="r_AB", angle="phi")
    b = b.vector("r_s", length="s_1", angle="beta").vector("r_t", length=50, angle="beta + alpha_off")
    return b.loop("r_g + r_AB = r_s").point("A", "r_g + r_AB").point("T_1", "r_s + r_t").build()


@pytest.fixture(scope="module")
def sixbar():
    """Two loops, rigid offsets of −20° and +120° (sympy refolds both), a Cartesian ground vector."""
    b = ls.MechanismBuilder("Watt six-bar", length_unit="mm", angle_unit="deg")
    for n, v in dict(r1=60, r2=25, r3=70, r4=45, r4d=40, r5=60, r6=50).items():
        b = b.parameter(n, v)
    b = b.variable("theta2", input=True, guess=90).variable("theta3", guess=16).variable("theta4", guess=81)
    b = b.variable("theta5", guess=-20).variable("theta6", guess=80)
    b = b.vector("r1", length="r1", angle=0).vector("r2", length="r2", angle="theta2")
    b = b.vector("r3", length="r3", angle="theta3").vector("r4", length="r4", angle="theta4")
    b = b.vector("r4d", length="r4d", angle="theta4 - 20").vector("r5", length="r5", angle="theta5")
    b = b.vector("r6", length="r6", angle="theta6 + 120").vector("r7", x=120, y=-20)
    b = b.loop("r2 + r3 = r1 + r4").loop("r1 + r4d + r5 = r7 + r6", name="outer")
    return b.point("D", "r1 + r4d + r5").build()


class TestRendering:
    def test_greek_underscore_and_sliding_names(self, greek):
        tex = to_latex(greek, at=30)
        for piece in (r"\phi", r"\beta", r"r_{AB}", r"d_{0}", r"\alpha_{\mathrm{off}}", r"\dot{s}_{1}",
                      r"\ddot{s}_{1}", r"\dot{\beta}", r"\vec{r}_{AB}", r"s_{1}\,\mathrm{e}^{\mathrm{j}\beta}",
                      r"d_{0}\,\mathrm{e}^{\mathrm{j}90^{\circ}}", r"x_{T_{1}}", r"15^{\circ}",
                      r"\cos(\alpha_{\mathrm{off}} + \beta)", r"\& underscore names \#1"):
            assert piece in tex, piece
        # the Coriolis term of the sliding joint: 2 β̇ ṡ
        assert r"2 \dot{\beta} \dot{s}_{1} \sin\beta" in tex
        assert "__" not in tex and "Derivative" not in tex

    def test_greek_document_compiles(self, greek, tmp_path):
        require("pdflatex", "pdftotext")
        pdf = write_pdf(to_latex(greek, at=30), tmp_path / "greek.pdf")
        text = pdf_text(pdf)
        for piece in ("rAB cos ϕ = s1 cos β", "d0 + rAB sin ϕ = s1 sin β", "αoff"):
            assert piece in text, piece

    def test_multi_loop_offsets_and_cartesian_vectors(self, sixbar, tmp_path):
        tex = to_latex(sixbar)
        assert "Loop 2 (outer):" in tex and "Loop 1:" in tex
        assert r"r_{4d}\,\mathrm{e}^{\mathrm{j}\left(\theta_{4} - 20^{\circ}\right)}" in tex
        assert r"r_{6}\,\mathrm{e}^{\mathrm{j}\left(\theta_{6} + 120^{\circ}\right)}" in tex
        assert r"\left(120 - \mathrm{j}\,20\right)" in tex
        # sympy folds cos(θ4 − 20°) into sin(θ4 + 70°): printed with the declared angles again
        for piece in (r"r_{4d} \cos(\theta_{4} - 20^{\circ})", r"r_{4d} \sin(\theta_{4} - 20^{\circ})",
                      r"r_{6} \cos(\theta_{6} + 120^{\circ})", r"- r_{4d} \sin(\theta_{4} - 20^{\circ})"):
            assert piece in tex, piece
        assert r"\pi" not in tex and "70^{" not in tex and "30^{" not in tex
        assert r"\boldsymbol{\Phi}_{\mathbf{q}} &= \begin{bmatrix}" in tex  # 4×4: written out once
        require("pdflatex")
        assert write_pdf(tex, tmp_path / "six.pdf").stat().st_size > 1000

    def test_radian_model_prints_radians(self):
        b = ls.MechanismBuilder("radian four-bar", length_unit="m", angle_unit="rad")
        for n, v in dict(a=0.06, b=0.025, c=0.07, d=0.045).items():
            b = b.parameter(n, v)
        b = b.variable("theta2", input=True, guess=1.57).variable("theta3", guess=0.28)
        b = b.variable("theta4", guess=0.885)
        b = b.vector("r1", length="a", angle=0).vector("r2", length="b", angle="theta2")
        b = b.vector("r3", length="c", angle="theta3").vector("r4", length="d", angle="theta4 + pi/6")
        tex = to_latex(b.loop("r2 + r3 = r1 + r4").build(), at=1.57)
        assert r"d \cos(\theta_{4} + \frac{\pi}{6})" in tex
        assert "angles in radians" in tex and r"\circ" not in tex

    def test_long_sums_are_broken_over_lines(self, sixbar):
        tex = to_latex(sixbar)
        jerk = tex[tex.index("entries of $\\mathbf{b}_{3}$"):]
        b31 = jerk[jerk.index("b_{3,1} &="):jerk.index("b_{3,2}")]
        assert b31.count(r"&\quad {}") >= 1  # continuation line, sign kept
        for line in b31.split("\\\\"):
            assert line.count(r"\sin") + line.count(r"\cos") <= 6

    def test_numeric_table_matches_the_solver(self):
        mech = ls.load(ls.models_dir() / "thesis_crank_rocker.toml")
        tex = to_latex(mech, at=90)
        row = mech.solve(90).row()
        assert r"$\theta_{4}$ & $%s^{\circ}$" % ("%.6g" % row["theta4"]) in tex
        assert r"$%s\,\mathrm{rad/s}$" % ("%.6g" % row["theta4_vel"]) in tex
        assert r"$x_{C}$ & $%s\,\mathrm{mm}$" % ("%.6g" % row["C_x"]) in tex
        assert r"$x_{B}$ & $0\,\mathrm{mm}$" in tex  # cos 90° round-off shown as 0
        assert "Numeric solution" not in to_latex(mech)

    def test_numeric_table_unassemblable_input(self):
        mech = ls.load(ls.models_dir() / "example1_slider_crank.toml")
        with pytest.raises(ls.SolveError):
            to_latex(mech, input="r1", at=20)  # r1 > r2 + r3: cannot be assembled

    def test_input_override(self):
        """The notes' case (ii): the slider position r1 drives; θ2 and θ3 are unknown."""
        mech = ls.load(ls.models_dir() / "example1_slider_crank.toml")
        tex = to_latex(mech, input="r1")
        assert (r"\begin{bmatrix} - r_{2} \sin\theta_{2} & - r_{3} \sin\theta_{3} \\ r_{2} \cos\theta_{2} & "
                r"r_{3} \cos\theta_{3} \end{bmatrix} \begin{bmatrix} \dot{\theta}_{2} \\ \dot{\theta}_{3} "
                r"\end{bmatrix} &= \begin{bmatrix} \dot{r}_{1} \\ 0 \end{bmatrix}") in tex

    def test_snippet_and_inline(self):
        mech = ls.load(ls.models_dir() / "thesis_crank_rocker.toml")
        snippet = to_latex(mech, snippet=True)
        assert "\\documentclass" not in snippet and "\\section" not in snippet and "tabular" not in snippet
        assert snippet.count("\\begin{align*}") >= 5
        assert "% Mechanism" not in snippet  # no equation-free headings
        assert "tabular" in to_latex(mech, snippet=True, at=90)
        inline = to_latex(mech, snippet=True, inline=True)
        assert inline.startswith("\\begin{aligned}") and inline.rstrip().endswith("\\end{aligned}")
        assert inline.count("\\begin{aligned}") == 1 and "align*" not in inline and "$" not in inline
        assert r"\vec{r}_{2} + \vec{r}_{3} &= \vec{r}_{1} + \vec{r}_{4}" in inline
        html = mech._repr_latex_()
        assert html.startswith("$\\displaystyle \\begin{aligned}") and html.endswith("$")
        assert mech.to_latex() == to_latex(mech)

    def test_snippet_pdf(self, tmp_path):
        require("pdflatex")
        mech = ls.load(ls.models_dir() / "quick_return.toml")
        out = write_pdf(to_latex(mech, snippet=True), tmp_path / "snippet.pdf")
        assert out.read_bytes()[:5] == b"%PDF-"


# ----------------------------------------------------------------------------- PDF errors and CLI


class TestWritePdf:
    def test_missing_program_is_named(self, monkeypatch, tmp_path):
        monkeypatch.setenv("PATH", str(tmp_path))
        with pytest.raises(MissingDependencyError, match="pdflatex or latexmk"):
            write_pdf("\\documentclass{article}\\begin{document}x\\end{document}", tmp_path / "x.pdf")
        assert not (tmp_path / "x.pdf").exists()

    def test_compile_error_quotes_the_log(self, tmp_path):
        require("pdflatex")
        bad = "\\documentclass{article}\n\\begin{document}\n$\\notacommand{x}$\n\\end{document}\n"
        with pytest.raises(LoopsolveError) as info:
            write_pdf(bad, tmp_path / "bad.pdf")
        msg = str(info.value)
        assert "pdflatex failed" in msg and "Undefined control sequence" in msg and "l.3" in msg
        assert not (tmp_path / "bad.pdf").exists()

    def test_unwritable_output(self, tmp_path):
        require("pdflatex")
        with pytest.raises(LoopsolveError, match="cannot write the PDF"):
            write_pdf("\\documentclass{article}\\begin{document}x\\end{document}",
                      tmp_path / "no" / "such" / "dir.pdf")


class TestCli:
    def test_latex_to_file(self, tmp_path, capsys):
        out = tmp_path / "d.tex"
        assert cli.main(["latex", str(MODELS[0]), "-o", str(out)]) == 0
        assert out.read_text().startswith("\\documentclass")

    def test_snippet_to_stdout(self, capsys):
        assert cli.main(["latex", str(ls.models_dir() / "quick_return.toml"), "--snippet"]) == 0
        text = capsys.readouterr().out
        assert "\\documentclass" not in text and r"\dot{s}" in text

    def test_pdf(self, tmp_path, capsys):
        require("pdflatex")
        out = tmp_path / "d.pdf"
        model = str(ls.models_dir() / "prob1_fourbar.toml")
        assert cli.main(["latex", model, "--pdf", "-o", str(out), "--at", "40"]) == 0
        assert out.read_bytes()[:5] == b"%PDF-"
        assert "wrote" in capsys.readouterr().err

    @pytest.mark.parametrize("args, name", [(["--pdf"], "d.tex"), ([], "d.pdf"), ([], "D.PDF")])
    def test_pdf_and_tex_names_do_not_cross(self, tmp_path, capsys, args, name):
        # `latex -o thesis.tex --pdf` wrote a PDF named thesis.tex (and `-o x.pdf` TeX named .pdf)
        out = tmp_path / name
        model = str(ls.models_dir() / "prob1_fourbar.toml")
        assert cli.main(["latex", model, *args, "-o", str(out)]) == 2
        err = capsys.readouterr().err
        assert len(err.splitlines()) == 1 and err.startswith("loopsolve: ModelError:") and "--pdf" in err
        assert not out.exists()

    def test_pdf_without_tex(self, tmp_path, monkeypatch, capsys):
        monkeypatch.setenv("PATH", str(tmp_path))
        model = str(ls.models_dir() / "prob1_fourbar.toml")
        assert cli.main(["latex", model, "--pdf", "-o", str(tmp_path / "d.pdf")]) == 2
        err = capsys.readouterr().err
        assert "MissingDependencyError" in err and "pdflatex" in err


def test_a_declared_angle_is_not_rewritten_through_a_quarter_turn_offset():
    """θ3 and θ3 + 90° both declared (a coupler frame's unit vectors): cos θ3 stays cos θ3."""
    import sympy as sp

    from loopsolve.output.latex import LatexPrinter

    t3 = sp.Symbol("theta3")
    pr = LatexPrinter({"degrees": True, "angles": (t3 + sp.pi / 2,)})
    assert pr.doprint(sp.cos(t3)) == "\\cos\\theta_{3}"
    assert pr.doprint(sp.sin(t3)) == "\\sin\\theta_{3}"
