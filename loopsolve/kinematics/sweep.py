"""Sweeps of the input: the output grid, the rows, the public :func:`sweep`, reachable ranges.

The front end of the tracker (:mod:`loopsolve.kinematics.continuation`): it parses the range, builds the
output grid, starts the tracer from the solved start, enumerates the grid values the traced
path crosses (in the order traversed), solves them (tracked, or vectorized by
:mod:`loopsolve.kinematics.batch`) and computes their rates in one pass. Where a mechanism can be
assembled (:func:`reachable_ranges`, :func:`nearest_assemblable`, :func:`default_range`) is
answered by :mod:`loopsolve.kinematics.reach`, the output grid is :mod:`loopsolve.kinematics.grid`.
"""

from __future__ import annotations

import math
import numbers
import sys

import numpy as np

from .grid import Grid, exact_radians, grid  # noqa: F401  (grid, exact_radians: public here before the split)
from .reach import (assembly_failure, default_range, nearest_assemblable, no_assembly_error,  # noqa: F401
                    reachable_ranges)  # where the input can go: kinematics/reach.py (public here before the split)
from . import batch
from .numba_engine import jit as numba_jit
from .continuation import (Kernel, Path, RowSolution, StepControl, Tracer, fill_node_rows, first_node,
                           solve_rows_scalar)
from ..errors import AssemblyError, ConvergenceError, ModelError, SingularPositionError, SolveError, warn
from .scalar_solver import kernel_of
from .newton import Newton
from .results import Event, EventKind, Sweep
from .solve import input_unit, display_value, initial_z, input_rates, input_value, plain_value, start_position
from ..model.units import Kind

__all__ = ["StepControl", "sweep", "grid", "reachable_ranges", "default_range", "nearest_assemblable",
           "assembly_failure", "AUTO_BATCH"]

#: a start this close (display units) to a located limit position starts on it
_AT_LIMIT = 1e-9
#: ``method="auto"`` uses the batched path from this many output points on
AUTO_BATCH = 720


# ============================================================================= rows


class Rows:
    """The output rows in path order: grid index ``ks``; ``node`` (index of the path node that is
    the row, or -1) and ``seg`` (index of the segment to solve it on, or -1); ``x`` the input values."""

    __slots__ = ("ks", "seg", "node", "x")

    def __init__(self, ks, seg, node, x):
        self.ks, self.seg, self.node, self.x = ks, seg, node, x

    def __len__(self) -> int:
        return len(self.ks)


def _enumerate_rows(kern: Kernel, path: Path, g: Grid) -> Rows:
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
        return Rows(e, e.copy(), e.copy(), np.zeros(0))
    if len(chunks) == 1:
        return Rows(*chunks[0])
    return Rows(*(np.concatenate(c) for c in zip(*chunks)))


def _whole_rows(fast, first, g: Grid, nv: int):
    """Rows and positions of a path the compiled fast lane traced whole (:meth:`FastLane.whole_rows`)."""
    ks, node, Z, res, its, R = fast.whole_rows(first)
    # every row is a node that landed exactly on its grid value (Grid.value, compiled)
    rows = Rows(ks, np.full(len(ks), -1, dtype=np.int64), node, Z[fast.k.ix].copy())
    sol = RowSolution(len(ks), nv)
    sol.Z, sol.res, sol.its = Z, res, its
    sol.code[:] = sol.code_of(first.sig)
    return rows, sol, R


def solve_rows_tracked(tracer: Tracer, path: Path, rows: Rows, g: Grid) -> RowSolution:
    """Positions of every row: nodes as they are, other crossings by a corrector from the segment."""
    sol = RowSolution(len(rows), tracer.k.nv)
    other = fill_node_rows(path, rows, sol)
    solve_rows_scalar(tracer, path, rows, g, sol, np.flatnonzero(other))
    return sol


#: a sweep of fewer rows gets no automatic bar: it ends well before the bar's half-second delay
_BAR_ROWS = 2000


def _progress(total: int, enabled: bool | None):
    """A tqdm bar on stderr for long sweeps (shown after 0.5 s, only on a terminal)."""
    if enabled is None:
        enabled = total >= _BAR_ROWS and sys.stderr.isatty()
    if not enabled or total < 2:
        return None
    try:
        from tqdm import tqdm
    except ImportError:
        return None
    return tqdm(total=total, unit="pt", file=sys.stderr, leave=False, delay=0.5)


# ============================================================================= start


# ============================================================================= public API


def _parse_range(ck, start, stop, step):

    name = ck.inputs[0]
    kind = ck.kinds[ck.index(name)]
    # sweep bounds and steps are never reduced modulo a turn (that would silently move the range)
    x0, x1 = (x if (x := plain_value(ck, v, kind)) is not None else input_value(ck, v, name, reduce=False)
              for v in (start, stop))
    if isinstance(step, str):
        h = input_value(ck, step, name, reduce=False)
    elif kind is Kind.ANGLE:
        h = math.radians(float(step)) if ck.mechanism.units.angle == "deg" else float(step)
    else:
        h = float(step)
    if not (math.isfinite(x0) and math.isfinite(x1)):
        raise ModelError(f"the sweep range of {name} must be finite (got {start!r} to {stop!r})")
    if kind is Kind.ANGLE and max(abs(x0), abs(x1)) > MAX_TURNS * 2 * math.pi:
        raise ModelError(f"the sweep range of {name} ({start!r} to {stop!r}) lies beyond {MAX_TURNS} turns, where "
                         "angles lose their digits: shift the range by whole turns towards 0")
    if not (h > 0 and math.isfinite(h)):
        raise ModelError(f"--step {step!r}: the output step must be a positive number (the direction of the "
                         "sweep is from --from to --to)")
    deg = None
    if kind is Kind.ANGLE and ck.mechanism.units.angle == "deg":
        d0 = float(start) if not isinstance(start, str) else math.degrees(x0)
        dh = float(step) if not isinstance(step, str) else math.degrees(h)
        deg = (d0, math.copysign(abs(dh), x1 - x0) if x1 != x0 else abs(dh))
    return x0, x1, h, kind, deg


#: sweep bounds of an angle input must lie within this many turns of 0
MAX_TURNS = 65536

#: default cap on the output rows of one sweep (``max_rows=``, ``--max-rows``)
MAX_ROWS = 1_000_000


def _make_grid(x0, x1, h, kind, through_limits, deg=None, max_rows=MAX_ROWS) -> Grid:
    """The output grid ``x0 + k·h`` towards ``x1``, and the input range [x0, x1] the tracer covers.

    The rows are counted before anything is allocated: more than ``max_rows`` is a ModelError.
    """
    if isinstance(max_rows, bool) or not isinstance(max_rows, numbers.Real) or not max_rows >= 1:
        raise ModelError(f"--max-rows (max_rows=) {max_rows!r}: the limit on a sweep's rows must be a number of "
                         f"at least 1 (default {MAX_ROWS:,})")
    h = math.copysign(abs(h), x1 - x0) if x1 != x0 else abs(h)
    count = (x1 - x0) / h
    full_turn = through_limits and kind is Kind.ANGLE and abs(x1 - x0) >= 2 * math.pi - 1e-9
    m = 2 * math.pi / abs(h) if full_turn else 0.0
    total = count + m + 1
    if not (total <= max_rows):  # also inf and nan (a step below the range's resolution)
        rows = (f"{math.floor(total + 1e-9):,}" if total < 1e15 else f"{total:.3g}") if math.isfinite(total) \
            else "too many"
        raise ModelError(f"the sweep would have {rows} rows (from the range and --step), more than the limit of "
                         f"{max_rows:,}: use a larger --step or a smaller range, or raise the limit with "
                         "--max-rows (max_rows=)")
    n = max(int(math.floor(count + 1e-9)), 0)
    g = Grid(x0, h, 0, n, x0, x0, deg)
    if n and g.value(n) == g.value(n - 1):
        raise ModelError(f"--step {abs(h):g} is below the resolution of the input values in this range")
    xs, xn = g.value(0), g.value(n)
    if abs(x1 - xn) <= 1e-9 * abs(h):  # the end is the last grid value (up to round-off)
        x1 = xn
    # the tracer covers the whole requested range (a limit between the last grid value and the
    # end is reported), and at least the grid (the last grid value may pass x1 by round-off)
    lo, hi = min(xs, xn, x1), max(xs, xn, x1)
    kmin, kmax = 0, n
    if full_turn:
        # a full turn of the input: every angle is in range; the path may go back past the start
        kmin = -int(math.floor(m + 1e-9))
        if h > 0:
            lo = xs - 2 * math.pi
        else:
            hi = xs + 2 * math.pi
    return Grid(x0, h, kmin, kmax, lo, hi, deg)


def sweep(mech, start, stop, step, *, speed=None, accel=None, jerk=None, input: str | None = None,
          mode: str | None = None, guess: dict | None = None, compiled=None,
          through_limits: bool = False, progress: bool | None = None, method: str = "auto",
          derivatives: int = 3, control: StepControl | None = None, settings: Newton | None = None,
          max_rows: int = MAX_ROWS, limit_rows: bool = False, engine: str | None = None) -> Sweep:
    """Sweep the input from ``start`` to ``stop`` by ``step`` (display units), tracking the mode.

    Parameters
    ----------
    mech : Mechanism
    start, stop, step : float or str
        The input range and the output step, in the model's units or with a unit (``"1.5rad"``).
        The rows are at ``start + k·step`` (k = 0, 1, ...) towards ``stop``; ``stop`` itself is a
        row only when it falls on that grid. ``step`` is positive (the direction is from ``start``
        to ``stop``). The tracker covers the whole range: a limit position anywhere between
        ``start`` and ``stop`` is reported, also one after the last row.
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
        (see :mod:`loopsolve.kinematics.batch`); ``"auto"`` is batched from ``AUTO_BATCH`` points on.
    derivatives : {1, 2, 3}
        Highest time derivative computed: velocities, accelerations, jerks (default). The
        unknowns' higher rates are NaN (empty in CSV, null in JSON); for speed when they are
        not needed.
    control : StepControl, optional
        The tracker's step control (default ``StepControl()``).
    settings : Newton, optional
        Newton's tolerances (default ``Newton()``).
    max_rows : int
        Refuse (``ModelError``, before any work) a grid of more rows than this (default 10⁶).
    limit_rows : bool
        Also a row at every limit position the sweep reaches (off the grid: the located input,
        the positions there, NaN rates), so that plotted branches meet at their fold.
    engine : {"python", "numba", "auto"}, optional
        Who takes the tracer's regular natural steps: Python, or the compiled fast lane
        (:mod:`loopsolve.kinematics.numba_engine.steps`, needs the ``fast`` extra: numba).
        ``"auto"``, the default (else ``$LOOPSOLVE_ENGINE``), is numba once it pays: numba
        installed, the model covered, and this process's sweeps past
        :data:`~loopsolve.kinematics.numba_engine.jit.AUTO_ROWS` rows (see
        :func:`~loopsolve.kinematics.numba_engine.jit.engine_for`). The rows agree to round-off;
        :attr:`Sweep.engine` says which ran.

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
    ModelError
        A bad range or step, or more than ``max_rows`` rows.

    Warns
    -----
    LoopsolveWarning
        The sweep stopped at a limit position (or could not continue) before ``stop``: one line
        naming the input value; the rows up to there are returned.

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
    if method not in ("auto", "tracked", "batched"):
        raise ModelError(f"method {method!r}: expected 'auto', 'tracked' or 'batched'")
    control = StepControl() if control is None else control
    settings = Newton() if settings is None else settings
    if derivatives not in (1, 2, 3):
        raise ModelError(f"derivatives={derivatives!r}: expected 1 (velocities), 2 (accelerations) or 3 (jerks)")
    ck = compiled if compiled is not None else mech.compile(input)
    x0, x1, h, kind, deg = _parse_range(ck, start, stop, step)
    g = _make_grid(x0, x1, h, kind, through_limits, deg, max_rows=max_rows)
    x0 = g.value(0)  # start exactly on the first grid value (the two may differ by an ulp)
    rates = input_rates(ck, speed, accel, jerk)
    kern = kernel_of(ck)
    n_grid = g.kmax - g.kmin + 1
    ran = numba_jit.engine_for(engine, kern, n_grid)
    lane = numba_jit.fast_lane(kern, lazy=method != "batched") if ran == "numba" else None
    started = lane.start(x0, mode=mode, guess=guess, settings=settings) if lane is not None else None
    z0, _, _ = started or start_position(ck, x0, mode=mode, guess=guess, settings=settings)
    d = 1.0 if g.step > 0 else -1.0
    first = first_node(kern, z0, d, allow_fold=True)
    if first.kind == "fold" and abs(display_value(ck, first.z[kern.ix]) - display_value(ck, x0)) > _AT_LIMIT:
        from .modes import modes_at

        if not modes_at(ck, x0):  # Newton found a near-solution beyond the limit: not assemblable
            raise assembly_failure(ck, x0, AssemblyError("beyond a limit position"))
    use_batch = method == "batched" or (method == "auto" and n_grid >= AUTO_BATCH)
    bar = _progress(n_grid, progress)
    if use_batch:  # a denser coarse pass keeps the cubic warm start at ~1e-9
        control = StepControl(**{**{f: getattr(control, f) for f in control.__slots__},
                                 "max_step": min(control.max_step, math.radians(1.0))})
    try:
        tracer = Tracer(kern, g, control, land=not use_batch, through_limits=through_limits, x_start=x0,
                         bar=None if use_batch else bar)
        fused = None  # the rows' rates, computed in the fast lane's step loop
        if lane is not None:
            lane.lazy = not use_batch
            lane.want_rates(rates, derivatives)
            tracer.fast = lane
        path = tracer.trace(first)
        if tracer.fast is not None and tracer.fast.whole is not None:  # traced whole by the fast lane
            rows, sol, fused = _whole_rows(tracer.fast, first, g, kern.nv)
        elif use_batch:
            rows = _enumerate_rows(kern, path, g)
            sol = batch.solve_rows(tracer, path, rows, g)
        else:
            rows = _enumerate_rows(kern, path, g)
            sol = solve_rows_tracked(tracer, path, rows, g)
    finally:
        if bar is not None:
            bar.close()
    events = list(path.events) + sol.events
    if first.kind == "fold":
        xf = display_value(ck, first.z[ck.input_idx[0]])
        events.insert(0, Event(EventKind.LIMIT, xf, "limit position (toggle/fold) where the sweep starts (the "
                               f"rates are undefined there); the sweep enters mode {first.sig}"))
    ok = sol.ok
    every = bool(ok.all())
    ix = ck.input_idx[0]
    key = None  # position of each row along the path (for the limit rows)
    if limit_rows:
        key = np.where(rows.node >= 0, rows.node, rows.seg + 0.5)
        key = key if every else key[ok]
    Z = sol.Z if every else sol.Z[:, ok]
    Z[ix] = rows.x if every else rows.x[ok]
    J = None
    if sol.J is not None:
        J = sol.J if every else sol.J[:, ok]
        missing = ~(sol.J_ok if every else sol.J_ok[ok])
        if missing.any():
            J[:, missing] = ck.module.jac_v(Z[:, missing], ck.p).reshape(J.shape[0], -1)
    if fused is not None and every and J is None:  # computed at each node in the step loop
        Z1, Z2, Z3, cond = lane.whole_rates(fused, rates)
    elif lane is not None and J is None:  # the same rates, compiled
        Z1, Z2, Z3, cond = lane.rates(Z, rates, derivatives)
    else:
        Z1, Z2, Z3, cond = batch.rates_v(ck, Z, rates, J=J, derivatives=derivatives)
    code, res, its = (sol.code, sol.res, sol.its) if every else (sol.code[ok], sol.res[ok], sol.its[ok])
    bad = ~(cond <= batch.SINGULAR_COND)
    if np.any(bad):
        for i in np.flatnonzero(bad):
            x = display_value(ck, Z[ix, i])
            events.append(Event(EventKind.SINGULAR, x, "singular position: Φ_q is singular (rates undefined); "
                                "row left out"))
        keep = ~bad
        Z, Z1, Z2, Z3, cond = Z[:, keep], Z1[:, keep], Z2[:, keep], Z3[:, keep], cond[keep]
        code, res, its = code[keep], res[keep], its[keep]
        key = key[keep] if key is not None else None
    if limit_rows:
        Z, Z1, Z2, Z3, cond, code, res, its = _insert_limit_rows(ck, path, sol, key, rates, Z, Z1, Z2, Z3, cond,
                                                                code, res, its)
    if len(sol.sigs) == 1:  # one mode on every row (codes are 0): no object array
        modes = (sol.sigs[0],) * len(code)
    else:
        names = np.empty(len(sol.sigs), dtype=object)
        names[:] = sol.sigs
        modes = tuple(names[code])
    _announce_stop(ck, path.events, through_limits)
    if mech.pairs is not None and mech.pairs.gears:
        from .pairchecks import check_gears

        check_gears(ck, Z, [display_value(ck, x) for x in Z[ix]])
    return Sweep.from_arrays(ck, Z.T, Z1.T, Z2.T, Z3.T, modes=modes, residual=res, n_iter=its,
                             cond=cond, events=tuple(events), mode=first.sig,
                             method="batched" if use_batch else "tracked", engine=ran, copy=False)


def _insert_limit_rows(ck, path, sol, key, rates, Z, Z1, Z2, Z3, cond, code, res, its):
    """Add a row at every limit position the path passes (positions of the located fold, NaN rates)."""
    folds = [(i, nd) for i, nd in enumerate(path.nodes) if nd.kind == "fold"]
    if not folds:
        return Z, Z1, Z2, Z3, cond, code, res, its
    ix = ck.input_idx[0]
    pos = np.searchsorted(key, [i for i, _ in folds], side="right")
    fz = np.array([nd.z for _, nd in folds], dtype=float).T
    nan = np.full_like(fz, np.nan)
    r1, r2, r3 = nan.copy(), nan.copy(), nan.copy()
    for r, v in ((r1, rates[0]), (r2, rates[1]), (r3, rates[2])):
        r[ix] = v
        for j in ck.input_idx[1:]:
            r[j] = 0.0
    for j in ck.input_idx[1:]:
        fz[j] = path.nodes[0].z[j]
    fsig = [path.seg_sig[i - 1] if i > 0 else nd.sig for i, nd in folds]
    fcode = np.array([sol.code_of(sg) for sg in fsig], dtype=np.int64)
    return (np.insert(Z, pos, fz, axis=1), np.insert(Z1, pos, r1, axis=1), np.insert(Z2, pos, r2, axis=1),
            np.insert(Z3, pos, r3, axis=1), np.insert(cond, pos, np.inf), np.insert(code, pos, fcode),
            np.insert(res, pos, [nd.residual for _, nd in folds]), np.insert(its, pos, 0))


def _announce_stop(ck, events, through_limits: bool) -> None:
    """One :class:`LoopsolveWarning` line when the sweep stopped before the end of its range."""
    from .solve import input_unit

    for e in events:
        stop = (e.kind is EventKind.LIMIT and not through_limits) or (
            e.kind is EventKind.SINGULAR and "the rows stop here" in e.message)
        if stop:
            what = "a limit position (toggle)" if e.kind is EventKind.LIMIT else "a singular position"
            hint = "; --through-limits (through_limits=True) goes around it" if e.kind is EventKind.LIMIT else ""
            warn(f"{ck.mechanism.source or ck.mechanism.name}: the sweep stops at {what} at "
                 f"{ck.inputs[0]} = {e.input:.10g}{input_unit(ck)}{hint}")
            return


# ============================================================================= reachable ranges


