"""Curve descriptors free of position, orientation, scale and starting point, and the placement they remove.

Pure numpy, no model: curves are ``(K, 2)`` arrays of points (or ``(E, K, 2)`` for many), in any
length unit. Used by the atlas (:mod:`loopsolve.design.atlas.build`) to store every design's curve and by
shape synthesis (:mod:`loopsolve.design.synthesis.shape.run`) to match a drawn curve against it.

Closed curves: elliptic Fourier descriptors (Kuhl & Giardina 1982)
------------------------------------------------------------------
A closed polygon p_0 … p_{K−1} (p_K = p_0) is a curve x(t), y(t) parametrized by arc length
t ∈ [0, L) (L its perimeter), linear on every side. Its Fourier series

    x(t) = A0 + Σ_n a_n cos(2πnt/L) + b_n sin(2πnt/L),   y(t) = C0 + Σ_n c_n cos(…) + d_n sin(…)

has the closed-form coefficients of Kuhl & Giardina (Computer Graphics and Image Processing 18,
1982, eq. 6–7): with Δx_p, Δy_p, Δt_p the p-th side and t_p = Δt_1 + … + Δt_p,

    a_n = L / (2n²π²) Σ_p Δx_p/Δt_p (cos 2πn t_p/L − cos 2πn t_{p−1}/L)       (b_n: sin; c_n, d_n: Δy)

and (A0, C0) the centroid of the polygon as a wire of uniform density. Harmonic n is an ellipse
traced n times. The normalization (their section 4) removes, in this order:

1. **starting point**: the parameter is shifted by θ₁ = ½ atan2(2(a₁b₁ + c₁d₁), a₁² + c₁² − b₁² − d₁²)
   so that t = 0 is at an end of the first harmonic's major axis; harmonic n turns by nθ₁;
2. **orientation**: ψ₁ = atan2(c₁*, a₁*), the major axis' direction, is rotated onto +x;
3. **scale**: every coefficient is divided by E = √(a₁*² + c₁*²), the semi-major axis;
4. **position**: A0, C0 are dropped.

Afterwards a₁ = 1, b₁ = c₁ = 0 and d₁ = ±(minor/major axis): positive when the curve runs
counterclockwise. The descriptor is (d₁, a_n, b_n, c_n, d_n for n = 2 … H): 4H − 3 numbers.

**Ambiguities.** (i) θ₁ + π is the other end of the same major axis and is as good a start:
it multiplies harmonic n by (−1)ⁿ and turns ψ₁ by π, which multiplies every coefficient by −1,
so the second normalization is the first with harmonic n multiplied by (−1)^(n+1) (even
harmonics change sign). Which of the two a rule picks jumps with tiny changes of a curve, so a
query compares the target in *both* variants with the stored one (:func:`efd_variants`).
(ii) When the first harmonic is a circle (minor/major → 1) θ₁ and ψ₁ are undefined and the
descriptor of a nearly circular curve changes fast with noise; :func:`efd_normalize` returns
the ratio |d₁| so a caller can tell (shape synthesis then ranks by :func:`procrustes` alone).
(iii) Direction: running the curve the other way (t → L − t) negates b_n and d_n; a match free
in timing compares both directions.

Open curves: arc length and principal axes
-------------------------------------------
An open curve is resampled at n points equally spaced in arc length (:func:`resample`), moved
to its centroid, divided by its RMS distance from the centroid and rotated so that its
principal axis (the covariance's major eigenvector) is +x (:func:`open_normalize`). Its
ambiguities are the axis' sign (a half turn) and the direction (the reversed point order):
:func:`open_distance` is the smallest distance over the four, so a curve and its reverse have
distance 0. Shape synthesis matches an open target against *stretches* of the stored curves
with :func:`procrustes`, which needs no axis at all.

Procrustes matching
-------------------
Two point lists w, t (complex numbers, t centred with ‖t‖ = 1) paired point by point are as
close as a similarity allows when min_a ‖a(w − w̄) − t‖² = 1 − |⟨w − w̄, t⟩|² / ‖w − w̄‖²
(a complex: rotation and scale); the square root of that, in [0, 1], is the distance used.
:func:`procrustes` evaluates it for every window of every stored curve at once (every start
point and several stretch lengths), which makes it free of the starting point as well.

Placement
---------
Every normalization returns what it removed — centre (x, y), rotation ``angle`` (radians),
``scale`` and, for EFD, the start ``theta`` (radians of the first harmonic, i.e. arc length
θL/2π) — so that ``curve = (x, y) + scale · R(angle) · normalized``.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import fft as _fft

from ...errors import ModelError

__all__ = ["check_curve", "resample", "resample_many", "efd", "efd_normalize", "efd_descriptor", "efd_variants",
           "open_normalize", "open_normalize_many", "open_distance", "procrustes", "procrustes_both", "MIN_POINTS"]

#: fewest points of a target curve (the contract: any number of points ≥ 5)
MIN_POINTS = 5


# ----------------------------------------------------------------------------- checks


def check_curve(xy, *, closed: bool, where: str = "curve") -> np.ndarray:
    """A target curve ``(K, 2)`` checked: enough points, finite, no repeated consecutive points, not degenerate.

    For a closed curve a last point equal to the first (the curve drawn back to its start) is
    dropped. Raises :class:`~loopsolve.errors.ModelError` naming the row and what to do.
    """
    a = np.asarray(xy, dtype=float)
    if a.ndim != 2 or a.shape[1] != 2:
        raise ModelError(f"{where}: expected rows of x,y, got shape {a.shape}")
    bad = np.flatnonzero(~np.all(np.isfinite(a), axis=1))
    if bad.size:
        raise ModelError(f"{where}: point {bad[0] + 1} is not a finite number pair (NaN or infinite); "
                         "give finite x,y on every row")
    extent0 = float(np.max(np.ptp(a, axis=0))) if len(a) else 0.0
    if closed and len(a) > 1 and float(np.hypot(*(a[0] - a[-1]))) <= 1e-9 * extent0:
        a = a[:-1]  # the curve drawn back to its start (to round-off: 10 + 8 sin 360° is not 10 + 8 sin 0°)
    if len(a) < MIN_POINTS:
        raise ModelError(f"{where}: {len(a)} distinct point(s); a shape needs at least {MIN_POINTS} "
                         f"(an ordered curve: give more rows)")
    extent = float(np.max(np.ptp(a, axis=0)))
    if not extent > 0:
        raise ModelError(f"{where}: every point is the same ({a[0, 0]:g}, {a[0, 1]:g}); a shape needs a curve")
    step = np.hypot(*np.diff(a, axis=0).T)
    same = np.flatnonzero(step <= 1e-12 * extent)
    if same.size:
        i = int(same[0])
        raise ModelError(f"{where}: points {i + 1} and {i + 2} are the same ({a[i, 0]:g}, {a[i, 1]:g}); "
                         "remove the repeated point")
    if closed and np.hypot(*(a[0] - a[-1])) <= 1e-9 * extent:
        raise ModelError(f"{where}: the last point repeats the first twice; remove the repeated point")
    # all points on one line through a point (a segment): fine for an open curve, a degenerate
    # closed one (no area, but still a shape) is allowed too; only a single point is refused
    return a


# ----------------------------------------------------------------------------- resampling


def _arc(xy, closed):
    seg = np.diff(np.vstack([xy, xy[:1]]) if closed else xy, axis=0)
    d = np.hypot(seg[:, 0], seg[:, 1])
    return np.concatenate([[0.0], np.cumsum(d)])


def resample(xy, n: int, *, closed: bool) -> np.ndarray:
    """``n`` points equally spaced in arc length along the polygon ``xy`` ``(K, 2)`` (closed: around it)."""
    xy = np.asarray(xy, dtype=float)
    s = _arc(xy, closed)
    pts = np.vstack([xy, xy[:1]]) if closed else xy
    L = s[-1]
    u = np.arange(n) * (L / n) if closed else np.linspace(0.0, L, n)
    return np.stack([np.interp(u, s, pts[:, 0]), np.interp(u, s, pts[:, 1])], axis=1)


def resample_many(curves, counts, n: int, closed) -> np.ndarray:
    """Resample many polylines at once: ``curves`` ``(E, K, 2)`` with ``counts[e]`` valid rows each.

    ``closed`` (E,) bool: closed curves get ``n`` points around (the closing side included),
    open ones ``n`` points from the first row to the last. Returns ``(E, n, 2)``; a curve with
    fewer than 2 rows or no length is NaN.
    """
    C = np.asarray(curves, dtype=float)
    E, K, _ = C.shape
    counts = np.asarray(counts, dtype=int)
    closed = np.broadcast_to(np.asarray(closed, dtype=bool), (E,))
    idx = np.arange(K + 1)
    # the polyline with the closing point appended (closed) or the last valid row repeated (open)
    last = np.clip(counts - 1, 0, K - 1)
    ext = np.empty((E, K + 1, 2))
    ext[:, :K] = C
    ext[:, K] = np.where(closed[:, None], C[:, 0], C[np.arange(E), last])
    valid = idx[None, :] < counts[:, None]
    # rows past the valid ones repeat the end point (zero-length sides)
    endp = np.where(closed[:, None], C[:, 0], C[np.arange(E), last])
    ext = np.where(valid[:, :, None], ext, endp[:, None, :])
    seg = np.hypot(*np.moveaxis(np.diff(ext, axis=1), 2, 0))
    seg = np.where(np.isfinite(seg), seg, 0.0)
    s = np.concatenate([np.zeros((E, 1)), np.cumsum(seg, axis=1)], axis=1)  # (E, K+1)
    L = s[:, -1]
    k = np.arange(n)
    u = np.where(closed[:, None], k[None, :] * (L[:, None] / n), k[None, :] * (L[:, None] / max(n - 1, 1)))
    # segment of every u: the last index with s <= u (s nondecreasing)
    j = np.empty((E, n), dtype=int)
    for e0 in range(0, E, 4096):  # bounded memory: (chunk, n, K+1) booleans
        sl = slice(e0, e0 + 4096)
        j[sl] = np.sum(s[sl, None, :] <= u[sl, :, None] + 0.0, axis=2) - 1
    j = np.clip(j, 0, K - 1)
    rows = np.arange(E)[:, None]
    s0, s1 = s[rows, j], s[rows, j + 1]
    w = np.where(s1 > s0, (u - s0) / np.where(s1 > s0, s1 - s0, 1.0), 0.0)
    out = ext[rows, j] * (1 - w)[..., None] + ext[rows, j + 1] * w[..., None]
    bad = (counts < 2) | ~(L > 0)
    out[bad] = np.nan
    return out


# ----------------------------------------------------------------------------- elliptic Fourier


def efd(xy, harmonics: int = 10) -> np.ndarray:
    """Kuhl–Giardina coefficients of closed polygons: ``(…, H, 4)`` as (a_n, b_n, c_n, d_n), n = 1 … H.

    ``xy`` ``(K, 2)`` or ``(E, K, 2)``; the polygon is closed by its last side back to the first
    point. The zeroth harmonic (A0, C0) is the wire centroid: :func:`centroid`.
    """
    P = np.asarray(xy, dtype=float)
    single = P.ndim == 2
    if single:
        P = P[None]
    d = np.diff(np.concatenate([P, P[:, :1]], axis=1), axis=1)  # (E, K, 2): side p from p-1 to p
    dt = np.hypot(d[..., 0], d[..., 1])
    t = np.concatenate([np.zeros((P.shape[0], 1)), np.cumsum(dt, axis=1)], axis=1)  # (E, K+1)
    L = t[:, -1:]
    safe = np.where(dt > 0, dt, 1.0)
    rx, ry = np.where(dt > 0, d[..., 0] / safe, 0.0), np.where(dt > 0, d[..., 1] / safe, 0.0)
    n = np.arange(1, harmonics + 1)[None, :, None]  # (1, H, 1)
    phi = 2 * math.pi * n * (t[:, None, :] / L[:, :, None])  # (E, H, K+1)
    dc = np.cos(phi[..., 1:]) - np.cos(phi[..., :-1])
    ds = np.sin(phi[..., 1:]) - np.sin(phi[..., :-1])
    const = L / (2 * math.pi ** 2 * n[..., 0] ** 2)  # (E, H)
    a = const * np.sum(rx[:, None, :] * dc, axis=2)
    b = const * np.sum(rx[:, None, :] * ds, axis=2)
    c = const * np.sum(ry[:, None, :] * dc, axis=2)
    dd = const * np.sum(ry[:, None, :] * ds, axis=2)
    out = np.stack([a, b, c, dd], axis=-1)
    return out[0] if single else out


def centroid(xy) -> np.ndarray:
    """Centroid of closed polygons as wires of uniform density (A0, C0 of the series): ``(…, 2)``."""
    P = np.asarray(xy, dtype=float)
    Q = np.roll(P, -1, axis=-2)
    w = np.hypot(*np.moveaxis(Q - P, -1, 0))
    mid = 0.5 * (P + Q)
    return np.sum(mid * w[..., None], axis=-2) / np.sum(w, axis=-1)[..., None]


def efd_normalize(coef):
    """Normalize EFD coefficients ``(…, H, 4)``: ``(normalized (…, H, 4), theta, angle, scale, roundness)``.

    ``theta`` the start shift (radians of the first harmonic), ``angle`` the rotation removed,
    ``scale`` the semi-major axis E, ``roundness`` |minor/major| of the first harmonic (near 1:
    the normalization is ill-conditioned, see the module docstring).
    """
    C = np.asarray(coef, dtype=float)
    a1, b1, c1, d1 = (C[..., 0, i] for i in range(4))
    theta = 0.5 * np.arctan2(2 * (a1 * b1 + c1 * d1), a1 * a1 + c1 * c1 - b1 * b1 - d1 * d1)
    H = C.shape[-2]
    n = np.arange(1, H + 1)
    ct, st = np.cos(n * theta[..., None]), np.sin(n * theta[..., None])  # (…, H)
    a, b, c, d = (C[..., i] for i in range(4))
    # [a* b*; c* d*] = [a b; c d] [cos nθ, −sin nθ; sin nθ, cos nθ]
    a_s, b_s = a * ct + b * st, -a * st + b * ct
    c_s, d_s = c * ct + d * st, -c * st + d * ct
    psi = np.arctan2(c_s[..., 0], a_s[..., 0])
    E = np.hypot(a_s[..., 0], c_s[..., 0])
    cp, sp = np.cos(psi)[..., None], np.sin(psi)[..., None]
    Es = np.where(E > 0, E, 1.0)[..., None]
    na, nb = (cp * a_s + sp * c_s) / Es, (cp * b_s + sp * d_s) / Es
    nc, nd = (-sp * a_s + cp * c_s) / Es, (-sp * b_s + cp * d_s) / Es
    out = np.stack([na, nb, nc, nd], axis=-1)
    return out, theta, psi, E, np.abs(out[..., 0, 3])


def efd_descriptor(normalized) -> np.ndarray:
    """The descriptor vector of normalized coefficients: (d₁, a_n, b_n, c_n, d_n for n ≥ 2): ``(…, 4H − 3)``."""
    N = np.asarray(normalized)
    return np.concatenate([N[..., 0, 3:4], N[..., 1:, :].reshape(N.shape[:-2] + (-1,))], axis=-1)


def efd_variants(xy, harmonics: int = 10) -> np.ndarray:
    """Descriptors of a closed curve ``(K, 2)`` under its ambiguities: ``(4, 4H − 3)``.

    Rows: start θ₁ and θ₁ + π (harmonic n × (−1)^(n+1)), each for the curve as given and reversed.
    """
    xy = np.asarray(xy, dtype=float)
    out = []
    sign = (-1.0) ** (np.arange(1, harmonics + 1) + 1)
    for curve in (xy, xy[::-1]):
        N = efd_normalize(efd(curve, harmonics))[0]
        out.append(efd_descriptor(N))
        out.append(efd_descriptor(N * sign[:, None]))
    return np.array(out)


# ----------------------------------------------------------------------------- open curves


def open_normalize(xy, n: int = 64):
    """An open curve resampled at ``n`` points and normalized: ``(points (n, 2), (x, y, angle, scale))``.

    Centroid at 0, RMS distance from it 1, principal axis along +x, the axis' sign chosen so
    that the first point has x ≤ 0 (one of the four variants, see :func:`open_distance`).
    """
    Q, place = open_normalize_many(resample(xy, n, closed=False)[None])
    if not np.all(np.isfinite(Q)):
        raise ModelError("open curve: every point is the same; a shape needs a curve")
    return Q[0], tuple(float(v) for v in place[0])


def open_normalize_many(R):
    """:func:`open_normalize` of curves already resampled ``(E, n, 2)``: ``(normalized, (E, 4) x, y, angle, scale)``."""
    R = np.asarray(R, dtype=float)
    c = R.mean(axis=1)
    Q = R - c[:, None, :]
    s = np.sqrt(np.mean(np.sum(Q * Q, axis=2), axis=1))
    with np.errstate(all="ignore"):
        Q = Q / np.where(s > 0, s, np.nan)[:, None, None]
    sxx = np.sum(Q[..., 0] ** 2, axis=1)
    syy = np.sum(Q[..., 1] ** 2, axis=1)
    sxy = np.sum(Q[..., 0] * Q[..., 1], axis=1)
    ang = 0.5 * np.arctan2(2 * sxy, sxx - syy)  # the major axis of the 2x2 covariance
    z = (Q[..., 0] + 1j * Q[..., 1]) * np.exp(-1j * ang)[:, None]
    flip = z[:, 0].real > 0
    z = np.where(flip[:, None], -z, z)
    ang = np.where(flip, ang + math.pi, ang)
    ang = np.remainder(ang + math.pi, 2 * math.pi) - math.pi
    return np.stack([z.real, z.imag], axis=-1), np.stack([c[:, 0], c[:, 1], ang, s], axis=1)


def open_distance(a, b, n: int = 64) -> float:
    """Distance of two open curves: the RMS point distance of their normalizations, least over the
    ambiguities of ``b`` (its axis' sign, its direction). A curve and its reverse are at distance 0."""
    A = open_normalize(a, n)[0]
    best = math.inf
    for curve in (np.asarray(b, dtype=float), np.asarray(b, dtype=float)[::-1]):
        B = open_normalize(curve, n)[0]
        for sgn in (1.0, -1.0):
            best = min(best, math.sqrt(float(np.mean(np.sum((A - sgn * B) ** 2, axis=1)))))
    return best


# ----------------------------------------------------------------------------- Procrustes windows


def _as_complex(xy):
    xy = np.asarray(xy)
    return xy[..., 0] + 1j * xy[..., 1]


def target_vector(xy):
    """A target's points as a centred, unit-norm complex vector: ``(t, centre, norm)``."""
    z = _as_complex(np.asarray(xy, dtype=float))
    c = z.mean()
    t = z - c
    nrm = float(np.linalg.norm(t))
    return t / nrm, c, nrm


def procrustes(curves, closed, target, strides=(1,)):
    """Best similarity fit of a target to a window of every stored curve.

    Parameters
    ----------
    curves : ``(E, N, 2)`` stored curves (N points equally spaced in arc length).
    closed : ``(E,)`` bool: a closed curve's windows wrap around, an open one's do not.
    target : ``(m, 2)`` points of the target, equally spaced in arc length (the window has m
        points too: stored points s, s + Δ, …, s + (m − 1)Δ).
    strides : the Δ to try (window lengths (m − 1)Δ + 1 points of the N).

    Returns
    -------
    ``(dist (E,), start (E,), stride (E,), factor (E,) complex, mean (E,) complex)``: the least
    distance (see the module docstring) over every start and stride, and the fit there: the target's
    normalized points t ≈ factor · (window − mean). Entries with no valid window get distance inf.
    """
    return procrustes_both(curves, closed, target, strides, both=False)[0]


def procrustes_both(curves, closed, target, strides=(1,), *, both: bool = True):
    """:func:`procrustes` of the target and (``both``) of the target reversed: a list of one or two results.

    The window sums over every start are circular correlations of each stored curve with a sparse
    kernel (the target's points at every Δ-th place), so they are computed with FFTs: one transform
    of the curves and of their squared moduli, then one inverse per sum, stride and direction (the
    squared moduli's sums are real, so two strides share one inverse) — 20 transforms of the atlas'
    curves for an open target's strides 1, 2, 3, 4, 6 (8 spans 64 points: longer than 64 stored ones)
    and two directions. scipy's FFT: numpy's transforms a block's short rows one at a time.
    """
    curves = np.asarray(curves)
    E = curves.shape[0]
    closed = np.broadcast_to(np.asarray(closed, dtype=bool), (E,))
    if E >= _SINGLE:  # the ranking in single precision, then its best and their near-ties again in double
        out = _procrustes_blocks(curves, closed, target, strides, both, single=True)
        best = np.min([r[0] for r in out], axis=0)
        order = np.argsort(best, kind="stable")
        edge = max(best[order[min(_RERANK, E) - 1]], best[order[0]] + _SINGLE_TIE)
        sel = np.sort(order[:min(int(np.searchsorted(best[order], edge, side="right")), _SINGLE - 1)])
        again = _procrustes_blocks(curves[sel], closed[sel], target, strides, both, single=False)
        for r, a in zip(out, again):
            for col, new in zip(r, a):
                col[sel] = new
        return out
    return _procrustes_blocks(curves, closed, target, strides, both, single=False)


#: a batch of this many curves or more is ranked in single precision (its transforms halved)
_SINGLE = 4096
#: then this many of its best, and every one within ``_SINGLE_TIE`` of the best, are ranked again in double:
#: single precision's 1 − |C|²/var carries ~1e-6 of round-off, so distances near 0 (sqrt of it) read ~1e-3
#: apart from the truth, and a good stretch's best windows all read 0 (the foot path of test_shape: 40 of them)
_RERANK = 256
_SINGLE_TIE = 3e-3
#: curves per block of the window sums: a block's (rows, N) arrays stay in the processor's cache (64 points:
#: 1 MB in single precision), where numpy's element-wise passes run about twice as fast as on an atlas' 10⁵ rows
_ROWS = 2048


def _kernels(N, m, dlt, targets):
    """Conjugated spectra of the stride-``dlt`` kernels: the window's ones, then each target's points."""
    def spec(k):
        return np.conj(np.fft.fft(k))

    ones = np.zeros(N)
    np.add.at(ones, (np.arange(m) * dlt) % N, 1.0)
    out = [spec(ones)]
    for t in targets:
        kern = np.zeros(N, dtype=complex)
        np.add.at(kern, (np.arange(m) * dlt) % N, np.conj(t))
        out.append(np.conj(np.fft.fft(np.conj(kern))))
    return out


def _procrustes_blocks(curves, closed, target, strides, both, single):
    """The window fits of :func:`procrustes_both` (``single``: in single precision), block by block of rows."""
    E, N = curves.shape[0], curves.shape[1]
    cdt = np.complex64 if single else np.complex128
    t_f, _, _ = target_vector(target)
    targets = [t_f, t_f[::-1]] if both else [t_f]
    m = len(t_f)
    strides = [int(d) for d in strides if (m - 1) * int(d) <= N - 1]  # (a window longer than the stored curve: none)
    kerns = [[k.astype(cdt) for k in _kernels(N, m, dlt, targets)] for dlt in strides]
    # the squared moduli's window sums are real: two strides' in one inverse transform (real and imaginary part)
    pairs = [(kerns[i][0] + (1j * kerns[i + 1][0] if i + 1 < len(strides) else 0)).astype(cdt)
             for i in range(0, len(strides), 2)]
    res = [[np.full(E, np.inf), np.zeros(E, dtype=int), np.ones(E, dtype=int), np.zeros(E, dtype=complex),
            np.zeros(E, dtype=complex)] for _ in targets]
    for a in range(0, E, _ROWS):
        sl = slice(a, a + _ROWS)
        Z = _as_complex(curves[sl]).astype(cdt)
        e = Z.shape[0]
        rows = np.arange(e)
        open_ = ~closed[sl]
        Zf = _fft.fft(Z, axis=1)
        A2f = _fft.fft(Z.real ** 2 + Z.imag ** 2, axis=1)
        S2s = []
        for pk in pairs:
            both_s2 = _fft.ifft(A2f * pk, axis=1, overwrite_x=True)
            S2s += [both_s2.real, both_s2.imag]
        blk = [[np.full(e, np.inf), np.zeros(e, dtype=int), np.ones(e, dtype=int), np.zeros(e, dtype=complex),
                np.zeros(e, dtype=complex)] for _ in targets]
        for dlt, ks, S2 in zip(strides, kerns, S2s):
            span = (m - 1) * dlt
            S1 = _fft.ifft(Zf * ks[0], axis=1, overwrite_x=True)
            var = S1.real ** 2  # (in place: numpy's passes over the block are the cost)
            var += S1.imag ** 2
            var *= -1.0 / m
            var += S2
            ok = var > 1e-12 * S2
            if span > 0 and open_.any():  # an open curve's windows do not wrap around
                ok[open_, N - span:] = False
            inv = np.divide(1.0, var, out=np.zeros_like(var), where=ok)
            any_ok = ok.any(axis=1)
            for K, r in zip(ks[1:], blk):
                C = _fft.ifft(Zf * K, axis=1, overwrite_x=True)
                q = C.real ** 2
                q += C.imag ** 2
                q *= inv  # |C|²/var: 1 − the squared distance
                s = np.argmax(q, axis=1)
                v = np.where(any_ok, np.maximum(1.0 - q[rows, s], 0.0), np.inf)
                better = v < r[0]
                r[0] = np.where(better, v, r[0])
                r[1] = np.where(better, s, r[1])
                r[2] = np.where(better, dlt, r[2])
                # C = Σ w conj(t): the factor a with a (w − w̄) ≈ t is ⟨w − w̄, t⟩ / ‖w − w̄‖² = conj(C)/var
                r[3] = np.where(better, np.conj(C[rows, s]) * inv[rows, s], r[3])
                r[4] = np.where(better, S1[rows, s] / m, r[4])
        for r, b in zip(res, blk):
            for col, new in zip(r, b):
                col[sl] = new
    return [(np.sqrt(r[0]), r[1], r[2], r[3], r[4]) for r in res]
