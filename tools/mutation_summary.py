"""Survival rate per module from mutmut's results in ./mutants (see tools/mutation.sh).

``python3 tools/mutation_summary.py`` prints, per mutated module, how many mutants were tested,
killed (incl. timeouts), survived, had no covering test or are not yet checked, and the survival
rate over the tested ones; then the names of the survivors. ``--names --every N`` prints every
Nth mutant name of each module (a reproducible sample for ``mutmut run NAME...``).
"""

from __future__ import annotations

import argparse
import json
from collections import Counter
from pathlib import Path

KILLED = {1, 3, 36, 24, -24, 152, 255, -9, -11, 37}  # failing tests, timeouts, crashes
SURVIVED = {0}
NO_TESTS = {33, 5}


def load(root: Path = Path("mutants")) -> dict[str, dict[str, int | None]]:
    out = {}
    for meta in sorted(root.rglob("*.py.meta")):
        module = str(meta.relative_to(root))[: -len(".py.meta")].replace("/", ".")
        out[module] = json.loads(meta.read_text())["exit_code_by_key"]
    return out


def _natural(name: str):
    stem, _, n = name.rpartition("__mutmut_")
    return stem, int(n) if n.isdigit() else 0


def generate() -> int:
    """What ``mutmut run`` does before testing: copy the tree to ./mutants and write the mutants."""
    import os

    import mutmut.__main__ as mm

    mm.set_mutant_under_test("mutant_generation")
    os.makedirs("mutants", exist_ok=True)
    mm.copy_src_dir()
    mm.copy_also_copy_files()
    mm.setup_source_paths()
    mm.store_lines_covered_by_tests()
    stats = mm.create_mutants(1)
    print(f"{stats.mutated} files mutated")
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--names", action="store_true", help="print a sample of mutant names instead")
    ap.add_argument("--every", type=int, default=1)
    ap.add_argument("--generate", action="store_true", help="only (re)generate the mutants, run no test")
    args = ap.parse_args(argv)
    if args.generate:
        return generate()
    data = load()
    if args.names:
        for codes in data.values():
            for name in sorted(codes, key=_natural)[:: args.every]:
                print(name)
        return 0
    print(f"{'module':28s} {'mutants':>7s} {'tested':>6s} {'killed':>6s} {'survived':>8s} "
          f"{'no test':>7s} {'unchecked':>9s} {'survival':>8s}")
    survivors = []
    for module, codes in data.items():
        c = Counter()
        for name, code in codes.items():
            key = ("unchecked" if code is None else "killed" if code in KILLED else "survived"
                   if code in SURVIVED else "no test" if code in NO_TESTS else "other")
            c[key] += 1
            if key == "survived":
                survivors.append(name)
        tested = c["killed"] + c["survived"]
        rate = f"{100 * c['survived'] / tested:7.1f}%" if tested else "      -"
        print(f"{module:28s} {len(codes):7d} {tested:6d} {c['killed']:6d} {c['survived']:8d} "
              f"{c['no test']:7d} {c['unchecked']:9d} {rate}")
    if survivors:
        print("\nsurvivors (`mutmut show NAME` prints the diff):")
        for name in survivors:
            print("  " + name)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
