"""The edited document: the model ``dict``, undo/redo, the sweep settings, the file it saves to.

:func:`apply_op` is the one door for every change the page asks for (a JSON object with an
``op``); it runs in a worker process (:mod:`loopsolve.editor.jobs`) so that its work is bounded,
and returns the new model ``dict`` and its analysis. :class:`Document` keeps the history in the
server process and writes the file (:meth:`Document.save`): through
:func:`loopsolve.model.modelfile.dumps` (the writer of ``-o``), atomically
(:func:`loopsolve.model.files.write_text`), never over an existing file unless the page
confirmed it, and only to the file the editor was started with or to a ``.toml`` name the user
gave under the working directory.
"""

from __future__ import annotations

import copy
import hashlib
import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ..errors import LoopsolveError, ModelError, ModelFileError
from ..model.files import OutputError
from . import editing
from .analysis import analyze, build

__all__ = ["Document", "apply_op", "SaveConflict", "check_save_name", "MAX_MODEL_TEXT", "MAX_HISTORY"]

#: the largest model text the page may send (characters); model files themselves allow 1 MiB
MAX_MODEL_TEXT = 256 * 1024
#: undo steps kept
MAX_HISTORY = 200

_GEOMETRIC = {"move", "coords", "dimension", "parameter"}


class SaveConflict(LoopsolveError):
    """Saving would replace an existing file (or needs a name): the page asks the user first."""

    exit_code = 2

    def __init__(self, message: str, *, need: str, target: str | None = None):
        super().__init__(message)
        self.need = need  # "confirm" (overwrite?) or "name"
        self.target = target


def _number(v, what: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(float(v)):
        raise ModelError(f"{what}: expected a finite number, got {v!r}")
    return float(v)


def _solve_at(mech, at, mode):
    """The pose at input ``at`` (display units; ``None``: the input's guess) in ``mode`` (rates not needed)."""
    from ..errors import SingularPositionError
    from ..kinematics.solve import solve

    try:
        return solve(mech, None if at is None else _number(at, "at"), mode=mode)
    except SingularPositionError as exc:  # a dead centre: the positions are there, the rates are not
        if exc.result is None:
            raise
        return exc.result


def _mode_of(mech) -> str | None:
    from ..kinematics.solve import guessed_mode

    return guessed_mode(mech.compile())


def model_from_text(text: str, source: str = "<page>") -> dict:
    """A model ``dict`` from TOML text sent by the page: bounded, then the model-file parser checks it."""
    import tomllib

    from ..model.modelfile import loads

    if not isinstance(text, str):
        raise ModelFileError(f"{source}: the model must be TOML text", path=source)
    if len(text) > MAX_MODEL_TEXT:
        raise ModelFileError(f"{source}: {len(text)} characters is too large for a model sent to the editor "
                             f"(limit {MAX_MODEL_TEXT})", path=source)
    loads(text, source=source)  # the same checks as a file (shape, numbers, text), then a mechanism
    data = tomllib.loads(text.lstrip("\ufeff"))
    if editing.is_diagram(data):
        editing._count_check(data)
    return data


def apply_op(data: Mapping, op: Mapping[str, Any], settings: Mapping | None = None) -> dict:
    """Apply one edit of the page to a model ``dict``: ``{"data": new dict, "analysis": ...}``.

    Geometric edits (``move``, ``coords``, ``dimension``, ``parameter``) keep the assembly mode:
    one that would change it raises :class:`~loopsolve.errors.ModeError` and nothing changes.
    """
    if not isinstance(op, Mapping) or not isinstance(op.get("op"), str):
        raise ModelError('an edit is a JSON object with "op"')
    kind = op["op"]
    at, row_mode = op.get("at"), op.get("mode") or None
    new: dict
    if kind in _GEOMETRIC:
        mech = build(data)
        mode = row_mode or _mode_of(mech)
        if kind == "parameter":  # a vector-loop model: a parameter's value, typed
            new = _set_parameter(data, mech, op.get("name"), op.get("value"))
        elif kind == "dimension":
            draft = editing.set_dimension(data, str(op.get("name")), op.get("value"))
            dmech = build(draft)
            state = _solve_at(dmech, at, mode)
            new = editing.repose(draft, dmech, state)
        else:
            state = _solve_at(mech, at, mode)
            if kind == "move":
                new = editing.move_joint(data, mech, state, str(op.get("joint")), op.get("to"))
            else:
                new = editing.set_coordinates(data, mech, state, str(op.get("joint")), op.get("x"), op.get("y"))
        nmech = build(new)
        what = {"move": f"moving {op.get('joint')}", "coords": f"the coordinates of {op.get('joint')}",
                "dimension": f"{op.get('name')} = {op.get('value')}",
                "parameter": f"{op.get('name')} = {op.get('value')}"}[kind]
        editing.mode_check(mode, _mode_of(nmech), what, mech.mode_aliases)
    elif kind == "add_link":
        new = editing.add_link(data, op.get("joints") or [], op.get("new") or {})
    elif kind == "add_point":
        base = _reposed(data, at, row_mode)
        new = editing.add_point(base, str(op.get("link")), op.get("to"))
    elif kind == "add_slider":
        base = _reposed(data, at, row_mode)
        new = editing.add_slider(base, str(op.get("joint")), str(op.get("guide") or "ground"),
                                 op.get("axis") or [1, 0])
    elif kind == "delete":
        new = editing.delete(data, joint=op.get("joint"), link=op.get("link"))
    elif kind == "input":
        new = editing.set_input(data, joint=op.get("joint"), link=op.get("link"))
    elif kind == "body":
        new = editing.set_body(data, str(op.get("link")), op.get("props"))
    elif kind == "loads":
        new = editing.set_loads(data, op.get("loads"))
    elif kind == "gravity":
        new = editing.set_gravity(data, op.get("gravity"))
    elif kind == "rates":
        new = _set_rates(data, op)
    elif kind == "name":
        name = op.get("name")
        if not isinstance(name, str) or not name.strip() or len(name) > 200:
            raise ModelError("the model's name is a line of text (at most 200 characters)")
        new = dict(copy.deepcopy(dict(data)), name=name.strip())
    elif kind == "replace":
        new = model_from_text(op.get("toml"), source=str(op.get("source") or "<page>"))
    elif kind == "settings":
        new = copy.deepcopy(dict(data))
    else:
        raise ModelError(f"unknown edit {kind!r}")
    if kind in ("replace",) or kind not in _GEOMETRIC:
        # the same door as a file: whatever the edit made must be writable and readable as a model file
        from ..model.modelfile import dumps

        text = dumps(new)
        if len(text) > MAX_MODEL_TEXT:
            raise ModelError(f"the model would be {len(text)} characters, more than the editor's limit "
                             f"{MAX_MODEL_TEXT}")
    return {"data": new, "analysis": analyze(new, settings)}


def _reposed(data, at, mode):
    """The diagram drawn at the page's current input (so positions the page sends are in its pose)."""
    if at is None or not editing.is_diagram(data):
        return copy.deepcopy(dict(data))
    try:
        mech = build(data)
        state = _solve_at(mech, at, mode or _mode_of(mech))
    except LoopsolveError:  # not a mechanism (yet): the drawn pose is what the page shows
        return copy.deepcopy(dict(data))
    return editing.repose(data, mech, state)


def _set_parameter(data, mech, name, value) -> dict:
    from ..model.units import Kind, parse_quantity

    params = data.get("parameters")
    if not isinstance(params, Mapping) or name not in params:
        raise ModelError(f"no parameter {name!r}; the parameters are "
                         f"{', '.join(params) if isinstance(params, Mapping) else 'none'}")
    p = next(p for p in mech.parameters if p.name == name)
    kind = Kind.ANGLE if p.kind is Kind.ANGLE else Kind.LENGTH if p.kind is Kind.LENGTH else None
    if kind is None:
        v = _number(value if not isinstance(value, str) else _float(value, name), f"parameters.{name}")
    else:
        v = parse_quantity(value, kind, angle_unit=mech.units.angle, length_unit=mech.units.length,
                           where=f"parameters.{name}")
        if kind is Kind.ANGLE and mech.units.angle == "deg":
            v = math.degrees(v)
    new = copy.deepcopy(dict(data))
    new["parameters"][name] = editing._r(v)
    return new


def _float(text: str, name: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise ModelError(f"parameters.{name}: {text!r} is not a number") from None


def _set_rates(data, op) -> dict:
    new = copy.deepcopy(dict(data))
    if editing.is_diagram(new):
        holder = new.get("input")
        if not isinstance(holder, dict):
            raise ModelError("choose the input (the driven joint) before its speed")
    else:
        variables = new.get("variables") or {}
        name = next((k for k, v in variables.items() if isinstance(v, dict) and v.get("input")), None)
        if name is None:
            raise ModelError("the model has no input variable to give a speed")
        holder = variables[name]
    for key in ("speed", "accel"):
        if key in op:
            val = op[key]
            if val in (None, ""):
                holder.pop(key, None)
            elif isinstance(val, (str, int, float)) and not isinstance(val, bool):
                holder[key] = val
            else:
                raise ModelError(f"{key}: expected a number or a quantity such as \"10rpm\", got {val!r}")
    return new


# ------------------------------------------------------------------------------ saving
def check_save_name(name: str, base: Path) -> Path:
    """The file a save-dialog name stands for: a ``.toml`` file under ``base`` (no traversal, no links out).

    Raises :class:`ModelError` naming what is wrong.
    """
    if not isinstance(name, str) or not name.strip():
        raise ModelError("give the model file a name, such as design.toml")
    if len(name) > 255 or any(ord(c) < 32 or c in "\x7f\\" for c in name) or "\x00" in name:
        raise ModelError(f"{name!r}: not a file name (control characters, backslashes or too long)")
    p = Path(name)
    if p.is_absolute() or name.startswith("~"):
        raise ModelError(f"{name!r}: give a name relative to the working directory {os.fspath(base)!r}")
    if any(part in ("..", "") for part in p.parts) or ".." in name.replace("\\", "/").split("/"):
        raise ModelError(f"{name!r}: '..' is not allowed; the editor saves under {os.fspath(base)!r} only")
    if p.suffix.lower() != ".toml":
        raise ModelError(f"{name!r}: a model file name ends in .toml")
    base_r = base.resolve()
    target = (base_r / p)
    parent = target.parent.resolve()
    if parent != base_r and base_r not in parent.parents:
        raise ModelError(f"{name!r}: the folder leads out of the working directory (a symbolic link?)")
    if not parent.is_dir():
        raise ModelError(f"{name!r}: the folder {os.fspath(parent.relative_to(base_r)) or '.'} does not exist")
    if target.is_symlink():
        raise ModelError(f"{name!r} is a symbolic link; the editor does not write through links")
    return parent / p.name


class Document:
    """The model being edited, its history and its file."""

    def __init__(self, data: Mapping, path: Path | None = None, *, base: Path | None = None):
        self.data = copy.deepcopy(dict(data))
        self.path = Path(path) if path is not None else None
        self.base = Path(base or os.getcwd())
        self.settings: dict = {}
        self.undo_stack: list[dict] = []
        self.redo_stack: list[dict] = []
        self.analysis: dict | None = None
        self.saved_text = self._text() if path is not None else None
        self.disk_hash = self._disk_hash()

    def _text(self) -> str:
        from ..model.modelfile import dumps

        return dumps(self.data)

    def _disk_hash(self) -> str | None:
        if self.path is None or not self.path.is_file():
            return None
        try:
            return hashlib.sha256(self.path.read_bytes()).hexdigest()
        except OSError:
            return None

    def push(self, new: Mapping, analysis: dict | None) -> None:
        if new != self.data:
            self.undo_stack.append(self.data)
            del self.undo_stack[:-MAX_HISTORY]
            self.redo_stack.clear()
            self.data = copy.deepcopy(dict(new))
        self.analysis = analysis

    def undo(self) -> bool:
        if not self.undo_stack:
            return False
        self.redo_stack.append(self.data)
        self.data = self.undo_stack.pop()
        return True

    def redo(self) -> bool:
        if not self.redo_stack:
            return False
        self.undo_stack.append(self.data)
        self.data = self.redo_stack.pop()
        return True

    @property
    def dirty(self) -> bool:
        return self.saved_text != self._text()

    def state(self) -> dict:
        return {"path": os.fspath(self.path) if self.path else None, "dirty": self.dirty,
                "undo": len(self.undo_stack), "redo": len(self.redo_stack), "toml": self._text(),
                "base": os.fspath(self.base)}

    def save(self, name: str | None = None, *, overwrite: bool = False) -> Path:
        """Write the model file (see the module notes); :class:`SaveConflict` when the page must ask first."""
        from ..model.files import write_text

        if name:
            target = check_save_name(name, self.base)
        elif self.path is not None:
            target = self.path
        else:
            raise SaveConflict("the model has no file yet: give it a name (a .toml file under the working "
                               "directory)", need="name")
        text = self._text()
        exists = target.exists()
        if exists and not overwrite:
            changed = self.path is not None and target == self.path and self._disk_hash() != self.disk_hash
            raise SaveConflict(f"{os.fspath(target)} exists" + (" and changed on disk since the editor read it"
                                                                 if changed else "") + ": replace it?",
                               need="confirm", target=os.fspath(target))
        if exists and not target.is_file():
            raise OutputError(f"cannot write {os.fspath(target)!r}: it is not a regular file")
        write_text(target, text, ())
        self.path = target
        self.saved_text = text
        self.disk_hash = self._disk_hash()
        return target
