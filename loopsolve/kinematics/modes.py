"""Assembly modes: every real solution of the loop equations at one input value.

An assembly mode is named by its *signature*: the signs of the determinants of the diagonal
blocks of Φ_q in solve order (for a four-bar the sign of ``sin(θ4 − θ3)``; ``"-"`` is the
"open" four-bar). The name does not depend on where a sweep started, and models may give
signatures aliases (``[modes] open = "-"``).

Each block of the solve order is solved for all of its real roots:

* a block of two unknowns that form a **dyad** in one vector loop is solved in closed form.
  The loop's complex residual ``F = Φx + i Φy`` is probed at a few values of the two
  unknowns to recognise one of the dyad forms (the generalisation of the notes' half-angle
  solution)::

      angle, angle      F = A e^{±i a} + B e^{±i b} + C      circle–circle intersection
      angle, length     F = A e^{±i a} + D b + C             circle–line intersection
      length, length    F = D1 a + D2 b + C                  linear (one root)
      polar vector      F = D b e^{±i a} + C                 b = ±|C/D| (two roots)

  with complex constants read off the probes. The recognised form is then checked at
  random points, so a loop that is not of that form (an angle entering twice, a length
  multiplying an angle...) is never mistaken for one. Probing the compiled residual
  rather than pattern-matching the declarations handles offsets, signs, degree-valued
  expressions and rigid link extensions uniformly.
* any other block is solved by damped Newton from the guesses and from seeded random
  starts, and the roots are deduplicated (angles compared modulo 2π).

Examples
--------
>>> modes = ls.fourbar(60, 25, 70, 45).modes(90)
>>> [(m.signature, m.aliases) for m in modes]
[('+', ('crossed',)), ('-', ('open',))]
>>> round(modes[1].positions["theta4"], 2)
80.72
"""

from __future__ import annotations

import cmath
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from ..errors import AssemblyError, ModeError, ModelError
from .newton import Newton, NewtonStatus, newton
from ..model.units import Kind

__all__ = ["Mode", "assembly_modes", "select_mode", "format_modes", "modes_to_json", "all_solutions",
           "branch_solutions"]

TWO_PI = 2.0 * math.pi


@dataclass(frozen=True, eq=False)
class Mode:
    """One real assembly mode at one input value.

    ``signature`` is the mode's name (``"+"``, ``"-+"``...), ``aliases`` the model's names for
    it (``("open",)``), ``positions`` every variable in display units (unknown angles wrapped to
    (−180°, 180°]) and ``z`` all variables in internal units (declaration order).

    Users receive modes from ``mech.modes(at)``; they need not construct one.

    Parameters
    ----------
    signature : str
        The mode's name: one sign per block of the solve order (``"+"``, ``"-+"``...).
    aliases : tuple of str
        The model's names for it (``("open",)``).
    positions : dict
        Every variable → its value in display units (unknown angles wrapped to (−180°, 180°]).
    z : numpy.ndarray
        All variables in internal units (declaration order).
    residual : float, optional
        The loop-closure residual of the solution (model length unit).
    units : dict, optional
        Every variable → its display unit.

    Attributes
    ----------
    signature, aliases, positions, z, residual, units
        As the parameters of the same names.

    Examples
    --------
    >>> m = ls.fourbar(60, 25, 70, 45).modes(90)[1]
    >>> m.signature, m.aliases, round(m.positions["theta3"], 2)
    ('-', ('open',), 16.1)
    """

    signature: str
    aliases: tuple[str, ...]
    positions: Mapping[str, float]
    z: np.ndarray = field(repr=False)
    residual: float = 0.0
    units: Mapping[str, str] = field(default_factory=dict, repr=False)

    def to_dict(self) -> dict:
        return {"signature": self.signature, "aliases": list(self.aliases),
                "positions": dict(self.positions), "units": dict(self.units), "residual": self.residual}


# ----------------------------------------------------------------------------- dyad forms


def _wrap_near(a: float, ref: float) -> float:
    """``a`` shifted by a multiple of 2π to lie within π of ``ref``."""
    return ref + (a - ref + math.pi) % TWO_PI - math.pi


class _Probe:
    """The complex residual of one loop block as a function of its two unknowns."""

    def __init__(self, ck, z, rows, cols):
        self.ck, self.z, self.rows = ck, np.array(z, dtype=float), rows
        self.iz = [int(ck.unknown_idx[c]) for c in cols]

    def __call__(self, a: float, b: float) -> complex:
        z = self.z.copy()
        z[self.iz[0]], z[self.iz[1]] = a, b
        f = self.ck.phi(z)
        return complex(f[self.rows[0]], f[self.rows[1]])


def _sense(probe_quarter: complex, amp: complex) -> int | None:
    """+1 if ``probe_quarter ≈ i·amp`` (angle enters as +a), −1 if ``≈ −i·amp``, else None."""
    tol = 1e-9 * (1.0 + abs(amp))
    if abs(probe_quarter - 1j * amp) <= tol:
        return 1
    if abs(probe_quarter + 1j * amp) <= tol:
        return -1
    return None


def _single_roots(ck, z, block) -> list[tuple[float]] | None:
    """Roots of a one-equation, one-unknown block in closed form, or None if not of a known form.

    An angle: ``f(a) = P cos a + Q sin a + R`` (one or more vectors turning with ``a``) gives
    ``a = φ ± acos(−R / hypot(P, Q))``; a length: ``f(b) = D b + R``.
    """
    e = block.eqs[0]
    iz = int(ck.unknown_idx[block.unknowns[0]])
    zz = np.array(z, dtype=float)
    s = float(ck.scale)
    tol = 1e-9 * (s + 1.0)

    def f(v):
        zz[iz] = v
        return float(ck.phi(zz)[e])

    rng = np.random.default_rng(11)
    if ck.kinds[iz] is Kind.ANGLE and not ck.periodic[iz]:
        # an angle tied by a gear pair, rolling contact or constraint: linear in it (one root) or unknown
        f0 = f(0.0)
        D = f(1.0) - f0
        tests = rng.uniform(-2 * math.pi, 2 * math.pi, 3)
        if D == 0 or any(abs(f(t) - (D * t + f0)) > tol for t in tests):
            return None
        return [(-f0 / D,)]
    if ck.kinds[iz] is Kind.ANGLE:
        f0, fp, fh = f(0.0), f(math.pi), f(math.pi / 2)
        R = (f0 + fp) / 2
        P, Q = f0 - R, fh - R
        tests = rng.uniform(-math.pi, math.pi, 3)
        if any(abs(f(t) - (P * math.cos(t) + Q * math.sin(t) + R)) > tol for t in tests):
            return None
        A = math.hypot(P, Q)
        if A <= tol:
            return None
        c = -R / A
        if abs(c) > 1.0:
            return []
        ph = math.atan2(Q, P)
        ac = math.acos(c)
        return [(ph + ac,), (ph - ac,)] if ac > 0 else [(ph,)]
    f0 = f(0.0)
    D = (f(s) - f0) / s
    tests = rng.uniform(-2, 2, 3) * s
    if D == 0 or any(abs(f(t) - (D * t + f0)) > tol for t in tests):
        return None
    return [(-f0 / D,)]


def _dyad_roots(ck, z, block) -> list[tuple[float, float]] | None:
    """All real roots of a two-unknown block in closed form, or None if it is not a dyad."""
    eqs, cols = block.eqs, block.unknowns
    if len(cols) == 1 and len(eqs) == 1:
        return _single_roots(ck, z, block)
    if len(cols) != 2 or len(eqs) != 2 or eqs[0] % 2 or eqs[1] != eqs[0] + 1:
        return None
    kinds = [ck.kinds[int(ck.unknown_idx[c])] for c in cols]
    F = _Probe(ck, z, eqs, cols)
    s = float(ck.scale)
    rng = np.random.default_rng(7)
    tests = [(float(rng.uniform(-math.pi, math.pi)) if k is Kind.ANGLE else float(rng.uniform(-2, 2) * s)
              for k in kinds) for _ in range(3)]
    tol = 1e-9 * (s + 1.0)

    def verify(model) -> bool:
        return all(abs(F(a, b) - model(a, b)) <= tol for a, b in tests)

    ang = [k is Kind.ANGLE for k in kinds]
    if all(ang):
        f00, fp0, f0p = F(0.0, 0.0), F(math.pi, 0.0), F(0.0, math.pi)
        A, B = (f00 - fp0) / 2, (f00 - f0p) / 2
        C = f00 - A - B
        sa = _sense(F(math.pi / 2, 0.0) - (f00 - A), A)
        sb = _sense(F(0.0, math.pi / 2) - (f00 - B), B)
        if sa is None or sb is None or abs(A) < tol or abs(B) < tol:
            return None
        if not verify(lambda a, b: A * cmath.exp(1j * sa * a) + B * cmath.exp(1j * sb * b) + C):
            return None
        # P = A e^{i sa a} on the circle |P| = |A|, Q = -C - P on the circle |Q| = |B|
        D = -C
        d, r1, r2 = abs(D), abs(A), abs(B)
        if d < tol:
            return None  # concentric circles: a continuum of roots, not a dyad
        m = (r1 * r1 - r2 * r2 + d * d) / (2 * d)
        h2 = r1 * r1 - m * m
        if h2 < 0:
            return []
        h = math.sqrt(h2)
        u = D / d
        out = []
        for sgn in ((1.0, -1.0) if h > 0 else (1.0,)):
            P = u * complex(m, sgn * h)
            a = sa * (cmath.phase(P) - cmath.phase(A))
            b = sb * (cmath.phase(D - P) - cmath.phase(B))
            out.append((a, b))
        return out
    if not any(ang):
        f00 = F(0.0, 0.0)
        D1, D2 = (F(s, 0.0) - f00) / s, (F(0.0, s) - f00) / s
        if not verify(lambda a, b: D1 * a + D2 * b + f00):
            return None
        det = D1.real * D2.imag - D1.imag * D2.real
        if abs(det) <= 1e-12 * (abs(D1) * abs(D2) + 1e-300):
            return None
        rx, ry = -f00.real, -f00.imag
        return [((rx * D2.imag - ry * D2.real) / det, (D1.real * ry - D1.imag * rx) / det)]
    # one angle, one length
    ia = 0 if ang[0] else 1

    def G(a, b):  # angle first
        return F(a, b) if ia == 0 else F(b, a)

    def order(a, b):
        return (a, b) if ia == 0 else (b, a)

    g00 = G(0.0, 0.0)
    # polar vector: F = D b e^{i sa a} + C (b = 0 removes the angle)
    if abs(G(1.0, 0.0) - g00) <= tol:
        C = g00
        D = (G(0.0, s) - C) / s
        sa = _sense((G(math.pi / 2, s) - C) / s, D)
        if sa is not None and abs(D) > 0 and verify(
                lambda a, b: (D * b * cmath.exp(1j * sa * a) + C) if ia == 0 else (D * a * cmath.exp(1j * sa * b) + C)):
            W = -C / D
            r = abs(W)
            if r <= tol:
                return None  # the vector collapses: angle undetermined
            th = cmath.phase(W)
            return [order(sa * th, r), order(sa * (th + math.pi), -r)]
        return None
    # circle-line: F = A e^{i sa a} + D b + C
    A = (g00 - G(math.pi, 0.0)) / 2
    D = (G(0.0, s) - g00) / s
    C = g00 - A
    sa = _sense(G(math.pi / 2, 0.0) - C, A)
    if sa is None or abs(A) < tol or abs(D) < 1e-12:
        return None
    model = lambda a, b: A * cmath.exp(1j * sa * a) + D * b + C  # noqa: E731
    if not verify(lambda a, b: model(a, b) if ia == 0 else model(b, a)):
        return None
    dh = D / abs(D)
    A2, C2 = A / dh, -C / dh  # rotate so the line of b is the real axis
    sv = C2.imag / abs(A2)
    if abs(sv) > 1.0:
        return []
    phi = cmath.phase(A2)
    psis = (math.asin(sv), math.pi - math.asin(sv)) if abs(sv) < 1.0 else (math.asin(sv),)
    out = []
    for psi in psis:
        a = sa * (psi - phi)
        b = (C2.real - abs(A2) * math.cos(psi)) / abs(D)
        out.append(order(a, b))
    return out


# ----------------------------------------------------------------------------- multi-start


def _newton_block(ck, z, block, start, settings=Newton(max_iter=80)):
    eqs = np.array(block.eqs)
    cols = np.array(block.unknowns)
    zi = ck.unknown_idx[cols]
    zz = np.array(z, dtype=float)

    def fun(u):
        zz[zi] = u
        return ck.phi(zz)[eqs]

    def jac(u):
        zz[zi] = u
        return ck.jac(zz)[np.ix_(eqs, cols)]

    return newton(fun, jac, np.asarray(start, dtype=float), scale=ck.scale, settings=settings)


def _multistart_roots(ck, z, block, n_starts: int = 48) -> list[np.ndarray]:
    """Every root of ``block`` (at the other values of ``z``) that Newton finds from the current values and
    ``n_starts`` random starts (angles anywhere on the circle, lengths within ±2 length scales).

    First all the starts run together (:func:`_any_root`, one vectorized Newton) until one converges:
    where none does, the block has no root here and the answer is ``[]`` at the cost of ~80 vectorized
    iterations instead of 49 × 80 scalar ones (an input with no assembly: seconds per error message on a
    cam follower's block, whose nearest-assemblable search looks at every sample on the way). Otherwise
    the starts run one by one with the scalar Newton, whose roots are the modes (as before the screen)."""
    cols = block.unknowns
    zi = ck.unknown_idx[np.array(cols)]
    angle = np.array([ck.kinds[int(i)] is Kind.ANGLE for i in zi])
    rng = np.random.default_rng(20240607)
    starts = [np.array(z, dtype=float)[zi]]
    for _ in range(n_starts):
        st = np.where(angle, rng.uniform(-math.pi, math.pi, len(cols)), rng.uniform(-2, 2, len(cols)) * ck.scale)
        starts.append(st)
    if not _any_root(ck, z, block, np.array(starts)):
        return []
    found: list[np.ndarray] = []
    w = np.where(angle, 1.0, 1.0 / ck.scale)
    turn = angle & ck.periodic[zi]  # an angle tied by a gear or rolling contact is not reduced by turns
    for st in starts:
        res = _newton_block(ck, z, block, st)
        if res.status is not NewtonStatus.CONVERGED or not np.all(np.isfinite(res.x)):
            continue
        x = np.where(turn, (res.x + math.pi) % TWO_PI - math.pi, res.x)
        if any(np.max(np.abs(np.where(turn, (x - f + math.pi) % TWO_PI - math.pi, x - f) * w)) < 1e-7 for f in found):
            continue
        found.append(x)
    return found


def _any_root(ck, z, block, starts: np.ndarray, max_iter: int = 80) -> bool:
    """Whether Newton on ``block`` converges from any row of ``starts``: all of them at once, with the
    vectorized Φ and Φ_q and the scalar Newton's rules (:func:`loopsolve.kinematics.newton.newton`: the
    step halved until the residual's norm falls, at most ``max_iter`` iterations; a start with no descent
    counts when within the stall tolerance, else it is dropped, as is a start that leaves the finite
    numbers). Stops at the first iteration where one converged."""
    eqs, cols = np.array(block.eqs), np.array(block.unknowns)
    zi = ck.unknown_idx[cols]
    k = starts.shape[1]
    Z = np.repeat(np.array(z, dtype=float)[:, None], starts.shape[0], axis=1)
    Z[zi, :] = starts.T
    tol, stall = Newton().atol * ck.scale, Newton().stall_tol * ck.scale

    def residual(Zc):
        with np.errstate(all="ignore"):
            F = np.asarray(ck.phi_v(Zc), dtype=float)
        return np.broadcast_to(F, (F.shape[0], Zc.shape[1]))[eqs, :]

    def norms(F):
        with np.errstate(all="ignore"):
            return np.sqrt(np.sum(F * F, axis=0))

    F = residual(Z)
    for _ in range(max_iter + 1):
        fmax = np.max(np.abs(F), axis=0)
        if np.any(fmax <= tol):
            return True
        keep = np.isfinite(fmax)
        Z, F = Z[:, keep], F[:, keep]
        if not keep.any():
            return False
        with np.errstate(all="ignore"):
            J = np.asarray(ck.jac_v(Z), dtype=float)[:, eqs][:, :, cols]  # (N, k, k)
            big = np.max(np.abs(J), axis=(1, 2))
            ok = np.isfinite(big) & (big > 0)
            big = np.where(ok, big, 1.0)
            Jn, Fn = J / big[:, None, None], F.T / big[:, None]
            # Levenberg–Marquardt with a tiny damping: the Newton step where Φ_q is regular, a bounded one
            # where it is (nearly) singular
            JtJ = np.einsum("nij,nik->njk", Jn, Jn)
            mu = 1e-10 * np.maximum(np.max(np.abs(JtJ), axis=(1, 2)), 1e-300)
            g = np.einsum("nij,ni->nj", Jn, Fn)
            dx = -np.linalg.solve(JtJ + mu[:, None, None] * np.eye(k), g[:, :, None])[:, :, 0].T  # (k, N)
        ok &= np.all(np.isfinite(dx), axis=0)
        f2 = norms(F)
        t = np.ones(Z.shape[1])
        accepted = np.zeros(Z.shape[1], dtype=bool)
        Znew, Fnew = Z.copy(), F.copy()
        for _half in range(34):  # down to t = 2**-33 ~ 1e-10, the scalar Newton's last try
            todo = np.flatnonzero(ok & ~accepted)
            if not todo.size:
                break
            Zt = Z[:, todo].copy()
            Zt[zi, :] += t[todo] * dx[:, todo]
            Ft = residual(Zt)
            n2 = norms(Ft)
            good = np.isfinite(n2) & (n2 <= np.sqrt(1 - 1e-4 * t[todo]) * f2[todo])
            Znew[:, todo[good]], Fnew[:, todo[good]] = Zt[:, good], Ft[:, good]
            accepted[todo[good]] = True
            t[todo[~good]] *= 0.5
        # no descent along the step: a root where the residual is already within the stall tolerance (a
        # double root at a limit position converges slowly), as the scalar Newton takes it
        if np.any(~accepted & (np.max(np.abs(F), axis=0) <= stall)):
            return True
        Z, F = Znew[:, accepted], Fnew[:, accepted]
    return False


def _linear_roots(ck, z, block) -> list[np.ndarray] | None:
    """The one root of a block linear in its unknowns (gear trains, rolling, linear constraints), else None.

    Φ(u) = A u + c is probed at the unit vectors and checked at random points, as the dyad forms are."""
    cols = block.unknowns
    zi = ck.unknown_idx[np.array(cols)]
    if any(ck.periodic[int(i)] for i in zi):
        return None  # an angle of the loops enters through its sine and cosine
    eqs = np.array(block.eqs)
    zz = np.array(z, dtype=float)
    s = float(ck.scale)

    def f(u):
        zz[zi] = u
        return ck.phi(zz)[eqs]

    unit = np.array([1.0 if ck.kinds[int(i)] is Kind.ANGLE else s for i in zi])
    c = f(np.zeros(len(zi)))
    A = np.column_stack([(f(np.eye(len(zi))[j] * unit[j]) - c) / unit[j] for j in range(len(zi))])
    rng = np.random.default_rng(3)
    tol = 1e-9 * (s + 1.0)
    for _ in range(3):
        u = rng.uniform(-2, 2, len(zi)) * unit
        if not np.all(np.abs(f(u) - (A @ u + c)) <= tol * (1.0 + np.max(np.abs(u / unit)))):
            return None
    try:
        if np.linalg.cond(A) > 1e12:
            return None
        return [np.linalg.solve(A, -c)]
    except np.linalg.LinAlgError:
        return None


def _block_roots(ck, z, block) -> list[np.ndarray]:
    roots = _dyad_roots(ck, z, block)
    if roots is not None:
        return [np.array(r, dtype=float) for r in roots]
    roots = _linear_roots(ck, z, block)
    if roots is not None:
        return roots
    return _multistart_roots(ck, z, block)


def block_feeds(ck) -> list[bool]:
    """For each block in solve order: whether a later block's equations involve its unknowns."""
    n = len(ck.unknowns)
    eq_block, col_block = {}, {}
    for bi, b in enumerate(ck.blocks):
        eq_block.update({e: bi for e in b.eqs})
        col_block.update({c: bi for c in b.unknowns})
    out = [False] * len(ck.blocks)
    for k in ck.module.JAC_NZ:
        i, j = divmod(int(k), n)
        bi, bj = eq_block.get(i), col_block.get(j)
        if bi is not None and bj is not None and bi != bj:
            out[bj] = True
    return out


def branch_solutions(ck, z0, *, feeds=None) -> list[np.ndarray]:
    """Solutions ``z`` enough to tell where the mechanism assembles: linear in the blocks.

    Like :func:`all_solutions`, but a block whose unknowns enter no later block and whose roots
    come in closed form (a dyad: two roots that meet at its limit) contributes one root only,
    so an N-loop fan gives a handful of solutions instead of 2^N. Empty when some block has no
    real root.

    Examples
    --------
    >>> ck = ls.fourbar(4, 3, 3.5, 5).compile()
    >>> len(branch_solutions(ck, np.array([0.5, 0.0, 1.0]))), len(branch_solutions(ck, np.array([0.0, 0.0, 1.0])))
    (1, 0)
    """
    feeds = block_feeds(ck) if feeds is None else feeds
    return _solutions(ck, z0, [not f for f in feeds])


def all_solutions(ck, z0) -> list[np.ndarray]:
    """Every real solution ``z`` (all variables) with the inputs of ``z0``, in solve order.

    Angles are placed within π of the values in ``z0`` (the guesses); each solution is
    polished by Newton so its residual is at machine precision.

    Examples
    --------
    >>> ck = ls.load(ls.models_dir() / "quick_return.toml").compile()
    >>> z0 = np.array([0.0, 1.1, 220.0])
    >>> sorted(round(float(z[2]), 3) for z in all_solutions(ck, z0))
    [-223.607, 223.607]
    """
    return _solutions(ck, z0, [False] * len(ck.blocks))


def _solutions(ck, z0, one_root: list[bool]) -> list[np.ndarray]:
    sols = [np.array(z0, dtype=float)]
    for b, one in zip(ck.blocks, one_root):
        zi = ck.unknown_idx[np.array(b.unknowns)]
        nxt = []
        for z in sols:
            roots = None
            if one:
                roots = _dyad_roots(ck, z, b)
                if roots is not None:
                    roots = [np.array(r, dtype=float) for r in roots[:1]]
            if roots is None:
                roots = _block_roots(ck, z, b)
            for r in roots:
                zz = z.copy()
                for k, i in enumerate(zi):
                    zz[i] = (_wrap_near(float(r[k]), float(z0[i])) if ck.kinds[int(i)] is Kind.ANGLE
                             and ck.periodic[int(i)] else float(r[k]))
                res = _newton_block(ck, zz, b, zz[zi], settings=Newton(max_iter=8))
                if res.status is NewtonStatus.CONVERGED and np.all(np.abs(res.x - zz[zi]) < 1e-6 * (1 + ck.scale)):
                    zz[zi] = res.x
                nxt.append(zz)
        sols = nxt
    good = []
    for z in sols:
        if float(np.max(np.abs(ck.phi(z)))) <= 1e-8 * ck.scale:
            good.append(z)
    return good


# ----------------------------------------------------------------------------- public API


def _input_internal(ck, at):
    from .solve import input_value

    name = ck.inputs[0]
    if at is None:
        g = ck.mechanism.variable(name).guess
        if g is None:
            raise ModelError(f"{ck.mechanism.source or ck.mechanism.name}: no input value: pass --at (or `at=`) "
                             f"or give {name} a guess in [variables]")
        return float(g)
    return input_value(ck, at, name)


def modes_at(ck, x: float) -> tuple[Mode, ...]:
    from .results import column_units, in_display_units
    from .solve import initial_z

    mech = ck.mechanism
    units = column_units(ck)
    z0 = initial_z(ck, warn=False)
    z0[ck.input_idx[0]] = x
    out = []
    inputs = set(ck.inputs)
    for z in all_solutions(ck, z0):
        sig = ck.signature(z)
        aliases = tuple(k for k, v in mech.mode_aliases.items() if v == sig)
        pos = {n: float(in_display_units(ck, n, 0, z[ck.index(n)], wrap=n not in inputs)) for n in ck.variables}
        out.append(Mode(sig, aliases, pos, z, float(np.max(np.abs(ck.phi(z)))),
                        {n: units[n] for n in ck.variables}))
    out.sort(key=lambda m: (m.signature, tuple(round(v, 9) for v in m.positions.values())))
    return tuple(out)


def assembly_modes(mech, at=None, *, input: str | None = None, compiled=None) -> tuple[Mode, ...]:
    """Every real assembly mode of ``mech`` at input value ``at`` (display units or with a unit).

    Parameters
    ----------
    mech : Mechanism
    at : float or str, optional
        Input value; default the input's declared guess.
    input : str, optional
        Drive this variable instead of the declared input.
    compiled : CompiledKinematics, optional
        Reuse an already compiled model.

    Returns
    -------
    tuple of Mode
        Sorted by signature; empty when the mechanism cannot be assembled at ``at``.

    Examples
    --------
    >>> mech = ls.load(ls.models_dir() / "example1_slider_crank.toml")
    >>> [(m.signature, round(m.positions["r1"], 4)) for m in assembly_modes(mech, 45)]
    [('+-', 10.7119), ('--', -3.6408)]
    """
    ck = compiled if compiled is not None else mech.compile(input)
    return modes_at(ck, _input_internal(ck, at))


def resolve_signature(mech, mode: str) -> str | None:
    if not isinstance(mode, str):
        return None
    sig = mech.mode_aliases.get(mode, mode)
    return sig


def mode_names(mech, modes) -> str:
    parts = []
    for m in modes:
        parts.append(m.signature + (f" ({', '.join(m.aliases)})" if m.aliases else ""))
    return ", ".join(parts) if parts else "none"


def select_mode(mech, x_internal: float, mode: str, *, compiled=None) -> np.ndarray:
    """Starting point ``z`` (all variables, internal units) in assembly mode ``mode`` at input ``x``.

    ``mode`` is a signature (``"+"``, ``"-+"``...) or an alias of the model (``"open"``).
    When several distinct solutions share the signature (possible for blocks larger than
    a dyad), the one nearest the declared guesses is taken.

    Raises
    ------
    ModelError
        Unknown alias or malformed signature.
    ModeError
        No mode with that signature at ``x`` (the message lists the modes there).
    AssemblyError
        No real assembly mode at all at ``x`` (names the nearest assemblable inputs).

    Examples
    --------
    >>> mech = ls.fourbar(60, 25, 70, 45)
    >>> ck = mech.compile()
    >>> z = select_mode(mech, math.radians(90), "crossed", compiled=ck)
    >>> ck.signature(z), round(math.degrees(z[2]) % 360, 2)
    ('+', 234.04)
    """
    ck = compiled if compiled is not None else mech.compile()
    from .solve import display_value

    name = ck.inputs[0]
    disp = display_value(ck, x_internal, name)
    nb = len(ck.blocks)
    sig = resolve_signature(mech, mode)
    aliases = ", ".join(f"{k} = {v}" for k, v in mech.mode_aliases.items())
    if sig is None or len(sig) != nb or set(sig) - {"+", "-"}:
        raise ModelError(
            f"{mech.source or mech.name}: unknown assembly mode {mode!r}: give a signature of {nb} sign(s) "
            f"(+ or -, one per block of the solve order)" + (f" or one of the aliases {aliases}" if aliases else "")
            + f"; the modes at {name} = {disp:g} are: {mode_names(mech, modes_at(ck, x_internal))}")
    modes = modes_at(ck, x_internal)
    if not modes:
        from .reach import nearest_assemblable

        near = nearest_assemblable(ck, x_internal)
        raise AssemblyError(
            f"{mech.source or mech.name}: cannot be assembled at {name} = {disp:g}: no real assembly mode there"
            + nearest_text(ck, near),
            input_value=disp, nearest=near)
    match = [m for m in modes if m.signature == sig]
    if not match:
        raise ModeError(f"{mech.source or mech.name}: assembly mode {mode!r} ({sig}) does not exist at {name} = "
                        f"{disp:g}; the modes there are: {mode_names(mech, modes)}",
                        mode=sig, modes=tuple(m.signature for m in modes), input_value=disp)
    return nearest_solution(ck, match)


def nearest_solution(ck, modes, *, guess: dict | None = None) -> np.ndarray:
    """``z`` of the mode nearest the guesses (angles compared modulo a turn, lengths scaled).

    Several distinct solutions may share a signature when a block is larger than a dyad; the
    guesses then choose among them.
    """
    from .solve import initial_z

    if len(modes) == 1:
        return np.array(modes[0].z, dtype=float)
    g = initial_z(ck, guess=guess, warn=False)
    w = np.array([1.0 if k is Kind.ANGLE else 1.0 / ck.scale for k in ck.kinds])
    ang = np.array([k is Kind.ANGLE for k in ck.kinds])

    def dist(m):
        d = m.z - g
        d = np.where(ang, (d + math.pi) % TWO_PI - math.pi, d)
        return float(np.linalg.norm(d * w))

    return np.array(min(modes, key=dist).z, dtype=float)


def nearest_text(ck, near) -> str:
    from .solve import input_unit

    if not near:
        return "; no assemblable input was found nearby: check the link lengths"
    unit = input_unit(ck)
    vals = " or ".join(f"{v if abs(v) >= 1e-9 else 0.0:.10g}{unit}" for v in near)  # no -4e-15 for 0
    return f"; the nearest assemblable input values are {ck.inputs[0]} = {vals}"


def format_modes(modes) -> str:
    """A text table of :func:`assembly_modes` (one line per mode).

    Examples
    --------
    >>> print(format_modes(ls.fourbar(60, 25, 70, 45).modes(90)), end="")
    mode         theta2 [deg]  theta3 [deg]  theta4 [deg]
    + (crossed)            90      -61.3392      -125.962
    - (open)               90       16.0994       80.7225
    """
    if not modes:
        return "no real assembly mode at this input: the mechanism cannot be assembled there\n"
    names = list(modes[0].positions)
    heads = [f"{n} [{modes[0].units[n]}]" if n in modes[0].units else n for n in names]
    labels = [m.signature + (f" ({', '.join(m.aliases)})" if m.aliases else "") for m in modes]
    cells = [[f"{m.positions[n]:.6g}" for n in names] for m in modes]
    w0 = max(len("mode"), *(len(s) for s in labels))
    widths = [max(len(h), *(len(c[i]) for c in cells)) for i, h in enumerate(heads)]
    lines = ["  ".join(["mode".ljust(w0)] + [h.rjust(w) for h, w in zip(heads, widths)])]
    for lab, c in zip(labels, cells):
        lines.append("  ".join([lab.ljust(w0)] + [v.rjust(w) for v, w in zip(c, widths)]))
    return "\n".join(lines) + "\n"


def modes_to_json(modes) -> str:
    """JSON list of the modes: ``[{"signature", "aliases", "positions", "residual"}, ...]``.

    Examples
    --------
    >>> import json
    >>> [d["signature"] for d in json.loads(modes_to_json(ls.fourbar(60, 25, 70, 45).modes(90)))]
    ['+', '-']
    """
    return json.dumps([m.to_dict() for m in modes], indent=1, allow_nan=False)
