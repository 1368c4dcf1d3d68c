"""The atlas on disk: a chunked zarr store, written chunk by chunk, opened only when it can be trusted.

Layout (zarr format 3, one directory)::

    ATLAS.zarr/zarr.json        group; attributes["loopsolve_atlas"]: what the atlas is (below)
    ATLAS.zarr/<array>/...      one array per field, chunked along the entries by the build chunk

Arrays (numeric only; ``E`` the atlas' size, ``C`` its chunk): ``params`` (E, k) float64 (model
units), ``status`` (E,) int8, ``crank`` (E,) bool, ``mode`` (E, nb) int8, ``x_start`` (E,),
``x_range`` (E, 2) float64 (internal input values), ``transmission`` (E, 2) float32 (degrees),
``grashof`` (E, nloops) int8, ``margin`` (E,) float64, ``place`` (E, 5) float64, ``curve`` (E, n, 2)
float32, ``efd`` (E, 4H − 3) float32, ``roundness`` (E,) float32, and ``filled`` (chunks,) int32:
how many entries of each chunk are written (a chunk is written whole, then its count).
Every chunk is compressed with zstd *with its checksum*, so a damaged chunk is an error, not
wrong numbers.

The attributes (``meta``): ``format``, ``model`` (the model file's text), ``source``, ``name``,
``fingerprint`` (:func:`fingerprint`: the model's structure, not its numbers), ``point``,
``names``, ``lo``, ``hi``, ``log`` (the sampled box), ``seed``, ``chunk``, ``size``,
``curve_points``, ``harmonics``, ``step_deg``, ``loops`` (four-bar loops of ``grashof``),
``blocks``, ``loopsolve`` (the version that built it).

**Trust.** A zarr store is data, but a foreign one could name codecs that run code (a pickle
codec) or be swapped under the user's feet. :func:`open_store` refuses, with one line naming the
path: a symlink anywhere in the store, a file or directory owned by another user or writable by
group or others (the compile cache's rule, :mod:`loopsolve.symbolic.compiled`), metadata that is
not this layout (unknown arrays, data types or codecs), and — when reading — chunks that fail
their checksum.
"""

from __future__ import annotations

import hashlib
import json
import os
import stat
import warnings

import numpy as np

from ...errors import ModelError

__all__ = ["FORMAT", "AtlasFileError", "fingerprint", "create_store", "open_store", "write_chunk", "read_arrays",
           "check_tree"]

FORMAT = 1
#: array name -> (data type, fill value)
FIELDS = {
    "params": ("float64", np.nan), "status": ("int8", 0), "crank": ("bool", False), "mode": ("int8", 0),
    "x_start": ("float64", np.nan), "x_range": ("float64", np.nan), "transmission": ("float32", np.nan),
    "grashof": ("int8", 0), "margin": ("float64", np.nan), "place": ("float64", np.nan),
    "curve": ("float32", np.nan), "efd": ("float32", np.nan), "roundness": ("float32", np.nan),
}
_CODECS = {"bytes", "zstd"}
_MAX_META = 10_000_000


class AtlasFileError(ModelError):
    """An atlas that is missing, foreign, unsafe, of another model or damaged (exit 2)."""


def fingerprint(mech) -> str:
    """Hash of a model's structure: units, variables, parameters (names and kinds), vectors, loops, points.

    Not the parameter values, the guesses, the name or the loopsolve version: an atlas built on a
    model serves every model file with the same declaration.
    """
    from ...model import expr as _expr

    def t(node):
        return None if node is None else _expr.to_text(node)

    parts = (
        (mech.units.length, mech.units.angle),
        tuple((v.name, v.kind.name, v.name in mech.inputs) for v in mech.variables),
        tuple((p.name, p.kind.name) for p in mech.parameters),
        tuple((v.name, t(v.length), t(v.angle), t(v.offset), t(v.x), t(v.y)) for v in mech.vectors),
        tuple((lp.name, lp.terms) for lp in mech.loops),
        tuple((pt.name, pt.terms, tuple(t(f) for f in pt.factors)) for pt in mech.points),
    )
    return hashlib.sha256(repr(parts).encode()).hexdigest()[:24]


def _zarr():
    try:
        import zarr
    except ImportError:
        from ...errors import MissingDependencyError

        raise MissingDependencyError("atlases need zarr: pip install 'loopsolve[study]'") from None
    major = zarr.__version__.split(".", 1)[0]
    if not major.isdigit() or int(major) < 3:
        from ...errors import MissingDependencyError

        # an atlas is zarr format 3 (checksummed zstd chunks); zarr 2 cannot write or read it
        raise MissingDependencyError(f"atlases need zarr 3 or newer (this environment has zarr {zarr.__version__}): "
                                     "pip install -U 'zarr>=3'")
    return zarr


# ----------------------------------------------------------------------------- trust


def check_tree(path) -> None:
    """Refuse a store with a symlink, a foreign or group/other-writable entry, or a non-regular file."""
    uid = os.getuid() if hasattr(os, "getuid") else None

    def check(p, st, what):
        if stat.S_ISLNK(st.st_mode):
            raise AtlasFileError(f"{path}: {what} {p} is a symlink; an atlas is one directory of plain files "
                                 "(rebuild it)")
        if not (stat.S_ISDIR(st.st_mode) or stat.S_ISREG(st.st_mode)):
            raise AtlasFileError(f"{path}: {p} is not a regular file or directory; not an atlas")
        if uid is not None and st.st_uid != uid:
            raise AtlasFileError(f"{path}: {p} belongs to another user (uid {st.st_uid}); an atlas is read only "
                                 "when it is yours (copy it, or rebuild it)")
        if st.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
            raise AtlasFileError(f"{path}: {p} is writable by group or others (mode {stat.S_IMODE(st.st_mode):o}); "
                                 f"an atlas is read only when nobody else can change it (chmod -R go-w {path})")

    try:
        top = os.lstat(path)
    except FileNotFoundError:
        raise AtlasFileError(f"{path}: no such atlas (build one: loopsolve atlas build MODEL ... -o {path})") from None
    except OSError as exc:
        raise AtlasFileError(f"{path}: cannot read the atlas: {exc.strerror or exc}") from None
    check(path, top, "the atlas")
    if not stat.S_ISDIR(top.st_mode):
        raise AtlasFileError(f"{path}: not an atlas (an atlas is a directory, ATLAS.zarr)")
    for root, dirs, files in os.walk(path, followlinks=False):
        for name in dirs + files:
            p = os.path.join(root, name)
            check(p, os.lstat(p), "entry")


def _read_json(path, what):
    try:
        with open(path, "rb") as f:
            data = f.read(_MAX_META + 1)
    except FileNotFoundError:
        raise AtlasFileError(f"{what}: missing {os.path.basename(path)}; not an atlas (or a damaged one: rebuild "
                             "it)") from None
    if len(data) > _MAX_META:
        raise AtlasFileError(f"{what}: {path} is too large for atlas metadata; not an atlas")
    try:
        return json.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise AtlasFileError(f"{what}: {path} is damaged ({exc}); rebuild the atlas") from None


def _check_meta(meta, where):
    need = {"format", "model", "fingerprint", "point", "names", "lo", "hi", "log", "seed", "chunk", "size",
            "curve_points", "harmonics", "step_deg", "loops", "blocks"}
    if not isinstance(meta, dict) or not need <= set(meta):
        raise AtlasFileError(f"{where}: not a loopsolve atlas (its zarr.json has no atlas description)")
    if meta["format"] != FORMAT:
        raise AtlasFileError(f"{where}: atlas format {meta['format']!r}, this loopsolve reads format {FORMAT}; "
                             "rebuild the atlas")
    try:
        k = len(meta["names"])
        ok = (isinstance(meta["model"], str) and len(meta["lo"]) == k == len(meta["hi"]) == len(meta["log"])
              and int(meta["chunk"]) >= 1 and int(meta["size"]) >= 0 and int(meta["curve_points"]) >= 8
              and int(meta["harmonics"]) >= 2 and int(meta["blocks"]) >= 0)
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise AtlasFileError(f"{where}: the atlas description is damaged; rebuild the atlas")


def _shapes(meta):
    k, nb, nl = len(meta["names"]), int(meta["blocks"]), len(meta["loops"])
    n, H = int(meta["curve_points"]), int(meta["harmonics"])
    return {"params": (k,), "status": (), "crank": (), "mode": (nb,), "x_start": (), "x_range": (2,),
            "transmission": (2,), "grashof": (nl,), "margin": (), "place": (5,), "curve": (n, 2),
            "efd": (4 * H - 3,), "roundness": ()}


def _check_array_meta(path, name, dtype, shape, chunk, where):
    m = _read_json(os.path.join(path, name, "zarr.json"), where)
    try:
        okay = (m.get("node_type") == "array" and m.get("zarr_format") == 3 and m.get("data_type") == dtype
                and tuple(m["shape"]) == tuple(shape)
                and tuple(m["chunk_grid"]["configuration"]["chunk_shape"])[:1] == (chunk,)
                and all(c.get("name") in _CODECS for c in m.get("codecs", []))
                and not m.get("storage_transformers"))
    except (KeyError, TypeError, AttributeError):
        okay = False
    if not okay:
        raise AtlasFileError(f"{where}: the array {name!r} is not of this atlas' layout; rebuild the atlas")


# ----------------------------------------------------------------------------- create, open, write


def create_store(path, meta) -> object:
    """A new empty store at ``path`` (a directory that must not exist) with ``meta``; returns the zarr group."""
    zarr = _zarr()
    from zarr.codecs import ZstdCodec

    size, C = int(meta["size"]), int(meta["chunk"])
    nchunks = -(-size // C)
    parent = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(parent):
        raise ModelError(f"-o {path}: the folder {parent} does not exist")
    os.mkdir(path, 0o700)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        g = zarr.open_group(str(path), mode="w")
        g.attrs["loopsolve_atlas"] = meta
        for name, tail in _shapes(meta).items():
            dtype, fill = FIELDS[name]
            g.create_array(name, shape=(size,) + tail, chunks=(C,) + tail, dtype=dtype, fill_value=fill,
                           compressors=ZstdCodec(level=3, checksum=True))
        g.create_array("filled", shape=(nchunks,), chunks=(max(nchunks, 1),), dtype="int32", fill_value=0,
                       compressors=ZstdCodec(level=3, checksum=True))
    _private(path)
    return g


def _private(path):
    """Group/other write bits off everywhere in the store (whatever the umask made)."""
    for root, dirs, files in os.walk(path):
        for name in dirs + files:
            p = os.path.join(root, name)
            st = os.lstat(p)
            if st.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
                os.chmod(p, stat.S_IMODE(st.st_mode) & ~(stat.S_IWGRP | stat.S_IWOTH))
    os.chmod(path, 0o700)


def open_store(path, *, write: bool = False):
    """Open a trusted store: ``(zarr group, meta)``; raises :class:`AtlasFileError` (see the module docstring)."""
    zarr = _zarr()
    path = os.fspath(path)
    check_tree(path)
    root = _read_json(os.path.join(path, "zarr.json"), path)
    if not isinstance(root, dict) or root.get("node_type") != "group":
        raise AtlasFileError(f"{path}: not an atlas (its zarr.json is not a zarr group)")
    meta = (root.get("attributes") or {}).get("loopsolve_atlas")
    _check_meta(meta, path)
    size, C = int(meta["size"]), int(meta["chunk"])
    for name, tail in _shapes(meta).items():
        _check_array_meta(path, name, FIELDS[name][0], (size,) + tail, C, path)
    _check_array_meta(path, "filled", "int32", (-(-size // C),), max(-(-size // C), 1), path)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            g = zarr.open_group(path, mode="r+" if write else "r")
    except Exception as exc:  # noqa: BLE001 — any failure of a foreign or damaged store is one line
        raise AtlasFileError(f"{path}: cannot open the atlas ({type(exc).__name__}: {exc}); rebuild it") from None
    return g, meta


def resize_store(g, meta, size: int) -> dict:
    """Grow every array to ``size`` entries (the chunks written stay); returns the new meta."""
    C = int(meta["chunk"])
    nchunks = -(-size // C)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name, tail in _shapes(meta).items():
            g[name].resize((size,) + tail)
        old = np.asarray(g["filled"][:])
        del g["filled"]
        from zarr.codecs import ZstdCodec

        f = g.create_array("filled", shape=(nchunks,), chunks=(max(nchunks, 1),), dtype="int32", fill_value=0,
                           compressors=ZstdCodec(level=3, checksum=True))
        new = np.zeros(nchunks, dtype=np.int32)
        new[:len(old)] = old[:nchunks]
        f[:] = new
        meta = dict(meta, size=int(size))
        g.attrs["loopsolve_atlas"] = meta
    return meta


def write_chunk(g, meta, c: int, arrays: dict, count: int) -> None:
    """Write chunk ``c`` (its first ``count`` entries) and then its count (so a half-written chunk is redone)."""
    C = int(meta["chunk"])
    a = c * C
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name in FIELDS:
            g[name][a:a + count] = np.asarray(arrays[name])[:count]
        filled = g["filled"]
        cur = np.asarray(filled[:])
        cur[c] = count
        filled[:] = cur


def read_arrays(g, meta, where) -> dict:
    """Every field, read into memory; a chunk failing its checksum is an :class:`AtlasFileError`."""
    out = {}
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            for name in FIELDS:
                out[name] = np.asarray(g[name][:])
            out["filled"] = np.asarray(g["filled"][:])
    except Exception as exc:  # noqa: BLE001 — a damaged chunk (checksum, truncation) of any kind
        raise AtlasFileError(f"{where}: the atlas is damaged ({type(exc).__name__}: "
                             f"{str(exc).splitlines()[0] if str(exc) else 'unreadable chunk'}); rebuild it") from None
    return out
