"""Immutable results: the :class:`State` at one input value and the :class:`Sweep` over many.

Internally everything is radians and the model's length unit. ``row()``/``rows`` give the
values at the human interface: angles in the model's angle unit (wrapped to (−180°, 180°] for
unknowns), rates in rad/s, rad/s², rad/s³ (or length unit/s...), with the column names of the
command-line contract: ``q``, ``q_vel``, ``q_acc``, ``q_jerk``, ``P_x``, ``P_y``, ``P_x_vel``....
"""

from __future__ import annotations

import enum
import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field

import numpy as np

from .errors import ModelError
from .units import Kind, unit_label

__all__ = ["State", "Sweep", "Event", "EventKind", "AccelerationComponents", "column_units"]

_SUFFIX = ("", "_vel", "_acc", "_jerk")
_RATE_KINDS = {
    Kind.ANGLE: (Kind.ANGLE, Kind.ANGULAR_RATE, Kind.ANGULAR_ACCEL, Kind.ANGULAR_JERK),
    Kind.LENGTH: (Kind.LENGTH, Kind.LENGTH_RATE, Kind.LENGTH_ACCEL, Kind.LENGTH_JERK),
}


class EventKind(enum.Enum):
    """What happened along a sweep (values are the contract's ``kind`` strings)."""

    LIMIT = "limit"
    SINGULAR = "singular"
    NOT_ASSEMBLABLE = "not-assemblable"
    MODE_CHANGE = "mode-change"


@dataclass(frozen=True, slots=True)
class Event:
    """An event at input value ``input`` (display units)."""

    kind: EventKind
    input: float
    message: str

    def to_dict(self) -> dict:
        return {"kind": self.kind.value, "input": _clean(self.input), "message": self.message}


@dataclass(frozen=True, slots=True)
class AccelerationComponents:
    """Acceleration of the tip of a vector of varying length r and angle θ, split as in the notes.

    ``tangential`` = r θ̈ e_t, ``normal`` = −r θ̇² e_r, ``slip`` = r̈ e_r, ``coriolis`` = 2 ṙ θ̇ e_t,
    where e_r = (cos θ, sin θ) and e_t = (−sin θ, cos θ). Each is an (x, y) array in length
    unit/s²; their sum is the vector's second time derivative.
    """

    vector: str
    tangential: np.ndarray
    normal: np.ndarray
    slip: np.ndarray
    coriolis: np.ndarray

    @property
    def total(self) -> np.ndarray:
        return self.tangential + self.normal + self.slip + self.coriolis

    def to_dict(self) -> dict:
        return {k: [float(v) for v in getattr(self, k)] for k in ("tangential", "normal", "slip", "coriolis", "total")}


def _clean(v: float) -> float | None:
    v = float(v)
    if not math.isfinite(v):
        return None
    return 0.0 if v == 0 else v


def _wrap_deg(x: np.ndarray | float, unit: str):
    """Wrap an angle in display units to (−180, 180] (or (−π, π])."""
    half = 180.0 if unit == "deg" else math.pi
    y = np.mod(np.asarray(x, dtype=float) + half, 2 * half) - half
    return np.where(y == -half, half, y)


def column_units(compiled) -> dict[str, str]:
    """Column name → unit label for every column of :meth:`State.row`."""
    u = compiled.mechanism.units
    out: dict[str, str] = {}
    for name, kind in zip(compiled.variables, compiled.kinds):
        for suffix, k in zip(_SUFFIX, _RATE_KINDS[kind]):
            out[name + suffix] = unit_label(k, u.angle, u.length)
    for p in compiled.points:
        for c in ("x", "y"):
            for suffix, k in zip(_SUFFIX, _RATE_KINDS[Kind.LENGTH]):
                out[f"{p}_{c}{suffix}"] = unit_label(k, u.angle, u.length)
    return out


def _display(compiled, name: str, order: int, value, *, wrap: bool):
    kind = compiled.kinds[compiled.index(name)]
    if kind is Kind.ANGLE and order == 0:
        unit = compiled.mechanism.units.angle
        v = np.degrees(value) if unit == "deg" else np.asarray(value, dtype=float)
        return _wrap_deg(v, unit) if wrap else v
    return value


@dataclass(frozen=True, eq=False)
class State:
    """Positions and rates of every variable and point at one input value.

    ``z``, ``z1``, ``z2``, ``z3`` are all joint variables and their 1st–3rd time derivatives in
    internal units (declaration order, see ``compiled.variables``); ``points`` is a
    ``(4, P, 2)`` array (position, velocity, acceleration, jerk of every point).

    Indexing by name gives display units: ``state["theta3"]`` (degrees in a degree model),
    ``state["theta3_vel"]`` (rad/s), ``state["C_x"]``, ``state["C_y_acc"]``.
    """

    compiled: object = field(repr=False)
    z: np.ndarray
    z1: np.ndarray
    z2: np.ndarray
    z3: np.ndarray
    points: np.ndarray = field(repr=False)
    mode: str = ""
    residual: float = 0.0
    n_iter: int = 0
    cond: float = 1.0

    @property
    def mechanism(self):
        return self.compiled.mechanism

    @property
    def input(self) -> str:
        return self.compiled.inputs[0]

    @property
    def input_value(self) -> float:
        """The driving input in display units."""
        return float(_display(self.compiled, self.input, 0, self.z[self.compiled.index(self.input)], wrap=False))

    def row(self) -> dict[str, float]:
        """One row of the output contract (display units), input first."""
        ck = self.compiled
        out: dict[str, float] = {}
        inputs = set(ck.inputs)
        order = list(ck.inputs) + [n for n in ck.variables if n not in inputs]
        for name in order:
            i = ck.index(name)
            for k, (suffix, arr) in enumerate(zip(_SUFFIX, (self.z, self.z1, self.z2, self.z3))):
                out[name + suffix] = _clean(_display(ck, name, k, arr[i], wrap=name not in inputs))
        for j, p in enumerate(ck.points):
            for c, axis in (("x", 0), ("y", 1)):
                for k, suffix in enumerate(_SUFFIX):
                    out[f"{p}_{c}{suffix}"] = _clean(self.points[k, j, axis])
        return out

    def __getitem__(self, key: str) -> float:
        row = self.row()
        try:
            return row[key]
        except KeyError:
            raise ModelError(f"no column {key!r}; the columns are {', '.join(row)}") from None

    def units(self) -> dict[str, str]:
        return column_units(self.compiled)

    def acceleration_components(self, vector: str) -> AccelerationComponents:
        """Tangential, normal, slip and Coriolis parts of a vector's acceleration (see the notes).

        Meaningful for a vector whose length and angle both vary (a block sliding on a
        rotating link); for others the slip and Coriolis parts are zero.
        """
        ck = self.compiled
        if vector not in ck.vectors:
            raise ModelError(f"unknown vector {vector!r}; the vectors are {', '.join(ck.vectors)}")
        j = ck.vectors.index(vector)
        r, th = ck.vector_values(0, self.z)[j]
        rd, thd = ck.vector_values(1, self.z, self.z1)[j]
        rdd, thdd = ck.vector_values(2, self.z, self.z1, self.z2)[j]
        er = np.array([math.cos(th), math.sin(th)])
        et = np.array([-math.sin(th), math.cos(th)])
        return AccelerationComponents(vector, r * thdd * et, -r * thd**2 * er, rdd * er, 2 * rd * thd * et)


@dataclass(frozen=True, eq=False)
class Sweep:
    """Results of a sweep: one :class:`State` per output point, the events and the mode.

    ``columns`` maps every column name of the output contract to an array (display units);
    ``states`` keeps the full states; ``events`` lists limits, singular points, mode changes.
    """

    compiled: object = field(repr=False)
    states: tuple[State, ...]
    events: tuple[Event, ...] = ()
    mode: str = ""

    @property
    def mechanism(self):
        return self.compiled.mechanism

    @property
    def input(self) -> str:
        return self.compiled.inputs[0]

    @property
    def rows(self) -> list[dict[str, float]]:
        return [s.row() for s in self.states]

    @property
    def columns(self) -> Mapping[str, np.ndarray]:
        rows = self.rows
        keys = list(rows[0]) if rows else list(column_units(self.compiled))
        return {k: np.array([np.nan if r[k] is None else r[k] for r in rows], dtype=float) for k in keys}

    def __getitem__(self, key: str) -> np.ndarray:
        cols = self.columns
        try:
            return cols[key]
        except KeyError:
            raise ModelError(f"no column {key!r}; the columns are {', '.join(cols)}") from None

    def __len__(self) -> int:
        return len(self.states)

    def __iter__(self) -> Iterator[State]:
        return iter(self.states)

    def units(self) -> dict[str, str]:
        return column_units(self.compiled)

    def to_json(self, **kwargs) -> str:
        from .export import to_json

        return to_json(self, **kwargs)

    def to_csv(self, **kwargs) -> str:
        from .export import to_csv

        return to_csv(self, **kwargs)

    def plot(self, *args, **kwargs):
        """Stacked plots of the chosen variables: see :func:`loopsolve.plotting.plot_sweep`."""
        from .plotting import plot_sweep

        return plot_sweep(self, *args, **kwargs)

    def animate(self, *args, **kwargs):
        """Animation of the linkage over the sweep: see :func:`loopsolve.plotting.animate`."""
        from .plotting import animate

        return animate(self, *args, **kwargs)
