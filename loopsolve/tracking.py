"""Sweeps of the input with branch tracking.

From the solved start, every output point is reached by internal steps: a tangent predictor
(the kinematic coefficients dq/dx from the velocity solution), a Newton corrector, and a check
that the assembly-mode signature did not change. A failed or mode-changing step is halved;
when the step cannot shrink further the sweep stops and records why (a limit position where
the input cannot go further, or a singular position). The output grid is not the internal
step, so a coarse grid never loses the branch.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .errors import AssemblyError, ModelError, SolveError
from .newton import Newton, NewtonStatus, newton
from .results import Event, EventKind, State, Sweep
from .solve import (SINGULAR_COND, display_value, initial_z, input_rates, input_value, solve, solve_position,
                    solve_rates)
from .units import Kind

__all__ = ["StepControl", "sweep", "grid"]


@dataclass(frozen=True, slots=True)
class StepControl:
    """Internal step control of the tracker (input units: radians or length unit).

    ``max_step`` bounds one internal step; ``min_step`` is where halving gives up;
    ``max_angle`` bounds the change of the unknowns in one step (radians / fraction of scale).
    """

    max_step: float = math.radians(2.0)
    min_step: float = 1e-10
    max_change: float = 0.1


def grid(start: float, stop: float, step: float) -> np.ndarray:
    """Output grid from ``start`` to ``stop`` (inclusive when it falls on the grid)."""
    if step == 0 or not math.isfinite(step):
        raise ModelError("--step must be a nonzero number")
    if (stop - start) * step < 0:
        step = -step
    n = int(math.floor((stop - start) / step + 1e-9))
    g = start + step * np.arange(n + 1)
    if abs(g[-1] - stop) > 1e-9 * max(1.0, abs(stop)) and n >= 0 and abs(stop - g[-1]) > 1e-12:
        pass  # the range does not end on the grid: stop at the last grid point
    return g


def _progress(total: int, enabled: bool | None):
    if enabled is None:
        enabled = sys.stderr.isatty() and total >= 200
    if not enabled:
        return None
    try:
        from tqdm import tqdm
    except ImportError:
        return None
    return tqdm(total=total, unit="pt", file=sys.stderr, leave=False)


def sweep(mech, start, stop, step, *, speed=None, accel=None, jerk=None, input: str | None = None,
          mode: str | None = None, guess: dict | None = None, compiled=None,
          through_limits: bool = False, progress: bool | None = None,
          control: StepControl = StepControl(), settings: Newton = Newton()) -> Sweep:
    """Sweep the input from ``start`` to ``stop`` by ``step`` (display units), tracking the mode.

    Returns a :class:`~loopsolve.results.Sweep`. A sweep that reaches a limit position stops
    there with a ``limit`` event and the rows computed so far.

    Examples
    --------
    >>> mech = ls.load(ls.models_dir() / "thesis_crank_rocker.toml")
    >>> sw = mech.sweep(0, 360, 30)
    >>> len(sw), sw.mode, round(float(sw["theta4"][3]), 2)
    (13, '-', 80.72)
    """
    ck = compiled if compiled is not None else mech.compile(input)
    name = ck.inputs[0]
    xs = [input_value(ck, v, name) for v in (start, stop)]
    kind = ck.kinds[ck.index(name)]
    u = ck.mechanism.units
    step_int = input_value(ck, step, name) if kind is Kind.LENGTH or isinstance(step, str) else \
        (math.radians(float(step)) if u.angle == "deg" else float(step))
    g = grid(xs[0], xs[1], step_int)
    rates = input_rates(ck, speed, accel, jerk)
    first = solve(mech, display_value(ck, g[0], name), speed=rates[0], accel=rates[1], jerk=rates[2],
                  mode=mode, guess=guess, compiled=ck, settings=settings) if True else None
    states = [first]
    events: list[Event] = []
    sig = first.mode
    z = first.z.copy()
    max_step = control.max_step if kind is Kind.ANGLE else control.max_step * ck.scale / 2
    min_step = control.min_step * (1 if kind is Kind.ANGLE else ck.scale)
    bar = _progress(len(g), progress)
    try:
        for target in g[1:]:
            z, stop_event = _advance(ck, z, float(target), sig, max_step, min_step, settings)
            if stop_event is not None:
                events.append(stop_event)
                break
            disp = display_value(ck, target, name)
            try:
                z1, z2, z3, pts, cond = solve_rates(ck, z, rates, display_input=disp)
            except SolveError as exc:
                events.append(Event(EventKind.SINGULAR, disp, str(exc)))
                break
            states.append(State(ck, z.copy(), z1, z2, z3, pts, sig, float(np.max(np.abs(ck.phi(z)))), 0, cond))
            if bar is not None:
                bar.update(1)
    finally:
        if bar is not None:
            bar.close()
    return Sweep(ck, tuple(states), tuple(events), sig)


def _tangent(ck, z) -> np.ndarray:
    """dz/dx: kinematic coefficients of every variable along the driving input."""
    J = ck.jac(z)
    zk = np.zeros(len(ck.variables))
    zk[ck.input_idx[0]] = 1.0
    b = ck.rhs(1, z, zk)
    zk[ck.unknown_idx] = np.linalg.solve(J, b)
    return zk


def _correct(ck, z_pred, settings) -> tuple[np.ndarray | None, float]:
    try:
        z, residual, _ = solve_position(ck, z_pred, settings=settings)
    except SolveError:
        return None, math.inf
    return z, residual


def _advance(ck, z, target, sig, max_step, min_step, settings):
    """Move the input from its value in ``z`` to ``target`` in adaptive steps on the same branch."""
    i = ck.input_idx[0]
    x = z[i]
    h = min(max_step, abs(target - x))
    direction = 1.0 if target >= x else -1.0
    name = ck.inputs[0]
    while abs(target - x) > 1e-15 * max(1.0, abs(target)):
        h = min(h, abs(target - x))
        try:
            t = _tangent(ck, z)
        except np.linalg.LinAlgError:
            t = None
        if t is None or not np.all(np.isfinite(t)):
            disp = display_value(ck, x, name)
            return z, Event(EventKind.SINGULAR, disp, f"singular position at {name} = {disp:.10g}")
        z_pred = z + direction * h * t
        z_pred[i] = x + direction * h
        change = float(np.max(np.abs((z_pred - z)[ck.unknown_idx])))
        if change > 0.3 and h > min_step:
            h *= 0.5
            continue
        z_new, _ = _correct(ck, z_pred, settings)
        ok = z_new is not None and float(np.max(np.abs((z_new - z_pred)[ck.unknown_idx]))) < 0.2 * max(change, 1e-3) + 1e-6 \
            and ck.signature(z_new) == sig
        if ok:
            z = z_new
            x = z[i]
            h = min(h * 1.5, max_step)
            continue
        if h <= min_step:
            disp = display_value(ck, x, name)
            return z, Event(EventKind.LIMIT, disp,
                            f"the input cannot go beyond {name} = {disp:.10g} on this assembly mode "
                            "(limit position: toggle/fold); the rows stop here")
        h *= 0.5
    return z, None
