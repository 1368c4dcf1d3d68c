"""Exports from the editor's page, through the command line's exporters.

PNG and SVG are the figure of ``loopsolve draw`` (:func:`loopsolve.output.plotting.draw`), DXF the
CAD drawing of ``loopsolve draw -o x.dxf`` (:func:`loopsolve.output.cad.export_cad`), LaTeX the
derivation of ``loopsolve latex`` (:func:`loopsolve.output.latex.to_latex`), all of the edited
model at the page's current input value and mode. The file is made in a private temporary
folder and handed back as bytes (the page downloads it; nothing is written in the user's folders).
"""

from __future__ import annotations

import math
import re
import tempfile
from collections.abc import Mapping
from pathlib import Path

from ..errors import ModelError
from .analysis import build

__all__ = ["export", "FORMATS"]

#: format → (suffix, media type)
FORMATS = {"png": (".png", "image/png"), "svg": (".svg", "image/svg+xml"), "dxf": (".dxf", "application/dxf"),
           "tex": (".tex", "application/x-tex")}


def _stem(name: str) -> str:
    s = re.sub(r"[^A-Za-z0-9_-]+", "_", name or "model").strip("_")
    return (s or "model")[:60]


def export(data: Mapping, fmt: str, at=None, mode: str | None = None) -> tuple[str, bytes, str]:
    """``(file name, content, media type)`` of the model ``data`` exported as ``fmt`` at input ``at``."""
    if fmt not in FORMATS:
        raise ModelError(f"export format {fmt!r}: expected one of {', '.join(FORMATS)}")
    if at is not None and (isinstance(at, bool) or not isinstance(at, (int, float)) or not math.isfinite(at)):
        raise ModelError(f"at={at!r}: expected a finite number")
    mech = build(data)
    suffix, media = FORMATS[fmt]
    name = _stem(str(data.get("name", "model"))) + suffix
    if fmt == "tex":
        from ..output.latex import to_latex

        return name, to_latex(mech, at=at).encode("utf-8"), media
    with tempfile.TemporaryDirectory(prefix="loopsolve-export-") as tmp:
        out = Path(tmp) / name
        if fmt == "dxf":
            from ..output.cad import export_cad

            export_cad(mech, out, at, mode=mode)
        else:
            import matplotlib

            matplotlib.use("Agg")
            import matplotlib.pyplot as plt

            from ..output.plotting import draw

            fig = draw(mech, at, mode=mode, output=out)
            plt.close(fig) if fig is not None else None
        return name, out.read_bytes(), media
