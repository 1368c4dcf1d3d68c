"""The disk cache never executes a file it did not write for this user (issue 9, critical 4).

A planted, foreign, world-writable, FIFO, symlinked or crafted entry is never run, the results
stay right (checked against the four-bar closed form written here), and foreign entries give
exactly one warning. Writes are atomic, UTF-8 whatever the locale, and leave no debris.
"""

from __future__ import annotations

import math
import os
import stat
import subprocess
import sys
import warnings

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.symbolic import compiled
from loopsolve.symbolic.compiled import structure_key

THESIS = ls.models_dir() / "thesis_crank_rocker.toml"
IS_ROOT = hasattr(os, "geteuid") and os.geteuid() == 0


def theta4_closed_form(r1, r2, r3, r4, theta2_deg):
    """Open-mode (sin(θ4 − θ3) > 0) rocker angle of a four-bar, by the circle-intersection construction."""
    t2 = math.radians(theta2_deg)
    bx, by = r2 * math.cos(t2), r2 * math.sin(t2)  # crank tip B
    dx, dy = r1 - bx, -by  # from B to the rocker pivot O4
    d = math.hypot(dx, dy)
    a = (r3**2 - r4**2 + d**2) / (2 * d)
    h = math.sqrt(r3**2 - a**2)
    candidates = []
    for sgn in (1, -1):
        cx = bx + a * dx / d - sgn * h * dy / d
        cy = by + a * dy / d + sgn * h * dx / d
        t3 = math.atan2(cy - by, cx - bx)
        t4 = math.atan2(cy, cx - r1)
        candidates.append((math.sin(t4 - t3), math.degrees(t4)))
    return [t4 for s, t4 in candidates if s > 0][0]


EXPECTED = theta4_closed_form(60, 25, 70, 45, 90)


@pytest.fixture
def cache(tmp_path, monkeypatch):
    d = tmp_path / "cache"
    monkeypatch.setenv("LOOPSOLVE_CACHE_DIR", str(d))
    monkeypatch.setattr(compiled, "_MEMO", {})
    return d


def entry_path(cache_dir):
    mech = ls.load(THESIS)
    return cache_dir / f"m_{structure_key(mech, mech.resolve_inputs(None))}.py"


def solve_fresh():
    compiled._MEMO.clear()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        value = ls.load(THESIS).solve(90)["theta4"]
    return value, [w for w in caught if issubclass(w.category, ls.LoopsolveWarning)]


EVIL = "import pathlib\npathlib.Path({marker!r}).write_text('ran')\nimport sys\nsys.exit(0)\n"
WRONG = "VARIABLES = ('theta2', 'theta3', 'theta4')\n"  # a crafted module is refused before it runs


def test_directory_is_created_private_whatever_the_umask(cache):
    old = os.umask(0o002)
    try:
        assert solve_fresh()[0] == pytest.approx(EXPECTED, abs=1e-9)
    finally:
        os.umask(old)
    assert stat.S_IMODE(cache.stat().st_mode) == 0o700
    (entry,) = cache.glob("m_*.py")
    assert stat.S_IMODE(entry.stat().st_mode) & 0o022 == 0
    assert entry.read_bytes().startswith(b"# loopsolve-cache key=")
    assert not [p for p in cache.iterdir() if p.suffix == ".tmp"]


def test_directory_is_never_more_open_than_0700(cache, monkeypatch):
    """The directory is created 0700 by mkdir itself, not opened up and then closed by a chmod:
    with umask 0 and the follow-up chmod intercepted, it is 0700 from its first instant (kills
    loopsolve.symbolic.compiled.x_ensure_dir__mutmut_12, ``os.mkdir(directory, 449)``: 449 is 0o701)."""
    calls = []
    monkeypatch.setattr(compiled.os, "chmod", lambda path, mode, *a, **k: calls.append((str(path), mode)))
    old = os.umask(0)
    try:
        compiled.ensure_dir(cache)
    finally:
        os.umask(old)
    assert stat.S_IMODE(cache.stat().st_mode) == 0o700
    assert calls == [(str(cache), 0o700)]


def test_planted_entry_of_this_user_is_never_run_and_is_replaced(cache, tmp_path):
    cache.mkdir(mode=0o700)
    marker = tmp_path / "MARKER"
    path = entry_path(cache)
    for text in (EVIL.format(marker=str(marker)), WRONG, "raise SystemExit(0)\n"):
        path.write_text(text, encoding="utf-8")
        value, warned = solve_fresh()
        assert value == pytest.approx(EXPECTED, abs=1e-9)
        assert not marker.exists()
        assert path.read_bytes().startswith(b"# loopsolve-cache key=")  # regenerated


def test_crafted_entry_with_a_forged_header_is_refused(cache, tmp_path):
    """The header's hash must match the body: editing generated code gives no wrong numbers."""
    solve_fresh()
    path = entry_path(cache)
    text = path.read_text(encoding="utf-8")
    # keep the header, change the numbers the module computes
    forged = text.replace("def phi(z, p):", "def phi(z, p):\n    return [0.0] * N_EQ\n\ndef _old_phi(z, p):")
    assert forged != text
    path.write_text(forged, encoding="utf-8")
    value, _ = solve_fresh()
    assert value == pytest.approx(EXPECTED, abs=1e-9)
    assert path.read_text(encoding="utf-8") == text


@pytest.mark.parametrize("how", ["foreign-owner", "group-writable-file", "world-writable-dir", "fifo", "symlink",
                                 "directory-at-key", "foreign-dir"])
def test_foreign_entries_are_never_run(cache, tmp_path, how):
    if how in ("foreign-owner", "foreign-dir") and not IS_ROOT:
        pytest.skip("simulating another user's file needs os.chown as root")
    cache.mkdir(mode=0o700)
    marker = tmp_path / "MARKER"
    path = entry_path(cache)
    evil = EVIL.format(marker=str(marker))
    if how == "fifo":
        os.mkfifo(path)
    elif how == "symlink":
        target = tmp_path / "evil.py"
        target.write_text(evil, encoding="utf-8")
        path.symlink_to(target)
    elif how == "directory-at-key":
        path.mkdir()
    else:
        path.write_text(evil, encoding="utf-8")
        os.chmod(path, 0o644)
        if how == "foreign-owner":
            os.chown(path, 4242, 4242)
        elif how == "group-writable-file":
            os.chmod(path, 0o664)
        elif how == "world-writable-dir":
            os.chmod(cache, 0o777)
        elif how == "foreign-dir":
            os.chown(cache, 4242, 4242)
    before = os.lstat(path)
    value, warned = solve_fresh()
    assert value == pytest.approx(EXPECTED, abs=1e-9)
    assert not marker.exists()
    assert len(warned) == 1, [str(w.message) for w in warned]
    assert "compiled in memory" in str(warned[0].message)
    after = os.lstat(path)
    assert (after.st_ino, after.st_mode) == (before.st_ino, before.st_mode)  # left alone
    if how == "world-writable-dir":  # our own directory is made private for the next run
        assert stat.S_IMODE(cache.stat().st_mode) == 0o700


def test_foreign_entry_on_the_command_line_gives_one_warning_line(cache, tmp_path):
    cache.mkdir(mode=0o700)
    os.mkfifo(entry_path(cache))
    env = dict(os.environ, LOOPSOLVE_CACHE_DIR=str(cache), PYTHONPATH=os.pathsep.join(sys.path))
    env.pop("LOOPSOLVE_DEBUG", None)
    proc = subprocess.run([sys.executable, "-m", "loopsolve.cli", "solve", str(THESIS), "--at", "90", "--format",
                           "json"], capture_output=True, text=True, env=env, timeout=300)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("loopsolve: warning: not using the compile cache"), lines
    import json

    row = json.loads(proc.stdout)["rows"][0]
    assert row["theta4"] == pytest.approx(EXPECTED, abs=1e-9)


@pytest.mark.parametrize("env_extra", [{"LC_ALL": "C", "LANG": "C", "PYTHONUTF8": "0", "PYTHONIOENCODING": "ascii"},
                                       {"LC_ALL": "C", "PYTHONUTF8": "0"}])
def test_non_ascii_name_under_an_ascii_locale(tmp_path, env_extra):
    model = tmp_path / "m.toml"
    model.write_text(THESIS.read_text(encoding="utf-8").replace('name = "', 'name = "Kurbelschwinge ° θ ', 1),
                     encoding="utf-8")
    cache = tmp_path / "cache"
    env = dict(os.environ, LOOPSOLVE_CACHE_DIR=str(cache), PYTHONPATH=os.pathsep.join(sys.path), **env_extra)
    env.pop("LOOPSOLVE_DEBUG", None)
    for _ in range(2):  # a cold then a warm cache
        proc = subprocess.run([sys.executable, "-m", "loopsolve.cli", "solve", str(model), "--at", "90",
                               "--format", "csv", "-o", str(tmp_path / "out.csv")], capture_output=True, env=env,
                              timeout=300)
        assert proc.returncode == 0, proc.stderr
    assert len(list(cache.glob("m_*.py"))) == 1
    assert not [p for p in cache.iterdir() if p.name.endswith(".tmp")]
    assert "theta4" in (tmp_path / "out.csv").read_text(encoding="utf-8")


def test_full_disk_cache_write_leaves_no_temp_file(full_fs, monkeypatch):
    tiny_fs = full_fs
    cache = tiny_fs / "cache"
    cache.mkdir(mode=0o700)
    monkeypatch.setenv("LOOPSOLVE_CACHE_DIR", str(cache))
    monkeypatch.setattr(compiled, "_MEMO", {})
    assert ls.load(THESIS).solve(90)["theta4"] == pytest.approx(EXPECTED, abs=1e-9)
    assert list(cache.iterdir()) == []


def test_size_limited_cache_write_leaves_no_temp_file(tmp_path):
    """RLIMIT_FSIZE (no root needed): the writer fails with EFBIG and cleans up."""
    cache = tmp_path / "cache"
    code = (
        "import resource, signal\n"
        "signal.signal(signal.SIGXFSZ, signal.SIG_IGN)\n"
        "resource.setrlimit(resource.RLIMIT_FSIZE, (2000, 2000))\n"
        "import loopsolve as ls\n"
        f"print(round(ls.load({str(THESIS)!r}).solve(90)['theta4'], 6))\n"
    )
    env = dict(os.environ, LOOPSOLVE_CACHE_DIR=str(cache), PYTHONPATH=os.pathsep.join(sys.path))
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert float(proc.stdout) == pytest.approx(EXPECTED, abs=1e-6)
    assert list(cache.iterdir()) == []


def test_closed_form_sanity():
    """The test's own closed form against an independent identity: loop closure holds."""
    t4 = math.radians(EXPECTED)
    b = np.array([0.0, 25.0])
    c = np.array([60 + 45 * math.cos(t4), 45 * math.sin(t4)])
    assert np.hypot(*(c - b)) == pytest.approx(70, abs=1e-9)
