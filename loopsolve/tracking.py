"""Sweeps of the input with branch tracking, limit positions and singular points.

The solution set of Φ(q; x) = 0 is a curve in (q, x) space; a sweep follows it from the
solved start through the assembly mode the start picked, and reports the output grid of the
input. The output grid is *not* the internal step: whatever the output step (1° or 45°), the
curve is followed in steps bounded by :class:`StepControl` (2° of scaled arc length by
default), so a coarse grid cannot jump from one mode to the other.

Algorithm (Allgower and Georg, *Introduction to Numerical Continuation Methods*, ch. 2 and 9):

* **Natural steps** in the input while the curve is transversal to it (``|dx/ds| ≥ 0.3`` in
  scaled coordinates: radians and lengths divided by the model's length scale): a predictor
  from the kinematic coefficients dq/dx (the velocity solution with a unit input rate, plus a
  second-order term from the previous node), a Newton corrector at fixed input solved block by
  block, landing on the output grid when it is within the step.
* **Pseudo-arclength steps** near folds: predictor along the unit tangent, corrector on
  Φ = 0 plus the hyperplane through the predictor normal to the tangent (the bordered
  Jacobian stays regular at a fold, where Φ_q does not).
* Every accepted step is checked: the corrector converged in few iterations, it moved
  little from the predictor, the tangent turned by less than ``max_turn``, and the
  **mode signature** (signs of the determinants of the diagonal blocks of Φ_q) is unchanged.
  A rejected step is halved.
* A signature change that survives those checks means a zero of a block determinant
  between the two nodes. It is located along the chord of the step by the Illinois
  (regula falsi) method to ~1e-11 in scaled arc length, which puts a fold's input value
  within ~1e-20 of the true limit (x is stationary there). If the input reversed, the point
  is a **limit** (toggle/fold): the sweep stops there with a ``limit`` event, or with
  ``through_limits`` goes on around the fold onto the other mode (``mode-change`` event),
  back over the same output grid, until the circuit closes or the input leaves the range.
  Otherwise the branches touch (a **change point**): a ``singular`` event, and the sweep
  continues on the smooth branch.

Rows are the output grid values crossed, in the order traversed. Rates at every row are
computed in one vectorized pass (:func:`loopsolve.batch.rates_v`). ``method="batched"``
traces the curve once at the internal step and solves all output points at once
(:mod:`loopsolve.batch`); ``"auto"`` picks it for dense grids.
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass, field

import numpy as np

from .errors import AssemblyError, ConvergenceError, ModelError, SingularPositionError, SolveError
from .newton import Newton
from .results import Event, EventKind, Sweep
from .solve import _input_unit, display_value, initial_z, input_rates, input_value, start_position
from .units import Kind

__all__ = ["StepControl", "sweep", "grid", "reachable_ranges", "default_range", "nearest_assemblable",
           "assembly_failure", "AUTO_BATCH"]

#: ``method="auto"`` uses the batched path from this many output points on
AUTO_BATCH = 720

#: nodes whose Jacobian blocks have a Hadamard ratio below this are not accepted: the step
#: is retried so that it straddles the singular position, which is then located exactly
_NEAR_SINGULAR = 1e-7
#: Newton stops when its correction is at round-off level: this times (1 + |scaled unknowns|)
_ROUNDOFF = 8 * 2.220446049250313e-16
#: a sweep does not start where the regularity (≈ 2/cond of the scaled blocks) is below this
_START_REGULAR = 1e-5


@dataclass(frozen=True, slots=True)
class StepControl:
    """Internal step control of the tracker.

    Steps are measured in scaled arc length: angles in radians, lengths divided by the
    model's characteristic length (``CompiledKinematics.scale``).

    Attributes
    ----------
    max_step : float
        Longest internal step (default 2° = 0.0349).
    min_step : float
        Halving gives up below this step (the sweep then stops with an event).
    max_iter : int
        Corrector iterations allowed in one step.
    max_turn : float
        Largest angle between the tangents at the two ends of a step (radians).
    natural_min, natural_back : float
        Switch to pseudo-arclength steps when ``|dx/ds|`` falls below ``natural_min``, back to
        natural steps above ``natural_back``.
    max_nodes : int
        Upper bound on the internal steps of one sweep.

    Examples
    --------
    >>> fine = StepControl(max_step=math.radians(0.5))
    >>> len(ls.fourbar(60, 25, 70, 45).sweep(0, 360, 90, control=fine))
    5
    """

    max_step: float = math.radians(2.0)
    min_step: float = 1e-10
    max_iter: int = 7
    max_turn: float = math.radians(12.0)
    natural_min: float = 0.3
    natural_back: float = 0.5
    max_nodes: int = 5_000_000


def grid(start: float, stop: float, step: float) -> np.ndarray:
    """Output grid from ``start`` towards ``stop`` by ``|step|`` (``stop`` included when on the grid).

    Examples
    --------
    >>> grid(0, 10, 4).tolist(), grid(10, 0, 4).tolist()
    ([0.0, 4.0, 8.0], [10.0, 6.0, 2.0])
    """
    if step == 0 or not math.isfinite(step):
        raise ModelError("--step must be a nonzero number")
    step = math.copysign(abs(step), stop - start) if stop != start else abs(step)
    n = int(math.floor((stop - start) / step + 1e-9))
    return start + step * np.arange(max(n, 0) + 1)


# ============================================================================= scalar kernel


class _Kernel:
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
            if k == 1:
                d = J[eqs[0] * n + cols[0]]
                out.append(d)
                had.append(1.0 if d != 0 else 0.0)
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


# ============================================================================= path


@dataclass(slots=True)
class _Node:
    z: list
    t: list  # unit tangent in scaled (u, x), oriented along the path
    sig: str
    kind: str = "regular"  # regular | fold | singular | end
    grid: int | None = None
    residual: float = 0.0
    n_iter: int = 0
    J: list | None = None


@dataclass(slots=True)
class _Path:
    nodes: list
    seg_sig: list  # signature of segment i (between nodes i and i+1)
    events: list = field(default_factory=list)


class _Grid:
    """Output grid values ``start + k·step`` for k in [kmin, kmax], and the input bounds.

    ``deg`` = (start, step) in degrees for a degree-unit angle input: the internal value of
    grid point k is then the radian value whose display is exactly ``start + k·step`` degrees.
    """

    def __init__(self, start, step, kmin, kmax, lo, hi, deg=None):
        self.start, self.step, self.kmin, self.kmax, self.lo, self.hi = start, step, kmin, kmax, lo, hi
        self.deg = deg

    def value(self, k: int) -> float:
        if self.deg is None:
            return self.start + self.step * k
        v = self.deg[0] + self.deg[1] * k
        x = math.radians(v)
        for _ in range(4):
            d = math.degrees(x)  # the same product x * (180/pi) as np.degrees
            if d == v:
                break
            x = math.nextafter(x, math.inf if d < v else -math.inf)
        return x

    def values(self, ks: np.ndarray) -> np.ndarray:
        """Vectorized :meth:`value`."""
        ks = np.asarray(ks)
        if self.deg is None:
            return self.start + self.step * ks
        v = self.deg[0] + self.deg[1] * ks
        x = np.radians(v)
        for _ in range(4):
            d = np.degrees(x)
            off = d != v
            if not off.any():
                break
            x[off] = np.nextafter(x[off], np.where(d[off] < v[off], np.inf, -np.inf))
        return x

    def crossed(self, xa: float, xb: float) -> range:
        """Grid indices strictly after ``xa`` up to ``xb`` inclusive, in the order from xa to xb."""
        if xb == xa:
            return range(0)
        fa = (xa - self.start) / self.step
        fb = (xb - self.start) / self.step
        if fb > fa:
            k0, k1 = math.floor(fa + 1e-9) + 1, math.floor(fb + 1e-9)
            return range(max(k0, self.kmin), min(k1, self.kmax) + 1)
        k0, k1 = math.ceil(fa - 1e-9) - 1, math.ceil(fb - 1e-9)
        return range(min(k0, self.kmax), max(k1, self.kmin) - 1, -1)

    def next_after(self, x: float, d: float) -> int | None:
        """First grid index beyond ``x`` in input direction ``d`` (None past the ends)."""
        f = (x - self.start) / self.step
        if d * self.step > 0:
            k = math.floor(f + 1e-9) + 1
        else:
            k = math.ceil(f - 1e-9) - 1
        return k if self.kmin <= k <= self.kmax else None


def _hermite(ya, ta, yb, tb, s):
    L = math.sqrt(sum((b - a) ** 2 for a, b in zip(ya, yb)))
    s2, s3 = s * s, s * s * s
    h00, h10, h01, h11 = 2 * s3 - 3 * s2 + 1, s3 - 2 * s2 + s, -2 * s3 + 3 * s2, s3 - s2
    return [h00 * a + h10 * L * p + h01 * b + h11 * L * q for a, p, b, q in zip(ya, ta, yb, tb)]


class _Tracer:
    def __init__(self, kern: _Kernel, gridspec: _Grid, control: StepControl, *, land: bool,
                 through_limits: bool, x_start: float, bar=None):
        self.k = kern
        self.g = gridspec
        self.c = control
        self.land = land
        self.through = through_limits
        self.x_start = x_start
        self.bar = bar
        self.cos_turn = math.cos(control.max_turn)
        self.cos_grow = math.cos(control.max_turn / 3)

    # ------------------------------------------------------------------ helpers
    def _display(self, x):

        return display_value(self.k.ck, x, self.k.ck.inputs[0])

    def _unit(self):

        return _input_unit(self.k.ck)

    def _label(self, sig):
        names = [a for a, s in self.k.ck.mechanism.mode_aliases.items() if s == sig]
        return f"{sig} ({', '.join(names)})" if names else sig

    def _finish_node(self, z, it, res, t_prev, natural_d=None, row=None):
        """Jacobian, dets, signature and tangent at a converged ``z``; None if singular."""
        k = self.k
        J = k.jac_f(z, k.p)
        dets, had = k.dets(J)
        if min(had, default=1.0) < _NEAR_SINGULAR:
            return None, dets, had  # too close to a singular position to take its mode or tangent
        if natural_d is not None:
            du = k.dudx(z, J)
            if du is None:
                return None, dets, had
            t = k.natural_tangent(du, natural_d)
        else:
            t = k.aug_tangent(z, J, row if row is not None else t_prev)
            if t is None:
                return None, dets, had
        if t_prev is not None and sum(a * b for a, b in zip(t, t_prev)) < 0:
            t = [-v for v in t]
        return _Node(z, t, k.sig(dets), residual=res, n_iter=it, J=J), dets, had

    # ------------------------------------------------------------------ steps
    def _natural_target(self, xa: float, d: float, dx: float, land: bool):
        """Input value of the next natural step: the grid point when within reach, the range end."""
        target = xa + d * dx
        gidx = None
        g = self.g
        if self.land and land:
            kn = g.next_after(xa, d)
            if kn is not None:
                gx = g.value(kn)
                if d * (gx - target) <= 1e-12 * (1 + abs(gx)):
                    target, gidx = gx, kn
        bound = g.hi if d > 0 else g.lo
        at_bound = False
        if d * (target - bound) >= 0:
            target, at_bound = bound, True
            kb = round((bound - g.start) / g.step)
            gidx = kb if abs(g.value(kb) - bound) <= 1e-12 * (1 + abs(bound)) else None
            if gidx is not None:
                target = g.value(gidx)
        return target, gidx, at_bound

    def _natural_step(self, a: _Node, a_prev: _Node | None, h: float, land: bool = True):
        k = self.k
        if k.single2:
            return self._natural_step_2x2(a, a_prev, h, land)
        n = k.n
        d = 1.0 if a.t[n] > 0 else -1.0
        xa = a.z[k.ix]
        target, gidx, at_bound = self._natural_target(xa, d, h * abs(a.t[n]) / k.wx, land)
        delta = target - xa
        if delta == 0:
            return None, at_bound
        # predictor: tangent + second-order term from the previous natural node
        du = [(a.t[i] / k.wu[i]) / (a.t[n] / k.wx) for i in range(n)]
        z = list(a.z)
        z[k.ix] = target
        curv = None
        if a_prev is not None and a_prev.sig == a.sig and abs(a_prev.t[n]) > 0.1:
            xp = a_prev.z[k.ix]
            if (xa - xp) * d > 0:
                dup = [(a_prev.t[i] / k.wu[i]) / (a_prev.t[n] / k.wx) for i in range(n)]
                curv = [(u1 - u0) / (xa - xp) for u0, u1 in zip(dup, du)]
        for i, idx in enumerate(k.iu):
            z[idx] = a.z[idx] + delta * du[i] + (0.5 * delta * delta * curv[i] if curv else 0.0)
        pred = k.yhat(z)
        z, it, ok, _ = k.newton(z, self.c.max_iter)
        if not ok:
            return None, at_bound
        res = k.residual(z)
        if not res <= k.tol:
            return None, at_bound
        node, _, _ = self._finish_node(z, it, res, a.t, natural_d=d)
        if node is None:
            return None, at_bound
        node.grid = gidx
        y = k.yhat(z)
        step_len = math.sqrt(sum((p - q) ** 2 for p, q in zip(k.yhat(a.z), y)))
        corr = max(abs(p - q) for p, q in zip(pred, y))
        if corr > 0.25 * step_len + 1e-12:
            return None, at_bound
        return node, at_bound

    def _natural_step_2x2(self, a: _Node, a_prev: _Node | None, h: float, land: bool = True):
        """:meth:`_natural_step` written out for one 2×2 block (four-bars and the like): same
        predictor, corrector, checks and node, on plain floats."""
        k = self.k
        i0, i1 = k.iu
        ix = k.ix
        w0, w1 = k.wu
        wx = k.wx
        t0, t1, tx = a.t
        d = 1.0 if tx > 0 else -1.0
        az = a.z
        xa = az[ix]
        target, gidx, at_bound = self._natural_target(xa, d, h * abs(tx) / wx, land)
        delta = target - xa
        if delta == 0:
            return None, at_bound
        r = wx / tx
        du0, du1 = t0 / w0 * r, t1 / w1 * r
        p0 = az[i0] + delta * du0
        p1 = az[i1] + delta * du1
        if a_prev is not None and a_prev.sig == a.sig and abs(a_prev.t[2]) > 0.1:
            xp = a_prev.z[ix]
            if (xa - xp) * d > 0:
                q0, q1, qx = a_prev.t
                rq = wx / qx
                c = 0.5 * delta * delta / (xa - xp)
                p0 += c * (du0 - q0 / w0 * rq)
                p1 += c * (du1 - q1 / w1 * rq)
        z = list(az)
        z[ix] = target
        z[i0] = p0
        z[i1] = p1
        phi, jac, p = k.phi_f, k.jac_f, k.p
        tiny = _ROUNDOFF * (1.0 + abs(p0) * w0 + abs(p1) * w1)
        prev = 0.0
        f0, f1 = phi(z, p)
        for it in range(1, self.c.max_iter + 1):
            J = jac(z, p)
            A, B, C, D = J
            det = A * D - B * C
            if det == 0:
                return None, at_bound
            s0 = (B * f1 - D * f0) / det
            s1 = (C * f0 - A * f1) / det
            z[i0] += s0
            z[i1] += s1
            st = max(abs(s0) * w0, abs(s1) * w1)
            f0, f1 = phi(z, p)
            if st <= tiny or (prev and st * (st / prev) ** 2 <= tiny):
                break
            if not st < math.inf:
                return None, at_bound
            prev = st
        else:
            return None, at_bound
        res = max(abs(f0), abs(f1))
        if not res <= k.tol:
            return None, at_bound
        # Φ_q from the last iteration: z moved by a round-off-sized correction since (the tangent
        # and the mode need no better; the rates are computed afresh at every row)
        cs0, cs1 = 1.0 / w0, 1.0 / w1
        nr = 0.5 * ((A * A + C * C) * cs0 * cs0 + (B * B + D * D) * cs1 * cs1)
        if not abs(det) * cs0 * cs1 >= _NEAR_SINGULAR * nr:
            return None, at_bound
        b0, b1 = k.rhs1_f(z, k.ex, p)
        n0 = (D * b0 - B * b1) / det * w0 * d
        n1 = (A * b1 - C * b0) / det * w1 * d
        nx = wx * d
        nrm = math.sqrt(n0 * n0 + n1 * n1 + nx * nx)
        t = [n0 / nrm, n1 / nrm, nx / nrm]
        u0, u1 = z[i0], z[i1]
        corr = max(abs(u0 - p0) * w0, abs(u1 - p1) * w1)
        step_len = math.sqrt(((u0 - az[i0]) * w0) ** 2 + ((u1 - az[i1]) * w1) ** 2 + (delta * wx) ** 2)
        if corr > 0.25 * step_len + 1e-12:
            return None, at_bound
        node = _Node(z, t, "+" if det > 0 else "-", residual=res, n_iter=it, J=J)
        node.grid = gidx
        return node, at_bound

    def _arc_step(self, a: _Node, h: float):
        k = self.k
        ya = k.yhat(a.z)
        pred = [y + h * t for y, t in zip(ya, a.t)]
        z = list(a.z)
        k.set_yhat(z, pred)
        target = sum(t * p for t, p in zip(a.t, pred))
        z, it, ok, _ = k.aug_newton(z, a.t, target, self.c.max_iter)
        if not ok:
            return None
        res = k.residual(z)
        if not res <= k.tol:
            return None
        node, _, _ = self._finish_node(z, it, res, a.t)
        if node is None:
            return None
        y = k.yhat(z)
        corr = math.sqrt(sum((p - q) ** 2 for p, q in zip(pred, y)))
        if corr > 0.25 * h + 1e-12:
            return None
        return node

    # ------------------------------------------------------------------ points on a segment
    def _point_on_chord(self, a: _Node, b: _Node, s: float, guess=None):
        """Solution on the hyperplane normal to the chord a→b at fraction ``s``; None on failure."""
        k = self.k
        ya, yb = k.yhat(a.z), k.yhat(b.z)
        L = math.sqrt(sum((q - p) ** 2 for p, q in zip(ya, yb)))
        if L == 0:
            return None
        c = [(q - p) / L for p, q in zip(ya, yb)]
        y0 = guess if guess is not None else _hermite(ya, a.t, yb, b.t, s)
        z = list(a.z)
        k.set_yhat(z, y0)
        target = sum(ci * p for ci, p in zip(c, ya)) + s * L
        z, it, ok, _ = k.aug_newton(z, c, target, 12)
        if not ok:
            return None
        if not k.residual(z) <= k.tol * 10:
            return None
        return z

    def _locate(self, a: _Node, b: _Node):
        """Zero of the first block determinant that changes sign between ``a`` and ``b``."""
        k = self.k
        da, _ = k.dets(a.J)
        db, _ = k.dets(b.J)
        j = next((i for i, (p, q) in enumerate(zip(da, db)) if (p > 0) != (q > 0) or p == 0 or q == 0), None)
        if j is None:
            return None
        ya, yb = k.yhat(a.z), k.yhat(b.z)
        L = math.sqrt(sum((q - p) ** 2 for p, q in zip(ya, yb)))
        lo, hi = (0.0, da[j], a.z), (1.0, db[j], b.z)
        side = 0
        z_best = None
        for _ in range(200):
            if (hi[0] - lo[0]) * L <= 1e-11 or lo[1] == 0 or hi[1] == 0:
                break
            s = (lo[0] * hi[1] - hi[0] * lo[1]) / (hi[1] - lo[1])  # regula falsi
            if not lo[0] < s < hi[0]:
                s = 0.5 * (lo[0] + hi[0])
            yl, yh = k.yhat(lo[2]), k.yhat(hi[2])
            fr = (s - lo[0]) / (hi[0] - lo[0])
            guess = None if (lo[0] == 0.0 and hi[0] == 1.0) else [p + fr * (q - p) for p, q in zip(yl, yh)]
            z = self._point_on_chord(a, b, s, guess)
            if z is None:
                s = 0.5 * (lo[0] + hi[0])
                guess = [p + 0.5 * (q - p) for p, q in zip(yl, yh)]
                z = self._point_on_chord(a, b, s, guess)
                if z is None:
                    break
            dj = k.dets(k.jac_f(z, k.p))[0][j]
            z_best = z
            if (dj > 0) == (lo[1] > 0) and dj != 0:
                lo = (s, dj, z)
                if side == -1:  # Illinois: halve the stale end's value
                    hi = (hi[0], hi[1] * 0.5, hi[2])
                side = -1
            else:
                hi = (s, dj, z)
                if side == 1:
                    lo = (lo[0], lo[1] * 0.5, lo[2])
                side = 1
        zs = lo[2] if abs(lo[1]) < abs(hi[1]) else hi[2]
        if zs is a.z or zs is b.z:
            zs = z_best
        if zs is None:
            return None
        J = k.jac_f(zs, k.p)
        dets, had = k.dets(J)
        if had[j] > 1e-5:  # the determinant jumped instead of passing through zero
            return None
        c = [(q - p) / L for p, q in zip(ya, yb)]
        t = k.aug_tangent(zs, J, c)
        if t is None:
            t = c
        return _Node(list(zs), t, k.sig(dets), residual=k.residual(zs), J=J)

    def solve_at(self, a: _Node, b: _Node, x: float, sig: str, depth: int = 0):
        """The solution at input ``x`` on the segment a→b (monotone in x), in mode ``sig``."""
        k = self.k
        ya, yb = k.yhat(a.z), k.yhat(b.z)
        xh = k.wx * x
        # parameter of the Hermite cubic where x is reached (bisection on a monotone cubic)
        lo, hi = 0.0, 1.0
        inc = yb[-1] > ya[-1]
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            xm = _hermite(ya, a.t, yb, b.t, mid)[-1]
            if (xm < xh) == inc:
                lo = mid
            else:
                hi = mid
        s = 0.5 * (lo + hi)
        y0 = _hermite(ya, a.t, yb, b.t, s)
        z = list(a.z)
        k.set_yhat(z, y0)
        z[k.ix] = x
        L = math.sqrt(sum((q - p) ** 2 for p, q in zip(ya, yb)))
        z, it, ok, _ = k.newton(z, 10)
        if ok:
            res = k.residual(z)
            J = k.jac_f(z, k.p)
            dets, had = k.dets(J)
            moved = max(abs(p - q) for p, q in zip(k.yhat(z), y0))
            if res <= k.tol and k.sig(dets) == sig and moved <= 0.2 * L + 1e-9:
                return z, res, it
        if depth >= 12 or L < 1e-12:
            return None
        zm = self._point_on_chord(a, b, 0.5)
        if zm is None:
            return None
        J = k.jac_f(zm, k.p)
        c = [(q - p) / L for p, q in zip(ya, yb)]
        t = k.aug_tangent(zm, J, c)
        if t is None:
            return None
        m = _Node(zm, t, sig, J=J)
        xm = zm[k.ix]
        first = (a, m) if (x - a.z[k.ix]) * (xm - x) >= 0 else (m, b)
        return self.solve_at(first[0], first[1], x, sig, depth + 1)

    # ------------------------------------------------------------------ main loop
    def trace(self, first: _Node) -> _Path:
        k, c = self.k, self.c
        n = k.n
        nodes = [first]
        seg_sig: list[str] = []
        events: list[Event] = []
        path = _Path(nodes, seg_sig, events)
        natural = abs(first.t[n]) >= c.natural_min
        h = c.max_step
        prev_natural: _Node | None = None
        folds = 0
        start_sig = first.sig
        name = k.ck.inputs[0]
        while True:
            a = nodes[-1]
            if len(nodes) > c.max_nodes:
                events.append(Event(EventKind.SINGULAR, self._display(a.z[k.ix]),
                                    f"stopped after {c.max_nodes} internal steps at {name} = "
                                    f"{self._display(a.z[k.ix]):.10g}{self._unit()} (StepControl.max_nodes)"))
                break
            at_bound = False
            if natural:
                b, at_bound = self._natural_step(a, prev_natural, h)
                if b is None and at_bound and a.z[k.ix] == (self.g.hi if a.t[n] > 0 else self.g.lo):
                    break  # already at the end of the range
                if b is None and self.land and not at_bound:
                    # landing on the grid point failed (it may be a singular position): step past it
                    b, at_bound = self._natural_step(a, prev_natural, h, land=False)
            else:
                b = self._arc_step(a, h)
            dot = sum(p * q for p, q in zip(a.t, b.t)) if b is not None else 0.0
            if b is not None and dot < self.cos_turn:
                b = None
            if b is None:
                h *= 0.5
                if h < c.min_step:
                    x = self._display(a.z[k.ix])
                    events.append(Event(EventKind.SINGULAR, x,
                                        f"branch tracking cannot continue beyond {name} = {x:.10g}{self._unit()} "
                                        f"on mode {self._label(a.sig)} (no converged step down to the minimum "
                                        "step); the rows stop here"))
                    break
                continue
            end = at_bound
            # the input leaves the range inside an arclength step: stop on the bound
            xa, xb = a.z[k.ix], b.z[k.ix]
            if not natural:
                for bound in (self.g.lo, self.g.hi):
                    if (xa - bound) * (xb - bound) < 0 or (xb == bound and xa != bound):
                        sol = self.solve_at(a, b, bound, b.sig if b.sig == a.sig else a.sig)
                        if sol is not None:
                            zb, res, it = sol
                            nb, _, _ = self._finish_node(zb, it, res, a.t)
                            if nb is not None:
                                kb = round((bound - self.g.start) / self.g.step)
                                nb.grid = kb if abs(self.g.value(kb) - bound) <= 1e-12 * (1 + abs(bound)) else None
                                b = nb
                                end = True
                        break
            if b.sig != a.sig:
                s = self._locate(a, b)
                if s is None:
                    h *= 0.5
                    if h < c.min_step:
                        x = self._display(a.z[k.ix])
                        events.append(Event(EventKind.SINGULAR, x, f"singular position near {name} = {x:.10g}"
                                            f"{self._unit()}: the mode signature changes but no crossing of a "
                                            "singular configuration could be located; the rows stop here"))
                        break
                    continue
                reversed_ = (a.t[n] > 0) != (b.t[n] > 0)
                fold = reversed_ and self._is_fold(s)
                if reversed_ and not fold:
                    # the corrector jumped onto the other branch of a change point: take a smaller step
                    h *= 0.5
                    continue
                xs = s.z[k.ix]
                disp = self._display(xs)
                if fold:
                    s.kind = "fold"
                    nodes.append(s)
                    seg_sig.append(a.sig)
                    msg = (f"limit position at {name} = {disp:.12g}{self._unit()}: the input cannot go further "
                           f"on mode {self._label(a.sig)} (toggle/fold)")
                    if not self.through:
                        events.append(Event(EventKind.LIMIT, disp, msg + "; the rows stop here (use "
                                            "--through-limits to continue around it)"))
                        break
                    events.append(Event(EventKind.LIMIT, disp, msg))
                    events.append(Event(EventKind.MODE_CHANGE, disp,
                                        f"continuing around the limit position at {name} = {disp:.12g}"
                                        f"{self._unit()} onto mode {self._label(b.sig)}; the input turns back"))
                    folds += 1
                else:
                    s.kind = "singular"
                    nodes.append(s)
                    seg_sig.append(a.sig)
                    events.append(Event(EventKind.SINGULAR, disp,
                                        f"singular position (change point: the branches touch) at {name} = "
                                        f"{disp:.12g}{self._unit()}: Φ_q is singular there; continuing on the smooth "
                                        f"branch, whose signature changes from {self._label(a.sig)} to "
                                        f"{self._label(b.sig)}"))
                a = s
            # the circuit closes when the path comes back to the start in the start mode
            if self.through and folds and b.sig == start_sig and not end:
                xa2, xb2 = a.z[k.ix], b.z[k.ix]
                x0 = self.x_start
                if (x0 - xa2) * (xb2 - x0) >= 0 and xa2 != x0:
                    sol = self.solve_at(a, b, x0, b.sig) if xb2 != x0 else (b.z, b.residual, b.n_iter)
                    if sol is not None and self._same_as_start(sol[0], first.z):
                        nb, _, _ = self._finish_node(list(sol[0]), sol[2], sol[1], a.t, row=a.t)
                        if nb is not None:
                            nb.grid = 0
                            b = nb
                            end = True
            nodes.append(b)
            seg_sig.append(b.sig)
            if self.bar is not None:
                self.bar.update(len(self.g.crossed(a.z[k.ix], b.z[k.ix])))
            if end:
                break
            prev_natural = a if natural else None
            if natural and abs(b.t[n]) < c.natural_min:
                natural = False
                prev_natural = None
            elif not natural and abs(b.t[n]) > c.natural_back:
                natural = True
            if b.n_iter <= 3 and dot > self.cos_grow and h < c.max_step:
                h = min(h * 1.6, c.max_step)
        return path

    def _is_fold(self, s: _Node) -> bool:
        """A fold (limit) rather than a branch point: ∂Φ/∂x is not in the range of the singular Φ_q.

        With ψ the left null vector of Φ_q, ψ·Φ_x ≠ 0 at a fold (the input cannot move) and
        = 0 where branches cross (Allgower and Georg, sec. 8.1).
        """
        k = self.k
        n = k.n
        J = np.asarray(s.J, dtype=float).reshape(n, n)
        fx = np.asarray(k.jx(s.z), dtype=float)
        nf = float(np.linalg.norm(fx))
        if nf == 0:
            return False
        U, sv, _ = np.linalg.svd(J)
        psi = U[:, -1]
        return abs(float(psi @ fx)) > 1e-4 * nf

    def _same_as_start(self, z, z0) -> bool:
        k = self.k
        for i, idx in enumerate(k.iu):
            d = z[idx] - z0[idx]
            if k.angle_u[i]:
                d = (d + math.pi) % (2 * math.pi) - math.pi
            if abs(d) * k.wu[i] > 1e-6:
                return False
        return True


# ============================================================================= rows


class _Rows:
    """The output rows in path order: grid index ``ks``; ``node`` (index of the path node that is
    the row, or -1) and ``seg`` (index of the segment to solve it on, or -1); ``x`` the input values."""

    __slots__ = ("ks", "seg", "node", "x")

    def __init__(self, ks, seg, node, x):
        self.ks, self.seg, self.node, self.x = ks, seg, node, x

    def __len__(self) -> int:
        return len(self.ks)


def _enumerate_rows(kern: _Kernel, path: _Path, g: _Grid) -> _Rows:
    """Every output grid value crossed by the path, in the order traversed.

    Grid values within the input tolerance of a fold (or within 1e3 times it of a change
    point) are left out: the rates are undefined there and the event reports the position.
    """
    ix = kern.ix
    nodes = path.nodes
    chunks = []
    sk, ss, sn = [], [], []

    def flush():
        if sk:
            kk = np.array(sk, dtype=np.int64)
            chunks.append((kk, np.array(ss, dtype=np.int64), np.array(sn, dtype=np.int64), g.values(kk)))
            sk.clear(), ss.clear(), sn.clear()

    first = nodes[0]
    if first.grid is not None:
        sk.append(first.grid), ss.append(-1), sn.append(0)
    for i in range(len(nodes) - 1):
        a, b = nodes[i], nodes[i + 1]
        xa, xb = a.z[ix], b.z[ix]
        rng = g.crossed(xa, xb)
        if not rng:
            continue
        if len(rng) == 1 and b.grid == rng[0] and b.kind == "regular" and a.kind == "regular":
            sk.append(b.grid), ss.append(-1), sn.append(i + 1)  # a node landed on the grid: the usual case
            continue
        sing = [(nd.z[ix], kern.x_tol if nd.kind == "fold" else 1e3 * kern.x_tol)
                for nd in (a, b) if nd.kind in ("fold", "singular")]
        land_ok = b.kind in ("regular", "end")
        if len(rng) <= 32:
            for kk in rng:
                x = g.value(kk)
                if any(abs(x - xs) <= tol for xs, tol in sing):
                    continue
                if land_ok and (b.grid == kk or abs(x - xb) <= 1e-12 * (1 + abs(x))):
                    sk.append(kk), ss.append(-1), sn.append(i + 1)
                else:
                    sk.append(kk), ss.append(i), sn.append(-1)
            continue
        flush()
        kk = np.arange(rng.start, rng.stop, rng.step, dtype=np.int64)
        x = g.values(kk)
        keep = np.ones(len(kk), dtype=bool)
        for xs, tol in sing:
            keep &= np.abs(x - xs) > tol
        seg = np.full(len(kk), i, dtype=np.int64)
        node = np.full(len(kk), -1, dtype=np.int64)
        if land_ok:
            landed = (kk == (b.grid if b.grid is not None else -(2**62))) | (np.abs(x - xb) <= 1e-12 * (1 + np.abs(x)))
            seg[landed] = -1
            node[landed] = i + 1
        if keep.all():
            chunks.append((kk, seg, node, x))
        else:
            chunks.append((kk[keep], seg[keep], node[keep], x[keep]))
    flush()
    if not chunks:
        e = np.zeros(0, dtype=np.int64)
        return _Rows(e, e.copy(), e.copy(), np.zeros(0))
    if len(chunks) == 1:
        return _Rows(*chunks[0])
    return _Rows(*(np.concatenate(c) for c in zip(*chunks)))


class _RowSolution:
    """Positions of the rows (``Z`` (nvar, N)) with their mode codes, residuals, iterations, and
    which rows could be solved (``ok``); ``sigs`` lists the signature of each code."""

    def __init__(self, n, nv):
        self.Z = np.empty((nv, n))
        self.code = np.zeros(n, dtype=np.int64)
        self.res = np.zeros(n)
        self.its = np.zeros(n, dtype=np.int64)
        self.ok = np.ones(n, dtype=bool)
        self.sigs: list[str] = []
        self._codes: dict[str, int] = {}
        self.events: list[Event] = []
        self.J = None  # raw Jacobians (n*n, N) where known (batched path)
        self.J_ok = None

    def code_of(self, sig: str) -> int:
        c = self._codes.get(sig)
        if c is None:
            c = self._codes[sig] = len(self.sigs)
            self.sigs.append(sig)
        return c


def _fill_node_rows(path: _Path, rows: _Rows, sol: _RowSolution) -> np.ndarray:
    """Rows that are path nodes: copy them. Returns the mask of the other rows."""
    is_node = rows.node >= 0
    if is_node.any():
        nodes = path.nodes
        mark = np.zeros(len(nodes), dtype=bool)
        mark[rows.node[is_node]] = True
        used = np.flatnonzero(mark)
        pos = np.full(len(nodes), -1, dtype=np.int64)
        pos[used] = np.arange(len(used))
        NZ = np.array([nodes[i].z for i in used], dtype=float)
        ref = pos[rows.node[is_node]]
        sol.Z[:, is_node] = NZ[ref].T
        sol.res[is_node] = np.array([nodes[i].residual for i in used])[ref]
        sol.its[is_node] = np.array([nodes[i].n_iter for i in used], dtype=np.int64)[ref]
        sol.code[is_node] = np.array([sol.code_of(nodes[i].sig) for i in used], dtype=np.int64)[ref]
    return ~is_node


def _solve_rows_scalar(tracer: _Tracer, path: _Path, rows: _Rows, g: _Grid, sol: _RowSolution, which) -> None:
    """Solve the given rows one by one with the tracker's corrector on their segment."""
    kern = tracer.k
    for r in which:
        seg = int(rows.seg[r])
        kk = int(rows.ks[r])
        a, b = path.nodes[seg], path.nodes[seg + 1]
        s = path.seg_sig[seg]
        res = tracer.solve_at(a, b, g.value(kk), s)
        sol.code[r] = sol.code_of(s)
        if res is None:
            x = tracer._display(g.value(kk))
            sol.events.append(Event(EventKind.SINGULAR, x, f"no converged solution at {kern.ck.inputs[0]} = "
                                    f"{x:.10g} on mode {s}; row left out"))
            sol.ok[r] = False
            continue
        z, rr, it = res
        sol.Z[:, r] = z
        sol.res[r] = rr
        sol.its[r] = it


def _solve_rows_tracked(tracer: _Tracer, path: _Path, rows: _Rows, g: _Grid) -> _RowSolution:
    """Positions of every row: nodes as they are, other crossings by a corrector from the segment."""
    sol = _RowSolution(len(rows), tracer.k.nv)
    other = _fill_node_rows(path, rows, sol)
    _solve_rows_scalar(tracer, path, rows, g, sol, np.flatnonzero(other))
    return sol


def _progress(total: int, enabled: bool | None):
    """A tqdm bar on stderr for long sweeps (shown after 0.5 s, only on a terminal)."""
    if enabled is None:
        enabled = sys.stderr.isatty()
    if not enabled or total < 2:
        return None
    try:
        from tqdm import tqdm
    except ImportError:
        return None
    return tqdm(total=total, unit="pt", file=sys.stderr, leave=False, delay=0.5)


# ============================================================================= start


def assembly_failure(ck, x: float, exc: SolveError) -> SolveError:
    """Turn a stalled Newton at input ``x`` into the error to raise.

    No real assembly mode at ``x``: :class:`AssemblyError` naming the nearest assemblable
    input values. Otherwise the guesses were poor: :class:`ConvergenceError` listing the modes.

    Examples
    --------
    >>> ck = ls.fourbar(4, 3, 3.5, 5).compile()
    >>> err = assembly_failure(ck, 0.0, ls.AssemblyError("stalled"))
    >>> type(err).__name__, [round(v, 6) for v in err.nearest]
    ('AssemblyError', [-18.57335, 18.57335])
    """
    from .modes import _mode_names, _modes_at, _nearest_text

    name = ck.inputs[0]
    disp = display_value(ck, x, name)
    where = ck.mechanism.source or ck.mechanism.name
    modes = _modes_at(ck, x)
    if modes:
        return ConvergenceError(
            f"{where}: Newton from the guesses stalled at {name} = {disp:g}, but the mechanism assembles there "
            f"in mode(s) {_mode_names(ck.mechanism, modes)}: pass --mode (mode=) or improve the guesses",
            input_value=disp, result=getattr(exc, "result", None))
    near = nearest_assemblable(ck, x)
    return AssemblyError(
        f"{where}: cannot be assembled at {name} = {disp:g}: the loop equations have no real solution there"
        + _nearest_text(ck, near),
        input_value=disp, residual=getattr(exc, "residual", None), nearest=near, result=getattr(exc, "result", None))


def _first_node(kern: _Kernel, z, d: float) -> _Node:

    z = [float(v) for v in z]
    J = kern.jac_f(z, kern.p)
    dets, had = kern.dets(J)
    du = kern.dudx(z, J)
    if du is None or min(had, default=1.0) < _START_REGULAR:
        name = kern.ck.inputs[0]
        disp = display_value(kern.ck, z[kern.ix], name)
        raise SingularPositionError(
            f"{kern.ck.mechanism.source or kern.ck.mechanism.name}: the sweep starts at a singular position "
            f"({name} = {disp:g}: limit, dead centre or change point, where the mode is ambiguous, or within "
            "about 1e-5 of one); start the sweep slightly away from it", input_value=disp, result=np.array(z))
    t = kern.natural_tangent(du, d)
    return _Node(z, t, kern.sig(dets), grid=0, residual=kern.residual(z), J=J)


# ============================================================================= public API


def _parse_range(ck, start, stop, step):

    name = ck.inputs[0]
    kind = ck.kinds[ck.index(name)]
    x0, x1 = (input_value(ck, v, name) for v in (start, stop))
    if isinstance(step, str):
        h = input_value(ck, step, name)
    elif kind is Kind.ANGLE:
        h = math.radians(float(step)) if ck.mechanism.units.angle == "deg" else float(step)
    else:
        h = float(step)
    if h == 0 or not math.isfinite(h):
        raise ModelError("--step must be a nonzero number")
    deg = None
    if kind is Kind.ANGLE and ck.mechanism.units.angle == "deg":
        d0 = float(start) if not isinstance(start, str) else math.degrees(x0)
        dh = float(step) if not isinstance(step, str) else math.degrees(h)
        deg = (d0, math.copysign(abs(dh), x1 - x0) if x1 != x0 else abs(dh))
    return x0, x1, h, kind, deg


def _make_grid(x0, x1, h, kind, through_limits, deg=None) -> _Grid:
    h = math.copysign(abs(h), x1 - x0) if x1 != x0 else abs(h)
    n = max(int(math.floor((x1 - x0) / h + 1e-9)), 0)
    g = _Grid(x0, h, 0, n, x0, x0, deg)
    xs, xn = g.value(0), g.value(n)
    lo, hi = min(xs, xn), max(xs, xn)
    kmin, kmax = 0, n
    if through_limits and kind is Kind.ANGLE and abs(x1 - x0) >= 2 * math.pi - 1e-9:
        # a full turn of the input: every angle is in range; the path may go back past the start
        m = int(math.floor(2 * math.pi / abs(h) + 1e-9))
        kmin = -m
        if h > 0:
            lo = x0 - 2 * math.pi
        else:
            hi = x0 + 2 * math.pi
    return _Grid(x0, h, kmin, kmax, lo, hi, deg)


def sweep(mech, start, stop, step, *, speed=None, accel=None, jerk=None, input: str | None = None,
          mode: str | None = None, guess: dict | None = None, compiled=None,
          through_limits: bool = False, progress: bool | None = None, method: str = "auto",
          derivatives: int = 3, control: StepControl = StepControl(), settings: Newton = Newton()) -> Sweep:
    """Sweep the input from ``start`` to ``stop`` by ``step`` (display units), tracking the mode.

    Parameters
    ----------
    mech : Mechanism
    start, stop, step : float or str
        Output grid of the input, in the model's units or with a unit (``"1.5rad"``).
    speed, accel, jerk : float or str, optional
        Rates of the input (default: the model's, else 1, 0, 0).
    input : str, optional
        Drive another variable.
    mode : str, optional
        Assembly mode (signature or alias) to start in, whatever the guesses say.
    guess : dict, optional
        Override guesses (internal units).
    through_limits : bool
        At a limit position continue around the fold onto the other mode (the input turns back
        over the same output grid) until the circuit closes or the input leaves the range. With
        a full turn of an angle input (``|stop - start| >= 360°``) every angle is in range.
    progress : bool, optional
        Progress bar (tqdm) on stderr; default: on a terminal, shown after half a second.
    method : {"auto", "tracked", "batched"}
        ``"tracked"`` solves every output point by continuation; ``"batched"`` traces the curve
        at the internal step and solves all output points at once with vectorized Newton
        (see :mod:`loopsolve.batch`); ``"auto"`` is batched from ``AUTO_BATCH`` points on.
    derivatives : {1, 2, 3}
        Highest time derivative computed: velocities, accelerations, jerks (default). The
        unknowns' higher rates are NaN (empty in CSV, null in JSON); for speed when they are
        not needed.
    control : StepControl
        Internal step control.

    Returns
    -------
    Sweep
        Rows in the order traversed, the events (``limit``, ``singular``, ``mode-change``) and
        the starting mode. A sweep that reaches a limit without ``through_limits`` stops there
        with a ``limit`` event and the rows computed so far.

    Raises
    ------
    AssemblyError
        The mechanism cannot be assembled at ``start`` (names the nearest assemblable inputs).
    SingularPositionError
        ``start`` is a singular position.

    Examples
    --------
    >>> mech = ls.load(ls.models_dir() / "thesis_crank_rocker.toml")
    >>> sw = mech.sweep(0, 360, 30)
    >>> len(sw), sw.mode, round(float(sw["theta4"][3]), 2)
    (13, '-', 80.72)
    >>> lim = ls.fourbar(4, 3, 3.5, 5).sweep(300, 360, 10)
    >>> [e.kind.value for e in lim.events], round(lim.events[0].input, 8), len(lim)
    (['limit'], 341.42665028, 5)
    """
    from . import batch

    if method not in ("auto", "tracked", "batched"):
        raise ModelError(f"method {method!r}: expected 'auto', 'tracked' or 'batched'")
    if derivatives not in (1, 2, 3):
        raise ModelError(f"derivatives={derivatives!r}: expected 1 (velocities), 2 (accelerations) or 3 (jerks)")
    ck = compiled if compiled is not None else mech.compile(input)
    x0, x1, h, kind, deg = _parse_range(ck, start, stop, step)
    g = _make_grid(x0, x1, h, kind, through_limits, deg)
    rates = input_rates(ck, speed, accel, jerk)
    z0, _, _ = start_position(ck, x0, mode=mode, guess=guess, settings=settings)
    kern = _Kernel(ck)
    d = 1.0 if g.step > 0 else -1.0
    first = _first_node(kern, z0, d)
    n_grid = g.kmax - g.kmin + 1
    use_batch = method == "batched" or (method == "auto" and n_grid >= AUTO_BATCH)
    bar = _progress(n_grid, progress)
    if use_batch:  # a denser coarse pass keeps the cubic warm start at ~1e-9
        control = StepControl(**{**{f: getattr(control, f) for f in control.__slots__},
                                 "max_step": min(control.max_step, math.radians(1.0))})
    try:
        tracer = _Tracer(kern, g, control, land=not use_batch, through_limits=through_limits, x_start=x0,
                         bar=None if use_batch else bar)
        path = tracer.trace(first)
        rows = _enumerate_rows(kern, path, g)
        if use_batch:
            sol = batch.solve_rows(tracer, path, rows, g)
        else:
            sol = _solve_rows_tracked(tracer, path, rows, g)
    finally:
        if bar is not None:
            bar.close()
    events = list(path.events) + sol.events
    ok = sol.ok
    every = bool(ok.all())
    ix = ck.input_idx[0]
    Z = sol.Z if every else sol.Z[:, ok]
    Z[ix] = rows.x if every else rows.x[ok]
    J = None
    if sol.J is not None:
        J = sol.J if every else sol.J[:, ok]
        missing = ~(sol.J_ok if every else sol.J_ok[ok])
        if missing.any():
            J[:, missing] = ck.module.jac_v(Z[:, missing], ck.p).reshape(J.shape[0], -1)
    Z1, Z2, Z3, cond = batch.rates_v(ck, Z, rates, J=J, derivatives=derivatives)
    code, res, its = (sol.code, sol.res, sol.its) if every else (sol.code[ok], sol.res[ok], sol.its[ok])
    bad = ~(cond <= batch.SINGULAR_COND)
    if np.any(bad):
        for i in np.flatnonzero(bad):
            x = display_value(ck, Z[ix, i])
            events.append(Event(EventKind.SINGULAR, x, f"singular position at {ck.inputs[0]} = {x:.10g}: Φ_q is "
                                "singular (rates undefined); row left out"))
        keep = ~bad
        Z, Z1, Z2, Z3, cond = Z[:, keep], Z1[:, keep], Z2[:, keep], Z3[:, keep], cond[keep]
        code, res, its = code[keep], res[keep], its[keep]
    names = np.empty(len(sol.sigs), dtype=object)
    names[:] = sol.sigs
    return Sweep.from_arrays(ck, Z.T, Z1.T, Z2.T, Z3.T, modes=tuple(names[code]), residual=res, n_iter=its,
                             cond=cond, events=tuple(events), mode=first.sig,
                             method="batched" if use_batch else "tracked", copy=False)


# ============================================================================= reachable ranges


def _assemblable_at(ck, x) -> list:
    from .modes import all_solutions

    z0 = initial_z(ck, warn=False)
    z0[ck.input_idx[0]] = x
    return all_solutions(ck, z0)


def _limit_towards(ck, kern, z, x_to) -> float | None:
    """Track from the assemblable ``z`` towards ``x_to``; the limit input found on the way, if any."""
    x_from = z[kern.ix]
    lo, hi = min(x_from, x_to), max(x_from, x_to)
    g = _Grid(x_from, x_to - x_from, 0, 1, lo, hi)
    try:
        first = _first_node(kern, z, 1.0 if x_to > x_from else -1.0)
    except SingularPositionError:
        return x_from
    tr = _Tracer(kern, g, StepControl(), land=False, through_limits=False, x_start=x_from)
    path = tr.trace(first)
    for e in path.events:
        if e.kind is EventKind.LIMIT:
            return path.nodes[-1].z[kern.ix]
    return None


def default_range(ck, step: float, *, mode=None) -> tuple[float, float, bool]:
    """Sensible sweep range when the user gives none: ``(start, stop, through_limits)``, display units.

    A full turn from 0 when the mechanism can be assembled at 0 (a length input: ±4 length
    scales around its guess); otherwise the reachable interval that holds the input's guess:
    from its first grid point inside to beyond its far end, traced with ``through_limits`` so
    the sweep turns at each limit position and follows the whole circuit.

    Examples
    --------
    >>> default_range(ls.fourbar(60, 25, 70, 45).compile(), 4)
    (0.0, 360.0, False)
    >>> default_range(ls.load(ls.models_dir() / "double_rocker.toml").compile(), 4)
    (28.0, 72.0, True)
    """
    i = ck.input_idx[0]
    angle = ck.kinds[i] is Kind.ANGLE
    if angle:
        turn = display_value(ck, 2 * math.pi)
        try:
            start_position(ck, 0.0, mode=mode)
            return 0.0, float(turn), False
        except SolveError:
            pass
    ranges = reachable_ranges(ck)
    if not ranges:
        raise AssemblyError(f"{ck.mechanism.source or ck.mechanism.name}: no assemblable input value found "
                            f"for {ck.inputs[0]}; check the link lengths")
    g = ck.mechanism.variable(ck.inputs[0]).guess
    g = 0.0 if g is None else g
    a, b = next(((a, b) for a, b in ranges if a <= g <= b), ranges[0])
    if not angle and len(ranges) == 1 and (a, b) == ranges[0]:
        lo, hi = display_value(ck, a), display_value(ck, b)
        return float(lo), float(hi), False
    lo, hi = display_value(ck, a), display_value(ck, b)
    # start inside (clear of the limit, where the rates are undefined); end beyond the far
    # limit so that the sweep turns there and traces the whole circuit back over the grid
    start = math.floor(lo / step + 1e-9) * step + step
    if start >= hi:  # the range is narrower than the step
        start = 0.5 * (lo + hi)
    stop = math.ceil(hi / step - 1e-9) * step + (step if math.isclose(hi % step, 0.0, abs_tol=1e-9) else 0.0)
    return float(start), float(stop), True


def reachable_ranges(ck, *, samples: int | None = None) -> list[tuple[float, float]]:
    """Intervals of the driving input (internal units) where the mechanism can be assembled.

    The input is sampled (a full turn for an angle; ±4 length scales around the guess for a
    length), every assembly mode is found at each sample (:func:`loopsolve.modes.all_solutions`),
    and each end of a run of assemblable samples is located exactly by tracking towards the
    next sample until the limit position. Ranges narrower than the sampling step can be
    missed. A fully rotating angle input gives one interval of length 2π.

    Examples
    --------
    >>> ck = ls.fourbar(4, 3, 3.5, 5).compile()
    >>> [tuple(round(math.degrees(v), 6) for v in r) for r in reachable_ranges(ck)]
    [(18.57335, 341.42665)]
    """
    kern = _Kernel(ck)
    angle = kern.angle_x
    g0 = ck.mechanism.variable(ck.inputs[0]).guess
    g0 = 0.0 if g0 is None else float(g0)
    if angle:
        m = samples or 144
        xs = [-math.pi + 2 * math.pi * i / m for i in range(m)]
    else:
        m = samples or 200
        xs = [g0 - 4 * ck.scale + 8 * ck.scale * i / (m - 1) for i in range(m)]
    sols = [_assemblable_at(ck, x) for x in xs]
    ok = [bool(s) for s in sols]
    if all(ok):
        if angle:
            return [(-math.pi, math.pi)]
        return [(xs[0], xs[-1])]
    if not any(ok):
        return []
    out = []
    idx = range(m)
    if angle:  # rotate so that the list starts with a non-assemblable sample
        r = ok.index(False)
        idx = [(r + i) % m for i in range(m)]
    runs = []
    cur = None
    for i in idx:
        if ok[i] and cur is None:
            cur = [i, i]
        elif ok[i]:
            cur[1] = i
        elif cur is not None:
            runs.append(cur)
            cur = None
    if cur is not None:
        runs.append(cur)
    step = xs[1] - xs[0]
    for i0, i1 in runs:
        x_lo = xs[i0]
        x_hi = xs[i1]
        if angle and x_hi < x_lo:
            x_hi += 2 * math.pi
        ends = []
        for (xi, zs), toward in (((x_lo, sols[i0]), x_lo - step), ((x_hi, sols[i1]), x_hi + step)):
            best = None
            for z in zs:
                z = np.array(z, dtype=float)
                z[kern.ix] = xi
                lim = _limit_towards(ck, kern, z, toward)
                if lim is None:
                    lim = toward
                if best is None or abs(lim - xi) > abs(best - xi):
                    best = lim
            ends.append(best if best is not None else xi)
        out.append((ends[0], ends[1]))
    out.sort()
    return out


def nearest_assemblable(ck, x: float) -> tuple[float, ...]:
    """The nearest assemblable input values below and above ``x`` (display units).

    ``(x,)`` when ``x`` itself is inside a reachable range.

    Examples
    --------
    >>> ck = ls.fourbar(4, 3, 3.5, 5).compile()
    >>> [round(v, 6) for v in nearest_assemblable(ck, 0.0)]
    [-18.57335, 18.57335]
    """

    ranges = reachable_ranges(ck)
    kern = _Kernel(ck)
    below, above = None, None
    for lo, hi in ranges:
        shifts = [2 * math.pi * j for j in range(-2, 3)] if kern.angle_x else [0.0]
        if any(lo + sh <= x <= hi + sh for sh in shifts):
            return (display_value(ck, x, ck.inputs[0]),)
        cands = [v + sh for v in (lo, hi) for sh in shifts]
        for v in cands:
            if v <= x and (below is None or v > below):
                below = v
            if v >= x and (above is None or v < above):
                above = v
    out = [v for v in (below, above) if v is not None]
    return tuple(display_value(ck, v, ck.inputs[0]) for v in out)
