"""Running the ``loopsolve`` command in a subprocess and reading its one-line errors."""

import os
import subprocess
import sys


def run(*args, cwd=None):
    env = dict(os.environ)
    return subprocess.run([sys.executable, "-m", "loopsolve.cli", *map(str, args)], capture_output=True,
                          text=True, cwd=cwd, env=env)


def one_line_error(p, code=2):
    assert p.returncode == code, (p.returncode, p.stderr)
    assert "Traceback" not in p.stderr
    lines = [ln for ln in p.stderr.strip().splitlines() if not ln.startswith("wrote ")]  # the report's note
    assert len(lines) == 1 and lines[0].startswith("loopsolve: "), p.stderr
    return lines[0]
