"""Pictures of a shape synthesis: the target curve, the certified candidates, the chosen one moving.

:func:`shape_html` writes one self-contained page (no network access when opened): on top, an
overview in SVG — the target points and every candidate's curve, in the target's coordinates, the
chosen one drawn heavier — and a selector ``<select id="loopsolve-candidate">`` (value: the
candidate's index, best first) that switches between the candidates; under it, the chosen
candidate's linkage moving over its certified motion, the interactive page of
:mod:`loopsolve.output.view` of its sweep (with that page's hooks: ``#loopsolve-input`` and the
``[data-point]`` circles), one per candidate, embedded as an ``<iframe srcdoc>`` of which only the
chosen one is shown. :func:`plot_shape` draws the same overview with matplotlib.

The pages are made from :func:`candidate_sweeps`: each candidate's model (its parameters, in the
target's coordinates) swept by the tracker in its mode over its motion — the full turn for a
closed curve, the stretch from the first to the last target for an open one.
"""

from __future__ import annotations

import html
import json
import math

import numpy as np

from ..errors import ModelError

__all__ = ["shape_html", "plot_shape", "candidate_sweeps", "sweeps_from_report"]

_COLORS = ("#1f77b4", "#2ca02c", "#9467bd", "#8c564b", "#e377c2", "#17becf", "#bcbd22", "#ff7f0e")


def _motion_sweep(mech, point, motion, closed, mode, rows=360):
    import warnings

    from ..errors import LoopsolveWarning

    a, b = float(motion[0]), float(motion[1])
    if closed:
        turn = 360.0 if mech.units.angle == "deg" else 2 * math.pi
        b = a + math.copysign(turn, (b - a) or 1.0)
    step = abs(b - a) / rows if b != a else 1.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LoopsolveWarning)
        return mech.sweep(a, b, step, mode=mode, progress=False, derivatives=1)


def candidate_sweeps(result) -> list:
    """The sweep of every candidate of a :class:`~loopsolve.design.synthesis.shape.run.ShapeResult`, best first."""
    rep = result.report
    out = []
    for c, cand in zip(rep["candidates"], result.candidates):
        out.append(_motion_sweep(cand["mechanism"], rep["point"], c["motion"], rep["closed"], c["mode"]))
    return out


def sweeps_from_report(mech, report) -> list:
    """The candidates' sweeps from a shape report (``--report``) and the model it was made with.

    The candidates' parameters are set on the model (on its vector form with the frame parameters
    when shape synthesis added them: :func:`loopsolve.design.atlas.frame.frame_of`).
    """
    from ..design.atlas.frame import frame_of

    if not isinstance(report, dict) or report.get("task") != "shape" or not report.get("candidates"):
        raise ModelError("--shape: not the report of a shape synthesis (loopsolve synthesize --shape ... --report R)")
    point = report.get("point")
    fr = frame_of(mech, point)
    out = []
    for c in report["candidates"]:
        params = c.get("parameters") or {}
        unknown = set(params) - {p.name for p in fr.mech.parameters}
        if unknown:
            raise ModelError(f"--shape: the report's candidates have parameters {', '.join(sorted(unknown))} that "
                             f"{mech.source or mech.name} has not: the report is of another model")
        m = fr.mech.with_parameters(**{k: float(v) for k, v in params.items()})
        out.append(_motion_sweep(m, point, c["motion"], report["closed"], c["mode"]))
    return out


def _curves(sweeps, point):
    return [np.stack([np.asarray(sw.columns[f"{point}_x"]), np.asarray(sw.columns[f"{point}_y"])], axis=1)
            for sw in sweeps]


def shape_html(targets, report, sweeps, *, title=None) -> str:
    """The page (see the module docstring) of the target curve ``targets`` ``(T, 2)`` and a shape report's candidates."""
    from .view import to_html

    point = report["point"]
    curves = _curves(sweeps, point)
    pts = np.vstack([np.asarray(targets, dtype=float)] + [c[np.all(np.isfinite(c), axis=1)] for c in curves])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    span = float(max(hi - lo)) or 1.0
    pad = 0.06 * span
    x0, y0 = lo[0] - pad, lo[1] - pad
    w, h = hi[0] - lo[0] + 2 * pad, hi[1] - lo[1] + 2 * pad
    r = 0.006 * span
    sw = 0.004 * span

    def path(xy):
        xy = xy[np.all(np.isfinite(xy), axis=1)]
        return " ".join(f"{'M' if i == 0 else 'L'}{x:.6g},{y:.6g}" for i, (x, y) in enumerate(xy))

    svg = [f'<svg id="loopsolve-shape" viewBox="{x0:.6g} {-(y0 + h):.6g} {w:.6g} {h:.6g}" '
           f'style="width:100%;max-height:420px;background:#fff">', '<g transform="scale(1,-1)">']
    for k, c in enumerate(curves):
        col = _COLORS[k % len(_COLORS)]
        closing = " Z" if report["closed"] else ""
        svg.append(f'<path class="cand" data-candidate="{k}" d="{path(c)}{closing}" fill="none" stroke="{col}" '
                   f'stroke-width="{sw:.4g}" opacity="{1 if k == 0 else 0.35}"/>')
    for x, y in np.asarray(targets, dtype=float):
        svg.append(f'<circle class="target" cx="{x:.8g}" cy="{y:.8g}" r="{r:.4g}" fill="none" stroke="#d62728" '
                   f'stroke-width="{sw / 2:.4g}"/>')
    svg.append("</g></svg>")
    options, frames = [], []
    for k, c in enumerate(report["candidates"]):
        e = c["shape_error"]
        label = (f"{k + 1}: rms {e['rms']:.4g}, max {e['max']:.4g}, {c.get('grashof') or 'no four-bar loop'}, "
                 f"mode {c['mode']}")
        options.append(f'<option value="{k}"{" selected" if k == 0 else ""}>{html.escape(label)}</option>')
        page = to_html(sweeps[k], title=f"candidate {k + 1}")
        frames.append(f'<iframe class="cand-page" data-candidate="{k}" srcdoc="{html.escape(page, quote=True)}" '
                      f'sandbox="allow-scripts" style="width:100%;height:760px;border:1px solid #ddd;'
                      f'display:{"block" if k == 0 else "none"}" title="candidate {k + 1}"></iframe>')
    name = html.escape(title or f"shape synthesis of point {point}")
    info = json.dumps({"closed": report["closed"], "candidates": len(report["candidates"])})
    script = """
const sel = document.getElementById('loopsolve-candidate');
function show(k) {
  document.querySelectorAll('path.cand').forEach(p => {
    const on = p.dataset.candidate === String(k);
    p.setAttribute('opacity', on ? 1 : 0.35); p.setAttribute('stroke-width', on ? WIDTH * 1.6 : WIDTH); });
  document.querySelectorAll('iframe.cand-page').forEach(f => {
    f.style.display = f.dataset.candidate === String(k) ? 'block' : 'none'; });
}
sel.addEventListener('change', () => show(sel.value));
show(sel.value);
""".replace("WIDTH", f"{sw:.4g}")
    return ("<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>" + name + "</title>"
            "<style>body{font-family:system-ui,sans-serif;margin:12px}label{font-weight:600}</style></head><body>"
            f"<h2>{name}</h2><p>targets (red circles) and the certified candidates' curves, in the target's "
            f"coordinates; the chosen one moves below.</p>"
            + "".join(svg)
            + f'<p><label for="loopsolve-candidate">candidate </label><select id="loopsolve-candidate">'
            + "".join(options) + "</select></p>" + "".join(frames)
            + f'<script type="application/json" id="loopsolve-shape-data">{info}</script>'
            + f"<script>{script}</script></body></html>\n")


def plot_shape(result, *, ax=None, output=None, k=None):
    """Matplotlib: the targets and the candidates' curves (``k``: that candidate only, with its linkage at the first
    target)."""
    import matplotlib.pyplot as plt

    rep = result.report
    sweeps = candidate_sweeps(result)
    curves = _curves(sweeps, rep["point"])
    if ax is None:
        fig, ax = plt.subplots(figsize=(7, 6))
    else:
        fig = ax.figure
    which = range(len(curves)) if k is None else [k]
    for j in which:
        c = curves[j]
        if rep["closed"]:
            c = np.vstack([c, c[:1]])
        e = rep["candidates"][j]["shape_error"]
        ax.plot(c[:, 0], c[:, 1], "-", color=_COLORS[j % len(_COLORS)], lw=1.6 if j == (k or 0) else 1.0,
                label=f"{j + 1}: rms {e['rms']:.3g}")
    if k is not None:
        from .plotting import draw

        sw = sweeps[k]
        guess = {n: float(sw.z[0, i]) for i, n in enumerate(sw.compiled.variables)}
        try:
            draw(result.candidates[k]["mechanism"], float(sw.columns[sw.input][0]), ax=ax, guess=guess)
        except Exception:  # noqa: BLE001 — the drawing is an extra; the curves are the figure
            pass
    t = np.asarray(result.targets)
    ax.plot(t[:, 0], t[:, 1], "o", mfc="none", color="#d62728", ms=6, label="targets")
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend(loc="best", fontsize=8)
    ax.set_title(f"shape synthesis of {rep['point']}: {len(rep['candidates'])} certified design(s)")
    if output is not None:
        fig.savefig(output, dpi=120, bbox_inches="tight")
    return fig
