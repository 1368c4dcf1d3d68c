"""Atlases of coupler curves: build one (in chunks, here or on a Dask cluster), grow it, open it.

An atlas samples the box of some parameters of a model (``vary``), traces every design's
point over its whole motion and stores its certificate labels and curve descriptors
(:mod:`loopsolve.design.atlas.trace`) in a chunked zarr store (:mod:`loopsolve.design.atlas.store`).
Shape synthesis (:mod:`loopsolve.design.synthesis.shape.run`) retrieves the designs whose curves are nearest a
target's and polishes them.

**Sampling.** A scrambled Sobol sequence (``scipy.stats.qmc.Sobol``, seeded) over the box, a
length whose box is positive on a log scale (a uniform sample of [0.4, 4] would put half the
designs above 2.2). Entry i is always the i-th point of the sequence, so an atlas of N entries
is the first N of any bigger one, and growing an atlas (``size`` larger than it holds) computes
only the new chunks.

**Chunks.** Entry i belongs to chunk i // C (C the atlas' ``chunk``); a chunk is always traced
at its full size C (the last one's extra designs are traced and not stored), so every design is
computed in the same array at the same place whichever way the atlas is built — in this
process, on a local Dask cluster or a remote one, in one go or grown in steps: the stored
numbers are identical. A chunk lost with a Dask worker is recomputed by Dask (``retries``);
an interrupted build keeps the chunks it wrote (each with its count, written last), and the
same command resumes it.
"""

from __future__ import annotations

import math
import os
import sys
import warnings
from collections.abc import Mapping

import numpy as np

from ...errors import ModelError
from ...model.units import Kind
from . import store as _st
from .trace import GRASHOF_CLASSES, STATUS, fourbar_loops, trace_chunk

__all__ = ["Atlas", "build_atlas", "open_atlas", "MAX_SIZE", "DEFAULT_CHUNK"]

#: the largest atlas built without ``max_size`` (``--max-size``)
MAX_SIZE = 2_000_000
DEFAULT_CHUNK = 2048


class Atlas:
    """An atlas in memory (see the module docstring); open one with :func:`open_atlas`.

    Users receive atlases from :func:`loopsolve.build_atlas` and :func:`loopsolve.open_atlas`; they
    need not construct one.

    Parameters
    ----------
    path : str or pathlib.Path or None
        The zarr store it was read from (None for an atlas built in memory).
    meta : dict
        The store's description: the model, the point, the varied parameters and their box, the
        size and chunk.
    arrays : dict
        The per-entry arrays by name (``params``, ``status``, ``crank``, ``curve``, ...).

    Attributes
    ----------
    path, meta, arrays
        As the parameters of the same names.
    mechanism : Mechanism
        The atlas' model.
    point : str
        The traced point.
    names : tuple of str
        The varied parameters.
    lo, hi : numpy.ndarray
        The box of the varied parameters (model units).
    size : int
        The number of entries.
    present : numpy.ndarray
        True for the entries computed so far.
    params, status, crank, curve
        The per-entry arrays of :mod:`loopsolve.design.atlas.store`, read as attributes: the
        varied values (model units), the entry's status, whether the input is a crank, the traced
        curve's samples.

    Examples
    --------
    >>> import loopsolve as ls
    >>> mech = ls.load(ls.models_dir() / "fourbar_path_synthesis.toml")
    >>> atlas = ls.build_atlas(mech, point="P", vary={"r2": (0.5, 2)}, size=16, chunk=16, progress=False)
    >>> atlas.point, atlas.names, atlas.size, atlas.params.shape
    ('P', ('r2',), 16, (16, 1))
    >>> float(atlas.lo[0]), float(atlas.hi[0]), bool(atlas.present.all())
    (0.5, 2.0, True)
    """

    def __init__(self, path, meta, arrays):
        from ...model.modelfile import loads

        self.path = path
        self.meta = meta
        self.arrays = arrays
        self.mechanism = loads(meta["model"], source=meta.get("source") or "<atlas>")
        self.point = meta["point"]
        self.names = tuple(meta["names"])
        self.lo = np.asarray(meta["lo"], dtype=float)
        self.hi = np.asarray(meta["hi"], dtype=float)
        C = int(meta["chunk"])
        filled = arrays["filled"]
        present = np.zeros(int(meta["size"]), dtype=bool)
        for c, n in enumerate(filled):
            present[c * C:c * C + int(n)] = True
        self.present = present

    def __getattr__(self, name):
        arrays = self.__dict__.get("arrays", {})
        if name in arrays:
            return arrays[name]
        raise AttributeError(name)

    @property
    def size(self) -> int:
        return int(self.meta["size"])

    @property
    def traced(self) -> np.ndarray:
        """Entries with a usable curve (certified motion, non-degenerate curve)."""
        return self.present & (self.arrays["status"] == STATUS["traced"])

    @property
    def complete(self) -> bool:
        return bool(self.present.all())

    def values(self, i: int) -> dict:
        """Every parameter of entry ``i`` (model units): the atlas model's values with the entry's."""
        spec = self.mechanism.spec["parameters"]
        out = {p.name: float(spec[p.name]) for p in self.mechanism.parameters}
        out.update({n: float(v) for n, v in zip(self.names, self.arrays["params"][i])})
        return out

    def grashof(self, i: int) -> str:
        """The Grashof classes of entry ``i``'s four-bar loops, joined with " + " ("" without one)."""
        return " + ".join(GRASHOF_CLASSES[c] for c in self.arrays["grashof"][i] if c) if len(self.meta["loops"]) \
            else ""

    def summary(self) -> dict:
        """Counts: entries, traced (certified), cranks, rockers, not assemblable, degenerate; the box."""
        st = self.arrays["status"]
        pres = self.present
        tr = self.traced
        return {"model": self.mechanism.name, "point": self.point, "size": self.size,
                "built": int(pres.sum()), "certified": int(tr.sum()),
                "crank": int((tr & self.arrays["crank"]).sum()), "rocker": int((tr & ~self.arrays["crank"]).sum()),
                "not_assemblable": int((pres & (st == STATUS["no-assembly"])).sum()),
                "degenerate": int((pres & (st == STATUS["degenerate"])).sum()),
                "vary": {n: [float(a), float(b)] for n, a, b in zip(self.names, self.lo, self.hi)},
                "seed": int(self.meta["seed"])}

    def __repr__(self) -> str:
        s = self.summary()
        return (f"Atlas({s['model']!r}, point={s['point']!r}, {s['certified']} certified of {s['size']}: "
                f"{s['crank']} crank, {s['rocker']} rocker)")


# ----------------------------------------------------------------------------- sampling


def sample_chunk(meta, c: int) -> np.ndarray:
    """The designs of chunk ``c`` ``(C, k)``: points ``cC … cC + C − 1`` of the atlas' Sobol sequence."""
    from scipy.stats import qmc

    k = len(meta["names"])
    C = int(meta["chunk"])
    lo, hi = np.asarray(meta["lo"], dtype=float), np.asarray(meta["hi"], dtype=float)
    logs = np.asarray(meta["log"], dtype=bool)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # Sobol's balance warning: the sequence is cut in chunks on purpose
        eng = qmc.Sobol(d=k, scramble=True, seed=int(meta["seed"]))
        if c:
            eng.fast_forward(c * C)
        U = eng.random(C)
    lo_u = np.where(logs, np.log(np.where(logs, lo, 1.0)), lo)
    hi_u = np.where(logs, np.log(np.where(logs, hi, 1.0)), hi)
    V = lo_u + U * (hi_u - lo_u)
    return np.clip(np.where(logs, np.exp(V), V), lo, hi)


def _chunk_task(model_text, source, meta, c):
    """Trace chunk ``c`` (a Dask task: plain data in and out)."""
    from ...model.modelfile import loads

    mech = loads(model_text, source=source)
    V = sample_chunk(meta, c)
    arrays = trace_chunk(mech, meta["point"], tuple(meta["names"]), V, step_deg=float(meta["step_deg"]),
                         curve_points=int(meta["curve_points"]), harmonics=int(meta["harmonics"]),
                         loops=_loops_of(mech, meta))
    arrays["params"] = V
    return arrays


def _loops_of(mech, meta):
    loops = fourbar_loops(mech)
    names = [lp["loop"] for lp in loops]
    return [loops[names.index(n)] for n in meta["loops"] if n in names]


# ----------------------------------------------------------------------------- build


def _check_vary(mech, vary):
    if not isinstance(vary, Mapping) or not vary:
        raise ModelError("give the parameters to sample: --vary NAME=LOW:HIGH (repeatable)")
    pnames = [p.name for p in mech.parameters]
    names, lo, hi, logs = [], [], [], []
    for n, box in vary.items():
        if n not in pnames:
            raise ModelError(f"{mech.source or mech.name}: --vary {n}: not a parameter; the parameters are "
                             f"{', '.join(pnames) or 'none'}")
        try:
            a, b = (float(v) for v in box)
        except (TypeError, ValueError):
            raise ModelError(f"--vary {n}: expected bounds LOW:HIGH, got {box!r}") from None
        if not (math.isfinite(a) and math.isfinite(b)) or not a < b:
            raise ModelError(f"--vary {n}={a:g}:{b:g}: LOW and HIGH must be finite numbers with LOW < HIGH")
        kind = mech.parameters[pnames.index(n)].kind
        names.append(n)
        lo.append(a)
        hi.append(b)
        logs.append(bool(kind is Kind.LENGTH and a > 0))
    return names, lo, hi, logs


def describe(mech, point, vary, *, seed=0, chunk=DEFAULT_CHUNK, size=0, step_deg=3.0, curve_points=64,
             harmonics=10) -> dict:
    """The atlas description (store metadata) of a build: what is sampled and how."""
    from ... import __version__
    from ...model.modelfile import dumps

    ck = mech.compile()
    if point not in ck.points:
        raise ModelError(f"{mech.source or mech.name}: --point {point!r} is not a declared point; the points are "
                         f"{', '.join(ck.points) or 'none (add a [points] section)'}")
    names, lo, hi, logs = _check_vary(mech, vary)
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ModelError(f"--seed {seed!r}: a whole number, at least 0")
    if not isinstance(chunk, (int, np.integer)) or chunk < 1:
        raise ModelError(f"chunk={chunk!r}: must be at least 1")
    return {"format": _st.FORMAT, "model": dumps(mech), "source": str(mech.source or ""), "name": mech.name,
            "fingerprint": _st.fingerprint(mech), "point": point, "names": names, "lo": lo, "hi": hi, "log": logs,
            "seed": int(seed), "chunk": int(chunk), "size": int(size), "curve_points": int(curve_points),
            "harmonics": int(harmonics), "step_deg": float(step_deg),
            "loops": [lp["loop"] for lp in fourbar_loops(mech)], "blocks": len(ck.blocks),
            "loopsolve": __version__}


_SAME = ("fingerprint", "point", "names", "lo", "hi", "log", "seed", "chunk", "curve_points", "harmonics", "step_deg",
         "loops", "blocks")


def build_atlas(mech, *, point: str, vary, size: int, seed: int = 0, out=None, chunk: int = DEFAULT_CHUNK,
                workers: int | None = None, scheduler: str | None = None, client=None, max_size: int = MAX_SIZE,
                progress: bool | None = None, step_deg: float = 3.0, curve_points: int = 64, harmonics: int = 10,
                _desc: str = "atlas"):
    """Build (or grow, or resume) an atlas of ``mech``'s point ``point`` over the box ``vary``.

    Parameters
    ----------
    mech : Mechanism
    point : str
        The point whose curve is stored.
    vary : mapping name → (low, high)
        The sampled parameters and their box (model units); a length with a positive box is
        sampled on a log scale. The others keep the model's values.
    size : int
        Entries (sampled designs; those that cannot be assembled are kept with that label).
    seed : int
        Seed of the scrambled Sobol sequence.
    out : path, optional
        The store (a directory, ``.zarr``). An existing atlas of the same model, point, box,
        seed and chunk is grown to ``size`` (or resumed); any other existing path is refused.
        Without ``out`` the atlas is built in a temporary directory and kept in memory.
    chunk : int
        Designs per chunk (per Dask task).
    workers, scheduler, client
        Build the chunks on a Dask cluster (a local one of ``workers`` processes, the scheduler
        at ``scheduler``, or ``client``); the result is the same as built here.
    max_size : int
        Refuse a ``size`` above this before any work.
    progress : bool or callable, optional
        Entries done on stderr (tqdm); default: on a terminal. A callable is called as
        ``progress(done, total)`` (designs) when the build starts and after every chunk (the
        editor's progress bar).
    step_deg, curve_points, harmonics : optional
        The tracer's input step (degrees), the points stored per curve (resampled by arc length)
        and the elliptic Fourier harmonics of its shape descriptor.

    Returns
    -------
    Atlas

    Raises
    ------
    ModelError
        Bad point, parameters, bounds, size, an ``out`` that is not this atlas.

    Examples
    --------
    >>> mech = ls.load(ls.models_dir() / "fourbar_path_synthesis.toml")
    >>> a = build_atlas(mech, point="P", vary={"r2": (0.5, 2), "rcy": (-2, 2)}, size=64, chunk=32, progress=False)
    >>> s = a.summary(); s["size"], s["certified"] > 0
    (64, True)
    """
    from ..studies import check_cluster

    if isinstance(size, bool) or not isinstance(size, (int, np.integer)) or size < 1:
        raise ModelError(f"--size {size!r}: the number of designs to sample, at least 1")
    if isinstance(max_size, bool) or not isinstance(max_size, (int, np.integer)) or max_size < 1:
        raise ModelError(f"--max-size {max_size!r}: at least 1")
    if size > max_size:
        raise ModelError(f"--size {size}: more than --max-size {max_size} designs; raise --max-size to build it "
                         f"(an atlas of N four-bars takes about N x 0.7 kB on disk)")
    check_cluster(workers, scheduler)
    meta = describe(mech, point, vary, seed=seed, chunk=chunk, size=size, step_deg=step_deg,
                    curve_points=curve_points, harmonics=harmonics)
    if out is None:
        import tempfile

        with tempfile.TemporaryDirectory(prefix="loopsolve-atlas-") as tmp:
            path = os.path.join(tmp, "atlas.zarr")
            _build_into(mech, path, meta, size, workers, scheduler, client, progress, _desc)
            atlas = open_atlas(path)
            atlas.path = None
            return atlas
    path = os.fspath(out)
    _build_into(mech, path, meta, size, workers, scheduler, client, progress, _desc)
    return open_atlas(path)


def _build_into(mech, path, meta, size, workers, scheduler, client, progress, desc):
    if os.path.lexists(path):
        try:
            g, old = _st.open_store(path, write=True)
        except _st.AtlasFileError as exc:
            raise _st.AtlasFileError(f"-o {path}: exists and is not an atlas that can be grown ({exc}); choose "
                                     "another name") from None
        diff = [k for k in _SAME if old.get(k) != meta.get(k)]
        if diff:
            raise _st.AtlasFileError(f"-o {path}: holds another atlas (its {', '.join(diff)} differ); choose another "
                                     "name (an atlas is grown only with the same model, point, box, seed and chunk)")
        if size > int(old["size"]):
            old = _st.resize_store(g, old, size)
        meta = old
    else:
        g = _st.create_store(path, meta)
    C = int(meta["chunk"])
    size = int(meta["size"])
    nchunks = -(-size // C)
    filled = np.asarray(g["filled"][:])
    todo = [c for c in range(nchunks) if int(filled[c]) < min(C, size - c * C)]
    if not todo:
        return
    from ...model.modelfile import dumps

    text, source = dumps(mech), str(mech.source or "")
    bar = _bar(sum(min(C, size - c * C) for c in todo), progress, desc)
    own = None
    try:
        if client is None and (workers or scheduler):
            from ..studies import make_client

            own = client = make_client(workers, scheduler)
        if client is None:
            for c in todo:
                arrays = _chunk_task(text, source, meta, c)
                n = min(C, size - c * C)
                _st.write_chunk(g, meta, c, arrays, n)
                if bar is not None:
                    bar.update(n)
        else:
            _run_dask(client, todo, text, source, meta, g, size, bar)
    finally:
        if bar is not None:
            bar.close()
        if own is not None:
            from ..studies import close_client

            close_client(own, workers)


def _run_dask(client, todo, text, source, meta, g, size, bar):
    """The chunks as Dask tasks (a bounded number in flight); the client writes each one as it arrives."""
    import uuid

    from distributed import as_completed

    C = int(meta["chunk"])
    nworkers = max(1, len(client.scheduler_info().get("workers", {})))
    inflight = 2 * nworkers + 2
    token = uuid.uuid4().hex[:12]
    pending = list(todo)
    key_of = {}

    def submit(c):
        f = client.submit(_chunk_task, text, source, meta, c, key=f"loopsolve-atlas-{token}-{c}", pure=False,
                          retries=3)
        key_of[f.key] = c
        return f

    ac = as_completed([submit(pending.pop(0)) for _ in range(min(inflight, len(pending)))])
    for fut in ac:
        c = key_of[fut.key]
        arrays = fut.result()
        fut.release()
        n = min(C, size - c * C)
        _st.write_chunk(g, meta, c, arrays, n)
        if bar is not None:
            bar.update(n)
        if pending:
            ac.add(submit(pending.pop(0)))


class _CallbackBar:
    """tqdm's ``update``/``close`` for a ``progress(done, total)`` callable."""

    def __init__(self, total, fn):
        self.total, self.done, self.fn = int(total), 0, fn
        fn(0, self.total)

    def update(self, n):
        self.done += int(n)
        self.fn(self.done, self.total)

    def close(self):
        pass


def _bar(total, progress, desc):
    if callable(progress):
        return _CallbackBar(total, progress)
    if progress is None:
        progress = sys.stderr.isatty()
    if not progress:
        return None
    from tqdm import tqdm

    return tqdm(total=total, unit="design", desc=desc, file=sys.stderr)


# ----------------------------------------------------------------------------- open


def open_atlas(path, mech=None) -> Atlas:
    """Open the atlas at ``path`` (checked: see :mod:`loopsolve.design.atlas.store`); with ``mech``, it must be of it.

    Parameters
    ----------
    path : str or path
        The atlas (a directory, ``.zarr``) that :func:`build_atlas` wrote.
    mech : Mechanism, optional
        When given, the atlas must be of this model's structure (:func:`~loopsolve.design.atlas.store.fingerprint`).

    Returns
    -------
    Atlas

    Raises
    ------
    AtlasFileError
        (a ``ModelError``, exit 2) A missing, foreign, unsafe, damaged or incomplete atlas, or one of
        another model.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> mech = ls.load(ls.models_dir() / "fourbar_path_synthesis.toml")
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "small.zarr"
    >>> _ = build_atlas(mech, point="P", vary={"r2": (0.5, 2)}, size=32, chunk=32, out=out, progress=False)
    >>> open_atlas(out, mech).summary()["size"]
    32
    """
    path = os.fspath(path)
    g, meta = _st.open_store(path)
    if mech is not None and meta["fingerprint"] != _st.fingerprint(mech):
        raise _st.AtlasFileError(f"{path}: an atlas of {meta.get('name')!r} ({meta.get('source') or 'no file'}), "
                                 f"not of {mech.name!r} ({mech.source or 'no file'}): its vectors, loops, points or "
                                 "parameters differ; build an atlas of this model (loopsolve atlas build)")
    arrays = _st.read_arrays(g, meta, path)
    atlas = Atlas(path, meta, arrays)
    if not atlas.present.any():
        raise _st.AtlasFileError(f"{path}: the atlas holds no entries yet (an interrupted build: run the same "
                                 "`loopsolve atlas build` again to resume it)")
    return atlas
