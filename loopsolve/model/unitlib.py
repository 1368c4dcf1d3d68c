"""The units library behind every quantity: pint, built lazily, its answers remembered on disk.

:mod:`loopsolve.model.units` asks one question of this module: *what is the unit ``text``?* — its
dimension (powers of ``mass``, ``length``, ``time``, ``angle``, ...) and its exact size in the
coherent SI units (kg, m, s, rad). pint answers it from its definitions by dimensional analysis;
no spelling of a unit is listed here or anywhere else in loopsolve.

* **One registry, built lazily.** Importing pint and building a registry takes ~0.7 s, so it is
  done on the first question this process cannot answer from the memo, never at import.
* **The radian is a dimension.** pint's default definitions make the radian dimensionless, so
  ``Hz`` would be an angular rate (1 Hz = 1 rad/s, not 2π) and ``N*m`` a torsional stiffness. Here
  ``radian = [angle]``: ``rpm``, ``deg/s`` and ``rad/s`` are angular rates, ``Hz`` is not.
* **Exact factors.** The registry computes with :class:`fractions.Fraction` (pint's
  ``non_int_type``), so ``slug*ft^2``, ``in*lbf`` and ``ft`` convert exactly (1 ft = 0.3048 m, not
  0.30479999999999996); a factor involving π (``deg``, ``rpm``) is kept as a rational multiple of
  π and evaluated as ``math.pi * n / d`` (the ``math.pi / 180`` every numeric code uses).
* **Definitions through pint's public API.** pint's own definitions file is loaded by pint,
  unedited; then the radian is redefined as a base unit of ``[angle]`` and the engineering
  spellings of :data:`ENGINEERING_UNITS` and :data:`SYMBOL_ALIASES` are defined with
  ``define``/``load_definitions``: ``rev`` (pint has ``revolution`` and ``turn``), ``°``, ``lbm``
  and the run-together ``Nm``, ``Nmm``, ``kNm``, ``Ns``, ``Nms``. A spelling pint already defines
  with the same size is left to pint; one pint defines otherwise is replaced — silently where
  :data:`REPLACED` says why (pint 0.25's ``Nm`` is the textile count "number metric"; to an
  engineer it is the newton metre), else with one :class:`~loopsolve.errors.LoopsolveWarning`
  naming it. ``s2``/``s3`` after a unit name read as ``s^2``/``s^3``.
* **Bounded work.** A unit is at most 60 characters; every number in it is an exponent of at
  most 4, a power of a power (``rad**4**4``) is refused, and the exponents a name is raised to
  through nested parentheses multiply to at most :data:`MAX_POWER`. A unit whose size in SI is
  0, infinite or subnormal in floating point (``ym**16``) is not a unit either.
* **The memo.** Each answer (dimension, exact factor) is stored in a small JSON file next to the
  compiled models (``units-<hash>.json`` in :func:`loopsolve.symbolic.compiled.cache_dir`'s directory,
  keyed by pint's definitions file, ours and this module's source; written atomically with a
  first line holding the key and the SHA-256 of the rest, read only when it is a regular file of
  the user's that nobody else can write and its content matches that line). An unreadable memo
  — truncated, corrupt, of another layout, nested beyond reason — is treated as absent and
  rewritten. A run whose units are all in the memo never imports pint: that is what keeps a
  cached command line within 150 ms of ``import numpy``. The memo is written once the cache
  directory exists (the compiler makes it).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import re
import stat
import sys
import tempfile
import threading
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path

__all__ = ["UnitInfo", "lookup", "refusal", "registry", "ENGINEERING_UNITS", "SYMBOL_ALIASES", "REPLACED", "MAX_POWER"]

#: spellings designers write, each with what it is in pint's terms (defined with ``define``)
ENGINEERING_UNITS: tuple[tuple[str, str], ...] = (
    ("rev", "turn"),
    ("lbm", "pound"),
    ("Nm", "newton * meter"),
    ("Nmm", "newton * millimeter"),
    ("kNm", "kilonewton * meter"),
    ("Ns", "newton * second"),
    ("Nms", "newton * meter * second"),
)
#: spellings that are not identifiers, as ``(pint's unit, alias)`` (pint's ``@alias`` directive)
SYMBOL_ALIASES: tuple[tuple[str, str], ...] = (("degree", "°"),)
#: spellings pint defines with another meaning that loopsolve replaces on purpose, and why
REPLACED: dict[str, str] = {"Nm": "pint's 'Nm' is the textile count 'number metric' (km/kg); an engineer's Nm is N·m"}
#: largest power a unit name may be raised to (through nested parentheses: ``(mm**4)**4`` is 16)
MAX_POWER = 16

_FORMAT = 2  # layout of the memo file
_MAX_TEXT = 60  # a unit longer than this is not a unit
_MAX_MEMO = 1 << 20
_MAX_ENTRIES = 512  # the memo stops growing here (a model uses a dozen units)
_EXP_RE = re.compile(r"(?<=[A-Za-zµμ°])([23])(?![0-9A-Za-z_])")  # s2 -> s**2
_NUM_RE = re.compile(r"[0-9]+(?:\.[0-9]*)?")
_ALLOWED_RE = re.compile(r"[A-Za-z0-9_µμ°·⋅ */^()²³.\-]+\Z")
_TOKEN_RE = re.compile(r"\s*(\*\*|\^|[*/()]|-?[0-9]+(?:\.[0-9]*)?|[^\s*/^()0-9-][^\s*/^()]*|-)")


@dataclass(frozen=True, slots=True)
class UnitInfo:
    """What a unit is: ``dims`` (sorted ``(dimension, power)`` pairs, e.g. ``(("length", 2),
    ("mass", 1))``) and its size in coherent SI units, exactly ``ratio * pi**pi_power``."""

    dims: tuple[tuple[str, Fraction], ...]
    ratio: Fraction
    pi_power: int = 0

    @property
    def si_factor(self) -> float:
        """Size of the unit in coherent SI (kg, m, s, rad) as a float."""
        return _to_float(self.ratio, self.pi_power)

    def factor_to(self, other: "UnitInfo") -> float:
        """``f`` such that ``x`` in this unit is ``x * f`` in ``other`` (same dimension)."""
        return _to_float(self.ratio / other.ratio, self.pi_power - other.pi_power)

    def dimension_text(self) -> str:
        """``[length]^2·[mass]`` style, for messages."""
        if not self.dims:
            return "dimensionless"
        return "·".join(f"[{d}]" + ("" if p == 1 else f"^{p}") for d, p in self.dims)


def _to_float(ratio: Fraction, pi_power: int) -> float:
    if pi_power == 0:
        return float(ratio)
    n, d = ratio.numerator, ratio.denominator
    small = max(abs(n), d) < 2**53
    if pi_power > 0:
        return (n * math.pi**pi_power) / d if small else float(ratio) * math.pi**pi_power
    return n / math.pi**-pi_power / d if small else float(ratio) / math.pi**-pi_power


# --------------------------------------------------------------------------- registry

_LOCK = threading.RLock()
_REGISTRY = None
_PI: Fraction | None = None
_SI = {"mass": "kilogram", "length": "meter", "time": "second", "angle": "radian", "current": "ampere",
       "temperature": "kelvin", "substance": "mole", "luminosity": "candela"}


def registry():
    """The process's pint ``UnitRegistry`` (built on first use: ~0.3 s).

    Raises
    ------
    MissingDependencyError
        pint is not installed, or its definitions cannot be read.
    """
    global _REGISTRY, _PI
    with _LOCK:
        if _REGISTRY is None:
            reg = _build_registry()
            _PI = Fraction(reg.Quantity(Fraction(1), "turn").to("radian").magnitude) / 2
            _REGISTRY = reg
        return _REGISTRY


def _build_registry():
    """pint's definitions as pint reads them, then the radian as a dimension and the engineering spellings.

    Only pint's public API: ``UnitRegistry(None)`` (no definitions), ``load_definitions`` of the
    definitions file pint ships, ``define``. Everything is defined before any unit is asked about,
    so every unit's dimension is computed with the radian as ``[angle]``.
    """
    from ..errors import MissingDependencyError, warn

    try:
        import pint
    except ImportError as exc:  # a dependency of the package: only a broken install lacks it
        raise MissingDependencyError(f"units need pint, which cannot be imported ({exc}); "
                                     "reinstall loopsolve (pip install loopsolve)") from None
    version = getattr(pint, "__version__", "?")
    reg = _pint_registry(pint, version)
    reg.define("radian = [angle] = rad")
    # nothing is asked of this registry by unit text before every definition is in: pint caches what it
    # parses and the sizes it computes ("Nm" -> number_meter), so pint's own names are found with
    # parse_unit_name only, and a spelling pint defines otherwise is compared in a scratch registry
    theirs = {name: _exact_unit(reg, name) for name, _ in ENGINEERING_UNITS}
    displaced = {theirs[name] for name in REPLACED if theirs.get(name)}  # and their plurals ('Nms')
    scratch = None
    for name, meaning in ENGINEERING_UNITS:
        if theirs[name] is not None and name not in REPLACED and theirs[name] not in displaced:
            if scratch is None:
                scratch = _pint_registry(pint, version)
                scratch.define("radian = [angle] = rad")
            if _same_size(scratch, theirs[name], meaning):
                continue  # pint has it already, with the same meaning
            warn(f"pint {version} defines the unit {name!r} as {theirs[name]!r}; loopsolve reads {name!r} as "
                 f"{meaning}")
        reg.define(f"{name} = {meaning}")
    reg.load_definitions([f"@alias {unit} = {alias}" for unit, alias in SYMBOL_ALIASES
                          if _exact_unit(reg, alias) is None])
    return reg


def _pint_registry(pint, version: str):
    """A registry holding pint's own definitions, read by pint, exact (fractions)."""
    from ..errors import MissingDependencyError

    definitions = Path(pint.__file__).parent / "default_en.txt"
    reg = pint.UnitRegistry(None, non_int_type=Fraction, autoconvert_offset_to_baseunit=False,
                            on_redefinition="ignore")
    try:
        reg.load_definitions(definitions)
    except Exception as exc:  # pint raises its own kinds; the message is what matters
        raise MissingDependencyError(f"pint {version}: its unit definitions ({definitions}) cannot be read "
                                     f"({type(exc).__name__}: {exc}); reinstall pint") from None
    return reg


def _exact_unit(reg, name: str) -> str | None:
    """pint's unit that the spelling ``name`` is (itself or a plural of it, not a prefixed one), or ``None``."""
    try:
        candidates = reg.parse_unit_name(name, case_sensitive=True)
    except Exception:  # a spelling pint's parser cannot take is not one of its names
        return None
    return next((unit for prefix, unit, suffix in candidates if not prefix and not suffix), None)


def _same_size(reg, unit: str, meaning: str) -> bool:
    try:
        theirs, ours = reg.Quantity(Fraction(1), unit).to_root_units(), reg.parse_expression(meaning).to_root_units()
        return theirs.units == ours.units and Fraction(theirs.magnitude) == Fraction(ours.magnitude)
    except Exception:  # not convertible (pint raises its own kinds)
        return False


_EXPONENT_RE = re.compile(r"\s*(?:\(\s*([+-]?[0-9]+(?:\.[0-9]*)?(?:\s*/\s*[0-9]+)?)\s*\)|([+-]?[0-9]+(?:\.[0-9]*)?))")
_NAME_RE = re.compile(r"[^\s*/^()²³]+")
_NUMBER_RE = re.compile(r"[0-9.]+")


def _power_bound(s: str) -> Fraction | None:
    """The largest power any name in the unit ``s`` is raised to (``(mm**4)**4``: 16), or ``None``
    for text that is not a product of powers: a power of a power (``rad**4**4``), a power of
    nothing, unbalanced parentheses."""
    stack = [Fraction(0)]  # largest power so far in each open group
    last: Fraction | None = None  # power of the atom just read: a name 1, a number 0, a group its largest
    powered = False  # that atom carries an exponent already

    def flush():
        nonlocal last, powered
        if last is not None:
            stack[-1] = max(stack[-1], last)
        last, powered = None, False

    i, n = 0, len(s)
    while i < n:
        c = s[i]
        if c.isspace():
            i += 1
        elif s.startswith("**", i) or c in "^²³":
            if last is None or powered:
                return None
            if c in "²³":
                e, i = Fraction(2 if c == "²" else 3), i + 1
            else:
                m = _EXPONENT_RE.match(s, i + (2 if c == "*" else 1))
                if m is None:
                    return None
                e, i = abs(Fraction((m.group(1) or m.group(2)).replace(" ", ""))), m.end()
            last, powered = last * e, True
        elif c == "(":
            flush()
            stack.append(Fraction(0))
            i += 1
        elif c == ")":
            flush()
            if len(stack) == 1:
                return None
            last, i = stack.pop(), i + 1
        elif c in "*/":
            flush()
            i += 1
        else:
            flush()
            number = _NUMBER_RE.match(s, i)
            if number is not None:
                last, i = Fraction(0), number.end()
            else:
                last, i = Fraction(1), _NAME_RE.match(s, i).end()
    flush()
    return stack[0] if len(stack) == 1 else None


def _normalize(text: str) -> str | None:
    s = text.strip().replace("·", "*").replace("⋅", "*")
    if not s or len(s) > _MAX_TEXT or not _ALLOWED_RE.match(s) or not (s[0].isalpha() or s[0] in "°µμ("):
        return None
    s = _EXP_RE.sub(r"**\1", s)
    # every number in a unit is a small exponent, and powers do not nest beyond MAX_POWER: 10**9999 or
    # rad**4**4**4 would take pint's exact arithmetic forever
    if any(float(m.group(0)) > 4 for m in _NUM_RE.finditer(s)):
        return None
    bound = _power_bound(s)
    if bound is None or bound > MAX_POWER:
        return None
    return s


def refusal(text: str) -> str | None:
    """Why ``text``, which :func:`lookup` does not take, is refused *as written* (a power tower, a
    size out of floating-point range, ...), or ``None`` when it is simply not a unit pint knows.
    For error messages only: it may ask pint again.

    Examples
    --------
    >>> refusal("rad**4**4/s")
    'a power of a power (write one exponent, at most 16)'
    >>> refusal("furlong/fortnight") is None
    True
    """
    s = text.strip().replace("·", "*").replace("⋅", "*")
    if len(s) > _MAX_TEXT:
        return f"longer than {_MAX_TEXT} characters"
    if not s or not _ALLOWED_RE.match(s):
        return None
    s = _EXP_RE.sub(r"**\1", s)
    if any(float(m.group(0)) > 4 for m in _NUM_RE.finditer(s)):
        return "a number in a unit is an exponent, at most 4"
    bound = _power_bound(s)
    if bound is None:
        return ("a power of a power (write one exponent, at most 16)" if re.search(r"(\*\*|\^)[^*^]*(\*\*|\^)", s)
                else None)
    if bound > MAX_POWER:
        return f"a power of {bound} (at most {MAX_POWER})"
    if _normalize(text) is not None and lookup(text) is None:
        try:
            q = registry().Quantity(Fraction(1), _normalize(text))
            q.to_base_units()
        except Exception:  # not a unit pint knows: nothing more to say
            return None
        return "its size in SI units is 0, infinite or too small for floating point"
    return None


def _ask_pint(text: str) -> UnitInfo | None:
    s = _normalize(text)
    if s is None:
        return None
    reg = registry()
    try:
        q = reg.Quantity(Fraction(1), s)
        dims = dict(q.dimensionality)
        target = "*".join(f"{_SI[d.strip('[]')]}**({Fraction(p)})" for d, p in dims.items())
        mag = q.to(target).magnitude if target else q.to("dimensionless").magnitude
        ratio = Fraction(mag)
    except Exception:  # pint raises many kinds of error for text that is not a unit
        return None
    if ratio <= 0:
        return None
    ordered = tuple(sorted((d.strip("[]"), Fraction(p)) for d, p in dims.items()))
    angle_power = dict(ordered).get("angle", Fraction(0))
    k = int(angle_power) if angle_power.denominator == 1 else 0
    pi_power = 0
    if k:
        r = ratio / _PI**k  # a unit defined from π (deg, rev, rpm): a small rational multiple of π^k
        if max(abs(r.numerator), r.denominator) < 10**15 <= max(abs(ratio.numerator), ratio.denominator):
            ratio, pi_power = r, k
    info = UnitInfo(ordered, ratio, pi_power)
    return info if _normal_size(info) else None


def _normal_size(info: UnitInfo) -> bool:
    """The unit's SI size is a normal float: not 0, not infinite, not subnormal."""
    try:
        size = info.si_factor
    except (OverflowError, ZeroDivisionError):
        return False
    return sys.float_info.min <= size < math.inf


# --------------------------------------------------------------------------- memo

_MEMO: dict[str, UnitInfo | None] = {}
_DISK_LOADED: str | None = None  # the memo path read into _MEMO


def _memo_path() -> Path | None:
    env = os.environ.get("LOOPSOLVE_CACHE_DIR")
    if env is not None:
        if not env:
            return None
        directory = Path(env)
    else:
        base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
        directory = Path(base) / "loopsolve"
    return directory / f"units-{_memo_key()}.json"


_KEY: str | None = None


def _memo_key() -> str:
    """pint's definitions file (its size and time), ours and this module's source: another pint,
    other definitions or another way of reading units start a new memo. Found without importing
    pint (or ``importlib.metadata``, itself ~20 ms)."""
    global _KEY
    if _KEY is None:
        from importlib.util import find_spec

        try:
            spec = find_spec("pint")
            st = os.stat(Path(spec.origin).parent / "default_en.txt")
            stamp = f"{spec.origin}:{st.st_size}:{st.st_mtime_ns}"
        except (AttributeError, TypeError, ValueError, OSError):  # pint missing: pint's import will say so
            stamp = "none"
        try:  # this module's own source: a change in how units are read starts a new memo too
            own = hashlib.sha256(Path(__file__).read_bytes()).hexdigest()
        except OSError:  # pragma: no cover - frozen or zipped installs
            own = "?"
        ours = repr((ENGINEERING_UNITS, SYMBOL_ALIASES, MAX_POWER))
        _KEY = hashlib.sha256(f"{_FORMAT}\n{stamp}\n{own}\n{ours}".encode()).hexdigest()[:16]
    return _KEY


def _private(st: os.stat_result) -> bool:
    uid = os.getuid() if hasattr(os, "getuid") else None
    return (uid is None or st.st_uid == uid) and not st.st_mode & (stat.S_IWGRP | stat.S_IWOTH)


_HEADER = "loopsolve-units key={key} sha256={digest}\n"


def _read_disk(path: Path) -> dict[str, UnitInfo | None]:
    """The memo at ``path`` if it is a private regular file of ours whose content matches its first
    line (key and hash) and has the memo's layout; else ``{}`` (absent: the next write replaces it)."""
    try:
        if not _private(os.stat(path.parent)):
            return {}
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0))
    except OSError:
        return {}
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode) or not _private(st) or st.st_size > _MAX_MEMO:
            return {}
        with os.fdopen(os.dup(fd), "rb") as f:
            data = f.read(_MAX_MEMO + 1)
    except OSError:
        return {}
    finally:
        os.close(fd)
    head, sep, body = data.partition(b"\n")
    if not sep or head + sep != _HEADER.format(key=_memo_key(), digest=hashlib.sha256(body).hexdigest()).encode():
        return {}
    try:
        return _entries(json.loads(body.decode("utf-8")))
    except (ValueError, TypeError, AttributeError, ZeroDivisionError, RecursionError):
        return {}  # not the memo's layout (a hand-edited or planted file): absent


def _entries(raw) -> dict[str, UnitInfo | None]:
    """The memo's entries from its JSON: ``{text: null | [[[dimension, power], ...], ratio, pi_power]}``."""
    if not isinstance(raw, dict):
        raise TypeError("the memo is not an object")
    out: dict[str, UnitInfo | None] = {}
    for text, entry in raw.items():
        if entry is None:
            out[text] = None
            continue
        dims, ratio, pi_power = entry
        if not isinstance(dims, list) or not isinstance(pi_power, int) or not all(
                isinstance(d, list) and len(d) == 2 and d[0] in _SI and isinstance(d[1], str) for d in dims):
            raise TypeError(f"entry {text!r} is not an answer")
        info = UnitInfo(tuple((d, Fraction(p)) for d, p in dims), Fraction(ratio), pi_power)
        if info.ratio <= 0 or not _normal_size(info):
            raise ValueError(f"entry {text!r} has no size")
        out[text] = info
    return out


def _write_disk(path: Path) -> None:
    """Store the memo atomically (temporary file, then rename); on any failure leave nothing behind."""
    data = {t: None if u is None else [[[d, str(p)] for d, p in u.dims], str(u.ratio), u.pi_power]
            for t, u in _MEMO.items()}
    body = json.dumps(data, sort_keys=True).encode("utf-8")
    head = _HEADER.format(key=_memo_key(), digest=hashlib.sha256(body).hexdigest()).encode()
    try:
        if not path.parent.is_dir() or not _private(os.stat(path.parent)):
            return
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".units.", suffix=".tmp")
    except OSError:
        return
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(head + body)
        os.replace(tmp, path)
    except OSError:
        try:
            os.unlink(tmp)
        except OSError:
            pass


def lookup(text: str) -> UnitInfo | None:
    """The dimension and exact SI size of the unit ``text`` (``"in*lbf"``, ``"rpm"``), or ``None``
    when it is not a unit (unknown name, garbage, or more than a unit such as ``"2*pi"``).

    Examples
    --------
    >>> from loopsolve.model.unitlib import lookup
    >>> u = lookup("in*lbf")
    >>> u.dimension_text(), u.si_factor
    ('[length]^2·[mass]·[time]^-2', 0.1129848290276167)
    >>> lookup("rpm").si_factor == math.pi / 30
    True
    >>> lookup("2*pi") is None, lookup("furlongs") is None
    (True, False)
    """
    global _DISK_LOADED
    if not isinstance(text, str):
        return None
    key = text.strip()
    with _LOCK:
        if key in _MEMO:
            return _MEMO[key]
        path = _memo_path()
        if path is not None and _DISK_LOADED != str(path):
            _MEMO.update(_read_disk(path))
            _DISK_LOADED = str(path)
            if key in _MEMO:
                return _MEMO[key]
        info = _ask_pint(key)
        _MEMO[key] = info
        if path is not None and len(_MEMO) <= _MAX_ENTRIES:  # a fuzzer's garbage does not grow it forever
            _write_disk(path)
        return info
