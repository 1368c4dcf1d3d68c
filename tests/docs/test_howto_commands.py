"""The commands of the how-to page on matching a drawn curve run as the page says.

``docs/howto/match_curve.md`` shows the curve (a ``text`` block starting ``x,y``) and its shell
blocks: every command of every ``sh``/``bash`` block runs, in order, in a fresh directory holding a
copy of ``models/`` and that curve, and exits 0; the design it writes loads and solves, and the
report is a shape report with certified candidates. (The ``text`` block with the default atlas's
command is not run: it builds the default atlas, minutes of work.)
"""

from __future__ import annotations

import json
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


def test_match_curve_page_commands(tmp_path):
    text = PAGE.read_text(encoding="utf-8")
    blocks = _blocks(text)
    work = tmp_path / "work"
    work.mkdir()
    shutil.copytree(ROOT / "models", work / "models")
    curve = next(body for lang, body in blocks if lang == "text" and body.startswith("x,y"))
    name = re.search(r"`([\w.]+\.csv)`:\n", text).group(1)
    (work / name).write_text(curve)
    env = dict(os.environ, MPLBACKEND="Agg", LOOPSOLVE_CACHE_DIR=str(tmp_path / "cache"))
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(ROOT), env.get("PYTHONPATH", "")) if p)
    env.pop("LOOPSOLVE_DEBUG", None)
    shells = [body for lang, body in blocks if lang in ("sh", "bash")]
    assert shells, "the page shows no commands"
    ran = 0
    for body in shells:
        for cmd in _commands(body):
            proc = _run(cmd, work, env)
            assert proc.returncode == 0, f"{cmd}\n{proc.stderr[-2000:]}"
            ran += 1
    assert ran >= 3
    import loopsolve as ls

    design = ls.load(work / "design.toml")  # the written design loads and solves at its guesses
    state = design.solve()
    assert abs(state["P_x"]) < 1e6 and abs(state["P_y"]) < 1e6
    report = json.loads((work / "report.json").read_text())
    assert report["task"] == "shape" and report["candidates"]
    assert all(not c["certificate"]["defects"] for c in report["candidates"])
