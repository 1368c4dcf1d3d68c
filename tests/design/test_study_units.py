"""Units of every study variable, read back from ``.nc`` and ``.zarr`` (issue 18, row 8).

The expected unit of each variable is worked out here from the model file's declarations
(which unknowns are angles, which lengths, which points exist) and the conventions of the
docs (docs/explanation/units.md): positions in the model's units (deg, mm), rates in rad/s and mm/s (and their
derivatives), sensitivities ``d_<q>_d_<p>`` in q's unit per p's unit, the input coordinate,
``stop`` and the varied parameters in the model's units.
"""

from __future__ import annotations

import numpy as np
import pytest

import loopsolve as ls

xr = pytest.importorskip("xarray")

SUFFIX = {"": 0, "_vel": 1, "_acc": 2, "_jerk": 3}
ANGLE_UNITS = ["deg", "rad/s", "rad/s^2", "rad/s^3"]
LENGTH_UNITS = ["mm", "mm/s", "mm/s^2", "mm/s^3"]

CASES = {
    # model: (input, {unknown: kind}, points, {varied parameter: values})
    "thesis_crank_rocker": ("theta2", {"theta3": "angle", "theta4": "angle"}, ["B", "C"],
                            {"r2": [24.0, 25.0], "r3": [70.0]}),
    "quick_return": ("theta2", {"theta4": "angle", "s": "length"}, ["O2", "A"], {"d": [200.0, 210.0]}),
}


def expected_units(case) -> dict[str, str]:
    inp, unknowns, points, vary = case
    out = {}
    for name, kind in [(inp, "angle"), *unknowns.items()]:
        for suf, k in SUFFIX.items():
            out[name + suf] = (ANGLE_UNITS if kind == "angle" else LENGTH_UNITS)[k]
    for p in points:
        for c in "xy":
            for suf, k in SUFFIX.items():
                out[f"{p}_{c}{suf}"] = LENGTH_UNITS[k]
    for q, kind in unknowns.items():
        for p in vary:  # every varied parameter here is a length in mm
            out[f"d_{q}_d_{p}"] = ("deg" if kind == "angle" else "mm") + "/mm"
    for p in vary:
        out[p] = "mm"
    out["stop"] = "deg"
    return out


@pytest.mark.parametrize("ext", [".nc", ".zarr"])
@pytest.mark.parametrize("model", sorted(CASES))
def test_units_of_every_study_variable_survive_the_file(tmp_path, model, ext):
    if ext == ".zarr":
        pytest.importorskip("zarr")
    else:
        pytest.importorskip("netCDF4")
    case = CASES[model]
    inp, _, _, vary = case
    mech = ls.load(ls.models_dir() / f"{model}.toml")
    out = tmp_path / f"study{ext}"
    ls.study(mech, vary, 0, 360, 90, sensitivity=True, out=out, progress=False)
    opener = xr.open_zarr if ext == ".zarr" else xr.open_dataset
    with opener(out) as ds:
        want = expected_units(case)
        got = {k: ds[k].attrs.get("units") for k in list(ds.data_vars) + list(ds.coords)}
        # every variable with a physical unit is checked, and nothing unexpected carries one
        for k, u in want.items():
            assert got.get(k) == u, (model, ext, k, got.get(k), u)
        unitless = {"status", "events", "nearest", "mode", "lockstep", "design"}
        assert set(got) == set(want) | unitless, set(got) ^ (set(want) | unitless)
        for k in unitless:
            assert not got[k], k
        # the numbers are in those units: theta2 in degrees, a rate in rad/s at 10 rpm or 60 rpm
        assert np.allclose(ds[inp].values, [0, 90, 180, 270, 360])
        w = ds[f"{inp}_vel"].values
        assert np.allclose(w[np.isfinite(w)], w[0, 0]) and w[0, 0] in (pytest.approx(2 * np.pi / 6),
                                                                      pytest.approx(2 * np.pi))
