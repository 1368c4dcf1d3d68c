"""The classical methods behind ``loopsolve synthesize ... --method freudenstein|burmester``.

Function generation (``--function OUT``, targets CSV ``input,output`` in the model's units)
by Freudenstein's equation and motion generation (``--motion P --link VAR``, targets CSV
``x,y,angle``, three to five poses) by Burmester theory (:mod:`loopsolve.design.synthesis.classical.motion`),
on four-bar models. The model names the task's variables and point (they are checked: a misspelt
``--link`` is an error, not a guess; ``--function`` must be the output link's angle, ``--link``
the coupler's). The classical design is computed in the model's own frame and angle references
and then written into the user's model (:func:`loopsolve.design.synthesis.classical.transplant.transplant`: the same
names, points, vectors and loops; the parameter values, guesses and, where no parameter can
give a link its direction, the link's ``offset`` changed), which is also what the certificate
(:func:`loopsolve.design.synthesis.certificate.certify`, the general method's) is computed on. The report
follows the synthesis contract (docs/reference/results.md, "Synthesis report") and adds ``method``, ``fit``, and the
method's own numbers (``K`` and ``design``; Burmester's ``ranking`` and ``candidates``).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ....errors import ModelError, SolveError
from ..design_model import ClassicSynthesis
from ..targets import read_table
from ....model.units import Kind

__all__ = ["classic_synthesize", "METHODS", "parse_transmission"]

METHODS = ("freudenstein", "burmester")


def _where(source) -> str:
    return str(source) if isinstance(source, (str, Path)) and "\n" not in str(source) else "targets"


def parse_transmission(transmission):
    """``(lo, hi)`` degrees from ``"LO:HI"`` or a pair (None stays None)."""
    if transmission is None:
        return None
    if isinstance(transmission, str):
        try:
            transmission = tuple(float(v) for v in transmission.split(":"))
        except ValueError:
            raise ModelError(f"--transmission {transmission!r}: expected LO:HI in degrees") from None
    t = tuple(float(v) for v in transmission)
    if len(t) != 2 or not (0 <= t[0] < t[1] <= 180):
        raise ModelError(f"--transmission {transmission}: expected LO:HI (degrees, 0 <= LO < HI <= 180)")
    return t


def angle_period(mech) -> float:
    """One turn in the model's angle unit."""
    return 360.0 if mech.units.angle == "deg" else 2 * math.pi


def to_model(mech, kind, value: float) -> float:
    """An internal value in the model's units (radians to degrees in a degree model)."""
    return math.degrees(value) if kind is Kind.ANGLE and mech.units.angle == "deg" else float(value)


def to_internal(mech, kind, value: float) -> float:
    return math.radians(value) if kind is Kind.ANGLE and mech.units.angle == "deg" else float(value)


def _references(mech, lay):
    """The model's angle references (radians): the frame's direction O2→O4 γ, the input and output
    links' directions at their variables' zero relative to γ, and the frame's length."""
    from ....kinematics.solve import initial_z

    ck = mech.compile()
    z = initial_z(ck, warn=False)

    def direction(role, zz, frm, to):
        L, th = ck.vector_values(0, zz)[ck.vectors.index(lay.vectors[role])]
        s, tail, head = lay.ends[role]
        th = th + (math.pi if s * L < 0 else 0.0)  # head - tail
        return th if (tail, head) == (frm, to) else th + math.pi

    gamma = direction("ground", z, "O2", "O4")
    out = []
    for role, frm, to in (("input", "O2", "A"), ("output", "O4", "B")):
        i = ck.index(lay.variables[role])
        z0, z1 = z.copy(), z.copy()
        z0[i], z1[i] = 0.0, 0.5
        g0, g1 = direction(role, z0, frm, to), direction(role, z1, frm, to)
        if abs(math.remainder(g1 - g0 - 0.5, 2 * math.pi)) > 1e-9:
            raise ModelError(f"--method freudenstein: the {role} link's direction in {mech.name!r} is not its "
                             f"variable {lay.variables[role]} plus a constant; use the general method")
        out.append(math.remainder(g0 - gamma, 2 * math.pi))
    ground = abs(float(ck.vector_values(0, z)[ck.vectors.index(lay.vectors["ground"])][0]))
    return gamma, out[0], out[1], ground


def classic_synthesize(mech, *, method: str, targets, function: str | None = None, motion: str | None = None,
                       link: str | None = None, fit: str | None = None, input_range=None, desired=None,
                       polish: bool = True, crank: bool = False, transmission=None,
                       max_targets: int | None = None) -> ClassicSynthesis:
    """Run Freudenstein (``function=``) or Burmester (``motion=``, ``link=``) on a four-bar model.

    The design is written into ``mech`` itself (its names kept; see the module docstring); the
    report's certificate is the general method's, computed on that model, with ``crank`` (the
    input turns fully) and ``transmission`` (degrees) as requirements.

    Raises
    ------
    ModelError
        ``input_range`` (function generation: the intended input range, model units; default the
        targets' span) is checked (a limit inside it is a ``range`` defect) and the report's
        ``structural_error`` covers it (against ``desired(x)``, model units, when given; else the
        PCHIP through the targets).
        ``polish``: a certified least-squares Freudenstein design (more than three targets) is
        polished by the general method (:func:`loopsolve.design.synthesis.design_model.polish_design` on the
        model's input, coupler and output lengths, the ground fixed) and replaced when the polished
        design is certified, better, and reaches as much of the input range; the report's
        ``polish`` says what happened.

        Not a four-bar, an unknown ``function``/``link`` variable or ``motion`` point, a
        ``function`` that is not the output link's angle or a ``link`` that is not the coupler's,
        a malformed targets file, too few (or too many: more than ``max_targets``, default 1000,
        for Freudenstein) targets for the method, two targets at one input angle, a repeated
        pose, a model that cannot hold the design (its frame or coupler point not placed by
        parameters).
    SolveError
        No candidate is free of defects (the report is on ``.report`` of the error).

    Examples
    --------
    >>> from loopsolve.design.synthesis.classical.run import classic_synthesize
    >>> mech = ls.fourbar(60, 25, 70, 45)
    >>> r = classic_synthesize(mech, method="freudenstein", function="theta4",
    ...                        targets="input,output\\n49.019,153.441\\n75,201.633\\n100.981,222.57\\n")
    >>> r.report["method"], r.report["certificate"]["defects"], sorted(r.report["parameters"])
    ('freudenstein', [], ['r1', 'r2', 'r3', 'r4'])
    """
    if method not in METHODS:
        raise ModelError(f"--method {method!r}: expected one of {', '.join(METHODS)}")
    transmission = parse_transmission(transmission)
    if method == "burmester":
        from .motion import burmester_synthesize

        return burmester_synthesize(mech, targets=targets, motion=motion, link=link, crank=crank,
                                    transmission=transmission)
    if function is None:
        raise ModelError("--method freudenstein is for function generation (--function OUT)")
    from .transplant import fourbar_layout

    lay = fourbar_layout(mech, "freudenstein")
    names = [v.name for v in mech.variables]
    if function not in names or function in mech.inputs:
        raise ModelError(f"--function {function!r}: not an unknown of the model (unknowns: "
                         f"{', '.join(n for n in names if n not in mech.inputs)})")
    if function != lay.variables["output"]:
        raise ModelError(f"--function {function!r}: Freudenstein's equation relates the angles of the input and "
                         f"output links; the output link's angle of {mech.name!r} is {lay.variables['output']!r}")
    if lay.variables["input"] not in mech.inputs:
        raise ModelError(f"--method freudenstein: the input link's angle {lay.variables['input']!r} is not the input "
                         "of the model; use the general method")
    rows = read_table(targets, ("input", "output"))
    from ..limits import MAX_TARGETS, check_target_count

    check_target_count(len(rows), _where(targets), MAX_TARGETS if max_targets is None else max_targets)
    if len(rows) < 3:
        raise ModelError(f"too few targets for Freudenstein: {len(rows)} (three are met exactly, more by least "
                         "squares)")
    return _freudenstein(mech, lay, rows, fit, input_range, desired, polish, crank, transmission)


def _freudenstein(mech, lay, rows, fit, input_range, desired, polish, crank, transmission) -> ClassicSynthesis:
    from .transplant import transplant
    from .freudenstein import fourbar_output, freudenstein_points

    ck = mech.compile()
    in_var, out_var = lay.variables["input"], lay.variables["output"]
    kin, kout = ck.kinds[ck.index(in_var)], ck.kinds[ck.index(out_var)]
    x_int = np.array([to_internal(mech, kin, v) for v in rows[:, 0]])
    y_int = np.array([to_internal(mech, kout, v) for v in rows[:, 1]])
    gamma, s_in, s_out, ground = _references(mech, lay)
    # Freudenstein's angles: measured from the frame line (degrees)
    a = np.degrees(x_int + s_in)
    b = np.degrees(y_int + s_out)
    rng = None if input_range is None else tuple(math.degrees(to_internal(mech, kin, float(v)) + s_in)
                                                for v in input_range)
    try:
        d = freudenstein_points(a, b, fit=fit or ("exact" if len(rows) == 3 else "least-squares"), ground=ground,
                                length_unit=mech.units.length, name=f"{mech.name} (Freudenstein)", input_range=rng)
    except ModelError as exc:
        if abs(s_in) < 1e-12 and abs(s_out) < 1e-12:
            raise
        raise ModelError(f"{exc} (Freudenstein's angles are measured from the ground line of {mech.name!r}: its "
                         f"{in_var} {math.degrees(s_in):+.6g} deg, {out_var} {math.degrees(s_out):+.6g} deg)") from None
    # the design's joints at every target it assembles at, in the model's frame (turned by gamma)
    k1, k2, _ = d.K
    r2s, r4s = ground / k1, ground / k2
    rot = np.array([[math.cos(gamma), -math.sin(gamma)], [math.sin(gamma), math.cos(gamma)]])
    joints, known, at = [], [], []
    for j, t2 in enumerate(np.radians(a)):
        out, ok = fourbar_output(d.K, np.array([t2]), d.root)
        if not ok[0]:
            continue
        o = float(out[0])
        O2, O4 = np.zeros(2), np.array([ground, 0.0])
        A = r2s * np.array([math.cos(t2), math.sin(t2)])
        B = O4 + r4s * np.array([math.cos(o), math.sin(o)])
        joints.append({k: rot @ v for k, v in (("O2", O2), ("A", A), ("B", B), ("O4", O4))})
        # the model's output variable: Freudenstein's angle less the model's reference, near the target
        yv = y_int[j] + math.remainder(o - s_out - y_int[j], 2 * math.pi)
        known.append({in_var: float(x_int[j]), out_var: float(yv)})
        at.append(j)
    if not at:
        raise ModelError("the Freudenstein design cannot be assembled at any target")
    tr = transplant(mech, lay, joints, known, what="freudenstein")
    report = _function_report(tr.mechanism, lay, rows, x_int, tr.Z, at, crank, transmission,
                              [x.kind for x in d.defects], [x.message for x in d.defects], input_range, desired)
    report = {"task": "function", "method": "freudenstein", **report, "K": list(d.K), "design": d.to_dict(),
              "model_changes": {"offsets": tr.offsets}}
    result = ClassicSynthesis(tr.mechanism, report, d)
    if polish and not report["certificate"]["defects"] and len(rows) > 3:
        result = _polish(result, lay, rows, x_int, crank, transmission, input_range, desired)
    return result


def _function_report(M, lay, rows, x_int, Z, at, crank, transmission, extra_defects, extra_notes, input_range,
                     desired) -> dict:
    """The contract's fields of function design ``M`` (the user's model with values) from its positions ``Z``
    ``(nvar, len(at))`` at the targets ``at``: objective, parameters, mode, direction, targets, certificate,
    fit, structural error."""
    from ..certificate import certify, flags, sort_defects
    from ..structural_error import structural_error
    from ..report import fit_block, targets_scale, wrap_half

    ck = M.compile()
    out_var = lay.variables["output"]
    iout = ck.index(out_var)
    kout = ck.kinds[iout]
    period = angle_period(M) if kout is Kind.ANGLE else None
    entries, errs_rad = [], []
    col = dict(zip(at, range(len(at))))
    for j, (x, y) in enumerate(rows):
        if j not in col:
            entries.append({"input": float(x), "target": float(y), "value": None, "error": None})
            errs_rad.append(None)
            continue
        v = to_model(M, kout, float(Z[iout, col[j]]))
        e = float(wrap_half(v - y, period)) if period else v - float(y)
        entries.append({"input": float(x), "target": float(y), "value": float(y) + e, "error": e})
        errs_rad.append(to_internal(M, kout, e))
    objective = None if None in errs_rad else float(sum(e * e for e in errs_rad))
    if len(at) == len(rows):
        cert = certify(M, x_int, poses=Z, crank=crank, transmission=transmission)
    else:
        cert = {"crank": None, "transmission": None, "grashof_margin": None, "defects": ["assembly"],
                "notes": [f"the design cannot be assembled at target {j + 1}" for j in range(len(rows)) if j not in col]}
    defects = sort_defects(set(cert["defects"]) | set(extra_defects))
    info = (M.info(reach=False).get("fourbars") or [{}])[0]
    certificate = {**flags(defects), "crank": False if "crank" in defects else cert.get("crank"),
                   "transmission": cert.get("transmission"), "grashof_margin": cert.get("grashof_margin"),
                   "grashof": info.get("grashof"), "defects": defects,
                   "notes": list(cert.get("notes", [])) + list(extra_notes)}
    x0 = float(rows[at[0], 0])
    yref = rows[:, 1] if period is None else np.unwrap(rows[:, 1], period=period)  # one continuous curve
    se = structural_error(M, out_var, x0, targets=(rows[:, 0], yref), input_range=input_range, desired=desired)
    params = {p.name: to_model(M, p.kind, p.value) for p in M.parameters}
    return {"objective": objective, "parameters": params, "mode": ck.signature(Z[:, 0]),
            "direction": 1 if rows[-1, 0] >= rows[0, 0] else -1, "targets": entries, "certificate": certificate,
            "fit": fit_block([t["error"] for t in entries], targets_scale("function", rows[:, 1:2])),
            "structural_error": se}


def _polish(res: ClassicSynthesis, lay, rows, x_int, crank, transmission, input_range, desired) -> ClassicSynthesis:
    """The general method's local polish of a least-squares design on the model's own link lengths."""
    from ....model import expr as _expr
    from ..problem import define
    from ..design_model import design_model, polish_design

    rep = res.report
    M = res.mechanism
    pnames = {p.name for p in M.parameters}
    vary = {}
    for role in ("input", "coupler", "output"):
        v = M.vector(lay.vectors[role])
        if isinstance(v.length, _expr.Name) and v.length.id in pnames:
            p0 = rep["parameters"][v.length.id]
            vary[v.length.id] = (0.2 * p0, 5.0 * p0)
    info = {"method": "general (loopsolve.design.synthesis.design_model.polish_design)", "varied": sorted(vary),
            "objective_before": rep["objective"], "objective": None, "used": False}
    out = res
    if not vary:
        info["note"] = "no link length of the model is a parameter: nothing to polish"
        rep["polish"] = info
        return res
    try:
        problem = define(M, function=lay.variables["output"], targets={"input": rows[:, 0], "output": rows[:, 1]},
                         vary=vary, mode=None)
        p, cert = polish_design(problem, [rep["parameters"][n] for n in problem.names], hmax=math.radians(0.1))
    except (ModelError, SolveError) as exc:
        p, cert = {"objective": math.inf}, {"defects": ["assembly"], "notes": [str(exc)]}
    f = p.get("objective", math.inf)
    info.update({"objective": f if math.isfinite(f) else None,
                 "certificate": {k: v for k, v in cert.items() if k != "notes"}})
    if math.isfinite(f) and not cert.get("defects") and rep["objective"] is not None and f < rep["objective"]:
        new = design_model(problem, p["values"], p["inputs"], p["Z"])
        nrep = _function_report(new, lay, rows, x_int, p["Z"], list(range(len(rows))), crank, transmission, [], [],
                                input_range, desired)
        old_reach = rep["structural_error"]["reached"]
        reach = nrep["structural_error"]["reached"]
        if nrep["certificate"]["defects"]:
            info["note"] = "the polished design is not certified: kept the least-squares design"
        elif reach is not None and old_reach is not None and reach[0] <= old_reach[0] + 1e-9 \
                and reach[1] >= old_reach[1] - 1e-9:
            info["used"] = True
            out = ClassicSynthesis(new, {**rep, **nrep, "model_changes": rep["model_changes"]}, res.design)
        else:
            info["note"] = "the polished design reaches less of the input range: kept the least-squares design"
    out.report["polish"] = info
    return out
