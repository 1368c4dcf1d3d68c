"""Burmester on the planted five-pose problem: the planted crank-rocker among the candidates, exactly.

The poses are those of a crank-rocker (ground pivots O2 = (1, 2), O4 = O2 + 60∠10°, crank 25,
coupler 70, rocker 45, coupler point 30 from the crank pin at 40° from the coupler line) at crank
angles 20°, 70°, 120°, 170°, 220°, computed here by circle intersection. The script prints every
dyad and every four-bar with its Grashof class and defects, the planted linkage's recovery error
(largest difference of a link length or pivot coordinate) and the time. Not a test; run from the
repository root::

    python benchmarks/bench_burmester.py
"""

from __future__ import annotations

import math
import time

import numpy as np

import loopsolve as ls

O2 = np.array([1.0, 2.0])
T1 = math.radians(10.0)
R1, R2, R3, R4, RP, GP = 60.0, 25.0, 70.0, 45.0, 30.0, math.radians(40.0)
O4 = O2 + R1 * np.array([math.cos(T1), math.sin(T1)])


def pose(t2_deg: float):
    t2 = math.radians(t2_deg)
    A = O2 + R2 * np.array([math.cos(t2), math.sin(t2)])
    d = O4 - A
    L = float(np.hypot(*d))
    a = (R3 * R3 - R4 * R4 + L * L) / (2 * L)
    B = A + a * d / L + math.sqrt(R3 * R3 - a * a) * np.array([-d[1], d[0]]) / L
    th3 = math.atan2(B[1] - A[1], B[0] - A[0])
    P = A + RP * np.array([math.cos(th3 + GP), math.sin(th3 + GP)])
    return float(P[0]), float(P[1]), math.degrees(th3)


def main() -> None:
    poses = [pose(t) for t in (20, 70, 120, 170, 220)]
    ls.burmester(poses)  # compile the candidate model once (disk cache)
    t = time.perf_counter()
    res = ls.burmester(poses)
    dt = time.perf_counter() - t
    print(f"{len(res.dyads)} real dyads, {len(res.candidates)} four-bars, {len(res.usable)} certified; {dt:.2f} s\n")
    for i, d in enumerate(res.dyads):
        print(f"dyad {i}: centre ({d.center[0]:.6f}, {d.center[1]:.6f}), radius {d.radius:.6f}")
    print()
    best = math.inf
    for c in res.candidates:
        print(f"dyads {c.dyads}: lengths ({', '.join(f'{v:.6g}' for v in c.lengths)}), {c.grashof.value}, "
              f"defects {[d.kind for d in c.defects] or 'none'}")
        p = {q.name: q.value for q in c.mechanism.parameters}
        o2 = np.array([p["x0"], p["y0"]])
        o4 = o2 + p["r1"] * np.array([math.cos(p["t1"]), math.sin(p["t1"])])
        err = max(np.abs(np.array(c.lengths) - (R1, R2, R3, R4)).max(), np.abs(o2 - O2).max(), np.abs(o4 - O4).max())
        best = min(best, err)
    print(f"\nplanted linkage recovered to {best:.2e} (largest length or pivot coordinate difference)")


if __name__ == "__main__":
    main()
