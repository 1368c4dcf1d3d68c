"""Forward dynamics: integrate the one-degree-of-freedom equation of motion with scipy's ``solve_ivp``.

    M(x) ẍ + ½ M′(x) ẋ² = Q(x, ẋ, t) + T(x, ẋ, t)

(see :mod:`loopsolve.dynamics.dynamics_model`). At every evaluation the pose is solved by Newton from the last
one, so the assembly mode is tracked; a limit position (the Jacobian of the loops turning singular)
is a terminal event, reported, not a crash. Energy is conserved to the integration accuracy when
no power enters or leaves.
"""

from __future__ import annotations

import csv
import io
import json
import math
import numbers
from dataclasses import dataclass, field

import numpy as np

from .dynamics_model import DynamicsModel, compile_drive, compile_dynamics, mass_terms_from
from ..errors import ModelError, SolveError, warn
from .kinetostatics import generalized_from, inverse_dynamics
from ..kinematics.results import Event, EventKind, finite_or_none
from ..model.units import Kind, unit_label

__all__ = ["Simulation", "simulate", "equation_of_motion_rhs", "NonFiniteError", "MAX_STEPS", "MIN_STEP"]


@dataclass(frozen=True, eq=False)
class Simulation:
    """Rows of a simulation at ``t`` = 0, step, 2·step, … in the units the CLI prints.

    Users receive one from :func:`loopsolve.simulate` (``mech.simulate``); they need not construct
    one. :meth:`units` names the unit of every column and of ``t``, ``x``, ``xd``, ``xdd``.

    Parameters
    ----------
    compiled : CompiledKinematics
        The compiled mechanism simulated.
    t, x, xd, xdd, z, kinetic_energy, potential_energy : numpy.ndarray
        The attributes below.
    modes, events : tuple, optional
        The assembly mode per row and the events.
    message : str, optional
        The integrator's message.

    Attributes
    ----------
    t : numpy.ndarray
        Times (s).
    x : numpy.ndarray
        The input, continuous (not wrapped), in the model's units: degrees in a degree model, the
        model's length unit for a slider (``mech.solve(sim.x[i])`` is the pose of row i).
    xd, xdd : numpy.ndarray
        The input's speed and acceleration (rad/s, rad/s², or length unit/s, /s²).
    z : numpy.ndarray
        ``(N, nvar)`` the poses in internal units (radians, as ``Sweep.z``).
    kinetic_energy, potential_energy : numpy.ndarray
        Energies (J).
    modes : tuple
        The assembly mode at every row.
    events : tuple of Event
        A limit reached stops the integration.
    message : str
        The integrator's message.
    compiled : CompiledKinematics
        The compiled mechanism.

    Examples
    --------
    >>> import loopsolve as ls
    >>> mech = ls.load(ls.models_dir() / "thesis_crank_rocker_dynamics.toml")
    >>> sim = ls.simulate(mech, 0.1, step=0.05, speed0="60rpm")
    >>> [float(t) for t in sim.t], round(float(sim.xd[0]), 4), sim.units()["xd"]
    ([0.0, 0.05, 0.1], 6.2832, 'rad/s')
    """

    compiled: object = field(repr=False)
    t: np.ndarray
    x: np.ndarray
    xd: np.ndarray
    xdd: np.ndarray
    z: np.ndarray = field(repr=False)
    kinetic_energy: np.ndarray
    potential_energy: np.ndarray
    modes: tuple = ()
    events: tuple = ()
    message: str = ""

    @property
    def input(self) -> str:
        return self.compiled.inputs[0]

    @property
    def total_energy(self) -> np.ndarray:
        return self.kinetic_energy + self.potential_energy

    @property
    def columns(self) -> dict:
        name = self.input
        return {"t": self.t, name: self.x, name + "_vel": self.xd,
                name + "_acc": self.xdd, "kinetic_energy": self.kinetic_energy,
                "potential_energy": self.potential_energy}

    def units(self) -> dict:
        ck = self.compiled
        name = self.input
        u = ck.mechanism.units
        kind = ck.kinds[ck.index(name)]
        kinds = ((Kind.ANGLE, Kind.ANGULAR_RATE, Kind.ANGULAR_ACCEL) if kind is Kind.ANGLE
                 else (Kind.LENGTH, Kind.LENGTH_RATE, Kind.LENGTH_ACCEL))
        out = {"t": "s"}
        for suffix, k in zip(("", "_vel", "_acc"), kinds):
            out[name + suffix] = unit_label(k, u.angle, u.length)
        out.update(kinetic_energy="J", potential_energy="J")
        out.update(x=out[name], xd=out[name + "_vel"], xdd=out[name + "_acc"])
        return out

    @property
    def rows(self) -> list[dict]:
        cols = self.columns
        keys = list(cols)
        out = []
        for i in range(len(self.t)):
            r = {k: finite_or_none(cols[k][i]) for k in keys}
            r["mode"] = self.modes[i] if i < len(self.modes) else ""
            out.append(r)
        return out

    def to_json(self, *, indent: int | None = 1) -> str:
        ck = self.compiled
        u = ck.mechanism.units
        return json.dumps({"mechanism": ck.mechanism.name, "input": self.input,
                           "units": {"length": u.length, "angle": u.angle, **self.units()},
                           "rows": self.rows, "events": [e.to_dict() for e in self.events]},
                          indent=indent, allow_nan=False)

    def to_csv(self) -> str:
        units = self.units()
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        keys = list(self.columns)
        w.writerow([f"{k} [{units[k]}]" for k in keys] + ["mode"])
        for r in self.rows:
            w.writerow(["" if r[k] is None else repr(float(r[k])) for k in keys] + [r["mode"]])
        return buf.getvalue()

    def table(self) -> str:
        units = self.units()
        keys = list(self.columns)
        headers = [f"{k} [{units[k]}]" for k in keys] + ["mode"]
        widths = [max(len(h), 12) for h in headers]
        out = [f"{self.compiled.mechanism.name}: simulation of {self.input} ({len(self.t)} rows)",
               "  ".join(h.rjust(w) for h, w in zip(headers, widths))]
        cols = self.columns
        for i in range(len(self.t)):
            cells = [f"{float(cols[k][i]) + 0.0:.6g}" for k in keys] + [self.modes[i] if i < len(self.modes) else ""]
            out.append("  ".join(c.rjust(w) for c, w in zip(cells, widths)))
        for e in self.events:
            out.append(f"{e.kind.value} at t = {e.input:.10g} s: {e.message}")
        return "\n".join(out) + "\n"


#: the integration stops (an event, the rows so far kept, a warning) after this many steps (plus 200
#: per output row) ...
MAX_STEPS = 20000
#: ... or when a step falls below this fraction of the duration (no wall clock: the work is bounded)
MIN_STEP = 1e-9

#: condition number of Φ_q (columns scaled: angles 1, lengths the model's scale) above which a
#: simulation stops at a limit position of its input (the input cannot carry the motion through it)
LIMIT_COND = 1e3


class _Pose:
    """The pose at an input value, solved by Newton from the last pose (the mode is tracked).

    Scalar compiled code only (one pose per call): a predictor along the kinematic coefficients,
    then Newton on Φ(q; x) = 0; the kinematic coefficients at the solution are kept.
    """

    def __init__(self, ck, z0):
        self.ck = ck
        self.ix = int(ck.input_idx[0])
        self.iq = ck.unknown_idx
        self.nv = len(ck.variables)
        self.z = np.array(z0, dtype=float)
        self.d1, self.d2 = self.coefficients(self.z)
        #: longest input step taken at once (0.05 rad, or 1 % of the model's length scale)
        self.max_step = 0.05 if ck.kinds[self.ix] is Kind.ANGLE else 0.01 * ck.scale

    def coefficients(self, z):
        ck = self.ck
        J = ck.jac(z)
        d1 = np.zeros(self.nv)
        d1[self.ix] = 1.0
        d1[self.iq] = np.linalg.solve(J, ck.rhs(1, z, d1))
        d2 = np.zeros(self.nv)
        d2[self.iq] = np.linalg.solve(J, ck.rhs(2, z, d1, d2))
        return d1, d2

    def at(self, x: float) -> np.ndarray:
        if self.z[self.ix] == x:
            return self.z
        x0 = self.z[self.ix]
        n = int(min(10000, np.ceil(abs(x - x0) / self.max_step)))
        for k in range(1, n):  # continuation in short steps: Newton never jumps to another mode
            self._step(x0 + (x - x0) * k / n)
        return self._step(x)

    def _step(self, x: float) -> np.ndarray:
        ck = self.ck
        h = x - self.z[self.ix]
        z = self.z + self.d1 * h + 0.5 * self.d2 * h * h
        z[self.ix] = x
        tol = 1e-13 * ck.scale
        for _ in range(30):
            f = ck.phi(z)
            if not np.all(np.isfinite(f)):
                break
            dq = np.linalg.solve(ck.jac(z), -f)
            z[self.iq] += dq
            if np.max(np.abs(dq)) <= 1e-15 * (1 + np.max(np.abs(z))) or np.max(np.abs(f)) <= tol:
                f = ck.phi(z)
                if np.max(np.abs(f)) <= 1e-9 * ck.scale:
                    self.z = z
                    self.d1, self.d2 = self.coefficients(z)
                    return z
        from ..kinematics.solve import solve_position

        z, _, _ = solve_position(ck, z)  # the robust solver, which raises a named error on failure
        self.z = z
        self.d1, self.d2 = self.coefficients(z)
        return z


class NonFiniteError(SolveError):
    """The equation of motion is not a finite number at some state (a load outside its domain)."""


def equation_of_motion_rhs(dm: DynamicsModel, pose: _Pose, x, xd, t, drive) -> float:
    """ẍ (internal units) at the input ``x`` with speed ``xd``: (Q + T − ½ M′ Ẋ²) / (M s).

    Raises :class:`NonFiniteError` naming the load (or the driving torque) that is not a finite
    number there, and the time.
    """
    z = pose.at(x)
    d1, d2 = pose.d1, pose.d2
    with np.errstate(all="ignore"):
        e1 = dm.evaluate(z, d1, d2)
        loads = dm.evaluate(z, d1 * xd, np.zeros_like(z))["load"] if dm.loads_use_rates else e1["load"]
        M, dM = mass_terms_from(dm, e1)
        Q = generalized_from(dm, e1, loads, xd)
    s = dm.coord_factor
    T = drive(x, xd, t)
    acc = float((Q[0] + T - 0.5 * dM[0] * (s * xd) ** 2) / (M[0] * s))
    if not np.isfinite(acc):
        raise NonFiniteError(_nonfinite_message(dm, z, loads, T, t, x, xd))
    mech = dm.ck.mechanism
    if mech.pairs is not None and mech.pairs.friction and xd != 0:
        acc = _with_friction(dm, z, xd, T, acc, float(M[0] * s), t)
    return acc


class SelfLockingError(SolveError):
    """The mechanism self-locks: with its joints' friction no driving torque moves it on (simulation)."""


def _with_friction(dm, z, xd, T, acc, inertia, t) -> float:
    """ẍ with Coulomb friction: the input acceleration whose inverse dynamics (with the joints' friction,
    :mod:`loopsolve.dynamics.friction`) needs the applied driving torque T. The required torque is piecewise
    linear in ẍ (slope the generalized inertia, where the friction's signs hold): secant steps from the
    frictionless ẍ."""
    from .kinetostatics import inverse_dynamics

    def excess(a):
        data = inverse_dynamics(dm, z[None, :], xd, a, check=False)
        return float(data["drive"][0]) - T

    a0, f0 = acc, excess(acc)
    if not np.isfinite(f0):
        raise SelfLockingError(f"self-locking at t = {t:.6g} s: with the joints' friction no driving torque moves the "
                               "mechanism on")
    a1 = a0 - f0 / inertia
    for _ in range(8):
        f1 = excess(a1)
        if not np.isfinite(f1):
            raise SelfLockingError(f"self-locking at t = {t:.6g} s: with the joints' friction no driving torque moves "
                                   "the mechanism on")
        if abs(f1) <= 1e-10 * (abs(T) + abs(inertia * a1) + 1e-300):
            return a1
        slope = (f1 - f0) / (a1 - a0) if a1 != a0 else inertia
        a0, f0 = a1, f1
        a1 = a1 - f1 / (slope if slope != 0 else inertia)
    return a1


def _safe_acc(dm, pose, x, xd, t, drive) -> float:
    try:
        return equation_of_motion_rhs(dm, pose, x, xd, t, drive)
    except SelfLockingError:
        return math.nan


def _nonfinite_message(dm, z, loads, T, t, x, xd) -> str:
    ck = dm.ck
    mech = ck.mechanism
    from ..kinematics.results import in_display_units

    where = ", ".join(f"{n} = {float(in_display_units(ck, n, 0, z[ck.index(n)], wrap=False)):.6g}"
                      for n in ck.variables)
    what = "the equation of motion (the mass properties or the kinematic coefficients)"
    if not np.isfinite(T):
        what = f"the driving {'torque' if dm.input_kind.name == 'ANGLE' else 'force'} (--torque) is {T} there"
    else:
        for (i, c), v in zip(dm.load_slots, np.asarray(loads).reshape(len(dm.load_slots), -1)[:, 0]):
            if not np.isfinite(v):
                ld = dm.dynamics.loads[i]
                what = (f"the load {ld.name!r} (loads[{ld.index}]) is {v} there: its expression is outside its domain "
                        "(a power of a negative number, a division by zero, ...)")
                break
    return (f"{mech.source or mech.name}: the simulation cannot go on at t = {t:.10g} s ({where}, "
            f"{ck.inputs[0]}_vel = {xd:.6g}): {what}")


def simulate(mech, duration: float, *, step: float = 0.01, torque=0.0, speed0=None, at=None, input=None,
             mode=None, rtol: float = 1e-11, atol: float = 1e-12, method: str = "DOP853",
             max_steps: int | None = None) -> Simulation:
    """Integrate the equation of motion from rest (or ``speed0``) at ``at`` for ``duration`` seconds.

    Parameters
    ----------
    torque : float, str or callable
        Driving torque (N·m) or force (N, length input): a number, an expression of the input
        (model units), ``<input>_vel`` and ``t`` (``"2 - 0.1*theta2_vel"``, a motor curve), or a
        Python callable ``f(t, x, xd)`` of time and the input in internal units (rad, rad/s).
    speed0 : float or str, optional
        Initial input speed (``"60rpm"``); default the model's, else 0.

    max_steps : int, optional
        Bound on the integrator's steps (default ``MAX_STEPS`` + 200 per output row). The
        integration also stops when a step falls below ``MIN_STEP`` times the duration; either way
        the rows so far are kept, with a ``singular`` event and a warning (no wall clock involved).
        No step is longer than ``step`` (the output step).

    Returns
    -------
    Simulation

    Raises
    ------
    NonFiniteError
        A load (or the driving torque) is not a finite number at a state reached; names the load
        and the time. Its ``result`` holds the rows up to there (``None`` when it fails at t = 0).

    Examples
    --------
    >>> mech = ls.load(ls.models_dir() / "thesis_crank_rocker_dynamics.toml")
    >>> sim = ls.simulate(mech, 0.1, step=0.05, speed0="60rpm")
    >>> len(sim.t), sim.events, round(float(sim.x[0]), 4), sim.units()["x"]
    (3, (), 90.0, 'deg')
    """
    from scipy.integrate import DOP853, LSODA, RK45, Radau

    if not duration > 0 or not step > 0:
        raise ModelError(f"--duration and --step must be positive (got {duration!r}, {step!r})")
    ck = mech.compile(input)
    if callable(torque):
        user = torque

        def drive(x, xd, t):
            return float(user(t, x, xd))
    else:
        drive = compile_drive(mech, str(torque), ck.inputs)
    state0 = mech.solve(at, input=input, mode=mode, compiled=ck)
    dm = compile_dynamics(mech, compiled=ck)
    from .declcheck import check_carriers

    check_carriers(dm, state0.z[None, :])  # a declaration slip is an error before any integration
    ix = ck.input_idx[0]
    if speed0 is None:
        declared = mech.variable(ck.inputs[0]).speed
        w0 = declared if declared is not None else 0.0
    else:
        from ..model.units import parse_quantity

        u = mech.units
        w0 = parse_quantity(speed0, Kind.ANGULAR_RATE if ck.kinds[ix] is Kind.ANGLE else Kind.LENGTH_RATE,
                            angle_unit=u.angle, length_unit=u.length, where="--speed0")
    pose = _Pose(ck, state0.z)
    sig0 = ck.signature(state0.z)
    failure: list = []

    class _Stop(Exception):
        pass

    def limit_event(t_at: float, why) -> Event:
        return Event(EventKind.LIMIT, float(t_at), f"{ck.inputs[0]} reaches a limit position just after t = "
                     f"{t_at:.6g} s ({why}): the integration stops here")

    col_scale = np.array([1.0 if k_ is Kind.ANGLE else ck.scale for k_ in ck.kinds])[ck.unknown_idx]

    def rhs(t, y):
        try:
            acc = equation_of_motion_rhs(dm, pose, y[0], y[1], t, drive)
        except NonFiniteError:
            raise
        except SolveError as exc:
            failure.append((t, exc))
            raise _Stop from None
        kappa = np.linalg.cond(ck.jac(pose.z) * col_scale)
        if not kappa < LIMIT_COND:  # a dead centre of the input: the coordinate cannot carry the motion on
            failure.append((t, f"the loops' Jacobian is nearly singular (condition {kappa:.3g})"))
            raise _Stop
        return np.array([y[1], acc])

    n = int(math.floor(duration / step + 1e-9))
    t_eval = np.linspace(0.0, n * step, n + 1)
    solvers = {"RK45": RK45, "DOP853": DOP853, "Radau": Radau, "LSODA": LSODA}
    if method not in solvers:
        raise ModelError(f"unknown integration method {method!r} (one of {', '.join(solvers)})")
    y0 = np.array([state0.z[ix], w0])
    out_t, out_y = [0.0], [y0]
    events = []
    message = "the integration reached the duration"
    check = _Pose(ck, state0.z)  # the pose at the accepted steps: a mode change there is a limit passed
    t_end = float(t_eval[-1])
    if max_steps is None:
        max_steps = MAX_STEPS + 200 * len(t_eval)
    elif isinstance(max_steps, bool) or not isinstance(max_steps, numbers.Integral) or max_steps < 1:
        raise ModelError(f"--max-steps (max_steps=) {max_steps!r}: the bound on the integrator's steps must be a "
                         "whole number of at least 1 (default: 20000 + 200 per output row)")
    h_min = MIN_STEP * t_end
    try:
        solver = solvers[method](rhs, 0.0, y0, t_end, rtol=rtol, atol=atol, max_step=step)
    except NonFiniteError as exc:  # at the start: nothing to keep
        raise NonFiniteError(str(exc)) from None
    except _Stop:  # the start itself is at (or within round-off of) a limit position
        solver = None
        events.append(limit_event(0.0, failure[-1][1]))
        message = "stopped at a limit position"
    k = 1
    steps = 0
    capped = False
    fatal = None
    while solver is not None and solver.status == "running" and k < len(t_eval):
        t_before = solver.t
        try:
            solver.step()
        except NonFiniteError as exc:
            fatal = exc
            break
        except _Stop:
            if isinstance(failure[-1][1], SelfLockingError):
                events.append(Event(EventKind.SELF_LOCKING, float(t_before), str(failure[-1][1])))
                message = "stopped: the mechanism self-locks"
            else:
                events.append(limit_event(t_before, failure[-1][1]))
                message = "stopped at a limit position"
            break
        steps += 1
        if solver.status == "running" and (steps >= max_steps or (solver.step_size is not None
                                                                  and solver.step_size < h_min)):
            why = (f"{steps} integration steps (max_steps)" if steps >= max_steps else
                   f"an integration step of {solver.step_size:.3g} s, below {MIN_STEP:g} of the duration")
            message = (f"the integration stopped at t = {solver.t:.6g} s after {why}: the equation of motion is "
                       "stiff or singular there (a torque or load growing without bound?); the rows so far are kept")
            events.append(Event(EventKind.SINGULAR, float(solver.t), message))
            warn(f"{mech.source or mech.name}: {message}")
            capped = True
        if solver.status == "failed" or not np.all(np.isfinite(solver.y)):
            message = f"the integrator failed at t = {solver.t:.6g} s"
            events.append(Event(EventKind.SINGULAR, float(t_before), message))
            break
        try:
            sig = ck.signature(check.at(solver.y[0]))
        except SolveError:
            sig = "?"
        dense = solver.dense_output()
        if sig != sig0:
            events.append(Event(EventKind.LIMIT, float(t_before), f"a limit position of {ck.inputs[0]} is reached "
                                f"between t = {t_before:.6g} s and {solver.t:.6g} s (the loops' Jacobian turns "
                                "singular): the integration stops here"))
            message = "stopped at a limit position"
            break
        while k < len(t_eval) and t_eval[k] <= solver.t + 1e-12 * max(1.0, solver.t):
            out_t.append(float(t_eval[k]))
            out_y.append(dense(min(t_eval[k], solver.t)))
            k += 1
        if capped:
            break
    ts = np.array(out_t)
    xs = np.array([y[0] for y in out_y])
    ws = np.array([y[1] for y in out_y])
    # poses at the output times, tracked in order from the start
    out_pose = _Pose(ck, state0.z)
    zs = np.array([out_pose.at(x).copy() for x in xs]) if len(xs) else np.zeros((0, len(ck.variables)))
    acc_pose = _Pose(ck, state0.z)
    acc = np.array([_safe_acc(dm, acc_pose, x, w, t, drive) for x, w, t in zip(xs, ws, ts)])
    if len(xs):
        data = inverse_dynamics(dm, zs, ws, acc)
        ke, pe = data["kinetic_energy"], data["potential_energy"]
        modes = tuple(ck.signature(z) for z in zs)
    else:
        ke = pe = np.zeros(0)
        modes = ()
    deg = ck.kinds[ix] is Kind.ANGLE and mech.units.angle == "deg"
    sim = Simulation(ck, ts, np.degrees(xs) if deg else xs, ws, acc, zs, ke, pe, modes, tuple(events), message)
    if fatal is not None:
        raise NonFiniteError(f"{fatal} (the {len(ts)} rows up to t = {ts[-1]:.6g} s are in the error's `result`)",
                             result=sim)
    return sim
