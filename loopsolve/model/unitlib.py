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
* **Definitions pint lacks** are added in :data:`EXTRA_DEFINITIONS`: ``rev`` (pint has
  ``revolution`` and ``turn``), ``°``, ``lbm`` and the run-together engineering spellings ``Nm``,
  ``Nmm``, ``kNm``, ``Ns``, ``Nms`` (pint's ``Nm``, the textile count "number metric", is dropped:
  to an engineer it is the newton metre). ``s2``/``s3`` after a unit name read as ``s^2``/``s^3``.
* **The memo.** Each answer (dimension, exact factor) is stored in a small JSON file next to the
  compiled models (``units-<hash>.json`` in :func:`loopsolve.symbolic.compiled.cache_dir`'s directory,
  keyed by pint's definitions file, ours and this module's source; written atomically, read only
  when it is a regular file of the user's that nobody else can write). A run whose units are all
  in the memo never imports pint: that is what keeps a cached command line within 150 ms of
  ``import numpy``. The memo is written once the cache directory exists (the compiler makes it).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import re
import stat
import tempfile
import threading
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path

__all__ = ["UnitInfo", "lookup", "registry", "EXTRA_DEFINITIONS"]

#: units designers write that pint's default definitions lack (pint definition syntax)
EXTRA_DEFINITIONS = """
@alias turn = rev
@alias degree = °
lbm = pound
Nm = newton * meter
Nmm = newton * millimeter
kNm = kilonewton * meter
Ns = newton * second
Nms = newton * meter * second
"""

_FORMAT = 1  # layout of the memo file
_MAX_TEXT = 60  # a unit longer than this is not a unit
_MAX_MEMO = 1 << 20
_MAX_ENTRIES = 512  # the memo stops growing here (a model uses a dozen units)
_EXP_RE = re.compile(r"(?<=[A-Za-zµμ°])([23])(?![0-9A-Za-z_])")  # s2 -> s**2
_NUM_RE = re.compile(r"[0-9]+(?:\.[0-9]*)?")
_ALLOWED_RE = re.compile(r"[A-Za-z0-9_µμ°·⋅ */^()²³.\-]+\Z")


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
    """The process's pint ``UnitRegistry`` (built on first use: ~0.7 s)."""
    global _REGISTRY, _PI
    with _LOCK:
        if _REGISTRY is None:
            import pint

            base = Path(pint.__file__).parent
            text = (base / "default_en.txt").read_text(encoding="utf-8")
            constants = (base / "constants_en.txt").read_text(encoding="utf-8")
            for old, new in (("\nradian = [] = rad\n", "\nradian = [angle] = rad\n"),
                             ("number_meter = kilometer / kilogram = Nm\n", "number_meter = kilometer / kilogram\n"),
                             ("\n@import constants_en.txt\n", "\n" + constants + "\n")):
                if old not in text:  # pragma: no cover - a pint whose definitions changed layout
                    raise RuntimeError(f"pint {pint.__version__}: its definitions lack {old.strip()!r}")
                text = text.replace(old, new)
            reg = pint.UnitRegistry(None, non_int_type=Fraction, autoconvert_offset_to_baseunit=False,
                                    on_redefinition="raise")
            reg.load_definitions((text + EXTRA_DEFINITIONS).splitlines())
            reg._build_cache()
            _PI = Fraction(reg.Quantity(Fraction(1), "turn").to("radian").magnitude) / 2
            _REGISTRY = reg
        return _REGISTRY


def _normalize(text: str) -> str | None:
    s = text.strip().replace("·", "*").replace("⋅", "*")
    if not s or len(s) > _MAX_TEXT or not _ALLOWED_RE.match(s) or not (s[0].isalpha() or s[0] in "°µμ("):
        return None
    s = _EXP_RE.sub(r"**\1", s)
    # every number in a unit is a small exponent: 10**9999 would take pint's exact arithmetic forever
    if any(float(m.group(0)) > 4 for m in _NUM_RE.finditer(s)):
        return None
    return s


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
    if ratio == 0:
        return None
    ordered = tuple(sorted((d.strip("[]"), Fraction(p)) for d, p in dims.items()))
    angle_power = dict(ordered).get("angle", Fraction(0))
    k = int(angle_power) if angle_power.denominator == 1 else 0
    pi_power = 0
    if k:
        r = ratio / _PI**k  # a unit defined from π (deg, rev, rpm): a small rational multiple of π^k
        if max(abs(r.numerator), r.denominator) < 10**15 <= max(abs(ratio.numerator), ratio.denominator):
            ratio, pi_power = r, k
    return UnitInfo(ordered, ratio, pi_power)


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
        _KEY = hashlib.sha256(f"{_FORMAT}\n{stamp}\n{own}\n{EXTRA_DEFINITIONS}".encode()).hexdigest()[:16]
    return _KEY


def _private(st: os.stat_result) -> bool:
    uid = os.getuid() if hasattr(os, "getuid") else None
    return (uid is None or st.st_uid == uid) and not st.st_mode & (stat.S_IWGRP | stat.S_IWOTH)


def _read_disk(path: Path) -> dict[str, UnitInfo | None]:
    """The memo at ``path`` if it is a private regular file of ours with a valid layout, else ``{}``."""
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
            raw = json.loads(f.read(_MAX_MEMO + 1).decode("utf-8"))
    except (OSError, ValueError):
        return {}
    finally:
        os.close(fd)
    out: dict[str, UnitInfo | None] = {}
    try:
        for text, entry in raw.items():
            if entry is None:
                out[text] = None
                continue
            dims, ratio, pi_power = entry
            out[text] = UnitInfo(tuple((str(d), Fraction(p)) for d, p in dims), Fraction(ratio), int(pi_power))
            if out[text].ratio == 0:
                return {}
    except (TypeError, ValueError, ZeroDivisionError, AttributeError):
        return {}
    return out


def _write_disk(path: Path) -> None:
    """Store the memo atomically (temporary file, then rename); on any failure leave nothing behind."""
    data = {t: None if u is None else [[[d, str(p)] for d, p in u.dims], str(u.ratio), u.pi_power]
            for t, u in _MEMO.items()}
    try:
        if not path.parent.is_dir() or not _private(os.stat(path.parent)):
            return
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".units.", suffix=".tmp")
    except OSError:
        return
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            json.dump(data, f, sort_keys=True)
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
