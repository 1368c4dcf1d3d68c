"""The file arguments of every command: which are read, which are written, and what each may be named.

Every option or positional that names a file is declared with :func:`file_argument` and a role:
``"input"`` (the model, a targets or poses file) or ``"output"`` (``-o``, ``--report``, ``--plot``).
An output also names its format rule (:data:`FORMATS`). Before a command does any work,
:func:`check_files` refuses, each with one line naming the option and the path (exit status 2):

* an output that is one of the command's inputs — compared by resolved path and by inode, so a
  symlink or a hard link to the model or the targets is caught;
* two outputs of one command on the same file (``-o X --report X``: one would be lost);
* an output whose extension says another format than the one written (``synthesize -o x.dxf``
  would write TOML into a ``.dxf``). A name without an extension is accepted for text outputs
  (it claims no format); pictures, animations, CAD drawings, pages and studies choose their
  format by extension, so theirs is required. Character devices (``/dev/null``) are exempt.

The tests read the roles back from the parser (:func:`command_parsers`), so a new file option
is covered by the same table as the old ones.
"""

from __future__ import annotations

import argparse
import os
import stat
from collections.abc import Callable
from pathlib import Path

__all__ = ["file_argument", "command_parsers", "file_actions", "check_files", "input_files", "FORMATS"]

#: text tables (``--format table``): extensions that say "plain text"
_TABLE = (".txt", ".text", ".dat", ".tbl", ".table", ".out")
_BY_FORMAT = {"table": (_TABLE, "a text table (--format table)"), "csv": ((".csv",), "CSV (--format csv)"),
              "json": ((".json",), "JSON (--format json)")}


def _by_format(args):
    suffixes, what = _BY_FORMAT[getattr(args, "format", "table") or "table"]
    return suffixes, what, "or choose the format with --format table|csv|json", True


def _latex(args):
    if args.pdf:
        return (".pdf",), "a PDF (--pdf)", "or leave out --pdf for the LaTeX source (.tex)", True
    return (".tex",), "LaTeX source", "or add --pdf to compile it to a PDF", True


def _draw(args):
    if args.cad:
        return (".dxf", ".svg"), "a CAD drawing (--cad)", "", False
    return (".png", ".svg", ".pdf", ".dxf"), "a figure or a CAD drawing", "a CAD drawing is .dxf, or .svg with --cad", False


def _fixed(suffixes, what, hint="", bare=False):
    def rule(args):
        return suffixes, what, hint, bare

    return rule


#: an output's format rule: ``rule(args) -> (suffixes, what is written, hint, bare name allowed)``
FORMATS: dict[str, Callable] = {
    "text": _by_format,
    "toml": _fixed((".toml",), "a model file (TOML)", bare=True),
    "json": _fixed((".json",), "JSON", bare=True),
    "latex": _latex,
    "figure": _fixed((".png", ".svg", ".pdf"), "a figure"),
    "draw": _draw,
    "animation": _fixed((".gif", ".mp4"), "an animation"),
    "page": _fixed((".html", ".htm"), "an HTML page"),
    "study": _fixed((".nc", ".zarr", ".csv"), "a study Dataset (netCDF, Zarr or long-format CSV)"),
    "cam": _fixed((".dxf", ".svg", ".csv"), "a cam profile (DXF, SVG or CSV)"),
}


def file_argument(parser: argparse.ArgumentParser, *flags, role: str, fmt: str | None = None,
                  what: str | None = None, **kwargs) -> argparse.Action:
    """``parser.add_argument(*flags, **kwargs)`` for a file: ``role`` ``"input"`` or ``"output"``;
    an output's ``fmt`` is a key of :data:`FORMATS`; ``what`` names an input in messages."""
    if role not in ("input", "output"):
        raise ValueError(f"role {role!r}")
    if role == "output" and fmt not in FORMATS:
        raise ValueError(f"an output needs a format rule, one of {', '.join(FORMATS)}")
    action = parser.add_argument(*flags, **kwargs)
    action.file_role = role
    action.file_format = fmt
    action.file_what = what
    return action


def command_parsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    """The subcommands' parsers of the ``loopsolve`` parser, by name."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    return {}


def file_actions(parser: argparse.ArgumentParser, role: str) -> list[argparse.Action]:
    """The actions of one command's parser that name files of ``role`` (declared by :func:`file_argument`)."""
    return [a for a in parser._actions if getattr(a, "file_role", None) == role]


def _flag(action) -> str:
    return action.option_strings[0] if action.option_strings else action.dest


def _given(args, action):
    """``(flag, path)`` for every path the user gave to ``action`` (``-`` is standard output or input)."""
    value = getattr(args, action.dest, None)
    out = []
    for v in (value if isinstance(value, (list, tuple)) else [value]):
        if isinstance(v, (str, os.PathLike)) and os.fspath(v) not in ("", "-"):
            out.append((_flag(action), os.fspath(v)))
    return out


def input_files(parser: argparse.ArgumentParser, args) -> list[str]:
    """Every input file named on the command line of ``args.command``."""
    sub = command_parsers(parser).get(getattr(args, "command", None))
    if sub is None:
        return []
    return [path for a in file_actions(sub, "input") for _, path in _given(args, a)]


def _same(a: str, b: str) -> bool:
    try:
        if os.path.realpath(a) == os.path.realpath(b):
            return True
        return os.path.samefile(a, b)
    except OSError:
        return False


def _is_char_device(path: str) -> bool:
    try:
        return stat.S_ISCHR(os.stat(path).st_mode)
    except OSError:
        return False


def check_files(parser: argparse.ArgumentParser, args) -> None:
    """Refuse, before any work, an output onto an input, two outputs on one file, a wrong extension.

    Raises :class:`~loopsolve.model.files.OutputError` (exit status 2) for the first two,
    :class:`~loopsolve.errors.ModelError` for the extension; each names the option and the path.
    """
    from ..errors import ModelError
    from ..kinematics.export import printable as _one_line  # a path shown on one line
    from ..model.files import OutputError

    sub = command_parsers(parser).get(getattr(args, "command", None))
    if sub is None:
        return
    inputs = [(a, flag, path) for a in file_actions(sub, "input") for flag, path in _given(args, a)]
    outputs = [(a, flag, path) for a in file_actions(sub, "output") for flag, path in _given(args, a)]
    for _, flag, path in outputs:
        for ia, iflag, ipath in inputs:
            if _same(path, ipath):
                what = ia.file_what or ("the model" if ia.dest == "model" else iflag)
                raise OutputError(f"refusing to write {flag} {_one_line(path)!r}: it is the input file "
                                  f"{_one_line(ipath)!r} ({what}); choose another name")
    for i, (_, flag, path) in enumerate(outputs):
        for _, flag2, path2 in outputs[i + 1:]:
            if _same(path, path2):
                raise OutputError(f"{flag} {_one_line(path)!r} and {flag2} {_one_line(path2)!r} are the same file: "
                                  "one output would replace the other; give each its own name")
    for a, flag, path in outputs:
        if _is_char_device(path):
            continue
        suffixes, what, hint, bare = FORMATS[a.file_format](args)
        suffix = Path(path).suffix.lower()
        if suffix in suffixes or (bare and not suffix):
            continue
        shown = suffixes[0] if len(suffixes) == 1 else f"{', '.join(suffixes[:-1])} or {suffixes[-1]}"
        raise ModelError(f"{flag} {_one_line(path)!r}: {args.command} writes {what} there; the file name must end in "
                         f"{shown}{' (or have no extension)' if bare else ''}" + (f"; {hint}" if hint else ""))
