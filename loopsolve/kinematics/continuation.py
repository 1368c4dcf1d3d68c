"""Continuation: the tracer that follows the solution curve, and locates limits and change points.

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
* **Trust radius.** Every step is at most a quarter of the node's separation ratio
  ρ = σ_min/σ_max of the scaled [Φ_q Φ_x] (:meth:`Kernel.rho`). ρ bounds the curve's
  radius of curvature and the distance at which another piece of the solution set can pass
  (the second derivatives of rotating loop vectors are as large as the first), so a step and
  its corrector stay on the piece they started from: a sweep cannot jump across a narrow gap
  where the linkage cannot be assembled, however coarse the output grid. ρ is of order one
  except near change points, where the internal steps shrink accordingly. Where ρ < 1e-5 the
  branches touch within round-off (an exact change point) and one step of 1e-4 passes it.
* Every accepted step is checked: the corrector converged in few iterations, it moved
  little from the predictor, the tangent turned by less than ``max_turn``, the input did not
  turn back, and the **mode signature** (signs of the determinants of the diagonal blocks of
  Φ_q) is unchanged — unless a singular point between the two nodes explains it. A rejected
  step is halved.
* A signature change means a zero of a block determinant between the two nodes. It is
  located along the chord of the step by the Illinois (regula falsi) method to ~1e-11 in
  scaled arc length, which puts a fold's input value within ~1e-20 of the true limit (x is
  stationary there). If the input turned back, the point is a **limit** (toggle/fold): the
  sweep stops there with a ``limit`` event, or with ``through_limits`` goes on around the
  fold onto the other mode (``mode-change`` event), back over the same output grid, until the
  circuit closes or the input leaves the range. Otherwise the branches touch (a **change
  point**): a ``singular`` event, and the sweep continues on the smooth branch. The
  algebraic test (ψ·Φ_x ≠ 0 at a fold, ψ the left null vector of Φ_q) must agree, or the
  step is retried shorter.

Rows are the output grid values crossed, in the order traversed. Rates at every row are
computed in one vectorized pass (:func:`loopsolve.kinematics.batch.rates_v`). ``method="batched"``
traces the curve once at the internal step and solves all output points at once
(:mod:`loopsolve.kinematics.batch`); ``"auto"`` picks it for dense grids.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .rows import RowSolution, fill_node_rows, solve_rows_scalar  # noqa: F401  (kinematics/rows.py; public here before)
from ..errors import SingularPositionError
from .scalar_solver import ROUNDOFF as _ROUNDOFF
from .scalar_solver import Kernel
from .stepgen import python_step
from .results import Event, EventKind
from .solve import input_unit, display_value

__all__ = ["StepControl", "Kernel", "Node", "Path", "Tracer", "RowSolution", "first_node", "fill_node_rows",
           "solve_rows_scalar"]

#: nodes whose Jacobian blocks have a Hadamard ratio below this are not accepted: the step
#: is retried so that it straddles the singular position, which is then located exactly
NEAR_SINGULAR = 1e-7
#: a sweep does not start where the regularity (≈ 2/cond of the scaled blocks) is below this
_START_REGULAR = 1e-5
#: internal steps are at most this fraction of the separation ratio ρ (:meth:`Kernel.rho`)
TRUST = 0.25
#: below this ρ the branches touch within round-off (an exact change point) ...
RHO_TOUCH = 1e-5
#: ... and the tracer passes the branch point with a step of this length
_PASS_STEP = 1e-4


@dataclass(frozen=True, slots=True)
class StepControl:
    """Internal step control of the tracker.

    Steps are measured in scaled arc length: angles in radians, lengths divided by the
    model's characteristic length (``CompiledKinematics.scale``).

    Pass one as ``control=`` to :func:`loopsolve.sweep`; the fields are read back as attributes
    of the same names.

    Parameters
    ----------
    max_step : float, optional
        Longest internal step (default 2° = 0.0349).
    min_step : float, optional
        Halving gives up below this step (the sweep then stops with an event); default 1e-10.
    max_iter : int, optional
        Corrector iterations allowed in one step; default 7.
    max_turn : float, optional
        Largest angle between the tangents at the two ends of a step (radians; default 12°).
    natural_min, natural_back : float, optional
        Switch to pseudo-arclength steps when ``|dx/ds|`` falls below ``natural_min`` (default
        0.3), back to natural steps above ``natural_back`` (default 0.5).
    max_nodes : int, optional
        Upper bound on the internal steps of one sweep (default 5 000 000).

    Examples
    --------
    >>> import math
    >>> import loopsolve as ls
    >>> fine = ls.StepControl(max_step=math.radians(0.5))
    >>> sw = ls.fourbar(60, 25, 70, 45).sweep(0, 360, 90, control=fine)
    >>> len(sw), [round(float(v), 2) for v in sw["theta4"]]
    (5, [58.41, 80.72, 124.65, 125.96, 58.41])
    """

    max_step: float = math.radians(2.0)
    min_step: float = 1e-10
    max_iter: int = 7
    max_turn: float = math.radians(12.0)
    natural_min: float = 0.3
    natural_back: float = 0.5
    max_nodes: int = 5_000_000


# ============================================================================= path


@dataclass(slots=True)
class Node:
    z: list
    t: list  # unit tangent in scaled (u, x), oriented along the path
    sig: str
    kind: str = "regular"  # regular | fold | singular | end
    grid: int | None = None
    residual: float = 0.0
    n_iter: int = 0
    J: list | None = None
    rho: float | None = None  # separation ratio of [Φ_q Φ_x] (Kernel.rho), computed when needed


@dataclass(slots=True)
class Path:
    nodes: list
    seg_sig: list  # signature of segment i (between nodes i and i+1)
    events: list = field(default_factory=list)


def _hermite(ya, ta, yb, tb, s):
    L = math.sqrt(sum((b - a) ** 2 for a, b in zip(ya, yb)))
    s2, s3 = s * s, s * s * s
    h00, h10, h01, h11 = 2 * s3 - 3 * s2 + 1, s3 - 2 * s2 + s, -2 * s3 + 3 * s2, s3 - s2
    return [h00 * a + h10 * L * p + h01 * b + h11 * L * q for a, p, b, q in zip(ya, ta, yb, tb)]


class Tracer:
    def __init__(self, kern: Kernel, gridspec, control: StepControl, *, land: bool,
                 through_limits: bool, x_start: float, bar=None):
        self.k = kern
        self.g = gridspec
        self.c = control
        self.land = land
        self.through = through_limits
        self.x_start = x_start
        self.bar = bar
        self.near = NEAR_SINGULAR  # regularity below which a node is refused (see trace)
        self.cos_turn = math.cos(control.max_turn)
        self.cos_grow = math.cos(control.max_turn / 3)
        self.step = python_step(kern)  # the generated natural step (loopsolve.kinematics.stepgen), or None
        self.step_f = getattr(kern, "_step_config", None)
        self.sigs = getattr(kern, "_sigs", None)
        self.fast = None  # compiled fast lane of regular natural steps (loopsolve.kinematics.numba_engine.steps), or None

    # ------------------------------------------------------------------ helpers
    def _display(self, x):

        return display_value(self.k.ck, x, self.k.ck.inputs[0])

    def _unit(self):

        return input_unit(self.k.ck)

    def _label(self, sig):
        names = [a for a, s in self.k.ck.mechanism.mode_aliases.items() if s == sig]
        return f"{sig} ({', '.join(names)})" if names else sig

    def _finish_node(self, z, it, res, t_prev, natural_d=None, row=None):
        """Jacobian, dets, signature and tangent at a converged ``z``; None if singular."""
        k = self.k
        J = k.jac_f(z, k.p)
        dets, had = k.dets(J)
        if min(had, default=1.0) < self.near:
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
        return Node(z, t, k.sig(dets), residual=res, n_iter=it, J=J), dets, had

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

    def _natural_step(self, a: Node, a_prev: Node | None, h: float, land: bool = True):
        """A natural step from ``a`` (``a_prev``: the previous natural node) of length ``h``, landing on
        the next grid value within reach when ``land``. Returns ``(node or None, at_bound)``.

        The step itself is generated for the model's block structure (:mod:`loopsolve.kinematics.stepgen`):
        the same text that the ``numba`` engine compiles. Structures with a block larger than 2×2 take
        :meth:`_natural_step_general`.
        """
        k = self.k
        step = self.step
        if step is None:
            return self._natural_step_general(a, a_prev, h, land)
        n = k.n
        at = a.t
        tx = at[n]
        az = a.z
        xa = az[k.ix]
        target, gidx, at_bound = self._natural_target(xa, 1.0 if tx > 0 else -1.0, h * abs(tx) / k.wx, land)
        if target - xa == 0:
            return None, at_bound
        if a_prev is not None and a_prev.sig == a.sig and abs(a_prev.t[n]) > 0.1:
            ok, it, res, rho, mask, t, J = step(az, at, True, a_prev.t, a_prev.z[k.ix], target, self.near, k.p, k.ex,
                                                self.step_f, self.c.max_iter, z := list(az))
        else:
            ok, it, res, rho, mask, t, J = step(az, at, False, at, 0.0, target, self.near, k.p, k.ex, self.step_f,
                                                self.c.max_iter, z := list(az))
        if not ok:
            return None, at_bound
        return Node(z, list(t), self.sigs[mask], grid=gidx, residual=res, n_iter=it, J=list(J), rho=rho), at_bound

    def _natural_step_general(self, a: Node, a_prev: Node | None, h: float, land: bool = True):
        """:meth:`_natural_step` of a structure with a block larger than 2×2 (no generated step):
        the same predictor and checks on the kernel's general block solves."""
        k = self.k
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

    def _arc_step(self, a: Node, h: float):
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
    def _point_on_chord(self, a: Node, b: Node, s: float, guess=None):
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

    def _locate(self, a: Node, b: Node):
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
        return Node(list(zs), t, k.sig(dets), residual=k.residual(zs), J=J)

    def solve_at(self, a: Node, b: Node, x: float, sig: str, depth: int = 0):
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
        if not ok:
            ok = self._at_roundoff(z)
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
        m = Node(zm, t, sig, J=J)
        xm = zm[k.ix]
        first = (a, m) if (x - a.z[k.ix]) * (xm - x) >= 0 else (m, b)
        return self.solve_at(first[0], first[1], x, sig, depth + 1)

    # ------------------------------------------------------------------ main loop
    def trace(self, first: Node) -> Path:
        k, c = self.k, self.c
        n = k.n
        nodes = [first]
        seg_sig: list[str] = []
        events: list[Event] = []
        path = Path(nodes, seg_sig, events)
        natural = abs(first.t[n]) >= c.natural_min
        h = c.max_step
        prev_natural: Node | None = None
        folds = 0
        start_sig = first.sig
        passing = None  # the node a pass step across a branch point was last tried from
        fast_ok = self.fast is not None
        while True:
            a = nodes[-1]
            if len(nodes) > c.max_nodes:
                events.append(Event(EventKind.SINGULAR, self._display(a.z[k.ix]),
                                    f"stopped after {c.max_nodes} internal steps (StepControl.max_nodes); the rows "
                                    "stop here"))
                break
            if fast_ok and natural and a.kind == "regular":
                # the compiled fast lane takes the regular natural steps; the first step it does not
                # take is taken below, in Python, and it is called again after a node accepted here
                h, prev_natural, natural, stop = self.fast.advance(self, path, prev_natural, h, folds, start_sig)
                fast_ok = False
                if stop:
                    break
                continue
            at_bound = False
            if a.rho is None:
                a.rho = k.rho(a.z, a.J if a.J is not None else k.jac_f(a.z, k.p))
            # trust radius: a fraction of the separation ratio, so that a step cannot reach another
            # piece of the solution set (near change points) nor cut a sharp turn; below the floor
            # the branches touch within round-off (an exact change point): pass straight through
            if a.rho < RHO_TOUCH:
                if passing is not a:  # first try from this node: one step across the branch point
                    h, passing = _PASS_STEP, a
                self.near = NEAR_SINGULAR
            else:
                h = min(h, max(TRUST * a.rho, c.min_step * 1e3))
                # a node this close to a singular position is refused so that the step straddles it;
                # where the steps are short (ρ small: the determinant grows only like ρ·distance) the
                # bound shrinks with them, or no step could ever get past
                self.near = min(NEAR_SINGULAR, 0.01 * a.rho * h)
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
                                        f"branch tracking cannot continue beyond this input on mode "
                                        f"{self._label(a.sig)} (no converged step down to the minimum step); the rows "
                                        "stop here"))
                    break
                continue
            end = at_bound
            # the input leaves the range inside an arclength step: stop on the bound
            xa, xb = a.z[k.ix], b.z[k.ix]
            if not natural and len(nodes) == 1 and a.kind == "fold" and any(
                    (xb - xa) * out > 0 and (xa - bound) * out >= -k.x_tol
                    for bound, out in ((self.g.lo, -1.0), (self.g.hi, 1.0))):
                # the sweep starts on a limit position at an end of its range and the mechanism can
                # only move out of the range from there: nothing to trace (the rest of the range,
                # if any, lies beyond the limit)
                if self.g.hi - self.g.lo > k.x_tol and not self.through:
                    events.append(Event(EventKind.LIMIT, self._display(xa),
                                        "limit position (toggle/fold): the input cannot go further on mode "
                                        f"{self._label(a.sig)}; the rows stop here"))
                break
            if not natural and any((xb - xa) * out > 0 and (xa - bound) * out >= 0
                                   and (a.t[n] * out > 0 or self.g.hi - self.g.lo <= k.x_tol)
                                   for bound, out in ((self.g.lo, -1.0), (self.g.hi, 1.0))):
                # a node on an end of the range (a one-row sweep's start) and the step leaves it. A step
                # that comes back out of the range although the tangent pointed into it went round a
                # limit position just inside the range: that is located below, not a silent stop
                break
            if not natural:
                for bound, out in ((self.g.lo, -1.0), (self.g.hi, 1.0)):
                    if (xb - xa) * out > 0 and ((xa - bound) * (xb - bound) < 0 or (xb == bound and xa != bound)):
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
            if b.sig == a.sig and a.kind != "fold" and (a.t[n] > 0) != (b.t[n] > 0):
                h *= 0.5  # the input turned back without a fold in between: the step was too long
                if h >= c.min_step:
                    continue
            if b.sig != a.sig:
                s = self._locate(a, b)
                if s is None:
                    h *= 0.5
                    if h < c.min_step:
                        x = self._display(a.z[k.ix])
                        events.append(Event(EventKind.SINGULAR, x, "singular position nearby: the mode signature "
                                            "changes but no crossing of a singular configuration could be located; "
                                            "the rows stop here"))
                        break
                    continue
                reversed_ = (a.t[n] > 0) != (b.t[n] > 0)
                fold = reversed_
                # within the trust radius the input's turn classifies the point; the algebraic test
                # (ψ·Φ_x ≠ 0 at a fold) must agree. Near a change point a fold's ψ·Φ_x is small
                # (≈ the square root of the design's distance from the change point), so the test's
                # threshold comes down to what separates it from an exact change point's round-off
                tol = 1e-4 if k.rho(s.z, s.J) > 1e-3 else 1e-8
                if reversed_ != self._is_fold(s, tol):
                    # the located singular point does not explain the step (a fold crossed without
                    # the input turning back, or the input turning at a branch point): the step left
                    # the piece it started on; take a smaller one
                    h *= 0.5
                    if h < c.min_step:
                        x = self._display(a.z[k.ix])
                        events.append(Event(EventKind.SINGULAR, x, "singular position nearby that could not be "
                                            "classified; the rows stop here"))
                        break
                    continue
                xs = s.z[k.ix]
                disp = self._display(xs)
                if fold:
                    s.kind = "fold"
                    nodes.append(s)
                    seg_sig.append(a.sig)
                    if self.through and first.kind == "fold" and folds and abs(xs - first.z[k.ix]) <= 1e3 * k.x_tol:
                        break  # back at the limit position the sweep started from: the circuit is closed
                    msg = f"limit position (toggle/fold): the input cannot go further on mode {self._label(a.sig)}"
                    if not self.through:
                        events.append(Event(EventKind.LIMIT, disp, msg + "; the rows stop here (use "
                                            "--through-limits to continue around it)"))
                        break
                    events.append(Event(EventKind.LIMIT, disp, msg))
                    events.append(Event(EventKind.MODE_CHANGE, disp,
                                        f"continuing around the limit position onto mode {self._label(b.sig)}; "
                                        "the input turns back"))
                    folds += 1
                else:
                    s.kind = "singular"
                    nodes.append(s)
                    seg_sig.append(a.sig)
                    events.append(Event(EventKind.SINGULAR, disp,
                                        "singular position (change point: the branches touch): Φ_q is singular "
                                        "there; continuing on the smooth "
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
            fast_ok = self.fast is not None
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

    def _at_roundoff(self, z) -> bool:
        """Whether ``z`` is a root to round-off although Newton did not report convergence.

        Next to a singular position (a change point) Φ_q is ill-conditioned and the Newton steps
        stall at round-off times its condition number, above Newton's stopping threshold: ``z``
        is a root all the same when its residual is within tolerance and one more step is
        round-off amplified by the conditioning (the blocks' regularity ≈ 2/cond), and small.
        """
        k = self.k
        f = k.phi_f(z, k.p)
        if not max((abs(v) for v in f), default=0.0) <= k.tol:
            return False
        J = k.jac_f(z, k.p)
        dx = k.solve(J, [-v for v in f])
        if dx is None:
            return False
        st = max((abs(d) * w for d, w in zip(dx, k.wu)), default=0.0)
        had = min(k.dets(J)[1], default=1.0)
        ymax = max((abs(z[i]) * w for i, w in zip(k.iu, k.wu)), default=0.0)
        return st <= 1e-10 and st * had <= _ROUNDOFF * (1 + ymax)

    def _is_fold(self, s: Node, tol: float = 1e-4) -> bool:
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
        return abs(float(psi @ fx)) > tol * nf

    def _same_as_start(self, z, z0) -> bool:
        k = self.k
        for i, idx in enumerate(k.iu):
            d = z[idx] - z0[idx]
            if k.turn_u[i]:
                d = (d + math.pi) % (2 * math.pi) - math.pi
            if abs(d) * k.wu[i] > 1e-6:
                return False
        return True


# ============================================================================= start


def _fold_start(kern: Kernel, z, J, sig_wanted: str | None) -> Node | None:
    """The start node when the start is a limit position (a fold of the input), else None.

    At a fold Φ_q is singular but [Φ_q Φ_x] is not: its null vector is the tangent, normal to
    the input axis. The point is refined on the hyperplane through it normal to the tangent,
    and the tangent is oriented into the assembly mode ``sig_wanted`` (the solved start's, when
    it has one): both directions enter the reachable range, one mode each.
    """
    found = kern.fold_point(z, J)
    if found is None:
        return None
    zz, t = found
    best = None
    for sgn in (1.0, -1.0):  # the mode on each side
        tt = [sgn * v for v in t]
        y = [a + 1e-4 * b for a, b in zip(kern.yhat(zz), tt)]
        zt = list(zz)
        kern.set_yhat(zt, y)
        zt, _, ok, _ = kern.aug_newton(zt, tt, sum(a * b for a, b in zip(tt, y)), 12)
        if not ok:
            continue
        sig = kern.sig(kern.dets(kern.jac_f(zt, kern.p))[0])
        if "0" in sig:
            continue
        if best is None or sig == sig_wanted:
            best = (tt, sig)
    if best is None:
        return None
    Jz = kern.jac_f(zz, kern.p)
    return Node(zz, best[0], best[1], kind="fold", grid=None, residual=kern.residual(zz), J=Jz)


def first_node(kern: Kernel, z, d: float, *, allow_fold: bool = False) -> Node:
    """The tracer's first node at the solved start ``z``, heading in input direction ``d``.

    Raises :class:`SingularPositionError` at a singular start, except, with ``allow_fold``, at a
    limit position: the node is then the fold itself (``kind="fold"``, no row) heading into the
    start's assembly mode.
    """
    z = [float(v) for v in z]
    J = kern.jac_f(z, kern.p)
    dets, had = kern.dets(J)
    du = kern.dudx(z, J)
    if du is None or min(had, default=1.0) < _START_REGULAR:
        node = _fold_start(kern, z, J, kern.sig(dets)) if allow_fold else None
        if node is not None:
            return node
        name = kern.ck.inputs[0]
        disp = display_value(kern.ck, z[kern.ix], name)
        raise SingularPositionError(
            f"{kern.ck.mechanism.source or kern.ck.mechanism.name}: the sweep starts at a singular position "
            f"({name} = {disp:g}: limit, dead centre or change point, where the mode is ambiguous, or within "
            "about 1e-5 of one); start the sweep slightly away from it", input_value=disp, result=np.array(z))
    t = kern.natural_tangent(du, d)
    return Node(z, t, kern.sig(dets), grid=0, residual=kern.residual(z), J=J)
