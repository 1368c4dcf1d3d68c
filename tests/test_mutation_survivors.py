"""Tests written for mutants that survived ``tools/mutation.sh`` (mutmut) and change what a user sees.

Each test names the mutant it kills (``mutmut show NAME`` prints the diff). Surviving mutants that
cannot change a user-visible result are listed, with the reason, in the closing note of issue 13.
"""

from __future__ import annotations

import math

import loopsolve as ls
from loopsolve import export
from loopsolve.cli import main


def test_state_table_ends_with_its_last_section(capsys):
    """loopsolve.export.x_state_table__mutmut_136 appended text after the last section."""
    mech = ls.slider_crank(5, 8, theta2=45)
    out = export.to_table(mech.solve(45))
    assert out.endswith("\n") and not out.endswith("\n\n")
    last = out.rstrip("\n").splitlines()[-1].split()
    # the last section is the points table: its last row is the slider C, with 8 numbers
    assert last[0] == "C" and len(last) == 9
    assert last[1] == f"{5 * math.cos(math.pi / 4) + math.sqrt(64 - 12.5):g}"  # x of C, 6 digits
    assert main(["solve", str(ls.models_dir() / "example1_slider_crank.toml")]) == 0
    printed = capsys.readouterr().out
    assert printed.endswith("\n") and printed.rstrip("\n").splitlines()[-1].split()[0] == "C"
