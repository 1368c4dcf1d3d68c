"""What the editor's page shows for a model: one JSON-ready ``dict`` per analysis.

:func:`analyze` builds the mechanism from the model ``dict`` exactly as a model file is read
(the text :func:`loopsolve.model.modelfile.dumps` writes goes through
:func:`loopsolve.model.modelfile.loads`, the safe parser), sweeps it over its default range (or
the page's) in the mode its guesses name, and returns:

* ``page``: the interactive page's data (:func:`loopsolve.output.view.page_data`: the scene drawn
  to scale, the unknowns' positions, velocities and accelerations, events), with extra series:
  the transmission angle of every dyad of two angle unknowns (``mu_<a>/<b>``, degrees) and,
  when the model declares masses, the driving torque (force) and the magnitude of every joint
  force;
* ``forces``: the columns of :func:`loopsolve.dynamics.kinetostatics.forces` on the same rows
  (the numbers ``loopsolve forces`` prints), when the model has ``[bodies]``;
* ``info``: mobility, Grashof class and transmission range of every four-bar loop, the
  reachable input ranges (the limit positions), from :meth:`Mechanism.info`;
* ``joints``/``links``: the diagram's elements (what the page can drag and edit);
* ``dimensions``: the model's parameters (generated lengths of a diagram) with their values;
* ``mode``: the signature the guesses name and its alias.

A model that is not (yet) a mechanism — a link just added, a mobility that does not match the
input — still gives a ``dict``: ``ok`` is false, ``error`` says why, and ``joints``/``links``
let the page draw the diagram as declared.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..errors import LoopsolveError, ModelError
from .editing import is_diagram

__all__ = ["analyze", "build", "MAX_ROWS", "default_settings"]

#: most rows of the sweep behind one analysis (bounded work per request)
MAX_ROWS = 4000


def build(data: Mapping, source: str = "<editor>"):
    """The mechanism of a model ``dict``, through the model-file writer and the safe parser."""
    from ..model.modelfile import dumps, loads

    return loads(dumps(data), source=source)


def _clean(v):
    if isinstance(v, (float, np.floating)):
        v = float(v)
        return v if math.isfinite(v) else None
    if isinstance(v, np.integer):
        return int(v)
    if isinstance(v, np.ndarray):
        return [_clean(x) for x in v.tolist()]
    if isinstance(v, Mapping):
        return {str(k): _clean(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_clean(x) for x in v]
    return v


def default_settings(ck, mode=None) -> dict:
    """The sweep range the page starts with: the CLI's default range, 2° (or 1/180 of the range) a row."""
    from ..kinematics.reach import default_range
    from ..kinematics.solve import display_value
    from ..model.units import Kind

    i = ck.input_idx[0]
    if ck.kinds[i] is Kind.ANGLE:
        step = float(display_value(ck, math.radians(2.0)))
        start, stop, through = default_range(ck, step, mode=mode)
        return {"from": start, "to": stop, "step": step, "through": bool(through)}
    probe = float(display_value(ck, ck.scale / 50))
    start, stop, through = default_range(ck, probe, mode=mode)
    span = abs(stop - start)
    step = float(f"{span / 180:.3g}") if span > 0 else probe
    start, stop, through = default_range(ck, step, mode=mode)
    return {"from": start, "to": stop, "step": step, "through": bool(through)}


def _transmission(sweep) -> dict:
    ck = sweep.compiled
    from ..model.units import Kind

    out = {}
    cols = sweep.columns
    for b in ck.blocks:
        if len(b.unknowns) != 2:
            continue
        a, c = (ck.unknowns[u] for u in b.unknowns)
        if ck.kinds[ck.index(a)] is not Kind.ANGLE or ck.kinds[ck.index(c)] is not Kind.ANGLE:
            continue
        d = np.radians(cols[a] - cols[c]) if ck.mechanism.units.angle == "deg" else cols[a] - cols[c]
        mu = np.degrees(np.abs(np.arctan2(np.sin(d), np.cos(d))))
        short = lambda n: n[6:] if n.startswith("theta_") else n  # noqa: E731
        out[f"mu_{short(a)}/{short(c)} [deg]"] = mu
    return out


def _forces(sweep) -> tuple[dict, dict, dict]:
    """(extra series, every force column, units) of the force analysis on the sweep's rows."""
    from ..dynamics.kinetostatics import force_analysis

    fs = force_analysis(sweep)
    unit = "N*m" if fs.drive_name == "input_torque" else "N"
    extra = {f"{fs.drive_name} [{unit}]": np.asarray(fs.drive, dtype=float)}
    cols = fs.force_columns
    names = [k[:-2] for k in cols if k.startswith("F_") and k.endswith("_x")]
    for n in names:
        if f"{n}_y" in cols:
            extra[f"|{n}| [N]"] = np.hypot(cols[f"{n}_x"], cols[f"{n}_y"])
    units = fs.units()
    return extra, {k: np.asarray(v, dtype=float) for k, v in cols.items()}, {k: units.get(k, "") for k in cols}


def _elements(data: Mapping) -> tuple[list, dict]:
    """The diagram's joints (name, kind, drawn position, links) and links, as the page draws them."""
    if not is_diagram(data):
        return [], {}
    links = {str(k): [str(j) for j in v] for k, v in (data.get("links") or {}).items() if isinstance(v, list)}
    carried = {}
    for k, js in links.items():
        for j in js:
            carried.setdefault(j, []).append(k)
    joints = []
    for name, entry in (data.get("joints") or {}).items():
        if not isinstance(entry, Mapping):
            continue
        at = entry.get("at")
        try:
            xy = [float(at[0]), float(at[1])]
        except (TypeError, ValueError, IndexError, KeyError):
            xy = None
        kind = "P" if str(entry.get("type", "R")).upper() in ("P", "PRISMATIC", "SLIDER") else "R"
        on = carried.get(name, [])
        joints.append({"name": str(name), "type": kind, "at": xy, "links": on,
                       "ground": "ground" in on, "point": len(on) == 1 and kind == "R"})
    return joints, links


def analyze(data: Mapping, settings: Mapping[str, Any] | None = None, *, source: str = "<editor>") -> dict:
    """The page's analysis of a model ``dict`` (see the module notes); never raises for a model error."""
    from ..kinematics.solve import guessed_mode
    from ..output.geometry import mode_label
    from ..output.view import page_data

    joints, links = _elements(data)
    out: dict[str, Any] = {"ok": False, "kind": "diagram" if is_diagram(data) else "vectors",
                           "joints": joints, "links": links, "name": str(data.get("name", "")),
                           "units": dict(data.get("units") or {"length": "mm", "angle": "deg"})}
    try:
        mech = build(data, source)
        out["units"] = {"length": mech.units.length, "angle": mech.units.angle}
        out["dimensions"] = [{"name": p.name, "value": _clean(_param_value(mech, p)), "kind": p.kind.name.lower()}
                             for p in mech.parameters]
        ck = mech.compile()
        mode = guessed_mode(ck)
        out["mode"] = {"signature": mode, "label": mode_label(mech, mode) if mode else None,
                       "aliases": dict(mech.mode_aliases)}
        out["input"] = {"name": ck.inputs[0], "guess": _clean(mech.variable(ck.inputs[0]).guess)}
        sett = default_settings(ck)
        given = {k: settings[k] for k in ("from", "to", "step", "through") if settings and settings.get(k) is not None}
        sett.update(given)
        step = float(sett["step"])
        if not math.isfinite(step) or step <= 0:
            raise ModelError(f"step {sett['step']!r}: must be a positive number")
        if abs(float(sett["to"]) - float(sett["from"])) / step > MAX_ROWS:
            raise ModelError(f"the sweep from {sett['from']} to {sett['to']} by {step} has more than {MAX_ROWS} "
                             "rows, the editor's limit: take a larger step")
        out["settings"] = _clean(sett)
        sweep = mech.sweep(sett["from"], sett["to"], step, through_limits=bool(sett["through"]), progress=False,
                           max_rows=MAX_ROWS, limit_rows=True)
        extra = _transmission(sweep)
        if getattr(mech, "dynamics", None) is not None and len(sweep):
            fx, cols, units = _forces(sweep)
            extra.update(fx)
            out["forces"] = {"columns": _clean(cols), "units": units}
        out["page"] = page_data(sweep, extra_series=extra)
        info = mech.info()
        out["info"] = _clean({k: info.get(k) for k in ("mobility", "fourbars", "reachable_input_ranges",
                                                       "quick_return", "inputs", "unknowns")})
        out["events"] = [e.to_dict() for e in sweep.events]
        out["ok"] = True
    except LoopsolveError as exc:
        out["error"] = f"{type(exc).__name__}: {exc}"
    except (ArithmeticError, ValueError, OverflowError) as exc:
        out["error"] = f"numeric failure ({type(exc).__name__}: {exc}); check the model's magnitudes"
    return out


def _param_value(mech, p) -> float:
    from ..model.units import Kind

    v = float(p.value)
    if p.kind is Kind.ANGLE and mech.units.angle == "deg":
        return math.degrees(v)
    return v
