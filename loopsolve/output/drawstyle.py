"""How a picture of a mechanism is dressed: sizes, sides of ground symbols and guides, labels.

From all the :class:`~loopsolve.output.geometry.Frame` s of one picture, :func:`drawing_style` derives
what stays the same in it (a :class:`Style`: the symbol size, the extent, the side of every
ground symbol and guide, the length of slotted levers); :func:`arrow_label_sides` and
:func:`label_placements` put the vector and point labels where they cross nothing. Like
:mod:`loopsolve.output.geometry` it is plain numpy, shared by :mod:`loopsolve.output.plotting` and
:mod:`loopsolve.output.view`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .geometry import Frame, hull_order, unit_vector

__all__ = ["Style", "drawing_style", "arrow_label_sides", "label_placements"]


@dataclass
class Style:
    """What stays the same over all the frames of one picture (made by :func:`drawing_style`).

    Examples
    --------
    >>> from loopsolve.output.drawstyle import drawing_style
    >>> from loopsolve.output.geometry import pose_frames
    >>> frames, _ = pose_frames([ls.load(ls.models_dir() / "thesis_crank_rocker.toml").solve(60)], vectors=False)
    >>> style = drawing_style(frames)
    >>> sorted(np.round(u, 3).tolist() for u in style.pivot_dir.values())
    [[0.0, -1.0], [0.0, -1.0]]
    """

    size: float  # the characteristic symbol size (data units)
    lo: np.ndarray
    hi: np.ndarray
    pivot_dir: dict  # pivot key -> unit vector towards the ground
    guide_side: dict  # guide key -> unit normal of the hatched side
    guide_span: dict  # guide key -> (s_min, s_max) along the guide through its reference point
    lever_len: dict  # lever key -> drawn length


#: the directions a ground symbol may point (down, up, left, right) and the bias towards each
_PIVOT_CHOICES = np.array([(0.0, -1.0), (0.0, 1.0), (-1.0, 0.0), (1.0, 0.0)])
_PIVOT_BIAS = np.array([0.3, 0.1, 0.0, 0.0])


def _units(v: np.ndarray) -> np.ndarray:
    """:func:`unit_vector` of every row of ``v`` (``(..., 2)``)."""
    n = np.hypot(v[..., 0], v[..., 1])[..., None]
    safe = np.where(n > 0, n, 1.0)
    return np.where(n > 0, v / safe, 0.0)


def _pivot_clearance(frames: list[Frame], span: float) -> dict:
    """Per pivot key: the sum over frames of each choice's clearance (``(4,)``), in frame order.

    A choice's clearance in a frame is its angle to the nearest direction attached at the
    pivot (links through it, levers pivoted there, frame lines ending there), at most a right
    angle; π/2 when nothing is attached. Frames with the same shapes are stacked and done in
    one go (numpy), so the cost is O(frames) array work. The attachment test is
    ``np.isclose(q, pivot, atol=1e-9 * span)`` on both coordinates.
    """
    atol = 1e-9 * span
    groups: dict = {}
    for i, f in enumerate(frames):
        if f.pivots:
            sig = (tuple(len(xy) for _, xy, _ in f.links), tuple(key for _, key in f.pivots), len(f.levers),
                   len(f.ground_lines))
            groups.setdefault(sig, []).append(i)
    per_frame: dict = {}  # key -> (len(frames), 4) contributions (zero where the key is absent)
    for (_, keys, n_levers, n_lines), rows in groups.items():
        fs = [frames[i] for i in rows]
        P = np.array([[p for p, _ in f.pivots] for f in fs], dtype=float)[:, :, None, :]  # (G, K, 1, 2)
        best = np.full((len(fs), len(keys), len(_PIVOT_CHOICES)), -np.inf)

        def close(q):  # q (G, 1, M, 2) -> (G, K, M)
            return np.isclose(q, P, rtol=1e-5, atol=atol).all(axis=-1)

        def take(dirs, valid):  # dirs (G, K|1, M, 2), valid (G, K, M)
            nonlocal best
            if valid.shape[-1]:
                dots = np.where(valid[..., None], dirs @ _PIVOT_CHOICES.T, -np.inf)
                best = np.maximum(best, dots.max(axis=2))

        for j in range(len(fs[0].links)):
            Q = np.array([f.links[j][1] for f in fs], dtype=float)[:, None, :, :]
            on = close(Q)
            take(_units(Q - P), on.any(axis=-1, keepdims=True) & ~on)
        if n_levers:
            tails = np.array([[t for _, t, _, _ in f.levers] for f in fs], dtype=float)[:, None, :, :]
            dirs = np.array([[d for _, _, d, _ in f.levers] for f in fs], dtype=float)[:, None, :, :]
            take(dirs, close(tails))
        if n_lines:
            A = np.array([[a for a, _ in f.ground_lines] for f in fs], dtype=float)[:, None, :, :]
            B = np.array([[b for _, b in f.ground_lines] for f in fs], dtype=float)[:, None, :, :]
            at_a = close(A)
            take(_units(B - A), at_a)
            take(_units(A - B), close(B) & ~at_a)
        # angle to the nearest direction = acos of the largest cosine; capped at a right angle
        clear = np.full(best.shape, 0.5 * math.pi)
        for idx in zip(*np.nonzero(best > 0)):
            clear[idx] = min(math.acos(min(1.0, float(best[idx]))), 0.5 * math.pi)
        for k, key in enumerate(keys):
            per_frame.setdefault(key, np.zeros((len(frames), len(_PIVOT_CHOICES))))[rows] = clear[:, k, :]
    first = {}
    for f in frames:
        for _, key in f.pivots:
            first.setdefault(key, None)
    # summed in frame order (as a running sum would), so the result does not depend on grouping
    return {key: np.cumsum(per_frame[key], axis=0)[-1] for key in first}


def drawing_style(frames: list[Frame]) -> Style:
    """The style of a picture made of ``frames``: symbol size, extent, ground sides, guide spans, levers.

    * the symbol size is 4.5 % of the larger side of the box around everything drawn;
    * a ground pivot's symbol points, of the four axis directions, where it is clearest of
      what is attached at the pivot, averaged over all frames (down when free);
    * a fixed guide is hatched on the side away from the centre of the drawing and spans
      every position of its block, plus three symbol sizes either side;
    * a slotted lever reaches 2.5 symbol sizes beyond the farthest position of its block.

    The cost is O(frames) numpy work (a few microseconds a frame).

    Parameters
    ----------
    frames : list of Frame
        From :func:`pose_frames`, at least one.

    Returns
    -------
    Style

    Examples
    --------
    >>> from loopsolve.output.drawstyle import drawing_style
    >>> from loopsolve.output.geometry import pose_frames
    >>> sw = ls.load(ls.models_dir() / "example1_slider_crank.toml").sweep(0, 360, 30)
    >>> style = drawing_style(pose_frames(list(sw.states), vectors=False)[0])
    >>> list(style.guide_side), style.guide_side["r1"].tolist()
    (['r1'], [0.0, -1.0])
    >>> lo, hi = style.guide_span["r1"]
    >>> bool(np.isclose(hi - lo, 2 * 5 + 6 * style.size))  # the slider's stroke (twice the crank) + margins
    True
    """
    pts = []
    for f in frames:
        for _, xy, _ in f.links:
            pts += list(xy)
        pts += [p for p, _ in f.pivots] + [p for p, _ in f.blocks] + list(f.joints) + [p for p, _ in f.points]
        pts += [p for pair in f.ground_lines for p in pair]
        pts += [t for t, h, _ in f.arrows] + [h for t, h, _ in f.arrows]
        for v, tail, d, block in f.levers:
            pts.append(tail)
    pts = np.array(pts, dtype=float).reshape(-1, 2)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    span = float(max(hi - lo)) or 1.0
    size = 0.045 * span
    centre = pts.mean(axis=0)
    choices = list(_PIVOT_CHOICES)
    snapped = {key: choices[int(np.argmax(score / len(frames) + _PIVOT_BIAS))]
               for key, score in _pivot_clearance(frames, span).items()}
    guide_side, guide_span, guide_ref = {}, {}, {}
    for f in frames:
        for key, p, d, ground, tail in f.guides:
            ref = guide_ref.setdefault(key, np.asarray(p, dtype=float))
            n = np.array([-d[1], d[0]])
            side = guide_side.setdefault(key, np.zeros(2))
            side += -(n @ (centre - p)) * n
            s = float((p - ref) @ d)
            cand = [s - 3.0 * size, s + 3.0 * size]
            s_lo, s_hi = guide_span.get(key, (math.inf, -math.inf))
            guide_span[key] = (min(s_lo, *cand), max(s_hi, *cand))
    for key, side in guide_side.items():
        guide_side[key] = unit_vector(side) if np.hypot(*side) > 1e-12 else np.array([0.0, -1.0])
    extra = [guide_ref[k] + d * s for f in frames[:1] for k, _, d, _, _ in f.guides for s in guide_span[k]]
    # a slotted lever is drawn from its pivot to beyond the farthest position of its block
    lever_len = {}
    for f in frames:
        for v, tail, d, block in f.levers:
            lever_len[v] = max(lever_len.get(v, 0.0), float((np.asarray(block) - tail) @ d))
    lever_len = {v: L + 2.5 * size for v, L in lever_len.items()}
    for f in frames:
        extra += [tail + d * lever_len[v] for v, tail, d, _ in f.levers]
    if extra:
        pts = np.vstack([pts, np.array(extra)])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    return Style(size, lo, hi, snapped, guide_side, guide_span, lever_len)


# --------------------------------------------------------------------------------- labels
def _segment_distance(p, a, b) -> float:
    ab = b - a
    t = float(np.clip((p - a) @ ab / (ab @ ab), 0.0, 1.0)) if ab @ ab > 0 else 0.0
    return float(np.hypot(*(p - a - t * ab)))


def _inside(p, poly) -> bool:
    """``p`` inside the convex polygon ``poly`` (corners in hull order)."""
    signs = [float((b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]))
             for a, b in zip(poly, np.roll(poly, -1, axis=0))]
    return all(s > 0 for s in signs) or all(s < 0 for s in signs)


def arrow_label_sides(frame: Frame, style: Style) -> list[tuple[np.ndarray, np.ndarray]]:
    """For every vector arrow: its midpoint and the unit normal on the side its name goes.

    The name sits beside the arrow, perpendicular to it, on the side that is clearer of the
    links (bars, the inside of plates, frame lines) and of the other arrows and their names.

    Returns
    -------
    list of (mid, normal)
        One per ``frame.arrows``, in order: the arrow's midpoint and the unit normal towards
        its name.

    Examples
    --------
    >>> from loopsolve.output.drawstyle import arrow_label_sides, drawing_style
    >>> from loopsolve.output.geometry import pose_frames
    >>> frames, _ = pose_frames([ls.load(ls.models_dir() / "thesis_crank_rocker.toml").solve(60)], vectors=True)
    >>> sides = arrow_label_sides(frames[0], drawing_style(frames))
    >>> len(sides) == len(frames[0].arrows), [bool(np.isclose(np.hypot(*n), 1.0)) for _, n in sides]
    (True, [True, True, True, True])
    """
    size = style.size
    segs, plates = [], []
    for _, xy, _ in frame.links:
        xy = np.asarray(xy, dtype=float)
        segs += [(xy[a], xy[b]) for a in range(len(xy)) for b in range(a + 1, len(xy))]
        if len(xy) >= 3:
            plates.append(xy[hull_order(xy)])
    segs += [(np.asarray(a, dtype=float), np.asarray(b, dtype=float)) for a, b in frame.ground_lines]
    arrows = [(np.asarray(t, dtype=float), np.asarray(h, dtype=float)) for t, h, _ in frame.arrows]
    placed: list[np.ndarray] = []
    out = []
    for k, (tail, head) in enumerate(arrows):
        d = unit_vector(head - tail)
        n = np.array([-d[1], d[0]])
        mid = 0.5 * (tail + head)
        best, best_score = n, -math.inf
        for side in (n, -n):
            p = mid + side * 0.9 * size
            clear = min([_segment_distance(p, a, b) for a, b in segs]
                        + [_segment_distance(p, a, b) for i, (a, b) in enumerate(arrows) if i != k]
                        + [float(np.hypot(*(p - q))) for q in placed], default=10 * size)
            score = min(clear, 2 * size) - sum(2 * size for poly in plates if _inside(p, poly))
            if score > best_score + 1e-12:
                best, best_score = side, score
        placed.append(mid + best * 0.9 * size)
        out.append((mid, best))
    return out


def label_placements(frame: Frame, style: Style) -> list[tuple[np.ndarray, str, str, str]]:
    """Where the joint and point names of ``frame`` go: each in the freest direction around its joint.

    Of 24 directions, the one farthest (in angle) from everything attached at the joint
    (links, frame lines, levers, arrows, the ground symbol, a block and its guide), leaning
    away from their mean direction and slightly upwards; the name is put 0.75 symbol sizes
    away (a full size at a block).

    Returns
    -------
    list of (xy, text, ha, va)
        The anchor point (data units), the name, and its horizontal (``left``, ``center``,
        ``right``) and vertical (``bottom``, ``center``, ``top``) alignment at the anchor.

    Examples
    --------
    >>> from loopsolve.output.drawstyle import drawing_style, label_placements
    >>> from loopsolve.output.geometry import pose_frames
    >>> frames, _ = pose_frames([ls.load(ls.models_dir() / "thesis_crank_rocker.toml").solve(60)], vectors=False)
    >>> sorted((text, va) for _, text, _, va in label_placements(frames[0], drawing_style(frames)))
    [('B', 'bottom'), ('C', 'bottom'), ('O2', 'bottom'), ('O4', 'bottom')]
    """
    out = []
    span = float(max(style.hi - style.lo)) or 1.0
    tol = 1e-9 * span
    segs = []
    for _, xy, _ in frame.links:
        xy = [np.asarray(q, dtype=float) for q in xy]
        segs += [(a, b) for i, a in enumerate(xy) for b in xy[i + 1:]]
    segs += [(np.asarray(a), np.asarray(b)) for a, b in frame.ground_lines]
    for v, tail, d, _ in frame.levers:
        segs.append((tail, tail + d * style.lever_len[v]))
    for tail, head, _ in frame.arrows:
        segs.append((np.asarray(tail), np.asarray(head)))
    pivots = {key: style.pivot_dir.get(key, np.array([0.0, -1.0])) for _, key in frame.pivots}
    blocks = [(np.asarray(p), a) for p, a in frame.blocks]
    sides = {g[0]: style.guide_side.get(g[0]) for g in frame.guides}
    candidates = [np.array([math.cos(t), math.sin(t)]) for t in np.linspace(0, 2 * math.pi, 24, endpoint=False)]
    for p, text, key in frame.labels:
        p = np.asarray(p, dtype=float)
        dirs = []
        for a, b in segs:
            if np.linalg.norm(a - p) < tol and np.linalg.norm(b - p) > tol:
                dirs.append(unit_vector(b - a))
            elif np.linalg.norm(b - p) < tol and np.linalg.norm(a - p) > tol:
                dirs.append(unit_vector(a - b))
        if key in pivots:
            u = pivots[key]
            dirs += [u, unit_vector(u + np.array([-u[1], u[0]])), unit_vector(u - np.array([-u[1], u[0]]))]
        radius = 0.75 * style.size
        for bp, angle in blocks:
            if np.linalg.norm(bp - p) < tol:
                d = np.array([math.cos(angle), math.sin(angle)])
                dirs += [d, -d]
                radius = 1.0 * style.size
                for g in frame.guides:
                    if np.linalg.norm(np.asarray(g[1]) - p) < tol and sides.get(g[0]) is not None:
                        dirs.append(sides[g[0]])
        want = -unit_vector(np.sum(dirs, axis=0)) if dirs else np.array([0.6, 0.8])

        def score(c):
            clear = min((math.acos(max(-1.0, min(1.0, float(c @ d)))) for d in dirs), default=math.pi)
            return clear + 0.25 * float(c @ want) + 0.05 * c[1]

        c = max(candidates, key=score)
        ha = "left" if c[0] > 0.35 else "right" if c[0] < -0.35 else "center"
        va = "bottom" if c[1] > 0.35 else "top" if c[1] < -0.35 else "center"
        out.append((p + c * radius, text, ha, va))
    return out
