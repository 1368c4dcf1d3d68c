"""Fresh-process command line with the model already compiled and cached, against ``import numpy``.

The budget (issue 23): a cached ``loopsolve`` command stays within +150 ms of ``python -c "import
numpy"``. Quantities are read through pint, whose import and registry take ~0.7 s, so the script
also checks that a cached run does not import pint at all (its unit answers come from the memo
stored next to the compiled models).

    python benchmarks/bench_cli.py            # median of 11 runs of each command
    python benchmarks/bench_cli.py --runs 21
    python benchmarks/bench_cli.py --against ../main   # the same commands from another checkout, interleaved

It uses a private cache directory (a fresh temporary one), warms it with one run of each command,
then times. Run it on a quiet machine: other jobs make single timings vary by tens of ms.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
MODELS = ROOT / "models"
BUDGET_MS = 150.0

#: the budget applies to the first command (the kinematics sweep the issue measured at +123 ms); the
#: forces command is shown for its units (kg, kg/m^3, N*m, m/s^2): it imports sympy on every run for
#: its dynamics (on the main branch too), which is outside this budget
COMMANDS = {
    "sweep (kinematics, speed 10rpm)": ["sweep", str(MODELS / "thesis_crank_rocker.toml"), "--from", "0", "--to",
                                        "360", "--step", "1", "--format", "csv", "-o", os.devnull, "-q"],
    "forces (kg, kg/m^3, N*m, m/s^2)": ["forces", str(MODELS / "thesis_crank_rocker_dynamics.toml"), "--from", "0",
                                        "--to", "360", "--step", "5", "--format", "csv", "-o", os.devnull],
}

_PROBE = ("import sys; from loopsolve.cli import main; code = main(sys.argv[1:]); "
          "sys.stderr.write('PINT=%s\\n' % ('pint' in sys.modules)); sys.exit(code)")


def _time(cmd: list[str], env: dict) -> tuple[float, float]:
    """Wall-clock and CPU (user + system) seconds of one run: on a busy machine the CPU time is the
    steadier figure (it does not count the time the process waited for a core)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    subprocess.run(cmd, check=True, capture_output=True, env=env)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=11)
    ap.add_argument("--against", metavar="DIR", help="also time the commands with this checkout of loopsolve "
                    "first on PYTHONPATH (e.g. the main branch), interleaved with this one")
    args = ap.parse_args()
    cli = [sys.executable, "-m", "loopsolve.cli"]
    bare = [sys.executable, "-c", "import numpy"]
    trees = {"": ROOT} | ({" [against]": Path(args.against).resolve()} if args.against else {})
    with tempfile.TemporaryDirectory() as cache, tempfile.TemporaryDirectory() as cache2:
        envs = {}
        for (tag, root), cdir in zip(trees.items(), (cache, cache2)):
            env = dict(os.environ, LOOPSOLVE_CACHE_DIR=cdir)
            env["PYTHONPATH"] = os.pathsep.join([str(root)] + [p for p in env.get("PYTHONPATH", "").split(os.pathsep)
                                                               if p])
            envs[tag] = env
        pint_used = {}
        for tag, env in envs.items():
            for label, argv in COMMANDS.items():
                subprocess.run(cli + argv, check=True, capture_output=True, env=env)  # compile, fill the caches
                probe = subprocess.run([sys.executable, "-c", _PROBE] + argv, check=True, capture_output=True,
                                       text=True, env=env)
                pint_used[label + tag] = "PINT=True" in probe.stderr
        labels = [label + tag for tag in envs for label in COMMANDS]
        times: dict[str, list[tuple[float, float]]] = {"bare": []} | {label: [] for label in labels}
        for _ in range(args.runs):  # interleaved, so slow phases of the machine hit every command alike
            times["bare"].append(_time(bare, envs[""]))
            for tag, env in envs.items():
                for label, argv in COMMANDS.items():
                    times[label + tag].append(_time(cli + argv, env))
    def med(label, i):
        return statistics.median(t[i] for t in times[label])

    base, base_cpu = med("bare", 0), med("bare", 1)
    print(f"median of {args.runs} fresh processes, model compiled and cached (wall clock; CPU user+system):")
    bare_label = 'python -c "import numpy"'
    print(f"  {bare_label:54s} {base * 1e3:7.1f} ms; CPU {base_cpu * 1e3:6.1f} ms")
    worst = worst_cpu = 0.0
    for label in labels:
        m, c = med(label, 0), med(label, 1)
        if label == next(iter(COMMANDS)):
            worst, worst_cpu = m - base, c - base_cpu
        print(f"  loopsolve {label:44s} {m * 1e3:7.1f} ms (+{(m - base) * 1e3:.0f}); CPU {c * 1e3:6.1f} ms "
              f"(+{(c - base_cpu) * 1e3:.0f}); pint imported: {'yes' if pint_used[label] else 'no'}")
    ok = worst * 1e3 <= BUDGET_MS and not any(pint_used[label] for label in COMMANDS)
    print(f"budget: cached sweep <= +{BUDGET_MS:.0f} ms over bare numpy, no command importing pint: "
          f"{'MET' if ok else 'NOT MET'} (+{worst * 1e3:.0f} ms wall, +{worst_cpu * 1e3:.0f} ms CPU)")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
