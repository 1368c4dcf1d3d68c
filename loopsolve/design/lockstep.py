"""Lockstep continuation: one sweep of many designs at once, on the compiled numpy kernels.

The generated ``*_v`` functions broadcast over their last axis, so a parameter vector ``P``
of shape ``(npar, D)`` evaluates D designs in one call. :func:`sweep_chunk` follows every
design of a chunk along the same input values:

1. **Start.** Newton from the declared guesses at the guesses' input value, every design at
   once; a design whose solution does not have the signature of Φ_q's blocks *at the guesses*,
   evaluated with that design's parameters (the mode the guesses name, as
   :func:`loopsolve.solve.start_position` asks for), is handed off; then natural-parameter
   continuation to the start of the range.
2. **Continuation** over the output grid in internal substeps of at most 1° (or 1 % of the
   length scale; 2° on the way from the guesses to the start): Taylor predictor from the
   tangent dq/dx = Φ_q⁻¹ b₁ (and its change over the previous step), Newton corrector (a fused
   Φ/Φ_q kernel, chord iterations) to round-off with converged designs frozen. Rates and points
   of every output row are computed for all designs at once with the row's Jacobian.
3. **Checks at every substep, per design**: the corrector converges in a few iterations with
   a small first correction, the scaled slope |dq/dx| stays below ``FOLD_SLOPE`` (a limit is
   near), the regularity (≈ 2/cond of each scaled block) stays above ``REGULAR_MIN`` (a
   change point or a dead centre is near), and the signs of the block determinants (the
   assembly mode) never change.
4. **Designs that leave the path.** For a model whose blocks the closed-form assembly test of
   :mod:`loopsolve.kinematics.assemblable` recognizes (dyads of two angles, single unknowns),
   the chunk decides at once which designs cannot be assembled at the start and locates their
   nearest assemblable inputs (:func:`_not_assemblable`), and locates the limit position of
   designs that left the path approaching one, filling their rows up to it
   (:func:`loopsolve.design.lockstep_limits.locate_limits`; it also starts the designs the path did not
   bring from the guesses to the start, and completes those dropped for a steep slope): status,
   stop, nearest inputs, events, mode and rows as their single sweep gives them (the limits
   located by bisection to round-off, the tracker's to 1e-9).
5. **Hand-off.** Any other design for which a check fails — near a change point, a signature
   change, a start that cannot be decided, a model the test does not recognize — is not
   guessed at: it is swept alone by the public :func:`loopsolve.sweep` with its own parameter
   values, which gives its rows, events and status. The checks are far more conservative than
   the tracker's own (which locates folds to round-off), so every design the lockstep path
   keeps is one whose single sweep is a regular path in one mode.

Mechanisms with a solve-order block larger than 2×2 (where a signature need not single out
one root) are swept design by design.

**Engines.** Where the numba engine is chosen for the chunk (``engine=``, ``LOOPSOLVE_ENGINE``, or
``"auto"`` by :func:`~loopsolve.kinematics.numba_engine.jit.engine_for` on the chunk's designs × rows;
the model needs a compiled lane), steps 2 and 3 run compiled, design by design in one loop
(:mod:`loopsolve.kinematics.numba_engine.lockstep_kernel`, in the model's numba module with its
generated functions): the same predictor, corrector, checks and rows as the numpy loop here, which
stays the engine without numba (and with ``engine="python"``); the two agree to round-off. The
start (step 1), the limits and the hand-offs are the same code for both.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from ..errors import AssemblyError, LoopsolveWarning, ModelError, SingularPositionError, SolveError
from ..model.units import Kind
from .designops import REGULAR_MIN, DesignOps, design_scale, display_value_of, param_matrix

__all__ = ["sweep_chunk", "lockstep_engine", "AUTO_CELLS", "AUTO_CHUNK", "FOLD_SLOPE", "REGULAR_MIN", "Chunk"]

#: a design is handed to the single-design sweep when a scaled |dq/dx| exceeds this
FOLD_SLOPE = 3.0
#: ... or the first corrector step is larger than this (scaled units)
FIRST_CORRECTION = 0.05
#: a design missing assembly at the start by less than this (relative, see AssemblyTest.at) is the single sweep's to decide
_START_MARGIN = 1e-8
#: a corrector step smaller than this (scaled) leaves an error ~ its square: converged
_CONVERGED = 1e-11
_SUB_ANGLE = math.radians(1.0)


class Chunk:
    """Rows of D designs on K grid points (internal units).

    ``Z[0..d]`` are positions and their time derivatives up to ``derivatives``, ``(nv, K, D)``,
    NaN where a design has no row; ``points`` ``(d+1, P, 2, K, D)`` the points of the lockstep
    designs (the others' are computed from their rows afterwards); ``status``, ``stop``, ``events``,
    ``nearest``, ``mode`` per design; ``lockstep`` marks the designs the vectorized path solved;
    ``warnings`` the warnings of the designs swept alone (summarized per study by the caller).
    """

    def __init__(self, nv, D, K, npts=0, derivatives=3, design_major=False):
        # rows are written for every design by the lockstep loop; the rest is set to NaN after it.
        # ``design_major``: each design's rows contiguous in memory (the compiled lockstep writes design by
        # design: in the numpy loop's layout every value it stores is a cache line of its own)
        if design_major:
            self.rows = np.moveaxis(np.empty((D, derivatives + 1, nv, K)), 0, -1)
            self.points = np.moveaxis(np.empty((D, derivatives + 1, npts, 2, K)), 0, -1) if npts else None
        else:
            self.rows = np.empty((derivatives + 1, nv, K, D))
            self.points = np.empty((derivatives + 1, npts, 2, K, D)) if npts else None
        self.Z = list(self.rows)  # views of one array ``rows`` (d+1, nv, K, D) (the compiled lockstep fills it)
        self.filled = 0  # grid rows written by the lockstep loop
        self.status = np.array(["ok"] * D, dtype=object)
        self.stop = np.full(D, np.nan)
        self.events = np.array([""] * D, dtype=object)
        self.nearest = np.array([""] * D, dtype=object)
        self.mode = np.array([""] * D, dtype=object)
        self.lockstep = np.zeros(D, dtype=bool)
        self.warnings: list[tuple[int, str]] = []  # (design in the chunk, message) of the single sweeps


def _plain(v):
    """A number given as a number or a plain numeric string (no unit), else None."""
    try:
        return float(v)
    except (TypeError, ValueError):
        return None


def grid_values(ck, start, stop, step, *, max_rows=None, max_rows_error=None):
    """The sweep's output grid: internal values ``(K,)`` and display values ``(K,)``.

    With ``max_rows``, a grid of more rows raises ``max_rows_error(rows)`` before it is made.
    """
    from ..kinematics.solve import display_value, input_value

    name = ck.inputs[0]
    kind = ck.kinds[ck.index(name)]
    deg = kind is Kind.ANGLE and ck.mechanism.units.angle == "deg"
    x0, x1 = input_value(ck, start, name, reduce=False), input_value(ck, stop, name, reduce=False)
    if isinstance(step, str) and _plain(step) is not None:
        step = _plain(step)
    if isinstance(step, str):
        h = input_value(ck, step, name, reduce=False)
        hd = display_value(ck, h, name) if deg else h
    else:
        hd = float(step)
        h = math.radians(hd) if kind is Kind.ANGLE and ck.mechanism.units.angle == "deg" else hd
    if h == 0 or not math.isfinite(h):
        from ..errors import ModelError

        raise ModelError("--step must be a nonzero number")
    h = math.copysign(abs(h), x1 - x0) if x1 != x0 else abs(h)
    count = (x1 - x0) / h
    if max_rows is not None:  # counted before anything is made
        rows = math.floor(count + 1e-9) + 1 if math.isfinite(count) else math.inf
        if not rows <= max_rows:
            raise max_rows_error(rows)
    n = max(int(math.floor(count + 1e-9)), 0)
    k = np.arange(n + 1)
    if not deg:
        xs = x0 + h * k
        return xs, xs.copy()
    d0 = _plain(start)
    d0 = math.degrees(x0) if d0 is None else d0
    dh = math.copysign(abs(hd), x1 - x0) if x1 != x0 else abs(hd)
    v = d0 + dh * k
    from ..kinematics.grid import exact_radians  # the single sweep's grid rule, so rows agree to the bit

    return exact_radians(v), v


def _no_path(message: str, mech) -> str:
    """A per-design message without the leading model path (or name) and no machine path in it.

    The Dataset names the model once (``attrs``); a path inside the message keeps its file name.
    """
    import os

    message = message.removeprefix(f"{mech.name}: ")
    if not mech.source:
        return message
    src = str(mech.source)
    return message.removeprefix(src + ": ").replace(src, os.path.basename(src))


def _sweep_one(mech, names, row, start, stop, step, speed, accel, jerk, mode, derivatives, ch, j, xs_disp,
               engine=None):
    """The single sweep of design j, or None with its status and events set in ``ch``."""
    def text(exc, default):
        return _no_path(str(exc).splitlines()[0], mech) if str(exc) else default

    try:
        m = mech.with_parameters(**{n: float(v) for n, v in zip(names, row)})
    except ModelError as exc:  # a check of the model file that the design fails
        ch.status[j] = "invalid"
        ch.events[j] = text(exc, "invalid")
        return None
    try:
        return m.sweep(start, stop, step, speed=speed, accel=accel, jerk=jerk, mode=mode,
                       derivatives=derivatives, progress=False, engine=engine)
    except AssemblyError as exc:
        ch.status[j] = "not-assemblable"
        ch.nearest[j] = ", ".join(f"{v:.10g}" for v in exc.nearest)
        ch.events[j] = text(exc, "not-assemblable")
    except SingularPositionError as exc:
        ch.status[j] = "singular"
        ch.events[j] = text(exc, "singular")
    except SolveError as exc:
        ch.status[j] = "failed"
        ch.events[j] = f"{type(exc).__name__}: {text(exc, '')}"
    ch.stop[j] = xs_disp[0]
    return None


def _single(mech, names, row, start, stop, step, speed, accel, jerk, mode, derivatives, ch, j, xs_disp, engine=None):
    """Sweep design j alone with the public sweep and put its rows, events and status into ``ch``.

    Its loopsolve warnings (a stop at a limit ...) go to ``ch.warnings`` without the model
    file's path, for one summary per study; other warnings go on as they came.
    """
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sw = _sweep_one(mech, names, row, start, stop, step, speed, accel, jerk, mode, derivatives, ch, j, xs_disp,
                        engine)
    for w in caught:
        if issubclass(w.category, LoopsolveWarning):
            ch.warnings.append((j, _no_path(str(w.message), mech)))
        else:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    if sw is None:
        return
    ck = sw.compiled
    if len(sw):
        xd = np.asarray(sw.columns[ck.inputs[0]], dtype=float)
        step_d = xs_disp[1] - xs_disp[0] if len(xs_disp) > 1 else 1.0
        k = np.rint((xd - xs_disp[0]) / step_d).astype(int)
        ok = (k >= 0) & (k < len(xs_disp))
        for a, arr in enumerate((sw.z, sw.z1, sw.z2, sw.z3)[: len(ch.Z)]):
            ch.Z[a][:, k[ok], j] = arr[ok].T
    ch.mode[j] = sw.mode
    ev = [e for e in sw.events]
    ch.events[j] = "; ".join(f"{e.kind.value}@{e.input:.10g}" for e in ev)
    lim = [e for e in ev if e.kind.value == "limit"]
    if lim:
        ch.status[j] = "limit"
        ch.stop[j] = lim[0].input


def sweep_chunk(mech, names, values, start, stop, step, *, speed=None, accel=None, jerk=None, mode=None,
                derivatives: int = 3, method: str = "lockstep", engine: str | None = None
                ) -> tuple[Chunk, object, np.ndarray]:
    """Sweep the designs ``values`` ``(D, k)`` of the parameters ``names``; returns ``(chunk, ck, P)``.

    ``method="lockstep"`` (vectorized, with hand-off) or ``"single"`` (every design by the
    public sweep). See the module docstring. ``engine`` as for :func:`loopsolve.sweep`: where
    :func:`~loopsolve.kinematics.numba_engine.jit.engine_for` picks ``"numba"`` for the chunk's
    designs × rows, the continuation runs compiled (:mod:`loopsolve.kinematics.numba_engine.lockstep_kernel`);
    the designs swept alone get the same ``engine``.

    Examples
    --------
    >>> mech = ls.fourbar(60, 25, 70, 45)
    >>> ch, ck, P = sweep_chunk(mech, ("r2",), np.array([[20.0], [25.0]]), 0, 360, 90)
    >>> ch.status.tolist(), ch.lockstep.tolist(), ch.Z[0].shape
    (['ok', 'ok'], [True, True], (3, 5, 2))
    """
    from ..kinematics.solve import input_rates, input_value

    values = np.asarray(values, dtype=float).reshape(-1, len(names))
    ck = mech.compile()
    ops = DesignOps(ck)
    P = param_matrix(ck, names, values)
    D = P.shape[1]
    xs, xs_disp = grid_values(ck, start, stop, step)
    K = len(xs)
    nv = len(ck.variables)
    rates = input_rates(ck, speed, accel, jerk)
    lockstep = (method == "lockstep" and mode is None and all(len(c) <= 2 for _, c in ops.blocks)
                and ops.n > 0)
    lane = _compiled_lockstep(ck, engine, D, K) if lockstep else None
    ch = Chunk(nv, D, K, len(ck.points), derivatives, design_major=lane is not None)
    from .designs import design_problems

    problems = design_problems(mech, names, values)  # the model file's checks, design by design
    invalid = problems != ""
    alive = np.zeros(D, dtype=bool)
    if lockstep:
        from .sensitivity import fused_module

        varied = set(names)
        Pr = [P[i] if p.name in varied else P[i, :1] for i, p in enumerate(mech.parameters)]
        lops = DesignOps(ck, shared_input=True)
        lops.fused = fused_module(ck)
        from ..kinematics.solve import input_value

        # the single sweep tracks on to `stop` past the last grid row (a limit there is its event): so do the checks
        x_end = input_value(ck, stop, ck.inputs[0], reduce=False)
        alive, last, irregular, sig0 = _lockstep(ck, lops, Pr, P, xs, ch, rates, derivatives, ~invalid, x_end=x_end,
                                                 lane=lane)
    ch.lockstep[:] = alive
    for arr in ch.Z:
        arr[:, ch.filled:, :] = np.nan
    if ch.points is not None:
        ch.points[..., ch.filled:, :] = np.nan
    for j in np.flatnonzero(invalid):
        ch.status[j] = "invalid"
        ch.events[j] = problems[j]
    single = np.flatnonzero(~alive & ~invalid)
    limits = np.zeros(0, dtype=int)
    if lockstep and len(single):
        single = _not_assemblable(ck, P, xs, xs_disp, single, ch)
        x_end = input_value(ck, stop, ck.inputs[0], reduce=False)
        from .lockstep_limits import locate_limits

        single, limits = locate_limits(ck, P, xs, x_end, single, last, irregular, sig0, ch, rates, derivatives)
    for j in np.flatnonzero(~alive):
        if j in limits:
            continue
        for arr in ch.Z:
            arr[:, :, j] = np.nan
        if ch.points is not None:
            ch.points[..., j] = np.nan
    for j in single:
        _single(mech, names, values[j], start, stop, step, speed, accel, jerk, mode, derivatives, ch, j, xs_disp,
                engine=engine)
    return ch, ck, P


#: under ``engine="auto"`` a study's continuation runs compiled from this many designs × rows on, whatever
#: the process swept before (below it the saving cannot pay the ~1 s of importing numba and loading the
#: model's cached kernel; the first study of a model also compiles the kernel, 10–15 s once, cached on disk)
#: — and only when its chunks are smaller than :data:`AUTO_CHUNK`
AUTO_CELLS = 1_000_000
#: under ``engine="auto"`` chunks of at least this many designs run the numpy lockstep: its vectorized passes
#: cost ~0.3 s a chunk and then as much per design as the compiled kernel (issue 32, benchmarks/README.md "A
#: study's chunk size", untraced CPU: 20000 designs in chunks of 2000 13.3 s numpy, 14.3 s compiled; 2000
#: designs in chunks of 1024 1.49 / 1.40 s, of 512 2.07–2.45 / 1.16 s, of 256 3.1 / 1.5 s). A cluster's
#: chunks are small (a few per worker): those run compiled.
AUTO_CHUNK = 1024


def lockstep_engine(ck, engine, cells: int, designs: int | None = None) -> str:
    """The engine of the continuation of ``cells`` designs × rows in chunks of ``designs``: ``"numba"`` or
    ``"python"`` (numpy).

    ``engine`` as for :func:`loopsolve.sweep` (None: ``$LOOPSOLVE_ENGINE``, else ``"auto"``); ``"auto"`` is
    numba when it is installed, the model has a compiled lane, ``cells`` reaches :data:`AUTO_CELLS` and the
    chunks have fewer than :data:`AUTO_CHUNK` designs (``designs=None``: not looked at).
    """
    from ..kinematics.numba_engine import jit
    from ..kinematics.scalar_solver import kernel_of

    kern = kernel_of(ck)
    name, _ = jit.engine_name(engine)
    if name != "auto":
        return jit.engine_for(name, kern, cells)
    if cells < AUTO_CELLS or (designs is not None and designs >= AUTO_CHUNK):
        return "python"
    return "numba" if jit.has_lane(kern) and jit.use_numba(name) else "python"


def _compiled_lockstep(ck, engine, designs, rows):
    """The numba module whose ``lockstep_run`` sweeps a chunk of ``designs`` × ``rows`` grid rows, or None (numpy)."""
    if lockstep_engine(ck, engine, rows * designs, designs) != "numba":
        return None
    from ..kinematics.numba_engine.jit import numba_module

    return numba_module(ck)


def _not_assemblable(ck, P, xs, xs_disp, cand, ch) -> np.ndarray:
    """Decide, all at once, which designs ``cand`` cannot be assembled at the start, and name their nearest
    assemblable inputs (:mod:`loopsolve.kinematics.assemblable`); returns the designs left for the single sweep.

    Their status, stop, nearest inputs and event are those :func:`_single` would record from the
    single sweep's :class:`AssemblyError` (the same test, samples and message)."""
    from ..kinematics.assemblable import AssemblyTest
    from ..kinematics.reach import no_assembly_error

    test = AssemblyTest(ck, DesignOps(ck), P, design_scale(ck, P))
    if not test.usable:
        return cand
    x0 = float(xs[0])
    # a design that misses assembly at the start by a hair (1e-8 relative, ~1e-4 in angle) goes to the
    # single sweep, which may call it a singular start instead (its tolerance, not this closed form's)
    ok, decided = test.at(np.full(len(cand), x0), cand, margin=_START_MARGIN)
    na = cand[decided & ~ok]
    near = test.nearest(x0, na)
    done = []
    for j, nv in zip(na, near):
        if nv is None:
            continue
        disp = tuple(display_value_of(ck, v) for v in nv)
        err = no_assembly_error(ck, x0, disp)
        ch.status[j] = "not-assemblable"
        ch.stop[j] = xs_disp[0]
        ch.nearest[j] = ", ".join(f"{v:.10g}" for v in disp)
        ch.events[j] = _no_path(str(err).splitlines()[0], ck.mechanism)
        done.append(j)
    return np.setdiff1d(cand, np.array(done, dtype=int))


def _newton_start(ops, Z, P, scale, alive):
    """Newton at fixed input from the guesses, all designs at once; designs needing damping drop out."""
    iu = ops.iu
    F = ops.phi(Z, P)
    fn = np.max(np.abs(F), axis=0)
    polished = np.zeros(Z.shape[1], dtype=bool)
    done = np.zeros(Z.shape[1], dtype=bool)
    w = np.where(ops.is_len[:, None], 1.0 / scale, 1.0)
    for _ in range(40):
        act = alive & ~done
        if not act.any():
            break
        J = ops.jac(Z, P)
        dU = ops.solve(J, -F)
        U = Z[iu] + np.where(act, dU, 0.0)
        Zn = Z.copy()
        Zn[iu] = U
        Fn = ops.phi(Zn, P)
        fnn = np.max(np.abs(Fn), axis=0)
        f2, f2n = np.sum(F * F, axis=0), np.sum(Fn * Fn, axis=0)
        descent = np.isfinite(f2n) & (f2n <= (1 - 1e-4) * f2) | (f2 <= (1e-12 * scale * 1e-3) ** 2)
        alive &= ~(act & ~descent)  # the scalar Newton would damp: not decided here
        act &= alive
        Z[iu] = np.where(act, U, Z[iu])
        F = np.where(act, Fn, F)
        fn = np.where(act, fnn, fn)
        step = np.max(np.abs(dU * w), axis=0)
        conv = act & (fn <= 1e-12 * scale)
        small = step <= 1e-12 * (1 + np.max(np.abs(Z[iu] * w), axis=0))
        done |= conv & (polished | small)
        polished |= conv
    alive &= done
    return Z


def _lockstep(ck, ops, P, Pfull, xs, ch, rates, derivatives, alive=None, x_end=None, lane=None):
    """``P``: the parameter rows as the generated code takes them (fixed ones as one value).

    ``alive``: the designs to sweep (default all); the others are left out from the start.
    ``x_end``: the end of the range (internal units); the checks run on to it past the last grid row.
    ``lane``: the model's numba module: the continuation after the start runs compiled (:func:`_run_compiled`).
    """
    from ..kinematics.solve import initial_z

    D = Pfull.shape[1]
    ix = ops.ix
    scale = design_scale(ck, Pfull)
    w = np.where(ops.is_len[:, None], 1.0 / scale, 1.0)  # scaled unknowns: angles, lengths / scale
    z0 = initial_z(ck, warn=False)
    x_guess = ck.mechanism.variable(ck.inputs[0]).guess
    x0 = float(xs[0])
    if x_guess is None or abs(x_guess - x0) <= 1e-12 * max(1.0, abs(x0)):
        x_guess = x0
    Z = np.repeat(z0[:, None], D, axis=1)
    Z[ix] = x_guess
    alive = np.ones(D, dtype=bool) if alive is None else np.array(alive, dtype=bool)
    last = np.full(D, -1)  # the last grid row each design reached in lockstep
    irregular = np.zeros(D, dtype=bool)  # dropped near a change point or for a signature change
    mech = ck.mechanism
    guessed = all(mech.variable(n).guess is not None for n in ck.unknowns)
    with np.errstate(all="ignore"):
        # the mode each design is asked for: the signs at the guesses, with this design's parameters
        req = ops.guess_signs(ops.jac(Z, P)) if guessed else None
        Z = _newton_start(ops, Z, P, scale, alive)
        J = ops.jac(Z, P)
        sig0, reg = ops.signs_and_regularity(J, scale)
        alive &= reg >= REGULAR_MIN
        if req is not None:  # Newton fell into another mode: the single sweep finds the one asked for
            alive &= np.all((req == 0) | (sig0 == req), axis=0)
        # the path: from the guesses' input to the start, then the grid
        kind = ck.kinds[ix]
        hmax = _SUB_ANGLE if kind is Kind.ANGLE else 0.01 * float(np.median(scale))
        targets: list[tuple[float, int]] = []
        if x_guess != x0:
            m = max(1, int(math.ceil(abs(x0 - x_guess) / (2 * hmax))))
            targets += [(x_guess + (x0 - x_guess) * i / m, -1) for i in range(1, m)] + [(x0, 0)]
        else:
            targets.append((x0, 0))
        for k in range(1, len(xs)):
            a, b = float(xs[k - 1]), float(xs[k])
            m = max(1, int(math.ceil(abs(b - a) / hmax - 1e-9)))
            targets += [(a + (b - a) * i / m, -1) for i in range(1, m)] + [(b, k)]
        a = float(xs[-1])
        if x_end is not None and abs(x_end - a) > 1e-12 * max(1.0, abs(x_end)):
            # between the last row and `stop` (less than a step): checked, no row stored
            m = max(1, int(math.ceil(abs(x_end - a) / hmax - 1e-9)))
            targets += [(a + (x_end - a) * i / m, -1) for i in range(1, m + 1)]
        if lane is not None and _run_compiled(lane, ck, ops, Z, Pfull, alive, sig0, scale, x_guess, targets, ch,
                                              rates, derivatives, last, irregular):
            targets = []
        zk1 = np.zeros_like(Z)
        zk1[ix] = 1.0
        x_prev = x_guess
        T = None  # dq/dx at Z, when known
        T_prev, h_prev = None, 0.0
        for x, k in targets:
            if x != x_prev:
                if not alive.any():
                    break
                if T is None:
                    T = ops.solve(J, ops.rhs(1, (Z, zk1), P))
                h = x - x_prev
                C2 = (T - T_prev) / h_prev if T_prev is not None and h * h_prev > 0 else None
                Z = _substep(ops, Z, P, T, C2, x, x_prev, w, alive)
                J = ops.jac(Z, P)  # at the converged Z: mode, regularity, tangent and the rows' rates
                sig, reg = ops.signs_and_regularity(J, scale)
                keep = (reg >= REGULAR_MIN) & np.all(sig == sig0, axis=0)
                irregular |= alive & ~keep
                alive &= keep
                x_prev, T_prev, h_prev = x, T, h
                T = None
            if k >= 0:
                T = _store_row(ck, ops, Z, J, P, ch, k, rates, derivatives)
                last[alive] = k
    codes = np.where(sig0 > 0, "+", np.where(sig0 < 0, "-", "0"))
    for j in np.flatnonzero(alive):
        ch.mode[j] = "".join(codes[:, j])
    return alive, last, irregular, sig0


def _run_compiled(lane, ck, ops, Z, Pfull, alive, sig0, scale, x_guess, targets, ch, rates, derivatives, last,
                  irregular) -> bool:
    """The continuation through ``targets`` by the compiled ``lockstep_run`` of the model's numba module;
    ``alive``, ``last``, ``irregular`` and the rows of ``ch`` updated in place. False when numba cannot
    compile it for this model (one warning; the numpy loop then runs)."""
    D = Z.shape[1]
    nb = len(ops.blocks)
    bs = np.array([len(c) for _, c in ops.blocks], dtype=np.int64)
    be = np.array([(e[0], e[-1]) for e, _ in ops.blocks], dtype=np.int64).reshape(nb, 2)
    bc = np.array([(c[0], c[-1]) for _, c in ops.blocks], dtype=np.int64).reshape(nb, 2)
    tx = np.array([t[0] for t in targets], dtype=float)
    tk = np.array([t[1] for t in targets], dtype=np.int64)
    # the kernel writes design-major arrays (D, ...): a design-major Chunk's own, else copies written back
    rows = getattr(ch, "rows", None)
    OZ = np.moveaxis(rows if rows is not None else np.stack(ch.Z), -1, 0)
    own = rows is not None and OZ.flags.c_contiguous  # a view of the chunk's rows: written in place
    OZ = OZ if own else np.ascontiguousarray(OZ)
    K = OZ.shape[3]
    OP = (np.empty((D, len(ch.Z), 0, 2, K)) if ch.points is None else
          np.ascontiguousarray(np.moveaxis(ch.points, -1, 0)))
    own_points = ch.points is None or np.may_share_memory(OP, ch.points)
    ok = np.array(alive, dtype=bool)
    lastc = np.full(D, -1, dtype=np.int64)
    irr = np.zeros(D, dtype=bool)
    cf = np.array([FOLD_SLOPE, FIRST_CORRECTION, _CONVERGED, REGULAR_MIN])
    try:
        lane.lockstep_run(np.ascontiguousarray(Z.T), np.ascontiguousarray(Pfull.T), ok, np.asarray(sig0, dtype=float),
                          np.ascontiguousarray(scale, dtype=float), np.asarray(ops.is_len, dtype=np.bool_),
                          float(x_guess), tx, tk, np.array(rates, dtype=float), int(derivatives), cf, ops.ix,
                          np.asarray(ops.iu, dtype=np.int64), bs, be, bc, OZ, OP, lastc, irr)
    except Exception as exc:
        if not type(exc).__module__.startswith("numba"):
            raise
        from ..errors import warn

        warn(f"{ck.mechanism.source or ck.mechanism.name}: numba could not compile the study's lockstep "
             f"({type(exc).__name__}); the numpy lockstep runs")
        return False
    if not own:  # (a chunk in the numpy loop's layout, or not made by Chunk: copy the rows back)
        for a in range(len(ch.Z)):
            ch.Z[a][...] = np.moveaxis(OZ[:, a], 0, -1)
    if not own_points:
        ch.points[...] = np.moveaxis(OP, 0, -1)
    ch.filled = K
    alive[:] = ok
    last[:] = lastc
    irregular |= irr
    return True


def _store_row(ck, ops, Z, J, P, ch, k, rates, derivatives):
    """Positions, rates and points of grid row k for every design (Jacobian ``J`` at ``Z``); returns dq/dx."""
    ix = ops.ix
    out = [Z]
    ch.Z[0][:, k, :] = Z
    ch.filled = k + 1
    T = None
    for order in range(1, derivatives + 1):
        Zk = np.zeros_like(Z)
        Zk[ix] = rates[order - 1]
        Zk[ops.iu] = ops.solve(J, ops.rhs(order, out + [Zk], P))
        out.append(Zk)
        ch.Z[order][:, k, :] = Zk
        if order == 1 and rates[0] != 0:
            T = Zk[ops.iu] / rates[0]
    if ch.points is not None:
        npts = ch.points.shape[1]
        D = Z.shape[1]
        for order in range(derivatives + 1):
            v = np.asarray(ops.points(order, out[: order + 1], P))
            ch.points[order, :, :, k, :] = np.broadcast_to(v.reshape(npts, 2, -1), (npts, 2, D))
    return T


def _substep(ops, Z, P, T, C2, x, x_prev, w, alive):
    """Predictor and Newton corrector to x, all designs at once; returns Z.

    The predictor is the Taylor polynomial with the tangent ``T`` = dq/dx at Z and, when
    known, ``C2`` ≈ d²q/dx² (from the previous tangent). The corrector is Newton with the
    Jacobian of the predicted point kept for two more (chord) iterations, then refreshed. A
    design is converged when its correction is below ``_CONVERGED``: from a predictor error
    ~1e-6 a chord step contracts by about that factor, so what is left is far below round-off.
    """
    iu, ix = ops.iu, ops.ix
    slope = np.max(np.abs(T * w), axis=0)
    alive &= np.isfinite(slope) & (slope <= FOLD_SLOPE)
    h = x - x_prev
    Z = Z.copy()
    Z[ix] = x
    Z[iu] = Z[iu] + T * h + (0.5 * h * h * C2 if C2 is not None else 0.0)
    done = ~alive
    Jn = None
    for it in range(8):
        if it % 3 == 0:
            F, Jn = ops.phi_jac(Z, P)
        else:
            F = ops.phi(Z, P)
        dU = ops.solve(Jn, -F)
        size = np.max(np.abs(dU * w), axis=0)
        if it == 0:
            alive &= np.isfinite(size) & (size <= FIRST_CORRECTION)
        Z[iu] = np.where(alive & ~done, Z[iu] + dU, Z[iu])
        done |= (size <= _CONVERGED) | ~alive
        if done.all():
            break
    alive &= done
    return Z
