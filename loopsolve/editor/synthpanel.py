"""The synthesis panel's methods: a curve (or precision points) in, certified four-bars out.

Each method is a function ``method(params, progress) -> result`` registered in :data:`METHODS`
under the name the page sends: ``progress(fraction, text)`` reports how far it is and returns
nothing; the result holds ``candidates``, each a certified design as an editable
kinematic-diagram model (``model``, its TOML ``toml``), its numbers (``objective``, ``rms``,
``max``, ``grashof``, ``transmission``, ``mode``, ``certificate``) and its ``curve`` (the traced
path of the coupler point, for the preview). Another method (shape synthesis from an atlas)
plugs in by adding an entry with the same signature.

* ``path``: path generation with free timing (``loopsolve synthesize --path P`` without input
  values) on the four-bar of :func:`path_template` — ground pivot, ground angle, the four
  lengths and the coupler point all design variables, bounded by the size of the curve — one
  seeded run after the other (``runs``), each run's certified best a candidate;
* ``freudenstein``: function generation through three (or more) precision points
  ``[input, output]`` in degrees by Freudenstein's equation (``--method freudenstein``).

A design becomes a diagram by solving it at its first target in its mode and drawing every
joint where it is (:func:`loopsolve.editor.editing.diagram_from_positions`): the drawn pose
names the same mode, so the edited mechanism is the certified one.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from ..errors import ModelError, SynthesisError
from .editing import diagram_from_positions

__all__ = ["METHODS", "path_template", "run", "path_synthesis", "freudenstein_synthesis", "MAX_TARGETS",
           "MAX_RUNS"]

MAX_TARGETS = 40
MAX_RUNS = 10

_FOURBAR_LINKS = {"ground": ["O2", "O4"], "crank": ["O2", "A"], "coupler": ["A", "B", "P"], "rocker": ["O4", "B"]}


def path_template(units: Mapping[str, str] | None = None) -> dict:
    """The four-bar whose every dimension is a parameter (``models/fourbar_path_synthesis.toml``'s layout)."""
    return {
        "name": "Four-bar (path synthesis)",
        "units": dict(units or {"length": "mm", "angle": "deg"}),
        "parameters": {"x0": 0, "y0": 0, "theta0": 0, "r1": 4, "r2": 1, "r3": 3.5, "r4": 3, "rcx": 1.5, "rcy": 1},
        "variables": {"theta2": {"input": True, "guess": 60}, "theta3": {"guess": 36}, "theta4": {"guess": 103}},
        "vectors": {"r0": {"x": "x0", "y": "y0"}, "r1": {"length": "r1", "angle": "theta0"},
                    "r2": {"length": "r2", "angle": "theta2 + theta0"}, "r3": {"length": "r3", "angle": "theta3"},
                    "r4": {"length": "r4", "angle": "theta4"}, "u3": {"length": 1, "angle": "theta3"},
                    "n3": {"length": 1, "angle": "theta3", "offset": 90}},
        "loops": [{"equation": "r2 + r3 = r1 + r4"}],
        "points": {"O2": "r0", "A": "r0 + r2", "B": "r0 + r2 + r3", "O4": "r0 + r1",
                   "P": "r0 + r2 + rcx*u3 + rcy*n3"},
    }


def _targets(points) -> np.ndarray:
    try:
        arr = np.array(points, dtype=float)
    except (TypeError, ValueError):
        raise ModelError("targets: expected a list of [x, y] points") from None
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise ModelError("targets: expected a list of [x, y] points")
    if not np.isfinite(arr).all():
        raise ModelError("targets: every coordinate must be a finite number")
    if len(arr) < 3 or len(arr) > MAX_TARGETS:
        raise ModelError(f"targets: {len(arr)} points; give 3 to {MAX_TARGETS}")
    return arr


def _diagram_of(mech, at, mode, names: Mapping[str, str], links, name: str, description: str) -> dict:
    """A certified design drawn as a diagram at input ``at`` in ``mode`` (``names``: diagram joint ← model point)."""
    st = mech.solve(at, mode=mode)
    pos = {j: (float(st[f"{p}_x"]), float(st[f"{p}_y"])) for j, p in names.items()}
    units = {"length": mech.units.length, "angle": mech.units.angle}
    return diagram_from_positions(name, units, pos, links, "O2", description=description)


def _curve(data: Mapping, point: str) -> tuple[list, dict]:
    """The traced path of ``point`` over the design's default range (the preview), and its info."""
    from .analysis import build, default_settings

    mech = build(data)
    ck = mech.compile()
    s = default_settings(ck)
    sw = mech.sweep(s["from"], s["to"], s["step"], through_limits=s["through"], progress=False)
    xy = np.column_stack([sw[f"{point}_x"], sw[f"{point}_y"]])
    info = mech.info()
    fb = (info.get("fourbars") or [{}])[0]
    return [[float(f"{v:.10g}") for v in row] for row in xy if np.isfinite(row).all()], {
        "grashof": fb.get("grashof"), "transmission": fb.get("transmission_angle_range")}


def path_synthesis(params: Mapping[str, Any], progress: Callable[[float, str], None]) -> dict:
    """Free-timing path generation of a four-bar's coupler point through drawn points (see the module notes)."""
    from ..design.synthrun import synthesize
    from ..model.modelfile import dumps, loads

    pts = _targets(params.get("points"))
    runs = int(params.get("runs", 3))
    if not 1 <= runs <= MAX_RUNS:
        raise ModelError(f"runs: {runs}; give 1 to {MAX_RUNS}")
    seed = int(params.get("seed", 0))
    crank = bool(params.get("crank", False))
    units = params.get("units") or {"length": "mm", "angle": "deg"}
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    size = float(max(np.ptp(pts, axis=0).max(), 1e-9))
    centre = (lo + hi) / 2
    data = path_template(units)
    data["parameters"].update({"x0": float(centre[0]), "y0": float(centre[1] - size), "r1": size, "r2": size / 3,
                               "r3": size, "r4": size, "rcx": size / 2, "rcy": size / 2})
    mech = loads(dumps(data), source="<path synthesis>")
    vary = {"x0": (float(centre[0] - 2 * size), float(centre[0] + 2 * size)),
            "y0": (float(centre[1] - 2 * size), float(centre[1] + 2 * size)),
            "theta0": (-180.0, 180.0) if mech.units.angle == "deg" else (-math.pi, math.pi),
            "r1": (0.1 * size, 4 * size), "r2": (0.05 * size, 2 * size), "r3": (0.1 * size, 4 * size),
            "r4": (0.1 * size, 4 * size), "rcx": (-3 * size, 3 * size), "rcy": (-3 * size, 3 * size)}
    targets = {"x": pts[:, 0].tolist(), "y": pts[:, 1].tolist()}
    candidates, notes = [], []
    for k in range(runs):
        progress(k / runs, f"run {k + 1} of {runs} (seed {seed + k})")
        try:
            res = synthesize(mech, path="P", targets=targets, vary=vary, runs=1, seed=seed + k, crank=crank,
                             mode="any", progress=False)
        except SynthesisError as exc:
            notes.append(f"run {k + 1}: {exc}")
            continue
        rep = res.report
        if any(abs(c["objective"] - rep["objective"]) <= 1e-6 * max(rep["objective"], 1e-12 * size * size)
               and c["parameters"] == rep["parameters"] for c in candidates):
            continue
        at = rep["targets"][0]["input"]
        model = _diagram_of(res.mechanism, at, rep["mode"], {j: j for j in ("O2", "A", "B", "O4", "P")},
                            _FOURBAR_LINKS, "Four-bar (path synthesis)",
                            f"Coupler point P through {len(pts)} drawn points, free timing (loopsolve edit, "
                            f"seed {seed + k}); objective {rep['objective']:.6g}")
        curve, extra = _curve(model, "P")
        errs = [float(t["error"]) for t in rep["targets"]]
        candidates.append({"objective": rep["objective"], "rms": math.sqrt(sum(e * e for e in errs) / len(errs)),
                           "max": max(errs), "mode": rep["mode"], "direction": rep["direction"],
                           "certificate": rep["certificate"], "parameters": rep["parameters"], "model": model,
                           "toml": dumps(model), "curve": curve, "seed": seed + k, **extra})
    progress(1.0, f"{len(candidates)} certified candidate(s) from {runs} run(s)")
    candidates.sort(key=lambda c: c["objective"])
    return {"task": "path", "candidates": candidates, "notes": notes, "targets": pts.tolist()}


def freudenstein_synthesis(params: Mapping[str, Any], progress: Callable[[float, str], None]) -> dict:
    """Function generation through precision points ``[[input, output], ...]`` (degrees), Freudenstein."""
    from ..design.classicsynth import classic_synthesize
    from ..model.factories import fourbar
    from ..model.modelfile import dumps

    rows = params.get("points")
    try:
        arr = np.array(rows, dtype=float)
    except (TypeError, ValueError):
        raise ModelError("precision points: expected rows [input angle, output angle] in degrees") from None
    if arr.ndim != 2 or arr.shape[1] != 2 or not 3 <= len(arr) <= MAX_TARGETS or not np.isfinite(arr).all():
        raise ModelError(f"precision points: give 3 to {MAX_TARGETS} rows [input angle, output angle] (degrees)")
    progress(0.0, "Freudenstein's equation")
    units = params.get("units") or {"length": "mm", "angle": "deg"}
    base = fourbar(60, 25, 70, 45)
    try:
        res = classic_synthesize(base, method="freudenstein", function="theta4", targets=arr.tolist())
    except SynthesisError:
        raise
    rep = res.report
    if rep["certificate"]["defects"]:
        raise SynthesisError(f"Freudenstein: the four-bar through these points has defects "
                             f"({', '.join(rep['certificate']['defects'])}): try other precision points",
                             report=rep)
    model = _diagram_of(res.mechanism, float(arr[0, 0]), rep["mode"], {j: j for j in ("O2", "B", "C", "O4")},
                        {"ground": ["O2", "O4"], "crank": ["O2", "B"], "coupler": ["B", "C"], "rocker": ["C", "O4"]},
                        "Four-bar (Freudenstein)",
                        "Function generator through " + ", ".join(f"({a:g}, {b:g})" for a, b in arr)
                        + " deg (loopsolve edit, Freudenstein)")
    curve, extra = _curve(model, "C")
    errs = [float(t["error"]) for t in rep["targets"]]
    progress(1.0, "done")
    return {"task": "function", "targets": arr.tolist(), "notes": [], "candidates": [{
        "objective": rep["objective"], "rms": math.sqrt(sum(e * e for e in errs) / len(errs)), "max": max(errs),
        "mode": rep["mode"], "certificate": rep["certificate"], "parameters": rep["parameters"], "model": model,
        "toml": dumps(model), "curve": curve, "structural_error": rep.get("structural_error"), **extra}]}


#: the panel's methods by the name the page sends (a shape method plugs in here)
METHODS: dict[str, Callable[[Mapping[str, Any], Callable[[float, str], None]], dict]] = {
    "path": path_synthesis,
    "freudenstein": freudenstein_synthesis,
}


def run(method: str, params: Mapping[str, Any], progress: Callable[[float, str], None]) -> dict:
    """Run a registered method (``ModelError`` for an unknown one)."""
    if method not in METHODS:
        raise ModelError(f"unknown synthesis method {method!r} (methods: {', '.join(METHODS)})")
    return METHODS[method](params, progress)
