"""Model files: TOML in, :class:`~loopsolve.model.mechanism.Mechanism` out (and back).

Two layouts load (see the design notes): the vector-loop layout (``[vectors]`` and
``[[loops]]``) and the kinematic-diagram layout (``[joints]`` and ``[links]``), which
:mod:`loopsolve.model.diagram` turns into vectors and loops. A model file is data: its expressions
go through the safe parser of :mod:`loopsolve.model.expr`, never ``eval``.
"""

from __future__ import annotations

import math
import os
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ..errors import ModelError, ModelFileError
from .mechanism import Mechanism
from .diagram import diagram_to_spec
from .spec import build_mechanism

__all__ = ["load", "loads", "dumps", "models_dir"]

MAX_FILE_SIZE = 1 << 20  # a model file is small; refuse megabytes of hostile input
MAX_DEPTH = 32  # nesting of arrays and inline tables
MAX_KEY_PARTS = 32  # parts of one dotted key (the TOML reader is quadratic in them)
_FLOAT_MAX_INT = 2 ** 1024  # an integer at least this large is not a float


def _check_shape(text: str, source: str) -> None:
    """Refuse nesting and dotted keys beyond the bounds before the TOML reader sees them.

    A light scan: strings and comments are skipped, brackets and braces counted; dots are
    counted in runs between separators (a float has one or two, a dotted key one per part).
    """
    depth, dots, line, i, n = 0, 0, 1, 0, len(text)
    while i < n:
        c = text[i]
        if c in "\"'":
            q3 = text.startswith(c * 3, i)
            end_tok = c * 3 if q3 else c
            j = i + len(end_tok)
            while j < n:
                if c == '"' and text[j] == "\\":
                    j += 2
                    continue
                if text.startswith(end_tok, j):
                    break
                if text[j] == "\n":
                    if not q3:
                        break
                    line += 1
                j += 1
            i = j + len(end_tok)
            continue
        if c == "#":
            j = text.find("\n", i)
            i = n if j < 0 else j
            continue
        if c in "[{":
            depth += 1
            if depth > MAX_DEPTH:
                raise ModelFileError(f"{source}: line {line}: arrays or tables nested more than {MAX_DEPTH} "
                                     "deep", path=source)
        elif c in "]}":
            depth = max(0, depth - 1)
        if c == ".":
            dots += 1
            if dots > MAX_KEY_PARTS:
                raise ModelFileError(f"{source}: line {line}: a key of more than {MAX_KEY_PARTS} dotted "
                                     "parts", path=source)
        elif c in "=,[]{}\n":
            dots = 0
        if c == "\n":
            line += 1
        i += 1


def _check_numbers(value: Any, source: str, where: tuple) -> None:
    """Integers must fit a float (``r1 = 1`` followed by 400 zeros is refused, naming the key)."""
    if isinstance(value, bool):
        return
    if isinstance(value, int):
        if abs(value) >= _FLOAT_MAX_INT:
            key = ".".join(str(w) for w in where) or "(top level)"
            raise ModelFileError(f"{source}: {key}: the integer is too large (more than about 1.8e308)",
                                 path=source, key=key)
    elif isinstance(value, Mapping):
        for k, v in value.items():
            _check_numbers(v, source, where + (k,))
    elif isinstance(value, list):
        for k, v in enumerate(value):
            _check_numbers(v, source, where + (k,))


def models_dir() -> Path:
    """The directory of the shipped reference models (``models/`` of the source tree).

    Returns
    -------
    pathlib.Path
        In a source checkout ``models/``; in an installed wheel the copy shipped inside the package.

    Examples
    --------
    >>> "thesis_crank_rocker.toml" in {p.name for p in ls.models_dir().glob("*.toml")}
    True
    """
    import sys
    import sysconfig

    here = Path(__file__).resolve().parents[1]  # the package (this module is in model/)
    # a checkout; a wheel's data files in the environment (venv, system, conda) or the user's scheme (--user)
    places = [here.parent / "models", Path(sys.prefix) / "share" / "loopsolve" / "models"]
    try:
        places.append(Path(sysconfig.get_path("data", f"{os.name}_user")) / "share" / "loopsolve" / "models")
    except KeyError:  # no user scheme on this platform
        pass
    for cand in places:
        if cand.is_dir():
            return cand
    return here.parent / "models"


def load(path: str | os.PathLike) -> Mechanism:
    """Read a model file.

    Parameters
    ----------
    path : str or path-like
        A TOML model file (a regular file of at most 1 MiB; format: the docs' "The model file format").

    Returns
    -------
    Mechanism
        The validated, frozen declaration.

    Raises
    ------
    ModelFileError
        Naming the file, the key and the offending text; every problem of the file at once.

    Examples
    --------
    >>> mech = ls.load(ls.models_dir() / "thesis_crank_rocker.toml")
    >>> mech.name, mech.inputs
    ('Crank-rocker four-bar', ('theta2',))
    """
    from .files import read_regular

    name = os.fspath(path)
    try:
        data = read_regular(name, MAX_FILE_SIZE, what="model file")
    except FileNotFoundError:
        raise ModelFileError(f"{name}: no such model file", path=name) from None
    except IsADirectoryError:
        raise ModelFileError(f"{name}: is a directory, not a model file", path=name) from None
    except ValueError as exc:  # not a regular file, or too large
        raise ModelFileError(str(exc), path=name) from None
    except OSError as exc:
        raise ModelFileError(f"{name}: cannot read the model file ({exc.strerror or exc})", path=name) from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ModelFileError(f"{name}: not UTF-8 text ({exc.reason} at byte {exc.start})", path=name) from None
    return loads(text, source=name)


def loads(text: str, *, source: str = "<string>") -> Mechanism:
    """Parse model-file text (``source`` names it in error messages).

    A leading UTF-8 byte-order mark is ignored. Text the TOML reader would choke on (nesting
    deeper than :data:`MAX_DEPTH`, keys of more than :data:`MAX_KEY_PARTS` dotted parts, integers
    of more digits than a float can hold) is refused with a :class:`ModelFileError` at once.

    Parameters
    ----------
    text : str
        The model file's text.
    source : str, optional
        The name errors give for it.

    Returns
    -------
    Mechanism
        As :func:`load` gives.

    Examples
    --------
    >>> mech = ls.loads('''
    ... [parameters]
    ... r2 = 25
    ... r3 = 70
    ... [variables]
    ... theta2 = { input = true, guess = 30 }
    ... theta3 = { guess = -10 }
    ... x = { guess = 90 }
    ... [vectors]
    ... r1 = { length = "x", angle = 0 }
    ... r2 = { length = "r2", angle = "theta2" }
    ... r3 = { length = "r3", angle = "theta3" }
    ... [[loops]]
    ... equation = "r2 + r3 = r1"
    ... ''')
    >>> round(mech.solve(90)["x"], 4)
    65.3835
    """
    if not isinstance(text, str):
        raise ModelFileError(f"{source}: model text must be a string, not {type(text).__name__}", path=source)
    if text.startswith("\ufeff"):
        text = text[1:]
    if len(text) > MAX_FILE_SIZE:
        raise ModelFileError(f"{source}: {len(text)} characters is too large for a model file "
                             f"(limit {MAX_FILE_SIZE})", path=source)
    _check_shape(text, source)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        hint = " (a key or table is declared twice)" if "overwrite" in str(exc).lower() else ""
        raise ModelFileError(f"{source}: malformed TOML: {exc}{hint}", path=source) from None
    except (ValueError, RecursionError, MemoryError, OverflowError) as exc:
        what = "too deeply nested" if isinstance(exc, RecursionError) else str(exc).split("; ")[0]
        raise ModelFileError(f"{source}: malformed TOML: {what}", path=source) from None
    _check_numbers(data, source, ())
    _check_text(data, source, ())
    if "joints" in data or "links" in data:
        if "vectors" in data or "loops" in data:
            raise ModelFileError(
                f"{source}: a model has either [joints]/[links] (a kinematic diagram) or "
                "[vectors]/[[loops]], not both", path=source)
        data = diagram_to_spec(data, source=source)
    return build_mechanism(data, source=source)


# ----------------------------------------------------------------------------- writing

_ESCAPES = {"\\": "\\\\", '"': '\\"', "\b": "\\b", "\t": "\\t", "\n": "\\n", "\f": "\\f", "\r": "\\r"}


def _toml_string(s: str) -> str:
    """A TOML basic string: quotes, backslashes and every control character escaped."""
    out = []
    for ch in s:
        if ch in _ESCAPES:
            out.append(_ESCAPES[ch])
        elif ord(ch) < 0x20 or 0x7F <= ord(ch) < 0xA0:
            out.append(f"\\u{ord(ch):04X}")
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'


def _fmt_key(k: Any) -> str:
    k = str(k)
    if k and all(c.isascii() and (c.isalnum() or c in "_-") for c in k):
        return k
    return _toml_string(k)


def _check_text(value: Any, source: str, where: tuple) -> None:
    """Refuse control characters in the file's keys and strings (they would reach terminals raw).

    A tab is allowed anywhere, a line break only in ``description``.
    """
    if isinstance(value, str):
        allowed = "\t\n" if where == ("description",) else "\t"
        bad = [c for c in value if (ord(c) < 0x20 or 0x7F <= ord(c) < 0xA0) and c not in allowed]
        if bad:
            key = ".".join(str(w) for w in where) or "(top level)"
            raise ModelFileError(f"{source}: {key}: control character {bad[0]!r} in {value!r}; names and "
                                 "expressions are printable text", path=source, key=key)
    elif isinstance(value, Mapping):
        for k, v in value.items():
            if any(ord(c) < 0x20 or 0x7F <= ord(c) < 0xA0 for c in k):
                raise ModelFileError(f"{source}: control character in the key {k!r}", path=source, key=k)
            _check_text(v, source, where + (k,))
    elif isinstance(value, list):
        for k, v in enumerate(value):
            _check_text(v, source, where + (k,))


def _fmt_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            raise ModelError(f"cannot write the non-finite number {v!r} to a model file")
        return repr(v)
    if isinstance(v, str):
        return _toml_string(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_fmt_value(x) for x in v) + "]"
    if isinstance(v, Mapping):
        return "{ " + ", ".join(f"{_fmt_key(k)} = {_fmt_value(x)}" for k, x in v.items()) + " }"
    raise ModelError(f"cannot write {v!r} to a model file")


_TOP_SCALARS = ("name", "description", "units", "gravity")
_VECTOR_SECTIONS = ("parameters", "variables", "vectors")
_LATE_SECTIONS = ("points", "modes", "bodies")
_DIAGRAM_SECTIONS = ("parameters", "joints", "links", "input", "modes", "bodies")


def _is_table_array(v: Any) -> bool:
    return isinstance(v, (list, tuple)) and bool(v) and all(isinstance(x, Mapping) for x in v)


def _section(out: list[str], name: str, table: Mapping[str, Any]) -> None:
    out.append("")
    out.append(f"[{_fmt_key(name)}]")
    for k, v in table.items():
        out.append(f"{_fmt_key(k)} = {_fmt_value(v)}")


def _table_array(out: list[str], name: str, items) -> None:
    for item in items:
        out.append("")
        out.append(f"[[{_fmt_key(name)}]]")
        for k, v in (item.items() if isinstance(item, Mapping) else {"equation": item}.items()):
            out.append(f"{_fmt_key(k)} = {_fmt_value(v)}")


def dumps(mech_or_spec: Mechanism | Mapping[str, Any]) -> str:
    """The model file (TOML text) of a mechanism or a model ``dict``.

    A mechanism, or a vector-loop ``dict``, is written in the vector-loop layout:
    ``loads(dumps(m))`` gives a mechanism with the same derivation as ``m``, and the same
    ``gravity``, ``[bodies]`` and ``[[loads]]`` (so the same force analysis) and higher pairs
    (``[gears]``, ``[cams.NAME]``, ...: written as any other key). A ``dict`` in the
    kinematic-diagram layout (``[joints]`` and ``[links]``, no ``[vectors]``) is written in that
    layout. Either way a ``dict`` read from a model file comes back key for key and value for
    value (``tomllib.loads(dumps(d)) == d``): keys loopsolve does not know are written too.

    Parameters
    ----------
    mech_or_spec : Mechanism or dict
        A mechanism, or a model ``dict`` (as ``tomllib`` reads a model file).

    Returns
    -------
    str
        TOML text that :func:`loads` reads back.

    Examples
    --------
    >>> import tomllib
    >>> d = tomllib.loads((ls.models_dir() / "thesis_crank_rocker_diagram.toml").read_text())
    >>> tomllib.loads(ls.dumps(d)) == d
    True
    >>> print(ls.dumps(d).split("[links]")[0].splitlines()[-2])
    O4 = { at = [60, 0] }
    """
    spec = mech_or_spec.spec if isinstance(mech_or_spec, Mechanism) else mech_or_spec
    diagram = (not isinstance(mech_or_spec, Mechanism) and ("joints" in spec or "links" in spec)
               and "vectors" not in spec and "loops" not in spec)
    out = []
    for key in _TOP_SCALARS:
        if key in spec:
            out.append(f"{key} = {_fmt_value(spec[key])}")
    known = set(_TOP_SCALARS) | {"loops", "loads"}
    known |= set(_DIAGRAM_SECTIONS) if diagram else set(_VECTOR_SECTIONS) | set(_LATE_SECTIONS)
    if not diagram:  # the vector loops generated from a diagram: the diagram's own keys are not written
        known |= {"joints", "links", "input"}
    rest = [k for k in spec if k not in known]
    for k in rest:  # other plain values must come before the first table
        if not isinstance(spec[k], Mapping) and not _is_table_array(spec[k]):
            out.append(f"{_fmt_key(k)} = {_fmt_value(spec[k])}")
    if diagram:
        for section in _DIAGRAM_SECTIONS:
            if isinstance(spec.get(section), Mapping) and (spec[section] or section in ("joints", "links")):
                _section(out, section, spec[section])
            elif section in spec and not isinstance(spec[section], Mapping):
                raise ModelError(f"cannot write [{section}]: expected a table, got {spec[section]!r}")
    else:
        for section in _VECTOR_SECTIONS:
            if spec.get(section):
                _section(out, section, spec[section])
        _table_array(out, "loops", spec.get("loops", []))
        for section in _LATE_SECTIONS:
            if spec.get(section):
                _section(out, section, spec[section])
    _table_array(out, "loads", spec.get("loads", []) or [])
    for k in rest:
        if isinstance(spec[k], Mapping):
            _section(out, k, spec[k])
        elif _is_table_array(spec[k]):
            _table_array(out, k, spec[k])
    return "\n".join(out) + "\n"
