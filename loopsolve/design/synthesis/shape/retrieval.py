"""Retrieval: the atlas entries whose curves are nearest a target's, as placed starts of a polish.

:func:`retrieve` ranks atlas entries against a target curve, free in position, orientation,
scale and starting point (:mod:`loopsolve.design.atlas.descriptors`):

* a **closed** target is compared with the entries whose input turns fully (a closed curve in
  one motion), first by elliptic Fourier descriptors (the target in its four variants: both
  ends of the first harmonic's major axis, both directions; the nearest ``prefilter`` entries
  go on), then by the Procrustes distance over every starting point of the stored curve, both
  directions. A target whose first harmonic is nearly a circle (where the EFD normalization is
  ill-conditioned) skips the first stage: every closed entry is compared by Procrustes.
* an **open** target is a stretch of some motion: it is compared with every window of every
  stored curve (closed ones wrap around, open ones — a rocker's swing — do not) of several
  lengths (1/8 … the whole curve), both directions, by the Procrustes distance.

:func:`placed_starts` turns the best matches into starts of the polish: the entry's design
scaled, turned and moved onto the target by the similarity of its match, and the input value of
every target point — the entry's motion traced again and the matched stretch of arc length
mapped back to the input.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...atlas import descriptors as _d
from ...atlas.trace import STATUS

__all__ = ["Match", "retrieve", "placed_starts"]

#: window lengths of an open target, in stored-curve steps between its 9 points (N = 64: 1/8 … 1)
_OPEN_STRIDES = (1, 2, 3, 4, 6, 8)
_OPEN_POINTS = 9
#: entries kept after the descriptor stage for the Procrustes ranking of a closed target
_PREFILTER = 600
#: a first harmonic rounder than this (minor/major) makes the EFD normalization ill-conditioned
_ROUND = 0.9


@dataclass
class Match:
    """One retrieved entry: its Procrustes ``dist`` and the fit (see :func:`descriptors.procrustes`)."""

    entry: int
    dist: float
    start: int
    stride: int
    factor: complex
    mean: complex
    reverse: bool
    efd_dist: float = math.nan


def _pool(atlas, closed: bool, crank: bool) -> np.ndarray:
    ok = atlas.traced
    if closed or crank:
        ok = ok & atlas.arrays["crank"]
    return np.flatnonzero(ok)


def retrieve(atlas, xy, *, closed: bool, crank: bool = False, count: int = 40, prefilter: int = _PREFILTER):
    """The ``count`` best matches of the curve ``xy`` ``(T, 2)`` in ``atlas``, best first (see the module docstring)."""
    pool = _pool(atlas, closed, crank)
    if not pool.size:
        return [], {"pool": 0}
    N = int(atlas.meta["curve_points"])
    curves = atlas.arrays["curve"]
    stats = {"pool": int(pool.size)}
    if closed:
        H = int(atlas.meta["harmonics"])
        coef = _d.efd(xy, H)
        _, _, _, _, rnd = _d.efd_normalize(coef)
        cand = pool
        efd_dist = np.full(pool.size, np.nan)
        if rnd < _ROUND and pool.size > prefilter:
            var = _d.efd_variants(xy, H)  # (4, F)
            E = atlas.arrays["efd"][pool].astype(float)
            d2 = None  # the least over the variants, one at a time (no (pool, 4, F) array)
            for v in var:
                d = E - v
                s2 = np.sum(d * d, axis=1)
                d2 = s2 if d2 is None else np.minimum(d2, s2)
            keep = np.argsort(d2, kind="stable")[:prefilter]
            cand, efd_dist = pool[keep], np.sqrt(d2[keep])
            stats["efd_stage"] = True
        else:
            efd_dist = np.full(cand.size, np.nan)
            stats["efd_stage"] = False
        R = _d.resample(xy, N, closed=True)
        fw = _d.procrustes(curves[cand], np.ones(cand.size, bool), R, strides=(1,))
        R_rev = np.roll(R[::-1], 1, axis=0)  # the same points from point 0 backwards
        bw = _d.procrustes(curves[cand], np.ones(cand.size, bool), R_rev, strides=(1,))
        if not stats["efd_stage"]:
            stats["candidates"] = int(cand.size)
    else:
        cand = pool
        efd_dist = np.full(cand.size, np.nan)
        R = _d.resample(xy, _OPEN_POINTS, closed=False)
        cl = atlas.arrays["crank"][cand]
        fw, bw = _d.procrustes_both(curves[cand], cl, R, strides=_OPEN_STRIDES)
        stats["efd_stage"] = False
    rev = bw[0] < fw[0]
    best = [np.where(rev, b, f) for f, b in zip(fw, bw)]
    order = np.argsort(best[0], kind="stable")[:count]
    out = [Match(int(cand[i]), float(best[0][i]), int(best[1][i]), int(best[2][i]), complex(best[3][i]),
                 complex(best[4][i]), bool(rev[i]), float(efd_dist[i])) for i in order if np.isfinite(best[0][i])]
    stats["candidates"] = int(cand.size)
    return out, stats


def diverse(atlas, matches, k: int, *, dist: float = 0.03):
    """Up to ``k`` matches, best first, whose designs differ by more than ``dist`` of the box (one per basin)."""
    lo, hi = atlas.lo, atlas.hi
    logs = np.asarray(atlas.meta["log"], dtype=bool)
    P = atlas.arrays["params"]

    def unit(v):
        u = np.where(logs, np.log(np.where(logs, np.maximum(v, 1e-300), 1.0)), v)
        a = np.where(logs, np.log(np.where(logs, lo, 1.0)), lo)
        b = np.where(logs, np.log(np.where(logs, hi, 1.0)), hi)
        return (u - a) / np.where(b > a, b - a, 1.0)

    chosen, units = [], []
    for m in matches:
        u = unit(P[m.entry])
        if all(np.max(np.abs(u - w)) > dist for w in units):
            chosen.append(m)
            units.append(u)
            if len(chosen) >= k:
                break
    return chosen


def _retrace(atlas, entries, step_deg: float | None = None):
    """The entries' motions again: ``(inputs (D, R), points (D, R, 2), counts (D,))`` along increasing input.

    At the atlas' own step (``step_deg`` by default ``atlas.meta["step_deg"]``), as the build traced them: the
    stored curves, to whose arc length a match refers, were resampled from those rows (a finer retrace, 1°, cost
    four times as many continuation steps for starts whose inputs the polish moves anyway)."""
    from ..candidates import Batch

    mech = atlas.mechanism
    ck = mech.compile()
    b = Batch(ck, atlas.names)
    V = atlas.arrays["params"][entries]
    P = b.params(V)
    D = len(entries)
    sig = atlas.arrays["mode"][entries].T.astype(float)
    x0 = atlas.arrays["x_start"][entries]
    xr = atlas.arrays["x_range"][entries]
    crank = atlas.arrays["crank"][entries]
    step_deg = float(atlas.meta.get("step_deg", 1.0)) if step_deg is None else step_deg
    h = math.radians(step_deg) if b.input_is_angle else (xr[:, 1] - xr[:, 0]).max() / 200
    ip = ck.points.index(atlas.point)
    with np.errstate(all="ignore"):
        Z0, ok = b.assemble(P, x0, sig)
        Z0[:, ~ok] = np.nan
        up = np.where(crank, 2 * math.pi, xr[:, 1] - x0)
        down = np.where(crank, 0.0, x0 - xr[:, 0])
        Kf = int(math.ceil(float(np.nanmax(up)) / h)) + 1
        Kb = int(math.ceil(float(np.nanmax(down)) / h)) + 1
        kf = np.arange(Kf)[:, None] * h
        Xf = x0[None, :] + np.minimum(kf, up[None, :])
        Zf, rf = b.follow(Z0, P, Xf, hmax=h, signs=sig, stop_on_singular=False)
        kb = np.arange(Kb)[:, None] * h
        Xb = x0[None, :] - np.minimum(kb, down[None, :])
        Zb, rb = b.follow(Z0, P, Xb, hmax=h, signs=sig, stop_on_singular=False)
    R = Kf + Kb - 1
    X = np.full((D, R), np.nan)
    pts = np.full((D, R, 2), np.nan)
    cnt = np.zeros(D, dtype=int)
    for j in range(D):
        xs = np.concatenate([Xb[:rb[j], j][::-1][:-1], Xf[:rf[j], j]]) if rb[j] > 0 else Xf[:rf[j], j]
        zs = np.concatenate([Zb[:, :rb[j], j][:, ::-1][:, :-1], Zf[:, :rf[j], j]], axis=1) if rb[j] > 0 \
            else Zf[:, :rf[j], j]
        if crank[j] and zs.shape[1] > 1:  # one turn: the last row is the first again
            xs, zs = xs[:-1], zs[:, :-1]
        # repeated inputs (a swing clipped at its end) collapse to one row
        keep = np.concatenate([[True], np.diff(xs) > 0]) if xs.size else np.zeros(0, bool)
        xs, zs = xs[keep], zs[:, keep]
        n = xs.size
        if n:
            X[j, :n] = xs
            pts[j, :n] = b.points(zs, np.repeat(P[:, j:j + 1], n, axis=1))[ip].T
        cnt[j] = n
    return X, pts, cnt


def _input_at(xs, pts, n, closed, frac):
    """Input values at arc-length fractions ``frac`` of a traced motion (closed: fractions may pass 1)."""
    p = pts[:n]
    x = xs[:n]
    if closed:
        seg = np.hypot(*np.diff(np.vstack([p, p[:1]]), axis=0).T)
        s = np.concatenate([[0.0], np.cumsum(seg)])
        xe = np.concatenate([x, [x[0] + 2 * math.pi]])
        L = s[-1]
        f = np.asarray(frac, dtype=float)
        turns = np.floor(f)
        return np.interp((f - turns) * L, s, xe) + 2 * math.pi * turns
    seg = np.hypot(*np.diff(p, axis=0).T)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    return np.interp(np.clip(frac, 0.0, 1.0) * s[-1], s, x)


def _placed_values(atlas, m, c_t, n_t, frame, names, deg):
    """The problem's varied values of match ``m``'s design placed on the target (model units), and its scale and turn."""
    cx, cy, psi, se, _ = atlas.arrays["place"][m.entry]
    a = m.factor
    A = n_t * a * np.exp(-1j * psi) / se
    B = c_t - A * (cx + 1j * cy) - n_t * a * m.mean
    vals = atlas.values(m.entry)
    te = complex(vals.get(frame.x, 0.0), vals.get(frame.y, 0.0))
    th_e = vals.get(frame.angle, 0.0)
    th_e = math.radians(th_e) if deg else th_e
    t_new = A * te + B
    turn = math.atan2(A.imag, A.real)
    th = math.remainder(th_e + turn, 2 * math.pi)
    scale = abs(A)
    row = []
    for n in names:
        if n == frame.x:
            row.append(t_new.real)
        elif n == frame.y:
            row.append(t_new.imag)
        elif n == frame.angle:
            row.append(math.degrees(th) if deg else th)
        elif n in frame.lengths:
            row.append(vals[n] * scale)
        else:
            row.append(vals[n])
    return np.array(row), th, th_e


def within_bounds(atlas, matches, xy, closed: bool, frame, problem, *, deg: bool, slack: float = 0.05):
    """The matches whose design, placed on the target, lies within the problem's bounds (to ``slack`` of each
    range; a periodic angle always does): a start clipped into the bounds would be another design."""
    from ..problem import periodic

    N = int(atlas.meta["curve_points"])
    R = _d.resample(xy, N if closed else _OPEN_POINTS, closed=closed)
    _, c_t, n_t = _d.target_vector(R)
    per, _ = periodic(problem)
    span = problem.hi - problem.lo
    lo, hi = problem.lo - slack * span, problem.hi + slack * span
    out = []
    for m in matches:
        v, _, _ = _placed_values(atlas, m, c_t, n_t, frame, problem.names, deg)
        if np.all(per | ((v >= lo) & (v <= hi))):
            out.append(m)
    return out


def placed_starts(atlas, matches, xy, idx, closed: bool, frame, problem, *, deg: bool, step_deg: float | None = None):
    """Starts of the polish from ``matches``: ``(V (S, k), signs (nb, S), X (M, S), entries)``.

    ``xy`` the target ``(T, 2)``, ``idx`` the target points of the polish (M of them), ``frame``
    the model's :class:`~loopsolve.design.atlas.frame.Frame`, ``problem`` the polish problem (its
    varied parameters and bounds), ``step_deg`` the step of the retrace (:func:`_retrace`). See the module
    docstring.
    """
    N = int(atlas.meta["curve_points"])
    entries = np.array([m.entry for m in matches], dtype=int)
    Xs, pts, cnt = _retrace(atlas, entries, step_deg)
    # arc-length fraction of every polish point along the target (the resampling's parameter)
    seg = np.hypot(*np.diff(np.vstack([xy, xy[:1]]) if closed else xy, axis=0).T)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    u = s[idx] / s[-1]
    R = _d.resample(xy, N if closed else _OPEN_POINTS, closed=closed)
    _, c_t, n_t = _d.target_vector(R)
    names = problem.names
    V, S, X, used = [], [], [], []
    for j, m in enumerate(matches):
        if cnt[j] < 3:
            continue
        row, th, th_e = _placed_values(atlas, m, c_t, n_t, frame, names, deg)
        # stored-curve fraction of every polish point (see the module docstring), then its input
        if closed:
            f = m.start / N + (-u if m.reverse else u)
        else:
            span = (_OPEN_POINTS - 1) * m.stride
            f = (m.start + ((1 - u) if m.reverse else u) * span) / (N - 1)
        x = _input_at(Xs[j], pts[j], cnt[j], bool(atlas.arrays["crank"][m.entry]) and closed, f)
        if not closed and atlas.arrays["crank"][m.entry]:
            f = (m.start + ((1 - u) if m.reverse else u) * span) / N
            x = _input_at(Xs[j], pts[j], cnt[j], True, f)
        if frame.input_turns:
            x = x + (th - th_e)
        V.append(row)
        S.append(atlas.arrays["mode"][m.entry].astype(float))
        X.append(x)
        used.append(m)
    if not V:
        return np.zeros((0, len(names))), np.zeros((problem.batch.ops.blocks.__len__(), 0)), np.zeros((len(idx), 0)), []
    V = np.clip(np.array(V), problem.lo, problem.hi)
    return V, np.array(S).T, np.array(X).T, used
