"""The progress bar of a study counts every design, run locally, on Dask, and on Dask into Zarr.

Mutation testing (issue 18): with a progress bar (a terminal, or ``progress=True``) the Dask
run into a ``.zarr`` store read a bound that does not exist and crashed; no test turned the
bar on. Each run below must end its bar at designs/designs and give the local run's numbers.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

import loopsolve as ls

pytest.importorskip("xarray")
pytest.importorskip("tqdm")

VARY = {"r2": [20.0, 22.0, 24.0, 26.0, 28.0]}


def final_count(err: str) -> tuple[int, int]:
    counts = re.findall(r"(\d+)/(\d+)", err.replace("\r", "\n"))
    assert counts, err
    return tuple(map(int, counts[-1]))


@pytest.fixture(scope="module")
def mech():
    return ls.load(ls.models_dir() / "thesis_crank_rocker.toml")


@pytest.fixture(scope="module")
def client():
    distributed = pytest.importorskip("distributed")
    c = distributed.Client(processes=False, n_workers=1, threads_per_worker=2, dashboard_address=":0")
    yield c
    c.close()


def test_progress_local(mech, capsys):
    ds = ls.study(mech, VARY, 0, 360, 30, chunk_size=2, progress=True)
    assert final_count(capsys.readouterr().err) == (5, 5)
    assert (ds.status.values == "ok").all()


def test_progress_dask_and_dask_zarr(mech, client, capsys, tmp_path):
    pytest.importorskip("zarr")
    local = ls.study(mech, VARY, 0, 360, 30, chunk_size=2, progress=False)
    capsys.readouterr()
    remote = ls.study(mech, VARY, 0, 360, 30, chunk_size=2, client=client, progress=True)
    assert final_count(capsys.readouterr().err) == (5, 5)
    np.testing.assert_array_equal(remote.theta4.values, local.theta4.values)
    store = tmp_path / "s.zarr"
    z = ls.study(mech, VARY, 0, 360, 30, chunk_size=2, client=client, out=store, progress=True)
    assert final_count(capsys.readouterr().err) == (5, 5)
    np.testing.assert_array_equal(z.theta4.values, local.theta4.values)
