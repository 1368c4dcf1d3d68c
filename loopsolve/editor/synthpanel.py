"""The synthesis panel's methods: a curve (or precision points) in, certified four-bars out.

Each method is a function ``method(params, progress) -> result`` registered in :data:`METHODS`
under the name the page sends: ``progress(fraction, text)`` reports how far it is and returns
nothing; the result holds ``candidates``, each a certified design as an editable
kinematic-diagram model (``model``, its TOML ``toml``), its numbers (``objective``, ``rms``,
``max``, ``grashof``, ``transmission``, ``mode``, ``certificate``) and its ``curve`` (the traced
path of the coupler point, for the preview).

* ``shape`` (the page's default for a drawn curve): shape synthesis (``loopsolve synthesize
  --shape P``) of the four-bar of ``models/fourbar_path_synthesis.toml`` from its default atlas
  — the coupler point traces the drawn shape anywhere, at any size, orientation and timing; the
  ``top`` certified designs, best first. The curve is closed when the stroke ends near its start
  (:func:`closed_rule`: the gap from the last point to the first at most
  :data:`CLOSE_FRACTION` of the curve's size, the larger side of its bounding box), else open;
  ``closed`` true/false overrides. The first use builds the default atlas into the cache
  (minutes; the progress says so, and cancelling stops it — the next use resumes it);
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

__all__ = ["METHODS", "path_template", "run", "path_synthesis", "shape_synthesis", "freudenstein_synthesis",
           "closed_rule", "MAX_TARGETS", "MAX_SHAPE_TARGETS", "MAX_RUNS", "MAX_TOP", "CLOSE_FRACTION"]

MAX_TARGETS = 40
MAX_SHAPE_TARGETS = 200
MAX_RUNS = 10
MAX_TOP = 10
#: a drawn curve is closed when its end is within this fraction of its size from its start
CLOSE_FRACTION = 0.15

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


def _targets(points, low: int = 3, high: int = MAX_TARGETS) -> np.ndarray:
    try:
        arr = np.array(points, dtype=float)
    except (TypeError, ValueError):
        raise ModelError("targets: expected a list of [x, y] points") from None
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise ModelError("targets: expected a list of [x, y] points")
    if not np.isfinite(arr).all():
        raise ModelError("targets: every coordinate must be a finite number")
    if len(arr) < low or len(arr) > high:
        raise ModelError(f"targets: {len(arr)} points; give {low} to {high}")
    return arr


def _diagram_of(mech, at, mode, names: Mapping[str, str], links, name: str, description: str,
                units: Mapping[str, str] | None = None) -> dict:
    """A certified design drawn as a diagram at input ``at`` in ``mode`` (``names``: diagram joint ← model point;
    ``units``: the diagram's, default the design's — the coordinates are written as they are)."""
    st = mech.solve(at, mode=mode)
    pos = {j: (float(st[f"{p}_x"]), float(st[f"{p}_y"])) for j, p in names.items()}
    units = dict(units or {"length": mech.units.length, "angle": mech.units.angle})
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
    from ..design.synthesis.run import synthesize
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


def closed_rule(pts: np.ndarray) -> tuple[bool, float]:
    """Is the drawn curve closed: ``(closed, gap)``, ``gap`` the distance from its last point to its first over
    its size (the larger side of its bounding box); closed when ``gap <= CLOSE_FRACTION``."""
    size = float(np.ptp(pts, axis=0).max())
    gap = float(np.hypot(*(pts[-1] - pts[0]))) / size if size > 0 else 0.0
    return gap <= CLOSE_FRACTION, gap


def _flag(params: Mapping[str, Any], key: str):
    v = params.get(key)
    if v is None or v == "auto":
        return None
    if isinstance(v, bool):
        return v
    raise ModelError(f"{key}: {v!r}; give true, false or \"auto\"")


def shape_synthesis(params: Mapping[str, Any], progress: Callable[[float, str], None], *, atlas=None) -> dict:
    """Shape synthesis of a four-bar's coupler curve from the default atlas (see the module notes).

    ``params``: ``points`` (5 to :data:`MAX_SHAPE_TARGETS` ``[x, y]`` in order along the curve), ``closed``
    (true, false or ``"auto"``: :func:`closed_rule`), ``top`` (1 to :data:`MAX_TOP`, default 5), ``crank``,
    ``units``. ``atlas`` (from Python only, never from the page): an atlas of the model's point ``P`` to use
    instead of the default one.
    """
    from ..design.atlas.defaults import default_atlas
    from ..design.synthesis.run import synthesize
    from ..model.modelfile import dumps, load, models_dir

    pts = _targets(params.get("points"), 5, MAX_SHAPE_TARGETS)
    top = params.get("top", 5)
    if isinstance(top, bool) or not isinstance(top, int) or not 1 <= top <= MAX_TOP:
        raise ModelError(f"top: {top!r}; give a whole number 1 to {MAX_TOP}")
    crank = bool(params.get("crank", False))
    units = params.get("units") or {"length": "mm", "angle": "deg"}
    auto, gap = closed_rule(pts)
    closed = _flag(params, "closed")
    notes = [f"{'closed' if (auto if closed is None else closed) else 'open'} curve: "
             + (f"its end is {gap:.0%} of its size from its start (closed at most {CLOSE_FRACTION:.0%})"
                if closed is None else "as chosen")]
    closed = auto if closed is None else closed
    mech = load(models_dir() / "fourbar_path_synthesis.toml")
    if atlas is None:
        progress(0.0, "opening the default four-bar atlas")

        def built(done: int, total: int) -> None:
            progress(0.8 * done / max(total, 1), f"building the default four-bar atlas into the cache (once): "
                     f"{done:,} of {total:,} designs")

        atlas = default_atlas(mech, "P", progress=built)
    summ = atlas.summary()
    notes.append(f"atlas of {summ['size']:,} four-bars ({summ['certified']:,} certified)")
    progress(0.8, f"matching the {'closed' if closed else 'open'} curve against {summ['size']:,} designs, "
             "polishing and certifying")
    res = synthesize(mech, shape="P", targets=pts, closed=closed, atlas=atlas, top=top, crank=crank)
    names = {j: j for j in ("O2", "A", "B", "O4", "P")}
    candidates = []
    for k, (c, rep) in enumerate(zip(res.candidates, res.report["candidates"])):
        progress(0.9 + 0.1 * k / len(res.candidates), f"drawing candidate {k + 1} of {len(res.candidates)}")
        err = rep["shape_error"]
        model = _diagram_of(c["mechanism"], rep["motion"][0], rep["mode"], names, _FOURBAR_LINKS,
                            "Four-bar (shape synthesis)",
                            f"Coupler point P traces the shape of {len(pts)} drawn points "
                            f"({'closed' if closed else 'open'}; loopsolve edit, shape synthesis, candidate {k + 1}); "
                            f"rms distance {err['rms']:.6g}, max {err['max']:.6g}", units=units)
        curve, extra = _curve(model, "P")
        candidates.append({"objective": rep["objective"], "rms": err["rms"], "max": err["max"], "mode": rep["mode"],
                           "direction": rep["direction"], "certificate": rep["certificate"],
                           "parameters": rep["parameters"], "placement": rep["placement"], "motion": rep["motion"],
                           "model": model, "toml": dumps(model), "curve": curve,
                           "grashof": extra["grashof"] or rep["grashof"],
                           "transmission": extra["transmission"] or rep["transmission"]})
    progress(1.0, f"{len(candidates)} certified candidate(s)")
    return {"task": "shape", "closed": bool(closed), "candidates": candidates, "notes": notes,
            "targets": pts.tolist()}


def freudenstein_synthesis(params: Mapping[str, Any], progress: Callable[[float, str], None]) -> dict:
    """Function generation through precision points ``[[input, output], ...]`` (degrees), Freudenstein."""
    from ..design.synthesis.classical.run import classic_synthesize
    from ..model.modelfile import dumps, loads

    rows = params.get("points")
    try:
        arr = np.array(rows, dtype=float)
    except (TypeError, ValueError):
        raise ModelError("precision points: expected rows [input angle, output angle] in degrees") from None
    if arr.ndim != 2 or arr.shape[1] != 2 or not 3 <= len(arr) <= MAX_TARGETS or not np.isfinite(arr).all():
        raise ModelError(f"precision points: give 3 to {MAX_TARGETS} rows [input angle, output angle] (degrees)")
    progress(0.0, "Freudenstein's equation")
    units = params.get("units") or {"length": "mm", "angle": "deg"}
    # the four-bar the design is written into (classical designs keep the model's names): its joints as points
    base = loads(dumps({
        "name": "four-bar", "units": {"length": "mm", "angle": "deg"},
        "parameters": {"r1": 60, "r2": 25, "r3": 70, "r4": 45},
        "variables": {"theta2": {"input": True, "guess": 90.0}, "theta3": {"guess": 16.1}, "theta4": {"guess": 80.7}},
        "vectors": {"r1": {"length": "r1", "angle": 0}, "r2": {"length": "r2", "angle": "theta2"},
                    "r3": {"length": "r3", "angle": "theta3"}, "r4": {"length": "r4", "angle": "theta4"}},
        "loops": [{"equation": "r2 + r3 = r1 + r4"}],
        "points": {"O2": "0", "B": "r2", "C": "r2 + r3", "O4": "r1"}}), source="<Freudenstein>")
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
    errs = [abs(float(t["error"])) for t in rep["targets"]]  # degrees of output (signed in the report)
    progress(1.0, "done")
    return {"task": "function", "targets": arr.tolist(), "notes": [], "candidates": [{
        "objective": rep["objective"], "rms": math.sqrt(sum(e * e for e in errs) / len(errs)), "max": max(errs),
        "mode": rep["mode"], "certificate": rep["certificate"], "parameters": rep["parameters"], "model": model,
        "toml": dumps(model), "curve": curve, "structural_error": rep.get("structural_error"), **extra}]}


#: the panel's methods by the name the page sends
METHODS: dict[str, Callable[[Mapping[str, Any], Callable[[float, str], None]], dict]] = {
    "shape": shape_synthesis,
    "path": path_synthesis,
    "freudenstein": freudenstein_synthesis,
}


def run(method: str, params: Mapping[str, Any], progress: Callable[[float, str], None]) -> dict:
    """Run a registered method (``ModelError`` for an unknown one)."""
    if method not in METHODS:
        raise ModelError(f"unknown synthesis method {method!r} (methods: {', '.join(METHODS)})")
    return METHODS[method](params, progress)
