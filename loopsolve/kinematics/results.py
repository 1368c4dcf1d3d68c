"""Immutable results: the :class:`State` at one input value and the :class:`Sweep` over many.

Internally everything is radians and the model's length unit. ``row()``/``rows`` give the
values at the human interface: angles in the model's angle unit (an unknown's angle in
(−180°, 180°] at one position; along a sweep the first row is in (−180°, 180°] and later rows
follow the motion, see :func:`angle_turns`), rates in rad/s, rad/s², rad/s³ (or length unit/s...), with the column names of the
command-line contract: ``q``, ``q_vel``, ``q_acc``, ``q_jerk``, ``P_x``, ``P_y``, ``P_x_vel``....
"""

from __future__ import annotations

import enum
import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field

import numpy as np

from ..errors import ModelError
from ..model.units import Kind, unit_label

__all__ = ["State", "Sweep", "Event", "EventKind", "AccelerationComponents", "column_units", "angle_turns"]

_SUFFIX = ("", "_vel", "_acc", "_jerk")
_RATE_KINDS = {
    Kind.ANGLE: (Kind.ANGLE, Kind.ANGULAR_RATE, Kind.ANGULAR_ACCEL, Kind.ANGULAR_JERK),
    Kind.LENGTH: (Kind.LENGTH, Kind.LENGTH_RATE, Kind.LENGTH_ACCEL, Kind.LENGTH_JERK),
}


class EventKind(enum.Enum):
    """What happened along a sweep (values are the contract's ``kind`` strings).

    Parameters
    ----------
    value : str
        The event's ``kind`` string of the output contract (``"limit"``, ``"singular"``,
        ``"not-assemblable"``, ``"mode-change"``, ``"self-locking"``): ``EventKind("limit")`` is
        ``EventKind.LIMIT``. Users receive these in ``Event.kind`` of ``sweep.events``.

    Attributes
    ----------
    LIMIT : EventKind
        A limit position (toggle, fold): the input cannot go further in this mode.
    SINGULAR : EventKind
        A singular position (dead centre, change point) where the rates are undefined.
    NOT_ASSEMBLABLE : EventKind
        The mechanism cannot be assembled over part of the range.
    MODE_CHANGE : EventKind
        The assembly mode changes (through a limit, with ``through_limits=True``).
    SELF_LOCKING : EventKind
        A force analysis with friction: no driving force or torque can move the mechanism there.

    Examples
    --------
    >>> import loopsolve as ls
    >>> triple_rocker = ls.fourbar(60, 50, 40, 30, theta2=10)
    >>> sw = ls.sweep(triple_rocker, 10, 360, 10, through_limits=True)
    >>> [e.kind.value for e in sw.events]
    ['limit', 'mode-change']
    >>> ls.EventKind("limit") is ls.EventKind.LIMIT
    True
    """

    LIMIT = "limit"
    SINGULAR = "singular"
    NOT_ASSEMBLABLE = "not-assemblable"
    MODE_CHANGE = "mode-change"
    #: a force analysis with friction: no driving force or torque can move the mechanism there
    SELF_LOCKING = "self-locking"


@dataclass(frozen=True, slots=True)
class Event:
    """An event at input value ``input`` (display units).

    Parameters
    ----------
    kind : EventKind
        ``limit``, ``singular``, ``not-assemblable`` or ``mode-change``.
    input : float
        Where it happened, in the input's display unit.
    message : str
        What happened, in words.

    Attributes
    ----------
    kind, input, message
        As the parameters of the same names.

    Examples
    --------
    >>> sw = ls.load(ls.models_dir() / "double_rocker.toml").sweep(60, 180, 10)
    >>> [(e.kind.value, round(e.input, 4)) for e in sw.events]
    [('limit', 71.79)]
    """

    kind: EventKind
    input: float
    message: str

    def to_dict(self) -> dict:
        return {"kind": self.kind.value, "input": finite_or_none(self.input), "message": self.message}


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


def finite_or_none(v: float) -> float | None:
    """``v`` as a float for JSON: ``None`` when not finite, ``-0.0`` written as ``0.0``."""
    v = float(v)
    if not math.isfinite(v):
        return None
    return 0.0 if v == 0 else v


def _wrap_deg(x: np.ndarray | float, unit: str):
    """Wrap an angle in display units to (−180, 180] (or (−π, π])."""
    half = 180.0 if unit == "deg" else math.pi
    y = np.mod(np.asarray(x, dtype=float) + half, 2 * half) - half
    return np.where(y == -half, half, y)


def angle_turns(values, unit: str, *, after=None) -> np.ndarray:
    """Whole turns to subtract from angles along rows so that they are continuous.

    ``values`` are angles in display units (``(N,)`` or ``(N, D)``, rows along axis 0, NaN
    where there is no row). The first finite row of each column is brought into (−180°, 180°]
    (or (−π, π]) and every later row within half a turn of the finite row before it, so that
    ``values - period * turns`` follows the motion instead of jumping by a turn where the
    angle passes ±180°. The rule of every sweep's table, CSV, JSON, arrays, plot and page.
    ``after`` (one value per column, NaN for none) continues a previous part of the rows: the
    first row goes within half a turn of it instead.

    Examples
    --------
    >>> from loopsolve.kinematics.results import angle_turns
    >>> v = np.array([350.0, 365.0, 375.0, np.nan, 541.0])
    >>> v - 360 * angle_turns(v, "deg")
    array([-10.,   5.,  15.,  nan, 181.])
    """
    period = 360.0 if unit == "deg" else 2 * math.pi
    half = period / 2
    v = np.asarray(values, dtype=float)
    if v.size == 0:
        return np.zeros(v.shape, dtype=np.int64)
    flat = v.reshape(v.shape[0], -1) if v.ndim else v.reshape(1, 1)
    n = flat.shape[0]
    ok = np.isfinite(flat)
    # forward-fill the gaps (and back-fill leading ones with the first finite value)
    idx = np.where(ok, np.arange(n)[:, None], -1)
    np.maximum.accumulate(idx, axis=0, out=idx)
    first = np.argmax(ok, axis=0)
    idx = np.where(idx < 0, first[None, :], idx)
    g = np.take_along_axis(np.where(ok, flat, 0.0), idx, axis=0)
    g0 = g[0]
    k0 = np.floor((g0 + half) / period)
    k0 = np.where(g0 - period * k0 == -half, k0 - 1, k0)  # -180 is written 180
    if after is not None:
        a = np.broadcast_to(np.asarray(after, dtype=float).reshape(-1), g0.shape)
        with np.errstate(invalid="ignore"):
            k0 = np.where(np.isfinite(a), np.round((g0 - a) / period), k0)
    steps = np.round(np.diff(g, axis=0) / period)
    turns = k0[None, :] + np.concatenate([np.zeros((1, g.shape[1])), np.cumsum(steps, axis=0)], axis=0)
    turns = np.where(np.isfinite(turns), turns, 0.0).astype(np.int64)
    return turns.reshape(v.shape) if v.ndim else turns.reshape(())


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


def in_display_units(compiled, name: str, order: int, value, *, wrap: bool):
    """The internal ``value`` of variable ``name`` (rate ``order``) in display units, angles wrapped if ``wrap``."""
    kind = compiled.kinds[compiled.index(name)]
    if kind is Kind.ANGLE and order == 0:
        unit = compiled.mechanism.units.angle
        if unit == "deg":
            v = np.degrees(value)
            # undo the round trip through radians (60 -> 59.99999999999999) and nothing else
            r = np.round(v, 9)
            v = np.where(np.abs(v - r) <= 1e-13 * np.maximum(1.0, np.abs(v)), r, v)
        else:
            v = np.asarray(value, dtype=float)
        return _wrap_deg(v, unit) if wrap else v
    return value


def _period(compiled) -> float:
    return 360.0 if compiled.mechanism.units.angle == "deg" else 2 * math.pi


def turns_of(ck, z, after=None):
    """:func:`angle_turns` of every unknown angle of rows ``z`` ``(N, nvar)``, internal units.

    Returns ``(turns, last)``: ``(N, nvar)`` integers and, per variable, the last finite displayed
    value (``after`` where the rows have none) — what the next part of the rows continues from.
    """
    t = np.zeros(z.shape, dtype=np.int64)
    last = np.full(len(ck.variables), np.nan) if after is None else np.array(after, dtype=float)
    unit = ck.mechanism.units.angle
    period = _period(ck)
    for i, (name, kind) in enumerate(zip(ck.variables, ck.kinds)):
        if kind is Kind.ANGLE and name not in ck.inputs and len(z):
            v = np.asarray(in_display_units(ck, name, 0, z[:, i], wrap=False), dtype=float)
            t[:, i] = angle_turns(v, unit, after=last[i])
            ok = np.flatnonzero(np.isfinite(v))
            if len(ok):
                last[i] = v[ok[-1]] - period * t[ok[-1], i]
    return t, last


@dataclass(frozen=True, eq=False)
class State:
    """Positions and rates of every variable and point at one input value.

    ``z``, ``z1``, ``z2``, ``z3`` are all joint variables and their 1st–3rd time derivatives in
    internal units (declaration order, see ``compiled.variables``); ``points`` is a
    ``(4, P, 2)`` array (position, velocity, acceleration, jerk of every point).

    Indexing by name gives display units: ``state["theta3"]`` (degrees in a degree model),
    ``state["theta3_vel"]`` (rad/s), ``state["C_x"]``, ``state["C_y_acc"]``.

    Parameters
    ----------
    compiled : CompiledKinematics
        The compiled mechanism it belongs to.
    z, z1, z2, z3 : ndarray
        Joint variables and their derivatives (internal units). Made by
        :func:`loopsolve.solve`, not by hand.
    points : ndarray
        ``(4, P, 2)``: position, velocity, acceleration and jerk of every output point
        (model length unit, per second...).
    mode : str, optional
        The assembly-mode signature of the solution.
    residual, n_iter, cond : float, int, float, optional
        The solver's figures: loop-closure residual (model length unit), Newton iterations,
        condition number of Φ_q.
    turns : tuple of int, optional
        Whole turns of the unknown angles relative to their wrapped values, when a sweep
        tracked them continuously.

    Attributes
    ----------
    compiled, z, z1, z2, z3, points, mode, residual, n_iter, cond, turns
        As the parameters of the same names.

    Examples
    --------
    >>> state = ls.load(ls.models_dir() / "thesis_crank_rocker.toml").solve(90)
    >>> round(state["theta4"], 4), round(state["theta4_vel"], 6), round(state["C_x"], 4)
    (80.7225, 0.618656, 67.2547)
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
    #: whole turns subtracted from each variable's angle (declaration order) for display, as
    #: the row of a sweep it belongs to; ``None``: unknown angles in (−180°, 180°]
    turns: tuple[int, ...] | None = field(default=None, repr=False)

    @property
    def mechanism(self):
        return self.compiled.mechanism

    @property
    def input(self) -> str:
        return self.compiled.inputs[0]

    @property
    def input_value(self) -> float:
        """The driving input in display units."""
        ck = self.compiled
        return float(in_display_units(ck, self.input, 0, self.z[ck.index(self.input)], wrap=False))

    def row(self) -> dict[str, float]:
        """One row of the output contract (display units), input first."""
        ck = self.compiled
        out: dict[str, float] = {}
        inputs = set(ck.inputs)
        order = list(ck.inputs) + [n for n in ck.variables if n not in inputs]
        for name in order:
            i = ck.index(name)
            for k, (suffix, arr) in enumerate(zip(_SUFFIX, (self.z, self.z1, self.z2, self.z3))):
                if k == 0 and self.turns is not None and name not in inputs and ck.kinds[i] is Kind.ANGLE:
                    v = in_display_units(ck, name, 0, arr[i], wrap=False) - _period(ck) * self.turns[i]
                else:
                    v = in_display_units(ck, name, k, arr[i], wrap=name not in inputs)
                out[name + suffix] = finite_or_none(v)
        for j, p in enumerate(ck.points):
            for c, axis in (("x", 0), ("y", 1)):
                for k, suffix in enumerate(_SUFFIX):
                    out[f"{p}_{c}{suffix}"] = finite_or_none(self.points[k, j, axis])
        return out

    def __getitem__(self, key: str) -> float:
        row = self.row()
        try:
            return row[key]
        except KeyError:
            raise ModelError(f"no column {key!r}; the columns are {', '.join(row)}") from None

    def __repr__(self) -> str:
        # the positions in display units, as indexing and the tables give them (the fields z, z1…
        # are internal units: radians in a degree model, which read wrongly at a prompt)
        ck, row, units = self.compiled, self.row(), self.units()
        inputs = set(ck.inputs)
        names = list(ck.inputs) + [n for n in ck.variables if n not in inputs]
        pos = ", ".join(f"{n}={row[n]:.6g} {units.get(n, '')}".rstrip() for n in names)
        return f"State({ck.mechanism.name!r}, {pos}, mode={self.mode!r}, residual={self.residual:.1e})"

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


class Sweep:
    """Results of a sweep: arrays per variable and output point, the events and the mode.

    Immutable. Made by :func:`loopsolve.sweep` (``mech.sweep``); columns and units: the docs'
    "Results". Index it by column name (``sw["theta4"]``, display units) or by row
    (``sw.states[i]``, a :class:`State`).

    Users receive sweeps from :func:`loopsolve.sweep`; they need not construct one.
    ``Sweep(compiled, states, events, mode)`` builds one from states, :meth:`from_arrays` from
    arrays (what the sweeps do).

    Parameters
    ----------
    compiled : CompiledKinematics
        The compiled mechanism the rows belong to.
    states : sequence of State, optional
        One solved state per row, in the order traversed.
    events : sequence of Event, optional
        Limits, singular points, mode changes met along the way.
    mode : str, optional
        The assembly mode at the start (a signature such as ``"-"``).
    method : str, optional
        How the rows were solved (``"tracked"``, ``"closed-form"``...).
    engine : str, optional
        Who took the tracer's regular steps: ``"python"`` or ``"numba"``.

    Attributes
    ----------
    z, z1, z2, z3 : numpy.ndarray
        ``(N, nvar)`` positions, velocities, accelerations and jerks of every variable (internal
        units: rad, rad/s, ... and the model's length unit), one row per output point in the order
        traversed.
    modes : numpy.ndarray
        The assembly-mode signature at every row.
    residual, n_iter, cond : numpy.ndarray
        The solver's figures per row: loop-closure residual (model length unit), Newton
        iterations, condition number of Φ_q.
    columns : dict
        Every column name of the output contract → array (display units; the angles of unknowns
        continuous along the rows, the first in (−180°, 180°], see :attr:`turns`; plus a ``mode``
        column of signatures when the rows are not all in one mode, as through limits).
    states : tuple of State
        One :class:`State` per row (built on first use).
    events : tuple of Event
        Limits, singular points, mode changes.
    mode : str
        The starting mode.
    method : str
        How the points were solved.
    engine : str
        Who took the tracer's regular steps (``"python"``, ``"numba"``; see ``engine=`` of
        :func:`loopsolve.sweep`).
    compiled : CompiledKinematics
        The compiled mechanism.

    Examples
    --------
    >>> import loopsolve as ls
    >>> sw = ls.load(ls.models_dir() / "thesis_crank_rocker.toml").sweep(0, 360, 90)
    >>> [round(float(v), 4) for v in sw["theta4"]]
    [58.4119, 80.7225, 124.6546, 125.9622, 58.4119]
    >>> sw.units()["theta4_vel"]
    'rad/s'
    >>> len(sw), sw.mode, sw.z.shape
    (5, '-', (5, 3))
    """

    __slots__ = ("compiled", "events", "mode", "method", "engine", "z", "z1", "z2", "z3", "modes", "residual",
                 "n_iter", "cond", "_cache")

    def __init__(self, compiled, states=(), events=(), mode: str = "", *, method: str = "tracked",
                 engine: str = "python"):
        states = tuple(states)
        nv = len(compiled.variables)
        if states:
            arrs = [np.array([getattr(s, a) for s in states], dtype=float) for a in ("z", "z1", "z2", "z3")]
        else:
            arrs = [np.zeros((0, nv)) for _ in range(4)]
        self._init(compiled, *arrs, tuple(s.mode for s in states),
                   np.array([s.residual for s in states], dtype=float),
                   np.array([s.n_iter for s in states], dtype=int),
                   np.array([s.cond for s in states], dtype=float), tuple(events), mode, method, engine)
        if states:
            self._cache["states"] = states
            self._cache["points"] = np.array([s.points for s in states], dtype=float)

    def _init(self, compiled, z, z1, z2, z3, modes, residual, n_iter, cond, events, mode, method, engine="python",
              copy=True):
        put = object.__setattr__
        put(self, "compiled", compiled)
        for name, a in (("z", z), ("z1", z1), ("z2", z2), ("z3", z3), ("residual", residual),
                        ("n_iter", n_iter), ("cond", cond)):
            a = np.array(a, copy=True) if copy else np.asarray(a)
            a.setflags(write=False)
            put(self, name, a)
        put(self, "modes", tuple(modes))
        put(self, "events", tuple(events))
        put(self, "mode", mode)
        put(self, "method", method)
        put(self, "engine", engine)
        put(self, "_cache", {})

    @classmethod
    def from_arrays(cls, compiled, z, z1, z2, z3, *, modes, residual=None, n_iter=None, cond=None, events=(),
                    mode: str = "", method: str = "tracked", engine: str = "python", copy: bool = True,
                    turns=None) -> "Sweep":
        """A sweep from ``(N, nvar)`` arrays of positions and rates (internal units).

        ``copy=False`` takes the arrays as they are (the caller hands them over and must not
        keep writing to them); they are made read-only either way. ``turns`` (``(N, nvar)``
        integers, see :attr:`turns`) continues the angles of a longer sweep this one is a part of.
        """
        self = cls.__new__(cls)
        z = np.asarray(z, dtype=float).reshape(-1, len(compiled.variables))
        n = z.shape[0]
        self._init(compiled, z, z1, z2, z3, modes,
                   np.zeros(n) if residual is None else residual,
                   np.zeros(n, dtype=int) if n_iter is None else n_iter,
                   np.ones(n) if cond is None else cond, events, mode, method, engine, copy)
        if turns is not None:
            t = np.array(turns, dtype=np.int64).reshape(n, len(compiled.variables))
            t.setflags(write=False)
            self._cache["turns"] = t
        return self

    @property
    def turns(self) -> np.ndarray:
        """``(N, nvar)`` whole turns subtracted from each angle for display (0 for lengths and inputs).

        Chosen by :func:`angle_turns`: an unknown's angle is in (−180°, 180°] at the first row
        and follows the motion after it, so the rows never jump by a turn.
        """
        if "turns" not in self._cache:
            t, _ = turns_of(self.compiled, self.z)
            t.setflags(write=False)
            self._cache["turns"] = t
        return self._cache["turns"]

    def __setattr__(self, key, value):
        raise AttributeError(f"Sweep is immutable (cannot set {key!r})")

    def __repr__(self) -> str:
        return (f"Sweep({self.compiled.mechanism.name!r}, {len(self)} points, mode={self.mode!r}, "
                f"events={[e.kind.value for e in self.events]}, method={self.method!r})")

    @property
    def mechanism(self):
        return self.compiled.mechanism

    @property
    def input(self) -> str:
        return self.compiled.inputs[0]

    @property
    def points(self) -> np.ndarray:
        """``(N, 4, P, 2)``: position, velocity, acceleration, jerk of every point (computed on first use)."""
        if "points" not in self._cache:
            ck = self.compiled
            n = len(self)
            if not ck.points or n == 0:
                pts = np.zeros((n, 4, len(ck.points), 2))
            else:
                zs = [self.z.T, self.z1.T, self.z2.T, self.z3.T]
                pts = np.stack([np.broadcast_to(ck.point_values_v(k, *zs[: k + 1]).reshape(len(ck.points), 2, -1),
                                                (len(ck.points), 2, n)) for k in range(4)])
                pts = np.ascontiguousarray(np.moveaxis(pts, -1, 0))
            pts.setflags(write=False)
            self._cache["points"] = pts
        return self._cache["points"]

    @property
    def states(self) -> tuple[State, ...]:
        if "states" not in self._cache:
            pts = self.points
            turns = self.turns
            self._cache["states"] = tuple(
                State(self.compiled, self.z[i].copy(), self.z1[i].copy(), self.z2[i].copy(), self.z3[i].copy(),
                      pts[i].copy(), self.modes[i], float(self.residual[i]), int(self.n_iter[i]), float(self.cond[i]),
                      tuple(int(t) for t in turns[i]))
                for i in range(len(self)))
        return self._cache["states"]

    @property
    def columns(self) -> Mapping[str, np.ndarray]:
        """Column name → array of values in display units (NaN where undefined)."""
        if "columns" not in self._cache:
            ck = self.compiled
            out: dict[str, np.ndarray] = {}
            inputs = set(ck.inputs)
            order = list(ck.inputs) + [n for n in ck.variables if n not in inputs]
            turns = self.turns
            period = _period(ck)
            for name in order:
                i = ck.index(name)
                for k, (suffix, arr) in enumerate(zip(_SUFFIX, (self.z, self.z1, self.z2, self.z3))):
                    v = np.asarray(in_display_units(ck, name, k, arr[:, i], wrap=False), dtype=float)
                    if k == 0 and name not in inputs and ck.kinds[i] is Kind.ANGLE:
                        v = v - period * turns[:, i]  # continuous along the rows (angle_turns)
                    out[name + suffix] = v + 0.0
            pts = self.points
            for j, p in enumerate(ck.points):
                for c, axis in (("x", 0), ("y", 1)):
                    for k, suffix in enumerate(_SUFFIX):
                        out[f"{p}_{c}{suffix}"] = pts[:, k, j, axis] + 0.0
            if len(set(self.modes)) > 1:  # a sweep through limits: every row states its own mode
                out["mode"] = np.array(self.modes, dtype=object)
            for v in out.values():
                v.setflags(write=False)
            self._cache["columns"] = out
        return self._cache["columns"]

    @property
    def rows(self) -> list[dict[str, float]]:
        cols = self.columns
        keys = list(cols)
        lists = [cols[k].tolist() for k in keys]
        return [{k: v if k == "mode" else finite_or_none(v) for k, v in zip(keys, vals)} for vals in zip(*lists)]

    def __getitem__(self, key: str) -> np.ndarray:
        cols = self.columns
        try:
            return cols[key]
        except KeyError:
            raise ModelError(f"no column {key!r}; the columns are {', '.join(cols)}") from None

    def __len__(self) -> int:
        return int(self.z.shape[0])

    def __iter__(self) -> Iterator[State]:
        return iter(self.states)

    def units(self) -> dict[str, str]:
        return column_units(self.compiled)

    def to_json(self, *, indent: 'int | None' = 1) -> 'str':
        from .export import to_json

        return to_json(self, indent=indent)

    def to_csv(self) -> 'str':
        from .export import to_csv

        return to_csv(self)

    def plot(self, vars=None, *, output=None):
        """Stacked plots of the chosen variables: see :func:`loopsolve.output.plotting.plot_sweep`."""
        from ..output.plotting import plot_sweep

        return plot_sweep(self, vars, output=output)

    def animate(self, *, output, fps: 'float' = 20, progress=None, vectors: 'bool' = False, dpi: 'int' = 100,
                max_frames: 'int | None' = 3600) -> 'Path':
        """Animation of the linkage over the sweep: see :func:`loopsolve.output.plotting.animate`."""
        from ..output.plotting import animate

        return animate(self, output=output, fps=fps, progress=progress, vectors=vectors, dpi=dpi,
                       max_frames=max_frames)

    def to_html(self, vars=None, *, extra_series=None, title=None) -> 'str':
        """The interactive page of this sweep (self-contained HTML): see :func:`loopsolve.output.view.to_html`.

        Examples
        --------
        >>> sw = ls.load(ls.models_dir() / "thesis_crank_rocker.toml").sweep(0, 360, 30)
        >>> sw.to_html(["theta4"]).startswith("<!DOCTYPE html>")
        True
        """
        from ..output.view import to_html

        return to_html(self, vars, extra_series=extra_series, title=title)

    def view(self, vars=None, *, extra_series=None, title=None):
        """The interactive page, shown inline by Jupyter (the cell's value): see :class:`loopsolve.output.view.Page`.

        Takes the arguments of :meth:`to_html`; ``display(sw.view())`` shows it from the middle of a
        cell, ``sw.view().save("page.html")`` writes the file.

        Examples
        --------
        >>> sw = ls.load(ls.models_dir() / "thesis_crank_rocker.toml").sweep(0, 360, 30)
        >>> sw.view()  # doctest: +ELLIPSIS
        <loopsolve page, ... characters>
        """
        from ..output.view import Page, to_html

        return Page(to_html(self, vars, extra_series=extra_series, title=title))

    def _repr_html_(self):
        """Jupyter shows a sweep as its interactive page (its text repr when empty or longer than
        :data:`loopsolve.output.view.MAX_INLINE_ROWS` rows)."""
        from ..output.view import MAX_INLINE_ROWS, Page

        if not 0 < len(self) <= MAX_INLINE_ROWS:
            return None
        return Page(self.to_html())._repr_html_()
