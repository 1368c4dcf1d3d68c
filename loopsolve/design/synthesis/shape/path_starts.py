"""Atlas starts for path synthesis with free timing: the targets as a curve, its nearest atlas designs placed on it.

A free-timing path problem (``synthesize --path P`` without inputs) asks for a design whose point
passes through the targets in order: a curve through them. :func:`atlas_starts` treats the targets
as that curve — closed when the last target repeats the first, open otherwise — retrieves the atlas
designs whose curves are nearest it (:mod:`loopsolve.design.synthesis.shape.retrieval`) and whose placed
dimensions lie within the problem's bounds (a start clipped into them would be another design), places each on the
targets (scaled, turned and moved by the similarity of its match, written into the problem's
varied parameters: the frame's translation and rotation, every length) and gives the input value
of every target on the placed design's motion. These starts join the differential evolution's and
the multistart's in the lockstep Levenberg–Marquardt of every run
(:func:`loopsolve.design.synthesis.run.one_run`): a basin the random populations rarely reach (the
published ellipse and line problems, one certified run in ten before) is then among the starts.

Used only where it can help: a path task with free timing, at least five distinct targets, a model
with a default atlas recipe (:data:`loopsolve.design.atlas.defaults.RECIPES`, whose atlas is built
into the cache on first use) or an atlas given, and a problem that varies the frame's translation
and rotation and at least one length (otherwise a placed design cannot be expressed in its
parameters). Any failure to provide starts (no recipe, no atlas, a curve that is degenerate)
leaves the run as it was, with a note in its statistics.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["atlas_starts", "ATLAS_STARTS"]

#: atlas starts added to a run
ATLAS_STARTS = 16
_MEMO: dict = {}


def _atlas_for(problem, atlas):
    from ....errors import LoopsolveError
    from ...atlas.build import Atlas, open_atlas
    from ...atlas.defaults import RECIPES, default_atlas, recipe_for

    if isinstance(atlas, Atlas):
        return atlas
    if atlas not in (None, True):
        key = ("path", str(atlas))
        if key not in _MEMO:
            _MEMO[key] = open_atlas(atlas, problem.mech)
        return _MEMO[key]
    name = recipe_for(problem.mech, problem.point)[0]
    if name not in RECIPES:
        return None
    key = ("default", name, problem.point)
    if key not in _MEMO:
        try:
            _MEMO[key] = default_atlas(problem.mech, problem.point, progress=None)
        except LoopsolveError:
            _MEMO[key] = None
    return _MEMO[key]


def usable(problem) -> bool:
    """Whether atlas starts apply to ``problem`` (see the module docstring) — checked before any atlas is read."""
    if problem.task != "path" or not problem.free or problem.T < 5:
        return False
    from ...atlas.frame import frame_of
    from ....errors import LoopsolveError

    try:
        fr = frame_of(problem.mech, problem.point)
    except LoopsolveError:
        return False
    names = set(problem.names)
    return not fr.added and {fr.x, fr.y, fr.angle} <= names and bool(names & set(fr.lengths))


def atlas_starts(problem, *, atlas=None, count: int = ATLAS_STARTS):
    """Starts ``(V (S, k), signs (nb, S), X (T, S), direction (S,))`` for ``problem`` from the atlas, or None.

    ``atlas``: an :class:`~loopsolve.design.atlas.build.Atlas` or path, ``None`` for the model's default
    atlas, ``False`` for none.
    """
    from ....errors import LoopsolveError
    from ...atlas.descriptors import check_curve
    from ...atlas.frame import frame_of
    from .retrieval import diverse, placed_starts, retrieve, within_bounds

    if atlas is False or not usable(problem):
        return None
    try:
        a = _atlas_for(problem, atlas)
    except LoopsolveError:
        return None
    if a is None or a.point != problem.point:
        return None
    tg = problem.targets[:, :2]
    size = float(np.max(np.ptp(tg, axis=0)))
    if not size > 0:
        return None
    closed = len(tg) > 5 and float(np.hypot(*(tg[0] - tg[-1]))) <= 1e-9 * size
    try:
        xy = check_curve(tg, closed=closed, where="targets")
    except LoopsolveError:
        return None
    fr = frame_of(problem.mech, problem.point)
    matches, _ = retrieve(a, xy, closed=closed, crank=problem.crank, count=max(2000, 100 * count))
    deg = problem.mech.units.angle == "deg"
    matches = within_bounds(a, matches, xy, closed, fr, problem, deg=deg)  # a clipped start is another design
    if not matches:
        return None
    picked = diverse(a, matches, count)
    idx = np.arange(len(xy))
    V, S, X, used = placed_starts(a, picked, xy, idx, closed, fr, problem, deg=deg, step_deg=1.0)
    if not len(used):
        return None
    if closed:  # the repeated last target: one turn on, just short of the full turn (an order within one turn)
        d = np.sign(X[-1] - X[0])
        d = np.where(d == 0, 1.0, d)
        X = np.vstack([X, X[:1] + d * (2 * math.pi - 1e-6)])
    if X.shape[0] != problem.T:
        return None
    di = np.sign(X[-1] - X[0]).astype(int)
    return V, S, X, np.where(di == 0, 1, di)
