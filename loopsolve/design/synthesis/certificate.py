"""Certificates of synthesized designs, from the tracker (never from the optimizer).

:func:`certify` takes one design (parameter values), the input value at every target and,
optionally, the positions the optimizer claims there, and checks with the public sweep
(:func:`loopsolve.sweep`, whose tracker locates limits, change points and mode changes):

``assembly``
    the loop closes at every target input (the claimed pose, or, when none is given, the
    assembly mode whose point is nearest the target).
``order``
    the target inputs follow one another one way (strictly monotone) within one turn.
``circuit`` / ``branch``
    one continuous motion of the input, started at the first target's pose, reaches every next
    target's pose: each stretch between two targets is swept; a stretch that stops at a limit
    (toggle), crosses a change point or a mode change, or arrives at another pose than the
    claimed one is a defect — ``branch`` when the claimed pose lies on the same circuit (the
    sweep *through* the limits finds it), ``circuit`` when it does not (the linkage would have
    to be taken apart).
``crank``
    with ``crank=True``: the input turns fully from the first target's pose and comes back to it.
``transmission``
    with bounds: the transmission angle (the angle between the two links of every dyad of two
    angle unknowns, in [0°, 180°]) stays within them over the motion (over the full turn with
    ``crank``).

The certificate dict is the report's ``certificate`` (see ``DESIGN.md``, Synthesis).
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from ...errors import LoopsolveError, LoopsolveWarning
from ...model.units import Kind

__all__ = ["certify", "DEFECTS", "flags", "sort_defects"]

#: every defect kind of a certificate (``range``: function generation, part of the intended input range
#: cannot be reached; the classical methods report it)
DEFECTS = ("assembly", "circuit", "branch", "order", "crank", "transmission", "range")


def sort_defects(kinds) -> list:
    """The defect kinds in the order of :data:`DEFECTS` (unknown kinds last, by name)."""
    return sorted(set(kinds), key=lambda k: (DEFECTS.index(k) if k in DEFECTS else len(DEFECTS), k))


def flags(defects) -> dict:
    """The certificate's flags, one function for every method so they always agree with ``defects``.

    ``assembles``: no ``assembly`` defect; ``one_circuit``: none of ``assembly``, ``circuit``,
    ``branch`` (one continuous motion in one mode joins the targets); ``order``: no ``order``
    defect. ``crank``/``transmission``/``range`` defects leave them as they are.

    Examples
    --------
    >>> flags(["branch"])
    {'assembles': True, 'one_circuit': False, 'order': True}
    """
    d = set(defects)
    return {"assembles": "assembly" not in d, "one_circuit": not ({"circuit", "branch", "assembly"} & d),
            "order": "order" not in d}
_FROM_INFO = object()  # certify(grashof_margin=...) not given: from mech.info()
_TWO_PI = 2 * math.pi


def _wrap(a):
    return (np.asarray(a) + math.pi) % _TWO_PI - math.pi


def _same_pose(ck, za, zb, tol=1e-6) -> bool:
    d = np.asarray(za, dtype=float) - np.asarray(zb, dtype=float)
    w = np.array([1.0 if k is Kind.ANGLE else 1.0 / ck.scale for k in ck.kinds])
    ang = np.array([k is Kind.ANGLE for k in ck.kinds])
    d = np.where(ang, _wrap(d), d)
    return bool(np.all(np.isfinite(d)) and np.max(np.abs(d * w)) <= tol)


def _disp(ck, x):
    from ...kinematics.solve import display_value

    return display_value(ck, float(x))


def _guess(ck, z):
    return {n: float(z[i]) for i, n in enumerate(ck.variables)}


def _sweep(mech, ck, xa, xb, z, *, through=False, max_step_deg=1.0):
    """Sweep from pose ``z`` at ``xa`` to ``xb`` (internal) with rows landing exactly on ``xb``."""
    a, b = _disp(ck, xa), _disp(ck, xb)
    unit = math.radians(max_step_deg) if ck.kinds[ck.input_idx[0]] is Kind.ANGLE else 0.01 * ck.scale
    m = max(1, int(math.ceil(abs(xb - xa) / unit - 1e-9)))
    step = abs(b - a) / m
    return mech.sweep(a, b, step, guess=_guess(ck, z), progress=False, derivatives=1, through_limits=through)


def _on_circuit(mech, ck, xa, za, xb, zb, direction) -> bool:
    """Whether the pose ``zb`` at ``xb`` lies on the circuit through ``za`` (a sweep through the limits)."""
    try:
        sw = _sweep(mech, ck, xa, xa + direction * _TWO_PI, za, through=True, max_step_deg=0.5)
    except LoopsolveError:
        return False
    ix = ck.input_idx[0]
    xs = sw.z[:, ix]
    near = np.flatnonzero(np.abs(_wrap(xs - xb)) <= math.radians(0.75))
    w = np.array([1.0 if k is Kind.ANGLE else 1.0 / ck.scale for k in ck.kinds])
    ang = np.array([k is Kind.ANGLE for k in ck.kinds])
    for r in near:
        d = sw.z[r] - zb
        d = np.where(ang, _wrap(d), d) * w
        d[ix] = 0.0
        if np.max(np.abs(d)) <= 0.05:
            return True
    return False


def _transmission(ck, Z) -> tuple[float, float] | None:
    """Range (degrees) of the angle between the two links of every angle–angle dyad over the rows ``Z``."""
    mus = []
    for b in ck.blocks:
        if len(b.unknowns) == 2:
            i, j = (int(ck.unknown_idx[c]) for c in b.unknowns)
            if ck.kinds[i] is Kind.ANGLE and ck.kinds[j] is Kind.ANGLE:
                mus.append(np.abs(_wrap(Z[:, i] - Z[:, j])))
    if not mus:
        return None
    mu = np.degrees(np.concatenate(mus))
    mu = mu[np.isfinite(mu)]
    return (float(mu.min()), float(mu.max())) if mu.size else None


def _grashof_margin(mech) -> float | None:
    try:
        fbs = mech.info(reach=False).get("fourbars") or []
    except LoopsolveError:
        return None
    margins = []
    for fb in fbs:
        ls_ = sorted(float(v) for v in fb["lengths"].values())
        if len(ls_) == 4:
            margins.append(ls_[1] + ls_[2] - ls_[0] - ls_[3])
    return min(margins) if margins else None


def certify(mech, inputs, *, poses=None, crank: bool = False, transmission=None, point=None,
            targets=None, grashof_margin=_FROM_INFO, sweeps=None) -> dict:
    """The certificate of design ``mech`` (a model with the design's parameter values).

    Parameters
    ----------
    mech : Mechanism
    inputs : sequence of float
        Input value at every target, internal units (radians), in the order of the motion.
    poses : array ``(nvar, T)``, optional
        The positions claimed at the targets (internal units). Without them, the assembly mode
        whose ``point`` is nearest the target (``targets`` ``(T, 2)``) is taken at each input.
    crank, transmission
        Requirements (see the module docstring); ``transmission`` as ``(lo, hi)`` in degrees.
    grashof_margin : float or None, optional
        The design's Grashof margin when the caller has it (shape synthesis computes it from the
        four-bar loops' lengths for many designs at once); by default from ``mech.info()``.
    sweeps : list, optional
        Receives the tracker's sweeps of the motion the certificate judged (with ``crank``, the
        full turn from the first target; otherwise the stretches between the targets, in order),
        so a caller that needs that motion's rows does not sweep it again.

    Returns
    -------
    dict
        ``assembles``, ``one_circuit``, ``order``, ``crank``, ``transmission`` ([min, max] in
        degrees or None), ``grashof_margin`` (None when the model has no four-bar loop),
        ``defects`` (a sorted list of :data:`DEFECTS` names) and ``notes`` (what was found where).

    Examples
    --------
    >>> m = ls.load(ls.models_dir() / "fourbar_path_synthesis.toml")   # a Grashof crank-rocker
    >>> c = certify(m, np.radians([30, 60, 90]), crank=True)
    >>> c["defects"], c["crank"], [round(v, 1) for v in c["transmission"]]
    ([], True, [54.3, 100.3])
    >>> certify(m, np.radians([30, 90, 60]))["defects"]
    ['order']
    """
    with warnings.catch_warnings():  # the tracker's stop notices are what the certificate reports
        warnings.simplefilter("ignore", LoopsolveWarning)
        cert = _certify(mech, inputs, poses, crank, transmission, point, targets, grashof_margin is _FROM_INFO,
                        sweeps)
    if grashof_margin is not _FROM_INFO:
        cert["grashof_margin"] = grashof_margin
    return cert


def _certify(mech, inputs, poses, crank, transmission, point, targets, margin=True, sweeps=None):
    from ...kinematics.modes import modes_at

    ck = mech.compile()
    xs = np.asarray(inputs, dtype=float)
    T = len(xs)
    defects, notes = set(), []
    ix = ck.input_idx[0]
    Zc = []
    for t in range(T):
        if poses is not None:
            z = np.array(poses[:, t], dtype=float)
            z[ix] = xs[t]
            closes = np.all(np.isfinite(z)) and float(np.max(np.abs(ck.phi(z)))) <= 1e-8 * ck.scale
        elif targets is None:  # the mode the guesses name
            from ...kinematics.solve import start_position

            try:
                z, closes = start_position(ck, xs[t])[0], True
            except LoopsolveError:
                z, closes = None, False
        else:
            modes = modes_at(ck, xs[t])
            z, closes = None, bool(modes)
            if modes:
                pi = ck.points.index(point)
                z = min((np.array(m.z, dtype=float) for m in modes),
                        key=lambda zz: float(np.sum((ck.point_values(0, zz)[pi] - targets[t][:2]) ** 2)))
        if not closes:
            defects.add("assembly")
            notes.append(f"target {t + 1}: the loop does not close at input {_disp(ck, xs[t]):.6g}")
        Zc.append(z)
    d = np.diff(xs)
    direction = 1 if T < 2 or d[0] > 0 else -1
    if T > 1 and not (np.all(d > 0) or np.all(d < 0)):
        defects.add("order")
        notes.append("the target inputs do not follow one another one way")
    if T > 1 and ck.kinds[ix] is Kind.ANGLE and abs(xs[-1] - xs[0]) >= _TWO_PI:
        defects.add("order")
        notes.append("the targets span more than one turn of the input")
    rows, swept = [], []
    if "assembly" not in defects and "order" not in defects:
        z = Zc[0]
        for t in range(T - 1):
            kind = None
            try:
                sw = _sweep(mech, ck, xs[t], xs[t + 1], z)
                ev = [e.kind.value for e in sw.events]
                rows.append(sw.z)
                swept.append(sw)
                if "limit" in ev or "not-assemblable" in ev or len(sw) == 0 or \
                        abs(sw.z[-1, ix] - xs[t + 1]) > 1e-9 * max(1.0, abs(xs[t + 1])):
                    kind = "limit"
                elif "singular" in ev or "mode-change" in ev:
                    kind = "singular"
                elif not _same_pose(ck, sw.z[-1], Zc[t + 1], 1e-5):
                    kind = "other pose"
            except LoopsolveError as exc:
                kind = "limit"
                notes.append(f"targets {t + 1}-{t + 2}: {str(exc).splitlines()[0]}")
            if kind is not None:
                same = _on_circuit(mech, ck, xs[t], z, xs[t + 1], Zc[t + 1], direction)
                defects.add("branch" if same or kind == "singular" else "circuit")
                notes.append(f"targets {t + 1}-{t + 2}: " + {
                    "limit": "the input reaches a limit (toggle) position between them",
                    "singular": "the motion crosses a change point or a mode change between them",
                    "other pose": "the motion arrives at another assembly than the target's"}[kind]
                    + (" (the target's assembly is on the same circuit, past a limit or change point)" if same
                       else " (the target's assembly is on another circuit)"))
                z = Zc[t + 1]
            else:
                z = Zc[t + 1]
    turns = None
    if ck.kinds[ix] is Kind.ANGLE and Zc[0] is not None and "assembly" not in defects:
        try:
            sw = _sweep(mech, ck, xs[0], xs[0] + direction * _TWO_PI, Zc[0])
            ev = [e.kind.value for e in sw.events]
            turns = bool(len(sw) and "limit" not in ev and "not-assemblable" not in ev and
                         abs(sw.z[-1, ix] - (xs[0] + direction * _TWO_PI)) < 1e-9 * (1 + abs(xs[0])) and
                         _same_pose(ck, sw.z[-1], Zc[0], 1e-6))
            if crank:
                rows, swept = [sw.z], [sw]
        except LoopsolveError:
            turns = False
    if crank and not turns:
        defects.add("crank")
        notes.append("the input does not turn fully")
    if sweeps is not None:
        sweeps.extend(swept)
    mu = _transmission(ck, np.vstack(rows)) if rows else None
    if transmission is not None:
        lo, hi = transmission
        if mu is None or mu[0] < lo or mu[1] > hi:
            defects.add("transmission")
            notes.append(f"transmission angle {'unknown' if mu is None else f'{mu[0]:.1f}-{mu[1]:.1f} deg'} "
                         f"outside {lo:g}-{hi:g} deg")
    return {**flags(defects),
            "crank": False if "crank" in defects else turns,
            "transmission": None if mu is None else [round(mu[0], 6), round(mu[1], 6)],
            "grashof_margin": _grashof_margin(mech) if margin else None,
            "defects": sorted(defects, key=DEFECTS.index),
            "notes": notes}
