"""A synthesized design as a model and its certificate.

A design is the model's varied parameters set to the found values. :func:`design_model` writes
it into the model (its guesses the pose at the first target, so the model opens in the design's
mode), :func:`certify_design` has the tracker certify it, and :func:`polish_design` polishes one
start by least squares and certifies the result. The general method (:mod:`loopsolve.design.synthesis.run`),
the classical ones (:mod:`loopsolve.design.synthesis.classical.run`) and shape synthesis
(:mod:`loopsolve.design.synthesis.shape.run`) all hand their designs to these.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass

import numpy as np

from .problem import evaluate, polish

__all__ = ["clean", "design_model", "certify_design", "polish_design", "ClassicSynthesis"]


def clean(v):
    """A report value as JSON holds it: numpy numbers as Python's, non-finite floats as None."""
    if isinstance(v, (float, np.floating)):
        return float(v) if math.isfinite(v) else None
    if isinstance(v, (np.integer,)):
        return int(v)
    if isinstance(v, dict):
        return {k: clean(x) for k, x in v.items()}
    if isinstance(v, (list, tuple, np.ndarray)):
        return [clean(x) for x in v]
    return v


def design_model(problem, values, inputs, Z):
    """The model with the found parameter values, its guesses the pose at the first target (so its mode)."""
    from ...model.modelfile import loads, dumps
    from ...model.units import Kind

    mech = problem.mech
    spec = copy.deepcopy(mech.spec)
    params = spec.setdefault("parameters", {})
    for n, v in zip(problem.names, values):
        params[n] = float(v)
    ck = problem.ck
    deg = mech.units.angle == "deg"
    variables = spec.get("variables", {})
    if Z is not None:
        for i, name in enumerate(ck.variables):
            if name in variables:
                val = float(Z[i, 0])
                if ck.kinds[i] is Kind.ANGLE and deg:
                    val = math.degrees(val)
                entry = variables[name]
                if isinstance(entry, dict):
                    entry["guess"] = round(val, 12)
                else:
                    variables[name] = {"guess": round(val, 12)}
    return loads(dumps(spec), source=mech.source or "<synthesized>")


def certify_design(problem, values, inputs=None, signs=None, poses=None) -> dict:
    """Certificate of one parameter set (model units) on a problem: see :func:`loopsolve.design.synthesis.certificate.certify`.

    Without ``inputs`` (free timing) or ``poses``, the positions are traced by the batch engine in
    the mode ``signs`` (default: the problem's best mode for the design).
    """
    from .certificate import certify

    values = np.asarray(values, dtype=float)
    b = problem.batch
    P = b.params(values[None])
    if poses is None:
        if inputs is None or signs is None:
            f, mi, di, X = evaluate(problem, values[None])
            signs = problem.modes(P)[mi[0]][:, 0] if signs is None else np.asarray(signs, dtype=float)
            inputs = X[:, 0] if inputs is None else inputs
        with np.errstate(all="ignore"):
            Zt, reached = problem.trace(P, np.asarray(inputs, dtype=float)[:, None],
                                        np.asarray(signs, dtype=float)[:, None], singular_stop=False)
        poses = Zt[:, :, 0] if reached[0] >= problem.T else None
    mech = problem.mech.with_parameters(**{n: float(v) for n, v in zip(problem.names, values)})
    inputs = problem.inputs if inputs is None else np.asarray(inputs, dtype=float)
    if inputs is None:
        return {"assembles": False, "one_circuit": False, "order": False, "crank": None, "transmission": None,
                "grashof_margin": None, "defects": ["assembly"], "notes": ["no motion through the targets found"]}
    return certify(mech, inputs, poses=poses, crank=problem.crank, transmission=problem.transmission,
                   point=problem.point, targets=problem.targets)


def polish_design(problem, values, *, inputs=None, signs=None, hmax=None):
    """Polish one start (model units) and certify it: ``(polished dict, certificate)``.

    ``hmax``: the trace's largest input step (internal units; default the engine's 5°).
    """
    p = polish(problem, values, inputs=inputs, signs=signs, **({} if hmax is None else {"hmax": hmax}))
    if not math.isfinite(p.get("objective", math.inf)):
        return p, {"defects": ["assembly"], "notes": ["the start cannot be traced through the targets"]}
    cert = certify_design(problem, p["values"], p["inputs"], p["signs"], p["Z"])
    return p, cert


@dataclass(frozen=True)
class ClassicSynthesis:
    """A classical synthesis run: ``mechanism`` (the user's model with the chosen design's values),
    ``report`` (JSON-ready), ``design`` (the method's own result)."""

    mechanism: object
    report: dict
    design: object

    @property
    def objective(self) -> float:
        return self.report["objective"]

    def to_toml(self) -> str:
        from ...model.modelfile import dumps

        return dumps(self.mechanism)
