"""Motion generation: the general method on the planted five-pose problem, and Burmester beside it.

The poses are those of a crank-rocker (ground pivots O2 = (1, 2), O4 = O2 + 60∠10°, crank 25,
coupler 70, rocker 45, coupler point 30 from the crank pin at 40° from the coupler line) at crank
angles 20°, 70°, 120°, 170°, 220°, computed here by circle intersection (the problem of
``bench_burmester.py``). The general method (:func:`loopsolve.synthesize` with ``motion="P",
link="theta3"``, free timing, the assembly mode left to the search) runs on
``models/fourbar_path_synthesis.toml`` with every dimension and the frame placement varied:
r1…r4 ∈ [5, 100], x0, y0 ∈ [−50, 50], θ0 ∈ [−180°, 180°], rcx, rcy ∈ [−60, 60] (the phase φ is
redundant with free timing and stays 0). The objective is the contract's
Σ|Pᵢ − Tᵢ|² + (L·Δφᵢ)²; a planted exact linkage exists, so the optimum is 0.

Printed: every run's objective, certificate and seconds; the median and best objective, the
number of certified runs, the median seconds; and Burmester's recovery error (largest difference
of a link length or pivot coordinate from the planted linkage). Not a test; run from the
repository root::

    python benchmarks/bench_motion.py --runs 30
    python benchmarks/bench_motion.py --runs 3 --json motion.json
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import time
from pathlib import Path

import numpy as np

import loopsolve as ls

# the planted crank-rocker and its poses: the same linkage as bench_burmester.py (run from this folder)
from bench_burmester import GP, O2, O4, R1, R2, R3, R4, RP, T1, pose  # noqa: E402,F401

CRANK = (20, 70, 120, 170, 220)
VARY = {"r1": (5, 100), "r2": (5, 100), "r3": (5, 100), "r4": (5, 100), "x0": (-50, 50), "y0": (-50, 50),
        "theta0": (-180, 180), "rcx": (-60, 60), "rcy": (-60, 60)}


def burmester_recovery(poses):
    t = time.perf_counter()
    res = ls.burmester(poses)
    dt = time.perf_counter() - t
    best = math.inf
    for c in res.candidates:
        p = {q.name: q.value for q in c.mechanism.parameters}
        o2 = np.array([p["x0"], p["y0"]])
        o4 = o2 + p["r1"] * np.array([math.cos(p["t1"]), math.sin(p["t1"])])
        err = max(np.abs(np.array(c.lengths) - (R1, R2, R3, R4)).max(), np.abs(o2 - O2).max(), np.abs(o4 - O4).max())
        if c.certified:
            best = min(best, err)
    return best, len(res.candidates), len(res.usable), dt


def run_general(mech, targets, seed, maxiter, popsize, restarts):
    t = time.perf_counter()
    try:
        res = ls.synthesize(mech, motion="P", link="theta3", targets=targets, vary=VARY, seed=seed,
                            maxiter=maxiter, popsize=popsize, restarts=restarts, progress=False)
        f, cert, params = res.objective, res.report["certificate"], res.report["parameters"]
    except ls.SynthesisError:
        f, cert, params = math.inf, None, {}
    return f, time.perf_counter() - t, bool(cert) and not cert["defects"], params


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=30)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--maxiter", type=int, default=150)
    ap.add_argument("--popsize", type=int, default=15)
    ap.add_argument("--restarts", type=int, default=4)
    ap.add_argument("--json", help="write the figures here")
    args = ap.parse_args(argv)
    poses = [pose(t) for t in CRANK]
    targets = {"x": [p[0] for p in poses], "y": [p[1] for p in poses], "angle": [p[2] for p in poses]}
    ls.burmester(poses)  # compile the candidate model once (disk cache)
    rec, ncand, nusable, bsec = burmester_recovery(poses)
    print(f"Burmester: {ncand} four-bars, {nusable} certified, planted linkage recovered to {rec:.2e} "
          f"({bsec:.2f} s)", flush=True)
    mech = ls.load(Path(ls.models_dir()) / "fourbar_path_synthesis.toml")
    runs = []
    for r in range(args.runs):
        f, sec, ok, params = run_general(mech, targets, args.seed + r, args.maxiter, args.popsize, args.restarts)
        runs.append((f, sec, ok))
        dims = ", ".join(f"{k}={params[k]:.6g}" for k in ("r1", "r2", "r3", "r4") if k in params)
        print(f"run {r} (seed {args.seed + r}): f={f:.4g} certified={ok} {sec:.1f} s  {dims}", flush=True)
    fs = [f for f, _, _ in runs]
    summary = {"runs": args.runs, "median": statistics.median(fs), "best": min(fs),
               "at_most_1e-12": sum(f <= 1e-12 for f in fs), "certified": sum(ok for _, _, ok in runs),
               "median_seconds": statistics.median(s for _, s, _ in runs),
               "burmester": {"recovery_error": rec, "candidates": ncand, "certified": nusable, "seconds": bsec}}
    print(json.dumps(summary, indent=2), flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(summary, indent=2))


if __name__ == "__main__":
    main()
