"""Design studies: sweep many designs of one mechanism, keep each one's mode, scale out on Dask.

:func:`study` draws the designs (:mod:`loopsolve.design.designs`), splits them into chunks, sweeps
each chunk with the lockstep continuation of :mod:`loopsolve.design.lockstep` (designs it cannot
decide are swept one by one with the public :func:`loopsolve.sweep`), evaluates metrics
(:mod:`loopsolve.design.metrics`) and sensitivities (:mod:`loopsolve.design.sensitivity`) chunk by chunk,
and assembles an :class:`xarray.Dataset` with dims ``design`` and the input. Chunks run in
this process, or as Dask tasks on a cluster (``client=``, ``workers=``, ``scheduler=``); a
chunk lost with a dying worker is recomputed by Dask. Written to ``.zarr`` the chunks are
streamed to the store in order, so memory stays bounded by a few chunks whatever the number
of designs. ``.nc`` (netCDF) is written from the assembled Dataset in this process; on a cluster the
workers write a temporary zarr store next to the output and the client converts it chunk by chunk
(:func:`store_to_netcdf`), so the client never holds the study. Long-format ``.csv`` is written from
the assembled Dataset.

Dataset layout
--------------
* every column of a sweep (``theta3``, ``theta3_vel``, ``C_x_acc`` ...) as a ``(design, input)``
  variable in display units (NaN where a design has no row: after a limit, or not assemblable);
* the varied parameters as ``design`` coordinates (fixed ones in ``attrs["fixed"]``);
* ``status`` (``ok``, ``limit``, ``not-assemblable``, ``singular`` — the start is a singular
  position —, ``failed`` — the solver gave up —, ``invalid`` — the design fails a check of the
  model file, such as a link of zero or negative length; not swept), ``stop`` (the input where
  a design stopped), ``events`` (``kind@input; ...``, or the reason a design has no rows; never
  the model file's path), ``nearest`` (nearest assemblable inputs), ``mode`` (the
  assembly-mode signature each design starts in and keeps),
  ``lockstep`` (solved by the vectorized path);
* one ``(design,)`` variable per metric, and ``d_<unknown>_d_<parameter>`` sensitivities.
"""

from __future__ import annotations

import contextlib
import math
import os
import shutil
import sys
import warnings
from collections.abc import Mapping, Sequence

import numpy as np

from .designs import MAX_DESIGNS, design_count, designs_from
from ..errors import ModelError, warn
from .designops import DesignOps
from .studyfiles import Writer as _Writer, need as _need, scratch_dir as _scratch_dir, scratch_store as _scratch_store
from .studyfiles import store_to_netcdf, to_long_frame, write
from .lockstep import sweep_chunk
from .metrics import evaluate_metrics, parse_metric
from ..kinematics.results import angle_turns, in_display_units
from ..model.units import Kind

__all__ = ["study", "write", "to_long_frame", "MAX_CELLS"]

_SUFFIX = ("", "_vel", "_acc", "_jerk")

#: default cap on designs × rows of one study (``max_cells=``, ``--max-cells``)
MAX_CELLS = 5_000_000

# The default chunk (designs per chunk, per Dask task), chosen by measurement (benchmarks/bench_study.py
# --part chunks). The numpy lockstep pays a fixed cost per input row of a chunk whatever its designs
# (~0.3 s a chunk of 361 rows, more than 1000 designs' own work), so small chunks are slow: 2000
# four-bars took 3.8 s in chunks of 256 and 0.9 s in one. The compiled lockstep pays ~0.02–0.05 s a chunk
# (20000 designs: 14.3 s in chunks of 2000, 15.9 s in chunks of 256, 14.0 s in 4155; benchmarks/README.md,
# issue 32, untraced: tracemalloc added ~0.25 s a chunk to the figures before). A chunk's working arrays are
# ~2.5× its part of the result, so many small chunks bound the peak memory of a large study. The rule takes both:
CHUNK_CELLS = 1_500_000   # a study of at most this many designs × rows is one chunk (~90 MB of a four-bar's
                          # result at 361 rows); no chunk holds more (its memory bounded, e.g. with .zarr);
CHUNK_PARTS = 10          # a larger study is cut in tenths (peak memory ≈ result + 2.5/10 of it)
CHUNK_MIN = 1024          # of at least this many designs (the row cost amortized);
CHUNK_PER_WORKER = 4      # on a cluster, at least this many chunks a worker (balance, progress).
#: the variables every study Dataset has besides the sweep columns
_PER_DESIGN = ("status", "stop", "events", "nearest", "mode", "lockstep")
#: designs named in a summarized warning
_FIRST = 5


# ----------------------------------------------------------------------------- one chunk


def _display_columns(ch, ck, P, derivatives=3):
    """Sweep columns (display units), each ``(K, D)``, from a chunk's internal rows ``(nv, K, D)``.

    Columns of derivatives not computed (``derivatives`` < 3) are left out. Angles of unknowns
    are continuous along each design's rows, the first in (−180°, 180°], as in a sweep
    (:func:`loopsolve.kinematics.results.angle_turns`); the input is the Dataset's coordinate.
    """
    Zs = ch.Z
    nv, K, D = Zs[0].shape
    deg = ck.mechanism.units.angle == "deg"
    out: dict[str, np.ndarray] = {}
    inputs = set(ck.inputs)
    order = list(ck.inputs) + [n for n in ck.variables if n not in inputs]
    for name in order:
        i = ck.index(name)
        for k in range(derivatives + 1):
            if k == 0 and name == ck.inputs[0]:
                continue  # the coordinate
            v = Zs[k][i]
            if k == 0 and ck.kinds[i] is Kind.ANGLE:
                v = in_display_units(ck, name, 0, v, wrap=False) + 0.0  # as a sweep's table, to the bit
                if name not in inputs:  # continuous along each design's rows, as in a sweep
                    v = v - (360.0 if deg else 2 * math.pi) * angle_turns(v, "deg" if deg else "rad")
            out[name + _SUFFIX[k]] = v
    if ck.points:
        pts = ch.points
        other = np.flatnonzero(~ch.lockstep)
        if len(other):  # designs swept alone: their points from their rows
            flat = [z[:, :, other].reshape(nv, -1) for z in Zs]
            Pf = np.repeat(P[:, None, other], K, axis=1).reshape(P.shape[0], -1)
            ok = np.all(np.isfinite(flat[0]), axis=0)
            for k in range(derivatives + 1):
                vals = np.full((len(ck.points), 2, K * len(other)), np.nan)
                if ok.any():
                    with np.errstate(all="ignore"):
                        v = getattr(ck.module, f"points{k}_v")(*[f[:, ok] for f in flat[: k + 1]], Pf[:, ok])
                    vals[:, :, ok] = np.broadcast_to(np.asarray(v).reshape(len(ck.points), 2, -1),
                                                     (len(ck.points), 2, int(ok.sum())))
                pts[k][:, :, :, other] = vals.reshape(len(ck.points), 2, K, len(other))
        for j, p in enumerate(ck.points):
            for c, axis in (("x", 0), ("y", 1)):
                for k in range(derivatives + 1):
                    out[f"{p}_{c}{_SUFFIX[k]}"] = pts[k, j, axis]
    return out


def _sensitivities(ck, ops, Z, P, names):
    """∂q/∂p (display units, ``(K, D)``) of every unknown for every varied parameter: Φ_q q_p = −Φ_p."""
    from .sensitivity import phi_p_v

    nv, K, D = Z.shape
    flat = Z.reshape(nv, -1)
    Pf = np.broadcast_to(P[:, None, :], (P.shape[0], K, D)).reshape(P.shape[0], -1)
    ok = np.all(np.isfinite(flat), axis=0)
    pnames = [p.name for p in ck.mechanism.parameters]
    deg = ck.mechanism.units.angle == "deg"
    out = {}
    with np.errstate(all="ignore"):
        J = ops.jac(flat[:, ok], Pf[:, ok])
        Fp = phi_p_v(ck, flat[:, ok], Pf[:, ok])
        for pn in names:
            ip = pnames.index(pn)
            S = ops.solve(J, -Fp[:, ip, :])
            pf = math.pi / 180 if (deg and ck.mechanism.parameters[ip].kind is Kind.ANGLE) else 1.0
            for a, u in enumerate(ck.unknowns):
                qf = 180 / math.pi if (deg and ck.kinds[ck.index(u)] is Kind.ANGLE) else 1.0
                full = np.full(D * K, np.nan)
                full[ok] = S[a] * qf * pf
                out[f"d_{u}_d_{pn}"] = full.reshape(K, D)
    return out


def _chunk_task(mech, names, values, start, stop, step, opts):
    """Sweep one chunk of designs and evaluate its metrics; plain arrays out (what a Dask task returns)."""
    ch, ck, P = sweep_chunk(mech, names, values, start, stop, step, speed=opts["speed"], accel=opts["accel"],
                            jerk=opts["jerk"], mode=opts["mode"], derivatives=opts["derivatives"],
                            method=opts["method"], engine=opts.get("engine"))
    from .lockstep import grid_values

    ops = DesignOps(ck)
    cols = _display_columns(ch, ck, P, opts["derivatives"])
    xs, xs_disp = grid_values(ck, start, stop, step)
    out = {"columns": cols, "status": ch.status.astype(str), "stop": ch.stop, "events": ch.events.astype(str),
           "nearest": ch.nearest.astype(str), "mode": ch.mode.astype(str), "lockstep": ch.lockstep, "x": xs_disp,
           "warnings": list(ch.warnings)}
    if opts["sensitivity"]:
        out["sensitivity"] = _sensitivities(ck, ops, ch.Z[0], P, names)
    if opts["metrics"]:
        angle_cols = tuple(n for n, k in zip(ck.variables, ck.kinds) if k is Kind.ANGLE)
        deg = mech.units.angle == "deg"
        params = {}  # model units: the numbers of the model file
        for i, p in enumerate(mech.parameters):
            if p.name in names:
                v = values[:, list(names).index(p.name)]
            else:
                v = math.degrees(ck.p[i]) if (deg and p.kind is Kind.ANGLE) else ck.p[i]
            params[p.name] = np.asarray(v, dtype=float) * np.ones(len(values))
        kind = ck.kinds[ck.index(ck.inputs[0])]
        full = kind is Kind.ANGLE and abs(xs[-1] - xs[0]) >= 2 * math.pi - 1e-9
        out["metrics"] = evaluate_metrics([parse_metric(m) for m in opts["metrics"]],
                                          {k: v.T for k, v in cols.items()}, params, xs_disp,
                                          angle_columns=angle_cols, full_turn=full, input_name=ck.inputs[0],
                                          input_angle_deg=kind is Kind.ANGLE and mech.units.angle == "deg")
    return out


def _chunk_dataset(res, ck_info, names, values, offset):
    xr = _need("xarray")
    inp = ck_info["input"]
    D = len(values)
    dims = ("design", inp)
    units, punits = ck_info["units"], ck_info["param_units"]
    data = {k: (dims, v.T, {"units": units.get(k, "")}) for k, v in res["columns"].items() if k != inp}
    for k, v in res.get("sensitivity", {}).items():
        data[k] = (dims, v.T, {"units": ck_info["sensitivity_units"].get(k, "")})
    for k in ("status", "events", "nearest", "mode"):
        data[k] = ("design", np.asarray(res[k], dtype=object))
    data["stop"] = ("design", res["stop"], {"units": units[inp]})
    data["lockstep"] = ("design", res["lockstep"])
    for k, v in res.get("metrics", {}).items():
        data[k] = ("design", v)
    coords = {"design": np.arange(offset, offset + D), inp: (inp, res["x"], {"units": units[inp]})}
    for j, n in enumerate(names):
        coords[n] = ("design", values[:, j], {"units": punits[n]})
    return xr.Dataset(data, coords=coords, attrs=ck_info["attrs"])


# ----------------------------------------------------------------------------- the public call


def _study_engine(ck, engine, cells: int, chunk: int) -> str:
    """The engine of every chunk of a study of ``cells`` designs × rows in chunks of ``chunk`` designs, decided
    once here (:func:`~loopsolve.design.lockstep.lockstep_engine`: ``"auto"`` by the study's size and its
    chunks'): the chunks of one
    study, in this process or on the workers of a cluster, run the same engine (the compiled lockstep and
    the numpy one agree to round-off, not to the bit), whatever each process swept before."""
    from .lockstep import lockstep_engine

    return lockstep_engine(ck, engine, cells, chunk)


def default_chunk(designs: int, rows: int, workers: int | None = None) -> int:
    """Designs per chunk when the caller gives none: ``designs`` in all, ``rows`` input rows each,
    ``workers`` the cluster's worker count (``None``: this process). See ``CHUNK_MIN`` and the rest.

    >>> default_chunk(2000, 361), default_chunk(20000, 361), default_chunk(2000, 361, workers=2)
    (2000, 2000, 250)
    """
    cap = max(1, CHUNK_CELLS // max(rows, 1))
    if workers:
        return max(1, min(designs, cap, math.ceil(designs / (CHUNK_PER_WORKER * workers))))
    if designs <= cap:
        return max(1, designs)
    return min(cap, max(CHUNK_MIN, math.ceil(designs / CHUNK_PARTS)))


def study(mech, vary, start, stop, step, *, samples: int | None = None, lhs: int | None = None, seed: int | None = 0,
          metrics: Sequence[str] | Mapping[str, str] = (), sensitivity: bool = False, speed=None, accel=None,
          jerk=None, mode: str | None = None, derivatives: int = 3, chunk_size: int | None = None, client=None,
          workers: int | None = None, scheduler: str | None = None, out=None, progress: bool | None = None,
          method: str = "lockstep", max_designs: int = MAX_DESIGNS, max_cells: int = MAX_CELLS):
    """Sweep every design of a parameter grid or sample over the input; one Dataset back.

    Parameters
    ----------
    mech : Mechanism
    vary : mapping or Designs
        Parameter name → list of values (a grid: cartesian product), or → ``(low, high)``
        with ``samples``/``lhs``; or a ready :class:`~loopsolve.design.designs.Designs`.
    start, stop, step : float or str
        The input range, as for :func:`loopsolve.sweep`.
    samples, lhs, seed : int, optional
        Draw ``samples`` random designs (or a Latin hypercube of ``lhs``) from the box of ``vary``:
        every value of ``vary`` is then a pair ``(low, high)`` (a list of other length is refused).
    metrics : sequence of ``"NAME=EXPR"`` or mapping NAME → EXPR
        See :mod:`loopsolve.design.metrics`.
    sensitivity : bool
        Add ``d_<unknown>_d_<parameter>`` columns: ∂q/∂p at every row for every varied parameter.
    speed, accel, jerk, mode, derivatives
        As for :func:`loopsolve.sweep` (a ``mode`` sweeps every design by the single-design sweep).
    chunk_size : int, optional
        Designs per chunk (per Dask task). Default: :func:`default_chunk` — in this process one chunk
        for a study of at most 1.5·10⁶ designs × rows, tenths of a larger one (at least 1024 designs);
        on a cluster at least four chunks a worker; never more than 1.5·10⁶ designs × rows a chunk.
    client : distributed.Client, optional
        Run the chunks on this Dask cluster. ``workers=N`` starts a local cluster of N
        processes; ``scheduler="tcp://..."`` connects to a running one.
    out : str or Path, optional
        Also write the Dataset (``.nc``, ``.zarr``, ``.csv``); ``.zarr`` is streamed chunk by
        chunk and the returned Dataset is opened lazily from the store. On a Dask cluster the
        workers write their chunks into the store themselves (so the path must be on storage
        they can write: the local disk for a local cluster, a shared filesystem otherwise). ``.nc``
        on a cluster: the workers write a temporary store in a new hidden directory next to the
        output (the same rule), the client converts it to netCDF a chunk at a time and removes it
        (also on an error or Ctrl-C); the returned Dataset is the file opened lazily. An existing
        output file is replaced, as in this process.
    progress : bool, optional
        Completed designs of the total (tqdm) on stderr; default: on a terminal.
    method : {"lockstep", "single"}
        ``"single"`` sweeps every design with :func:`loopsolve.sweep` (for comparisons).
    max_designs, max_cells : int
        Refuse, before any work, more designs than ``max_designs`` (default 10⁵; a grid is
        counted without being made) or more designs × input rows than ``max_cells`` (default
        5·10⁶: every sweep column of the Dataset holds that many numbers).

    Warns
    -----
    LoopsolveWarning
        One line per kind of warning the designs gave (a stop at a limit position ...), with
        how many designs gave it and the first few of them; each design's own ``status``,
        ``stop`` and ``events`` are in the Dataset. ``events`` never holds the model file's path.

    Raises
    ------
    ModelError
        A bad range, parameter, metric (also one named like a variable of the Dataset), too many
        designs or cells, ``workers`` beyond the machine's CPUs, a malformed ``scheduler`` address.

    Returns
    -------
    xarray.Dataset
        See the module docstring for the variables.

    Examples
    --------
    >>> mech = ls.load(ls.models_dir() / "thesis_crank_rocker.toml")
    >>> ds = ls.study(mech, {"r2": [20, 25, 40]}, 0, 360, 30, metrics=["mu=transmission(theta3, theta4)"])
    >>> ds.status.values.tolist()
    ['ok', 'ok', 'not-assemblable']
    >>> np.round(ds.mu.values[:2], 2).tolist(), float(ds.theta4.sel(theta2=90).values[1].round(2))
    ([32.3, 25.21], 80.72)
    """
    xr = _need("xarray")
    if method not in ("lockstep", "single"):
        raise ModelError(f"method {method!r}: expected 'lockstep' or 'single'")
    if derivatives not in (1, 2, 3):
        raise ModelError(f"derivatives={derivatives!r}: expected 1, 2 or 3")
    if chunk_size is not None and (isinstance(chunk_size, bool) or not isinstance(chunk_size, (int, np.integer))
                                   or chunk_size < 1):
        raise ModelError(f"chunk_size={chunk_size!r}: must be at least 1")
    check_cluster(workers, scheduler)
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0):
        raise ModelError(f"--seed {seed!r}: the seed of --samples/--lhs must be a whole number, at least 0")
    if samples is not None and lhs is not None:
        raise ModelError("give either --samples or --lhs, not both")
    N = design_count(vary, samples=samples, lhs=lhs)  # counted, not made
    if N > max_designs:
        designs_from(vary, samples=samples, lhs=lhs, seed=seed, max_designs=max_designs)  # raises, naming the cause
    names = tuple(vary.names if hasattr(vary, "names") else vary)
    pnames = [p.name for p in mech.parameters]
    bad = [n for n in names if n not in pnames]
    if bad:
        raise ModelError(f"{mech.name}: cannot vary {', '.join(map(repr, bad))}: not a parameter; "
                         f"the parameters are {', '.join(pnames)}")
    if isinstance(metrics, Mapping):
        metrics = [f"{k}={v}" for k, v in metrics.items()]
    metrics = tuple(metrics)
    parsed = [parse_metric(m) for m in metrics]  # fail early, before any work
    ck = mech.compile()
    from .lockstep import grid_values
    from ..kinematics.results import column_units

    units = column_units(ck)
    _check_metric_names(parsed, ck, units, names, sensitivity)

    def too_many(rows):
        return ModelError(f"the study would have {_count(N)} designs × {_count(rows)} rows = {_count(N * rows)} "
                          f"cells per column, more than the limit of {max_cells:,}: use fewer designs, a larger "
                          "--step or a smaller range, or raise the limit with --max-cells (max_cells=)")

    rows = len(grid_values(ck, start, stop, step, max_rows=max_cells / max(N, 1), max_rows_error=too_many)[0])
    designs = designs_from(vary, samples=samples, lhs=lhs, seed=seed, max_designs=max_designs)
    if sensitivity:
        from .sensitivity import phi_p_module

        phi_p_module(ck)  # derive once here, so workers load it from the cache
    names = designs.names
    values = np.column_stack([designs.values[n] for n in names])
    values = _whole_teeth(mech, names, values)
    sens_units = {}
    if sensitivity:
        for pn in names:
            p = mech.parameters[pnames.index(pn)]
            pu = mech.units.angle if p.kind is Kind.ANGLE else (mech.units.length if p.kind is Kind.LENGTH else "")
            for u in ck.unknowns:
                sens_units[f"d_{u}_d_{pn}"] = f"{units[u]}/{pu}" if pu else units[u]
    fixed = {p.name: (math.degrees(p.value) if p.kind is Kind.ANGLE and mech.units.angle == "deg" else p.value)
             for p in mech.parameters if p.name not in names}
    ck_info = {"input": ck.inputs[0], "units": units, "sensitivity_units": sens_units,
               "param_units": {p.name: (mech.units.angle if p.kind is Kind.ANGLE else mech.units.length
                                        if p.kind is Kind.LENGTH else "1") for p in mech.parameters},
               "attrs": {"model": mech.name, "source": str(mech.source or ""), "start": str(start), "stop": str(stop),
                         "step": str(step), "fixed": repr(fixed), "metrics": "; ".join(metrics),
                         "length_unit": mech.units.length, "angle_unit": mech.units.angle}}
    N = len(values)
    opts = {"speed": speed, "accel": accel, "jerk": jerk, "mode": mode, "derivatives": derivatives,
            "method": method, "sensitivity": bool(sensitivity), "metrics": metrics}
    writer = _Writer(out, xr) if out is not None else None
    whole = _Assembler(N, xr)
    warned: list[tuple[int, str]] = []
    bounds: list[tuple[int, int]] = []

    def consume(i, res):
        warned.extend((bounds[i][0] + j, msg) for j, msg in res.get("warnings", ()))
        ds = _chunk_dataset(res, ck_info, names, values[bounds[i][0]:bounds[i][1]], bounds[i][0])
        if writer is not None and writer.streaming:
            writer.append(ds)
        else:
            whole.add(ds, *bounds[i])

    bar = _bar(N, progress)
    own_client = None
    scratch = None  # .nc on a cluster: the directory of the workers' temporary store, removed whatever happens
    try:
        try:
            if client is None and (workers or scheduler):
                own_client = make_client(workers, scheduler)
                client = own_client
            if chunk_size is None:
                chunk_size = default_chunk(N, rows, None if client is None else _worker_count(client))
            opts["engine"] = _study_engine(ck, None, N * rows, min(chunk_size, N))
            bounds.extend((a, min(a + chunk_size, N)) for a in range(0, N, chunk_size))
            tasks = [(mech, names, values[a:b], start, stop, step, opts) for a, b in bounds]
            if client is None:
                for i, t in enumerate(tasks):
                    consume(i, _chunk_task(*t))
                    if bar is not None:
                        bar.update(bounds[i][1] - bounds[i][0])
            elif writer is not None and writer.streaming:
                warned.extend(_run_dask_zarr(client, tasks, bounds, ck_info, names, writer.path, bar))
                writer.started = True
            elif writer is not None and writer.netcdf:
                scratch = _scratch_dir(writer.path)
                warned.extend(_run_dask_zarr(client, tasks, bounds, ck_info, names, _scratch_store(scratch), bar))
            else:
                _run_dask(client, tasks, bounds, consume, bar)
        finally:
            if bar is not None:
                bar.close()
            if own_client is not None:
                close_client(own_client, workers)
        for line in summarize_warnings(warned, N):
            warn(line)
        if writer is not None and writer.streaming:
            return writer.finish()
        if scratch is not None:
            return store_to_netcdf(_scratch_store(scratch), writer.path)
    finally:
        if scratch is not None:
            shutil.rmtree(scratch, ignore_errors=True)
    ds = whole.finish()
    if writer is not None:
        write(ds, out)
    return ds


class _Assembler:
    """The study's Dataset filled chunk by chunk into arrays allocated once for every design.

    Why: collecting the chunks' Datasets and ``xr.concat``-ing them held the chunks and the result at
    once (peak memory twice the result; issue 32 measured +2.2 GB for a 1.16 GB study). Here a chunk's
    values are copied into their rows as the chunk arrives and the chunk is dropped, so the peak is the
    result plus one chunk. Every chunk has the same variables, dimensions and units (one model, one
    input grid); a variable whose dtype widens in a later chunk (e.g. a metric that is an integer in
    one chunk and a float in another) is widened in place.
    """

    def __init__(self, n: int, xr):
        self.n, self.xr = n, xr
        self.first = None
        self.arrays: dict = {}

    def add(self, ds, a: int, b: int) -> None:
        if a == 0 and b == self.n:  # the whole study in one chunk: it is the result, no copy
            self.first, self.arrays = ds, {}
            return
        if self.first is None:
            self.first = ds
            for name, var in ds.variables.items():
                if var.dims and var.dims[0] == "design":
                    self.arrays[name] = np.empty((self.n,) + var.shape[1:], dtype=var.dtype)
        for name, arr in self.arrays.items():
            v = ds.variables[name].values
            if not np.can_cast(v.dtype, arr.dtype, casting="same_kind") or v.dtype.itemsize > arr.dtype.itemsize:
                wide = np.result_type(arr.dtype, v.dtype)
                if wide != arr.dtype:
                    arr = self.arrays[name] = arr.astype(wide)
            arr[a:b] = v

    def finish(self):
        first = self.first
        if not self.arrays:
            return first
        data = {k: (v.dims, self.arrays[k] if k in self.arrays else v.values, v.attrs)
                for k, v in first.data_vars.items()}
        coords = {k: (v.dims, self.arrays[k] if k in self.arrays else v.values, v.attrs)
                  for k, v in first.coords.items()}
        return self.xr.Dataset(data, coords=coords, attrs=first.attrs)


def _whole_teeth(mech, names, values):
    """Tooth numbers vary over the integers: their values rounded, designs that then repeat dropped."""
    from ..model.gears import teeth_parameters

    teeth = [j for j, n in enumerate(names) if n in teeth_parameters(mech)]
    if not teeth:
        return values
    values = values.copy()
    values[:, teeth] = np.rint(values[:, teeth])
    _, first = np.unique(values, axis=0, return_index=True)
    return values[np.sort(first)]


def _bar(total, progress):
    if progress is None:
        progress = sys.stderr.isatty()
    if not progress:
        return None
    from tqdm import tqdm

    return tqdm(total=total, unit="design", desc="study", file=sys.stderr)


def usable_cpus() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def check_cluster(workers, scheduler) -> None:
    """``workers`` within this machine's CPUs, ``scheduler`` an address: before any work."""
    if workers is not None:
        if isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) or workers < 1:
            raise ModelError(f"--workers {workers!r}: a number of worker processes, at least 1")
        if workers > usable_cpus():
            raise ModelError(f"--workers {workers}: this machine has {usable_cpus()} CPU(s); a local cluster of more "
                             "worker processes than CPUs is slower, not faster (for more, start a cluster and "
                             "pass --scheduler ADDRESS)")
    if scheduler is not None:
        import re

        text = str(scheduler)
        if not re.fullmatch(r"(?:[a-z][a-z0-9+.-]*://)?(?:\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9._-]+):\d{1,5}", text):
            raise ModelError(f"--scheduler {text!r}: not the address of a Dask scheduler; expected "
                             "tcp://HOST:PORT (as the scheduler prints it, e.g. tcp://127.0.0.1:8786)")


def _count(n) -> str:
    return f"{n:,.0f}" if n < 1e15 else (f"{float(n):.3g}" if math.isfinite(n) else "too many")


def _check_metric_names(parsed, ck, units, names, sensitivity) -> None:
    """A metric's name must not be a variable or coordinate of the Dataset (it would overwrite it)."""
    taken = set(units) | set(_PER_DESIGN) | {"design", ck.inputs[0]} | set(names)
    if sensitivity:
        taken |= {f"d_{u}_d_{p}" for u in ck.unknowns for p in names}
    seen = set()
    for m in parsed:
        if m.name in taken:
            raise ModelError(f"--metric {m.name}={m.text}: {m.name!r} is already a variable of the study's Dataset "
                             "(a sweep column, a varied parameter, the input or one of "
                             f"{', '.join(_PER_DESIGN)}); choose another name")
        if m.name in seen:
            raise ModelError(f"--metric {m.name}: two metrics have this name")
        seen.add(m.name)


def summarize_warnings(warned, total: int) -> list[str]:
    """One line per kind of per-design warning: how many designs, the first message, the first designs.

    ``warned`` is ``[(design, message), ...]``; two messages are of one kind when they differ
    only in their numbers (a stop at a limit position at different inputs).

    Examples
    --------
    >>> lines = summarize_warnings([(3, "stops at theta2 = 81.5 deg"), (7, "stops at theta2 = 84 deg")], 10)
    >>> len(lines), lines[0][:95]
    (1, "2 of 10 designs gave this warning (design 3's): stops at theta2 = 81.5 deg; the other: design 7")
    """
    import re

    groups: dict[str, list[tuple[int, str]]] = {}
    for d, msg in warned:
        msg = re.sub(r"; --through-limits \(through_limits=True\) goes around it$", "", msg)
        kind = re.sub(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?", "#", msg)
        groups.setdefault(kind, []).append((d, msg))
    lines = []
    for items in groups.values():
        designs = sorted({d for d, _ in items})
        first, msg = min(items)
        rest = [d for d in designs if d != first]
        others = ""
        if rest:
            shown = ", ".join(map(str, rest[: _FIRST - 1]))
            more = f" and {len(rest) - (_FIRST - 1)} more" if len(rest) > _FIRST - 1 else ""
            others = f"; the other{'s' if len(rest) > 1 else ''}: design{'s' if len(rest) > 1 else ''} {shown}{more}"
        lines.append(f"{len(designs)} of {total} design{'s' if total != 1 else ''} gave this warning (design "
                     f"{first}'s): {msg}{others}; each design's status, stop and events are in the Dataset")
    return lines


def make_client(workers, scheduler):
    distributed = _need("distributed")
    if scheduler:
        try:
            return distributed.Client(scheduler, timeout="20s")
        except (ValueError, TypeError, OSError, TimeoutError) as exc:
            raise ModelError(f"--scheduler {scheduler!r}: cannot connect to a Dask scheduler there "
                             f"({type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}); check the "
                             "address the scheduler printed and that it is running") from None
    cluster = distributed.LocalCluster(n_workers=int(workers), threads_per_worker=1, processes=True,
                                       host="127.0.0.1", dashboard_address=":0")
    return distributed.Client(cluster)


def close_client(client, workers) -> None:
    """Close a client :func:`make_client` made, and with ``workers`` the local cluster it started."""
    cluster = client.cluster
    client.close()
    if cluster is not None and workers:
        cluster.close()


def _worker_count(client) -> int:
    """The workers a Dask client's cluster has now (at least 1)."""
    return max(1, len(client.scheduler_info().get("workers", {})))


def _run_dask(client, tasks, bounds, consume, bar):
    """Submit the chunks with a bounded number in flight; hand results over in order."""
    import uuid

    from distributed import as_completed

    inflight = 2 * _worker_count(client) + 2
    token = uuid.uuid4().hex[:12]
    pending = list(range(len(tasks)))
    key_of = {}

    def submit(i):
        f = client.submit(_chunk_task, *tasks[i], key=f"loopsolve-study-{token}-{i}", pure=False, retries=3)
        key_of[f.key] = i
        return f

    ac = as_completed([submit(pending.pop(0)) for _ in range(min(inflight, len(pending)))])
    ready: dict[int, dict] = {}
    nxt = 0
    for fut in ac:
        i = key_of[fut.key]
        ready[i] = fut.result()
        fut.release()
        if bar is not None:
            bar.update(bounds[i][1] - bounds[i][0])
        while nxt in ready:
            consume(nxt, ready.pop(nxt))
            nxt += 1
        if pending:
            ac.add(submit(pending.pop(0)))


def _region_write(ds, path, a, b):
    """Write a chunk's Dataset into rows ``a:b`` of an initialized store (idempotent: a rerun rewrites them)."""
    drop = [k for k, v in ds.variables.items() if "design" not in v.dims]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ds.drop_vars(drop).to_zarr(path, region={"design": slice(a, b)})


def _chunk_to_zarr(task, ck_info, names, a, b, path):
    """A Dask task: sweep one chunk and write it into its region of the store; its size and warnings."""
    res = _chunk_task(*task)
    if not os.path.isdir(path):  # a study interrupted meanwhile removed its temporary store: do not recreate it
        raise FileNotFoundError(f"the study's store {path!r} is gone")
    _region_write(_chunk_dataset(res, ck_info, names, task[2], a), path, a, b)
    return b - a, [(a + j, msg) for j, msg in res["warnings"]]


def _run_dask_zarr(client, tasks, bounds, ck_info, names, path, bar):
    """Zarr on a cluster: the store's layout from one design swept here, then the workers write every chunk.

    Nothing but a count (and the chunk's warnings) travels back to the client, so its memory does not grow with the number
    of designs, and the compression of the columns runs on the workers in parallel. The client's own work is
    one design's sweep, whatever the study's size (it swept the whole first chunk before: with the default
    chunk of a quarter of a worker's share, an eighth of a 2-worker study ran serially here). A chunk
    lost with a worker is recomputed and rewrites the same region.
    """
    import uuid

    import dask.array as da
    from distributed import as_completed

    xr = _need("xarray")
    N = bounds[-1][1]
    c = bounds[0][1] - bounds[0][0]
    # the first design alone: names, dtypes, units (in numpy: the client never loads the compiled lockstep)
    probe = tasks[0][:2] + (tasks[0][2][:1],) + tasks[0][3:6] + ({**tasks[0][6], "engine": "python"},)
    first = _chunk_dataset(_chunk_task(*probe), ck_info, names, probe[2], 0)
    warned: list[tuple[int, str]] = []  # its warnings come again with its chunk

    def lazy(v):
        shape = (N,) + v.shape[1:]
        if v.dtype == object:
            return da.from_array(np.full(shape, "", dtype=object), chunks=(c,) + v.shape[1:])
        return da.empty(shape, chunks=(c,) + v.shape[1:], dtype=v.dtype)

    tmpl = xr.Dataset({k: (v.dims, lazy(v), v.attrs) for k, v in first.data_vars.items()},
                      coords={k: ((v.dims, lazy(v), v.attrs) if "design" in v.dims and k != "design" else v)
                              for k, v in first.coords.items() if k != "design"},
                      attrs=first.attrs)
    tmpl = tmpl.assign_coords(design=np.arange(N))
    _need("zarr")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        # every design-dim array chunked by the task size (strings too: a shared zarr chunk would be a
        # read-modify-write race between workers)
        enc = {k: {"chunks": (c,) + tuple(v.shape[1:])} for k, v in tmpl.variables.items()
               if v.dims and v.dims[0] == "design" and k != "design"}
        tmpl.to_zarr(path, compute=False, mode="w", encoding=enc)
    token = uuid.uuid4().hex[:12]
    pending = list(range(len(tasks)))[::-1]
    model = client.scatter(tasks[0][0], broadcast=True)  # sent once, not pickled into every task

    def submit():  # a bounded number in flight
        i = pending.pop()
        return client.submit(_chunk_to_zarr, (model,) + tasks[i][1:], ck_info, names, bounds[i][0], bounds[i][1], path,
                             key=f"loopsolve-study-zarr-{token}-{i}", pure=False, retries=3)

    ac = as_completed([submit() for _ in range(min(2 * _worker_count(client) + 2, len(pending)))])
    try:
        for fut in ac:
            n, w = fut.result()
            warned.extend(w)
            fut.release()
            if bar is not None:
                bar.update(n)
            if pending:
                ac.add(submit())
    except BaseException:  # an error or Ctrl-C: the chunks not yet started are not started
        with contextlib.suppress(Exception):
            client.cancel(list(ac.futures))
        raise
    return warned
