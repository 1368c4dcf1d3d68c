"""Dimensional synthesis: find parameter values that make a declared model do a given job.

Design
------
**Problem.** :class:`Problem` is the frozen statement of one job on one model: the task
(``path``: a point through target positions; ``function``: an unknown as a function of the
input; ``motion``: a point and a link angle through poses), the targets (internal units), the
timing (prescribed: one input value per target; free: the input values are unknowns), the varied
parameters with their bounds (model units), the mode, and the requirements (``crank``: the input
turns fully; ``transmission``: the transmission angle stays within bounds). A task is only a
residual function of the positions at the targets (:meth:`Problem.residuals`) and its
derivative, so the three tasks share everything else.

**Evaluation** is batched (:mod:`loopsolve.design.synthesis.candidates`): the designs of one generation are the
columns of one parameter matrix and are solved together by the generated numpy kernels —
assembled at the first target in the asked mode by a multistart block Newton, then continued
target to target (predictor–corrector substeps, stopping a design at a limit, a sign change of
a block determinant or a near-singular block). A design that cannot reach every target in one
continuous motion in one mode gets a penalty that grows with the number of targets it misses,
so the search is pushed towards defect-free designs, never towards ones that need a jump.
Free timing is handled in the search by tracing each design over a whole turn both ways on a
grid and assigning the targets to grid points in order by dynamic programming (monotone
assignment, both directions); the polish then makes the input values exact unknowns.

**Global search: differential evolution** (scipy, ``vectorized=True``, ``updating="deferred"``):
a whole generation is one batch, so the cost per generation is a few kernel calls on arrays of
the population's size instead of hundreds of Python-level solves. Chosen over a Latin-hypercube
multistart because the objective is multimodal with narrow basins (the published four-bar
problems), and DE's recombination of good designs finds those basins with far fewer evaluations
than independent starts; the seeded initial population is itself a Latin hypercube. The search
is not trusted to end in the right basin, though: on the eighteen-point benchmark 150 DE
generations end at f ≈ 4–15 and the basin a *polish* falls into decides the result (0.0090,
0.0098, 0.014, ...). So a run polishes many starts — the distinct best members of the DE
populations and the best of a Latin-hypercube multistart — together by a lockstep
Levenberg–Marquardt (:mod:`loopsolve.design.synthesis.lockstep_lm`: one batch per iteration, hundreds of starts for
the price of a few scalar polishes), and only the distinct basins they end in go on to the exact
polish below (polishing near-identical candidates was 35–50 % of a run before). With the
multistart, one short DE search per mode (``restarts=1``, 60 generations) is enough; the
searches of a mode run in lockstep (:func:`search_many`: one thread per search, each
waiting for the others; every generation of all of them is one batch), which pays the kernels'
per-call overhead once per generation instead of once per search (1.3–1.5× faster, the
same designs). The search strategy is a setting (``strategy``). A positive
range spanning more than a decade (link lengths in [0.2, 50]) is searched on a log scale: on the
eighteen-point benchmark this took the runs from 0.0098–0.0306 to 0.0099 every time, and the
five-point runs to the optimum faster. A periodic angle (bounds spanning a whole turn, θ0, φ ∈
[0°, 360°]) is searched on a circle: its DE range is widened by half a turn each side and
wrapped back, so a basin at 0°/360° is one basin, not two halves cut at the box's edge.

**Local polish**: ``scipy.optimize.least_squares`` (trust-region reflective within the bounds)
on the residual vector with the analytic Jacobian (implicit function theorem: ∂q/∂p = −Φ_q⁻¹ Φ_p,
∂q/∂x = Φ_q⁻¹ b₁ for free input values, explicit ∂P/∂p from a generated kernel), from the
distinct basins the lockstep Levenberg–Marquardt ended in (:func:`loopsolve.design.synthesis.lockstep_lm.distinct`:
the same objective at the same place is one basin; a basin far above the best polished one is
skipped). An angle parameter whose bounds span a whole turn (θ0, φ ∈ [0°, 360°]) is periodic:
it is unbounded in the polish and wrapped into its bounds afterwards, so a design whose optimum
lies across 0°/360° is not stopped at the bound.

**Certificate** (:mod:`loopsolve.design.synthesis.certificate`): from the tracker (the public sweep), never from
the optimizer. A design is reported only when it is certified; rejected candidates are listed
with their defects in the report's ``statistics``.

Units: parameters and bounds in model units; angles in the report in the model's angle unit;
the objective in internal units (lengths², radians for angles) as the contract says.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from ...errors import ModelError, SynthesisError  # noqa: F401  (re-exported)
from ...model.units import Kind
from .targets import read_targets  # noqa: F401  (re-exported)

__all__ = ["Problem", "define", "read_targets", "evaluate", "search", "search_many", "polish", "SynthesisError"]

#: input step of the search's grid for free timing, and its largest continuation substep
_FREE_STEP = math.radians(10.0)
_SEARCH_H = math.radians(10.0)


# ---------------------------------------------------------------------------------------- problem


@dataclass(frozen=True, eq=False)
class Problem:
    """One synthesis job on one model (internal units; see the module docstring). Build with :func:`define`."""

    mech: object
    ck: object
    task: str
    point: str | None
    output: str | None
    link: str | None
    targets: np.ndarray  # (T, c): path x,y; function y; motion x,y,angle (internal units)
    inputs: np.ndarray | None  # (T,) internal, or None for free timing
    names: tuple[str, ...]
    lo: np.ndarray
    hi: np.ndarray
    crank: bool
    transmission: tuple[float, float] | None
    mode: str | None  # None: the guesses'; "any": the search's choice; or a signature
    L: float
    batch: object = field(repr=False)
    shown_inputs: tuple | None = None  # the prescribed inputs as the user gave them (model units)

    @property
    def free(self) -> bool:
        return self.inputs is None

    @property
    def T(self) -> int:
        return len(self.targets)

    def display_input(self, x) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        return np.degrees(x) if self.batch.input_is_angle and self.mech.units.angle == "deg" else x

    def residuals(self, Zt, P) -> np.ndarray:
        """``(m, T, D)`` residuals at the positions ``Zt`` ``(nv, T, D)`` of the designs ``P`` ``(npar, D)``."""
        b = self.batch
        nv, T, D = Zt.shape
        flat = Zt.reshape(nv, T * D)
        Pt = np.tile(P, (1, T))
        if self.task == "function":
            r = flat[self.ck.index(self.output)] - np.repeat(self.targets[:, 0], D)
            if self.ck.kinds[self.ck.index(self.output)] is Kind.ANGLE:  # an angle target in any turn
                r = (r + math.pi) % (2 * math.pi) - math.pi
            return r.reshape(1, T, D)
        pts = b.points(flat, Pt)[self.ck.points.index(self.point)]  # (2, T*D)
        r = pts - np.repeat(self.targets[:, :2].T, D, axis=1)
        if self.task == "path":
            return r.reshape(2, T, D)
        d = flat[self.ck.index(self.link)] - np.repeat(self.targets[:, 2], D)
        d = (d + math.pi) % (2 * math.pi) - math.pi
        return np.concatenate([r, (self.L * d)[None]], axis=0).reshape(3, T, D)

    def jacobian(self, Zt, P) -> tuple[np.ndarray, np.ndarray]:
        """``(dr/dv (m, T, k), dr/dx (m, T))`` of one design (D = 1): v the varied parameters (model units)."""
        b = self.batch
        Z = Zt[:, :, 0]
        Pt = np.repeat(P, Z.shape[1], axis=1)
        dq_dp, dq_dx = b.sensitivities(Z, Pt)  # (n, k, T), (n, T)
        pc = b.pconv[None, :, None]
        if self.task == "function":
            u = list(self.ck.unknowns).index(self.output)
            return (dq_dp[u] * pc[0]).T[None], dq_dx[u][None]
        ip = self.ck.points.index(self.point)
        dP, dPx = b.point_derivatives(Z, Pt, ip, dq_dp, dq_dx)  # (2, k, T), (2, T)
        Jp = np.moveaxis(dP * pc, 2, 1)  # (2, T, k)
        if self.task == "path":
            return Jp, dPx
        u = list(self.ck.unknowns).index(self.link)
        Ja = (self.L * dq_dp[u] * pc[0]).T[None]
        return np.concatenate([Jp, Ja], 0), np.concatenate([dPx, self.L * dq_dx[u][None]], 0)

    def modes(self, P) -> list[np.ndarray]:
        """The block-sign combinations to try: ``(nb, D)`` each."""
        b = self.batch
        D = P.shape[1]
        if self.mode == "any":
            return [np.repeat(s[:, None], D, axis=1) for s in b.all_signs()]
        if self.mode is None:
            return [b.guessed_signs(P)]
        s = np.array([1.0 if c == "+" else -1.0 if c == "-" else 0.0 for c in self.mode])
        return [np.repeat(s[:, None], D, axis=1)]

    def trace(self, P, X, signs, *, hmax=_SEARCH_H, singular_stop=True):
        """Positions at the inputs ``X`` ``(T', D)`` in the mode ``signs``: ``(Zt, reached)``."""
        b = self.batch
        Z, ok = b.assemble(P, X[0], signs)
        Z[:, ~ok] = np.nan
        return b.follow(Z, P, X, hmax=hmax, signs=signs, stop_on_singular=singular_stop)


def sign_string(signs) -> str:
    return "".join("+" if s > 0 else "-" if s < 0 else "0" for s in signs)


def define(mech, *, path: str | None = None, function: str | None = None, motion: str | None = None,
           link: str | None = None, targets=None, inputs=None, vary: Mapping | None = None, crank: bool = False,
           transmission=None, mode: str | None = "any", max_targets: int | None = None) -> Problem:
    """Check and build a :class:`Problem` (see :func:`synthesize` for the arguments).

    The targets are checked by :mod:`loopsolve.design.synthesis.limits` (at most ``max_targets``, default
    1000; none at the same prescribed input; no repeat in a row with free timing; an angle input's
    values within one turn)."""
    from ...kinematics.solve import input_value
    from .candidates import Batch
    from .limits import MAX_TARGETS, check_target_count, check_targets

    tasks = [(k, v) for k, v in (("path", path), ("function", function), ("motion", motion)) if v is not None]
    if len(tasks) != 1:
        raise ModelError("give exactly one task: --path POINT, --function OUT or --motion POINT --link VAR")
    task, what = tasks[0]
    ck = mech.compile()
    name = mech.source or mech.name
    if task in ("path", "motion") and what not in ck.points:
        raise ModelError(f"{name}: --{task} {what!r} is not a declared point; the points are "
                         f"{', '.join(ck.points) or 'none (add a [points] section)'}")
    if task == "function" and what not in ck.unknowns:
        raise ModelError(f"{name}: --function {what!r} is not an unknown of the model; the unknowns are "
                         f"{', '.join(ck.unknowns)}")
    if task == "motion":
        if link is None:
            raise ModelError("--motion needs --link VAR: the angle variable of the link whose pose is prescribed")
        if link not in ck.unknowns or ck.kinds[ck.index(link)] is not Kind.ANGLE:
            angles = [u for u in ck.unknowns if ck.kinds[ck.index(u)] is Kind.ANGLE]
            raise ModelError(f"{name}: --link {link!r} is not an angle unknown of the model; the angle unknowns "
                             f"are {', '.join(angles)}")
    elif link is not None:
        raise ModelError("--link is for --motion only")
    if targets is None:
        raise ModelError("--targets: a CSV file of targets is required")
    cols = read_targets(targets, task)
    T = len(next(iter(cols.values())))
    if T < 2:
        raise ModelError(f"--targets: {T} target(s); synthesis needs at least 2 (give more rows)")
    where = os.fspath(targets) if isinstance(targets, (str, os.PathLike)) and "\n" not in str(targets) else "targets"
    check_target_count(T, where, MAX_TARGETS if max_targets is None else max_targets)
    if not vary:
        raise ModelError("give at least one varied parameter: --vary NAME=LOW:HIGH")
    pnames = [p.name for p in mech.parameters]
    names, lo, hi = [], [], []
    for n, box in vary.items():
        if n not in pnames:
            raise ModelError(f"{name}: --vary {n}: not a parameter; the parameters are {', '.join(pnames) or 'none'}")
        try:
            a, b_ = (float(v) for v in box)
        except (TypeError, ValueError):
            raise ModelError(f"--vary {n}: expected bounds LOW:HIGH, got {box!r}") from None
        if not (math.isfinite(a) and math.isfinite(b_)):
            raise ModelError(f"--vary {n}={a}:{b_}: bounds must be finite numbers")
        if a >= b_:
            raise ModelError(f"--vary {n}={a:g}:{b_:g}: LOW must be smaller than HIGH")
        names.append(n)
        lo.append(a)
        hi.append(b_)
    xs = shown = None
    if inputs is not None and "input" in cols:
        raise ModelError("give the timing either as an input column of --targets or as --inputs, not both")
    if inputs is not None:
        if isinstance(inputs, str):
            inputs = [s for s in inputs.split(",") if s.strip()]
        if len(inputs) != T:
            raise ModelError(f"--inputs: {len(inputs)} values for {T} targets")
        xs = np.array([input_value(ck, v, reduce=False) for v in inputs])
        shown = [float(v) if _is_number(v) else None for v in inputs]
    elif "input" in cols:
        xs = np.array([input_value(ck, float(v), reduce=False) for v in cols["input"]])
        shown = [float(v) for v in cols["input"]]
    ang = mech.units.angle == "deg"
    if task == "path":
        tg = np.stack([cols["x"], cols["y"]], axis=1)
    elif task == "function":
        out = cols["output"]
        if ck.kinds[ck.index(what)] is Kind.ANGLE and ang:
            out = np.radians(out)
        tg = out[:, None]
    else:
        tg = np.stack([cols["x"], cols["y"], np.radians(cols["angle"]) if ang else cols["angle"]], axis=1)
    check_targets(ck, task, tg, xs, shown, where, "--inputs" if inputs is not None else f"--targets {where} (input column)")
    if xs is None and ck.kinds[ck.index(ck.inputs[0])] is not Kind.ANGLE:
        raise ModelError(f"{name}: free timing needs an angle input ({ck.inputs[0]} is a length): give the input "
                         "value of every target (--inputs or an input column)")
    if transmission is not None:
        if isinstance(transmission, str):
            try:
                transmission = tuple(float(v) for v in transmission.split(":"))
            except ValueError:
                raise ModelError(f"--transmission {transmission!r}: expected LO:HI in degrees") from None
        transmission = tuple(float(v) for v in transmission)
        if len(transmission) != 2 or not transmission[0] < transmission[1]:
            raise ModelError(f"--transmission {transmission}: expected LO:HI (degrees) with LO < HI")
        dyads = [b for b in ck.blocks if len(b.unknowns) == 2 and all(
            ck.kinds[int(ck.unknown_idx[c])] is Kind.ANGLE for c in b.unknowns)]
        if not dyads:
            raise ModelError(f"{name}: --transmission needs a dyad of two angle unknowns (the angle between its "
                             "links is the transmission angle); this model has none")
    if mode is not None and mode != "any":
        nb = len(ck.blocks)
        if len(mode) != nb or any(c not in "+-" for c in mode):
            raise ModelError(f"--mode {mode!r}: expected 'any', 'guesses' or a signature of {nb} signs (+/-)")
    L = 1.0
    if task == "motion":
        d = tg[:, None, :2] - tg[None, :, :2]
        L = float(np.sqrt(np.max(np.sum(d * d, axis=-1))))
        L = L if L > 0 else 1.0
    return Problem(mech, ck, task, what if task != "function" else None, what if task == "function" else None, link,
                   tg, xs, tuple(names), np.array(lo), np.array(hi), bool(crank), transmission, mode, L,
                   Batch(ck, names), None if shown is None or None in shown else tuple(shown))


def _is_number(v) -> bool:
    try:
        float(v)
    except (TypeError, ValueError):
        return False
    return True


# ---------------------------------------------------------------------------------------- search


def _big(problem) -> float:
    """A penalty per missed target larger than any attainable objective."""
    s = max(float(np.max(np.abs(problem.hi))), float(np.max(np.abs(problem.lo))), float(np.max(np.abs(problem.targets))), 1.0)
    return 1e3 * problem.T * s * s


def evaluate(problem: Problem, V, signs=None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Search objective of the designs ``V`` ``(D, k)``: ``(f, mode index, direction, inputs (T, D))``.

    Penalized: every target a design cannot reach in one continuous motion in one mode adds
    :func:`_big`; a design that fails a requirement (``crank``: its input cannot turn fully back
    to the first target's pose; ``transmission``: the angle leaves the bounds over the motion;
    :func:`loopsolve.design.synthesis.requirements.check`) adds one more, growing with how far it fails.
    ``signs`` ``(nb, D)``: each design's own mode instead of the problem's modes (the mode index
    is then 0).
    """
    from . import requirements

    b = problem.batch
    P = b.params(V)
    D = P.shape[1]
    big = _big(problem)
    best = np.full(D, np.inf)
    mode_ix = np.zeros(D, dtype=int)
    direc = np.ones(D, dtype=int)
    X_best = np.full((problem.T, D), np.nan)
    with np.errstate(all="ignore"):
        for m, signs in enumerate(problem.modes(P) if signs is None else [np.asarray(signs, dtype=float)]):
            if problem.free:
                f, d, X = _free_objective(problem, P, signs, big)
            else:
                f, d, X = _timed_objective(problem, P, signs, big)
            better = f < best
            best = np.where(better, f, best)
            mode_ix = np.where(better, m, mode_ix)
            direc = np.where(better, d, direc)
            X_best[:, better] = X[:, better]
    return best, mode_ix, direc, X_best


def _penalty(problem, P, big, Zg, full, mask=None):
    """The requirements' penalty of :func:`evaluate` from positions along the motion (see requirements.assess)."""
    from . import requirements

    ok, viol = requirements.assess(problem, P, Zg, full, mask)
    return np.where(ok, 0.0, big * (1.0 + viol / 90.0))


def _timed_objective(problem, P, signs, big):
    from . import requirements

    D = P.shape[1]
    xs = problem.inputs
    X = np.repeat(xs[:, None], D, axis=1)
    direction = 1 if xs[-1] >= xs[0] else -1
    T = problem.T
    if requirements.active(problem):  # one trace through the targets and the motion the requirements concern
        u = np.unique(np.r_[requirements.grid(problem, xs[:, None])[:, 0], xs])
        u = u if direction > 0 else u[::-1]
        at = np.array([int(np.argmin(np.abs(u - x))) for x in xs])
        Zu, ru = problem.trace(P, np.repeat(u[:, None], D, axis=1), signs)
        Zt = Zu[:, at]
        reached = np.sum(at[:, None] < ru[None, :], axis=0)
        extra = _penalty(problem, P, big, Zu, ru >= len(u))
    else:
        Zt, reached = problem.trace(P, X, signs)
        extra = 0.0
    R = problem.residuals(np.nan_to_num(Zt[:, :T]), P)
    e = np.sum(R * R, axis=0)  # (T, D)
    got = np.arange(T)[:, None] < reached[None, :]
    f = np.sum(np.where(got, e, 0.0), axis=0) + big * (T - np.minimum(reached, T)) + extra
    f = np.where(np.isfinite(f), f, big * (T + 2))
    return f, np.full(D, direction), X[:T]


def _free_objective(problem, P, signs, big):
    """Trace a turn each way on a grid and assign the targets to grid points in order (both directions)."""
    b = problem.batch
    D = P.shape[1]
    N = int(round(2 * math.pi / _FREE_STEP))
    x0 = b.x_guess
    ks = np.arange(N + 1)
    Xf = np.repeat((x0 + ks * _FREE_STEP)[:, None], D, axis=1)
    Zf, rf = problem.trace(P, Xf, signs, hmax=_FREE_STEP)
    Zb, rb = b.follow(Zf[:, 0], P, np.repeat((x0 - ks * _FREE_STEP)[:, None], D, axis=1), hmax=_FREE_STEP,
                      signs=signs)
    Zall = np.concatenate([Zb[:, ::-1], Zf[:, 1:]], axis=1)  # (nv, 2N+1, D) along increasing input
    xall = x0 + np.arange(-N, N + 1) * _FREE_STEP
    K = Zall.shape[1]
    T = problem.T
    # distance of every target to every grid point: residuals with the targets tiled
    Rt = _pair_errors(problem, Zall, P)  # (T, K, D)
    Rt = np.where(np.isfinite(Rt), Rt, np.inf)
    best_f = np.full(D, np.inf)
    best_dir = np.ones(D, dtype=int)
    best_X = np.full((T, D), np.nan)
    best_k = np.zeros((2, D), dtype=int)  # the first and last grid index of the motion
    for direction in (1, -1):
        E = Rt if direction == 1 else Rt[::-1]
        cost, idx = _monotone_assignment(E)
        span = idx[-1] - idx[0]
        cost = np.where(span <= N, cost, cost + big)
        Xd = xall[idx]
        if direction == -1:
            Xd = Xd[::-1]
        better = cost < best_f
        best_f = np.where(better, cost, best_f)
        best_dir = np.where(better, direction, best_dir)
        best_X[:, better] = Xd[:, better]
        best_k[:, better] = np.stack([idx[0], idx[-1]])[:, better]
    from . import requirements

    if requirements.active(problem) and D:
        if problem.crank:  # the turn from the guess: a design that turns fully turns from any of its poses
            best_f = best_f + _penalty(problem, P, big, Zf, rf >= N + 1)
        else:
            k = np.arange(K)[:, None]
            mask = (k >= best_k[0][None, :]) & (k <= best_k[1][None, :])
            full = np.all(np.isfinite(Zall) | ~mask[None], axis=(0, 1))
            best_f = best_f + _penalty(problem, P, big, Zall, full, mask)
    best_f = np.where(np.isfinite(best_f), best_f, big * (T + 2))
    return best_f, best_dir, best_X


def _pair_errors(problem, Zall, P):
    """``(T, K, D)`` squared error of target t at grid position k."""
    nv, K, D = Zall.shape
    flat = Zall.reshape(nv, K * D)
    Pt = np.tile(P, (1, K))
    b = problem.batch
    T = problem.T
    if problem.task == "function":
        y = flat[problem.ck.index(problem.output)]
        d = y[None, :] - problem.targets[:, :1]
        if problem.ck.kinds[problem.ck.index(problem.output)] is Kind.ANGLE:
            d = (d + math.pi) % (2 * math.pi) - math.pi
        return (d ** 2).reshape(T, K, D)
    pts = np.nan_to_num(b.points(np.nan_to_num(flat), Pt)[problem.ck.points.index(problem.point)], nan=np.inf)
    pts = np.where(np.all(np.isfinite(flat), axis=0), pts, np.inf)
    e = (pts[0][None] - problem.targets[:, :1]) ** 2 + (pts[1][None] - problem.targets[:, 1:2]) ** 2
    if problem.task == "motion":
        a = flat[problem.ck.index(problem.link)][None] - problem.targets[:, 2:3]
        a = (a + math.pi) % (2 * math.pi) - math.pi
        e = e + (problem.L * a) ** 2
    return e.reshape(T, K, D)


def _monotone_assignment(E):
    """Min over k_1 ≤ k_2 ≤ … of Σ_t E[t, k_t] for every design: ``(cost (D,), k (T, D))``."""
    T, K, D = E.shape
    ar = np.arange(K)[:, None]
    cost = E[0]
    back = []
    for t in range(1, T):
        cm = np.minimum.accumulate(cost, axis=0)
        arg = np.maximum.accumulate(np.where(cost <= cm, ar, 0), axis=0)
        back.append(arg)
        cost = E[t] + cm
    k = np.argmin(cost, axis=0)
    out = [k]
    cols = np.arange(D)
    for t in range(T - 2, -1, -1):
        k = back[t][k, cols]
        out.append(k)
    return np.min(cost, axis=0), np.array(out[::-1])


class _Lockstep:
    """Evaluate the generations of several DE searches (one thread each) as one batch.

    Each search thread hands its generation to :meth:`__call__` and waits; when every search
    still running has handed one in, the last arrival evaluates their concatenation in one call
    of :func:`evaluate` (the kernels' per-call overhead is paid once for all of them) and hands
    every thread its own columns back. A design's objective does not depend on the other
    columns of the batch, so each search follows the same course as when run alone.
    """

    def __init__(self, problem, n, parts=None):
        import threading

        self.problem = problem
        self.parts = parts  # ident -> the one-mode problem of that search (searches of several modes)
        self.active = n
        self.pending = {}
        self.results = {}
        self.cv = threading.Condition()

    def __call__(self, ident, V):
        with self.cv:
            self.pending[ident] = V
            self._maybe_run()
            while ident not in self.results:
                self.cv.wait()
            out = self.results.pop(ident)
        if isinstance(out, BaseException):
            raise out
        return out

    def done(self):
        with self.cv:
            self.active -= 1
            self._maybe_run()

    def _maybe_run(self):
        if not self.pending or len(self.pending) < self.active:
            return
        items = list(self.pending.items())
        self.pending.clear()
        try:
            V = np.vstack([v for _, v in items])
            signs = None
            if self.parts is not None:  # each search's own mode, all modes in one batch
                signs = np.hstack([self.parts[i].modes(self.problem.batch.params(v))[0] for i, v in items])
            f, mi, di, X = evaluate(self.problem, V, signs)
            a = 0
            for ident, v in items:
                n = v.shape[0]
                self.results[ident] = (f[a:a + n], mi[a:a + n], di[a:a + n], X[:, a:a + n])
                a += n
        except BaseException as exc:  # every waiting search gets the error, none hangs
            for ident, _ in items:
                self.results[ident] = exc
        self.cv.notify_all()


def search_many(problem: Problem, seeds, *, problems=None, **kwargs) -> list:
    """Several seeded :func:`search` runs on one problem whose generations are evaluated together.

    Returns the list of :func:`search` results, in the order of ``seeds``; each is the one
    ``search(problem, seed=s, **kwargs)`` returns (the searches run in lockstep threads that
    only wait on each other, so one batch of all their populations is evaluated per generation).
    ``problems``: one one-mode problem per seed (the searches of several assembly modes of
    ``problem`` in one batch per generation); search i then runs on ``problems[i]``.
    """
    import threading

    seeds = list(seeds)
    subs = list(problems) if problems is not None else [problem] * len(seeds)
    if len(seeds) <= 1:
        return [search(sub, seed=s, **kwargs) for sub, s in zip(subs, seeds)]
    step = _Lockstep(problem, len(seeds), dict(enumerate(subs)) if problems is not None else None)
    out = [None] * len(seeds)

    def work(i, s):
        try:
            out[i] = search(subs[i], seed=s, _evaluate=lambda V: step(i, V), **kwargs)
        except BaseException as exc:
            out[i] = exc
        finally:
            step.done()

    threads = [threading.Thread(target=work, args=(i, s), daemon=True) for i, s in enumerate(seeds)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for r in out:
        if isinstance(r, BaseException):
            raise r
    return out


def search(problem: Problem, *, seed: int = 0, popsize: int = 15, maxiter: int = 400, tol: float = 1e-3,
           strategy: str = "best1bin", progress=None, _evaluate=None):
    """One seeded differential-evolution run; returns the final population sorted by objective.

    Returns ``(V (S, k), f (S,), mode index (S,), direction (S,), inputs (T, S), generations, evaluations,
    history)``; ``history`` is the best objective of every evaluated batch (the convergence).
    ``_evaluate``: the batch evaluation of a generation (default :func:`evaluate` on ``problem``;
    :func:`search_many` passes its lockstep batcher).
    """
    from scipy.optimize import differential_evolution

    if _evaluate is None:
        def _evaluate(V):
            return evaluate(problem, V)

    k = len(problem.names)
    # a positive range spanning more than a decade (a link length in [0.2, 50]) is searched on a
    # log scale: a uniform sample of the box would put almost no design at the small lengths
    logs = (problem.lo > 0) & (problem.hi >= 10 * problem.lo)
    lo_u = np.where(logs, np.log(np.where(logs, problem.lo, 1.0)), problem.lo)
    hi_u = np.where(logs, np.log(np.where(logs, problem.hi, 1.0)), problem.hi)
    # a periodic angle (bounds spanning a whole turn) is searched on a circle: its search range is
    # widened by half a turn each side and wrapped back into its bounds, so a basin at 0°/360° is
    # one basin (seen twice), not two halves cut by the box (DE resamples a mutant outside the box)
    per, period = periodic(problem)
    lo_u = np.where(per, problem.lo - period / 2, lo_u)
    hi_u = np.where(per, problem.hi + period / 2, hi_u)

    def to_values(U):  # (k, S) search coordinates -> (S, k) model values
        V = np.where(logs[:, None], np.exp(U), U)
        V = np.where(per[:, None], (problem.lo + np.mod(U.T - problem.lo, period)).T, V)
        return V.T

    bounds = list(zip(lo_u, hi_u))
    state = {"n": 0, "gen": 0, "history": []}
    archive_v, archive_f = [], []  # the best designs of every generation: basins the final population left

    def fun(x):
        Vx = to_values(x)
        f, _, _, _ = _evaluate(Vx)
        state["n"] += x.shape[1]
        state["history"].append(float(np.min(f)) if f.size else math.inf)
        for i in np.argsort(f)[:3]:
            if np.isfinite(f[i]):
                archive_v.append(Vx[i].copy())
                archive_f.append(float(f[i]))
        return f

    def cb(*args, **kwargs):
        state["gen"] += 1
        if progress is not None:
            progress.update(1)

    res = differential_evolution(fun, bounds, vectorized=True, updating="deferred", popsize=popsize,
                                 maxiter=maxiter, tol=tol, seed=seed, init="latinhypercube", polish=False,
                                 callback=cb, strategy=strategy)
    V = np.vstack([to_values(np.atleast_2d(res.x).T), to_values(np.asarray(res.population).T)])
    V = np.clip(V, problem.lo, problem.hi)
    if archive_v:
        order = np.argsort(archive_f)[:20 * max(1, k)]
        V = np.vstack([V, np.array(archive_v)[order]])
    f, mi, di, X = evaluate(problem, V)
    order = np.argsort(f, kind="stable")
    return V[order], f[order], mi[order], di[order], X[:, order], state["gen"], state["n"], state["history"]


# ---------------------------------------------------------------------------------------- polish


def periodic(problem: Problem) -> tuple[np.ndarray, np.ndarray]:
    """``(mask, period)`` of the varied parameters: angles whose bounds span a whole turn (model units)."""
    b = problem.batch
    ang = np.array([b.mech.parameters[i].kind is Kind.ANGLE for i in b.pidx], dtype=bool)
    period = 2 * math.pi / b.pconv
    return ang & ((problem.hi - problem.lo) >= period * (1 - 1e-12)), period


def polish(problem: Problem, values, *, signs=None, inputs=None, max_nfev: int = 200,
           hmax: float = math.radians(5)) -> dict:
    """Local least-squares polish from ``values`` (model units, one per varied parameter).

    ``signs``: the mode (block signs; default: the best of the problem's modes at ``values``);
    ``inputs``: internal input values at the targets (free timing: the start of the unknown
    input values; prescribed: ignored). Returns a dict with ``values``, ``inputs``, ``signs``,
    ``objective``, ``Z`` (positions at the targets) or ``objective = inf`` when the start
    cannot be traced. ``hmax``: the trace's largest input step (internal units; smaller follows
    designs whose output turns fast, e.g. near a limit position).
    """
    from scipy.optimize import least_squares

    from . import requirements

    b = problem.batch
    v0 = np.clip(np.asarray(values, dtype=float), problem.lo, problem.hi)
    k = len(v0)
    if signs is None or (inputs is None and problem.free):
        f, mi, di, X = evaluate(problem, v0[None])
        if not np.isfinite(f[0]):
            return {"objective": math.inf}
        signs = problem.modes(b.params(v0[None]))[mi[0]][:, 0]
        if inputs is None:
            inputs = X[:, 0]
    if not problem.free:
        inputs = problem.inputs
    inputs = np.asarray(inputs, dtype=float)
    T = problem.T
    free = problem.free
    sg = np.asarray(signs, dtype=float)[:, None]
    cache = {}

    last = {}

    def state(u):
        key = u.tobytes()
        if key not in cache:
            v = u[:k]
            x = u[k:] if free else inputs
            P = b.params(v[None])
            ok = False
            if "Z" in last:  # warm start: Newton at every target from the last accepted positions
                Z = last["Z"].copy()
                Z[b.ix] = x
                PT = np.repeat(P, T, axis=1)
                ok = bool(np.all(b.newton(Z, PT, np.repeat(sg, T, axis=1))))
                if ok:
                    Zt, reached = Z[:, :, None], T
            if not ok:
                with np.errstate(all="ignore"):
                    Zt, r = problem.trace(P, x[:, None], sg, hmax=hmax, singular_stop=False)
                reached = int(r[0])
            if reached >= T and wall["on"] and not requirements.check(problem, P, sg, x[:, None])[0][0]:
                reached = -1  # a trial design that fails a requirement is a wall, like one that cannot be traced
            if reached >= T:
                last["Z"] = Zt[:, :, 0].copy()
            cache.clear()
            cache[key] = (P, Zt, reached)
        return cache[key]

    r_fail = None

    def fun(u):  # a step that leaves the mode or cannot be traced gets a large constant residual
        P, Zt, reached = state(u)
        if reached < T:
            return r_fail
        r = problem.residuals(Zt, P)[:, :, 0].T.ravel()
        return r if np.all(np.isfinite(r)) else r_fail

    def jac(u):
        P, Zt, reached = state(u)
        m = 2 if problem.task == "path" else 1 if problem.task == "function" else 3
        if reached < T:
            return np.zeros((T * m, len(u)))
        Jp, Jx = problem.jacobian(Zt, P)  # (m, T, k), (m, T)
        J = np.transpose(Jp, (1, 0, 2)).reshape(T * m, k)
        if free:
            Jx_full = np.zeros((T, m, T))
            for t in range(T):
                Jx_full[t, :, t] = Jx[:, t]
            J = np.hstack([J, Jx_full.reshape(T * m, T)])
        return J

    # the requirements (crank, transmission) cost a trace per trial design: polished first without
    # them; only when that polish ends failing them is it redone with every trial design within them
    wall = {"on": False}
    u0 = np.concatenate([v0, inputs]) if free else v0
    P0, Zt0, reached0 = state(u0)
    if reached0 < T:
        return {"objective": math.inf, "values": v0, "inputs": inputs, "signs": sg[:, 0]}
    r0 = fun(u0)
    r_fail = np.full_like(r0, 10 * max(1.0, float(np.max(np.abs(r0)))) + 1.0)
    # an angle whose bounds span a whole turn is periodic: unbounded here, wrapped into its bounds
    # after (a bound at 0° or 360° would stop a design whose optimum lies across it)
    per, period = periodic(problem)
    plo, phi_ = np.where(per, -np.inf, problem.lo), np.where(per, np.inf, problem.hi)

    def solve(blo, bhi):
        lo = np.concatenate([blo, np.full(T, -np.inf)]) if free else blo
        hi = np.concatenate([bhi, np.full(T, np.inf)]) if free else bhi
        with np.errstate(all="ignore"):
            res = least_squares(fun, u0, jac=jac, bounds=(lo, hi), method="trf", x_scale="jac", ftol=1e-15,
                                xtol=1e-15, gtol=1e-15, max_nfev=max_nfev)
        return res.x if float(np.sum(fun(res.x) ** 2)) <= float(np.sum(r0 ** 2)) else u0

    def run():
        u = solve(plo, phi_)
        if np.any(per):
            uw = u.copy()
            uw[:k][per] = problem.lo[per] + np.mod(u[:k][per] - problem.lo[per], period[per])
            if not np.array_equal(uw, u):
                f_u, f_w = float(np.sum(fun(u) ** 2)), float(np.sum(fun(uw) ** 2))
                u = uw if abs(f_w - f_u) <= 1e-9 * f_u + 1e-24 else solve(problem.lo, problem.hi)
        return u

    u = run()
    if requirements.active(problem):
        P, Zt, reached = state(u)
        x = u[k:] if free else inputs
        if reached < T or not requirements.check(problem, P, sg, x[:, None])[0][0]:
            wall["on"] = True
            cache.clear()
            last.clear()
            if state(u0)[2] < T:  # the start itself fails the requirements
                return {"objective": math.inf, "values": v0, "inputs": inputs, "signs": sg[:, 0]}
            u = run()
    P, Zt, reached = state(u)
    if reached < T:
        return {"objective": math.inf, "values": u[:k], "inputs": inputs, "signs": sg[:, 0]}
    r = problem.residuals(Zt, P)
    return {"values": u[:k], "inputs": u[k:] if free else inputs, "signs": sg[:, 0],
            "objective": float(np.sum(r * r)), "errors": np.sqrt(np.sum(r * r, axis=0))[:, 0], "Z": Zt[:, :, 0]}
