"""Coulomb friction in the force analysis: the exact solution of the piecewise-linear Newton–Euler system.

With friction at some joints (:mod:`loopsolve.model.friction`), each row's Newton–Euler system becomes

    A u + Σ_k c_k |L_k u| g_k = b,

``u`` the unknown joint forces and driver, ``|L_k u|`` the normal force of sliding contact ``k`` (its
absolute value) or the force of revolute joint ``k`` (its magnitude), ``c_k`` the coefficient (μ, or
``r sin φ`` with ``tan φ = μ`` for a journal of radius ``r``: the friction circle) and ``g_k`` how a unit
friction force (torque) opposing the joint's relative velocity enters the bodies' equations. The
textbooks solve it by guessing the direction of each normal force and checking the guess; here the
frictionless solution starts a semismooth Newton iteration on the same equations (its Jacobian has
``sign(L_k u)`` or ``L_k u/|L_k u|`` rows), which ends in a few steps on the exact solution where one
exists. Where none exists — the driver would have to pull as the mechanism moves, however hard it
pushes, because the friction grows faster than the drive can — the mechanism **self-locks**: those
rows get no forces and an event ``self-locking``, not a failure. The power each joint loses,
``c_k |L_k u| |relative velocity|``, is reported and enters the power balance.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["FrictionTerm", "friction_terms", "solve_with_friction", "MAX_ITER"]

MAX_ITER = 60


@dataclass
class FrictionTerm:
    """One joint's friction: the columns of its force (``cols``), coefficient ``c`` (N,), the unit load
    ``g`` (N, equations) opposing the motion, the relative speed (N,) and the joint's name."""

    name: str
    cols: tuple
    c: np.ndarray
    g: np.ndarray
    speed: np.ndarray


def _cross(dx, dy, fx, fy):
    return dx * fy - dy * fx


def friction_terms(dm, lay, e, G, vG, om, geo, rigid_v) -> list[FrictionTerm]:
    """The friction terms of ``dm``'s mechanism for the rows of an evaluation (SI arrays)."""
    from ..model.pairs import evaluator
    from ..model.units import Kind

    mech = dm.ck.mechanism
    n = G.shape[-1]
    ne = lay.n_equations
    values = evaluator(mech)
    names = [b.name for b in dm.bodies]
    out = []
    n_pins, n_guides = len(lay.pins), len(lay.guides)
    contact_col = {}
    col = 2 * n_pins + 2 * n_guides + 1
    for i, c in enumerate(lay.contacts):
        contact_col[c.key] = (col, i)
        col += c.n

    def force_at(g, body, sign, Q, t):
        """Add to ``g`` the rows of a force ``sign·t`` at point ``Q`` on ``body``."""
        if body < 0:
            return
        g[:, 3 * body] += sign * t[:, 0]
        g[:, 3 * body + 1] += sign * t[:, 1]
        g[:, 3 * body + 2] += sign * _cross(Q[:, 0] - G[body, 0], Q[:, 1] - G[body, 1], t[:, 0], t[:, 1])

    for fr in mech.pairs.friction:
        if fr.kind == "pin":
            r = values(fr.radius, Kind.LENGTH) * dm.length_factor
            c = np.full(n, r * fr.mu / np.sqrt(1.0 + fr.mu**2))
            for k, (_, j, a, o) in enumerate(lay.pins):
                if dm.point_names[j] != fr.target:
                    continue
                w = om[a] - (om[o] if o >= 0 else 0.0)
                s = np.sign(w)
                g = np.zeros((n, ne))
                g[:, 3 * a + 2] -= s
                if o >= 0:
                    g[:, 3 * o + 2] += s
                out.append(FrictionTerm(fr.name, (2 * k, 2 * k + 1), c, g, np.abs(w)))
            continue
        if fr.kind == "guide":
            gi = next(i for i, (_, b, _, _) in enumerate(lay.guides) if names[b] == fr.target)
            _, b, o, vec = lay.guides[gi]
            phi = e["phi"][vec]
            t = np.stack([np.cos(phi), np.sin(phi)], axis=1)
            Q = G[b].T
            vo = rigid_v(o, Q[:, 0], Q[:, 1])
            vrel = vG[b].T - np.stack(vo, axis=1)
            cols = (2 * n_pins + 2 * gi,)
            a, other = b, o
        else:  # a slot or a cam: the contact's normal force, sliding along its tangent
            key = f"{'slots' if fr.kind == 'slot' else 'cams'}.{fr.target}"
            col0, ci = contact_col[key]
            cnt = lay.contacts[ci]
            Q = geo[ci]["P"]
            nrm = geo[ci]["dirs"][0]
            t = np.stack([-nrm[:, 1], nrm[:, 0]], axis=1)
            va, vb = rigid_v(cnt.a, Q[:, 0], Q[:, 1]), rigid_v(cnt.b, Q[:, 0], Q[:, 1])
            vrel = np.stack(va, axis=1) - np.stack(vb, axis=1)
            cols = (col0,)
            a, other = cnt.a, cnt.b
        slide = np.sum(vrel * t, axis=1)
        s = np.sign(slide)
        g = np.zeros((n, ne))
        force_at(g, a, -1.0, Q, s[:, None] * t)
        force_at(g, other, 1.0, Q, s[:, None] * t)
        out.append(FrictionTerm(fr.name, cols, np.full(n, fr.mu), g, np.abs(slide)))
    return out


def column_magnitude(u, cols):
    """The magnitude ``(N,)`` of the force components ``cols`` (one or two) of the solutions ``u``."""
    if len(cols) == 1:
        return np.abs(u[:, cols[0]])
    return np.sqrt(u[:, cols[0]] ** 2 + u[:, cols[1]] ** 2)


def _residual(A, u, b, terms):
    F = np.einsum("nij,nj->ni", A, u) - b
    for t in terms:
        F += (t.c * column_magnitude(u, t.cols))[:, None] * t.g
    return F


def solve_with_friction(entries, rhs, lay, n, terms, u0):
    """The exact solution with friction from the frictionless ``u0``: ``(u, locked)`` (``locked``: rows with
    no solution, where the mechanism self-locks; their ``u`` is NaN)."""
    ne, nu = lay.n_equations, lay.n_unknowns
    A = np.zeros((n, ne, nu))
    for r, c, v in entries:
        A[:, r, c] += v
    u = np.array(u0, dtype=float)
    ok = np.all(np.isfinite(u), axis=1) & np.all(np.isfinite(A), axis=(1, 2))
    u[~ok] = 0.0
    scale = np.max(np.abs(rhs), axis=1) + np.max(np.abs(np.einsum("nij,nj->ni", A, u)), axis=1) + 1e-300
    F = _residual(A, u, rhs, terms)
    done = ~ok | (np.max(np.abs(F), axis=1) <= 1e-11 * scale)
    for _ in range(MAX_ITER):
        todo = np.flatnonzero(~done)
        if not todo.size:
            break
        J = A[todo].copy()
        for t in terms:
            uc = u[todo][:, list(t.cols)]
            m = column_magnitude(u[todo], t.cols)
            grad = np.where(m[:, None] > 0, uc / np.where(m > 0, m, 1.0)[:, None], 0.0)
            if len(t.cols) == 1:
                grad = np.sign(uc)
            for k, col in enumerate(t.cols):
                J[:, :, col] += (t.c[todo] * grad[:, k])[:, None] * t.g[todo]
        try:
            du = np.linalg.solve(J, -F[todo][..., None])[..., 0]
        except np.linalg.LinAlgError:
            du = np.stack([np.linalg.lstsq(Jr, -Fr, rcond=None)[0] for Jr, Fr in zip(J, F[todo])])
        norm0 = np.max(np.abs(F[todo]), axis=1)
        step = np.ones(len(todo))
        for _ in range(12):  # backtracking: the residual must fall
            trial = u[todo] + step[:, None] * du
            Ft = _residual(A[todo], trial, rhs[todo], [_rows(t, todo) for t in terms])
            better = np.max(np.abs(Ft), axis=1) < norm0
            if better.all():
                break
            step = np.where(better, step, step / 2)
        u[todo] = trial
        F[todo] = Ft
        done[todo] = np.max(np.abs(Ft), axis=1) <= 1e-11 * scale[todo]
    locked = ok & ~done
    u[~ok] = np.nan
    u[locked] = np.nan
    return u, locked


def _rows(t: FrictionTerm, idx) -> FrictionTerm:
    return FrictionTerm(t.name, t.cols, t.c[idx], t.g[idx], t.speed[idx])


def lost_power(terms, u) -> dict:
    """``{joint: (N,) W}``: the power each joint's friction dissipates (≥ 0)."""
    out: dict = {}
    for t in terms:
        p = t.c * column_magnitude(u, t.cols) * t.speed
        out[t.name] = out.get(t.name, 0.0) + p
    return out
