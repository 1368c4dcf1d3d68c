"""Batched evaluation of many candidate designs for synthesis: positions at the targets, residuals, Jacobians.

One :class:`Batch` wraps a compiled model and the list of varied parameters. Every method takes
``P``, the ``(npar, D)`` matrix of internal parameter values of D designs (one column each, see
:func:`loopsolve.design.lockstep.param_matrix`), and works on all columns at once with the generated
``*_v`` kernels, as the lockstep study does:

* :meth:`Batch.assemble` — the position at one input value per design, *in a named mode*:
  block by block in solve order, Newton from several starts (the guesses, and the guesses'
  angles turned by quarter turns, lengths ± the design's scale), keeping per design the first
  converged root whose block-determinant sign is the one asked for. A design with no such
  root is ``assembly``-defective. A root is never taken from a complex number or forced real.
* :meth:`Batch.follow` — natural-parameter continuation from there through the next input
  values (per design), in substeps of at most ``hmax``: tangent predictor, Newton corrector;
  a design whose corrector fails (a limit: the input cannot go on), whose block signs change
  (a branch/change point) or whose blocks become near-singular stops there and is marked.
  What it reaches is one continuous motion in one mode — a conservative proxy of the tracker,
  which certifies the final design (:mod:`loopsolve.design.synthesis.certificate`).
* :meth:`Batch.residuals` / :meth:`Batch.jacobian` — the task's residual vector at the
  targets and its exact derivative: ∂q/∂p = −Φ_q⁻¹ Φ_p (implicit function theorem, Φ_p from
  :mod:`loopsolve.design.sensitivity`), ∂q/∂x = Φ_q⁻¹ b₁ for free input values, and the explicit
  ∂P/∂p of a point from a generated kernel (sympy once, cached like the other kernels).

The hot loops — :meth:`Batch.follow` after its start and the block Newton of :meth:`Batch.assemble` —
run compiled where numba is installed (``follow_run`` and ``block_newton_run`` of
:mod:`loopsolve.kinematics.numba_engine.lockstep_kernel`, in the model's numba module): the same
operations design by design, so the two agree to round-off (``tests/design/test_synthesis_compiled.py``);
numpy stays the reference and the fallback. Which one runs: :func:`follow_engine` (``LOOPSOLVE_ENGINE``;
``auto`` once the process has done enough of this work to pay numba's import).
"""

from __future__ import annotations

import itertools
import math
import threading

import numpy as np

from ..designops import DesignOps, design_scale, param_matrix
from ...kinematics.solve import initial_z
from ...model.units import Kind

__all__ = ["Batch", "points_p_module", "follow_engine", "FOLLOW_AUTO_CELLS"]

#: a design whose scaled block regularity (≈ 2/cond) drops below this is stopped (search only)
REGULAR_MIN = 1e-4
#: ... or whose first corrector step exceeds this (scaled units)
FIRST_CORRECTION = 0.3
_TOL = 1e-11

#: under ``engine="auto"`` :meth:`Batch.follow` runs compiled once the traces of this process have asked for
#: this many designs × substeps (a rent-or-buy rule, as the tracer's ``AUTO_ROWS``): numpy costs 4–10 µs per
#: design-substep (the ellipse / five-point benchmarks of issue 32), the compiled trace ~0.7 µs, and importing
#: numba and loading the model's cached ``follow_run`` ~0.8 s CPU. A one-off prescribed-timing run (~90 000)
#: stays in numpy; a free-timing run (~2.5·10⁷) switches within its first second. The first run of a model
#: with a new numba module also compiles it (~10 s, once: cached on disk).
FOLLOW_AUTO_CELLS = 100_000
_FOLLOW_SEEN = [0]
_FOLLOW_LOCK = threading.Lock()


def follow_engine(ck, engine, cells: int) -> str:
    """The engine of a :meth:`Batch.follow` of ``cells`` designs × substeps: ``"numba"`` or ``"python"`` (numpy).

    ``engine`` as for :func:`loopsolve.sweep` (None: ``$LOOPSOLVE_ENGINE``, else ``"auto"``); ``"auto"`` is numba
    when it is installed, the model has a compiled lane and the traces of this process, this one included,
    have asked for :data:`FOLLOW_AUTO_CELLS` designs × substeps (numba is not imported before).
    """
    from ...kinematics.numba_engine import jit
    from ...kinematics.scalar_solver import kernel_of

    kern = kernel_of(ck)
    name, _ = jit.engine_name(engine)
    if name != "auto":
        return jit.engine_for(name, kern, cells)
    if not jit.has_lane(kern):
        return "python"
    with _FOLLOW_LOCK:
        _FOLLOW_SEEN[0] += int(cells)
        worth = _FOLLOW_SEEN[0] >= FOLLOW_AUTO_CELLS
    return "numba" if worth and jit.use_numba(name) else "python"


def generate_points_p_source(kin) -> str:
    """Python source of ``points_p_v(z, p)``: ∂(x, y of every point)/∂p, row-major (coordinate, parameter)."""
    from ..sensitivity import parameter_derivative_source

    coords = [c for name in kin.points for c in kin.points[name][0]]
    return parameter_derivative_source(kin, coords, func="points_p_v", count="NCOORD",
                                       what="dPoints/dp (row-major: coordinate, parameter)")


def points_p_module(ck):
    """The compiled ∂points/∂p module of ``ck`` (derived with sympy on first use, then cached)."""
    from ..sensitivity import generated_module

    return generated_module(ck, "ptsp", generate_points_p_source, "points_p_v")


class Batch:
    """Vectorized evaluations of one model for synthesis (see the module docstring).

    Parameters
    ----------
    ck : CompiledKinematics
    names : sequence of str
        The varied parameters (the columns of ``V`` in :meth:`params`).
    """

    def __init__(self, ck, names):
        from ..sensitivity import fused_module

        self.ck = ck
        self.mech = ck.mechanism
        self.names = tuple(names)
        self.ops = DesignOps(ck)
        self.ops.fused = fused_module(ck)
        self.iu, self.ix = self.ops.iu, self.ops.ix
        self.nv = len(ck.variables)
        pnames = [p.name for p in self.mech.parameters]
        self.pidx = [pnames.index(n) for n in self.names]
        deg = self.mech.units.angle == "deg"
        #: d(internal value)/d(model value) of every varied parameter
        self.pconv = np.array([math.pi / 180 if deg and self.mech.parameters[i].kind is Kind.ANGLE else 1.0
                               for i in self.pidx])
        z0 = initial_z(ck, warn=False)
        xg = self.mech.variable(ck.inputs[0]).guess
        z0[self.ix] = 0.0 if xg is None else xg
        self.z0 = z0
        self.x_guess = float(z0[self.ix])
        self.is_len = self.ops.is_len
        self.input_is_angle = ck.kinds[self.ix] is Kind.ANGLE
        #: the engine of :meth:`follow` (:func:`follow_engine`; None: ``$LOOPSOLVE_ENGINE``, else ``"auto"``)
        self.engine = None

    # ------------------------------------------------------------------ parameters and modes
    def params(self, V) -> np.ndarray:
        """``(npar, D)`` internal parameter matrix of the designs ``V`` ``(D, k)`` (model units)."""
        return param_matrix(self.ck, self.names, np.atleast_2d(np.asarray(V, dtype=float)))

    def scale(self, P) -> np.ndarray:
        return design_scale(self.ck, P)

    def guessed_signs(self, P) -> np.ndarray:
        """``(nb, D)`` signs of the block determinants at the declared guesses (the mode the guesses name)."""
        Z = np.repeat(self.z0[:, None], P.shape[1], axis=1)
        with np.errstate(all="ignore"):
            sig, _ = self.ops.signs_and_regularity(self.ops.jac(Z, P), self.scale(P))
        return sig

    def all_signs(self) -> list[np.ndarray]:
        """Every combination of block signs (each ``(nb,)``) that can occur: the modes a search may try.

        A block whose determinant has one sign at 64 random positions (e.g. a slider's 1×1
        block, linear in its length) keeps that sign only.
        """
        if getattr(self, "_all_signs", None) is None:
            rng = np.random.default_rng(0)
            N = 64
            Z = np.repeat(self.z0[:, None], N, axis=1)
            sc = self.ck.scale
            for a, i in enumerate(self.iu):
                Z[i] = rng.uniform(-sc, sc, N) if self.is_len[a] else rng.uniform(-math.pi, math.pi, N)
            Z[self.ix] = rng.uniform(-math.pi, math.pi, N) if self.input_is_angle else rng.uniform(-sc, sc, N)
            P = np.repeat(np.asarray(self.ck.p, dtype=float)[:, None], N, axis=1)
            with np.errstate(all="ignore"):
                sig, _ = self.ops.signs_and_regularity(self.ops.jac(Z, P), np.full(N, sc))
            choices = []
            for row in sig:
                seen = sorted({float(v) for v in row if v != 0}, reverse=True)
                choices.append(seen or [1.0, -1.0])
            self._all_signs = [np.array(c, dtype=float) for c in itertools.product(*choices)]
        return self._all_signs

    # ------------------------------------------------------------------ positions
    def _starts(self, cols, Z, scale, second: bool = False):
        """Starting values of a block's unknowns: ``(S, len(cols), D)``.

        First pass: the guesses and their half turns (lengths: the guess and ± the scale);
        second pass (for the columns the first left without a root): quarter turns as well.
        """
        choices = []
        for c in cols:
            g = Z[self.iu[c]]
            if self.is_len[c]:
                choices.append([g, scale, -scale, 0.25 * scale] if second else [g, -scale])
            else:
                choices.append([g + k * (math.pi / 2) for k in (0, 1, 2, 3)] if second else [g, g + math.pi])
        combos = list(itertools.product(*[range(len(ch)) for ch in choices]))
        if second:
            first = set(itertools.product(*[(0, 2) if not self.is_len[c] else (0, 2) for c in cols]))
            combos = [c for c in combos if c not in first] or combos
        if len(combos) > 64:
            rng = np.random.default_rng(0)
            combos = [combos[0]] + [combos[i] for i in rng.choice(len(combos), 63, replace=False)]
        return np.array([[choices[a][k] for a, k in enumerate(cmb)] for cmb in combos])

    def assemble(self, P, x, signs) -> tuple[np.ndarray, np.ndarray]:
        """Positions ``(nv, D)`` at the inputs ``x`` ``(D,)`` in the block signs ``signs`` ``(nb, D)`` (0: any).

        Returns ``(Z, ok)``; ``ok`` is False where no root of the asked mode was found.
        """
        D = P.shape[1]
        scale = self.scale(P)
        Z = np.repeat(self.z0[:, None], D, axis=1)
        Z[self.ix] = x
        ok = np.ones(D, dtype=bool)
        n = self.ops.n
        with np.errstate(all="ignore"):
            for b, (eqs, cols) in enumerate(self.ops.blocks):
                found, some = self._assemble_block(Z, P, scale, b, eqs, cols, signs, np.arange(D), False)
                rest = np.flatnonzero(~found & some)  # a root, but not of the asked mode: more starts
                if rest.size:
                    found[rest] = self._assemble_block(Z, P, scale, b, eqs, cols, signs, rest, True)[0]
                ok &= found
        return Z, ok

    def _assemble_block(self, Zfull, Pfull, scfull, b, eqs, cols, signs, cols_ix, second):
        """One multistart pass on block ``b`` for the designs ``cols_ix``; writes their roots into ``Zfull``."""
        n = self.ops.n
        Z, P, scale = Zfull[:, cols_ix], Pfull[:, cols_ix], scfull[cols_ix]
        D = len(cols_ix)
        if True:
            if True:
                S0 = self._starts(cols, Z, scale, second)  # (S, nc, D)
                S = S0.shape[0]
                Zs = np.tile(Z, (1, S))
                Ps = np.tile(P, (1, S))
                sc = np.tile(scale, S)
                for a, c in enumerate(cols):
                    Zs[self.iu[c]] = S0[:, a, :].reshape(-1)
                conv = self._block_newton_compiled(Zs, Ps, eqs, cols, sc)
                if conv is None:
                    conv = self._block_newton(Zs, Ps, eqs, cols, sc)
                J = self.ops.jac(Zs, Ps)
                if len(cols) == 1:
                    det = J[eqs[0] * n + cols[0]]
                elif len(cols) == 2:
                    (e0, e1), (c0, c1) = eqs, cols
                    det = J[e0 * n + c0] * J[e1 * n + c1] - J[e0 * n + c1] * J[e1 * n + c0]
                else:
                    det = np.linalg.det(np.moveaxis(np.array([[J[e * n + c] for c in cols] for e in eqs]), -1, 0))
                sgn = np.sign(det).reshape(S, D)
                conv = conv.reshape(S, D)
                want = signs[b][cols_ix][None, :]
                good = conv & ((want == 0) | (sgn == want))
                first = np.argmax(good, axis=0)
                found = good[first, np.arange(D)]
                idx = first * D + np.arange(D)
                for c in cols:
                    Zfull[self.iu[c], cols_ix] = np.where(found, Zs[self.iu[c], idx], Zfull[self.iu[c], cols_ix])
        return found, np.any(conv, axis=0)

    def _block_newton_compiled(self, Z, P, eqs, cols, scale, iters: int = 30):
        """:meth:`_block_newton` by the compiled ``block_newton_run`` of the model's numba module, or None (numpy
        runs it: the engine's choice, :func:`follow_engine`, or a block larger than 2×2)."""
        if len(cols) > 2:
            return None
        lane = self._lane(Z.shape[1])
        if lane is None:
            return None
        Zw = np.array(Z.T, dtype=float, order="C")
        lim = np.array([scale if self.is_len[c] else np.ones_like(scale) for c in cols], dtype=float)
        conv = np.zeros(Z.shape[1], dtype=bool)
        try:
            lane.block_newton_run(Zw, np.ascontiguousarray(P.T, dtype=float), np.asarray(eqs, dtype=np.int64),
                                  np.asarray(cols, dtype=np.int64), np.asarray(self.iu, dtype=np.int64), lim,
                                  np.ascontiguousarray(scale, dtype=float), int(iters), conv)
        except Exception as exc:
            self._numba_failed(exc, "assembly")
            return None
        Z[...] = Zw.T
        return conv

    def _block_newton(self, Z, P, eqs, cols, scale, iters: int = 30) -> np.ndarray:
        """Newton on one block's unknowns (the others fixed), in place; returns converged flags.

        Columns that converge or diverge drop out of the arrays the kernels are called on.
        """
        n = self.ops.n
        iu = self.iu
        eqs = list(eqs)
        lim = np.array([scale if self.is_len[c] else np.ones_like(scale) for c in cols])  # (nc, N)
        N = Z.shape[1]
        conv = np.zeros(N, dtype=bool)
        act = np.arange(N)
        Za, Pa, la = Z, P, lim
        for it in range(iters):
            F, J = self.ops.phi_jac(Za, Pa)
            F = F[eqs]
            if it == 12:  # no root near: Newton still far from closing the loop (non-assemblable) drops out
                far = np.max(np.abs(F), axis=0) > 1e-2 * la[0] * np.max(la, axis=0)
                if far.any():
                    if Za is not Z:
                        Z[:, act] = Za
                    keep = ~far
                    act = act[keep]
                    if not act.size:
                        break
                    Za, Pa, la = Z[:, act], P[:, act], lim[:, act]
                    F, J = F[:, keep], J[:, keep]
            if len(cols) == 1:
                dU = (-F[0] / J[eqs[0] * n + cols[0]])[None, :]
            elif len(cols) == 2:
                (e0, e1), (c0, c1) = eqs, cols
                a, b, c, d_ = J[e0 * n + c0], J[e0 * n + c1], J[e1 * n + c0], J[e1 * n + c1]
                det = a * d_ - b * c
                dU = np.array([(-d_ * F[0] + b * F[1]) / det, (c * F[0] - a * F[1]) / det])
            else:
                M = np.moveaxis(np.array([[J[e * n + c] for c in cols] for e in eqs]), -1, 0)
                dU = np.moveaxis(np.linalg.solve(M, -F.T[..., None])[..., 0], 0, -1)
            big = np.max(np.abs(dU) / la, axis=0)
            dU = dU / np.maximum(1.0, big)  # at most a radian (angles) or a scale (lengths) per step
            finite = np.all(np.isfinite(dU), axis=0)
            dU = np.where(finite, dU, 0.0)
            for a_, c in enumerate(cols):
                Za[iu[c]] += dU[a_]
            step = np.max(np.abs(dU) / la, axis=0)
            done = (step <= 1e-13) | ~finite
            if done.any():
                if Za is not Z:
                    Z[:, act] = Za
                conv[act[done & finite]] = True
                keep = ~done
                act = act[keep]
                if not act.size:
                    break
                Za, Pa, la = Z[:, act], P[:, act], lim[:, act]
        if Za is not Z and act.size:
            Z[:, act] = Za
        conv[act] = False
        F = self.ops.phi(Z, P)[eqs]
        return conv & np.all(np.abs(F) <= 1e-9 * scale, axis=0)

    def follow(self, Z, P, X, *, hmax: float, signs=None, stop_on_singular: bool = True):
        """Continue every design from ``Z`` (at ``X[0]``) through the inputs ``X`` ``(T, D)``.

        Returns ``(Zt, reached)``: positions ``(nv, T, D)`` (NaN past where a design stopped) and
        the number of inputs reached per design (``T`` for a design that went all the way).
        """
        T, D = X.shape
        ops = self.ops
        scale = self.scale(P)
        w = np.where(self.is_len[:, None], 1.0 / scale, 1.0)
        Zt = np.full((self.nv, T, D), np.nan)
        Z = Z.copy()
        alive = np.all(np.isfinite(Z), axis=0)
        with np.errstate(all="ignore"):
            J = ops.jac(Z, P)
            sig0, reg = ops.signs_and_regularity(J, scale)
            if signs is not None:
                alive &= np.all((signs == 0) | (sig0 == signs), axis=0)
            if stop_on_singular:
                alive &= reg >= REGULAR_MIN
            Zt[:, 0] = np.where(alive, Z, np.nan)
            reached = alive.astype(int)
            lane = self._follow_lane(X, alive, hmax)
            if lane is not None and self._follow_compiled(lane, Z, P, X, alive, sig0, scale, hmax, stop_on_singular,
                                                          Zt, reached):
                return Zt, reached
            # only the designs still going are computed on: the columns are compacted as they stop
            cols = np.flatnonzero(alive)
            Z, P, J, scale, w, sig0, X = (Z[:, cols], P[:, cols], J[:, cols], scale[cols], w[:, cols],
                                          sig0[:, cols], X[:, cols])
            alive = np.ones(cols.size, dtype=bool)
            for t in range(1, T):
                if not cols.size:
                    break
                dx = X[t] - X[t - 1]
                amax = float(np.max(np.abs(dx)))
                m = max(1, int(math.ceil(amax / hmax - 1e-9)))
                h = dx / m
                for s in range(1, m + 1):
                    zk1 = np.zeros_like(Z)
                    zk1[self.ix] = 1.0
                    Tq = ops.solve(J, ops.rhs(1, (Z, zk1), P))
                    Z = Z.copy()
                    Z[self.ix] = X[t - 1] + dx * (s / m)
                    Z[self.iu] = Z[self.iu] + Tq * h
                    done = ~alive
                    for it in range(10):
                        if it % 2 == 0:
                            F, Jn = ops.phi_jac(Z, P)
                        else:
                            F = ops.phi(Z, P)
                        dU = ops.solve(Jn, -F)
                        size = np.max(np.abs(dU * w), axis=0)
                        if it == 0:
                            alive &= np.isfinite(size) & (size <= FIRST_CORRECTION)
                        Z[self.iu] = np.where(alive & ~done, Z[self.iu] + dU, Z[self.iu])
                        done |= (size <= _TOL) | ~alive
                        if done.all():
                            break
                    alive &= done
                    J = ops.jac(Z, P)
                    sig, reg = ops.signs_and_regularity(J, scale)
                    alive &= np.all(sig == sig0, axis=0)
                    if stop_on_singular:
                        alive &= reg >= REGULAR_MIN
                    if not alive.all():
                        keep = alive
                        cols = cols[keep]
                        Z, P, J, scale, w, sig0, X = (Z[:, keep], P[:, keep], J[:, keep], scale[keep], w[:, keep],
                                                      sig0[:, keep], X[:, keep])
                        alive = np.ones(cols.size, dtype=bool)
                        dx, h = dx[keep], h[keep]
                    if not cols.size:
                        break
                Zt[:, t, cols] = Z
                reached[cols] = t + 1
        return Zt, reached

    def _follow_lane(self, X, alive, hmax):
        """The model's numba module when :meth:`follow` of these designs runs compiled (:func:`follow_engine`),
        else None."""
        if not alive.any():
            return None
        Xa = X[:, alive]
        if not np.all(np.isfinite(Xa)):
            return None  # (numpy's substep count raises on a NaN input: left to it)
        steps = np.ceil(np.max(np.abs(np.diff(Xa, axis=0)), axis=1) / hmax - 1e-9) if X.shape[0] > 1 else np.zeros(0)
        return self._lane(int(np.maximum(steps, 1).sum()) * int(alive.sum()))

    def _lane(self, cells):
        """The model's numba module when work of ``cells`` designs × substeps runs compiled (:func:`follow_engine`)."""
        if self.engine == "python" or follow_engine(self.ck, self.engine, cells) != "numba":
            return None
        from ...kinematics.numba_engine.jit import numba_module

        return numba_module(self.ck)

    def _numba_failed(self, exc, what):
        """numba could not compile ``what`` for this model: one warning, then numpy for this batch."""
        if not type(exc).__module__.startswith("numba"):
            raise exc
        from ...errors import warn

        if self.engine != "python":
            warn(f"{self.mech.source or self.mech.name}: numba could not compile the synthesis {what} "
                 f"({type(exc).__name__}); numpy runs it")
        self.engine = "python"

    def _follow_compiled(self, lane, Z, P, X, alive, sig0, scale, hmax, stop_on_singular, Zt, reached) -> bool:
        """:meth:`follow` after its start by the compiled ``follow_run`` of the model's numba module (``Zt``,
        ``reached`` filled in place). False when numba cannot compile it for this model (one warning; numpy runs)."""
        ops = self.ops
        nb = len(ops.blocks)
        bs = np.array([len(c) for _, c in ops.blocks], dtype=np.int64)
        be = np.array([(e[0], e[-1]) for e, _ in ops.blocks], dtype=np.int64).reshape(nb, 2)
        bc = np.array([(c[0], c[-1]) for _, c in ops.blocks], dtype=np.int64).reshape(nb, 2)
        cf = np.array([FIRST_CORRECTION, _TOL, REGULAR_MIN if stop_on_singular else -math.inf])
        ok = np.array(alive, dtype=bool)
        got = np.zeros(len(ok), dtype=np.int64)
        try:
            lane.follow_run(np.array(Z.T, dtype=float, order="C"), np.ascontiguousarray(P.T, dtype=float),
                            np.ascontiguousarray(X, dtype=float), ok, np.ascontiguousarray(sig0, dtype=float),
                            np.ascontiguousarray(scale, dtype=float), np.asarray(self.is_len, dtype=np.bool_),
                            float(hmax), cf, int(self.ix), np.asarray(self.iu, dtype=np.int64), bs, be, bc, Zt, got)
        except Exception as exc:
            self._numba_failed(exc, "trace")
            return False
        np.maximum(reached, got, out=reached)
        return True

    def newton(self, Z, P, signs, iters: int = 12):
        """Newton on all unknowns from ``Z`` (a nearby solution, e.g. the last polish step's); in place.

        Returns the flags of the columns that converged with the block signs ``signs`` ``(nb, N)``.
        """
        ops = self.ops
        scale = self.scale(P)
        w = np.where(self.is_len[:, None], 1.0 / scale, 1.0)
        conv = np.zeros(Z.shape[1], dtype=bool)
        with np.errstate(all="ignore"):
            for _ in range(iters):
                F, J = ops.phi_jac(Z, P)
                dU = ops.solve(J, -F)
                size = np.max(np.abs(dU * w), axis=0)
                if not np.all(np.isfinite(size)) or np.any(size > 0.5):
                    return conv
                Z[self.iu] += dU
                if np.all(size <= 1e-13):
                    break
            F, J = ops.phi_jac(Z, P)
            sig, reg = ops.signs_and_regularity(J, scale)
            conv = np.all(np.abs(F) <= 1e-10 * scale, axis=0) & np.all((signs == 0) | (sig == signs), axis=0)
        return conv

    def reassemble(self, Z, P, x, signs, iters: int = 12, multistart: bool = True):
        """Positions ``(nv, D)`` at the inputs ``x`` ``(D,)`` from nearby ones ``Z`` (the same designs a step ago).

        Newton on all unknowns per column from ``Z`` (a column whose correction exceeds half a
        radian or scale, or is not finite, stops there), then, for the columns it left without a
        root of the block signs ``signs``, the multistart :meth:`assemble` (``multistart``; without it they are
        returned not ok). Returns ``(Z, ok)`` as
        :meth:`assemble`. Why: an optimizer's next trial design is a small step from the last one,
        and its position there is a few Newton steps from the last position, where :meth:`assemble`
        would run Newton from many starts per block.
        """
        ops = self.ops
        Z = np.array(Z, dtype=float)
        Z[self.ix] = x
        D = Z.shape[1]
        scale = self.scale(P)
        w = np.where(self.is_len[:, None], 1.0 / scale, 1.0)
        going = np.all(np.isfinite(Z), axis=0)
        with np.errstate(all="ignore"):
            for _ in range(iters):
                if going.all():  # (every column: no gather and scatter; the same arithmetic)
                    F, J = ops.phi_jac(Z, P)
                    dU = ops.solve(J, -F)
                    size = np.max(np.abs(dU * w), axis=0)
                    bad = ~np.isfinite(size) | (size > 0.5)
                    Z[self.iu] += np.where(bad, 0.0, dU)
                    going[bad | (size <= 1e-13)] = False
                    continue
                a = np.flatnonzero(going)
                if not a.size:
                    break
                Za, Pa = Z[:, a], P[:, a]
                F, J = ops.phi_jac(Za, Pa)
                dU = ops.solve(J, -F)
                size = np.max(np.abs(dU * w[:, a]), axis=0)
                bad = ~np.isfinite(size) | (size > 0.5)
                Z[np.ix_(self.iu, a[~bad])] += dU[:, ~bad]
                going[a[bad | (size <= 1e-13)]] = False
            F, J = ops.phi_jac(Z, P)
            sig, _ = ops.signs_and_regularity(J, scale)
            ok = (np.all(np.abs(F) <= 1e-10 * scale, axis=0) & np.all((signs == 0) | (sig == signs), axis=0)
                  & np.all(np.isfinite(Z), axis=0))
        rest = np.flatnonzero(~ok)
        if rest.size and multistart:
            Zr, okr = self.assemble(P[:, rest], np.asarray(x, dtype=float)[rest], signs[:, rest])
            Z[:, rest] = Zr
            ok[rest] = okr
        return Z, ok

    # ------------------------------------------------------------------ residuals
    def points(self, Z, P) -> np.ndarray:
        """``(npts, 2, N)`` point coordinates at positions ``Z`` ``(nv, N)``."""
        v = np.asarray(self.ops.points(0, [Z], P), dtype=float)
        return np.broadcast_to(v.reshape(len(self.ck.points), 2, -1), (len(self.ck.points), 2, Z.shape[1]))

    def sensitivities(self, Z, P):
        """``(dq/dp (n, k, N), dq/dx (n, N))`` at positions ``Z`` ``(nv, N)`` (internal units, per varied parameter)."""
        from ..sensitivity import phi_p_v

        J = self.ops.jac(Z, P)
        Fp = phi_p_v(self.ck, Z, P)
        N, k = Z.shape[1], len(self.pidx)
        zk1 = np.zeros_like(Z)
        zk1[self.ix] = 1.0
        # every right-hand side (one per varied parameter, and the input's) in one block solve of (k + 1)·N columns
        B = np.concatenate([-Fp[:, list(self.pidx), :].reshape(Fp.shape[0], k * N), self.ops.rhs(1, (Z, zk1), P)],
                           axis=1)
        Q = self.ops.solve(np.tile(J, (1, k + 1)), B)
        return Q[:, :k * N].reshape(-1, k, N), Q[:, k * N:]

    def point_derivatives(self, Z, P, point: int, dq_dp, dq_dx):
        """``(dPoint/dp (2, k, N), dPoint/dx (2, N))`` of point number ``point``."""
        N = Z.shape[1]
        k = len(self.pidx)
        # the point's velocity along every parameter's tangent and the input's, in one call on (k + 1)·N columns
        V = np.zeros((Z.shape[0], (k + 1) * N))
        V[self.iu] = np.concatenate([dq_dp.reshape(dq_dp.shape[0], k * N), dq_dx], axis=1)
        V[self.ix, k * N:] = 1.0
        v = np.asarray(self.ops.points(1, [np.tile(Z, (1, k + 1)), V], np.tile(P, (1, k + 1))), dtype=float)
        v = np.broadcast_to(v.reshape(-1, 2, (k + 1) * N)[point], (2, (k + 1) * N))
        out = v[:, :k * N].reshape(2, k, N).copy()
        dx = v[:, k * N:]
        mod = points_p_module(self.ck)
        vals = mod.points_p_v(Z, P)
        npar = mod.NPARAM
        sel = [vals[(2 * point + c) * npar + ip] for c in range(2) for ip in self.pidx]  # scalars and (N,) arrays
        out += np.array(np.broadcast_arrays(np.zeros(N), *sel)[1:], dtype=float).reshape(2, k, N)
        return out, dx
