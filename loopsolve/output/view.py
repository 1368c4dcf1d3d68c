"""The interactive page: one self-contained HTML file in which the linkage moves over a sweep.

:func:`to_html` turns a :class:`~loopsolve.kinematics.results.Sweep` into a page that works offline
(no network request when opened: the script and the style sheet are inline), showing the
kinematic diagram as :func:`loopsolve.output.plotting.draw` draws it, the linkage moving with
play/pause and speed, a slider over the rows (arrow keys step), the traces of the moving
points, the chosen variables against the input with a cursor at the current row, the current
row's values with units, the sweep's events (on the slider and the plots) and, when the
sweep changes assembly mode (``through_limits=True``), the mode of every part at each row.

Rendering: hand-written SVG and a small script (``view.js``, ``view.css`` next to this
module, shipped as package data). The alternatives were weighed: plotly's offline bundle
adds about 3.5 MB to every page and still needs custom shapes and callbacks for hatched
ground pivots, blocks on guides and rigid-link polygons; bokeh's inline resources are about
1 MB and need ``CustomJS`` for the same. The diagram needs a dozen kinds of shapes whose
coordinates change with the row, which is a few hundred lines of plain JavaScript; the
line plots are polylines. The page stays small (tens of kB plus the data), has no
dependency to keep up with, and the contract's hooks (``#loopsolve-input``, ``[data-point]``
circles in model coordinates under a y-flipping parent transform) are natural in it.

What is drawn comes from the same geometry as the matplotlib pictures: the frames and
style of :mod:`loopsolve.output.geometry` (links and their joints, ground pivots with their
directions, blocks on guides, slotted levers) are computed once per row in Python and
shipped as point trajectories plus a scene that refers to them. The page is deterministic:
the same sweep gives the same bytes (no time stamps, no random ids), whether written by
``loopsolve view`` or :meth:`Sweep.to_html`.
"""

from __future__ import annotations

import html
import json
import math
import re
from importlib import resources
from pathlib import Path

import numpy as np

from ..errors import ModelError
from .drawstyle import drawing_style
from .geometry import LINK_COLORS, hull_order, mode_label, plot_vars, polygon_area, pose_frames, unit_vector

__all__ = ["to_html", "write_html", "page_data", "check_output", "Page", "MAX_INLINE_ROWS"]

#: the largest sweep a notebook shows as a page on its own (``Sweep._repr_html_``)
MAX_INLINE_ROWS = 5000

_EVENT_COLORS = {"limit": ("#d62728", "6 3"), "singular": ("#ff7f0e", "6 2 1 2"),
                 "not-assemblable": ("#666666", "2 2"), "mode-change": ("#9467bd", "6 3")}
_GREEK = {"alpha": "α", "beta": "β", "gamma": "γ", "delta": "δ", "epsilon": "ε", "zeta": "ζ", "eta": "η",
          "theta": "θ", "iota": "ι", "kappa": "κ", "lambda": "λ", "mu": "μ", "nu": "ν", "xi": "ξ", "pi": "π",
          "rho": "ρ", "sigma": "σ", "tau": "τ", "upsilon": "υ", "phi": "φ", "chi": "χ", "psi": "ψ",
          "omega": "ω"}
_DIGITS = 12  # significant digits of the page's values and shapes (1e-12 relative); point paths are exact


# ------------------------------------------------------------------------------ numbers
def _num(v) -> float | None:
    v = float(v)
    if not math.isfinite(v):
        return None
    v = float(format(v, f".{_DIGITS}g"))
    return 0.0 if v == 0 else v


def _nums(a) -> list:
    return [_num(v) for v in np.asarray(a, dtype=float).ravel()]


def _coords(a) -> list:
    """Coordinates as they are (JSON keeps every bit of a float): the page draws every point and
    joint at exactly the numbers the sweep holds, however far from the origin the model is."""
    return [float(v) + 0.0 if math.isfinite(v) else None for v in np.asarray(a, dtype=float).ravel()]


def _sort_key(a) -> tuple:
    """A total order on arrays with NaNs (for shapes that come in set order)."""
    return tuple(math.inf if v is None else v for v in _nums(a))


def _pretty_name(name: str) -> list[str]:
    """``theta3`` → ``["θ", "3"]``, ``C_x`` → ``["C", "x"]``: the base and its subscript."""
    if "_" in name:
        base, sub = name.split("_", 1)
        if base in _GREEK or re.fullmatch(r"[A-Za-z]", base):
            return [_GREEK.get(base, base), sub]
        return [name.replace("_", " "), ""]
    m = re.fullmatch(r"([A-Za-z]+?)([0-9]+[A-Za-z]*|[A-Z][A-Z0-9]*)", name)
    if m and (m.group(1) in _GREEK or len(m.group(1)) == 1):
        return [_GREEK.get(m.group(1), m.group(1)), m.group(2)]
    return [_GREEK.get(name, name), ""]


def _pretty_unit(unit: str) -> str:
    return unit.replace("^2", "²").replace("^3", "³").replace("*", "·")


# ------------------------------------------------------------------------------ the scene
class _Table:
    """Trajectories (``(N, 2)`` arrays) shipped once each; equal ones share an index."""

    def __init__(self, scale: float):
        self.items: list[list] = []
        self.index: dict[tuple, int] = {}
        self.tol = 1e-9 * scale

    def add(self, xy) -> int:
        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        good = np.isfinite(xy).all(axis=1)
        if good.any() and np.ptp(xy[good], axis=0).max() <= self.tol and good.all():
            flat = _coords(xy[0])  # a fixed point: two numbers
        else:
            flat = _coords(xy)
        key = tuple(flat)
        if key not in self.index:
            self.index[key] = len(self.items)
            self.items.append(flat)
        return self.index[key]


def _angles(values) -> float | list:
    a = np.unwrap(np.asarray(values, dtype=float))
    return _num(a[0]) if np.ptp(a) <= 1e-12 else _nums(a)


def _scene(sweep) -> dict:
    """Trajectories and shapes of the diagram, from :mod:`loopsolve.output.geometry`'s frames and style."""
    ck = sweep.compiled
    from .pairdraw import check_drawable

    check_drawable(sweep.mechanism)
    frames, _ = pose_frames(list(sweep.states), vectors=False)
    style = drawing_style(frames)
    size = float(style.size)
    table = _Table(ck.scale)
    f0 = frames[0]

    def traj(get) -> int:
        return table.add(np.array([get(f) for f in frames], dtype=float))

    def canonical(items, key):
        """Frames list some shapes in set order (which differs between processes): sort them."""
        return sorted(range(len(items)), key=key)

    statics: list[dict] = []  # fixed shapes, absolute model coordinates
    for p0, p1 in sorted(([tuple(_nums(a)), tuple(_nums(b))] for a, b in f0.ground_lines),
                         key=lambda ab: (ab[0], ab[1])):
        statics.append({"k": "line", "c": "ground-line", "p": list(p0) + list(p1)})
    pivots = []
    for k in canonical(f0.pivots, lambda k: _sort_key(f0.pivots[k][0])):
        p, key = f0.pivots[k]
        p = np.asarray(p, dtype=float)
        u = np.asarray(style.pivot_dir.get(key, np.array([0.0, -1.0])), dtype=float)
        n = np.array([-u[1], u[0]])
        a, b = 1.1 * size, 0.75 * size
        w = 1.45 * b
        base = p + u * a
        strip = [base - n * w, base + n * w, base + u * 0.45 * size + n * w, base + u * 0.45 * size - n * w]
        statics.append({"k": "poly", "c": "hatch", "p": _nums(strip)})
        statics.append({"k": "poly", "c": "pivot", "p": _nums([p, base - n * b, base + n * b])})
        statics.append({"k": "line", "c": "ground", "p": _nums([base - n * w, base + n * w])})
        pivots.append({"t": table.add(p), "u": _nums(u)})
    guide_side = {}
    for key, p, d, ground, tail in f0.guides:
        if not ground:
            continue
        lo_s, hi_s = style.guide_span[key]
        side = np.asarray(style.guide_side[key], dtype=float)
        guide_side[key] = side
        ref = np.asarray(p, dtype=float)
        base = ref + side * 0.5 * size
        g0, g1 = base + d * lo_s, base + d * hi_s
        statics.append({"k": "line", "c": "axis", "p": _nums([ref + d * lo_s, ref + d * hi_s])})
        statics.append({"k": "poly", "c": "hatch", "p": _nums([g0, g1, g1 + side * 0.45 * size,
                                                                g0 + side * 0.45 * size])})
        statics.append({"k": "line", "c": "ground", "p": _nums([g0, g1])})

    links = []
    for k, (key, xy, color) in enumerate(f0.links):
        members = [traj(lambda f, k=k, j=j: f.links[k][1][j]) for j in range(len(xy))]
        xy0 = np.asarray(xy, dtype=float)
        polygon = len(xy0) >= 3 and polygon_area(xy0) > 1e-6 * (size / 0.045) ** 2
        if polygon:
            members = [members[j] for j in hull_order(xy0)]
        links.append({"n": members, "poly": bool(polygon), "color": LINK_COLORS[color % len(LINK_COLORS)]})
    angle_list: list = []

    def angle(values) -> int:
        angle_list.append(_angles(values))
        return len(angle_list) - 1

    levers = [{"t": traj(lambda f, k=k: f.levers[k][1]),
               "a": angle([math.atan2(f.levers[k][2][1], f.levers[k][2][0]) for f in frames]),
               "len": _num(style.lever_len[v])}
              for k, (v, *_rest) in enumerate(f0.levers)]
    guides = [{"t": traj(lambda f, k=k: f.guides[k][1]),
               "a": angle([math.atan2(f.guides[k][2][1], f.guides[k][2][0]) for f in frames])}
              for k, g in enumerate(f0.guides) if not g[3]]
    blocks = []
    for k, (p, _) in enumerate(f0.blocks):
        t = traj(lambda f, k=k: f.blocks[k][0])
        side = [_nums(guide_side[g[0]]) for g in f0.guides
                if g[0] in guide_side and np.linalg.norm(np.asarray(g[1]) - p) < 1e-9 * ck.scale]
        blocks.append({"t": t, "a": angle([f.blocks[k][1] for f in frames]), "side": side})
    paths = [np.array([f.joints[k] for f in frames], dtype=float) for k in range(len(f0.joints))]
    joints = list(dict.fromkeys(table.add(a) for a in sorted(paths, key=_sort_key)))
    labels = []
    for k in canonical(f0.labels, lambda k: (str(f0.labels[k][1]), _sort_key(f0.labels[k][0]))):
        labels.append({"t": traj(lambda f, k=k: f.labels[k][0]), "text": str(f0.labels[k][1])})
    # what is attached at each label (the page puts the label in the freest direction)
    for lab in labels:
        t = lab["t"]
        lab["nb"] = sorted({m for link in links if t in link["n"] for m in link["n"] if m != t})
        lab["lev"] = [lv["a"] for lv in levers if lv["t"] == t]
        lab["blk"] = [b["a"] for b in blocks if b["t"] == t]
        lab["dirs"] = [d for b in blocks if b["t"] == t for d in b["side"]]
        for pv in pivots:
            if pv["t"] == t:
                u = np.array(pv["u"])
                n = np.array([-u[1], u[0]])
                lab["dirs"] += [_nums(u), _nums(unit_vector(u + n)), _nums(unit_vector(u - n))]
        p0 = np.asarray(table.items[t][:2], dtype=float)
        for a, b in f0.ground_lines:
            a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
            for here, there in ((a, b), (b, a)):
                if np.linalg.norm(here - p0) < 1e-9 * ck.scale < np.linalg.norm(there - p0):
                    lab["dirs"].append(_nums(unit_vector(there - here)))
    # the named points: the contract's [data-point] circles, at the sweep's own coordinates
    cols = sweep.columns
    points = []
    joint_set = set(joints)
    for j, name in enumerate(ck.points):
        xy = np.column_stack([cols[f"{name}_x"], cols[f"{name}_y"]])
        t = table.add(xy)
        good = np.isfinite(xy).all(axis=1)
        moves = bool(good.sum() > 1 and np.ptp(xy[good], axis=0).max() > 1e-9 * ck.scale)
        pin = any(_close(table.items[t], table.items[jt], 1e-7 * ck.scale) for jt in joint_set)
        # points that always coincide (a pin and the block on it) share one path
        path = next((q["path"] for q in points if _close(table.items[q["t"]], table.items[t], 1e-7 * ck.scale)), j)
        points.append({"name": name, "t": t, "pin": pin, "moves": moves, "path": path})
    from .pairdraw import page_shapes

    pairs = page_shapes(sweep, table.add, angle)  # gears, cams and followers, slots
    lo, hi = np.asarray(style.lo, dtype=float), np.asarray(style.hi, dtype=float)
    for shape in pairs:  # a cam's profile reaches past its centre's trajectory
        if shape["k"] == "rot":
            reach = float(np.max(np.hypot(shape["p"][0::2], shape["p"][1::2])))
            c = np.asarray(table.items[shape["t"]], dtype=float).reshape(-1, 2)
            lo, hi = np.fmin(lo, np.nanmin(c, axis=0) - reach), np.fmax(hi, np.nanmax(c, axis=0) + reach)
        elif shape["k"] == "circle":
            c = np.asarray(table.items[shape["t"]], dtype=float).reshape(-1, 2)
            lo, hi = np.fmin(lo, np.nanmin(c, axis=0) - shape["r"]), np.fmax(hi, np.nanmax(c, axis=0) + shape["r"])
    for flat in table.items:
        xy = np.array([math.nan if v is None else v for v in flat], dtype=float).reshape(-1, 2)
        if np.isfinite(xy).any():
            lo, hi = np.fmin(lo, np.nanmin(xy, axis=0)), np.fmax(hi, np.nanmax(xy, axis=0))
    pad = 2.6 * size
    extent = _nums([lo - pad, hi + pad])
    return {"size": _num(size), "extent": extent, "traj": table.items, "angles": angle_list,
            "static": statics, "links": links, "levers": levers, "guides": guides, "blocks": blocks,
            "joints": joints, "labels": labels, "points": points, "unit": ck.mechanism.units.length,
            "pairs": pairs}


def _close(a: list, b: list, tol: float) -> bool:
    """Two shipped trajectories are the same path (a fixed one is two numbers)."""
    if len(a) != len(b):
        if len(a) == 2 or len(b) == 2:
            fixed, other = (a, b) if len(a) == 2 else (b, a)
            return all(o is not None and abs(o - fixed[i % 2]) <= tol for i, o in enumerate(other))
        return False
    return all(x is not None and y is not None and abs(x - y) <= tol for x, y in zip(a, b))


# ------------------------------------------------------------------------------ the data
def _event_rows(x: np.ndarray, events) -> list[int]:
    """The row of each event: the first row after the previous event's where the input is nearest."""
    rows, start = [], 0
    good = np.isfinite(x)
    dx = np.abs(np.diff(x[good])) if good.sum() > 1 else np.array([0.0])
    step = float(np.median(dx)) if dx.size else 0.0
    for ev in events:
        if not len(x):
            break
        d = np.abs(x[start:] - ev.input)
        d = np.where(np.isfinite(d), d, np.inf)
        if not np.isfinite(d).any():
            rows.append(start)
            continue
        hit = int(np.argmax(d <= d.min() + 0.51 * step))
        rows.append(start + hit)
        start += hit
    return rows


def force_series(sweep) -> dict:
    """The driving torque (or force) per row when the model declares mass properties, else ``{}``.

    A page of a model with ``[bodies]`` plots it next to the chosen variables (the default
    ``extra_series`` of :func:`to_html`); pass ``extra_series={}`` to leave it out.

    Examples
    --------
    >>> from loopsolve.output.view import force_series
    >>> sw = ls.load(ls.models_dir() / "thesis_crank_rocker_dynamics.toml").sweep(0, 360, 90)
    >>> [(k, len(v)) for k, v in force_series(sw).items()]
    [('input_torque [N*m]', 5)]
    >>> force_series(ls.load(ls.models_dir() / "thesis_crank_rocker.toml").sweep(0, 360, 90))
    {}
    """
    if getattr(sweep.mechanism, "dynamics", None) is None or len(sweep) == 0:
        return {}
    from ..dynamics.kinetostatics import force_analysis

    fs = force_analysis(sweep)
    unit = "N*m" if fs.drive_name == "input_torque" else "N"
    return {f"{fs.drive_name} [{unit}]": np.asarray(fs.drive, dtype=float)}


def page_data(sweep, vars=None, *, extra_series=None, title=None) -> dict:
    """Everything the page shows, as plain JSON-ready data (see :func:`to_html` for the arguments).

    ``input`` (the driving variable's values per row), ``series`` (each chosen variable's
    position — angles as in the table, continuous along the rows —, velocity and acceleration), ``extra``, ``events`` (with the
    row each is marked at), ``modes`` (runs of rows in one assembly mode, the unknowns of each
    part) and ``scene`` (point trajectories in model units and the shapes that refer to them).

    Examples
    --------
    >>> from loopsolve.output.view import page_data
    >>> sw = ls.load(ls.models_dir() / "double_rocker.toml").sweep(60, 180, 10, through_limits=True)
    >>> data = page_data(sw)
    >>> data["rows"] == len(sw), [s["name"] for s in data["series"]]
    (True, ['theta3', 'theta4'])
    >>> [(e["kind"], round(e["input"], 2)) for e in data["events"]]
    [('limit', 71.79), ('mode-change', 71.79)]
    >>> [run[2] for run in data["modes"]["runs"]]
    ['-', '+']
    """
    ck = sweep.compiled
    n = len(sweep)
    if n == 0:
        raise ModelError("cannot make a page of an empty sweep (no solved positions)")
    names = plot_vars(sweep, vars)
    units = sweep.units()
    cols = sweep.columns
    inp = ck.inputs[0]
    x = np.asarray(cols[inp], dtype=float)
    series = []
    for name in names:
        unit = units[name]
        angular = name in ck.variables and unit in ("deg", "rad")
        pos = cols[name]  # angles continuous along the rows, as in the table
        period = 0  # the readout shows the table's value (continuous), not a re-wrapped one
        series.append({"name": name, "label": _pretty_name(name), "unit": _pretty_unit(unit),
                       "units": [_pretty_unit(units[name + s]) for s in ("", "_vel", "_acc")],
                       "angular": angular, "wrap": period,
                       "q": [_nums(pos), _nums(cols[name + "_vel"]), _nums(cols[name + "_acc"])]})
    if extra_series is None:
        extra_series = force_series(sweep)
    extras = []
    for key, values in extra_series.items():
        values = np.asarray(values, dtype=float).ravel()
        if values.shape != (n,):
            raise ModelError(f"extra series {key!r} has {values.size} values; the sweep has {n} rows")
        m = re.fullmatch(r"\s*(.*?)\s*\[(.*)\]\s*", str(key))
        name, unit = (m.group(1), m.group(2)) if m else (str(key), "")
        extras.append({"name": name, "label": _pretty_name(name), "unit": _pretty_unit(unit), "q": [_nums(values)]})
    events = []
    for ev, row in zip(sweep.events, _event_rows(x, sweep.events)):
        color, dash = _EVENT_COLORS.get(ev.kind.value, ("#000000", "6 3"))
        events.append({"kind": ev.kind.value, "input": _num(ev.input), "row": row, "message": ev.message,
                       "color": color, "dash": dash})
    modes = list(sweep.modes)
    runs = []
    for i, m in enumerate(modes):
        if runs and runs[-1][2] == m:
            runs[-1][1] = i
        else:
            runs.append([i, i, m])
    mech = ck.mechanism
    aliases = {sig: mode_label(mech, sig) for sig in dict.fromkeys(modes) if sig}
    parts = [[_pretty_name(ck.unknowns[u]) for u in b.unknowns] for b in ck.blocks]
    return {
        "title": title or mech.name,
        "rows": n,
        "input": {"name": inp, "label": _pretty_name(inp), "unit": _pretty_unit(units[inp]), "x": _nums(x),
                  "units": [_pretty_unit(units[inp + s]) for s in ("", "_vel", "_acc")],
                  "vel": _nums(cols[inp + "_vel"]), "acc": _nums(cols[inp + "_acc"])},
        "series": series,
        "extra": extras,
        "events": events,
        "modes": {"runs": runs, "labels": aliases, "parts": parts, "changes": len(runs) > 1},
        "scene": _scene(sweep),
    }


# ------------------------------------------------------------------------------ the page
def _asset(name: str) -> str:
    return resources.files(__package__).joinpath(name).read_text(encoding="utf-8")


def _script_json(data) -> str:
    """JSON safe inside a ``<script>`` element (no ``</``, no ``<!--``)."""
    text = json.dumps(data, separators=(",", ":"), ensure_ascii=False, allow_nan=False)
    return text.replace("<", "\\u003c").replace("\u2028", "\\u2028").replace("\u2029", "\\u2029")


def to_html(sweep, vars=None, *, extra_series=None, title=None) -> str:
    """The interactive page of a sweep: one self-contained HTML document (no network access).

    Parameters
    ----------
    sweep : Sweep
        A sweep (:func:`loopsolve.sweep`, :meth:`Mechanism.sweep`).
    vars : sequence of str, optional
        Variables (``theta3``), points (``C``: both coordinates) or point coordinates
        (``C_x``) to plot against the input. Default: the unknowns.
    extra_series : mapping of str to array, optional
        More quantities to plot and tabulate, one value per row, keyed ``"name [unit]"``
        (for example ``{"input_torque [N*m]": tau}``). Default: the driving torque (force) of
        the force analysis when the model declares ``[bodies]`` (:func:`force_series`), else none.
    title : str, optional
        The page's title; default the mechanism's name.

    Returns
    -------
    str
        The page. The same sweep always gives the same text.

    Raises
    ------
    ModelError
        An unknown variable name, an extra series of the wrong length, or an empty sweep.

    Examples
    --------
    >>> from loopsolve.output.view import to_html
    >>> sw = ls.load(ls.models_dir() / "thesis_crank_rocker.toml").sweep(0, 360, 30)
    >>> page = to_html(sw)
    >>> page.startswith("<!DOCTYPE html>"), 'id="loopsolve-input"' in page, "http" in page.split("<script")[0]
    (True, True, False)
    >>> page == sw.to_html()
    True
    """
    data = page_data(sweep, vars, extra_series=extra_series, title=title)
    from .. import __version__

    n = data["rows"]
    return (
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
        "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
        f"<meta name=\"generator\" content=\"loopsolve {html.escape(__version__)}\">\n"
        f"<title>{html.escape(data['title'])} · loopsolve</title>\n"
        f"<style>\n{_asset('view.css')}</style>\n</head>\n<body>\n"
        "<div id=\"ls-app\">\n"
        f"<header><h1>{html.escape(data['title'])}</h1><div id=\"ls-status\"></div></header>\n"
        "<div id=\"ls-controls\">"
        "<button id=\"ls-play\" type=\"button\" title=\"play / pause (space)\">▶</button>"
        "<label class=\"ls-speed\">speed <select id=\"ls-speed\">"
        + "".join(f"<option value=\"{s}\"{' selected' if s == '1' else ''}>{s}×</option>"
                  for s in ("0.25", "0.5", "1", "2", "4"))
        + "</select></label>"
        "<div class=\"ls-slider\">"
        f"<input type=\"range\" id=\"loopsolve-input\" min=\"0\" max=\"{n - 1}\" step=\"1\" value=\"0\" "
        "aria-label=\"row of the sweep\">"
        "<svg id=\"ls-marks\" aria-hidden=\"true\"></svg></div>"
        "<span id=\"ls-row\"></span></div>\n"
        "<main>\n<section id=\"ls-diagram-box\"><svg id=\"ls-diagram\" role=\"img\" "
        f"aria-label=\"kinematic diagram of {html.escape(data['title'])}\"></svg>"
        "<div id=\"ls-legend\"></div></section>\n"
        "<aside><div id=\"ls-tabs\"></div><div id=\"ls-plots\"></div>"
        "<table id=\"ls-values\"></table><ul id=\"ls-events\"></ul></aside>\n</main>\n"
        "<footer>← → step · shift ×10 · Home/End · space play/pause · made with loopsolve</footer>\n"
        "</div>\n"
        f"<script type=\"application/json\" id=\"ls-data\">{_script_json(data)}</script>\n"
        f"<script>\n{_asset('view.js')}</script>\n</body>\n</html>\n")


def write_html(sweep, output, vars=None, *, extra_series=None, title=None) -> Path:
    """Write the page of :func:`to_html` to ``output`` (``.html`` or ``.htm``) and return its path.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from loopsolve.output.view import write_html
    >>> sw = ls.load(ls.models_dir() / "example1_slider_crank.toml").sweep(0, 360, 30)
    >>> out = write_html(sw, pathlib.Path(tempfile.mkdtemp()) / "slider.html")
    >>> out.read_text(encoding="utf-8") == sw.to_html()
    True
    """
    check_output(output)
    text = to_html(sweep, vars, extra_series=extra_series, title=title)
    from ..model.files import write_text

    write_text(output, text, ())
    return Path(output)


def check_output(output) -> None:
    """Raise :class:`ModelError` unless ``output`` names an ``.html``/``.htm`` file (checked before a sweep).

    Examples
    --------
    >>> from loopsolve.output.view import check_output
    >>> check_output("page.HTML")
    >>> check_output("page.png")
    Traceback (most recent call last):
    ...
    loopsolve.errors.ModelError: cannot write the page to 'page.png': the file name must end in .html
    """
    if Path(output).suffix.lower() not in (".html", ".htm"):
        raise ModelError(f"cannot write the page to {str(output)!r}: the file name must end in .html")


class Page:
    """A page shown inline by Jupyter (in an isolated frame), or saved with :meth:`~loopsolve.output.view.Page.save`.

    ``html`` is the whole document (:func:`~loopsolve.output.view.to_html`).

    Parameters
    ----------
    html_text : str
        The whole HTML document.
    height : int, optional
        Height of the inline frame in a notebook (pixels; default 760).

    Attributes
    ----------
    html : str
        The whole document (as :meth:`loopsolve.Sweep.to_html` gives).
    height : int
        As the parameter.

    Examples
    --------
    >>> sw = ls.load(ls.models_dir() / "thesis_crank_rocker.toml").sweep(0, 360, 30)
    >>> page = sw.view()
    >>> page.html == sw.to_html(), page._repr_html_().startswith("<iframe")
    (True, True)
    """

    __slots__ = ("html", "height")

    def __init__(self, html_text: str, height: int = 760):
        self.html = html_text
        self.height = int(height)

    def _repr_html_(self) -> str:
        return (f"<iframe srcdoc=\"{html.escape(self.html, quote=True)}\" sandbox=\"allow-scripts\" "
                f"style=\"width:100%;height:{self.height}px;border:1px solid #ddd;border-radius:4px\" "
                "title=\"loopsolve interactive page\"></iframe>")

    def save(self, output) -> Path:
        """Write the page to a ``.html`` file."""
        check_output(output)
        path = Path(output)
        path.write_text(self.html, encoding="utf-8")
        return path

    def __repr__(self) -> str:
        return f"<loopsolve page, {len(self.html)} characters>"
