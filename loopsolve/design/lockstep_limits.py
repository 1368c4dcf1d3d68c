"""Limit positions of many designs inside a lockstep chunk, for every model the assembly test recognizes.

A design leaves the lockstep path (:mod:`loopsolve.design.lockstep`) when its slope |dq/dx| grows or
its corrector struggles, usually because a limit position (a toggle, a fold) is near. Its single
sweep stops there with a ``limit`` event, and costs as much as fifty ordinary designs. Here the
limit is located for all such designs of a chunk at once, for any model whose solve-order blocks
:class:`loopsolve.kinematics.assemblable.AssemblyTest` recognizes (dyads of two angles, single angles or
lengths: four-bars, slider-cranks, six-bars, fans of dyads):

* **The design's root in its mode.** A design keeps the signature of its block determinants
  (its assembly mode, ``sig0``) along a regular path. Each block has one root per sign of its
  determinant (a dyad's two circle intersections, an angle's two solutions of
  ``P cos a + Q sin a + R = 0``, a length's one), so the path is, block after block in solve
  order, the root whose determinant has the design's sign, with the blocks before it at theirs
  (:func:`_in_mode`). The design can go on while every block has real roots; the limit is the
  first input where one has none.
* **Bracket.** The first grid value after the design's last lockstep row where it has no root in
  its mode (or the end of the range) brackets the limit. The stretch from the last row is cut
  into pieces of 5°/64 (an angle input; else 64 per grid step), and the first piece without a
  root brackets it more tightly. A dip of a block's discriminant on the way (a local minimum
  below 1 % of its largest value there) may hide a gap narrower than a piece, or be a change
  point: such a design goes to the single sweep, whose tracer tells them apart.
* **Location.** Bisection on the same test, all designs at once, to round-off (the tracer
  locates the fold to about 1e-9 in the input; the test that compares both allows that).
* **Necks.** Where the design has a root in its mode again within 1e-3 rad past the located
  limit (probes at 1e-3 · 2^−k), the gap is a near change point, which the tracer passes with a
  ``singular`` event when it is narrow enough: such a design goes to the single sweep.
* **Rows.** The rows between the last lockstep row and the limit are the designs' roots in their
  mode, polished by Newton to round-off, angles continued from the row before; rates and points
  from them, as the lockstep rows.

* **No limit.** A design with a root in its mode at every piece to the end of the range (the
  lockstep path dropped it for a steep slope, not for a limit) has its rows filled the same way
  to the end, status ``ok``, when no discriminant dips on the way.
* **Designs the lockstep path did not bring to the start** (a limit between the guesses' input
  and the start, Newton from the guesses needing damping) start here as the single sweep starts
  (:func:`loopsolve.solve.start_position`): at the start, the root with the signature the
  guesses name (angles in (−π, π]), when it is regular (:func:`_start_here`).

Designs dropped near a change point or for a signature change (``irregular``), designs whose
root in the mode at the last row is not the tracked one, and designs any step cannot decide are
left for the single sweep.
"""

from __future__ import annotations

import math

import numpy as np

from ..model.units import Kind

__all__ = ["locate_limits"]

#: a limit with a root in the mode again within this (radians, or lengths over the scale) is a neck
_NECK = 1e-3
_PROBES = 31  # probes at _NECK · 2^−k past the limit


def _in_mode(test, x, cols, sig):
    """The designs ``cols``'s roots in their modes at inputs ``x`` (N,), block after block.

    ``sig`` ``(nb, N)``: the signs of the block determinants to keep. Returns ``(ok, decided, Z,
    margins)``: whether every block has a root, whether the test decided that, the positions
    ``(nv, N)`` (meaningful where ``ok``), and per block its discriminant (a dyad's h², an angle's
    sin² of half the angle between its roots; None for a length, which has no limit).
    """
    ops = test.ops
    x = np.asarray(x, dtype=float)
    cols = np.asarray(cols)
    N = len(x)
    s = test.scale[cols]
    tol = 1e-9 * (s + 1.0)
    Pc = test.P[:, cols]
    Z = np.repeat(test.z0[:, None], N, axis=1)
    Z[test.ix] = x
    ok = np.ones(N, dtype=bool)
    dec = np.ones(N, dtype=bool)
    margins = []
    with np.errstate(all="ignore"):
        for b, (kind, eqs, iz) in enumerate(test.blocks):
            if kind == "dyad":
                r, d, roots = test._dyad(Z, cols, eqs, iz, tol)
                margin = test._last[-1]
            elif kind == "angle":
                r, d, roots = test._angle(Z, cols, eqs[0], iz[0], tol)
                margin = np.sin(0.5 * (roots[0][0] - roots[1][0])) ** 2
            else:
                r, d, roots = test._length(Z, cols, eqs[0], iz[0], s, tol)
                margin = None
            dec &= d | ~ok  # a design already without a root decides nothing more
            ok &= r
            Zc = Z.copy()
            for i, v in zip(iz, roots[0]):
                Zc[i] = v
            sg, _ = ops.signs_and_regularity(ops.jac(Zc, Pc), s)
            pick = sg[b] == sig[b]  # the first root has the design's sign, else the other
            if len(roots) == 1:  # a length's one root: its determinant must keep the design's sign
                dec &= pick | ~ok
            for k, i in enumerate(iz):
                Z[i] = np.where(pick, roots[0][k], roots[-1][k])
            margins.append(margin)
    return ok, dec, Z, margins


def _in_mode_pieces(test, x, cols, sig, size=50_000):
    """``(ok, decided, margins)`` of :func:`_in_mode` at many inputs, ``size`` at a time (bounded memory)."""
    parts = [_in_mode(test, x[a:a + size], cols[a:a + size], sig[:, a:a + size]) for a in range(0, len(x), size)]
    ok = np.concatenate([p[0] for p in parts])
    dec = np.concatenate([p[1] for p in parts])
    margins = [None if parts[0][3][b] is None else np.concatenate([p[3][b] for p in parts])
               for b in range(len(parts[0][3]))]
    return ok, dec, margins


def _bisect(test, good, bad, cols, sig):
    """The boundary between ``good`` (a root in the mode) and ``bad`` inputs, per design, to round-off."""
    good, bad = good.copy(), bad.copy()
    for _ in range(80):
        mid = 0.5 * (good + bad)
        if np.all((mid == good) | (mid == bad)):
            break
        ok, _, _, _ = _in_mode(test, mid, cols, sig)
        good = np.where(ok, mid, good)
        bad = np.where(ok, bad, mid)
    return 0.5 * (good + bad)


def _dips(margins, f):
    """Whether a block's discriminant has a local minimum below 1 % of its largest value in ``[:f]``."""
    for h in margins:
        if h is None or f <= 2:
            continue
        h = h[:f]
        dip = (h[1:-1] <= h[:-2]) & (h[1:-1] <= h[2:]) & (h[1:-1] < 1e-2 * np.max(h))
        if dip.any():
            return True
    return False


def _first_without(test, xe, c, lc, sig0, ch, angles):
    """Per design ``c[r]``, the first index into ``xe`` after its last row ``lc[r]`` without a root in its
    mode; ``len(xe)`` where every value to the end has one; −1 where its root at the last row is not
    the tracked one or a value is undecided. In windows of 4, 16, 64, ... values, all designs at once."""
    n, L = len(c), len(xe)
    kb = np.full(n, -1)
    lo = np.array(lc, dtype=int)
    pending = np.arange(n)
    is_len = np.array([k is Kind.LENGTH for k in test.ck.kinds])
    w = 4
    first = True
    while len(pending):
        ranges = [np.arange(lo[r], min(lo[r] + w, L)) for r in pending]
        kk = np.concatenate(ranges)
        dj = np.repeat(c[pending], [len(v) for v in ranges])
        ok, dec, Z, _ = _in_mode(test, xe[kk], dj, sig0[:, dj])
        o, nxt = 0, []
        for r, rg in zip(pending, ranges):
            m = len(rg)
            okj, decj = ok[o:o + m], dec[o:o + m]
            if first:  # the tracked row: the root in the mode must be it (angles modulo 2π)
                j = c[r]
                dz = Z[:, o] - ch.Z[0][:, int(lc[r]), j]
                if angles:
                    dz[angles] = (dz[angles] + math.pi) % (2 * math.pi) - math.pi
                if not okj[0] or not np.all(np.abs(dz) <= 1e-7 * np.where(is_len, test.scale[j], 1.0)):
                    o += m
                    continue
            o += m
            f = int(np.argmax(~okj)) if not okj.all() else m
            if not decj[:f + 1].all():
                continue
            if f < m:
                kb[r] = rg[f]
            elif rg[-1] < L - 1:
                nxt.append(r)
                lo[r] = rg[-1] + 1
            else:
                kb[r] = L  # a root in its mode at every value to the end
        pending = np.array(nxt, dtype=int)
        first = False
        w *= 4
    return kb


def _start_here(test, ck, P, x0, cols, last, sig0, ch, rates, derivatives):
    """Start the designs ``cols`` that the lockstep path did not bring to the start (a limit between the
    guesses' input and the start, Newton from the guesses needing damping): row 0 is the root in the
    mode the guesses name, as :func:`loopsolve.solve.start_position` takes it (the unique root with that
    signature, angles in (−π, π]). Sets ``last`` to 0 and ``sig0`` to that mode where it is regular;
    returns those designs."""
    from .designops import REGULAR_MIN, fill_rows
    from ..kinematics.solve import initial_z

    mech = ck.mechanism
    none = np.zeros(0, dtype=int)
    if not len(cols) or not all(mech.variable(n).guess is not None for n in ck.unknowns):
        return none
    ops = test.ops
    z = initial_z(ck, warn=False)
    x_guess = mech.variable(ck.inputs[0]).guess
    z[test.ix] = x0 if x_guess is None else x_guess
    Zg = np.repeat(z[:, None], len(cols), axis=1)
    with np.errstate(all="ignore"):
        req = ops.guess_signs(ops.jac(Zg, P[:, cols]))  # the mode the guesses name, per design
        ok, dec, Z, _ = _in_mode(test, np.full(len(cols), x0), cols, req)
        Pc = P[:, cols]
        for _ in range(3):  # polish to round-off
            Z[ops.iu] = Z[ops.iu] + ops.solve(ops.jac(Z, Pc), -ops.phi(Z, Pc))
        sg, reg = ops.signs_and_regularity(ops.jac(Z, Pc), test.scale[cols])
        res = np.max(np.abs(ops.phi(Z, Pc)), axis=0)
    ang = [int(i) for i in ops.iu if ck.kinds[int(i)] is Kind.ANGLE]
    Z[ang] = -((-Z[ang] + math.pi) % (2 * math.pi) - math.pi)  # into (−π, π]
    edge = np.any(np.abs(np.abs(Z[ang]) - math.pi) < 1e-6, axis=0) if ang else np.zeros(len(cols), dtype=bool)
    good = (ok & dec & np.all(req != 0, axis=0) & np.all(sg == req, axis=0) & (reg >= REGULAR_MIN) & ~edge
            & (res <= 1e-12 * test.scale[cols]))
    if not good.any():
        return none
    cg = np.asarray(cols)[good]
    fill_rows(ck, ops, Z[:, good], P[:, cg], ch, np.zeros(len(cg), dtype=int), cg, rates, derivatives)
    last[cg] = 0
    sig0[:, cg] = req[:, good]
    return cg


def locate_limits(ck, P, xs, x_end, cand, last, irregular, sig0, ch, rates, derivatives):
    """Designs ``cand`` that left the lockstep path (their last row ``last``, their mode ``sig0``
    ``(nb, D)``): locate the limit each approaches and fill its rows up to it, all designs at once.

    Sets status ``limit``, stop, event, warning, mode and rows in ``ch`` as the single sweep gives
    them (a design without a limit in the range: its rows and mode, status ``ok``); returns
    ``(designs left for the single sweep, designs done here)``.
    """
    from ..kinematics.assemblable import AssemblyTest
    from .designops import DesignOps, design_scale, display_value_of, fill_rows
    from ..kinematics.solve import input_unit

    none = np.zeros(0, dtype=int)
    K = len(xs)
    if K < 2 or not len(cand):
        return cand, none
    ops = DesignOps(ck)
    test = AssemblyTest(ck, ops, P, design_scale(ck, P))
    if not test.usable:
        return cand, none
    xs = np.asarray(xs, dtype=float)
    last, sig0 = last.copy(), sig0.copy()
    here = _start_here(test, ck, P, xs[0], cand[last[cand] < 0], last, sig0, ch, rates, derivatives)
    c = cand[(last[cand] >= 0) & ~irregular[cand] | np.isin(cand, here)]  # the path before the start is not theirs
    if not len(c):
        return cand, none
    xe = np.append(xs, x_end)  # the grid, then the end of the range
    dirn = 1.0 if xs[-1] > xs[0] else -1.0
    if dirn * (x_end - xs[-1]) <= 0:
        xe = xe[:-1]
    angles = [i for _, _, iz in test.blocks for i in iz if ck.kinds[i] is Kind.ANGLE]
    # 1. from each design's last row on, in growing windows: the first grid value without a root in its mode
    kb = _first_without(test, xe, c, last[c], sig0, ch, angles)
    found = kb >= 0
    if not found.any():
        return cand, none
    c, kb = c[found], kb[found]
    # 2. pieces of 5°/64 from the last row to that value (or the end): the first piece without a root
    # brackets the limit; a design with a root in every piece to the end is completed without one
    L = len(xe)
    reach = kb == L
    kb = np.where(reach, L - 1, kb)
    h = abs(float(xs[1] - xs[0]))
    per = 64 if ck.kinds[test.ix] is not Kind.ANGLE else max(4, math.ceil(64 * h / math.radians(5.0) - 1e-9))
    spans = [np.linspace(xe[int(last[j])], xe[k], per * (k - int(last[j])) + 1) for j, k in zip(c, kb)]
    dsp = np.repeat(c, [len(v) for v in spans])
    okf, decf, mf = _in_mode_pieces(test, np.concatenate(spans), dsp, sig0[:, dsp])
    xa_, xb_, keep = [], [], []
    o = 0
    for r, xx in enumerate(spans):
        m = len(xx)
        okj, decj = okf[o:o + m], decf[o:o + m]
        margins = [None if g is None else g[o:o + m] for g in mf]
        o += m
        f = m if okj.all() else int(np.argmax(~okj))
        if not decj.all() or f == 0 or (f == m) != reach[r] or _dips(margins, f):
            continue
        xa_.append(xx[f - 1])
        xb_.append(xx[f] if f < m else xx[f - 1])
        keep.append(r)
    if not keep:
        return cand, none
    c, kb, reach = c[keep], kb[keep], reach[keep]
    xf = np.where(reach, dirn * np.inf, 0.0)
    lim = ~reach
    if lim.any():
        xf[lim] = _bisect(test, np.array(xa_)[lim], np.array(xb_)[lim], c[lim], sig0[:, c[lim]])
        # a gap narrower than _NECK (a root in the mode again just past the limit) is a near change point,
        # which the tracer may pass with a singular event: the single sweep decides
        cl = c[lim]
        width = _NECK * (1.0 if ck.kinds[test.ix] is Kind.ANGLE else test.scale[cl])
        off = 2.0 ** -np.arange(_PROBES)
        xp = (xf[lim] + dirn * np.outer(width * np.ones(len(cl)), off).T).T
        okp, _, _, _ = _in_mode(test, xp.ravel(), np.repeat(cl, _PROBES), sig0[:, np.repeat(cl, _PROBES)])
        neck = np.zeros(len(c), dtype=bool)
        neck[np.flatnonzero(lim)] = okp.reshape(len(cl), _PROBES).any(axis=1)
        c, kb, reach, xf = c[~neck], kb[~neck], reach[~neck], xf[~neck]
    # 3. the rows between each design's last lockstep row and the limit, all designs at once
    rows_of = [np.array([k for k in range(int(last[j]) + 1, K if to_end else min(int(k_bad), K))
                         if dirn * (xs[k] - x_lim) < 0], dtype=int) for j, x_lim, k_bad, to_end in zip(c, xf, kb, reach)]
    rk = np.concatenate(rows_of) if rows_of else np.zeros(0, dtype=int)
    rj = np.repeat(c, [len(v) for v in rows_of])
    failed = set()
    if len(rk):
        okr, decr, Z, _ = _in_mode(test, xs[rk], rj, sig0[:, rj])
        failed = set(rj[~(okr & decr)].tolist())
        Pj = P[:, rj]
        with np.errstate(all="ignore"):
            for _ in range(3):  # polish to round-off
                Z[ops.iu] = Z[ops.iu] + ops.solve(ops.jac(Z, Pj), -ops.phi(Z, Pj))
        o = 0
        for j, rws in zip(c, rows_of):  # angles continued from the row before
            for i in angles:
                seq = np.concatenate([[ch.Z[0][i, int(last[j]), j]], Z[i, o:o + len(rws)]])
                Z[i, o:o + len(rws)] = np.unwrap(seq)[1:]
            o += len(rws)
        fill_rows(ck, ops, Z, Pj, ch, rk, rj, rates, derivatives)
    done = []
    for j, x_lim, rws, to_end in zip(c, xf, rows_of, reach):
        if int(j) in failed:
            continue
        ch.mode[j] = "".join(np.where(sig0[:, j] > 0, "+", np.where(sig0[:, j] < 0, "-", "0")))
        ch.lockstep[j] = True
        done.append(int(j))
        if to_end:  # a regular path to the end of the range: no event, status ok
            continue
        end = int(last[j]) + 1 + len(rws)
        for arr in ch.Z:
            arr[:, end:, j] = np.nan
        if ch.points is not None:
            ch.points[..., end:, j] = np.nan
        disp = display_value_of(ck, float(x_lim))
        ch.status[j] = "limit"
        ch.stop[j] = disp
        ch.events[j] = f"limit@{disp:.10g}"
        # the warning the single sweep gives at this stop (sweep._announce_stop), summarized per study
        ch.warnings.append((j, f"the sweep stops at a limit position (toggle) at {ck.inputs[0]} = "
                               f"{disp:.10g}{input_unit(ck)}"))
    done = np.array(done, dtype=int)
    return np.setdiff1d(cand, done), done
