"""Geometry of the higher pairs along a solved motion: gear centres and the mesh check.

A gear pair's equation (Willis' formula) ties angles only; the gears mesh only if their centres stay
the sum of the pitch radii apart (the difference for an internal pair) as the mechanism moves. The
centre of a gear is the point about which it turns relative to its carrier: a declared point
(``centers``), or else the instant centre of the gear's link relative to the carrier, from the
positions and velocities of a bar of each link (:mod:`loopsolve.model.placement`) — the pivot, when
the gear is mounted on one. :func:`gear_centres` gives them for rows of a motion; :func:`check_gears`
raises a :class:`~loopsolve.errors.ModelError` naming the pair when the distance drifts or differs
from the pitch radii: a pair whose centres do not stay in mesh is a wrong declaration, not a motion.
"""

from __future__ import annotations

import numpy as np

from ..errors import ModelError
from ..model.gears import ratio_values
from ..model.placement import link_vectors, placement

__all__ = ["gear_centres", "check_gears", "link_point", "unit_rates"]

#: relative change of a centre distance along a motion above which the centres drift
DRIFT = 1e-6


def _vec_xy(lv, dlv=None):
    """Cartesian components (and their rates) of vectors from their (length, angle) and rates."""
    L, a = lv[..., 0], lv[..., 1]
    xy = np.stack([L * np.cos(a), L * np.sin(a)], axis=-1)
    if dlv is None:
        return xy, None
    dL, da = dlv[..., 0], dlv[..., 1]
    v = np.stack([dL * np.cos(a) - L * da * np.sin(a), dL * np.sin(a) + L * da * np.cos(a)], axis=-1)
    return xy, v


class Motion:
    """Positions and velocities of the vectors of rows ``Z`` ``(nv, N)`` with rates ``Z1``."""

    def __init__(self, ck, Z, Z1):
        self.ck = ck
        self.Z, self.Z1 = np.atleast_2d(Z), np.atleast_2d(Z1)
        lv = ck.vector_values_v(0, self.Z)
        dlv = ck.vector_values_v(1, self.Z, self.Z1)
        n = self.Z.shape[1]
        lv = np.broadcast_to(lv, (len(ck.vectors), 2, n)) if lv.ndim == 3 else lv[..., None]
        dlv = np.broadcast_to(dlv, (len(ck.vectors), 2, n)) if dlv.ndim == 3 else dlv[..., None]
        xy, v = _vec_xy(np.moveaxis(lv, 1, -1), np.moveaxis(dlv, 1, -1))  # (V, N, 2)
        self.xy = {name: xy[i] for i, name in enumerate(ck.vectors)}
        self.v = {name: v[i] for i, name in enumerate(ck.vectors)}
        self.place = placement(ck.mechanism)
        self.n = n

    def node(self, terms):
        """Position and velocity ``(N, 2)`` of a sum of signed vectors from the origin."""
        p = np.zeros((self.n, 2))
        v = np.zeros((self.n, 2))
        for sign, name in terms:
            p += sign * self.xy[name]
            v += sign * self.v[name]
        return p, v

    def point(self, name):
        """Position and velocity ``(N, 2)`` of a declared point."""
        j = self.ck.points.index(name)
        P = self.ck.point_values_v(0, self.Z)
        V = self.ck.point_values_v(1, self.Z, self.Z1)
        P = P[j].T if P.ndim == 3 else np.broadcast_to(P[j], (self.n, 2))
        V = V[j].T if V.ndim == 3 else np.broadcast_to(V[j], (self.n, 2))
        return np.asarray(P, dtype=float), np.asarray(V, dtype=float)


def link_point(motion: Motion, angle: str):
    """A point of the link turning with ``angle`` (a bar's tail) with its velocity; None when none is placed."""
    for v in link_vectors(motion.ck.mechanism, angle):
        if v in motion.place.tail:
            return motion.node(motion.place.tail[v])
    return None


def _omega(motion, var):
    return motion.Z1[motion.ck.index(var)] if var else np.zeros(motion.n)


def instant_centre(motion, link: str, carrier: str):
    """The instant centre ``(N, 2)`` of ``link`` relative to ``carrier`` (NaN where they turn together)."""
    A = link_point(motion, link) if link else (np.zeros((motion.n, 2)), np.zeros((motion.n, 2)))
    B = link_point(motion, carrier) if carrier else (np.zeros((motion.n, 2)), np.zeros((motion.n, 2)))
    if A is None or B is None:
        return None
    (pa, va), (pb, vb) = A, B
    wa, wb = _omega(motion, link), _omega(motion, carrier)
    w = wa - wb
    # v_A + ω_a k×(P − A) = v_B + ω_b k×(P − B)  →  (ω_a − ω_b) k×P = R
    Rx = vb[:, 0] - va[:, 0] - wa * pa[:, 1] + wb * pb[:, 1]
    Ry = vb[:, 1] - va[:, 1] + wa * pa[:, 0] - wb * pb[:, 0]
    scale = np.maximum(np.abs(wa), np.abs(wb)) + np.abs(w)
    ok = np.abs(w) > 1e-9 * np.where(scale > 0, scale, 1.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        P = np.stack([Ry / w, -Rx / w], axis=1)
    P[~ok] = np.nan
    return P


def gear_centres(ck, Z, Z1, pair):
    """``(C_gear, C_mate)``, each ``(N, 2)`` or None: the centres of a pair's gears along rows ``Z``.

    A frame gear turns about its own instant centre relative to the carrier too (when the carrier
    turns); a declared ``centers`` entry is used as it is.
    """
    motion = Motion(ck, Z, Z1)
    out = []
    for i, member in enumerate((pair.gear, pair.mate)[: 1 if pair.rack else 2]):
        if pair.centers:
            out.append(motion.point(pair.centers[i])[0])
        else:
            out.append(instant_centre(motion, member, pair.carrier))
    return tuple(out) + ((None,) if pair.rack else ())


def unit_rates(ck, Z) -> np.ndarray:
    """``(nv, N)`` velocities of every variable at unit speed of the driving input (NaN where Φ_q is singular)."""
    Z = np.atleast_2d(np.asarray(Z, dtype=float))
    n, nv = Z.shape[1], Z.shape[0]
    Z1 = np.zeros((nv, n))
    Z1[ck.input_idx[0]] = 1.0
    J = ck.jac_v(Z)
    J = np.broadcast_to(J, (n,) + J.shape[-2:]) if J.shape[0] != n else J
    b = np.broadcast_to(ck.rhs_v(1, Z, Z1), (len(ck.unknowns), n)).T
    ok = np.all(np.isfinite(J), axis=(1, 2)) & (np.abs(np.linalg.det(np.where(np.isfinite(J), J, 0.0))) > 0)
    Js = np.where(ok[:, None, None], J, np.eye(J.shape[-1]))
    q1 = np.linalg.solve(Js, np.where(ok[:, None], b, 0.0)[..., None])[..., 0]
    q1[~ok] = np.nan
    Z1[ck.unknown_idx] = q1.T
    return Z1


def check_gears(ck, Z, xs=None) -> None:
    """Raise :class:`ModelError` when the centres of a gear pair do not stay in mesh along rows ``Z``.

    ``Z`` holds ``(nv, N)`` positions (or ``(N, nv)``); ``xs`` the rows' input values (display units,
    for the message). Pairs whose centres cannot be found (a gear with no bar in the loops and no
    ``centers``) are not checked.
    """
    mech = ck.mechanism
    if mech.pairs is None or not mech.pairs.gears:
        return
    Z = np.atleast_2d(np.asarray(Z, dtype=float))
    if Z.shape[0] != len(ck.variables):
        Z = Z.T
    Z1 = unit_rates(ck, Z)
    if Z.shape[1] == 1 and np.all(np.isfinite(Z1)):  # one pose: its neighbours along the tangent show a drift
        eps = 1e-4 / max(1.0, float(np.max(np.abs(Z1))))
        Z = np.concatenate([Z - eps * Z1, Z, Z + eps * Z1], axis=1)
        Z1 = unit_rates(ck, Z)
        xs = None if xs is None else [xs[0]] * 3
    ok_rows = np.all(np.isfinite(Z), axis=0) & np.all(np.isfinite(Z1), axis=0)
    if not ok_rows.any():
        return
    values = pair_evaluator(ck)
    where = mech.source or mech.name
    unit = mech.units.length
    for pair in mech.pairs.gears:
        if pair.rack:
            continue
        cg, cm = gear_centres(ck, Z, Z1, pair)
        for member, c in ((pair.gear, cg), (pair.mate, cm)):
            moved = _moves_on_carrier(ck, Z, Z1, pair.carrier, c, ok_rows)
            if moved is not None:
                i, dist = moved
                at = f" (it moves {dist:.3g} {unit} on the carrier"
                at += f", {ck.inputs[0]} = {float(np.asarray(xs)[i]):.6g})" if xs is not None else ")"
                raise ModelError(
                    f"{where}: {pair.key}: the gear {member or 'frame'!r} does not turn about a fixed centre of the "
                    f"carrier ({pair.carrier or 'the frame'}){at}: its centre drifts, so the pair cannot stay in "
                    "mesh; mesh gears whose links are pivoted on the carrier, or name the centres with `centers`")
        if cg is None or cm is None:
            continue
        d = np.linalg.norm(cg - cm, axis=1)
        good = np.isfinite(d) & ok_rows
        if not good.any():
            continue
        rg, rm, _ = ratio_values(pair, values)
        if rg is not None:
            want = abs(rg - rm) if pair.internal else rg + rm
            what = (f"the {'difference' if pair.internal else 'sum'} of the pitch radii {rg:.6g} "
                    f"{'-' if pair.internal else '+'} {rm:.6g} = {want:.6g} {unit}")
        else:
            want = float(d[good][0])
            what = f"its value {want:.6g} {unit} at the first row"
        err = np.where(good, np.abs(d - want), 0.0)
        tol = DRIFT * max(want, float(ck.scale))
        if float(err.max()) > tol:
            i = int(np.argmax(err))
            at = ""
            if xs is not None:
                at = f" at {ck.inputs[0]} = {float(np.asarray(xs)[i]):.6g}"
            drift = rg is None or float(np.nanmax(d[good]) - np.nanmin(d[good])) > tol
            raise ModelError(
                f"{where}: {pair.key}: the distance between the gears' centres is {d[i]:.6g} {unit}{at}, not "
                f"{what}: {'the centres drift as the mechanism moves, so ' if drift else ''}the gears cannot stay "
                "in mesh; mount both gears on pivots of the carrier "
                f"({pair.carrier or 'the frame'}) whose distance is the sum (difference, internal) of the pitch "
                "radii, or name the centres with `centers`")


def _moves_on_carrier(ck, Z, Z1, carrier, centre, ok_rows):
    """``(row, distance)`` where a gear centre moves relative to its carrier, else None."""
    if centre is None:
        return None
    motion = Motion(ck, Z, Z1)
    if carrier:
        B = link_point(motion, carrier)
        if B is None:
            return None
        th = Z[ck.index(carrier)]
        d = centre - B[0]
        c, s = np.cos(th), np.sin(th)
        local = np.stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]], axis=1)
    else:
        local = centre
    good = ok_rows & np.all(np.isfinite(local), axis=1)
    if good.sum() < 2:
        return None
    ref = local[np.flatnonzero(good)[0]]
    dist = np.where(good, np.linalg.norm(local - ref, axis=1), 0.0)
    if float(dist.max()) > DRIFT * float(ck.scale):
        i = int(np.argmax(dist))
        return i, float(dist[i])
    return None


def pair_evaluator(ck):
    """``values(node, kind)`` of the mechanism of ``ck``: its parameter expressions in internal units."""
    from ..model.pairs import evaluator

    return evaluator(ck.mechanism)
