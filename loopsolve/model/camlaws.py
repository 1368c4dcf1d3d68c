"""Cam motion laws: the normalized rise curves and a law over segments of one turn.

A rise of height ``h`` over a cam angle ``β`` follows ``s = h·S(u)``, ``u = (θ − θ₀)/β`` in [0, 1], with
``S(0) = 0``, ``S(1) = 1`` and zero velocity at both ends (a return is a negative rise). The curves
(Norton, *Cam Design and Manufacturing Handbook*; Rothbart, *Cam Design Handbook*):

``cycloidal``          S = u − sin(2πu)/(2π)                         (acceleration zero at the ends)
``harmonic``           S = (1 − cos πu)/2                            (acceleration jumps at the ends)
``3-4-5``              S = 10u³ − 15u⁴ + 6u⁵                         (acceleration zero at the ends)
``4-5-6-7``            S = 35u⁴ − 84u⁵ + 70u⁶ − 20u⁷                 (jerk zero at the ends too)
``modified-trapezoid`` constant acceleration ±8π/(2+π) joined by sine quarters (5 pieces)
``modified-sine``      a sine acceleration pulse, 4π²/(π+4) peak (3 pieces)

Every function here takes an ``ops`` namespace with ``sin``, ``cos``, ``pi`` and ``select`` so that one
description gives numbers (:data:`NUMERIC`, numpy) and, in :mod:`loopsolve.symbolic.pairs`, the sympy
expression that becomes a row of Φ. :func:`curve` gives S and its first three derivatives in u.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["CURVES", "curve", "pieces", "NUMERIC", "Law", "law_values", "joins"]

CURVES = ("cycloidal", "harmonic", "3-4-5", "4-5-6-7", "modified-trapezoid", "modified-sine")


class _Numeric:
    sin = staticmethod(np.sin)
    cos = staticmethod(np.cos)
    pi = math.pi

    @staticmethod
    def select(pieces, u):
        """``pieces`` [(upper bound of u, value), ...]: the value of the first piece whose bound exceeds u."""
        out = np.asarray(pieces[-1][1], dtype=float) * np.ones_like(u, dtype=float)
        for bound, value in reversed(pieces[:-1]):
            out = np.where(u < bound, value, out)
        return out


#: the numpy namespace for :func:`curve`
NUMERIC = _Numeric()


def pieces(name: str, u, ops) -> list[tuple[float, tuple]]:
    """``[(upper bound of u, (S, S′, S″, S‴)), ...]`` of a curve: one piece for the smooth curves."""
    sin, cos, pi = ops.sin, ops.cos, ops.pi
    if name == "cycloidal":
        w = 2 * pi * u
        return [(1, (u - sin(w) / (2 * pi), 1 - cos(w), 2 * pi * sin(w), 4 * pi**2 * cos(w)))]
    if name == "harmonic":
        w = pi * u
        return [(1, ((1 - cos(w)) / 2, pi / 2 * sin(w), pi**2 / 2 * cos(w), -pi**3 / 2 * sin(w)))]
    if name == "3-4-5":
        return [(1, (10 * u**3 - 15 * u**4 + 6 * u**5, 30 * u**2 - 60 * u**3 + 30 * u**4,
                     60 * u - 180 * u**2 + 120 * u**3, 60 - 360 * u + 360 * u**2))]
    if name == "4-5-6-7":
        return [(1, (35 * u**4 - 84 * u**5 + 70 * u**6 - 20 * u**7,
                     140 * u**3 - 420 * u**4 + 420 * u**5 - 140 * u**6,
                     420 * u**2 - 1680 * u**3 + 2100 * u**4 - 840 * u**5,
                     840 * u - 5040 * u**2 + 8400 * u**3 - 4200 * u**4))]
    if name == "modified-trapezoid":
        K = 2 + pi
        w = 4 * pi * u
        ramp = lambda c: ((4 * pi * u - sin(w)) / (2 * pi * K) + c, 2 * (1 - cos(w)) / K,  # noqa: E731
                          8 * pi * sin(w) / K, 32 * pi**2 * cos(w) / K)
        return [
            (1 / 8, ramp(0)),
            (3 / 8, ((64 * pi**2 * u**2 + (32 * pi - 16 * pi**2) * u + pi**2 - 8) / (16 * pi * K),
                     (8 * pi * u + 2 - pi) / K, 8 * pi / K, 0 * u)),
            (5 / 8, ((4 * pi * u + 4 * pi**2 * u + sin(w) - pi**2) / (2 * pi * K), 2 * (1 + pi + cos(w)) / K,
                     -8 * pi * sin(w) / K, -32 * pi**2 * cos(w) / K)),
            (7 / 8, ((-64 * pi**2 * u**2 + (32 * pi + 112 * pi**2) * u - 33 * pi**2 + 8) / (16 * pi * K),
                     (-8 * pi * u + 2 + 7 * pi) / K, -8 * pi / K, 0 * u)),
            (1, ((2 * pi * u - sin(w) / 2 + pi**2) / (pi * K), 2 * (1 - cos(w)) / K, 8 * pi * sin(w) / K,
                 32 * pi**2 * cos(w) / K)),
        ]
    if name == "modified-sine":
        M = pi + 4
        w = 4 * pi * u
        v = pi * (4 * u + 1) / 3
        end = lambda c: ((pi * u - sin(w) / 4 + c) / M, (pi - pi * cos(w)) / M,  # noqa: E731
                         4 * pi**2 * sin(w) / M, 16 * pi**3 * cos(w) / M)
        return [
            (1 / 8, end(0)),
            (7 / 8, ((pi * u - 9 * sin(v) / 4 + 2) / M, (pi - 3 * pi * cos(v)) / M, 4 * pi**2 * sin(v) / M,
                     16 * pi**3 / 3 * cos(v) / M)),
            (1, end(4)),
        ]
    raise ValueError(f"unknown curve {name!r}")


def curve(name: str, u, ops=NUMERIC) -> tuple:
    """``(S, S′, S″, S‴)`` of curve ``name`` at ``u`` (numpy with the default ``ops``).

    Examples
    --------
    >>> from loopsolve.model.camlaws import curve
    >>> [round(float(x), 6) for x in curve("cycloidal", 0.5)]
    [0.5, 2.0, 0.0, -39.478418]
    """
    ps = pieces(name, u, ops)
    if len(ps) == 1:
        return ps[0][1]
    u = np.asarray(u, dtype=float)
    return tuple(ops.select([(b, vals[k]) for b, vals in ps], u) for k in range(4))


@dataclass(frozen=True)
class Law:
    """A law over one turn, in numbers: segment ends (radians, increasing, the last ``start`` + 2π), rises
    (0 for a dwell; length or radians), curves (``None`` for a dwell) and the angle ``start`` of the first.
    A cam declared by its pitch curve has one segment and ``table``, its
    :class:`~loopsolve.model.campitch.ProfileLaw` (a smooth periodic displacement: no joins)."""

    start: float
    ends: tuple[float, ...]
    rises: tuple[float, ...]
    curves: tuple
    table: object = None

    @property
    def levels(self) -> tuple[float, ...]:
        """The displacement at the start of each segment."""
        out, s = [], 0.0
        for h in self.rises:
            out.append(s)
            s += h
        return tuple(out)


def law_values(law: Law, theta) -> tuple[np.ndarray, ...]:
    """``(s, s′, s″, s‴)`` of a law at cam angles ``theta`` (radians; derivatives per radian)."""
    if law.table is not None:
        return ppoly_values(law.table, theta)
    th = np.asarray(theta, dtype=float)
    w = law.start + np.mod(th - law.start, 2 * math.pi)
    out = [np.zeros_like(w) for _ in range(4)]
    lo = law.start
    for end, h, name, s0 in zip(law.ends, law.rises, law.curves, law.levels):
        beta = end - lo
        inside = (w >= lo) & (w < end)
        if inside.any():
            if name is None:
                out[0][inside] = s0
            else:
                S = curve(name, (w[inside] - lo) / beta)
                out[0][inside] = s0 + h * S[0]
                for k in (1, 2, 3):
                    out[k][inside] = h * S[k] / beta**k
        lo = end
    return tuple(out)


def joins(law: Law) -> list[dict]:
    """The jumps of s, s′ and s″ where one segment meets the next (the last meets the first).

    Each entry: ``{"angle": radians, "position": jump, "velocity": jump, "acceleration": jump}``
    (right value minus left value, per radian).
    """
    if law.table is not None:  # a periodic quintic spline: s, s′, s″ (and s‴) continuous everywhere
        return []
    n = len(law.ends)
    ends_left = []
    for i in range(n):
        lo = law.start if i == 0 else law.ends[i - 1]
        beta = law.ends[i] - lo
        h, name, s0 = law.rises[i], law.curves[i], law.levels[i]
        if name is None:
            left = (s0, 0.0, 0.0)
            right = (s0, 0.0, 0.0)
        else:
            S1, S0 = curve(name, 1.0), curve(name, 0.0)
            left = (s0 + h * float(S1[0]), h * float(S1[1]) / beta, h * float(S1[2]) / beta**2)
            right = (s0 + h * float(S0[0]), h * float(S0[1]) / beta, h * float(S0[2]) / beta**2)
        ends_left.append((left, right))
    out = []
    for i in range(n):
        left = ends_left[i][0]
        nxt = ends_left[(i + 1) % n][1]  # after the last segment the turn starts again from s = 0
        angle = law.ends[i] if i < n - 1 else law.start
        out.append({"angle": angle, "position": nxt[0] - left[0], "velocity": nxt[1] - left[1],
                    "acceleration": nxt[2] - left[2]})
    return out


def ppoly_values(law, theta) -> tuple[np.ndarray, ...]:
    """``(s, s′, s″, s‴)`` of a profile law (:class:`~loopsolve.model.campitch.ProfileLaw`: its ``breaks`` and
    ``coeffs``) at cam angles ``theta`` (radians)."""
    from scipy.interpolate import PPoly

    pp = PPoly(np.asarray(law.coeffs, dtype=float), np.asarray(law.breaks, dtype=float), extrapolate="periodic")
    th = np.asarray(theta, dtype=float)
    return tuple(np.asarray(pp(th, nu=k), dtype=float) for k in range(4))
