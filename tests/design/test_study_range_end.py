"""A limit between a study's last grid row and its ``stop`` is the design's event, as in its own sweep.

``study(..., 0.3, 360.3, 7)`` has rows up to 357.3°; a single sweep tracks on to 360.3° and
reports a limit it meets there. Near-change-point four-bars (50, 25, 70, 45 − ε) cannot be
assembled in a narrow band around θ2 = 0: the lockstep path used to stop checking at the last
row and call them ``ok`` (found while writing the tests of issue 18). The limit is where
|B O4| = r3 − r4: cos θ2 = (r1² + r2² − (r3 − r4)²) / (2 r1 r2), computed here.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import loopsolve as ls

pytest.importorskip("xarray")

EPS = [1e-6, 1e-5, 1e-4, 3e-4]  # the band around 0 is narrower than 0.3° (so the start is assemblable)


def limit_before_360(eps):
    r1, r2, r3, r4 = 50.0, 25.0, 70.0, 45.0 - eps
    c = (r1 * r1 + r2 * r2 - (r3 - r4) ** 2) / (2 * r1 * r2)
    return 360.0 - math.degrees(math.acos(c))


def test_limit_after_the_last_row_is_reported():
    mech = ls.fourbar(50, 25, 70, 45)
    ds = ls.study(mech, {"r4": [45.0 - e for e in EPS]}, 0.3, 360.3, 7, progress=False)
    assert float(ds.theta2.values[-1]) == pytest.approx(357.3)
    for j, eps in enumerate(EPS):
        want = limit_before_360(eps)
        assert 357.3 < want < 360.0
        assert ds.status.values[j] == "limit", (eps, ds.status.values[j], ds.events.values[j])
        assert float(ds.stop.values[j]) == pytest.approx(want, abs=1e-6)
        assert "limit@" in ds.events.values[j]
    single = ls.study(mech, {"r4": [45.0 - e for e in EPS]}, 0.3, 360.3, 7, progress=False, method="single")
    assert ds.status.values.tolist() == single.status.values.tolist()
    np.testing.assert_allclose(ds.stop.values, single.stop.values, rtol=0, atol=1e-9)
    np.testing.assert_allclose(ds.theta4.values, single.theta4.values, rtol=0, atol=1e-9)


def test_grashof_side_still_runs_through():
    """The other side of the change point (45 + ε) turns fully: ok, rows to 357.3°."""
    mech = ls.fourbar(50, 25, 70, 45)
    ds = ls.study(mech, {"r4": [45.0 + e for e in EPS]}, 0.3, 360.3, 7, progress=False)
    assert ds.status.values.tolist() == ["ok"] * len(EPS)
    assert np.isfinite(ds.theta4.values).all()
