"""The tracer's compiled fast lane: regular natural steps in machine code (the ``numba`` engine).

:class:`~loopsolve.kinematics.continuation.Tracer` follows the solution curve step by step in Python.
Most steps of most sweeps are *regular*: a natural step in the input that lands on the next
output grid value, converges in two or three corrector iterations, keeps the mode signature,
and passes every check. This module takes exactly those steps in a compiled loop
(:func:`run_steps`, compiled by numba together with the model's generated Φ, Φ_q and b₁ and the
natural step generated for its block structure, see
:mod:`loopsolve.kinematics.numba_engine.jit`) and hands control back to the Python tracer the moment a step is
anything else:

* the trust radius ρ of the node is below the touching floor (a change point);
* the step fails: the corrector does not converge in ``max_iter`` iterations, the residual is
  above tolerance, the node is nearer a singular position than the regularity bound, the
  corrector moved more than a quarter of the step from the predictor, the step would not
  move (``delta == 0``) — *including* the landing failures that the Python tracer retries
  without landing;
* the tangent turned by more than ``max_turn``, the input turned back, or the mode
  signature changed (a fold or a change point to locate);
* with ``through_limits`` after a fold, the node is back in the start's mode (the circuit
  may close there).

The rejected step is not consumed: the Python tracer takes it again from the same node with
the same step length, so it decides (halving, location, arc steps, events) exactly as
without the fast lane, and it calls the fast lane again once it has accepted a node of its
own. The step itself is not a copy: :func:`run_steps` calls ``natural_step``, the source that
:mod:`loopsolve.kinematics.stepgen` generates for the model's block structure and that
:meth:`Tracer._natural_step <loopsolve.kinematics.continuation.Tracer._natural_step>` runs as
Python; the loop around it applies the tracer's acceptance rules, step growth and trust radius
in the same floating-point order, so the nodes agree with the pure-Python tracer's to round-off
(the tests check 1e-12; in practice they are identical to the bit).

Structures covered: every solve order of 1×1 and 2×2 diagonal blocks of Φ_q — four-bars and
other one-loop models with two unknowns (one 2×2 block), slider-cranks (two 1×1 blocks),
inverted slider-cranks and shapers (a 2×2 block and 1×1 blocks), six-bars (Watt, Stephenson:
two 2×2 blocks in solve order), cam and geared models, the diagram models. A structure with a
block larger than 2×2 has no fast lane: the tracer runs in Python whatever the engine. The
compiled start (:func:`start2`) and the rows' rates fused into the step loop (:func:`node_rates`,
:func:`rates2`) exist for a single 2×2 block; other structures start and take their rates as the
Python engine does.
"""

from __future__ import annotations

import inspect
import math
import weakref

import numpy as np

from ...errors import warn
from ...model.units import Kind
from ..batch import SINGULAR_COND, rates_v
from ..continuation import NEAR_SINGULAR, RHO_TOUCH, TRUST, Node
from ..scalar_solver import ROUNDOFF, rho_2x3  # rho_2x3: compiled into the template from its one definition
from ..stepgen import mask_of_sig, rho_rows, step_config
from ..newton import Newton
from ..solve import guess_pose, initial_z

__all__ = ["FastLane", "TEMPLATE_FUNCTIONS", "IRREGULAR", "END", "ARC", "FULL", "NOGRID"]

#: the step was not taken (a Python step decides); the range end was reached; the curve
#: turned (arclength steps from here); the output buffer is full (call again)
IRREGULAR, END, ARC, FULL = 0, 1, 2, 3
#: "no grid index" in the integer output
NOGRID = -(2**62)

# float configuration (f) and integer configuration (iv) of run_steps
(F_TOL, F_W0, F_W1, F_WX, F_COS_TURN, F_COS_GROW, F_MAX_STEP, F_MIN_STEP, F_NATURAL_MIN, F_TRUST, F_RHO_TOUCH,
 F_NEAR, F_G_START, F_G_STEP, F_G_LO, F_G_HI, F_DEG0, F_DEG1, F_ROUNDOFF, F_SIZE) = range(20)
(I_I0, I_I1, I_IX, I_MAX_ITER, I_LAND, I_KMIN, I_KMAX, I_DEG, I_CLOSING, I_START_SIG, I_SIZE) = range(11)


# ----------------------------------------------------------------------------- compiled template
# These functions are compiled by numba in the module that loopsolve.kinematics.numba_engine.jit generates for
# each model structure, next to that model's phi, jac and rhs1 (the globals they call). They
# mirror Grid.value / Grid.next_after (loopsolve.kinematics.sweep), Tracer._natural_target and the
# accept/reject rules of Tracer.trace (loopsolve.kinematics.continuation) operation for operation; a change
# there must be made here too (tests/kinematics/test_numba_engine.py compares them). The step itself (predictor,
# corrector, checks, tangent, rho) is not here: it is generated (loopsolve.kinematics.stepgen), rho_2x3 and
# rho_rows are compiled from their one definitions.


def grid_value(k, f, iv):
    if iv[7] == 0:  # I_DEG
        return f[12] + f[13] * k  # F_G_START, F_G_STEP
    v = f[16] + f[17] * k  # F_DEG0, F_DEG1
    x = math.radians(v)
    for _ in range(4):
        d = math.degrees(x)
        if d == v:
            break
        x = np.nextafter(x, math.inf if d < v else -math.inf)
    return x


def grid_next_after(x, d, f, iv):
    fr = (x - f[12]) / f[13]
    if d * f[13] > 0:
        k = math.floor(fr + 1e-9) + 1
    else:
        k = math.ceil(fr - 1e-9) - 1
    if iv[5] <= k <= iv[6]:  # I_KMIN, I_KMAX
        return k
    return -(2**62)


def natural_target(xa, d, dx, land, f, iv):
    target = xa + d * dx
    gidx = -(2**62)
    if land:
        kn = grid_next_after(xa, d, f, iv)
        if kn != -(2**62):
            gx = grid_value(kn, f, iv)
            if d * (gx - target) <= 1e-12 * (1 + abs(gx)):
                target, gidx = gx, kn
    bound = f[15] if d > 0 else f[14]  # F_G_HI, F_G_LO
    at_bound = False
    if d * (target - bound) >= 0:
        target, at_bound = bound, True
        kb = int(np.rint((bound - f[12]) / f[13]))
        gidx = kb if abs(grid_value(kb, f, iv) - bound) <= 1e-12 * (1 + abs(bound)) else -(2**62)
        if gidx != -(2**62):
            target = grid_value(gidx, f, iv)
    return target, gidx, at_bound


def run_steps(z, t, sig, rho, has_prev, pt, xp, h, p, ex, f, sf, iv, oz, ot, oj, of, oi, rr, orr):
    """Regular natural steps from the node (z, t, sig, rho) until one is not regular or the
    output (oz, ot, oj, of, oi) is full. Returns (count, status, h).

    The step is the model structure's generated ``natural_step`` (loopsolve.kinematics.stepgen, the
    text the Python tracer runs); ``sig`` is the integer signature (stepgen.mask_of_sig). With
    ``rr[3] > 0`` (rr = input speed, acceleration, jerk, derivatives, singular_cond; a single 2×2
    block only) also the rates of each node (``orr[1 + k]``) and of the start node (``orr[0]``), as rates2."""
    nv = z.shape[0]
    n = ot.shape[1] - 1
    az = z.copy()
    at = t.copy()
    pt = pt.copy()
    bz = np.empty(nv)
    orow = np.empty(7)
    ix = iv[2]
    if rr[3] > 0:
        start_rates(z, p, iv, rr, orr)  # noqa: F821 - generated next to the model's functions
    land = iv[4] != 0
    closing = iv[8] != 0
    start_sig = iv[9]
    cap = oz.shape[0]
    count = 0
    while count < cap:
        if rho < f[10]:  # F_RHO_TOUCH: the branches touch here
            return count, 0, h
        h = min(h, max(f[9] * rho, f[7] * 1e3))  # F_TRUST, F_MIN_STEP
        near = min(f[11], 0.01 * rho * h)  # F_NEAR
        tx = at[n]
        xa = az[ix]
        target, gidx, at_bound = natural_target(xa, 1.0 if tx > 0 else -1.0, h * abs(tx) / f[3], land, f, iv)
        if target - xa == 0:
            return count, 0, h
        for i in range(nv):
            bz[i] = az[i]
        ok, it, res, brho, mask, bt, bj = natural_step(az, at, has_prev, pt, xp, target, near, p, ex, sf,  # noqa: F821
                                                       iv[3], bz, rr, orow)
        if not ok:
            return count, 0, h
        dot = 0.0
        for i in range(n + 1):
            dot += at[i] * bt[i]
        if dot < f[4]:  # F_COS_TURN
            return count, 0, h
        if mask != sig or (at[n] > 0) != (bt[n] > 0):  # a fold, change point or turn: Python decides
            return count, 0, h
        if closing and mask == start_sig and not at_bound:
            return count, 0, h
        for i in range(nv):
            oz[count, i] = bz[i]
        for i in range(n + 1):
            ot[count, i] = bt[i]
        for i in range(n * n):
            oj[count, i] = bj[i]
        of[count, 0], of[count, 1] = res, brho
        oi[count, 0], oi[count, 1] = gidx, it
        if rr[3] > 0:
            for i in range(7):
                orr[count + 1, i] = orow[i]
        count += 1
        if at_bound:
            return count, 1, h
        if it <= 3 and dot > f[5] and h < f[6]:  # F_COS_GROW, F_MAX_STEP
            h = min(h * 1.6, f[6])
        if abs(bt[n]) < f[8]:  # F_NATURAL_MIN: arclength steps from here
            return count, 2, h
        has_prev = abs(at[n]) > 0.1
        for i in range(n + 1):
            pt[i] = at[i]
        xp = az[ix]
        for i in range(nv):
            az[i] = bz[i]
        for i in range(n + 1):
            at[i] = bt[i]
        rho = brho
    return count, 3, h


def norm2(a, b):
    big = max(abs(a), abs(b))
    if not big < math.inf:
        return big  # inf, or NaN
    if big == 0.0:
        return 0.0
    return big * math.sqrt((a / big) ** 2 + (b / big) ** 2)


def start2(zg, z, p, i0, i1, tol, rtol, max_iter):
    """The sweep's start by loopsolve.kinematics.newton's damped Newton (one 2×2 block), from ``z`` (modified),
    in the mode the guesses ``zg`` name. Returns (1, residual, iterations) when it converged in that
    mode with a regular Jacobian all the way; (0, ., .) for anything else (Python decides)."""
    A, B, C, D = jac(zg, p)  # noqa: F821
    d = A * D - B * C
    norms = math.sqrt(A * A + C * C) * math.sqrt(B * B + D * D)
    if not abs(d) > 2e-9 * norms:  # GUESS_SINGULAR (with a margin): the guesses name no mode
        return 0, 0.0, 0
    want = 1 if d > 0 else -1
    x0, x1 = z[i0], z[i1]
    f0, f1 = phi(z, p)  # noqa: F821
    fn = max(abs(f0), abs(f1))
    polished = False
    for it in range(1, max_iter + 1):
        if not fn < math.inf:
            return 0, fn, it
        A, B, C, D = jac(z, p)  # noqa: F821
        big = max(abs(A), abs(B), abs(C), abs(D))
        if not (0.0 < big < math.inf):
            return 0, fn, it
        a, b, c, dd = A / big, B / big, C / big, D / big
        g0, g1 = f0 / big, f1 / big
        fro = a * a + b * b + c * c + dd * dd
        det = a * dd - b * c
        disc = math.sqrt(max(fro * fro - 4 * det * det, 0.0))
        s1 = math.sqrt((fro + disc) / 2)
        if not abs(det) / s1 > s1 * 1e-8:  # cond ≥ 1e8: near-singular, Python's regularized step
            return 0, fn, it
        d0 = (b * g1 - dd * g0) / det
        d1 = (c * g0 - a * g1) / det
        f2 = norm2(f0, f1)
        t = 1.0
        while True:
            z[i0] = x0 + t * d0
            z[i1] = x1 + t * d1
            n0, n1 = phi(z, p)  # noqa: F821
            f2n = norm2(n0, n1)
            if f2n < math.inf and (f2n <= math.sqrt(1 - 1e-4 * t) * f2 or f2 <= tol * 1e-3):
                break
            t *= 0.5
            if t < 1e-10:
                return 0, fn, it
        step = max(abs(t * d0), abs(t * d1))
        x0, x1 = z[i0], z[i1]
        f0, f1 = n0, n1
        fn = max(abs(f0), abs(f1))
        if fn <= tol:
            if polished or step <= rtol * (1.0 + max(abs(x0), abs(x1))):
                A, B, C, D = jac(z, p)  # noqa: F821
                d = A * D - B * C
                norms = math.sqrt(A * A + C * C) * math.sqrt(B * B + D * D)
                if not abs(d) > 1e-6 * norms or (1 if d > 0 else -1) != want:
                    return 0, fn, it  # another mode, or a near-singular start: Python decides
                return 1, fn, it
            polished = True
    return 0, fn, max_iter


def node_rates(zt, p, i0, i1, ix, r1, r2, r3, derivatives, singular_cond):
    """Rates of the unknowns at the node ``zt`` (a tuple): velocities, accelerations, jerks (NaN
    beyond ``derivatives``, all NaN where cond > singular_cond) and the condition number of Φ_q.
    Inlined (in natural_step after the corrector's last Φ: the sines and cosines are shared)."""
    A, B, C, D = jac(zt, p)  # noqa: F821
    fro = A * A + B * B + C * C + D * D
    adet = abs(A * D - B * C)
    disc = math.sqrt(max(fro * fro - 4 * adet * adet, 0.0))
    s1 = math.sqrt((fro + disc) / 2)
    s2 = adet / s1
    cond = s1 / s2 if s2 > 0 else math.inf
    det = A * D - B * C
    b0, b1 = rhs1(zt, rvec(r1, 0.0, 0.0), p)  # noqa: F821
    v0 = (D * b0 - B * b1) / det
    v1 = (A * b1 - C * b0) / det
    a0 = a1 = j0 = j1 = math.nan
    if derivatives >= 2:
        b0, b1 = rhs2(zt, rvec(r1, v0, v1), rvec(r2, 0.0, 0.0), p)  # noqa: F821
        a0 = (D * b0 - B * b1) / det
        a1 = (A * b1 - C * b0) / det
        if derivatives >= 3:
            b0, b1 = rhs3(zt, rvec(r1, v0, v1), rvec(r2, a0, a1), rvec(r3, 0.0, 0.0), p)  # noqa: F821
            j0 = (D * b0 - B * b1) / det
            j1 = (A * b1 - C * b0) / det
    if not cond <= singular_cond:
        v0 = v1 = a0 = a1 = j0 = j1 = math.nan
    return v0, v1, a0, a1, j0, j1, cond


def fill_rates(R, r1, r2, r3, i0, i1, ix, singular_cond, Z1, Z2, Z3, cond):
    """Rows of rates (``Z1, Z2, Z3`` (nv, n), ``cond``) from node_rates' tuples ``R`` (n, 7), as rates2 has them."""
    nv, n = Z1.shape
    for j in range(n):
        for i in range(nv):
            Z1[i, j] = 0.0
            Z2[i, j] = 0.0
            Z3[i, j] = 0.0
        Z1[ix, j], Z2[ix, j], Z3[ix, j] = r1, r2, r3
        Z1[i0, j], Z1[i1, j] = R[j, 0], R[j, 1]
        Z2[i0, j], Z2[i1, j] = R[j, 2], R[j, 3]
        Z3[i0, j], Z3[i1, j] = R[j, 4], R[j, 5]
        cond[j] = R[j, 6]
        if not R[j, 6] <= singular_cond:
            for i in range(nv):
                Z1[i, j] = Z2[i, j] = Z3[i, j] = math.nan
            Z1[ix, j], Z2[ix, j], Z3[ix, j] = r1, r2, r3


def rates2(Z, r1, r2, r3, p, i0, i1, ix, derivatives, singular_cond, Z1, Z2, Z3, cond):
    """loopsolve.kinematics.batch.rates_v for one 2×2 block, row by row: velocities, accelerations, jerks
    (NaN beyond ``derivatives``) and the condition numbers; NaN rates where cond > singular_cond."""
    nv, n = Z.shape
    R = np.empty((n, 7))
    for j in range(n):
        R[j, 0], R[j, 1], R[j, 2], R[j, 3], R[j, 4], R[j, 5], R[j, 6] = node_rates(
            ztuple(Z[:, j]), p, i0, i1, ix, r1, r2, r3, derivatives, singular_cond)  # noqa: F821
    fill_rates(R, r1, r2, r3, i0, i1, ix, singular_cond, Z1, Z2, Z3, cond)


#: the template functions, in the order they are written into the generated module
TEMPLATE_FUNCTIONS = (grid_value, grid_next_after, natural_target, rho_2x3, rho_rows, node_rates, run_steps, norm2,
                      start2, fill_rates, rates2)
#: the template functions inlined where they are called (so that LLVM shares their sines and cosines)
TEMPLATE_INLINE = (node_rates,)


def template_source() -> str:
    """Source text of the template functions (for :mod:`loopsolve.kinematics.numba_engine.jit`)."""
    return "\n\n".join(inspect.getsource(fn) for fn in TEMPLATE_FUNCTIONS)


# ----------------------------------------------------------------------------- Python side


def _compiled(fn, lane, *args):
    """``fn(*args)``, or None when numba cannot compile it for this model (one warning, then the
    lane is off and the Python path does the work)."""
    if lane.failed:
        return None
    try:
        return fn(*args)
    except Exception as exc:
        if not type(exc).__module__.startswith("numba"):
            raise
        lane.failed = True
        warn(f"{lane.k.ck.mechanism.source or lane.k.ck.mechanism.name}: numba could not compile this model's "
             f"fast lane ({type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}); the Python "
             "tracer is used")
        return None


#: the start's guess pose at input 0, whether the pose follows the input, and the initial z, per kernel
_GUESSES: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()
#: ``rr`` of run_steps when no rates are wanted
_NO_RATES = np.zeros(5)  # (writable: numba compiles read-only arrays separately)


class FastLane:
    """The fast lane of one :class:`~loopsolve.kinematics.scalar_solver.Kernel` (blocks of 1×1 and 2×2 only).

    Built by :func:`loopsolve.kinematics.numba_engine.jit.fast_lane`; :meth:`advance` is the hook that
    :meth:`Tracer.trace <loopsolve.kinematics.continuation.Tracer.trace>` calls on natural steps.
    """

    def __init__(self, kern, run, *, lazy: bool = False, start=None, rates=None, fill=None):
        self.k = kern
        self.run = run
        self.start_run = start
        self.rates_run = rates
        self.fill_run = fill
        #: the natural steps this lane took compiled (accepted nodes, kept or traced whole)
        self.steps = 0
        self.sf = np.asarray(step_config(kern), dtype=float)
        #: the rows' input rates and derivatives (:meth:`want_rates`): a path traced whole then has its
        #: rates computed at each node inside the step loop (``whole[3]``), as :meth:`rates` would
        self.rr = _NO_RATES
        self.failed = False  # numba could not compile this model's lane: the Python path does the work
        self.p = np.asarray(kern.p, dtype=float)
        self.ex = np.asarray(kern.ex, dtype=float)
        #: with ``lazy``, a path that the fast lane traces whole in one call, from its first node to
        #: the end of the range, is kept as arrays (:attr:`whole`) instead of nodes: the path then
        #: holds only its first node, and :meth:`whole_rows` gives the rows
        self.lazy = lazy
        self.whole = None

    def want_rates(self, rates, derivatives: int) -> None:
        """Ask for the rows' rates of a path traced whole (input speed, acceleration, jerk); only a single
        2×2 block computes them in the step loop (the others take :meth:`rates` afterwards)."""
        if self.fill_run is None:
            return
        self.rr = np.array([float(rates[0]), float(rates[1]), float(rates[2]), float(int(derivatives)),
                            SINGULAR_COND])

    def whole_rates(self, R, rates):
        """``Z1, Z2, Z3, cond`` of the rows of a path traced whole from their fused rates ``R`` (n, 7)
        (:meth:`whole_rows`): the same arrays as :meth:`rates` of their positions."""
        k = self.k
        n = R.shape[0]
        Z1, Z2, Z3 = np.empty((k.nv, n)), np.empty((k.nv, n)), np.empty((k.nv, n))
        cond = np.empty(n)
        self.fill_run(R, float(rates[0]), float(rates[1]), float(rates[2]), k.iu[0], k.iu[1], k.ix, self.rr[4],
                      Z1, Z2, Z3, cond)
        return Z1, Z2, Z3, cond

    def rates(self, Z, rates, derivatives: int = 3):
        """:func:`loopsolve.kinematics.batch.rates_v` (without known Jacobians), compiled: ``Z1, Z2, Z3, cond``."""
        k = self.k
        nv, n = Z.shape
        Z1, Z2, Z3 = np.empty((nv, n)), np.empty((nv, n)), np.empty((nv, n))
        cond = np.empty(n)
        if self.rates_run is None:  # several blocks: the vectorized rates of the Python engine
            return rates_v(k.ck, Z, rates, derivatives=derivatives)
        if _compiled(self.rates_run, self, np.ascontiguousarray(Z, dtype=float), float(rates[0]), float(rates[1]),
                     float(rates[2]), self.p, k.iu[0], k.iu[1], k.ix, int(derivatives), SINGULAR_COND, Z1, Z2, Z3,
                     cond) is None and self.failed:
            return rates_v(k.ck, Z, rates, derivatives=derivatives)
        return Z1, Z2, Z3, cond

    def start(self, x: float, *, mode=None, guess=None, settings=None):
        """The sweep's start ``(z, residual, n_iter)`` at input ``x`` by the compiled Newton, or None.

        The common case of :func:`loopsolve.solve.start_position` — no ``mode``, every unknown
        guessed, Newton from the guesses converging without regularization or stall into the mode
        the guesses name, with the unknown angles within (−π, π] — by the same damped Newton
        (:mod:`loopsolve.kinematics.newton`), compiled. None for everything else: the caller then runs
        ``start_position``, which decides (other modes, warnings, errors) as always.
        """
        if mode is not None or self.start_run is None:
            return None
        ck, k = self.k.ck, self.k
        settings = settings if settings is not None else Newton()
        if guess is None:  # the model's own guesses: the same for every call (per kernel)
            base = _GUESSES.get(k)
            if base is None:
                g0 = guess_pose(ck, 0.0)
                follows = g0 is not None and not np.array_equal(g0, guess_pose(ck, 1.0))
                base = _GUESSES[k] = (g0, follows, initial_z(ck, warn=False))
            g0, follows, z0 = base
            if g0 is None:
                return None
            zg = g0.copy()
            if follows:  # the input has no guess of its own: the pose is at x
                zg[k.ix] = x
            z = z0.copy()
        else:
            zg = guess_pose(ck, x, guess=guess)
            z = initial_z(ck, guess=guess, warn=False)
        if zg is None or not np.all(np.isfinite(zg)):
            return None
        z[k.ix] = x
        out = _compiled(self.start_run, self, zg, z, self.p, k.iu[0], k.iu[1], settings.atol * ck.scale,
                        settings.rtol, settings.max_iter)
        if out is None:
            return None
        ok, res, it = out
        if not ok:
            return None
        if any(ck.kinds[i] is Kind.ANGLE and not abs(z[i]) <= math.pi for i in k.iu):
            return None  # turns away: start_position reduces and polishes
        return z, float(res), int(it)

    def _config(self, tracer, closing: bool, start_sig: str):
        k, c, g = self.k, tracer.c, tracer.g
        f = np.empty(F_SIZE)
        f[F_TOL], f[F_W0], f[F_W1], f[F_WX] = k.tol, k.wu[0], k.wu[1] if k.n > 1 else 0.0, k.wx
        f[F_COS_TURN], f[F_COS_GROW] = tracer.cos_turn, tracer.cos_grow
        f[F_MAX_STEP], f[F_MIN_STEP], f[F_NATURAL_MIN] = c.max_step, c.min_step, c.natural_min
        f[F_TRUST], f[F_RHO_TOUCH], f[F_NEAR] = TRUST, RHO_TOUCH, NEAR_SINGULAR
        f[F_G_START], f[F_G_STEP], f[F_G_LO], f[F_G_HI] = g.start, g.step, g.lo, g.hi
        f[F_DEG0], f[F_DEG1] = g.deg if g.deg is not None else (0.0, 0.0)
        f[F_ROUNDOFF] = ROUNDOFF
        iv = np.array([k.iu[0], k.iu[1] if k.n > 1 else -1, k.ix, c.max_iter, 1 if tracer.land else 0, g.kmin, g.kmax,
                       0 if g.deg is None else 1, 1 if closing else 0, mask_of_sig(start_sig)],
                      dtype=np.int64)
        return f, iv

    def advance(self, tracer, path, prev_natural, h: float, folds: int, start_sig: str):
        """Regular natural steps from the last node of ``path`` (appended to it).

        Returns ``(h, prev_natural, natural, stop)``: the step length, the previous natural
        node and whether the next step is natural, as the Python loop would have them after the
        same steps, and ``stop`` when the range end was reached.
        """
        k = self.k
        nodes, seg_sig = path.nodes, path.seg_sig
        f, iv = self._config(tracer, tracer.through and folds > 0, start_sig)
        natural = True
        first_x = nodes[-1].z[k.ix]
        g = tracer.g
        whole = self.lazy and len(nodes) == 1  # may trace the whole path in one call
        while True:
            a = nodes[-1]
            cap = min(tracer.c.max_nodes + 1 - len(nodes), 2 * (g.kmax - g.kmin) + 4096 if whole else 4096)
            if cap <= 0:
                break
            if a.rho is None:
                a.rho = k.rho(a.z, a.J if a.J is not None else k.jac_f(a.z, k.p))
            pn = prev_natural
            has_prev = pn is not None and pn.sig == a.sig and abs(pn.t[k.n]) > 0.1
            pt = np.asarray(pn.t if has_prev else a.t, dtype=float)
            xp = pn.z[k.ix] if has_prev else 0.0
            oz = np.empty((cap, k.nv))
            ot = np.empty((cap, k.n + 1))
            oj = np.empty((cap, k.n * k.n))
            of = np.empty((cap, 2))
            oi = np.empty((cap, 2), dtype=np.int64)
            rr = self.rr if whole else _NO_RATES
            orr = np.empty((cap + 1 if rr[3] > 0 else 1, 7))
            out = _compiled(self.run, self, np.asarray(a.z, dtype=float), np.asarray(a.t, dtype=float),
                            mask_of_sig(a.sig), float(a.rho), has_prev, pt, float(xp), float(h),
                            self.p, self.ex, f, self.sf, iv, oz, ot, oj, of, oi, rr, orr)
            if out is None:
                return h, prev_natural, natural, False  # the Python tracer goes on from here
            count, status, h = out
            self.steps += int(count)
            if whole and status == END:
                self.whole = (oz[:count], of[:count, 0], oi[:count], orr[:count + 1] if rr[3] > 0 else None)
                if tracer.bar is not None:
                    tracer.bar.update(len(g.crossed(first_x, oz[count - 1, k.ix])))
                return h, prev_natural, natural, True
            whole = False
            if count:
                zs, ts, js, fs, gi = oz[:count].tolist(), ot[:count].tolist(), oj[:count].tolist(), \
                    of[:count].tolist(), oi[:count].tolist()
                sig = a.sig
                new = [Node(z, t, sig, grid=g if g != NOGRID else None, residual=r, n_iter=it, J=J, rho=rho)
                       for z, t, J, (r, rho), (g, it) in zip(zs, ts, js, fs, gi)]
                prev_natural = nodes[-1] if count == 1 else new[-2]
                nodes.extend(new)
                seg_sig.extend([sig] * count)
            if status == FULL:
                continue
            if status == ARC:
                natural, prev_natural = False, None
            break
        if tracer.bar is not None:
            tracer.bar.update(len(tracer.g.crossed(first_x, nodes[-1].z[k.ix])))
        return h, prev_natural, natural, status == END

    def whole_rows(self, first):
        """Rows of a path traced whole (:attr:`whole`): ``(ks, node, Z, res, its, R)`` in path order, the
        grid indices, node numbers along the path, positions ``(nvar, N)``, residuals, iterations
        and the rows' fused rates ``(N, 7)`` (None unless :meth:`want_rates` asked for them).

        Every natural step lands on the next grid value within its reach, so the grid values the
        path crosses are exactly its nodes with a grid index (and the first node when it has one).
        """
        oz, res, oi, orr = self.whole
        R = None
        if oi[:, 0].min(initial=0) != NOGRID:  # the usual case: every node is a row
            ks, Z, r, its, node = oi[:, 0], oz.T, res, oi[:, 1], np.arange(1, len(oz) + 1)
            if orr is not None:
                R = orr if first.grid is not None else orr[1:]
        else:
            on = np.flatnonzero(oi[:, 0] != NOGRID)
            ks, Z, r, its, node = oi[on, 0], oz[on].T, res[on], oi[on, 1], on + 1
            if orr is not None:
                R = orr[np.concatenate(([0], on + 1))] if first.grid is not None else orr[on + 1]
        if first.grid is None:
            return ks, node, np.ascontiguousarray(Z), r, its, R
        n = len(ks) + 1
        ks1, node1, Z1, r1, its1 = (np.empty(n, dtype=np.int64), np.empty(n, dtype=np.int64), np.empty((Z.shape[0], n)),
                                    np.empty(n), np.empty(n, dtype=np.int64))
        ks1[0], node1[0], Z1[:, 0], r1[0], its1[0] = first.grid, 0, first.z, first.residual, first.n_iter
        ks1[1:], node1[1:], Z1[:, 1:], r1[1:], its1[1:] = ks, node, Z, r, its
        return ks1, node1, Z1, r1, its1, R
