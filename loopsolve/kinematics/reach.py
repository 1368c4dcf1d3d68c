"""Where a mechanism can be assembled: reachable ranges of the input, the nearest assemblable
input values, the default sweep range, and the error for an input where it cannot be assembled.

The sweep uses them to start and to stop, :mod:`loopsolve.kinematics.solve` to explain a failed solve.
"""

from __future__ import annotations

import math

import numpy as np

from .continuation import Kernel, StepControl, Tracer, first_node
from ..errors import AssemblyError, ConvergenceError, SingularPositionError, SolveError
from .grid import Grid
from .results import EventKind
from .solve import input_unit, display_value, initial_z
from ..model.units import Kind


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
    from .modes import mode_names, modes_at

    name = ck.inputs[0]
    disp = display_value(ck, x, name)
    where = ck.mechanism.source or ck.mechanism.name
    modes = modes_at(ck, x)
    if modes:
        return ConvergenceError(
            f"{where}: Newton from the guesses stalled at {name} = {disp:g}{input_unit(ck)}, but the mechanism assembles there "
            f"in mode(s) {mode_names(ck.mechanism, modes)}: pass --mode (mode=) or improve the guesses",
            input_value=disp, result=getattr(exc, "result", None))
    return no_assembly_error(ck, x, nearest_assemblable(ck, x), residual=getattr(exc, "residual", None),
                             result=getattr(exc, "result", None))



def no_assembly_error(ck, x: float, near: tuple[float, ...], *, residual=None, result=None) -> AssemblyError:
    """The :class:`AssemblyError` of input ``x`` (internal units), where no assembly mode exists,
    naming the nearest assemblable inputs ``near`` (display units)."""
    from .modes import nearest_text

    name = ck.inputs[0]
    disp = display_value(ck, x, name)
    where = ck.mechanism.source or ck.mechanism.name
    return AssemblyError(
        f"{where}: cannot be assembled at {name} = {disp:g}{input_unit(ck)}: the loop equations have no real solution there"
        + nearest_text(ck, near),
        input_value=disp, residual=residual, nearest=near, result=result)



def _assemblable_at(ck, x, feeds=None) -> list:
    """Solutions at input ``x`` enough to find the reachable ranges (one per branch that matters)."""
    from .modes import branch_solutions

    z0 = initial_z(ck, warn=False)
    z0[ck.input_idx[0]] = x
    return branch_solutions(ck, z0, feeds=feeds)



def _limit_towards(ck, kern, z, x_to) -> float | None:
    """Track from the assemblable ``z`` towards ``x_to``: the limit input found on the way, None if none.

    The tracker cannot step across a gap in the assemblable input however narrow (its steps
    stay within the separation ratio, see :class:`loopsolve.kinematics.continuation.Tracer`), so the first
    limit on the way is the end of the reachable interval in that direction.
    """
    x_from = z[kern.ix]
    lo, hi = min(x_from, x_to), max(x_from, x_to)
    g = Grid(x_from, x_to - x_from, 0, 1, lo, hi)
    try:
        first = first_node(kern, z, 1.0 if x_to > x_from else -1.0)
    except SingularPositionError:
        return x_from
    tr = Tracer(kern, g, StepControl(), land=False, through_limits=False, x_start=x_from)
    path = tr.trace(first)
    for e in path.events:
        if e.kind is EventKind.LIMIT or (e.kind is EventKind.SINGULAR and "the rows stop here" in e.message):
            return path.nodes[-1].z[kern.ix]
    return None



def default_range(ck, step: float, *, mode=None) -> tuple[float, float, bool]:
    """Sensible sweep range when the user gives none: ``(start, stop, through_limits)``, display units.

    A full turn from 0 when the input turns fully (a length input: its reachable interval
    within ±4 length scales of its guess); otherwise the reachable interval that holds the
    input's guess, from its limit position (located exactly, :func:`reachable_ranges`) to one
    step beyond its far end, traced with ``through_limits`` so that the sweep turns at the far
    limit and follows the whole circuit back to the start.

    Examples
    --------
    >>> default_range(ls.fourbar(60, 25, 70, 45).compile(), 4)
    (0.0, 360.0, False)
    >>> default_range(ls.load(ls.models_dir() / "double_rocker.toml").compile(), 4)
    (24.146847997, 72.146847997, True)
    """
    i = ck.input_idx[0]
    angle = ck.kinds[i] is Kind.ANGLE
    ranges = reachable_ranges(ck)
    if not ranges:
        raise AssemblyError(f"{ck.mechanism.source or ck.mechanism.name}: no assemblable input value found "
                            f"for {ck.inputs[0]}; check the link lengths")
    if angle and ranges == [(-math.pi, math.pi)]:
        return 0.0, float(display_value(ck, 2 * math.pi)), False
    g = ck.mechanism.variable(ck.inputs[0]).guess
    g = 0.0 if g is None else g

    def holds(r):
        a, b = r
        if not angle:
            return a <= g <= b
        return a <= a + (g - a) % (2 * math.pi) <= b

    a, b = next((r for r in ranges if holds(r)), ranges[0])
    lo, hi = display_value(ck, a), display_value(ck, b)
    if not angle and len(ranges) == 1:
        return float(lo), float(hi), False
    # start on the limit position (rounded inwards to 1e-9 of a display unit: the sweep starts
    # there with a `limit` event); stop one step beyond the far limit, so that the sweep turns
    # there and traces the whole circuit back over the grid
    start = math.ceil(lo * 1e9) / 1e9
    stop = start + (math.floor((hi - start) / step) + 1) * step
    return float(start), float(round(stop, 9)), True



def input_samples(ck, kern, samples: int | None = None) -> list[float]:
    """The input values :func:`reachable_ranges` samples (internal units): a full turn for an
    angle (144 samples from −π), ±4 length scales around the guess for a length (200)."""
    if kern.angle_x:
        m = samples or 144
        return [-math.pi + 2 * math.pi * i / m for i in range(m)]
    g0 = ck.mechanism.variable(ck.inputs[0]).guess
    g0 = 0.0 if g0 is None else float(g0)
    m = samples or 200
    return [g0 - 4 * ck.scale + 8 * ck.scale * i / (m - 1) for i in range(m)]



def _reach(ck, kern, zs, x_from, x_to):
    """How far the modes ``zs`` at ``x_from`` get towards ``x_to``: ``x_to`` when one gets there,
    else the farthest located limit (None: no mode at ``x_from``)."""
    best = None
    for z in zs:
        z = np.array(z, dtype=float)
        z[kern.ix] = x_from
        lim = _limit_towards(ck, kern, z, x_to)
        if lim is None:
            return x_to
        if best is None or abs(lim - x_from) > abs(best - x_from):
            best = lim
    return best



def reachable_ranges(ck, *, samples: int | None = None) -> list[tuple[float, float]]:
    """Intervals of the driving input (internal units) where the mechanism can be assembled.

    The input is sampled (a full turn for an angle; ±4 length scales around the guess for a
    length) and every assembly mode is found at each sample (:func:`loopsolve.kinematics.modes.all_solutions`).
    From every assemblable sample each mode is tracked towards both neighbouring samples; the
    tracker stops at the first limit position on the way, located to ~1e-9, so every gap
    between assemblable samples is found however narrow, and its ends are the located folds.
    (An assemblable island narrower than the sampling step between two samples where the
    mechanism cannot be assembled would be missed.) A fully rotating angle input gives one
    interval of length 2π; an interval that wraps ends above π.

    Examples
    --------
    >>> ck = ls.fourbar(4, 3, 3.5, 5).compile()
    >>> [tuple(round(math.degrees(v), 6) for v in r) for r in reachable_ranges(ck)]
    [(18.57335, 341.42665)]
    """
    kern = Kernel(ck)
    angle = kern.angle_x
    xs = input_samples(ck, kern, samples)
    m = len(xs)
    from .modes import block_feeds

    feeds = block_feeds(ck)
    sols = [_assemblable_at(ck, x, feeds) for x in xs]
    if not any(sols):
        return []
    step = xs[1] - xs[0]

    def reach(zs, x_from, x_to):
        return _reach(ck, kern, zs, x_from, x_to)

    pieces = []
    for i in range(m if angle else m - 1):
        xa, xb = xs[i], xs[i] + step
        j = (i + 1) % m
        ea = reach(sols[i], xa, xb) if sols[i] else None
        if ea == xb:
            pieces.append((xa, xb))
            continue
        eb = reach(sols[j], xb, xa) if sols[j] else None
        if eb == xa:
            pieces.append((xa, xb))
            continue
        if ea is not None:
            pieces.append((xa, ea))
        if eb is not None:
            pieces.append((eb, xb))
    for i, z in enumerate(sols):  # isolated assemblable samples (between two gaps)
        if z and not any(a <= xs[i] <= b for a, b in pieces):
            pieces.append((xs[i], xs[i]))
    pieces.sort()
    out: list[list[float]] = []
    for a, b in pieces:
        if out and a <= out[-1][1] + 1e-12 * (1 + abs(a)):
            out[-1][1] = max(out[-1][1], b)
        else:
            out.append([a, b])
    if angle:
        end = xs[0] + 2 * math.pi
        if len(out) == 1 and out[0][0] <= xs[0] and out[0][1] >= end - 1e-12:
            return [(-math.pi, math.pi)]
        if len(out) > 1 and out[0][0] <= xs[0] and out[-1][1] >= end - 1e-12:
            first = out.pop(0)  # the interval through ±π
            out[-1][1] = first[1] + 2 * math.pi
    res = [(float(a), float(b)) for a, b in out]
    res.sort()
    return res



def nearest_assemblable(ck, x: float) -> tuple[float, ...]:
    """The nearest assemblable input values below and above ``x`` (display units).

    ``(x,)`` when ``x`` itself is inside a reachable range.

    Examples
    --------
    >>> ck = ls.fourbar(4, 3, 3.5, 5).compile()
    >>> [round(v, 6) for v in nearest_assemblable(ck, 0.0)]
    [-18.57335, 18.57335]
    """
    kern = Kernel(ck)
    xs = input_samples(ck, kern)
    if not kern.angle_x and not xs[0] <= x <= xs[-1]:
        return _nearest_from_ranges(ck, kern, x)
    return _nearest_local(ck, kern, xs, x)



def _nearest_local(ck, kern, xs, x):
    """:func:`nearest_assemblable` without the whole :func:`reachable_ranges`: the same samples and
    the same traces, but only those of the sampling intervals from ``x`` outwards to the first
    assemblable sample on each side (the ends of the ranges next to ``x``, the same numbers)."""
    from .modes import block_feeds

    feeds = block_feeds(ck)
    m, step = len(xs), xs[1] - xs[0]
    angle = kern.angle_x
    n_int = m if angle else m - 1  # sampling intervals [xs[i], xs[i] + step]
    memo: dict[int, list] = {}

    def sols(i):
        i %= m
        if i not in memo:
            memo[i] = _assemblable_at(ck, xs[i], feeds)
        return memo[i]

    def shift(k):  # interval k (unwrapped) -> (its index, the input offset of its turn)
        if not angle:
            return k, 0.0
        return k % m, 2 * math.pi * (k // m)

    t = (x - xs[0]) / step
    k0 = min(int(math.floor(t)), n_int - 1) if not angle else int(math.floor(t))
    i0, sh0 = shift(k0)
    xa, xb = xs[i0], xs[i0] + step
    disp = lambda v: display_value(ck, v, ck.inputs[0])  # noqa: E731
    ea = _reach(ck, kern, sols(i0), xa, xb) if sols(i0) else None
    eb = _reach(ck, kern, sols(i0 + 1), xb, xa) if sols(i0 + 1) else None
    xr = x - sh0
    if (ea is not None and ea >= xr) or (eb is not None and eb <= xr):
        return (disp(x),)  # inside a reachable range
    below = ea + sh0 if ea is not None else None
    above = eb + sh0 if eb is not None else None
    for d in range(1, n_int):
        if below is not None:
            break
        k = k0 - d
        if not angle and k < 0:
            break
        i, sh = shift(k)
        if sols(i):
            below = _reach(ck, kern, sols(i), xs[i], xs[i] + step) + sh
    for d in range(1, n_int):
        if above is not None:
            break
        k = k0 + d
        if not angle and k >= n_int:
            break
        i, sh = shift(k)
        if sols(i + 1):
            above = _reach(ck, kern, sols(i + 1), xs[i] + step, xs[i]) + sh
    return tuple(disp(v) for v in (below, above) if v is not None)



def _nearest_from_ranges(ck, kern, x):
    """:func:`nearest_assemblable` from the whole :func:`reachable_ranges` (an input beyond the samples)."""
    ranges = reachable_ranges(ck)
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
