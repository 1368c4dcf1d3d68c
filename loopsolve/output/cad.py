"""A linkage at one pose as a CAD drawing: DXF (through ezdxf) or SVG, in model units.

What is drawn comes from :mod:`loopsolve.output.geometry` (the same frames the figures use), placed in
the model's coordinates (every named point where the solve puts it, wherever the model places its
frame; 1 drawing unit = 1 model length unit, which the DXF header's ``$INSUNITS`` names), on
one layer per role:

========== ===============================================================================
layer      entities
========== ===============================================================================
LINKS      a line between every two joints of a link (a link of three or more joints: its
           closed outline as well)
PINS       a circle at every joint (radius ``pin``)
GROUND     a triangle under every ground pivot, the fixed vectors (ground lines), guides
SLIDERS    a rectangle for every slider block
POINTS     a small circle at every tracer point (a named point that is not a joint: a coupler
           point, a centre of mass), at the solve's coordinates
CURVES     the path of each tracer point that moves (or each ``curves`` point) over a sweep: a
           polyline
PAIRS      the higher pairs (:mod:`loopsolve.output.pairdraw`): a gear's pitch circle, a cam's
           profile turned to the pose and its follower (roller circle, flat face or knife
           edge), a slot's outline
LABELS     the joint and point names
========== ===============================================================================

The DXF is written with ezdxf (the ``cad`` extra), never by hand; the SVG is plain XML (one
``<g id="LAYER">`` group per layer, model coordinates, y up through the group's transform).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import MissingDependencyError, ModelError

__all__ = ["Entity", "LAYERS", "drawing_entities", "check_cad_output", "dxf_units", "export_cad", "point_curves",
           "write_dxf", "write_svg", "CAD_FORMATS"]

CAD_FORMATS = ("dxf", "svg")

#: layer name -> (AutoCAD colour index, SVG stroke colour)
LAYERS = {
    "LINKS": (5, "#1f4e79"),
    "PINS": (7, "#000000"),
    "GROUND": (8, "#555555"),
    "SLIDERS": (2, "#b9770e"),
    "POINTS": (1, "#b03a2e"),
    "CURVES": (3, "#1e8449"),
    "PAIRS": (6, "#7d3c98"),
    "LABELS": (7, "#000000"),
}

#: the DXF ``$INSUNITS`` codes of lengths and the size of each unit in metres (DXF reference, HEADER)
_INSUNITS = {1: 0.0254, 2: 0.3048, 3: 1609.344, 4: 1e-3, 5: 1e-2, 6: 1.0, 7: 1e3, 8: 2.54e-8, 9: 2.54e-5,
             10: 0.9144, 11: 1e-10, 12: 1e-9, 13: 1e-6, 14: 0.1, 15: 10.0, 16: 100.0, 17: 1e9}
#: the codes of the inch-based units (``$MEASUREMENT`` 0: imperial; every other unit is metric, 1)
_IMPERIAL = frozenset({1, 2, 3, 8, 9, 10})


def dxf_units(unit: str) -> tuple[int, int]:
    """``($INSUNITS, $MEASUREMENT)`` of a model length unit: the DXF code of the same size (0, unitless,
    for a unit DXF has no code for or a display-only name such as ``"units"``) and 0 (imperial) or
    1 (metric).

    Examples
    --------
    >>> from loopsolve.output.cad import dxf_units
    >>> dxf_units("mm"), dxf_units("cm"), dxf_units("m"), dxf_units("inch"), dxf_units("units")
    ((4, 1), (5, 1), (6, 1), (1, 0), (0, 1))
    """
    from ..model.units import is_physical_length, length_factor

    if not is_physical_length(unit):
        return 0, 1
    metres = length_factor(unit, "m")
    code = next((c for c, f in _INSUNITS.items() if math.isclose(metres, f, rel_tol=1e-9)), 0)
    return code, 0 if code in _IMPERIAL else 1


@dataclass(frozen=True)
class Entity:
    """One drawn item: ``kind`` is ``line``, ``circle``, ``polyline`` or ``text``.

    ``points`` are model coordinates (two for a line, the centre for a circle and a text, the
    vertices of a polyline); ``size`` the radius (circle) or height (text); ``closed`` for a
    polyline; ``text`` and ``name`` (the joint/point/link the entity belongs to).
    """

    layer: str
    kind: str
    points: tuple
    size: float = 0.0
    closed: bool = False
    text: str = ""
    name: str = ""

    def __repr__(self) -> str:
        # a curve has hundreds of vertices: name the count, so that the list export_cad returns
        # reads as a summary at a prompt or in a notebook
        pts = (repr(self.points) if len(self.points) <= 3 else
               f"<{len(self.points)} points from ({self.points[0][0]:.6g}, {self.points[0][1]:.6g})>")
        extra = "".join(f", {k}={v!r}" for k, v in (("size", self.size), ("closed", self.closed), ("text", self.text),
                                                   ("name", self.name)) if v)
        return f"Entity(layer={self.layer!r}, kind={self.kind!r}, points={pts}{extra})"


def _xy(p) -> tuple[float, float]:
    return float(p[0]), float(p[1])


def drawing_entities(state, *, curves: dict | None = None) -> list[Entity]:
    """The entities of the drawing of a solved ``state`` (and of the point ``curves``).

    Parameters
    ----------
    state : State
        A solved pose.
    curves : dict, optional
        ``{point name: (N, 2) array}`` paths drawn as polylines on ``CURVES``.

    Examples
    --------
    >>> from loopsolve.output.cad import drawing_entities
    >>> ents = drawing_entities(ls.load(ls.models_dir() / "thesis_crank_rocker.toml").solve(60))
    >>> sorted({e.layer for e in ents})
    ['GROUND', 'LABELS', 'LINKS', 'PINS']
    """
    from .drawstyle import drawing_style
    from .geometry import pose_frames
    from .pairdraw import check_drawable

    check_drawable(state.compiled.mechanism)
    (frame,), _ = pose_frames([state], vectors=False)
    style = drawing_style([frame])
    size = float(style.size)
    pin = 0.22 * size
    out: list[Entity] = []
    for key, xy, _ in frame.links:
        pts = [_xy(p) for p in xy]
        name = str(key)
        for a in range(len(pts)):
            for b in range(a + 1, len(pts)):
                out.append(Entity("LINKS", "line", (pts[a], pts[b]), name=name))
        if len(pts) >= 3:
            from .geometry import hull_order

            order = hull_order(np.asarray(pts))
            out.append(Entity("LINKS", "polyline", tuple(pts[i] for i in order), closed=True, name=name))
    for p in frame.joints:
        out.append(Entity("PINS", "circle", (_xy(p),), size=pin))
    for p, key in frame.pivots:
        u = np.asarray(style.pivot_dir.get(key, np.array([0.0, -1.0])), dtype=float)
        n = np.array([-u[1], u[0]])
        p = np.asarray(p, dtype=float)
        a, b = 1.1 * size, 0.75 * size
        tri = (_xy(p), _xy(p + u * a - n * b), _xy(p + u * a + n * b))
        out.append(Entity("GROUND", "polyline", tri, closed=True, name=str(key)))
        w = 1.45 * b
        out.append(Entity("GROUND", "line", (_xy(p + u * a - n * w), _xy(p + u * a + n * w)), name=str(key)))
    for p0, p1 in frame.ground_lines:
        out.append(Entity("GROUND", "line", (_xy(p0), _xy(p1))))
    for key, p, d, ground, tail in frame.guides:
        d = np.asarray(d, dtype=float)
        p = np.asarray(p, dtype=float)
        out.append(Entity("GROUND" if ground else "SLIDERS", "line", (_xy(p - 3 * size * d), _xy(p + 3 * size * d)),
                          name=str(key)))
    for v, tail, d, blk in frame.levers:
        d = np.asarray(d, dtype=float)
        tail = np.asarray(tail, dtype=float)
        reach = float(np.dot(np.asarray(blk) - tail, d)) + 2 * size
        out.append(Entity("LINKS", "line", (_xy(tail), _xy(tail + d * max(reach, 2 * size))), name=str(v)))
    for p, angle in frame.blocks:
        d = np.array([math.cos(angle), math.sin(angle)])
        n = np.array([-d[1], d[0]])
        p = np.asarray(p, dtype=float)
        a, b = 0.95 * size, 0.5 * size
        corners = (p - d * a - n * b, p + d * a - n * b, p + d * a + n * b, p - d * a + n * b)
        out.append(Entity("SLIDERS", "polyline", tuple(_xy(c) for c in corners), closed=True))
    for p, name in frame.points:  # every named point that is not a joint, at the solve's coordinates
        out.append(Entity("POINTS", "circle", (_xy(p),), size=0.16 * size, name=str(name)))
    for p, text, _ in frame.labels:
        q = np.asarray(p, dtype=float) + np.array([0.35, 0.35]) * size
        out.append(Entity("LABELS", "text", (_xy(q),), size=0.6 * size, text=str(text), name=str(text)))
    from .pairdraw import pair_shapes

    out += shape_entities(pair_shapes(state))  # gears as pitch circles, cams, followers, slots
    for name, xy in (curves or {}).items():
        xy = np.asarray(xy, dtype=float)
        xy = xy[np.isfinite(xy).all(axis=1)]
        if len(xy) >= 2:
            out.append(Entity("CURVES", "polyline", tuple(_xy(p) for p in xy), name=str(name)))
    return out


def _ezdxf():
    try:
        import ezdxf
    except ImportError:
        raise MissingDependencyError("DXF output needs ezdxf: pip install 'loopsolve[cad]'") from None
    return ezdxf


def write_dxf(entities, output, *, unit: str = "mm", title: str = "") -> None:
    """Write ``entities`` to a DXF file (R2010) with ezdxf, one layer per role."""
    ezdxf = _ezdxf()
    doc = ezdxf.new("R2010", setup=True)
    doc.header["$INSUNITS"], doc.header["$MEASUREMENT"] = dxf_units(unit)
    for name, (aci, _) in LAYERS.items():
        doc.layers.add(name, color=aci)
    msp = doc.modelspace()
    for e in entities:
        attribs = {"layer": e.layer}
        if e.kind == "line":
            msp.add_line(e.points[0], e.points[1], dxfattribs=attribs)
        elif e.kind == "circle":
            msp.add_circle(e.points[0], e.size, dxfattribs=attribs)
        elif e.kind == "polyline":
            msp.add_lwpolyline(list(e.points), close=e.closed, dxfattribs=attribs)
        elif e.kind == "text":
            msp.add_text(e.text, height=e.size, dxfattribs=attribs).set_placement(e.points[0])
    if title:
        doc.header["$PROJECTNAME"] = title[:255]
    doc.saveas(str(output))


def write_svg(entities, output, *, unit: str = "mm", title: str = "") -> None:
    """Write ``entities`` to an SVG file in model coordinates (one ``<g id=LAYER>`` per layer)."""
    import xml.etree.ElementTree as ET

    pts = np.array([p for e in entities for p in e.points], dtype=float).reshape(-1, 2)
    if len(pts) == 0:
        raise ModelError("nothing to draw")
    grow = max((e.size for e in entities), default=0.0)
    lo, hi = pts.min(axis=0) - 2 * grow, pts.max(axis=0) + 2 * grow
    span = float(max(hi - lo)) or 1.0
    lo, hi = lo - 0.05 * span, hi + 0.05 * span
    w, h = hi - lo
    units = {"mm": "mm", "cm": "cm", "in": "in", "m": "m"}
    u = units.get(unit, "")
    root = ET.Element("svg", {"xmlns": "http://www.w3.org/2000/svg", "version": "1.1",
                              "viewBox": f"{lo[0]:.12g} {-hi[1]:.12g} {w:.12g} {h:.12g}",
                              "width": f"{w:.12g}{u}" if u != "m" else f"{1000 * w:.12g}mm",
                              "height": f"{h:.12g}{u}" if u != "m" else f"{1000 * h:.12g}mm"})
    if title:
        ET.SubElement(root, "title").text = title
    stroke = 0.004 * span
    for layer, (_, colour) in LAYERS.items():
        g = ET.SubElement(root, "g", {"id": layer, "transform": "scale(1,-1)", "stroke": colour,
                                      "fill": "none", "stroke-width": f"{stroke:.6g}"})
        for e in (e for e in entities if e.layer == layer):
            attrs = {"data-name": e.name} if e.name else {}
            if e.kind == "line":
                (x1, y1), (x2, y2) = e.points
                ET.SubElement(g, "line", {"x1": repr(x1), "y1": repr(y1), "x2": repr(x2), "y2": repr(y2), **attrs})
            elif e.kind == "circle":
                (cx, cy), = e.points
                ET.SubElement(g, "circle", {"cx": repr(cx), "cy": repr(cy), "r": repr(e.size), **attrs})
            elif e.kind == "polyline":
                text = " ".join(f"{x!r},{y!r}" for x, y in e.points)
                ET.SubElement(g, "polygon" if e.closed else "polyline", {"points": text, **attrs})
            elif e.kind == "text":
                (x, y), = e.points
                # text is drawn upright: undo the group's flip around its own baseline
                t = ET.SubElement(g, "text", {"x": repr(x), "y": repr(-y), "transform": "scale(1,-1)",
                                              "font-size": f"{e.size:.6g}", "stroke": "none", "fill": colour,
                                              "font-family": "sans-serif", **attrs})
                t.text = e.text
    ET.ElementTree(root).write(str(output), encoding="utf-8", xml_declaration=True)


def _tracer_points(state) -> list[str]:
    """The named points that are not joints (coupler points, centres of mass ...): the default curves."""
    from .geometry import pose_frames

    (frame,), _ = pose_frames([state], vectors=False)
    return [str(name) for _, name in frame.points]


def _moves(xy, scale: float) -> bool:
    xy = np.asarray(xy, dtype=float)
    xy = xy[np.isfinite(xy).all(axis=1)]
    return len(xy) >= 2 and float(np.ptp(xy, axis=0).max()) > 1e-9 * scale


def point_curves(mech, state, names, *, step=None) -> dict:
    """Paths of the points ``names`` over the default sweep of ``mech`` in the state's mode."""
    from ..kinematics.reach import default_range

    if not names:
        return {}
    ck = state.compiled
    known = set(ck.points)
    bad = [n for n in names if n not in known]
    if bad:
        raise ModelError(f"--curve {bad[0]!r}: not a point of the model (points: {', '.join(ck.points) or 'none'})")
    angle = ck.kinds[ck.input_idx[0]].name == "ANGLE"
    if step is None:
        step = 1.0 if angle and state.units()[ck.inputs[0]] == "deg" else None
    if step is None:
        start, stop, _ = default_range(ck, 1.0, mode=state.mode)
        step = abs(stop - start) / 360 or 1.0
    start, stop, through = default_range(ck, float(step), mode=state.mode)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sw = mech.sweep(start, stop, step, mode=state.mode, through_limits=through, progress=False,
                        derivatives=1, input=ck.inputs[0])
    return {n: np.column_stack([np.asarray(sw[f"{n}_x"]), np.asarray(sw[f"{n}_y"])]) for n in names}


def check_cad_output(output) -> str:
    """The CAD format of ``output`` (``dxf``/``svg``), checked before any work (ezdxf present for DXF)."""
    fmt = Path(output).suffix.lower().lstrip(".")
    if fmt not in CAD_FORMATS:
        raise ModelError(f"{output}: a CAD drawing is .dxf or .svg (got {fmt or 'no extension'!r})")
    if fmt == "dxf":
        _ezdxf()
    return fmt


def export_cad(mech, output, at=None, *, input: str | None = None, mode: str | None = None,
               curves: list[str] | None = None, step=None, **solve_kwargs):
    """Write the linkage at input ``at`` as a CAD drawing (``.dxf`` or ``.svg`` by extension).

    Parameters
    ----------
    mech : Mechanism
        The model (a synthesized design's ``.mechanism`` as well).
    output : str or Path
        ``.dxf`` (ezdxf, needs the ``cad`` extra) or ``.svg``.
    at : float or str, optional
        Input value (default: the input's guess).
    curves : list of str, optional
        Points whose paths over the default sweep are drawn (default: the tracer points, i.e.
        points of a link that are not joints, such as a coupler point). ``[]`` draws none.
    step : float, optional
        Sweep step of the curves (default 1° or 1/360 of the range).

    Returns
    -------
    list of Entity
        What was written.

    Examples
    --------
    >>> import tempfile, os
    >>> from loopsolve.output.cad import export_cad
    >>> mech = ls.load(ls.models_dir() / "fourbar_coupler_curve.toml")
    >>> with tempfile.TemporaryDirectory() as d:
    ...     ents = export_cad(mech, os.path.join(d, "design.svg"), 60)
    >>> [e.name for e in ents if e.layer == "CURVES"]
    ['P']
    """
    fmt = check_cad_output(output)
    state = mech.solve(at, input=input, mode=mode, **solve_kwargs)
    names = _tracer_points(state) if curves is None else list(curves)
    paths = point_curves(mech, state, names, step=step)
    if curves is None:  # by default the paths of the tracer points that move
        paths = {n: xy for n, xy in paths.items() if _moves(xy, state.compiled.scale)}
    ents = drawing_entities(state, curves=paths)
    unit = mech.units.length
    title = f"{mech.name} at {state.input} = {state.input_value:.6g}"
    (write_dxf if fmt == "dxf" else write_svg)(ents, output, unit=unit, title=title)
    return ents


def shape_entities(shapes) -> list:
    """CAD entities of the shapes, on ``PAIRS``: pitch circles and cam profiles are not the bars and plates of
    ``LINKS`` (whose lines end at joints), nor a roller the block of ``SLIDERS``; a CAD user shows or hides
    them as one."""
    out = []
    for s in shapes:
        layer = "PAIRS"
        if s.kind == "circle":
            out.append(Entity(layer, "circle", (tuple(map(float, s.points)),), size=float(s.size), name=s.name))
        elif s.kind == "polyline":
            out.append(Entity(layer, "polyline", tuple((float(x), float(y)) for x, y in s.points), closed=s.closed,
                              name=s.name))
        else:
            out.append(Entity(layer, "line", tuple((float(x), float(y)) for x, y in s.points), name=s.name))
    return out
