"""Freudenstein function generation against hand computations written here.

References: the notes' form K1 cos θ4 − K2 cos θ2 + K3 = cos(θ2 − θ4) with K1 = r1/r2,
K2 = r1/r4, K3 = (r1² + r2² + r4² − r3²)/(2 r2 r4) (../shared/seeds/000_*.txt, eq. (A));
the textbook log₁₀ example (K = (2.00276, −0.69862, 1.08420)) and the issue's x^1.6 figure (1.30°).
"""

import math

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.errors import ModelError
from loopsolve.design.synthesis.classical.freudenstein import chebyshev_spacing, freudenstein, freudenstein_constants, links_from_constants


def cramer3(a, b):
    """Solve a 3×3 system by Cramer's rule (independent of numpy.linalg.solve)."""
    def det(m):
        return (m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
                + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]))
    d = det(a)
    out = []
    for k in range(3):
        m = [[b[i] if j == k else a[i][j] for j in range(3)] for i in range(3)]
        out.append(det(m) / d)
    return out


def fourbar_theta4(r1, r2, r3, r4, t2, open_=True):
    """Output angle by the circle intersection (B on the crank circle, C at r3 from B and r4 from O4)."""
    bx, by = r2 * math.cos(t2), r2 * math.sin(t2)
    dx, dy = r1 - bx, -by
    d = math.hypot(dx, dy)
    a = (r3 * r3 - r4 * r4 + d * d) / (2 * d)
    h = math.sqrt(r3 * r3 - a * a)
    s = 1 if open_ else -1
    cx, cy = bx + a * dx / d - s * h * dy / d, by + a * dy / d + s * h * dx / d
    return math.atan2(cy, cx - r1)


class TestConstants:
    def test_known_crank_rocker_recovered(self):
        # r1..r4 = 60, 25, 70, 45: K1 = 60/25 = 2.4, K2 = 60/45 = 4/3,
        # K3 = (3600 + 625 + 2025 - 4900)/(2*25*45) = 1350/2250 = 0.6
        t2 = [math.radians(a) for a in (20.0, 75.0, 140.0)]
        t4 = [fourbar_theta4(60, 25, 70, 45, a) for a in t2]
        K = freudenstein_constants(t2, t4)
        assert K == pytest.approx([2.4, 4 / 3, 0.6], abs=1e-12)
        assert links_from_constants(K, 60) == pytest.approx((60, 25, 70, 45), abs=1e-9)

    def test_log10_textbook_constants(self):
        # Chebyshev points on 1..10 by hand: 5.5 -+ 4.5 cos(30°), 5.5
        xs = [5.5 - 4.5 * math.sqrt(3) / 2, 5.5, 5.5 + 4.5 * math.sqrt(3) / 2]
        assert chebyshev_spacing(1, 10, 3) == pytest.approx(xs, abs=1e-12)
        t2 = [math.radians(45 + 60 * (x - 1) / 9) for x in xs]
        t4 = [math.radians(135 + 90 * math.log10(x)) for x in xs]
        a = [[math.cos(q4), -math.cos(q2), 1.0] for q2, q4 in zip(t2, t4)]
        b = [math.cos(q2 - q4) for q2, q4 in zip(t2, t4)]
        hand = cramer3(a, b)
        assert hand == pytest.approx([2.00276, -0.69862, 1.08420], abs=5e-6)  # the textbook's numbers
        d = freudenstein(np.log10, (1, 10), (45, 105), (135, 225))
        assert d.K == pytest.approx(hand, abs=1e-12)
        # lengths with r1 = 100: r2 = 100/K1, |r4| = 100/|K2|, r3² = r1² + r2² + r4² - 2 r2 r4 K3 (r4 < 0)
        r2, r4 = 100 / hand[0], 100 / hand[1]
        r3 = math.sqrt(100 ** 2 + r2 ** 2 + r4 ** 2 - 2 * r2 * r4 * hand[2])
        assert d.lengths == pytest.approx((100, r2, r3, -r4), rel=1e-12)

    def test_too_few_points_and_no_coupler(self):
        with pytest.raises(ModelError, match="at least three"):
            freudenstein_constants([0.1, 0.2], [0.3, 0.4])
        with pytest.raises(ModelError, match="r3"):
            links_from_constants((1.0, 1.0, 5.0))
        with pytest.raises(ModelError, match="three precision points"):
            freudenstein(np.log10, (1, 10), (45, 105), (135, 225), points=4)


@pytest.fixture(scope="module")
def design():
    """Computed once for the tests of :class:`TestLog10` (a module function: pytest retires class-scoped
    fixtures defined as instance methods)."""
    return freudenstein(np.log10, (1, 10), (45, 105), (135, 225))


class TestLog10:
    def test_range_defect_with_located_limit(self, design):
        # the limit where coupler and output fold over each other: |B - O4| = r3 - r4
        # (|B - O4| stays within r1 -+ r2 = 50.1 .. 149.9 < r3 + r4), i.e.
        # cos θ2 = (r1² + r2² - (r3 - r4)²) / (2 r1 r2)
        r1, r2, r3, r4 = design.lengths
        lim = math.degrees(math.acos((r1 ** 2 + r2 ** 2 - (r3 - r4) ** 2) / (2 * r1 * r2)))
        assert lim == pytest.approx(48.95, abs=0.005)
        assert design.grashof.value == "triple rocker"
        [defect] = design.defects
        assert defect.kind == "range"
        assert defect.input == pytest.approx(lim, abs=1e-6)
        assert "45.00°–48.95°" in defect.message
        assert design.precision[0][2] - defect.input == pytest.approx(0.07, abs=0.005)
        assert design.reachable == pytest.approx((lim, 105), abs=1e-6)
        assert not design.certified and "least-squares" in design.suggestion

    def test_mechanism_meets_the_precision_points(self, design):
        for x, y, t2, t4 in design.precision:
            s = design.mechanism.solve(t2, mode=design.mode)
            diff = (s["theta4"] - (135 + 90 * math.log10(x)) + 180) % 360 - 180  # a single solve wraps
            assert diff == pytest.approx(0, abs=1e-8)

    def test_alternative_free_offsets_is_certified(self, design):
        d = design.alternative()  # the minimax fit with the reference angles free
        assert (d.fit, len(d.precision), d.input_range, d.output_range) == ("minimax", 7, (45, 105), (135, 225))
        assert d.certified and d.reachable == pytest.approx((45, 105))
        assert d.max_error < 0.2  # vs 5.7° where the exact design reaches


class TestStructuralError:
    def test_three_point_x16_error_is_1_30_deg_over_the_range(self):
        f = lambda x: x ** 1.6  # noqa: E731
        d = freudenstein(f, (1, 4), (30, 120), (90, 180))
        assert d.certified
        # independent: circle intersection on a dense grid in the design's mode
        r1, r2, r3, r4 = d.lengths
        errs = []
        t4p = math.radians(d.precision[0][3])
        for x in np.linspace(1, 4, 3001):
            t2 = math.radians(30 + 90 * (x - 1) / 3)
            # the model's physical vectors: signs of K say which way r2, r4 point
            k1, k2, _ = d.K
            t2phys = t2 + (math.pi if k1 < 0 else 0)
            cands = [fourbar_theta4(r1, r2, r3, r4, t2phys, o) for o in (True, False)]
            t4 = [c - (math.pi if k2 < 0 else 0) for c in cands]
            want = math.radians(90 + 90 * (x ** 1.6 - 1) / (4 ** 1.6 - 1))
            errs.append(min(abs((a - want + math.pi) % (2 * math.pi) - math.pi) for a in t4))
        assert max(math.degrees(e) for e in errs) == pytest.approx(1.30, abs=0.005)
        assert d.max_error == pytest.approx(max(math.degrees(e) for e in errs), abs=1e-3)
        assert t4p  # the first point's output is defined

    def test_minimax_with_free_offsets_beats_three_points_tenfold_within_a_link_ratio(self):
        d = freudenstein(lambda x: x ** 1.6, (1, 4), (30, 120), (90, 180), points=12, fit="minimax",
                         free_offsets=True, max_link_ratio=4)
        assert d.certified and d.reachable == pytest.approx((30, 120))
        assert max(d.lengths) / min(d.lengths) <= 4 + 1e-9
        # independent: the output by circle intersection at 601 inputs, in the design's branch
        r1, r2, r3, r4 = d.lengths
        al, be = (math.radians(v) for v in d.offsets)
        k1, k2, _ = d.K
        worst, prev = 0.0, None
        for x in np.linspace(1, 4, 601):
            t2 = math.radians(30 + 90 * (x - 1) / 3) + al + (math.pi if k1 < 0 else 0)
            want = math.radians(90 + 90 * (x ** 1.6 - 1) / (4 ** 1.6 - 1))
            t4s = [fourbar_theta4(r1, r2, r3, r4, t2, o) - be - (math.pi if k2 < 0 else 0) for o in (True, False)]
            ref = want if prev is None else prev
            prev = min(t4s, key=lambda a: abs((a - ref + math.pi) % (2 * math.pi) - math.pi))
            worst = max(worst, abs((prev - want + math.pi) % (2 * math.pi) - math.pi))
        assert math.degrees(worst) == pytest.approx(d.max_error, abs=1e-4)
        assert d.max_error < 1.30 / 10

    def test_points_out_of_order_and_precision_met(self):
        d = freudenstein(lambda x: x ** 1.6, (1, 4), (30, 120), (90, 180), points=[1.2, 3.5, 2.0])
        assert [x.kind for x in d.defects] == ["order"]


def test_design_model_file_round_trip():
    from loopsolve.design.synthesis.classical.freudenstein import freudenstein_points

    d = freudenstein_points([49.019, 75.0, 100.981], [153.441, 201.633, 222.570])
    mech = ls.loads(ls.dumps(d.mechanism))
    for _, _, t2, t4 in d.precision:
        s = mech.solve(t2, mode=d.mode)
        assert (s["theta4"] - t4 + 180) % 360 - 180 == pytest.approx(0, abs=1e-8)


@pytest.mark.parametrize("lengths, inputs, kind", [
    ((60, 25, 70, 45), (20, 75, 140), "circuit"),  # Grashof crank-rocker: open and crossed are two circuits
    ((4, 3, 3.5, 5), (30, 60, 90), "branch"),  # non-Grashof: one circuit, the modes meet at limits
])
def test_precision_points_in_two_modes(lengths, inputs, kind):
    from loopsolve.design.synthesis.classical.freudenstein import freudenstein_points

    # outputs by circle intersection: the first two open, the third crossed
    outs = [math.degrees(fourbar_theta4(*lengths, math.radians(a), o)) for a, o in zip(inputs, (True, True, False))]
    d = freudenstein_points(inputs, outs, ground=lengths[0])
    assert d.lengths == pytest.approx(lengths, abs=1e-9)  # K does not know the mode
    assert [x.kind for x in d.defects] == [kind]
    assert d.defects[0].input == pytest.approx(inputs[2])
    outs = [math.degrees(fourbar_theta4(*lengths, math.radians(a), True)) for a in inputs]
    assert freudenstein_points(inputs, outs, ground=lengths[0]).certified
