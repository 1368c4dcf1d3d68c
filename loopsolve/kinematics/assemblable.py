"""Where many designs can be assembled, all at once: the vectorized assembly test and nearest inputs.

The lockstep study (:mod:`loopsolve.design.lockstep`) used to hand every design it could not start to
the single-design sweep, which proves that the design cannot be assembled at the start and
names the nearest assemblable inputs (:func:`loopsolve.sweep.nearest_assemblable`) — about as
much work as fifty ordinary designs. This module decides both for a whole chunk at once, with
the same closed forms and the same samples as the single-design path:

* **Assembly test.** When every solve-order block is a dyad of two angles or one angle or
  length, :func:`loopsolve.kinematics.modes._dyad_roots` identifies each block's complex residual as
  ``A e^{±ia} + B e^{±ib} + C`` (or ``P cos a + Q sin a + R``, or linear) from a few evaluations
  of Φ and decides from the circle intersection whether a real root exists; a block whose
  unknowns enter a later block contributes each of its roots, as in
  :func:`loopsolve.kinematics.modes.branch_solutions`. Here the same probes are evaluated with the
  vectorized kernels on every design (and every sample input) at once, and the same test
  decides. A design whose block is not recognized (the checks at the three random points of
  the scalar routine fail) is *undecided* and goes to the single-design sweep as before.
* **Nearest assemblable inputs** (angle inputs): the single-design path samples the input at
  144 values and, from the first assemblable sample on each side of ``x``, traces towards ``x``
  to the first limit position. Here the assembly test runs on the same 144 samples for all
  designs at once, and the limit between the nearest assemblable sample and its neighbour is
  located by bisection on the assembly test, all designs at once, to round-off. (The scalar
  path locates the same fold to ~1e-12; the study's ``nearest`` is printed to 10 digits.)
"""

from __future__ import annotations

import math

import numpy as np

from ..model.units import Kind

__all__ = ["AssemblyTest"]

_TWO_PI = 2 * math.pi


class AssemblyTest:
    """The vectorized assembly test of one compiled model with per-column parameters.

    ``ops`` is a :class:`loopsolve.design.designops.DesignOps` (not shared-input), ``P`` ``(npar, D)`` and
    ``scale`` ``(D,)`` the designs' parameters and length scales. ``usable`` is False when the
    model's blocks are not of the recognized form (then nothing is decided here).

    Examples
    --------
    >>> from loopsolve.design.designops import DesignOps, param_matrix, design_scale
    >>> ck = ls.fourbar(60, 25, 70, 45).compile()
    >>> P = param_matrix(ck, ("r2",), np.array([[25.0], [50.0]]))
    >>> t = AssemblyTest(ck, DesignOps(ck), P, design_scale(ck, P))
    >>> ok, decided = t.at(np.array([0.0, 0.0]))
    >>> ok.tolist(), decided.tolist()
    ([True, False], [True, True])
    """

    def __init__(self, ck, ops, P, scale):
        from .modes import block_feeds
        from .solve import initial_z

        self.ck, self.ops, self.P, self.scale = ck, ops, P, np.asarray(scale, dtype=float)
        self.z0 = initial_z(ck, warn=False)
        self.ix = int(ck.input_idx[0])
        blocks = list(ck.blocks)
        self.usable = bool(blocks)
        self.feeds = block_feeds(ck)
        self.blocks = []
        for b in blocks:
            eqs, cols = tuple(b.eqs), tuple(b.unknowns)
            iz = [int(ck.unknown_idx[c]) for c in cols]
            kinds = [ck.kinds[i] for i in iz]
            if len(cols) == 2 and len(eqs) == 2 and eqs[0] % 2 == 0 and eqs[1] == eqs[0] + 1 \
                    and all(k is Kind.ANGLE for k in kinds):
                self.blocks.append(("dyad", eqs, iz))
            elif len(cols) == 1 and len(eqs) == 1:
                self.blocks.append(("angle" if kinds[0] is Kind.ANGLE else "length", eqs, iz))
            else:
                self.usable = False

    def _phi(self, base, sets, cols):
        """Φ at the positions ``base`` (nv, N) with ``z[i] = v`` for ``(i, v)`` in ``sets``; designs ``cols``."""
        Z = base.copy()
        for i, v in sets:
            Z[i] = v
        return self.ops.phi(Z, self.P[:, cols])

    def at(self, x, cols=None, *, margin: float = 0.0):
        """``(assemblable, decided)`` at inputs ``x`` (N,) of designs ``cols`` (N,; default all in order).

        The blocks in solve order, as :func:`loopsolve.kinematics.modes.branch_solutions` takes them: a block
        whose unknowns enter a later block splits the test into one branch per root (a dyad's two,
        an angle's two, a length's one); assemblable where some branch has a root in every block.
        With ``margin`` > 0, a block that misses a root by less than that (relative: the dyad's
        squared half-chord over its larger radius squared, an angle's |cos| over 1) decides
        nothing: there the single sweep tells "cannot be assembled" from "starts at a singular
        position" with its own tolerance (about 1e-5 in angle)."""
        x = np.asarray(x, dtype=float)
        cols = np.arange(len(x)) if cols is None else np.asarray(cols)
        decided = np.full(len(x), self.usable)
        if not self.usable:
            return np.ones(len(x), dtype=bool), decided
        s = self.scale[cols]
        tol = 1e-9 * (s + 1.0)
        base = np.repeat(self.z0[:, None], len(x), axis=1)
        base[self.ix] = x
        branches = [(base, np.ones(len(x), dtype=bool))]
        with np.errstate(all="ignore"):
            for (kind, eqs, iz), feeds in zip(self.blocks, self.feeds):
                new = []
                for Zb, alive in branches:
                    if kind == "dyad":
                        r, d, roots = self._dyad(Zb, cols, eqs, iz, tol, margin)
                    elif kind == "angle":
                        r, d, roots = self._angle(Zb, cols, eqs[0], iz[0], tol, margin)
                    else:
                        r, d, roots = self._length(Zb, cols, eqs[0], iz[0], s, tol)
                    decided &= d | ~alive  # a branch already without a root decides nothing more
                    alive = alive & r
                    if not feeds:
                        new.append((Zb, alive))
                        continue
                    for root in roots:
                        Zn = Zb.copy()
                        for i, v in zip(iz, root):
                            Zn[i] = np.where(alive, v, Zn[i])
                        new.append((Zn, alive))
                branches = new
        ok = np.zeros(len(x), dtype=bool)
        for _, alive in branches:
            ok |= alive
        return ok, decided

    def _dyad(self, base, cols, eqs, iz, tol, margin=0.0):
        """The all-angle branch of :func:`loopsolve.kinematics.modes._dyad_roots`, on every column."""
        e0, e1 = eqs
        ia, ib = iz

        def F(a, b):
            f = self._phi(base, ((ia, a), (ib, b)), cols)
            return f[e0] + 1j * f[e1]

        f00, fp0, f0p = F(0.0, 0.0), F(math.pi, 0.0), F(0.0, math.pi)
        A, B = (f00 - fp0) / 2, (f00 - f0p) / 2
        C = f00 - A - B
        sa = _sense(F(math.pi / 2, 0.0) - (f00 - A), A)
        sb = _sense(F(0.0, math.pi / 2) - (f00 - B), B)
        decided = (sa != 0) & (sb != 0) & (np.abs(A) >= tol) & (np.abs(B) >= tol)
        rng = np.random.default_rng(7)  # the scalar routine's three check points
        for _ in range(3):
            a, b = float(rng.uniform(-math.pi, math.pi)), float(rng.uniform(-math.pi, math.pi))
            model = A * np.exp(1j * sa * a) + B * np.exp(1j * sb * b) + C
            decided &= np.abs(F(a, b) - model) <= tol
        D = -C
        d, r1, r2 = np.abs(D), np.abs(A), np.abs(B)
        decided &= d >= tol  # concentric circles: not a dyad
        m = (r1 * r1 - r2 * r2 + d * d) / (2 * d)
        h2 = r1 * r1 - m * m
        self._last = (A, B, D, sa, sb, m, h2)
        u = D / d
        h = np.sqrt(np.maximum(h2, 0.0))
        roots = []
        for sgn in (1.0, -1.0):
            Pp = u * (m + 1j * sgn * h)
            roots.append((sa * (np.angle(Pp) - np.angle(A)), sb * (np.angle(D - Pp) - np.angle(B))))
        self._roots = roots
        if margin:
            decided &= ~((h2 < 0) & (-h2 <= margin * np.maximum(r1, r2) ** 2))
        return decided & ~(h2 < 0), decided & np.isfinite(h2), roots

    def _angle(self, base, cols, e, i, tol, margin=0.0):
        """The angle branch of :func:`loopsolve.kinematics.modes._single_roots`: ``P cos a + Q sin a + R``."""

        def f(v):
            return self._phi(base, ((i, v),), cols)[e]

        f0, fp, fh = f(0.0), f(math.pi), f(math.pi / 2)
        R = (f0 + fp) / 2
        Pc, Q = f0 - R, fh - R
        decided = np.ones(base.shape[1], dtype=bool)
        for t in np.random.default_rng(11).uniform(-math.pi, math.pi, 3):
            decided &= np.abs(f(float(t)) - (Pc * math.cos(t) + Q * math.sin(t) + R)) <= tol
        A = np.hypot(Pc, Q)
        decided &= A > tol
        c = -R / A
        ph, ac = np.arctan2(Q, Pc), np.arccos(np.clip(c, -1.0, 1.0))
        if margin:
            decided &= ~((np.abs(c) > 1.0) & (np.abs(c) - 1.0 <= margin))
        return decided & ~(np.abs(c) > 1.0), decided & np.isfinite(c), [(ph + ac,), (ph - ac,)]

    def _length(self, base, cols, e, i, s, tol):
        """The length branch of :func:`loopsolve.kinematics.modes._single_roots`: linear, one root unless degenerate."""
        f0 = self._phi(base, ((i, 0.0),), cols)[e]
        D = (self._phi(base, ((i, s),), cols)[e] - f0) / s
        decided = D != 0
        for t in np.random.default_rng(11).uniform(-2, 2, 3):
            decided &= np.abs(self._phi(base, ((i, t * s),), cols)[e] - (D * t * s + f0)) <= tol
        return decided, decided, [(-f0 / D,)]

    def nearest(self, x0: float, cols) -> list[tuple[float, ...] | None]:
        """Nearest assemblable inputs (internal units) below and above ``x0`` for the designs ``cols``,
        none of which is assemblable at ``x0``; None for a design this cannot decide (a length input,
        an undecided sample). The logic of :func:`loopsolve.sweep._nearest_local` on its samples."""
        from .reach import input_samples
        from .scalar_solver import Kernel

        cols = np.asarray(cols)
        if not self.usable or self.ck.kinds[self.ix] is not Kind.ANGLE or not len(cols):
            return [None] * len(cols)
        xs = input_samples(self.ck, Kernel(self.ck))
        m = len(xs)
        step = xs[1] - xs[0]
        n = len(cols)
        ok, dec = self.at(np.tile(np.asarray(xs), n), np.repeat(cols, m))
        ok, dec = ok.reshape(n, m), dec.reshape(n, m)
        k0 = int(math.floor((x0 - xs[0]) / step))
        brackets = []  # (design row, side, good end, bad end)
        out: list = [None] * n
        for r in range(n):
            if not dec[r].all():
                continue
            if not ok[r].any():
                out[r] = ()
                continue
            for side in (-1, 1):
                for dd in range(m):
                    k = k0 - dd if side < 0 else k0 + dd
                    i, sh = k % m, _TWO_PI * (k // m)
                    j = i if side < 0 else (i + 1) % m  # the sample on the far end of interval k
                    if ok[r, j]:
                        lo, hi = xs[i] + sh, xs[i] + step + sh
                        if side < 0:
                            brackets.append((r, side, lo, x0 if dd == 0 else hi))
                        else:
                            brackets.append((r, side, hi, x0 if dd == 0 else lo))
                        break
            out[r] = []
        if brackets:
            rows = np.array([b[0] for b in brackets])
            good = np.array([b[2] for b in brackets])
            bad = np.array([b[3] for b in brackets])
            edge = self._bisect(good, bad, cols[rows])
            for (r, side, _, _), v in zip(brackets, edge):
                out[r].append((side, float(v)))
        res = []
        for o in out:
            if o is None or o == ():
                res.append(o)
            else:
                res.append(tuple(v for _, v in sorted(o)))
        return res

    def _bisect(self, good, bad, cols):
        """The assemblability boundary between ``good`` (assemblable) and ``bad`` inputs, per column."""
        good, bad = good.copy(), bad.copy()
        for _ in range(80):
            mid = 0.5 * (good + bad)
            if np.all((mid == good) | (mid == bad)):
                break
            ok, _ = self.at(mid, cols)
            good = np.where(ok, mid, good)
            bad = np.where(ok, bad, mid)
        return 0.5 * (good + bad)


def _sense(q, amp):
    """Vectorized :func:`loopsolve.kinematics.modes._sense`: +1, −1, or 0 where neither."""
    tol = 1e-9 * (1.0 + np.abs(amp))
    return np.where(np.abs(q - 1j * amp) <= tol, 1, np.where(np.abs(q + 1j * amp) <= tol, -1, 0))
