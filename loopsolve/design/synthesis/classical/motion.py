"""``synthesize --method burmester``: three to five poses, candidates ranked by a stated rule, the user's model.

The candidates and their screening and score are :mod:`loopsolve.design.synthesis.classical.burmester_search`'s (the rule is
:data:`loopsolve.design.synthesis.classical.burmester_search.RULE`, also in the report's ``ranking``). Each candidate that
passes the screening is, best score first, moved through the poses by the tracker
(:func:`loopsolve.design.synthesis.classical.burmester.candidate_four_bar`), written into the user's model
(:func:`loopsolve.design.synthesis.classical.transplant.transplant`) and certified there by the general method's
certificate (with ``crank`` and ``transmission``). Five poses: every pair of Ball–Burmester
dyads is tried (both ways; the better one is listed). Three or four: up to ``_TRY`` candidates
are tried, and the search stops once ``_KEEP`` are certified. The best certified candidate is
the design (``-o``); the report lists every candidate tried with its score, rank and defects.
"""

from __future__ import annotations

import math

import numpy as np

from ....errors import ModelError, SolveError
from ....model.units import Kind

__all__ = ["burmester_synthesize"]

_TRY = 40
_KEEP = 5


def burmester_synthesize(mech, *, targets, motion, link, crank: bool = False, transmission=None):
    """Burmester motion generation on ``mech`` (see the module docstring); a ``ClassicSynthesis``."""
    from .burmester_search import RULE, candidate_dyads, screen
    from .transplant import fourbar_layout
    from ..design_model import ClassicSynthesis
    from ..targets import read_table

    if motion is None or link is None:
        raise ModelError("--method burmester is for motion generation (--motion POINT --link VAR)")
    lay = fourbar_layout(mech, "burmester")
    if motion not in [p.name for p in mech.points]:
        raise ModelError(f"--motion {motion!r}: not a point of the model (points: "
                         f"{', '.join(p.name for p in mech.points) or 'none'})")
    names = [v.name for v in mech.variables]
    if link not in names:
        raise ModelError(f"--link {link!r}: not a variable of the model (variables: {', '.join(names)})")
    if link != lay.variables["coupler"]:
        raise ModelError(f"--link {link!r}: Burmester theory guides the coupler; the coupler's angle of "
                         f"{mech.name!r} is {lay.variables['coupler']!r}")
    if lay.variables["input"] not in mech.inputs:
        raise ModelError(f"--method burmester: the input link's angle {lay.variables['input']!r} is not the input of "
                         "the model; use the general method")
    poses = read_table(targets, ("x", "y", "angle"), what="poses")
    n = len(poses)
    if not 3 <= n <= 5:
        raise ModelError(f"{'too few' if n < 3 else 'too many'} poses for Burmester: {n} (three, four or five: five "
                         "give a finite set of four-bars, three or four a choice made by the ranking rule)")
    deg = mech.units.angle == "deg"
    pdeg = poses.copy()
    if not deg:
        pdeg[:, 2] = np.degrees(pdeg[:, 2])
    dyads = candidate_dyads(pdeg)
    scr = screen(pdeg, dyads, crank=crank, transmission=transmission)
    M = len(scr.pairs)
    if n == 5:
        chosen = list(range(M))
    else:
        ok = np.flatnonzero(scr.feasible)
        chosen = list(ok[np.argsort(scr.score[ok], kind="stable")][:_TRY])
    cache: dict = {}
    tried = []
    certified = 0
    for m in chosen:
        entry = _try(mech, lay, pdeg, poses, dyads, scr, m, motion, link, crank, transmission, cache)
        if entry is None:
            continue
        tried.append(entry)
        certified += entry["certified"]
        if n < 5 and certified >= _KEEP:
            break
    if n == 5:  # one per pair of dyads: the better way to drive it
        best = {}
        for e in tried:
            key = tuple(sorted(e["dyads"]))
            if key not in best or _order(e) < _order(best[key]):
                best[key] = e
        tried = list(best.values())
    tried.sort(key=_order)
    rank = 0
    for e in tried:
        e["rank"] = None
        if e["certified"]:
            rank += 1
            e["rank"] = rank
    L = float(max(math.dist(a[:2], b[:2]) for a in poses for b in poses))
    reasons = {}
    for w in scr.why:
        if w:
            reasons[w] = reasons.get(w, 0) + 1
    ranking = {"rule": RULE, "pairs": M, "passed_screening": int(np.count_nonzero(scr.feasible)),
               "screening_defects": reasons, "tried": len(tried), "certified": rank}
    report = {"task": "motion", "method": "burmester", "ranking": ranking,
              "candidates": [{k: v for k, v in e.items() if not k.startswith("_")} for e in tried]}
    if n == 5:
        report["dyads"] = [{"center": list(d.center), "circle": list(d.circle), "radius": d.radius} for d in dyads]
    usable = [e for e in tried if e["certified"]]
    if not usable:
        from ..certificate import flags, sort_defects

        kinds = sort_defects({d["kind"] for e in tried for d in e["defects"]} or set(reasons) or {"assembly"})
        report.update({"objective": None, "parameters": None, "mode": None, "direction": None, "targets": None,
                       "fit": None, "certificate": {**flags(kinds), "defects": kinds}})
        what = (f"{len(tried)} four-bar(s) tried, none free of defects ({', '.join(kinds)})" if tried else
                f"no four-bar of the {M} pairs of dyads passes the screening ({', '.join(kinds)})")
        held = next((d["message"] for e in tried for d in e["defects"] if d["kind"] == "model"), None)
        if held is not None:
            n_ok = sum(1 for e in tried if [d["kind"] for d in e["defects"]] == ["model"])
            what = f"{n_ok} four-bar(s) move through the poses but {held.split(': ', 1)[-1]}"
        advice = "" if held is not None else " — try the general method"
        err = SolveError(f"Burmester: {len(dyads)} dyads, {what}; the report lists them{advice}")
        err.report = report
        raise err
    best = usable[0]
    report.update(_motion_fields(best["_design"], best["_Z"], lay, poses, motion, link, best["_cert"]))
    report["model_changes"] = {"offsets": best["_offsets"]}
    report["scale"] = L
    return ClassicSynthesis(best["_design"], report, best["_candidate"])


def _order(e):
    score = e["score"] if e["score"] is not None else math.inf
    return (not e["certified"], len(e["defects"]), score)


def _conv(mech, deg_value):
    """An angle in degrees in the model's angle unit."""
    return float(deg_value) if mech.units.angle == "deg" else math.radians(float(deg_value))


def _try(mech, lay, pdeg, poses, dyads, scr, m, motion, link, crank, transmission, cache):
    """One candidate: the tracker on the classical four-bar, then the user's model and its certificate."""
    from .burmester import candidate_four_bar
    from ..certificate import certify, flags, sort_defects
    from .transplant import transplant

    i, j = (int(v) for v in scr.pairs[m])
    try:
        cand = candidate_four_bar((i, j), dyads[i], dyads[j], pdeg, f"{mech.name} (Burmester)", mech.units.length)
    except ModelError:
        return None
    da, db = dyads[i], dyads[j]
    score = float(scr.raw[m]) if math.isfinite(scr.raw[m]) else None  # the rule's score (screening aside)
    entry = {"rank": None, "certified": False, "score": score, "size": float(scr.size[m]),
             "worst_transmission": float(scr.worst[m]), "transmission": [float(v) for v in scr.mu[m]],
             "grashof": cand.grashof.value, "turns_fully": bool(scr.crank[m]),
             "lengths": [float(v) for v in cand.lengths], "dyads": [i, j],
             "pivots": {"O2": list(da.center), "O4": list(db.center)},
             "pins": {"A": [float(v) for v in da.pin(pdeg[0])], "B": [float(v) for v in db.pin(pdeg[0])]},
             "inputs": [_conv(mech, v) for v in cand.inputs], "direction": cand.direction,
             "pose_errors": [e if math.isfinite(e) else None for e in cand.pose_errors],
             "mode": None, "parameters": None, "defects": [], "certificate": None}
    defects = [{"kind": d.kind, "message": d.message, "input": None if d.input is None else _conv(mech, d.input)}
               for d in cand.defects]
    if defects:
        kinds = sort_defects({d["kind"] for d in defects})
        entry.update(defects=defects, certificate={**flags(kinds), "defects": kinds})
        return entry
    joints, known = [], []
    for pose in pdeg:
        joints.append({"O2": np.array(da.center), "A": da.pin(pose), "B": db.pin(pose), "O4": np.array(db.center),
                       "P": np.array(pose[:2])})
        known.append({link: math.radians(pose[2])})
    try:
        tr = transplant(mech, lay, joints, known, point=motion, what="burmester", cache=cache)
    except ModelError as exc:
        entry.update(defects=[{"kind": "model", "message": str(exc), "input": None}],
                     certificate={**flags([]), "defects": ["model"]})
        return entry
    ck = tr.mechanism.compile()
    ix = ck.index(lay.variables["input"])
    Z = tr.Z.copy()
    # the input values in the order of the motion: each step the way the crank turns (the tracker's)
    steps = [((cand.direction * (b - a)) % 360.0) * cand.direction for a, b in zip(cand.inputs, cand.inputs[1:])]
    u = Z[ix]
    first = math.remainder(u[1] - u[0], 2 * math.pi)
    sigma = 1.0 if abs(math.remainder(first - math.radians(steps[0]), 2 * math.pi)) < 1e-6 else -1.0
    x = u[0] + sigma * np.radians(np.r_[0.0, np.cumsum(steps)])
    if np.max(np.abs(np.remainder(x - u + math.pi, 2 * math.pi) - math.pi)) > 1e-6:
        entry.update(defects=[{"kind": "model", "message": "the model's input does not follow the crank",
                               "input": None}], certificate={**flags([]), "defects": ["model"]})
        return entry
    Z[ix] = x
    cert = certify(tr.mechanism, x, poses=Z, crank=crank, transmission=transmission, point=motion,
                   targets=poses[:, :2])
    cert["grashof"] = cand.grashof.value
    entry.update(mode=ck.signature(Z[:, 0]), parameters=tr.parameters, certificate=cert,
                 defects=[{"kind": k, "message": "; ".join(cert["notes"]), "input": None} for k in cert["defects"]],
                 certified=not cert["defects"], _design=tr.mechanism, _Z=Z, _cert=cert, _offsets=tr.offsets,
                 _candidate=cand)
    return entry


def _motion_fields(M, Z, lay, poses, motion, link, cert) -> dict:
    """objective, parameters, mode, direction, targets, certificate, fit of the design ``M`` at positions ``Z``."""
    from ..report import fit_block, targets_scale, wrap_half

    ck = M.compile()
    il, ix = ck.index(link), ck.index(lay.variables["input"])
    deg = M.units.angle == "deg"
    period = 360.0 if deg else 2 * math.pi
    L = float(max(math.dist(a[:2], b[:2]) for a in poses for b in poses)) or 1.0
    entries = []
    total = 0.0
    for c, (x, y, a) in enumerate(poses):
        z = Z[:, c]
        P = ck.point_values(0, z)[ck.points.index(motion)]
        ang = math.degrees(z[il]) if deg else float(z[il])
        da = float(wrap_half(ang - a, period))
        dx, dy = float(P[0] - x), float(P[1] - y)
        e = math.hypot(math.hypot(dx, dy), L * (math.radians(da) if deg else da))
        total += e * e
        xin = float(z[ix])
        entries.append({"input": math.degrees(xin) if deg and ck.kinds[ix] is Kind.ANGLE else xin,
                        "target": [float(x), float(y), float(a)], "value": [float(P[0]), float(P[1]), float(a) + da],
                        "error": e, "dx": dx, "dy": dy, "dangle": da})
    xs = Z[ix]
    params = {p.name: (math.degrees(p.value) if p.kind is Kind.ANGLE and deg else p.value) for p in M.parameters}
    return {"objective": total, "parameters": params, "mode": ck.signature(Z[:, 0]),
            "direction": 1 if xs[-1] >= xs[0] else -1, "targets": entries,
            "certificate": {k: v for k, v in cert.items()},
            "fit": fit_block([t["error"] for t in entries], targets_scale("motion", poses))}
