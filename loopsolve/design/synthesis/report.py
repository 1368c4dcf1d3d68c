"""Pieces of a synthesis report shared by the general and the classical methods: the per-target entries
and the ``fit`` block, each in one unit and with one sign convention (docs/reference/results.md, "Synthesis report").

Per-target entries (``targets``), the design's values from its positions at the targets:

* path: ``{"input", "target": [x, y], "value": [x, y], "error", "dx", "dy"}`` — ``error`` the
  distance |P − T| (model length unit, ≥ 0), ``dx``/``dy`` the signed differences design − target;
* function: ``{"input", "target", "value", "error"}`` — ``error`` = value − target, signed, in the
  output's model unit (an angle in the model's angle unit, within half a turn);
* motion: ``{"input", "target": [x, y, angle], "value": [x, y, angle], "error", "dx", "dy",
  "dangle"}`` — ``error`` = √(|P − T|² + (L·Δφ)²) (model length unit, ≥ 0, the term of the
  objective), ``dangle`` = Δφ, signed, in the model's angle unit, within half a turn.

An angle ``value`` is the design's, taken within half a turn of its target (so value − target is
the error). ``input`` is the input value at the target, model units.

The ``fit`` block says how well the design meets the targets, independently of the certificate
(which says whether it moves through them): ``{"max", "rms", "scale", "relative", "verdict"}``
— the largest and the root-mean-square error at the targets (their ``error``, absolute values),
the targets' size ``scale`` (path and motion: the largest distance between two targets; function:
the span of the target outputs; 1 if that is 0) and ``relative = max / scale``; the verdict is
``exact`` (relative ≤ 1e-6), ``close`` (≤ 1e-2), ``approximate`` (≤ 0.1) or ``poor``.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["fit_block", "fit_phrase", "targets_scale", "target_entries", "VERDICTS", "wrap_half"]

#: (upper bound of the relative error, verdict), in order
VERDICTS = ((1e-6, "exact"), (1e-2, "close"), (1e-1, "approximate"), (math.inf, "poor"))


def wrap_half(d, period: float):
    """``d`` taken into [−period/2, period/2)."""
    return (np.asarray(d, dtype=float) + period / 2) % period - period / 2


def targets_scale(task: str, targets) -> float:
    """The targets' size (see the module docstring), in the units of ``targets`` (model units)."""
    t = np.asarray(targets, dtype=float)
    if task == "function":
        y = t.reshape(len(t), -1)[:, 0]
        s = float(np.max(y) - np.min(y)) if len(y) else 0.0
    else:
        p = t[:, :2]
        s = float(np.max(np.hypot(*(p[:, None] - p[None]).transpose(2, 0, 1)))) if len(p) else 0.0
    return s if s > 0 and math.isfinite(s) else 1.0


def fit_block(errors, scale: float) -> dict:
    """``{"max", "rms", "scale", "relative", "verdict"}`` of the errors at the targets (None: not reached)."""
    e = [abs(float(v)) for v in errors if v is not None and math.isfinite(float(v))]
    if len(e) < len(list(errors)) or not e:
        return {"max": None, "rms": None, "scale": float(scale), "relative": None, "verdict": "poor",
                "note": "the design does not reach every target"}
    mx = max(e)
    rms = math.sqrt(sum(v * v for v in e) / len(e))
    rel = mx / scale
    verdict = next(v for bound, v in VERDICTS if rel <= bound)
    return {"max": mx, "rms": rms, "scale": float(scale), "relative": rel, "verdict": verdict}


def fit_phrase(fit: dict) -> str:
    """A few words for the command line's summary line: '' for an exact or close fit."""
    if fit is None or fit.get("verdict") in ("exact", "close"):
        return ""
    if fit.get("relative") is None:
        return "; poor fit: not every target is reached"
    return (f"; {fit['verdict']} fit: the largest error at a target is {fit['max']:.3g} = "
            f"{100 * fit['relative']:.3g} % of the targets' size {fit['scale']:.3g}")


def target_entries(problem, values, shown_inputs, Z) -> list[dict]:
    """The per-target entries of a general-method design (see the module docstring).

    ``values``: the varied parameters (model units); ``shown_inputs``: the input at each target as
    the report shows it (model units); ``Z`` ``(nvar, T)``: the positions at the targets (internal).
    """
    from ...model.units import Kind

    b = problem.batch
    ck = problem.ck
    deg = problem.mech.units.angle == "deg"
    T = problem.T
    Z = np.asarray(Z, dtype=float)
    out = []
    if problem.task == "function":
        iout = ck.index(problem.output)
        ang = ck.kinds[iout] is Kind.ANGLE
        conv = (lambda v: math.degrees(v)) if ang and deg else (lambda v: float(v))
        period = (360.0 if deg else 2 * math.pi) if ang else None
        for t in range(T):
            v, y = conv(Z[iout, t]), conv(problem.targets[t, 0])
            e = float(wrap_half(v - y, period)) if period else v - y
            out.append({"input": shown_inputs[t], "target": y, "value": y + e, "error": e})
        return out
    P = b.params(np.asarray(values, dtype=float)[None])
    pts = b.points(Z, np.repeat(P, T, axis=1))[ck.points.index(problem.point)]  # (2, T)
    tg = problem.targets
    for t in range(T):
        dx, dy = float(pts[0, t] - tg[t, 0]), float(pts[1, t] - tg[t, 1])
        e = {"input": shown_inputs[t], "target": [float(tg[t, 0]), float(tg[t, 1])],
             "value": [float(pts[0, t]), float(pts[1, t])], "error": math.hypot(dx, dy), "dx": dx, "dy": dy}
        if problem.task == "motion":
            il = ck.index(problem.link)
            d = float(wrap_half(Z[il, t] - tg[t, 2], 2 * math.pi))  # radians
            conv = math.degrees if deg else float
            e["target"].append(conv(tg[t, 2]))
            e["value"].append(conv(tg[t, 2] + d))
            e["error"] = math.hypot(e["error"], problem.L * d)
            e["dangle"] = conv(d)
        out.append(e)
    return out
