"""The warning for variables without a guess names options that exist (issue 18, triage re-check).

A mutant that upper-cased the hint ("OR CHOOSE A MODE WITH --MODE") was once triaged as
"wording only"; but the hint tells users what to type, and ``--MODE`` is no option of any
command. The hint must name ``--mode`` (an option of every command that solves), ``mode=``
for Python and the ``modes`` command, and following it must work.
"""

from __future__ import annotations

import re
import subprocess
import sys
import warnings

import pytest

import loopsolve as ls
from loopsolve.cli import build_parser

THESIS = ls.models_dir() / "thesis_crank_rocker.toml"
NO_GUESS = THESIS.read_text(encoding="utf-8").replace("theta3 = { guess = 20 }", "theta3 = {}")


def test_missing_guess_warning_names_real_options():
    assert NO_GUESS != THESIS.read_text(encoding="utf-8")
    mech = ls.loads(NO_GUESS, source="no_guess.toml")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        mech.solve(90)
    msgs = [str(w.message) for w in caught if issubclass(w.category, ls.LoopsolveWarning)]
    assert len(msgs) == 1
    msg = msgs[0]
    assert "no guess for theta3" in msg
    # the options it names, exactly as a user types them
    flags = re.findall(r"--[A-Za-z][\w-]*", msg)
    assert flags == ["--mode"], flags
    assert "mode=" in msg and "`loopsolve modes`" in msg
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command" or getattr(a, "choices", None))
    assert "modes" in sub.choices
    for command in ("solve", "sweep", "forces", "study", "draw", "plot", "view", "simulate"):
        opts = {o for a in sub.choices[command]._actions for o in a.option_strings}
        assert "--mode" in opts, command
    # following the hint works: mode= in Python picks the crossed circuit
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert mech.solve(90, mode="crossed").mode == "+"


def test_missing_guess_warning_on_the_command_line(tmp_path):
    model = tmp_path / "no_guess.toml"
    model.write_text(NO_GUESS, encoding="utf-8")
    r = subprocess.run([sys.executable, "-m", "loopsolve.cli", "solve", str(model), "--at", "90"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    line = next(x for x in r.stderr.splitlines() if "no guess for theta3" in x)
    assert line.startswith("loopsolve: warning: ") and "--mode SIGNATURE" in line and "--MODE" not in line
    r2 = subprocess.run([sys.executable, "-m", "loopsolve.cli", "solve", str(model), "--at", "90", "--mode", "+"],
                        capture_output=True, text=True)
    assert r2.returncode == 0, r2.stderr
