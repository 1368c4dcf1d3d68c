"""Structural error of a function generator over the whole input range (not only at the targets).

A function-generation design meets its targets; between them its output follows the linkage, not
the wanted function. :func:`structural_error` tracks the design over the intended input range
(by default the targets' range) in the mode of the first target, both ways from it, and compares
the output with a reference: a callable ``desired(x)`` (model units) or, from targets alone, the
shape-preserving piecewise cubic (PCHIP) through the targets. The largest difference and where it
occurs go in the report as ``structural_error`` (output units; angles in the model's angle unit).
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from ...errors import ModelError, SolveError

__all__ = ["structural_error", "targets_reference"]


def targets_reference(inputs, outputs):
    """The PCHIP curve through the targets (sorted by input; extrapolated beyond the ends)."""
    from scipy.interpolate import PchipInterpolator

    x = np.asarray(inputs, dtype=float)
    y = np.asarray(outputs, dtype=float)
    order = np.argsort(x)
    x, y = x[order], y[order]
    if len(x) < 2 or np.any(np.diff(x) <= 0):
        raise ModelError("structural error: the targets need at least two different inputs (and no input twice)")
    return PchipInterpolator(x, y, extrapolate=True)


def structural_error(mech, output: str, start: float, *, desired=None, targets=None, input_range=None,
                     points: int = 1001) -> dict:
    """``{"max", "at", "range", "reached", "reference", "points"}`` of ``mech``'s output ``output``.

    ``start``: an input (model units) where the mechanism's guesses hold (the first target);
    ``targets``: ``(inputs, outputs)`` for the default reference and range; ``input_range``:
    ``(lo, hi)`` (default: the targets' inputs' span). ``reached`` is the part of the range the
    tracked motion covers (a limit position ends it early: the range defect).
    """
    if desired is None:
        if targets is None:
            raise ModelError("structural error: give the wanted function (desired=) or the targets")
        desired = targets_reference(*targets)
        reference = "pchip through the targets"
    else:
        reference = "function"
    if input_range is None:
        if targets is None:
            raise ModelError("structural error: give the input range (input_range=) or the targets")
        xs = np.asarray(targets[0], dtype=float)
        input_range = (float(xs.min()), float(xs.max()))
    lo, hi = (float(v) for v in input_range)
    if not hi > lo:
        raise ModelError(f"structural error: input range {lo:g}:{hi:g} needs LO < HIGH")
    ck = mech.compile()
    inp = mech.inputs[0]
    deg = mech.units.angle == "deg"
    kind = next(v.kind for v in mech.variables if v.name == output)
    is_angle = kind.name == "ANGLE"
    period = (360.0 if deg else 2 * math.pi) if is_angle else None
    guess = {v.name: (math.degrees(v.guess) if v.kind.name == "ANGLE" and deg else v.guess)
             for v in mech.variables if not v.input and v.guess is not None}
    mode = ck.signature(np.array([v.guess if v.guess is not None else 0.0 for v in mech.variables], dtype=float)) \
        if all(v.guess is not None for v in mech.variables if not v.input) else None
    start = min(max(float(start), lo), hi)
    xs_all, ys_all, reached = [], [], [start, start]
    step = (hi - lo) / max(points - 1, 8)
    for end, k in ((lo, 0), (hi, 1)):
        if abs(end - start) < 1e-12 * max(1.0, abs(end)):
            reached[k] = end
            continue
        n = max(8, int(math.ceil(abs(end - start) / step)))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                sw = mech.sweep(start, end, abs(end - start) / n, guess=guess, mode=mode, progress=False,
                                method="tracked")
            except SolveError:
                continue
        x = np.asarray(sw[inp], dtype=float)
        y = np.asarray(sw[output], dtype=float)
        good = np.isfinite(x) & np.isfinite(y)
        x, y = x[good], y[good]
        if len(x):
            reached[k] = float(x[-1])
        xs_all.append(x)
        ys_all.append(y)
    if not xs_all or not sum(len(x) for x in xs_all):
        return {"max": None, "at": None, "range": [lo, hi], "reached": None, "reference": reference, "points": 0}
    x = np.concatenate(xs_all)
    y = np.concatenate(ys_all)
    e = y - np.asarray(desired(x), dtype=float)
    if period is not None:
        e = (e + period / 2) % period - period / 2
    i = int(np.argmax(np.abs(e)))
    return {"max": float(abs(e[i])), "at": float(x[i]), "signed": float(e[i]), "range": [lo, hi],
            "reached": [float(min(reached)), float(max(reached))], "reference": reference, "points": int(len(x))}
