"""The roots of a block with no closed form (a cam follower's, a geared five-bar's, a six-bar's driven
from a far link): 49 Newton starts, screened by one vectorized Newton over all of them, so that an input
where the block has no root costs no scalar start (the nearest-assemblable search of an AssemblyError
visits every sample on its way: 6786 scalar Newton runs, 18–31 s, on the cam rocker driven past its lift)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.kinematics import modes
from loopsolve.kinematics.solve import initial_z

CASES = [  # model, the unknown that drives, inputs (rad) with and without roots of its multistart block
    ("cam_rocker", "psi", [0.05, 0.2, 0.35, 0.5]),
    ("geared_fivebar", "theta3", [0.3, 2.0, -2.5]),
    ("stephenson3_sixbar", "theta_link5", [0.3, -1.0]),
]


def _multistart_block(model, unknown):
    ck = ls.load(ls.models_dir() / f"{model}.toml").compile([unknown])
    z = initial_z(ck, warn=False)
    blocks = [b for b in ck.blocks if modes._dyad_roots(ck, z, b) is None and modes._linear_roots(ck, z, b) is None]
    assert blocks, f"{model} driven by {unknown}: no block without a closed form"
    return ck, z, blocks[0]


def _counting(monkeypatch, name):
    calls = [0]
    real = getattr(modes, name)

    def counted(*args, **kwargs):
        calls[0] += 1
        return real(*args, **kwargs)

    monkeypatch.setattr(modes, name, counted)
    return calls


@pytest.mark.parametrize("model, unknown, inputs", CASES, ids=[c[0] for c in CASES])
def test_the_screen_changes_no_root_and_drops_only_empty_inputs(model, unknown, inputs, monkeypatch):
    ck, z, block = _multistart_block(model, unknown)
    seen_empty = seen_roots = False
    for x in inputs:
        z[ck.input_idx[0]] = x
        screened = modes._multistart_roots(ck, z, block)
        with monkeypatch.context() as m:  # every start by the scalar Newton, as without the screen
            m.setattr(modes, "_any_root", lambda *a, **k: True)
            every = modes._multistart_roots(ck, z, block)
        assert len(screened) == len(every)
        for a, b in zip(screened, every):
            assert np.array_equal(a, b)
        for r in screened:  # each closes the block's equations
            zz = z.copy()
            zz[ck.unknown_idx[np.array(block.unknowns)]] = r
            assert np.max(np.abs(ck.phi(zz)[np.array(block.eqs)])) <= 1e-9 * ck.scale
        seen_empty |= not screened
        seen_roots |= bool(screened)
    assert seen_roots and (seen_empty or model == "geared_fivebar")


def test_an_input_with_no_root_runs_no_scalar_start(monkeypatch):
    ck, z, block = _multistart_block("cam_rocker", "psi")
    z[ck.input_idx[0]] = math.radians(30)  # the follower's lift is 20°
    scalar = _counting(monkeypatch, "_newton_block")
    assert modes._multistart_roots(ck, z, block) == [] and scalar[0] == 0


def test_driving_a_follower_past_its_lift_fails_with_bounded_work(monkeypatch):
    """psi = 40°: the search walks from 40° up round the turn to 360° and down to 20° (137 samples); only
    the samples where the cam's block has roots (the ends of the two walks, a dozen) run the 49 scalar
    starts."""
    mech = ls.load(ls.models_dir() / "cam_rocker.toml")
    ck = mech.compile(["psi"])
    scalar = _counting(monkeypatch, "_newton_block")
    screens = _counting(monkeypatch, "_any_root")
    with pytest.raises(ls.AssemblyError, match=r"psi = 40 deg.*nearest assemblable input values are psi = 20 deg") as info:
        mech.solve(40.0, compiled=ck)
    assert info.value.nearest[0] == pytest.approx(20.0, abs=1e-6)
    assert screens[0] >= 100  # the walk screened the empty samples...
    assert scalar[0] <= 49 * 13  # ...and ran scalar starts only where there are roots (6786 without the screen)
