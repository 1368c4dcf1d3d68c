"""What the default engine costs a user, and where its switch belongs (not a test).

``engine="auto"``, the default, runs the Python tracer until the process's sweeps have asked for
``AUTO_ROWS`` rows, then the compiled fast lane (numba). This measures, each in a fresh process
with the compiled model already in the cache (what a user has after the first use):

1. the one-off cost of the compiled engine: ``import numba`` and the first numba sweep of a
   cached model, less a warm numba sweep;
2. the Python tracer's cost per row of a 361-row cycle of the thesis crank-rocker;
3. their break-even in rows, next to ``AUTO_ROWS``;
4. a program that sweeps the 361-row cycle N times (N = 1 … 1000), with ``engine="python"``,
   ``"numba"`` and the default: each as a ratio to the cheaper of the two fixed engines (a
   rent-or-buy rule stays within 2× of the better choice made in hindsight).

Run from the repository root (needs the ``fast`` extra)::

    python benchmarks/bench_engine_default.py          # --quick: N up to 100
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MODEL = ROOT / "models" / "thesis_crank_rocker.toml"

CHILD = r"""
import json, sys, time
t0 = time.perf_counter()
import loopsolve as ls
mech = ls.load(sys.argv[1])
engine = None if sys.argv[2] == "default" else sys.argv[2]
n = int(sys.argv[3])
t1 = time.perf_counter()
engines = []
for _ in range(n):
    engines.append(mech.sweep(0, 360, 1, engine=engine).engine)
t2 = time.perf_counter()
print(json.dumps({"import": t1 - t0, "sweeps": t2 - t1, "numba": engines.count("numba")}))
"""


def child(engine: str, n: int, env: dict) -> dict:
    out = subprocess.run([sys.executable, "-c", CHILD, str(MODEL), engine, str(n)], env=env, check=True,
                         capture_output=True, text=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def best(engine: str, n: int, env: dict, repeats: int) -> dict:
    runs = [child(engine, n, env) for _ in range(repeats)]
    return min(runs, key=lambda r: r["sweeps"])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="N up to 100, fewer repeats")
    args = ap.parse_args()
    from loopsolve.kinematics.numba_engine.jit import AUTO_ROWS

    repeats = 2 if args.quick else 3
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, LOOPSOLVE_CACHE_DIR=cache, PYTHONPATH=str(ROOT))
        env.pop("LOOPSOLVE_ENGINE", None)
        child("numba", 1, env)  # compile once into this cache: the user's state after the first use
        one_nb = best("numba", 1, env, repeats)["sweeps"]
        many_nb = best("numba", 50, env, repeats)["sweeps"]
        warm_nb = (many_nb - one_nb) / 49
        buy = one_nb - warm_nb  # import numba + load the cached compiled model (the sweeps' part)
        py = best("python", 50, env, repeats)["sweeps"] / 50
        per_row = py / 361
        print(f"compiled engine, one-off (import numba + load a cached model): {buy * 1e3:.0f} ms")
        print(f"361-row cycle: Python {py * 1e3:.2f} ms ({per_row * 1e6:.1f} us/row), numba warm "
              f"{warm_nb * 1e3:.3f} ms")
        even = buy / max(per_row - warm_nb / 361, 1e-12)
        print(f"break-even: {even:,.0f} rows; AUTO_ROWS = {AUTO_ROWS:,} ({AUTO_ROWS / even:.2f}x the break-even)")
        print()
        print(f"{'N cycles':>9} | {'python':>9} | {'numba':>9} | {'default':>9} | default / best | numba sweeps")
        for n in ([1, 10, 30, 100] if args.quick else [1, 10, 30, 100, 300, 1000]):
            t = {e: best(e, n, env, repeats) for e in ("python", "numba", "default")}
            b = min(t["python"]["sweeps"], t["numba"]["sweeps"])
            print(f"{n:>9} | {t['python']['sweeps']:>8.3f}s | {t['numba']['sweeps']:>8.3f}s | "
                  f"{t['default']['sweeps']:>8.3f}s | {t['default']['sweeps'] / b:>14.2f} | "
                  f"{t['default']['numba']}/{n}")


if __name__ == "__main__":
    main()
