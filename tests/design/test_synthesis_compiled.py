"""The compiled synthesis trace and assembly (issue 32, item 5) against the numpy ones.

:meth:`Batch.follow <loopsolve.design.synthesis.candidates.Batch.follow>` (many candidate designs traced
through their own input values) runs after its start, and the block Newton of :meth:`Batch.assemble`
runs, either in numpy or in the model's numba module (``follow_run``, ``block_newton_run`` of
:mod:`loopsolve.kinematics.numba_engine.lockstep_kernel`). On a small batch of four-bars — designs that
go all the way, that stop at a limit, that cannot be assembled — in both modes, with and without the
regularity stop, the two assemble the same designs and reach the same targets with the same positions
to round-off. ``LOOPSOLVE_ENGINE=python`` keeps numpy; ``auto`` waits for enough work to pay numba.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.design.synthesis import candidates
from loopsolve.design.synthesis.problem import define
from loopsolve.kinematics.numba_engine import jit

from support.models import VARY6
from support.synthesis import FOURBAR


@pytest.fixture(scope="module")
def batch():
    mech = ls.load(FOURBAR)
    return define(mech, path="P", targets={"x": [0, 1, 2, 3], "y": [0, 1, 1, 0]}, vary=VARY6).batch


def _designs(b, D=60, seed=1):
    """``D`` four-bars of the box (some not assemblable, some reaching a limit) and their inputs ``(8, D)``."""
    rng = np.random.default_rng(seed)
    V = np.column_stack([rng.uniform(lo, hi, D) for lo, hi in VARY6.values()])
    X = rng.uniform(0, 2 * math.pi, D) + np.cumsum(np.vstack([np.zeros((1, D)), rng.uniform(-0.3, 0.6, (7, D))]),
                                                   axis=0)
    return b.params(V), X


def _on(b, engine, method, *args, **kwargs):
    b.engine = engine
    try:
        return getattr(b, method)(*args, **kwargs)
    finally:
        b.engine = None


def test_compiled_assembly_agrees_with_numpy(batch, monkeypatch):
    pytest.importorskip("numba", reason="the compiled assembly needs numba")
    calls = []
    real = candidates.Batch._block_newton_compiled
    monkeypatch.setattr(candidates.Batch, "_block_newton_compiled", lambda *a: calls.append(real(*a)) or calls[-1])
    P, X = _designs(batch)
    D = P.shape[1]
    for signs in batch.all_signs():
        S = np.repeat(signs[:, None], D, axis=1)
        Za, oka = _on(batch, "python", "assemble", P, X[0], S)
        Zb, okb = _on(batch, "numba", "assemble", P, X[0], S)
        assert 0 < oka.sum() < D  # some designs cannot be assembled
        assert okb.tolist() == oka.tolist()
        np.testing.assert_allclose(Zb[:, oka], Za[:, oka], rtol=0, atol=1e-11 * np.max(np.abs(Za[:, oka])))
    modes = len(batch.all_signs())
    assert sum(c is None for c in calls) >= modes and sum(c is not None for c in calls) >= modes  # numpy, then numba


@pytest.mark.parametrize("stop", [True, False])
def test_compiled_follow_agrees_with_numpy(batch, stop, monkeypatch):
    pytest.importorskip("numba", reason="the compiled trace needs numba")
    calls = []
    real = candidates.Batch._follow_compiled
    monkeypatch.setattr(candidates.Batch, "_follow_compiled", lambda *a: calls.append(real(*a)) or calls[-1])
    P, X = _designs(batch)
    D = P.shape[1]
    for signs in batch.all_signs():
        S = np.repeat(signs[:, None], D, axis=1)
        Z, ok = batch.assemble(P, X[0], S)
        Z[:, ~ok] = np.nan
        Za, ra = _on(batch, "python", "follow", Z, P, X, hmax=math.radians(10), signs=S, stop_on_singular=stop)
        Zb, rb = _on(batch, "numba", "follow", Z, P, X, hmax=math.radians(10), signs=S, stop_on_singular=stop)
        assert 0 < np.sum(ra == X.shape[0]) < np.sum(ra > 0) < D  # all the way, stopped on the way, never started
        assert rb.tolist() == ra.tolist()
        assert np.array_equal(np.isnan(Zb), np.isnan(Za))
        np.testing.assert_allclose(Zb, Za, rtol=0, atol=1e-11 * np.nanmax(np.abs(Za)), equal_nan=True)
    assert calls == [True, True]  # numba ran once per mode, numpy otherwise


def test_engine_choice(batch, monkeypatch):
    ck = batch.ck
    monkeypatch.setenv("LOOPSOLVE_ENGINE", "python")
    assert candidates.follow_engine(ck, None, 10**9) == "python"
    monkeypatch.setattr(jit, "numba_module", lambda *a: pytest.fail("the compiled engine was asked for"))
    P, X = _designs(batch, D=8)
    S = np.repeat(batch.all_signs()[0][:, None], 8, axis=1)
    Z, ok = batch.assemble(P, X[0], S)  # numpy, as asked
    batch.follow(Z, P, X, hmax=math.radians(10), signs=S)
    monkeypatch.setenv("LOOPSOLVE_ENGINE", "auto")
    monkeypatch.setattr(candidates, "_FOLLOW_SEEN", [0])
    assert candidates.follow_engine(ck, None, 1000) == "python"  # too little work to pay numba's import
    if candidates.follow_engine(ck, None, candidates.FOLLOW_AUTO_CELLS) == "numba":
        pytest.importorskip("numba")  # (numba then must be installed)
        assert candidates.follow_engine(ck, None, 1) == "numba"  # from there on, for the rest of the process
    else:
        with pytest.raises(ImportError):
            import numba  # noqa: F401
