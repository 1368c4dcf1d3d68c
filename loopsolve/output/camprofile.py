"""A cam's report and its profile: what ``loopsolve cam MODEL NAME`` prints and writes.

:func:`cam_report` gives, over one turn of the cam, the law's displacement, velocity, acceleration and
jerk, the pressure angle and the radius of curvature (the pitch curve's; the profile's for a flat
face) with their extremes, the discontinuities of the acceleration at the segments' joins and any
undercut, in the model's units (see :mod:`loopsolve.model.camgeometry` for the geometry). The JSON is
the contract's ``{"cam", "units", "rows", "extremes", "undercut"}`` with ``defects``,
``discontinuities`` and, for a flat face, ``flat_face`` (the contact's travel along the face, the face
width and the smallest base circle without undercut) added.

:func:`cam_entities` draws the profile for CAD with the layers of ``draw`` (:mod:`loopsolve.output.cad`):
the profile on ``LINKS``, the pitch curve on ``CURVES``, the base and pitch circles on ``GROUND``, the
cam's bore on ``PINS``, the follower at cam angle 0 on ``SLIDERS``; in the cam's own frame (its centre
at the origin, the follower along +y, or the pivot of an oscillating follower on +x).
"""

from __future__ import annotations

import json
import math

import numpy as np

from ..errors import ModelError

__all__ = ["cam_report", "format_cam", "cam_entities", "write_cam_profile", "plot_svaj", "find_cam"]


def find_cam(mech, name: str):
    """The cam ``name`` of ``mech`` (a ModelError listing the cams otherwise)."""
    cams = mech.pairs.cams if mech.pairs is not None else ()
    for c in cams:
        if c.name == name:
            return c
    raise ModelError(f"{mech.source or mech.name}: no cam {name!r}; the cams are "
                     + (", ".join(c.name for c in cams) if cams else "none (declare [cams.NAME])"))


def _rates(mech, cam):
    """The cam's declared speed, acceleration and jerk (rad/s...), or None when its speed is not declared."""
    var = mech.variable(cam.cam)
    if var.speed is None:
        return None
    return var.speed, var.accel or 0.0, var.jerk or 0.0


def cam_report(mech, name: str, *, step=None) -> dict:
    """The cam's report as a JSON-ready dict (see the module notes); ``step`` the row spacing in the
    model's angle unit (default 1 degree)."""
    from ..model.cams import cam_report as analyse, joins, undercut_problem
    from ..model.pairs import evaluator

    cam = find_cam(mech, name)
    values = evaluator(mech)
    deg = mech.units.angle == "deg"
    k = math.pi / 180.0 if deg else 1.0
    h = (1.0 if deg else math.pi / 180.0) if step is None else float(step)
    if not (h > 0 and math.isfinite(h)) or 2 * math.pi / (h * k) > 1e6:
        raise ModelError(f"--step {step!r}: a positive angle step of at most a turn, at least 1e-6 of a turn")
    n = max(int(round(2 * math.pi / (h * k))), 8)
    data = analyse(cam, values, n=n)
    law = data["numbers"].law
    osc = cam.kind == "oscillating"
    s, v, a, j = data["s"], data["v"], data["a"], data["j"]
    rates = _rates(mech, cam)
    if rates is not None:  # per second: chain rule with the cam's speed, acceleration and jerk
        w, al, je = rates
        v, a, j = v * w, a * w**2 + v * al, j * w**3 + 3 * a * w * al + v * je
    disp = (lambda r: math.degrees(r)) if deg else (lambda r: r)
    lu, au = mech.units.length, mech.units.angle
    su = au if osc else lu
    per = "s" if rates is not None else "rad"
    base = "rad" if osc else lu
    units = {"angle": au, "s": su, "v": f"{base}/{per}", "a": f"{base}/{per}^2", "j": f"{base}/{per}^3",
             "pressure_angle": au, "curvature_radius": lu}
    sd = np.degrees(s) if (osc and deg) else s
    rows = []
    for i in range(n):
        rows.append({"angle": _num(disp(data["angle"][i])), "s": _num(sd[i]), "v": _num(v[i]), "a": _num(a[i]),
                     "j": _num(j[i]), "pressure_angle": _num(disp(data["pressure"][i])),
                     "curvature_radius": _num(data["rho"][i])})
    rho = data["rho"]
    finite = rho[np.isfinite(rho)]
    convex = finite[finite > 0]
    report = {
        "cam": cam.name,
        "units": units,
        "rows": rows,
        "extremes": {"pressure_angle": [_num(disp(float(np.min(data["pressure"])))),
                                        _num(disp(float(np.max(data["pressure"]))))],
                     "curvature_radius": [_num(float(finite.min())) if finite.size else None,
                                          _num(float(finite.max())) if finite.size else None]},
        "undercut": bool(np.any(data["undercut"])),
        "min_convex_curvature_radius": _num(float(convex.min())) if convex.size else None,
        "defects": [],
        "discontinuities": [],
        "follower": {"kind": cam.kind, "contact": cam.contact},
    }
    problem = undercut_problem(cam, values)
    if problem is not None:
        report["defects"].append(f"{problem[0]}: {problem[1]}")
    for jn in joins(law):
        if abs(jn["acceleration"]) > 1e-9 * max(1.0, max(abs(x) for x in law.rises)):
            report["discontinuities"].append({"angle": _num(disp(jn["angle"])), "derivative": "acceleration",
                                              "jump": _num(jn["acceleration"])})
    if cam.contact == "flat":
        off = data["face_offset"]
        report["flat_face"] = {"contact_offset": [_num(float(off.min())), _num(float(off.max()))],
                               "face_width": _num(float(off.max() - off.min()))}
        if not osc:
            report["flat_face"]["min_base_radius"] = _num(float(np.max(-(data["s"] + data["a"]))))
    return report


def _num(x):
    x = float(x)
    return None if not math.isfinite(x) else (0.0 if x == 0 else x)


def format_cam(report: dict, fmt: str = "table", *, svaj: bool = False) -> str:
    """The report as JSON, or as a table: the summary, and with ``svaj`` every row."""
    if fmt == "json":
        return json.dumps(report, indent=1) + "\n"
    u = report["units"]
    ex = report["extremes"]
    lines = [f"cam {report['cam']}: {report['follower']['kind']} {report['follower']['contact']} follower",
             f"  pressure angle: {_fmt(ex['pressure_angle'][0])} to {_fmt(ex['pressure_angle'][1])} "
             f"{u['pressure_angle']}",
             f"  radius of curvature: {_fmt(ex['curvature_radius'][0])} to {_fmt(ex['curvature_radius'][1])} "
             f"{u['curvature_radius']} (smallest convex {_fmt(report['min_convex_curvature_radius'])})",
             f"  undercut: {'yes' if report['undercut'] else 'no'}"]
    for d in report["defects"]:
        lines.append(f"  defect: {d}")
    for d in report["discontinuities"]:
        lines.append(f"  the acceleration jumps by {_fmt(d['jump'])} {u['a']} at {_fmt(d['angle'])} {u['angle']} "
                     "(infinite jerk)")
    if "flat_face" in report:
        ff = report["flat_face"]
        lines.append(f"  flat face: contact from {_fmt(ff['contact_offset'][0])} to {_fmt(ff['contact_offset'][1])} "
                     f"{u['curvature_radius']} along the face (width {_fmt(ff['face_width'])})"
                     + (f"; smallest base circle without undercut {_fmt(ff['min_base_radius'])}"
                        if "min_base_radius" in ff else ""))
    if svaj:
        head = ["angle", "s", "v", "a", "j", "pressure_angle", "curvature_radius"]
        titles = [f"{h} [{u[h]}]" for h in head]
        table = [titles] + [[_fmt(r[h]) for h in head] for r in report["rows"]]
        widths = [max(len(row[i]) for row in table) for i in range(len(head))]
        lines.append("")
        lines += ["  ".join(c.rjust(w) for c, w in zip(row, widths)) for row in table]
    return "\n".join(lines) + "\n"


def _fmt(x) -> str:
    return "-" if x is None else f"{x:.6g}"


def cam_entities(mech, name: str, *, samples: int = 720) -> list:
    """The cam's profile as CAD entities (see the module notes), in the model's length unit."""
    from ..model.cams import cam_report as analyse
    from ..model.pairs import evaluator
    from .cad import Entity

    cam = find_cam(mech, name)
    data = analyse(cam, evaluator(mech), n=samples)
    cn = data["numbers"]

    def poly(xy):
        return tuple((float(x), float(y)) for x, y in xy)

    out = [Entity("LINKS", "polyline", poly(data["profile"]), closed=True, name=f"{name} profile")]
    if cam.contact != "flat":
        out.append(Entity("CURVES", "polyline", poly(data["pitch"]), closed=True, name=f"{name} pitch curve"))
    out.append(Entity("GROUND", "circle", ((0.0, 0.0),), size=cn.base, name="base circle"))
    if cn.roller > 0:
        out.append(Entity("GROUND", "circle", ((0.0, 0.0),), size=cn.pitch_base, name="prime circle"))
    bore = 0.12 * cn.base
    out.append(Entity("PINS", "circle", ((0.0, 0.0),), size=bore, name=f"{name} centre"))
    # the follower at cam angle 0 (the start of the law)
    C = data["contact"][0]
    if cam.contact == "roller":
        from ..model.camgeometry import follower_pose

        pitch = follower_pose(cn, np.array([cn.law.start]))[0][0]
        out.append(Entity("SLIDERS", "circle", ((float(pitch[0]), float(pitch[1])),), size=cn.roller,
                          name="roller"))
    elif cam.contact == "flat":
        n = data["normal"][0]
        t = np.array([-n[1], n[0]])
        w = 1.2 * max(abs(x) for x in (report_width(data), cn.base * 0.3))
        out.append(Entity("SLIDERS", "line", ((float(C[0] - w * t[0]), float(C[1] - w * t[1])),
                                              (float(C[0] + w * t[0]), float(C[1] + w * t[1]))), name="face"))
    else:
        out.append(Entity("SLIDERS", "circle", ((float(C[0]), float(C[1])),), size=0.04 * cn.base, name="knife"))
    out.append(Entity("LABELS", "text", ((0.0, -1.15 * cn.base),), size=0.08 * cn.base, text=str(name),
                      name=str(name)))
    return out


def report_width(data) -> float:
    off = data.get("face_offset")
    return float(np.max(np.abs(off))) if off is not None else 0.0


def write_cam_profile(mech, name: str, output) -> list:
    """Write the profile: ``.dxf`` or ``.svg`` (the entities of :func:`cam_entities`), or ``.csv`` (the
    profile's points ``x,y`` and the pitch curve's ``pitch_x,pitch_y`` at every degree of cam angle)."""
    from pathlib import Path

    fmt = Path(output).suffix.lower().lstrip(".")
    if fmt not in ("dxf", "svg", "csv"):
        raise ModelError(f"{output}: a cam profile is written as .dxf, .svg or .csv (got {fmt or 'no extension'!r})")
    if fmt == "csv":
        from ..model.cams import cam_report as analyse
        from ..model.pairs import evaluator

        data = analyse(find_cam(mech, name), evaluator(mech), n=360)
        deg = mech.units.angle == "deg"
        lines = ["angle,x,y,pitch_x,pitch_y"]
        for th, (x, y), (px, py) in zip(data["angle"], data["profile"], data["pitch"]):
            a = math.degrees(th) if deg else th
            lines.append(f"{a:.12g},{x:.12g},{y:.12g},{px:.12g},{py:.12g}")
        from ..model.files import write_text

        write_text(output, "\n".join(lines) + "\n", [mech.source] if mech.source else [])
        return []
    from .cad import write_dxf, write_svg

    ents = cam_entities(mech, name)
    (write_dxf if fmt == "dxf" else write_svg)(ents, output, unit=mech.units.length, title=f"{mech.name}: cam {name}")
    return ents


def plot_svaj(mech, name: str, *, output=None):
    """The SVAJ diagrams and the pressure angle of a cam over one turn (matplotlib figure)."""
    import matplotlib.pyplot as plt

    rep = cam_report(mech, name)
    rows = rep["rows"]
    u = rep["units"]
    ang = [r["angle"] for r in rows]
    keys = [("s", "displacement"), ("v", "velocity"), ("a", "acceleration"), ("j", "jerk"),
            ("pressure_angle", "pressure angle")]
    fig, axes = plt.subplots(len(keys), 1, sharex=True, figsize=(7, 9))
    for ax, (k, title) in zip(axes, keys):
        ax.plot(ang, [np.nan if r[k] is None else r[k] for r in rows], lw=1.2)
        ax.set_ylabel(f"{k} [{u[k]}]")
        ax.set_title(title, fontsize=9, loc="left")
        ax.grid(True, alpha=0.3)
    axes[-1].set_xlabel(f"cam angle [{u['angle']}]")
    fig.suptitle(f"{mech.name}: cam {name}")
    fig.tight_layout()
    if output is not None:
        fig.savefig(output)
    return fig
