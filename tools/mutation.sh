#!/usr/bin/env bash
# Mutation testing of the numerical core and the outputs (symbolic, compiled, solve, newton,
# kernel/continuation/sweep, batch, export, info, kinetostatics) and of forces, studies and the page
# (dynamics, bodies, forceresults, simulation, lockstep, studies, metrics, sensitivity, designs, view)
# with mutmut 3; configured in pyproject.toml
# [tool.mutmut] (modules to mutate, a fast in-process test selection). Slow, so it is not part of
# the test command. Results are kept in ./mutants/ (git-ignored); a second run only re-tests what
# changed.
#
#   tools/mutation.sh                          # every mutant of every configured module (hours)
#   tools/mutation.sh 'loopsolve.symbolic.compiled*'    # one module (mutant names are module.function__mutmut_N)
#   MUTATION_SAMPLE=10 tools/mutation.sh       # a reproducible sample: every 10th mutant of each module
#   MUTATION_SAMPLE=60 MUTATION_MODULES="studies view" tools/mutation.sh   # ... of these modules only (design.studies, output.view)
#   tools/mutation.sh --summary                # only print the survival rate per module and the verdicts
#                                              # of tools/mutation_triage/<module>.txt on the survivors
#
# Jobs run niced with MUTMUT_CHILDREN (default 1) workers.
set -euo pipefail
cd "$(dirname "$0")/.."
export PYTHONPATH="$PWD/mutants"    # CLI tests in subprocesses import the mutated package too
export MPLBACKEND=Agg
unset LOOPSOLVE_DEBUG

if [[ "${1:-}" != "--summary" ]]; then
  names=("$@")
  if [[ -n "${MUTATION_SAMPLE:-}" && ${#names[@]} -eq 0 ]]; then
    # generate the mutants (no test run), then pick every Nth name of each module (natural order)
    nice -n 19 python3 tools/mutation_summary.py --generate >/dev/null
    # MUTATION_MODULES="studies view" limits the sample to those modules
    mods="${MUTATION_MODULES:-.*}"
    mapfile -t names < <(python3 tools/mutation_summary.py --names --every "$MUTATION_SAMPLE" \
                         | grep -E "^loopsolve\.([a-z_]+\.)?(${mods// /|})\.")
  fi
  nice -n 19 mutmut run --max-children "${MUTMUT_CHILDREN:-1}" "${names[@]}" || true
fi
python3 tools/mutation_summary.py
