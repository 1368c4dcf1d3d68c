"""``[friction]``: Coulomb friction per joint, for the force analysis.

::

    [friction]
    O2 = { mu = 0.1, radius = "6mm" }     # a revolute joint (a pin of [bodies]): its journal radius
    block = { mu = 0.2 }                  # a body's guide (prismatic joint): by body or guide vector
    s1 = { mu = 0.15 }                    # a pin in a slot, by the slot's name
    c1 = { mu = 0.05 }                    # a knife-edge or flat-face cam contact, by the cam's name

A revolute joint resists the relative rotation of its two bodies by the torque ``r sin φ |F|`` (the
friction circle: ``tan φ = μ``, ``r`` the journal radius, ``F`` the joint's force); a sliding contact
(guide, slot, cam) by the force ``μ |N|`` along the sliding direction, ``N`` its normal force. Each
opposes the relative velocity (:mod:`loopsolve.dynamics.friction` solves the force analysis with them).
A roller follower rolls: its friction belongs to the roller's pin, not to the cam contact.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .units import Kind

__all__ = ["Friction", "parse"]

_KEYS = {"mu", "radius"}


@dataclass(frozen=True, slots=True)
class Friction:
    """Friction at one joint: ``kind`` ``"pin"`` (``radius`` its journal radius, an expression),
    ``"guide"`` (``target`` the guided body), ``"slot"`` or ``"cam"`` (``target`` the pair's name)."""

    name: str
    key: str
    kind: str
    target: str
    mu: float
    radius: object = None


def parse(ctx, pairs) -> tuple[Friction, ...]:
    table = ctx.table("friction")
    if not table:
        return ()
    p = ctx.problems
    dyn = ctx.dynamics
    if dyn is None or not dyn.bodies:
        p.add("friction", "friction acts in the force analysis: declare the [bodies] whose joints it acts in")
        return ()
    pins = {j for b in dyn.bodies for j in b.joints} - {sl.point for sl in pairs.slots}
    guides = {b.name: b.name for b in dyn.bodies if b.guide is not None}
    guides.update({b.guide: b.name for b in dyn.bodies if b.guide is not None})
    slots = {sl.name for sl in pairs.slots}
    cams = {c.name: c for c in pairs.cams}
    out = []
    for name, raw in table.items():
        d = ctx.entry("friction", name, raw, _KEYS, '{ mu = 0.1, radius = "6mm" }')
        if d is None:
            continue
        key = f"friction.{name}"
        mu = d.get("mu")
        if isinstance(mu, bool) or not isinstance(mu, (int, float)) or not math.isfinite(mu) or mu < 0:
            p.add(f"{key}.mu", f"the coefficient of friction is a number ≥ 0, got {mu!r}")
            continue
        if name in pins:
            if "radius" not in d:
                p.add(key, f"a revolute joint's friction needs `radius`, the journal radius of {name!r}")
                continue
            radius = ctx.quantity(d["radius"], f"{key}.radius", Kind.LENGTH, positive=True)
            if radius is not None:
                out.append(Friction(str(name), key, "pin", str(name), float(mu), radius))
            continue
        kind = target = None
        if name in guides:
            kind, target = "guide", guides[name]
        elif name in slots:
            kind, target = "slot", name
        elif name in cams:
            if cams[name].contact == "roller":
                p.add(key, f"the cam {name!r} drives a roller, which rolls: give the roller's pin its friction instead")
                continue
            kind, target = "cam", name
        if kind is None:
            known = sorted(pins) + sorted(guides) + sorted(slots) + sorted(c for c in cams)
            p.add(key, f"{name!r} is not a joint of the bodies: friction acts at a pin "
                  f"({', '.join(sorted(pins)) or 'none'}), a body's guide ({', '.join(sorted(guides)) or 'none'}), "
                  "a slot or a cam" + ("" if known else " (none declared)"))
            continue
        if "radius" in d:
            p.add(f"{key}.radius", f"a journal radius belongs to a revolute joint, not to a {kind}")
            continue
        out.append(Friction(str(name), key, kind, target, float(mu)))
    return tuple(out)
