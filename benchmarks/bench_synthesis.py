"""Path-synthesis benchmarks of the literature: loopsolve's synthesize against scipy's DE on a closed form.

Two classic four-bar problems (objective f = Σ|P(θ2ᵢ) − Tᵢ|², see issue 19):

* ``five``: five points, prescribed timing θ2 = 30°…90° (Kunjur & Krishnamurty 1997; Cabrera et al.
  2002 "case 2"); x0 = y0 = θ0 = 0, r1…r4 ∈ [0.2, 50], rcx, rcy ∈ [−50, 50]. Best published 1.284e-6.
* ``eighteen``: eighteen points on a closed curve, θ2 = φ + 20°·(i − 1), φ free, crank required
  (Cabrera et al. "case 3"); r ∈ [0.2, 50], x0, y0, rcx, rcy ∈ [−50, 50], θ0, φ ∈ [0°, 360°].
  Best published 9.11e-3.

For each problem, ``--runs`` seeded runs of :func:`loopsolve.synthesize` (every reported design
certified by the tracker) and, in the same process, ``--runs`` seeded runs of
``scipy.optimize.differential_evolution`` with its defaults on a hand-written closed-form numpy
objective (circle intersection, the better of the two assembly modes at every point — no
continuity check, as the published codes) with the same bounds. Medians, bests and times are
printed; ``--json`` writes them.

    python benchmarks/bench_synthesis.py --runs 30          # the README's figures
    python benchmarks/bench_synthesis.py --runs 3 --only five
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

FIVE_T = np.array([(3, 3), (2.759, 3.363), (2.372, 3.663), (1.89, 3.862), (1.355, 3.943)], dtype=float)
FIVE_X = np.radians([30, 45, 60, 75, 90])
EIGHTEEN_T = np.array([(0.5, 1.1), (0.4, 1.1), (0.3, 1.1), (0.2, 1.0), (0.1, 0.9), (0.05, 0.75), (0.02, 0.6),
                       (0, 0.5), (0, 0.4), (0.03, 0.3), (0.1, 0.25), (0.15, 0.2), (0.2, 0.3), (0.3, 0.4),
                       (0.4, 0.5), (0.5, 0.7), (0.6, 0.9), (0.6, 1.0)], dtype=float)
EIGHTEEN_X = np.radians(20.0 * np.arange(18))

PROBLEMS = {
    "five": {"targets": FIVE_T, "inputs": FIVE_X, "crank": False, "published": 1.284e-6,
             "vary": {"r1": (0.2, 50), "r2": (0.2, 50), "r3": (0.2, 50), "r4": (0.2, 50), "rcx": (-50, 50),
                      "rcy": (-50, 50)}},
    "eighteen": {"targets": EIGHTEEN_T, "inputs": EIGHTEEN_X, "crank": True, "published": 9.11e-3,
                 "vary": {"r1": (0.2, 50), "r2": (0.2, 50), "r3": (0.2, 50), "r4": (0.2, 50), "rcx": (-50, 50),
                          "rcy": (-50, 50), "x0": (-50, 50), "y0": (-50, 50), "theta0": (0, 360),
                          "phi": (0, 360)}},
}


def closed_form_objective(names, targets, inputs, crank):
    """f(v) by circle intersection, per design (what a hand-written baseline does)."""
    idx = {n: i for i, n in enumerate(names)}

    def get(v, n, default=0.0):
        return v[idx[n]] if n in idx else default

    def f(v):
        r1, r2, r3, r4 = (get(v, n) for n in ("r1", "r2", "r3", "r4"))
        rcx, rcy, x0, y0 = get(v, "rcx"), get(v, "rcy"), get(v, "x0"), get(v, "y0")
        t0, ph = math.radians(get(v, "theta0")), math.radians(get(v, "phi"))
        if crank:  # Grashof crank: s + l <= p + q with the crank shortest
            s = sorted((r1, r2, r3, r4))
            if r2 != s[0] or s[0] + s[3] > s[1] + s[2]:
                return 1e6
        a = inputs + ph + t0
        Ax, Ay = x0 + r2 * np.cos(a), y0 + r2 * np.sin(a)
        Ox, Oy = x0 + r1 * math.cos(t0), y0 + r1 * math.sin(t0)
        dx, dy = Ox - Ax, Oy - Ay
        d = np.hypot(dx, dy)
        if np.any(d > r3 + r4) or np.any(d < abs(r3 - r4)):
            return 1e6
        along = (d * d + r3 * r3 - r4 * r4) / (2 * d)
        h = np.sqrt(np.maximum(r3 * r3 - along * along, 0.0))
        best = np.inf
        for sgn in (1.0, -1.0):
            Bx = Ax + (along * dx - sgn * h * dy) / d
            By = Ay + (along * dy + sgn * h * dx) / d
            ux, uy = (Bx - Ax) / r3, (By - Ay) / r3
            Px, Py = Ax + rcx * ux - rcy * uy, Ay + rcx * uy + rcy * ux
            best = min(best, float(np.sum((Px - targets[:, 0]) ** 2 + (Py - targets[:, 1]) ** 2)))
        return best

    return f


def run_baseline(prob, seed):
    from scipy.optimize import differential_evolution

    names = list(prob["vary"])
    f = closed_form_objective(names, prob["targets"], prob["inputs"], prob["crank"])
    t = time.perf_counter()
    res = differential_evolution(f, [prob["vary"][n] for n in names], seed=seed)
    return float(res.fun), time.perf_counter() - t


def run_loopsolve(mech, prob, seed, **opts):
    t = time.perf_counter()
    try:
        res = ls.synthesize(mech, path="P", targets={"x": prob["targets"][:, 0], "y": prob["targets"][:, 1]},
                            inputs=np.degrees(prob["inputs"]).tolist(), vary=prob["vary"], crank=prob["crank"],
                            seed=seed, progress=False, **opts)
        f, cert = res.objective, res.report["certificate"]
    except ls.SynthesisError:
        f, cert = math.inf, None
    return f, time.perf_counter() - t, cert


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=30)
    ap.add_argument("--only", choices=list(PROBLEMS))
    ap.add_argument("--maxiter", type=int, help="DE generations (default: synthesize's)")
    ap.add_argument("--popsize", type=int, help="DE population factor (default: synthesize's)")
    ap.add_argument("--restarts", type=int, help="DE searches per mode (default: synthesize's)")
    ap.add_argument("--starts", type=int, help="multistart designs polished in lockstep (default: synthesize's)")
    ap.add_argument("--no-baseline", action="store_true")
    ap.add_argument("--json", help="write the figures here")
    args = ap.parse_args(argv)
    mech = ls.load(Path(ls.models_dir()) / "fourbar_path_synthesis.toml")
    out = {}
    for name, prob in PROBLEMS.items():
        if args.only and name != args.only:
            continue
        ours, base = [], []
        for r in range(args.runs):
            opts = {k: v for k, v in (("restarts", args.restarts), ("starts", args.starts), ("maxiter", args.maxiter),
                                      ("popsize", args.popsize)) if v is not None}
            f, sec, cert = run_loopsolve(mech, prob, r, **opts)
            ours.append((f, sec, bool(cert) and not cert["defects"]))
            line = f"{name} run {r}: loopsolve f={f:.6g} ({sec:.1f} s, certified={ours[-1][2]})"
            if not args.no_baseline:
                fb, sb = run_baseline(prob, r)
                base.append((fb, sb))
                line += f"; scipy DE closed form f={fb:.6g} ({sb:.1f} s)"
            print(line, flush=True)
        fs = [f for f, _, _ in ours]
        summary = {"published_best": prob["published"], "runs": args.runs,
                   "loopsolve": {"median": statistics.median(fs), "best": min(fs),
                                 "median_seconds": statistics.median(s for _, s, _ in ours),
                                 "certified": sum(c for _, _, c in ours)}}
        if base:
            summary["scipy_de_closed_form"] = {"median": statistics.median(f for f, _ in base),
                                               "best": min(f for f, _ in base),
                                               "median_seconds": statistics.median(s for _, s in base)}
        out[name] = summary
        print(json.dumps({name: summary}, indent=2), flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
