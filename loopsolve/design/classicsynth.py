"""The classical methods behind ``loopsolve synthesize ... --method freudenstein|burmester``.

Function generation (``--function OUT``, targets CSV ``input,output`` in the model's angle unit)
by Freudenstein's equation and motion generation (``--motion P --link VAR``, targets CSV
``x,y,angle``) by Burmester theory, on four-bar models. The model file names the task's
variables and point (they are checked: a misspelt ``--link`` is an error, not a guess); the
design is the classical method's own four-bar (:mod:`loopsolve.design.freudenstein`,
:mod:`loopsolve.design.burmester`), written as a model file by ``-o``. The report follows the
synthesis contract (task, objective, parameters, mode, direction, targets, certificate) and adds
``method`` and, for Burmester, every candidate with its defects.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import ModelError, SolveError
from .targets import csv_records, read_text_file

__all__ = ["read_table", "ClassicSynthesis", "classic_synthesize", "METHODS"]

METHODS = ("freudenstein", "burmester")


def read_table(source, columns: tuple[str, ...], *, what: str = "targets") -> np.ndarray:
    """Rows of the named numeric ``columns`` from a CSV file (or text) with a header line.

    Errors name the file, the line and the column (:class:`ModelError`).

    Examples
    --------
    >>> from loopsolve.design.classicsynth import read_table
    >>> read_table("x,y,angle\\n1,2,30\\n3,4,45\\n", ("x", "y", "angle")).tolist()
    [[1.0, 2.0, 30.0], [3.0, 4.0, 45.0]]
    """
    if not isinstance(source, (str, Path)):  # rows of numbers already (an array or a list of rows)
        try:
            arr = np.array(source, dtype=float)
        except (TypeError, ValueError):
            raise ModelError(f"{what}: expected a file, CSV text or rows of {len(columns)} numbers "
                             f"({','.join(columns)})") from None
        if arr.ndim != 2 or arr.shape[1] != len(columns) or len(arr) == 0:
            raise ModelError(f"{what}: expected rows of {len(columns)} numbers ({','.join(columns)}), got shape "
                             f"{arr.shape}")
        if not np.isfinite(arr).all():
            raise ModelError(f"{what}: every value must be a finite number")
        return arr
    if isinstance(source, Path) or (isinstance(source, str) and "\n" not in source and "," not in source):
        where = str(source)
        text = read_text_file(source, what=what)
    else:
        where, text = f"<{what}>", str(source)
    rows = [(i, r) for i, r in csv_records(text, where) if r and any(c.strip() for c in r)]
    rows = [(i, r) for i, r in rows if not r[0].lstrip().startswith("#")]
    if not rows:
        raise ModelError(f"{where}: empty {what} file; expected a header line {','.join(columns)} and rows")
    line, header = rows[0]
    names = [h.strip().lower() for h in header]
    missing = [c for c in columns if c not in names]
    if missing:
        raise ModelError(f"{where}, line {line}: the header {','.join(h.strip() for h in header)!r} lacks the "
                         f"column(s) {', '.join(missing)}; expected {','.join(columns)}")
    idx = [names.index(c) for c in columns]
    out = []
    for line, r in rows[1:]:
        if len(r) != len(header):
            raise ModelError(f"{where}, line {line}: {len(r)} fields, the header has {len(header)}")
        vals = []
        for c, j in zip(columns, idx):
            try:
                v = float(r[j])
            except ValueError:
                raise ModelError(f"{where}, line {line}, column {c}: {r[j].strip()!r} is not a number") from None
            if not math.isfinite(v):
                raise ModelError(f"{where}, line {line}, column {c}: {r[j].strip()!r} is not a finite number")
            vals.append(v)
        out.append(vals)
    if not out:
        raise ModelError(f"{where}: no {what} rows after the header")
    return np.array(out, dtype=float)


def _where(source) -> str:
    return str(source) if isinstance(source, (str, Path)) and "\n" not in str(source) else "targets"


def _check_fourbar(mech, method: str) -> None:
    if len(mech.loops) != 1 or len(mech.variables) != 3 or len(mech.inputs) != 1:
        raise ModelError(f"--method {method} is for four-bar models (one loop, one input, two unknowns); "
                         f"{mech.name!r} has {len(mech.loops)} loop(s) and {len(mech.variables)} variables: use the "
                         "general method")


@dataclass(frozen=True)
class ClassicSynthesis:
    """A classical synthesis run: ``mechanism`` (the chosen design), ``report`` (JSON-ready), ``design``."""

    mechanism: object
    report: dict
    design: object

    @property
    def objective(self) -> float:
        return self.report["objective"]

    def to_toml(self) -> str:
        from ..model.modelfile import dumps

        return dumps(self.mechanism)


def _polish_freudenstein(res: ClassicSynthesis, a, b, rng, want, deg: bool) -> ClassicSynthesis:
    """The general method's local polish of a least-squares design (angles ``a``, ``b`` in degrees)."""
    import copy

    from ..model.modelfile import dumps, loads
    from .structerr import structural_error
    from .synthesis import define
    from .synthrun import design_model, polish_design

    rep = res.report
    mech = res.mechanism
    spec = copy.deepcopy(mech.spec)
    g = spec["variables"]["theta4"]["guess"]  # the tracked output starts within half a turn of the target
    spec["variables"]["theta4"]["guess"] = g + 360.0 * round((b[0] - g) / 360.0)
    mech = loads(dumps(spec), source=mech.source or mech.name)
    p0 = rep["parameters"]
    vary = {n: (0.2 * p0[n], 5.0 * p0[n]) for n in ("r2", "r3", "r4")}
    info = {"method": "general (loopsolve.design.synthrun.polish_design)", "varied": sorted(vary),
            "objective_before": rep["objective"], "objective": None, "used": False}
    out = res
    try:
        problem = define(mech, function="theta4", targets={"input": a, "output": b}, vary=vary, mode=None)
        p, cert = polish_design(problem, [p0[n] for n in problem.names], hmax=math.radians(0.1))
    except (ModelError, SolveError) as exc:
        p, cert = {"objective": math.inf}, {"defects": ["assembly"], "notes": [str(exc)]}
    f = p.get("objective", math.inf)
    info.update({"objective": f if math.isfinite(f) else None, "certificate": cert})
    if math.isfinite(f) and not cert.get("defects") and f < rep["objective"]:
        new = design_model(problem, p["values"], p["inputs"], p["Z"])
        se = structural_error(new, "theta4", float(a[0]), targets=(a, b), input_range=rng, desired=want)
        old_reach = rep["structural_error"]["reached"]
        if se["reached"] is not None and se["reached"][0] <= old_reach[0] + 1e-9 \
                and se["reached"][1] >= old_reach[1] - 1e-9:
            errs = []
            for x, y in zip(a, b):
                out_ = new.solve(float(x), mode=rep["mode"])["theta4"]
                errs.append(math.radians((out_ - y + 180) % 360 - 180))
            if not deg:
                se = {k: ([math.radians(x) for x in v] if isinstance(v, list) else
                          math.radians(v) if k in ("max", "at", "signed") and v is not None else v)
                      for k, v in se.items()}
            from ..kinematics.classic import grashof

            pars = _parameters(new)
            cls = grashof(*(abs(pars[n]) for n in ("r1", "r2", "r3", "r4"))).value
            rep = dict(rep, objective=float(sum(e * e for e in errs)), parameters=pars,
                       targets=[{"input": t["input"], "error": e} for t, e in zip(rep["targets"], errs)],
                       structural_error=se, certificate=dict(rep["certificate"], **{
                           k: cert[k] for k in ("assembles", "one_circuit", "order", "defects") if k in cert}, grashof=cls))
            info["used"] = True
            out = ClassicSynthesis(new, rep, res.design)
        else:
            info["note"] = "the polished design reaches less of the input range: kept the least-squares design"
    out.report["polish"] = info
    return out


def _parameters(mech) -> dict:
    return {p.name: (math.degrees(p.value) if p.kind.name == "ANGLE" else p.value) for p in mech.parameters}


def classic_synthesize(mech, *, method: str, targets, function: str | None = None, motion: str | None = None,
                       link: str | None = None, fit: str | None = None, input_range=None,
                       desired=None, polish: bool = True, max_targets: int | None = None) -> ClassicSynthesis:
    """Run Freudenstein (``function=``) or Burmester (``motion=``, ``link=``) on a four-bar model.

    Raises
    ------
    ModelError
        ``input_range`` (function generation: the intended input range, model units; default the
        targets' span) is checked (a limit inside it is a ``range`` defect) and the report's
        ``structural_error`` covers it (against ``desired(x)``, model units, when given; else the
        PCHIP through the targets).
        ``polish``: a certified least-squares Freudenstein design (more than three targets) is
        polished by the general method (:func:`loopsolve.design.synthrun.polish_design` on r2, r3, r4,
        the ground r1 fixed) and replaced when the polished design is certified, better, and
        reaches as much of the input range; the report's ``polish`` says what happened.

        Not a four-bar, an unknown ``function``/``link`` variable or ``motion`` point, a malformed
        targets file, too few (or too many: more than ``max_targets``, default 1000, for
        Freudenstein) targets for the method, two targets at one input angle, a repeated pose.
    SolveError
        No candidate is free of defects (the report is on ``.report`` of the error's ``args``).

    Examples
    --------
    >>> from loopsolve.design.classicsynth import classic_synthesize
    >>> mech = ls.fourbar(60, 25, 70, 45)
    >>> r = classic_synthesize(mech, method="freudenstein", function="theta4",
    ...                        targets="input,output\\n49.019,153.441\\n75,201.633\\n100.981,222.57\\n")
    >>> r.report["method"], r.report["certificate"]["defects"]
    ('freudenstein', [])
    """
    if method not in METHODS:
        raise ModelError(f"--method {method!r}: expected one of {', '.join(METHODS)}")
    _check_fourbar(mech, method)
    names = [v.name for v in mech.variables]
    if method == "freudenstein":
        if function is None:
            raise ModelError("--method freudenstein is for function generation (--function OUT)")
        if function not in names or function in mech.inputs:
            raise ModelError(f"--function {function!r}: not an unknown of the model (unknowns: "
                             f"{', '.join(n for n in names if n not in mech.inputs)})")
        rows = read_table(targets, ("input", "output"))
        from .synthlimits import MAX_TARGETS, check_target_count

        check_target_count(len(rows), _where(targets), MAX_TARGETS if max_targets is None else max_targets)
        if len(rows) < 3:
            raise ModelError(f"too few targets for Freudenstein: {len(rows)} (three are met exactly, more by least "
                             "squares)")
        from .freudenstein import freudenstein_points

        deg = mech.units.angle == "deg"
        conv = (lambda v: v) if deg else np.degrees
        rng = None if input_range is None else tuple(float(conv(float(v))) for v in input_range)
        d = freudenstein_points(conv(rows[:, 0]), conv(rows[:, 1]), fit=fit or ("exact" if len(rows) == 3 else
                                                                                   "least-squares"),
                                length_unit=mech.units.length, name=f"{mech.name} (Freudenstein)", input_range=rng)
        errs = []
        for a, b in rows:
            out = d.mechanism.solve(float(conv(a)), mode=d.mode)["theta4"] if d.certified else math.nan
            errs.append(math.radians((out - conv(b) + 180) % 360 - 180) if d.certified else math.nan)
        objective = float(np.nansum(np.square(errs))) if d.certified else math.nan
        cert = {"assembles": not any(x.kind == "assembly" for x in d.defects),
                "one_circuit": not any(x.kind in ("circuit", "branch") for x in d.defects),
                "order": not any(x.kind == "order" for x in d.defects), "grashof": d.grashof.value,
                "defects": sorted({x.kind for x in d.defects})}
        report = {"task": "function", "method": "freudenstein", "objective": objective,
                  "parameters": _parameters(d.mechanism), "K": list(d.K), "mode": d.mode, "direction": 1,
                  "targets": [{"input": float(a), "error": e} for (a, _), e in zip(rows, errs)],
                  "certificate": cert, "design": d.to_dict()}
        from .structerr import structural_error

        # the design model is in degrees: the error in degrees, converted to the model's angle unit
        want = None
        if desired is not None:
            def want(x):  # the design model is in degrees; desired takes and gives model units
                return conv(np.asarray(desired(x if deg else np.radians(x)), dtype=float))
        se = structural_error(d.mechanism, "theta4", float(conv(rows[0, 0])), targets=(conv(rows[:, 0]),
                              conv(rows[:, 1])), input_range=rng, desired=want)
        if not deg:
            se = {k: ([math.radians(x) for x in v] if isinstance(v, list) else
                      math.radians(v) if k in ("max", "at", "signed") and v is not None else v) for k, v in se.items()}
        report["structural_error"] = se
        result = ClassicSynthesis(d.mechanism, report, d)
        if polish and d.certified and len(rows) > 3:
            result = _polish_freudenstein(result, conv(rows[:, 0]), conv(rows[:, 1]), rng, want, deg)
        return result
    if motion is None or link is None:
        raise ModelError("--method burmester is for motion generation (--motion POINT --link VAR)")
    if motion not in [p.name for p in mech.points]:
        raise ModelError(f"--motion {motion!r}: not a point of the model (points: "
                         f"{', '.join(p.name for p in mech.points) or 'none'})")
    if link not in names:
        raise ModelError(f"--link {link!r}: not a variable of the model (variables: {', '.join(names)})")
    poses = read_table(targets, ("x", "y", "angle"), what="poses")
    if len(poses) != 5:
        raise ModelError(f"{'too few' if len(poses) < 5 else 'too many'} poses for Burmester: {len(poses)} (five "
                         "give a finite set of four-bars; four give the centre-point and circle-point curves: "
                         "ls.burmester_curves)")
    if mech.units.angle != "deg":
        poses = poses.copy()
        poses[:, 2] = np.degrees(poses[:, 2])
    from .burmester import burmester

    res = burmester(poses, length_unit=mech.units.length, name=f"{mech.name} (Burmester)")
    L = max(math.dist(a[:2], b[:2]) for a in poses for b in poses)
    report = {"task": "motion", "method": "burmester", "candidates": [c.to_dict() for c in res.candidates],
              "dyads": res.to_dict()["dyads"]}
    usable = res.usable
    if not usable:
        report.update({"objective": None, "certificate": {"defects": sorted({d.kind for c in res.candidates
                                                                             for d in c.defects})}})
        err = SolveError(f"Burmester: {len(res.dyads)} real dyads, {len(res.candidates)} four-bars, none free of "
                         "defects (circuit, branch or order); the report lists them — try the general method")
        err.report = report
        raise err
    best = usable[0]
    errs = [float(e) for e in best.pose_errors]
    report.update({"objective": float(sum(e * e for e in errs)), "parameters": _parameters(best.mechanism),
                   "mode": best.mode, "direction": best.direction,
                   "targets": [{"input": x, "error": e} for x, e in zip(best.inputs, errs)],
                   "certificate": best.certificate, "scale": L})
    return ClassicSynthesis(best.mechanism, report, res)
