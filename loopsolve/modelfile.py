"""Model files: TOML in, :class:`~loopsolve.model.Mechanism` out (and back).

Two layouts load (see the design notes): the vector-loop layout (``[vectors]`` and
``[[loops]]``) and the kinematic-diagram layout (``[joints]`` and ``[links]``), which
:mod:`loopsolve.diagram` turns into vectors and loops. A model file is data: its expressions
go through the safe parser of :mod:`loopsolve.expr`, never ``eval``.
"""

from __future__ import annotations

import math
import os
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from .errors import ModelError, ModelFileError
from .model import Mechanism, build_mechanism

__all__ = ["load", "loads", "dumps", "models_dir"]

MAX_FILE_SIZE = 1 << 20  # a model file is small; refuse megabytes of hostile input


def models_dir() -> Path:
    """The directory of the shipped reference models (``models/`` of the source tree).

    Examples
    --------
    >>> "thesis_crank_rocker.toml" in {p.name for p in ls.models_dir().glob("*.toml")}
    True
    """
    import sys

    here = Path(__file__).resolve().parent
    for cand in (here.parent / "models", Path(sys.prefix) / "share" / "loopsolve" / "models"):
        if cand.is_dir():
            return cand
    return here.parent / "models"


def load(path: str | os.PathLike) -> Mechanism:
    """Read a model file.

    Raises
    ------
    ModelFileError
        Naming the file, the key and the offending text; every problem of the file at once.
    """
    p = Path(path)
    name = str(path)
    try:
        size = p.stat().st_size
    except FileNotFoundError:
        raise ModelFileError(f"{name}: no such model file", path=name) from None
    except OSError as exc:
        raise ModelFileError(f"{name}: cannot read the model file ({exc.strerror})", path=name) from None
    if p.is_dir():
        raise ModelFileError(f"{name}: is a directory, not a model file", path=name)
    if size > MAX_FILE_SIZE:
        raise ModelFileError(f"{name}: {size} bytes is too large for a model file (limit {MAX_FILE_SIZE})",
                             path=name)
    try:
        text = p.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise ModelFileError(f"{name}: not UTF-8 text ({exc.reason} at byte {exc.start})", path=name) from None
    except OSError as exc:
        raise ModelFileError(f"{name}: cannot read the model file ({exc.strerror})", path=name) from None
    return loads(text, source=name)


def loads(text: str, *, source: str = "<string>") -> Mechanism:
    """Parse model-file text (``source`` names it in error messages)."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        hint = " (a key or table is declared twice)" if "overwrite" in str(exc).lower() else ""
        raise ModelFileError(f"{source}: malformed TOML: {exc}{hint}", path=source) from None
    if "joints" in data or "links" in data:
        if "vectors" in data or "loops" in data:
            raise ModelFileError(
                f"{source}: a model has either [joints]/[links] (a kinematic diagram) or "
                "[vectors]/[[loops]], not both", path=source)
        from .diagram import diagram_to_spec

        data = diagram_to_spec(data, source=source)
    return build_mechanism(data, source=source)


# ----------------------------------------------------------------------------- writing


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
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_fmt_value(x) for x in v) + "]"
    if isinstance(v, Mapping):
        return "{ " + ", ".join(f"{k} = {_fmt_value(x)}" for k, x in v.items()) + " }"
    raise ModelError(f"cannot write {v!r} to a model file")


def dumps(mech_or_spec: Mechanism | Mapping[str, Any]) -> str:
    """The vector-loop model file (TOML text) of a mechanism or a model ``dict``.

    ``loads(dumps(m))`` gives a mechanism with the same derivation as ``m``.
    """
    spec = mech_or_spec.spec if isinstance(mech_or_spec, Mechanism) else mech_or_spec
    out = []
    for key in ("name", "description"):
        if key in spec:
            out.append(f"{key} = {_fmt_value(spec[key])}")
    if "units" in spec:
        out.append(f"units = {_fmt_value(spec['units'])}")
    for section in ("parameters", "variables", "vectors"):
        if spec.get(section):
            out.append("")
            out.append(f"[{section}]")
            for k, v in spec[section].items():
                out.append(f"{k} = {_fmt_value(v)}")
    for loop in spec.get("loops", []):
        out.append("")
        out.append("[[loops]]")
        for k, v in (loop.items() if isinstance(loop, Mapping) else {"equation": loop}.items()):
            out.append(f"{k} = {_fmt_value(v)}")
    for section in ("points", "modes"):
        if spec.get(section):
            out.append("")
            out.append(f"[{section}]")
            for k, v in spec[section].items():
                out.append(f"{k} = {_fmt_value(v)}")
    return "\n".join(out) + "\n"
