"""Design studies that must not run or must say why (issue 17, items 6, 13, 14 and the small ones).

Designs that are not designs get status ``invalid`` (the model file's link-length check, design
by design); a metric cannot overwrite a Dataset variable; too many designs or cells, too many
workers and a malformed scheduler address are refused before any work (one stderr line, exit
2); warnings are summarized per study and per-design events hold no machine path; sensitivity
variables carry units; ``python -m loopsolve`` runs; ``--lhs``/``--samples`` need LOW:HIGH boxes.
"""

from __future__ import annotations

import math
import os
import shutil
import subprocess
import sys
import tracemalloc

import numpy as np
import pytest

import loopsolve as ls

xr = pytest.importorskip("xarray", reason="the study extra (xarray) is not installed")

THESIS = ls.models_dir() / "thesis_crank_rocker.toml"


def run(*args, cwd=None):
    env = dict(os.environ)
    env.pop("LOOPSOLVE_DEBUG", None)
    return subprocess.run([sys.executable, "-m", "loopsolve.cli", *map(str, args)], capture_output=True, text=True,
                          env=env, cwd=cwd)


def study_cli(tmp_path, *args, model=THESIS, out="out.nc"):
    return run("study", model, *args, "-q", "-o", tmp_path / out)


def assert_refused(proc, *words):
    """Exit 2, one line on stderr naming ``words``, no traceback."""
    assert proc.returncode == 2, (proc.returncode, proc.stderr)
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith("loopsolve: ") and "Traceback" not in proc.stderr and "internal error" not in lines[0]
    for w in words:
        assert w in lines[0], (w, lines[0])


def fourbar_theta4(a, b, c, d, t2, open_=True):
    """theta4 (degrees) of r2 + r3 = r1 + r4 (r1 = d along x, r2 = a, r3 = b, r4 = c), Norton's half-angle form."""
    t2 = math.radians(t2)
    k1, k2, k3 = d / a, d / c, (a * a - b * b + c * c + d * d) / (2 * a * c)
    A = math.cos(t2) - k1 - k2 * math.cos(t2) + k3
    B = -2 * math.sin(t2)
    C = k1 - (k2 + 1) * math.cos(t2) + k3
    s = -1 if open_ else 1
    return math.degrees(2 * math.atan2(-B + s * math.sqrt(B * B - 4 * A * C), 2 * A))


# ----------------------------------------------------------------------------- item 6: designs that are not designs


def test_cli_negative_and_zero_crank_are_invalid_designs(tmp_path):
    proc = study_cli(tmp_path, "--vary", "r2=-25,0,25", "--from", "0", "--to", "360", "--step", "30")
    assert proc.returncode == 0, proc.stderr
    assert "1 invalid" not in proc.stderr and "2 invalid" in proc.stderr and "1 ok" in proc.stderr
    with xr.open_dataset(tmp_path / "out.nc") as ds:
        assert ds.status.values.tolist() == ["invalid", "invalid", "ok"]
        for i, r2 in ((0, -25), (1, 0)):
            ev = str(ds.events.values[i])
            assert "r2" in ev and "length" in ev and f"= {r2}" in ev, ev
            assert np.all(np.isnan(ds.theta4.values[i])) and np.all(np.isnan(ds.C_x.values[i]))
        # the valid design: the closed form (open circuit, as the model's guesses)
        for t2 in (0.0, 90.0, 210.0):
            got = float(ds.theta4.sel(theta2=t2).values[2])
            ref = fourbar_theta4(25, 70, 45, 60, t2)
            assert abs((got - ref + 180) % 360 - 180) < 1e-8, (t2, got, ref)


def test_python_invalid_designs_in_a_random_box():
    mech = ls.load(THESIS)
    ds = ls.study(mech, {"r2": (-30.0, 40.0)}, 0, 360, 30, samples=40, seed=2, progress=False)
    r2 = ds.r2.values
    assert (r2 <= 0).any() and (r2 > 0).any()
    st = ds.status.values
    assert np.array_equal(st == "invalid", r2 <= 0)
    assert all("must be positive" in str(e) for e in ds.events.values[r2 <= 0])
    # the same designs swept one by one (method="single") agree
    single = ls.study(mech, {"r2": r2[:6].tolist()}, 0, 360, 30, method="single", progress=False)
    assert single.status.values.tolist() == st[:6].tolist()


def test_a_length_expression_of_varied_parameters_is_checked(tmp_path):
    text = THESIS.read_text().replace("r2 = 25", "r2 = 25\nr5 = 0").replace(
        'r2 = { length = "r2", angle = "theta2" }', 'r2 = { length = "r2 + r5", angle = "theta2" }')
    model = tmp_path / "sum.toml"
    model.write_text(text)
    ds = ls.study(ls.load(model), {"r2": [25.0, 10.0], "r5": [0.0, -10.0]}, 0, 360, 90, progress=False)
    st = ds.status.values.reshape(2, 2)
    assert st.tolist() == [["ok", "ok"], ["ok", "invalid"]]  # r2 + r5 = 0 for (10, -10)
    assert "r2 = 10, r5 = -10" in str(ds.events.values[3])


@pytest.mark.parametrize("metric, extra", [("status=min(theta3)", ()), ("theta2=min(theta3)", ()),
                                           ("r2=min(theta3)", ()), ("d_theta4_d_r2=min(theta4)", ("--sensitivity",))])
def test_cli_metric_named_like_a_dataset_variable_is_refused(tmp_path, metric, extra):
    proc = study_cli(tmp_path, "--vary", "r2=20,25", "--from", "0", "--to", "360", "--step", "30", "--metric", metric,
                     *extra)
    assert_refused(proc, repr(metric.split("=")[0]), "already a variable")
    assert not (tmp_path / "out.nc").exists()


def test_python_metric_names_refused():
    mech = ls.load(THESIS)
    for metrics in ({"status": "min(theta3)"}, ["mode=min(theta4)"], ["theta3=max(theta3)"], ["C_x_acc=max(C_x)"],
                    ["events=r2/r3"], ["lockstep=r2"], ["design=r2"], ["mu=min(theta4)", "mu=max(theta4)"]):
        with pytest.raises(ls.ModelError, match="already a variable|two metrics"):
            ls.study(mech, {"r2": [20.0]}, 0, 90, 30, metrics=metrics, progress=False)
    ds = ls.study(mech, {"r2": [20.0]}, 0, 90, 30, metrics={"r3": "r3 + 0"}, progress=False)  # a fixed parameter
    assert ds.status.values.tolist() == ["ok"] and float(ds["r3"].values[0]) == 70.0


# ----------------------------------------------------------------------------- item 13: bounded work


def test_cli_too_many_cells_refused(tmp_path):
    proc = study_cli(tmp_path, "--vary", "r2=20:40:100000", "--from", "0", "--to", "360", "--step", "0.1")
    assert_refused(proc, "100,000 designs", "3,601 rows", "--max-cells")
    assert not (tmp_path / "out.nc").exists()


def test_cli_too_many_designs_refused(tmp_path):
    proc = study_cli(tmp_path, "--vary", "r2=20:40:2000", "--vary", "r3=60:80:2000", "--vary", "r4=40:50:2000",
                     "--from", "0", "--to", "360", "--step", "10")
    assert_refused(proc, "8,000,000,000 designs", "--max-designs")
    proc = study_cli(tmp_path, "--vary", "r2=20:40:100000000000", "--from", "0", "--to", "360", "--step", "10")
    assert_refused(proc, "100,000,000,000 designs", "--max-designs")
    proc = study_cli(tmp_path, "--vary", "r2=20:40", "--samples", "1000000", "--from", "0", "--to", "360",
                     "--step", "10")
    assert_refused(proc, "1,000,000 designs")


def test_cli_limits_are_overridable(tmp_path):
    args = ("--vary", "r2=20,25,30", "--from", "0", "--to", "360", "--step", "30")  # 3 designs x 13 rows = 39 cells
    assert_refused(study_cli(tmp_path, *args, "--max-cells", "38"), "39 cells", "38")
    assert_refused(study_cli(tmp_path, *args, "--max-designs", "2"), "3 designs")
    proc = study_cli(tmp_path, *args, "--max-cells", "39", "--max-designs", "3")
    assert proc.returncode == 0, proc.stderr
    with xr.open_dataset(tmp_path / "out.nc") as ds:
        assert ds.sizes == {"design": 3, "theta2": 13}


def test_python_limits_refuse_before_making_the_grid():
    mech = ls.load(THESIS)
    axes = {"r2": np.linspace(20, 40, 2000), "r3": np.linspace(60, 80, 2000), "r4": np.linspace(40, 50, 2000)}
    tracemalloc.start()
    try:
        with pytest.raises(ls.ModelError, match="8,000,000,000 designs"):
            ls.study(mech, axes, 0, 360, 10, progress=False)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 20e6, peak  # the 8e9-design grid (64 GB per axis) was never made
    with pytest.raises(ls.ModelError, match="max_cells"):
        ls.study(mech, {"r2": [20.0, 25.0]}, 0, 360, 30, max_cells=25, progress=False)  # 2 x 13 = 26
    with pytest.raises(ls.ModelError, match="max_designs"):
        ls.study(mech, {"r2": [20.0, 25.0]}, 0, 360, 30, max_designs=1, progress=False)
    with pytest.raises(ls.ModelError, match="max_designs"):
        ls.study(mech, {"r2": (20.0, 25.0)}, 0, 360, 30, lhs=11, max_designs=10, progress=False)
    ds = ls.study(mech, {"r2": [20.0, 25.0]}, 0, 360, 30, max_cells=26, max_designs=2, progress=False)
    assert ds.sizes["design"] == 2


def test_cli_workers_beyond_the_machine_refused(tmp_path):
    try:
        cpus = len(os.sched_getaffinity(0))
    except AttributeError:
        cpus = os.cpu_count()
    for n in (cpus + 1, 0):
        proc = study_cli(tmp_path, "--vary", "r2=20,25", "--from", "0", "--to", "90", "--step", "30",
                         "--workers", str(n))
        assert_refused(proc, f"--workers {n}")
    with pytest.raises(ls.ModelError, match="--workers"):
        ls.study(ls.load(THESIS), {"r2": [20.0]}, 0, 90, 30, workers=cpus + 1, progress=False)


@pytest.mark.parametrize("address", ["not a url", "127.0.0.1"])
def test_cli_bad_scheduler_address_is_a_usage_error(tmp_path, address):
    proc = study_cli(tmp_path, "--vary", "r2=20,25", "--from", "0", "--to", "90", "--step", "30",
                     "--scheduler", address)
    assert_refused(proc, "--scheduler", repr(address))


# ----------------------------------------------------------------------------- item 14: warnings and events


def test_cli_random_box_warns_once_per_kind(tmp_path):
    proc = study_cli(tmp_path, "--vary", "r2=20:80", "--vary", "r3=40:90", "--samples", "30", "--from", "0", "--to",
                     "360", "--step", "30")
    assert proc.returncode == 0, proc.stderr
    lines = proc.stderr.strip().splitlines()
    warned = [ln for ln in lines if ln.startswith("loopsolve: warning:")]
    with xr.open_dataset(tmp_path / "out.nc") as ds:
        limit = int((ds.status.values == "limit").sum())
        first = int(np.flatnonzero(ds.status.values == "limit")[0])
        stop = float(ds.stop.values[first])
    assert limit >= 5  # the box holds designs that jam
    assert len(warned) == 1, lines  # one line for all of them (one per design before)
    assert f"{limit} of 30 designs" in warned[0] and "limit position" in warned[0]
    assert f"(design {first}'s)" in warned[0] and f"{stop:.10g}" in warned[0]
    assert "--through-limits" not in warned[0]  # not an option of a study
    assert len(lines) == 2 and lines[1].startswith("wrote ")


def test_python_study_warns_once_per_kind():
    import warnings

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ds = ls.study(ls.load(THESIS), {"r2": (20.0, 80.0), "r3": (40.0, 90.0)}, 0, 360, 30, samples=30,
                      progress=False)
    ours = [w for w in caught if issubclass(w.category, ls.LoopsolveWarning)]
    limit = int((ds.status.values == "limit").sum())
    assert limit >= 5 and len(ours) == 1 and f"{limit} of 30 designs" in str(ours[0].message)


def test_events_hold_no_machine_path(tmp_path):
    where = tmp_path / "a_private_directory_name"
    where.mkdir()
    model = where / "rocker.toml"
    shutil.copy(THESIS, model)
    # not assemblable at the start, a limit, invalid and ok designs
    proc = study_cli(tmp_path, "--vary", "r2=-5,10,25,40,45", "--vary", "r3=40,70", "--from", "0", "--to", "360",
                     "--step", "10", model=model)
    assert proc.returncode == 0, proc.stderr
    assert "a_private_directory_name" not in proc.stderr
    with xr.open_dataset(tmp_path / "out.nc") as ds:
        st = set(ds.status.values.tolist())
        assert {"ok", "limit", "not-assemblable", "invalid"} <= st, st
        events = [str(e) for e in ds.events.values]
        assert all(e for e, s in zip(events, ds.status.values) if s != "ok")
        for e in events:
            assert "a_private_directory_name" not in e and str(tmp_path) not in e, e
            assert not e.startswith(ds.attrs["model"])
        na = events[ds.status.values.tolist().index("not-assemblable")]
        assert na.startswith("cannot be assembled at theta2 = 0 deg"), na


# ----------------------------------------------------------------------------- smaller items


def test_sensitivity_variables_have_units(tmp_path):
    ds = ls.study(ls.load(THESIS), {"r2": [20.0, 25.0]}, 0, 360, 30, sensitivity=True, progress=False)
    assert ds["d_theta4_d_r2"].attrs["units"] == "deg/mm"
    assert ds["d_theta3_d_r2"].attrs["units"] == "deg/mm"
    ls.design.studies.write(ds, tmp_path / "s.nc")
    with xr.open_dataset(tmp_path / "s.nc") as back:
        assert back["d_theta4_d_r2"].attrs["units"] == "deg/mm"
        assert back["theta4_vel"].attrs["units"] == "rad/s"


def test_sensitivity_units_of_a_slider_and_an_angle_parameter(tmp_path):
    pytest.importorskip("zarr")
    text = THESIS.read_text().replace("r1 = 60", "r1 = 60\nbeta = 0").replace(
        'r1 = { length = "r1", angle = 0 }', 'r1 = { length = "r1", angle = "beta" }')
    model = tmp_path / "tilted.toml"
    model.write_text(text)
    ls.study(ls.load(model), {"beta": [0.0, 5.0]}, 0, 360, 90, sensitivity=True, progress=False,
             out=tmp_path / "s.zarr")
    ds = xr.open_zarr(tmp_path / "s.zarr")
    assert ds["d_theta4_d_beta"].attrs["units"] == "deg/deg"


def test_lhs_and_samples_refuse_a_count_or_a_list(tmp_path):
    base = ("--from", "0", "--to", "360", "--step", "90")
    assert_refused(study_cli(tmp_path, "--vary", "r2=20:40:5", "--lhs", "10", *base), "r2=20:40:5", "LOW:HIGH")
    assert_refused(study_cli(tmp_path, "--vary", "r2=20,30,40", "--samples", "10", *base), "LOW:HIGH")
    proc = study_cli(tmp_path, "--vary", "r2=20:40", "--lhs", "10", *base)
    assert proc.returncode == 0, proc.stderr
    with xr.open_dataset(tmp_path / "out.nc") as ds:  # one design in each tenth of [20, 40]
        assert sorted(np.floor((ds.r2.values - 20) / 2).astype(int).tolist()) == list(range(10))
    with pytest.raises(ls.ModelError, match="LOW:HIGH"):
        ls.study(ls.load(THESIS), {"r2": [20.0, 30.0, 40.0]}, 0, 360, 90, lhs=5, progress=False)


def test_python_dash_m_loopsolve_runs(tmp_path):
    env = dict(os.environ)
    proc = subprocess.run([sys.executable, "-m", "loopsolve", "solve", str(THESIS), "--at", "90", "--format", "json"],
                          capture_output=True, text=True, env=env)
    assert proc.returncode == 0, proc.stderr
    import json

    row = json.loads(proc.stdout)["rows"][0]
    assert abs((row["theta4"] - fourbar_theta4(25, 70, 45, 60, 90.0) + 180) % 360 - 180) < 1e-9
    bad = subprocess.run([sys.executable, "-m", "loopsolve", "solve", str(tmp_path / "missing.toml")],
                         capture_output=True, text=True, env=env)
    assert bad.returncode == 2 and len(bad.stderr.strip().splitlines()) == 1


def test_unreachable_scheduler_is_a_model_error(monkeypatch):
    """A well-formed address where no scheduler answers: one ModelError naming it (no wait in the test)."""
    distributed = pytest.importorskip("distributed")

    def refuse(address, timeout=None, **kw):
        raise OSError(f"Timed out trying to connect to {address} after {timeout}")

    monkeypatch.setattr(distributed, "Client", refuse)
    with pytest.raises(ls.ModelError, match=r"--scheduler 'tcp://127.0.0.1:9'.*cannot connect") as info:
        ls.study(ls.load(THESIS), {"r2": [20.0]}, 0, 90, 30, scheduler="tcp://127.0.0.1:9", progress=False)
    assert "\n" not in str(info.value)


def test_a_negative_seed_is_refused_before_any_work(tmp_path):
    """``study --samples N --seed -1`` was an internal ValueError from numpy (issue 29)."""
    assert_refused(study_cli(tmp_path, "--vary", "r2=20:30", "--samples", "3", "--seed", "-1", "--from", "0", "--to",
                             "90", "--step", "30"), "--seed -1", "at least 0")
    assert not (tmp_path / "out.nc").exists()
