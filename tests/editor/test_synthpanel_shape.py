"""The synthesis panel's ``shape`` method (issue 34, item 4): a drawn curve in, certified four-bars
whose coupler point traces its shape out, each an editable kinematic-diagram model.

The curves are traced by known four-bars (moved, turned and scaled); every candidate's model is
solved here — its coupler point swept over the input — and each drawn point's distance to that
curve measured, not read from the report. The default atlas is small (``LOOPSOLVE_ATLAS_SIZE``)
and built into a temporary cache, as ``tests/cli/test_shape_cli.py`` does.
"""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.editor import synthpanel
from loopsolve.errors import ModelError

from support.synthesis import candidate_curve, distance, traced

pytest.importorskip("zarr", reason="atlases need zarr (the study extra)")

FOURBAR = ls.models_dir() / "fourbar_path_synthesis.toml"


@pytest.fixture(scope="module")
def small_default_atlas(tmp_path_factory):
    """A default atlas of 4,096 designs in a fresh cache (the environment the panel's job sees)."""
    mp = pytest.MonkeyPatch()
    mp.setenv("LOOPSOLVE_CACHE_DIR", str(tmp_path_factory.mktemp("cache")))
    mp.setenv("LOOPSOLVE_ATLAS_SIZE", "4096")
    mp.delenv("LOOPSOLVE_ATLAS_WORKERS", raising=False)
    yield
    mp.undo()


def check_candidates(result, targets, closed, tol):
    size = float(np.ptp(targets, axis=0).max())
    assert result["task"] == "shape" and result["closed"] is closed
    assert result["candidates"]
    for c in result["candidates"]:
        assert c["certificate"]["defects"] == [], c["certificate"]
        assert set(c["model"]["joints"]) == {"O2", "A", "B", "O4", "P"}
        assert tomllib.loads(c["toml"])["links"] == c["model"]["links"]
        dist = distance(targets, candidate_curve(c["toml"], closed))
        assert dist.max() < tol * size, (dist.max(), c["rms"], c["max"])
        # the report's numbers are the ones measured here (to the tracing's chord error)
        assert c["max"] == pytest.approx(dist.max(), abs=2e-3 * size)
    return size


def test_closed_curve_from_the_default_atlas_built_once_with_progress(small_default_atlas):
    targets = traced(1.2, 4.5, 3.8, 1.0, 2.5, stop=351, turn=30, scale=7.0, shift=(40.0, -15.0))
    seen = []
    res = synthpanel.run("shape", {"points": targets.tolist(), "top": 3}, lambda f, t: seen.append((f, t)))
    check_candidates(res, targets, True, 1e-3)
    assert 1 <= len(res["candidates"]) <= 3
    assert res["candidates"][0]["rms"] < 1e-4 * np.ptp(targets, axis=0).max()  # the atlas holds this shape's family
    fr = [f for f, _ in seen]
    assert fr == sorted(fr) and fr[-1] == 1.0
    building = [t for _, t in seen if "building the default four-bar atlas" in t]
    assert building and building[-1].endswith("4,096 of 4,096 designs")
    assert any("closed curve" in n for n in res["notes"])
    # the second use opens the atlas from the cache: nothing built again
    seen.clear()
    again = synthpanel.run("shape", {"points": targets.tolist(), "top": 1}, lambda f, t: seen.append((f, t)))
    assert not any("building" in t for _, t in seen)
    assert again["candidates"][0]["parameters"] == pytest.approx(res["candidates"][0]["parameters"], rel=1e-6,
                                                                 abs=1e-6)


def test_open_stroke_with_an_atlas_passed_in():
    mech = ls.load(FOURBAR)
    atlas = ls.build_atlas(mech, point="P", vary={"r2": (0.4, 4.0), "r3": (1.6, 16.0), "r4": (1.6, 16.0),
                                                  "rcx": (-8.0, 16.0), "rcy": (-12.0, 12.0)},
                           size=2048, chunk=1024, progress=False)
    targets = traced(1.5, 4.0, 3.5, 2.0, 1.0, start=20, stop=200, step=6, turn=-75, scale=0.5, shift=(3.0, 8.0))
    closed, gap = synthpanel.closed_rule(targets)
    assert not closed and gap > synthpanel.CLOSE_FRACTION
    res = synthpanel.shape_synthesis({"points": targets.tolist(), "top": 2}, lambda f, t: None, atlas=atlas)
    check_candidates(res, targets, False, 5e-3)
    assert any("open curve" in n for n in res["notes"])


def test_closed_rule_and_bad_requests():
    t = np.linspace(0, 2 * math.pi, 41)[:-1]
    ring = np.column_stack([10 + 4 * np.cos(t), 3 * np.sin(t)])
    a = 2 * math.pi / 40  # the last point is one step before the first, on an ellipse 8 wide
    assert synthpanel.closed_rule(ring) == (True, pytest.approx(math.hypot(4 * (1 - math.cos(a)), 3 * math.sin(a)) / 8))
    half = ring[:21]
    assert synthpanel.closed_rule(half) == (False, pytest.approx(1.0))
    # the rule's edge: an end 15 % of the size from the start is closed, 16 % is not
    line = np.column_stack([np.linspace(0, 1, 10), np.zeros(10)])
    hook = np.vstack([line, [[0.0, 0.5], [0.0, 0.15]]])
    assert synthpanel.closed_rule(hook)[0] is True
    assert synthpanel.closed_rule(np.vstack([line, [[0.0, 0.5], [0.0, 0.16]]]))[0] is False
    quiet = lambda f, t: None  # noqa: E731
    with pytest.raises(ModelError, match="give 5 to 200"):
        synthpanel.shape_synthesis({"points": ring[:4].tolist()}, quiet)
    with pytest.raises(ModelError, match="top"):
        synthpanel.shape_synthesis({"points": ring.tolist(), "top": 0}, quiet)
    with pytest.raises(ModelError, match="closed"):
        synthpanel.shape_synthesis({"points": ring.tolist(), "closed": "maybe"}, quiet)
    with pytest.raises(ModelError, match="finite"):
        synthpanel.shape_synthesis({"points": [[0, 0]] * 4 + [[float("nan"), 1]]}, quiet)
    assert list(synthpanel.METHODS)[0] == "shape" and "path" in synthpanel.METHODS
