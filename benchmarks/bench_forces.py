"""Benchmark: force analysis along a 10⁵-point sweep against the kinematic sweep alone (not a test).

Models with bodies (the thesis crank-rocker with steel bars, the engine slider-crank, the
crank-shaper): the median time of ``mech.sweep(0, 360, step)`` (positions, velocities,
accelerations, jerks; batched) and of ``ls.forces(mech, 0, 360, step)`` (the same sweep, then
Newton–Euler for every point: driving torque, joint forces, shaking force, energies and the
power-balance residual), and their ratio, in one run. Target: forces within 3× the sweep.
The dynamics are derived (sympy) once per process before timing.

Run from the repository root::

    python benchmarks/bench_forces.py            # --quick: fewer repeats, 10⁴ points
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np

import loopsolve as ls

ROOT = Path(__file__).resolve().parents[1]
MODELS = ("thesis_crank_rocker_dynamics", "engine_slider_crank", "shaper_dynamics")


def median(fn, repeats):
    times, out = [], None
    for _ in range(repeats):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times), out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="3 repeats and 10^4 points")
    args = ap.parse_args()
    n = 10_000 if args.quick else 100_000
    repeats = 3 if args.quick else 5
    step = 360.0 / n
    print(f"{'model':34s} {'points':>8s} {'sweep [s]':>10s} {'forces [s]':>11s} {'ratio':>6s}  check")
    for name in MODELS:
        mech = ls.load(ROOT / "models" / f"{name}.toml")
        ls.forces(mech, 0, 360, 30)  # derive and compile once (sympy), outside the timing
        t_kin, sw = median(lambda: mech.sweep(0, 360, step, progress=False), repeats)
        t_dyn, fs = median(lambda: ls.forces(mech, 0, 360, step), repeats)
        worst = float(np.nanmax(np.abs(fs.power_residual)) / max(np.nanmax(np.abs(fs.drive)), 1e-300))
        print(f"{name:34s} {len(sw):8d} {t_kin:10.3f} {t_dyn:11.3f} {t_dyn / t_kin:6.2f}  "
              f"max |power residual| / max |T| = {worst:.1e}")


if __name__ == "__main__":
    main()
