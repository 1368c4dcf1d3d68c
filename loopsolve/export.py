"""Tables for people and files for programs: text table, CSV and JSON of states and sweeps.

Every header carries its unit. JSON follows the command-line contract::

    {"mechanism": name, "input": name, "units": {...}, "rows": [...], "events": [...]}
"""

from __future__ import annotations

import csv
import io
import json
import math

from .results import State, Sweep, column_units
from .units import Kind, unit_label

__all__ = ["to_json", "to_csv", "to_table", "state_table", "sweep_table"]


def mode_label(mech, signature: str) -> str:
    """``"-"`` or ``"- (open)"`` when the model names that mode."""
    names = [k for k, v in getattr(mech, "mode_aliases", {}).items() if v == signature]
    return f"{signature} ({', '.join(names)})" if names else signature


def _items(obj) -> tuple[list[dict], list, object]:
    if isinstance(obj, State):
        return [obj.row()], [], obj.compiled
    return obj.rows, list(obj.events), obj.compiled


def to_json(obj: State | Sweep, *, indent: int | None = 1) -> str:
    """The contract's JSON object for a state or a sweep."""
    rows, events, ck = _items(obj)
    u = ck.mechanism.units
    units = {"length": u.length, "angle": u.angle, **column_units(ck)}
    doc = {
        "mechanism": ck.mechanism.name,
        "input": ck.inputs[0],
        "units": units,
        "mode": obj.mode,
        "rows": rows,
        "events": [e.to_dict() for e in events],
    }
    if isinstance(obj, State) and ck.sliding:
        doc["acceleration_components"] = {v: obj.acceleration_components(v).to_dict() for v in ck.sliding}
    return json.dumps(doc, indent=indent, allow_nan=False)


def to_csv(obj: State | Sweep) -> str:
    """CSV with one header row ``name [unit]``; events are not part of CSV (see JSON)."""
    rows, _, ck = _items(obj)
    units = column_units(ck)
    buf = io.StringIO()
    keys = list(rows[0]) if rows else list(units)
    w = csv.writer(buf, lineterminator="\n")
    w.writerow([f"{k} [{units[k]}]" if units.get(k) else k for k in keys])
    for r in rows:
        w.writerow(["" if r[k] is None else repr(float(r[k])) for k in keys])
    return buf.getvalue()


def _fmt(v, width=14) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "nan".rjust(width)
    return f"{v:{width}.6g}"


def _grid(headers: list[str], rows: list[list[str]]) -> str:
    widths = [max(len(h), *(len(r[i]) for r in rows)) if rows else len(h) for i, h in enumerate(headers)]
    line = "  ".join(h.rjust(w) if i else h.ljust(w) for i, (h, w) in enumerate(zip(headers, widths)))
    out = [line, "-" * len(line)]
    for r in rows:
        out.append("  ".join(c.rjust(w) if i else c.ljust(w) for i, (c, w) in enumerate(zip(r, widths))))
    return "\n".join(out)


def state_table(state: State) -> str:
    """A readable multi-section table of one state (variables, points, acceleration parts)."""
    ck = state.compiled
    u = ck.mechanism.units
    row = state.row()
    head = (f"{ck.mechanism.name}: {ck.inputs[0]} = {state.input_value:g} "
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
        rows = []
        for n in names:
            tag = f"{n} (input)" if n in ck.inputs else n
            rows.append([tag] + [_fmt(row[n + s]).strip() for s in ("", "_vel", "_acc", "_jerk")])
        sections.append(_grid(headers, rows))
    if ck.points:
        L = u.length
        headers = ["point", f"x [{L}]", f"y [{L}]", f"v_x [{L}/s]", f"v_y [{L}/s]",
                   f"a_x [{L}/s^2]", f"a_y [{L}/s^2]", f"j_x [{L}/s^3]", f"j_y [{L}/s^3]"]
        rows = []
        for p in ck.points:
            rows.append([p] + [_fmt(row[f"{p}_{c}{s}"]).strip() for s in ("", "_vel", "_acc", "_jerk") for c in "xy"])
        sections.append(_grid(headers, rows))
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
    headers = [f"{c} [{units[c]}]" for c in columns]
    rows = [[_fmt(r[c]).strip() for c in columns] for r in sweep.rows]
    out = f"{ck.mechanism.name}: sweep of {ck.inputs[0]} ({len(rows)} rows, mode {mode_label(ck.mechanism, sweep.mode)})\n" + _grid(headers, rows)
    for e in sweep.events:
        out += f"\n{e.kind.value} at {ck.inputs[0]} = {e.input:.10g}: {e.message}"
    return out + "\n"


def to_table(obj: State | Sweep) -> str:
    return state_table(obj) if isinstance(obj, State) else sweep_table(obj)
