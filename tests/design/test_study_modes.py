"""Every design of a study keeps the assembly mode its guesses name (issue 18 row 7, issue 17 item 5).

The contract (DESIGN.md, Conventions): the mode asked for is the signature of Φ_q's blocks at
the guesses. For the four-bar r2 + r3 = r1 + r4 with unknowns (θ3, θ4),
det Φ_q = r3 r4 sin(θ3 − θ4), so guesses θ3 = 20°, θ4 = 80° name "−" (open) for every design,
whatever its lengths. One design of the chunk below is planted where Newton started from
those guesses falls onto the other branch ("+", crossed: r3 = 30, r4 = 79.56, the family of
``../shared/repro/study_mode_98.toml``); the other designs run on the lockstep path. Each design
must come out in mode "−" with the open-branch closed form as its rows.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import loopsolve as ls

pytest.importorskip("xarray")

MODEL = """name = "Four-bar, guesses naming the open mode"
units = { length = "mm", angle = "deg" }
[parameters]
r1 = 72.23
r2 = 14.2
r3 = 45
r4 = 70
[variables]
theta2 = { input = true, guess = 90, speed = "10rpm" }
theta3 = { guess = 20 }
theta4 = { guess = 80 }
[vectors]
r1 = { length = "r1", angle = 0 }
r2 = { length = "r2", angle = "theta2" }
r3 = { length = "r3", angle = "theta3" }
r4 = { length = "r4", angle = "theta4" }
[[loops]]
equation = "r2 + r3 = r1 + r4"
[points]
B = "r2"
C = "r2 + r3"
[modes]
open = "-"
crossed = "+"
"""

#: (r3, r4): four designs the guesses describe well, and the planted one (index 2)
DESIGNS = [(45.0, 70.0), (50.0, 70.0), (30.0, 79.56), (45.0, 65.0), (50.0, 75.0)]
PLANTED = 2


def signature_at_guesses(r3, r4, theta3=20.0, theta4=80.0) -> str:
    d = r3 * r4 * math.sin(math.radians(theta3 - theta4))
    return "+" if d > 0 else "-"


def closed_form(r1, r2, r3, r4, theta2_deg, sign):
    """θ3, θ4 (deg) of the branch whose det sign(sin(θ3 − θ4)) is ``sign`` (circle intersection)."""
    t = math.radians(theta2_deg)
    bx, by = r2 * math.cos(t), r2 * math.sin(t)
    dx, dy = r1 - bx, -by  # B -> O4
    d = math.hypot(dx, dy)
    a = (r3 * r3 - r4 * r4 + d * d) / (2 * d)
    h = math.sqrt(r3 * r3 - a * a)
    out = []
    for s in (1, -1):
        cx = bx + (a * dx - s * h * dy) / d
        cy = by + (a * dy + s * h * dx) / d
        th3 = math.atan2(cy - by, cx - bx)
        th4 = math.atan2(cy, cx - r1)
        if (math.sin(th3 - th4) > 0) == (sign == "+"):
            out.append((math.degrees(th3), math.degrees(th4)))
    assert len(out) == 1
    return out[0]


def wrapped(a):
    return (np.asarray(a) + 180.0) % 360.0 - 180.0


@pytest.fixture(scope="module")
def planted_study():
    from loopsolve.design.designs import Designs

    # the designs as rows (a zip of r3 and r4, not their product), all in one chunk
    designs = Designs(("r3", "r4"), {"r3": np.array([d[0] for d in DESIGNS]),
                                     "r4": np.array([d[1] for d in DESIGNS])})
    return ls.study(ls.loads(MODEL), designs, 0, 360, 30, chunk_size=len(DESIGNS))


def newton_from_guesses(r3, r4, r1=72.23, r2=14.2, th2=90.0, th3=20.0, th4=80.0):
    """Plain undamped Newton on the loop equations from the guesses (written here); (θ3, θ4) in deg."""
    t2, q = math.radians(th2), np.radians([th3, th4])
    for _ in range(50):
        f = np.array([r2 * math.cos(t2) + r3 * math.cos(q[0]) - r1 - r4 * math.cos(q[1]),
                      r2 * math.sin(t2) + r3 * math.sin(q[0]) - r4 * math.sin(q[1])])
        J = np.array([[-r3 * math.sin(q[0]), r4 * math.sin(q[1])], [r3 * math.cos(q[0]), -r4 * math.cos(q[1])]])
        q = q - np.linalg.solve(J, f)
    return np.degrees(q)


def test_the_planted_design_is_one_newton_takes_to_the_other_branch():
    """The premise: Newton from the guesses at θ2 = 90° lands on the crossed branch for the
    planted design and on the open one for the others."""
    for j, (r3, r4) in enumerate(DESIGNS):
        th3, th4 = newton_from_guesses(r3, r4)
        landed = "+" if math.sin(math.radians(th3 - th4)) > 0 else "-"
        assert landed == ("+" if j == PLANTED else "-"), (r3, r4, th3, th4)
        assert abs(wrapped(th4 - closed_form(72.23, 14.2, r3, r4, 90, landed)[1])) < 1e-9


def test_every_design_keeps_the_mode_its_guesses_name(planted_study):
    ds = planted_study
    assert ds.status.values.tolist() == ["ok"] * len(DESIGNS)
    # the chunk really ran on the lockstep path for the well-guessed designs
    assert all(ds.lockstep.values[j] for j in range(len(DESIGNS)) if j != PLANTED)
    for j, (r3, r4) in enumerate(DESIGNS):
        want = signature_at_guesses(r3, r4)
        assert want == "-"
        assert ds.mode.values[j] == want, (j, r3, r4, ds.mode.values[j])
        for k, th2 in enumerate(ds.theta2.values):
            th3, th4 = closed_form(72.23, 14.2, r3, r4, float(th2), want)
            assert abs(wrapped(ds.theta3.values[j, k] - th3)) < 1e-8, (j, th2)
            assert abs(wrapped(ds.theta4.values[j, k] - th4)) < 1e-8, (j, th2)


def test_well_guessed_designs_are_on_the_open_branch_today(planted_study):
    """The part of the contract today's code already keeps: the designs whose guesses are close
    are in mode "−" with the open-branch rows, on the lockstep path."""
    ds = planted_study
    for j, (r3, r4) in enumerate(DESIGNS):
        if j == PLANTED:
            continue
        assert ds.lockstep.values[j] and ds.mode.values[j] == "-"
        for k, th2 in enumerate(ds.theta2.values):
            th3, th4 = closed_form(72.23, 14.2, r3, r4, float(th2), "-")
            assert abs(wrapped(ds.theta4.values[j, k] - th4)) < 1e-8
