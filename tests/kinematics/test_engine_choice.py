"""The engine a sweep runs when the user does not name one (``engine=None``, no ``--engine``).

The default is ``"auto"``: the Python tracer until the sweeps of the process have asked for
``AUTO_ROWS`` rows (the break-even of importing numba and loading a compiled model), then the
compiled fast lane where numba is installed and the model has one; ``$LOOPSOLVE_ENGINE`` and the
argument override it. ``Sweep.engine`` says which engine ran.
"""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.kinematics.numba_engine import jit
from loopsolve.kinematics.scalar_solver import kernel_of

from support.models import write_pitch_cam

THESIS = ls.models_dir() / "thesis_crank_rocker.toml"
HAS_NUMBA = importlib.util.find_spec("numba") is not None


@pytest.fixture
def fresh(monkeypatch):
    """A process that has swept nothing yet, with no engine in the environment."""
    monkeypatch.delenv("LOOPSOLVE_ENGINE", raising=False)
    monkeypatch.setattr(jit, "_AUTO_SEEN", [0])


def _no_numba(monkeypatch):
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "numba" else real(name, *a))
    monkeypatch.setitem(sys.modules, "numba", None)  # also when an earlier test imported it: not installed


def test_without_numba_the_default_is_python_however_long_the_sweep(fresh, monkeypatch):
    _no_numba(monkeypatch)
    mech = ls.load(THESIS)
    sw = mech.sweep(0, 360, 0.01)  # 36001 rows: past AUTO_ROWS in one sweep
    assert len(sw) == 36001 > jit.AUTO_ROWS
    assert sw.engine == "python"
    with pytest.raises(ls.MissingDependencyError):  # naming numba is still an error without it
        mech.sweep(0, 90, 10, engine="numba")


@pytest.mark.skipif(not HAS_NUMBA, reason="the fast extra (numba) is not installed")
def test_the_default_switches_to_numba_once_the_rows_asked_for_pay_for_it(fresh):
    mech = ls.load(THESIS)
    assert jit.has_lane(kernel_of(mech.compile()))
    first = mech.sweep(0, 360, 1)
    assert first.engine == "python"  # 361 rows: importing numba would cost more than it saves
    n, engines = len(first), [first.engine]
    while n < jit.AUTO_ROWS:
        sw = mech.sweep(0, 360, 1)
        n += len(sw)
        engines.append(sw.engine)
    # rent, then buy: Python for every sweep before the total reached AUTO_ROWS, numba from it on
    assert engines[:-1] == ["python"] * (len(engines) - 1) and engines[-1] == "numba"
    assert mech.sweep(0, 360, 1).engine == "numba"  # and it stays switched
    for a in ("z", "z1", "z2"):  # the engines agree to round-off
        assert np.max(np.abs(getattr(sw, a) - getattr(first, a))) <= 1e-12
    assert sw.modes == first.modes and sw.mode == first.mode


@pytest.mark.skipif(not HAS_NUMBA, reason="the fast extra (numba) is not installed")
def test_one_long_sweep_takes_numba_at_once(fresh):
    sw = ls.load(THESIS).sweep(0, 360, 360 / jit.AUTO_ROWS)
    assert len(sw) > jit.AUTO_ROWS and sw.engine == "numba"


@pytest.mark.skipif(not HAS_NUMBA, reason="the fast extra (numba) is not installed")
def test_the_environment_and_the_argument_override_the_default(fresh, monkeypatch):
    mech = ls.load(THESIS)
    monkeypatch.setenv("LOOPSOLVE_ENGINE", "numba")
    assert mech.sweep(0, 90, 10).engine == "numba"  # a short sweep, but the environment asks
    assert mech.sweep(0, 90, 10, engine="python").engine == "python"  # the argument wins
    monkeypatch.setenv("LOOPSOLVE_ENGINE", "python")
    assert mech.sweep(0, 360, 0.01).engine == "python"
    monkeypatch.setenv("LOOPSOLVE_ENGINE", "auto")
    assert mech.sweep(0, 90, 10).engine == "python"
    assert jit._AUTO_SEEN[0] == 10  # only "auto" sweeps count towards the switch


def test_every_shipped_model_has_a_fast_lane():
    for path in sorted(ls.models_dir().glob("*.toml")):
        assert jit.has_lane(kernel_of(ls.load(path).compile())), path.name


def test_a_model_numba_cannot_compile_in_time_runs_python_and_says_so_under_numba(fresh, tmp_path):
    """A cam declared by 72 pitch points: its spline makes generated functions of hundreds of thousands of
    characters, which numba's type inference does not get through in minutes (it hung a test for 15)."""
    mech = ls.load(write_pitch_cam(tmp_path, np.arange(0.0, 360.0, 5.0)))
    kern = kernel_of(mech.compile())
    assert jit.model_source_chars(kern.ck) > jit.MAX_LANE_SOURCE and not jit.has_lane(kern)
    ref = mech.sweep(0, 90, 5, engine="python")
    assert mech.sweep(0, 360, 360 / jit.AUTO_ROWS).engine == "python"  # "auto" past AUTO_ROWS: still Python
    if HAS_NUMBA:
        with pytest.warns(ls.LoopsolveWarning, match=r"cam\.toml: engine='numba' but the model has no compiled "
                                                     r"lane \(its generated functions are [\d,]+ characters"):
            sw = mech.sweep(0, 90, 5, engine="numba")
        assert sw.engine == "python" and np.array_equal(sw.z, ref.z)


def test_a_one_off_command_line_sweep_does_not_import_numba(tmp_path):
    """The default keeps a short command-line sweep at the start-up cost of numpy: numba is not imported."""
    script = ("import sys\nfrom loopsolve.cli import main\n"
              f"code = main(['sweep', {str(THESIS)!r}, '--from', '0', '--to', '360', '--step', '1', '-q', "
              f"'--format', 'csv', '-o', {str(tmp_path / 'out.csv')!r}])\n"
              "print(code, 'numba' in sys.modules)\n")
    env = {k: v for k, v in os.environ.items() if k != "LOOPSOLVE_ENGINE"}
    out = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["0", "False"], out.stderr
    assert (tmp_path / "out.csv").read_text().count("\n") == 362  # header + 361 rows
