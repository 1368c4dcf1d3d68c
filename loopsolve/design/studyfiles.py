"""The files of a design study: ``.zarr`` streamed chunk by chunk, ``.nc`` (netCDF), long-format ``.csv``.

:func:`write` writes a study Dataset by extension. :func:`store_to_netcdf` converts a finished study
store to netCDF one chunk at a time: a study to ``.nc`` on a Dask cluster has its workers write a
temporary store (in a directory from :func:`scratch_dir`, next to the output) and the client converts
it, so the client's memory is bounded by a chunk, not by the study.
"""

from __future__ import annotations

import os
import tempfile
import warnings

import numpy as np

from ..errors import MissingDependencyError, ModelError

__all__ = ["write", "to_long_frame", "store_to_netcdf"]


def need(module: str):
    try:
        return __import__(module)
    except ImportError:
        raise MissingDependencyError(
            f"design studies need {module}: pip install 'loopsolve[study]'") from None


class Writer:
    def __init__(self, path, xr):
        self.path = os.fspath(path)
        self.xr = xr
        ext = os.path.splitext(self.path)[1].lower()
        if ext not in (".nc", ".zarr", ".csv"):
            raise ModelError(f"output {self.path!r}: the extension must be .nc (netCDF), .zarr or .csv")
        self.streaming = ext == ".zarr"
        self.netcdf = ext == ".nc"
        self.started = False

    def append(self, ds):
        need("zarr")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            if not self.started:
                ds.to_zarr(self.path, mode="w")
                self.started = True
            else:
                ds.to_zarr(self.path, append_dim="design")

    def finish(self):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return self.xr.open_zarr(self.path)


def to_long_frame(ds):
    """Long-format table: one row per design and input value, with the parameters, status and metrics."""
    pd = need("pandas")
    inp = [d for d in ds.dims if d != "design"][0]
    two = [k for k, v in ds.data_vars.items() if v.dims == ("design", inp)]
    one = [k for k, v in ds.data_vars.items() if v.dims == ("design",)]
    params = [k for k, v in ds.coords.items() if v.dims == ("design",) and k != "design"]
    D, K = ds.sizes["design"], ds.sizes[inp]
    frame = {"design": np.repeat(ds["design"].values, K)}
    for p in params:
        frame[p] = np.repeat(ds[p].values, K)
    frame[inp] = np.tile(ds[inp].values, D)
    for k in two:
        if k != inp:
            frame[k] = np.asarray(ds[k].values).reshape(-1)
    for k in one:
        frame[k] = np.repeat(np.asarray(ds[k].values), K)
    df = pd.DataFrame(frame)
    cols = [k for k in two if k != inp]
    if cols:  # rows a design does not have are left out; a design without rows keeps one (its status)
        has = np.isfinite(np.asarray(ds[cols[0]].values))
        none = ~np.any(has, axis=1)
        has[none, 0] = True
        df = df[has.reshape(-1)]
    return df.reset_index(drop=True)


def write(ds, path) -> None:
    """Write a study Dataset by extension: ``.nc`` (netCDF), ``.zarr`` or long-format ``.csv``."""
    path = os.fspath(path)
    ext = os.path.splitext(path)[1].lower()
    if ext == ".zarr":
        need("zarr")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ds.to_zarr(path, mode="w")
    elif ext == ".nc":
        _netcdf_ready(ds).to_netcdf(path, engine=_netcdf_engine())
    elif ext == ".csv":
        to_long_frame(ds).to_csv(path, index=False)
    else:
        raise ModelError(f"output {path!r}: the extension must be .nc (netCDF), .zarr or .csv")


def _netcdf_engine() -> str:
    try:
        import netCDF4  # noqa: F401

        return "netcdf4"
    except ImportError:
        try:
            import h5netcdf  # noqa: F401
            import h5py  # noqa: F401

            return "h5netcdf"
        except ImportError:
            raise MissingDependencyError("writing .nc needs netCDF4 (or h5netcdf with h5py): "
                                         "pip install 'loopsolve[study]'") from None


def _plain_strings(block):
    """An array of text as an object array of Python ``str``: what netCDF's variable-length strings take
    from any source (numpy's ``StringDType`` of a newer zarr, or ``str`` mixed with ``np.str_``, which the
    lowest xarray the project allows cannot encode)."""
    out = np.empty(block.shape, dtype=object)
    out.ravel()[:] = [str(x) for x in block.ravel()]
    return out


def _netcdf_ready(ds):
    """The study Dataset as netCDF stores it: text as variable-length strings, ``lockstep`` as int8 (netCDF has
    no bool). An in-memory Dataset is converted here; a Dask-backed one (a store opened lazily) chunk by
    chunk when it is written."""
    out = ds.copy()
    for k in ("status", "events", "nearest", "mode"):
        if k not in out:
            continue
        data = out[k].data
        if hasattr(data, "map_blocks"):
            out[k] = out[k].copy(data=data.map_blocks(_plain_strings, dtype=object))
        else:
            out[k] = out[k].copy(data=_plain_strings(np.asarray(data)))
    out["lockstep"] = out["lockstep"].astype("int8")
    return out


def scratch_dir(path) -> str:
    """A new, empty directory next to the output ``path`` for the workers' temporary store (a fresh name:
    nothing of the user's is ever written into or removed with it). Next to the output, because a cluster's
    workers can write where the output goes (the same rule as for ``.zarr``) and the store is on its disk."""
    folder = os.path.dirname(os.path.abspath(path))
    try:
        return tempfile.mkdtemp(prefix=f".{os.path.basename(path)}.", suffix=".tmp", dir=folder)
    except OSError as exc:
        raise ModelError(f"output {path!r}: cannot create the temporary store next to it "
                         f"({type(exc).__name__}: {exc.strerror or exc})") from None


def scratch_store(scratch: str) -> str:
    return os.path.join(scratch, "study.zarr")


def store_to_netcdf(store, path):
    """Convert a finished study store (``.zarr``) to netCDF at ``path``, one zarr chunk at a time, and return
    the file opened lazily.

    Why: a study on a Dask cluster has its workers write the chunks into a store; the client then reads it
    back chunk by chunk (Dask's synchronous scheduler in this process, whatever Dask client is the default)
    so its memory is bounded by a chunk, not by the study. The values are those of the single-process
    ``.nc``: the same variables, dtypes on disk, attributes and units.
    """
    xr = need("xarray")
    import dask

    engine = _netcdf_engine()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        src = xr.open_zarr(store, chunks={})
        for v in src.variables.values():  # the store's own encoding (compressors, zarr chunks) is not netCDF's
            v.encoding = {}
        with dask.config.set(scheduler="synchronous"):
            _netcdf_ready(src).to_netcdf(path, engine=engine)
        src.close()
        ds = xr.open_dataset(path, engine=engine)
    ds["lockstep"] = ds["lockstep"].astype(bool)
    return ds
