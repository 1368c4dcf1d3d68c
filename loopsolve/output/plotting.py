"""Pictures: sweep plots, kinematic diagrams and animations (matplotlib + Pillow, the ``plot`` extra).

Nothing here runs at import time: matplotlib is imported inside the functions, and figures
are made with the object-oriented API on an Agg canvas (``matplotlib.figure.Figure``), so
the global pyplot state and backend of the caller (a script, a notebook) are never touched.

This module only renders. What is drawn for a pose (links, joints, ground pivots, blocks on
guides, slotted levers, labels, vector arrows) and the style shared by the frames of a
picture come from :mod:`loopsolve.output.geometry`, which the interactive page
(:mod:`loopsolve.output.view`) uses too.
"""

from __future__ import annotations

import math
import re
import shutil
import sys
from pathlib import Path

import numpy as np

from ..errors import LoopsolveError, MissingDependencyError, ModelError
from .drawstyle import Style, arrow_label_sides, drawing_style, label_placements
from .geometry import LINK_COLORS, Frame, hull_order, mode_label, plot_vars, polygon_area, pose_frames

__all__ = ["plot_sweep", "draw", "animate", "check_output", "tex_name", "FIGURE_FORMATS", "ANIMATION_FORMATS"]

#: image formats of :func:`plot_sweep` and :func:`draw` (by file suffix)
FIGURE_FORMATS = ("png", "svg", "pdf")
#: formats of :func:`animate` (MP4 needs the ffmpeg program)
ANIMATION_FORMATS = ("gif", "mp4")

_EXTRA = "pip install 'loopsolve[plot]'"
_GREEK = ("alpha", "beta", "gamma", "delta", "epsilon", "zeta", "eta", "theta", "iota", "kappa", "lambda",
          "mu", "nu", "xi", "pi", "rho", "sigma", "tau", "upsilon", "phi", "chi", "psi", "omega")
_EVENT_STYLE = {"limit": ("tab:red", "--"), "singular": ("tab:orange", "-."),
                "not-assemblable": ("0.4", ":"), "mode-change": ("tab:purple", "--")}


# ----------------------------------------------------------------------------------- imports
def _matplotlib():
    """Import matplotlib (and check Pillow) or raise :class:`MissingDependencyError`."""
    try:
        import matplotlib
        from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: F401
        from matplotlib.figure import Figure  # noqa: F401
    except ImportError as exc:
        raise MissingDependencyError(
            f"plots, diagrams and animations need matplotlib ({exc}); install the plot extra: {_EXTRA}") from None
    try:
        import PIL  # noqa: F401
    except ImportError as exc:
        raise MissingDependencyError(
            f"plots, diagrams and animations need Pillow ({exc}); install the plot extra: {_EXTRA}") from None
    return matplotlib


def new_figure(figsize):
    """A matplotlib figure of size ``figsize`` (inches) on the Agg canvas, constrained layout."""
    _matplotlib()
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _format_of(output, allowed: tuple[str, ...], what: str) -> str:
    suffix = Path(output).suffix.lower().lstrip(".")
    if suffix not in allowed:
        raise ModelError(f"cannot write {what} to {str(output)!r}: the file name must end in "
                         + ", ".join("." + a for a in allowed))
    return suffix


def check_output(output, what: str = "figure") -> str:
    """Check, before any work, that ``output`` can be written as a ``"figure"`` or ``"animation"``.

    Returns the format (the lower-case suffix). Raises :class:`ModelError` for an unsupported
    suffix and :class:`MissingDependencyError` when matplotlib/Pillow (or ffmpeg for an MP4)
    is missing, so the command line fails fast instead of after a long sweep.

    Examples
    --------
    >>> from loopsolve.output.plotting import check_output
    >>> check_output("crank.svg"), check_output("crank.GIF", "animation")
    ('svg', 'gif')
    >>> check_output("crank.jpg")
    Traceback (most recent call last):
    ...
    loopsolve.errors.ModelError: cannot write a figure to 'crank.jpg': the file name must end in .png, .svg, .pdf
    """
    if what not in ("figure", "animation"):
        raise ModelError(f"what must be 'figure' or 'animation', not {what!r}")
    fmt = _format_of(output, FIGURE_FORMATS if what == "figure" else ANIMATION_FORMATS, f"a{'n' * (what[0] == 'a')} "
                     + what)
    _matplotlib()
    if fmt == "mp4" and shutil.which("ffmpeg") is None:
        raise MissingDependencyError(
            "writing an MP4 needs the ffmpeg program on the PATH; install ffmpeg or write a .gif instead")
    return fmt


def save_figure(fig, output, *, dpi=150) -> None:
    """Write ``fig`` to ``output`` in the format its extension names (a loopsolve error if it cannot)."""
    fmt = _format_of(output, FIGURE_FORMATS, "a figure")
    try:
        fig.savefig(output, format=fmt, dpi=dpi)
    except OSError as exc:
        raise LoopsolveError(f"cannot write {str(output)!r}: {exc.strerror or exc}") from None


# ------------------------------------------------------------------------------------- names
def tex_name(name: str) -> str:
    """A variable, point or vector name as matplotlib mathtext: ``theta2`` → ``$\\theta_{2}$``.

    Greek-letter names become the letter; a trailing number or upper-case tag
    (``theta2``, ``rAB``) or anything after the first underscore (``C_x``, ``theta_crank``)
    becomes a subscript. Names that fit none of these are returned unchanged.

    Examples
    --------
    >>> from loopsolve.output.plotting import tex_name
    >>> tex_name("theta2"), tex_name("rAB"), tex_name("C_x"), tex_name("s")
    ('$\\\\theta_{2}$', '$r_{AB}$', '$C_{x}$', '$s$')
    >>> tex_name("theta_crank"), tex_name("r_ground_O2"), tex_name("omega")
    ('$\\\\theta_{\\\\mathrm{crank}}$', '$r_{\\\\mathrm{ground\\\\_O2}}$', '$\\\\omega$')
    """
    def base_tex(base: str) -> str:
        return "\\" + base if base in _GREEK else base

    if "_" in name:
        base, sub = name.split("_", 1)
        if re.fullmatch(r"[A-Za-z]+", base) and re.fullmatch(r"[A-Za-z0-9_]+", sub):
            sub = sub if len(sub) == 1 or sub.isdigit() else "\\mathrm{" + sub.replace("_", "\\_") + "}"
            return f"${base_tex(base)}_{{{sub}}}$"
        return name
    m = re.fullmatch(r"([A-Za-z]+?)([0-9]+[A-Za-z]*|[A-Z][A-Z0-9]*)", name)
    if m and (m.group(1) in _GREEK or len(m.group(1)) == 1):
        return f"${base_tex(m.group(1))}_{{{m.group(2)}}}$"
    if name in _GREEK:
        return f"${base_tex(name)}$"
    if re.fullmatch(r"[A-Za-z]", name):
        return f"${name}$"
    return name


# ------------------------------------------------------------------------------------- plots
def _pretty_unit(unit: str) -> str:
    """``rad/s^2`` → ``rad/s²`` for axis labels."""
    return unit.replace("^2", "\u00b2").replace("^3", "\u00b3")


def _angle_ticks(ax, lo: float, hi: float, unit: str) -> None:
    if unit != "deg" or not np.isfinite([lo, hi]).all() or hi - lo < 90:
        return
    from matplotlib.ticker import MultipleLocator

    for step in (15, 30, 45, 90, 180, 360):
        if (hi - lo) / step <= 12:
            ax.xaxis.set_major_locator(MultipleLocator(step))
            return


def _rate_note(sweep) -> str:
    if not len(sweep):
        return ""
    ck = sweep.compiled
    name = ck.inputs[0]
    units = sweep.units()
    st = sweep.states[0]
    i = ck.index(name)
    vel, acc = float(st.z1[i]), float(st.z2[i])
    if vel == 1.0 and acc == 0.0:
        return f"rates per unit input speed ({tex_name(name)} at 1 {units[name + '_vel']})"
    note = f"{tex_name(name)} speed {vel:.4g} {units[name + '_vel']}"
    if acc:
        note += f", acceleration {acc:.4g} {units[name + '_acc']}"
    return note


def plot_sweep(sweep, vars=None, *, output=None):
    """Positions, velocities and accelerations of the chosen variables against the input.

    One column of panels per unit (angles and lengths are never mixed on an axis), three
    rows: position, velocity, acceleration. Angles are the table's (continuous along the rows,
    the first in (−180°, 180°]); limit, singular, not-assemblable and mode-change events of the sweep
    are marked with vertical lines.

    Parameters
    ----------
    sweep : Sweep
        A sweep (:func:`loopsolve.sweep`, :meth:`Mechanism.sweep`).
    vars : sequence of str, optional
        Variables (``theta3``), points (``C``: both coordinates) or point coordinates
        (``C_x``). Default: the unknowns.
    output : str or Path, optional
        Also write the figure to this file (``.png``, ``.svg`` or ``.pdf``).

    Returns
    -------
    matplotlib.figure.Figure

    Raises
    ------
    MissingDependencyError
        matplotlib or Pillow is not installed (``pip install 'loopsolve[plot]'``).
    ModelError
        An unknown variable name or an unsupported file suffix.

    Examples
    --------
    >>> from loopsolve.output.plotting import plot_sweep
    >>> sw = ls.load(ls.models_dir() / "thesis_crank_rocker.toml").sweep(0, 360, 10)
    >>> fig = plot_sweep(sw, ["theta3", "theta4"])
    >>> [ax.get_ylabel() for ax in fig.axes]
    ['angle [deg]', 'angular velocity [rad/s]', 'angular acceleration [rad/s²]']
    """
    names = plot_vars(sweep, vars)
    ck = sweep.compiled
    units = sweep.units()
    cols = sweep.columns
    x = cols[ck.inputs[0]]
    x_unit = units[ck.inputs[0]]
    groups: dict[str, list[str]] = {}
    for n in names:
        groups.setdefault(units[n], []).append(n)
    fig = new_figure((6.4 * len(groups) if len(groups) > 1 else 7.5, 8.0))
    axes = fig.subplots(3, len(groups), sharex=True, squeeze=False)
    suffixes = ("", "_vel", "_acc")
    breaks, at_limit = _branch_breaks(sweep, x)
    for c, (unit, members) in enumerate(groups.items()):
        angular = unit in ("deg", "rad")
        titles = (("angle", "angular velocity", "angular acceleration") if angular else
                  ("position", "velocity", "acceleration"))
        for r, suffix in enumerate(suffixes):
            ax = axes[r, c]
            for k, n in enumerate(members):
                y = np.array(cols[n + suffix], dtype=float)  # angles continuous as in the table
                if r > 0:  # at a limit position the rates are unbounded: no value there
                    y[at_limit] = np.nan
                style = "-o" if len(x) < 40 else "-"
                xs, ys = _broken(x, y, breaks)
                ax.plot(xs, ys, style, ms=3, lw=1.6, color=f"C{k}", label=tex_name(n))
            ax.set_ylabel(f"{titles[r]} [{_pretty_unit(units[members[0] + suffix])}]")
            ax.grid(True, alpha=0.35)
            lo, hi = ax.dataLim.intervaly
            if lo < 0 < hi:
                ax.axhline(0.0, color="0.6", lw=0.6, zorder=0)
            _mark_events(ax, sweep.events, legend=(r == 0 and c == 0))
            if r == 0:
                entries = len(members) + len({e.kind for e in sweep.events})
                ax.legend(loc="best", fontsize=9, ncols=1 if entries <= 3 else 2, framealpha=0.85)
        axes[-1, c].set_xlabel(f"{tex_name(ck.inputs[0])} [{_pretty_unit(x_unit)}]")
        if len(x):
            _angle_ticks(axes[-1, c], float(np.nanmin(x)), float(np.nanmax(x)), x_unit)
    modes = [m for m in dict.fromkeys([sweep.mode] + [st.mode for st in sweep.states]) if m]
    mode = (", mode " + " → ".join(mode_label(ck.mechanism, m) for m in modes)) if modes else ""
    fig.suptitle(f"{ck.mechanism.name}{mode}\n{_rate_note(sweep)}", fontsize=11)
    if output is not None:
        save_figure(fig, output)
    return fig


def _branch_breaks(sweep, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where the plotted lines must not join consecutive rows, and the rows at a limit position.

    Rows on different assembly modes are two branches: a line between them would be a jump
    that the linkage never makes. They meet only through a row at the limit position (or mode
    change) where the sweep turned, which then belongs to both branches. ``breaks[i]`` is true
    when rows ``i`` and ``i + 1`` are not joined; ``at_limit[i]`` when row ``i`` sits at a limit
    event (where the rates are unbounded).
    """
    n = len(x)
    modes = list(getattr(sweep, "modes", ())) or [st.mode for st in sweep.states]
    turns = [ev.input for ev in sweep.events if ev.kind.value in ("limit", "mode-change")]
    limits = [ev.input for ev in sweep.events if ev.kind.value == "limit"]
    scale = max(1.0, float(np.nanmax(np.abs(x)))) if n else 1.0

    def near(xi, values):
        return any(abs(xi - v) <= 1e-7 * scale for v in values)

    junction = np.array([near(float(xi), turns) for xi in x], dtype=bool)
    at_limit = np.array([near(float(xi), limits) for xi in x], dtype=bool)
    breaks = np.zeros(max(n - 1, 0), dtype=bool)
    for i in range(n - 1):
        a, b = modes[i] if i < len(modes) else "", modes[i + 1] if i + 1 < len(modes) else ""
        if a and b and a != b and not (junction[i] or junction[i + 1]):
            breaks[i] = True
    return breaks, at_limit


def _broken(x: np.ndarray, y: np.ndarray, breaks: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``x``, ``y`` with a NaN between the rows that must not be joined (matplotlib lifts the pen there)."""
    if not breaks.any():
        return x, y
    cut = np.flatnonzero(breaks) + 1
    return (np.insert(np.asarray(x, dtype=float), cut, np.nan), np.insert(np.asarray(y, dtype=float), cut, np.nan))


def _mark_events(ax, events, *, legend: bool) -> None:
    seen = set()
    for ev in events:
        kind = ev.kind.value
        color, ls = _EVENT_STYLE.get(kind, ("k", "--"))
        label = f"{kind} at {ev.input:.4g}" if legend and kind not in seen else None
        seen.add(kind)
        ax.axvline(ev.input, color=color, ls=ls, lw=2.6 if kind == "limit" else 1.3, label=label,
                   zorder=1.5 if kind == "limit" else 2)


# ------------------------------------------------------------------------------ rendering

def _ground_symbol(ax, p, u, size, zorder=2):
    from matplotlib.patches import Polygon

    n = np.array([-u[1], u[0]])
    a, b = 1.1 * size, 0.75 * size
    base0, base1 = p + u * a - n * b, p + u * a + n * b
    out = [ax.add_patch(Polygon([p, base0, base1], closed=True, facecolor="white", edgecolor="k", lw=1.2,
                                zorder=zorder))]
    w = 1.45 * b
    strip = [p + u * a - n * w, p + u * a + n * w, p + u * (a + 0.45 * size) + n * w,
             p + u * (a + 0.45 * size) - n * w]
    out.append(ax.add_patch(Polygon(strip, closed=True, fill=False, hatch="////", lw=0, edgecolor="0.25",
                                    zorder=zorder)))
    out += ax.plot(*np.array([p + u * a - n * w, p + u * a + n * w]).T, color="k", lw=1.6, zorder=zorder)
    return out


def _render_static(ax, frame: Frame, style: Style):
    """Ground: hatched pivots, hatched guides and the (dashed) fixed vectors."""
    from matplotlib.patches import Polygon

    size = style.size
    out = []
    for p0, p1 in frame.ground_lines:
        out += ax.plot(*np.array([p0, p1]).T, color="0.55", lw=1.0, ls=(0, (6, 3)), zorder=1)
    for p, key in frame.pivots:
        out += _ground_symbol(ax, np.asarray(p), style.pivot_dir.get(key, np.array([0.0, -1.0])), size)
    ref = {g[0]: np.asarray(g[1], dtype=float) for g in frame.guides}
    for key, p, d, ground, tail in frame.guides:
        if not ground:
            continue
        lo_s, hi_s = style.guide_span[key]
        side = style.guide_side[key]
        h = 0.5 * size
        base = ref[key] + side * h
        g0, g1 = base + d * lo_s, base + d * hi_s
        out += ax.plot(*np.array([ref[key] + d * lo_s, ref[key] + d * hi_s]).T, color="0.5", lw=0.8,
                       ls=(0, (8, 3, 2, 3)), zorder=1)
        out += ax.plot(*np.array([g0, g1]).T, color="k", lw=1.6, zorder=2)
        if ground:
            strip = [g0, g1, g1 + side * 0.45 * size, g0 + side * 0.45 * size]
            out.append(ax.add_patch(Polygon(strip, closed=True, fill=False, hatch="////", lw=0,
                                            edgecolor="0.25", zorder=1)))
    return out


def _render_moving(ax, frame: Frame, style: Style, *, label_fixed: bool = True):
    from matplotlib.patches import Circle, Polygon

    size = style.size
    out = []
    for v, tail, d, _ in frame.levers:
        end = tail + d * style.lever_len[v]
        out += ax.plot(*np.array([tail, end]).T, color="#444444", lw=7.5, solid_capstyle="round", zorder=3,
                       alpha=0.9)
        out += ax.plot(*np.array([tail, end]).T, color="white", lw=2.0, zorder=3)  # the slot
    for key, xy, i in frame.links:
        color = LINK_COLORS[i % len(LINK_COLORS)]
        xy = np.asarray(xy, dtype=float)
        if len(xy) >= 3 and polygon_area(xy) > 1e-6 * (style.size / 0.045) ** 2:
            order = hull_order(xy)
            out.append(ax.add_patch(Polygon(xy[order], closed=True, facecolor=color, alpha=0.35, edgecolor=color,
                                            lw=2.5, joinstyle="round", zorder=4)))
        else:
            for a in range(len(xy)):
                for b in range(a + 1, len(xy)):
                    out += ax.plot(*xy[[a, b]].T, color=color, lw=4.5, solid_capstyle="round", zorder=4)
    for key, p, d, ground, tail in frame.guides:
        if not ground:  # a guide that moves (on a translating body): a line through the block
            ends = np.array([p - d * 3.0 * size, p + d * 3.0 * size])
            out += ax.plot(*ends.T, color="k", lw=1.6, zorder=3)
    for p, angle in frame.blocks:
        d = np.array([math.cos(angle), math.sin(angle)])
        n = np.array([-d[1], d[0]])
        a, b = 0.95 * size, 0.5 * size
        corners = [p - d * a - n * b, p + d * a - n * b, p + d * a + n * b, p - d * a + n * b]
        out.append(ax.add_patch(Polygon(corners, closed=True, facecolor="#f4d03f", edgecolor="k", lw=1.4,
                                        zorder=5)))
    for p in frame.joints:
        out.append(ax.add_patch(Circle(p, 0.22 * size, facecolor="white", edgecolor="k", lw=1.3, zorder=6)))
    for p, _ in frame.points:
        out.append(ax.add_patch(Circle(p, 0.16 * size, facecolor="k", edgecolor="k", zorder=6)))
    for tail, head, name in frame.arrows:
        out.append(ax.annotate("", xy=head, xytext=tail, zorder=7,
                               arrowprops=dict(arrowstyle="-|>", color="tab:blue", lw=1.4, shrinkA=0, shrinkB=0,
                                               mutation_scale=14)))
    for (tail, head, name), (mid, n) in zip(frame.arrows, arrow_label_sides(frame, style)):
        ha = "left" if n[0] > 0.35 else "right" if n[0] < -0.35 else "center"
        va = "bottom" if n[1] > 0.35 else "top" if n[1] < -0.35 else "center"
        out.append(ax.annotate(tex_name(name), mid, xytext=tuple(7 * n), textcoords="offset points",
                               ha=ha, va=va, color="tab:blue", fontsize=10, zorder=8,
                               bbox=dict(boxstyle="round,pad=0.08", fc="white", ec="none", alpha=0.7)))
    out += _labels(ax, frame, style)
    return out


def _labels(ax, frame: Frame, style: Style):
    """Joint and point names, each in the freest direction around its joint (data units)."""
    return [ax.text(*xy, text, fontsize=11, fontweight="bold", ha=ha, va=va, zorder=9,
                    bbox=dict(boxstyle="round,pad=0.12", fc="white", ec="none", alpha=0.75))
            for xy, text, ha, va in label_placements(frame, style)]


def _frame_axes(ax, style: Style, mech) -> None:
    pad = 2.6 * style.size
    lo, hi = style.lo - pad, style.hi + pad
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_aspect("equal", adjustable="box")
    unit = mech.units.length
    ax.set_xlabel(f"x [{unit}]")
    ax.set_ylabel(f"y [{unit}]")
    ax.grid(True, alpha=0.25)


def _pose_title(state) -> str:
    ck = state.compiled
    name = ck.inputs[0]
    unit = state.units()[name]
    mode = f", mode {mode_label(ck.mechanism, state.mode)}" if state.mode else ""
    return f"{ck.mechanism.name}\n{tex_name(name)} = {state.input_value:.4g} {_pretty_unit(unit)}{mode}"


def _figsize(style: Style, width: float = 7.0) -> tuple[float, float]:
    w, h = (style.hi - style.lo) + 5.2 * style.size
    ratio = float(h / w) if w > 0 else 1.0
    height = width * ratio + 1.0
    if height > 9.0:  # a tall mechanism: narrower figure rather than empty margins
        height = 9.0
        width = max(4.5, (height - 1.0) / ratio + 1.2)
    return width, float(max(height, 3.5))


def draw(mech, at=None, *, input=None, mode=None, vectors=False, output=None, ax=None, **solve_kwargs):
    """The kinematic diagram at one input value.

    Ground pivots are hatched, links are bars (a link with three or more joints is a filled
    polygon), sliders are blocks on their guides (hatched when the guide is fixed), joints
    are circles, points are labelled; with ``vectors=True`` the loop vectors are drawn as
    arrows with their names. Both axes have the same scale.

    Parameters
    ----------
    mech : Mechanism or State
        The mechanism (solved here at ``at``), or an already solved state.
    at : float or str, optional
        Input value (model units, or with a unit). Default: the input's guess.
    input : str, optional
        Drive this variable instead of the declared input.
    mode : str, optional
        Assembly mode (signature or alias).
    vectors : bool
        Draw the loop vectors as named arrows.
    output : str or Path, optional
        Also write the figure to this file (``.png``, ``.svg`` or ``.pdf``).
    ax : matplotlib.axes.Axes, optional
        Draw into these axes instead of a new figure.
    **solve_kwargs
        Passed on to :func:`loopsolve.solve` (``guess=``, ``speed=``...).

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> from loopsolve.output.plotting import draw
    >>> mech = ls.load(ls.models_dir() / "thesis_crank_rocker.toml")
    >>> fig = draw(mech, 60, vectors=True)
    >>> ax = fig.axes[0]
    >>> sorted(t.get_text() for t in ax.texts if t.get_text() in ("B", "C", "O2", "O4"))
    ['B', 'C', 'O2', 'O4']
    """
    from ..kinematics.results import State

    if isinstance(mech, State):
        state = mech
    else:
        state = mech.solve(at, input=input, mode=mode, **solve_kwargs)
    from .pairdraw import check_drawable

    check_drawable(state.mechanism)
    frames, _ = pose_frames([state], vectors=vectors)
    style = drawing_style(frames)
    if ax is None:
        fig = new_figure(_figsize(style))
        ax = fig.add_subplot()
    else:
        _matplotlib()
        fig = ax.figure
    _render_static(ax, frames[0], style)
    _render_moving(ax, frames[0], style)
    _frame_axes(ax, style, state.mechanism)
    from .pairdraw import draw_pairs

    draw_pairs(ax, state, pad=2.6 * style.size)  # gears, cams, slots
    ax.set_title(_pose_title(state), fontsize=11)
    if output is not None:
        save_figure(fig, output)
    return fig


# ------------------------------------------------------------------------------- animation
def _write_gif(fig, ax, render, n: int, output: Path, fps: float, dpi: int, bar) -> None:
    """Render ``n`` frames by blitting the moving artists over the static background; save with Pillow.

    The static part (axes, ground, dotted paths, legend) is drawn once; every frame restores it
    and draws only what moves. All frames share the palette of the first one (no flicker).
    """
    from PIL import Image

    fig.set_dpi(dpi)
    canvas = fig.canvas
    ax.title.set_animated(True)
    canvas.draw()  # lays out the figure once; the title is drawn per frame
    fig.set_layout_engine("none")
    background = canvas.copy_from_bbox(fig.bbox)
    images = []
    palette = None
    for i in range(n):
        canvas.restore_region(background)
        live = render(i, blit=True)
        rgb = Image.fromarray(np.asarray(canvas.buffer_rgba())[..., :3].copy())
        if palette is None:
            palette = rgb.quantize(colors=255, method=Image.Quantize.MEDIANCUT)
            images.append(palette)
        else:
            images.append(rgb.quantize(palette=palette, dither=Image.Dither.NONE))
        for artist in live:
            artist.remove()
        if bar is not None:
            bar.update(1)
    images[0].save(output, format="GIF", save_all=True, append_images=images[1:], loop=0,
                   duration=max(1, int(round(1000.0 / fps))), disposal=1)


def _progress_bar(total: int, progress):
    if progress is False or (progress is None and not sys.stderr.isatty()):
        return None
    try:
        from tqdm import tqdm
    except ImportError:
        return None
    return tqdm(total=total, unit="frame", desc="rendering", file=sys.stderr, leave=False)


#: most frames an animation renders unless the caller raises it (``max_frames=``, ``--max-frames``)
MAX_FRAMES = 3600


def check_frames(n: int, max_frames: int | None = MAX_FRAMES) -> None:
    """Refuse an animation of ``n`` frames above ``max_frames`` before anything is rendered.

    Examples
    --------
    >>> from loopsolve.output.plotting import check_frames
    >>> check_frames(361)
    >>> check_frames(360001)
    Traceback (most recent call last):
    ...
    loopsolve.errors.ModelError: the animation would have 360001 frames, more than the cap of 3600: use a larger --step (or a shorter --from/--to range), or raise the cap with --max-frames 360001 (max_frames= in Python)
    """
    if max_frames is None:
        return
    if not isinstance(max_frames, int) or isinstance(max_frames, bool) or max_frames < 1:
        raise ModelError(f"max_frames must be a positive whole number, not {max_frames!r}")
    if n > max_frames:
        raise ModelError(f"the animation would have {n} frames, more than the cap of {max_frames}: use a larger "
                         f"--step (or a shorter --from/--to range), or raise the cap with --max-frames {n} "
                         "(max_frames= in Python)")


def frames_before_sweep(mech, start, stop, step, *, input=None, mode=None) -> int | None:
    """Number of frames an animation of the sweep ``start`` → ``stop`` by ``step`` has at least.

    Counted from the grid before any sweep (``None`` when it cannot be known yet: a default
    range that is not a full turn). Without ``start``/``stop`` the range is the command's
    default: a full turn of an angle input when the linkage assembles at 0.

    Examples
    --------
    >>> from loopsolve.output.plotting import frames_before_sweep
    >>> frames_before_sweep(ls.fourbar(60, 25, 70, 45), None, None, "0.001")
    360001
    >>> frames_before_sweep(ls.fourbar(60, 25, 70, 45), "0", "90", "1")
    91
    """
    from ..errors import LoopsolveError
    from ..kinematics.solve import display_value, input_value
    from ..model.units import Kind

    try:
        ck = mech.compile(input)
        h = abs(float(display_value(ck, input_value(ck, step))))
        if start is not None and stop is not None:
            a, b = (float(display_value(ck, input_value(ck, v))) for v in (start, stop))
        else:
            if ck.kinds[ck.input_idx[0]] is not Kind.ANGLE:
                return None
            mech.solve(0, input=input, mode=mode)
            turn = float(display_value(ck, 2 * math.pi))
            a = 0.0 if start is None else float(display_value(ck, input_value(ck, start)))
            b = a + turn if stop is None else float(display_value(ck, input_value(ck, stop)))
    except (LoopsolveError, TypeError, ValueError, OverflowError):
        return None  # the sweep itself reports what is wrong
    if not (h > 0 and math.isfinite(h) and math.isfinite(a) and math.isfinite(b)):
        return None
    return int(math.floor(abs(b - a) / h * (1 + 1e-12) + 1e-9)) + 1


def animate(sweep, *, output, fps: float = 20, progress=None, vectors: bool = False, dpi: int = 100,
            max_frames: int | None = MAX_FRAMES) -> Path:
    """The linkage moving over a sweep: one frame per output row, with the traces of the points.

    Writes a GIF with Pillow, or an MP4 with matplotlib's ffmpeg writer when the ``ffmpeg``
    program is on the PATH. A progress bar (tqdm) shows while frames render on a terminal.

    Parameters
    ----------
    sweep : Sweep
    output : str or Path
        ``.gif`` or ``.mp4`` file.
    fps : float
        Frames per second.
    progress : bool, optional
        Show a progress bar; default: when standard error is a terminal.
    vectors : bool
        Draw the loop vectors as named arrows in every frame.
    dpi : int
        Resolution of the frames (the figure is 7 inches wide).
    max_frames : int or None
        Refuse (before rendering) a sweep with more rows than this (default 3600); ``None``:
        no cap.

    Returns
    -------
    pathlib.Path
        The file written.

    Raises
    ------
    MissingDependencyError
        matplotlib or Pillow is missing, or ffmpeg for an MP4.
    ModelError
        The suffix is not ``.gif``/``.mp4``, ``fps`` is not positive, the sweep is empty or
        has more rows than ``max_frames``.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from loopsolve.output.plotting import animate
    >>> sw = ls.load(ls.models_dir() / "thesis_crank_rocker.toml").sweep(0, 360, 60)
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "crank.gif"
    >>> animate(sw, output=out, fps=5).name
    'crank.gif'
    >>> from PIL import Image
    >>> Image.open(out).n_frames == len(sw)
    True
    """
    fmt = check_output(output, "animation")
    if not (isinstance(fps, (int, float)) and fps > 0 and math.isfinite(fps)):
        raise ModelError(f"fps must be a positive number of frames per second, not {fps!r}")
    if not len(sweep):
        raise ModelError("cannot animate an empty sweep (no solved positions)")
    check_frames(len(sweep), max_frames)
    from .pairdraw import check_drawable

    check_drawable(sweep.mechanism)
    frames, _ = pose_frames(list(sweep.states), vectors=vectors)
    style = drawing_style(frames)
    fig = new_figure(_figsize(style))
    ax = fig.add_subplot()
    _render_static(ax, frames[0], style)
    _frame_axes(ax, style, sweep.mechanism)
    from .pairdraw import draw_pairs, pair_shapes, widen

    if sweep.mechanism.pairs is not None:  # room for the gears, cams and slots of every frame
        widen(ax, [s for st in sweep.states for s in pair_shapes(st)], 2.6 * style.size)
    # traces of every point that moves: the whole path dotted, the path so far solid
    ck = sweep.compiled
    paths = np.array([s.points[0] for s in sweep.states])  # (N, P, 2)
    moving = [j for j in range(paths.shape[1]) if np.ptp(paths[:, j, :], axis=0).max() > 1e-9 * ck.scale]
    for k, j in enumerate(moving):
        ax.plot(paths[:, j, 0], paths[:, j, 1], color=f"C{k}", lw=1.6, ls=":", alpha=0.8, zorder=1,
                label=f"path of {ck.points[j]}")
    if moving:
        ax.legend(loc="best", fontsize=8, framealpha=0.85)
    ax.set_title(_pose_title(sweep.states[0]), fontsize=11)
    bar = _progress_bar(len(frames), progress)
    output = Path(output)

    def render(i, blit: bool):
        artists = _render_moving(ax, frames[i], style) + draw_pairs(ax, sweep.states[i])
        for k, j in enumerate(moving):
            artists += ax.plot(paths[: i + 1, j, 0], paths[: i + 1, j, 1], color=f"C{k}", lw=1.8, zorder=2)
        ax.set_title(_pose_title(sweep.states[i]), fontsize=11)
        if blit:
            for artist in artists + [ax.title]:
                ax.draw_artist(artist)
        return artists

    try:
        if fmt == "gif":
            _write_gif(fig, ax, render, len(frames), output, fps, dpi, bar)
        else:
            from matplotlib.animation import FFMpegWriter

            writer = FFMpegWriter(fps=fps)
            with writer.saving(fig, str(output), dpi):
                for i in range(len(frames)):
                    live = render(i, blit=False)
                    writer.grab_frame()
                    if i == 0:  # freeze the layout: every frame has the same axes box
                        fig.set_layout_engine("none")
                    for artist in live:
                        artist.remove()
                    if bar is not None:
                        bar.update(1)
    except OSError as exc:
        raise LoopsolveError(f"cannot write {str(output)!r}: {exc.strerror or exc}") from None
    finally:
        if bar is not None:
            bar.close()
    return output
