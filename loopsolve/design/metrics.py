"""Design metrics: reductions over the input of expressions of a study's columns.

A metric is ``NAME=EXPR`` where ``EXPR`` is

* a reduction ``min``, ``max``, ``mean``, ``ptp``, ``argmin`` or ``argmax`` of an expression
  of the columns, e.g. ``min(abs(sin(theta4 - theta3)))``; ``argmin``/``argmax`` give the
  input value (display units) where the extreme is;
* a built-in: ``transmission(a, b)`` — minimum transmission angle (degrees, 0–90) between the
  links at angles ``a`` and ``b``; ``swing(v)`` / ``stroke(v)`` — travel (max − min, display
  units) of an output; ``time_ratio(v)`` — quick-return time ratio of an oscillating output
  over a full turn of the input at constant speed (longer stroke time over shorter; the
  extremes are the roots of the velocity, located by cubic Hermite interpolation of the
  velocity and acceleration between rows); ``max_acc(v)`` — max |acceleration| of ``v``;
  ``grashof(a, b, c, d)`` — Grashof class of four lengths (1 Grashof, 0 change point,
  −1 non-Grashof);
* an expression of the parameters alone (one value per design), e.g. ``r2 / r3``.

Expressions use the safe language of :mod:`loopsolve.model.expr` (no ``eval``), evaluated on
whole arrays. Inside expressions the positions of angle variables are in **radians** (so
``sin(theta4 - theta3)`` means what it says); every other column (rates, lengths, points)
is in its display unit, parameters in model units. Reductions ignore rows a design does
not have (NaN); a design without rows gets NaN.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..model import expr as _expr
from ..errors import ModelError

__all__ = ["Metric", "parse_metric", "evaluate_metrics", "REDUCTIONS", "BUILTINS"]

REDUCTIONS = ("min", "max", "mean", "ptp", "argmin", "argmax")
BUILTINS = {"transmission": 2, "swing": 1, "stroke": 1, "time_ratio": 1, "max_acc": 1, "grashof": 4}
_NP = {"sin": np.sin, "cos": np.cos, "tan": np.tan, "asin": np.arcsin, "acos": np.arccos, "atan": np.arctan,
       "atan2": np.arctan2, "sqrt": np.sqrt, "abs": np.abs}
_CALL = re.compile(r"^\s*([A-Za-z_]\w*)\s*\((.*)\)\s*$", re.S)


@dataclass(frozen=True)
class Metric:
    """One parsed metric: ``func`` is a reduction, a built-in or ``"value"`` (parameters only)."""

    name: str
    text: str
    func: str
    args: tuple  # parsed expression trees


def _split_args(text: str) -> list[str]:
    out, depth, cur = [], 0, ""
    for ch in text:
        if ch == "(":
            depth += 1
        elif ch == ")":
            depth -= 1
        if ch == "," and depth == 0:
            out.append(cur)
            cur = ""
        else:
            cur += ch
    out.append(cur)
    return [a.strip() for a in out]


def parse_metric(text: str) -> Metric:
    """Parse ``NAME=EXPR`` (see the module docstring).

    Examples
    --------
    >>> m = parse_metric("min_transmission=min(abs(sin(theta4 - theta3)))")
    >>> m.name, m.func
    ('min_transmission', 'min')
    >>> parse_metric("mu=transmission(theta3, theta4)").args[1]
    Name(id='theta4')
    """
    name, sep, body = text.partition("=")
    name = name.strip()
    if not sep or not re.fullmatch(r"[A-Za-z_]\w*", name) or not body.strip():
        raise ModelError(f"--metric {text!r}: expected NAME=EXPR, e.g. min_tr=min(abs(sin(theta4 - theta3)))")
    m = _CALL.match(body)
    if m and m.group(1) in REDUCTIONS:
        return Metric(name, body.strip(), m.group(1), (_expr.parse(m.group(2)),))
    if m and m.group(1) in BUILTINS:
        args = _split_args(m.group(2))
        if len(args) != BUILTINS[m.group(1)]:
            raise ModelError(f"--metric {text!r}: {m.group(1)}() takes {BUILTINS[m.group(1)]} argument(s)")
        return Metric(name, body.strip(), m.group(1), tuple(_expr.parse(a) for a in args))
    try:
        node = _expr.parse(body)
    except _expr.ExpressionError as exc:
        raise ModelError(f"--metric {text!r}: {exc}; a metric is a reduction ({', '.join(REDUCTIONS)}) of an "
                         f"expression of the columns, a built-in ({', '.join(BUILTINS)}) or an expression of the "
                         "parameters") from None
    return Metric(name, body.strip(), "value", (node,))


def _eval(node, env: Mapping[str, np.ndarray], text: str):
    if isinstance(node, _expr.Num):
        if node.unit is None:
            return float(node.value)
        return _expr.evaluate(node, angle_unit_factor=1.0)  # angle literals in radians, as the columns
    if isinstance(node, _expr.Name):
        try:
            return env[node.id]
        except KeyError:
            raise ModelError(f"metric {text!r}: unknown name {node.id!r}; use a column or parameter: "
                             f"{', '.join(sorted(env))}") from None
    if isinstance(node, _expr.Const):
        return _expr.CONSTANTS[node.name]
    if isinstance(node, _expr.Unary):
        v = _eval(node.operand, env, text)
        return -v if node.op == "-" else v
    if isinstance(node, _expr.Binary):
        a, b = _eval(node.left, env, text), _eval(node.right, env, text)
        return {"+": np.add, "-": np.subtract, "*": np.multiply, "/": np.divide, "**": np.power}[node.op](a, b)
    if isinstance(node, _expr.Call):
        return _NP[node.func](*[_eval(a, env, text) for a in node.args])
    raise ModelError(f"metric {text!r}: not an expression node {node!r}")  # pragma: no cover


def _extreme_x(v, x, which):
    """Input of the extreme of each row of ``v`` (D, K), refined by a parabola through 3 grid points."""
    D, K = v.shape
    out = np.full(D, np.nan)
    filled = np.where(np.isnan(v), -np.inf if which == "max" else np.inf, v)
    k = np.argmax(filled, axis=1) if which == "max" else np.argmin(filled, axis=1)
    has = ~np.all(np.isnan(v), axis=1)
    for d in np.flatnonzero(has):
        i = k[d]
        out[d] = x[i]
        if 0 < i < K - 1 and np.all(np.isfinite(v[d, i - 1:i + 2])):
            y0, y1, y2 = v[d, i - 1:i + 2]
            den = y0 - 2 * y1 + y2
            if den != 0:
                out[d] = x[i] + 0.5 * (y0 - y2) / den * (x[i + 1] - x[i])
    return out


def _turning_points(vel, acc, speed, x, deg):
    """Inputs where an output's velocity changes sign (+ to −: its maximum; − to +: its minimum).

    On each bracketing grid interval the velocity is a cubic Hermite in the input from its
    values and slopes dv/dx = acc / speed (constant input speed) at both rows; its root is
    found by bisection. Returns ``(x_max, x_min)`` per design (NaN where not found).
    """
    D = vel.shape[0]
    conv = math.pi / 180 if deg else 1.0
    out = np.full((2, D), np.nan)
    sgn = np.sign(x[-1] - x[0])
    for d in range(D):
        v, a, w = vel[d], acc[d], speed[d]
        for i in range(len(x) - 1):
            v0, v1 = v[i], v[i + 1]
            if not (np.isfinite(v0) and np.isfinite(v1)) or (v0 > 0) == (v1 > 0) or v0 == 0:
                continue
            kind = 0 if (v0 > 0) == (sgn > 0) else 1  # v decreasing in x: a maximum
            H = x[i + 1] - x[i]
            m0, m1 = a[i] / w[i] * conv * H, a[i + 1] / w[i + 1] * conv * H

            def p(t):
                return ((2 * t**3 - 3 * t**2 + 1) * v0 + (t**3 - 2 * t**2 + t) * m0 + (-2 * t**3 + 3 * t**2) * v1
                        + (t**3 - t**2) * m1)

            lo, hi = 0.0, 1.0
            plo = p(lo)
            for _ in range(60):
                mid = 0.5 * (lo + hi)
                pm = p(mid)
                if (pm > 0) == (plo > 0):
                    lo, plo = mid, pm
                else:
                    hi = mid
            if np.isnan(out[kind, d]):
                out[kind, d] = x[i] + 0.5 * (lo + hi) * H
    return out[0], out[1]


def evaluate_metrics(metrics, columns: Mapping[str, np.ndarray], params: Mapping[str, np.ndarray],
                     x: np.ndarray, *, angle_columns=(), full_turn: bool = False, input_name: str = "",
                     input_angle_deg: bool = False) -> dict[str, np.ndarray]:
    """Evaluate parsed metrics on ``columns`` (name → (D, K), display units) and ``params`` (name → (D,)).

    ``x`` is the input grid (display units); ``angle_columns`` the position columns of angle
    variables in degrees (converted to radians inside expressions); ``full_turn`` whether the
    grid covers a full turn of an angle input (needed by ``time_ratio``); ``input_name`` the
    input (its ``_vel`` column is the input speed) and ``input_angle_deg`` whether it is in degrees.

    Examples
    --------
    >>> cols = {"theta4": np.array([[0.0, 90.0, 180.0]])}
    >>> out = evaluate_metrics([parse_metric("m=max(sin(theta4))")], cols, {}, np.array([0., 1., 2.]),
    ...                        angle_columns=("theta4",))
    >>> round(float(out["m"][0]), 12)
    1.0
    """
    env: dict[str, np.ndarray] = {}
    for k, v in columns.items():
        env[k] = np.radians(v) if k in angle_columns else v
    D = next(iter(columns.values())).shape[0] if columns else (len(next(iter(params.values()))) if params else 0)
    for k, v in params.items():
        env[k] = np.asarray(v, dtype=float)[:, None]
    out: dict[str, np.ndarray] = {}
    with np.errstate(all="ignore"):
        for m in metrics:
            if m.func in REDUCTIONS:
                v = np.broadcast_to(np.asarray(_eval(m.args[0], env, m.text), dtype=float), (D, len(x)))
                empty = np.all(np.isnan(v), axis=1)
                vv = np.where(empty[:, None], 0.0, v)
                if m.func == "min":
                    r = np.nanmin(vv, axis=1)
                elif m.func == "max":
                    r = np.nanmax(vv, axis=1)
                elif m.func == "mean":
                    r = np.nanmean(vv, axis=1)
                elif m.func == "ptp":
                    r = np.nanmax(vv, axis=1) - np.nanmin(vv, axis=1)
                else:
                    filled = np.where(np.isnan(vv), np.inf if m.func == "argmin" else -np.inf, vv)
                    idx = np.argmin(filled, axis=1) if m.func == "argmin" else np.argmax(filled, axis=1)
                    r = np.asarray(x, dtype=float)[idx]
                out[m.name] = np.where(empty, np.nan, r)
            elif m.func == "value":
                out[m.name] = np.broadcast_to(np.asarray(_eval(m.args[0], env, m.text), dtype=float).reshape(D, -1)
                                              [:, 0], (D,)).copy()
            else:
                out[m.name] = _builtin(m, env, columns, x, angle_columns, full_turn, D, input_name, input_angle_deg)
    return out


def _column_of(m, node, columns):
    if not isinstance(node, _expr.Name) or node.id not in columns:
        raise ModelError(f"metric {m.text!r}: {m.func}() takes column names; the columns are {', '.join(columns)}")
    return node.id


def _builtin(m, env, columns, x, angle_columns, full_turn, D, input_name, input_angle_deg):
    if m.func == "transmission":
        a, b = (np.asarray(_eval(n, env, m.text), dtype=float) for n in m.args)
        mu = np.degrees(np.arcsin(np.clip(np.abs(np.sin(a - b)), 0, 1)))
        mu = np.broadcast_to(mu, (D, len(x)))
        empty = np.all(np.isnan(mu), axis=1)
        return np.where(empty, np.nan, np.nanmin(np.where(empty[:, None], 0, mu), axis=1))
    if m.func == "grashof":
        L = np.stack([np.broadcast_to(np.asarray(_eval(n, env, m.text), dtype=float).reshape(D, -1)[:, 0], (D,))
                      for n in m.args])
        L = np.sort(np.abs(L), axis=0)
        sl, pq = L[0] + L[3], L[1] + L[2]
        tol = 1e-9 * L[3]
        return np.where(np.abs(sl - pq) <= tol, 0.0, np.where(sl < pq, 1.0, -1.0))
    col = _column_of(m, m.args[0], columns)
    if m.func == "max_acc":
        if col + "_acc" not in columns:
            raise ModelError(f"metric {m.text!r}: no column {col}_acc")
        v = np.abs(columns[col + "_acc"])
        empty = np.all(np.isnan(v), axis=1)
        return np.where(empty, np.nan, np.nanmax(np.where(empty[:, None], 0, v), axis=1))
    v = columns[col]
    if col in angle_columns:  # unwrap a wrapped angle so a swing through ±180° is measured right
        v = np.degrees(np.unwrap(np.radians(np.nan_to_num(v)), axis=1))
        v = np.where(np.isnan(columns[col]), np.nan, v)
    empty = np.all(np.isnan(v), axis=1)
    vv = np.where(empty[:, None], 0.0, v)
    if m.func in ("swing", "stroke"):
        return np.where(empty, np.nan, np.nanmax(vv, axis=1) - np.nanmin(vv, axis=1))
    # time_ratio
    if not full_turn:
        return np.full(D, np.nan)
    complete = ~np.any(np.isnan(v), axis=1)
    if col + "_vel" in columns and col + "_acc" in columns and input_name + "_vel" in columns:
        xa, xb = _turning_points(columns[col + "_vel"], columns[col + "_acc"], columns[input_name + "_vel"], x,
                                 input_angle_deg)
    else:
        xa = _extreme_x(v, x, "max")
        xb = _extreme_x(v, x, "min")
    turn = 360.0 if abs(x[-1] - x[0]) >= 359.999 else 2 * math.pi
    fwd = np.mod((xa - xb) * np.sign(x[-1] - x[0]), turn)
    r = np.maximum(fwd, turn - fwd) / np.minimum(fwd, turn - fwd)
    return np.where(complete, r, np.nan)
