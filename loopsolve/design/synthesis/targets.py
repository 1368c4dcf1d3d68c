"""Reading synthesis targets: a CSV file or text, a mapping of columns or a list of rows.

:func:`read_targets` returns the task's columns (``x,y`` for a path, ``input,output`` for a
function, ``x,y,angle`` for a motion, each with an optional ``input`` column for prescribed
timing) as float arrays, or raises :class:`~loopsolve.errors.ModelError` naming the file, line and
column. :mod:`loopsolve.design.synthesis.problem` re-exports :func:`read_targets`.
"""

from __future__ import annotations

import csv
import io
import math
import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ...errors import ModelError

__all__ = ["read_targets", "read_table", "read_text_file", "csv_records"]

_TASK_COLUMNS = {"path": ("x", "y"), "function": ("input", "output"), "motion": ("x", "y", "angle")}


def read_targets(targets, task: str = "path", *, source: str | None = None) -> dict[str, np.ndarray]:
    """Target columns from a CSV file (path), CSV text, a mapping of columns or a list of rows.

    Returns a dict of float arrays with the task's columns (``x,y`` / ``input,output`` /
    ``x,y,angle``) and ``input`` when given (prescribed timing). Raises :class:`ModelError`
    naming the file, line and column.

    Examples
    --------
    >>> cols = read_targets("x,y,input\\n1,2,30\\n3,4,60\\n")
    >>> cols["x"].tolist(), cols["input"].tolist()
    ([1.0, 3.0], [30.0, 60.0])
    """
    need = _TASK_COLUMNS[task]
    where = source or "targets"
    if isinstance(targets, (str, os.PathLike)) and not (isinstance(targets, str) and "\n" in targets):
        where = os.fspath(targets)
        rows = _csv_rows(read_text_file(targets, what="targets"), where)
    elif isinstance(targets, str):
        rows = _csv_rows(targets, where)
    elif isinstance(targets, Mapping):
        cols = {str(k).strip().lower(): np.atleast_1d(np.asarray(v, dtype=float)) for k, v in targets.items()}
        return _check_columns(cols, need, where)
    else:
        arr = np.asarray(targets, dtype=float)
        if arr.ndim != 2 or arr.shape[1] not in (len(need), len(need) + 1):
            raise ModelError(f"{where}: expected rows of {', '.join(need)} (and optionally input), got shape "
                             f"{arr.shape}")
        cols = {c: arr[:, j] for j, c in enumerate(need)}
        if arr.shape[1] == len(need) + 1:
            cols["input"] = arr[:, -1]
        return _check_columns(cols, need, where)
    header, body = rows
    cols = {}
    for j, h in enumerate(header):
        vals = []
        for line, r in body:
            try:
                v = float(r[j])
            except (ValueError, IndexError):
                raise ModelError(f"{where}: line {line}, column {h!r}: {r[j] if j < len(r) else ''!r} is not a "
                                 "number") from None
            if not math.isfinite(v):
                raise ModelError(f"{where}: line {line}, column {h!r}: {r[j]!r} is not a finite number")
            vals.append(v)
        cols[h] = np.array(vals)
    return _check_columns(cols, need, where)


#: the largest targets or poses file read (bytes)
MAX_FILE_SIZE = 50_000_000


def read_text_file(path, *, what: str = "targets") -> str:
    """The text of a CSV file of targets or poses: a regular file of at most :data:`MAX_FILE_SIZE`
    bytes, UTF-8 with or without a byte-order mark (as spreadsheet programs write). Errors are
    :class:`ModelError` naming the file."""
    from ...model.files import read_regular

    where = os.fspath(path)
    try:
        data = read_regular(path, MAX_FILE_SIZE, what=f"{what} file")
    except OSError as exc:
        raise ModelError(f"{where}: cannot read the {what} file: {exc.strerror or exc}") from None
    except ValueError as exc:
        raise ModelError(f"cannot read the {what} file: {exc}") from None
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = data[:exc.start].count(b"\n") + 1
        raise ModelError(f"{where}: line {line}: not UTF-8 text (byte {data[exc.start]:#04x}); save the {what} "
                         "file as UTF-8 CSV") from None


def csv_records(text: str, where: str):
    """``(line, fields)`` of every CSV record of ``text`` (a leading byte-order mark dropped); a field
    longer than the csv module's limit (131,072 characters) or a malformed record is a
    :class:`ModelError` naming ``where`` and the line."""
    if text.startswith("\ufeff"):
        text = text[1:]
    reader = csv.reader(io.StringIO(text))
    out = []
    while True:
        try:
            r = next(reader)
        except StopIteration:
            return out
        except csv.Error as exc:
            line = reader.line_num
            if "field larger than field limit" in str(exc):
                raise ModelError(f"{where}: line {line}: a field of more than {csv.field_size_limit():,} characters; "
                                 "every field is one number") from None
            raise ModelError(f"{where}: line {line}: not a CSV record ({exc})") from None
        out.append((reader.line_num, r))


def _csv_rows(text: str, where: str):
    lines = [(i, r) for i, r in csv_records(text, where)
             if r and any(c.strip() for c in r) and not r[0].lstrip().startswith("#")]
    if not lines:
        raise ModelError(f"{where}: no header line (expected a CSV with a header such as x,y)")
    (hl, header), body = lines[0], lines[1:]
    header = [h.strip().lower() for h in header]
    if len(set(header)) != len(header):
        raise ModelError(f"{where}: line {hl}: repeated column names in {','.join(header)}")
    for line, r in body:
        if len(r) != len(header):
            raise ModelError(f"{where}: line {line}: {len(r)} values for {len(header)} columns "
                             f"({','.join(header)})")
    return header, body


def _check_columns(cols, need, where):
    missing = [c for c in need if c not in cols]
    if missing:
        raise ModelError(f"{where}: missing column(s) {', '.join(missing)}; the columns are "
                         f"{', '.join(cols) or 'none'} (expected {','.join(need)}[,input])")
    extra = [c for c in cols if c not in need and c != "input"]
    if extra:
        raise ModelError(f"{where}: unknown column(s) {', '.join(extra)} (expected {','.join(need)}[,input])")
    n = {len(v) for v in cols.values()}
    if len(n) != 1:
        raise ModelError(f"{where}: columns of different lengths")
    for c, v in cols.items():
        if not np.all(np.isfinite(v)):
            raise ModelError(f"{where}: column {c!r} holds a value that is not a finite number")
    return {c: np.asarray(v, dtype=float) for c, v in cols.items()}


def read_table(source, columns: tuple[str, ...], *, what: str = "targets") -> np.ndarray:
    """Rows of the named numeric ``columns`` from a CSV file (or text) with a header line.

    Errors name the file, the line and the column (:class:`ModelError`).

    Examples
    --------
    >>> from loopsolve.design.synthesis.targets import read_table
    >>> read_table("x,y,angle\\n1,2,30\\n3,4,45\\n", ("x", "y", "angle")).tolist()
    [[1.0, 2.0, 30.0], [3.0, 4.0, 45.0]]
    """
    if isinstance(source, Mapping):  # columns by name, as the general method takes them
        cols = {str(k).strip().lower(): v for k, v in source.items()}
        missing = [c for c in columns if c not in cols]
        if missing:
            raise ModelError(f"{what}: missing column(s) {', '.join(missing)}; the columns are "
                             f"{', '.join(cols) or 'none'} (expected {','.join(columns)})")
        try:
            source = np.column_stack([np.atleast_1d(np.asarray(cols[c], dtype=float)) for c in columns])
        except (TypeError, ValueError):
            raise ModelError(f"{what}: the columns {','.join(columns)} must be numbers of one length") from None
    if not isinstance(source, (str, Path)):  # rows of numbers already (an array or a list of rows)
        try:
            arr = np.array(source, dtype=float)
        except (TypeError, ValueError):
            raise ModelError(f"{what}: expected a file, CSV text or rows of {len(columns)} numbers "
                             f"({','.join(columns)})") from None
        if arr.ndim != 2 or arr.shape[1] != len(columns) or len(arr) == 0:
            raise ModelError(f"{what}: expected rows of {len(columns)} numbers ({','.join(columns)}), got shape "
                             f"{arr.shape}")
        if not np.isfinite(arr).all():
            raise ModelError(f"{what}: every value must be a finite number")
        return arr
    if isinstance(source, Path) or (isinstance(source, str) and "\n" not in source and "," not in source):
        where = str(source)
        text = read_text_file(source, what=what)
    else:
        where, text = f"<{what}>", str(source)
    rows = [(i, r) for i, r in csv_records(text, where) if r and any(c.strip() for c in r)]
    rows = [(i, r) for i, r in rows if not r[0].lstrip().startswith("#")]
    if not rows:
        raise ModelError(f"{where}: empty {what} file; expected a header line {','.join(columns)} and rows")
    line, header = rows[0]
    names = [h.strip().lower() for h in header]
    missing = [c for c in columns if c not in names]
    if missing:
        raise ModelError(f"{where}, line {line}: the header {','.join(h.strip() for h in header)!r} lacks the "
                         f"column(s) {', '.join(missing)}; expected {','.join(columns)}")
    idx = [names.index(c) for c in columns]
    out = []
    for line, r in rows[1:]:
        if len(r) != len(header):
            raise ModelError(f"{where}, line {line}: {len(r)} fields, the header has {len(header)}")
        vals = []
        for c, j in zip(columns, idx):
            try:
                v = float(r[j])
            except ValueError:
                raise ModelError(f"{where}, line {line}, column {c}: {r[j].strip()!r} is not a number") from None
            if not math.isfinite(v):
                raise ModelError(f"{where}, line {line}, column {c}: {r[j].strip()!r} is not a finite number")
            vals.append(v)
        out.append(vals)
    if not out:
        raise ModelError(f"{where}: no {what} rows after the header")
    return np.array(out, dtype=float)
