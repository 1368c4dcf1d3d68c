"""The commands of the how-to page on matching a drawn curve run as the page says.

``docs/howto/match_curve.md`` is written against the contract of shape synthesis (DESIGN.md,
"Atlas and shape synthesis"), which is not in this release. Its shell blocks are marked: a block
whose first line is ``# runs today`` must run and exit 0 now (with the ``curve.csv`` the page
shows); a block marked ``# not yet available`` must fail as a usage error (exit 2) while
``loopsolve synthesize --help`` has no ``--shape``, and the page must say so in its warning —
and once shape synthesis lands, those commands must run too, so the page cannot silently stay
wrong in either direction.
"""

from __future__ import annotations

import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PAGE = ROOT / "docs" / "howto" / "match_curve.md"


def _blocks(text: str) -> list[tuple[str, str]]:
    return [(m.group(1).strip(), m.group(2)) for m in re.finditer(r"^```([^\n]*)\n(.*?)^```", text, re.M | re.S)]


def _commands(body: str) -> list[str]:
    out, cur = [], ""
    for line in body.splitlines():
        if not cur and (not line.strip() or line.lstrip().startswith("#")):
            continue
        cur = f"{cur}\n{line}" if cur else line
        if not line.rstrip().endswith("\\"):
            out.append(cur)
            cur = ""
    return out


def _run(cmd: str, cwd: Path, env: dict) -> subprocess.CompletedProcess:
    script = re.sub(r"^loopsolve\b", f"{shlex.quote(sys.executable)} -m loopsolve", cmd.strip())
    return subprocess.run(["bash", "-c", script], cwd=cwd, env=env, capture_output=True, text=True)


def _shape_available(env: dict) -> bool:
    proc = subprocess.run([sys.executable, "-m", "loopsolve", "synthesize", "--help"], capture_output=True, text=True,
                          env=env)
    return "--shape" in proc.stdout


def test_match_curve_page_commands(tmp_path):
    text = PAGE.read_text(encoding="utf-8")
    blocks = _blocks(text)
    work = tmp_path / "work"
    work.mkdir()
    shutil.copytree(ROOT / "models", work / "models")
    curve = next(body for lang, body in blocks if lang == "text" and body.startswith("x,y"))
    (work / "curve.csv").write_text(curve)
    env = dict(os.environ, MPLBACKEND="Agg", LOOPSOLVE_CACHE_DIR=str(tmp_path / "cache"))
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(ROOT), env.get("PYTHONPATH", "")) if p)
    env.pop("LOOPSOLVE_DEBUG", None)
    shells = [body for lang, body in blocks if lang in ("sh", "bash")]
    today = [b for b in shells if b.lstrip().startswith("# runs today")]
    later = [b for b in shells if b.lstrip().startswith("# not yet available")]
    assert today and later, "the page's shell blocks must each say whether they run today"
    for body in today:
        for cmd in _commands(body):
            proc = _run(cmd, work, env)
            assert proc.returncode == 0, f"{cmd}\n{proc.stderr[-2000:]}"
    import loopsolve as ls

    design = ls.load(work / "design.toml")  # the written design loads and solves at its guesses
    state = design.solve()
    assert abs(state["P_x"]) < 1e6 and abs(state["P_y"]) < 1e6
    if _shape_available(env):
        for body in later:
            for cmd in _commands(body):
                proc = _run(cmd, work, env)
                assert proc.returncode == 0, f"shape synthesis has landed; the page's command fails: {cmd}\n" \
                                             f"{proc.stderr[-2000:]}"
    else:
        assert "Not yet available" in text and "not in this release" in text
        for body in later:
            for cmd in _commands(body):
                proc = _run(cmd, work, env)
                assert proc.returncode == 2, f"{cmd}: exit {proc.returncode}, {proc.stderr}"
