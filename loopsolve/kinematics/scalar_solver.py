"""Scalar kernel of the continuation: the compiled functions on Python lists, block solves.

The tracker (:mod:`loopsolve.kinematics.continuation`) calls the compiled residual and Jacobian once per
corrector iteration; at a few microseconds per call, Python lists and explicit 1×1/2×2 block
solves beat numpy's per-call overhead. Coordinates are *scaled*: angles in radians, lengths
divided by the model's length scale (``CompiledKinematics.scale``), so that steps, tangents and
tolerances mean the same thing for every model.
"""

from __future__ import annotations

import math
import threading
from collections import OrderedDict

import numpy as np

from ..model.units import Kind

__all__ = ["Kernel", "ROUNDOFF", "kernel_of"]

#: Newton stops when its correction is at round-off level: this times (1 + |scaled unknowns|)
ROUNDOFF = 8 * 2.220446049250313e-16
_ROUNDOFF = ROUNDOFF

def rho_2x3(a0, a1, a2, b0, b1, b2) -> float:
    """σ_min/σ_max of the 2×3 matrix with rows ``a``, ``b`` (:meth:`Kernel.rho` of one 2×2 block), in
    closed form on plain floats: the tracker's step for four-bars computes it in place."""
    big = max(abs(a0), abs(a1), abs(a2), abs(b0), abs(b1), abs(b2))
    if not (0.0 < big < math.inf):
        return 0.0
    # σ_min/σ_max does not change with a common factor: divide by the largest entry so that the
    # squares below cannot overflow (links of 1e90 model units)
    a0, a1, a2, b0, b1, b2 = a0 / big, a1 / big, a2 / big, b0 / big, b1 / big, b2 / big
    g11 = a0 * a0 + a1 * a1 + a2 * a2
    g22 = b0 * b0 + b1 * b1 + b2 * b2
    g12 = a0 * b0 + a1 * b1 + a2 * b2
    # det(A Aᵀ) by Cauchy-Binet: the sum of the squared 2×2 minors (no cancellation)
    m01 = a0 * b1 - a1 * b0
    m02 = a0 * b2 - a2 * b0
    m12 = a1 * b2 - a2 * b1
    det = m01 * m01 + m02 * m02 + m12 * m12
    tr = g11 + g22
    lmax = 0.5 * (tr + math.sqrt(max((g11 - g22) ** 2 + 4 * g12 * g12, 0.0)))
    if not lmax > 0:
        return 0.0
    return math.sqrt(max(det / lmax, 0.0) / lmax)


#: the kernels of the last few compiled models: (id(mechanism), inputs, id(module)) -> Kernel. A kernel
#: holds its mechanism, so the key's ids stay valid while it is here; bounded, so that a study's many
#: mechanisms are not kept alive
_KERNELS: "OrderedDict" = OrderedDict()
_KERNELS_MAX = 16
_KERNELS_LOCK = threading.Lock()


def kernel_of(ck) -> "Kernel":
    """The :class:`Kernel` of ``ck``, reused (a sweep's front end calls this every time, and
    ``mech.compile()`` returns an equal new ``ck`` each call: the kernel of an earlier one, of the same
    mechanism object, inputs and generated module, is the same). A kernel holds a copy of the
    parameter values: it is rebuilt when ``ck.p`` no longer equals them; a model with other
    parameters (``with_parameters``) is another mechanism, hence another kernel."""
    key = (id(ck.mechanism), tuple(ck.inputs), id(ck.module))
    with _KERNELS_LOCK:
        kern = _KERNELS.get(key)
        if kern is not None and kern.ck.mechanism is ck.mechanism and kern.ck.module is ck.module \
                and kern.p == ck.p.tolist():
            _KERNELS.move_to_end(key)
            return kern
    kern = Kernel(ck)
    with _KERNELS_LOCK:
        _KERNELS[key] = kern
        _KERNELS.move_to_end(key)
        while len(_KERNELS) > _KERNELS_MAX:
            _KERNELS.popitem(last=False)
    return kern


class Kernel:
    """Fast scalar evaluation of the compiled functions on Python lists, with block solves."""

    def __init__(self, ck):
        m = ck.module
        self.ck = ck
        self.phi_f, self.jac_f = m.phi, m.jac
        self.rhs1_f = m.rhs1
        self.p = [float(v) for v in ck.p]
        self.nv = len(ck.variables)
        self.n = len(ck.unknowns)
        self.iu = [int(i) for i in ck.unknown_idx]
        self.ix = int(ck.input_idx[0])
        self.blocks = [(tuple(b.eqs), tuple(b.unknowns)) for b in ck.blocks]
        self.single2 = len(self.blocks) == 1 and self.n == 2 and self.blocks[0] == ((0, 1), (0, 1))
        sc = float(ck.scale)
        self.scale = sc
        self.angle_u = [ck.kinds[i] is Kind.ANGLE for i in self.iu]
        self.turn_u = [bool(ck.periodic[i]) for i in self.iu]  # angles a whole turn leaves the same pose
        self.wu = [1.0 if a else 1.0 / sc for a in self.angle_u]
        self.angle_x = ck.kinds[self.ix] is Kind.ANGLE
        self.wx = 1.0 if self.angle_x else 1.0 / sc
        self.w = self.wu + [self.wx]
        self.colscale = [1.0 / w for w in self.wu]
        self.any_length = not all(self.angle_u)
        self.tol = 1e-11 * sc
        self.x_tol = 1e-9 if self.angle_x else 1e-9 * sc
        ex = [0.0] * self.nv
        ex[self.ix] = 1.0
        self.ex = ex

    # ---- linear algebra on the block-triangular Jacobian (flat, row-major)
    def solve(self, J, b):
        n = self.n
        try:
            if self.single2:
                a, bb, c, d = J
                det = a * d - bb * c
                return [(d * b[0] - bb * b[1]) / det, (a * b[1] - c * b[0]) / det]
            x = [0.0] * n
            for eqs, cols in self.blocks:
                r = [b[e] - sum(J[e * n + c] * x[c] for c in range(n)) for e in eqs]
                k = len(cols)
                if k == 1:
                    x[cols[0]] = r[0] / J[eqs[0] * n + cols[0]]
                elif k == 2:
                    e0, e1 = eqs
                    c0, c1 = cols
                    a, bb, c, d = J[e0 * n + c0], J[e0 * n + c1], J[e1 * n + c0], J[e1 * n + c1]
                    det = a * d - bb * c
                    x[c0] = (d * r[0] - bb * r[1]) / det
                    x[c1] = (a * r[1] - c * r[0]) / det
                else:
                    M = np.array([[J[e * n + c] for c in cols] for e in eqs])
                    sol = np.linalg.solve(M, np.array(r))
                    for c, v in zip(cols, sol):
                        x[c] = float(v)
            return x
        except (ZeroDivisionError, np.linalg.LinAlgError):
            return None

    def dets(self, J):
        """Determinant and regularity |det| / (‖B‖_F² / k)^(k/2) (≈ 2/cond for 2×2; 0 = singular) per block.

        Columns of length unknowns are scaled by the model's length scale first (positive
        factors: the signs are those of Φ_q), so the regularity does not depend on the unit.
        """
        n = self.n
        cs = self.colscale
        J = [J[i] * cs[i % n] for i in range(n * n)] if self.any_length else J
        out, had = [], []
        for eqs, cols in self.blocks:
            k = len(cols)
            if k == 1:  # relative to the model's length scale (the column is scaled already)
                d = J[eqs[0] * n + cols[0]]
                out.append(d)
                had.append(min(1.0, abs(d) / self.scale))
                continue
            if k == 2:
                e0, e1 = eqs
                c0, c1 = cols
                a, bb, c, dd = J[e0 * n + c0], J[e0 * n + c1], J[e1 * n + c0], J[e1 * n + c1]
                d = a * dd - bb * c
                nr = 0.5 * (a * a + bb * bb + c * c + dd * dd)
            else:
                M = np.array([[J[e * n + c] for c in cols] for e in eqs])
                d = float(np.linalg.det(M))
                nr = float(np.sum(M * M) / k) ** (k / 2)
            out.append(d)
            had.append(abs(d) / nr if nr > 0 else 0.0)
        return out, had

    @staticmethod
    def sig(dets) -> str:
        return "".join("+" if d > 0 else "-" if d < 0 else "0" for d in dets)

    # ---- Newton at fixed input, block-triangular solves
    def newton(self, z, max_iter):
        phi, jac, p, iu, wu = self.phi_f, self.jac_f, self.p, self.iu, self.wu
        prev = None
        first = None
        tiny = _ROUNDOFF * (1.0 + max((abs(z[i]) * w for i, w in zip(iu, wu)), default=0.0))
        for it in range(1, max_iter + 1):
            f = phi(z, p)
            dx = self.solve(jac(z, p), [-v for v in f])
            if dx is None:
                return z, it, False, first
            st = max(abs(d) * w for d, w in zip(dx, wu))
            if not st < math.inf:
                return z, it, False, first
            for k, i in enumerate(iu):
                z[i] += dx[k]
            if first is None:
                first = st
            if st <= tiny or (prev is not None and st * (st / prev) ** 2 <= tiny):
                return z, it, True, first
            prev = st
        return z, max_iter, False, first

    def rho(self, z, J) -> float:
        """Separation ratio σ_min/σ_max of the scaled ``[Φ_q  Φ_x]`` (n × (n+1)); 1 for no unknowns.

        The curve Φ = 0 is a regular 1-manifold where it is > 0. It bounds how sharply the
        curve turns (radius of curvature ≳ ρ in scaled units, the second derivatives of the
        rotating loop vectors being as large as the first) and how close another piece of the
        solution set can pass: a second solution at distance δ across the curve needs
        σ_min ≲ M δ / 2 (Taylor), M ≈ σ_max. Steps and corrections within a fraction of ρ
        therefore stay on the piece they started on. ρ is small only near change points
        (the branches touch) and where two pieces nearly touch (near-change-point designs);
        at a simple fold it stays of order one.
        """
        n = self.n
        if n == 0:
            return 1.0
        cs = self.colscale
        fx = self.jx(z)
        wx = self.wx
        rows = [[J[e * n + c] * cs[c] for c in range(n)] + [fx[e] / wx] for e in range(n)]
        # σ_min/σ_max does not change with a common factor: divide by the largest entry so that the
        # squares below cannot overflow (links of 1e90 model units)
        big = max((abs(v) for r in rows for v in r), default=0.0)
        if not (0.0 < big < math.inf):
            return 0.0
        if n == 2:
            (a0, a1, a2), (b0, b1, b2) = rows
            return rho_2x3(a0, a1, a2, b0, b1, b2)
        rows = [[v / big for v in r] for r in rows]
        try:
            sv = np.linalg.svd(np.array(rows), compute_uv=False)
        except np.linalg.LinAlgError:
            return 0.0
        return float(sv[-1] / sv[0]) if sv[0] > 0 else 0.0

    def fold_point(self, z, J):
        """``(z*, t)``: the limit position (fold of the input) next to ``z`` and its tangent, or None.

        At a fold Φ_q is singular but [Φ_q Φ_x] is not (ρ of order one): its null vector is the
        tangent, normal to the input axis. The fold is the regular root of the extended system
        Φ(u, x) = 0, det B(u, x) = 0 (B the diagonal block that is singular there), solved by
        Newton in (u, x) with the determinant's gradient by central differences.
        """
        n = self.n
        if n == 0 or self.rho(z, J) < 1e-4:
            return None  # Φ_x in the range of Φ_q: a change point or worse, not a fold
        j = min(range(len(self.blocks)), key=lambda b: self.dets(J)[1][b])
        z = list(z)
        w = self.w
        for _ in range(30):
            Jz = self.jac_f(z, self.p)
            f = list(self.phi_f(z, self.p)) + [self.dets(Jz)[0][j]]
            A = np.empty((n + 1, n + 1))
            A[:n, :n] = np.asarray(Jz, dtype=float).reshape(n, n)
            A[:n, n] = self.jx(z)
            y = self.yhat(z)
            for c in range(n + 1):  # d det / d y_c by central differences (scaled coordinates)
                hh = 1e-6
                zp, zm = list(z), list(z)
                yp, ym = list(y), list(y)
                yp[c] += hh
                ym[c] -= hh
                self.set_yhat(zp, yp)
                self.set_yhat(zm, ym)
                dp = self.dets(self.jac_f(zp, self.p))[0][j]
                dm = self.dets(self.jac_f(zm, self.p))[0][j]
                A[n, c] = (dp - dm) / (2 * hh) * w[c]
            try:
                dz = np.linalg.solve(A, -np.asarray(f))
            except np.linalg.LinAlgError:
                return None
            if not np.all(np.isfinite(dz)):
                return None
            for k, i in enumerate(self.iu):
                z[i] += float(dz[k])
            z[self.ix] += float(dz[n])
            if float(np.max(np.abs(dz * np.asarray(w)))) <= 1e-15 * (1 + max(abs(v) for v in self.yhat(z))):
                break
        if not self.residual(z) <= self.tol:
            return None
        Jz = self.jac_f(z, self.p)
        A = np.empty((n, n + 1))
        A[:, :n] = np.asarray(Jz, dtype=float).reshape(n, n) * np.asarray(self.colscale)
        A[:, n] = np.asarray(self.jx(z)) / self.wx
        t = [float(v) for v in np.linalg.svd(A)[2][-1]]
        if abs(t[n]) > 1e-3:
            return None
        t[n] = 0.0
        return z, t

    def residual(self, z) -> float:
        return max(abs(v) for v in self.phi_f(z, self.p)) if self.n else 0.0

    def jx(self, z):
        """∂Φ/∂x of the driving input (the velocity right-hand side with unit input rate, negated)."""
        return [-v for v in self.rhs1_f(z, self.ex, self.p)]

    def dudx(self, z, J):
        return self.solve(J, self.rhs1_f(z, self.ex, self.p))

    # ---- scaled coordinates y = (u, x)
    def yhat(self, z):
        return [w * z[i] for w, i in zip(self.wu, self.iu)] + [self.wx * z[self.ix]]

    def set_yhat(self, z, y):
        for k, i in enumerate(self.iu):
            z[i] = y[k] / self.wu[k]
        z[self.ix] = y[-1] / self.wx

    def natural_tangent(self, dudx, d):
        t = [w * v * d for w, v in zip(self.wu, dudx)] + [self.wx * d]
        nrm = math.sqrt(sum(v * v for v in t))
        return [v / nrm for v in t]

    def _bordered(self, z, J, row):
        n = self.n
        A = np.empty((n + 1, n + 1))
        A[:n, :n] = np.asarray(J, dtype=float).reshape(n, n)
        A[:n, n] = self.jx(z)
        A[n, :n] = np.asarray(row[:n]) * np.asarray(self.wu)
        A[n, n] = row[n] * self.wx
        return A

    def aug_newton(self, z, row, target, max_iter):
        """Solve Φ = 0 together with ``row · ŷ = target`` (ŷ scaled (u, x)) from ``z`` (modified)."""
        n, iu, ix, w = self.n, self.iu, self.ix, self.w
        prev = None
        first = None
        tiny = _ROUNDOFF * (1.0 + max(abs(v) for v in self.yhat(z)))
        for it in range(1, max_iter + 1):
            f = self.phi_f(z, self.p)
            J = self.jac_f(z, self.p)
            y = self.yhat(z)
            g = np.array(list(f) + [sum(r * v for r, v in zip(row, y)) - target])
            try:
                dy = np.linalg.solve(self._bordered(z, J, row), -g)
            except np.linalg.LinAlgError:
                return z, it, False, first
            st = float(np.max(np.abs(dy * np.asarray(w))))
            if not st < math.inf:
                return z, it, False, first
            for k, i in enumerate(iu):
                z[i] += float(dy[k])
            z[ix] += float(dy[n])
            if first is None:
                first = st
            if st <= tiny or (prev is not None and st * (st / prev) ** 2 <= tiny):
                return z, it, True, first
            prev = st
        return z, max_iter, False, first

    def aug_tangent(self, z, J, row):
        """Unit tangent (scaled) of the solution curve at ``z``, oriented so that ``row · t > 0``."""
        n = self.n
        rhs = np.zeros(n + 1)
        rhs[n] = 1.0
        try:
            tau = np.linalg.solve(self._bordered(z, J, row), rhs)
        except np.linalg.LinAlgError:
            return None
        t = tau * np.asarray(self.w)
        nrm = float(np.linalg.norm(t))
        if not nrm > 0 or not math.isfinite(nrm):
            return None
        return [float(v) / nrm for v in t]

