"""The thesis crank-rocker (L1 = 60, L2 = 25, L3 = 70, L4 = 45 mm, crank at 10 rpm, α2 = 0).

Reference numbers: ``tests/data/thesis_crank_rocker.json``, a verbatim copy of
``../shared/reference/thesis_crank_rocker.json``, which transcribes Tables 4–8 and 11 and
Figures 41–43 of the degree thesis "The Design and Simulation of Mechanisms"
(seed ``001_6bcfc5c45935de12.txt``): its Excel table (2 decimals) and its SolidWorks Motion
export (2 decimals, absolute values in deg/s and deg/s²).

Findings recorded here:

* ω2. The thesis converts 10 rpm and prints ω2 = 1.05 rad/s, but its table was computed with
  the exact 2π·10/60 = 1.0472 rad/s: with it every printed θ3, θ4, ω3, ω4, α3 is reproduced
  within rounding; with 1.05 several rows are not (ω4 and α3 at 300°, α3 at 330°).
* α4. Eight printed Excel α4 values are wrong (θ2 = 30, 60, 90, 120, 240, 270, 300, 330°;
  330° even has the wrong sign). They are exactly what the thesis's printed eq. (25) gives:
  its last numerator term reads ω3² L4 cos(θ4 − θ3) where Myszka's formula has ω4². The
  SolidWorks export agrees with the correct α4 — shown by two independent checks, finite
  differences of the solved positions and ``classic.fourbar_acceleration`` (Cramer's rule on
  the notes' acceleration system) — to within 0.6 deg/s² (0.5 % of the 117.6 deg/s² peak).
  That tolerance is SolidWorks's own numerical error, which has the same size on the quantities
  the Excel table gets right (|α3| off by up to 0.34 deg/s², |ω4| by 0.20 deg/s, θ4 by 0.11°).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.kinematics import classic
from loopsolve.kinematics.solve import initial_z, solve_position

DATA = Path(__file__).parents[1] / "data" / "thesis_crank_rocker.json"
REF = json.loads(DATA.read_text())
EXCEL = REF["published_excel_table"]
SW = REF["solidworks_motion_export"]
THETA2 = np.array(REF["theta2_deg"], dtype=float)
L1, L2, L3, L4 = 60, 25, 70, 45
OMEGA2 = 2 * math.pi * 10 / 60  # 10 rpm exactly
ROUND = 0.005 + 1e-9  # half a unit in the printed second decimal

#: rows (θ2 in degrees) where the printed Excel α4 is wrong beyond its rounding
WRONG_ALPHA4_ROWS = (30, 60, 90, 120, 240, 270, 300, 330)
#: SolidWorks Motion's numerical error (deg/s²) allowed when comparing its accelerations
SW_ACCEL_TOL = 0.6


@pytest.fixture(scope="module")
def mech():
    return ls.load(ls.models_dir() / "thesis_crank_rocker.toml")


def _table(mech, speed=None):
    """Solve the 13 rows (continuation from the model's guesses), display units."""
    ck = mech.compile()
    rows, guess = [], None
    for t2 in THETA2:
        s = mech.solve(float(t2), speed=speed, guess=guess, compiled=ck)
        guess = {"theta3": s.z[ck.index("theta3")], "theta4": s.z[ck.index("theta4")]}
        rows.append(s)
    return rows


@pytest.fixture(scope="module")
def rows(mech):
    return _table(mech)


#: SHA-256 of /work/shared/reference/thesis_crank_rocker.json (the project's published numbers),
#: recorded when tests/data was copied from it, so the copy is checked even where ../shared is absent
SHARED_REFERENCE_SHA256 = "5badb3f301f1bd87f3ebfae22bd993e066128b13c5d84727f54ae386e5c064b0"


def test_reference_copy_matches_shared_reference():
    """tests/data holds the shared reference verbatim (provenance: its ``source`` field)."""
    import hashlib

    assert hashlib.sha256(DATA.read_bytes()).hexdigest() == SHARED_REFERENCE_SHA256
    shared = Path(__file__).resolve().parents[3] / "shared" / "reference" / "thesis_crank_rocker.json"
    if shared.exists():  # the shared tree sits beside the repository in the project workspace
        assert json.loads(shared.read_text()) == REF
    assert "001_6bcfc5c45935de12" in REF["source"]
    assert REF["mechanism"]["ground_L1_mm"] == L1 and REF["mechanism"]["rocker_L4_mm"] == L4
    # both published tables are here, complete: 13 rows of every column
    for table in (EXCEL, SW):
        assert table and all(len(v) == len(THETA2) for v in table.values()), table.keys()
    assert set(SW) >= {"theta3_deg", "theta4_inner_deg", "abs_omega3_deg_s", "abs_omega4_deg_s",
                       "abs_alpha3_deg_s2", "abs_alpha4_deg_s2"}


def test_model_runs_at_exact_10_rpm(rows):
    assert rows[0]["theta2_vel"] == pytest.approx(OMEGA2, rel=1e-15)
    assert rows[0]["theta2_acc"] == 0.0


@pytest.mark.parametrize(
    "column, key",
    [("theta3", "theta3_deg"), ("theta4", "theta4_outer_deg"), ("theta3_vel", "omega3_rad_s"),
     ("theta4_vel", "omega4_rad_s"), ("theta3_acc", "alpha3_rad_s2")],
)
def test_excel_table_reproduced_within_rounding(rows, column, key):
    got = np.array([s[column] for s in rows])
    want = np.array(EXCEL[key])
    assert np.all(np.abs(got - want) <= ROUND), list(zip(THETA2, got.round(4), want))


def test_inner_theta4_is_outer_minus_180(rows):
    got = np.array([s["theta4"] for s in rows]) - 180.0
    assert np.all(np.abs(got - np.array(EXCEL["theta4_inner_deg"])) <= ROUND)


@pytest.mark.parametrize(
    "column, key",
    [("theta3_vel", "abs_omega3_deg_s"), ("theta4_vel", "abs_omega4_deg_s"), ("theta3_acc", "abs_alpha3_deg_s2")],
)
def test_excel_absolute_degree_columns_within_rounding(rows, column, key):
    got = np.abs(np.degrees([s[column] for s in rows]))
    assert np.all(np.abs(got - np.array(EXCEL[key])) <= ROUND)


def test_printed_omega2_of_1_05_does_not_reproduce_the_table(mech):
    """The table was computed with 1.0472 rad/s: the printed, rounded 1.05 misses some rows."""
    rows_105 = _table(mech, speed=1.05)
    misses = set()
    for column, key in (("theta4_vel", "omega4_rad_s"), ("theta3_acc", "alpha3_rad_s2")):
        got = np.array([s[column] for s in rows_105])
        misses |= {int(t) for t, g, w in zip(THETA2, got, EXCEL[key]) if abs(g - w) > ROUND}
    assert misses >= {300, 330}


# ----------------------------------------------------------------------------- α4


def _alpha4_by_finite_differences(mech, h_deg=0.5):
    """α4 = ω2² d²θ4/dθ2² (α2 = 0) from 9-point FD of Newton-solved positions (no rate equations)."""
    ck = mech.compile()
    i, j = ck.index("theta2"), ck.index("theta4")
    offsets = np.arange(-4, 5)
    a = np.vander(offsets.astype(float), 9, increasing=True).T
    rhs = np.zeros(9)
    rhs[2] = 2.0
    w = np.linalg.solve(a, rhs)
    h = math.radians(h_deg)
    z = initial_z(ck, warn=False)
    out = []
    for t2 in np.radians(THETA2):
        th4 = []
        for k in offsets:
            z[i] = t2 + k * h
            z, _, _ = solve_position(ck, z)
            th4.append(z[j])
        z[i] = t2
        out.append(OMEGA2**2 * (w @ np.array(th4)) / h**2)
    return np.array(out)


def _alpha4_closed_form():
    t2 = np.radians(THETA2)
    t3, t4 = classic.fourbar_position(L1, L2, L3, L4, t2, mode=+1)
    w3, w4 = classic.fourbar_velocity(L2, L3, L4, t2, t3, t4, OMEGA2)
    _, a4 = classic.fourbar_acceleration(L2, L3, L4, t2, t3, t4, OMEGA2, w3, w4, 0.0)
    return np.asarray(a4)


def _alpha4_thesis_eq25():
    """The thesis's printed eq. (25), typo included: ω3² L4 cos(θ4 − θ3) instead of ω4²."""
    t2 = np.radians(THETA2)
    t3, t4 = classic.fourbar_position(L1, L2, L3, L4, t2, mode=+1)
    w3, _ = classic.fourbar_velocity(L2, L3, L4, t2, t3, t4, OMEGA2)
    num = OMEGA2**2 * L2 * np.cos(t2 - t3) + w3**2 * L3 - w3**2 * L4 * np.cos(t4 - t3)
    return num / (L4 * np.sin(t4 - t3))


def test_alpha4_independent_checks_agree_with_the_solver(mech, rows):
    solver = np.array([s["theta4_acc"] for s in rows])
    fd = _alpha4_by_finite_differences(mech)
    closed = _alpha4_closed_form()
    assert np.max(np.abs(solver - closed)) < 1e-12
    assert np.max(np.abs(solver - fd)) < 1e-7


def test_alpha4_wrong_excel_rows_are_recorded(rows):
    """Exactly the rows in WRONG_ALPHA4_ROWS miss the correct α4 by more than their rounding."""
    solver = np.array([s["theta4_acc"] for s in rows])
    printed = np.array(EXCEL["alpha4_rad_s2"])
    wrong = tuple(int(t) for t, g, p in zip(THETA2, solver, printed) if abs(g - p) > ROUND)
    assert wrong == WRONG_ALPHA4_ROWS
    # 330 deg: even the sign is wrong
    k = list(THETA2).index(330)
    assert solver[k] < 0 < printed[k]


def test_excel_alpha4_is_the_printed_eq25_typo(rows):
    """Every printed Excel α4 (right or wrong) is eq. (25) as printed in the thesis, rounded —
    evaluated on loopsolve's solved θ3, θ4, ω3 as well as on the classic closed forms."""
    printed = np.array(EXCEL["alpha4_rad_s2"])
    assert np.all(np.abs(_alpha4_thesis_eq25() - printed) <= ROUND)
    t2 = np.radians(THETA2)
    t3 = np.radians([s["theta3"] for s in rows])
    t4 = np.radians([s["theta4"] for s in rows])
    w3 = np.array([s["theta3_vel"] for s in rows])
    eq25 = (OMEGA2**2 * L2 * np.cos(t2 - t3) + w3**2 * L3 - w3**2 * L4 * np.cos(t4 - t3)) / (L4 * np.sin(t4 - t3))
    assert np.all(np.abs(eq25 - printed) <= ROUND)
    # with ω4² (Myszka's formula) the same expression is loopsolve's α4, not the printed column
    w4 = np.array([s["theta4_vel"] for s in rows])
    fixed = (OMEGA2**2 * L2 * np.cos(t2 - t3) + w3**2 * L3 - w4**2 * L4 * np.cos(t4 - t3)) / (L4 * np.sin(t4 - t3))
    np.testing.assert_allclose(fixed, [s["theta4_acc"] for s in rows], rtol=1e-10, atol=1e-12)


def test_solidworks_agrees_with_the_correct_alpha4(mech):
    """SolidWorks |α4| is within its numerical error of the FD and closed-form α4; Excel is not."""
    sw = np.array(SW["abs_alpha4_deg_s2"])
    excel = np.array(EXCEL["abs_alpha4_deg_s2"])
    for check in (_alpha4_by_finite_differences(mech), _alpha4_closed_form()):
        exact = np.abs(np.degrees(check))
        assert np.max(np.abs(sw - exact)) <= SW_ACCEL_TOL
        for t in WRONG_ALPHA4_ROWS:
            k = list(THETA2).index(t)
            sw_err, excel_err = abs(sw[k] - exact[k]), abs(excel[k] - exact[k])
            assert excel_err > SW_ACCEL_TOL and excel_err > 3 * sw_err, (t, sw_err, excel_err)


def test_solidworks_error_size_on_quantities_excel_gets_right(rows):
    """The SW tolerance is honest: SW differs by similar amounts where Excel is right."""
    t3 = np.array([s["theta3"] for s in rows])
    t4_inner = np.array([s["theta4"] for s in rows]) - 180
    assert np.max(np.abs(t3 - SW["theta3_deg"])) < 0.1
    assert np.max(np.abs(t4_inner - SW["theta4_inner_deg"])) < 0.12
    for column, key, tol in (("theta3_vel", "abs_omega3_deg_s", 0.15), ("theta4_vel", "abs_omega4_deg_s", 0.25),
                             ("theta3_acc", "abs_alpha3_deg_s2", 0.4)):
        got = np.abs(np.degrees([s[column] for s in rows]))
        dev = np.abs(got - np.array(SW[key]))
        assert np.max(dev) < tol
        assert np.max(dev) > 0.01  # SW is numeric: it is not exact either
    # the export's clock is the crank angle at 10 rpm: 60 deg per second
    assert np.allclose(np.array(SW["time_s"]) * 60.0, THETA2)
