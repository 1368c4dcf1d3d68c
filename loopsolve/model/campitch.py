"""A cam declared by its pitch curve: ``profile = "pitch.csv"`` in ``[cams.NAME]`` instead of a ``law``.

The file is a CSV with the header ``x,y`` and one point a line: the pitch curve in the cam's own frame
(the frame of :mod:`loopsolve.model.camgeometry` at cam angle 0; the model's length unit): the path of
the roller centre or the knife edge, or, for a flat face, the cam profile itself. The points go once
round the cam centre (either sense; the first point need not be repeated at the end).

From the points: a closed curve, the periodic quintic interpolating spline through them in their
cumulative chord length (C⁴: its tangent and curvature are continuous); from the curve, the follower's
displacement at ``SAMPLES`` cam angles, where the follower meets the turned curve (a translating knife or
roller: the line of motion, ``x = ε``; an oscillating one: the circle of the arm about its pivot; a
flat face: the curve's support in the follower's direction), zero at the lowest position; from those,
the periodic quintic interpolating spline of the displacement in the cam angle, a piecewise polynomial
(:class:`ProfileLaw`) that both the numbers (:func:`loopsolve.model.camlaws.law_values`) and the row
of Φ (:mod:`loopsolve.symbolic.pairs`) use. The base circle follows from the curve (the lowest
position); ``base`` and ``start`` are not keys of a profile cam.

Refused, each with the file and the key named: a missing or unreadable file, a file over
:data:`MAX_BYTES` or with more than :data:`MAX_POINTS` points, fewer than :data:`MIN_POINTS`, a header
other than ``x,y``, a value that is not a finite number, repeated consecutive points, and a curve that
the follower does not meet exactly once at every cam angle (not star-shaped about the cam centre for
a radial follower). Nothing in the file is evaluated: values are read with ``float``.
"""

from __future__ import annotations

import csv
import hashlib
import math
import os
from dataclasses import dataclass, field

import numpy as np

__all__ = ["ProfileLaw", "read_points", "build", "MAX_BYTES", "MAX_POINTS", "MIN_POINTS"]

MAX_BYTES = 4 << 20
MAX_POINTS = 50_000
MIN_POINTS = 8
#: cam angles at which the follower's meeting with the curve is checked (once each)
CHECK = 1440
_NEWTON = 12


class ProfileError(ValueError):
    """A problem with a profile file (the message names what; the caller adds the file and key)."""


@dataclass(frozen=True)
class ProfileLaw:
    """The displacement of a profile cam as a periodic piecewise polynomial in the cam angle (radians).

    ``breaks`` (M + 1 angles from 0 to 2π) and ``coeffs`` (6 rows, highest power first, M columns: the
    convention of :class:`scipy.interpolate.PPoly`); ``base`` the base circle of the cam profile it
    implies (the pitch curve's least distance minus the roller), ``file`` the file as written and
    ``digest`` a hash of the polynomial (part of the declaration's structure).
    """

    file: str
    digest: str
    base: float
    pitch_base: float
    breaks: tuple = field(repr=False, compare=False)
    coeffs: tuple = field(repr=False, compare=False)

    def derivative_coeffs(self, order: int) -> np.ndarray:
        """The coefficients (lowest power first, ``(M, k)``) of the ``order``-th derivative of each piece."""
        c = np.asarray(self.coeffs, dtype=float)[::-1].T  # (M, 6), lowest power first
        for _ in range(order):
            k = np.arange(1, c.shape[1])
            c = c[:, 1:] * k if c.shape[1] > 1 else np.zeros((c.shape[0], 1))
        return c


def read_points(path: str) -> np.ndarray:
    """The points of a profile file, ``(N, 2)``, checked (see the module notes); ProfileError otherwise."""
    try:
        st = os.stat(path)
    except OSError as exc:
        raise ProfileError(f"cannot read the profile ({exc.strerror or exc}); give a CSV file with header x,y, "
                           "its path relative to the model file") from None
    if not os.path.isfile(path):
        raise ProfileError("is not a file; give a CSV file with header x,y")
    if st.st_size > MAX_BYTES:
        raise ProfileError(f"the file has {st.st_size} bytes, more than the {MAX_BYTES} a profile may have")
    try:
        with open(path, newline="", encoding="utf-8-sig") as fh:
            text = fh.read(MAX_BYTES + 1)
    except (OSError, UnicodeDecodeError) as exc:
        raise ProfileError(f"cannot read the profile ({getattr(exc, 'strerror', None) or exc})") from None
    rows = [r for r in csv.reader(text.splitlines()) if r and any(c.strip() for c in r)]
    if not rows or [c.strip().lower() for c in rows[0]] != ["x", "y"]:
        got = ",".join(rows[0])[:40] if rows else "an empty file"
        raise ProfileError(f"expected the header x,y on the first line, got {got!r}")
    rows = rows[1:]
    if len(rows) > MAX_POINTS:
        raise ProfileError(f"{len(rows)} points, more than the {MAX_POINTS} a profile may have")
    pts = np.empty((len(rows), 2))
    for i, r in enumerate(rows):
        if len(r) != 2:
            raise ProfileError(f"line {i + 2}: expected two values x,y, got {len(r)}")
        for j, c in enumerate(r):
            try:
                v = float(c.strip())
            except ValueError:
                raise ProfileError(f"line {i + 2}: {c.strip()[:20]!r} is not a number") from None
            if not math.isfinite(v):
                raise ProfileError(f"line {i + 2}: {c.strip()[:20]!r} is not a finite number")
            pts[i, j] = v
    if len(pts) > 1 and np.allclose(pts[0], pts[-1], rtol=0, atol=1e-12 * max(1.0, np.abs(pts).max())):
        pts = pts[:-1]  # the curve closed by repeating its first point
    if len(pts) < MIN_POINTS:
        raise ProfileError(f"{len(pts)} distinct points; a profile needs at least {MIN_POINTS}")
    step = np.linalg.norm(np.diff(np.vstack([pts, pts[:1]]), axis=0), axis=1)
    if not (step > 1e-9 * np.abs(pts).max()).all():
        i = int(np.argmin(step))
        raise ProfileError(f"points {i + 1} and {(i + 1) % len(pts) + 1} coincide: the points of a curve are distinct")
    return pts


def _curve(pts: np.ndarray):
    """The closed curve through ``pts``: a periodic quintic spline in the chord length (its period)."""
    from scipy.interpolate import make_interp_spline

    closed = np.vstack([pts, pts[:1]])
    t = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(closed, axis=0), axis=1))])
    k = 5 if len(pts) >= 8 else 3
    return make_interp_spline(t, closed, k=k, bc_type="periodic"), float(t[-1])


def _meet(spl, period, theta, g_and_dg, side_ok, dense):
    """The curve parameter at which the follower meets the curve turned by each of ``theta``: the one
    root of ``g`` (between dense samples where ``side_ok``) refined by Newton steps. ProfileError when a
    cam angle has none or more than one."""
    tk = np.linspace(0.0, period, dense, endpoint=False)
    Pk = spl(tk)
    out = np.empty(len(theta))
    for lo in range(0, len(theta), 64):
        th = theta[lo:lo + 64]
        g, _ = g_and_dg(Pk[None, :, :], None, th[:, None])
        g1 = np.roll(g, -1, axis=1)
        ok = side_ok(Pk[None, :, :], th[:, None]) | side_ok(np.roll(Pk, -1, axis=0)[None, :, :], th[:, None])
        cross = ((g <= 0) & (g1 > 0) | (g > 0) & (g1 <= 0)) & ok
        count = cross.sum(axis=1)
        bad = np.flatnonzero(count != 1)
        if bad.size:
            i = int(bad[0])
            raise ProfileError(f"the follower meets the curve {int(count[i])} times at cam angle "
                               f"{math.degrees(th[i]):.6g} deg, not once: the points must go once round the cam "
                               "centre, a curve the follower's line (arm) meets once at every angle")
        k = np.argmax(cross, axis=1)
        rows = np.arange(len(th))
        frac = g[rows, k] / (g[rows, k] - g1[rows, k])
        t = tk[k] + frac * (period / dense)
        for _ in range(_NEWTON):
            P, dP = spl(np.mod(t, period)), spl(np.mod(t, period), 1)
            gv, dg = g_and_dg(P, dP, th)
            step = np.where(dg != 0, gv / np.where(dg != 0, dg, 1.0), 0.0)
            t = t - np.clip(step, -period / dense, period / dense)
        out[lo:lo + 64] = np.mod(t, period)
    return out


def _displacement(pts, kind, contact, offset, pivot, arm, side, n):
    """``(theta, s, pitch_base)``: the follower's displacement at ``n`` cam angles (radians; length or
    radians) from the lowest position, and the least distance of the pitch point from the cam centre."""
    spl, period = _curve(pts)
    dense = int(min(max(8 * len(pts), 2880), 40_000))
    theta = np.linspace(0.0, 2 * math.pi, n, endpoint=False)
    check = np.linspace(0.0, 2 * math.pi, CHECK, endpoint=False) + math.pi / CHECK

    def turned(P, th):  # R(θ)P: the curve's point in the fixed frame
        c, s = np.cos(th), np.sin(th)
        return c * P[..., 0] - s * P[..., 1], s * P[..., 0] + c * P[..., 1]

    if contact == "flat":
        if kind != "translating":
            raise ProfileError("a profile drives a translating follower (knife, roller or flat) or an oscillating "
                               "knife or roller follower; give the oscillating flat face a `law`")
        tk = np.linspace(0.0, period, max(len(pts) * 16, 4096), endpoint=False)
        Pk = spl(tk)

        def support(th):
            Y = turned(Pk[None, :, :], th[:, None])[1]
            k = np.argmax(Y, axis=1)
            t = tk[k]
            for _ in range(_NEWTON):  # dY/dt = 0 at the support point
                P1, P2 = spl(np.mod(t, period), 1), spl(np.mod(t, period), 2)
                d1, d2 = turned(P1, th)[1], turned(P2, th)[1]
                step = np.where(d2 < 0, d1 / np.where(d2 < 0, d2, -1.0), 0.0)
                t = t - np.clip(step, -period / len(tk), period / len(tk))
            return turned(spl(np.mod(t, period)), th)[1]

        h = support(theta)
        if support(check).min() <= 0 or h.min() <= 0:
            raise ProfileError("the curve does not go round the cam centre (a flat face must touch it on every "
                               "side)")
        return theta, h - h.min(), float(h.min())
    if kind == "translating":
        def g_and_dg(P, dP, th):
            x, _ = turned(P, th)
            return x - offset, (None if dP is None else turned(dP, th)[0])

        def side_ok(P, th):
            return turned(P, th)[1] > 0

        _meet(spl, period, check, g_and_dg, side_ok, dense)
        t = _meet(spl, period, theta, g_and_dg, side_ok, dense)
        Y = turned(spl(t), theta)[1]
        y0 = float(Y.min())
        return theta, Y - y0, math.hypot(y0, offset)
    A = np.array([pivot, 0.0])

    def g_and_dg(P, dP, th):
        x, y = turned(P, th)
        g = (x - A[0]) ** 2 + (y - A[1]) ** 2 - arm**2
        if dP is None:
            return g, None
        dx, dy = turned(dP, th)
        return g, 2 * ((x - A[0]) * dx + (y - A[1]) * dy)

    def side_ok(P, th):
        return side * turned(P, th)[1] > 0

    _meet(spl, period, check, g_and_dg, side_ok, dense)
    t = _meet(spl, period, theta, g_and_dg, side_ok, dense)
    x, y = turned(spl(t), theta)
    gam = np.unwrap(np.arctan2(y, x - pivot))
    r = np.hypot(x, y)
    return theta, gam, float(r.min())


def _periodic(theta, s):
    """The periodic quintic interpolating spline of ``s`` at ``theta`` (one turn), as a PPoly on [0, 2π]."""
    from scipy.interpolate import PPoly, make_interp_spline

    closed_th = np.concatenate([theta, [2 * math.pi]])
    closed_s = np.concatenate([s, s[:1]])
    pp = PPoly.from_spline(make_interp_spline(closed_th, closed_s, k=5, bc_type="periodic"))
    inside = pp.x[:-1] < pp.x[1:]
    x = np.concatenate([pp.x[:-1][inside], [pp.x[-1]]])
    c = pp.c[:, inside]
    lo = np.searchsorted(x, 0.0, side="right") - 1
    hi = np.searchsorted(x, 2 * math.pi, side="left")
    x, c = x[lo:hi + 1].copy(), c[:, lo:hi]
    if abs(x[0]) > 1e-12 or abs(x[-1] - 2 * math.pi) > 1e-12:  # the data sites are knots of the spline
        raise ProfileError("internal: the spline's pieces do not start at cam angle 0")
    x[0], x[-1] = 0.0, 2 * math.pi
    return PPoly(c, x, extrapolate="periodic")


def _least(pp) -> float:
    """The least value of a periodic PPoly over a turn (dense samples refined by Newton steps)."""
    th = np.linspace(0.0, 2 * math.pi, 16 * (len(pp.x) - 1), endpoint=False)
    t = th[int(np.argmin(pp(th)))]
    h = 2 * math.pi / len(th)
    for _ in range(_NEWTON):
        d2 = float(pp(t, 2))
        if d2 <= 0:
            break
        t -= float(np.clip(pp(t, 1) / d2, -h, h))
    return float(min(pp(t), pp(th).min()))


def build(pts: np.ndarray, *, kind: str, contact: str, roller: float, offset: float, pivot: float, arm: float,
          side: int, file: str, pieces: int | None = None) -> ProfileLaw:
    """The :class:`ProfileLaw` of a cam whose pitch curve (profile for a flat face) passes through ``pts``."""
    m = int(pieces or min(max(len(pts), 180), 720))
    theta, s, rp = _displacement(pts, kind, contact, offset, pivot, arm, side, m)
    base = rp - roller
    pp = _periodic(theta, s)
    low = _least(pp)
    if kind == "oscillating":  # s is the arm's angle γ: zero lift where σγ is least (nearest the centre)
        from .camgeometry import CamNumbers
        from .camlaws import Law

        def numbers(b):
            return CamNumbers(kind, contact, Law(0.0, (2 * math.pi,), (0.0,), (None,)), b, roller, 0.0, pivot, arm,
                              side)

        try:
            _, sigma = numbers(base).arm_start()
        except ValueError as exc:
            raise ProfileError(f"{exc} (pivot {pivot:g}, arm {arm:g}, the curve's least radius {rp:.6g})") from None
        pp = _periodic(theta, sigma * s)
        low = _least(pp)
        g0 = sigma * low
        rp = math.hypot(pivot + arm * math.cos(g0), arm * math.sin(g0))
        base = rp - roller
        try:
            g_check, _ = numbers(base).arm_start()
        except ValueError as exc:
            raise ProfileError(f"{exc} (pivot {pivot:g}, arm {arm:g}, the curve's least radius {rp:.6g})") from None
        if abs(math.remainder(g_check - g0, 2 * math.pi)) > 1e-6:
            raise ProfileError("the arm does not rest on the curve on its `side` of the line from the cam centre "
                               "to the pivot")
    elif contact == "flat":
        base = rp + low
        rp = base
    else:
        y0 = math.sqrt(max(rp**2 - offset**2, 0.0)) + low
        rp = math.hypot(y0, offset)
        base = rp - roller
    if base <= 0:
        raise ProfileError(f"the pitch curve comes within {rp:.6g} of the cam centre, not more than the roller "
                           f"({roller:g}): no cam profile fits inside")
    c = np.array(pp.c)
    c[-1] -= low
    x = np.asarray(pp.x)
    digest = hashlib.sha256(np.ascontiguousarray(x).tobytes() + np.ascontiguousarray(c).tobytes()).hexdigest()[:16]
    return ProfileLaw(file, digest, float(base), float(rp), tuple(map(float, x)),
                      tuple(tuple(map(float, row)) for row in c))
