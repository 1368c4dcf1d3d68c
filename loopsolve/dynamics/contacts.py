"""Contact forces of the higher pairs in the Newton–Euler system: gear teeth, cam and follower, pin in
slot, rolling contact.

Each higher pair joining two bodies (or a body and the frame) adds unknowns to the force analysis
(:mod:`loopsolve.dynamics.kinetostatics`), acting at its contact point, equal and opposite on the two:

* a gear pair: the tooth force at the pitch point, along the line of action. Its tangential part
  ``W`` (the unknown, along the common tangent) transmits the torque; the radial part
  ``|W| tan φ`` (φ the pressure angle) pushes the gears apart, towards each gear's centre. The force
  along the line of action is ``|W| / cos φ``. The sign of ``W`` (which flank is loaded) is found
  by solving twice;
* a cam: the contact force along the common normal (no friction: the normal force only);
* a pin in a slot: the reaction normal to the slot;
* a rolling contact: the normal force and the tangential (no-slip) force at the contact point.

The contact points and directions come from the solved kinematics (:mod:`loopsolve.kinematics.pairchecks`).
A contact does no work on the pair: its two bodies' material points at the contact have the same
velocity along its direction, which the power balance checks.

``F_<name>`` is reported on the body of the pair's first member (the ``gear``; the follower of a cam;
the point's body in a slot; the wheel) from the other, with ``F_<name>_x``, ``F_<name>_y``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ModelError
from ..model import expr as _expr
from ..model.bodies import FRAME
from ..model.gears import ratio_values

__all__ = ["Contact", "contacts", "contact_geometry", "member_body"]


@dataclass(frozen=True)
class Contact:
    """One higher pair in the force analysis: ``n`` unknowns acting on body ``a`` from body ``b`` (−1: frame)."""

    name: str
    key: str
    kind: str
    a: int
    b: int
    n: int
    elem: object


def _where(dm) -> str:
    mech = dm.ck.mechanism
    return str(mech.source or mech.name)


def member_body(dm, var: str, key: str, what: str) -> int:
    """The body turning with the angle ``var`` (−1 for ``""``, the frame); a ModelError naming ``key`` if none."""
    if not var:
        return -1
    variables = {v.name for v in dm.ck.mechanism.variables}
    for i, b in enumerate(dm.bodies):
        if b.angle is not None and _expr.names(b.angle) & variables == {var}:
            return i
    raise ModelError(f"{_where(dm)}: {key}: no body turns with {var!r} ({what}): the contact force acts on it; "
                     f"declare it in [bodies] with angle = \"{var}\"")


def slider_body(dm, var: str, key: str, what: str) -> int:
    """The body sliding on a guide whose length is the variable ``var`` (a rack, a translating follower)."""
    mech = dm.ck.mechanism
    for i, b in enumerate(dm.bodies):
        if b.guide is None:
            continue
        v = mech.vector(b.guide)
        if v.length is not None and var in _expr.names(v.length):
            return i
    raise ModelError(f"{_where(dm)}: {key}: no body slides along a guide of length {var!r} ({what}): the contact "
                     "force acts on it; declare it in [bodies] with guide = \"<the vector of length "
                     f"{var}>\"")


def _body_of(dm, name: str, key: str) -> int:
    if name in (FRAME, "ground"):
        return -1
    for i, b in enumerate(dm.bodies):
        if b.name == name:
            return i
    raise ModelError(f"{_where(dm)}: {key}: {name!r} is not a body; the bodies are "
                     f"{', '.join(b.name for b in dm.bodies)}")


def contacts(dm) -> tuple[Contact, ...]:
    """The contact unknowns of every higher pair of ``dm``'s mechanism (structure only)."""
    mech = dm.ck.mechanism
    pairs = mech.pairs
    if pairs is None:
        return ()
    out = []
    for g in pairs.gears:
        a = member_body(dm, g.gear, g.key, "the gear")
        if g.rack:
            b = slider_body(dm, g.mate, g.key, "the rack")
        else:
            b = member_body(dm, g.mate, g.key, "the mate")
        out.append(Contact(f"F_{g.name}", g.key, "rack" if g.rack else "gear", a, b, 1, g))
    for c in pairs.cams:
        if c.kind == "translating":
            a = slider_body(dm, c.follower, c.key, "the follower")
        else:
            a = member_body(dm, c.follower, c.key, "the follower")
        out.append(Contact(f"F_{c.name}", c.key, "cam", a, member_body(dm, c.cam, c.key, "the cam"), 1, c))
    for sl in pairs.slots:
        pin = [i for i, b in enumerate(dm.bodies) if sl.point in b.joints]
        if len(pin) != 1:
            now = ", ".join(dm.bodies[i].name for i in pin) or "none"
            raise ModelError(f"{_where(dm)}: {sl.key}: list the slot's pin {sl.point!r} in the joints of the one body "
                             f"that carries it (now {now})")
        out.append(Contact(f"F_{sl.name}", sl.key, "slot", pin[0], _body_of(dm, sl.link, f"{sl.key}.link"), 1, sl))
    for r in pairs.rolling:
        base = member_body(dm, r.on, r.key, "the base") if r.circle else -1
        out.append(Contact(f"F_{r.name}", r.key, "rolling", member_body(dm, r.angle, r.key, "the wheel"), base, 2, r))
    return tuple(out)


# ------------------------------------------------------------------------------ geometry per row
def contact_geometry(dm, c: Contact, Z, Z1, e: dict) -> dict:
    """Where and along what the contact ``c`` acts at rows ``Z`` (``(N, nv)``), SI positions.

    Returns ``P`` ``(N, 2)`` (metres) and, for a gear pair, ``t`` (the common tangent), ``r`` (the
    direction of the separating force on body ``a``: towards its centre, away from it for a ring) and
    ``tan`` (tan φ); for
    the other contacts ``dirs``, one ``(N, 2)`` unit direction per unknown.
    """
    if c.kind in ("gear", "rack"):
        return _gear_geometry(dm, c, Z, Z1, e)
    if c.kind == "cam":
        return _cam_geometry(dm, c, Z)
    if c.kind == "slot":
        return _slot_geometry(dm, c, Z)
    if c.kind == "rolling":
        return _rolling_geometry(dm, c, Z)
    raise ModelError(f"{_where(dm)}: {c.key}: contact forces of a {c.kind} are not available")


def _values(dm):
    from ..kinematics.pairchecks import pair_evaluator as values

    return values(dm.ck)


def _cam_geometry(dm, c, Z):
    """The contact point and the normal (pushing the follower away from the cam) in the mechanism's frame."""
    from ..model.camgeometry import analyse
    from ..model.cams import numbers

    cam = c.elem
    ck = dm.ck
    cn = numbers(cam, _values(dm))
    th = Z[:, ck.index(cam.cam)]
    data = analyse(cn, th)
    a = cn.frame_angle
    rot = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    X = data["contact"] @ rot.T
    n = data["normal"] @ rot.T
    if cam.center is not None:
        j = ck.points.index(cam.center)
        P = ck.point_values_v(0, Z.T)
        P = P[j].T if P.ndim == 3 else np.broadcast_to(P[j], (len(th), 2))
        X = X + P
    return {"P": X * dm.length_factor, "dirs": [n]}


def _points(ck, Z, name):
    j = ck.points.index(name)
    P = ck.point_values_v(0, Z.T)
    return np.asarray(P[j].T if P.ndim == 3 else np.broadcast_to(P[j], (Z.shape[0], 2)), dtype=float)


def _slot_geometry(dm, c, Z):
    """The reaction acts at the pin, normal to the slot (to its line, or along the arc's radius)."""
    sl = c.elem
    ck = dm.ck
    P = _points(ck, Z, sl.point)
    if sl.line is not None:
        lv = ck.vector_values_v(0, Z.T)
        k = ck.vectors.index(sl.line)
        L, a = (lv[k, 0], lv[k, 1]) if lv.ndim == 3 else (np.full(len(Z), lv[k, 0]), np.full(len(Z), lv[k, 1]))
        sgn = np.where(np.asarray(L) < 0, -1.0, 1.0)
        n = np.stack([-np.sin(a) * sgn, np.cos(a) * sgn], axis=1)
    else:
        d = P - _points(ck, Z, sl.center)
        n = d / np.linalg.norm(d, axis=1)[:, None]
    return {"P": P * dm.length_factor, "dirs": [n]}


def _rolling_geometry(dm, c, Z):
    """The contact point (the wheel's instant centre relative to the base) with the normal from the base
    into the wheel and the tangent."""
    from ..kinematics.pairchecks import Motion, instant_centre, unit_rates

    r = c.elem
    ck = dm.ck
    motion = Motion(ck, Z.T, unit_rates(ck, Z.T))
    P = instant_centre(motion, r.angle, r.on if r.circle else "")
    if P is None:
        raise ModelError(f"{_where(dm)}: {r.key}: the contact point is unknown (the wheel {r.angle!r} has no bar in "
                         "the loops or points): add a point on its rim for the force analysis")
    if r.circle:
        psi = Z[:, ck.index(r.arm)]
        n = r.sign * np.stack([np.cos(psi), np.sin(psi)], axis=1)
    else:
        mech = ck.mechanism
        travel = next((v.name for v in mech.vectors if v.length is not None and r.on in _expr.names(v.length)), None)
        if travel is None:
            raise ModelError(f"{_where(dm)}: {r.key}: no vector has the length {r.on!r}, so the line the wheel rolls "
                             "on is unknown for the force analysis: carry the wheel's centre along a vector of that "
                             "length")
        lv = ck.vector_values_v(0, Z.T)
        k = ck.vectors.index(travel)
        a = lv[k, 1] if lv.ndim == 3 else np.full(len(Z), lv[k, 1])
        n = r.sign * np.stack([-np.sin(a), np.cos(a)], axis=1)
    t = np.stack([-n[:, 1], n[:, 0]], axis=1)
    return {"P": P * dm.length_factor, "dirs": [n, t]}


def _gear_geometry(dm, c, Z, Z1, e):
    from ..kinematics.pairchecks import gear_centres, unit_rates

    g = c.elem
    ck = dm.ck
    lf = dm.length_factor
    cg, cm = gear_centres(ck, Z.T, unit_rates(ck, Z.T), g)
    if cg is None or (not g.rack and cm is None):
        raise ModelError(f"{_where(dm)}: {g.key}: the gears' centres are unknown (a gear's link has no bar in the "
                         "loops): name them with centers = [\"<point>\", \"<point>\"] for the force analysis")
    rg, rm, ratio = ratio_values(g, _values(dm))
    tan = np.tan(g.pressure_angle)
    if g.rack:
        gi = [b.guide for b in dm.bodies][c.b]
        phi = e["phi"][dm.guide_vectors.index(gi)]
        u = np.stack([np.cos(phi), np.sin(phi)], axis=1)
        n = np.stack([u[:, 1], -u[:, 0]], axis=1)  # from the pinion's centre to the pitch line
        P = cg + rg * n
        return {"P": P * lf, "t": u, "r": -n, "tan": tan}
    d = cm - cg
    dist = np.linalg.norm(d, axis=1)
    uu = d / np.where(dist > 0, dist, 1.0)[:, None]
    if rg is None:  # teeth only: the pitch radii split the centre distance in the ratio of the teeth
        rg = dist * ratio / (abs(ratio - 1.0) if g.internal else (ratio + 1.0))
        rm = rg / ratio
    if g.internal and np.all(np.asarray(rg) < np.asarray(rm)):  # the gear is the pinion inside the mate (ring)
        P = cm - rm * uu
    else:  # external pair, or the gear is the ring: the pitch point on the gear's circle towards the mate
        P = cg + rg * uu
    rvec = cg - P
    rn = np.linalg.norm(rvec, axis=1)
    r = rvec / np.where(rn > 0, rn, 1.0)[:, None]
    pinion_is_a = not g.internal or np.all(np.asarray(rg) < np.asarray(rm))
    if not pinion_is_a:  # the ring: the separating force pushes it away from its centre
        r = -r
    t = np.stack([-uu[:, 1], uu[:, 0]], axis=1)
    return {"P": P * lf, "t": t, "r": r, "tan": tan}
