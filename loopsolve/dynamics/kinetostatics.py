"""Inverse dynamics (kinetostatics): driving torque, joint forces, shaking force, energies, power balance.

For a prescribed motion of the input (position, speed, acceleration at every point of a sweep),
Newton–Euler for every moving body,

    Σ F = m a_G,      Σ M_G = I α,

is a linear system in the joint forces, the guide reactions (a normal force and a couple per
sliding contact) and the driving torque (or force); it is assembled from the compiled kinematics
and solved for all points at once. The shaking force and moment are what the mechanism exerts on
the frame through the frame pins, the guides on the frame and the driver (moments about the
model's origin). The power balance ``T ẋ = dE_k/dt + dV/dt − P_loads`` is reported as a residual.

Sign conventions (contract): ``F_<joint>`` is the force **on** the body declared first among those
carrying the joint **from** the other body (or the frame). Everything is SI.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model.bodies import FRAME, LoadKind
from .dynamics_model import DynamicsModel, kinematic_coefficients, mass_matrix_terms
from ..model.units import Kind

__all__ = ["Layout", "layout", "inverse_dynamics", "generalized_force", "virtual_work_drive",
           "SINGULAR_RATIO"]

#: Hadamard ratio |det A| / Π‖row‖ of the Newton–Euler matrix below which a pose is reported as
#: singular (a dead centre for the forces: the joint forces are undetermined)
SINGULAR_RATIO = 1e-12
_CHUNK = 4096
#: a fixed right-hand side with no structure (probes the inverse of the Newton–Euler matrix)
_PROBE = 1.0 + 0.5 * np.sin(1.7 * np.arange(1, 200) + 0.3)


def _cross(dx, dy, fx, fy):
    return dx * fy - dy * fx


@dataclass(frozen=True)
class Layout:
    """Unknowns of the Newton–Euler system: pins, guide reactions and the driver.

    ``pins``: (column name, joint index in ``dm.point_names``, body index, other body index or −1);
    ``guides``: (column name, body index, other index or −1, guide index); ``driver``: body index;
    ``contacts``: the higher pairs' contact unknowns (:class:`loopsolve.dynamics.contacts.Contact`),
    after the driver's column.
    """

    pins: tuple
    guides: tuple
    driver: int
    n_unknowns: int
    n_equations: int
    contacts: tuple = ()


def layout(dm: DynamicsModel) -> Layout:
    """The unknowns of the Newton–Euler system of ``dm`` (raises when it is not square)."""
    from ..errors import ModelError

    names = [b.name for b in dm.bodies]
    pins = []
    mech = dm.ck.mechanism
    slotted = {sl.point for sl in mech.pairs.slots} if mech.pairs is not None else set()
    for j, pname in enumerate(dm.point_names):
        carriers = [i for i, b in enumerate(dm.bodies) if pname in b.joints]
        if not carriers or pname in slotted:  # a pin in a slot: the slot's normal reaction (a contact)
            continue
        if len(carriers) == 1:
            pins.append((f"F_{pname}", j, carriers[0], -1))
        elif len(carriers) == 2:
            pins.append((f"F_{pname}", j, carriers[0], carriers[1]))
        else:
            for o in carriers[1:]:
                pins.append((f"F_{pname}_{names[o]}", j, carriers[0], o))
    guides = []
    for i, b in enumerate(dm.bodies):
        if b.guide is not None:
            other = -1 if b.guide_body == FRAME else names.index(b.guide_body)
            guides.append((f"{b.name}_guide", i, other, dm.guide_vectors.index(b.guide)))
    from .contacts import contacts

    pairs = contacts(dm)
    n_u = 2 * len(pins) + 2 * len(guides) + 1 + sum(c.n for c in pairs)
    n_e = 3 * len(dm.bodies)
    if n_u != n_e:
        mech = dm.ck.mechanism
        raise ModelError(
            f"{mech.source or mech.name}: bodies: the joint forces cannot be found by statics: "
            f"{len(dm.bodies)} bodies give {n_e} equations of motion but the pins, guides"
            f"{', contacts' if pairs else ''} and the driver have {n_u} unknown force components (each pin 2, each "
            f"guide 2, the driver 1{', each gear pair, cam or slot 1, each rolling contact 2' if pairs else ''}); "
            "declare every moving link as a body, with the joints it carries")
    return Layout(tuple(pins), tuple(guides), names.index(dm.input_body), n_u, n_e, pairs)


def _external(dm: DynamicsModel, e: dict, n: int):
    """Known forces and moments (about each G) on every body, and the loads' power and potential."""
    lf = dm.length_factor
    nb = len(dm.bodies)
    names = [b.name for b in dm.bodies]
    F = np.zeros((nb, 2, n))
    Mo = np.zeros((nb, n))
    G, vG = e["G"] * lf, e["vG"] * lf
    P, vP = e["P"] * lf, e["vP"] * lf
    m = np.array([b.mass for b in dm.bodies])
    F += m[:, None, None] * dm.gravity[None, :, None]
    power = np.zeros(n)  # power of the non-conservative loads
    potential = -np.sum(m[:, None] * np.einsum("k,bkn->bn", dm.gravity, G), axis=0)
    dpot = -np.sum(m[:, None] * np.einsum("k,bkn->bn", dm.gravity, vG), axis=0)
    slot = 0
    pidx = {p: i for i, p in enumerate(dm.point_names)}

    def apply(body, point_xy, f):
        if body == FRAME:
            return
        b = names.index(body)
        F[b] += f
        Mo[b] += _cross(point_xy[0] - G[b, 0], point_xy[1] - G[b, 1], f[0], f[1])

    frame_force = np.zeros((2, n))
    frame_moment = np.zeros(n)
    for ld in dm.dynamics.loads:
        vals = e["load"][slot:slot + len(ld.values)]
        slot += len(ld.values)
        if ld.kind is LoadKind.FORCE:
            j = pidx[ld.at]
            f = np.asarray(vals)
            apply(ld.body, P[j], f)
            if ld.body != FRAME:
                power += np.sum(f * vP[j], axis=0)
        elif ld.kind is LoadKind.TORQUE:
            if ld.body != FRAME:
                b = names.index(ld.body)
                Mo[b] += vals[0]
                power += vals[0] * e["om"][b]
        elif ld.kind in (LoadKind.SPRING, LoadKind.DAMPER):
            a, c = pidx[ld.ends[0]], pidx[ld.ends[1]]
            d = P[a] - P[c]
            L = np.sqrt(np.sum(d**2, axis=0))
            u = d / np.where(L > 0, L, 1.0)
            Ld = np.sum(u * (vP[a] - vP[c]), axis=0)
            if ld.kind is LoadKind.SPRING:
                f = ld.stiffness * (L - ld.free * lf)
                potential += 0.5 * ld.stiffness * (L - ld.free * lf) ** 2
                dpot += f * Ld
            else:
                f = ld.damping * Ld
                power -= f * Ld
            for end, body, sgn in ((a, ld.bodies[0], -1.0), (c, ld.bodies[1], 1.0)):
                apply(body, P[end], sgn * f * u)
                if body == FRAME:
                    frame_force += sgn * f * u
                    frame_moment += _cross(P[end][0], P[end][1], sgn * f * u[0], sgn * f * u[1])
        elif ld.kind is LoadKind.TORSION_SPRING:
            b = names.index(ld.body)
            tau = -ld.stiffness * (e["th"][b] - ld.free)
            Mo[b] += tau
            potential += 0.5 * ld.stiffness * (e["th"][b] - ld.free) ** 2
            dpot += -tau * e["om"][b]
        elif ld.kind is LoadKind.TORSION_DAMPER:
            b = names.index(ld.body)
            tau = -ld.damping * e["om"][b]
            Mo[b] += tau
            power += tau * e["om"][b]
    return F, Mo, power, potential, dpot, frame_force, frame_moment


def solve_batched(A: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Solve ``A[i] x[i] = b[i]`` for a stack of small square systems; also their Hadamard ratios.

    Gaussian elimination with partial pivoting written across the stack (each step one numpy
    operation on all systems: much faster than a LAPACK call per small matrix). The Hadamard ratio
    ``|det A| / Π‖row‖`` is 1 for orthogonal rows and 0 for a singular matrix, whatever the scale
    of each row; where it is 0 the solution is garbage (the caller masks it).

    Examples
    --------
    >>> from loopsolve.dynamics.kinetostatics import solve_batched
    >>> x, r = solve_batched(np.array([[[0.0, 2.0], [1.0, 1.0]]]), np.array([[4.0, 3.0]]))
    >>> x.round(12).tolist(), float(r[0].round(6))
    ([[1.0, 2.0]], 0.707107)
    """
    M = np.ascontiguousarray(np.moveaxis(np.asarray(A, dtype=float), 0, -1))  # (n, n, N)
    y = np.ascontiguousarray(np.asarray(b, dtype=float).T)  # (n, N)
    x, ratio = _solve_stacked(M, y)
    return x.T, ratio


def _solve_stacked(M: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`solve_batched` on ``(n, n, N)`` / ``(n, N)`` arrays (overwritten); returns ``(n, N)``.

    ``y`` may also be ``(n, m, N)``: m right-hand sides per system, the solution of the same shape.
    """
    n, N = y.shape[0], y.shape[-1]
    norms = np.prod(np.sqrt(np.einsum("ijk,ijk->ik", M, M)), axis=0)
    absdet = np.ones(N)
    for k in range(n):
        col = M[k:, k, :]
        rows = np.flatnonzero(np.any(col != 0, axis=1))  # rows that can hold the pivot
        if rows.size:
            piv = k + rows[np.argmax(np.abs(col[rows]), axis=0)]
            moved = np.flatnonzero(piv != k)
            if moved.size:
                pk = piv[moved]
                row = M[k, :, moved].copy()
                M[k, :, moved] = M[pk, :, moved]
                M[pk, :, moved] = row
                yk = y[k, ..., moved].copy()
                y[k, ..., moved] = y[pk, ..., moved]
                y[pk, ..., moved] = yk
        p = M[k, k, :]
        absdet *= np.abs(p)
        below = k + 1 + np.flatnonzero(np.any(M[k + 1:, k, :] != 0, axis=1))  # rows to eliminate
        if below.size:
            f = M[below, k, :] / np.where(p == 0, 1.0, p)
            nzc = k + np.flatnonzero(np.any(M[k, k:, :] != 0, axis=1))  # nonzero columns of the pivot row
            M[np.ix_(below, nzc)] -= f[:, None, :] * M[k, nzc, :][None]
            y[below] -= (f if y.ndim == 2 else f[:, None, :]) * y[k]
    x = np.empty(y.shape)
    for k in range(n - 1, -1, -1):
        acc = y[k] - np.einsum("jn,j...n->...n", M[k, k + 1:, :], x[k + 1:]) if k + 1 < n else y[k]
        p = M[k, k, :]
        x[k] = acc / np.where(p == 0, 1.0, p)
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = np.where(norms > 0, absdet / np.where(norms > 0, norms, 1.0), 0.0)
    return x, ratio


def inverse_dynamics(dm: DynamicsModel, z, xd, xdd, *, rates=None, check: bool = True) -> dict:
    """Newton–Euler at every point: ``z`` ``(N, nvar)`` positions, ``xd``/``xdd`` input speed and acceleration.

    ``xd``, ``xdd`` are in internal units (rad/s, rad/s² or length unit/s, /s²). Returns SI arrays:
    ``drive`` (N·m or N), ``pins`` {name: (N, 2)}, ``guides`` {name: (N, 3)} (force x, y and couple),
    ``shaking_force`` (N, 2), ``shaking_moment``, ``kinetic_energy``, ``potential_energy``,
    ``power_residual`` (W) and ``power_scale`` (W), ``singular`` (bool: no forces here),
    ``nonfinite`` (bool: singular because a load, mass property or rate is not a finite number
    there, not a dead centre), ``cond`` (the Hadamard ratio of the matrix, 1 = well conditioned,
    0 = singular), ``z1``, ``z2``,
    ``residual`` (N, bodies, 3) the Newton–Euler residuals of the solution, ``force_scale``.
    ``rates`` = ``(z1, z2)``, the ``(N, nvar)`` velocities and accelerations of this motion when
    already known (a sweep's), skips solving for them. ``kappa`` is the condition number of each
    row's Newton–Euler matrix (1-norm, rows and columns scaled to a largest entry of 1, the norm of
    the inverse estimated from below with one probe right-hand side; inf where singular) and ``spurious``
    {constraint or load: (N,) W} the power each pin, guide, driver and point load does on the bodies
    beyond what it should (zero for a consistent declaration).

    With ``check`` (default), the declarations are first checked against the kinematics
    (:func:`loopsolve.dynamics.declcheck.check_carriers`: raises :class:`ModelError` for a joint left out of
    a body, a load on a body that does not carry its point).
    """
    z = np.atleast_2d(np.asarray(z, dtype=float))
    n = z.shape[0]
    if check and n:
        from .declcheck import check_carriers

        check_carriers(dm, z)
    xd = np.broadcast_to(np.asarray(xd, dtype=float), (n,))
    xdd = np.broadcast_to(np.asarray(xdd, dtype=float), (n,))
    lay = layout(dm)
    if rates is None:
        d1, d2 = kinematic_coefficients(dm.ck, z)
        z1 = d1 * xd[:, None]
        z2 = d1 * xdd[:, None] + d2 * (xd**2)[:, None]
    else:  # the rates of a sweep at this input motion (consistent with xd, xdd)
        z1, z2 = (np.asarray(r, dtype=float) for r in rates)
        d1 = d2 = None
    e = dm.evaluate(z.T, z1.T, z2.T)
    lf = dm.length_factor
    G, aG, vG = e["G"] * lf, e["aG"] * lf, e["vG"] * lf
    P = e["P"] * lf
    nb = len(dm.bodies)
    m = np.array([b.mass for b in dm.bodies])
    inertia = np.array([b.inertia for b in dm.bodies])
    Fext, Mext, p_loads, pot, dpot, ff, fm = _external(dm, e, n)

    # the matrix as (row, column, values) entries; filled and solved in chunks that stay in cache
    entries: list = []
    col = 0
    for _, j, a, o in lay.pins:
        for body, sgn in ((a, 1.0), (o, -1.0)):
            if body < 0:
                continue
            dx, dy = P[j, 0] - G[body, 0], P[j, 1] - G[body, 1]
            entries += [(3 * body, col, sgn), (3 * body + 1, col + 1, sgn),
                        (3 * body + 2, col, -sgn * dy), (3 * body + 2, col + 1, sgn * dx)]
        col += 2
    for _, b, o, g in lay.guides:
        phi = e["phi"][g]
        nx, ny = -np.sin(phi), np.cos(phi)
        entries += [(3 * b, col, nx), (3 * b + 1, col, ny), (3 * b + 2, col + 1, 1.0)]
        if o >= 0:
            dx, dy = G[b, 0] - G[o, 0], G[b, 1] - G[o, 1]
            entries += [(3 * o, col, -nx), (3 * o + 1, col, -ny), (3 * o + 2, col, -_cross(dx, dy, nx, ny)),
                        (3 * o + 2, col + 1, -1.0)]
        col += 2
    drv = lay.driver
    if dm.input_kind is Kind.ANGLE:
        entries.append((3 * drv + 2, col, 1.0))
        ex = ey = None
    else:
        phi = e["phi"][dm.guide_vectors.index(dm.input_guide)]
        ex, ey = np.cos(phi), np.sin(phi)
        entries += [(3 * drv, col, ex), (3 * drv + 1, col, ey)]
    geo = [_contact_geometry(dm, c, z, z1, e) for c in lay.contacts]
    sigma = [np.ones(n) for _ in lay.contacts]  # the loaded flank of each gear pair (sign of W), found below
    rhs = np.zeros((n, lay.n_equations))
    for b in range(nb):
        rhs[:, 3 * b] = m[b] * aG[b, 0] - Fext[b, 0]
        rhs[:, 3 * b + 1] = m[b] * aG[b, 1] - Fext[b, 1]
        rhs[:, 3 * b + 2] = inertia[b] * e["al"][b] - Mext[b]

    def all_entries():
        return entries + _contact_entries(lay, geo, sigma, G, col + 1)

    u, residual, ratio, kappa, nonfinite = _solve_system(all_entries(), rhs, lay, n)
    for _ in range(3):  # a gear's radial force pushes the gears apart whichever flank is loaded
        flipped = False
        c0 = col + 1
        for i, c in enumerate(lay.contacts):
            if c.kind in ("gear", "rack"):
                s_new = np.where(np.isfinite(u[:, c0]), np.where(u[:, c0] < 0, -1.0, 1.0), sigma[i])
                flipped |= bool(np.any(s_new != sigma[i]))
                sigma[i] = s_new
            c0 += c.n
        if not flipped:
            break
        u, residual, ratio, kappa, nonfinite = _solve_system(all_entries(), rhs, lay, n)
    om = e["om"]

    def rigid_v(body, px, py):
        """Velocity (SI) of the material point of ``body`` at (px, py); the frame's is zero."""
        if body < 0:
            return np.zeros(n), np.zeros(n)
        return vG[body, 0] - om[body] * (py - G[body, 1]), vG[body, 1] + om[body] * (px - G[body, 0])

    mech = dm.ck.mechanism
    fterms, locked = [], np.zeros(n, dtype=bool)
    if mech.pairs is not None and mech.pairs.friction:  # Coulomb friction: the exact solution, or self-locking
        from .friction import friction_terms, solve_with_friction

        fterms = friction_terms(dm, lay, e, G, vG, om, geo, rigid_v)
        u, locked = solve_with_friction(all_entries(), rhs, lay, n, fterms, u)
        residual = _friction_residual(all_entries(), rhs, lay, n, fterms, u)
    singular = ~(ratio > SINGULAR_RATIO)
    residual = residual.reshape(n, nb, 3)
    cond = ratio

    kappa[singular] = np.inf
    out: dict = {"singular": singular, "nonfinite": nonfinite, "cond": cond, "kappa": kappa, "z1": z1, "z2": z2,
                 "layout": lay, "self_locking": locked}

    spurious: dict = {}
    pins, guides = {}, {}
    col = 0
    sf = np.zeros((n, 2))
    sm = np.zeros(n)
    for name, j, a, o in lay.pins:
        f = u[:, col:col + 2]
        pins[name] = f
        va, vo = rigid_v(a, P[j, 0], P[j, 1]), rigid_v(o, P[j, 0], P[j, 1])
        spurious[f"the pin {dm.point_names[j]!r} between {_body(dm, a)} and {_body(dm, o)}"] = (
            f[:, 0] * (va[0] - vo[0]) + f[:, 1] * (va[1] - vo[1]))
        if o < 0:
            sf -= f
            sm -= _cross(P[j, 0], P[j, 1], f[:, 0], f[:, 1])
        col += 2
    for name, b, o, g in lay.guides:
        phi = e["phi"][g]
        N, C = u[:, col], u[:, col + 1]
        f = np.stack([-np.sin(phi) * N, np.cos(phi) * N], axis=1)
        guides[name] = np.column_stack([f, C])
        vo = rigid_v(o, G[b, 0], G[b, 1])
        spurious[f"the guide of {_body(dm, b)} (guide = {dm.bodies[b].guide!r} on {_body(dm, o)})"] = (
            f[:, 0] * (vG[b, 0] - vo[0]) + f[:, 1] * (vG[b, 1] - vo[1])
            + C * (om[b] - (om[o] if o >= 0 else 0.0)))
        if o < 0:
            sf -= f
            sm -= _cross(G[b, 0], G[b, 1], f[:, 0], f[:, 1]) + C
        col += 2
    drive = u[:, col]
    if ex is None:
        sm -= drive
        p_drive = drive * xd
        spurious[f"the driver on {_body(dm, drv)}"] = drive * (om[drv] - xd)
    else:
        f = np.stack([ex * drive, ey * drive], axis=1)
        sf -= f
        sm -= _cross(G[drv, 0], G[drv, 1], f[:, 0], f[:, 1])
        p_drive = drive * xd * lf
        spurious[f"the driver on {_body(dm, drv)}"] = f[:, 0] * vG[drv, 0] + f[:, 1] * vG[drv, 1] - p_drive
    contact_forces = _contact_results(lay, geo, sigma, u, col + 1, rigid_v, spurious, sf, sm)
    vPs = e["vP"] * lf
    slot = 0
    for ld in dm.dynamics.loads:
        vals = e["load"][slot:slot + len(ld.values)]
        slot += len(ld.values)
        if ld.kind is LoadKind.FORCE and ld.body != FRAME:
            j = dm.point_names.index(ld.at)
            b = [bb.name for bb in dm.bodies].index(ld.body)
            vb = rigid_v(b, P[j, 0], P[j, 1])
            spurious[f"the load {ld.name!r} (loads[{ld.index}], at {ld.at!r} on {ld.body!r})"] = (
                vals[0] * (vb[0] - vPs[j, 0]) + vals[1] * (vb[1] - vPs[j, 1]))
    lost = {}
    if fterms:
        from .friction import lost_power

        lost = lost_power(fterms, u)
    p_lost = sum(lost.values()) if lost else np.zeros(n)
    ke = 0.5 * np.sum(m[:, None] * np.sum(vG**2, axis=1) + inertia[:, None] * e["om"] ** 2, axis=0)
    dke = np.sum(m[:, None] * np.sum(vG * aG, axis=1) + inertia[:, None] * e["om"] * e["al"], axis=0)
    scale = np.abs(p_drive) + np.abs(dke) + np.abs(dpot) + np.abs(p_loads) + np.abs(p_lost)
    fscale = (np.sum(np.abs(m[:, None, None] * aG), axis=(0, 1)) + np.sum(np.abs(Fext), axis=(0, 1))
              + np.abs(u).sum(axis=1))
    out.update(drive=drive, pins=pins, guides=guides, contacts=contact_forces, shaking_force=sf, shaking_moment=sm,
               kinetic_energy=ke, potential_energy=pot, power_lost=lost,
               power_residual=p_drive - (dke + dpot - p_loads + p_lost),
               power_scale=scale, residual=residual, force_scale=fscale, d1=d1, d2=d2, spurious=spurious)
    return out


def _solve_system(entries, rhs, lay, n):
    """Solve the Newton–Euler system given by its sparse ``entries`` (row, column, value or array) at
    every point, in chunks; returns ``u``, the residuals, the Hadamard ratios, the condition numbers
    and the rows where something was not finite."""
    ne = lay.n_equations
    u = np.empty((n, lay.n_unknowns))
    residual = np.empty((n, ne))
    ratio = np.empty(n)
    kappa = np.full(n, np.inf)
    nonfinite = np.zeros(n, dtype=bool)
    eye = np.eye(ne)
    for lo in range(0, n, _CHUNK):  # chunks that stay in cache
        hi = min(n, lo + _CHUNK)
        Mt = np.zeros((ne, lay.n_unknowns, hi - lo))  # (rows, columns, points)
        for r, c, v in entries:
            Mt[r, c] += v[lo:hi] if isinstance(v, np.ndarray) else v
        b_ = rhs[lo:hi]
        finite = np.all(np.isfinite(Mt), axis=(0, 1)) & np.all(np.isfinite(b_), axis=1)
        if not finite.all():
            Mt[:, :, ~finite] = eye[:, :, None]
            nonfinite[lo:hi] = ~finite
        # the condition of the matrix scaled to rows and columns of largest entry 1 (units do not count):
        # ‖S‖₁ and a lower estimate of ‖S⁻¹‖₁ from one more right-hand side, solved with the same elimination
        absM = np.abs(Mt)
        rmax = absM.max(axis=1)
        rmax[rmax == 0] = 1.0
        absM /= rmax[:, None, :]
        cmax = absM.max(axis=0)
        cmax[cmax == 0] = 1.0
        norm_s = (absM.sum(axis=0) / cmax).max(axis=0)
        rhs2 = np.stack([np.where(finite[:, None], b_, 0.0).T, rmax * _PROBE[:ne, None]], axis=1)
        uc2, had = _solve_stacked(Mt, rhs2)
        uc = uc2[:, 0]
        with np.errstate(invalid="ignore", over="ignore"):
            inv_s = np.sum(np.abs(uc2[:, 1] * cmax), axis=0) / np.sum(np.abs(_PROBE[:ne]))
            kappa[lo:hi] = np.where(finite & np.isfinite(inv_s), norm_s * inv_s, np.inf)
        had[~finite] = 0.0
        bad = ~(had > SINGULAR_RATIO)
        uc[:, bad] = np.nan
        u[lo:hi] = uc.T
        res = -b_.copy()
        for r, c, v in entries:  # A u − b from the sparse entries
            res[:, r] += (v[lo:hi] if isinstance(v, np.ndarray) else v) * uc[c]
        residual[lo:hi] = res
        ratio[lo:hi] = had
    return u, residual, ratio, kappa, nonfinite


def _friction_residual(entries, rhs, lay, n, terms, u):
    """The Newton–Euler residuals ``A u + friction − b`` of the solution with friction."""
    from .friction import column_magnitude

    res = -rhs.copy()
    for r, c, v in entries:
        res[:, r] += v * u[:, c]
    for t in terms:
        res += (t.c * column_magnitude(u, t.cols))[:, None] * t.g
    return res


def _contact_results(lay, geo, sigma, u, col0, rigid_v, spurious, sf, sm) -> dict:
    """``{F_<name>: (N, 3)}``: the contact force along its line (line of action, normal) and its x, y
    components on the pair's first body; the shaking force and moment and the spurious power updated."""
    out = {}
    col = col0
    for c, g, sg in zip(lay.contacts, geo, sigma):
        P = g["P"]
        if c.kind in ("gear", "rack"):
            W = u[:, col]
            f = W[:, None] * g["t"] + (np.abs(W) * g["tan"])[:, None] * g["r"]
            along = np.abs(W) * np.sqrt(1.0 + g["tan"] ** 2)  # |W| / cos φ
        else:
            comps = [u[:, col + k, None] * d for k, d in enumerate(g["dirs"])]
            f = sum(comps)
            along = u[:, col]  # the normal force (signed: negative pulls)
        col += c.n
        out[c.name] = np.column_stack([along, f])
        va, vb = rigid_v(c.a, P[:, 0], P[:, 1]), rigid_v(c.b, P[:, 0], P[:, 1])
        spurious[f"the contact {c.key}"] = f[:, 0] * (va[0] - vb[0]) + f[:, 1] * (va[1] - vb[1])
        for body, sgn in ((c.a, 1.0), (c.b, -1.0)):  # the frame's side: what the mechanism exerts on it
            if body < 0:
                sf += sgn * f
                sm += sgn * _cross(P[:, 0], P[:, 1], f[:, 0], f[:, 1])
    return out


def _contact_geometry(dm, c, z, z1, e):
    from .contacts import contact_geometry

    return contact_geometry(dm, c, z, z1, e)


def _contact_entries(lay, geo, sigma, G, col0):
    """The Newton–Euler entries of the contact unknowns: force on body ``a`` at the contact, minus it on ``b``."""
    out = []
    col = col0
    for c, g, sg in zip(lay.contacts, geo, sigma):
        if c.kind in ("gear", "rack"):
            dirs = [g["t"] + (sg * g["tan"])[:, None] * g["r"]]
        else:
            dirs = g["dirs"]
        P = g["P"]
        for d in dirs:
            for body, sgn in ((c.a, 1.0), (c.b, -1.0)):
                if body < 0:
                    continue
                dx, dy = P[:, 0] - G[body, 0], P[:, 1] - G[body, 1]
                out += [(3 * body, col, sgn * d[:, 0]), (3 * body + 1, col, sgn * d[:, 1]),
                        (3 * body + 2, col, sgn * _cross(dx, dy, d[:, 0], d[:, 1]))]
            col += 1
    return out


#: scaled condition number of Φ_q below which a pose is regular for the kinematics: there a
#: singular Newton–Euler system is a declaration fault, not a dead centre
_KIN_REGULAR = 1e6


def _check_determined(dm: DynamicsModel, data: dict, sweep, xs) -> None:
    """A Newton–Euler system singular where the kinematics are regular is a declaration fault.

    For a one-degree-of-freedom mechanism whose bodies, joints and guides are declared consistently,
    the joint forces and the driver are determined wherever Φ_q is regular (the forces' dead centres
    are the kinematic ones); a singular system at a regular pose means the constraints do not match
    the motion (a guide on the wrong vector or body, a body sliding on a turning guide declared on
    the frame, ...). Raises :class:`ModelError`.
    """
    from ..errors import ModelError

    ck = sweep.compiled
    rows = np.flatnonzero(np.asarray(data["singular"]) & ~np.asarray(data["nonfinite"]))
    col = np.array([1.0 if k is Kind.ANGLE else float(ck.scale) for k in ck.kinds])[ck.unknown_idx]
    for i in rows[:8]:
        z = sweep.z[i]
        if not np.all(np.isfinite(z)) or not np.all(np.isfinite(sweep.z1[i])):
            continue
        J = ck.jac(z)
        if not np.all(np.isfinite(J)):
            continue
        sv = np.linalg.svd(J * col, compute_uv=False)
        if sv[-1] > 0 and sv[0] / sv[-1] < _KIN_REGULAR:
            mech = ck.mechanism
            guided = [f"bodies.{b.name}.guide = {b.guide!r} (on {b.guide_body!r})" for b in dm.bodies if b.guide]
            raise ModelError(
                f"{mech.source or mech.name}: the joint forces are undetermined at {ck.inputs[0]} = {xs[i]:.10g} "
                f"although the mechanism is far from a dead centre there (condition of the loops' Jacobian "
                f"{sv[0] / sv[-1]:.3g}): the bodies' joints and guides do not match the motion"
                + (f"; check {', '.join(guided)}: a body slides along its guide relative to the body (or frame) "
                   "carrying it, and turns with it" if guided else "; check each body's `joints` and `angle`"))


def _body(dm: DynamicsModel, i: int) -> str:
    return "the frame" if i < 0 else repr(dm.bodies[i].name)
    A = A[finite]
    B = np.abs(A)
    for axis in (2, 1):
        s = np.max(B, axis=axis, keepdims=True)
        s[s == 0] = 1.0
        A /= s
        B /= s
    try:
        inv = np.linalg.inv(A)
    except np.linalg.LinAlgError:  # an exactly singular one: one at a time
        inv = np.empty_like(A)
        for i, a in enumerate(A):
            try:
                inv[i] = np.linalg.inv(a)
            except np.linalg.LinAlgError:
                inv[i] = np.inf
    with np.errstate(invalid="ignore", over="ignore"):
        np.abs(inv, out=inv)
        k = np.max(np.sum(B, axis=1), axis=1) * np.max(np.sum(inv, axis=1), axis=1)
    kappa[finite] = np.where(np.isfinite(k), k, np.inf)
    return kappa
    A = A[finite]
    for _ in range(_RUIZ):  # Ruiz equilibration: rows and columns of unit largest entry
        for axis in (2, 1):
            s = np.sqrt(np.max(np.abs(A), axis=axis, keepdims=True))
            A = A / np.where(s > 0, s, 1.0)
    sv = np.linalg.svd(A, compute_uv=False)
    with np.errstate(divide="ignore", invalid="ignore"):
        k = np.where(sv[:, -1] > 0, sv[:, 0] / sv[:, -1], np.inf)
    kappa[finite] = k
    return kappa


def generalized_force(dm: DynamicsModel, z, xd, d1) -> np.ndarray:
    """Q: the generalized force of gravity, loads, springs and dampers by virtual work (SI).

    ``z`` and the kinematic coefficients ``d1`` are ``(N, nvar)``; ``xd`` the input speed (internal
    units; loads and dampers may depend on it).
    """
    z = np.atleast_2d(z)
    n = z.shape[0]
    xd = np.broadcast_to(np.asarray(xd, dtype=float), (n,))
    e1 = dm.evaluate(z.T, d1.T, np.zeros_like(z.T))  # geometric coefficients dr/dx
    ev = dm.evaluate(z.T, (d1 * xd[:, None]).T, np.zeros_like(z.T)) if dm.loads_use_rates else e1
    return generalized_from(dm, e1, ev["load"], xd)


def generalized_from(dm: DynamicsModel, e1: dict, load_values, xd) -> np.ndarray:
    """Q from an evaluation ``e1`` at the kinematic coefficients and the loads' values (see above)."""
    s = dm.coord_factor
    lf = dm.length_factor
    m = np.array([b.mass for b in dm.bodies])
    names = [b.name for b in dm.bodies]
    pidx = {p: i for i, p in enumerate(dm.point_names)}
    vg = e1["vG"] * lf / s
    Q = np.sum(m[:, None] * np.einsum("k,bkn->bn", dm.gravity, vg), axis=0)
    P = e1["P"] * lf
    dP = e1["vP"] * lf / s
    xs = np.asarray(xd) * s  # generalized speed (SI)
    slot = 0
    for ld in dm.dynamics.loads:
        vals = load_values[slot:slot + len(ld.values)]
        slot += len(ld.values)
        if ld.kind is LoadKind.FORCE:
            if ld.body != FRAME:
                Q = Q + np.sum(np.asarray(vals) * dP[pidx[ld.at]], axis=0)
        elif ld.kind is LoadKind.TORQUE:
            if ld.body != FRAME:
                Q = Q + vals[0] * e1["om"][names.index(ld.body)] / s
        elif ld.kind in (LoadKind.SPRING, LoadKind.DAMPER):
            a, c = pidx[ld.ends[0]], pidx[ld.ends[1]]
            d = P[a] - P[c]
            L = np.sqrt(np.sum(d**2, axis=0))
            u = d / np.where(L > 0, L, 1.0)
            dL = np.sum(u * (dP[a] - dP[c]), axis=0)
            if ld.kind is LoadKind.SPRING:
                Q = Q - ld.stiffness * (L - ld.free * lf) * dL
            else:
                Q = Q - ld.damping * dL * xs * dL
        elif ld.kind is LoadKind.TORSION_SPRING:
            b = names.index(ld.body)
            Q = Q - ld.stiffness * (e1["th"][b] - ld.free) * e1["om"][b] / s
        elif ld.kind is LoadKind.TORSION_DAMPER:
            b = names.index(ld.body)
            w = e1["om"][b] / s
            Q = Q - ld.damping * w * xs * w
    return Q


def virtual_work_drive(dm: DynamicsModel, z, xd, xdd) -> np.ndarray:
    """Driving torque (force) from the equation of motion: ``T = M ẍ + ½ M′ ẋ² − Q`` (SI).

    Independent of the joint forces: M, M′ and Q come from the kinematic coefficients.
    """
    z = np.atleast_2d(np.asarray(z, dtype=float))
    d1, d2 = kinematic_coefficients(dm.ck, z)
    M, dM = mass_matrix_terms(dm, z, d1, d2)
    s = dm.coord_factor
    Q = generalized_force(dm, z, xd, d1)
    return M * np.asarray(xdd) * s + 0.5 * dM * (np.asarray(xd) * s) ** 2 - Q


def force_analysis(sweep, *, dynamics: DynamicsModel | None = None, scalar: bool = False):
    """Force analysis along an existing kinematic sweep (its input speed and acceleration).

    Returns a :class:`~loopsolve.dynamics.forceresults.ForceSweep`.
    """
    from .dynamics_model import compile_dynamics
    from .forceresults import ForceSweep

    ck = sweep.compiled
    dm = dynamics if dynamics is not None else compile_dynamics(ck.mechanism, compiled=ck)
    ix = ck.input_idx[0]
    if len(sweep) == 0:
        data = inverse_dynamics(dm, np.zeros((0, len(ck.variables))), np.zeros(0), np.zeros(0))
    else:
        data = inverse_dynamics(dm, sweep.z, sweep.z1[:, ix], sweep.z2[:, ix], rates=(sweep.z1, sweep.z2))
        _checks(dm, data, sweep)
    return ForceSweep(sweep, data, scalar=scalar)


def _checks(dm: DynamicsModel, data: dict, sweep) -> None:
    """The power balance as a check, and the dead-centre warning (see :mod:`loopsolve.dynamics.declcheck`)."""
    from .declcheck import check_power_balance, warn_ill_conditioned
    from ..kinematics.solve import input_unit

    ck = sweep.compiled
    xs = np.asarray(sweep[ck.inputs[0]], dtype=float)
    _check_determined(dm, data, sweep, xs)
    check_power_balance(dm, data, xs, spurious=data["spurious"])
    warn_ill_conditioned(dm, data["kappa"], xs, input_unit(ck))


def forces(mech, at=None, stop=None, step=None, *, speed=None, accel=None, input=None, mode=None,
           through_limits: bool = False, progress=False, method: str = "auto"):
    """Driving torque, joint forces, shaking force and energies at one input or along a sweep.

    ``forces(mech, 90)`` analyses one input value; ``forces(mech, 0, 360, 5)`` a sweep (the
    arguments of :meth:`Mechanism.sweep`). ``speed``/``accel`` set the input's motion (default:
    the model's, else 1 rad/s and 0). Results are SI.

    Returns
    -------
    ForceSweep
        At one input its attributes are scalars (``float(f.drive)``) and ``(2,)`` vectors; along
        a sweep, arrays over the rows.

    Raises
    ------
    ModelError
        The model declares no bodies, or the pins, guides and driver do not match the bodies.

    Examples
    --------
    >>> mech = ls.load(ls.models_dir() / "thesis_crank_rocker_dynamics.toml")
    >>> f = ls.forces(mech, 90, speed="60rpm")
    >>> round(float(f.drive), 5), round(f["input_torque"], 5), f.units()["drive"]
    (0.03015, 0.03015, 'N*m')
    """
    from .dynamics_model import compile_dynamics

    ck = mech.compile(input)
    dm = compile_dynamics(mech, compiled=ck)
    if stop is None:
        from ..kinematics.results import Sweep

        state = mech.solve(at, speed=speed, accel=accel, input=input, mode=mode, compiled=ck)
        sweep = Sweep(ck, [state], (), state.mode)
    else:
        if at is None or step is None:
            from ..errors import ModelError

            raise ModelError("a force sweep needs start, stop and step: forces(mech, 0, 360, 5)")
        sweep = mech.sweep(at, stop, step, speed=speed, accel=accel, input=input, mode=mode,
                           through_limits=through_limits, progress=progress, method=method)
    return force_analysis(sweep, dynamics=dm, scalar=stop is None)
