"""Shape synthesis: linkages whose point traces a drawn curve, from an atlas, polished and certified.

``synthesize(mech, shape="P", targets=curve, ...)`` (and ``loopsolve synthesize MODEL --shape P``):

1. **The target** is an ordered curve (``x,y``; any number ≥ 5 of points, noise allowed), closed
   unless ``closed=False`` (``--open``), checked by :func:`loopsolve.design.atlas.descriptors.check_curve`.
2. **The frame** (:mod:`loopsolve.design.atlas.frame`): the parameters that move, turn and scale the
   whole linkage (added to the model's vector form when it has none), so the match is free in
   position, orientation and scale and the design can be written in the target's coordinates.
3. **Retrieval** (:mod:`loopsolve.design.synthesis.shape.retrieval`): the atlas entries nearest the target by
   their curve descriptors, a few per basin (``diverse``), each placed on the target by the
   similarity of its match, with the input value of every target point.
4. **Polish**: the free-timing path problem of the target's points (at most ``polish_points`` of
   them, spread along the curve) on the framed model, whose varied parameters are the atlas'
   shape parameters, every length (so the scale) and the frame: all starts at once by the
   lockstep Levenberg–Marquardt with MINPACK's scaling and a damping from the gain ratio
   (:func:`loopsolve.design.synthesis.lockstep_lm.batch_lm` with ``trust``; the input value of every
   target point is a variable, so at the optimum each residual is the distance of that point to
   the design's curve), at most ``lm_iters`` iterations, a start stopping earlier once it converges
   or stalls (:data:`_STALL`). The distinct basins it ends in go on, best first.
5. **Certificate** from the tracker (:func:`loopsolve.design.synthesis.certificate.certify`) at up to 8 of the
   polished targets spread along the curve (the motion between them is swept): one circuit, in
   order, with a full turn of the input for a closed curve or ``crank``, within ``transmission``.
   Basins are certified until ``top`` designs are kept and the next one's polished objective is
   above theirs (:data:`_CERTIFY_MORE` when only some of the targets were polished).
6. **Shape error**: every target point's distance to the design's curve, on the motion the
   certificate swept (the tracker's rows at 1° over the full turn for a closed curve or ``crank``,
   the stretches from the first target to the last for an open one), refined to the foot of the
   perpendicular: RMS and maximum, in the target's units.
7. The best ``top`` certified designs, **distinct** (two designs whose parameters agree to 1 % of
   the target's size — lengths — and 1° — angles — in the same mode are one), ranked by RMS.

The report is the synthesis report with ``"task": "shape"`` (see ``DESIGN.md``): ``objective``
is Σ distance² over every target point; ``candidates`` lists each design's ``parameters`` (the
written model's values: in the target's coordinates), ``placement`` (``x``, ``y``: where the
frame's origin lies, ``angle`` its turn in the model's angle unit, ``scale``: the design's size
over that of the atlas entry it was polished from, measured on ``placement.reference``),
``shape_error``, ``grashof``, ``mode``, ``transmission``, ``certificate``.
"""

from __future__ import annotations

import math
import time

import numpy as np

from ....errors import ModelError, SynthesisError
from ....model.units import Kind

__all__ = ["synthesize_shape", "ShapeResult", "read_curve"]

#: target points the polish works on at most (spread along the curve by arc length)
POLISH_POINTS = 32
#: certificate checkpoints at most
_CERT_POINTS = 8
#: a column of the polish stops once its objective fell by less than ``_STALL_DROP`` (relative) over the last
#: ``_STALL`` iterations (after at least twice that many). On a 36-point kidney curve every polish ran to its
#: cap while its objective moved in the fourth digit after 10–20 evaluations; a planted design (quadratic
#: convergence) and the square free-timing fits that still halve their objective every ten iterations are not
#: stopped by it. (1 %, the rule of the per-basin MINPACK polish this replaced, stopped the fits of a noisy D
#: shape and of an open stretch 0.03 % above the bottoms that 0.1 % reaches.)
_STALL = 10
_STALL_DROP = 0.001
#: iterations of the polish (every start; a column stops earlier when it converges or stalls)
LM_ITERS = 120
#: certificates go on past ``top`` certified designs while a basin's polished objective is within this factor of
#: the worst one kept (the report ranks by the shape error over every target point, not only the polished ones)
_CERTIFY_MORE = 1.25


def read_curve(targets, closed: bool, where: str = "--targets", max_targets: int | None = None) -> np.ndarray:
    """The target curve ``(T, 2)`` from a CSV file/text, mapping or array (``x,y``), checked (at most
    ``max_targets`` points: the synthesis options' bound, ``--max-targets``)."""
    from ...atlas.descriptors import check_curve
    from ..targets import read_targets

    cols = read_targets(targets, "path", source=None if isinstance(targets, str) and "\n" not in targets else where)
    if "input" in cols:
        raise ModelError(f"{where}: an input column prescribes timing; shape synthesis matches the curve free in "
                         "timing (drop the column, or use --path for prescribed timing)")
    name = targets if isinstance(targets, str) and "\n" not in targets else where
    if max_targets is not None and len(cols["x"]) > max_targets:
        raise ModelError(f"{name}: {len(cols['x'])} points, more than --max-targets {max_targets}; resample the curve "
                         "or raise --max-targets")
    return check_curve(np.stack([cols["x"], cols["y"]], axis=1), closed=closed, where=str(name))


def _spread(xy, closed, m):
    """Indices of at most ``m`` points spread evenly in arc length along the curve (first included; last if open)."""
    T = len(xy)
    if T <= m:
        return np.arange(T)
    seg = np.hypot(*np.diff(np.vstack([xy, xy[:1]]) if closed else xy, axis=0).T)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    L = s[-1]
    want = np.arange(m) * (L / m) if closed else np.linspace(0.0, s[T - 1], m)
    idx = np.unique(np.clip(np.searchsorted(s[:T], want), 0, T - 1))
    if not closed:
        idx = np.unique(np.concatenate([[0], idx, [T - 1]]))
    return idx


def _bounds(frame, atlas, xy, vary, deg):
    """Polish bounds (model units) of every varied parameter: ``{name: (lo, hi)}`` and the fixed ``{name: value}``."""
    size = float(np.max(np.ptp(xy, axis=0)))
    cen = xy.mean(axis=0)
    big = 1e3 * size
    mech = frame.mech
    kinds = {p.name: p.kind for p in mech.parameters}
    turn = 360.0 if deg else 2 * math.pi
    out = {}
    amin = dict(zip(atlas.names, atlas.lo))
    amax = dict(zip(atlas.names, atlas.hi))
    base = atlas.values(0) if atlas.size else {}
    for n in frame.lengths:
        lo_a = amin.get(n, base.get(n, 1.0))
        out[n] = (1e-4 * size, big) if lo_a > 0 else (-big, big)
    out[frame.x] = (cen[0] - big, cen[0] + big)
    out[frame.y] = (cen[1] - big, cen[1] + big)
    out[frame.angle] = (-turn / 2, turn / 2)
    for n in atlas.names:
        if n not in out:
            a, b = amin[n], amax[n]
            if kinds.get(n) is Kind.ANGLE:
                out[n] = (a, b) if b - a >= turn else (a - (b - a) / 2, b + (b - a) / 2)
            else:
                out[n] = (a - (b - a) / 2, b + (b - a) / 2)
    fixed = {}
    for n, box in (vary or {}).items():
        if n not in kinds:
            raise ModelError(f"{mech.source or mech.name}: --vary {n}: not a parameter; the parameters are "
                             f"{', '.join(kinds)}")
        a, b = box
        if a == b:
            fixed[n] = float(a)
            out.pop(n, None)
        else:
            out[n] = (float(a), float(b))
    return out, fixed


def _distance_to_polyline(q, p):
    """Distance of every point ``q`` ``(T, 2)`` to the polyline ``p`` ``(R, 2)``, and the nearest segment's parameter."""
    a = p[:-1]
    d = p[1:] - a
    dd = np.sum(d * d, axis=1)
    rel = q[:, None, :] - a[None, :, :]
    t = np.clip(np.sum(rel * d[None], axis=2) / np.where(dd > 0, dd, 1.0)[None], 0.0, 1.0)
    near = a[None] + t[..., None] * d[None]
    dist = np.hypot(*(q[:, None, :] - near).transpose(2, 0, 1))
    k = np.argmin(dist, axis=1)
    return dist[np.arange(len(q)), k], k, t[np.arange(len(q)), k]


def _dense_curve(mech, point, x0, z0, span, direction):
    """The point's curve over the motion from pose ``z0`` at ``x0`` (internal) through ``span`` (internal, ≥ 0):
    ``(points (R, 2), inputs (R,), poses (R, nv))``; the tracker's (public sweep) rows at 0.5°."""
    import warnings

    from ....errors import LoopsolveWarning
    from ....kinematics.solve import display_value

    ck = mech.compile()
    a = display_value(ck, float(x0))
    b = display_value(ck, float(x0 + direction * span))
    unit = 0.5 if mech.units.angle == "deg" else math.radians(0.5)
    n = max(2, int(math.ceil(abs(b - a) / unit)))
    guess = {name: float(z0[i]) for i, name in enumerate(ck.variables)}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LoopsolveWarning)
        sw = mech.sweep(a, b, abs(b - a) / n, guess=guess, progress=False, derivatives=1)
    pts = np.stack([np.asarray(sw.columns[f"{point}_x"]), np.asarray(sw.columns[f"{point}_y"])], axis=1)
    return pts, np.asarray(sw.z[:, ck.input_idx[0]]), np.asarray(sw.z)


def _swept_curve(problem, sweeps):
    """The point's curve over the certificate's sweeps (joined in order): ``(points (R, 2), inputs (R,), poses)``."""
    ck = problem.ck
    pts = np.vstack([np.stack([np.asarray(sw.columns[f"{problem.point}_x"]),
                               np.asarray(sw.columns[f"{problem.point}_y"])], axis=1) for sw in sweeps])
    zs = np.vstack([np.asarray(sw.z) for sw in sweeps])
    return pts, zs[:, ck.input_idx[0]], zs


def _refine(problem, values, signs, q, xs0, Z0, lo, hi, iters: int = 6):
    """Distance of the points ``q`` to the design's curve, refined from the nearest polyline rows by Gauss–Newton
    on the input (the foot of the perpendicular), within ``[lo, hi]``: ``(dist, x)``; NaN where it fails."""
    b = problem.batch
    T = len(q)
    P = np.repeat(b.params(np.asarray(values, dtype=float)[None]), T, axis=1)
    S = np.repeat(np.asarray(signs, dtype=float)[:, None], T, axis=1)
    ip = problem.ck.points.index(problem.point)
    x = np.clip(np.asarray(xs0, dtype=float), lo, hi)
    Z = np.asarray(Z0, dtype=float).T.copy()
    with np.errstate(all="ignore"):
        for _ in range(iters):
            Z, ok = b.reassemble(Z, P, x, S)
            pts = b.points(Z, P)[ip]
            _, dq_dx = b.sensitivities(Z, P)
            V = np.zeros_like(Z)
            V[b.ix] = 1.0
            V[b.iu] = dq_dx
            dP = np.broadcast_to(np.asarray(b.ops.points(1, [Z, V], P), dtype=float).reshape(-1, 2, T)[ip], (2, T))
            r = pts - q.T
            step = np.sum(dP * r, axis=0) / np.sum(dP * dP, axis=0)
            x = np.clip(x - np.where(np.isfinite(step), step, 0.0), lo, hi)
        Z, ok = b.reassemble(Z, P, x, S)
        pts = b.points(Z, P)[ip]
    d = np.hypot(*(pts - q.T))
    return np.where(ok, d, np.nan), x


def _same_design(a, b, frame, size, deg) -> bool:
    if a["mode"] != b["mode"]:
        return False
    kinds = {p.name: p.kind for p in frame.mech.parameters}
    for n, va in a["parameters"].items():
        vb = b["parameters"][n]
        if kinds.get(n) is Kind.ANGLE:
            d = abs(math.remainder(va - vb, 360.0 if deg else 2 * math.pi))
            if d > (1.0 if deg else math.radians(1.0)):
                return False
        elif abs(va - vb) > 0.01 * size:
            return False
    return True


def synthesize_shape(mech, *, shape: str, targets, closed: bool = True, atlas=None, top: int = 5,
                     crank: bool = False, transmission=None, vary=None, seed: int = 0, progress=None,
                     polish_points: int = POLISH_POINTS, starts: int | None = None, lm_iters: int = LM_ITERS,
                     max_targets: int | None = None):
    """Linkages of ``mech`` whose point ``shape`` traces the curve ``targets`` (see the module docstring).

    Parameters
    ----------
    mech : Mechanism
    shape : str
        The point that must trace the curve.
    targets : path, CSV text, mapping or array
        The curve, ``x,y`` in the model's length unit, in order along it.
    closed : bool
        A closed curve (default) or an open stretch (``--open``).
    atlas : path or Atlas, optional
        The atlas to retrieve from (default: the model's default atlas, built on first use).
    top : int
        Certified designs reported (distinct, best first).
    crank, transmission
        Requirements, as for path synthesis (a closed curve needs the input to turn fully anyway).
    vary : mapping name → (low, high), optional
        Bounds of parameters in the polish (model units, the target's coordinates); LOW = HIGH
        fixes one (a placement parameter fixes the position or turn).
    seed : int
        Seed of the default atlas (when one is built).
    polish_points, starts, lm_iters
        Target points the polish uses, starts retrieved (default 3·top, at least 12), iterations
        of the lockstep Levenberg–Marquardt (:data:`LM_ITERS`).

    Returns
    -------
    ShapeResult

    Raises
    ------
    ModelError
        A bad curve, point, bound, atlas (exit 2).
    SynthesisError
        No certified design (exit 3; its ``report`` lists the rejected candidates).
    """
    from ...atlas.build import Atlas, open_atlas
    from ...atlas.frame import frame_of
    from .retrieval import diverse, placed_starts, retrieve, within_bounds
    from ..problem import define

    t0, c0 = time.perf_counter(), time.process_time()
    if isinstance(top, bool) or not isinstance(top, (int, np.integer)) or top < 1:
        raise ModelError(f"--top {top!r}: the number of designs to report, at least 1")
    xy = read_curve(targets, closed, max_targets=max_targets)
    frame = frame_of(mech, shape)
    if atlas is None:
        from ...atlas.defaults import default_atlas

        atlas = default_atlas(mech, shape, progress=progress, seed=seed)
    elif not isinstance(atlas, Atlas):
        atlas = open_atlas(atlas, mech)
    else:
        from ...atlas.store import AtlasFileError, fingerprint

        if atlas.meta["fingerprint"] != fingerprint(mech):
            raise AtlasFileError(f"the atlas is of {atlas.meta.get('name')!r}, not of {mech.name!r}")
    if atlas.point != shape:
        raise ModelError(f"the atlas holds the curves of point {atlas.point!r}, not {shape!r}; build an atlas of "
                         f"{shape!r} (loopsolve atlas build MODEL --point {shape} ...)")
    deg = mech.units.angle == "deg"
    bounds, fixed = _bounds(frame, atlas, xy, vary, deg)
    fmech = frame.mech.with_parameters(**fixed) if fixed else frame.mech
    if fixed:
        frame = type(frame)(fmech, frame.point, frame.x, frame.y, frame.angle, frame.lengths, frame.added,
                            frame.input_turns)
    idx = _spread(xy, closed, polish_points)
    need_crank = bool(closed or crank)
    problem = define(fmech, path=shape, targets={"x": xy[idx, 0], "y": xy[idx, 1]}, vary=bounds, crank=need_crank,
                     transmission=transmission, mode="any")
    n_starts = max(12, 3 * top) if starts is None else int(starts)
    t1, c1 = time.perf_counter(), time.process_time()
    matches, rstats = retrieve(atlas, xy, closed=closed, crank=crank, count=max(400, 40 * n_starts))
    if not matches:
        why = "no entry of the atlas has a full turn of the input" if need_crank else "the atlas has no traced entry"
        raise SynthesisError(f"{atlas.path or 'the atlas'}: {why}; build a larger atlas or widen its box",
                             report={"task": "shape", "objective": None, "candidates": []})
    if vary:  # bounds the user gave: starts within them (a start clipped into them would be another design)
        inside = within_bounds(atlas, matches, xy, closed, frame, problem, deg=deg)
        matches = inside or matches
    picked = diverse(atlas, matches, n_starts)
    V, S, X, used = placed_starts(atlas, picked, xy, idx, closed, frame, problem, deg=deg)
    t2, c2 = time.perf_counter(), time.process_time()
    cands, rejected = _polish_and_certify(problem, frame, atlas, xy, idx, closed, V, S, X, used, top, lm_iters,
                                          problem.transmission, deg)
    t3, c3 = time.perf_counter(), time.process_time()
    stats = {"retrieval": {**rstats, "matches": len(matches), "starts": len(used),
                           "best_distance": used[0].dist if used else None},
             "seconds": {"setup": t1 - t0, "retrieval": t2 - t1, "polish_certify": t3 - t2},
             "cpu_seconds": {"setup": c1 - c0, "retrieval": c2 - c1, "polish_certify": c3 - c2},
             "rejected": rejected, "atlas": atlas.summary() | {"path": str(atlas.path) if atlas.path else None}}
    return _result(problem, frame, atlas, xy, closed, cands, top, stats, time.perf_counter() - t0)


def _polish_and_certify(problem, frame, atlas, xy, idx, closed, V, S, X, used, top, lm_iters, transmission, deg):
    """Every start polished at once (the lockstep LM with MINPACK's scaling and a damping from the gain ratio), then
    certificates of the distinct basins, best first."""
    from ...atlas.trace import fourbar_loops
    from ..problem import periodic
    from ..lockstep_lm import batch_lm, distinct

    if not len(V):
        return [], []
    size = float(np.max(np.ptp(xy, axis=0)))
    Vl, Xl, fl, Zl = batch_lm(problem, V, S, X, iters=lm_iters, warm=True, poses=True, trust=True,
                              stall=(_STALL, _STALL_DROP))
    if not problem.crank:
        Xl, fl, Zl = _feet(problem, Vl, Xl, fl, Zl, S)
    per, period = periodic(problem)
    order = distinct(Vl, fl, problem.lo, problem.hi, k=max(2 * top, 6), rtol_f=1e-3, dist=0.01,
                     periodic_mask=per, period=period)
    loops = fourbar_loops(problem.mech)
    cands, rejected = [], []
    # every target polished: the polished objective is the sum of the targets' squared distances to the curve (at
    # the nearest points of their stretches), so the next basin cannot rank above the ones kept; a subset polished:
    # the others' distances may reorder designs that are nearly as good
    more = 1.0 if len(idx) == len(xy) else _CERTIFY_MORE
    for i in order:
        if len(cands) >= top and fl[i] > more * max(c["polished"] for c in cands):
            break  # the basins left end above every design kept
        p = {"values": Vl[i], "inputs": Xl[:, i], "signs": S[:, i], "objective": fl[i], "Z": Zl[:, :, i]}
        if not np.all(np.isfinite(p["Z"])):  # (the polish's last trace through the targets gives them)
            p.update(_poses(problem, p))
            if p.get("Z") is None:
                continue
        c = _candidate(problem, frame, atlas, xy, closed, p, used[i], transmission, deg, loops)
        if c is None:
            continue
        c["polished"] = p["objective"]
        if c["certificate"]["defects"]:
            rejected.append({"objective": c["objective"], "parameters": c["parameters"],
                             "defects": c["certificate"]["defects"], "notes": c["certificate"]["notes"]})
            continue
        if any(_same_design(c, d, frame, size, deg) for d in cands):
            continue
        cands.append(c)
    cands.sort(key=lambda c: c["shape_error"]["rms"])
    return cands, rejected


def _feet(problem, V, X, f, Z, S, iters: int = 8):
    """An open curve's polished designs with every target's input moved to the foot of its perpendicular on the
    design's curve (the design kept): ``(X, f, Z)``.

    Why: the motion of an open curve ends at the first and last targets' inputs, so an end target whose input
    has not converged cuts the curve short of its foot — on a stretch where the point dwells, the objective
    hardly changes while that input still moves, and a polish that stalled leaves it there. Gauss–Newton on each
    input alone (all designs and targets in one batch), then a trace through the targets in the design's mode;
    a design keeps the new inputs only when the trace reaches every target, in the same order, and its objective
    is not larger.
    """
    from ..lockstep_lm import POLISH_H

    b = problem.batch
    T = problem.T
    cols = np.flatnonzero(np.isfinite(f) & np.all(np.isfinite(Z), axis=(0, 1)))
    if not cols.size:
        return X, f, Z
    D = cols.size
    P = b.params(V[cols])
    PT, ST = np.tile(P, (1, T)), np.tile(np.asarray(S, dtype=float)[:, cols], (1, T))  # column t·D + d
    q = np.repeat(problem.targets[:, :2], D, axis=0).T
    ip = problem.ck.points.index(problem.point)
    x = X[:, cols].reshape(-1).copy()
    Zf = Z[:, :, cols].reshape(Z.shape[0], T * D).copy()
    with np.errstate(all="ignore"):
        for _ in range(iters):
            Zf, ok = b.reassemble(Zf, PT, x, ST)
            pts = b.points(Zf, PT)[ip]
            zk1 = np.zeros_like(Zf)
            zk1[b.ix] = 1.0
            Vt = np.zeros_like(Zf)
            Vt[b.ix] = 1.0
            Vt[b.iu] = b.ops.solve(b.ops.jac(Zf, PT), b.ops.rhs(1, (Zf, zk1), PT))
            dP = np.broadcast_to(np.asarray(b.ops.points(1, [Zf, Vt], PT), dtype=float).reshape(-1, 2, T * D)[ip],
                                 (2, T * D))
            step = np.sum(dP * (pts - q), axis=0) / np.sum(dP * dP, axis=0)
            x = x - np.where(ok & np.isfinite(step), step, 0.0)
        Xn = x.reshape(T, D)
        Zt, reached = problem.trace(P, Xn, np.asarray(S, dtype=float)[:, cols], hmax=POLISH_H, singular_stop=False)
        r = problem.residuals(np.nan_to_num(Zt[:, :T]), P)
        fn = np.where(reached >= T, np.sum(r * r, axis=(0, 1)), np.inf)
    same_order = np.all(np.sign(np.diff(Xn, axis=0)) == np.sign(np.diff(X[:, cols], axis=0)), axis=0)
    take = (fn <= f[cols]) & same_order
    X, f, Z = X.copy(), f.copy(), Z.copy()
    X[:, cols[take]] = Xn[:, take]
    f[cols[take]] = fn[take]
    Z[:, :, cols[take]] = Zt[:, :T, take]
    return X, f, Z


def _poses(problem, p):
    """The positions at the targets, traced through them in the design's mode (5° substeps, then 1°)."""
    with np.errstate(all="ignore"):
        P = problem.batch.params(np.asarray(p["values"])[None])
        for h in (5.0, 1.0):
            Zt, r = problem.trace(P, np.asarray(p["inputs"])[:, None], np.asarray(p["signs"])[:, None],
                                  hmax=math.radians(h), singular_stop=False)
            if r[0] >= problem.T:
                return {"Z": Zt[:, :, 0]}
    return {"Z": None}


def _candidate(problem, frame, atlas, xy, closed, p, match, transmission, deg, loops):
    """Certify one polished design and measure its shape error: the candidate dict, or None (cannot be traced)."""
    from ....errors import LoopsolveError
    from ..certificate import certify
    from ..problem import sign_string

    values = np.asarray(p["values"], dtype=float)
    inputs = np.asarray(p["inputs"], dtype=float)
    Z = p["Z"]
    params = dict(zip(problem.names, map(float, values)))
    try:
        mech = problem.mech.with_parameters(**params)
    except LoopsolveError:
        return None
    T = problem.T
    sub = np.unique(np.round(np.linspace(0, T - 1, min(T, _CERT_POINTS))).astype(int))
    margin, grashof = None, ""
    if loops:
        from ...atlas.trace import GRASHOF_CLASSES, grashof_codes, loop_lengths

        Pd = problem.batch.params(values[None])
        codes, marg = grashof_codes(loop_lengths(problem.ck, loops, Z[:, :1], Pd))
        grashof = " + ".join(GRASHOF_CLASSES[c] for c in codes[:, 0] if c)
        margin = float(marg[0]) if np.isfinite(marg[0]) else None
    swept = []
    cert = certify(mech, inputs[sub], poses=Z[:, sub], crank=problem.crank, transmission=transmission,
                   point=problem.point, targets=problem.targets[sub], grashof_margin=margin, sweeps=swept)
    direction = 1 if inputs[-1] >= inputs[0] else -1
    span = 2 * math.pi if problem.crank else abs(float(inputs[-1] - inputs[0]))
    if not cert["defects"] and swept:
        # the motion the certificate swept (the full turn, or the stretches from the first target to the last):
        # the curve whose distance to the targets is the shape error, not swept again
        pts, xs, zs = _swept_curve(problem, swept)
    else:
        try:
            pts, xs, zs = _dense_curve(mech, problem.point, inputs[0], Z[:, 0], span, direction)
        except LoopsolveError:
            pts = None
    if pts is None or len(pts) < 2:
        dist = np.full(len(xy), np.inf)
        near_x = np.full(len(xy), np.nan)
    else:
        dist, k, t = _distance_to_polyline(xy, pts)
        near_x = xs[k] + t * (xs[np.minimum(k + 1, len(xs) - 1)] - xs[k])
        lo_x, hi_x = (min(xs[0], xs[-1]), max(xs[0], xs[-1])) if not problem.crank else (-np.inf, np.inf)
        fine, fx = _refine(problem, values, p["signs"], xy, near_x, zs[k], lo_x, hi_x)
        # the refined foot is on the curve itself; the polyline's chords can be nearer a point than the curve by
        # their sagitta, so the refined distance wins unless it went to another part of the curve
        better = np.isfinite(fine) & (fine <= dist + 1e-3 * float(np.max(np.ptp(xy, axis=0))))
        dist = np.where(better, fine, dist)
        near_x = np.where(better, fx, near_x)
    ck = mech.compile()
    from ....kinematics.solve import display_value

    vals = atlas.values(match.entry)
    ref = next((n for n in frame.lengths if abs(vals.get(n, 0.0)) > 0), None)
    scale = abs(params.get(ref, vals.get(ref, 1.0)) / vals[ref]) if ref else 1.0
    full = dict(zip([q.name for q in mech.parameters], [float(mech.spec["parameters"][q.name])
                                                        for q in mech.parameters]))
    return {
        "parameters": full,
        "placement": {"x": full[frame.x], "y": full[frame.y], "angle": full[frame.angle], "scale": scale,
                      "reference": ref},
        "shape_error": {"rms": float(np.sqrt(np.mean(dist ** 2))), "max": float(np.max(dist))},
        "grashof": grashof,
        "mode": sign_string(p["signs"]),
        "transmission": cert.get("transmission"),
        "certificate": cert,
        "objective": float(np.sum(dist ** 2)),
        "direction": direction,
        "motion": [display_value(ck, float(inputs[0])), display_value(ck, float(inputs[-1]))],
        "atlas_entry": int(match.entry),
        "descriptor_distance": float(match.dist),
        "_inputs": inputs, "_Z": Z, "_errors": dist, "_near_x": near_x, "_curve": pts,
        "_display_inputs": [display_value(ck, float(x)) for x in near_x] if pts is not None else None,
    }


class ShapeResult:
    """The certified designs of a shape synthesis, best first.

    Users receive one from ``ls.synthesize(mech, shape=..., atlas=...)``; they need not construct
    one. ``to_toml(k)``, ``plot()`` and ``view()`` write, draw and show the candidates.

    Parameters
    ----------
    report : dict
        The synthesis contract's report (``objective``, ``candidates``, ``shape_error``...).
    candidates : list of dict
        One dict per certified design, best first, each with its ``mechanism``.
    targets : numpy.ndarray
        The target curve ``(T, 2)`` (the target's coordinates).
    closed : bool
        Whether the target curve is closed (a full turn of the crank).
    problem : object
        The shape-synthesis problem.

    Attributes
    ----------
    mechanism : Mechanism
        The best design, placed in the target's coordinates.
    objective : float
        The best design's objective (squared shape error, model length unit squared).
    report, candidates, targets, closed, problem
        As the parameters of the same names.

    Examples
    --------
    The coupler curve of the model's own four-bar, found again from a small atlas (the search takes
    a few seconds, so it is not run here):

    >>> import numpy as np
    >>> import loopsolve as ls
    >>> mech = ls.load(ls.models_dir() / "fourbar_path_synthesis.toml")
    >>> atlas = ls.build_atlas(mech, point="P", vary={"r2": (0.5, 2)}, size=16, chunk=16,
    ...                        progress=False)  # doctest: +SKIP
    >>> sw = mech.sweep(0, 360, 10)
    >>> curve = np.column_stack([sw["P_x"], sw["P_y"]])
    >>> res = ls.synthesize(mech, shape="P", targets=curve, atlas=atlas, top=1,
    ...                     progress=False)  # doctest: +SKIP
    >>> res.closed, res.targets.shape, round(res.report["parameters"]["r2"], 6)  # doctest: +SKIP
    (True, (36, 2), 1.0)
    """

    def __init__(self, report, candidates, targets, closed, problem):
        self.report = report
        self.candidates = candidates
        self.targets = targets
        self.closed = closed
        self.problem = problem
        self.mechanism = candidates[0]["mechanism"]
        self.objective = report["objective"]

    def __repr__(self) -> str:
        c = self.report["candidates"]
        return (f"ShapeResult({len(c)} certified, best rms {c[0]['shape_error']['rms']:.4g}, "
                f"max {c[0]['shape_error']['max']:.4g})")

    def to_toml(self, k: int = 0) -> str:
        """Candidate ``k`` (default the best) as a model file (TOML text)."""
        from ....model.modelfile import dumps

        return dumps(self.candidates[k]["mechanism"])

    def plot(self, *, ax=None, output=None, k: int | None = None):
        """The target curve and the candidates' curves (``k``: only that one, with its linkage)."""
        from ....output.shapeview import plot_shape

        return plot_shape(self, ax=ax, output=output, k=k)

    def to_html(self, *, title=None) -> str:
        """The interactive page: the target, the candidates (switchable), the chosen one moving."""
        from ....output.shapeview import candidate_sweeps, shape_html

        return shape_html(self.targets, self.report, candidate_sweeps(self), title=title)

    def view(self):
        """The interactive page inline in Jupyter (a :class:`loopsolve.output.view.Page`)."""
        from ....output.view import Page

        return Page(self.to_html(), height=1250)


def _result(problem, frame, atlas, xy, closed, cands, top, stats, seconds):
    from ..design_model import clean, design_model

    cands = cands[:top]
    report = {"task": "shape", "objective": None, "parameters": None, "runs": [], "seconds": [seconds],
              "mode": None, "direction": None, "targets": None, "certificate": None, "point": problem.point,
              "closed": bool(closed), "candidates": [], "statistics": stats}
    if not cands:
        rej = stats["rejected"]
        why = "; ".join(f"rms {math.sqrt(r['objective'] / len(xy)):.3g}: {', '.join(r['defects'])}"
                        for r in rej[:4]) or "no start could be traced through the targets"
        raise SynthesisError(f"{problem.mech.source or problem.mech.name}: no certified design ({why}); try a larger "
                             "atlas, relax --crank/--transmission, or check the curve", report=clean(report))
    out = []
    for c in cands:
        m = design_model(problem, [c["parameters"][n] for n in problem.names], c["_inputs"], c["_Z"])
        c["mechanism"] = m
        out.append({k: v for k, v in c.items() if not k.startswith("_") and k not in ("mechanism", "polished")})
    best = cands[0]
    report.update({
        "objective": best["objective"], "parameters": out[0]["parameters"], "runs": [best["objective"]],
        "mode": best["mode"], "direction": best["direction"],
        "targets": [{"input": (None if best["_display_inputs"] is None else float(x)), "error": float(e),
                     "x": float(q[0]), "y": float(q[1])}
                    for x, e, q in zip(best["_display_inputs"] or [None] * len(xy), best["_errors"], xy)],
        "certificate": best["certificate"], "placement": out[0]["placement"], "shape_error": out[0]["shape_error"],
        "candidates": out,
    })
    report = clean(report)
    return ShapeResult(report, cands, xy, closed, problem)
