"""Declarations checked against each other: which body carries which point, and the power balance.

A model's ``[bodies]`` and ``[[loads]]`` are read one key at a time (:mod:`loopsolve.model.bodies`); this
module checks them against the kinematics, where one slip (a joint left out of a body's list, a load
on a body that does not carry its point) would otherwise give a silently different number.

**Which body carries a point.** A point rides on a body when it moves rigidly with it: relative to
the body's centre of mass ``G`` it keeps its distance and turns with the body's angle. With the
kinematic coefficients (derivatives with respect to the input, solved from the loops) that is

    P′ − G′ − θ′ k×(P − G) = 0,     P″ − G″ − θ″ k×(P − G) + θ′² (P − G) = 0,

tested at a few poses of the analysis (both orders, so that no single pose can pass by
coincidence). A body that does not turn (no ``angle``) has ``θ′ = θ″ = 0``. Then:

- every joint a body lists rides on it;
- a joint rides on every body that lists it and on no other: a body that carries a joint a
  neighbour names but leaves it out of its ``joints`` is an error naming both bodies and the joint
  (otherwise the joint would silently become a pin to the frame at a moving point);
- a joint named by one body only is a pin to the frame, so it must not move;
- a point load (a force at a point, a spring's or damper's end) acts on a body that carries the
  point (or on the frame at a fixed point).

**The power balance.** Every force result reports ``power_residual`` = driving power − (dE_k/dt +
dV/dt − loads' power). The energy rate is computed analytically from the kinematics (not by
differencing rows), so with consistent declarations the residual is round-off, whatever the loads
(rate-dependent, non-conservative, non-smooth). :func:`check_power_balance` turns it into a check.
"""

from __future__ import annotations

import numpy as np

from ..model.bodies import FRAME, LoadKind
from ..errors import ModelError, PowerBalanceError, warn

__all__ = ["check_carriers", "rides", "guide_faults", "check_power_balance", "warn_ill_conditioned", "RIDE_RTOL",
           "POWER_RTOL", "POWER_RTOL_ERROR", "COND_WARN"]

#: relative tolerance of the rigid-motion test (poses are solved to ~1e-13; a point on another body
#: differs by O(1))
RIDE_RTOL = 1e-7
#: relative power residual (of the largest power term of the row) above which the balance fails
POWER_RTOL = 1e-7
#: ... above which (or with a constraint or load doing spurious work) it is an error, not a warning
POWER_RTOL_ERROR = 1e-4
#: condition number of the Newton–Euler system above which the forces are flagged (dead centre)
COND_WARN = 100.0
_EPS = np.finfo(float).eps
_SAMPLE = 8


def _where(dm) -> str:
    mech = dm.ck.mechanism
    return str(mech.source or mech.name)


def _sample(dm, z):
    """``dm.evaluate`` at the kinematic coefficients of up to :data:`_SAMPLE` poses of ``z`` (None if none)."""
    from .dynamics_model import kinematic_coefficients

    z = np.atleast_2d(np.asarray(z, dtype=float))
    z = z[np.all(np.isfinite(z), axis=1)]
    if len(z) > _SAMPLE:
        z = z[np.unique(np.linspace(0, len(z) - 1, _SAMPLE).round().astype(int))]
    if not len(z):
        return None
    with np.errstate(all="ignore"):
        d1, d2 = kinematic_coefficients(dm.ck, z)
        ok = np.all(np.isfinite(d1), axis=1) & np.all(np.isfinite(d2), axis=1)
        if not ok.any():
            return None
        z, d1, d2 = z[ok], d1[ok], d2[ok]
        return dm.evaluate(z.T, d1.T, d2.T)


def guide_faults(dm, z) -> list[str]:
    """Guided bodies whose motion relative to the guide's carrier is not a slide along the guide.

    A body that slides along ``guide`` on ``guide_body`` moves, relative to that body (or the frame),
    along the guide's direction and does not turn relative to it.
    """
    e = _sample(dm, z)
    if e is None:
        return []
    names = [b.name for b in dm.bodies]
    out = []
    floor = 1e-12 * dm.ck.scale
    for b, body in enumerate(dm.bodies):
        if body.guide is None:
            continue
        o = -1 if body.guide_body == FRAME else names.index(body.guide_body)
        phi = e["phi"][dm.guide_vectors.index(body.guide)]
        nx, ny = -np.sin(phi), np.cos(phi)
        if o >= 0:
            rx, ry = e["G"][b, 0] - e["G"][o, 0], e["G"][b, 1] - e["G"][o, 1]
            vox, voy = e["vG"][o, 0] - e["om"][o] * ry, e["vG"][o, 1] + e["om"][o] * rx
            wo = e["om"][o]
        else:
            vox = voy = wo = np.zeros_like(phi)
        vx, vy = e["vG"][b, 0] - vox, e["vG"][b, 1] - voy
        scale = np.hypot(e["vG"][b, 0], e["vG"][b, 1]) + np.hypot(vox, voy) + floor
        carrier = "the frame" if o < 0 else repr(body.guide_body)
        if not np.all(np.abs(nx * vx + ny * vy) <= RIDE_RTOL * scale):
            out.append(f"bodies.{body.name}.guide: {body.name!r} does not slide along {body.guide!r} relative to "
                       f"{carrier} (its motion there has a component across the guide): name the vector the body "
                       "slides along, and with guide_body the body that carries it")
        elif not np.all(np.abs(e["om"][b] - wo) <= RIDE_RTOL * (np.abs(e["om"][b]) + np.abs(wo) + 1e-12)):
            out.append(f"bodies.{body.name}: {body.name!r} slides on {carrier} along {body.guide!r} but turns "
                       f"relative to it: a sliding block turns with its guide (give it the guide's angle, "
                       f"angle = \"...\", or check guide_body)")
    return out


def rides(dm, z) -> tuple[np.ndarray, np.ndarray, list[str], list[str]] | None:
    """``(rides, fixed, bodies, points)``: ``rides[b, k]`` is True when point ``k`` of
    ``dm.point_names`` moves rigidly with body ``b`` at every sampled pose of ``z`` ``(N, nvar)``;
    ``fixed[k]`` when the point does not move. ``None`` when no pose has finite coefficients.
    """
    e = _sample(dm, z)
    if e is None or not dm.point_names:
        return None
    G, vG, aG = e["G"], e["vG"], e["aG"]  # (B, 2, N)
    om, al = e["om"], e["al"]  # (B, N)
    P, vP, aP = e["P"], e["vP"], e["aP"]  # (K, 2, N)
    floor = 1e-12 * dm.ck.scale
    r = P[None] - G[:, None]  # (B, K, 2, N)
    perp = np.stack([-r[:, :, 1], r[:, :, 0]], axis=2)
    rn = np.hypot(r[:, :, 0], r[:, :, 1])
    v_rel = vP[None] - vG[:, None] - om[:, None, None] * perp
    a_rel = aP[None] - aG[:, None] - al[:, None, None] * perp + (om**2)[:, None, None] * r

    def norm(a):
        return np.hypot(a[..., 0, :], a[..., 1, :])

    sv = norm(vP)[None] + norm(vG)[:, None] + np.abs(om)[:, None] * rn + floor
    sa = norm(aP)[None] + norm(aG)[:, None] + (np.abs(al) + om**2)[:, None] * rn + floor
    with np.errstate(invalid="ignore"):
        good = (norm(v_rel) <= RIDE_RTOL * sv) & (norm(a_rel) <= RIDE_RTOL * sa)
    ride = np.all(good, axis=-1)
    fixed = np.all((norm(vP) <= floor) & (norm(aP) <= floor), axis=-1)
    return ride, fixed, [b.name for b in dm.bodies], list(dm.point_names)


def found_positions(dm, z):
    """Positions ``(K, 2, n)`` of ``dm.point_names`` at the sampled poses of ``z`` (model units)."""
    z = np.atleast_2d(np.asarray(z, dtype=float))
    z = z[np.all(np.isfinite(z), axis=1)]
    if len(z) > _SAMPLE:
        z = z[np.unique(np.linspace(0, len(z) - 1, _SAMPLE).round().astype(int))]
    if not len(z):
        return None
    zero = np.zeros_like(z.T)
    with np.errstate(all="ignore"):
        return dm.evaluate(z.T, zero, zero)["P"]


def check_carriers(dm, z) -> None:
    """Raise :class:`ModelError` when a joint or a load point is not carried as declared (see module)."""
    found = rides(dm, z)
    if found is None:
        return
    ride, fixed, bodies, points = found
    where = _where(dm)
    k_of = {p: k for k, p in enumerate(points)}
    problems = []

    def carriers_of(k):
        return [bodies[b] for b in range(len(bodies)) if ride[b, k]]

    mech = dm.ck.mechanism
    slotted = {sl.point for sl in mech.pairs.slots} if mech.pairs is not None else set()  # pins in slots
    listed: dict[str, list[str]] = {}
    for b, body in enumerate(dm.bodies):
        for j in body.joints:
            listed.setdefault(j, []).append(body.name)
            if not ride[b, k_of[j]]:
                others = [c for c in carriers_of(k_of[j]) if c != body.name]
                hint = (f"{j} moves with {', '.join(others)}" if others
                        else ("it is a fixed point" if fixed[k_of[j]] else f"{j} moves with no declared body"))
                problems.append(f"bodies.{body.name}.joints lists {j!r}, which does not move with {body.name!r} "
                                f"({hint}): check the joint's name, and {body.name!r}'s `com` and `angle`")
    for j, names in listed.items():
        k = k_of[j]
        left_out = [c for c in carriers_of(k) if c not in names]
        for c in left_out:
            problems.append(f"joint {j!r} is named by {' and '.join(repr(n) for n in names)} but left out by "
                            f"{c!r}, which carries it ({j} moves with {c!r}): add \"{j}\" to bodies.{c}.joints")
        if len(names) == 1 and not left_out and not fixed[k] and ride[bodies.index(names[0]), k] and j not in slotted:
            problems.append(f"joint {j!r} is named by {names[0]!r} only, which makes it a pin to the frame, but {j} "
                            f"moves: add \"{j}\" to the joints of the body that {names[0]!r} meets there (or "
                            "declare that body in [bodies])")
    # points no body lists: a pivot (fixed point turning with a body) or a moving point shared by two
    # bodies is a joint left out by all of its bodies (an alias of a listed joint at the same place is not)
    P = found_positions(dm, z)
    for k, p in enumerate(points):
        if p in listed or P is None:
            continue
        if any(np.allclose(P[k], P[k_of[j]], rtol=0, atol=1e-9 * dm.ck.scale) for j in listed):
            continue
        on = carriers_of(k)
        if fixed[k] and on:
            problems.append(f"{on[0]!r} turns about the fixed point {p!r}, which no body lists: add \"{p}\" to "
                            f"bodies.{on[0]}.joints (a pin to the frame)")
        elif len(on) >= 2:
            problems.append(f"{p!r} moves with {' and '.join(repr(c) for c in on)}, which meet there, but no body "
                            f"lists it: add \"{p}\" to bodies.{on[0]}.joints and bodies.{on[1]}.joints")
    for ld in dm.dynamics.loads:
        if ld.kind is LoadKind.FORCE:
            ends = ((ld.at, ld.body, f"loads[{ld.index}].body"),)
        elif ld.kind in (LoadKind.SPRING, LoadKind.DAMPER):
            ends = tuple((p, b, f"loads[{ld.index}].bodies") for p, b in zip(ld.ends, ld.bodies))
        else:
            continue
        what = {LoadKind.FORCE: "the force", LoadKind.SPRING: "the spring", LoadKind.DAMPER: "the damper"}[ld.kind]
        for p, b, key in ends:
            k = k_of[p]
            if b == FRAME:
                if not fixed[k]:
                    problems.append(f"{key}: {what} {ld.name!r} acts at {p!r} on the frame, but {p} moves: name the "
                                    f"body that carries {p} ({', '.join(carriers_of(k)) or 'none declared'})")
                continue
            if not ride[bodies.index(b), k]:
                cands = carriers_of(k)
                hint = (f"{p} moves with {' and '.join(repr(c) for c in cands)}" if cands
                        else f"no declared body carries {p}")
                problems.append(f"{key}: {what} {ld.name!r} at {p!r} is declared on {b!r}, which does not carry "
                                f"{p} ({hint}): a point load acts on a body that carries its point (one of its "
                                "joints, or a point that moves with it)")
    problems += guide_faults(dm, z)
    if problems:
        raise ModelError(f"{where}: " + "; ".join(problems), problems=problems)


def check_power_balance(dm, data: dict, inputs_display, *, spurious: dict | None = None) -> None:
    """Raise :class:`PowerBalanceError` where the power residual of a force result is above round-off.

    The tolerance of a row is ``max(POWER_RTOL, 1e3 · eps · κ)`` times its largest power term, κ
    the condition number of its Newton–Euler system: round-off amplified by ill-conditioning near a
    dead centre is not a fault (a warning says so there, see :data:`COND_WARN`). Rows whose forces
    are undetermined (NaN) are skipped. ``spurious`` maps each constraint or load to the power it
    does where it should do none: the largest is named as the likely fault. A residual below
    :data:`POWER_RTOL_ERROR` of the largest term with no spurious work found is a
    :class:`LoopsolveWarning` instead (a load that jumps or kinks at that very row).
    """
    res = np.asarray(data["power_residual"], dtype=float)
    scale = np.asarray(data["power_scale"], dtype=float)
    big = scale[np.isfinite(scale)]
    if big.size:  # a row where nothing moves (a cam's dwell) has powers of round-off: judge it on the motion's scale
        scale = np.maximum(scale, 1e-6 * float(big.max()))
    kappa = np.asarray(data.get("kappa", np.ones_like(res)), dtype=float)
    with np.errstate(invalid="ignore"):
        tol = np.maximum(POWER_RTOL, 1e3 * _EPS * np.where(np.isfinite(kappa), kappa, np.inf)) * scale
        bad = np.isfinite(res) & (np.abs(res) > tol) & (scale > 0)
    if not bad.any():
        return
    i = int(np.flatnonzero(bad)[np.argmax(np.abs(res[bad]) / scale[bad])])
    fault = ""
    if spurious:
        name, p = max(spurious.items(), key=lambda kv: abs(kv[1][i]) if np.isfinite(kv[1][i]) else -1.0)
        if np.isfinite(p[i]) and abs(p[i]) > POWER_RTOL * scale[i]:
            fault = f"; the likely fault: {name} does {p[i]:.4g} W of work it should not"
    mech = dm.ck.mechanism
    x = float(inputs_display[i])
    rel = abs(res[i]) / scale[i]
    if rel <= POWER_RTOL_ERROR and not fault:
        # small, and no constraint or load is doing spurious work: round-off of a load evaluated at a
        # kink or jump (a non-smooth, non-conservative load such as sign(ω) at ω = 0), not a fault
        warn(f"{_where(dm)}: the power balance is off by {rel:.3g} of the largest power term at "
             f"{dm.ck.inputs[0]} = {x:.10g} ({int(bad.sum())} of {len(res)} rows), above round-off but with no "
             "constraint or load doing spurious work: a load that is not smooth there (a jump, a kink)?")
        return
    raise PowerBalanceError(
        f"{_where(dm)}: the power balance fails at {dm.ck.inputs[0]} = {x:.10g} ({int(bad.sum())} of {len(res)} "
        f"rows): driving power − (dE/dt − loads' power) = {res[i]:.6g} W, {abs(res[i]) / scale[i]:.3g} of the "
        f"largest power term ({scale[i]:.6g} W){fault}. The bodies, joints, guides or loads do not describe "
        "one consistent mechanism; check each body's `joints`, `angle`, `guide` and each load's `body`",
        residual=float(res[i]), scale=float(scale[i]), input_value=x, model=str(mech.source or mech.name))


def warn_ill_conditioned(dm, kappa, inputs_display, unit: str) -> None:
    """One :class:`LoopsolveWarning` when rows have a Newton–Euler condition above :data:`COND_WARN`."""
    kappa = np.asarray(kappa, dtype=float)
    with np.errstate(invalid="ignore"):
        bad = np.flatnonzero(np.isfinite(kappa) & (kappa > COND_WARN))
    if not bad.size:
        return
    i = int(bad[np.argmax(kappa[bad])])
    shown = "inf" if not np.isfinite(kappa[i]) else f"{kappa[i]:.3g}"
    warn(f"{_where(dm)}: near a dead centre at {dm.ck.inputs[0]} = {float(inputs_display[i]):.10g}{unit}"
         f" ({bad.size} row{'s' if bad.size > 1 else ''} with condition > {COND_WARN:g}): the Newton–Euler "
         f"system has condition {shown}, so the joint forces and the driving "
         f"{'torque' if dm.input_kind.name == 'ANGLE' else 'force'} there are ill-determined (they grow without "
         "bound at the dead centre)")
