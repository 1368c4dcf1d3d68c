"""Burmester theory: four-bars whose coupler passes through given poses, checked by the tracker.

A pose is ``(x, y, angle)``: where a coupler point P is and how the coupler is turned. A point
fixed in the coupler has moving-frame coordinates k (from P, in the coupler's frame) and sits at
``wⱼ = pⱼ + R(φⱼ) k`` in pose j. A *dyad* is a ground pivot (centre point) m and a coupler pin
(circle point) k whose positions stay on one circle about m: ``|wⱼ − m|`` is the same for every
pose. Subtracting pose 0's equation from pose j's leaves, for a given m, equations *linear* in k::

    aⱼ(m)·k + cⱼ(m) = 0,   aⱼ = 2 (R_jᵀ(pⱼ − m) − R_0ᵀ(p₀ − m)),   cⱼ = |pⱼ − m|² − |p₀ − m|²,

with aⱼ and cⱼ linear in m. Three poses give k for every m. Four poses give three equations in
two unknowns: they are compatible where ``det[aⱼ cⱼ]`` (j = 1, 2, 3) vanishes, a cubic in m — the
*centre-point curve*; the k that go with its points form the *circle-point curve*. The cubic passes
through the pole P₀₁ (where row 1 vanishes), so every line through P₀₁ meets it in at most two
more points: the curve is traced as the roots of a quadratic along the pencil of lines. Five
poses: the points of the four-pose curve where the fifth pose's compatibility also holds — the
*Ball–Burmester points*, up to four real ones (the other common points of the two cubics are
poles and the circular points at infinity, rejected because there the full system has no
solution). Each is polished by Newton on the full system; every pair of dyads is a four-bar.

Each four-bar is built as a model (ground pivots at the two centre points, input the first dyad's
crank angle ``theta2``, coupler angle ``phi`` equal to the poses' angle, point ``P``) and moved by
the tracker from each pose to the next: the defects (``circuit``, ``branch``, ``order``) and the
Grashof class say which candidates can do the job in one motion.

References: Sandor & Erdman, *Advanced Mechanism Design* (1984), ch. 3; McCarthy & Soh,
*Geometric Design of Linkages* (2011), ch. 4-5.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

import numpy as np

from ....kinematics.classic import GrashofClass, grashof
from ....errors import ModelError
from .verdict import Defect, circuit_sign, track_between

__all__ = ["Dyad", "BurmesterCurves", "FourBarCandidate", "BurmesterResult", "burmester", "burmester_curves",
           "dyad_for_center", "four_bar", "parse_poses"]


def _rot(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s], [s, c]])


def parse_poses(poses) -> np.ndarray:
    """Poses as an ``(n, 3)`` array ``x, y, angle`` (degrees); refuses malformed input."""
    try:
        arr = np.array(poses, dtype=float)
    except (TypeError, ValueError):
        raise ModelError("poses: expected rows of three numbers x, y, angle (degrees)") from None
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ModelError(f"poses: expected rows of three numbers x, y, angle (degrees), got shape {arr.shape}")
    if not np.isfinite(arr).all():
        raise ModelError("poses: every x, y, angle must be a finite number")
    _refuse_repeated(arr)
    return arr


def _refuse_repeated(arr) -> None:
    """Two equal poses (the angle modulo a turn; positions to 1e-9 of the poses' span) make Burmester's
    compatibility equations identically zero: refused, naming them (1-based, in the given order)."""
    n = len(arr)
    if n < 2:
        return
    if n <= 500:  # every pair, to a tolerance
        span = float(np.max(np.linalg.norm(arr[:, None, :2] - arr[None, :, :2], axis=-1)))
        dp = np.hypot(arr[:, None, 0] - arr[None, :, 0], arr[:, None, 1] - arr[None, :, 1])
        da = np.abs(np.remainder(arr[:, None, 2] - arr[None, :, 2] + 180.0, 360.0) - 180.0)
        hit = np.argwhere(np.triu((dp <= 1e-9 * span) & (da <= 1e-9), 1))
    else:  # many poses: exact repeats, by sorting
        key = np.column_stack([arr[:, :2], np.mod(arr[:, 2], 360.0)])
        order = np.lexsort(key.T[::-1])
        same = np.flatnonzero(np.all(np.diff(key[order], axis=0) == 0, axis=1))
        hit = np.sort(np.column_stack([order[same], order[same + 1]]), axis=1) if same.size else np.zeros((0, 2))
    if len(hit):
        i, j = (int(v) for v in min(map(tuple, hit)))
        raise ModelError(f"poses {i + 1} and {j + 1} are the same pose (x, y, angle = "
                         f"{', '.join(f'{v:g}' for v in arr[i])}): Burmester's equations are then identically zero; "
                         "give distinct poses")


class PoseFrame:
    """Poses normalized: centroid at the origin, unit size (results are mapped back)."""

    def __init__(self, poses):
        self.c = poses[:, :2].mean(axis=0)
        d = np.linalg.norm(poses[:, None, :2] - poses[None, :, :2], axis=-1).max()
        self.s = float(d) if d > 0 else 1.0
        self.p = (poses[:, :2] - self.c) / self.s
        self.phi = np.radians(poses[:, 2])
        self.R = np.array([_rot(a) for a in self.phi])

    def rows(self, m, idx):
        """``[aⱼ | cⱼ]`` rows for poses ``idx`` at centre points ``m`` (..., 2): shape (..., len(idx), 3)."""
        m = np.asarray(m, dtype=float)
        p0, R0 = self.p[0], self.R[0]
        out = []
        for j in idx:
            pj, Rj = self.p[j], self.R[j]
            a = 2 * ((pj - m) @ Rj - (p0 - m) @ R0)  # (p - m) @ R = Rᵀ(p - m)
            c = np.sum((pj - m) ** 2, axis=-1) - np.sum((p0 - m) ** 2, axis=-1)
            out.append(np.concatenate([a, c[..., None]], axis=-1))
        return np.stack(out, axis=-2)

    def order(self, n: int) -> tuple[int, ...]:
        """Poses 1 … n−1 with first one whose angle differs from pose 0's (its pole is finite)."""
        turned = [j for j in range(1, n) if abs(math.remainder(self.phi[j] - self.phi[0], 2 * math.pi)) > 1e-9]
        if not turned:
            raise ModelError("every pose has the same angle (a pure translation): Burmester's circle points are "
                             "at infinity; give poses that turn the coupler")
        return (turned[0],) + tuple(j for j in range(1, n) if j != turned[0])

    def compat(self, m, idx):
        return np.linalg.det(self.rows(m, idx))

    def pole(self, i, j):
        """The pole of poses i, j (normalized world coordinates); None for a pure translation."""
        A = self.R[i] - self.R[j]
        if abs(np.linalg.det(A)) < 1e-12:
            return None
        q = np.linalg.solve(A, self.p[j] - self.p[i])
        return self.p[i] + self.R[i] @ q

    def circle_point(self, m, idx):
        """k (normalized moving frame) for centre point m from the rows ``idx`` (least squares)."""
        r = self.rows(m, idx)
        k, *_ = np.linalg.lstsq(r[:, :2], -r[:, 2], rcond=None)
        return k


def _pencil(fr: PoseFrame, idx, n: int = 1440, psi=None):
    """The centre-point curve of rows ``idx`` along the lines through the pole P₀ⱼ (first of idx).

    Returns (psi, pts) with pts (n, 2, 2): the two curve points on each line (NaN where none).
    """
    P = fr.pole(0, idx[0])
    if P is None:
        raise ModelError("the first two poses of the pencil have the same angle")
    psi = np.linspace(0.0, math.pi, n, endpoint=False) if psi is None else np.atleast_1d(psi)
    n = len(psi)
    u = np.stack([np.cos(psi), np.sin(psi)], axis=-1)
    ts = np.array([1.0, -1.0, 2.0])
    f = np.stack([fr.compat(P + t * u, idx) for t in ts], axis=-1)  # f(t) = c1 t + c2 t² + c3 t³
    V = np.array([[t, t * t, t ** 3] for t in ts])
    c = np.linalg.solve(V, f.T).T  # (n, 3)
    c1, c2, c3 = c[:, 0], c[:, 1], c[:, 2]
    scale = np.abs(c).max(axis=1) + 1e-300
    pts = np.full((n, 2, 2), np.nan)
    disc = c2 * c2 - 4 * c3 * c1
    with np.errstate(invalid="ignore", divide="ignore"):
        # the root formulas that stay accurate when c3 -> 0 (a point runs off to infinity)
        q = -0.5 * (c2 + np.where(c2 >= 0, 1.0, -1.0) * np.sqrt(np.maximum(disc, 0.0)))
        roots = (q / np.where(np.abs(c3) > 1e-14 * scale, c3, np.nan), c1 / np.where(q != 0, q, np.nan))
    for b, t in enumerate(roots):
        ok = (disc >= 0) & np.isfinite(t)
        pts[ok, b] = P + t[ok, None] * u[ok]
    return psi, pts, P


@dataclass(frozen=True)
class BurmesterCurves:
    """Centre-point and circle-point curves of four poses (model length unit), as polylines.

    ``center[i]`` (a ground pivot) goes with ``circle[i]`` (the coupler pin in the first pose,
    world coordinates) and ``circle_moving[i]`` (the same pin in the coupler's frame, from P).
    Rows of NaN separate the pieces of the curves.

    Users receive the curves from :func:`loopsolve.burmester_curves`; they need not construct them.

    Parameters
    ----------
    center, circle, circle_moving : numpy.ndarray
        ``(N, 2)`` polylines: ground pivots, coupler pins in the first pose (world coordinates),
        the same pins in the coupler's frame (from P); model length unit.
    poles : numpy.ndarray
        ``(K, 2)``: the finite poles P12, P13, P14, P23, P24, P34 of the four poses (K ≤ 6).

    Attributes
    ----------
    center, circle, circle_moving, poles
        As the parameters of the same names.

    Examples
    --------
    >>> import loopsolve as ls
    >>> mech = ls.fourbar(60, 25, 70, 45)
    >>> poses = [(s["C_x"], s["C_y"], s["theta3"]) for s in (mech.solve(a) for a in (20, 70, 120, 170))]
    >>> curves = ls.burmester_curves(poses)
    >>> curves.center.shape[1], curves.poles.shape
    (2, (6, 2))
    """

    center: np.ndarray = field(repr=False)
    circle: np.ndarray = field(repr=False)
    circle_moving: np.ndarray = field(repr=False)
    poles: np.ndarray = field(repr=False)


def burmester_curves(poses, *, samples: int = 1440) -> BurmesterCurves:
    """The centre-point and circle-point curves of four poses ``(x, y, angle_deg)``.

    Examples
    --------
    >>> from loopsolve.design.synthesis.classical.burmester import burmester_curves
    >>> c = burmester_curves([(0, 0, 0), (1, 0.2, 10), (1.8, 0.7, 25), (2.2, 1.5, 45)])
    >>> c.center.shape[1], bool(np.isfinite(c.center).sum() > 1000)
    (2, True)
    """
    poses = parse_poses(poses)
    if len(poses) != 4:
        raise ModelError(f"centre-point and circle-point curves need exactly four poses (got {len(poses)})")
    fr = PoseFrame(poses)
    idx3 = fr.order(4)
    psi, pts, _ = _pencil(fr, idx3, samples)
    for _ in range(10):  # refine the lines' angles where the curve moves fast (near the pencil's pole)
        a, b = pts[:-1], pts[1:]
        step = np.minimum(np.hypot(*(b - a).transpose(2, 0, 1)).max(axis=1),
                          np.hypot(*(b[:, ::-1] - a).transpose(2, 0, 1)).max(axis=1))
        need = np.isfinite(step) & (step > 0.01) & (np.linalg.norm(np.nan_to_num(a), axis=2).max(axis=1) < 50)
        if not need.any() or len(psi) > 16 * samples:
            break
        psi = np.sort(np.r_[psi, 0.5 * (psi[:-1] + psi[1:])[need]])
        pts = _pencil(fr, idx3, psi=psi)[1]
    pts = np.where((np.linalg.norm(pts, axis=2) > 50)[..., None], np.nan, pts)  # beyond 50 pose spans: cut
    for i in range(1, len(pts)):  # keep each piece on one root: swap where that is nearer the previous line's
        a, b = pts[i - 1], pts[i]
        same = np.nansum(np.hypot(*(b - a).T))
        swap = np.nansum(np.hypot(*(b[::-1] - a).T))
        if swap < same and np.isfinite(b).all() and np.isfinite(a).all():
            pts[i] = b[::-1]
    centers, circles, moving = [], [], []
    for b in range(2):
        m = pts[:, b]
        ks = np.full_like(m, np.nan)
        good = np.flatnonzero(np.isfinite(m[:, 0]))
        if len(good):  # the three equations agree on the curve: least squares by the normal equations
            r = fr.rows(m[good], idx3)
            A, c = r[..., :2], -r[..., 2]
            AtA = np.einsum("nji,njk->nik", A, A)
            ok = np.abs(np.linalg.det(AtA)) > 1e-14 * np.einsum("nii->n", AtA) ** 2
            ks[good[ok]] = np.linalg.solve(AtA[ok], np.einsum("nji,nj->ni", A[ok], c[ok])[..., None])[..., 0]
        w = fr.p[0] + ks @ fr.R[0].T
        # break the polylines where a piece runs off towards an asymptote (a jump between lines)
        jump = np.r_[False, np.hypot(*(m[1:] - m[:-1]).T) > 0.25]
        for piece in np.split(np.arange(len(m)), np.flatnonzero(jump)):
            for lst, arr in ((centers, m), (moving, ks), (circles, w)):
                lst.append(arr[piece])
                lst.append(np.full((1, 2), np.nan))
    poles = [fr.pole(i, j) for i, j in itertools.combinations(range(4), 2)]
    poles = np.array([p for p in poles if p is not None])
    back = lambda a: fr.c + fr.s * a  # noqa: E731
    return BurmesterCurves(back(np.concatenate(centers)), back(np.concatenate(circles)),
                           fr.s * np.concatenate(moving), back(poles))


@dataclass(frozen=True, slots=True)
class Dyad:
    """Ground pivot ``center`` (world), coupler pin ``circle`` (coupler frame, from P), radius."""

    center: tuple[float, float]
    circle: tuple[float, float]
    radius: float

    def pin(self, pose) -> np.ndarray:
        """The coupler pin's world position in pose ``(x, y, angle_deg)``."""
        x, y, a = pose
        return np.array([x, y]) + _rot(math.radians(a)) @ np.array(self.circle)


def pose_dyads(poses) -> list[Dyad]:
    fr = PoseFrame(poses)
    o = fr.order(5)
    idx3, idx4 = o[:3], o[:2] + o[3:]
    psi, pts, P = _pencil(fr, idx3, 2880)
    seeds = []
    g = np.stack([fr.compat(np.nan_to_num(pts[:, b]), idx4) for b in range(2)], axis=1)
    g = np.where(np.isfinite(pts[:, :, 0]), g, np.nan)
    for i in range(len(psi) - 1):  # sign changes of g between curve points of neighbouring lines
        for b in range(2):
            for b2 in range(2):
                ma, mb = pts[i, b], pts[i + 1, b2]
                ga, gb = g[i, b], g[i + 1, b2]
                if not (np.isfinite(ga) and np.isfinite(gb) and ga * gb <= 0):
                    continue
                if b == b2:  # the same root formula: bisect on the line's angle
                    lo, hi = psi[i], psi[i + 1]
                    for _ in range(48):
                        mid = 0.5 * (lo + hi)
                        mm = _pencil(fr, idx3, psi=mid)[1][0, b]
                        if not np.isfinite(mm).all():
                            break
                        gm = fr.compat(mm, idx4)
                        if gm * ga <= 0:
                            hi = mid
                        else:
                            lo, ga = mid, gm
                    mm = _pencil(fr, idx3, psi=0.5 * (lo + hi))[1][0, b]
                    seeds.append(mm if np.isfinite(mm).all() else ma)
                elif np.linalg.norm(ma - mb) < 0.5 + 0.1 * np.linalg.norm(ma):
                    w = ga / (ga - gb) if ga != gb else 0.5
                    seeds.append(ma + w * (mb - ma))
    from scipy.optimize import least_squares

    def eqs(v):
        m, k = v[:2], v[2:]
        w = fr.p + np.einsum("jab,b->ja", fr.R, k)
        d2 = np.sum((w - m) ** 2, axis=1)
        return d2[1:] - d2[0]

    found: list[tuple[np.ndarray, np.ndarray]] = []
    poles = [fr.pole(i, j) for i, j in itertools.combinations(range(len(poses)), 2)]
    for m0 in seeds:
        if not np.isfinite(m0).all():
            continue
        k0 = fr.circle_point(m0, (1, 2, 3, 4))
        sol = least_squares(eqs, np.r_[m0, k0], method="lm", xtol=1e-15, ftol=1e-15, gtol=1e-15)
        m, k = sol.x[:2], sol.x[2:]
        if np.abs(eqs(sol.x)).max() > 1e-10 or np.linalg.norm(m) > 1e3:
            continue
        r = fr.rows(m, (1, 2, 3, 4))
        if np.linalg.matrix_rank(r[:, :2], tol=1e-7) < 2:  # a pole: k is not determined there
            continue
        if any(p is not None and np.linalg.norm(m - p) < 1e-7 for p in poles):
            continue
        rho = float(np.linalg.norm(fr.p[0] + fr.R[0] @ k - m))
        if rho < 1e-9:
            continue
        if not any(np.linalg.norm(m - m2) < 1e-7 and np.linalg.norm(k - k2) < 1e-7 for m2, k2 in found):
            found.append((m, k))
    out = []
    for m, k in found:
        mc = fr.c + fr.s * m
        kc = fr.s * k
        rho = float(np.linalg.norm(fr.c + fr.s * (fr.p[0] + fr.R[0] @ k) - mc))
        out.append(Dyad((float(mc[0]), float(mc[1])), (float(kc[0]), float(kc[1])), rho))
    out.sort(key=lambda d: (d.center[0], d.center[1]))
    return out


@dataclass(frozen=True)
class FourBarCandidate:
    """A four-bar from two dyads: the driving dyad's pivot is O2 (``theta2``), the other's O4.

    ``lengths`` = (ground, crank, coupler, rocker); ``inputs`` the crank angle (degrees) at each
    pose; ``pose_errors`` √(|P − T|² + (L·Δφ)²) at each pose where the tracked motion arrives
    (L the largest distance between two poses, Δφ in radians: the synthesis contract's motion
    objective is the sum of their squares; NaN where it does not arrive, null in ``to_dict``);
    ``defects`` empty means certified: one motion of the input, in ``mode``, crossing no limit,
    meets the poses in order. ``certificate`` is the synthesis contract's dict.
    """

    dyads: tuple[int, int]
    mechanism: object
    lengths: tuple[float, float, float, float]
    grashof: GrashofClass
    mode: str
    direction: int
    inputs: tuple[float, ...]
    pose_errors: tuple[float, ...]
    defects: tuple[Defect, ...]

    @property
    def certified(self) -> bool:
        return not self.defects

    @property
    def certificate(self) -> dict:
        from ..certificate import flags, sort_defects

        kinds = {d.kind for d in self.defects}
        return {**flags(kinds), "grashof": self.grashof.value, "mode": self.mode,
                "direction": self.direction, "defects": sort_defects(kinds)}

    def to_dict(self) -> dict:
        return {"dyads": list(self.dyads), "lengths": list(self.lengths), "grashof": self.grashof.value,
                "mode": self.mode, "direction": self.direction, "inputs": list(self.inputs),
                "pose_errors": [e if math.isfinite(e) else None for e in self.pose_errors],  # strict JSON: null
                "certified": self.certified,
                "defects": [d.to_dict() for d in self.defects], "certificate": self.certificate}


@dataclass(frozen=True)
class BurmesterResult:
    """Five-pose Burmester synthesis: the dyads (Ball–Burmester points) and every four-bar.

    Users receive a result from :func:`loopsolve.burmester`; they need not construct one.

    Parameters
    ----------
    poses : numpy.ndarray
        The five poses ``(x, y, angle)`` (model length unit, degrees).
    dyads : tuple of Dyad
        The Ball–Burmester dyads: a ground pivot ``center``, a coupler pin ``circle`` (coupler
        frame, from P) and their ``radius``.
    candidates : tuple of FourBarCandidate
        Every four-bar made of two dyads, with its certificate.

    Attributes
    ----------
    poses, dyads, candidates
        As the parameters of the same names.
    usable : tuple of FourBarCandidate
        The candidates without defects (certified by the tracker).

    Examples
    --------
    Five poses of the coupler of a four-bar; Burmester finds that four-bar among others:

    >>> import loopsolve as ls
    >>> mech = ls.fourbar(60, 25, 70, 45)
    >>> poses = [(s["C_x"], s["C_y"], s["theta3"]) for s in (mech.solve(a) for a in (20, 70, 120, 170, 220))]
    >>> res = ls.burmester(poses)
    >>> len(res.dyads), len(res.candidates), len(res.usable)
    (4, 6, 4)
    """

    poses: np.ndarray = field(repr=False)
    dyads: tuple[Dyad, ...]
    candidates: tuple[FourBarCandidate, ...]

    @property
    def usable(self) -> tuple[FourBarCandidate, ...]:
        """The candidates without defects (certified by the tracker)."""
        return tuple(c for c in self.candidates if c.certified)

    def to_dict(self) -> dict:
        return {"method": "burmester", "poses": self.poses.tolist(),
                "dyads": [{"center": list(d.center), "circle": list(d.circle), "radius": d.radius}
                          for d in self.dyads], "candidates": [c.to_dict() for c in self.candidates]}


def _model(da: Dyad, db: Dyad, pose0, name: str, length_unit: str):
    """The four-bar of dyads ``da`` (input) and ``db`` at pose 0, coupler angle ``phi`` = the pose angle."""
    from ....model.builder import MechanismBuilder

    x, y, a = pose0
    A, B = da.pin(pose0), db.pin(pose0)
    m2, m4 = np.array(da.center), np.array(db.center)
    P = np.array([x, y])
    ground, coupler = m4 - m2, B - A
    r1, r3 = float(np.linalg.norm(ground)), float(np.linalg.norm(coupler))
    if r1 < 1e-12 * (1 + da.radius + db.radius) or r3 < 1e-12 * (1 + da.radius + db.radius):
        raise ModelError("two dyads share a pivot or a pin: not a four-bar")
    deg = math.degrees
    t1 = deg(math.atan2(ground[1], ground[0]))
    d3 = deg(math.atan2(coupler[1], coupler[0])) - a
    rp_v = P - A
    rp = float(np.linalg.norm(rp_v))
    gp = deg(math.atan2(rp_v[1], rp_v[0])) - a if rp > 0 else 0.0
    t2 = deg(math.atan2(*(A - m2)[::-1]))
    t4 = deg(math.atan2(*(B - m4)[::-1]))
    b = MechanismBuilder(name, length_unit=length_unit, angle_unit="deg")
    for n, v in (("x0", m2[0]), ("y0", m2[1]), ("r1", r1), ("t1", t1), ("r2", da.radius), ("r3", r3),
                 ("r4", db.radius), ("d3", d3), ("rp", rp), ("gp", gp)):
        b.parameter(n, round(float(v), 12))
    b.variable("theta2", input=True, guess=round(float(t2), 9)).variable("phi", guess=round(float(a), 9))
    b.variable("theta4", guess=round(float(t4), 9))
    b.vector("r0", x="x0", y="y0").vector("r1", length="r1", angle="t1")
    b.vector("r2", length="r2", angle="theta2").vector("r3", length="r3", angle="phi", offset="d3")
    b.vector("r4", length="r4", angle="theta4").vector("rp", length="rp", angle="phi", offset="gp")
    b.loop("r0 + r2 + r3 = r0 + r1 + r4")  # r0 on both sides: the drawing places the pivots off the origin
    b.point("O2", "r0").point("A", "r0 + r2").point("B", "r0 + r2 + r3").point("O4", "r0 + r1")
    b.point("P", "r0 + r2 + rp")
    return b.build(), (r1, da.radius, r3, db.radius), math.radians(t1), math.radians(d3)


def _wrap_deg(a):
    return (a + 180.0) % 360.0 - 180.0


def candidate_four_bar(pair, da: Dyad, db: Dyad, poses, name, length_unit) -> FourBarCandidate:
    mech, lengths, t1, d3 = _model(da, db, poses[0], name, length_unit)
    ck = mech.compile()
    cls = grashof(*lengths)
    zs, inputs = [], []
    for pose in poses:
        A, B = da.pin(pose), db.pin(pose)
        t2 = math.atan2(*(A - np.array(da.center))[::-1])
        t4 = math.atan2(*(B - np.array(db.center))[::-1])
        zs.append(np.array([t2, math.radians(pose[2]), t4]))
        inputs.append(math.degrees(t2))
    sigs = [ck.signature(z) for z in zs]
    span = max(math.dist(a[:2], b[:2]) for a in poses for b in poses)
    circ = [circuit_sign(lengths, (t1, z[0], z[1] + d3, z[2])) for z in zs]
    steps = [_wrap_deg(inputs[j + 1] - inputs[j]) for j in range(len(inputs) - 1)]
    d = 1 if steps[0] >= 0 else -1
    crank = cls in (GrashofClass.CRANK_ROCKER, GrashofClass.DOUBLE_CRANK)
    defects: list[Defect] = []
    if crank:  # the crank may turn either way: the way that meets the poses within one turn
        totals = {dd: sum((dd * s) % 360.0 for s in steps) for dd in (d, -d)}
        if totals[d] >= 360.0 and totals[-d] < 360.0:
            d = -d
        total = totals[d]
        if total >= 360.0:
            defects.append(Defect("order", f"the crank meets the poses in another order: it turns {total:.1f}° "
                                  "(more than one turn) to visit them in the given order", inputs[-1]))
    elif any(s * d <= 0 for s in steps):
        j = next(j for j, s in enumerate(steps) if s * d <= 0)
        defects.append(Defect("order", f"the input turns back between poses {j + 1} and {j + 2} "
                              f"({inputs[j]:.4g}° → {inputs[j + 1]:.4g}°): the poses are not met in order",
                              inputs[j + 1]))
    errors = [0.0]
    if not defects:
        for j in range(1, len(zs)):
            if circ[j] != circ[0]:
                defects.append(Defect("circuit", f"pose {j + 1} lies on the other circuit of this {cls.value} linkage",
                                      inputs[j]))
                errors.append(math.nan)
                continue
            z, lim = track_between(mech, zs[j - 1], inputs[j], direction=d)
            if lim is not None or z is None or sigs[j] != sigs[0]:
                where = f" at input {lim:.6g}°" if lim is not None else ""
                defects.append(Defect("branch", f"between poses {j} and {j + 1} the linkage reaches a limit "
                                      f"position{where}", lim if lim is not None else inputs[j]))
                errors.append(math.nan)
                continue
            pt = ck.point_values(0, z)
            P = np.asarray(pt[ck.points.index("P")], dtype=float)
            # the motion objective's term: |P - T|² + (L·Δφ)², L the largest distance between two poses
            e = math.hypot(math.hypot(*(P - poses[j][:2])),
                           span * math.radians(_wrap_deg(math.degrees(z[1]) - poses[j][2])))
            errors.append(e)
            if e > 1e-6 * (1 + max(lengths)):
                defects.append(Defect("branch", f"the tracked motion misses pose {j + 1}", inputs[j]))
    while len(errors) < len(zs):
        errors.append(math.nan)
    return FourBarCandidate(pair, mech, tuple(float(v) for v in lengths), cls, sigs[0], d, tuple(inputs),
                            tuple(errors), tuple(defects))


def dyad_for_center(poses, center) -> Dyad:
    """The dyad whose ground pivot is ``center``: its coupler pin from the poses' equations.

    Three poses: any centre point has one. Four: ``center`` must lie on the centre-point curve
    (:func:`burmester_curves`); five: be a Ball–Burmester point. Raises :class:`ModelError` when
    the pin's distance to ``center`` is not the same in every pose (to 1e-7 of the poses' span).
    """
    poses = parse_poses(poses)
    if len(poses) < 3:
        raise ModelError(f"a dyad through poses needs at least three poses (got {len(poses)})")
    fr = PoseFrame(poses)
    m = (np.asarray(center, dtype=float) - fr.c) / fr.s
    k = fr.circle_point(m, tuple(range(1, len(poses))))
    w = fr.p + np.einsum("jab,b->ja", fr.R, k)
    d = np.hypot(*(w - m).T)
    if d.max() - d.min() > 1e-7 * max(1.0, d.max()):
        raise ModelError(f"centre point {tuple(float(v) for v in center)} is not a centre point of these poses: the "
                         f"pin's distance varies by {fr.s * (d.max() - d.min()):.3g} (pick a point of the centre-point "
                         "curve)")
    mc, kc = fr.c + fr.s * m, fr.s * k
    return Dyad((float(mc[0]), float(mc[1])), (float(kc[0]), float(kc[1])), float(fr.s * d[0]))


def four_bar(poses, center_a, center_b, *, length_unit: str = "mm",
             name: str = "Burmester four-bar") -> FourBarCandidate:
    """The four-bar with ground pivots ``center_a`` (input) and ``center_b``, checked through the poses.

    For three or four poses, where the centre points are a choice (any point, or points of the
    centre-point curve); the candidate carries the tracker's defects like :func:`burmester`'s.

    Examples
    --------
    >>> from loopsolve.design.synthesis.classical.burmester import four_bar
    >>> poses = [(0, 0, 0), (1, 0.2, 10), (1.8, 0.7, 25)]
    >>> c = four_bar(poses, (-1.0, -2.0), (3.0, -1.5))
    >>> len(c.inputs), c.mechanism.name
    (3, 'Burmester four-bar')
    """
    poses = parse_poses(poses)
    da, db = dyad_for_center(poses, center_a), dyad_for_center(poses, center_b)
    return candidate_four_bar((0, 1), da, db, poses, name, length_unit)


def burmester(poses, *, length_unit: str = "mm", name: str = "Burmester four-bar") -> BurmesterResult:
    """Five poses → Ball–Burmester dyads → every four-bar, each with the tracker's defects.

    Parameters
    ----------
    poses : sequence of (x, y, angle)
        Five poses of the coupler point P and the coupler angle (degrees), in the order the
        linkage must meet them.

    Returns
    -------
    BurmesterResult
        ``dyads`` (up to four real), ``candidates`` (a four-bar per pair of dyads, driven by the
        dyad that gives the fewest defects; first the certified ones), ``usable``.

    Raises
    ------
    ModelError
        Not five poses, malformed poses, or poses that all have the same angle.

    Examples
    --------
    >>> res = ls.burmester([(0, 0, 0), (1, 0.2, 10), (1.8, 0.7, 25), (2.2, 1.5, 45), (2.3, 2.4, 70)])
    >>> len(res.dyads) in (0, 2, 4), len(res.candidates) == len(res.dyads) * (len(res.dyads) - 1) // 2
    (True, True)
    """
    poses = parse_poses(poses)
    if len(poses) != 5:
        raise ModelError(f"Burmester synthesis needs exactly five poses (got {len(poses)}); four poses give the "
                         "centre-point and circle-point curves (burmester_curves)")
    dyads = pose_dyads(poses)
    cands = []
    for i, j in itertools.combinations(range(len(dyads)), 2):
        options = []
        for a, b in ((i, j), (j, i)):
            try:
                options.append(candidate_four_bar((a, b), dyads[a], dyads[b], poses, name, length_unit))
            except ModelError:
                continue
        if options:
            cands.append(min(options, key=lambda c: (len(c.defects), c.grashof is not GrashofClass.CRANK_ROCKER)))
    cands.sort(key=lambda c: (not c.certified, len(c.defects)))
    return BurmesterResult(poses, tuple(dyads), tuple(cands))
