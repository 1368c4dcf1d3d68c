"""Compiled numerics: the derivation printed once to Python source, cached on disk.

:func:`compile_mechanism` derives (sympy), eliminates common subexpressions, and prints a
small Python module with two flavours of every function: scalar (``math``, fastest for one
Newton step) and vectorized (``numpy``, for batched sweeps). The module is written to the
cache directory keyed by a hash of the declaration's *structure* (parameter values are passed
at run time) and the package and sympy versions, so a second command-line call on the same
model imports it and never touches sympy.

The generated functions take their arguments in declaration order:

``phi(z, p)``
    Φ, length m (two rows per loop).
``jac(z, p)``
    Φ_q, row-major, length m·n (n unknowns in :attr:`CompiledKinematics.unknowns` order).
``rhs1(z, z1, p)``, ``rhs2(z, z1, z2, p)``, ``rhs3(z, z1, z2, z3, p)``
    b₁, b₂, b₃ (the unknowns' own rates in ``zk`` are ignored).
``points0(z, p)`` … ``points3(z, z1, z2, z3, p)``
    x, y of every point (and their derivatives), interleaved.
``vectors0(z, p)`` … ``vectors2(z, z1, z2, p)``
    length, angle of every vector (and derivatives), interleaved.

``z`` holds every joint variable (radians / model length unit), ``z1``–``z3`` their rates and
``p`` the parameter values (internal units).
"""

from __future__ import annotations

import functools
import hashlib
import os
import stat
import tempfile
import threading
import weakref
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import ModuleType

import numpy as np

from .. import __version__
from ..model.files import read_capped
from ..model.mechanism import Mechanism
from ..model.topology import Block
from ..model.units import Kind

__all__ = ["CompiledKinematics", "compile_mechanism", "cache_dir", "generate_source"]

_MEMO: dict[str, ModuleType] = {}
_LOCK = threading.Lock()
FORMAT = 5  # bump when the generated module's layout changes (5: imports from loopsolve.symbolic.compiled)


def cache_dir() -> Path | None:
    """Where compiled models are cached: ``$LOOPSOLVE_CACHE_DIR`` or ``$XDG_CACHE_HOME/loopsolve``.

    Set ``LOOPSOLVE_CACHE_DIR`` to an empty string to disable the disk cache.
    """
    env = os.environ.get("LOOPSOLVE_CACHE_DIR")
    if env is not None:
        return Path(env) if env else None
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "loopsolve"


@functools.lru_cache(maxsize=1)
def _sympy_version() -> str:
    """sympy's installed version, looked up once per process (the lookup scans the installed
    distributions: ~1 ms, paid by every compile of every design of a study before)."""
    import importlib.metadata as md

    try:
        return md.version("sympy")
    except md.PackageNotFoundError:  # pragma: no cover
        return "?"


def structure_key(mech: Mechanism, inputs: Sequence[str]) -> str:
    """Hash of everything the generated code depends on (not the parameter values).

    Kept on the mechanism per choice of inputs (a ``Mechanism`` is immutable; hashing its
    declaration is most of a cached ``compile()``, which every ``mech.sweep(...)`` calls)."""
    inputs = tuple(inputs)
    key = _KEYS.get(mech, inputs)
    if key is None:
        key = _structure_key(mech, inputs)
        _KEYS.put(mech, inputs, key)
    return key


class _PerMechanism:
    """A memo per live mechanism and choice of inputs: ``id(mech) -> (weak reference, {inputs: value})``.

    It keeps no mechanism alive (the weak reference's callback drops the entry) and is not stored in the
    object (a pickled mechanism must not carry what another loopsolve version computed)."""

    def __init__(self):
        self._by_id: dict = {}

    def __len__(self) -> int:  # the mechanisms it holds values of
        return len(self._by_id)

    def get(self, mech, inputs):
        hit = self._by_id.get(id(mech))
        return hit[1].get(inputs) if hit is not None and hit[0]() is mech else None

    def put(self, mech, inputs, value) -> bool:
        """Remember ``value``; False when ``mech`` cannot be weakly referenced (nothing remembered)."""
        by_id = self._by_id
        try:
            ref = weakref.ref(mech, lambda _r, i=id(mech): by_id.pop(i, None))
        except TypeError:
            return False
        with _LOCK:
            hit = by_id.get(id(mech))
            if hit is None or hit[0]() is not mech:
                hit = by_id[id(mech)] = (ref, {})
            hit[1][inputs] = value
        return True


#: structure keys of live mechanisms (hashing the declaration is most of a cached ``compile()``)
_KEYS = _PerMechanism()


def _structure_key(mech: Mechanism, inputs: tuple) -> str:
    parts = (
        FORMAT,
        __version__,
        _sympy_version(),
        mech.units,
        tuple((v.name, v.kind.name) for v in mech.variables),
        tuple((p.name, p.kind.name) for p in mech.parameters),
        mech.vectors,
        tuple((lp.name, lp.terms) for lp in mech.loops),
        tuple((pt.name, pt.terms, pt.factors) for pt in mech.points),
        tuple(inputs),
    )
    if mech.pairs is not None and mech.pairs.n_rows:  # their equations are in the code (friction is not)
        parts += (mech.pairs.rows,)
    return hashlib.sha256(repr(parts).encode()).hexdigest()[:24]


# ----------------------------------------------------------------------------- code generation


def _function_source(name: str, args: Sequence[str], unpack: dict[str, Sequence[str]], exprs, printer,
                     vectorized: bool) -> str:
    import sympy as sp

    exprs = list(exprs)
    # structural zeros (most of a large Jacobian) stay out of cse: its cost grows with the count
    live = [k for k, e in enumerate(exprs) if not (isinstance(e, sp.Expr) and e.is_Number and e == 0)]
    repl, live_reduced = sp.cse([exprs[k] for k in live], symbols=sp.numbered_symbols("c"), optimizations="basic")
    reduced = [sp.Integer(0)] * len(exprs)
    for k, e in zip(live, live_reduced):
        reduced[k] = e
    used = set()
    for e in [r for _, r in repl] + reduced:
        used |= {str(s) for s in sp.sympify(e).free_symbols}
    lines = [f"def {name}({', '.join(args)}):"]
    for arg in args:
        names = unpack.get(arg, ())
        if names and any(n in used for n in names):
            lines.append(f"    {', '.join(names)}{',' if len(names) == 1 else ''} = {arg}")
    for sym, e in repl:
        lines.append(f"    {sym} = {printer.doprint(e)}")
    body = ", ".join(printer.doprint(e) for e in reduced)
    if vectorized:
        lines.append(f"    return _stack([{body}])")
    else:
        lines.append(f"    return [{body}]")
    return "\n".join(lines)


def generate_source(kin) -> tuple[str, dict]:
    """Python source of the compiled module for a :class:`~loopsolve.symbolic.loop_equations.Kinematics`."""
    import sympy as sp
    from sympy.printing.numpy import NumPyPrinter
    from sympy.printing.pycode import PythonCodePrinter

    from ..model.topology import solve_order

    nv, npar = len(kin.variables), len(kin.params)
    zs = [f"z_{i}" for i in range(nv)]
    vs = [f"v_{i}" for i in range(nv)]
    acs = [f"a_{i}" for i in range(nv)]
    js = [f"j_{i}" for i in range(nv)]
    ps = [f"p_{i}" for i in range(npar)]
    sub = {}
    for group, names in ((kin.z, zs), (kin.z1, vs), (kin.z2, acs), (kin.z3, js), (kin.params, ps)):
        for s, n in zip(group, names):
            sub[s] = sp.Symbol(n, real=True)
    unpack = {"z": zs, "z1": vs, "z2": acs, "z3": js, "p": ps}

    def x(e):
        return sp.sympify(e).xreplace(sub)

    phi = [x(e) for e in kin.phi]
    jac = [x(e) for e in kin.jac]
    b = [[x(e) for e in m] for m in kin.rhs]
    pts = [[], [], [], []]
    for name in kin.points:
        for order in range(4):
            m = kin.points[name][order]
            pts[order].extend([x(m[0]), x(m[1])])
    vecs = [[], [], []]
    sliding = []
    for name, (length, angle) in kin.vectors.items():
        if angle is None:
            xy = kin.vector_xy[name]
            angle = sp.atan2(xy[1], xy[0])
        d_len, d_ang = kin.time_derivative(length), kin.time_derivative(angle)
        dd_len, dd_ang = kin.time_derivative(d_len), kin.time_derivative(d_ang)
        vecs[0].extend([x(length), x(angle)])
        vecs[1].extend([x(d_len), x(d_ang)])
        vecs[2].extend([x(dd_len), x(dd_ang)])
        if length.free_symbols & set(kin.z) and angle.free_symbols & set(kin.z):
            sliding.append(name)

    jac_nz = tuple(k for k, e in enumerate(jac) if e != 0)
    specs = [
        ("phi", ("z", "p"), phi),
        ("jac", ("z", "p"), jac),
        ("jacnz", ("z", "p"), [jac[k] for k in jac_nz]),
        ("rhs1", ("z", "z1", "p"), b[0]),
        ("rhs2", ("z", "z1", "z2", "p"), b[1]),
        ("rhs3", ("z", "z1", "z2", "z3", "p"), b[2]),
        ("points0", ("z", "p"), pts[0]),
        ("points1", ("z", "z1", "p"), pts[1]),
        ("points2", ("z", "z1", "z2", "p"), pts[2]),
        ("points3", ("z", "z1", "z2", "z3", "p"), pts[3]),
        ("vectors0", ("z", "p"), vecs[0]),
        ("vectors1", ("z", "z1", "p"), vecs[1]),
        ("vectors2", ("z", "z1", "z2", "p"), vecs[2]),
    ]
    m, n = kin.jac.shape
    incidence = [[kin.jac[i, j] != 0 for j in range(n)] for i in range(m)]
    blocks = solve_order(incidence, unknown_names=kin.unknowns,
                         equation_names=list(kin.equation_names)
                         or [f"{ln}.{c}" for ln in kin.loop_names for c in "xy"])
    meta = {
        "VARIABLES": tuple(kin.variables),
        "KINDS": tuple(k.name for k in kin.kinds),
        "INPUTS": tuple(kin.inputs),
        "UNKNOWNS": tuple(kin.unknowns),
        "PARAMS": tuple(kin.param_names),
        "LOOPS": tuple(kin.loop_names),
        "POINTS": tuple(kin.points),
        "VECTORS": tuple(kin.vectors),
        "SLIDING": tuple(sliding),
        "BLOCKS": tuple((b.eqs, b.unknowns) for b in blocks),
        "N_EQ": m,
        "JAC_NZ": jac_nz,
    }
    out = [
        f"# Generated by loopsolve {__version__} for {kin.name!r}: compiled kinematics. Do not edit.",
        "import math",
        "import numpy",
        "from loopsolve.symbolic.compiled import _stack",
        "",
    ]
    for k_, v in meta.items():
        out.append(f"{k_} = {v!r}")
    out.append("")
    scalar, vector = PythonCodePrinter({"fully_qualified_modules": True}), NumPyPrinter()
    for name, args, exprs in specs:
        out.append(_function_source(name, args, unpack, exprs, scalar, vectorized=False))
        out.append("")
        if name == "jacnz":  # scalar only: the structural non-zeros of jac, at the flat indices JAC_NZ
            continue
        out.append(_function_source(name + "_v", args, unpack, exprs, vector, vectorized=True))
        out.append("")
    return "\n".join(out) + "\n", meta


def _stack(values):
    """Broadcast a list of scalars/arrays to one ``(k, N...)`` float array.

    Every generated vectorized function returns through this, thousands of times per synthesis on
    arrays of a few columns, so it fills one preallocated array (a third of the time of
    ``np.stack(np.broadcast_arrays(...))`` on the four-bar's Jacobian rows).
    """
    shape = ()
    for v in values:
        if isinstance(v, (float, int)):
            continue
        s = v.shape if isinstance(v, np.ndarray) else np.shape(v)
        if s != shape and s != ():
            shape = s if shape == () else np.broadcast_shapes(shape, s)
    out = np.empty((len(values),) + shape)
    for i, v in enumerate(values):
        out[i] = v
    return out


MAX_ENTRY_SIZE = 64 << 20  # a generated module of a 300-loop model is a few MB
_HEADER = "# loopsolve-cache key={key} sha256={digest}\n"


def _module_from_source(source: str, key: str, origin: str) -> ModuleType:
    """Execute generated source in a fresh module (never user text: see :func:`generate_source`)."""
    module = ModuleType(f"loopsolve_compiled_{key}")
    module.__file__ = origin
    code = compile(source, origin, "exec")
    exec(code, module.__dict__)
    module._SOURCE = source  # the text, for the numba engine (loopsolve.kinematics.numba_engine.jit)
    return module


def _load_source(source: str, key: str, path: Path | None = None) -> ModuleType:
    """The module of generated ``source`` (compiled in memory)."""
    return _module_from_source(source, key, f"<loopsolve generated {key}>")


def _entry_bytes(source: str, key: str) -> bytes:
    body = source.encode("utf-8")
    return _HEADER.format(key=key, digest=hashlib.sha256(body).hexdigest()).encode("ascii") + body


class Untrusted(Exception):
    """A cache directory or entry that must not be executed (the message says why)."""


def check_owner_mode(st: os.stat_result, what: str) -> None:
    uid = os.getuid() if hasattr(os, "getuid") else None
    if uid is not None and st.st_uid != uid:
        raise Untrusted(f"{what} belongs to another user (uid {st.st_uid})")
    if st.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
        raise Untrusted(f"{what} is writable by group or others (mode {stat.S_IMODE(st.st_mode):o})")


def check_dir(directory: Path) -> None:
    """The cache directory must be a directory of ours that nobody else can write to."""
    st = os.stat(directory)
    if not stat.S_ISDIR(st.st_mode):
        raise Untrusted(f"{directory} is not a directory")
    try:
        check_owner_mode(st, f"the cache directory {directory}")
    except Untrusted as exc:
        if hasattr(os, "getuid") and st.st_uid == os.getuid():
            try:  # our own directory, made by an older version under a lax umask: make it private
                os.chmod(directory, 0o700)  # for the next run; this run trusts none of its entries
                raise Untrusted(f"{exc} (now made private to you)") from None
            except OSError:
                pass
        raise


def read_entry(path: Path, key: str) -> str | None:
    """The source stored at ``path`` if it is a trustworthy entry for ``key``; ``None`` if absent.

    Raises :class:`Untrusted` for a symlink, FIFO, device, foreign or group/other-writable
    file, an oversized file or one whose content does not match its header (key and hash).
    """
    flags = os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0)
    try:
        lst = os.lstat(path)
    except FileNotFoundError:
        return None
    if stat.S_ISLNK(lst.st_mode):
        raise Untrusted(f"the cache entry {path} is a symlink")
    if not stat.S_ISREG(lst.st_mode):
        raise Untrusted(f"the cache entry {path} is not a regular file")
    try:
        fd = os.open(path, flags)
    except FileNotFoundError:
        return None
    except OSError as exc:
        if hasattr(os, "getuid") and lst.st_uid == os.getuid() and not lst.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
            raise Stale() from None  # our own entry, unreadable (mode 000, an I/O error): a miss, rewritten
        raise Untrusted(f"the cache entry {path} cannot be opened ({exc.strerror})") from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise Untrusted(f"the cache entry {path} is not a regular file")
        check_owner_mode(st, f"the cache entry {path}")
        if st.st_size > MAX_ENTRY_SIZE:
            raise Untrusted(f"the cache entry {path} is too large ({st.st_size} bytes)")
        data = read_capped(fd, MAX_ENTRY_SIZE)
        if data is None:
            raise Untrusted(f"the cache entry {path} is too large")
    except OSError as exc:  # our own regular file that cannot be read to its end (EIO, EISDIR...): a miss
        raise Stale() from exc
    finally:
        os.close(fd)
    head, sep, body = data.partition(b"\n")
    expected_head = _HEADER.format(key=key, digest=hashlib.sha256(body).hexdigest()).encode("ascii")
    if not sep or head + sep != expected_head:
        raise Stale()
    return body.decode("utf-8")


class Stale(Exception):
    """An entry of ours that is truncated, of an older layout or corrupt: regenerate it silently."""


def write_entry(path: Path, source: str, key: str) -> bool:
    """Write the entry atomically (temporary file in the directory, then rename); no debris on failure."""
    data = _entry_bytes(source, key)
    try:
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".m_{key}.", suffix=".tmp")
    except OSError:
        return False
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
        return True
    except OSError:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        return False


def ensure_dir(directory: Path) -> None:
    """Create the cache directory private to the user (0700 whatever the umask)."""
    if not directory.exists():
        directory.parent.mkdir(parents=True, exist_ok=True)
        try:
            os.mkdir(directory, 0o700)
        except FileExistsError:
            return
        os.chmod(directory, 0o700)


def warn_untrusted(reason: str) -> None:
    import warnings

    from ..errors import LoopsolveWarning

    warnings.warn(f"not using the compile cache: {reason}; compiled in memory instead", LoopsolveWarning,
                  stacklevel=4)


_FUNCTIONS = ("phi", "jac", "rhs1", "rhs2", "rhs3", "points0", "points1", "points2", "points3",
              "vectors0", "vectors1", "vectors2")


def _fits(module: ModuleType, mech: Mechanism, inputs: tuple[str, ...]) -> bool:
    """Whether a cached module has the full generated layout for this declaration."""
    try:
        return (
            tuple(module.VARIABLES) == tuple(v.name for v in mech.variables)
            and tuple(module.INPUTS) == tuple(inputs)
            and tuple(module.PARAMS) == tuple(p.name for p in mech.parameters)
            and tuple(module.POINTS) == tuple(p.name for p in mech.points)
            and tuple(module.VECTORS) == tuple(v.name for v in mech.vectors)
            and all(hasattr(module, a) for a in ("KINDS", "UNKNOWNS", "SLIDING", "BLOCKS", "N_EQ", "JAC_NZ"))
            and callable(getattr(module, "jacnz", None))
            and all(callable(getattr(module, f, None)) and callable(getattr(module, f + "_v", None))
                    for f in _FUNCTIONS)
        )
    except Exception:  # attributes of the wrong type in a foreign file
        return False


def _cached_module(mech: Mechanism, inputs: tuple[str, ...], cache: bool) -> ModuleType:
    """The generated module for ``mech``: from the in-process memo, the disk cache, or sympy.

    A disk entry is executed only if the directory and the file belong to the user, neither is
    writable by group or others, the entry is a regular file (not a symlink, FIFO or device) of
    bounded size, and its content matches the key and hash in its first line. Otherwise the
    module is compiled in memory (one :class:`~loopsolve.errors.LoopsolveWarning` says why when
    something foreign sits in the cache; a truncated or stale entry of ours is rewritten silently).
    """
    key = structure_key(mech, inputs)
    with _LOCK:
        if key in _MEMO:
            return _MEMO[key]
    directory = cache_dir() if cache else None
    path = directory / f"m_{key}.py" if directory else None
    module, writable = None, path is not None
    if path is not None:
        try:
            if directory.exists():
                check_dir(directory)
            source = read_entry(path, key)
            if source is not None:
                module = _module_from_source(source, key, str(path))
                if not _fits(module, mech, inputs):
                    module = None
        except Stale:
            module = None
        except Untrusted as exc:
            warn_untrusted(str(exc))
            module, writable = None, False
        except (Exception, SystemExit) as exc:  # an entry that fails to run: ours but broken
            module = None
            if isinstance(exc, OSError):
                writable = False
    if module is None:
        from .loop_equations import derive

        kin = derive(mech, input=inputs)
        source, _ = generate_source(kin)
        if writable:
            try:
                ensure_dir(directory)
                check_dir(directory)
                write_entry(path, source, key)
            except (OSError, Untrusted):
                pass
        module = _load_source(source, key)
    with _LOCK:
        _MEMO[key] = module
    return module


@dataclass(frozen=True, eq=False)
class CompiledKinematics:
    """Numeric kinematics of one mechanism for one choice of inputs.

    Built by :func:`compile_mechanism`; immutable. Index arrays map names to positions in
    ``z`` (all variables), and the ``*_v`` methods take ``(k, N)`` arrays for N points at once.

    Users receive compiled kinematics from :func:`loopsolve.compile_mechanism`
    (``mech.compile()``); they need not construct them.

    Parameters
    ----------
    mechanism, module, variables, kinds, inputs, unknowns, input_idx, unknown_idx
        The mechanism, its generated code and its variables (see Attributes).
    blocks, points, vectors, sliding, p, scale
        The solve order, the outputs, the parameter values and the length scale.

    Attributes
    ----------
    mechanism : Mechanism
        The declaration it was compiled from.
    module : module
        The generated numpy code (from the checked disk cache).
    variables : tuple of str
        Every joint variable, in declaration order: the columns of ``z``.
    kinds : tuple of Kind
        Angle or length, per variable.
    inputs, unknowns : tuple of str
        The driving inputs and the unknowns (the order of Φ_q's columns).
    input_idx, unknown_idx : numpy.ndarray
        Their positions in ``z``.
    blocks : tuple of Block
        The solve order: blocks of unknowns solved one after the other (one sign of a mode
        signature each).
    points, vectors : tuple of str
        The output points and the vectors, by name.
    sliding : tuple of str
        The variables that are sliding lengths.
    p : numpy.ndarray
        The parameter values (internal units).
    scale : float
        The model's characteristic length (model length unit): tolerances and step sizes are
        relative to it.

    Examples
    --------
    >>> import loopsolve as ls
    >>> mech = ls.load(ls.models_dir() / "thesis_crank_rocker.toml")
    >>> ck = ls.compile_mechanism(mech)
    >>> ck.inputs, ck.unknowns, ck.points, ck.scale
    (('theta2',), ('theta3', 'theta4'), ('B', 'C'), 70.0)
    >>> ck.jac(ls.solve(mech, 90).z).shape  # Φ_q: two loop rows x two unknowns
    (2, 2)
    """

    mechanism: Mechanism
    module: ModuleType = field(repr=False)
    variables: tuple[str, ...]
    kinds: tuple[Kind, ...]
    inputs: tuple[str, ...]
    unknowns: tuple[str, ...]
    input_idx: np.ndarray = field(repr=False)
    unknown_idx: np.ndarray = field(repr=False)
    blocks: tuple[Block, ...]
    points: tuple[str, ...]
    vectors: tuple[str, ...]
    sliding: tuple[str, ...]
    p: np.ndarray = field(repr=False)
    scale: float

    # scalar evaluations ---------------------------------------------------------------
    # The generated scalar code uses `math`, which raises where numpy gives NaN (sqrt of a
    # negative, 0.0**-1, overflow of **): such points are returned as NaN, so callers see a
    # non-finite residual (Newton backtracks) instead of a bare ValueError/ZeroDivisionError.
    def _call(self, fname: str, size: int, *args) -> np.ndarray:
        try:
            return np.array(getattr(self.module, fname)(*args, self.p), dtype=float)
        except (ArithmeticError, ValueError):
            return np.full(size, np.nan)

    def phi(self, z) -> np.ndarray:
        return self._call("phi", self.module.N_EQ, z)

    def jac(self, z) -> np.ndarray:
        """Φ_q at ``z``: only its structural non-zeros are evaluated (a large model's is sparse)."""
        n = len(self.unknowns)
        nz = self.module.JAC_NZ
        out = np.zeros(n * n)
        try:
            out[list(nz)] = np.array(self.module.jacnz(z, self.p), dtype=float)
        except (ArithmeticError, ValueError):
            out[:] = np.nan
        return out.reshape(n, n)

    def rhs(self, order: int, *zs) -> np.ndarray:
        return self._call(f"rhs{order}", self.module.N_EQ, *zs)

    def point_values(self, order: int, *zs) -> np.ndarray:
        """``(P, 2)`` array of point positions (order 0) or derivatives."""
        return self._call(f"points{order}", 2 * len(self.points), *zs).reshape(-1, 2)

    def vector_values(self, order: int, *zs) -> np.ndarray:
        """``(V, 2)`` array of (length, angle) of every vector, or their derivatives."""
        return self._call(f"vectors{order}", 2 * len(self.vectors), *zs).reshape(-1, 2)

    # vectorized evaluations: z has shape (nvar, N) ----------------------------------------
    def phi_v(self, z) -> np.ndarray:
        return self.module.phi_v(z, self.p)

    def jac_v(self, z) -> np.ndarray:
        """``(N, m, n)`` stack of Jacobians."""
        j = self.module.jac_v(z, self.p)
        n = len(self.unknowns)
        return np.moveaxis(j.reshape(n, n, -1), -1, 0)

    def rhs_v(self, order: int, *zs) -> np.ndarray:
        return getattr(self.module, f"rhs{order}_v")(*zs, self.p)

    def point_values_v(self, order: int, *zs) -> np.ndarray:
        """``(P, 2, N)`` array."""
        v = getattr(self.module, f"points{order}_v")(*zs, self.p)
        return v.reshape(-1, 2, v.shape[-1]) if v.ndim > 1 else v.reshape(-1, 2)

    def vector_values_v(self, order: int, *zs) -> np.ndarray:
        v = getattr(self.module, f"vectors{order}_v")(*zs, self.p)
        return v.reshape(-1, 2, v.shape[-1]) if v.ndim > 1 else v.reshape(-1, 2)

    @functools.cached_property
    def periodic(self) -> np.ndarray:
        """For each variable (declaration order): an angle on which Φ depends 2π-periodically.

        The angles of the loops are (they enter through sines and cosines); an angle tied by a gear
        pair, a rolling contact or a constraint outside a sine is not: turning it by a whole turn
        breaks the constraint, so it is never reduced modulo a turn (Φ at two seeded poses compared
        with the angle turned by 2π).
        """
        out = np.array([k is Kind.ANGLE for k in self.kinds])
        if not self.module.N_EQ or not out.any():
            return out
        rng = np.random.default_rng(5)
        zs = [np.where(out, rng.uniform(-np.pi, np.pi, len(out)), rng.uniform(0.5, 1.5, len(out)) * self.scale)
              for _ in range(2)]
        for i in np.flatnonzero(out):
            for z in zs:
                f0 = self.phi(z)
                z2 = z.copy()
                z2[i] += 2 * np.pi
                f1 = self.phi(z2)
                if not (np.all(np.isfinite(f0)) and np.all(np.isfinite(f1))):
                    continue
                if np.max(np.abs(f1 - f0)) > 1e-9 * (1.0 + self.scale + float(np.max(np.abs(f0)))):
                    out[i] = False
                    break
        return out

    def index(self, name: str) -> int:
        """Position of variable ``name`` in ``z``."""
        try:
            return self.variables.index(name)
        except ValueError:
            from ..errors import ModelError

            raise ModelError(f"unknown variable {name!r}; the variables are {', '.join(self.variables)}") from None

    def signature(self, z) -> str:
        """Assembly-mode signature: the signs of the determinants of the diagonal blocks of Φ_q."""
        j = self.jac(z)
        out = []
        for b in self.blocks:
            d = np.linalg.det(j[np.ix_(b.eqs, b.unknowns)])
            out.append("+" if d > 0 else "-" if d < 0 else "0")
        return "".join(out)


def compile_mechanism(mech: Mechanism, input: str | Sequence[str] | None = None, *,
                      cache: bool = True) -> CompiledKinematics:
    """Compile ``mech`` for the given input(s) (derive with sympy only on a cache miss).

    Examples
    --------
    >>> ck = ls.fourbar(r1=60, r2=25, r3=70, r4=45).compile()
    >>> ck.unknowns, len(ck.blocks)
    (('theta3', 'theta4'), 1)
    """
    inputs = mech.resolve_inputs(input)
    if mech.pairs is not None and mech.pairs.cams:
        from ..model.cams import check_cams

        check_cams(mech)  # an undercut profile is a wrong declaration (loopsolve cam reports it in full)
    module = _cached_module(mech, inputs, cache)
    fields = _COMPILED.get(mech, inputs)
    if fields is None or fields["module"] is not module:
        ck = _compiled_kinematics(mech, module)
        fields = dict(ck.__dict__)
        del fields["mechanism"]  # not kept: the memo must not keep the mechanism alive
        _COMPILED.put(mech, inputs, fields)
        return ck
    # a new object each call, with its own parameter array (a caller may change ``p`` in place)
    ck = object.__new__(CompiledKinematics)
    ck.__dict__.update(fields)
    object.__setattr__(ck, "mechanism", mech)
    object.__setattr__(ck, "p", fields["p"].copy())
    return ck


#: the fields of the compiled kinematics of live mechanisms but the mechanism itself; a ``mech.sweep(...)``
#: compiles every call, and a cached compile is then a lookup and a copy of ``p``
_COMPILED = _PerMechanism()


def _compiled_kinematics(mech: Mechanism, module: ModuleType) -> CompiledKinematics:
    variables = tuple(module.VARIABLES)
    kinds = tuple(Kind[k] for k in module.KINDS)
    p = np.array([pp.value for pp in mech.parameters], dtype=float)
    lengths = [abs(pp.value) for pp in mech.parameters if pp.kind is Kind.LENGTH]
    lengths += [abs(v.guess) for v in mech.variables if v.kind is Kind.LENGTH and v.guess is not None]
    scale = max(lengths) if lengths and max(lengths) > 0 else 1.0
    return CompiledKinematics(
        mechanism=mech,
        module=module,
        variables=variables,
        kinds=kinds,
        inputs=tuple(module.INPUTS),
        unknowns=tuple(module.UNKNOWNS),
        input_idx=np.array([variables.index(n) for n in module.INPUTS], dtype=int),
        unknown_idx=np.array([variables.index(n) for n in module.UNKNOWNS], dtype=int),
        blocks=tuple(Block(tuple(e), tuple(u)) for e, u in module.BLOCKS),
        points=tuple(module.POINTS),
        vectors=tuple(module.VECTORS),
        sliding=tuple(module.SLIDING),
        p=p,
        scale=scale,
    )
