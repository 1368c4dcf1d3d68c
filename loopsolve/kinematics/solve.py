"""Solve one position: Newton block by block, then the velocity, acceleration and jerk.

:func:`solve` is the one-input-value entry point behind ``Mechanism.solve`` and
``loopsolve solve``; :func:`solve_position` and :func:`solve_rates` are the two halves,
reused by the sweep tracker.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence

import numpy as np

from ..symbolic.compiled import CompiledKinematics
from ..errors import (AssemblyError, ConvergenceError, LoopsolveWarning, ModeError, ModelError,
                     SingularPositionError)
from ..model.mechanism import Mechanism
from .newton import Newton, NewtonStatus, newton
from .results import State
from ..model.units import MAX_MAGNITUDE, Kind, angle_factor, parse_quantity, to_display

__all__ = ["solve", "start_position", "solve_position", "solve_rates", "initial_z", "input_value", "input_rates",
           "guessed_mode", "block_signs", "signature_matches", "SINGULAR_COND", "GUESS_SINGULAR"]

#: a Jacobian block whose condition number exceeds this is treated as singular
SINGULAR_COND = 1e10
#: ... and so is one where the position uncertainty exceeds this fraction of the distance to
#: the nearest singular configuration (see :func:`solve_rates`)
SINGULAR_RATIO = 1e-2
#: an input this close (display units) to a located limit position is at it
_AT_LIMIT = 1e-9
#: relative round-off of a loop closure: the residual a position is known to, at best
_EPS_POSITION = 8 * 2.220446049250313e-16


def input_value(ck: CompiledKinematics, value, name: str | None = None, *, reduce: bool = True) -> float:
    """Convert a user input value (number in display units, or a string with a unit) to internal units.

    An angle of 65536 turns or more is reduced modulo a turn exactly in its own unit first
    (``--at 1e17`` is 280°, see :func:`loopsolve.model.units.parse_quantity`); pass ``reduce=False``
    for an increment (a sweep step). A value that is not finite after conversion is an error.
    """
    name = name or ck.inputs[0]
    kind = ck.kinds[ck.index(name)]
    u = ck.mechanism.units
    return parse_quantity(value, kind, angle_unit=u.angle, length_unit=u.length, where=f"input {name}",
                          reduce=reduce)


#: kinds whose plain number is already in internal units (parse_quantity returns it as it is)
_PLAIN_AS_IS = frozenset({Kind.LENGTH, Kind.LENGTH_RATE, Kind.LENGTH_ACCEL, Kind.LENGTH_JERK, Kind.ANGULAR_RATE,
                          Kind.ANGULAR_ACCEL, Kind.ANGULAR_JERK})
_ANGLE_FACTORS: dict = {}


def plain_value(ck: CompiledKinematics, value, kind: Kind) -> float | None:
    """``parse_quantity(value, kind, reduce=False)`` in ``ck``'s units for a plain finite ``int`` or
    ``float``, without the unit parser (a sweep's front end runs per call); None for anything else
    (strings, other types, values the parser refuses): the parser then decides, with its errors."""
    tv = type(value)
    if tv is not float and tv is not int:
        return None
    try:
        x = float(value)
    except OverflowError:
        return None
    if kind is Kind.ANGLE:
        unit = ck.mechanism.units.angle
        f = _ANGLE_FACTORS.get(unit)
        if f is None:
            f = _ANGLE_FACTORS[unit] = angle_factor(unit)
        x = x * f
    elif kind not in _PLAIN_AS_IS or not abs(x) <= MAX_MAGNITUDE:
        return None
    return x if math.isfinite(x) else None


def display_value(ck: CompiledKinematics, internal: float, name: str | None = None) -> float:
    """Internal value of an input (radians...) in display units (degrees...)."""
    name = name or ck.inputs[0]
    kind = ck.kinds[ck.index(name)]
    u = ck.mechanism.units
    return float(to_display(internal, kind, u.angle, u.length))


def initial_z(ck: CompiledKinematics, *, guess: dict | None = None, warn: bool = True) -> np.ndarray:
    """All variables at their declared guesses (internal units); ``guess`` overrides by name."""
    mech = ck.mechanism
    z = np.zeros(len(ck.variables))
    missing = []
    for v in mech.variables:
        i = ck.index(v.name)
        if guess and v.name in guess:
            z[i] = guess[v.name]
        elif v.guess is not None:
            z[i] = v.guess
        elif v.name not in ck.inputs:
            missing.append(v.name)
            z[i] = ck.scale if v.kind is Kind.LENGTH else 0.0
        elif v.kind is Kind.LENGTH:
            z[i] = ck.scale
    if missing and warn:
        warnings.warn(
            f"{mech.name}: no guess for {', '.join(missing)}; starting from 0 (angles) or "
            f"{ck.scale:g} (lengths). Guesses pick the assembly mode: give them in [variables] "
            "or choose a mode with --mode SIGNATURE (mode= in Python; `loopsolve modes` lists them)",
            LoopsolveWarning,
            stacklevel=3,
        )
    return z


def input_rates(ck: CompiledKinematics, speed=None, accel=None, jerk=None) -> tuple[float, float, float]:
    """Rates of the driving input (internal units): arguments, else the model's, else 1, 0, 0."""
    name = ck.inputs[0]
    var = ck.mechanism.variable(name)
    u = ck.mechanism.units
    kinds = ((Kind.ANGULAR_RATE, Kind.ANGULAR_ACCEL, Kind.ANGULAR_JERK) if var.kind is Kind.ANGLE
             else (Kind.LENGTH_RATE, Kind.LENGTH_ACCEL, Kind.LENGTH_JERK))
    out = []
    for given, declared, kind, default, label in ((speed, var.speed, kinds[0], 1.0, "speed"),
                                                  (accel, var.accel, kinds[1], 0.0, "accel"),
                                                  (jerk, var.jerk, kinds[2], 0.0, "jerk")):
        if given is not None:
            x = plain_value(ck, given, kind)
            out.append(x if x is not None else parse_quantity(given, kind, angle_unit=u.angle, length_unit=u.length,
                                                              where=f"--{label}"))
        elif declared is not None:
            out.append(declared)
        else:
            out.append(default)
    return out[0], out[1], out[2]


def solve_position(ck: CompiledKinematics, z0: np.ndarray, *, settings: Newton = Newton(),
                   display_input: float | None = None):
    """Newton on each block in solve order, from ``z0`` (inputs already set).

    Returns ``(z, residual, n_iter)``; raises :class:`AssemblyError` or
    :class:`ConvergenceError` naming the input value.
    """
    z = np.array(z0, dtype=float)
    total_iter = 0
    worst = 0.0
    for b in ck.blocks:
        eqs = np.array(b.eqs)
        cols = np.array(b.unknowns)
        zi = ck.unknown_idx[cols]

        def fun(u, zi=zi, eqs=eqs):
            z[zi] = u
            return ck.phi(z)[eqs]

        def jac(u, zi=zi, eqs=eqs, cols=cols):
            z[zi] = u
            return ck.jac(z)[np.ix_(eqs, cols)]

        res = newton(fun, jac, z[zi].copy(), scale=ck.scale, settings=settings)
        z[zi] = res.x
        total_iter += res.n_iter
        worst = max(worst, res.residual)
        if res.status is not NewtonStatus.CONVERGED:
            _raise_failure(ck, res, z, b, display_input)
    return z, worst, total_iter


def _raise_failure(ck, res, z, block, display_input):
    name = ck.inputs[0]
    unit = input_unit(ck)
    where = ck.mechanism.source or ck.mechanism.name
    unknowns = ", ".join(ck.unknowns[c] for c in block.unknowns)
    at = f"{name} = {display_input:g}{unit}" if display_input is not None else "the requested input"
    if res.status is NewtonStatus.STALLED:
        raise AssemblyError(
            f"{where}: cannot be assembled at {at}: the loop equations for {unknowns} have no real "
            f"solution there (closest approach leaves a residual of {res.residual:.3g} "
            f"{ck.mechanism.units.length}); choose an input inside the assemblable range "
            "(see `loopsolve info`) or check the link lengths",
            input_value=display_input, residual=res.residual, result=z.copy(),
        )
    raise ConvergenceError(
        f"{where}: Newton did not converge at {at} for {unknowns} ({res.status.value}; residual "
        f"{res.residual:.3g} after {res.n_iter} iterations); improve the guesses",
        input_value=display_input, result=z.copy(),
    )


def input_unit(ck) -> str:
    kind = ck.kinds[ck.index(ck.inputs[0])]
    if kind is Kind.ANGLE:
        return " deg" if ck.mechanism.units.angle == "deg" else " rad"
    return " " + ck.mechanism.units.length


def solve_rates(ck: CompiledKinematics, z: np.ndarray, rates: Sequence[float], *,
                display_input: float | None = None, mode: str = ""):
    """Velocities, accelerations and jerks of every variable at position ``z``.

    ``rates`` = (speed, accel, jerk) of the driving input; other inputs are held (zero rates).
    Raises :class:`SingularPositionError` when Φ_q is singular there: its condition number
    exceeds :data:`SINGULAR_COND`, or the position is indistinguishable from a singular one.
    The second test matters at toggles, dead centres and change points: there Newton converges
    only linearly and stops a distance e ≈ sqrt(residual) from the singular root, where
    cond(Φ_q) ≈ 1/e is merely ~1e6 and the rates would be huge and meaningless. The position
    uncertainty residual/σ_min is compared with the distance to singularity σ_min/σ_max:
    ``cond² · residual/σ_max > SINGULAR_RATIO`` means the rates cannot be trusted (σ of Φ_q with
    the columns of length unknowns times the model's length scale, so that the test does not
    depend on the unit of length).
    """
    J = ck.jac(z)
    if J.size:
        finite = bool(np.all(np.isfinite(J)))
        sv = np.linalg.svd(J, compute_uv=False) if finite else np.array([np.inf, 0.0])
        cond = float(sv[0] / sv[-1]) if sv[-1] > 0 else math.inf
        # the position is never known better than round-off of the loop sums, even where the
        # residual happens to come out exactly 0 (a closed form landing on a limit position)
        residual = max(float(np.max(np.abs(ck.phi(z)))), _EPS_POSITION * float(ck.scale))
        # judged with the length unknowns' columns in units of the model's length scale (an angle's
        # column is a length already): unscaled, a slider's column is 1 beside angle columns of the
        # order of the links, and a regular pose of large links looked singular (issue 13)
        col = np.array([1.0 if k is Kind.ANGLE else float(ck.scale) for k in ck.kinds])[ck.unknown_idx]
        ss = np.linalg.svd(J * col, compute_uv=False) if finite else sv
        scaled = float(ss[0] / ss[-1]) if ss[-1] > 0 else math.inf
        indistinct = math.isfinite(scaled) and scaled * scaled * residual / float(ss[0]) > SINGULAR_RATIO
    else:
        cond, indistinct = 1.0, False
    if not math.isfinite(cond) or cond > SINGULAR_COND or indistinct:
        name = ck.inputs[0]
        at = f"{name} = {display_input:g}{input_unit(ck)}" if display_input is not None else "this input"
        pos = ", ".join(
            f"{n} = {display_value(ck, z[ck.index(n)], n):.6g}" for n in ck.unknowns
        )
        raise SingularPositionError(
            f"{ck.mechanism.source or ck.mechanism.name}: singular position at {at} ({pos}): the "
            f"coefficient matrix Φ_q is singular{' within the accuracy of the position' if indistinct else ''} "
            f"(condition number {cond:.3g}), so the rates are "
            "undefined there (dead centre, toggle or change point); move the input away from it",
            input_value=display_input, cond=cond, result=z.copy(),
        )
    zs = [z]
    n = len(ck.variables)
    with np.errstate(over="ignore", invalid="ignore"):  # an overflow is reported below, once
        for order in (1, 2, 3):
            zk = np.zeros(n)
            zk[ck.input_idx[0]] = rates[order - 1]
            b = ck.rhs(order, *zs, zk)
            zk[ck.unknown_idx] = np.linalg.solve(J, b)
            zs.append(zk)
        pts = np.stack([ck.point_values(k, *zs[: k + 1]) for k in range(4)]) if ck.points else np.zeros((4, 0, 2))
    if not (all(np.all(np.isfinite(zk)) for zk in zs[1:]) and np.all(np.isfinite(pts))):
        u = input_unit(ck).strip()
        raise ModelError(
            f"{ck.mechanism.source or ck.mechanism.name}: the rates overflow floating point with the input "
            f"{ck.inputs[0]}'s speed {rates[0]:.3g}, accel {rates[1]:.3g}, jerk {rates[2]:.3g} "
            f"({'rad' if u in ('deg', 'rad') else u}/s based): give a smaller --speed/--accel/--jerk")
    return zs[1], zs[2], zs[3], pts, cond


#: a diagonal block of Φ_q at the guesses whose |det| is at most this fraction of the product of
#: its column norms (1 for orthogonal columns) names no sign: the guesses sit on a singular
#: configuration (for a four-bar: θ4 − θ3 within ~1e-9 rad of 0° or 180°)
GUESS_SINGULAR = 1e-9


def block_signs(ck: CompiledKinematics, z) -> str:
    """Signature at ``z`` with ``"0"`` for a block within :data:`GUESS_SINGULAR` of singular.

    The sign of each diagonal block's determinant of Φ_q, judged by its ratio to the product of
    the block's column norms (invariant to the units of the unknowns).
    """
    J = ck.jac(np.asarray(z, dtype=float))
    out = []
    for b in ck.blocks:
        M = J[np.ix_(b.eqs, b.unknowns)]
        d = float(np.linalg.det(M)) if M.size else 1.0
        norms = float(np.prod(np.linalg.norm(M, axis=0))) if M.size else 1.0
        if not (math.isfinite(d) and math.isfinite(norms)) or abs(d) <= GUESS_SINGULAR * norms:
            out.append("0")
        else:
            out.append("+" if d > 0 else "-")
    return "".join(out)


def signature_matches(signature: str, requested: str) -> bool:
    """Whether a solution's ``signature`` is the ``requested`` mode (a ``"0"`` there matches any sign).

    Examples
    --------
    >>> from loopsolve.kinematics.solve import signature_matches
    >>> signature_matches("+-", "+-"), signature_matches("+-", "0-"), signature_matches("+-", "--")
    (True, True, False)
    """
    return len(signature) == len(requested) and all(r in ("0", c) for c, r in zip(signature, requested))


def guess_pose(ck: CompiledKinematics, x: float | None = None, *, guess: dict | None = None):
    """All variables at the guesses (internal units), or ``None`` when an unknown has no guess.

    The input is at its own guess (the pose the guesses describe); at ``x`` when it has none,
    or when explicit ``guess`` overrides are given (those are for ``x`` itself).
    """
    mech = ck.mechanism
    if any(mech.variable(n).guess is None and not (guess and n in guess) for n in ck.unknowns):
        return None
    z = initial_z(ck, guess=guess, warn=False)
    name = ck.inputs[0]
    own = mech.variable(name).guess
    if guess and name not in guess or own is None:
        if x is None:
            return None
        z[ck.input_idx[0]] = x
    return z


def guessed_mode(ck: CompiledKinematics, x: float | None = None, *, guess: dict | None = None) -> str | None:
    """The assembly mode the guesses name: the signature of Φ_q's diagonal blocks at the guesses.

    **The guesses name the mode** (DESIGN.md, Conventions): a solve, sweep, study or force analysis
    without ``mode`` returns the solution with this signature, wherever Newton started. ``None``
    when some unknown has no guess (then Newton from the default start decides, with a warning).
    A ``"0"`` marks a block whose guesses sit on a singular configuration (see :func:`block_signs`):
    they name no sign for it, and a solve takes the one Newton reaches there, with a warning.

    Examples
    --------
    >>> mech = ls.load(ls.models_dir() / "thesis_crank_rocker.toml")   # theta3 = 20, theta4 = 80
    >>> from loopsolve.kinematics.solve import guessed_mode
    >>> guessed_mode(mech.compile())   # det = r3 r4 sin(θ3 − θ4) = r3 r4 sin(−60°) < 0: open
    '-'
    """
    z = guess_pose(ck, x, guess=guess)
    if z is None or not np.all(np.isfinite(z)):
        return None  # a NaN guess names nothing (Newton from it reports NOT_FINITE)
    return block_signs(ck, z)


def _requested_mode(ck: CompiledKinematics, x: float, mode, guess) -> tuple[str | None, str]:
    """``(signature, who asked)`` of the mode to solve in at ``x``: ``mode``, else the guesses'."""
    from .modes import mode_names, modes_at, resolve_signature

    mech = ck.mechanism
    where = mech.source or mech.name
    if mode is not None:
        sig = resolve_signature(mech, mode)
        nb = len(ck.blocks)
        if sig is None or len(sig) != nb or set(sig) - {"+", "-"}:
            aliases = ", ".join(f"{k} = {v}" for k, v in mech.mode_aliases.items())
            raise ModelError(
                f"{where}: unknown assembly mode {mode!r}: give a signature of {nb} sign(s) (+ or -, one per "
                "block of the solve order)" + (f" or one of the aliases {aliases}" if aliases else "")
                + f"; the modes at {ck.inputs[0]} = {display_value(ck, x):g}{input_unit(ck)} are: "
                + mode_names(mech, modes_at(ck, x)))
        return sig, f"--mode {mode}"
    sig = guessed_mode(ck, x, guess=guess)
    if sig is not None and "0" in sig:
        # the guesses sit on a singular configuration: they name no sign for those blocks, which
        # then take whatever Newton reaches (any sign matches a "0"), with a warning
        from ..errors import warn

        z = guess_pose(ck, x, guess=guess)
        bad = [b for b, c in zip(ck.blocks, sig) if c == "0"]
        names = sorted({ck.unknowns[c] for b in bad for c in b.unknowns}, key=ck.unknowns.index)
        vals = ", ".join(f"{n} = {display_value(ck, z[ck.index(n)], n):g}" for n in names)
        warn(f"{where}: the guesses {vals} sit on a singular configuration (dead centre, toggle or change "
             "point: a block of the coefficient matrix Φ_q is singular there), so they name no assembly mode "
             "for these unknowns and the solution Newton reaches is taken; move a guess off it or choose "
             "the mode with --mode (mode=)")
    return sig, "the guesses"


def start_position(ck: CompiledKinematics, x: float, *, mode=None, guess: dict | None = None,
                   settings: Newton = Newton()):
    """Solved position at input ``x`` (internal units), in ``mode`` or the one the guesses name.

    The start of every solve and sweep. The mode asked for is ``mode`` (signature or alias), else
    the signature of Φ_q's blocks at the guesses (:func:`guessed_mode`). Newton from the guesses
    is kept when it lands in that mode; otherwise every real solution at ``x`` is computed
    (:func:`loopsolve.kinematics.modes.assembly_modes`) and the one with that signature taken (the nearest
    the guesses if several). Returns ``(z, residual, n_iter)``.

    Raises
    ------
    AssemblyError
        No real solution at ``x`` (names the nearest assemblable inputs).
    ModeError
        Solutions exist at ``x``, but none in the mode asked for (names the modes there).
    ModelError
        ``mode`` is not a signature or alias, or the guesses sit on a singular configuration.

    Examples
    --------
    >>> ck = ls.fourbar(60, 25, 70, 45).compile()
    >>> from loopsolve.kinematics.solve import start_position
    >>> z, residual, _ = start_position(ck, math.radians(90), mode="crossed")
    >>> ck.signature(z), residual < 1e-12
    ('+', True)
    """
    disp = display_value(ck, x, ck.inputs[0])
    sig, who = _requested_mode(ck, x, mode, guess)
    z0 = initial_z(ck, guess=guess)
    z0[ck.input_idx[0]] = x
    failure = found = None
    try:
        found = _within_a_turn(ck, solve_position(ck, z0, settings=settings, display_input=disp), settings, disp)
        if sig is None or signature_matches(ck.signature(found[0]), sig):
            return found
    except (AssemblyError, ConvergenceError) as exc:
        failure = exc
    from .modes import mode_names, modes_at, nearest_solution

    modes = list(modes_at(ck, x))
    if found is not None and not any(_coincide(ck, [m.z, found[0]]) for m in modes):
        from .modes import Mode

        modes.append(Mode(ck.signature(found[0]), (), {}, found[0]))  # one the enumeration missed
    if sig is not None:
        match = [m for m in modes if signature_matches(m.signature, sig)]
        if match:
            z = nearest_solution(ck, match, guess=guess)
            return solve_position(ck, z, settings=settings, display_input=disp)
    if modes and _coincide(ck, [m.z for m in modes]):
        # a limit position: the modes meet there (its signature is round-off), and Newton stalls
        # from guesses on one side
        z = np.array(modes[0].z, dtype=float)
        return z, float(np.max(np.abs(ck.phi(z)))), 0
    if modes and sig is not None:
        where = ck.mechanism.source or ck.mechanism.name
        aliases = [k for k, v in ck.mechanism.mode_aliases.items() if v == sig]
        label = sig + (f" ({', '.join(aliases)})" if aliases else "")
        partial = found[0] if found is not None else getattr(failure, "result", None)
        raise ModeError(
            f"{where}: no solution in assembly mode {label} (named by {who}) at {ck.inputs[0]} = {disp:g}"
            f"{input_unit(ck)}: the mechanism assembles there only in mode(s) {mode_names(ck.mechanism, modes)}; "
            "choose one of them with --mode (mode=) or guesses in it, or another input value",
            mode=sig, modes=tuple(m.signature for m in modes), input_value=disp, result=partial)
    from .reach import assembly_failure

    if failure is None:
        failure = AssemblyError("no real solution")
    if modes and isinstance(failure, ConvergenceError):
        raise failure
    raise assembly_failure(ck, x, failure) from None


def _within_a_turn(ck, found, settings: Newton, disp):
    """``found`` with its unknown angles in (−π, π], polished again where Newton ran off by whole turns.

    Newton from far guesses can land turns away (θ3 = 616 rad is the right pose 98 turns on), where
    the angle's last digits are lost (an ulp of 616 is 1e-13): the start of a sweep must be exact,
    since the rows after it follow it continuously. One Newton polish from the reduced angles
    restores the residual.
    """
    z = np.array(found[0], dtype=float)
    ang = np.array([i for i in ck.unknown_idx if ck.kinds[i] is Kind.ANGLE and ck.periodic[i]], dtype=int)
    if not len(ang) or np.all(np.abs(z[ang]) <= math.pi) or not np.all(np.isfinite(z[ang])):
        return found
    ang = ang[np.abs(z[ang]) > math.pi]
    z[ang] = -((-z[ang] + math.pi) % (2 * math.pi) - math.pi)  # into (−π, π]
    return solve_position(ck, z, settings=settings, display_input=disp)


def _coincide(ck, zs) -> bool:
    """Whether the positions ``zs`` are one pose (within 1e-6 in scaled units, angles modulo 2π)."""
    w = np.array([1.0 if k is Kind.ANGLE else 1.0 / ck.scale for k in ck.kinds])
    ang = np.array([k is Kind.ANGLE for k in ck.kinds]) & ck.periodic
    for z in zs[1:]:
        d = np.asarray(z) - np.asarray(zs[0])
        d = np.where(ang, (d + math.pi) % (2 * math.pi) - math.pi, d)
        if float(np.max(np.abs(d * w))) > 1e-6:
            return False
    return True


def solve(mech: Mechanism, at=None, *, speed=None, accel=None, jerk=None, input: str | None = None,
          guess: dict | None = None, mode: str | None = None, compiled: CompiledKinematics | None = None,
          settings: Newton | None = None) -> State:
    """Positions, velocities, accelerations and jerks at one input value.

    Parameters
    ----------
    mech : Mechanism
    at : float or str, optional
        Input value in the model's unit (degrees for an angle by default) or with a unit
        (``"1.2rad"``). Default: the input's declared guess.
    speed, accel, jerk : float or str, optional
        Input rates (``"10rpm"``, ``10.5`` = rad/s). Default: the model's, else 1, 0, 0 (the
        rates are then the kinematic coefficients dq/dx, d²q/dx², d³q/dx³).
    input : str, optional
        Drive another variable (e.g. the slider position) without editing the model.
    guess : dict, optional
        Override guesses (internal units) by variable name.
    mode : str, optional
        Assembly-mode signature (``"+"``, ``"-+"``...) or alias (``"open"``/``"crossed"``) to
        solve in, whatever the guesses say.
    compiled : CompiledKinematics, optional
        The mechanism compiled for ``input`` (default: compiled on demand, cached).
    settings : Newton, optional
        Newton's tolerances (default ``Newton()``).

    Returns
    -------
    State

    Raises
    ------
    AssemblyError, ConvergenceError, SingularPositionError, ModelError

    Examples
    --------
    >>> mech = ls.load(ls.models_dir() / "thesis_crank_rocker.toml")
    >>> s = mech.solve(90)
    >>> round(s["theta3"], 2), round(s["theta4"], 2), round(s["theta4_vel"], 3)
    (16.1, 80.72, 0.619)
    """
    ck = compiled if compiled is not None else mech.compile(input)
    name = ck.inputs[0]
    if at is None:
        declared = mech.variable(name).guess
        if declared is None:
            raise ModelError(f"{mech.source or mech.name}: no input value: pass --at (or `at=`) or give "
                             f"{name} a guess in [variables]")
        x = declared
    else:
        x = input_value(ck, at, name)
    disp = display_value(ck, x, name)
    settings = Newton() if settings is None else settings
    z, residual, n_iter = start_position(ck, x, mode=mode, guess=guess, settings=settings)
    sig = ck.signature(z)
    try:
        z1, z2, z3, pts, cond = solve_rates(ck, z, input_rates(ck, speed, accel, jerk), display_input=disp)
    except SingularPositionError as exc:
        # Newton also converges (linearly) to a near-solution just beyond a limit position: a
        # singular position where no real one exists is an input outside the assemblable range
        from .modes import modes_at

        if not modes_at(ck, x):
            from .reach import assembly_failure

            err = assembly_failure(ck, x, exc)
            near = getattr(err, "nearest", None) or ()
            if not any(abs(v - disp) <= max(_AT_LIMIT, 1e-15 * abs(disp)) for v in near):
                raise err from None  # beyond the limit, not at it
        # at a limit Newton stops ~sqrt(round-off) short of the position: report the located fold
        from .scalar_solver import Kernel

        kern = Kernel(ck)
        found = kern.fold_point([float(v) for v in z], kern.jac_f([float(v) for v in z], kern.p))
        if found is not None and abs(display_value(ck, found[0][kern.ix]) - disp) <= max(_AT_LIMIT, 1e-15 * abs(disp)):
            zf = np.array(found[0], dtype=float)
            zf[kern.ix] = x
            solve_rates(ck, zf, (1.0, 0.0, 0.0), display_input=disp)  # raises with the refined positions
        raise
    if mech.pairs is not None and mech.pairs.gears:
        from .pairchecks import check_gears

        check_gears(ck, z[:, None], [disp])
    return State(ck, z, z1, z2, z3, pts, sig, residual, n_iter, cond)
