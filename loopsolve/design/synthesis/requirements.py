"""The requirements of a synthesis (``crank``, ``transmission``) as the search and the polishes see them.

Why: the certificate (:mod:`loopsolve.design.synthesis.certificate`) checks the requirements of the best designs
at the end. If the search only minimized the fit, a problem whose best fit is not a crank (a
triple rocker through the targets) would end with every polished basin failing ``--crank``,
although crank designs that fit well exist in the box. So the requirements are part of the
search's objective and a feasibility condition of both polishes:

* :func:`check` traces each design over the motion the certificate looks at — a full turn of the
  input from the first target with ``crank`` (the way the targets are met), else from the first
  target to the last — on a grid of ``_STEP`` in the design's mode, stopping at a limit, a sign
  change of a block determinant or a near-singular block, and measures the transmission angle
  (the angle between the two links of every dyad of two angle unknowns, as the certificate does)
  at the grid points, its extremes refined by a parabola through the three samples around each.
  A design fails when it does not turn fully back to its first pose (``crank``) or when its
  transmission angle leaves the bounds narrowed by ``MARGIN_DEG`` on each side (so a design polished
  onto the bound is still inside it when the certificate sweeps it finely).
* :func:`loopsolve.design.synthesis.problem.evaluate` adds to a failing design's objective a penalty larger
  than any fit (the search's penalty per missed target) that grows with how far it fails, so
  differential evolution and the multistart are led into the feasible designs;
* the lockstep Levenberg–Marquardt (:mod:`loopsolve.design.synthesis.lockstep_lm`) accepts a step only when the
  new design still passes, and the exact polish (:func:`loopsolve.design.synthesis.problem.polish`) treats a
  failing trial design like one that cannot be traced (its constant large residual), so both
  polishes stay among feasible designs and stop at the best one they can reach, not at the
  unconstrained optimum beyond the requirement.
"""

from __future__ import annotations

import math

import numpy as np

from ...model.units import Kind

__all__ = ["active", "check", "assess", "grid", "MARGIN_DEG"]

#: grid of the requirement trace (internal units of an angle input)
_STEP = math.radians(10.0)
#: the transmission bounds are narrowed by this much (degrees) in the search and the polishes
MARGIN_DEG = 0.5


def active(problem) -> bool:
    """Whether the problem has a requirement the search must respect."""
    return bool(problem.crank) or problem.transmission is not None


def grid(problem, X) -> np.ndarray:
    """``(K, D)`` input values of the requirement trace of designs whose target inputs are ``X`` ``(T, D)``."""
    x0, x1 = X[0], X[-1]
    if problem.crank:
        d = np.where(x1 >= x0, 1.0, -1.0)
        span = d * 2 * math.pi
        n = int(math.ceil(2 * math.pi / _STEP))
    else:
        span = x1 - x0
        n = max(1, int(math.ceil(float(np.max(np.abs(span))) / _STEP - 1e-9))) if span.size else 1
    return x0[None, :] + np.linspace(0.0, 1.0, n + 1)[:, None] * span[None, :]


def _dyads(problem) -> list[tuple[int, int]]:
    ck = problem.ck
    out = []
    for b in ck.blocks:
        if len(b.unknowns) == 2:
            i, j = (int(ck.unknown_idx[c]) for c in b.unknowns)
            if ck.kinds[i] is Kind.ANGLE and ck.kinds[j] is Kind.ANGLE:
                out.append((i, j))
    return out


def _extreme(mu, sign):
    """Min (``sign`` = 1) or max (−1) over axis 0 of ``mu`` ``(K, D)`` (NaN ignored), refined by a parabola."""
    K, D = mu.shape
    y = np.where(np.isfinite(mu), sign * mu, np.inf)
    k = np.argmin(y, axis=0)
    cols = np.arange(D)
    best = y[k, cols]
    inner = (k > 0) & (k < K - 1)
    km, kp = np.clip(k - 1, 0, K - 1), np.clip(k + 1, 0, K - 1)
    ym, yp = y[km, cols], y[kp, cols]
    curv = ym - 2 * best + yp
    with np.errstate(all="ignore"):
        vertex = best - (yp - ym) ** 2 / (8 * curv)
    refine = inner & np.isfinite(ym) & np.isfinite(yp) & (curv > 0)
    best = np.where(refine, np.minimum(best, vertex), best)
    return sign * best


def check(problem, P, signs, X) -> tuple[np.ndarray, np.ndarray]:
    """``(ok (D,), violation (D,))`` of the designs ``P`` ``(npar, D)`` in the modes ``signs`` ``(nb, D)``.

    ``X`` ``(T, D)``: each design's input values at the targets (internal units, in the order of the
    motion). ``violation`` (degrees, 0 when ``ok``) says how far a design fails: the part of the
    motion it cannot make (360 for none) plus how far its transmission angle leaves the narrowed
    bounds. Without requirements every design passes.
    """
    D = P.shape[1]
    if not active(problem) or D == 0:
        return np.ones(D, dtype=bool), np.zeros(D)
    X = np.asarray(X, dtype=float)
    if X.ndim == 1:
        X = X[:, None]
    finite = np.all(np.isfinite(X), axis=0)
    Xg = grid(problem, np.where(finite[None, :], X, 0.0))
    with np.errstate(all="ignore"):
        Zt, reached = problem.trace(P, Xg, np.asarray(signs, dtype=float), hmax=_STEP, singular_stop=True)
    ok, viol = assess(problem, P, Zt, reached >= Xg.shape[0])
    return ok & finite, np.where(finite, viol, 360.0)


def assess(problem, P, Zg, full, mask=None) -> tuple[np.ndarray, np.ndarray]:
    """:func:`check` from positions already traced: ``Zg`` ``(nv, K, D)`` along the motion the requirements
    concern (with ``crank`` a full turn: ``Zg[:, 0]`` the start, ``Zg[:, -1]`` one turn later; else
    the stretch through the targets; NaN where not reached), ``full`` ``(D,)``: traced entirely;
    ``mask`` ``(K, D)``: the samples that belong to each design's motion (default all)."""
    D = P.shape[1]
    K = Zg.shape[1]
    ok = np.asarray(full, dtype=bool).copy()
    if mask is not None:
        Zg = np.where(mask[None], Zg, np.nan)
    reached = np.sum(np.all(np.isfinite(Zg), axis=0), axis=0) if mask is None else \
        np.sum(np.all(np.isfinite(Zg), axis=0) & mask, axis=0)
    size = K if mask is None else np.maximum(np.sum(mask, axis=0), 1)
    viol = np.where(ok, 0.0, 360.0 * (1.0 - np.minimum(reached, size) / size) + 1.0)
    b = problem.batch
    if problem.crank:
        d = Zg[b.iu, -1] - Zg[b.iu, 0]
        ang = ~b.is_len
        d = np.where(ang[:, None], (d + math.pi) % (2 * math.pi) - math.pi, d / b.scale(P)[None, :])
        closes = np.all(np.abs(np.nan_to_num(d, nan=np.inf)) < 1e-6, axis=0)
        viol += np.where(ok & ~closes, 1.0, 0.0)
        ok &= closes
    if problem.transmission is not None:
        lo, hi = problem.transmission
        lo, hi = lo + MARGIN_DEG, hi - MARGIN_DEG
        mus = [np.degrees(np.abs((Zg[i] - Zg[j] + math.pi) % (2 * math.pi) - math.pi)) for i, j in _dyads(problem)]
        if mus:
            seen = np.any([np.any(np.isfinite(m), axis=0) for m in mus], axis=0)
            mn = np.min([_extreme(m, 1) for m in mus], axis=0)
            mx = np.max([_extreme(m, -1) for m in mus], axis=0)
            with np.errstate(invalid="ignore"):
                out = np.maximum(np.maximum(lo - mn, mx - hi), 0.0)
            out = np.where(seen & np.isfinite(out), out, 180.0)
            ok &= out <= 0
            viol += out
    return ok, viol
