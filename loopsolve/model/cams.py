"""``[cams.NAME]``: a disk cam on a link driving a follower by a motion law over one turn.

::

    [cams.c1]
    cam = "theta2"            # the cam's angle (a variable)
    follower = "s"            # the follower's displacement from its lowest position (a variable)
    kind = "translating"      # or "oscillating" (the displacement is then the arm's angle)
    contact = "roller"        # "knife", "roller" or "flat"
    roller = "8mm"
    base = "40mm"             # base circle of the cam profile (the pitch curve's is base + roller)
    offset = "5mm"            # translating follower's offset from the cam centre
    law = [ { to = 90, rise = "25mm", curve = "cycloidal" }, { to = 150, dwell = true },
            { to = 270, rise = "-25mm", curve = "3-4-5" }, { to = 360, dwell = true } ]

The law's segments are cam angles in the model's angle unit, from ``start`` (default 0) round one
turn; a segment is a ``dwell = true``, a ``rise`` or a ``return`` (a fall) with its ``curve`` (see
:mod:`loopsolve.model.camlaws`). The follower's displacement equals the law at the cam angle: one row of
Φ (:mod:`loopsolve.symbolic.pairs`). An oscillating follower also gives ``pivot`` (the distance from the
cam centre to its pivot), ``arm`` (pivot to roller centre, knife edge) and ``side`` (``"left"`` or
``"right"`` of the line from the cam centre to the pivot). ``center`` (a point, default the origin) and
``axis`` (the translating follower's direction, default 90°) or ``pivot_angle`` (the direction of the
pivot, default 0°) place the cam in the mechanism for drawings and forces.

Instead of ``law``, ``profile = "pitch.csv"`` gives the points of the pitch curve (a CSV file ``x,y`` next
to the model file; see :mod:`loopsolve.model.campitch`): the displacement is then computed from the curve
and ``base`` and ``start`` are not given.

Checked here: the segments cover one turn, the law closes (the rises add up to zero) with continuous
velocity, the geometry exists (offset inside the pitch base circle, an arm that reaches it). Checked
when the mechanism is compiled (:func:`check_cams`): the profile is not undercut.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from . import expr as _expr
from .camgeometry import CamNumbers, analyse
from .camlaws import CURVES, Law, joins
from .units import Kind

__all__ = ["Cam", "CamSegment", "parse", "kind_hints", "names_used", "numbers", "check_cams", "KINDS", "CONTACTS"]

KINDS = ("translating", "oscillating")
CONTACTS = ("knife", "roller", "flat")
_KEYS = {"cam", "follower", "kind", "contact", "roller", "base", "offset", "law", "profile", "start", "center",
         "axis", "pivot", "pivot_angle", "arm", "side"}
_SEG_KEYS = {"to", "rise", "return", "dwell", "curve"}
_EXAMPLE = '{ cam = "theta2", follower = "s", kind = "translating", contact = "roller", ... }'
#: samples of the cycle for the undercut check and the extremes
SAMPLES = 1440


@dataclass(frozen=True, slots=True)
class CamSegment:
    """One segment of a law: its end (an expression in the model's angle unit), its rise (``None``: a
    dwell; a return is a negative rise) and curve."""

    key: str
    end: _expr.Node
    rise: _expr.Node | None
    sign: int
    curve: str | None


@dataclass(frozen=True, slots=True)
class Cam:
    """A disk cam (expressions in model units; see the module notes for the keys)."""

    name: str
    key: str
    cam: str
    follower: str
    kind: str
    contact: str
    roller: object
    base: object
    offset: object
    segments: tuple
    start: object
    center: str | None
    axis: object
    pivot: object
    pivot_angle: object
    arm: object
    side: int
    text: str
    profile: object = None


def _table(spec) -> Mapping:
    val = spec.get("cams", {})
    return val if isinstance(val, Mapping) else {}


def kind_hints(spec):
    for name, d in _table(spec).items():
        if not isinstance(d, Mapping):
            continue
        key = f"cams.{name}"
        if isinstance(d.get("cam"), str):
            yield d["cam"], "angle", f"{key}.cam"
        if isinstance(d.get("follower"), str):
            yield d["follower"], "angle" if d.get("kind") == "oscillating" else "length", f"{key}.follower"


def names_used(spec):
    for name, d in _table(spec).items():
        if not isinstance(d, Mapping):
            continue
        key = f"cams.{name}"
        for k in ("cam", "follower"):
            if isinstance(d.get(k), str):
                yield d[k], key
        vals = [d.get(k) for k in ("roller", "base", "offset", "start", "axis", "pivot", "pivot_angle", "arm")]
        law = d.get("law")
        if isinstance(law, list):
            vals += [seg.get(k) for seg in law if isinstance(seg, Mapping) for k in ("to", "rise", "return")]
        for v in vals:
            if isinstance(v, str):
                try:
                    yield from ((n, key) for n in _expr.names(_expr.parse(v)))
                except Exception:
                    pass


def parse(ctx) -> tuple[Cam, ...]:
    out = []
    for name, raw in ctx.table("cams").items():
        d = ctx.entry("cams", name, raw, _KEYS, _EXAMPLE)
        if d is None:
            continue
        cam = _parse_cam(ctx, str(name), f"cams.{name}", d)
        if cam is not None:
            out.append(cam)
    return tuple(out)


def _choice(ctx, d, key, field, options, default):
    val = d.get(field, default)
    if val not in options:
        ctx.problems.add(f"{key}.{field}", f"{val!r}: expected one of {', '.join(map(repr, options))}")
        return None
    return val


def _parse_cam(ctx, name, key, d) -> Cam | None:
    p = ctx.problems
    n_before = len(p.items)
    for k in ("cam", "follower"):
        if k not in d:
            p.add(key, f"missing key {k!r}; a cam is {_EXAMPLE}")
            return None
    if ("law" in d) == ("profile" in d):
        p.add(key, "give exactly one of `law` (segments of the cam angle) and `profile` (a CSV file x,y of the "
              "pitch curve)" + (", not both" if "law" in d else ""))
        return None
    if "profile" in d:
        for k in ("base", "start"):
            if k in d:
                what = "the base circle follows from the curve" if k == "base" else "angle 0 is the curve's frame"
                p.add(f"{key}.{k}", f"a cam declared by its `profile` has no `{k}` ({what})")
                return None
    elif "base" not in d:
        p.add(key, f"missing key 'base'; a cam is {_EXAMPLE}")
        return None
    kind = _choice(ctx, d, key, "kind", KINDS, "translating")
    contact = _choice(ctx, d, key, "contact", CONTACTS, "roller")
    if kind is None or contact is None:
        return None
    cam = ctx.variable(d["cam"], f"{key}.cam", Kind.ANGLE)
    follower = ctx.variable(d["follower"], f"{key}.follower", Kind.LENGTH if kind == "translating" else Kind.ANGLE)
    if cam is None or follower is None:
        return None
    if cam == follower:
        p.add(f"{key}.follower", "the follower must be another variable than the cam")
        return None
    lift = Kind.LENGTH if kind == "translating" else Kind.ANGLE
    base = (ctx.quantity(d["base"], f"{key}.base", Kind.LENGTH, positive=True, allow_zero=False) if "base" in d
            else None)
    roller = None
    if contact == "roller":
        if "roller" not in d:
            p.add(key, "a roller follower needs `roller` (its radius)")
            return None
        roller = ctx.quantity(d["roller"], f"{key}.roller", Kind.LENGTH, positive=True, allow_zero=False)
    elif "roller" in d:
        p.add(f"{key}.roller", f"a {contact} follower has no roller")
        return None
    offset = ctx.quantity(d["offset"], f"{key}.offset", Kind.LENGTH) if "offset" in d else None
    start = ctx.quantity(d["start"], f"{key}.start", Kind.ANGLE) if "start" in d else None
    pivot = arm = pivot_angle = axis = None
    side = 1
    if kind == "oscillating":
        for k in ("pivot", "arm") if contact != "flat" else ("pivot",):
            if k not in d:
                what = "the distance from the cam centre to its pivot" if k == "pivot" else "the length of its arm"
                p.add(key, f"an oscillating follower needs `{k}` ({what})")
                return None
        pivot = ctx.quantity(d["pivot"], f"{key}.pivot", Kind.LENGTH, positive=True, allow_zero=False)
        arm = ctx.quantity(d["arm"], f"{key}.arm", Kind.LENGTH, positive=True, allow_zero=False) if "arm" in d else None
        pivot_angle = ctx.quantity(d["pivot_angle"], f"{key}.pivot_angle", Kind.ANGLE) if "pivot_angle" in d else None
        sd = _choice(ctx, d, key, "side", ("left", "right"), "left")
        side = 1 if sd == "left" else -1
        if offset is not None:
            p.add(f"{key}.offset", "an oscillating follower has no offset (place its pivot with `pivot`, "
                  "`pivot_angle`)")
            return None
    else:
        for k in ("pivot", "arm", "pivot_angle", "side"):
            if k in d:
                p.add(f"{key}.{k}", "a key of an oscillating follower (this one is translating)")
                return None
        axis = ctx.quantity(d["axis"], f"{key}.axis", Kind.ANGLE) if "axis" in d else None
    center = ctx.point(d["center"], f"{key}.center") if "center" in d else None
    profile = None
    if "profile" in d:
        if len(p.items) > n_before:
            return None
        segments = ()
        profile = _profile(ctx, key, d["profile"], kind, contact, roller, offset, pivot, arm, side)
        if profile is None:
            return None
    else:
        segments = _segments(ctx, d["law"], f"{key}.law", lift)
    if segments is None or len(p.items) > n_before:
        return None
    c = Cam(name, key, cam, follower, kind, contact, roller, base, offset, segments, start, center, axis, pivot,
            pivot_angle, arm, side, "", profile)
    c = dataclasses.replace(c, text=_describe(c))
    if not _check_numbers(ctx, c):
        return None
    return c


def _segments(ctx, raw, key, lift) -> tuple | None:
    p = ctx.problems
    if not isinstance(raw, list) or not raw:
        p.add(key, "expected a list of segments such as [ { to = 90, rise = \"25mm\", curve = \"cycloidal\" }, "
              "{ to = 360, ... } ]")
        return None
    out = []
    for i, seg in enumerate(raw):
        k = f"{key}[{i}]"
        if not isinstance(seg, Mapping):
            p.add(k, f"expected a table such as {{ to = 90, rise = \"25mm\", curve = \"cycloidal\" }}, got {seg!r}")
            return None
        extra = sorted(set(seg) - _SEG_KEYS)
        if extra:
            p.add(k, f"unknown key(s) {extra} (allowed: {', '.join(sorted(_SEG_KEYS))})")
            return None
        if "to" not in seg:
            p.add(k, "missing `to` (the cam angle where the segment ends)")
            return None
        end = ctx.quantity(seg["to"], f"{k}.to", Kind.ANGLE)
        what = [w for w in ("dwell", "rise", "return") if w in seg]
        if len(what) != 1:
            p.add(k, "a segment is one of `dwell = true`, `rise = ...` or `return = ...`")
            return None
        if what == ["dwell"]:
            if seg["dwell"] is not True:
                p.add(f"{k}.dwell", f"expected true, got {seg['dwell']!r}")
                return None
            if "curve" in seg:
                p.add(f"{k}.curve", "a dwell has no curve")
                return None
            out.append(CamSegment(k, end, None, 0, None))
            continue
        rise = ctx.quantity(seg[what[0]], f"{k}.{what[0]}", lift)
        crv = seg.get("curve")
        if crv not in CURVES:
            p.add(f"{k}.curve", f"{crv!r}: expected one of {', '.join(CURVES)}" if crv is not None
                  else f"a {what[0]} needs its `curve`, one of {', '.join(CURVES)}")
            return None
        if end is None or rise is None:
            return None
        out.append(CamSegment(k, end, rise, -1 if what[0] == "return" else 1, crv))
    return tuple(out)


def _profile(ctx, key, raw, kind, contact, roller, offset, pivot, arm, side):
    """The :class:`~loopsolve.model.campitch.ProfileLaw` of ``profile = "file.csv"`` (a problem otherwise)."""
    import os

    from . import campitch

    p = ctx.problems
    if not isinstance(raw, str) or not raw.strip():
        p.add(f"{key}.profile", f"expected the path of a CSV file (header x,y) of the pitch curve, got {raw!r}")
        return None
    geometry = {}
    for k, node in (("roller", roller), ("offset", offset), ("pivot", pivot), ("arm", arm)):
        if node is None:
            geometry[k] = 0.0
            continue
        if _expr.names(node):
            p.add(f"{key}.{k}", "a cam declared by its `profile` takes a number here, not a parameter (its "
                  "displacement is computed from the curve once, when the model is read)")
            return None
        val = ctx.value(node, Kind.LENGTH)
        if val is None:
            return None
        geometry[k] = float(val)
    source = getattr(p, "source", None)
    folder = os.path.dirname(os.path.abspath(source)) if source and os.path.exists(source) else os.getcwd()
    path = os.path.join(folder, raw)
    try:
        st = os.stat(path)
        stamp = (st.st_mtime_ns, st.st_size)
    except OSError:
        stamp = None
    try:
        return _profile_law(os.path.abspath(path), stamp, raw, kind, contact, side, tuple(sorted(geometry.items())))
    except campitch.ProfileError as exc:
        p.add(f"{key}.profile", f"{raw}: {exc}")
        return None


@functools.lru_cache(maxsize=32)
def _profile_law(path, stamp, raw, kind, contact, side, geometry):
    """Read and build a profile once per file version and geometry (a model is rebuilt for new parameters)."""
    from . import campitch

    g = dict(geometry)
    pts = campitch.read_points(path)
    return campitch.build(pts, kind=kind, contact=contact, roller=g["roller"], offset=g["offset"],
                          pivot=g["pivot"], arm=g["arm"], side=side, file=raw)


def _describe(c: Cam) -> str:
    if c.profile is not None:
        return f"{c.kind} {c.contact} follower {c.follower} of cam {c.cam}, profile {c.profile.file}"
    return (f"{c.kind} {c.contact} follower {c.follower} of cam {c.cam}, "
            + ", ".join(f"{s.curve or 'dwell'}" for s in c.segments))


def law_of(c: Cam, values) -> Law:
    """The law in numbers (radians; rises in the length unit or radians), ``values(node, kind)`` evaluating."""
    if c.profile is not None:
        return Law(0.0, (2 * math.pi,), (0.0,), (None,), table=c.profile)
    lift = Kind.LENGTH if c.kind == "translating" else Kind.ANGLE
    start = values(c.start, Kind.ANGLE) if c.start is not None else 0.0
    return Law(start, tuple(values(s.end, Kind.ANGLE) for s in c.segments),
               tuple(0.0 if s.rise is None else s.sign * values(s.rise, lift) for s in c.segments),
               tuple(s.curve for s in c.segments))


def numbers(c: Cam, values) -> CamNumbers:
    """The cam in numbers (:class:`~loopsolve.model.camgeometry.CamNumbers`)."""
    def v(node, kind, default=0.0):
        return default if node is None else values(node, kind)

    frame = (v(c.axis, Kind.ANGLE, math.pi / 2) - math.pi / 2 if c.kind == "translating"
             else v(c.pivot_angle, Kind.ANGLE))
    base = c.profile.base if c.profile is not None else v(c.base, Kind.LENGTH)
    return CamNumbers(c.kind, c.contact, law_of(c, values), base, v(c.roller, Kind.LENGTH),
                      v(c.offset, Kind.LENGTH), v(c.pivot, Kind.LENGTH), v(c.arm, Kind.LENGTH), c.side, frame)


def _check_numbers(ctx, c: Cam) -> bool:
    """The law covers one turn and closes; the geometry exists. Problems named by key."""
    p = ctx.problems

    def values(node, kind):
        out = ctx.value(node, kind)
        if out is None:
            raise ValueError
        return out

    try:
        law = law_of(c, values)
        cn = numbers(c, values)
    except ValueError:
        return False
    if c.profile is not None:  # closed, smooth and met once per angle: checked when it was built
        return True
    unit = ctx.angle_unit
    shown = (lambda r: math.degrees(r)) if unit == "deg" else (lambda r: r)
    lo = law.start
    for seg, end in zip(c.segments, law.ends):
        if not end > lo + 1e-12:
            p.add(f"{seg.key}.to", f"{shown(end):g} does not come after {shown(lo):g} ({unit}): the segments' "
                  "ends increase round the turn")
            return False
        lo = end
    if abs(law.ends[-1] - (law.start + 2 * math.pi)) > 1e-9:
        p.add(f"{c.key}.law", f"the segments end at {shown(law.ends[-1]):g} {unit}, not one turn after the start "
              f"({shown(law.start + 2 * math.pi):g}): a law covers 360 degrees (the last `to` is the start plus "
              "a turn)")
        return False
    scale = max(1.0, max(abs(h) for h in law.rises))
    for jn in joins(law):
        for what in ("position", "velocity"):
            if abs(jn[what]) > 1e-9 * scale:
                hint = (f"the rises and returns add up to {-jn['position']:g}, so the follower does not come back to "
                        "its start after a turn" if what == "position" else "a segment's curve starts or ends moving")
                p.add(f"{c.key}.law", f"the law is discontinuous in {what} at {shown(jn['angle']):g} {unit}: {hint}")
                return False
    if c.kind == "translating" and c.contact != "flat" and abs(cn.offset) >= cn.pitch_base:
        p.add(f"{c.key}.offset", f"the offset {cn.offset:g} is not inside the pitch base circle ({cn.pitch_base:g})")
        return False
    if c.kind == "oscillating":
        try:
            cn.arm_start()
        except ValueError as exc:
            p.add(f"{c.key}.pivot", f"{exc}: with pivot {cn.pivot:g}, arm {cn.arm:g} and base circle "
                  f"{cn.pitch_base:g} the follower cannot touch the cam")
            return False
    return True


def cam_report(c: Cam, values, n: int = SAMPLES) -> dict:
    """The analysis of a cam over one turn (see :func:`loopsolve.model.camgeometry.analyse`) with the angles."""
    cn = numbers(c, values)
    th = cn.law.start + np.linspace(0.0, 2 * math.pi, n, endpoint=False)
    data = analyse(cn, th)
    data["angle"] = th
    data["numbers"] = cn
    return data


def undercut_problem(c: Cam, values) -> tuple[str, str] | None:
    """``(key, message)`` when the cam's profile is undercut (a roller larger than a convex radius of
    curvature of the pitch curve, a flat face whose profile turns back), else None."""
    data = cam_report(c, values)
    bad = data["undercut"]
    if not bad.any():
        return None
    i = int(np.flatnonzero(bad)[np.argmin(data["rho"][bad])])
    ang = data["angle"][i]
    cn = data["numbers"]
    if c.contact == "flat":
        need = float(np.max(-(data["s"] + data["a"]))) if c.kind == "translating" else None
        more = f"; the base circle must exceed {need:.6g}" if need is not None else ""
        return (f"{c.key}.base", f"the flat face's profile folds back (radius of curvature {data['rho'][i]:.4g} at cam "
                f"angle {math.degrees(ang):.6g} deg): the cam is undercut; use a larger base circle{more}")
    rho = float(np.min(data["rho"][bad]))
    return (f"{c.key}.roller", f"the roller ({cn.roller:g}) is larger than the pitch curve's radius of curvature "
            f"{rho:.4g} at cam angle {math.degrees(ang):.6g} deg: the profile is undercut (a cusp); use a smaller "
            "roller or a larger base circle")


def check_cams(mech) -> None:
    """Raise :class:`~loopsolve.errors.ModelError` naming the key when a cam of ``mech`` is undercut."""
    if mech.pairs is None or not mech.pairs.cams:
        return
    from ..errors import ModelError
    from .pairs import evaluator

    values = evaluator(mech)
    problems = [pr for pr in (undercut_problem(c, values) for c in mech.pairs.cams) if pr is not None]
    if problems:
        where = mech.source or mech.name
        lines = [f"{where}: {k}: {m}" for k, m in problems]
        raise ModelError(lines[0] if len(lines) == 1 else "; ".join(lines), problems=lines)
