"""One chunk of an atlas: trace every design's point over its whole motion, label it, describe its curve.

:func:`trace_chunk` takes the parameter values of D designs of one model (one row each) and,
with the lockstep engine of synthesis (:class:`loopsolve.design.synthesis.candidates.Batch`: all designs
of the chunk in one array, the generated kernels called once per substep):

1. **Mode and start.** Each design keeps the assembly mode its guesses name (the signs of the
   block determinants at the guesses, with its own parameters). It is assembled in that mode at
   the guesses' input, or — when it cannot be — at the first of the inputs turned by 30°, 60°, …
   where it can (a design that assembles nowhere on that ring is ``assembles = false``).
2. **Motion.** From there the input is stepped (``step_deg``, 3° by default; predictor–corrector
   substeps) one full turn forward. A design that comes back to its start pose has a **crank**:
   its curve is closed. Any other is stepped backward from the start as well; it stopped both
   ways at limits (the corrector fails, a block turns near-singular or changes its sign), and its
   motion is the swing between them, in one mode: an open curve. Either way the motion is one
   continuous motion in one mode (``one_circuit``), never a jump between circuits or branches.
3. **Labels.** The input range traced (internal units), the transmission range over the motion
   (the angle between the links of every dyad of two angle unknowns, degrees, as the synthesis
   certificate measures it), the Grashof class and margin of every four-bar loop the model has
   (lengths from the design; :func:`loopsolve.kinematics.classic_limits.grashof`).
4. **Descriptors.** The point's curve is resampled at ``n`` points equally spaced in arc length
   (from the start pose round a closed curve, from the lower limit to the upper for an open
   one) and normalized (:mod:`loopsolve.design.atlas.descriptors`): closed curves by their elliptic
   Fourier descriptors (stored too), open ones by centroid, RMS size and principal axis. The
   placement removed — centre, angle, scale, EFD start — is kept, so the design's own curve is
   ``centre + scale · R(angle) · stored``.

Every number of a design depends only on that design's parameters and its place in the chunk
(chunks are always computed at full size, see :mod:`loopsolve.design.atlas.build`), so a chunk computed
on a Dask worker is the same as one computed here.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from ...model.units import Kind
from . import descriptors as _d

__all__ = ["trace_chunk", "GRASHOF_CLASSES", "fourbar_loops", "STATUS"]

#: entry status codes of the store
STATUS = {"empty": 0, "no-assembly": 1, "traced": 2, "degenerate": 3}
#: Grashof classes as stored (index) — "" for a design whose loop lengths are not all positive
GRASHOF_CLASSES = ("", "double crank", "crank-rocker", "rocker-crank", "double rocker", "change point",
                   "triple rocker")
#: inputs tried for assembly when the guesses' input fails: turned by this much each time
_RING = math.radians(30.0)


_LOOPS: dict = {}


def fourbar_loops(mech) -> list[dict]:
    """The four-bar loops of ``mech`` (``info()['fourbars']``) with how to measure their lengths in a design.

    Kept per model structure (``info()`` of a six-bar takes seconds, and the loops are the same for
    every design of a model).
    """
    from .store import fingerprint

    key = fingerprint(mech)
    if key not in _LOOPS:
        if len(_LOOPS) > 64:
            _LOOPS.clear()
        _LOOPS[key] = _fourbar_loops(mech)
    return [dict(lp) for lp in _LOOPS[key]]


def _fourbar_loops(mech) -> list[dict]:
    from ...errors import LoopsolveError

    try:
        fbs = mech.info().get("fourbars") or []
    except LoopsolveError:
        return []
    ck = mech.compile()
    out = []
    for fb in fbs:
        roles = ("ground", "input", "coupler", "output")
        if fb.get("joints"):
            j = fb["joints"]
            pairs = {"ground": (j["input_pivot"], j["output_pivot"]), "input": (j["input_pivot"], j["input_pin"]),
                     "coupler": (j["input_pin"], j["output_pin"]), "output": (j["output_pivot"], j["output_pin"])}
            if all(p in ck.points for pr in pairs.values() for p in pr):
                out.append({"loop": fb["loop"], "points": {r: tuple(ck.points.index(p) for p in pairs[r])
                                                            for r in roles}})
        elif all(fb["links"][r] in ck.vectors for r in roles):
            out.append({"loop": fb["loop"], "vectors": {r: ck.vectors.index(fb["links"][r]) for r in roles}})
    return out


def loop_lengths(ck, loops, Z, P):
    """``(nloops, 4, D)`` lengths (ground, input, coupler, output) of every four-bar loop at poses ``Z``."""
    out = np.full((len(loops), 4, Z.shape[1]), np.nan)
    if not loops:
        return out
    with np.errstate(all="ignore"):
        vec = pts = None
        for i, lp in enumerate(loops):
            for r, role in enumerate(("ground", "input", "coupler", "output")):
                if "vectors" in lp:
                    if vec is None:
                        vec = np.asarray(ck.module.vectors0_v(Z, P), dtype=float)
                        vec = np.broadcast_to(vec.reshape(len(ck.vectors), 2, -1), (len(ck.vectors), 2, Z.shape[1]))
                    out[i, r] = np.abs(vec[lp["vectors"][role], 0])  # (length, angle) of every vector
                else:
                    if pts is None:
                        pts = np.asarray(ck.module.points0_v(Z, P), dtype=float)
                        pts = np.broadcast_to(pts.reshape(len(ck.points), 2, -1), (len(ck.points), 2, Z.shape[1]))
                    a, b = lp["points"][role]
                    d = pts[a] - pts[b]
                    out[i, r] = np.hypot(d[0], d[1])
    return out


def grashof_codes(lengths):
    """Class codes ``(nloops, D)`` and the least margin P + Q − S − L over the loops ``(D,)``."""
    from ...kinematics.classic_limits import grashof

    nl, _, D = lengths.shape
    codes = np.zeros((nl, D), dtype=np.int8)
    margin = np.full(D, np.nan)
    for i in range(nl):
        L = lengths[i]
        srt = np.sort(L, axis=0)
        m = srt[1] + srt[2] - srt[0] - srt[3]
        margin = np.where(np.isnan(margin), m, np.minimum(margin, m))
        for d in range(D):
            g, a, b, c = (float(v) for v in L[:, d])
            if all(v > 0 and math.isfinite(v) for v in (g, a, b, c)):
                codes[i, d] = GRASHOF_CLASSES.index(grashof(g, a, b, c).value)
    return codes, margin


def _dyads(ck):
    out = []
    for b in ck.blocks:
        if len(b.unknowns) == 2:
            i, j = (int(ck.unknown_idx[c]) for c in b.unknowns)
            if ck.kinds[i] is Kind.ANGLE and ck.kinds[j] is Kind.ANGLE:
                out.append((i, j))
    return out


def _assemble_anywhere(b, P, sig, tries: int):
    """Positions at the guesses' input, or at the first input of the ring where the design assembles."""
    D = P.shape[1]
    x0 = b.x_guess
    Z = np.full((b.nv, D), np.nan)
    xs = np.full(D, np.nan)
    todo = np.arange(D)
    for k in range(tries):
        if not todo.size:
            break
        x = x0 + k * _RING if b.input_is_angle else x0
        Zk, ok = b.assemble(P[:, todo], np.full(todo.size, x), sig[:, todo])
        got = todo[ok]
        Z[:, got] = Zk[:, ok]
        xs[got] = x
        todo = todo[~ok]
    return Z, xs


def _wrap(a):
    return (a + math.pi) % (2 * math.pi) - math.pi


def trace_chunk(mech, point: str, names, V, *, step_deg: float = 3.0, curve_points: int = 64,
                harmonics: int = 10, loops=None) -> dict:
    """Trace, label and describe the designs ``V`` ``(D, k)`` (model units) of ``mech``: a dict of arrays.

    Keys: ``status`` (D,) (:data:`STATUS`), ``crank`` (D,) bool, ``mode`` (D, nb) int8 block signs,
    ``x_start``, ``x_range`` (D, 2) (internal input values), ``transmission`` (D, 2) degrees,
    ``grashof`` (D, nloops) codes of :data:`GRASHOF_CLASSES`, ``margin`` (D,), ``place`` (D, 5)
    (x, y, angle, scale, start), ``curve`` (D, n, 2), ``efd`` (D, 4H − 3), ``roundness`` (D,).
    """
    from ..synthesis.candidates import Batch

    ck = mech.compile()
    b = Batch(ck, names)
    # numpy whatever this process traced before: an atlas holds the same values whether one process, a Dask
    # cluster's fresh workers or a later growth built its chunks (synthesis's ``auto`` engine depends on what
    # its process has traced, and the two engines agree to round-off, not to the bit)
    b.engine = "python"
    V = np.asarray(V, dtype=float).reshape(-1, len(names))
    D = V.shape[0]
    P = b.params(V)
    ip = ck.points.index(point)
    loops = fourbar_loops(mech) if loops is None else loops
    nb = len(ck.blocks)
    out = {"status": np.zeros(D, dtype=np.int8), "crank": np.zeros(D, dtype=bool),
           "mode": np.zeros((D, nb), dtype=np.int8), "x_start": np.full(D, np.nan),
           "x_range": np.full((D, 2), np.nan), "transmission": np.full((D, 2), np.nan, dtype=np.float32),
           "grashof": np.zeros((D, len(loops)), dtype=np.int8), "margin": np.full(D, np.nan),
           "place": np.full((D, 5), np.nan), "curve": np.full((D, curve_points, 2), np.nan, dtype=np.float32),
           "efd": np.full((D, 4 * harmonics - 3), np.nan, dtype=np.float32),
           "roundness": np.full(D, np.nan, dtype=np.float32)}
    h = math.radians(step_deg) if b.input_is_angle else step_deg * 0.01 * float(ck.scale)
    K = int(round(2 * math.pi / h)) if b.input_is_angle else 100
    with np.errstate(all="ignore"):
        sig = b.guessed_signs(P)
        Z0, xs = _assemble_anywhere(b, P, sig, 12 if b.input_is_angle else 1)
        ok = np.all(np.isfinite(Z0), axis=0)
        out["status"][:] = STATUS["no-assembly"]
        if not ok.any():
            return out
        # the mode each design is traced in: its signs at the start pose (= the guesses' where they name one)
        J = b.ops.jac(np.nan_to_num(Z0), P)
        sig0, _ = b.ops.signs_and_regularity(J, b.scale(P))
        ks = np.arange(K + 1)
        Xf = xs[None, :] + h * ks[:, None]
        Zf, rf = b.follow(Z0, P, np.where(np.isfinite(Xf), Xf, 0.0), hmax=h, signs=sig0)
        d = Zf[:, K] - Zf[:, 0]
        ang = ~b.is_len
        dq = d[b.iu]
        dq = np.where(ang[:, None], _wrap(dq), dq)
        w = np.where(b.is_len[:, None], 1.0 / b.scale(P), 1.0)
        crank = ok & (rf == K + 1) & np.all(np.abs(dq * w) < 1e-6, axis=0) if b.input_is_angle else np.zeros(D, bool)
        rest = np.flatnonzero(ok & ~crank)
        Zb = np.full_like(Zf, np.nan)
        rb = np.zeros(D, dtype=int)
        if rest.size:
            Xb = xs[None, rest] - h * ks[:, None]
            Zr, rr = b.follow(Z0[:, rest], P[:, rest], Xb, hmax=h, signs=sig0[:, rest])
            Zb[:, :, rest] = Zr
            rb[rest] = rr
    # rows of every design's motion along increasing input: backward rows reversed, then forward
    R = 2 * K + 1
    rows = np.full((b.nv, R, D), np.nan)
    count = np.zeros(D, dtype=int)
    first = np.zeros(D, dtype=int)
    for j in np.flatnonzero(ok):
        if crank[j]:
            rows[:, :K, j] = Zf[:, :K, j]
            count[j] = K
        else:
            nbk, nfw = int(rb[j]), int(rf[j])
            seq = np.concatenate([Zb[:, nbk - 1:0:-1, j], Zf[:, :nfw, j]], axis=1) if nbk > 1 else Zf[:, :nfw, j]
            rows[:, :seq.shape[1], j] = seq
            count[j] = seq.shape[1]
            first[j] = nbk - 1 if nbk > 1 else 0
    flat = rows.reshape(b.nv, R * D)
    PP = np.tile(P, (1, R))  # column r*D + d: design d's parameters
    valid = np.all(np.isfinite(flat), axis=0)
    pts = np.full((2, R * D), np.nan)
    with np.errstate(all="ignore"):
        if valid.any():
            pts[:, valid] = b.points(flat[:, valid], PP[:, valid])[ip]
    curves = pts.reshape(2, R, D).transpose(2, 1, 0)  # (D, R, 2)
    out["crank"] = crank
    out["mode"] = np.where(ok[None, :], sig0, 0).T.astype(np.int8)
    out["x_start"] = np.where(ok, xs, np.nan)
    lo = np.where(crank, xs, xs - h * np.maximum(rb - 1, 0))
    hi = np.where(crank, xs + 2 * math.pi, xs + h * np.maximum(rf - 1, 0))
    out["x_range"] = np.where(ok[:, None], np.stack([lo, hi], axis=1), np.nan)
    dy = _dyads(ck)
    if dy:
        mus = []
        for i, j in dy:
            mus.append(np.degrees(np.abs(_wrap(rows[i] - rows[j]))))
        mu = np.concatenate(mus, axis=0)  # (ndyad*R, D)
        with np.errstate(all="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            out["transmission"] = np.stack([np.nanmin(mu, axis=0), np.nanmax(mu, axis=0)], axis=1).astype(np.float32)
    if loops:
        zany = np.where(ok[None, :], np.nan_to_num(Z0), 0.0)
        codes, margin = grashof_codes(loop_lengths(ck, loops, zany, P))
        out["grashof"] = np.where(ok[:, None], codes.T, 0).astype(np.int8)
        out["margin"] = np.where(ok, margin, np.nan)
    # descriptors
    res = _d.resample_many(curves, count, curve_points, crank)
    with np.errstate(all="ignore"):
        size = np.sqrt(np.mean(np.sum((res - np.mean(res, axis=1, keepdims=True)) ** 2, axis=2), axis=1))
    good = ok & np.all(np.isfinite(res), axis=(1, 2)) & (size > 1e-9 * float(ck.scale)) & (count >= 4)
    out["status"] = np.where(ok, np.where(good, STATUS["traced"], STATUS["degenerate"]), STATUS["no-assembly"]).astype(
        np.int8)
    cl = np.flatnonzero(good & crank)
    if cl.size:
        poly = curves[cl, :K]
        coef = _d.efd(poly, harmonics)
        N_, theta, psi, E, rnd = _d.efd_normalize(coef)
        cen = _d.centroid(poly)
        out["efd"][cl] = _d.efd_descriptor(N_)
        out["roundness"][cl] = rnd
        z = (res[cl, :, 0] + 1j * res[cl, :, 1] - (cen[:, 0] + 1j * cen[:, 1])[:, None]) * np.exp(-1j * psi)[:, None]
        z = z / E[:, None]
        out["curve"][cl] = np.stack([z.real, z.imag], axis=-1)
        out["place"][cl] = np.stack([cen[:, 0], cen[:, 1], psi, E, theta], axis=1)
    op = np.flatnonzero(good & ~crank)
    if op.size:
        Q, place = _d.open_normalize_many(res[op])
        fine = np.all(np.isfinite(Q), axis=(1, 2))
        out["curve"][op[fine]] = Q[fine]
        out["place"][op[fine]] = np.concatenate([place[fine], np.zeros((int(fine.sum()), 1))], axis=1)
        out["status"][op[~fine]] = STATUS["degenerate"]
    return out
