"""Atlas starts of free-timing path synthesis: a planted closed path (the last target repeating the first) solved
with a search too short to find it alone; problems the atlas cannot help are left alone."""

from __future__ import annotations

import math

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.design.atlas.build import build_atlas
from loopsolve.design.synthesis.shape.path_starts import atlas_starts, usable
from loopsolve.design.synthesis.problem import define

from support.models import fourbar_point

pytest.importorskip("zarr", reason="atlases need zarr (the study extra)")

FOURBAR = ls.models_dir() / "fourbar_path_synthesis.toml"
BOX = {"r2": (0.4, 4.0), "r3": (1.6, 16.0), "r4": (1.6, 16.0), "rcx": (-8.0, 16.0), "rcy": (-12.0, 12.0)}


@pytest.fixture(scope="module")
def fourbar():
    return ls.load(FOURBAR)


@pytest.fixture(scope="module")
def atlas(fourbar, tmp_path_factory):
    return build_atlas(fourbar, point="P", vary=BOX, size=1024, chunk=1024, out=tmp_path_factory.mktemp("pa") / "a.zarr",
                       step_deg=4.0, progress=False)


def _planted(fourbar, atlas, k=4):
    i = int(np.flatnonzero(atlas.traced & atlas.crank)[k])
    vals = atlas.values(i)
    d = fourbar.with_parameters(**{n: vals[n] for n in BOX}, x0=7.0, y0=-3.0, theta0=25.0)
    d = d.with_parameters(**{n: v * 5.0 for n, v in vals.items() if n in ("r1",) + tuple(BOX)})
    sw = d.sweep(13, 373, 40, progress=False)  # ten points, the tenth where the first is
    t = np.stack([sw.columns["P_x"], sw.columns["P_y"]], axis=1)
    return t


VARY = {"r1": (0.5, 200), "r2": (0.5, 200), "r3": (0.5, 200), "r4": (0.5, 200), "rcx": (-200, 200),
        "rcy": (-200, 200), "x0": (-200, 200), "y0": (-200, 200), "theta0": (0, 360)}


def test_a_planted_closed_path_is_found_from_the_atlas(fourbar, atlas):
    t = _planted(fourbar, atlas)
    assert np.allclose(t[0], t[-1])
    targets = {"x": t[:, 0], "y": t[:, 1]}
    # a search far too short to find it alone (two DE generations, no multistart)
    res = ls.synthesize(fourbar, path="P", targets=targets, vary=VARY, crank=True, seed=0, popsize=4, maxiter=2,
                        starts=0, atlas=atlas.path, progress=False)
    size = float(np.max(np.ptp(t, axis=0)))
    assert res.objective < 1e-16 * size * size
    cert = res.report["certificate"]
    assert cert["defects"] == [] and cert["crank"] is True and cert["order"] is True
    xs = [tg["input"] for tg in res.report["targets"]]
    assert abs(xs[-1] - xs[0]) < 360.0  # the repeated target met just short of the full turn


def test_the_starts_are_placed_on_the_targets(fourbar, atlas):
    t = _planted(fourbar, atlas)
    pr = define(fourbar, path="P", targets={"x": t[:, 0], "y": t[:, 1]}, vary=VARY, crank=True)
    assert usable(pr)
    V, S, X, d = atlas_starts(pr, atlas=atlas)
    assert V.shape[1] == len(pr.names) and X.shape == (pr.T, V.shape[0])
    # the best start's point at its inputs is near the targets already (the similarity of its match)
    from loopsolve.design.synthesis.lockstep_lm import residuals_and_jacobian

    r, _, ok, _ = residuals_and_jacobian(pr, V[:1], X[:, :1], S[:, :1], math.radians(5))
    size = float(np.max(np.ptp(t, axis=0)))
    assert ok[0] and np.sqrt(np.mean(r[0] ** 2)) < 0.05 * size


def test_problems_the_atlas_cannot_place_get_no_starts(fourbar, atlas):
    t = _planted(fourbar, atlas)
    tg = {"x": t[:, 0], "y": t[:, 1]}
    frame_fixed = define(fourbar, path="P", targets=tg, vary={"r2": (0.5, 3), "rcx": (-3, 3)})
    assert not usable(frame_fixed) and atlas_starts(frame_fixed, atlas=atlas) is None
    timed = define(fourbar, path="P", targets=tg, inputs=[13 + 36 * k for k in range(len(t))], vary=VARY)
    assert not usable(timed)
    few = define(fourbar, path="P", targets={"x": t[:4, 0], "y": t[:4, 1]}, vary=VARY)
    assert atlas_starts(few, atlas=atlas) is None


def test_the_atlas_starts_polished_as_synthesize_does_reach_the_planted_closed_curve(fourbar, atlas):
    """The free-timing lockstep polish of a run (MINPACK scaling, active set, stall stop, capped input steps, the
    free-timing floor) from the atlas starts alone: the planted closed curve (the tenth target repeats the first)
    is met to round-off, checked against the planted design's own sweep at the returned inputs."""
    from loopsolve.design.synthesis.lockstep_lm import batch_lm
    from loopsolve.design.synthesis.run import _FREE_INPUT_STEP, _STALL, _STALL_DROP, _polish_floor

    t = _planted(fourbar, atlas)
    pr = define(fourbar, path="P", targets={"x": t[:, 0], "y": t[:, 1]}, vary=VARY, crank=True)
    V, S, X, _ = atlas_starts(pr, atlas=atlas)
    Vl, Xl, f = batch_lm(pr, V, S, X, iters=60, floor=_polish_floor(pr), trust=True, stall=(_STALL, _STALL_DROP),
                         pin=True, free_step=_FREE_INPUT_STEP)
    j = int(np.argmin(f))
    assert f[j] < 1e-20
    q = {par.name: float(par.value) for par in fourbar.parameters} | dict(zip(pr.names, map(float, Vl[j])))
    got = np.array([fourbar_point(q, x, S[0, j]) for x in np.degrees(Xl[:, j])])  # circle intersection
    assert np.sum((got - t) ** 2) < 1e-20
