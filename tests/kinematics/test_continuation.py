"""Property tests of the continuation near change points and limits, against closed forms.

Four-bars within |S + L - P - Q| = 1e-6 ... 1e-3 of the longest link of a change point (every
length ordering, Grashof or not), and short-rod slider-cranks, are swept in both modes, both
directions, output steps of 15-60 deg, tracked and batched. The positions of every row are
compared with the circle-intersection closed form of the start's assembly mode, and the first
limit position on the way with the law of cosines (folds of the input where the coupler and the
output link are collinear). The closed forms are written here, independently of the package.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.kinematics.results import EventKind

#: every test here runs with the pure-Python tracer and with the compiled fast lane (conftest.py)
pytestmark = pytest.mark.usefixtures("both_engines")

DEG = 180.0 / math.pi
TOL_ROW = 1e-6  # deg
TOL_LIMIT = 1e-6  # deg


def wrapdeg(a):
    return (np.asarray(a, dtype=float) + 180.0) % 360.0 - 180.0


# ----------------------------------------------------------------------------- closed forms


def fourbar_closed(r1, r2, r3, r4, t2, side):
    """θ3, θ4 (deg) of the four-bar at θ2 (deg); side +1: C left of B→O4 (open, sin(θ4-θ3) > 0)."""
    t = math.radians(t2)
    bx, by = r2 * math.cos(t), r2 * math.sin(t)
    dx, dy = r1 - bx, -by
    d = math.hypot(dx, dy)
    a = (r3 * r3 - r4 * r4 + d * d) / (2 * d)
    h = math.sqrt(max(r3 * r3 - a * a, 0.0))
    cx = bx + (a * dx - side * h * dy) / d
    cy = by + (a * dy + side * h * dx) / d
    return math.degrees(math.atan2(cy - by, cx - bx)), math.degrees(math.atan2(cy, cx - r1))


def fourbar_folds(r1, r2, r3, r4):
    """Input angles (deg, in [0, 360)) where the coupler and the rocker are collinear."""
    out = []
    for d in (r3 + r4, abs(r3 - r4)):
        c = (r1 * r1 + r2 * r2 - d * d) / (2 * r1 * r2)
        if abs(c) <= 1:
            a = math.degrees(math.acos(c))
            out += [a % 360.0, (-a) % 360.0]
    return out


def fourbar_margin(r1, r2, r3, r4, t2):
    t = math.radians(t2)
    d = math.hypot(r1 - r2 * math.cos(t), r2 * math.sin(t))
    return min(r3 + r4 - d, d - abs(r3 - r4))


def slider_closed(r2, r3, e, t2, side):
    """θ3 (deg) and slider position x of the slider-crank (slide along x, offset e); side +1: right."""
    t = math.radians(t2)
    bx, by = r2 * math.cos(t), r2 * math.sin(t)
    dy = e - by
    dx = side * math.sqrt(max(r3 * r3 - dy * dy, 0.0))
    return math.degrees(math.atan2(dy, dx)), bx + dx


def slider_folds(r2, r3, e):
    out = []
    for v in (e + r3, e - r3):
        s = v / r2
        if abs(s) <= 1:
            a = math.degrees(math.asin(s))
            out += [a % 360.0, (180.0 - a) % 360.0]
    return out


def first_fold(t0, direction, folds, span):
    """Distance along the sweep to the first fold within ``span`` deg (None if none)."""
    ds = [((f - t0) * direction) % 360.0 for f in folds]
    ds = [d for d in ds if d <= span]
    return min(ds) if ds else None


# ----------------------------------------------------------------------------- checks


def check_sweep(sw, t0, direction, step, span, dist, closed, names):
    """Rows on the start mode's closed form, the first limit located, no row past it."""
    problems = []
    x = np.asarray(sw[sw.compiled.inputs[0]], dtype=float)
    along = (x - t0) * direction  # distance travelled, deg (the rows are not wrapped)
    limits = [e for e in sw.events if e.kind is EventKind.LIMIT]
    if dist is None:
        if limits:
            problems.append(f"limit reported at {limits[0].input} where there is none")
        expect = int(math.floor(span / step + 1e-9)) + 1
    else:
        if not limits:
            problems.append(f"no limit event (expected at {t0 + direction * dist})")
        else:
            got = (limits[0].input - t0) * direction
            if abs(got - dist) > TOL_LIMIT:
                problems.append(f"limit at {limits[0].input}, expected {t0 + direction * dist} ({got - dist:+.3g})")
        expect = int(math.floor(dist / step)) + 1
        if np.any(along > dist + 1e-9):
            problems.append(f"rows past the limit: {x[along > dist + 1e-9][:3]}")
    if len(x) != expect:
        problems.append(f"{len(x)} rows, expected {expect}")
    if not np.all(np.diff(along) > 0):
        problems.append("rows not in sweep order")
    for i, xi in enumerate(x):
        ref = closed(float(xi))
        for name, r in zip(names, ref):
            v = float(sw[name][i])
            err = abs(float(wrapdeg(v - r))) if name.startswith("theta") else abs(v - r)
            if not err <= TOL_ROW * (1 if name.startswith("theta") else 1e-2):
                problems.append(f"{name} at {xi}: {v} vs closed form {r}")
                break
    return problems


def near_change_fourbar(rng):
    """Four lengths with |S + L - P - Q| = δ·L, δ in [1e-6, 1e-3], in a random order."""
    while True:
        L = 1.0
        S = rng.uniform(0.08, 0.6)
        P = rng.uniform(S, L)
        delta = 10 ** rng.uniform(-6, -3) * rng.choice([-1.0, 1.0])
        Q = S + L - P + delta
        if S < Q < L and S < P and min(abs(Q - P), abs(Q - S), abs(L - Q), abs(P - S)) > 1e-3:
            break
    lengths = np.array([S, L, P, Q]) * rng.uniform(0.5, 200.0)
    rng.shuffle(lengths)
    return [float(v) for v in lengths]


def run_fourbars(seed, n, method):
    rng = np.random.default_rng(seed)
    failures = []
    for case in range(n):
        r1, r2, r3, r4 = near_change_fourbar(rng)
        folds = fourbar_folds(r1, r2, r3, r4)
        while True:  # a start clear of the limits
            t0 = float(np.round(rng.uniform(-180, 180), 3))
            if fourbar_margin(r1, r2, r3, r4, t0) > 0 and all(abs(wrapdeg(t0 - f)) > 0.05 for f in folds):
                break
        side = float(rng.choice([-1.0, 1.0]))
        mode = "open" if side > 0 else "crossed"
        direction = float(rng.choice([-1.0, 1.0]))
        step = float(np.round(rng.uniform(15, 60), 4))
        span = float(np.round(rng.uniform(40, 400), 4))
        mech = ls.fourbar(r1, r2, r3, r4, theta2=t0, mode=mode)
        dist = first_fold(t0, direction, folds, span)
        label = f"fourbar{(r1, r2, r3, r4)} {mode} from {t0} by {direction * step} over {span} ({method})"
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                sw = mech.sweep(t0, t0 + direction * span, step, mode=mode, method=method)
        except ls.LoopsolveError as exc:
            failures.append(f"{label}: {type(exc).__name__}: {exc}")
            continue
        probs = check_sweep(sw, t0, direction, step, span, dist,
                            lambda t: fourbar_closed(r1, r2, r3, r4, t, side), ("theta3", "theta4"))
        failures += [f"{label}: {p}" for p in probs]
    return failures


def run_sliders(seed, n, method):
    rng = np.random.default_rng(seed)
    failures = []
    for case in range(n):
        r2 = rng.uniform(5, 100)
        r3 = r2 * rng.uniform(0.2, 1.3)
        e = r2 * rng.uniform(-1.0, 1.0)
        folds = slider_folds(r2, r3, e)
        while True:
            t0 = float(np.round(rng.uniform(-180, 180), 3))
            by = r2 * math.sin(math.radians(t0))
            if abs(e - by) < r3 and all(abs(wrapdeg(t0 - f)) > 0.05 for f in folds):
                break
        side = float(rng.choice([-1.0, 1.0]))
        mode = "right" if side > 0 else "left"
        direction = float(rng.choice([-1.0, 1.0]))
        step = float(np.round(rng.uniform(15, 60), 4))
        span = float(np.round(rng.uniform(40, 400), 4))
        mech = ls.slider_crank(r2, r3, offset=e, theta2=t0, mode=mode)
        dist = first_fold(t0, direction, folds, span)
        label = f"slider{(r2, r3, e)} {mode} from {t0} by {direction * step} over {span} ({method})"
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                sw = mech.sweep(t0, t0 + direction * span, step, method=method)
        except ls.LoopsolveError as exc:
            failures.append(f"{label}: {type(exc).__name__}: {exc}")
            continue
        probs = check_sweep(sw, t0, direction, step, span, dist, lambda t: slider_closed(r2, r3, e, t, side),
                            ("theta3", "x"))
        failures += [f"{label}: {p}" for p in probs]
    return failures


N_FOURBAR = 700  # per method
N_SLIDER = 300  # per method


@pytest.mark.parametrize("method", ["tracked", "batched"])
def test_near_change_point_fourbars(method):
    failures = run_fourbars(11 if method == "tracked" else 12, N_FOURBAR, method)
    assert not failures, f"{len(failures)} of {N_FOURBAR}:\n" + "\n".join(failures[:10])


@pytest.mark.parametrize("method", ["tracked", "batched"])
def test_near_limit_slider_cranks(method):
    failures = run_sliders(21 if method == "tracked" else 22, N_SLIDER, method)
    assert not failures, f"{len(failures)} of {N_SLIDER}:\n" + "\n".join(failures[:10])


if __name__ == "__main__":  # python tests/kinematics/test_continuation.py: the failure counts
    import sys
    import time

    n = int(sys.argv[1]) if len(sys.argv) > 1 else N_FOURBAR
    for method in ("tracked", "batched"):
        t = time.perf_counter()
        f = run_fourbars(11 if method == "tracked" else 12, n, method)
        s = run_sliders(21 if method == "tracked" else 22, n * N_SLIDER // N_FOURBAR, method)
        cases = {x.split(":")[0] for x in f}, {x.split(":")[0] for x in s}
        print(f"{method}: four-bars {len(cases[0])}/{n} failed, slider-cranks {len(cases[1])}/"
              f"{n * N_SLIDER // N_FOURBAR} failed ({time.perf_counter() - t:.1f} s)")
        for x in (f[:4] + s[:4]):
            print("   ", x[:400])
