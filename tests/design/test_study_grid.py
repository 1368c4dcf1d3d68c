"""A study's input grid from a step given as text, with or without a unit (as the CLI passes it).

(Mutation survivor of issue 18: a step with a unit, ``"30deg"``, crashed once the plain-number
test was inverted, and no test passed a step as text.)
"""

from __future__ import annotations

import numpy as np
import pytest

import loopsolve as ls

pytest.importorskip("xarray")


@pytest.mark.parametrize("step", [30, "30", "30deg", "0.5235987755982988rad"])
def test_step_forms_give_the_same_grid(step):
    mech = ls.load(ls.models_dir() / "thesis_crank_rocker.toml")
    ds = ls.study(mech, {"r2": [25.0]}, "0", "360", step, progress=False)
    np.testing.assert_allclose(ds.theta2.values, np.arange(0, 361, 30), rtol=0, atol=1e-9)
    sw = mech.sweep(0, 360, 30)
    np.testing.assert_allclose(ds.theta4.values[0], sw["theta4"], rtol=0, atol=1e-9)
