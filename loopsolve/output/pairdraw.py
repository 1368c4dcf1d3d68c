"""What the higher pairs look like at a pose: gears as pitch circles, cams with their profile and
follower, slots as slots — for the figures (:mod:`loopsolve.output.plotting`), the page
(:mod:`loopsolve.output.view`) and CAD (:mod:`loopsolve.output.cad`).

:func:`pair_shapes` gives, for a solved :class:`~loopsolve.kinematics.results.State`, a list of
:class:`Shape` in the model's coordinates (numbers only); :func:`draw_shapes` renders them with
matplotlib, :func:`loopsolve.output.cad.shape_entities` as CAD entities. A gear whose centre cannot be found (no bar of its
link in the loops and no ``centers``) is not drawn; neither is a cam without a ``center`` point when
the origin is not where the model puts it (the cam is drawn about its ``center``, the origin by
default).
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass

import numpy as np

__all__ = ["Shape", "pair_shapes", "draw_shapes", "cam_outline", "check_drawable"]

_PROFILES: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def check_drawable(mech) -> None:
    """Refuse to draw a model with nothing to draw: no vectors (a gear train of constraints alone)."""
    if not mech.vectors:
        from ..errors import ModelError

        raise ModelError(f"{mech.source or mech.name}: nothing to draw: the model has no vectors (its higher pairs "
                         "tie angles alone); solve or sweep it for the numbers, or give its links vectors to see them")


@dataclass(frozen=True)
class Shape:
    """One drawn item: ``kind`` ``circle`` (``points`` its centre, ``size`` the radius), ``polyline``
    (``closed`` or not) or ``line``; ``role`` ``gear``, ``rack``, ``cam``, ``follower`` or ``slot``."""

    kind: str
    points: np.ndarray
    role: str
    name: str
    size: float = 0.0
    closed: bool = False


def _rot(xy, a):
    c, s = math.cos(a), math.sin(a)
    xy = np.asarray(xy, dtype=float)
    return np.stack([c * xy[..., 0] - s * xy[..., 1], s * xy[..., 0] + c * xy[..., 1]], axis=-1)


def cam_outline(mech, cam, samples: int = 360) -> dict:
    """The cam's analysis over a turn (its profile on the cam, cached per mechanism)."""
    from ..model.cams import cam_report
    from ..model.pairs import evaluator

    cache = _PROFILES.setdefault(mech, {})
    if cam.name not in cache:
        cache[cam.name] = cam_report(cam, evaluator(mech), n=samples)
    return cache[cam.name]


def pair_shapes(state) -> list[Shape]:
    """The shapes of every gear pair, cam and slot of the state's mechanism at its pose."""
    mech = state.compiled.mechanism
    if mech.pairs is None:
        return []
    out: list[Shape] = []
    out += _gear_shapes(state)
    out += _cam_shapes(state)
    out += _slot_shapes(state)
    return out


def _gear_shapes(state) -> list[Shape]:
    from ..kinematics.pairchecks import gear_centres, unit_rates
    from ..model.gears import ratio_values
    from ..model.pairs import evaluator

    ck = state.compiled
    mech = ck.mechanism
    z = np.asarray(state.z, dtype=float)[:, None]
    out = []
    for g in mech.pairs.gears:
        try:
            cg, cm = gear_centres(ck, z, unit_rates(ck, z), g)
        except Exception:  # noqa: BLE001 - a picture without the gear rather than no picture
            continue
        if cg is None or not np.all(np.isfinite(cg)):
            continue
        rg, rm, ratio = ratio_values(g, evaluator(mech))
        if g.rack:
            out.append(Shape("circle", cg[0], "gear", f"{g.name} pinion", size=float(rg)))
            continue
        if cm is None or not np.all(np.isfinite(cm)):
            continue
        if rg is None:
            d = float(np.linalg.norm(cm[0] - cg[0]))
            rg = d * ratio / (abs(ratio - 1.0) if g.internal else ratio + 1.0)
            rm = rg / ratio
        out.append(Shape("circle", cg[0], "gear", f"{g.name} {g.gear or 'frame'}", size=float(rg)))
        out.append(Shape("circle", cm[0], "gear", f"{g.name} {g.mate or 'frame'}", size=float(rm)))
    return out


def _cam_shapes(state) -> list[Shape]:
    from ..model.camgeometry import analyse

    ck = state.compiled
    mech = ck.mechanism
    out = []
    for cam in mech.pairs.cams:
        data = cam_outline(mech, cam)
        cn = data["numbers"]
        th = float(state.z[ck.index(cam.cam)])
        centre = np.zeros(2)
        if cam.center is not None:
            centre = np.asarray(state.points[0][ck.points.index(cam.center)], dtype=float)
        a = cn.frame_angle
        profile = centre + _rot(_rot(data["profile"], th), a)
        out.append(Shape("polyline", profile, "cam", f"{cam.name} profile", closed=True))
        out.append(Shape("circle", centre, "cam", f"{cam.name} centre", size=0.08 * cn.base))
        here = analyse(cn, np.array([th]))
        if cam.contact == "roller":
            from ..model.camgeometry import follower_pose

            pitch = follower_pose(cn, np.array([th]))[0][0]
            out.append(Shape("circle", centre + _rot(pitch, a), "follower", f"{cam.name} roller", size=cn.roller))
        elif cam.contact == "flat":
            X = here["contact"][0]
            n = here["normal"][0]
            t = np.array([-n[1], n[0]])
            w = 0.6 * cn.base
            ends = np.array([X - w * t, X + w * t])
            out.append(Shape("line", centre + _rot(ends, a), "follower", f"{cam.name} face"))
        else:
            X = here["contact"][0]
            m = np.asarray(here["normal"][0])
            tip = np.array([X, X + 0.3 * cn.base * m])
            out.append(Shape("line", centre + _rot(tip, a), "follower", f"{cam.name} knife"))
    return out


def _slot_shapes(state) -> list[Shape]:
    ck = state.compiled
    mech = ck.mechanism
    out = []
    pts = {name: np.asarray(state.points[0][j], dtype=float) for j, name in enumerate(ck.points)}
    lv = ck.vector_values(0, state.z)
    for sl in mech.pairs.slots:
        P = pts[sl.point]
        scale = float(ck.scale)
        w = 0.02 * scale
        if sl.line is not None:
            L, a = lv[ck.vectors.index(sl.line)]
            e = np.array([math.cos(a), math.sin(a)]) * (1.0 if L >= 0 else -1.0)
            if sl.through:
                A = pts[sl.through]
            else:
                A = np.zeros(2)
                for sign, v in sl.tail:
                    Lv, av = lv[ck.vectors.index(v)]
                    A = A + sign * Lv * np.array([math.cos(av), math.sin(av)])
            s_pin = float((P - A) @ e)
            lo, hi = min(0.0, s_pin) - 2 * w, max(abs(L), s_pin) + 2 * w
            n = np.array([-e[1], e[0]])
            outline = np.array([A + e * lo + n * w, A + e * hi + n * w, A + e * hi - n * w, A + e * lo - n * w])
        else:
            C = pts[sl.center]
            R = float(np.linalg.norm(P - C))
            phi = math.atan2(P[1] - C[1], P[0] - C[0])
            arc = np.linspace(phi - 0.45, phi + 0.45, 40)
            outer = C + (R + w) * np.stack([np.cos(arc), np.sin(arc)], axis=1)
            inner = C + (R - w) * np.stack([np.cos(arc[::-1]), np.sin(arc[::-1])], axis=1)
            outline = np.vstack([outer, inner])
        out.append(Shape("polyline", outline, "slot", sl.name, closed=True))
    return out


_STYLE = {"gear": dict(color="#7d3c98", lw=1.4, ls=(0, (5, 2))), "rack": dict(color="#7d3c98", lw=1.4),
          "cam": dict(color="#117a65", lw=1.8), "follower": dict(color="#b9770e", lw=1.8),
          "slot": dict(color="#444444", lw=1.4)}


def draw_shapes(ax, shapes) -> list:
    """Draw ``shapes`` on matplotlib axes; returns the artists."""
    from matplotlib.patches import Circle, Polygon

    out = []
    for s in shapes:
        st = _STYLE.get(s.role, dict(color="k", lw=1.2))
        if s.kind == "circle":
            out.append(ax.add_patch(Circle(s.points, s.size, fill=False, zorder=3, **st)))
        elif s.kind == "polyline":
            fill = s.role == "cam"
            out.append(ax.add_patch(Polygon(s.points, closed=s.closed, fill=fill, zorder=2,
                                            facecolor=(st["color"] if fill else "none"), alpha=0.8 if fill else 1.0,
                                            edgecolor=st["color"], lw=st["lw"])))
        else:
            out += ax.plot(s.points[:, 0], s.points[:, 1], zorder=5, **st)
    return out


def shape_extent(shapes):
    """``(lo, hi)`` corners of the shapes (None when there are none)."""
    pts = []
    for s in shapes:
        if s.kind == "circle":
            c = np.asarray(s.points, dtype=float)
            pts += [c - s.size, c + s.size]
        else:
            pts += list(np.asarray(s.points, dtype=float))
    if not pts:
        return None
    arr = np.array(pts, dtype=float)
    arr = arr[np.all(np.isfinite(arr), axis=1)]
    return (arr.min(axis=0), arr.max(axis=0)) if len(arr) else None


def widen(ax, shapes, pad: float) -> None:
    """Extend the axes' limits (equal aspect) to show ``shapes`` with a margin ``pad``."""
    ext = shape_extent(shapes)
    if ext is None:
        return
    lo, hi = ext
    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    ax.set_xlim(min(x0, lo[0] - pad), max(x1, hi[0] + pad))
    ax.set_ylim(min(y0, lo[1] - pad), max(y1, hi[1] + pad))


def draw_pairs(ax, state, *, pad: float | None = None) -> list:
    """Draw the higher pairs of ``state`` on ``ax`` (widening the limits when ``pad`` is given)."""
    mech = state.compiled.mechanism
    if mech.pairs is None or not (mech.pairs.gears or mech.pairs.cams or mech.pairs.slots):
        return []
    shapes = pair_shapes(state)
    if pad is not None:
        widen(ax, shapes, pad)
    return draw_shapes(ax, shapes)


def page_shapes(sweep, add_traj, add_angle) -> list[dict]:
    """The higher pairs for the interactive page: ``add_traj`` ships an ``(N, 2)`` trajectory (returns its
    index), ``add_angle`` a list of angles. A circle follows its centre; a cam's profile is shipped once
    in the cam's frame and turned by its angle; any other outline by the trajectory of each vertex."""
    states = list(sweep.states)
    if not states or sweep.mechanism.pairs is None:
        return []
    mech = sweep.mechanism
    per_frame = [pair_shapes(s) for s in states]
    if not per_frame[0]:
        return []
    ck = sweep.compiled
    out: list[dict] = []
    for k, s in enumerate(per_frame[0]):
        if any(len(f) != len(per_frame[0]) for f in per_frame):
            return out  # a shape came and went (a centre not found in some frames): keep what is sure
        if s.kind == "circle":
            centres = np.array([f[k].points for f in per_frame], dtype=float)
            out.append({"k": "circle", "c": s.role, "t": add_traj(centres), "r": float(s.size)})
        elif s.role == "cam" and s.kind == "polyline":
            cam = next(c for c in mech.pairs.cams if s.name == f"{c.name} profile")
            data = cam_outline(mech, cam)
            cn = data["numbers"]
            centre = np.zeros((len(states), 2))
            if cam.center is not None:
                j = ck.points.index(cam.center)
                centre = np.array([st.points[0][j] for st in states], dtype=float)
            turns = [float(st.z[ck.index(cam.cam)]) + cn.frame_angle for st in states]
            local = _rot(data["profile"], 0.0)
            out.append({"k": "rot", "c": "cam", "p": [float(v) for v in local.reshape(-1)],
                        "t": add_traj(centre), "a": add_angle(turns)})
        else:
            n = len(s.points)
            ts = [add_traj(np.array([f[k].points[v] for f in per_frame], dtype=float)) for v in range(n)]
            out.append({"k": "poly", "c": s.role, "n": ts, "closed": bool(s.closed)})
    return out
