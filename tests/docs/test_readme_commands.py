"""Every command the README shows runs, in a fresh directory, and exits 0.

The README's code blocks (``sh``, ``bash``, ``console``) are read as a reader reads them: in a
``console`` block the commands are the lines after ``$ `` (continued by a trailing backslash) and
what follows is their output, which must be what the command prints; in a shell block every line
is a command. They run in order in one temporary directory holding a copy of ``models/``, with the
``loopsolve`` of the environment that runs the tests.

The commands that install or test the package are not re-run inside the test suite (that would
install into the environment under test, or run this suite from inside itself); they are checked
against ``.ci/run``, which runs them on a clean machine: the README's test command is the one
``.ci/run`` runs under its comment "The README's test command (keep the two in sync)", the extras
the README installs exist, and the system packages it names are the ones ``.ci/run`` installs.
"""

from __future__ import annotations

import os
import re
import shlex
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
README = ROOT / "README.md"


def code_blocks(text: str) -> list[tuple[str, str]]:
    """(language, body) of every fenced code block."""
    return [(m.group(1).strip().lower(), m.group(2)) for m in re.finditer(r"^```([^\n]*)\n(.*?)^```", text, re.M | re.S)]


def _joined(lines: list[str]) -> list[str]:
    out, cur = [], ""
    for line in lines:
        if cur:
            cur += "\n" + line
        else:
            cur = line
        if not line.rstrip().endswith("\\"):
            out.append(cur)
            cur = ""
    if cur:
        out.append(cur)
    return out


def commands(text: str) -> list[tuple[str, str | None]]:
    """(command, expected output or None) of every shell and console block, in order."""
    found = []
    for lang, body in code_blocks(text):
        if lang in ("sh", "bash", "shell"):
            lines = [ln for ln in body.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
            found += [(c, None) for c in _joined(lines)]
        elif lang == "console":
            lines = body.splitlines()
            i = 0
            while i < len(lines):
                if not lines[i].startswith("$ "):
                    i += 1
                    continue
                cmd_lines = [lines[i][2:]]
                while cmd_lines[-1].rstrip().endswith("\\") and i + 1 < len(lines):
                    i += 1
                    cmd_lines.append(lines[i])
                i += 1
                output = []
                while i < len(lines) and not lines[i].startswith("$ "):
                    output.append(lines[i])
                    i += 1
                found.append(("\n".join(cmd_lines), "\n".join(output).strip("\n")))
    return found


_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:e[-+]?\d+)?", re.I)


def same_output(got: str, want: str) -> bool:
    """The same text, numbers equal to the digits printed; round-off (a residual, |x| < 1e-10) matches round-off."""
    g_lines = [ln.rstrip() for ln in got.splitlines()]
    w_lines = [ln.rstrip() for ln in want.splitlines()]
    if len(g_lines) != len(w_lines):
        return False
    for g, w in zip(g_lines, w_lines):
        if _NUMBER.sub("#", g) != _NUMBER.sub("#", w):
            return False
        for a, b in zip(_NUMBER.findall(g), _NUMBER.findall(w)):
            x, y = float(a), float(b)
            if abs(x) < 1e-10 and abs(y) < 1e-10:
                continue
            if abs(x - y) > 1e-6 * max(abs(x), abs(y)) + 1e-12:
                return False
    return True


def _is_setup(part: str) -> bool:
    """Installs, the test suite and the site's build: run by CI (.ci/run), checked below, not re-run here."""
    return bool(re.search(r"\b(pip install|pytest|apt-get|apt install)\b|(^|\s)-m sphinx\b", part))


def _ci_run() -> str:
    return (ROOT / ".ci" / "run").read_text()


def test_readme_shows_commands():
    cmds = commands(README.read_text(encoding="utf-8"))
    assert sum("loopsolve " in c for c, _ in cmds) >= 5


def test_the_test_command_is_the_one_ci_runs():
    """The README's test command is the line under .ci/run's comment "The README's test command"."""
    text = README.read_text(encoding="utf-8")
    ci = _ci_run()
    m = re.search(r"# The README's test command \(keep the two in sync\):\n\s*(.+)", ci)
    assert m, ".ci/run lost its comment naming the README's test command"
    ci_line = m.group(1)
    readme_tests = [c for c, _ in commands(text) if "pytest" in c]
    assert readme_tests, "the README shows no test command"
    quiet = re.compile(r"(pip install) -q\b")  # pip's -q in CI changes its output, not what it installs
    for cmd in readme_tests:
        for part in (p.strip() for p in cmd.split("&&")):
            assert quiet.sub(r"\1", part) in quiet.sub(r"\1", ci_line), \
                f"{part!r} (README) is not what .ci/run runs: {ci_line!r}"


def test_the_docs_command_is_the_documented_build():
    """The README's command that builds the site is the one docs/development/docs.md gives (and CI runs)."""
    page = (ROOT / "docs" / "development" / "docs.md").read_text(encoding="utf-8")
    for cmd, _ in commands(README.read_text(encoding="utf-8")):
        for part in (p.strip() for p in cmd.split("&&")):
            if "-m sphinx" in part:
                build = part.split("#")[0].strip()
                assert build in page, f"{build!r} is not the build docs/development/docs.md gives"


def test_installs_name_existing_extras_and_ci_packages():
    extras = set(tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"])
    ci = _ci_run()
    for cmd, _ in commands(README.read_text(encoding="utf-8")):
        for named in re.findall(r"""\.\[([a-z,]+)\]""", cmd):
            assert set(named.split(",")) <= extras, f"{cmd}: unknown extra in [{named}]"
        apt = re.search(r"apt-get install (.+)", cmd)
        if apt:
            for package in apt.group(1).split():
                if not package.startswith("-"):
                    assert re.search(rf"(^|\s){re.escape(package)}(\s|$)", ci, re.M), f"{package} is not in .ci/run"


def test_every_readme_command_runs(tmp_path):
    work = tmp_path / "readme"
    work.mkdir()
    shutil.copytree(ROOT / "models", work / "models")
    env = dict(os.environ, MPLBACKEND="Agg", LOOPSOLVE_CACHE_DIR=str(tmp_path / "cache"))
    env["PATH"] = os.pathsep.join([str(Path(sys.executable).parent), env.get("PATH", "")])
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(ROOT), env.get("PYTHONPATH", "")) if p)
    env.pop("LOOPSOLVE_DEBUG", None)
    ran = 0
    for cmd, expected in commands(README.read_text(encoding="utf-8")):
        parts = [p.strip() for p in cmd.split("&&")]
        runnable = [p for p in parts if not _is_setup(p)]
        if not runnable:
            continue
        script = " && ".join(runnable)
        if "venv" in script:  # the README's own environment: made and activated in a scratch folder
            proc = subprocess.run(["bash", "-c", script + " && command -v python3"], cwd=tmp_path, env=env,
                                  capture_output=True, text=True)
            assert proc.returncode == 0, f"{script}\n{proc.stderr}"
            assert str(tmp_path / ".venv") in proc.stdout
            continue
        # `loopsolve` is this environment's (the console script may not be on PATH in a checkout)
        script = re.sub(r"(^|&& |\| )loopsolve\b", lambda m: m.group(1) + f"{shlex.quote(sys.executable)} -m loopsolve",
                        script)
        proc = subprocess.run(["bash", "-c", script], cwd=work, env=env, capture_output=True, text=True)
        assert proc.returncode == 0, f"README command failed (exit {proc.returncode}): {cmd}\n{proc.stderr[-2000:]}"
        if expected:
            got = (proc.stdout + proc.stderr).strip("\n")
            assert same_output(got, expected), f"the README shows other output for {cmd}:\n--- README\n{expected}\n" \
                                               f"--- now\n{got}"
        ran += 1
    assert ran >= 5
