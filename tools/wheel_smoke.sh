#!/usr/bin/env bash
# The package as a user meets it: wheel_smoke.sh VENV WHEEL WORKDIR
# Installs WHEEL (with the plot extra) into the clean virtual environment VENV (made without system site
# packages), then, from WORKDIR (not the checkout), runs the README's main command, `loopsolve view`,
# `loopsolve synthesize` on a problem made from a shipped model, and `ls.models_dir()`, checking that the
# package, its page assets and its models come from the installed wheel.
set -euo pipefail
venv=$1 wheel=$2 work=$3
mkdir -p "$work"
"$venv/bin/python" -m pip install -q "${wheel}[plot]"
cd "$work"
export PATH="$venv/bin:$PATH" PYTHONPATH="" LOOPSOLVE_CACHE_DIR="$work/cache"
unset PYTHONHOME

where=$(python -c 'import loopsolve, sys; print(loopsolve.__file__)')
models=$(python -c 'import loopsolve as ls; print(ls.models_dir())')
prefix=$(python -c 'import sys; print(sys.prefix)')
case "$where" in "$prefix"/*) ;; *) echo "wheel smoke: loopsolve imported from $where, not the environment $prefix" >&2; exit 1;; esac
case "$models" in "$prefix"/*) ;; *) echo "wheel smoke: ls.models_dir() is $models, not in the environment $prefix" >&2; exit 1;; esac
echo "loopsolve from $where; models in $models"

# the README's main command
loopsolve sweep "$models/thesis_crank_rocker.toml" --from 0 --to 360 --step 30 > sweep.txt
grep -q "theta4" sweep.txt && [ "$(wc -l < sweep.txt)" -ge 13 ] || { echo "wheel smoke: sweep printed:" >&2; cat sweep.txt >&2; exit 1; }

# the page, its script and style inlined from the wheel's package data
loopsolve view "$models/thesis_crank_rocker.toml" -o page.html
grep -q 'id="loopsolve-input"' page.html && grep -q 'data-point' page.html \
  || { echo "wheel smoke: the page lacks its slider or points" >&2; exit 1; }
python - <<'PY'
import importlib.resources as res, pathlib
page = pathlib.Path("page.html").read_text(encoding="utf-8")
js = res.files("loopsolve.output").joinpath("view.js").read_text(encoding="utf-8")
assert js.strip()[:200] in page, "the page does not inline the wheel's view.js"
PY

# synthesis: five targets traced by the shipped path-synthesis model, found again by the general method
loopsolve solve "$models/fourbar_path_synthesis.toml" --at 30 --format json > /dev/null
python - "$models/fourbar_path_synthesis.toml" <<'PY'
import json, subprocess, sys
rows = []
for x in (30, 45, 60, 75, 90):
    out = subprocess.run(["loopsolve", "solve", sys.argv[1], "--at", str(x), "--format", "json"],
                         check=True, capture_output=True, text=True).stdout
    row = json.loads(out)["rows"][0]
    rows.append(f"{row['P_x']!r},{row['P_y']!r}")
open("targets.csv", "w").write("x,y\n" + "\n".join(rows) + "\n")
PY
loopsolve synthesize "$models/fourbar_path_synthesis.toml" --path P --targets targets.csv --inputs 30,45,60,75,90 \
  --vary r2=0.5:2 --vary r3=2:6 --seed 0 --quiet -o design.toml --report report.json
python - <<'PY'
import json
rep = json.load(open("report.json"))
assert rep["certificate"]["assembles"] and rep["objective"] < 1e-8, rep["objective"]
print(f"synthesize: objective {rep['objective']:.3g}, certified")
PY
loopsolve solve design.toml --at 45 > /dev/null

# the Python API from another directory
python -c 'import loopsolve as ls; m = ls.load(ls.models_dir() / "thesis_crank_rocker.toml"); print(m.solve(30))' > state.txt
echo "wheel smoke passed: $(python -c 'import sys; print(sys.version.split()[0])'), $(python -c 'import pint; print("pint", pint.__version__)')"
