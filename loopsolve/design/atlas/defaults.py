"""Default atlases: built once into the user's cache on first use, never shipped, never built twice.

Three recipes ship with loopsolve (:data:`RECIPES`): the four-bar of
``models/fourbar_path_synthesis.toml`` (163,840 designs sampled, about 108,000 certified) and the
Watt II and Stephenson III six-bars of ``models/watt2_sixbar_path.toml`` and
``models/stephenson3_sixbar_path.toml`` (32,768 each), every one of point ``P``. A model whose
declaration is one of these (the same vectors, loops, points and parameters, whatever its numbers
— :func:`loopsolve.design.atlas.store.fingerprint`) uses that recipe. Any other model gets a recipe
of its own (:func:`generic_recipe`: 16,384 designs around the model's own dimensions).

The atlas is built the first time it is needed into ``<cache>/atlas/`` (the compile cache's
directory, :func:`loopsolve.symbolic.compiled.cache_dir`; ``LOOPSOLVE_CACHE_DIR=""`` disables it:
the atlas is then built in memory at every use), with a progress bar on a terminal, seeded
(the same atlas on every machine), in this process (``LOOPSOLVE_ATLAS_WORKERS=N``: on a local Dask
cluster of N processes — only from a script guarded by ``if __name__ == "__main__":`` or from the
command line, as Dask's spawned workers import the caller's main module again). A lock file keeps two processes from building it at once (the
second waits, then opens it); an interrupted build resumes where it stopped.

Environment: ``LOOPSOLVE_ATLAS_SIZE=N`` builds every default atlas with N designs instead (tests,
a quick look); ``LOOPSOLVE_ATLAS_WORKERS=N`` builds on N local processes (default, 1: in this process).
``loopsolve atlas default MODEL --point P [--workers N]`` builds one ahead of its first use.
"""

from __future__ import annotations

import hashlib
import json
import os
import sys

from ...errors import ModelError
from ...model.units import Kind

__all__ = ["RECIPES", "default_atlas", "recipe_for", "generic_recipe", "atlas_dir"]

_FOURBAR = {"r2": (0.4, 4.0), "r3": (1.6, 16.0), "r4": (1.6, 16.0), "rcx": (-8.0, 16.0), "rcy": (-12.0, 12.0)}
_WATT2 = {"r2": (10, 40), "r3": (30, 120), "r4": (25, 100), "r5": (10, 80), "alpha": (0, 360), "r6": (30, 150),
          "r7": (30, 150), "beta": (0, 360), "r8": (20, 120), "pcx": (-60, 120), "pcy": (-80, 80)}
_STEPH3 = {"r2": (10, 40), "r3": (30, 120), "r4": (25, 100), "rc": (10, 100), "gamma": (0, 360), "r5": (30, 150),
           "r6": (30, 150), "r7": (30, 200), "beta": (0, 360), "pcx": (-60, 120), "pcy": (-80, 80)}

#: name -> (model file in models_dir(), point, vary, size)
RECIPES = {
    "fourbar": ("fourbar_path_synthesis.toml", "P", _FOURBAR, 40 * 4096),
    "watt2": ("watt2_sixbar_path.toml", "P", _WATT2, 8 * 4096),
    "stephenson3": ("stephenson3_sixbar_path.toml", "P", _STEPH3, 8 * 4096),
}
GENERIC_SIZE = 4 * 4096
CHUNK = 4096
STEP_DEG = 4.0


def atlas_dir():
    """Where default atlases live (``<cache>/atlas``), or None when the disk cache is disabled."""
    from ...symbolic.compiled import cache_dir

    base = cache_dir()
    return None if base is None else base / "atlas"


def _size(default: int) -> int:
    env = os.environ.get("LOOPSOLVE_ATLAS_SIZE")
    if not env:
        return default
    try:
        n = int(env)
    except ValueError:
        raise ModelError(f"LOOPSOLVE_ATLAS_SIZE={env!r}: a whole number of designs") from None
    if n < 1:
        raise ModelError(f"LOOPSOLVE_ATLAS_SIZE={env!r}: at least 1")
    return n


def _workers():
    """Local Dask workers for a default build: ``LOOPSOLVE_ATLAS_WORKERS`` (default: none, this process).

    Not one per CPU by default: Dask starts its worker processes by *spawning* them, which imports the
    caller's ``__main__`` again — a user's script without an ``if __name__ == "__main__":`` guard that calls
    ``ls.synthesize(..., shape=...)`` would run again in every worker (and wait for the atlas it is building).
    """
    from ..studies import usable_cpus

    env = os.environ.get("LOOPSOLVE_ATLAS_WORKERS")
    if not env:
        return None
    try:
        n = int(env)
    except ValueError:
        raise ModelError(f"LOOPSOLVE_ATLAS_WORKERS={env!r}: a whole number of processes") from None
    n = max(1, min(n, usable_cpus()))
    if n <= 1:
        return None
    try:
        import distributed  # noqa: F401
    except ImportError:
        return None
    return n


def generic_recipe(mech, point):
    """A recipe for any model: its lengths (but the first, which holds the scale) within a factor of 3 of its
    own values on a log scale, signed lengths and dimensionless parameters within ± the model's size, angles
    within ± 90°; the frame's parameters, which shape synthesis sets itself, are not sampled."""
    from .frame import frame_of

    fr = frame_of(mech, point)
    ck = mech.compile()
    size = float(ck.scale)
    vals = {p.name: float(mech.spec["parameters"][p.name]) for p in mech.parameters}
    vary = {}
    ref = fr.lengths[0] if fr.lengths else None
    deg = mech.units.angle == "deg"
    for p in mech.parameters:
        n = p.name
        if n in (fr.x, fr.y, fr.angle, ref) or n not in vals:
            continue
        v = vals[n]
        if p.kind is Kind.LENGTH and v > 0:
            vary[n] = (v / 3.0, v * 3.0)
        elif p.kind is Kind.ANGLE:
            q = 90.0 if deg else 1.5707963267948966
            vary[n] = (v - q, v + q)
        else:
            vary[n] = (v - size, v + size)
    if not vary:
        raise ModelError(f"{mech.source or mech.name}: the model has no parameters to sample for an atlas")
    return ("model", point, vary, GENERIC_SIZE)


def recipe_for(mech, point):
    """``(name, Mechanism of the recipe, point, vary, size)`` of the default atlas of ``mech``'s ``point``."""
    from ...model.modelfile import load, models_dir
    from .store import fingerprint

    fp = fingerprint(mech)
    for name, (fname, pt, vary, size) in RECIPES.items():
        path = models_dir() / fname
        if not path.is_file():
            continue
        model = load(path)
        if pt == point and fingerprint(model) == fp:
            return name, model, pt, vary, _size(size)
    name, pt, vary, size = generic_recipe(mech, point)
    return name, mech, pt, vary, _size(size)


def default_atlas(mech, point, *, progress=None, seed: int = 0, workers: int | None = None):
    """The default atlas of ``mech``'s ``point``: opened from the cache, or built there first (see the module docstring).

    ``workers``: build on a local Dask cluster of that many processes (default ``LOOPSOLVE_ATLAS_WORKERS``).
    ``progress``: a bar on stderr (``True``; default on a terminal), none (``False``), or a callable
    ``progress(done, total)`` called as the designs are built (not called when the atlas is in the cache).
    """
    from .build import build_atlas, describe, open_atlas

    name, model, pt, vary, size = recipe_for(mech, point)
    meta = describe(model, pt, vary, seed=seed, chunk=CHUNK, step_deg=STEP_DEG)
    key = hashlib.sha256(json.dumps({k: meta[k] for k in ("fingerprint", "point", "names", "lo", "hi", "log",
                                                          "seed", "chunk", "step_deg", "curve_points",
                                                          "harmonics")}, sort_keys=True).encode()).hexdigest()[:16]
    base = atlas_dir()
    kwargs = dict(point=pt, vary=vary, size=size, seed=seed, chunk=CHUNK, step_deg=STEP_DEG, progress=progress,
                  max_size=max(size, 1), _desc=f"default atlas ({name}, once)")
    if base is None:
        return build_atlas(model, workers=workers or _workers(), **kwargs)
    from ...symbolic.compiled import ensure_dir

    ensure_dir(base.parent)
    ensure_dir(base)
    path = base / f"{name}-{key}-{size}.zarr"
    lock = base / f"{name}-{key}-{size}.lock"
    if path.is_dir():
        try:
            atlas = _opened(path)
            if atlas.complete:
                return atlas
        except ModelError:
            pass
    import fcntl

    fd = os.open(lock, os.O_RDWR | os.O_CREAT, 0o600)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        if path.is_dir():
            try:
                atlas = open_atlas(path)
                if atlas.complete:
                    return atlas
            except ModelError as exc:  # a damaged or foreign default atlas: say so, and build a fresh one aside
                path = base / f"{name}-{key}-{size}-{os.getpid()}.zarr"
                _note(f"the cached default atlas cannot be used ({exc}); building a new one at {path}", progress)
        if progress is None and sys.stderr.isatty() or progress:
            _note(f"building the default atlas of {model.name!r} point {pt!r} ({size} designs, once) into {path}",
                  True)
        return build_atlas(model, out=path, workers=workers or _workers(), **kwargs)
    finally:
        try:
            fcntl.flock(fd, fcntl.LOCK_UN)
        finally:
            os.close(fd)


_OPEN: dict = {}


def _opened(path):
    """The default atlas at ``path``, read once per process (again when its chunk counts changed on disk)."""
    from .build import open_atlas

    try:
        stamp = os.stat(path / "filled" / "c" / "0").st_mtime_ns
    except OSError:
        stamp = None
    hit = _OPEN.get(str(path))
    if hit is not None and hit[0] == stamp and stamp is not None:
        from .store import check_tree

        check_tree(path)  # still ours and nobody else's to change
        return hit[1]
    atlas = open_atlas(path)
    _OPEN.clear()  # one atlas kept: they are tens of megabytes
    _OPEN[str(path)] = (stamp, atlas)
    return atlas


def _note(text, progress):
    if progress is None:
        progress = sys.stderr.isatty()
    if progress:
        print(f"loopsolve: {text}", file=sys.stderr)
