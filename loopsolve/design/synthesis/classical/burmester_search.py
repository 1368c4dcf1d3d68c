"""Burmester four-bars for three, four or five poses, screened and ranked by a stated rule.

Five poses give a finite set of dyads (the Ball–Burmester points, :func:`loopsolve.design.synthesis.classical.burmester.pose_dyads`);
four give a curve of centre points (:func:`loopsolve.design.synthesis.classical.burmester.burmester_curves`); three
give a dyad for every centre point. So a choice is always involved, and this module makes it by
a rule a designer can read:

1. **Candidates.** Five poses: every ordered pair of the dyads (either one may drive). Four:
   centre points sampled along the centre-point curve within ``_REACH`` pose spans of the poses'
   centre. Three: a grid of centre points over the square of side ``2·_REACH`` spans around it.
   Every ordered pair of distinct centre points is a four-bar whose coupler meets the poses.
2. **Screening by closed forms** (all pairs at once): the crank angle at each pose; the motion
   the poses ask of it (one way, each step the short way round; with an input that turns fully,
   the way that visits the poses within one turn); assembly all along it (the distance from the
   crank pin to the output pivot between |r3 − r4| and r3 + r4); the same branch at every pose
   (the side of the coupler on which the output pivot lies); ``crank`` (the input turns fully)
   and the transmission bounds when asked for.
3. **Score** (lower is better): ``size / sin(μ*)``. ``size`` is the largest of the four link
   lengths and the distances of the two ground pivots from the poses' centre, divided by the
   poses' span L (the largest distance between two poses): a compact linkage near its work
   scores low. ``μ*`` is the worst transmission angle over the motion (the angle between the
   coupler and the output link, taken as min(μ, 180° − μ), so 90° is best): ``1/sin μ*`` is how
   much a poor transmission multiplies the force the input must give (1 at 90°, 2 at 30°).
   The motion is the poses' stretch, or the full turn when ``crank`` is asked for.
4. The candidates that pass the screening go, best score first, to the tracker's certificate
   (:func:`loopsolve.design.synthesis.classical.burmester.candidate_four_bar`) and the caller's own check (the user's model);
   the report lists the certified ones with their scores.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ....errors import ModelError
from .burmester import Dyad, PoseFrame, pose_dyads, burmester_curves, parse_poses

__all__ = ["RULE", "Screened", "screen", "candidate_dyads", "REACH"]

#: how far from the poses' centre candidate ground pivots are sought (in pose spans)
REACH = 3.0
_GRID = 16  # three poses: centre points per side of the grid
_CURVE = 120  # four poses: centre points sampled along the curve
_SAMPLES = 120  # points of the screened motion

RULE = ("certified designs first (with --crank: the input turns fully; with --transmission: the transmission "
        "angle within the bounds); then the lowest score = size / sin(mu*), size = the largest of the link "
        "lengths and the ground pivots' distances from the poses' centre divided by the poses' span, mu* = the "
        "worst transmission angle over the motion folded to [0, 90] deg (the poses' stretch, the full turn with "
        "--crank)")


def candidate_dyads(poses) -> list[Dyad]:
    """The dyads candidates are made of: the Ball–Burmester points (five poses), centre-point-curve samples
    (four) or a grid of centre points (three); world coordinates, angles of ``poses`` in degrees."""
    poses = parse_poses(poses)
    n = len(poses)
    if n == 5:
        return pose_dyads(poses)
    fr = PoseFrame(poses)
    c, L = fr.c, fr.s
    if n == 4:
        cu = burmester_curves(poses, samples=480)
        m = cu.center
        ok = np.isfinite(m).all(axis=1) & (np.hypot(*(m - c).T) <= REACH * L)
        m = m[ok]
        if not len(m):
            return []
        # even spacing along the curve's pieces inside the reach: by cumulative arc length
        step = np.r_[0.0, np.hypot(*np.diff(m, axis=0).T)]
        step = np.where(step > 0.25 * L, 0.0, step)  # a jump between pieces is not length
        s = np.cumsum(step)
        idx = np.unique(np.searchsorted(s, np.linspace(0, s[-1], _CURVE)).clip(0, len(m) - 1)) if s[-1] > 0 \
            else np.arange(min(len(m), _CURVE))
        centers = m[idx]
    elif n == 3:
        g = np.linspace(-REACH, REACH, _GRID) * L
        centers = np.array([(c[0] + a, c[1] + b) for a in g for b in g])
    else:
        raise ModelError(f"Burmester synthesis needs three, four or five poses (got {n})")
    mn = (centers - fr.c) / fr.s
    rows = fr.rows(mn, tuple(range(1, n)))  # (N, n-1, 3)
    A, rhs = rows[..., :2], -rows[..., 2]
    out = []
    for i in range(len(mn)):
        k, *_ = np.linalg.lstsq(A[i], rhs[i], rcond=None)
        w = fr.p + np.einsum("jab,b->ja", fr.R, k)
        d = np.hypot(*(w - mn[i]).T)
        if not np.all(np.isfinite(d)) or d.max() - d.min() > 1e-7 * max(1.0, d.max()) or d[0] < 1e-6:
            continue
        kc = fr.s * k
        out.append(Dyad((float(centers[i][0]), float(centers[i][1])), (float(kc[0]), float(kc[1])),
                        float(fr.s * d[0])))
    return out


@dataclass(frozen=True)
class Screened:
    """The screening of ordered dyad pairs ``(i, j)`` (i drives): arrays, one entry per pair."""

    pairs: np.ndarray  # (M, 2)
    lengths: np.ndarray  # (M, 4): ground, crank, coupler, output
    crank: np.ndarray  # (M,) the input turns fully
    feasible: np.ndarray  # (M,)
    direction: np.ndarray  # (M,)
    size: np.ndarray  # (M,)
    mu: np.ndarray  # (M, 2) min and max transmission angle over the motion (degrees)
    worst: np.ndarray  # (M,) mu* (degrees)
    score: np.ndarray  # (M,) inf where not feasible
    why: list  # (M,) the first reason a pair fails the screening ("" when feasible)
    raw: np.ndarray = None  # (M,) the score whatever the screening says (the certificate decides)


def screen(poses, dyads, *, crank: bool = False, transmission=None) -> Screened:
    """Closed-form screening and score of every ordered pair of ``dyads`` (see the module docstring)."""
    poses = parse_poses(poses)
    n = len(poses)
    D = len(dyads)
    pairs = np.array([(i, j) for i in range(D) for j in range(D) if i != j], dtype=int).reshape(-1, 2)
    M = len(pairs)
    if M == 0:
        e = np.zeros(0)
        return Screened(pairs, np.zeros((0, 4)), e.astype(bool), e.astype(bool), e, e, np.zeros((0, 2)), e, e, [], e)
    C = np.array([d.center for d in dyads], dtype=float)
    K = np.array([d.circle for d in dyads], dtype=float)
    rho = np.array([d.radius for d in dyads], dtype=float)
    P = poses[:, :2]
    phi = np.radians(poses[:, 2])
    R = np.stack([np.stack([np.cos(phi), -np.sin(phi)], -1), np.stack([np.sin(phi), np.cos(phi)], -1)], -2)
    pins = P[None] + np.einsum("jab,db->dja", R, K)  # (D, n, 2): every dyad's pin at every pose
    a, b = pairs[:, 0], pairs[:, 1]
    O2, O4 = C[a], C[b]
    A, B = pins[a], pins[b]  # (M, n, 2)
    r1 = np.hypot(*(O4 - O2).T)
    r2, r4 = rho[a], rho[b]
    r3 = np.hypot(*(B[:, 0] - A[:, 0]).T)
    lengths = np.stack([r1, r2, r3, r4], axis=1)
    span = max(float(np.max(np.hypot(*(P[:, None] - P[None]).transpose(2, 0, 1)))), 1e-300)
    centre = P.mean(axis=0)
    size = np.max(np.stack([r1, r2, r3, r4, np.hypot(*(O2 - centre).T), np.hypot(*(O4 - centre).T)]), axis=0) / span
    th = np.arctan2(A[..., 1] - O2[:, None, 1], A[..., 0] - O2[:, None, 0])  # (M, n) crank angle at each pose
    steps = np.remainder(np.diff(th, axis=1) + math.pi, 2 * math.pi) - math.pi  # the short way round
    turns = (np.abs(r1 - r2) >= np.abs(r3 - r4) - 1e-12) & (r1 + r2 <= r3 + r4 + 1e-12)
    why = [""] * M
    # the direction and the total turn of the motion
    fwd = np.sum(np.remainder(steps, 2 * math.pi), axis=1)
    bwd = np.sum(np.remainder(-steps, 2 * math.pi), axis=1)
    d_crank = np.where(fwd <= bwd, 1.0, -1.0)
    total_crank = np.minimum(fwd, bwd)
    d0 = np.where(steps[:, 0] >= 0, 1.0, -1.0)
    mono = np.all(steps * d0[:, None] > 0, axis=1)
    direction = np.where(turns, d_crank, d0)
    total = np.where(turns, total_crank, np.abs(np.sum(steps, axis=1)))
    feasible = np.where(turns, total_crank < 2 * math.pi - 1e-9, mono)
    for m in np.flatnonzero(~feasible):
        why[m] = "order"
    # the branch: the side of the coupler line A->B on which O4 lies, at every pose
    side = np.sign((B[..., 0] - A[..., 0]) * (O4[:, None, 1] - A[..., 1])
                   - (B[..., 1] - A[..., 1]) * (O4[:, None, 0] - A[..., 0]))
    same = np.all(side == side[:, :1], axis=1) & (side[:, 0] != 0)
    for m in np.flatnonzero(feasible & ~same):
        why[m] = "branch"
    feasible &= same
    # the motion: the poses' stretch, or the full turn with --crank
    span_t = np.where(crank & turns, 2 * math.pi, total)
    t = np.linspace(0.0, 1.0, _SAMPLES)
    ang = th[:, :1] + direction[:, None] * span_t[:, None] * t[None, :]  # (M, S)
    Ax = O2[:, 0:1] + r2[:, None] * np.cos(ang)
    Ay = O2[:, 1:2] + r2[:, None] * np.sin(ang)
    d2 = (Ax - O4[:, 0:1]) ** 2 + (Ay - O4[:, 1:2]) ** 2
    r3c, r4c = r3[:, None], r4[:, None]
    with np.errstate(invalid="ignore", divide="ignore"):
        cos_mu = (r3c ** 2 + r4c ** 2 - d2) / (2 * r3c * r4c)
    inside = np.all(np.abs(cos_mu) <= 1 + 1e-12, axis=1)
    for m in np.flatnonzero(feasible & ~inside):
        why[m] = "branch"  # a limit (toggle) position on the way
    feasible &= inside
    mu = np.degrees(np.arccos(np.clip(cos_mu, -1, 1)))
    mu_rng = np.stack([mu.min(axis=1), mu.max(axis=1)], axis=1)
    worst = np.min(np.minimum(mu, 180.0 - mu), axis=1)
    if crank:
        for m in np.flatnonzero(feasible & ~turns):
            why[m] = "crank"
        feasible &= turns
    if transmission is not None:
        lo, hi = transmission
        okt = (mu_rng[:, 0] >= lo) & (mu_rng[:, 1] <= hi)
        for m in np.flatnonzero(feasible & ~okt):
            why[m] = "transmission"
        feasible &= okt
    with np.errstate(divide="ignore"):
        raw = np.where(worst > 0, size / np.sin(np.radians(worst)), np.inf)
    score = np.where(feasible, raw, np.inf)
    return Screened(pairs, lengths, turns, feasible, direction, size, mu_rng, worst, score, why, raw)
