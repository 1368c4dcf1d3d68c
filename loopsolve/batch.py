"""Vectorized fast path for dense sweeps: all output points solved at once with numpy.

``sweep(..., method="batched")`` (or ``"auto"`` for dense grids) does this:

1. **Coarse tracked pass.** The tracker of :mod:`loopsolve.tracking` follows the solution
   curve at its internal step (≤ 2° of scaled arc length), with every check of the tracked
   path (mode signature at every step, limits, change points), but without landing on the
   output grid.
2. **Warm start.** Every output point lying on a regular, transversal piece of that path gets
   a cubic Hermite guess in the input from the two tracked nodes around it (their positions
   and kinematic coefficients dq/dx), accurate to ~1e-8.
3. **Vectorized Newton** on the stacked systems: one Newton step and one chord step (the
   same Jacobians), with the compiled ``phi_v``/``jac_v`` and explicit 1×1/2×2 block solves
   (Cramer's rule on whole arrays, much faster than ``np.linalg.solve`` on (N, 2, 2) stacks;
   larger blocks use the stacked solve).
4. **Verification** of every point: the last correction is at round-off level, the loop
   residual is below tolerance, and the signs of the block determinants equal the mode of the
   tracked piece. Points that fail — and the points next to folds and change points, where a
   guess in the input is not reliable — are redone one by one by the tracker's corrector on
   the path segment (with subdivision).
5. **Rates** for all points at once (:func:`rates_v`): velocities, accelerations and jerks by
   block forward substitution on the stacked Φ_q.

The tracked and batched paths therefore return the same points, to round-off (the tests
check 1e-12 at 10⁴ points).
"""

from __future__ import annotations

import math

import numpy as np

from .results import Event, EventKind
from .units import Kind

__all__ = ["rates_v", "block_solve_v", "block_dets_v", "solve_rows", "SINGULAR_COND"]

#: a row whose Jacobian has a condition number above this is treated as singular
SINGULAR_COND = 1e10


def _blocks(ck):
    return [(tuple(b.eqs), tuple(b.unknowns)) for b in ck.blocks]


def block_solve_v(ck, J, B):
    """Solve Φ_q X = B for stacked systems.

    ``J`` is the raw ``(n*n, N)`` output of the compiled ``jac_v`` (row-major), ``B`` is
    ``(n, N)``; returns ``X`` ``(n, N)`` by forward substitution over the solve-order blocks.

    Examples
    --------
    >>> ck = ls.fourbar(60, 25, 70, 45).compile()
    >>> Z = np.radians([[90.0], [16.0994], [80.7225]])
    >>> J = ck.module.jac_v(Z, ck.p)
    >>> X = block_solve_v(ck, J, np.array([[1.0], [2.0]]))
    >>> bool(np.allclose(ck.jac(Z[:, 0]) @ X[:, 0], [1, 2]))
    True
    """
    n = len(ck.unknowns)
    N = B.shape[1]
    X = np.zeros((n, N))
    solved: list[int] = []
    for eqs, cols in _blocks(ck):
        r = [B[e] - sum(J[e * n + c] * X[c] for c in solved) if solved else B[e] for e in eqs]
        solved.extend(cols)
        k = len(cols)
        if k == 1:
            X[cols[0]] = r[0] / J[eqs[0] * n + cols[0]]
        elif k == 2:
            e0, e1 = eqs
            c0, c1 = cols
            a, b, c, d = J[e0 * n + c0], J[e0 * n + c1], J[e1 * n + c0], J[e1 * n + c1]
            det = a * d - b * c
            X[c0] = (d * r[0] - b * r[1]) / det
            X[c1] = (a * r[1] - c * r[0]) / det
        else:
            M = np.stack([np.stack([J[e * n + c] for c in cols], axis=-1) for e in eqs], axis=-2)
            sol = np.linalg.solve(M, np.stack(r, axis=-1)[..., None])[..., 0]
            for j, c in enumerate(cols):
                X[c] = sol[:, j]
    return X


def block_dets_v(ck, J):
    """``(nblocks, N)`` determinants of the diagonal blocks and their regularity (≈ 2/cond; 0 = singular).

    Length columns are scaled by the model's length scale (signs unchanged), as in the tracker.
    """
    n = len(ck.unknowns)
    cs = [1.0 if ck.kinds[int(i)] is Kind.ANGLE else float(ck.scale) for i in ck.unknown_idx]
    dets, had = [], []
    for eqs, cols in _blocks(ck):
        M = np.stack([np.stack([J[e * n + c] * cs[c] for c in cols], axis=-1) for e in eqs], axis=-2)  # (N, k, k)
        if len(cols) == 1:
            d = M[:, 0, 0]
            h = (d != 0).astype(float)
        elif len(cols) == 2:
            d = M[:, 0, 0] * M[:, 1, 1] - M[:, 0, 1] * M[:, 1, 0]
            h = np.abs(d) / (0.5 * np.sum(M * M, axis=(1, 2)))
        else:
            d = np.linalg.det(M)
            h = np.abs(d) / (np.sum(M * M, axis=(1, 2)) / len(cols)) ** (len(cols) / 2)
        dets.append(d)
        had.append(h)
    return np.array(dets).reshape(len(dets), -1), np.array(had).reshape(len(had), -1)


def _cond_v(ck, J):
    """Condition numbers (2-norm) of the stacked Jacobians: exact formula for one 2×2 block."""
    n = len(ck.unknowns)
    N = J.shape[1] if J.ndim > 1 else 1
    if n == 0:
        return np.ones(N)
    if n == 1:
        return np.where(J[0] != 0, 1.0, np.inf)
    if n == 2:
        a, b, c, d = J
        f = a * a + b * b + c * c + d * d
        det = np.abs(a * d - b * c)
        disc = np.sqrt(np.maximum(f * f - 4 * det * det, 0.0))
        s1 = np.sqrt((f + disc) / 2)
        with np.errstate(divide="ignore", invalid="ignore"):
            s2 = det / s1
            return np.where(s2 > 0, s1 / s2, np.inf)
    M = np.moveaxis(J.reshape(n, n, -1), -1, 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.linalg.cond(M)


def rates_v(ck, Z, rates):
    """Velocities, accelerations, jerks and condition numbers at the positions ``Z`` ``(nvar, N)``.

    ``rates`` = (speed, accel, jerk) of the driving input (internal units). Returns
    ``Z1, Z2, Z3`` ``(nvar, N)`` and ``cond`` ``(N,)``; rows whose Jacobian is singular get
    NaN rates and an infinite ``cond``.

    Examples
    --------
    >>> ck = ls.fourbar(60, 25, 70, 45).compile()
    >>> s = ck.mechanism.solve(90)
    >>> Z1, Z2, Z3, cond = rates_v(ck, s.z[:, None], (1.0, 0.0, 0.0))
    >>> bool(np.allclose(Z1[:, 0], s.z1))
    True
    """
    nv, N = Z.shape
    ix = int(ck.input_idx[0])
    iu = ck.unknown_idx
    if N == 0:
        e = np.zeros((nv, 0))
        return e, e.copy(), e.copy(), np.zeros(0)
    J = ck.module.jac_v(Z, ck.p)
    J = np.broadcast_to(J.reshape(J.shape[0], -1), (J.shape[0], N)) if J.size else J
    cond = _cond_v(ck, J)
    out = [Z]
    with np.errstate(divide="ignore", invalid="ignore"):
        for order in (1, 2, 3):
            Zk = np.zeros((nv, N))
            Zk[ix] = rates[order - 1]
            b = ck.rhs_v(order, *out, Zk)
            b = np.broadcast_to(np.asarray(b).reshape(len(iu), -1), (len(iu), N))
            Zk[iu] = block_solve_v(ck, J, b)
            out.append(Zk)
    bad = ~(cond <= SINGULAR_COND)
    if np.any(bad):
        for order, Zk in enumerate(out[1:], start=1):
            Zk[:, bad] = np.nan
            Zk[ix, bad] = rates[order - 1]
    return out[1], out[2], out[3], cond


def _newton_v(ck, Z, n_chord: int = 1):
    """One Newton step and ``n_chord`` chord steps on the stacked systems (Z modified in place).

    Returns the scaled size of the last correction per point.
    """
    iu = ck.unknown_idx
    J = ck.module.jac_v(Z, ck.p)
    last = None
    for it in range(1 + n_chord):
        F = ck.module.phi_v(Z, ck.p)
        dU = block_solve_v(ck, J, -F)
        Z[iu] += dU
        last = dU
    return last


def solve_rows(tracer, path, rows, g):
    """Positions of the output rows: vectorized where the path is regular, tracked elsewhere.

    Same return value as the tracked solver: ``(Z list, signatures, residuals, iterations,
    grid indices, events)``.
    """
    from .tracking import _Kernel  # noqa: F401  (documentation of the tracer's kernel)

    kern = tracer.k
    ck = kern.ck
    n, ix = kern.n, kern.ix
    nodes = path.nodes
    nrow = len(rows)
    nv = kern.nv
    Zout = np.empty((nrow, nv))
    sigs = [""] * nrow
    res = np.zeros(nrow)
    its = np.zeros(nrow, dtype=int)
    ks = np.array([r[0] for r in rows], dtype=int)
    ok = np.zeros(nrow, dtype=bool)
    # rows on nodes
    vec_rows, vec_seg = [], []
    for r, (kk, seg, node) in enumerate(rows):
        if node is not None:
            Zout[r] = node.z
            sigs[r] = node.sig
            res[r] = node.residual
            its[r] = node.n_iter
            ok[r] = True
            continue
        a, b = nodes[seg], nodes[seg + 1]
        sigs[r] = path.seg_sig[seg]
        if (a.kind in ("regular", "end") and b.kind in ("regular", "end") and a.sig == b.sig == sigs[r]
                and abs(a.t[n]) >= 0.1 and abs(b.t[n]) >= 0.1 and (a.t[n] > 0) == (b.t[n] > 0)):
            vec_rows.append(r)
            vec_seg.append(seg)
    if vec_rows:
        vr = np.array(vec_rows)
        seg_idx = np.array(vec_seg)
        used = np.unique(seg_idx)
        # per-node data for the segments in use
        nid = np.unique(np.concatenate([used, used + 1]))
        pos = {int(v): i for i, v in enumerate(nid)}
        NZ = np.array([nodes[i].z for i in nid], dtype=float)  # (m, nv)
        T = np.array([nodes[i].t for i in nid], dtype=float)  # (m, n+1)
        w = np.array(kern.wu)
        slope = (T[:, :n] / w) / (T[:, n:] / kern.wx)  # dq/dx at the nodes
        ia = np.array([pos[int(s)] for s in seg_idx])
        ib = np.array([pos[int(s) + 1] for s in seg_idx])
        xa, xb = NZ[ia, ix], NZ[ib, ix]
        x = g.start + g.step * ks[vr]
        hseg = xb - xa
        s = (x - xa) / hseg
        s2, s3 = s * s, s * s * s
        h00, h10, h01, h11 = 2 * s3 - 3 * s2 + 1, s3 - 2 * s2 + s, -2 * s3 + 3 * s2, s3 - s2
        Z = np.empty((nv, len(vr)))
        Z[:] = NZ[ia].T
        Z[ix] = x
        iu = ck.unknown_idx
        Z[iu] = (h00 * NZ[ia][:, iu].T + h10 * hseg * slope[ia].T + h01 * NZ[ib][:, iu].T + h11 * hseg * slope[ib].T)
        last = _newton_v(ck, Z)
        step = np.max(np.abs(last * w[:, None]), axis=0) if n else np.zeros(len(vr))
        F = ck.module.phi_v(Z, ck.p)
        resid = np.max(np.abs(F.reshape(F.shape[0], -1)), axis=0) if n else np.zeros(len(vr))
        J = ck.module.jac_v(Z, ck.p)
        dets, _ = block_dets_v(ck, J.reshape(J.shape[0], -1))
        want = np.array([[1.0 if ch == "+" else -1.0 for ch in sigs[r]] for r in vr]).T.reshape(dets.shape)
        good = (step <= 1e-11) & (resid <= kern.tol) & np.all(np.sign(dets) == want, axis=0) & np.all(
            np.isfinite(Z), axis=0)
        Zout[vr[good]] = Z[:, good].T
        res[vr[good]] = resid[good]
        its[vr[good]] = 2
        ok[vr[good]] = True
    events = []
    keep = np.ones(nrow, dtype=bool)
    for r in np.flatnonzero(~ok):
        kk, seg, _ = rows[r]
        a, b = nodes[seg], nodes[seg + 1]
        sol = tracer.solve_at(a, b, g.value(int(kk)), sigs[r])
        if sol is None:
            x = tracer._display(g.value(int(kk)))
            events.append(Event(EventKind.SINGULAR, x, f"no converged solution at {ck.inputs[0]} = {x:.10g} on "
                                f"mode {sigs[r]}; row left out"))
            keep[r] = False
            continue
        z, rr, it = sol
        Zout[r] = z
        res[r] = rr
        its[r] = it
    idx = np.flatnonzero(keep)
    return (Zout[idx], [sigs[i] for i in idx], res[idx].tolist(), its[idx].tolist(), ks[idx].tolist(), events)
