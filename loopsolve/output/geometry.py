"""What a picture of a mechanism shows, as numbers: the drawing geometry (no matplotlib).

Both renderers use it: :mod:`loopsolve.output.plotting` (matplotlib figures and animations) and
:mod:`loopsolve.output.view` (the interactive HTML page). For every solved pose, :func:`pose_frames`
says what is drawn where (a :class:`Frame`); :mod:`loopsolve.output.drawstyle` derives from all the
frames of a picture how it is dressed (symbol sizes, sides of ground symbols, label places).

The kinematic diagram of a vector-loop model is its skeleton (:mod:`loopsolve.output.skeleton`: which
vector ends meet, what is ground, link or slider) placed at each solved pose: every named point at
its solved coordinates (what ``solve`` prints), wherever the model puts its frame, and the other
joints reached from those along the vectors. A link with three or more joints is drawn as a filled
polygon (a ternary link is a triangle); a slider is a block at its tip on a guide along it (a
fixed guide, hatched, when its angle is constant; a slotted lever when it rotates). Every named
point that is not a joint (a coupler point, a centre of mass) is a tracer: ``Frame.points``.

A model written as a kinematic diagram (``[joints]``/``[links]``, see :mod:`loopsolve.model.diagram`)
is drawn from its links and joints instead, when its ``spec`` still carries them.

Also here, for the plots against the input: which columns to plot (:func:`plot_vars`),
angles tracked continuously (:func:`unwrapped`, for wrapped data) and the names of assembly modes
(:func:`mode_label`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ModelError
from .skeleton import Structure, diagram_structure, node_positions

__all__ = ["LINK_COLORS", "Frame", "pose_frames", "polygon_area", "hull_order", "unit_vector", "plot_vars",
           "unwrapped", "mode_label"]

#: the colours of the links, in turn (a link's ``color`` index in its :class:`Frame` wraps around)
LINK_COLORS = ("#1f4e79", "#b03a2e", "#1e8449", "#7d3c98", "#b9770e", "#117a65", "#5d6d7e", "#a04000")


# ------------------------------------------------------------------------ plotted columns
def plot_vars(sweep, vars) -> list[str]:
    """The columns to plot for ``vars``: variables, both coordinates of points, point coordinates.

    Parameters
    ----------
    sweep : Sweep
    vars : str or sequence of str or None
        Variables (``theta3``), points (``C``: ``C_x`` and ``C_y``) or point coordinates
        (``C_x``); ``None``: the unknowns.

    Returns
    -------
    list of str
        Column names, each once, in the order asked.

    Raises
    ------
    ModelError
        A name that is neither a variable, a point nor a point coordinate.

    Examples
    --------
    >>> from loopsolve.output.geometry import plot_vars
    >>> sw = ls.load(ls.models_dir() / "thesis_crank_rocker.toml").sweep(0, 90, 45)
    >>> plot_vars(sw, None), plot_vars(sw, ["theta3", "theta3"])
    (['theta3', 'theta4'], ['theta3'])
    """
    ck = sweep.compiled
    if vars is None:
        return list(ck.unknowns)
    if isinstance(vars, str):
        vars = [vars]
    out: list[str] = []
    for v in vars:
        if v in ck.variables or v in {f"{p}_{c}" for p in ck.points for c in "xy"}:
            out.append(v)
        elif v in ck.points:
            out += [f"{v}_x", f"{v}_y"]
        else:
            raise ModelError(f"cannot plot {v!r}: choose variables ({', '.join(ck.variables)}), points "
                             f"({', '.join(ck.points) or 'none'}) or point coordinates such as "
                             f"{(ck.points[0] if ck.points else 'P')}_x")
    return list(dict.fromkeys(out))


def unwrapped(values: np.ndarray, unit: str) -> np.ndarray:
    """Angles tracked continuously, for angle data wrapped to (−180°, 180°] from elsewhere.

    A sweep's own columns are continuous already (:func:`loopsolve.kinematics.results.angle_turns`), and
    plots and pages draw them as they are.

    The jumps of a whole turn are removed between finite values, then the curve is shifted by
    whole turns so that its mean lies within half a turn of zero. Fewer than two finite
    values are returned as they are.

    Parameters
    ----------
    values : ndarray
        Angles, one per row (NaN where there is no value).
    unit : str
        ``"deg"`` (a turn is 360) or anything else (a turn is 2π).

    Returns
    -------
    ndarray

    Examples
    --------
    >>> from loopsolve.output.geometry import unwrapped
    >>> unwrapped(np.array([170.0, 180.0, -170.0, np.nan, -160.0]), "deg")
    array([-190., -180., -170.,   nan, -160.])
    """
    period = 360.0 if unit == "deg" else 2 * math.pi
    good = np.isfinite(values)
    if good.sum() < 2:
        return values
    out = values.copy()
    out[good] = np.unwrap(values[good], period=period)
    shift = period * np.round(np.nanmean(out) / period)
    return out - shift



# ------------------------------------------------------------------------- diagram geometry
@dataclass
class Frame:
    """Everything drawn for one pose, in data coordinates (model length units).

    Made by :func:`pose_frames`; keys (``key``, ``name``) identify the same item in the
    frames of other poses and in :class:`Style`.

    Examples
    --------
    >>> from loopsolve.output.geometry import pose_frames
    >>> (frame,), _ = pose_frames([ls.load(ls.models_dir() / "thesis_crank_rocker.toml").solve(60)],
    ...                           vectors=False)
    >>> len(frame.links), len(frame.pivots), len(frame.joints), sorted(t for _, t, _ in frame.labels)
    (3, 2, 4, ['B', 'C', 'O2', 'O4'])
    """

    links: list  # (key, [xy...], color index)
    pivots: list  # (xy, name|None)
    blocks: list  # (xy, angle)
    guides: list  # (key, block xy, unit direction, ground: bool, tail xy | None)
    levers: list  # (vector, pivot xy, unit direction, block xy)
    joints: list  # xy
    points: list  # (xy, name)
    labels: list  # (xy, text, attached directions)
    arrows: list  # (tail, head, name)
    ground_lines: list  # (p0, p1)


def unit_vector(v) -> np.ndarray:
    """``v`` divided by its length (the zero vector for a zero vector).

    Examples
    --------
    >>> from loopsolve.output.geometry import unit_vector
    >>> unit_vector([3.0, 4.0]), unit_vector([0.0, 0.0])
    (array([0.6, 0.8]), array([0., 0.]))
    """
    n = float(np.hypot(*v))
    return np.asarray(v, dtype=float) / n if n > 0 else np.zeros(2)


def _diagram_spec(mech):
    spec = getattr(mech, "spec", None) or {}
    joints, links = spec.get("joints"), spec.get("links")
    if isinstance(joints, dict) and isinstance(links, dict) and links:
        return joints, links
    return None


def pose_frames(states, *, vectors: bool) -> tuple[list[Frame], Structure]:
    """What is drawn for each of ``states`` (poses of one compiled model), and the diagram's structure.

    Parameters
    ----------
    states : sequence of State
        Solved poses of the same compiled model (a sweep's ``states``), at least one.
    vectors : bool
        Also list the loop vectors as arrows (``Frame.arrows``).

    Returns
    -------
    frames : list of Frame
        One per state, in order.
    structure
        The pose-independent structure (which vectors are ground, links, sliders).

    Raises
    ------
    ModelError
        A kinematic-diagram model whose joints are not all points of the solved model.

    Examples
    --------
    >>> from loopsolve.output.geometry import pose_frames
    >>> mech = ls.load(ls.models_dir() / "thesis_crank_rocker.toml")
    >>> frames, _ = pose_frames([mech.solve(0), mech.solve(90)], vectors=True)
    >>> len(frames), sorted(name for _, _, name in frames[1].arrows)
    (2, ['r1', 'r2', 'r3', 'r4'])
    """
    states = list(states)
    ck = states[0].compiled
    st = diagram_structure(ck, states)
    layout = _diagram_spec(ck.mechanism)
    frames = []
    for s in states:
        pos, disp = node_positions(st, ck, s)
        frames.append(_frame_from_layout(layout, s, st, pos) if layout else _frame(st, ck, s, pos))
        if vectors:
            tails = {v: pos[st.node_of[("tail", v)]] for v in st.vectors}
            frames[-1].arrows = [(tails[v], tails[v] + disp[v], v) for v in st.vectors
                                 if float(np.hypot(*disp[v])) > 0]
    return frames, st


def _frame(st: Structure, ck, s, pos) -> Frame:
    at = np.asarray(s.points[0], dtype=float).reshape(-1, 2)
    links, blocks, guides, levers, ground_lines = [], [], [], [], []
    for i, (key, members) in enumerate(st.links.items()):
        links.append((key, [pos[n] for n in members], i))
    vv = ck.vector_values(0, s.z)
    for v, block in st.blocks:
        length, angle = vv[ck.vectors.index(v)]
        d = np.array([math.cos(angle), math.sin(angle)])
        tail = pos[st.node_of[("tail", v)]]
        if st.kind[v] == "rslider":
            levers.append((v, tail, d, pos[block]))
        else:
            ground = st.node_of[("tail", v)] in st.fixed
            guides.append((v, pos[block], d, ground, tail))
        blocks.append((pos[block], angle))
    for v in st.ground:
        ground_lines.append((pos[st.node_of[("tail", v)]], pos[st.node_of[("head", v)]]))
    # sets are walked in a fixed order, so a picture does not depend on the hash seed
    joints = sorted(st.joints, key=repr)
    pivots = [(pos[n], n) for n in joints if n in st.fixed]
    # every named point that is not a joint: a tracer, at the solve's coordinates
    points = [(at[j], name) for j, name in enumerate(ck.points) if st.point_node.get(name) not in st.joints]
    here: dict = {}
    for name, n in st.point_node.items():
        if n in st.joints:
            here.setdefault(n, []).append(name)
    labels = [(pos[n], ", ".join(here[n]) if n in here else st.names[n], n) for n in joints
              if n in here or n in st.names]
    labels += [(xy, name, name) for xy, name in points]
    return Frame(links, pivots, blocks, guides, levers, [pos[n] for n in joints], points, labels, [], ground_lines)


def _frame_from_layout(layout, s, st: Structure, pos) -> Frame:
    """A frame from a kinematic-diagram model: links and joints by name (every joint is a point).

    A link is drawn through its distinct joint positions (coincident joints, such as a pin
    and the prismatic joint of the same block, count once); a link whose joints all coincide
    is a block, drawn by its prismatic joint. A prismatic joint is a block along the sliding
    vector that ends at it (its ``axis`` when none does), on a hatched guide when the joint
    belongs to the ground link.
    """
    joints_spec, links_spec = layout
    ck = s.compiled
    where = {p: np.asarray(s.points[0, j], dtype=float) for j, p in enumerate(ck.points)}
    missing = [j for j in joints_spec if j not in where]
    if missing:
        raise ModelError(f"cannot draw {ck.mechanism.name!r}: joints {', '.join(missing)} are not points "
                         "of the solved model")
    tol = 1e-9 * ck.scale
    ground_name = "ground" if "ground" in links_spec else None
    ground_joints = set(links_spec.get(ground_name, ())) if ground_name else set()
    vv = ck.vector_values(0, s.z)

    def distinct(names):
        out = []
        for n in names:
            if not any(np.linalg.norm(where[n] - q) < tol for q in out):
                out.append(where[n])
        return out

    links, pivots, blocks, guides, joints = [], [], [], [], []
    for i, (name, members) in enumerate(links_spec.items()):
        xy = distinct(members)
        if name != ground_name and len(xy) >= 2:
            links.append((name, xy, i))
    kinds = {n: (str(spec.get("type", "R")).upper() if isinstance(spec, dict) else "R")
             for n, spec in joints_spec.items()}
    carried: dict[str, int] = {}
    for members in links_spec.values():
        for n in set(members):
            carried[n] = carried.get(n, 0) + 1
    # a revolute joint named by one link only is a tracer point of that link: a dot, not a pin
    tracers = [n for n in joints_spec if kinds[n] == "R" and carried.get(n, 0) == 1]
    for name, spec in joints_spec.items():
        if name in tracers:
            continue
        p = where[name]
        if kinds[name] == "P":
            angle = None
            for v, block in st.blocks:
                if np.linalg.norm(pos[block] - p) < tol:
                    angle = float(vv[ck.vectors.index(v)][1])
            if angle is None:
                axis = spec.get("axis", (1.0, 0.0))
                angle = math.atan2(float(axis[1]), float(axis[0]))
            blocks.append((p, angle))
            if name in ground_joints:
                guides.append((name, p, np.array([math.cos(angle), math.sin(angle)]), True, None))
        else:
            if name in ground_joints:
                pivots.append((p, name))
        if not any(np.linalg.norm(p - q) < tol for q in joints):
            joints.append(p)
    # one label per position: the revolute joints there (else the prismatic one)
    labels = []
    for p in joints:
        here = [n for n in joints_spec if np.linalg.norm(where[n] - p) < tol]
        named = [n for n in here if kinds[n] == "R"] or here
        labels.append((p, ", ".join(named), named[0]))
    extra = [(where[p], p) for p in ck.points if p not in joints_spec or p in tracers]
    return Frame(links, pivots, blocks, guides, [], joints, extra,
                  labels + [(xy, p, p) for xy, p in extra], [], [])



def polygon_area(xy) -> float:
    """The area of the convex polygon through the points ``xy`` (an ``(n, 2)`` array), in any order.

    Examples
    --------
    >>> from loopsolve.output.geometry import polygon_area
    >>> polygon_area(np.array([[0.0, 0.0], [2.0, 1.0], [2.0, 0.0], [0.0, 1.0]]))
    2.0
    """
    c = xy - xy.mean(axis=0)
    order = hull_order(xy)
    q = c[order]
    return 0.5 * abs(float(np.sum(q[:, 0] * np.roll(q[:, 1], -1) - np.roll(q[:, 0], -1) * q[:, 1])))


def hull_order(xy) -> np.ndarray:
    """The order in which to join the points ``xy`` (``(n, 2)``) into a convex polygon: by angle about their mean.

    Examples
    --------
    >>> from loopsolve.output.geometry import hull_order
    >>> hull_order(np.array([[1.0, 1.0], [-1.0, -1.0], [1.0, -1.0], [-1.0, 1.0]]))
    array([1, 2, 0, 3])
    """
    c = xy - xy.mean(axis=0)
    return np.argsort(np.arctan2(c[:, 1], c[:, 0]))


def mode_label(mech, signature: str) -> str:
    """An assembly mode's signature with the model's name for it: ``-`` → ``- (open)``.

    Parameters
    ----------
    mech : Mechanism
    signature : str
        A mode signature such as ``+`` or ``-+``.

    Returns
    -------
    str
        The signature, followed by its alias in parentheses when the model declares one.

    Examples
    --------
    >>> from loopsolve.output.geometry import mode_label
    >>> mech = ls.load(ls.models_dir() / "thesis_crank_rocker.toml")
    >>> mech.mode_aliases
    {'open': '-', 'crossed': '+'}
    >>> mode_label(mech, "-"), mode_label(mech, "-+")
    ('- (open)', '-+')
    """
    alias = {v: k for k, v in getattr(mech, "mode_aliases", {}).items()}.get(signature)
    return f"{signature} ({alias})" if alias else signature
