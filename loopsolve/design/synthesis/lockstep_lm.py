"""Lockstep Levenberg–Marquardt: many synthesis starts polished together, one batch per iteration.

Why: the global search of :mod:`loopsolve.design.synthesis.problem` ends with populations whose members lie
in many basins, and the basin a local polish falls into, not the search's best value, decides
a run's result (on the eighteen-point benchmark the searches end at f ≈ 4–15 and their
polishes reach 0.0098–0.04). Polishing one start at a time with ``least_squares`` costs a few
tenths of a second each, so only a handful could be polished. Here every start is one column
of one batch: each iteration is one trace of all trial designs through the targets and one
batched sensitivity solve (implicit function theorem, as :meth:`Problem.jacobian`), then a
damped Gauss–Newton step per column with its own damping (Marquardt's scaling; a step is
accepted only when it lowers that column's objective and its design still reaches every
target in its mode). Hundreds of starts cost about as much as a few scalar polishes. The
results are then clustered (:func:`distinct`) and only the distinct best basins go on to the
exact scalar polish and the certificate (:func:`loopsolve.design.synthesis.run.one_run`).

Bounds: a non-periodic parameter is clipped into its bounds; a periodic angle (bounds spanning
a whole turn) is wrapped. Free timing: the input values at the targets are variables too.

Cost (measured on the five-point benchmark, where the lockstep LM was ~0.55 s of a 1.3 s run):
an iteration's cost hardly depends on the number of columns (Python overhead of the trace's
substeps), so what pays is fewer iterations and cheaper ones. A trial design is a small step
from the last accepted one, so its first position is Newton from the last position
(:meth:`~loopsolve.design.synthesis.candidates.Batch.reassemble`; the multistart assembly only where that
fails) — the same root of the same mode, found without Newton from many starts per block. With
the floor of :func:`loopsolve.design.synthesis.run._polish_floor` given, the batch stops once three
columns agree on an exact fit (the rest crawl along a valley at 1.7e5 times the optimum to the
iteration cap).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["batch_lm", "distinct", "multistart", "sample"]

#: the trace step (the exact polish's 5°: at the search's 10° the trace loses designs whose output turns
#: fast, and the eighteen-point runs lost the 9.03e-3 basin) and the largest change of a free input per step
POLISH_H = math.radians(5.0)
_FREE_STEP = math.radians(10.0)


def residuals_and_jacobian(problem, V, X, signs, hmax, start=None, warm=False, retrace=True):
    """Residual vectors ``(D, M)``, Jacobians ``(D, M, k [+ T])``, the reached flags of designs ``V`` ``(D, k)``
    and their positions at the first target ``(nv, D)`` (``warm``: at every target, ``(nv, T, D)``).

    ``start``: positions at the first target of nearby designs (the last accepted step's), from
    which the first position is found by Newton (:meth:`Batch.reassemble`) instead of the
    multistart assembly of :meth:`Problem.trace`; the trace through the targets is the same.
    ``warm`` (``start`` then ``(nv, T, D)``): the position at *every* target by Newton from the
    nearby design's there, in its mode — one batch of T·D columns instead of a trace through the
    targets; a design whose Newton fails at some target is traced as above (``retrace``) or reported
    as not reached (``retrace=False``, nor assembled anew from many starts: the caller rejects that trial
    step). (The poses are of
    the asked mode at every target but not checked to be one continuous motion: shape synthesis,
    which uses this, certifies its designs with the tracker.)
    """
    b = problem.batch
    T = problem.T
    P = b.params(V)
    D = P.shape[1]
    with np.errstate(all="ignore"):
        if start is None:
            Zt, reached = problem.trace(P, X, signs, hmax=hmax, singular_stop=False)
        elif warm:
            Zt, reached = _warm_poses(problem, start, P, X, signs, hmax, retrace)
        else:
            Z0, ok0 = b.reassemble(start, P, X[0], signs)
            Z0[:, ~ok0] = np.nan
            Zt, reached = b.follow(Z0, P, X, hmax=hmax, signs=signs, stop_on_singular=False)
        first = Zt[:, :T].copy() if warm else Zt[:, 0].copy()
        ok = reached >= T
        Zt = np.where(ok[None, None, :], Zt, np.nan)
        Zs = np.nan_to_num(Zt[:, :T])
        R = problem.residuals(Zs, P)  # (m, T, D)
        m = R.shape[0]
        r = np.transpose(R, (2, 1, 0)).reshape(D, T * m)  # per design: target-major, as polish
        ok &= np.all(np.isfinite(r), axis=1)
        flat = Zs.reshape(Zs.shape[0], T * D)  # column t*D + d, as Problem.residuals
        Pt = np.tile(P, (1, T))
        dq_dp, dq_dx = b.sensitivities(flat, Pt)  # (n, k, T*D), (n, T*D)
        k = len(b.pidx)
        pc = b.pconv[None, :, None]
        if problem.task == "function":
            u = list(problem.ck.unknowns).index(problem.output)
            Jp = (dq_dp[u][None] * pc)  # (1, k, T*D)
            Jx = dq_dx[u][None]
        else:
            ip = problem.ck.points.index(problem.point)
            Jp, Jx = b.point_derivatives(flat, Pt, ip, dq_dp, dq_dx)
            Jp = Jp * pc
            if problem.task == "motion":
                u = list(problem.ck.unknowns).index(problem.link)
                Jp = np.concatenate([Jp, problem.L * dq_dp[u][None] * pc], 0)
                Jx = np.concatenate([Jx, problem.L * dq_dx[u][None]], 0)
        Jp = Jp.reshape(m, k, T, D).transpose(3, 2, 0, 1).reshape(D, T * m, k)
        if problem.free:
            Jx = Jx.reshape(m, T, D).transpose(2, 1, 0)  # (D, T, m)
            Jxf = np.zeros((D, T, m, T))
            ar = np.arange(T)
            Jxf[:, ar, :, ar] = np.transpose(Jx, (1, 0, 2))
            Jp = np.concatenate([Jp, Jxf.reshape(D, T * m, T)], axis=2)
        ok &= np.all(np.isfinite(Jp), axis=(1, 2))
    return r, Jp, ok, first


def _warm_poses(problem, start, P, X, signs, hmax, retrace=True):
    """Positions at every target by Newton from ``start`` ``(nv, T, D)`` (see :func:`residuals_and_jacobian`)."""
    b = problem.batch
    T, D = X.shape
    nv = start.shape[0]
    Zs = start.reshape(nv, T * D)  # column t*D + d
    PT = np.tile(P, (1, T))
    S = np.tile(signs, (1, T))
    Z, ok = b.reassemble(Zs, PT, X.reshape(-1), S, multistart=retrace)
    ok = ok.reshape(T, D).all(axis=0)
    Zt = np.where(ok[None, None, :], Z.reshape(nv, T, D), np.nan)
    reached = np.where(ok, T, 0)
    bad = np.flatnonzero(~ok)
    if bad.size and retrace:  # traced from the first target's position, as without warm poses
        Z0, ok0 = b.reassemble(start[:, 0, bad], P[:, bad], X[0, bad], signs[:, bad])
        Z0[:, ~ok0] = np.nan
        Zb, rb = b.follow(Z0, P[:, bad], X[:, bad], hmax=hmax, signs=signs[:, bad], stop_on_singular=False)
        Zt[:, :, bad] = Zb
        reached[bad] = rb
    return Zt, reached


#: the exact-fit stop of :func:`batch_lm`: once this many columns agree on the best objective (to a
#: relative ``_AGREE_RTOL``, or ``_AGREE_ATOL`` times the floor for a zero optimum) and it is below the
#: floor (an exact fit), the whole batch stops. On the five-point benchmark three columns agree on
#: 7.4158e-7 after 14–37 iterations (six seeds) of the 60 the crawling columns would take.
_AGREE = 3
_AGREE_RTOL = 1e-6
_AGREE_ATOL = 1e-12


def batch_lm(problem, V, signs, X=None, *, iters: int = 25, hmax: float = POLISH_H, floor: float | None = None,
             warm: bool = False, poses: bool = False, trust: bool = False, stall=None, pin: bool = False,
             free_step: float | None = None):
    """Levenberg–Marquardt on every row of ``V`` ``(D, k)`` (model units) in its mode ``signs`` ``(nb, D)``.

    ``X``: the internal input values at the targets ``(T, D)`` (free timing: the starts of those
    unknowns; prescribed: ignored). Returns ``(V, X, f)``: the improved designs, their inputs and
    objectives (``inf`` where a start cannot be traced through the targets).

    A column stops iterating when its step no longer lowers its objective by a relative 1e-12
    (converged) or when damping has grown past 1e8 (stuck). With ``floor`` given, once ``_AGREE``
    columns agree on the best objective and it is below ``floor`` (independent starts confirm one
    exact-fit basin bottom), every column stops and is returned as it stands. (A rule that dropped
    columns 1e4 times worse than the best after ten iterations was tried and removed: on a
    free-timing half circle the column that ends at f ≈ 1e-30 was above that early, and the run
    ended at 2.4e-7.) ``warm``: a trial design's positions at every target by Newton from the last
    accepted ones (:func:`residuals_and_jacobian`), checked every ``_VALIDATE`` iterations and at
    the end by a trace through the targets (:func:`_validate`: a column that left the one motion
    goes back to where it last passed and stops); shape synthesis uses it. ``poses`` (with ``warm``): also
    return the positions at every target of each returned design ``(nv, T, D)`` (NaN where ``f`` is
    ``inf``), the ones its last validating trace found, so the caller need not trace them again.

    ``trust`` (shape synthesis): MINPACK's scaling and Nielsen's damping instead of Marquardt's — the
    damping scales with the largest squared norm every Jacobian column has had (not the current one),
    grows ×2, ×4, ×8… on a rejected step and shrinks by the gain ratio (actual over predicted decrease)
    on an accepted one, and the free inputs' step is not capped. The plain rule crawls along the
    valleys of the shape fits (a planted four-bar took 400 iterations to its exact dimensions); with
    these the lockstep LM leaves them in as few evaluations as MINPACK's (scipy's ``least_squares(method="lm")``,
    which shape synthesis used to run on each basin after 40 lockstep iterations), for all starts at
    once. Its warm steps are checked at :data:`_TRUST_VALIDATE` iterations and at the end.
    ``stall=(n, drop)``: a column also stops once its objective fell by less than ``drop`` (relative)
    over its last ``n`` iterations (after ``2 n``).

    ``pin``: an active set for the bounds. A (non-periodic) parameter on its bound whose gradient pushes
    it outward is held there for that step — removed from the damped system — instead of being clipped
    after a step computed as if it could move: the clipped step's other components were solved for a
    move that did not happen, so a column with a length at its bound (the published ellipse's optimum
    has one at 80) crawls. ``free_step`` (radians or the input's length unit): the largest change of
    a free input per step (the step keeps its direction), also with ``trust``: a long jump of the input
    can pass a branch point or a limit of the motion (without ``trust`` the cap is :data:`_FREE_STEP`).

    Requirements (``crank``, ``transmission``; :mod:`loopsolve.design.synthesis.requirements`): the columns are
    first polished without them; the columns whose ends fail them and are better than every end
    that passes are polished again from their starts, each step accepted only when the design still
    passes (the constrained iterations trace every column over the motion once more, so only where
    the unconstrained polish left the requirements).
    """
    from . import requirements

    if not requirements.active(problem):
        out = _lm(problem, V, signs, X, iters, hmax, floor, False, warm, trust, stall, pin, free_step)
        return out if poses and warm else out[:3]
    # the requirements (crank, transmission) cost a trace per iteration: first without them; the
    # columns that end failing them are polished again from their starts, every step kept within them
    Vr, Xr, fr, Zr = _lm(problem, V, signs, X, iters, hmax, floor, False, warm, trust, stall, pin, free_step)
    fin = np.isfinite(fr)
    ok = fin.copy()
    if ok.any():
        ok[ok] = requirements.check(problem, problem.batch.params(Vr[ok]), np.asarray(signs, dtype=float)[:, ok],
                                Xr[:, ok])[0]
    # (a start that cannot be traced stays so; a column whose end is already worse than a passing end is not
    # redone: within the requirements it would end no better in the same basin)
    best_ok = float(np.min(fr[ok])) if ok.any() else math.inf
    redo = np.flatnonzero(fin & ~ok & (fr < best_ok))
    if redo.size:
        Vs = np.asarray(V, dtype=float)[redo]
        Xs = None if X is None or not problem.free else np.asarray(X, dtype=float)[:, redo]
        v2, x2, f2, z2 = _lm(problem, Vs, np.asarray(signs, dtype=float)[:, redo], Xs, iters, hmax, floor, True,
                             warm, trust, stall, pin, free_step)
        Vr[redo], Xr[:, redo], fr[redo] = v2, x2, f2
        if Zr is not None:
            Zr[..., redo] = z2
    return (Vr, Xr, fr, Zr) if poses and warm else (Vr, Xr, fr)


def _lm(problem, V, signs, X, iters, hmax, floor, need, warm, trust=False, stall=None, pin=False, free_step=None):
    """The lockstep Levenberg–Marquardt of :func:`batch_lm`; ``need``: every step within the requirements;
    ``warm``: warm poses at every target, validated by traces. Returns ``(V, X, f, Z)``, ``Z`` the validated
    positions at every target ``(nv, T, D)`` with ``warm``, else None."""
    from . import requirements
    from .problem import periodic

    b = problem.batch
    V = np.array(V, dtype=float)
    D, k = V.shape
    T = problem.T
    if problem.free:
        X = np.array(X, dtype=float)
    else:
        X = np.repeat(problem.inputs[:, None], D, axis=1)
    signs = np.asarray(signs, dtype=float)
    per, period = periodic(problem)
    lo, hi = problem.lo, problem.hi

    def project(Vt):
        Vw = lo + np.mod(Vt - lo, period)
        return np.where(per, Vw, np.clip(Vt, lo, hi))

    V = project(V)
    r, J, ok, Z0 = residuals_and_jacobian(problem, V, X, signs, hmax, warm=warm)
    if need and ok.any():  # a start that fails the requirements is not polished (its steps could not be judged)
        ok[ok] = requirements.check(problem, b.params(V[ok]), signs[:, ok], X[:, ok])[0]
    checked = None
    if warm:  # the starts, traced through their targets: the first checked states
        checked = {"V": V.copy(), "X": X.copy(), "f": np.where(ok, np.sum(r * r, axis=1), np.inf),
                   "Z": np.where(ok[None, None, :], Z0, np.nan)}
    f = np.where(ok, np.sum(r * r, axis=1), np.inf)
    lam = np.full(D, 1e-3)
    nu = np.full(D, 2.0)
    active = ok.copy()
    nk = k + (T if problem.free else 0)
    eye = np.eye(nk)
    scl = np.zeros((D, nk))  # (trust) the running largest squared column norms: MINPACK's scaling
    hist = [f.copy()]  # (stall) every column's objective after each evaluation
    for it in range(iters):
        if floor is not None and np.isfinite(f).any():
            best = float(np.min(f))
            if best <= floor and np.count_nonzero(f <= best * (1 + _AGREE_RTOL) + _AGREE_ATOL * floor) >= _AGREE:
                break
        if not active.any():
            break
        a = np.flatnonzero(active)
        Ja, ra = J[a], r[a]
        if trust:  # (matmul: BLAS; einsum loops, a third of an iteration at 15 columns × 64 residuals × 41 unknowns)
            Jt = np.swapaxes(Ja, 1, 2)
            A = Jt @ Ja
            g = (Jt @ ra[:, :, None])[:, :, 0]
        else:
            A = np.einsum("dmi,dmj->dij", Ja, Ja)
            g = np.einsum("dmi,dm->di", Ja, ra)
        dA = np.einsum("dii->di", A)
        if trust:
            scl[a] = np.maximum(scl[a], dA)
            dA = scl[a]
        M = A + (lam[a, None, None] * (dA[:, :, None] + 1e-12)) * eye
        if pin:  # the active set: a parameter on its bound pushed outward by the gradient stays put this step
            Va = V[a]
            out_ = ~per & (((Va <= lo) & (g[:, :k] > 0)) | ((Va >= hi) & (g[:, :k] < 0)))
            if out_.any():
                held = np.concatenate([out_, np.zeros((len(a), nk - k), dtype=bool)], axis=1)
                keep = ~held
                M = M * (keep[:, :, None] & keep[:, None, :]) + held[:, :, None] * eye
                g = np.where(held, 0.0, g)
        with np.errstate(all="ignore"):
            try:
                step = -np.linalg.solve(M, g[:, :, None])[:, :, 0]
            except np.linalg.LinAlgError:
                step = -np.stack([np.linalg.lstsq(Mi, gi, rcond=None)[0] for Mi, gi in zip(M, g)])
        good = np.all(np.isfinite(step), axis=1)
        cap = free_step if trust else (_FREE_STEP if free_step is None else free_step)
        if problem.free and cap is not None:  # a trust region on the input values: a long jump would be a long
            # trace (and would leave the turn the targets were assigned in); the step keeps its direction
            big = np.max(np.abs(step[:, k:]), axis=1)
            step = step * np.minimum(1.0, cap / np.where(big > 0, big, 1.0))[:, None]
        Vn = project(V[a] + np.where(good[:, None], step[:, :k], 0.0))
        Xn = X[:, a] + (np.where(good[:, None], step[:, k:], 0.0).T if problem.free else 0.0)
        # (trust: a trial whose poses Newton cannot reach from the last ones is a rejected step, not traced: the
        # damping grows and the next step is shorter; on an open half circle the traces were half the polish)
        rn, Jn, okn, Z0n = residuals_and_jacobian(problem, Vn, Xn, signs[:, a], hmax, start=Z0[..., a], warm=warm,
                                                  retrace=not trust)
        fn = np.where(okn & good, np.sum(rn * rn, axis=1), np.inf)
        acc = fn < f[a]
        if need and acc.any():  # a step must keep the design within the requirements (crank, transmission)
            ia_ = np.flatnonzero(acc)
            Xa = Xn[:, ia_] if problem.free else X[:, a[ia_]]
            acc[ia_] = requirements.check(problem, b.params(Vn[ia_]), signs[:, a[ia_]], Xa)[0]
        ia = a[acc]
        # a column whose step no longer lowers f by a relative 1e-12 has converged
        small = acc & (f[a] - fn <= 1e-12 * f[a] + 1e-300)
        if trust:  # Nielsen's damping from the gain ratio (actual over predicted decrease)
            s_ = np.concatenate([Vn - V[a], (Xn - X[:, a]).T], axis=1) if problem.free else Vn - V[a]
            lin = ra + (Ja @ s_[:, :, None])[:, :, 0]
            with np.errstate(all="ignore"):
                rho = (f[a] - fn) / (f[a] - np.sum(lin * lin, axis=1))
            rho = np.where(np.isfinite(rho), rho, 0.0)
            fac = np.maximum(1.0 / 3.0, 1.0 - (2.0 * np.clip(rho, 0.0, 1.0) - 1.0) ** 3)
            lam[ia] = np.maximum(lam[ia] * fac[acc], 1e-12)
            nu[ia] = 2.0
            rej = a[~acc]
            lam[rej] *= nu[rej]
            nu[rej] *= 2.0
        else:
            lam[ia] = np.maximum(lam[ia] / 3.0, 1e-9)
            lam[a[~acc]] *= 4.0
        V[ia], r[ia], J[ia], f[ia] = Vn[acc], rn[acc], Jn[acc], fn[acc]
        Z0[..., ia] = Z0n[..., acc]
        if problem.free:
            X[:, ia] = Xn[:, acc]
        active[a[small]] = False
        active[a[~acc & (lam[a] > (1e10 if trust else 1e8))]] = False
        if stall is not None:
            hist.append(f.copy())
            n_, drop = stall
            if len(hist) > 2 * n_:
                active &= ~(f >= (1.0 - drop) * hist[-1 - n_])
        due = (it + 1) in _TRUST_VALIDATE if trust else (it + 1) % _VALIDATE == 0
        if warm and (due or it == iters - 1 or not active.any()):
            checked = _validate(problem, V, X, signs, hmax, checked, active)
    if warm:
        checked = _validate(problem, V, X, signs, hmax, checked, active)
        return checked["V"], checked["X"], checked["f"], checked["Z"]
    return V, X, f, None


#: warm steps are checked every this many iterations: every target reached by one motion in the mode
_VALIDATE = 8
#: ... with ``trust``, after these iterations (and at the end): a check is a trace through the targets, which costs
#: about ten iterations; a column that fails goes back to its state at the last check (checks at 32 only: an open
#: stretch's best fit ended 0.3 % worse, its drifting column sent back further)
_TRUST_VALIDATE = (16, 64)


def _validate(problem, V, X, signs, hmax, checked, active):
    """Warm poses are of the right mode at every target but may lie on another circuit (a design that drifted
    into a rocker whose swing cannot reach every target in one motion). Trace every column through its targets;
    one that passes becomes its new checked state, one that fails goes back to its last checked state and stops.
    Returns the checked states ``{"V", "X", "f", "Z"}`` (copies; ``Z`` the positions at the targets)."""
    D = V.shape[0]
    if checked is None:
        checked = {"V": V.copy(), "X": X.copy(), "f": np.full(D, np.inf),
                   "Z": np.full((problem.batch.nv, problem.T, D), np.nan)}
        todo = np.arange(D)
    else:  # a column whose design and inputs are those last checked passed then: it is not traced again
        todo = np.flatnonzero(np.any(V != checked["V"], axis=1) | np.any(X != checked["X"], axis=0))
    if not todo.size:
        return {k: v.copy() for k, v in checked.items()}
    P = problem.batch.params(V[todo])
    with np.errstate(all="ignore"):
        Zt, reached = problem.trace(P, X[:, todo], signs[:, todo], hmax=hmax, singular_stop=False)
    ok = reached >= problem.T
    r = np.nan_to_num(problem.residuals(np.nan_to_num(Zt[:, :problem.T]), P))
    f_now = np.where(ok, np.sum(r * r, axis=(0, 1)), np.inf)
    passed = np.zeros(D, dtype=bool)
    passed[todo[ok]] = True
    checked["V"][passed] = V[passed]
    checked["X"][:, passed] = X[:, passed]
    checked["f"][passed] = f_now[ok]
    checked["Z"][:, :, passed] = Zt[:, :problem.T, ok]
    failed = np.zeros(D, dtype=bool)
    failed[todo[~ok]] = True
    V[failed] = checked["V"][failed]
    X[:, failed] = checked["X"][:, failed]
    active[failed] = False
    return {k: v.copy() for k, v in checked.items()}


def distinct(V, f, lo, hi, *, k: int, rtol_f: float = 1e-6, dist: float = 0.01, periodic_mask=None, period=None):
    """Indices of up to ``k`` designs, best first, none a duplicate of a better one.

    Two designs are duplicates when their objectives agree to ``rtol_f`` and their parameters
    to ``dist`` of the box (a periodic angle measured on its circle), i.e. the same basin's
    bottom reached twice; anything else (another objective, another place) is kept.
    """
    span = np.where(hi > lo, hi - lo, 1.0)
    out = []
    for i in np.argsort(f, kind="stable"):
        if not np.isfinite(f[i]):
            break
        dup = False
        for j in out:
            d = np.abs(V[i] - V[j])
            if periodic_mask is not None:
                d = np.where(periodic_mask, np.minimum(d, period - d), d)
            if abs(f[i] - f[j]) <= rtol_f * max(abs(f[j]), 1e-300) and np.max(d / span) <= dist:
                dup = True
                break
        if not dup:
            out.append(i)
            if len(out) >= k:
                break
    return out


def sample(problem, n: int, seed) -> np.ndarray:
    """``n`` designs ``(n, k)`` of a seeded Latin hypercube over the bounds (model units).

    As the search does: a positive range spanning more than a decade is sampled on a log scale
    (a uniform sample of [0.2, 50] would put almost no design at the small lengths).
    """
    from scipy.stats import qmc

    lo, hi = problem.lo, problem.hi
    logs = (lo > 0) & (hi >= 10 * lo)
    lo_u = np.where(logs, np.log(np.where(logs, lo, 1.0)), lo)
    hi_u = np.where(logs, np.log(np.where(logs, hi, 1.0)), hi)
    U = qmc.LatinHypercube(d=len(lo), seed=seed).random(n) * (hi_u - lo_u) + lo_u
    return np.clip(np.where(logs, np.exp(U), U), lo, hi)


def multistart(problem, n: int, keep: int, seed, *, chunk: int = 4000):
    """Sample ``n`` designs, keep the ``keep`` best by the search objective: ``(V, signs, X, f)``.

    Each kept design comes with the mode (block signs) and the input values (free timing) at
    which the search objective found it, ready for :func:`batch_lm`.
    """
    from .problem import evaluate

    V = sample(problem, n, seed)
    fs, Ss, Xs = [], [], []
    for a in range(0, n, chunk):
        Vc = V[a:a + chunk]
        f, mi, di, X = evaluate(problem, Vc)
        modes = problem.modes(problem.batch.params(Vc))
        Ss.append(np.stack([modes[m][:, j] for j, m in enumerate(mi)], axis=1))
        fs.append(f)
        Xs.append(X)
    f, S, X = np.concatenate(fs), np.hstack(Ss), np.hstack(Xs)
    o = np.argsort(f, kind="stable")[:keep]
    o = o[np.isfinite(f[o])]
    return V[o], S[:, o], X[:, o], f[o]
