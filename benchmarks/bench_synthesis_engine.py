"""Synthesis on numpy against synthesis with the compiled trace (issue 32, item 5), interleaved in one process.

Two problems, the same seeded ``ls.synthesize`` call under ``LOOPSOLVE_ENGINE=python`` (the numpy
reference) and under the default engine (``auto``: the candidates' traces, :meth:`Batch.follow
<loopsolve.design.synthesis.candidates.Batch.follow>`, compiled with numba once the process has traced
enough designs, :data:`~loopsolve.design.synthesis.candidates.FOLLOW_AUTO_CELLS`), one after the other
for every seed:

* ``five``: the five-point prescribed-timing problem of ``bench_synthesis.py``;
* ``ellipse``: ten points on an ellipse, free timing, crank required, no atlas starts (issue 30,
  ``bench_shape.py``'s ``PATH_PROBLEMS``).

Printed per run: CPU seconds and the objective of both engines (they agree to round-off); then the
median CPU of each and their ratio. The first default-engine run of the process includes numba's
import and the model's cached kernel (~0.8 s; the first run after a change of the kernel also compiles it).

    python benchmarks/bench_synthesis_engine.py --runs 3            # the README's figures
    python benchmarks/bench_synthesis_engine.py --runs 1 --only five
    LOOPSOLVE_ENGINE=python python benchmarks/bench_synthesis_engine.py --profile --only five   # where the CPU goes

``--profile``: one run (seed 0) of each problem under cProfile, with the engine of the environment;
prints the functions sorted by cumulative and by own time.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

import loopsolve as ls

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_shape import PATH_PROBLEMS  # noqa: E402
from bench_synthesis import PROBLEMS  # noqa: E402

ELLIPSE = PATH_PROBLEMS["ellipse (10 points, crank; published 4.02e-4)"]


def _five(mech, seed):
    prob = PROBLEMS["five"]
    return ls.synthesize(mech, path="P", targets={"x": prob["targets"][:, 0], "y": prob["targets"][:, 1]},
                         inputs=np.degrees(prob["inputs"]).tolist(), vary=prob["vary"], crank=prob["crank"],
                         seed=seed, progress=False)


def _ellipse(mech, seed):
    return ls.synthesize(mech, path="P", targets=ELLIPSE["targets"], vary=ELLIPSE["vary"], crank=True, seed=seed,
                         atlas=False, progress=False)


RUNS = {"five": _five, "ellipse": _ellipse}


def _one(fn, mech, seed, engine):
    old = os.environ.get("LOOPSOLVE_ENGINE")
    if engine is None:
        os.environ.pop("LOOPSOLVE_ENGINE", None)
    else:
        os.environ["LOOPSOLVE_ENGINE"] = engine
    try:
        c0 = time.process_time()
        try:
            f = fn(mech, seed).objective
        except ls.SynthesisError:
            f = math.inf
        return f, time.process_time() - c0
    finally:
        if old is None:
            os.environ.pop("LOOPSOLVE_ENGINE", None)
        else:
            os.environ["LOOPSOLVE_ENGINE"] = old


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--only", choices=list(RUNS))
    ap.add_argument("--json", help="write the figures here")
    ap.add_argument("--profile", action="store_true", help="profile one run of each problem instead")
    args = ap.parse_args(argv)
    mech = ls.load(Path(ls.models_dir()) / "fourbar_path_synthesis.toml")
    import scipy.stats  # noqa: F401 - imported by the multistart either way: not in the first run's figure

    if args.profile:
        import cProfile
        import pstats

        for name, fn in RUNS.items():
            if args.only and name != args.only:
                continue
            prof = cProfile.Profile()
            c0 = time.process_time()
            prof.enable()
            try:
                f = fn(mech, 0).objective
            except ls.SynthesisError:
                f = math.inf
            prof.disable()
            print(f"{name} seed 0 (LOOPSOLVE_ENGINE={os.environ.get('LOOPSOLVE_ENGINE', 'auto')}): f={f:.10g}, "
                  f"{time.process_time() - c0:.2f} s CPU", flush=True)
            for key in ("cumulative", "tottime"):
                pstats.Stats(prof, stream=sys.stdout).sort_stats(key).print_stats(30)
        return

    out = {}
    for name, fn in RUNS.items():
        if args.only and name != args.only:
            continue
        rows = []
        for seed in range(args.runs):
            fp, cp = _one(fn, mech, seed, "python")
            fa, ca = _one(fn, mech, seed, None)
            rows.append({"seed": seed, "numpy_cpu": cp, "default_cpu": ca, "numpy_f": fp, "default_f": fa})
            print(f"{name} seed {seed}: numpy {cp:.2f} s CPU (f={fp:.10g}); default engine {ca:.2f} s CPU "
                  f"(f={fa:.10g})", flush=True)
        mp = statistics.median(r["numpy_cpu"] for r in rows)
        ma = statistics.median(r["default_cpu"] for r in rows)
        out[name] = {"runs": rows, "numpy_median_cpu": mp, "default_median_cpu": ma, "ratio": ma / mp}
        print(f"{name}: median CPU numpy {mp:.2f} s, default engine {ma:.2f} s: {ma / mp:.2f}x", flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
