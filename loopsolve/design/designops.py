"""Many designs of one compiled model at once: their parameter matrix, length scales and the
vectorized evaluations (residuals, Jacobian blocks, rates, points) that lockstep sweeps, studies,
synthesis and assembly tests run on every design in one numpy call.

``P`` is the ``(npar, D)`` matrix of internal parameter values (one column per design) and ``Z``
the ``(nv, D)`` positions.
"""

from __future__ import annotations

import numpy as np

from ..model.units import Kind

__all__ = ["DesignOps", "param_matrix", "design_scale", "fill_rows", "display_value_of", "REGULAR_MIN"]

#: a design is handed to the single-design sweep when a block's regularity (|det| over the mean squared entry, ≈ 2/cond) falls below this
REGULAR_MIN = 1e-3


def param_matrix(ck, names, values) -> np.ndarray:
    """``(npar, D)`` internal parameter values: the model's, with ``names`` replaced by ``values`` (D, k)."""
    mech = ck.mechanism
    pnames = [p.name for p in mech.parameters]
    D = values.shape[0]
    P = np.repeat(np.asarray(ck.p, dtype=float)[:, None], D, axis=1)
    for j, n in enumerate(names):
        i = pnames.index(n)
        v = values[:, j]
        if mech.parameters[i].kind is Kind.ANGLE and mech.units.angle == "deg":
            v = np.radians(v)
        P[i] = v
    return P


def design_scale(ck, P) -> np.ndarray:
    """Length scale of every design, as :func:`loopsolve.symbolic.compiled.compile_mechanism` computes it."""
    mech = ck.mechanism
    rows = [np.abs(P[i]) for i, p in enumerate(mech.parameters) if p.kind is Kind.LENGTH]
    rows += [np.full(P.shape[1], abs(v.guess)) for v in mech.variables if v.kind is Kind.LENGTH and v.guess is not None]
    if not rows:
        return np.ones(P.shape[1])
    s = np.max(np.array(rows), axis=0)
    return np.where(s > 0, s, 1.0)


class DesignOps:
    """Vectorized evaluations of one compiled model with per-column parameters.

    With ``shared_input=True`` every column has the same input value (the lockstep case): the
    input's row is passed as one value, so the generated code evaluates the input's sines and
    cosines once instead of once per design (numpy broadcasting does the rest).
    """

    def __init__(self, ck, shared_input: bool = False):
        self.shared = shared_input
        self.inputs_idx = [int(i) for i in ck.input_idx]
        self.ck = ck
        self.m = ck.module
        self.n = len(ck.unknowns)
        self.iu = np.asarray(ck.unknown_idx)
        self.ix = int(ck.input_idx[0])
        self.blocks = [(tuple(b.eqs), tuple(b.unknowns)) for b in ck.blocks]
        self.is_len = np.array([ck.kinds[int(i)] is Kind.LENGTH for i in self.iu])

    def _bc(self, a, rows, N):
        a = np.asarray(a, dtype=float).reshape(rows, -1)
        return a if a.shape[1] == N else np.broadcast_to(a, (rows, N))

    def rows(self, Z):
        """``Z`` as the generated code takes it: with ``shared``, the inputs' rows as one value each."""
        if not self.shared:
            return Z
        r = list(Z)
        for i in self.inputs_idx:
            r[i] = Z[i, :1]
        return r

    def phi(self, Z, P):
        return self._bc(self.m.phi_v(self.rows(Z), P), self.m.N_EQ, Z.shape[1])

    def jac(self, Z, P):
        return self._bc(self.m.jac_v(self.rows(Z), P), self.n * self.n, Z.shape[1])

    def phi_jac(self, Z, P):
        """Φ and Φ_q at once (shared subexpressions), when the fused kernel is available."""
        if getattr(self, "fused", None) is None:
            return self.phi(Z, P), self.jac(Z, P)
        m = self.m.N_EQ
        out = self._bc(self.fused.phi_jac_v(self.rows(Z), P), m + self.n * self.n, Z.shape[1])
        return out[:m], out[m:]

    def rhs(self, order, zs, P):
        return self._bc(getattr(self.m, f"rhs{order}_v")(*[self.rows(z) for z in zs], P), self.n, zs[0].shape[1])

    def points(self, order, zs, P):
        return getattr(self.m, f"points{order}_v")(*[self.rows(z) for z in zs], P)

    def solve(self, J, B):
        """Φ_q X = B for stacked systems, by forward substitution over the solve-order blocks."""
        n = self.n
        X = np.zeros((n, B.shape[1]))
        solved = []
        for eqs, cols in self.blocks:
            r = [B[e] - sum(J[e * n + c] * X[c] for c in solved) for e in eqs]
            solved.extend(cols)
            if len(cols) == 1:
                X[cols[0]] = r[0] / J[eqs[0] * n + cols[0]]
            else:
                (e0, e1), (c0, c1) = eqs, cols
                a, b, c, d = J[e0 * n + c0], J[e0 * n + c1], J[e1 * n + c0], J[e1 * n + c1]
                det = a * d - b * c
                X[c0] = (d * r[0] - b * r[1]) / det
                X[c1] = (a * r[1] - c * r[0]) / det
        return X

    def guess_signs(self, J):
        """Signs ``(nb, N)`` of the diagonal-block determinants, 0 within :data:`GUESS_SINGULAR` of
        singular: the mode the guesses name, per design (:func:`loopsolve.solve.block_signs`)."""
        from ..kinematics.solve import GUESS_SINGULAR

        n = self.n
        out = []
        for eqs, cols in self.blocks:
            if len(cols) == 1:
                d = J[eqs[0] * n + cols[0]]
                norms = np.abs(d)
            else:
                (e0, e1), (c0, c1) = eqs, cols
                a, b, c, d_ = J[e0 * n + c0], J[e0 * n + c1], J[e1 * n + c0], J[e1 * n + c1]
                d = a * d_ - b * c
                norms = np.hypot(a, c) * np.hypot(b, d_)
            ok = np.isfinite(d) & np.isfinite(norms) & (np.abs(d) > GUESS_SINGULAR * norms)
            out.append(np.where(ok, np.sign(d), 0.0))
        return np.array(out).reshape(len(out), -1)

    def signs_and_regularity(self, J, scale):
        """Signs of the diagonal-block determinants ``(nb, N)`` and the smallest regularity ``(N,)``."""
        n = self.n
        sig, reg = [], np.full(J.shape[1], np.inf)
        cs = [np.where(self.is_len[c], scale, 1.0) for c in range(n)]
        for eqs, cols in self.blocks:
            if len(cols) == 1:
                d = J[eqs[0] * n + cols[0]]
                h = np.where(d != 0, 1.0, 0.0)
            else:
                (e0, e1), (c0, c1) = eqs, cols
                a, b = J[e0 * n + c0] * cs[c0], J[e0 * n + c1] * cs[c1]
                c, d_ = J[e1 * n + c0] * cs[c0], J[e1 * n + c1] * cs[c1]
                d = a * d_ - b * c
                h = np.abs(d) / (0.5 * (a * a + b * b + c * c + d_ * d_))
            sig.append(np.sign(d))
            reg = np.minimum(reg, np.where(np.isfinite(h), h, 0.0))
        return np.array(sig).reshape(len(sig), -1), reg


def fill_rows(ck, ops, Z, P, ch, rows, cols, rates, derivatives):
    """Rates and points at grid rows ``rows`` of designs ``cols`` (pairs) from their positions ``Z``."""
    J = ops.jac(Z, P)
    out = [Z]
    for order in range(1, derivatives + 1):
        Zk = np.zeros_like(Z)
        Zk[ops.ix] = rates[order - 1]
        Zk[ops.iu] = ops.solve(J, ops.rhs(order, out + [Zk], P))
        out.append(Zk)
    for order in range(derivatives + 1):
        ch.Z[order][:, rows, cols] = out[order]
    if ch.points is not None:
        npts = ch.points.shape[1]
        for order in range(derivatives + 1):
            v = np.asarray(ops.points(order, out[: order + 1], P))
            ch.points[order, :, :, rows, cols] = np.broadcast_to(v.reshape(npts, 2, -1),
                                                                 (npts, 2, len(rows))).transpose(2, 0, 1)


def display_value_of(ck, v: float) -> float:
    from ..kinematics.solve import display_value

    return display_value(ck, v, ck.inputs[0])
