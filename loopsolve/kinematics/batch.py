"""Vectorized fast path for dense sweeps: all output points solved at once with numpy.

``sweep(..., method="batched")`` (or ``"auto"`` for dense grids) does this:

1. **Coarse tracked pass.** The tracer of :mod:`loopsolve.kinematics.continuation` follows the solution
   curve at internal steps of at most 1° of scaled arc length, with every check of the tracked
   path (mode signature at every step, limits, change points), but without landing on the
   output grid.
2. **Warm start.** Every output point lying on a regular, transversal piece of that path gets
   a cubic Hermite guess in the input from the two tracked nodes around it (their positions
   and kinematic coefficients dq/dx), accurate to ~1e-9.
3. **Vectorized Newton** on the stacked systems: one Newton step, then one chord evaluation
   (same Jacobian) whose correction measures the error left, with the compiled
   ``phi_v``/``jac_v`` and explicit 1×1/2×2 block solves (Cramer's rule on whole arrays, much
   faster than ``np.linalg.solve`` on (N, 2, 2) stacks; larger blocks use the stacked solve).
4. **Verification** of every point: the remaining correction is at round-off level, the loop
   residual is below tolerance, and the signs of the block determinants equal the mode of the
   tracked piece. Points that fail — and the points next to folds and change points, where a
   guess in the input is not reliable — are redone one by one by the tracker's corrector on
   the path segment (with subdivision).
5. **Rates** for all points at once (:func:`rates_v`): velocities, accelerations and jerks by
   block forward substitution on the stacked Φ_q, reusing the Jacobians of step 4.

The tracked and batched paths therefore return the same points, to round-off (the tests
check 1e-12 at 10⁴ points). ``benchmarks/README.md`` has the timings.
"""

from __future__ import annotations

import numpy as np

from ..model.units import Kind
from .rows import RowSolution, fill_node_rows, solve_rows_scalar

__all__ = ["rates_v", "block_solve_v", "block_dets_v", "SINGULAR_COND"]

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

    Examples
    --------
    >>> ck = ls.fourbar(60, 25, 70, 45).compile()
    >>> Z = np.array([[math.pi / 2] * 2, [0.281, -1.071], [1.409, -2.198]])  # open, crossed
    >>> dets, reg = block_dets_v(ck, ck.module.jac_v(Z, ck.p))
    >>> np.sign(dets).tolist()
    [[-1.0, 1.0]]
    """
    n = len(ck.unknowns)
    cs = [1.0 if ck.kinds[int(i)] is Kind.ANGLE else float(ck.scale) for i in ck.unknown_idx]
    dets, had = [], []
    for eqs, cols in _blocks(ck):
        M = np.stack([np.stack([J[e * n + c] * cs[c] for c in cols], axis=-1) for e in eqs], axis=-2)  # (N, k, k)
        if len(cols) == 1:
            d = M[:, 0, 0]
            h = np.minimum(np.abs(d) / float(ck.scale), 1.0)
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


def rates_v(ck, Z, rates, J=None, derivatives: int = 3):
    """Velocities, accelerations, jerks and condition numbers at the positions ``Z`` ``(nvar, N)``.

    ``rates`` = (speed, accel, jerk) of the driving input (internal units); ``J``, the raw
    ``(n*n, N)`` Jacobians at ``Z`` when already known; ``derivatives`` the highest order
    computed (the unknowns' higher rates are NaN). Returns
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
    if J is None:
        J = ck.module.jac_v(Z, ck.p)
        J = np.broadcast_to(J.reshape(J.shape[0], -1), (J.shape[0], N)) if J.size else J
    cond = _cond_v(ck, J)
    out = [Z]
    with np.errstate(divide="ignore", invalid="ignore"):
        for order in (1, 2, 3):
            Zk = np.zeros((nv, N))
            Zk[ix] = rates[order - 1]
            if order <= derivatives:
                b = ck.rhs_v(order, *out, Zk)
                b = np.broadcast_to(np.asarray(b).reshape(len(iu), -1), (len(iu), N))
                Zk[iu] = block_solve_v(ck, J, b)
            else:
                Zk[iu] = np.nan
            out.append(Zk)
    bad = ~(cond <= SINGULAR_COND)
    if np.any(bad):
        for order, Zk in enumerate(out[1:], start=1):
            Zk[:, bad] = np.nan
            Zk[ix, bad] = rates[order - 1]
    return out[1], out[2], out[3], cond


def _newton_v(ck, Z):
    """One Newton step on the stacked systems (``Z`` modified in place), then the chord check.

    Returns the residuals ``F`` at the new ``Z`` and the scaled size of the next (chord) correction
    ``J0⁻¹ F``: the error left in ``Z``. From a guess within ~1e-8 one step reaches round-off.
    """
    iu = ck.unknown_idx
    J0 = ck.module.jac_v(Z, ck.p)
    F = ck.module.phi_v(Z, ck.p)
    Z[iu] -= block_solve_v(ck, J0, F)
    F = ck.module.phi_v(Z, ck.p)
    return F, block_solve_v(ck, J0, F)


def _sign_dets_v(ck, J):
    """Signs of the diagonal-block determinants, ``(nblocks, N)`` (fast path for 1x1 and 2x2 blocks)."""
    n = len(ck.unknowns)
    out = []
    for eqs, cols in _blocks(ck):
        if len(cols) == 1:
            d = J[eqs[0] * n + cols[0]]
        elif len(cols) == 2:
            e0, e1 = eqs
            c0, c1 = cols
            d = J[e0 * n + c0] * J[e1 * n + c1] - J[e0 * n + c1] * J[e1 * n + c0]
        else:
            M = np.stack([np.stack([J[e * n + c] for c in cols], axis=-1) for e in eqs], axis=-2)
            d = np.linalg.det(M)
        out.append(np.sign(d))
    return np.array(out).reshape(len(out), -1)


def solve_rows(tracer, path, rows, g):
    """Positions of the output rows: vectorized where the path is regular, tracked elsewhere.

    Internal to :func:`loopsolve.sweep.sweep` (``method="batched"``).

    Returns the tracker's row solution (positions, mode codes, residuals, iterations) with the
    Jacobians of the vectorized rows kept for the rates.
    """
    kern = tracer.k
    ck = kern.ck
    n, ix, nv = kern.n, kern.ix, kern.nv
    nodes = path.nodes
    N = len(rows)
    sol = RowSolution(N, nv)
    other = fill_node_rows(path, rows, sol)
    sol.J = np.empty((n * n, N))
    sol.J_ok = np.zeros(N, dtype=bool)
    # segments on which a cubic in the input is a reliable warm start
    nseg = len(nodes) - 1
    seg_ok = np.zeros(max(nseg, 0), dtype=bool)
    seg_code = np.zeros(max(nseg, 0), dtype=np.int64)
    for i in range(nseg):
        a, b = nodes[i], nodes[i + 1]
        s = path.seg_sig[i]
        seg_code[i] = sol.code_of(s)
        seg_ok[i] = (a.kind in ("regular", "end") and b.kind in ("regular", "end") and a.sig == b.sig == s
                     and abs(a.t[n]) >= 0.1 and abs(b.t[n]) >= 0.1 and (a.t[n] > 0) == (b.t[n] > 0))
    vec_mask = other.copy()
    vec_mask[other] = seg_ok[rows.seg[other]]
    redo_mask = other & ~vec_mask
    vec = np.flatnonzero(vec_mask)
    if len(vec):
        seg = rows.seg[vec]
        sol.code[vec] = seg_code[seg]
        # cubic Hermite in the input on each segment, in Horner form: coefficients per segment
        NZ = np.array([nd.z for nd in nodes], dtype=float)  # (nodes, nv)
        T = np.array([nd.t for nd in nodes], dtype=float)  # (nodes, n+1)
        w = np.array(kern.wu)
        iu = ck.unknown_idx
        with np.errstate(divide="ignore", invalid="ignore"):
            slope = (T[:, :n] / w) / (T[:, n:] / kern.wx)  # dq/dx at the nodes
        xa_s = NZ[:-1, ix]
        dx_s = NZ[1:, ix] - xa_s
        ua, ub = NZ[:-1][:, iu], NZ[1:][:, iu]
        ma, mb = slope[:-1] * dx_s[:, None], slope[1:] * dx_s[:, None]
        c2 = 3 * (ub - ua) - 2 * ma - mb
        c3 = 2 * (ua - ub) + ma + mb
        x = rows.x[vec]
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / dx_s
        t = (x - xa_s[seg]) * inv[seg]
        Z = np.empty((nv, len(vec)))
        Z[ix] = x
        for j in range(len(ck.inputs)):
            if j:  # inputs held during the sweep
                Z[ck.input_idx[j]] = NZ[0, ck.input_idx[j]]
        for j in range(n):
            Z[iu[j]] = ua[seg, j] + t * (ma[seg, j] + t * (c2[seg, j] + t * c3[seg, j]))
        F, dU = _newton_v(ck, Z)
        if kern.any_length:
            dU *= w[:, None]
        err = np.max(np.abs(dU), axis=0) if n else np.zeros(len(vec))
        resid = np.max(np.abs(F.reshape(F.shape[0], -1)), axis=0) if n else np.zeros(len(vec))
        J = ck.module.jac_v(Z, ck.p).reshape(n * n, -1)
        J = np.broadcast_to(J, (n * n, len(vec)))
        signs = _sign_dets_v(ck, J)
        codes = np.array([[1.0 if ch == "+" else -1.0 for ch in sg] for sg in sol.sigs]).reshape(len(sol.sigs), -1)
        vcode = sol.code[vec]
        if vcode.min() == vcode.max():
            same = np.all(signs == codes[vcode[0]][:, None], axis=0)
        else:
            same = np.all(signs == codes[vcode].T, axis=0)
        ymax = float(np.max(np.abs(NZ[:, iu] * w))) if n else 0.0
        good = (err <= 1e-13 * (1 + ymax)) & (resid <= kern.tol) & same
        if len(vec) == N and good.all():  # the common case: no scatter copies
            sol.Z, sol.res, sol.J = Z, resid, np.ascontiguousarray(J)
            sol.its[:] = 1
            sol.J_ok[:] = True
        else:
            gv = vec[good]
            sol.Z[:, gv] = Z[:, good]
            sol.res[gv] = resid[good]
            sol.its[gv] = 1
            sol.J[:, gv] = J[:, good]
            sol.J_ok[gv] = True
        redo_mask[vec[~good]] = True
    solve_rows_scalar(tracer, path, rows, g, sol, np.flatnonzero(redo_mask))
    return sol
