"""An unreadable cache entry of any kind is a miss: rebuilt, never a failure (issue 29).

Every kind of file loopsolve keeps in its cache directory is planted truncated, as garbage or empty
in a copy of a warm cache, and the user's command is run on it in a fresh process: it must exit 0
with the same output as on a fresh cache (the solve also against the four-bar's closed form), and
leave a good entry behind (its header's sha256 matches its text; numba's index unpickles and names
the compiled function). The kinds: the generated model module ``m_*.py`` (``solve``), the numba
engine's module ``nb_*.py`` and numba's index ``*.nbi`` and data ``*.nbc`` in ``__pycache__``
(``sweep --engine numba``), the study kernels ``phip_*.py`` and ``fused_*.py`` (``study
--sensitivity``) and the synthesis kernel ``ptsp_*.py`` (``synthesize``).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import pickle
import random
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import loopsolve as ls
from support.models import fourbar_open_angles

THESIS = ls.models_dir() / "thesis_crank_rocker.toml"
PATHSYN = ls.models_dir() / "fourbar_path_synthesis.toml"
TARGETS = "x,y\n1.247635,2.261923\n1.125070,2.556968\n0.759129,2.635152\n"


def theta4_closed_form(t2_deg):
    """The thesis four-bar's rocker angle (open mode, degrees), by circle intersection."""
    return math.degrees(fourbar_open_angles(math.radians(t2_deg))[1])


def run(cache: Path, *args, cwd: Path):
    env = dict(os.environ, LOOPSOLVE_CACHE_DIR=str(cache), PYTHONPATH=os.pathsep.join(sys.path))
    env.pop("LOOPSOLVE_DEBUG", None)
    env.pop("LOOPSOLVE_ENGINE", None)
    return subprocess.run([sys.executable, "-m", "loopsolve.cli", *map(str, args)], capture_output=True, text=True,
                          env=env, cwd=cwd)


def _solve(cache, work):
    p = run(cache, "solve", THESIS, "--at", "90", "--format", "json", cwd=work)
    return p, p.stdout


def _numba_sweep(cache, work):
    p = run(cache, "sweep", THESIS, "--from", "0", "--to", "360", "--step", "10", "--engine", "numba",
            "--format", "csv", "-q", cwd=work)
    return p, p.stdout


def _study(cache, work):
    out = work / "study.csv"
    if out.exists():
        out.unlink()
    p = run(cache, "study", THESIS, "--vary", "r2=20:30:3", "--from", "0", "--to", "90", "--step", "30",
            "--sensitivity", "-q", "-o", out, cwd=work)
    return p, out.read_text(encoding="utf-8") if out.exists() else None


def _synthesize(cache, work):
    tgt, rep = work / "t.csv", work / "r.json"
    tgt.write_text(TARGETS, encoding="utf-8")
    if rep.exists():
        rep.unlink()
    p = run(cache, "synthesize", PATHSYN, "--path", "P", "--targets", tgt, "--inputs", "30,60,90", "--vary",
            "r2=0.5:2", "--vary", "rcx=0:3", "--popsize", "4", "--maxiter", "3", "--starts", "5", "--report", rep,
            "-q", cwd=work)
    if not rep.exists():
        return p, None
    data = json.loads(rep.read_text(encoding="utf-8"))
    data.pop("seconds", None)
    return p, data


COMMANDS = {"solve": _solve, "numba": _numba_sweep, "study": _study, "synthesize": _synthesize}
# the kind of entry -> (glob in the cache directory, the command that uses it)
KINDS = {
    "model module": ("m_*.py", "solve"),
    "numba module": ("nb_*.py", "numba"),
    "numba index": ("__pycache__/nb_*.nbi", "numba"),
    "numba data": ("__pycache__/nb_*.nbc", "numba"),
    "sensitivity kernel": ("phip_*.py", "study"),
    "fused kernel": ("fused_*.py", "study"),
    "synthesis kernel": ("ptsp_*.py", "synthesize"),
}


@pytest.fixture(scope="module")
def warm(tmp_path_factory):
    """A cache of each command's own, filled by running it once, and its output there (the reference)."""
    try:
        import numba  # noqa: F401
        have_numba = True
    except ImportError:
        have_numba = False
    out = {}
    for name, cmd in COMMANDS.items():
        if name == "numba" and not have_numba:
            continue
        base = tmp_path_factory.mktemp(name)
        cache, work = base / "cache", base / "work"
        work.mkdir()
        p, ref = cmd(cache, work)
        assert p.returncode == 0, (name, p.stderr)
        out[name] = (cache, ref)
    return out


def _corrupt(path: Path, how: str) -> None:
    data = path.read_bytes()
    if how == "truncated":
        path.write_bytes(data[: len(data) // 2])
    elif how == "garbage":
        rng = random.Random(path.name)
        path.write_bytes(bytes(rng.randrange(256) for _ in range(max(64, len(data) // 4))))
    else:
        path.write_bytes(b"")


def _good_entry(path: Path) -> bool:
    """A generated module entry: its first line names the sha256 of the rest."""
    head, _, body = path.read_bytes().partition(b"\n")
    return head.decode("ascii", "replace").endswith(f"sha256={hashlib.sha256(body).hexdigest()}")


def _good_index(path: Path) -> bool:
    """numba's index: its version, then (source stamp, overloads) naming at least one data file that exists."""
    with open(path, "rb") as f:
        pickle.load(f)
        stamp, overloads = pickle.loads(f.read())
    return bool(overloads) and all((path.parent / name).is_file() for name in overloads.values())


CASES = [(k, h) for k in KINDS for h in ("truncated", "garbage")] + [("model module", "empty"), ("numba index", "empty")]


@pytest.mark.parametrize("kind, how", CASES)
def test_an_unreadable_cache_entry_is_a_miss_and_is_rebuilt(warm, tmp_path, kind, how):
    pattern, command = KINDS[kind]
    if command not in warm:
        pytest.skip("numba is not installed")
    cache0, ref = warm[command]
    cache = tmp_path / "cache"
    shutil.copytree(cache0, cache)
    planted = sorted(cache.glob(pattern))
    assert planted, f"the warm cache has no {pattern}"
    for p in planted:
        _corrupt(p, how)
    bad = {p: p.read_bytes() for p in planted}
    work = tmp_path / "work"
    work.mkdir()

    proc, out = COMMANDS[command](cache, work)

    assert proc.returncode == 0, proc.stderr
    assert "error" not in proc.stderr and "warning" not in proc.stderr, proc.stderr
    assert out == ref
    if command == "solve":
        assert json.loads(out)["rows"][0]["theta4"] == pytest.approx(theta4_closed_form(90.0), abs=1e-9)
    for p in planted:  # rebuilt where it was
        if p.suffix == ".py":
            assert _good_entry(p), p.name
        elif p.suffix == ".nbi":
            assert _good_index(p), p.name
        assert p.read_bytes() != bad[p], f"{p.name} was not rewritten"
    if kind == "numba data":
        assert all(_good_index(p) for p in cache.glob("__pycache__/nb_*.nbi"))
    # and the rebuilt cache serves the next run as well
    proc2, out2 = COMMANDS[command](cache, work)
    assert proc2.returncode == 0 and out2 == ref, proc2.stderr
