"""What every ``loopsolve`` command shares: the argument parser class, loading a model, writing
an output (never over an input), rendering a result as text or JSON.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
from collections.abc import Iterable

from .fileargs import file_argument


EXIT_OK, EXIT_USAGE, EXIT_SOLVE = 0, 2, 3

# The input files of the running command: an output never replaces one of them.
INPUTS: list[str] = []


class Parser(argparse.ArgumentParser):
    """The argument parser of every ``loopsolve`` command: a usage error is one line and exit 2."""

    def error(self, message):  # one line, exit 2
        self.exit(EXIT_USAGE, f"loopsolve: error: {one_line(message)} (see `{self.prog} --help`)\n")

    def _get_values(self, action, arg_strings):
        # `--at=--` is the value "--" (argparse would drop it and pass an empty list on)
        if action.option_strings and action.nargs is None and arg_strings == ["--"]:
            return self._get_value(action, "--")
        return super()._get_values(action, arg_strings)



def one_line(text: str) -> str:
    """One line of printable text (control characters shown as escapes)."""
    from ..kinematics.export import printable

    lines = [ln.strip() for ln in str(text).strip().splitlines() if ln.strip()]
    return printable("; ".join(lines).replace(":; ", ": "))



def add_text_output(p: argparse.ArgumentParser) -> None:
    """``-o/--output`` of a command whose ``--format`` is table, csv or json (the extension follows it)."""
    file_argument(p, "-o", "--output", role="output", fmt="text", help="write to this file instead of standard "
                  "output (.txt for a table, .csv or .json as --format)")



@contextlib.contextmanager
def temporary_output(path: str | os.PathLike, inputs: Iterable[str] | None = None):
    """A temporary path (same extension) for a writer; renamed onto ``path`` when the block succeeds.

    For commands that hand a file name to a writer (figures, PDFs, pages): refuses an input
    file as target, and leaves the old file intact on any failure.
    """
    from ..model.files import atomic_output

    with atomic_output(path, INPUTS if inputs is None else inputs) as tmp:
        yield tmp



def load_model(path: str):
    """The mechanism of the model file ``path`` (imported when first needed)."""
    from ..model.modelfile import load

    return load(path)



def write_output(text: str | Iterable[str], out: str | None, inputs: Iterable[str] | None = None) -> None:
    """Write text (or text chunks, streamed) as UTF-8 to standard output or, atomically, to ``out``."""
    if out in (None, "-"):
        chunks = [text] if isinstance(text, str) else text
        stream = sys.stdout
        if (getattr(stream, "encoding", None) or "").lower().replace("-", "") != "utf8" and hasattr(stream, "buffer"):
            stream.flush()
            for chunk in chunks:
                stream.buffer.write(chunk.encode("utf-8"))
            stream.buffer.flush()
        else:
            for chunk in chunks:
                stream.write(chunk)
    else:
        from ..model.files import write_text

        write_text(out, text, INPUTS if inputs is None else inputs)
        print(f"wrote {one_line(out)}", file=sys.stderr)



def check_writable(out: str | None) -> None:
    """Fail before any work when ``out`` can never be written (an input, a directory, no such folder)."""
    if out not in (None, "-"):
        from ..model.files import check_target

        check_target(out, INPUTS)



def render(obj, fmt: str):
    """The text of a state or sweep: a string (table) or text chunks (CSV/JSON, streamed)."""
    from ..kinematics import export

    if fmt == "json":
        return _chain(export.iter_json(obj), "\n")
    if fmt == "csv":
        return export.iter_csv(obj)
    return export.to_table(obj)



def _chain(chunks, tail: str):
    yield from chunks
    yield tail



def add_rate_args(p: argparse.ArgumentParser) -> None:
    """Add ``--speed``, ``--accel``, ``--jerk``, ``--input`` and ``--mode`` to the command ``p``."""
    p.add_argument("--speed", help="input speed, e.g. 10rpm, 10.5 (rad/s), 2rad/s, 5mm/s (default: the "
                   "model's, else 1: rates are then kinematic coefficients)")
    p.add_argument("--accel", help="input acceleration, e.g. 0, 2rad/s^2 (default: the model's, else 0)")
    p.add_argument("--jerk", help="input jerk (default: the model's, else 0)")
    p.add_argument("--input", metavar="NAME", help="drive this variable instead of the declared input")
    p.add_argument("--mode", metavar="SIGNATURE", help="assembly mode to use: a signature such as + or -+, or "
                   "an alias declared by the model (open, crossed)")


def synthesis_output(args, run, label: str):
    """Run a synthesis, write its report (also the failed one's, then re-raise) and ``-o`` model;
    print the report when no ``--report`` file is given. Returns the report when it went to a file."""
    import json

    from ..errors import SynthesisError

    try:
        res = run()
    except SynthesisError as exc:
        if args.report and exc.report is not None:
            write_output(json.dumps(exc.report, indent=2, allow_nan=False) + "\n", args.report)
        raise
    text = json.dumps(res.report, indent=2, allow_nan=False) + "\n"  # strict JSON: a NaN is a bug, not output
    if args.report:
        write_output(text, args.report)
    if args.output:
        write_output(res.to_toml(), args.output)
    if not args.report:
        sys.stdout.write(text)
        return None
    return res.report
