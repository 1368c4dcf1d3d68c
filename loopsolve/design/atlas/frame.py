"""The frame of a model: which parameters place it (translation, rotation) and whether its lengths scale it.

Shape synthesis matches a curve free in position, orientation and scale, and writes the best
design *in the target's coordinates*. That needs parameters that move the whole linkage:

* **translation** — a length parameter that moves every point by the same vector (``x0`` of
  ``r0 = { x = "x0", y = "y0" }`` when every point starts at ``r0``);
* **rotation** — an angle parameter that turns every point about the frame origin by its own
  change (``theta0`` added to every ground angle and to the crank's), at the same input or at
  the input turned by as much (an input measured from the +x axis);
* **scale** — multiplying every length parameter by s multiplies every point's position by s.

:func:`frame_of` finds them by **testing**, not by reading names: each candidate parameter is
changed by a finite amount and the model's points at a few inputs are compared with the moved,
turned or scaled ones (to 1e-9 of the model's size). A model that lacks translation or rotation
parameters (a kinematic-diagram model: its ground pivots are numbers) is given them: its vector
form gets a vector ``frame_r0 = { x = "frame_x", y = "frame_y" }`` added to every point and a
parameter ``frame_angle`` added to the angle of every vector whose angle is a constant (the
ground vectors; the joint variables absorb the rest). The result is tested the same way; a
model whose frame still cannot be placed (a Cartesian ground vector with parameters in it, a
literal length that does not scale) is refused with what to add. The written design of such a
model is its vector form with the frame parameters (a model file like any other).
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass

import numpy as np

from ...errors import ModelError
from ...model.units import Kind

__all__ = ["Frame", "frame_of", "curve_points"]


@dataclass(frozen=True, eq=False)
class Frame:
    """A model with its placement parameters (see the module docstring).

    ``mech`` is the model shape synthesis works on (the given one, or its vector form with the
    frame parameters added: ``added``); ``x``, ``y``, ``angle`` name its translation and rotation
    parameters; ``lengths`` the parameters that scale with the linkage (the length parameters but
    ``x``, ``y``, and dimensionless ones that multiply unit vectors, such as ``rcx`` in ``rcx*u3``);
    ``input_turns``: the input is measured from the +x axis, so turning the frame by α moves a
    pose from input x to input x + α (else the input is measured from the frame).
    """

    mech: object
    point: str
    x: str
    y: str
    angle: str
    lengths: tuple
    added: bool
    input_turns: bool = False


def _values(mech) -> dict:
    return {p.name: float(mech.spec["parameters"][p.name]) for p in mech.parameters}


def curve_points(mech, values_list, xs, signs=None, point=None):
    """Points of designs at inputs: ``(D, X, npts, 2)`` (NaN where a design does not assemble).

    ``values_list`` a list of parameter dicts (model units), ``xs`` ``(D, X)`` internal inputs.
    """
    from ..synthesis.candidates import Batch

    ck = mech.compile()
    names = [p.name for p in mech.parameters]
    b = Batch(ck, names)
    V = np.array([[v[n] for n in names] for v in values_list])
    P = b.params(V)
    D, X = np.asarray(xs).shape
    if signs is None:
        signs = b.guessed_signs(P[:, :1])[:, 0]
    S = np.repeat(np.asarray(signs, dtype=float)[:, None], D * X, axis=1)
    PP = np.repeat(P, X, axis=1)
    with np.errstate(all="ignore"):
        Z, ok = b.assemble(PP, np.asarray(xs, dtype=float).reshape(-1), S)
        pts = b.points(Z, PP)  # (npts, 2, D*X)
    pts = np.where(ok[None, None, :], pts, np.nan)
    return np.moveaxis(pts, 2, 0).reshape(D, X, len(ck.points), 2), signs


def _probe_inputs(mech):
    """A few inputs (internal) near the guess where the model assembles in its guessed mode."""
    from ..synthesis.candidates import Batch

    ck = mech.compile()
    b = Batch(ck, [])
    P = b.params(np.zeros((1, 0)))
    sig = b.guessed_signs(P)
    x0 = b.x_guess
    step = math.radians(6.0) if b.input_is_angle else 0.02 * ck.scale
    xs = x0 + step * np.arange(-4, 5)
    Z, ok = b.assemble(np.repeat(P, len(xs), axis=1), xs, np.repeat(sig, len(xs), axis=1))
    good = xs[ok]
    if good.size < 2:
        raise ModelError(f"{mech.source or mech.name}: the model does not assemble near its guesses in the mode "
                         "they name; fix the guesses before shape synthesis")
    return good[:4], sig[:, 0]


def _same(a, b, tol) -> bool:
    return bool(np.all(np.isfinite(a)) and np.all(np.isfinite(b)) and np.max(np.abs(a - b)) <= tol)


def _detect(mech):
    """``(x, y, angle, turns, scaled)``: parameters found by test (None where none does it), whether the
    input turns with ``angle`` (an input measured from +x), and the parameters whose common factor
    scales the linkage."""
    ck = mech.compile()
    base = _values(mech)
    xs, sig = _probe_inputs(mech)
    deg = mech.units.angle == "deg"
    size = float(ck.scale)
    tol = 1e-8 * size
    lens = [p.name for p in mech.parameters if p.kind is Kind.LENGTH]
    angs = [p.name for p in mech.parameters if p.kind is Kind.ANGLE]
    dl = 0.37 * size
    da = 0.6  # radians
    trials = [dict(base)]
    for n in lens:
        trials.append(dict(base, **{n: base[n] + dl}))
    for n in angs:
        trials.append(dict(base, **{n: base[n] + (math.degrees(da) if deg else da)}))
    # scaling: the length parameters, and with them the dimensionless ones if they must scale too
    # (factors of unit vectors: rcx in "rcx*u3" with u3 = { length = 1, ... })
    dims = [p.name for p in mech.parameters if p.kind is Kind.DIMENSIONLESS]
    scale_sets = [lens, lens + dims] if dims else [lens]
    for group in scale_sets:
        trials.append({n: (v * 1.7 if n in group else v) for n, v in base.items()})
    X = np.tile(xs, (len(trials), 1))
    pts, _ = curve_points(mech, trials, X, sig)
    # the rotation trials once more with the input turned as well (an input measured from +x)
    Xr = np.tile(xs + da, (len(angs), 1))
    pts_r, _ = curve_points(mech, trials[1 + len(lens):1 + len(lens) + len(angs)], Xr, sig) if angs else (None, None)
    p0 = pts[0]
    x = y = angle = None
    for i, n in enumerate(lens):
        d = pts[1 + i] - p0
        if x is None and _same(d, np.broadcast_to([dl, 0.0], d.shape), tol):
            x = n
        elif y is None and _same(d, np.broadcast_to([0.0, dl], d.shape), tol):
            y = n
    turns = False
    for j, n in enumerate(angs):
        for k, cand in enumerate((pts[1 + len(lens) + j], pts_r[j])):
            if angle is None and _rotation(p0, cand, da, base, x, y, tol):
                angle, turns = n, k == 1
    scalable = None
    for k, group in enumerate(scale_sets):
        if _same(pts[len(trials) - len(scale_sets) + k], 1.7 * p0, 1.7 * tol):
            scalable = tuple(group)
            break
    return x, y, angle, turns, scalable


def _rotation(p0, p1, da, base, x, y, tol) -> bool:
    """Whether ``p1`` is ``p0`` turned by ``da`` about one centre (the translation parameters' point, or any)."""
    z0 = p0[..., 0] + 1j * p0[..., 1]
    z1 = p1[..., 0] + 1j * p1[..., 1]
    if not (np.all(np.isfinite(z0)) and np.all(np.isfinite(z1))):
        return False
    w = np.exp(1j * da)
    c = (z1.reshape(-1)[0] - w * z0.reshape(-1)[0]) / (1 - w)
    return bool(np.max(np.abs(c + w * (z0 - c) - z1)) <= tol)


def _free_name(mech, want: str) -> str:
    taken = {p.name for p in mech.parameters} | {v.name for v in mech.variables} | {v.name for v in mech.vectors}
    name, k = want, 2
    while name in taken:
        name, k = f"{want}{k}", k + 1
    return name


def _axis_polar(v, _expr):
    """A Cartesian vector along an axis (one component the number 0) as ``(length text, angle in degrees)``."""
    def zero(n):
        return isinstance(n, _expr.Num) and n.value == 0 and n.unit is None

    if zero(v.x):
        return _expr.to_text(v.y), 90.0
    if zero(v.y):
        return _expr.to_text(v.x), 0.0
    return None


def _add_frame(mech, need_xy: bool, need_angle: bool):
    """The vector form of ``mech`` with frame parameters added; ``(mech2, x, y, angle)`` names (None: not added)."""
    from ...model import expr as _expr
    from ...model.modelfile import dumps, loads

    vec = loads(dumps(mech), source=mech.source)  # a diagram model's vector form (a vector model: itself)
    spec = copy.deepcopy(dict(vec.spec))
    spec.pop("joints", None)
    spec.pop("links", None)
    params = spec.setdefault("parameters", {})
    var_names = {v.name for v in vec.variables}
    xn = yn = an = None
    if need_angle:
        an = _free_name(vec, "frame_angle")
        params[an] = 0.0
        vectors = spec["vectors"]
        for v in vec.vectors:
            entry = vectors[v.name]
            if v.cartesian:
                polar = _axis_polar(v, _expr)
                if polar is not None and not (_expr.names(v.x) | _expr.names(v.y)) & var_names:
                    length, ang = polar  # { x = 0, y = "e" }: the length "e" at 90 degrees
                    vectors[v.name] = {"length": length, "angle": f"{ang} + {an}" if mech.units.angle == "deg"
                                       else f"{math.radians(ang)!r} + {an}"}
                    continue
                raise ModelError(f"{mech.source or mech.name}: vector {v.name!r} is Cartesian; shape synthesis "
                                 "cannot turn the model's frame. Declare it by length and angle, or give the model "
                                 "a rotation parameter (add \"+ theta0\" to every ground angle, as "
                                 "models/fourbar_path_synthesis.toml does)")
            if _expr.names(v.angle) & var_names:
                continue
            entry = dict(entry) if isinstance(entry, dict) else {"length": entry}
            entry["angle"] = f"({_expr.to_text(v.angle)}) + {an}"
            vectors[v.name] = entry
    if need_xy:
        xn, yn = _free_name(vec, "frame_x"), _free_name(vec, "frame_y")
        params[xn] = 0.0
        params[yn] = 0.0
        r0 = _free_name(vec, "frame_r0")
        spec["vectors"] = {r0: {"x": xn, "y": yn}, **spec["vectors"]}
        pts = spec.get("points", {})
        for name, text in list(pts.items()):
            t = str(text).strip()
            pts[name] = r0 if t == "0" else (f"{r0} {t}" if t.startswith("-") else f"{r0} + {t}")
    return loads(dumps(spec), source=mech.source), xn, yn, an


def frame_of(mech, point: str) -> Frame:
    """The frame of ``mech`` for shape synthesis of ``point`` (see the module docstring).

    Raises :class:`~loopsolve.errors.ModelError` when the model's frame cannot be placed or
    scaled, naming what to add.
    """
    ck = mech.compile()
    if point not in ck.points:
        raise ModelError(f"{mech.source or mech.name}: --shape {point!r} is not a declared point; the points are "
                         f"{', '.join(ck.points) or 'none (add a [points] section)'}")
    x, y, angle, turns, scalable = _detect(mech)
    added = False
    m = mech
    if x is None or y is None or angle is None:
        m, xn, yn, an = _add_frame(mech, x is None or y is None, angle is None)
        added = True
        x, y, angle, turns, scalable = _detect(m)
        if x is None or y is None or angle is None:
            raise ModelError(f"{mech.source or mech.name}: shape synthesis cannot place the model's frame (no "
                             "parameters move and turn the whole linkage); give it a vector r0 = { x = \"x0\", "
                             "y = \"y0\" } at the start of every point and \"+ theta0\" in every ground angle, as "
                             "models/fourbar_path_synthesis.toml does")
    if scalable is None:
        raise ModelError(f"{mech.source or mech.name}: the model's lengths do not scale the linkage (a length is "
                         "a number, not a parameter); make every length a parameter for shape synthesis")
    lengths = tuple(n for n in scalable if n not in (x, y))
    return Frame(m, point, x, y, angle, lengths, added, turns)
