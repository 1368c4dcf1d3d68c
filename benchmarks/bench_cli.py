"""Fresh-process command line with the model already compiled and cached, against ``import numpy``.

The budget (issue 23): a cached ``loopsolve`` command stays within +150 ms of ``python -c "import
numpy"``. Quantities are read through pint, whose import and registry take ~0.7 s, so the script
also checks that a cached run does not import pint at all (its unit answers come from the memo
stored next to the compiled models).

    python benchmarks/bench_cli.py            # median of 11 runs of each command
    python benchmarks/bench_cli.py --runs 21

It uses a private cache directory (a fresh temporary one), warms it with one run of each command,
then times. Run it on a quiet machine: other jobs make single timings vary by tens of ms.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
MODELS = ROOT / "models"
BUDGET_MS = 150.0

COMMANDS = {
    "sweep (kinematics, speed 10rpm)": ["sweep", str(MODELS / "thesis_crank_rocker.toml"), "--from", "0", "--to",
                                        "360", "--step", "1", "--format", "csv", "-o", os.devnull, "-q"],
    "forces (kg, kg/m^3, N*m, m/s^2)": ["forces", str(MODELS / "thesis_crank_rocker_dynamics.toml"), "--from", "0",
                                        "--to", "360", "--step", "5", "--format", "csv", "-o", os.devnull],
}

_PROBE = ("import sys; from loopsolve.cli import main; code = main(sys.argv[1:]); "
          "sys.stderr.write('PINT=%s\\n' % ('pint' in sys.modules)); sys.exit(code)")


def _time(cmd: list[str], env: dict) -> float:
    t = time.perf_counter()
    subprocess.run(cmd, check=True, capture_output=True, env=env)
    return time.perf_counter() - t


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=11)
    args = ap.parse_args()
    cli = [sys.executable, "-m", "loopsolve.cli"]
    bare = [sys.executable, "-c", "import numpy"]
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, LOOPSOLVE_CACHE_DIR=cache)
        env["PYTHONPATH"] = os.pathsep.join([str(ROOT)] + [p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p])
        pint_used = {}
        for label, argv in COMMANDS.items():
            subprocess.run(cli + argv, check=True, capture_output=True, env=env)  # compile, fill the caches
            probe = subprocess.run([sys.executable, "-c", _PROBE] + argv, check=True, capture_output=True,
                                   text=True, env=env)
            pint_used[label] = "PINT=True" in probe.stderr
        times: dict[str, list[float]] = {"bare": []} | {label: [] for label in COMMANDS}
        for _ in range(args.runs):  # interleaved, so slow phases of the machine hit every command alike
            times["bare"].append(_time(bare, env))
            for label, argv in COMMANDS.items():
                times[label].append(_time(cli + argv, env))
    base = statistics.median(times["bare"])
    print(f"median of {args.runs} fresh processes, model compiled and cached:")
    bare_label = 'python -c "import numpy"'
    print(f"  {bare_label:44s} {base * 1e3:7.1f} ms")
    worst = 0.0
    for label in COMMANDS:
        m = statistics.median(times[label])
        worst = max(worst, m - base)
        print(f"  loopsolve {label:34s} {m * 1e3:7.1f} ms  (+{(m - base) * 1e3:.0f} ms; "
              f"pint imported: {'yes' if pint_used[label] else 'no'})")
    ok = worst * 1e3 <= BUDGET_MS and not any(pint_used.values())
    print(f"budget: cached CLI <= +{BUDGET_MS:.0f} ms over bare numpy, without importing pint: "
          f"{'MET' if ok else 'NOT MET'} (worst +{worst * 1e3:.0f} ms)")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
