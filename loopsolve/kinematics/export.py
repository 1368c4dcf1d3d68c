"""Tables for people and files for programs: text table, CSV and JSON of states and sweeps.

Every header carries its unit. JSON follows the command-line contract::

    {"mechanism": name, "input": name, "units": {...}, "rows": [...], "events": [...]}
"""

from __future__ import annotations

import csv
import io
import json
import math

import numpy as np

from .results import State, Sweep, column_units, turns_of
from ..model.units import Kind, unit_label

__all__ = ["to_json", "to_csv", "to_table", "state_table", "sweep_table", "iter_json", "iter_csv", "printable",
           "fixed"]


CHUNK = 256  # rows formatted at a time when streaming a sweep
_CONTROL = {c: f"\\x{c:02x}" for c in (*range(0x20), *range(0x7F, 0xA0))}


def printable(text: str) -> str:
    r"""``text`` with control characters shown as ``\xNN`` (never raw terminal escapes).

    Examples
    --------
    >>> from loopsolve.kinematics.export import printable
    >>> print(printable("four-bar\x1b[31m"))
    four-bar\x1b[31m
    """
    return str(text).translate(_CONTROL)


def mode_label(mech, signature: str) -> str:
    """``"-"`` or ``"- (open)"`` when the model names that mode."""
    names = [k for k, v in getattr(mech, "mode_aliases", {}).items() if v == signature]
    return printable(f"{signature} ({', '.join(names)})" if names else signature)


def _chunks(sweep: Sweep, size: int = CHUNK):
    """The sweep as consecutive sub-sweeps of at most ``size`` rows (views, no copies)."""
    n = len(sweep)
    last = None  # angles stay continuous across the chunks (each continues the one before)
    for i in range(0, n, size):
        j = min(n, i + size)
        turns, last = turns_of(sweep.compiled, sweep.z[i:j], last)
        yield Sweep.from_arrays(sweep.compiled, sweep.z[i:j], sweep.z1[i:j], sweep.z2[i:j], sweep.z3[i:j],
                                modes=sweep.modes[i:j], residual=sweep.residual[i:j], n_iter=sweep.n_iter[i:j],
                                cond=sweep.cond[i:j], mode=sweep.mode, method=sweep.method, engine=sweep.engine,
                                copy=False, turns=turns)


def _keys(obj) -> list[str]:
    ck = obj.compiled
    keys = list(State(ck, *[np.zeros(len(ck.variables))] * 4, np.zeros((4, len(ck.points), 2))).row())
    if isinstance(obj, Sweep) and len(set(obj.modes)) > 1:
        keys.append("mode")
    return keys


def _row_lists(obj):
    """Chunks of rows, each a list of value lists in :func:`_keys` order (mode as its label)."""
    keys = _keys(obj)
    mech = obj.compiled.mechanism
    if isinstance(obj, State):
        row = obj.row()
        yield [[row[k] for k in keys]]
        return
    labels = {m: mode_label(mech, m) for m in set(obj.modes)}
    for part in _chunks(obj):
        cols = part.columns
        lists = []
        for k in keys:
            if k == "mode":
                lists.append([labels[m] for m in part.modes])
            else:
                lists.append([_clean(v) for v in cols[k].tolist()])
        yield [list(r) for r in zip(*lists)]


def _clean(v: float) -> float | None:
    v = float(v)
    if not math.isfinite(v):
        return None
    return 0.0 if v == 0 else v


def _header(obj) -> dict:
    ck = obj.compiled
    u = ck.mechanism.units
    return {
        "mechanism": ck.mechanism.name,
        "input": ck.inputs[0],
        "units": {"length": u.length, "angle": u.angle, **column_units(ck)},
        "mode": obj.mode,
    }


def iter_json(obj: State | Sweep, *, indent: int | None = 1):
    """The contract's JSON object as text chunks, rows formatted a chunk at a time.

    ``"".join(iter_json(s))`` equals :func:`to_json`; writing the chunks to a file keeps memory
    bounded however many rows the sweep has.
    """
    head = _header(obj)
    events = [e.to_dict() for e in obj.events] if isinstance(obj, Sweep) else []
    keys = _keys(obj)
    pad = "" if indent is None else " " * indent
    nl = "" if indent is None else "\n"
    sep = ", " if indent is None else ","
    dumps = lambda v: json.dumps(v, allow_nan=False)  # noqa: E731
    yield "{" + nl + (sep + nl).join(f"{pad}{dumps(k)}: {dumps(v)}" for k, v in head.items())
    yield sep + nl + f'{pad}"rows": [' + nl
    first = True
    for chunk in _row_lists(obj):
        parts = []
        for vals in chunk:
            parts.append(("" if first else sep + nl) + pad * 2 + dumps(dict(zip(keys, vals))))
            first = False
        yield "".join(parts)
    yield nl + pad + "]" + sep + nl + f'{pad}"events": {dumps(events)}'
    if isinstance(obj, State) and obj.compiled.sliding:
        comps = {v: obj.acceleration_components(v).to_dict() for v in obj.compiled.sliding}
        yield sep + nl + f'{pad}"acceleration_components": {dumps(comps)}'
    yield nl + "}"


def to_json(obj: State | Sweep, *, indent: int | None = 1) -> str:
    """The contract's JSON object for a state or a sweep."""
    return "".join(iter_json(obj, indent=indent))


def iter_csv(obj: State | Sweep):
    """CSV text chunks: one header row ``name [unit]``, then the rows a chunk at a time."""
    units = column_units(obj.compiled)
    keys = _keys(obj)
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow([f"{k} [{units[k]}]" if units.get(k) else k for k in keys])
    yield buf.getvalue()
    for chunk in _row_lists(obj):
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerows([["" if v is None else v if isinstance(v, str) else repr(v) for v in r] for r in chunk])
        yield buf.getvalue()


def to_csv(obj: State | Sweep) -> str:
    """CSV with one header row ``name [unit]``; events are not part of CSV (see JSON)."""
    return "".join(iter_csv(obj))


def _fmt(v, width=14) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "nan".rjust(width)
    return f"{v:{width}.6g}"


def fixed(v) -> str:
    """An input value in fixed notation (``1000000``, ``27.4``, never ``1e+06``).

    Examples
    --------
    >>> from loopsolve.kinematics.export import fixed
    >>> fixed(1e6), fixed(27.4), fixed(-0.0), fixed(1 / 3)
    ('1000000', '27.4', '0', '0.333333333')
    """
    if v is None or not math.isfinite(float(v)):
        return "nan"
    r = round(float(v), 9)
    return np.format_float_positional(r + 0.0, precision=9, trim="-")


def _column(values, *, is_input: bool = False) -> list[str]:
    """Format one table column: values below 1e-12 of the column's largest magnitude print 0."""
    vals = [None if v is None else float(v) for v in values]
    if is_input:
        return [fixed(v) for v in vals]
    finite = [abs(v) for v in vals if v is not None and math.isfinite(v)]
    floor = NOISE * max(finite) if finite else 0.0
    return [_fmt(0.0 if v is not None and math.isfinite(v) and abs(v) < floor else v).strip() for v in vals]


NOISE = 1e-12


def _grid(headers: list[str], rows: list[list[str]]) -> str:
    widths = [max(len(h), *(len(r[i]) for r in rows)) if rows else len(h) for i, h in enumerate(headers)]
    line = "  ".join(h.rjust(w) if i else h.ljust(w) for i, (h, w) in enumerate(zip(headers, widths)))
    out = [line, "-" * len(line)]
    for r in rows:
        out.append("  ".join(c.rjust(w) if i else c.ljust(w) for i, (c, w) in enumerate(zip(r, widths))))
    return "\n".join(out)


def _numeric_rows(labels: list[str], table: list[list]) -> list[list[str]]:
    """Rows of a label then numbers, each number column formatted by :func:`_column`."""
    cols = list(zip(*table)) if table else []
    text = [_column(c) for c in cols]
    return [[lab] + [t[i] for t in text] for i, lab in enumerate(labels)]


def state_table(state: State) -> str:
    """A readable multi-section table of one state (variables, points, acceleration parts)."""
    ck = state.compiled
    u = ck.mechanism.units
    row = state.row()
    head = (f"{printable(ck.mechanism.name)}: {ck.inputs[0]} = {fixed(state.input_value)} "
            f"{unit_label(ck.kinds[ck.index(ck.inputs[0])], u.angle, u.length)}, "
            f"input speed {row[ck.inputs[0] + '_vel']:g} {column_units(ck)[ck.inputs[0] + '_vel']}, "
            f"accel {row[ck.inputs[0] + '_acc']:g} {column_units(ck)[ck.inputs[0] + '_acc']}  "
            f"(mode {mode_label(ck.mechanism, state.mode)}, residual {state.residual:.1e})")
    sections = [head]
    order = list(ck.inputs) + [n for n in ck.variables if n not in ck.inputs]
    for kind in (Kind.ANGLE, Kind.LENGTH):
        names = [n for n in order if ck.kinds[ck.index(n)] is kind]
        if not names:
            continue
        rates = ((Kind.ANGLE, Kind.ANGULAR_RATE, Kind.ANGULAR_ACCEL, Kind.ANGULAR_JERK) if kind is Kind.ANGLE
                 else (Kind.LENGTH, Kind.LENGTH_RATE, Kind.LENGTH_ACCEL, Kind.LENGTH_JERK))
        labels = [unit_label(k, u.angle, u.length) for k in rates]
        headers = ["angle" if kind is Kind.ANGLE else "length", f"position [{labels[0]}]",
                   f"velocity [{labels[1]}]", f"acceleration [{labels[2]}]", f"jerk [{labels[3]}]"]
        tags = [f"{n} (input)" if n in ck.inputs else n for n in names]
        values = [[row[n + s] for s in ("", "_vel", "_acc", "_jerk")] for n in names]
        sections.append(_grid(headers, _numeric_rows(tags, values)))
    if ck.points:
        L = u.length
        headers = ["point", f"x [{L}]", f"y [{L}]", f"v_x [{L}/s]", f"v_y [{L}/s]",
                   f"a_x [{L}/s^2]", f"a_y [{L}/s^2]", f"j_x [{L}/s^3]", f"j_y [{L}/s^3]"]
        values = [[row[f"{p}_{c}{s}"] for s in ("", "_vel", "_acc", "_jerk") for c in "xy"] for p in ck.points]
        sections.append(_grid(headers, _numeric_rows(list(ck.points), values)))
    if ck.sliding:
        L = u.length
        headers = ["vector", f"tangential r*alpha [{L}/s^2]", f"normal -r*omega^2 [{L}/s^2]",
                   f"slip r'' [{L}/s^2]", f"Coriolis 2r'omega [{L}/s^2]"]
        rows = []
        for v in ck.sliding:
            c = state.acceleration_components(v)
            rows.append([v] + [f"({a[0]:.6g}, {a[1]:.6g})" for a in (c.tangential, c.normal, c.slip, c.coriolis)])
        sections.append("acceleration of sliding vectors, split as in the notes (x, y):\n" + _grid(headers, rows))
    return "\n\n".join(sections) + "\n"


def sweep_table(sweep: Sweep, *, columns: list[str] | None = None) -> str:
    """A wide table: the input, then position, velocity and acceleration of every unknown."""
    ck = sweep.compiled
    units = column_units(ck)
    if columns is None:
        columns = [ck.inputs[0]] + [n + s for n in ck.unknowns for s in ("", "_vel", "_acc")]
    cols = sweep.columns
    varying = len(set(sweep.modes)) > 1
    headers = [f"{c} [{units[c]}]" for c in columns] + (["mode"] if varying else [])
    text = [_column(cols[c].tolist(), is_input=c in ck.inputs) for c in columns]
    if varying:
        labels = {m: mode_label(ck.mechanism, m) for m in set(sweep.modes)}
        text.append([labels[m] for m in sweep.modes])
    rows = [list(r) for r in zip(*text)] if text else []
    out = (f"{printable(ck.mechanism.name)}: sweep of {ck.inputs[0]} ({len(sweep)} row{'' if len(sweep) == 1 else 's'}, mode "
           f"{mode_label(ck.mechanism, sweep.mode)})\n" + _grid(headers, rows))
    for e in sweep.events:
        out += f"\n{e.kind.value} at {ck.inputs[0]} = {e.input:.10g}: {printable(e.message)}"
    return out + "\n"


def to_table(obj: State | Sweep) -> str:
    return state_table(obj) if isinstance(obj, State) else sweep_table(obj)
