"""The output grid of a sweep: the requested input values, exactly (no accumulated steps).

A row is ``start + k*step`` computed from ``k``, so a grid value is the same number in every
sweep, study and page that asks for it.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import ModelError


def grid(start: float, stop: float, step: float) -> np.ndarray:
    """Output grid from ``start`` towards ``stop`` by ``|step|`` (``stop`` included when on the grid).

    Examples
    --------
    >>> grid(0, 10, 4).tolist(), grid(10, 0, 4).tolist()
    ([0.0, 4.0, 8.0], [10.0, 6.0, 2.0])
    """
    if step == 0 or not math.isfinite(step):
        raise ModelError("--step must be a nonzero number")
    step = math.copysign(abs(step), stop - start) if stop != start else abs(step)
    n = int(math.floor((stop - start) / step + 1e-9))
    return start + step * np.arange(max(n, 0) + 1)



def exact_radians(v: np.ndarray) -> np.ndarray:
    """Radians of the degree values ``v``, nudged by ulps so that converting back gives ``v`` exactly.

    A grid row is then shown as the decimal the user asked for (``27.4``, not ``27.400000000000002``).

    Examples
    --------
    >>> from loopsolve.kinematics.grid import exact_radians
    >>> v = np.array([27.4, 25.7, 67.9])
    >>> bool(np.all(np.degrees(exact_radians(v)) == v))
    True
    """
    v = np.asarray(v, dtype=float)
    x = np.radians(v)
    for _ in range(4):
        d = np.degrees(x)
        off = d != v
        if not off.any():
            break
        x[off] = np.nextafter(x[off], np.where(d[off] < v[off], np.inf, -np.inf))
    return x



class Grid:
    """Output grid values ``start + k·step`` for k in [kmin, kmax], and the input bounds.

    ``deg`` = (start, step) in degrees for a degree-unit angle input: the internal value of
    grid point k is then the radian value whose display is exactly ``start + k·step`` degrees.
    """

    def __init__(self, start, step, kmin, kmax, lo, hi, deg=None):
        self.start, self.step, self.kmin, self.kmax, self.lo, self.hi = start, step, kmin, kmax, lo, hi
        self.deg = deg

    def value(self, k: int) -> float:
        if self.deg is None:
            return self.start + self.step * k
        v = self.deg[0] + self.deg[1] * k
        x = math.radians(v)
        for _ in range(4):
            d = math.degrees(x)  # the same product x * (180/pi) as np.degrees
            if d == v:
                break
            x = math.nextafter(x, math.inf if d < v else -math.inf)
        return x

    def values(self, ks: np.ndarray) -> np.ndarray:
        """Vectorized :meth:`value`."""
        ks = np.asarray(ks)
        if self.deg is None:
            return self.start + self.step * ks
        return exact_radians(self.deg[0] + self.deg[1] * ks)

    def crossed(self, xa: float, xb: float) -> range:
        """Grid indices strictly after ``xa`` up to ``xb`` inclusive, in the order from xa to xb."""
        if xb == xa:
            return range(0)
        fa = (xa - self.start) / self.step
        fb = (xb - self.start) / self.step
        if fb > fa:
            k0, k1 = math.floor(fa + 1e-9) + 1, math.floor(fb + 1e-9)
            return range(max(k0, self.kmin), min(k1, self.kmax) + 1)
        k0, k1 = math.ceil(fa - 1e-9) - 1, math.ceil(fb - 1e-9)
        return range(min(k0, self.kmax), max(k1, self.kmin) - 1, -1)

    def next_after(self, x: float, d: float) -> int | None:
        """First grid index beyond ``x`` in input direction ``d`` (None past the ends)."""
        f = (x - self.start) / self.step
        if d * self.step > 0:
            k = math.floor(f + 1e-9) + 1
        else:
            k = math.ceil(f - 1e-9) - 1
        return k if self.kmin <= k <= self.kmax else None
