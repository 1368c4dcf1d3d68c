"""Design studies: every design equals its own single sweep and the closed form; metrics,
sensitivities (finite differences), Dask (identical results, a worker killed mid-study), files."""

from __future__ import annotations

import math
import os
import threading
import time

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.design.designs import grid, latin_hypercube, parse_vary, sample

from support.models import fan_model

xr = pytest.importorskip("xarray", reason="the study extra (xarray) is not installed")

THESIS = ls.models_dir() / "thesis_crank_rocker.toml"
STEP = 10.0


# ----------------------------------------------------------------------------- closed form (Norton)


def fourbar_roots(a, b, c, d, t2):
    """Both closed-form solutions (theta3, theta4) of the loop r2 + r3 = r1 + r4 (r1 along x), radians."""
    k1, k2, k3 = d / a, d / c, (a * a - b * b + c * c + d * d) / (2 * a * c)
    A = np.cos(t2) - k1 - k2 * np.cos(t2) + k3
    B = -2 * np.sin(t2)
    C = k1 - (k2 + 1) * np.cos(t2) + k3
    disc = np.sqrt(B * B - 4 * A * C)
    out = []
    for s in (-1, 1):
        t4 = 2 * np.arctan2(-B + s * disc, 2 * A)
        v = d + c * np.exp(1j * t4) - a * np.exp(1j * t2)  # = b e^{i theta3}
        out.append((np.angle(v), t4))
    return out


def wrap_deg(x):
    return (np.asarray(x) + 180.0) % 360.0 - 180.0


def close_angles(a, b, tol):
    return np.abs(wrap_deg(a - b)) <= tol


def single_rows(sw):
    """Single-sweep columns keyed by the input value."""
    return {float(x): i for i, x in enumerate(sw.columns[sw.input])}


@pytest.fixture(scope="module")
def thesis():
    return ls.load(THESIS)


# ----------------------------------------------------------------------------- designs


def test_designs_grid_sample_lhs():
    assert parse_vary("r2=20:40:5") == ("r2", [20.0, 25.0, 30.0, 35.0, 40.0])
    assert parse_vary("r3 = 1, 2.5") == ("r3", [1.0, 2.5])
    d = grid({"a": [1, 2], "b": [10, 20, 30]})
    assert len(d) == 6 and d.values["a"].tolist() == [1, 1, 1, 2, 2, 2] and d.values["b"].tolist()[:3] == [10, 20, 30]
    s1, s2 = sample({"a": (0, 1), "b": (5, 6)}, 50, seed=3), sample({"a": (0, 1), "b": (5, 6)}, 50, seed=3)
    assert np.array_equal(s1.values["b"], s2.values["b"]) and s1.values["b"].min() >= 5 and s1.values["b"].max() <= 6
    lhs = latin_hypercube({"a": (0, 1), "b": (0, 1)}, 20, seed=1)
    for n in ("a", "b"):  # one sample in each of the 20 strata of every axis
        assert sorted(np.floor(lhs.values[n] * 20).astype(int).tolist()) == list(range(20))
    for bad in ("r2", "r2=", "r2=1:2:0", "r2=a,b", "r2=1:2:3:4"):
        with pytest.raises(ls.ModelError):
            parse_vary(bad)


# ----------------------------------------------------------------------------- every design = its own sweep


R2 = [10.0, 20.0, 25.0, 32.0, 40.0, 50.0]
R3 = [40.0, 70.0, 90.0]


@pytest.fixture(scope="module")
def grid_study(thesis):
    return ls.study(thesis, {"r2": R2, "r3": R3}, 0, 360, STEP, chunk_size=8)


def test_grid_spans_the_cases(grid_study):
    st = grid_study.status.values.tolist()
    assert "ok" in st and "limit" in st and "not-assemblable" in st
    assert grid_study.lockstep.values.any() and not grid_study.lockstep.values.all()
    g = np.array([np.sign(min(60, r2, r3, 45) + max(60, r2, r3, 45) - (60 + r2 + r3 + 45 - min(60, r2, r3, 45)
                                                                        - max(60, r2, r3, 45)))
                  for r2, r3 in zip(grid_study.r2.values, grid_study.r3.values)])
    assert (g > 0).any() and (g < 0).any()  # Grashof and non-Grashof designs


def test_each_design_equals_its_single_sweep(thesis, grid_study):
    ds = grid_study
    inp = "theta2"
    cols = [k for k, v in ds.data_vars.items() if v.dims == ("design", inp)]
    for d in range(ds.sizes["design"]):
        r2, r3 = float(ds.r2[d]), float(ds.r3[d])
        m = thesis.with_parameters(r2=r2, r3=r3)
        status = str(ds.status.values[d])
        try:
            sw = m.sweep(0, 360, STEP)
        except ls.AssemblyError as exc:
            assert status == "not-assemblable"
            # located in the chunk by bisection to round-off; the single sweep's tracer to 1e-9 rad
            near = [float(v) for v in ds.nearest.values[d].split(",")]
            assert near == pytest.approx(list(exc.nearest), abs=6e-8)
            assert np.all(np.isnan(ds.theta3.values[d]))
            continue
        limits = [e.input for e in sw.events if e.kind is ls.EventKind.LIMIT]
        assert status == ("limit" if limits else "ok"), (r2, r3)
        if limits:
            assert ds.stop.values[d] == pytest.approx(limits[0], abs=6e-8)
        events = [e.split("@") for e in ds.events.values[d].split("; ") if e]
        assert [k for k, _ in events] == [e.kind.value for e in sw.events]
        assert [float(v) for _, v in events] == pytest.approx([e.input for e in sw.events], abs=6e-8)
        assert ds["mode"].values[d] == sw.mode
        rows = single_rows(sw)
        xs = ds[inp].values
        have = np.array([float(x) in rows for x in xs])
        assert np.all(np.isnan(ds.theta3.values[d][~have]))
        idx = [rows[float(x)] for x in xs[have]]
        for c in cols:
            mine = ds[c].values[d][have]
            ref = np.asarray(sw.columns[c])[idx]
            assert np.allclose(mine, ref, rtol=1e-10, atol=1e-9, equal_nan=True), (r2, r3, c)


def test_each_design_equals_the_closed_form(grid_study):
    ds = grid_study
    w2 = 2 * math.pi * 10 / 60  # the model's 10 rpm
    for d in range(ds.sizes["design"]):
        have = np.isfinite(ds.theta3.values[d])
        if not have.any():
            continue
        a, b, c, dd = float(ds.r2[d]), float(ds.r3[d]), 45.0, 60.0
        t2 = np.radians(ds.theta2.values[have])
        t3, t4 = ds.theta3.values[d][have], ds.theta4.values[d][have]
        matches = []
        for r3c, r4c in fourbar_roots(a, b, c, dd, t2):
            matches.append(close_angles(t3, np.degrees(r3c), 1e-7) & close_angles(t4, np.degrees(r4c), 1e-7))
        assert (matches[0] | matches[1]).all(), (a, b)
        if "singular" not in ds.events.values[d]:
            # every row on one closed-form branch, the same one throughout (the mode is kept); only a
            # design through a change point (r1 + r2 = r3 + r4 here: 25, 40) goes on smoothly onto the other
            assert matches[0].all() or matches[1].all(), (a, b)
        th3, th4 = np.radians(t3), np.radians(t4)
        w3 = a * w2 * np.sin(th4 - t2) / (b * np.sin(th3 - th4))
        w4 = a * w2 * np.sin(t2 - th3) / (c * np.sin(th4 - th3))
        assert np.allclose(ds.theta3_vel.values[d][have], w3, rtol=1e-8, atol=1e-10)
        assert np.allclose(ds.theta4_vel.values[d][have], w4, rtol=1e-8, atol=1e-10)


def test_near_change_point_designs_keep_mode_and_stop_at_limits():
    """Grashof change point r1 + r2 = r3 + r4 (60 + 25 = 40 + 45), perturbed both ways, in one chunk."""
    mech = ls.fourbar(60, 25, 40, 45)
    eps = [-1e-3, -1e-5, 1e-5, 1e-3]
    ds = ls.study(mech, {"r3": [40 + e for e in eps]}, 0, 360, 5, chunk_size=16)
    for d, e in enumerate(eps):
        r3 = 40 + e
        sw = mech.with_parameters(r3=r3).sweep(0, 360, 5)
        assert set(sw.modes) == {ds["mode"].values[d]}  # one mode throughout, the study's
        have = np.isfinite(ds.theta4.values[d])
        assert have.sum() == len(sw)
        assert np.allclose(ds.theta4.values[d][have], sw["theta4"], atol=1e-9)
        if e < 0:  # r1 + r2 > r3 + r4: non-Grashof, the crank stops where coupler and rocker line up
            lim = math.degrees(math.acos((25**2 + 60**2 - (r3 + 45) ** 2) / (2 * 25 * 60)))
            assert ds.status.values[d] == "limit"
            assert abs(ds.stop.values[d] - lim) < 1e-6
            assert np.nanmax(ds.theta2.values[have]) < lim
        else:
            assert ds.status.values[d] == "ok" and have.all()
        # the rows stay on one closed-form branch (no jump at the near-change point)
        t2 = np.radians(ds.theta2.values[have])
        roots = fourbar_roots(25.0, r3, 45.0, 60.0, t2)
        on = [close_angles(ds.theta4.values[d][have], np.degrees(r4), 1e-6) for _, r4 in roots]
        assert on[0].all() or on[1].all()


def test_single_method_equals_lockstep(thesis):
    vary = {"r2": [15.0, 22.0, 28.0]}
    a = ls.study(thesis, vary, 0, 360, 15)
    b = ls.study(thesis, vary, 0, 360, 15, method="single")
    assert a.lockstep.values.all() and not b.lockstep.values.any()
    for k, v in a.data_vars.items():
        if v.dtype.kind == "f":
            assert np.allclose(v.values, b[k].values, rtol=1e-10, atol=1e-10, equal_nan=True), k


# ----------------------------------------------------------------------------- metrics


def test_metrics_equal_reductions_of_the_columns(thesis):
    metrics = {"min_tr": "min(abs(sin(theta4 - theta3)))", "mx": "max(theta4_acc)", "mean_c": "mean(C_x)",
               "pp": "ptp(theta4)", "amin": "argmin(theta4)", "amax": "argmax(C_y)",
               "mu": "transmission(theta3, theta4)", "swing": "swing(theta4)", "acc": "max_acc(theta4)",
               "g": "grashof(r1, r2, r3, r4)", "ratio": "r2 / r3"}
    ds = ls.study(thesis, {"r2": [15.0, 25.0, 32.0, 45.0], "r3": [70.0]}, 0, 360, 5, metrics=metrics)
    x = ds.theta2.values
    for d in range(4):
        t3, t4 = np.radians(ds.theta3.values[d]), np.radians(ds.theta4.values[d])
        ok = np.isfinite(t3)
        if not ok.any():
            for k in ("min_tr", "mx", "mu", "swing"):
                assert np.isnan(ds[k].values[d])
        else:
            assert ds.min_tr.values[d] == pytest.approx(np.min(np.abs(np.sin(t4 - t3))[ok]), abs=1e-15)
            assert ds.mx.values[d] == pytest.approx(np.max(ds.theta4_acc.values[d][ok]), abs=1e-15)
            assert ds.mean_c.values[d] == pytest.approx(np.mean(ds.C_x.values[d][ok]), rel=1e-14)
            assert ds.pp.values[d] == pytest.approx(np.ptp(t4[ok]), abs=1e-14)  # angles in radians inside EXPR
            assert ds.amin.values[d] == x[ok][np.argmin(ds.theta4.values[d][ok])]
            assert ds.amax.values[d] == x[ok][np.argmax(ds.C_y.values[d][ok])]
            gam = np.degrees(np.abs(t4 - t3)[ok]) % 180
            assert ds.mu.values[d] == pytest.approx(np.min(np.minimum(gam, 180 - gam)), abs=1e-9)
            assert ds.swing.values[d] == pytest.approx(np.ptp(ds.theta4.values[d][ok]), abs=1e-12)
            assert ds.acc.values[d] == pytest.approx(np.max(np.abs(ds.theta4_acc.values[d][ok])), abs=1e-15)
        r2 = float(ds.r2[d])
        L = sorted([60, r2, 70, 45])
        assert ds.g.values[d] == (1.0 if L[0] + L[3] < L[1] + L[2] else -1.0)
        assert ds.ratio.values[d] == pytest.approx(r2 / 70)


def test_quick_return_time_ratio_metric():
    mech = ls.load(ls.models_dir() / "quick_return.toml")
    ds = ls.study(mech, {"r2": [60.0, 100.0, 150.0]}, 0, 360, 1, metrics=["tr=time_ratio(theta4)"])
    for d, r2 in enumerate([60.0, 100.0, 150.0]):
        alpha = math.degrees(math.acos(r2 / 200))  # crank perpendicular to the lever at the extremes
        assert ds.tr.values[d] == pytest.approx((360 - 2 * alpha) / (2 * alpha), rel=1e-7)


def test_bad_metric_and_parameter_are_model_errors(thesis):
    with pytest.raises(ls.ModelError, match="not a parameter"):
        ls.study(thesis, {"zz": [1.0]}, 0, 360, 10)
    with pytest.raises(ls.ModelError):
        ls.study(thesis, {"r2": [20.0]}, 0, 360, 10, metrics=["m=median(theta4)"])
    with pytest.raises(ls.ModelError, match="unknown name"):
        ls.study(thesis, {"r2": [20.0]}, 0, 360, 10, metrics=["m=min(theta9)"])


# ----------------------------------------------------------------------------- sensitivities


def test_sensitivities_equal_finite_differences():
    mech = ls.load(THESIS)
    ds = ls.study(mech, {"r1": [60.0, 58.0], "r2": [25.0, 22.0], "r3": [70.0]}, 0, 360, 20, sensitivity=True)
    h = 1e-3
    for d in range(ds.sizes["design"]):
        p = {"r1": float(ds.r1[d]), "r2": float(ds.r2[d]), "r3": float(ds.r3[d]), "r4": 45.0}
        ok = np.isfinite(ds.theta3.values[d])
        t2 = np.radians(ds.theta2.values[ok])
        # the closed-form branch of this design
        roots = fourbar_roots(p["r2"], p["r3"], p["r4"], p["r1"], t2)
        k = 0 if close_angles(ds.theta4.values[d][ok], np.degrees(roots[0][1]), 1e-7).all() else 1

        def q(**kw):
            pp = {**p, **kw}
            r3c, r4c = fourbar_roots(pp["r2"], pp["r3"], pp["r4"], pp["r1"], t2)[k]
            return np.degrees(np.unwrap(r3c)), np.degrees(np.unwrap(r4c))

        for name in ("r1", "r2", "r3"):
            f = [q(**{name: p[name] + s * h}) for s in (-2, -1, 1, 2)]
            for j, u in enumerate(("theta3", "theta4")):
                fd = (f[0][j] - 8 * f[1][j] + 8 * f[2][j] - f[3][j]) / (12 * h)
                got = ds[f"d_{u}_d_{name}"].values[d][ok]
                assert np.allclose(got, fd, rtol=0, atol=1e-7), (d, name, u, np.max(np.abs(got - fd)))


# ----------------------------------------------------------------------------- Dask


@pytest.fixture(scope="module")
def cluster():
    distributed = pytest.importorskip("distributed")
    cl = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=":0")
    client = distributed.Client(cl)
    yield client
    client.close()
    try:
        cl.close(timeout=60)
    except TimeoutError:  # a nanny still restarting a killed worker on a loaded machine: Dask's, not the product's
        pass


def test_a_cluster_zarr_study_costs_its_client_the_same_for_four_times_the_designs(thesis, cluster, tmp_path):
    """To ``.zarr`` on a cluster the workers sweep and write every chunk; the client sweeps one design for the
    store's layout and gets counts back. So its peak memory (tracemalloc: numpy's buffers too) stays below half
    a chunk's part of the result, and 4N designs cost it at most a quarter chunk more than N (Dask's own
    bookkeeping per task; measured at 4 and 16 chunks: 0.2 chunk, +0.04). Sweeping the first chunk here (the code before) peaked
    at ~2.5 chunks; gathering the chunks grows with N."""
    import gc
    import tracemalloc

    box, c, step = {"r2": (15, 35), "r3": (50, 90)}, 400, 2

    def peak(n):
        gc.collect()
        tracemalloc.start()
        try:
            ls.study(thesis, box, 0, 360, step, lhs=n, chunk_size=c, client=cluster, out=tmp_path / f"s{n}.zarr",
                     progress=False)
            return tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()

    peak(c)  # the workers' caches, the scheduler's first tasks
    ds = ls.study(thesis, box, 0, 360, step, lhs=20, chunk_size=20, progress=False)
    chunk = c / 20 * sum(v.values.nbytes for v in ds.variables.values() if "design" in v.dims)
    # both below AUTO_CELLS (designs x rows): the workers run numpy, no numba compile in this test's minute
    small, big = peak(2 * c), peak(8 * c)
    assert big < chunk / 2 and big <= small + chunk / 4, (small / chunk, big / chunk)


DASK_VARY = {"r2": [12.0, 18.0, 24.0, 30.0, 36.0, 42.0], "r3": [50.0, 70.0, 90.0]}
DASK_METRICS = ["mu=transmission(theta3, theta4)"]


@pytest.fixture(scope="module")
def local_run(thesis):
    return ls.study(thesis, DASK_VARY, 0, 360, 5, metrics=DASK_METRICS, chunk_size=3)


def test_dask_two_workers_identical_to_local(thesis, cluster, local_run):
    remote = ls.study(thesis, DASK_VARY, 0, 360, 5, metrics=DASK_METRICS, chunk_size=3, client=cluster)
    xr.testing.assert_identical(local_run, remote)


def test_dask_worker_killed_mid_study_loses_nothing(thesis, cluster, local_run):
    killed = {}

    def killer():
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and not killed:
            busy = {w: ts for w, ts in cluster.processing().items() if ts}
            if busy:
                addr = sorted(busy)[0]
                killed["addr"], killed["tasks"] = addr, list(busy[addr])
                try:
                    cluster.run(os._exit, 1, workers=[addr])
                except Exception:  # the worker dies before it answers
                    pass
                return
            time.sleep(0.01)

    t = threading.Thread(target=killer)
    t.start()
    again = ls.study(thesis, DASK_VARY, 0, 360, 5, metrics=DASK_METRICS, chunk_size=1, client=cluster)
    t.join()
    assert killed.get("tasks"), "no worker was processing a chunk when the killer looked"
    xr.testing.assert_identical(local_run, again)


def test_dask_zarr_written_by_the_workers_equals_local(thesis, cluster, local_run, tmp_path):
    store = tmp_path / "study.zarr"
    z = ls.study(thesis, DASK_VARY, 0, 360, 5, metrics=DASK_METRICS, chunk_size=3, client=cluster, out=store)
    z = z.load()
    zarr = pytest.importorskip("zarr")
    group = zarr.open_group(str(store), mode="r")
    for name in ("status", "events", "theta4", "mu", "r2"):  # one zarr chunk per task: no shared writes
        assert group[name].chunks[0] == 3, name
    assert set(z.variables) == set(local_run.variables)
    for k in local_run.variables:
        a, b = local_run[k].values, z[k].values
        if a.dtype.kind == "f":
            assert np.array_equal(a, b, equal_nan=True), k
        else:
            assert (a == b).all(), k


def test_a_cluster_nc_study_equals_the_single_process_nc_and_leaves_no_store(thesis, cluster, local_run, tmp_path):
    """``.nc`` on a cluster: the workers write a temporary zarr store next to the output, the client converts it;
    the file is identical to the single-process one (text columns, int8 ``lockstep``, units, attributes) and
    only the output is left in its directory."""
    from loopsolve.design.studies import write

    write(local_run, tmp_path / "here.nc")
    (tmp_path / "there.nc").write_text("an older output: replaced, as the single-process write does")
    ds = ls.study(thesis, DASK_VARY, 0, 360, 5, metrics=DASK_METRICS, chunk_size=3, client=cluster,
                  out=tmp_path / "there.nc")
    assert sorted(os.listdir(tmp_path)) == ["here.nc", "there.nc"]
    xr.testing.assert_identical(local_run, ds.load())
    ds.close()
    with xr.open_dataset(tmp_path / "here.nc") as a, xr.open_dataset(tmp_path / "there.nc") as b:
        xr.testing.assert_identical(a, b)
        assert b.lockstep.dtype == np.int8 and b.status.values.tolist() == local_run.status.values.tolist()


@pytest.mark.parametrize("where", ["_run_dask_zarr", "store_to_netcdf"])
def test_an_interrupted_cluster_nc_study_removes_its_store(thesis, cluster, tmp_path, monkeypatch, where):
    """Ctrl-C while the workers write the store, or while the client converts it: the temporary store is
    removed and the user's files are untouched."""
    from loopsolve.design import studies

    real = getattr(studies, where)

    def interrupted(*args, **kw):
        real(*args, **kw)
        raise KeyboardInterrupt

    monkeypatch.setattr(studies, where, interrupted)
    (tmp_path / "keep.txt").write_text("mine")
    with pytest.raises(KeyboardInterrupt):
        ls.study(thesis, DASK_VARY, 0, 360, 30, chunk_size=6, client=cluster, out=tmp_path / "s.nc", progress=False)
    assert sorted(os.listdir(tmp_path)) == (["keep.txt", "s.nc"] if where == "store_to_netcdf" else ["keep.txt"])
    assert (tmp_path / "keep.txt").read_text() == "mine"


def test_a_cluster_nc_study_costs_its_client_a_chunk_whatever_the_designs(thesis, cluster, tmp_path):
    """The conversion of the workers' store to ``.nc`` reads one zarr chunk of one variable at a time, so the
    client's peak memory (tracemalloc: numpy's buffers too) stays below a chunk's part of the result. What grows
    with the designs is Dask's graph of the conversion (~7 kB per chunk and variable, not the data): 4N designs
    cost at most a quarter chunk more than N (measured at 4 and 16 chunks: 0.35 and 0.63 chunk, the sweeps'
    layout included). Gathering the chunks (the code before) held all of them."""
    import gc
    import tracemalloc

    box, c, step = {"r2": (15, 35), "r3": (50, 90)}, 400, 2

    def peak(n):
        gc.collect()
        tracemalloc.start()
        try:
            ls.study(thesis, box, 0, 360, step, lhs=n, chunk_size=c, client=cluster, out=tmp_path / f"s{n}.nc",
                     progress=False).close()
            return tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()

    ls.study(thesis, box, 0, 360, step, lhs=40, chunk_size=20, client=cluster, out=tmp_path / "warm.nc",
             progress=False).close()  # the workers' caches
    ds = ls.study(thesis, box, 0, 360, step, lhs=20, chunk_size=20, progress=False)
    chunk = c / 20 * sum(v.values.nbytes for v in ds.variables.values() if "design" in v.dims)
    small, big = peak(2 * c), peak(8 * c)
    assert big < chunk and big <= small + chunk / 4, (small / chunk, big / chunk)


def test_text_columns_of_any_string_kind_round_trip_through_nc(local_run, tmp_path):
    """``str`` mixed with ``np.str_`` (what some xarray/zarr versions hand back; the lowest xarray allowed cannot
    encode the mix) and numpy's fixed-width text are written as netCDF strings and read back equal."""
    from loopsolve.design.studies import write

    ds = local_run.copy()
    mixed = np.array([np.str_(s) if i % 2 else str(s) for i, s in enumerate(ds.status.values)], dtype=object)
    ds["status"] = ("design", mixed)
    ds["events"] = ("design", ds.events.values.astype(str))
    write(ds, tmp_path / "mixed.nc")
    with xr.open_dataset(tmp_path / "mixed.nc") as back:
        for k in ("status", "events", "nearest", "mode"):
            assert back[k].values.tolist() == [str(s) for s in local_run[k].values], k
        assert back.lockstep.values.tolist() == local_run.lockstep.values.astype(int).tolist()


def test_dask_runs_summarize_warnings_as_the_local_run(thesis, cluster, local_run, tmp_path):
    """One warning per kind, the same from the workers (also writing Zarr themselves) as locally."""
    import warnings

    def warned(**kw):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            ls.study(thesis, DASK_VARY, 0, 360, 5, metrics=DASK_METRICS, chunk_size=3, **kw)
        return [str(w.message) for w in caught if issubclass(w.category, ls.LoopsolveWarning)]

    limit = int((local_run.status.values == "limit").sum())
    here = warned()
    assert limit >= 2 and len(here) == 1 and here[0].startswith(f"{limit} of 18 designs"), here
    assert warned(client=cluster) == here
    assert warned(client=cluster, out=tmp_path / "w.zarr") == here


def test_cli_scheduler_address_runs_on_that_cluster(cluster, local_run, tmp_path):
    from loopsolve.cli import main

    out = tmp_path / "remote.nc"
    assert main(["study", str(THESIS), "--vary", "r2=" + ",".join(map(str, DASK_VARY["r2"])), "--vary",
                 "r3=" + ",".join(map(str, DASK_VARY["r3"])), "--from", "0", "--to", "360", "--step", "5",
                 "--metric", DASK_METRICS[0], "--chunk", "4", "--scheduler", cluster.scheduler.address, "-q",
                 "-o", str(out)]) == 0
    with xr.open_dataset(out) as ds:
        assert np.array_equal(ds.theta4.values, local_run.theta4.values, equal_nan=True)
        assert np.array_equal(ds.mu.values, local_run.mu.values, equal_nan=True)
        assert ds.status.values.tolist() == local_run.status.values.tolist()


# ----------------------------------------------------------------------------- the command line


def test_cli_writes_nc_zarr_csv(tmp_path):
    pd = pytest.importorskip("pandas")
    from loopsolve.cli import main

    base = ["study", str(THESIS), "--vary", "r2=20:40:3", "--vary", "r3=60,70", "--from", "0", "--to", "360",
            "--step", "30", "--metric", "min_transmission=min(abs(sin(theta4 - theta3)))", "-q"]
    for ext in ("nc", "zarr", "csv"):
        assert main(base + ["-o", str(tmp_path / f"out.{ext}")]) == 0
    nc = xr.open_dataset(tmp_path / "out.nc")
    zr = xr.open_zarr(tmp_path / "out.zarr")
    for ds in (nc, zr):
        assert ds.sizes["design"] == 6 and ds.sizes["theta2"] == 13
        assert sorted(set(ds.r2.values.tolist())) == [20.0, 30.0, 40.0]
        assert set(ds.status.values.tolist()) <= {"ok", "limit", "not-assemblable", "singular"}
        assert "min_transmission" in ds and "theta4_acc" in ds
    assert np.allclose(nc.theta4.values, zr.theta4.values, equal_nan=True)
    ok = nc.status.values == "ok"
    ref = np.min(np.abs(np.sin(np.radians(nc.theta4.values - nc.theta3.values))), axis=1)
    assert np.allclose(nc.min_transmission.values[ok], ref[ok])
    df = pd.read_csv(tmp_path / "out.csv")
    assert {"design", "r2", "r3", "theta2", "theta4", "status", "min_transmission"} <= set(df.columns)
    first = df[df.design == 0]
    assert np.allclose(first.theta4.values, nc.theta4.values[0][np.isfinite(nc.theta4.values[0])])
    nc.close()


def test_cli_study_errors_exit_2(tmp_path, capsys):
    from loopsolve.cli import main

    assert main(["study", str(THESIS), "--vary", "nope=1,2", "--from", "0", "--to", "90", "--step", "10",
                 "-o", str(tmp_path / "x.nc")]) == 2
    assert main(["study", str(THESIS), "--vary", "r2=1,2", "--from", "0", "--to", "90", "--step", "10",
                 "-o", str(tmp_path / "x.txt")]) == 2
    err = capsys.readouterr().err
    assert "nope" in err and ".txt" in err


# ----------------------------------------------------------------------------- hand-offs (issue 21)


def _mixed_box(n=500, seed=21):
    """The issue's box (r1 = 60; r2, r3, r4 uniform in [15, 30], [62, 75], [40, 50]), a few designs
    from its corner where θ2 = 0 cannot be assembled, and a few triple rockers that jam at a limit."""
    rng = np.random.default_rng(seed)
    box = np.column_stack([rng.uniform(15, 30, n), rng.uniform(62, 75, n), rng.uniform(40, 50, n)])
    gap = np.column_stack([rng.uniform(28, 30, 8), rng.uniform(73, 75, 8), rng.uniform(40, 41, 8)])
    jam = np.column_stack([rng.uniform(35, 45, 6), rng.uniform(30, 40, 6), rng.uniform(40, 50, 6)])
    return np.vstack([box, gap, jam])


@pytest.mark.filterwarnings("ignore:.*limit position")
def test_handed_off_designs_equal_their_single_sweep_and_the_closed_form(thesis, monkeypatch):
    """Status, stop and nearest assemblable inputs of the non-assemblable and limit designs of a
    seeded mixed box of 514 designs: those of the design's own sweep, and the closed form
    (the crank angle where |B O4| = |r3 − r4| or r3 + r4: cos θ2 = (r1² + r2² − d²) / (2 r1 r2)).
    The designs that cannot be assembled at the start are decided without the single sweep."""
    from loopsolve.design import lockstep
    from loopsolve.design.designs import Designs

    v = _mixed_box()
    d = Designs(("r2", "r3", "r4"), {"r2": v[:, 0], "r3": v[:, 1], "r4": v[:, 2]})
    alone = []
    single = lockstep._single
    monkeypatch.setattr(lockstep, "_single", lambda *a: (alone.append(a[-2]), single(*a)))
    # one chunk: `alone` holds indices within the chunk
    ds = ls.study(thesis, d, 0, 360, 5, derivatives=1, chunk_size=len(d), progress=False)
    monkeypatch.undo()
    status = ds.status.values
    r1 = 60.0
    r2, r3, r4 = v.T
    # closed form: assemblable at θ2 = 0 when |r3 − r4| <= r1 − r2 <= r3 + r4
    closed_na = (np.abs(r3 - r4) > r1 - r2) | (r3 + r4 < r1 - r2)
    assert np.array_equal(status == "not-assemblable", closed_na)
    assert closed_na.sum() >= 8 and (status == "limit").sum() >= 6
    assert not set(alone) & set(np.flatnonzero(closed_na).tolist())
    assert not set(alone) & set(np.flatnonzero(status == "limit").tolist())  # located in the chunk
    for j in np.flatnonzero(status != "ok"):
        m = thesis.with_parameters(r2=float(r2[j]), r3=float(r3[j]), r4=float(r4[j]))
        if status[j] == "not-assemblable":
            with pytest.raises(ls.AssemblyError) as exc:
                m.sweep(0, 360, 5, derivatives=1, progress=False)
            near = [float(s) for s in str(ds.nearest.values[j]).split(",")]
            # the single sweep's tracer locates the fold to 1e-9 in the input (5.7e-8 deg)
            assert near == pytest.approx(list(exc.value.nearest), abs=6e-8)
            assert ds.events.values[j] == str(exc.value).splitlines()[0].split(": ", 1)[1]  # without the model path
            assert float(ds.stop.values[j]) == 0.0
            dist = abs(r3[j] - r4[j])  # the box's gap: B too close to O4
            c = (r1 ** 2 + r2[j] ** 2 - dist ** 2) / (2 * r1 * r2[j])
            edge = math.degrees(math.acos(c))
            assert near == pytest.approx([-edge, edge], rel=1e-9)  # printed to 10 digits
        else:
            assert status[j] == "limit"
            sw = m.sweep(0, 360, 5, derivatives=1, progress=False)
            lim = [e.input for e in sw.events if e.kind.value == "limit"]
            assert float(ds.stop.values[j]) == pytest.approx(lim[0], abs=6e-8)  # the tracker: 1e-9 rad
            assert ds.events.values[j] == f"limit@{float(ds.stop.values[j]):.10g}" and ds.mode.values[j] == sw.mode
            rows = single_rows(sw)
            for x, i in rows.items():  # the rows up to the limit, and none after it
                k = int(round(x / 5))
                for name in ("theta3", "theta4", "theta4_vel"):
                    assert ds[name].values[j, k] == pytest.approx(sw.columns[name][i], rel=1e-12, abs=1e-12)
            assert np.isnan(ds.theta4.values[j, max(rows.values()) + 1:]).all()
            dist = r3[j] + r4[j]  # the first limit on the way up: B too far from O4
            edge = math.degrees(math.acos((r1 ** 2 + r2[j] ** 2 - dist ** 2) / (2 * r1 * r2[j])))
            assert float(ds.stop.values[j]) == pytest.approx(edge, abs=1e-8)


@pytest.mark.filterwarnings("ignore:.*limit position")
@pytest.mark.parametrize("eps", [1e-3, 1.4e-6, 2e-8])
def test_a_gap_between_rows_stops_the_design_there(thesis, eps):
    """r3 + r4 = r1 + r2 − ε: a gap around θ2 = 180° narrower than the output step (2.4°, 0.06°,
    0.006° wide), between the rows 177.5° and 182.5°, and a wide one near 360°: the study stops at
    the first, where its single sweep stops (closed form: |B O4| = r3 + r4)."""
    from loopsolve.design.designs import Designs

    r3, r4 = 60.5 - eps / 2, 24.5 - eps / 2
    d = Designs(("r2", "r3", "r4"), {"r2": np.array([25.0, 25.0]), "r3": np.array([r3, 70.0]),
                                      "r4": np.array([r4, 45.0])})
    ds = ls.study(thesis, d, 32.5, 392.5, 5, derivatives=1, progress=False)
    sw = thesis.with_parameters(r2=25, r3=r3, r4=r4).sweep(32.5, 392.5, 5, derivatives=1, progress=False)
    lim = [e.input for e in sw.events if e.kind is ls.EventKind.LIMIT]
    edge = math.degrees(math.acos((60 ** 2 + 25 ** 2 - (r3 + r4) ** 2) / (2 * 60 * 25)))
    assert ds.status.values.tolist() == ["limit", "ok"]
    assert float(ds.stop.values[0]) == pytest.approx(lim[0], abs=6e-8)
    assert float(ds.stop.values[0]) == pytest.approx(edge, abs=1e-6)
    assert np.isnan(ds.theta4.values[0, 30:]).all() and not np.isnan(ds.theta4.values[0, :30]).any()


def test_not_assemblable_designs_of_a_fan_of_dyads(tmp_path, monkeypatch):
    """A model of three independent dyads (a fan of four-bars on one crank): the designs that cannot be
    assembled at the start are decided in the chunk (never swept alone), with the nearest assemblable
    inputs of their own sweep."""
    from loopsolve.design import lockstep

    path = tmp_path / "fan.toml"
    path.write_text(fan_model(3), encoding="utf-8")
    mech = ls.load(path)
    d = sample({"G0": (3.0, 6.5), "C1": (3.0, 4.0), "A": (0.5, 2.5)}, 60, seed=3)
    alone = []
    single = lockstep._single
    monkeypatch.setattr(lockstep, "_single", lambda *a: (alone.append(a[-2]), single(*a)))
    ds = ls.study(mech, d, 150, 300, 5, derivatives=1, progress=False)
    monkeypatch.undo()
    na = np.flatnonzero(ds.status.values == "not-assemblable")
    assert 10 <= len(na) < len(d) and not set(alone) & set(na.tolist())
    for j in na:
        row = d.row(j)
        with pytest.raises(ls.AssemblyError) as exc:
            mech.with_parameters(**row).sweep(150, 300, 5, derivatives=1, progress=False)
        near = [float(v) for v in ds.nearest.values[j].split(",")]
        assert near == pytest.approx(list(exc.value.nearest), abs=6e-8)


def test_not_assemblable_offset_slider_cranks_decided_in_the_chunk(monkeypatch):
    """An offset slider-crank (two 1×1 blocks, the coupler angle feeding the slider position): a design
    with offset e > r3 cannot be assembled at θ2 = 0; it is decided in the chunk, and its nearest
    assemblable inputs are where r2 sin θ2 − e = −r3 (closed form) and those of its own sweep (none
    when e − r3 > r2)."""
    from loopsolve.design import lockstep

    mech = ls.load(ls.models_dir() / "prob2_offset_slider_crank.toml")
    d = sample({"r2": (300.0, 900.0), "e": (1000.0, 2600.0)}, 40, seed=4)
    alone = []
    single = lockstep._single
    monkeypatch.setattr(lockstep, "_single", lambda *a: (alone.append(a[-2]), single(*a)))
    ds = ls.study(mech, d, 0, 360, 10, derivatives=1, progress=False)
    monkeypatch.undo()
    r2, e, r3 = d.values["r2"], d.values["e"], 1600.0
    na = e > r3
    assert np.array_equal(ds.status.values == "not-assemblable", na) and 5 <= na.sum() < len(d)
    assert not set(alone) & set(np.flatnonzero(na).tolist())
    for j in np.flatnonzero(na):
        with pytest.raises(ls.AssemblyError) as exc:
            mech.with_parameters(r2=float(r2[j]), e=float(e[j])).sweep(0, 360, 10, derivatives=1, progress=False)
        text = ds.nearest.values[j]
        near = [float(v) for v in text.split(",")] if text else []
        assert near == pytest.approx(list(exc.value.nearest), abs=6e-8)
        if e[j] - r3 > r2[j]:
            assert near == []
        else:
            a = math.degrees(math.asin((e[j] - r3) / r2[j]))
            assert near == pytest.approx([-180 - a, a], rel=1e-9)


@pytest.mark.parametrize("gap", [1e-9, 1e-8, 5e-8, 1e-7, 1e-5])
def test_a_start_a_hair_from_a_change_point_gets_the_single_sweeps_verdict(thesis, gap):
    """r2 + r3 = r1 + r4 exactly is a change point at θ2 = 0 (B, O4 and C in line). A rocker
    shorter by ``gap`` cannot be assembled there (|r3 − r4| > r1 − r2), but by so little that the
    single sweep may call the start singular instead: the study must say what the single sweep
    says (it used to decide "not-assemblable" from the closed form at 1e-9). Longer by ``gap``:
    assemblable or singular, as the single sweep says."""
    import warnings

    for r4 in (40.0 - gap, 40.0 + gap):
        mech = thesis.with_parameters(r2=25.0, r3=75.0, r4=r4)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                mech.sweep(0, 10, 5)
                want = "ok"
            except ls.SingularPositionError:
                want = "singular"
            except ls.AssemblyError:
                want = "not-assemblable"
            ds = ls.study(thesis, {"r2": [25.0], "r3": [75.0], "r4": [r4]}, start=0, stop=10, step=5)
        assert str(ds["status"].values[0]) == want, (r4, want)
        if r4 < 40.0 and gap >= 1e-7:  # clearly apart: the closed form and the sweep agree
            assert want == "not-assemblable"


def test_a_study_holds_its_result_and_one_chunk_not_the_result_twice(thesis):
    """The chunks are copied into the result's arrays as they come (not collected and concatenated): the peak
    memory of a study (tracemalloc sees numpy's buffers) stays within the result plus a few chunks' working
    arrays. Collecting the eight chunks and concatenating them peaked at twice the result."""
    import gc
    import tracemalloc

    n = 400
    # caches, and the engine a study of this size runs ("auto": numba's compile is not the study's memory)
    ls.study(thesis, {"r2": (15, 35), "r3": (50, 90)}, 0, 360, 2, lhs=n, chunk_size=n // 8, progress=False)
    gc.collect()
    tracemalloc.start()
    try:
        ds = ls.study(thesis, {"r2": (15, 35), "r3": (50, 90)}, 0, 360, 2, lhs=n, chunk_size=n // 8, progress=False)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    result = sum(v.values.nbytes for v in ds.variables.values())
    chunk = result / 8
    assert peak <= result + 4 * chunk, (peak / result)
    assert ds.sizes["design"] == n and np.array_equal(ds["design"].values, np.arange(n))


def test_the_default_chunk_is_one_for_a_small_study_and_tenths_of_a_large_one(thesis, tmp_path, monkeypatch):
    """Without ``chunk_size`` a study small enough (designs × rows ≤ CHUNK_CELLS) runs as one chunk, and its
    result is that chunk, not a copy; a larger one is cut in tenths of at least CHUNK_MIN designs, each
    chunk at most CHUNK_CELLS cells. The ``.zarr`` store's chunks are the study's (one write a chunk)."""
    zarr = pytest.importorskip("zarr")
    from loopsolve.design import studies

    box = {"r2": (15, 35), "r3": (50, 90)}
    rows = 13  # 0, 30, ..., 360
    small = ls.study(thesis, box, 0, 360, 30, lhs=40, progress=False, out=tmp_path / "small.zarr")
    assert zarr.open_group(str(tmp_path / "small.zarr"), mode="r")["theta4"].chunks[0] == 40
    monkeypatch.setattr(studies, "CHUNK_CELLS", 30 * rows)  # 30 designs at most a chunk
    monkeypatch.setattr(studies, "CHUNK_MIN", 5)
    big = ls.study(thesis, box, 0, 360, 30, lhs=40, progress=False, out=tmp_path / "big.zarr")
    assert zarr.open_group(str(tmp_path / "big.zarr"), mode="r")["theta4"].chunks[0] == 5  # tenths of 40 ≥ 5
    monkeypatch.setattr(studies, "CHUNK_MIN", 16)
    assert studies.default_chunk(40, rows) == 16 and studies.default_chunk(400, rows) == 30  # the cap
    assert studies.default_chunk(400, rows, workers=2) == 30 and studies.default_chunk(40, rows, workers=2) == 5
    local = ls.study(thesis, box, 0, 360, 30, lhs=40, progress=False)  # three chunks of 16, 16, 8
    for k in small.variables:  # a design's rows do not depend on its chunk's company, but to round-off
        for other in (big, local):  # (a chunk's Newton iterates until all of its designs converge)
            a, b = small[k].values, other[k].values
            if a.dtype.kind == "f":
                np.testing.assert_allclose(a, b, rtol=0, atol=1e-9, err_msg=k)
            else:
                assert np.array_equal(a, b), k
