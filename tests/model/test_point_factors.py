"""Points with scalar factors and the origin (``G3 = "r2 + 0.5*r3"``, ``P = "r2 + k*r3 - r7"``, ``O = "0"``).

Positions are checked against the vectors recomputed in the test from the solved angles, and the
rates against central finite differences of those positions along the input.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import loopsolve as ls

R1, R2, R3, R4, K = 60.0, 25.0, 70.0, 45.0, 0.3


def fourbar_with(points: dict, **extra_params) -> ls.Mechanism:
    b = ls.MechanismBuilder("four-bar with factors")
    for n, v in dict(r1=R1, r2=R2, r3=R3, r4=R4, k=K, **extra_params).items():
        b.parameter(n, v)
    b.variable("theta2", input=True, guess=90).variable("theta3", guess=20).variable("theta4", guess=80)
    b.vector("r1", length="r1", angle=0).vector("r2", length="r2", angle="theta2")
    b.vector("r3", length="r3", angle="theta3").vector("r4", length="r4", angle="theta4")
    b.vector("r7", x=10, y=-5)
    b.loop("r2 + r3 = r1 + r4")
    for n, t in points.items():
        b.point(n, t)
    return b.build()


POINTS = {
    "G3": "r2 + 0.5*r3",
    "P": "r2 + k*r3 - r7",
    "O": "0",
    "Q": "0.5*(r2 + r3)",
    "R": "r3/2 - r4",
    "S": "-k*r4 + r1",
}


def expected(name: str, t2: float, t3: float, t4: float) -> np.ndarray:
    e = lambda a: np.array([math.cos(a), math.sin(a)])  # noqa: E731
    r1, r2, r3, r4, r7 = R1 * e(0), R2 * e(t2), R3 * e(t3), R4 * e(t4), np.array([10.0, -5.0])
    return {"G3": r2 + 0.5 * r3, "P": r2 + K * r3 - r7, "O": np.zeros(2), "Q": 0.5 * (r2 + r3),
            "R": r3 / 2 - r4, "S": -K * r4 + r1}[name]


@pytest.fixture(scope="module")
def mech():
    return fourbar_with(POINTS)


class TestPositionsAndRates:
    @pytest.mark.parametrize("at", [0.0, 73.0, 190.0, 300.0])
    def test_positions(self, mech, at):
        s = mech.solve(at)
        angles = [math.radians(s[n]) for n in ("theta2", "theta3", "theta4")]
        for name in POINTS:
            want = expected(name, *angles)
            assert s[f"{name}_x"] == pytest.approx(want[0], abs=1e-9)
            assert s[f"{name}_y"] == pytest.approx(want[1], abs=1e-9)

    @pytest.mark.parametrize("at", [35.0, 250.0])
    def test_rates_by_finite_differences(self, mech, at):
        h = 1e-3  # degrees of input; speed 1 rad/s so rates are d/dθ2 per radian
        s0, sp_, sm = mech.solve(at), mech.solve(at + h), mech.solve(at - h)
        dx = math.radians(h)
        for name in POINTS:
            for c in "xy":
                fd_vel = (sp_[f"{name}_{c}"] - sm[f"{name}_{c}"]) / (2 * dx)
                fd_acc = (sp_[f"{name}_{c}"] - 2 * s0[f"{name}_{c}"] + sm[f"{name}_{c}"]) / dx**2
                assert s0[f"{name}_{c}_vel"] == pytest.approx(fd_vel, rel=1e-6, abs=1e-6)
                assert s0[f"{name}_{c}_acc"] == pytest.approx(fd_acc, rel=1e-4, abs=1e-4)

    def test_declaration(self, mech):
        by = {p.name: p for p in mech.points}
        assert by["O"].terms == () and by["O"].plain
        assert by["G3"].terms == ((1, "r2"), (1, "r3")) and not by["G3"].plain
        assert by["S"].terms[0] == (-1, "r4")

    def test_factor_change_recompiles(self):
        a = fourbar_with({"G": "r2 + 0.5*r3"}).solve(60)
        b = fourbar_with({"G": "r2 + 0.25*r3"}).solve(60)
        assert a["G_x"] != pytest.approx(b["G_x"])

    def test_latex_prints_factors(self, mech):
        tex = mech.to_latex()
        assert r"\vec{r}_{G_{3}} &= \vec{r}_{2} + \frac{1}{2}\,\vec{r}_{3}" in tex
        assert r"\vec{r}_{O} &= \vec{0}" in tex
        assert r"k\,\vec{r}_{3}" in tex

    def test_draw_skips_factor_points(self, mech, tmp_path):
        pytest.importorskip("matplotlib")
        out = tmp_path / "d.png"
        mech.draw(80, output=out)
        assert out.stat().st_size > 0


class TestBadPoints:
    @pytest.mark.parametrize("text, words", [
        ("r2 * r3", "multiplies two vectors"),
        ("r2 + 0.5", "has no vector"),
        ("r2 + q*r3", "'q'"),
        ("r2 + theta2*r3", "variable 'theta2'"),
        ("r2 + 3mm*r3", "plain number"),
        ("r2 / r3", "divides by a vector"),
        ("r2 + __import__", ""),
    ])
    def test_rejected(self, text, words):
        with pytest.raises(ls.ModelError) as exc:
            fourbar_with({"G": text})
        assert "points.G" in str(exc.value) and words in str(exc.value)

    def test_all_at_once(self):
        with pytest.raises(ls.ModelError) as exc:
            fourbar_with({"G": "r2 * r3", "H": "r9 + r2"})
        msg = str(exc.value)
        assert "points.G" in msg and "points.H" in msg
