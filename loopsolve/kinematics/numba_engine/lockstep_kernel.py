"""The lockstep continuation of a study chunk, compiled (the ``numba`` engine of :func:`loopsolve.design.lockstep.sweep_chunk`).

:func:`lockstep_run` is the continuation loop of :func:`loopsolve.design.lockstep._lockstep` after
the start — Taylor predictor, chord Newton corrector, the checks ``FOLD_SLOPE``,
``FIRST_CORRECTION``, ``REGULAR_MIN`` and the block signature, the rows' positions, rates and
points — for every design of a chunk in one compiled loop, design by design (the designs of a
lockstep chunk never interact: each one's checks decide only its own fate). It is a template
written into the model's numba module (:func:`loopsolve.kinematics.numba_engine.jit.numba_source`)
next to the model's generated Φ, Φ_q, b₁–b₃ and points, which it calls through the generated
array wrappers ``phi_a``, ``jac_a``, ``rhs1_a`` … ``points3_a`` (the tuples of the generated
functions unpacked into arrays; no copy of the model). The block structure is data (``bs``,
``be``, ``bc``): one template for every structure of 1×1 and 2×2 blocks.

Every operation is the numpy lockstep's in the same order (:meth:`DesignOps.solve
<loopsolve.design.designops.DesignOps.solve>`, :meth:`DesignOps.signs_and_regularity
<loopsolve.design.designops.DesignOps.signs_and_regularity>`, ``_substep``, ``_store_row``): a
change there must be made here too (``tests/design/test_lockstep_compiled.py`` compares the two).
The numpy corrector evaluates Φ and Φ_q with a fused kernel, so the two agree to round-off, not
to the bit.

Synthesis (issue 32, item 5) runs two more loops here on the same pieces: :func:`follow_run`, the trace
of many candidate designs through their own input values (:meth:`Batch.follow
<loopsolve.design.synthesis.candidates.Batch.follow>`: per-design inputs and a substep count shared by
the designs still going, which ``lockstep_run``'s shared grid cannot express), and
:func:`block_newton_run`, the block Newton of its multistart assembly (``Batch._block_newton``); the
same rule holds (``tests/design/test_synthesis_compiled.py``).
"""

from __future__ import annotations

import inspect
import math

import numpy as np

__all__ = ["TEMPLATE_FUNCTIONS", "template_source", "wrapper_source"]


def ls_solve(J, B, X, sol, n, bs, be, bc):
    """Φ_q X = B by forward substitution over the solve-order blocks (DesignOps.solve)."""
    for i in range(n):
        X[i] = 0.0
    ns = 0
    for b in range(bs.shape[0]):
        e0 = be[b, 0]
        c0 = bc[b, 0]
        s = 0.0
        for q in range(ns):
            s += J[e0 * n + sol[q]] * X[sol[q]]
        r0 = B[e0] - s
        if bs[b] == 1:
            X[c0] = r0 / J[e0 * n + c0]
            sol[ns] = c0
            ns += 1
        else:
            e1 = be[b, 1]
            c1 = bc[b, 1]
            s = 0.0
            for q in range(ns):
                s += J[e1 * n + sol[q]] * X[sol[q]]
            r1 = B[e1] - s
            a = J[e0 * n + c0]
            bb = J[e0 * n + c1]
            c = J[e1 * n + c0]
            d = J[e1 * n + c1]
            det = a * d - bb * c
            X[c0] = (d * r0 - bb * r1) / det
            X[c1] = (a * r1 - c * r0) / det
            sol[ns] = c0
            sol[ns + 1] = c1
            ns += 2


def ls_sign(d):
    if d > 0:
        return 1.0
    if d < 0:
        return -1.0
    if d == 0:
        return 0.0
    return math.nan


def ls_regular(J, sig0, j, cs, n, bs, be, bc, regmin):
    """Whether every block keeps its sign ``sig0[:, j]`` and the regularity stays ≥ ``regmin``
    (DesignOps.signs_and_regularity)."""
    reg = math.inf
    same = True
    for b in range(bs.shape[0]):
        e0 = be[b, 0]
        c0 = bc[b, 0]
        if bs[b] == 1:
            d = J[e0 * n + c0]
            h = 1.0 if d != 0 else 0.0
        else:
            e1 = be[b, 1]
            c1 = bc[b, 1]
            a = J[e0 * n + c0] * cs[c0]
            bb = J[e0 * n + c1] * cs[c1]
            c = J[e1 * n + c0] * cs[c0]
            dd = J[e1 * n + c1] * cs[c1]
            d = a * dd - bb * c
            h = abs(d) / (0.5 * (a * a + bb * bb + c * c + dd * dd))
        if not ls_sign(d) == sig0[b, j]:
            same = False
        if not (h - h == 0.0):  # not finite
            h = 0.0
        reg = min(reg, h)
    return same and reg >= regmin


def ls_scaled_max(a, w, n):
    """max |a·w| as numpy's max takes it (NaN when any is NaN)."""
    m = -math.inf
    for c in range(n):
        v = abs(a[c] * w[c])
        if v != v:
            return math.nan
        if v > m:
            m = v
    return m


def ls_store(zk, z, J, p, j, k, rates, derivatives, ix, iu, n, bs, be, bc, B, X, sol, OZ, OP, PT, npts):
    """Positions, rates and points of grid row ``k`` of design ``j`` (_store_row)."""
    nv = z.shape[0]
    for i in range(nv):
        zk[0, i] = z[i]
        OZ[j, 0, i, k] = z[i]
    for order in range(1, derivatives + 1):
        for i in range(nv):
            zk[order, i] = 0.0
        zk[order, ix] = rates[order - 1]
        if order == 1:
            rhs1_a(zk[0], zk[1], p, B)  # noqa: F821 - generated next to the model's functions
        elif order == 2:
            rhs2_a(zk[0], zk[1], zk[2], p, B)  # noqa: F821
        else:
            rhs3_a(zk[0], zk[1], zk[2], zk[3], p, B)  # noqa: F821
        ls_solve(J, B, X, sol, n, bs, be, bc)
        for c in range(n):
            zk[order, iu[c]] = X[c]
        for i in range(nv):
            OZ[j, order, i, k] = zk[order, i]
    if npts > 0:
        for order in range(derivatives + 1):
            if order == 0:
                points0_a(zk[0], p, PT)  # noqa: F821
            elif order == 1:
                points1_a(zk[0], zk[1], p, PT)  # noqa: F821
            elif order == 2:
                points2_a(zk[0], zk[1], zk[2], p, PT)  # noqa: F821
            else:
                points3_a(zk[0], zk[1], zk[2], zk[3], p, PT)  # noqa: F821
            for i in range(npts):
                OP[j, order, i, 0, k] = PT[2 * i]
                OP[j, order, i, 1, k] = PT[2 * i + 1]


def lockstep_run(Z0, P, alive, sig0, scale, islen, x_start, tx, tk, rates, derivatives, cf, ix, iu, bs, be, bc,
                 OZ, OP, last, irregular):
    """The lockstep continuation of every design ``j`` of a chunk from its start ``Z0[j]`` (at ``x_start``)
    through the targets ``tx`` (grid row ``tk`` or −1), parameters ``P[j]``; ``cf`` = (FOLD_SLOPE,
    FIRST_CORRECTION, converged, REGULAR_MIN). Writes the rows (``OZ`` positions and rates, ``OP`` the
    points; NaN after a design's last row), ``alive``, ``last`` and ``irregular`` as _lockstep has them.
    ``OZ`` and ``OP`` are design-major, ``(D, d+1, nv, K)`` and ``(D, d+1, P, 2, K)``: a design's rows are
    written together (the chunk sees them as ``(d+1, nv, K, D)``; written there, every value stored would be
    a cache line of its own)."""
    D = Z0.shape[0]
    nv = Z0.shape[1]
    n = iu.shape[0]
    K = OZ.shape[3]
    npts = OP.shape[2]
    fold, first, conv, regmin = cf[0], cf[1], cf[2], cf[3]
    z = np.empty(nv)
    zk = np.zeros((4, nv))
    zk1 = np.zeros(nv)
    J = np.empty(n * n)
    Jn = np.empty(n * n)
    F = np.empty(n)
    B = np.empty(n)
    X = np.empty(n)
    T = np.empty(n)
    Tp = np.empty(n)
    C2 = np.empty(n)
    w = np.empty(n)
    cs = np.empty(n)
    sol = np.empty(n, dtype=np.int64)
    PT = np.empty(max(2 * npts, 1))
    nt = tx.shape[0]
    for j in range(D):
        p = P[j]
        for i in range(nv):
            z[i] = Z0[j, i]
        for c in range(n):
            w[c] = 1.0 / scale[j] if islen[c] else 1.0
            cs[c] = scale[j] if islen[c] else 1.0
        ok = alive[j]
        last[j] = -1
        if ok:
            jac_a(z, p, J)  # noqa: F821
            x_prev = x_start
            has_t = False
            has_tp = False
            h_prev = 0.0
            for t in range(nt):
                x = tx[t]
                k = tk[t]
                if x != x_prev:
                    if not has_t:
                        for i in range(nv):
                            zk1[i] = 0.0
                        zk1[ix] = 1.0
                        rhs1_a(z, zk1, p, B)  # noqa: F821
                        ls_solve(J, B, T, sol, n, bs, be, bc)
                    h = x - x_prev
                    use_c2 = has_tp and h * h_prev > 0
                    if use_c2:
                        for c in range(n):
                            C2[c] = (T[c] - Tp[c]) / h_prev
                    # _substep: predictor, then the chord Newton corrector
                    slope = ls_scaled_max(T, w, n)
                    if not (slope - slope == 0.0 and slope <= fold):
                        ok = False
                        break
                    z[ix] = x
                    for c in range(n):
                        z[iu[c]] = z[iu[c]] + T[c] * h + (0.5 * h * h * C2[c] if use_c2 else 0.0)
                    done = False
                    for it in range(8):
                        if it % 3 == 0:
                            phi_a(z, p, F)  # noqa: F821
                            jac_a(z, p, Jn)  # noqa: F821
                        else:
                            phi_a(z, p, F)  # noqa: F821
                        for c in range(n):
                            F[c] = -F[c]
                        ls_solve(Jn, F, X, sol, n, bs, be, bc)
                        size = ls_scaled_max(X, w, n)
                        if it == 0 and not (size - size == 0.0 and size <= first):
                            break
                        for c in range(n):
                            z[iu[c]] = z[iu[c]] + X[c]
                        if size <= conv:
                            done = True
                            break
                    if not done:
                        ok = False
                        break
                    jac_a(z, p, J)  # noqa: F821
                    if not ls_regular(J, sig0, j, cs, n, bs, be, bc, regmin):
                        irregular[j] = True
                        ok = False
                        break
                    x_prev = x
                    for c in range(n):
                        Tp[c] = T[c]
                    has_tp = True
                    h_prev = h
                    has_t = False
                if k >= 0:
                    ls_store(zk, z, J, p, j, k, rates, derivatives, ix, iu, n, bs, be, bc, B, X, sol, OZ, OP, PT,
                             npts)
                    if derivatives >= 1 and rates[0] != 0:
                        for c in range(n):
                            T[c] = zk[1, iu[c]] / rates[0]
                        has_t = True
                    last[j] = k
        alive[j] = ok
        for o in range(OZ.shape[1]):
            for i in range(nv):
                for k in range(last[j] + 1, K):
                    OZ[j, o, i, k] = math.nan
            for i in range(npts):
                for k in range(last[j] + 1, K):
                    OP[j, o, i, 0, k] = math.nan
                    OP[j, o, i, 1, k] = math.nan


def follow_run(Zw, P, X, alive, sig0, scale, islen, hmax, cf, ix, iu, bs, be, bc, Zt, reached):
    """:meth:`Batch.follow <loopsolve.design.synthesis.candidates.Batch.follow>` after its start, compiled: every
    design ``j`` with ``alive[j]`` from ``Zw[j]`` (its position at ``X[0, j]``, parameters ``P[j]``) through its
    inputs ``X[:, j]``; ``cf`` = (FIRST_CORRECTION, converged, regularity floor or −inf). Target after target
    (``X[t]``): the substeps of a target are as many as the largest input change of the designs still going
    needs (numpy takes them for all those designs at once); each substep a tangent predictor and Newton with
    Φ_q refreshed every second iteration, then the block signs ``sig0`` and the regularity checked. Writes
    ``Zt`` (nv, T, D) at the targets a design reached, ``reached``, ``alive``; ``Zw`` is the work array."""
    D = Zw.shape[0]
    nv = Zw.shape[1]
    n = iu.shape[0]
    T = X.shape[0]
    first, conv, regmin = cf[0], cf[1], cf[2]
    Js = np.empty((D, n * n))
    Jn = np.empty(n * n)
    zk1 = np.zeros(nv)
    zk1[ix] = 1.0
    F = np.empty(n)
    B = np.empty(n)
    U = np.empty(n)
    Tq = np.empty(n)
    w = np.empty(n)
    cs = np.empty(n)
    sol = np.empty(n, dtype=np.int64)
    for j in range(D):
        if alive[j]:
            jac_a(Zw[j], P[j], Js[j])  # noqa: F821 - generated next to the model's functions
    for t in range(1, T):
        amax = -math.inf
        going = False
        for j in range(D):
            if alive[j]:
                going = True
                a = abs(X[t, j] - X[t - 1, j])
                if a > amax or a != a:
                    amax = a
        if not going:
            break
        m = max(1, int(math.ceil(amax / hmax - 1e-9)))
        for j in range(D):
            if not alive[j]:
                continue
            z = Zw[j]
            p = P[j]
            J = Js[j]
            for c in range(n):
                w[c] = 1.0 / scale[j] if islen[c] else 1.0
                cs[c] = scale[j] if islen[c] else 1.0
            dx = X[t, j] - X[t - 1, j]
            h = dx / m
            ok = True
            for s in range(1, m + 1):
                rhs1_a(z, zk1, p, B)  # noqa: F821
                ls_solve(J, B, Tq, sol, n, bs, be, bc)
                z[ix] = X[t - 1, j] + dx * (s / m)
                for c in range(n):
                    z[iu[c]] = z[iu[c]] + Tq[c] * h
                done = False
                for it in range(10):
                    phi_a(z, p, F)  # noqa: F821
                    if it % 2 == 0:
                        jac_a(z, p, Jn)  # noqa: F821
                    for c in range(n):
                        F[c] = -F[c]
                    ls_solve(Jn, F, U, sol, n, bs, be, bc)
                    size = ls_scaled_max(U, w, n)
                    if it == 0 and not (size - size == 0.0 and size <= first):
                        break
                    for c in range(n):
                        z[iu[c]] = z[iu[c]] + U[c]
                    if size <= conv:
                        done = True
                        break
                if not done:
                    ok = False
                    break
                jac_a(z, p, J)  # noqa: F821
                if not ls_regular(J, sig0, j, cs, n, bs, be, bc, regmin):
                    ok = False
                    break
            alive[j] = ok
            if ok:
                for i in range(nv):
                    Zt[i, t, j] = z[i]
                reached[j] = t + 1


def block_newton_run(Zw, P, eqs, cols, iu, lim, scale, iters, conv):
    """:meth:`Batch._block_newton <loopsolve.design.synthesis.candidates.Batch._block_newton>`, compiled: Newton on
    one 1×1 or 2×2 block's unknowns ``cols`` (equations ``eqs``) of every column ``j`` of ``Zw`` (N, nv) from
    where it is, the others fixed; a step at most ``lim[:, j]`` per unknown (a radian, or the design's scale),
    a column still far from closing the loop at iteration 12 dropped. Writes ``conv`` and the roots in ``Zw``."""
    N = Zw.shape[0]
    nc = cols.shape[0]
    n = iu.shape[0]
    F = np.empty(n)
    J = np.empty(n * n)
    dU = np.empty(2)
    for j in range(N):
        z = Zw[j]
        p = P[j]
        la0 = lim[0, j]
        lmax = lim[0, j]
        for a in range(1, nc):
            if lim[a, j] > lmax:
                lmax = lim[a, j]
        ok = False
        for it in range(iters):
            phi_a(z, p, F)  # noqa: F821 - generated next to the model's functions
            jac_a(z, p, J)  # noqa: F821
            f0 = F[eqs[0]]
            f1 = F[eqs[nc - 1]]
            if it == 12:  # no root near: Newton still far from closing the loop
                fm = abs(f0)
                if nc == 2:
                    v = abs(f1)
                    if fm != fm or v != v:
                        fm = math.nan
                    elif v > fm:
                        fm = v
                if fm > 1e-2 * la0 * lmax:
                    break
            if nc == 1:
                dU[0] = -f0 / J[eqs[0] * n + cols[0]]
            else:
                e0 = eqs[0]
                e1 = eqs[1]
                c0 = cols[0]
                c1 = cols[1]
                a_ = J[e0 * n + c0]
                b_ = J[e0 * n + c1]
                c_ = J[e1 * n + c0]
                d_ = J[e1 * n + c1]
                det = a_ * d_ - b_ * c_
                dU[0] = (-d_ * f0 + b_ * f1) / det
                dU[1] = (c_ * f0 - a_ * f1) / det
            big = -math.inf
            for a in range(nc):
                v = abs(dU[a]) / lim[a, j]
                if v != v:
                    big = math.nan
                    break
                if v > big:
                    big = v
            if not big <= 1.0:
                for a in range(nc):
                    dU[a] = dU[a] / big
            finite = True
            for a in range(nc):
                if not (dU[a] - dU[a] == 0.0):
                    finite = False
            step = 0.0
            for a in range(nc):
                if not finite:
                    dU[a] = 0.0
                z[iu[cols[a]]] = z[iu[cols[a]]] + dU[a]
                v = abs(dU[a]) / lim[a, j]
                if v > step:
                    step = v
            if step <= 1e-13 or not finite:
                ok = finite
                break
        if ok:
            phi_a(z, p, F)  # noqa: F821
            for a in range(nc):
                if not abs(F[eqs[a]]) <= 1e-9 * scale[j]:
                    ok = False
        conv[j] = ok


#: the template functions, in the order they are written into the model's numba module
TEMPLATE_FUNCTIONS = (ls_solve, ls_sign, ls_regular, ls_scaled_max, ls_store, lockstep_run, follow_run,
                      block_newton_run)


def template_source() -> str:
    """Source text of the template functions (for :func:`loopsolve.kinematics.numba_engine.jit.numba_source`)."""
    return "\n\n".join(inspect.getsource(fn) for fn in TEMPLATE_FUNCTIONS)


def wrapper_source(functions: dict, n: int, npts: int) -> str:
    """The array forms of the model's generated functions ``functions`` (name → the text of
    :func:`loopsolve.kinematics.numba_engine.jit._model_function`, ending in a tuple): the same text,
    renamed ``phi_a``, ``jac_a``, ``rhs1_a`` … ``points3_a``, with an argument ``out`` that receives the
    tuple (empty ``points*_a`` without points). Compiled as they are, not inlined into each other:
    numba's inlining of these long expressions cost seconds of compile time per model."""
    sizes = {"phi": n, "jac": n * n, "rhs1": n, "rhs2": n, "rhs3": n}
    sizes.update({f"points{k}": 2 * npts for k in range(4)})
    args = {"phi": "z, p", "jac": "z, p", "rhs1": "z, z1, p", "rhs2": "z, z1, z2, p", "rhs3": "z, z1, z2, z3, p",
            "points0": "z, p", "points1": "z, z1, p", "points2": "z, z1, z2, p", "points3": "z, z1, z2, z3, p"}
    L = []
    for name, count in sizes.items():
        head = f"def {name}_a({args[name]}, out):"
        if not count:
            L.append(f"{head}\n    return\n")
            continue
        lines = functions[name].split("\n")
        if not lines[0].startswith(f"def {name}({args[name]}):") or not lines[-1].startswith("    return ("):
            raise ValueError(f"unexpected generated {name}()")
        unpack = ", ".join(f"out[{i}]" for i in range(count)) + ("," if count == 1 else "")
        lines[0] = head
        lines[-1] = f"    {unpack} = " + lines[-1][len("    return "):]
        L.append("\n".join(lines) + "\n")
    return "\n\n".join(L)
