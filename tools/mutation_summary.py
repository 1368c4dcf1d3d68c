"""Survival rate per module from mutmut's results in ./mutants (see tools/mutation.sh).

``python3 tools/mutation_summary.py`` prints, per mutated module, how many mutants were tested,
killed (incl. timeouts), survived, had no covering test or are not yet checked, and the survival
rate over the tested ones; then the survivors, each with its verdict from the triage files
``tools/mutation_triage/<module>.txt`` (``NAME<TAB>killed: tests/...::test`` for a survivor that a
test written for it, or one the run's selection leaves out, kills; ``NAME<TAB>harmless: why`` for
one that cannot change what a user sees; ``NAME<TAB>untriaged: what is known``) or ``UNTRIAGED``. ``--names --every N`` prints every Nth mutant name of each module (a
reproducible sample for ``mutmut run NAME...``); ``--untriaged`` prints only the untriaged
survivors' names (for ``mutmut show``).

Mutant names number the mutations inside one function, so a triage line holds for the source it
was written against: after a function changes, re-run and re-triage its survivors.
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


TRIAGE = Path(__file__).with_name("mutation_triage")


def triage(folder: Path = TRIAGE) -> dict[str, str]:
    """Verdicts of the triage files: mutant name -> ``killed: ...`` or ``harmless: ...``."""
    out = {}
    for f in sorted(folder.glob("*.txt")) if folder.is_dir() else ():
        for line in f.read_text(encoding="utf-8").splitlines():
            name, sep, verdict = line.partition("\t")
            if sep and name.strip() and not name.startswith("#"):
                out[name.strip()] = verdict.strip()
    return out


def _kind(verdict: str) -> str:
    """``killed``, ``harmless`` or ``untriaged`` (no verdict, or one that says it is open)."""
    kind = verdict.split(":")[0].strip().lower()
    return kind if kind in ("killed", "harmless") else "untriaged"


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
    ap.add_argument("--untriaged", action="store_true", help="print only the untriaged survivors' names")
    args = ap.parse_args(argv)
    if args.generate:
        return generate()
    data = load()
    if args.names:
        for codes in data.values():
            for name in sorted(codes, key=_natural)[:: args.every]:
                print(name)
        return 0
    verdicts = triage()
    if not args.untriaged:
        print(f"{'module':24s} {'mutants':>7s} {'tested':>6s} {'killed':>6s} {'survived':>8s} "
              f"{'no test':>7s} {'unchecked':>9s} {'survival':>8s} {'triaged':>7s} {'after':>6s}")
    survivors = []
    for module, codes in data.items():
        c = Counter()
        for name, code in codes.items():
            key = ("unchecked" if code is None else "killed" if code in KILLED else "survived"
                   if code in SURVIVED else "no test" if code in NO_TESTS else "other")
            c[key] += 1
            if key == "survived":
                survivors.append(name)
                c["triaged"] += _kind(verdicts.get(name, "")) != "untriaged"
                c["now killed"] += verdicts.get(name, "").startswith("killed")
        tested = c["killed"] + c["survived"]
        rate = f"{100 * c['survived'] / tested:7.1f}%" if tested else "      -"
        # "after": survival once the tests written for survivors are counted (harmless ones stay)
        after = f"{100 * (c['survived'] - c['now killed']) / tested:5.1f}%" if tested else "     -"
        if not args.untriaged:
            print(f"{module:24s} {len(codes):7d} {tested:6d} {c['killed']:6d} {c['survived']:8d} "
                  f"{c['no test']:7d} {c['unchecked']:9d} {rate} {c['triaged']:7d} {after}")
    if args.untriaged:
        for name in survivors:
            if _kind(verdicts.get(name, "")) == "untriaged":
                print(name)
        return 0
    if survivors:
        kinds = Counter(_kind(verdicts.get(n, "")) for n in survivors)
        print(f"\nsurvivors: {len(survivors)} ({kinds['killed']} now killed by a test written for them or left "
              f"out of the run's selection, {kinds['harmless']} harmless, {kinds['untriaged']} untriaged); "
              "`mutmut show NAME` prints the diff")
        for name in survivors:
            print(f"  {name}  {verdicts.get(name, 'UNTRIAGED')}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
