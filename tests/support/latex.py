"""Reading the PDFs the LaTeX tests build, and skipping (or, in CI, failing) without TeX."""

import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest


def require(*programs: str) -> None:
    """Skip when a program is missing, unless LOOPSOLVE_REQUIRE_TEX is set (CI): then fail."""
    missing = [p for p in programs if shutil.which(p) is None]
    if not missing:
        return
    if os.environ.get("LOOPSOLVE_REQUIRE_TEX"):
        pytest.fail(f"{', '.join(missing)} not found but LOOPSOLVE_REQUIRE_TEX is set")
    pytest.skip(f"{', '.join(missing)} not installed (TeX Live / poppler-utils); "
                "set LOOPSOLVE_REQUIRE_TEX=1 to make this a failure")


def pdf_text(pdf: Path) -> str:
    out = subprocess.run(["pdftotext", "-layout", str(pdf), "-"], capture_output=True, check=True)
    return re.sub(r"\s+", " ", out.stdout.decode("utf-8"))
