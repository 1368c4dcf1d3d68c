"""The ``numba`` engine: the generated kinematics and the tracer's fast lane compiled to machine code.

:func:`fast_lane` takes the scalar functions Φ, Φ_q and b₁–b₃ that :mod:`loopsolve.symbolic.compiled`
generated for a model (plain ``math`` code), rewrites them to return tuples, appends the natural
step generated for the model's block structure (:func:`loopsolve.kinematics.stepgen.step_source`,
the text the Python tracer runs; every structure of 1×1 and 2×2 blocks, see :func:`fast_lane`) and
the fast lane's step loop (:mod:`loopsolve.kinematics.numba_engine.steps`) and compiles the module with
``numba.njit(cache=True)``. The module is written to the loopsolve cache directory as
``nb_<hash>.py`` (the hash of its text), and numba keeps the machine code next to it in
``__pycache__``, so a model compiled once is loaded in later processes without the JIT.

Unreadable entries: a truncated, corrupt or unreadable numba index or data file is a cache miss
(:class:`_MissOnError`): the function is compiled again and its entry rewritten, never an error;
a generated ``nb_<hash>.py`` whose content does not match its header is rewritten likewise.

Security: numba's cache holds pickled data and machine code, so the same rules as the
generated modules (:func:`loopsolve.symbolic.compiled.check_dir`, ``read_entry``) apply: the cache
directory and its ``__pycache__`` must belong to the user and be writable by nobody else,
the module file must be a regular file of the user's whose content matches the hash in its
first line, and no entry of ``__pycache__`` for it may be a symlink, foreign or writable by
others. Otherwise the module is compiled in memory (no disk cache) with one
:class:`~loopsolve.errors.LoopsolveWarning` naming the reason.

Engines (``engine=`` of :func:`loopsolve.sweep.sweep`, ``--engine`` of the CLI, default from
the ``LOOPSOLVE_ENGINE`` environment variable, else ``"auto"``):

``"python"``
    the pure-Python tracer (no numba import);
``"numba"``
    the fast lane; :class:`~loopsolve.errors.MissingDependencyError` when numba is not installed;
``"auto"`` (the default)
    the fast lane once it pays: when numba is installed, the model has a fast lane, and the sweeps
    of this process (this one included) have asked for at least :data:`AUTO_ROWS` rows. Below
    that the Python tracer is cheaper than importing numba and loading a compiled model (about
    1 s in a fresh process, the machine code cached on disk), so a one-off command-line sweep
    never imports numba, and a program that sweeps a lot switches once and stays switched.
    See :func:`engine_for`.
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import stat
import sys
import threading
from pathlib import Path
from types import ModuleType

from ...errors import MissingDependencyError, ModelError, warn

__all__ = ["ENGINES", "AUTO_ROWS", "MAX_LANE_SOURCE", "model_source_chars", "use_numba", "engine_name", "engine_for", "has_lane", "fast_lane", "numba_source",
           "numba_module"]

ENGINES = ("python", "numba", "auto")
FORMAT = 6  # bump when the generated numba module or its compile options change (6: the lockstep kernel)
_MEMO: dict[str, ModuleType] = {}
_LOCK = threading.Lock()
#: the numba module of each generated kinematics module (held with it: ids are not reused)
_BY_MODULE: dict[int, tuple[ModuleType, ModuleType]] = {}
#: the model's generated functions the fast lane calls
_MODEL_FUNCTIONS = ("phi", "jac", "rhs1", "rhs2", "rhs3")
#: the model's generated points the lockstep kernel calls (as array forms, with the model's functions)
_POINT_FUNCTIONS = ("points0", "points1", "points2", "points3")
#: the generated tuple helpers (inlined)
_HELPERS = ("ztuple", "zset", "rvec")
#: the generated functions of the model's structure (compiled, not inlined)
_GENERATED = ("start_rates", "natural_step")
#: the generated array forms of the model's functions (the compiled lockstep's calls; not inlined)
_WRAPPERS = ("phi_a", "jac_a", "rhs1_a", "rhs2_a", "rhs3_a", "points0_a", "points1_a", "points2_a", "points3_a")

#: ``"auto"`` takes the fast lane once the process's sweeps have asked for this many rows: the
#: break-even of importing numba and loading a cached compiled model (~1 s in a fresh process on
#: the shared 2-core machine: ``import numba`` 0.4 s, the model 0.2–0.6 s) against the Python
#: tracer's 20–60 µs a row (a 361-row cycle of the thesis crank-rocker: 10–21 ms). Measured by
#: ``benchmarks/bench_engine_default.py``.
AUTO_ROWS = 20_000
#: rows the process's ``"auto"`` sweeps asked for so far (guarded by _LOCK)
_AUTO_SEEN = [0]


def engine_name(engine: str | None) -> tuple[str, str]:
    """``engine``, or ``$LOOPSOLVE_ENGINE``, else ``"auto"``, checked; and where it came from."""
    src = "engine"
    if engine is None:
        engine = os.environ.get("LOOPSOLVE_ENGINE") or "auto"
        src = "LOOPSOLVE_ENGINE"
    if engine not in ENGINES:
        raise ModelError(f"{src}={engine!r}: expected one of {', '.join(ENGINES)}")
    return engine, src


def _installed() -> bool:
    """numba can be found: imported already (a dictionary lookup, for the sweeps of a busy program), or on
    the path (``find_spec``, ~20 µs, without importing it)."""
    return sys.modules.get("numba") is not None or importlib.util.find_spec("numba") is not None


def use_numba(engine: str | None) -> bool:
    """Whether ``engine`` (None: ``$LOOPSOLVE_ENGINE``, else ``"auto"``) can take the compiled fast lane.

    ``"numba"`` and ``"auto"`` with numba installed and importable; which engine a sweep then
    runs is :func:`engine_for`'s choice. Raises :class:`MissingDependencyError` for ``"numba"``
    without numba installed, and :class:`ModelError` for an unknown engine name.

    Examples
    --------
    >>> from loopsolve.kinematics.numba_engine.jit import use_numba
    >>> use_numba("python")
    False
    >>> use_numba("cuda")
    Traceback (most recent call last):
    ...
    loopsolve.errors.ModelError: engine='cuda': expected one of python, numba, auto
    """
    engine, src = engine_name(engine)
    if engine == "python":
        return False
    installed = _installed()
    if engine == "numba" and not installed:
        raise MissingDependencyError(f"{src}='numba' needs numba: pip install 'loopsolve[fast]' (or use "
                                     "engine='python')")
    if not installed:
        return False
    try:
        import numba  # noqa: F401
    except Exception as exc:  # installed but broken (e.g. a numpy it does not support)
        if engine == "auto":
            return False
        raise MissingDependencyError(f"{src}='numba': numba is installed but does not import "
                                     f"({type(exc).__name__}: {exc}); use engine='python'") from None
    return True


#: a model whose generated Φ, Φ_q and b₁–b₃ are longer than this (characters of source) has no fast lane:
#: numba's type inference and LLVM take time superlinear in the length of one expression, and such a
#: model does not compile in minutes (a cam declared by a pitch table: a spline of hundreds of pieces,
#: ~660 000 characters, expressions of ~150 000 each). The shipped models' are 1 500–6 000.
MAX_LANE_SOURCE = 60_000


def model_source_chars(ck) -> int:
    """Characters of the generated functions the fast lane compiles for ``ck``'s model (Φ, Φ_q, b₁–b₃)."""
    source = getattr(ck.module, "_SOURCE", None)
    if source is None:
        return 0
    return sum(len(_model_function(source, name)) for name in _MODEL_FUNCTIONS)


def has_lane(kern) -> bool:
    """Whether the model of a :class:`~loopsolve.kinematics.scalar_solver.Kernel` has a compiled fast lane:
    its natural step is generated (every structure of 1×1 and 2×2 blocks, see :func:`fast_lane`) and its
    generated functions are at most :data:`MAX_LANE_SOURCE` characters (numba's compile time grows
    faster than their length)."""
    from ..stepgen import supported

    lane = getattr(kern, "_has_lane", None)
    if lane is None:
        lane = kern._has_lane = supported(kern) and model_source_chars(kern.ck) <= MAX_LANE_SOURCE
    return lane


def _no_lane_reason(kern) -> str:
    from ..stepgen import MAX_UNKNOWNS, supported

    if not supported(kern):
        return f"a block larger than 2×2 or more than {MAX_UNKNOWNS} unknowns"
    return (f"its generated functions are {model_source_chars(kern.ck):,} characters, over the "
            f"{MAX_LANE_SOURCE:,} numba compiles in reasonable time")


def engine_for(engine: str | None, kern, rows: int) -> str:
    """The engine a sweep of ``rows`` output rows of ``kern``'s model runs: ``"numba"`` or ``"python"``.

    ``engine`` as :func:`use_numba` reads it. ``"python"``, or a model without a fast lane
    (:func:`has_lane`): Python. ``"numba"``: numba (the error of :func:`use_numba` without it).
    ``"auto"`` (the default): numba when installed and the ``"auto"`` sweeps of this process, this
    one included, have asked for :data:`AUTO_ROWS` rows or more — a rent-or-buy rule: the Python
    tracer runs while its total cost is below the one-off cost of numba's import and the compiled
    model's load, then the compiled lane for the rest of the process. So a one-off command line of
    a few hundred rows never imports numba; a sweep of more rows, or a program that sweeps many
    times, does. The rows of both engines agree to round-off.

    Examples
    --------
    >>> from loopsolve.kinematics.numba_engine.jit import engine_for
    >>> from loopsolve.kinematics.scalar_solver import kernel_of
    >>> kern = kernel_of(ls.fourbar(4, 2, 3.5, 3).compile())
    >>> engine_for("python", kern, 10**6)
    'python'
    """
    name, _ = engine_name(engine)
    if name == "python":
        return "python"
    if name == "numba":
        use_numba(name)  # the one-line error without numba
        if has_lane(kern):
            return "numba"
        if not getattr(kern, "_warned_lane", False):  # once per model, not once per sweep of a study
            kern._warned_lane = True
            warn(f"{kern.ck.mechanism.source or kern.ck.mechanism.name}: engine='numba' but the model has no "
                 f"compiled lane ({_no_lane_reason(kern)}); the Python tracer runs it (same rows)")
        return "python"
    if not has_lane(kern) or not _installed():  # no import: a cheap look
        return "python"
    with _LOCK:
        _AUTO_SEEN[0] += int(rows)
        worth = _AUTO_SEEN[0] >= AUTO_ROWS
    return "numba" if worth and use_numba(name) else "python"


def _model_function(source: str, name: str) -> str:
    """The scalar function ``name`` of a generated module's source, returning a tuple instead of a list."""
    start = source.find(f"\ndef {name}(")
    if start < 0:
        raise ValueError(f"generated module without {name}()")
    end = source.find("\n\n", start + 1)
    lines = source[start + 1:end if end >= 0 else len(source)].split("\n")
    last = lines[-1]
    if not (last.startswith("    return [") and last.endswith("]")):
        raise ValueError(f"unexpected end of {name}(): {last[:40]!r}")
    lines[-1] = "    return (" + last[len("    return ["):-1] + ",)"
    return "\n".join(lines)


def _tuple_helpers(nv: int, *indices: int) -> str:
    """Tuple helpers with the model's indices written in (``indices``: the unknowns' in order, then the
    input's; compile-time constants, part of the module's text, hence of its cache key): ``ztuple(z)``,
    a node's values; ``zset(z, u0, u1, ...)``, ``z`` with the unknowns replaced; ``rvec(rx, u0, u1, ...)``,
    a rate vector (``rx`` at the input, the unknowns' rates, 0 elsewhere). The compiled steps pass tuples, not arrays, to the model's
    functions: nothing in memory separates two calls at one point, so LLVM computes the sines and
    cosines they share once, and hoists those of the input (fixed during a corrector) out of its loop."""
    *iu, ix = indices
    at_u = {i: f"u{c}" for c, i in enumerate(iu)}
    us = ", ".join(f"u{c}" for c in range(len(iu)))

    def entries(at):
        return ", ".join(at(i) for i in range(nv))

    def z_or(i):
        return at_u.get(i, f"z[{i}]")

    def r_or(i):
        return "rx" if i == ix else at_u.get(i, "0.0")

    return (f"def ztuple(z):\n    return ({entries(lambda i: f'z[{i}]')},)\n\n\n"
            f"def zset(z, {us}):\n    return ({entries(z_or)},)\n\n\n"
            f"def rvec(rx, {us}):\n    return ({entries(r_or)},)\n")


def _start_rates(single2: bool) -> str:
    """``start_rates(z, p, iv, rr, orr)``: the start node's rates in the step loop (a single 2×2 block)."""
    if not single2:
        return "def start_rates(z, p, iv, rr, orr):\n    return\n"
    return ("def start_rates(z, p, iv, rr, orr):\n"
            "    orr[0, 0], orr[0, 1], orr[0, 2], orr[0, 3], orr[0, 4], orr[0, 5], orr[0, 6] = node_rates(\n"
            "        ztuple(z), p, iv[0], iv[1], iv[2], rr[0], rr[1], rr[2], rr[3], rr[4])\n")


def numba_source(ck) -> str:
    """Text of the numba module of ``ck``: its Φ, Φ_q, b₁–b₃, the natural step generated for its block
    structure (:func:`loopsolve.kinematics.stepgen.step_source`, the text the Python tracer runs) and
    the fast lane's template; then the model's points, the array wrappers and the compiled lockstep of
    a study chunk (:mod:`loopsolve.kinematics.numba_engine.lockstep_kernel`). numba compiles a function
    at its first call: a tracer never compiles the lockstep's functions."""
    from ... import __version__
    from ..scalar_solver import kernel_of
    from ..stepgen import step_source
    from .steps import template_source

    source = getattr(ck.module, "_SOURCE", None)
    if source is None:
        raise ValueError("compiled module without its source")
    # no model name in the text: models whose generated functions are the same share one module
    parts = [f"# Generated by loopsolve {__version__} (numba engine, format {FORMAT}). Do not edit.",
             "import math", "import numpy as np", ""]
    parts += [_model_function(source, name) + "\n" for name in _MODEL_FUNCTIONS]
    kern = kernel_of(ck)
    parts.append(_tuple_helpers(len(ck.variables), *kern.iu, kern.ix))
    parts.append(_start_rates(bool(kern.single2)))
    parts.append(step_source(kern, "numba"))
    parts.append(template_source())
    from . import lockstep_kernel

    npts = len(ck.points)
    names = _MODEL_FUNCTIONS + (_POINT_FUNCTIONS if npts else ())
    parts.append(lockstep_kernel.wrapper_source({name: _model_function(source, name) for name in names}, kern.n, npts))
    parts.append(lockstep_kernel.template_source())
    return "\n".join(parts) + "\n"


def _check_pycache(directory: Path, stem: str) -> None:
    """numba's ``__pycache__`` next to the module: private to the user, no foreign or linked entry for it."""
    from ...symbolic.compiled import check_dir, check_owner_mode, Untrusted

    pyc = directory / "__pycache__"
    if not pyc.exists():
        try:
            os.mkdir(pyc, 0o700)
        except FileExistsError:
            pass
        os.chmod(pyc, 0o700)
    check_dir(pyc)
    for entry in os.scandir(pyc):
        if not entry.name.startswith(stem + "."):
            continue
        st = os.lstat(entry.path)
        if not stat.S_ISREG(st.st_mode):
            raise Untrusted(f"the numba cache entry {entry.path} is not a regular file")
        check_owner_mode(st, f"the numba cache entry {entry.path}")


class _MissOnError:
    """numba's disk cache of one function, where an entry that cannot be read is a miss, never a failure.

    numba unpickles the function's index (``.nbi``) and data (``.nbc``) in ``__pycache__`` when it
    first compiles the function; a truncated, corrupt or unreadable file raised out of the first
    call (``UnpicklingError`` on every sweep of the model until the cache was cleared). Here any
    exception of a load is a miss: the index is replaced by an empty one (the data files it named
    are overwritten by the next save), numba compiles, and the save writes a good entry. A save
    that fails (a corrupt index read back) starts the index afresh once more; if that fails too
    the machine code is simply not cached.
    """

    def __init__(self, inner):
        self._inner = inner

    def __getattr__(self, name):
        return getattr(self._inner, name)

    def load_overload(self, sig, target_context):
        try:
            return self._inner.load_overload(sig, target_context)
        except Exception:  # noqa: BLE001 — whatever an unreadable entry raises, it is a miss
            self._reset()
            return None

    def save_overload(self, sig, data):
        try:
            self._inner.save_overload(sig, data)
        except Exception:  # noqa: BLE001
            self._reset()
            try:
                self._inner.save_overload(sig, data)
            except Exception:  # noqa: BLE001 — not cached: the compiled function still runs
                pass

    def _reset(self) -> None:
        try:
            self._inner.flush()  # an empty index, written atomically
        except Exception:  # noqa: BLE001
            pass


def _miss_on_error(dispatcher):
    """``dispatcher`` with its disk cache wrapped by :class:`_MissOnError` (when it has one)."""
    cache = getattr(dispatcher, "_cache", None)
    if cache is not None and type(cache).__name__ != "NullCache" and not isinstance(cache, _MissOnError):
        dispatcher._cache = _MissOnError(cache)
    return dispatcher


def _numba_module(ck) -> ModuleType:
    """The compiled numba module of ``ck`` (from the in-process memo, numba's disk cache or the JIT)."""
    hit = _BY_MODULE.get(id(ck.module))
    if hit is not None and hit[0] is ck.module:
        return hit[1]
    import numba

    from ...symbolic.compiled import (check_dir, ensure_dir, read_entry, Stale, Untrusted, warn_untrusted, write_entry,
                           cache_dir)

    source = numba_source(ck)
    key = hashlib.sha256(f"{numba.__version__}\n{source}".encode()).hexdigest()[:24]
    with _LOCK:
        if key in _MEMO:
            _BY_MODULE[id(ck.module)] = (ck.module, _MEMO[key])
            return _MEMO[key]
    directory = cache_dir()
    origin, cache = f"<loopsolve numba {key}>", False
    if directory is not None:
        path = directory / f"nb_{key}.py"
        try:
            ensure_dir(directory)
            check_dir(directory)
            _check_pycache(directory, f"nb_{key}")
            try:
                text = read_entry(path, key)
            except Stale:
                text = None
            if text != source:
                if not write_entry(path, source, key) or read_entry(path, key) != source:
                    raise OSError("not written")
            origin, cache = str(path), True
        except Untrusted as exc:
            warn_untrusted(str(exc))
        except (OSError, Stale):
            pass  # an unwritable cache: compile in memory
    module = ModuleType(f"loopsolve_numba_{key}")
    module.__file__ = origin
    # numba finds a function's globals by importing its module by name (also when it loads the
    # machine code from its cache): the module must be registered
    sys.modules[module.__name__] = module
    # the entry's first line is its header (a comment): one blank line keeps the line numbers
    exec(compile("\n" + source, origin, "exec"), module.__dict__)
    jit = numba.njit(cache=cache, error_model="numpy")
    # the model's functions are inlined where they are called, so that LLVM shares the sines and
    # cosines that Φ_q and b₁–b₃ take of the same angles (the rates of a row)
    inline = numba.njit(cache=cache, error_model="numpy", inline="always")
    from .steps import TEMPLATE_FUNCTIONS, TEMPLATE_INLINE

    from .lockstep_kernel import TEMPLATE_FUNCTIONS as LOCKSTEP_FUNCTIONS

    inlined = _MODEL_FUNCTIONS + _HELPERS + tuple(fn.__name__ for fn in TEMPLATE_INLINE)
    for name in inlined:
        setattr(module, name, _miss_on_error(inline(getattr(module, name))))
    for name in _GENERATED + _WRAPPERS + tuple(fn.__name__ for fn in TEMPLATE_FUNCTIONS + LOCKSTEP_FUNCTIONS
                                               if fn.__name__ not in inlined):
        setattr(module, name, _miss_on_error(jit(getattr(module, name))))
    with _LOCK:
        _MEMO[key] = module
        _BY_MODULE[id(ck.module)] = (ck.module, module)
    return module


def numba_module(ck) -> ModuleType:
    """The model's compiled numba module (its functions compiled at their first call): what the compiled
    lockstep of a study chunk calls (``lockstep_run``, :mod:`loopsolve.kinematics.numba_engine.lockstep_kernel`)."""
    return _numba_module(ck)


def fast_lane(kern, *, lazy: bool = False):
    """The compiled fast lane of a :class:`~loopsolve.kinematics.scalar_solver.Kernel`, or None where it has none.

    Every structure of 1×1 and 2×2 diagonal blocks in solve order has one (the natural step generated
    for it, :mod:`loopsolve.kinematics.stepgen`) up to ``stepgen.MAX_UNKNOWNS`` unknowns; a structure with a
    block larger than 2×2 or more unknowns has none (the tracer then runs in Python). The compiled start (:meth:`FastLane.start`) and the rates fused into the
    step loop exist for a single 2×2 block; other structures start and take their rates as the Python
    engine does.
    """
    from .steps import FastLane

    if not has_lane(kern):
        return None
    module = _numba_module(kern.ck)
    if kern.single2:
        return FastLane(kern, module.run_steps, lazy=lazy, start=module.start2, rates=module.rates2,
                        fill=module.fill_rates)
    return FastLane(kern, module.run_steps, lazy=lazy)
