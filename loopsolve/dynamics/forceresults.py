"""Immutable results of force analysis: :class:`ForceSweep` (one or many inputs) and :class:`Flywheel`.

A :class:`ForceSweep` wraps the kinematic :class:`~loopsolve.kinematics.results.Sweep` it was computed on and
adds, per point, the driving torque (or force), every joint force, the guide reactions, the shaking
force and moment, the kinetic and potential energy and the power-balance residual — all SI.
Its rows are the kinematic rows of the output contract followed by the force columns.
"""

from __future__ import annotations

import csv
import io
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..errors import ModelError
from ..kinematics.results import Event, EventKind, column_units, finite_or_none
from ..model.units import Kind

__all__ = ["ForceSweep", "Flywheel", "force_units"]


@dataclass(frozen=True)
class Flywheel:
    """Flywheel sizing from the driving-torque curve over one cycle at constant mean speed.

    Users receive one from ``ForceSweep.flywheel(cs)``; they need not construct one.

    Parameters
    ----------
    mean_torque, energy_fluctuation, inertia, speed, cs, at_max, at_min : float
        The attributes below, in this order.

    Attributes
    ----------
    mean_torque : float
        The mean driving torque over the cycle (N·m).
    energy_fluctuation : float
        ΔE, the largest swing of ∫(T − T_mean) dθ over the cycle (J).
    inertia : float
        The flywheel inertia ΔE / (C_s ω²) that keeps the speed within ``cs`` (kg·m²).
    speed : float
        ω, the mean speed (rad/s).
    cs : float
        The coefficient of speed fluctuation (ω_max − ω_min) / ω asked for.
    at_max, at_min : float
        The inputs (display units) of the largest and the smallest energy.

    Examples
    --------
    >>> import loopsolve as ls
    >>> mech = ls.load(ls.models_dir() / "thesis_crank_rocker_dynamics.toml")
    >>> fw = ls.forces(mech, 0, 360, 2, speed="300rpm").flywheel(0.02)
    >>> round(fw.energy_fluctuation, 4), round(fw.inertia, 6), round(fw.speed, 4)
    (0.0674, 0.003417, 31.4159)
    """

    mean_torque: float
    energy_fluctuation: float
    inertia: float
    speed: float
    cs: float
    at_max: float
    at_min: float

    def to_dict(self) -> dict:
        return {k: finite_or_none(getattr(self, k)) for k in ("mean_torque", "energy_fluctuation", "inertia", "speed",
                                                       "cs", "at_max", "at_min")}

    def units(self, angle_unit: str = "deg") -> dict[str, str]:
        """The unit of every field (``at_max``/``at_min`` in the model's angle unit)."""
        return {"mean_torque": "N*m", "energy_fluctuation": "J", "inertia": "kg*m^2", "speed": "rad/s", "cs": "1",
                "at_max": angle_unit, "at_min": angle_unit}

    def __str__(self) -> str:
        return (f"flywheel for C_s = {self.cs:g} at {self.speed:.6g} rad/s: mean torque {self.mean_torque:.6g} N*m, "
                f"energy fluctuation {self.energy_fluctuation:.6g} J (between inputs {self.at_min:g} and "
                f"{self.at_max:g}), flywheel inertia {self.inertia:.6g} kg*m^2")


def force_units(drive_name: str, columns) -> dict[str, str]:
    out = {}
    for c in columns:
        if c == drive_name:
            out[c] = "N*m" if c == "input_torque" else "N"
        elif c.startswith("M_") or c == "shaking_moment":
            out[c] = "N*m"
        elif c.startswith("F_") or c.startswith("shaking_force"):
            out[c] = "N"
        elif c.endswith("_energy"):
            out[c] = "J"
        elif c == "power_residual" or c.startswith("power_lost"):
            out[c] = "W"
    return out


class ForceSweep:
    """Force analysis along a sweep (or at one input: a one-row sweep). Immutable.

    Users receive force results from :func:`loopsolve.forces` (``mech.forces``); they need not
    construct one. The arrays run over the rows of the sweep; for a result at one input
    (``ls.forces(mech, 30)``: ``scalar`` is True) they are scalars and ``(2,)`` vectors, as
    :class:`State` gives. :meth:`units` names every unit.

    Parameters
    ----------
    sweep : Sweep
        The kinematic sweep the forces belong to.
    data : dict
        The computed arrays, by attribute name (see Attributes).
    scalar : bool, optional
        True for a result at one input: the attributes are then scalars and ``(2,)`` vectors.

    Attributes
    ----------
    sweep : Sweep
        The kinematic sweep.
    drive : numpy.ndarray
        The driving torque (N·m) or force (N) per row.
    joint_forces : dict
        ``F_<joint>`` → ``(N, 2)`` force (N, x and y) the joint transmits.
    guide_reactions : dict
        ``<body>_guide`` → ``(N, 3)``: the guide's force x, y (N) and couple (N·m).
    contact_forces : dict
        ``F_<pair>`` → ``(N, 3)``: the force along the gear's line of action (cam: along the
        normal; slot: the normal reaction), x and y on the pair's first body (N).
    shaking_force : numpy.ndarray
        ``(N, 2)`` force on the ground frame (N).
    shaking_moment : numpy.ndarray
        Moment on the ground frame (N·m).
    kinetic_energy, potential_energy : numpy.ndarray
        Energies (J).
    power_residual : numpy.ndarray
        Driving power − (dE/dt − loads' power) (W): round-off for consistent declarations.
    singular : numpy.ndarray
        True where the Newton–Euler system is singular (the forces are NaN there).
    condition : numpy.ndarray
        Condition number of the Newton–Euler system per row (large near a dead centre, where a
        warning is issued).
    events : tuple of Event
        The sweep's events (and self-locking positions with friction).
    scalar : bool
        True for a result at one input.

    Examples
    --------
    >>> import loopsolve as ls
    >>> mech = ls.load(ls.models_dir() / "thesis_crank_rocker_dynamics.toml")
    >>> fs = ls.forces(mech, 0, 360, 90, speed="60rpm")
    >>> [round(float(t), 3) for t in fs.drive], fs.units()["drive"]
    ([-0.036, 0.03, 0.011, -0.013, -0.036], 'N*m')
    >>> list(fs.joint_forces), fs.joint_forces["F_B"].shape
    (['F_O2', 'F_B', 'F_C', 'F_O4'], (5, 2))
    >>> one = ls.forces(mech, 30, speed="60rpm")
    >>> one.scalar, round(float(one.drive), 4)
    (True, 0.0133)
    """

    __slots__ = ("sweep", "drive", "drive_name", "joint_forces", "guide_reactions", "contact_forces", "power_lost",
                 "shaking_force",
                 "shaking_moment", "kinetic_energy", "potential_energy", "power_residual", "singular",
                 "condition", "events", "scalar", "_arrays", "_cache")

    def __init__(self, sweep, data: Mapping, *, scalar: bool = False):
        put = object.__setattr__
        ck = sweep.compiled
        put(self, "sweep", sweep)
        kind = ck.kinds[ck.index(ck.inputs[0])]
        put(self, "drive_name", "input_torque" if kind is Kind.ANGLE else "input_force")
        scalar = bool(scalar) and len(sweep) == 1
        put(self, "scalar", scalar)
        arrays: dict = {}
        for name in ("drive", "shaking_force", "shaking_moment", "kinetic_energy", "potential_energy",
                     "power_residual", "singular"):
            arrays[name] = _ro(data[name])
        arrays["condition"] = _ro(data.get("kappa", np.ones(len(arrays["drive"]))))
        arrays["joint_forces"] = {k: _ro(v) for k, v in data["pins"].items()}
        arrays["guide_reactions"] = {k: _ro(v) for k, v in data["guides"].items()}
        arrays["contact_forces"] = {k: _ro(v) for k, v in data.get("contacts", {}).items()}
        arrays["power_lost"] = {k: _ro(np.broadcast_to(np.asarray(v, dtype=float), arrays["drive"].shape))
                                for k, v in data.get("power_lost", {}).items()}
        put(self, "_arrays", arrays)
        for name, a in arrays.items():  # one input: scalars (and (2,) vectors), as State gives
            if isinstance(a, dict):
                put(self, name, {k: (_ro(v[0]) if scalar else v) for k, v in a.items()})
            elif scalar:
                put(self, name, a[0] if a.ndim == 1 else _ro(a[0]))
            else:
                put(self, name, a)
        events = list(sweep.events)
        sing = np.flatnonzero(arrays["singular"])
        xs = sweep[ck.inputs[0]] if sing.size else None
        nonfinite = np.asarray(data.get("nonfinite", np.zeros(len(arrays["singular"]), dtype=bool)))
        locked = np.asarray(data.get("self_locking", np.zeros(len(arrays["singular"]), dtype=bool)))
        if locked.any():
            xl = sweep[ck.inputs[0]]
            for i in np.flatnonzero(locked)[:20]:
                events.append(Event(EventKind.SELF_LOCKING, float(xl[i]),
                                    "self-locking: with the friction of the joints no driving "
                                    f"{'torque' if kind is Kind.ANGLE else 'force'} can move the mechanism here "
                                    "in this direction (the forces are undefined: NaN)"))
        for i in sing[:20]:
            if nonfinite[i]:
                why = ("a load, mass property or rate is not a finite number here (NaN or infinite: check the "
                       "[[loads]] expressions' domain): the joint forces and the driving torque are undefined (NaN)")
            else:
                why = ("the Newton–Euler system is singular here (a dead centre for the forces): the joint "
                       "forces and the driving torque are undetermined (NaN)")
            events.append(Event(EventKind.SINGULAR, float(xs[i]), why))
        put(self, "events", tuple(events))
        put(self, "_cache", {})

    def __setattr__(self, key, value):
        raise AttributeError(f"ForceSweep is immutable (cannot set {key!r})")

    def __len__(self) -> int:
        return len(self.sweep)

    def __repr__(self) -> str:
        return f"ForceSweep({self.mechanism.name!r}, {len(self)} points, joints={list(self.joint_forces)})"

    @property
    def mechanism(self):
        return self.sweep.mechanism

    @property
    def input(self) -> str:
        return self.sweep.input

    @property
    def mode(self) -> str:
        return self.sweep.mode

    @property
    def force_columns(self) -> Mapping[str, np.ndarray]:
        """The force columns only (SI), in contract order."""
        if "force" not in self._cache:
            a = self._arrays
            out: dict[str, np.ndarray] = {self.drive_name: a["drive"]}
            for name, f in a["joint_forces"].items():
                out[f"{name}_x"], out[f"{name}_y"] = f[:, 0], f[:, 1]
            for name, f in a["guide_reactions"].items():
                out[f"F_{name}_x"], out[f"F_{name}_y"], out[f"M_{name}"] = f[:, 0], f[:, 1], f[:, 2]
            for name, f in a["contact_forces"].items():  # higher pairs: along the line of action / normal, x, y
                out[name], out[f"{name}_x"], out[f"{name}_y"] = f[:, 0], f[:, 1], f[:, 2]
            out["shaking_force_x"], out["shaking_force_y"] = a["shaking_force"][:, 0], a["shaking_force"][:, 1]
            out["shaking_moment"] = a["shaking_moment"]
            out["kinetic_energy"], out["potential_energy"] = a["kinetic_energy"], a["potential_energy"]
            if a["power_lost"]:  # friction: the power each joint dissipates, and their sum
                for name, p in a["power_lost"].items():
                    out[f"power_lost_{name}"] = p
                out["power_lost"] = sum(a["power_lost"].values())
            out["power_residual"] = a["power_residual"]
            self._cache["force"] = out
        return self._cache["force"]

    @property
    def columns(self) -> Mapping[str, np.ndarray]:
        """Kinematic columns (display units) then the force columns (SI)."""
        return {**self.sweep.columns, **self.force_columns}

    def __getitem__(self, key: str) -> np.ndarray:
        """A column (array), or for a result at one input (``scalar``) its value, as ``State[key]``."""
        cols = self.columns
        try:
            col = cols[key]
        except KeyError:
            raise ModelError(f"no column {key!r}; the columns are {', '.join(cols)}") from None
        if self.scalar:
            return col[0] if key == "mode" else float(col[0])
        return col

    @property
    def rows(self) -> list[dict]:
        cols = self.columns
        keys = list(cols)
        lists = [list(cols[k]) if k == "mode" else np.asarray(cols[k], dtype=float).tolist() for k in keys]
        return [{k: (str(v) if k == "mode" else finite_or_none(v)) for k, v in zip(keys, vals)} for vals in zip(*lists)]

    def units(self) -> dict[str, str]:
        """Unit of every column, and of the attributes (``drive``, ``joint_forces``, ...): SI."""
        drive = "N*m" if self.drive_name == "input_torque" else "N"
        attrs = {"drive": drive, "joint_forces": "N", "guide_reactions": "N, N, N*m", "contact_forces": "N",
                 "power_lost": "W",
                 "shaking_force": "N",
                 "shaking_moment": "N*m", "kinetic_energy": "J", "potential_energy": "J", "power_residual": "W",
                 "condition": "1"}
        return {**column_units(self.sweep.compiled), **force_units(self.drive_name, self.force_columns), **attrs}

    # ------------------------------------------------------------------ outputs
    def to_json(self, *, indent: int | None = 1, flywheel: Flywheel | None = None) -> str:
        ck = self.sweep.compiled
        u = ck.mechanism.units
        doc = {"mechanism": ck.mechanism.name, "input": ck.inputs[0],
               "units": {"length": u.length, "angle": u.angle, **self.units()}, "mode": self.mode,
               "rows": self.rows, "events": [e.to_dict() for e in self.events]}
        if flywheel is not None:
            doc["flywheel"] = flywheel.to_dict()
        return json.dumps(doc, indent=indent, allow_nan=False)

    def to_csv(self) -> str:
        units = self.units()
        rows = self.rows
        keys = list(self.columns)
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow([f"{k} [{units[k]}]" if units.get(k) else k for k in keys])
        for r in rows:
            w.writerow([r[k] if k == "mode" else "" if r[k] is None else repr(float(r[k])) for k in keys])
        return buf.getvalue()

    def table(self) -> str:
        """A readable table: one input in sections, a sweep as one wide table of the force columns."""
        ck = self.sweep.compiled
        units = self.units()
        inp = ck.inputs[0]
        xs = self.sweep[inp]
        fc = self.force_columns
        if len(self) == 1:
            row = {k: float(v[0]) for k, v in fc.items()}
            vel = float(self.sweep[inp + "_vel"][0])
            acc = float(self.sweep[inp + "_acc"][0])
            cu = column_units(ck)
            lines = [f"{ck.mechanism.name}: {inp} = {xs[0]:g} {cu[inp]}, speed {vel:g} {cu[inp + '_vel']}, "
                     f"accel {acc:g} {cu[inp + '_acc']} (mode {self.mode})",
                     f"driving {'torque' if self.drive_name == 'input_torque' else 'force'}: "
                     f"{_f(row[self.drive_name])} {units[self.drive_name]}", "",
                     f"{'joint force (on first body, from other)':<42}{'F_x [N]':>14}{'F_y [N]':>14}{'|F| [N]':>14}"]
            for name, f in self._arrays["joint_forces"].items():
                fx, fy = f[0]
                lines.append(f"{name:<42}{_f(fx):>14}{_f(fy):>14}{_f(math.hypot(fx, fy)):>14}")
            for name, f in self._arrays["guide_reactions"].items():
                lines.append(f"{'F_' + name:<42}{_f(f[0, 0]):>14}{_f(f[0, 1]):>14}{_f(math.hypot(f[0, 0], f[0, 1])):>14}"
                             f"   couple {_f(f[0, 2])} N*m")
            lines += ["", f"shaking force: ({_f(row['shaking_force_x'])}, {_f(row['shaking_force_y'])}) N, "
                      f"shaking moment {_f(row['shaking_moment'])} N*m (about the origin)",
                      f"kinetic energy {_f(row['kinetic_energy'])} J, potential energy {_f(row['potential_energy'])} J, "
                      f"power-balance residual {_f(row['power_residual'])} W"]
            for e in self.events:
                lines.append(f"{e.kind.value} at {inp} = {e.input:.10g}: {e.message}")
            return "\n".join(lines) + "\n"
        keys = [inp] + list(fc)
        cols = {inp: xs, **fc}
        allu = {**column_units(ck), **units}
        headers = [f"{k} [{allu.get(k, '')}]" for k in keys]
        widths = [max(len(h), 12) for h in headers]
        out = [f"{ck.mechanism.name}: forces along {inp} ({len(self)} rows, mode {self.mode})",
               "  ".join(h.rjust(w) for h, w in zip(headers, widths))]
        for i in range(len(self)):
            out.append("  ".join(_f(float(cols[k][i])).rjust(w) for k, w in zip(keys, widths)))
        for e in self.events:
            out.append(f"{e.kind.value} at {inp} = {e.input:.10g}: {e.message}")
        return "\n".join(out) + "\n"

    # ------------------------------------------------------------------ analysis
    def flywheel(self, cs: float) -> Flywheel:
        """Size a flywheel for the coefficient of speed fluctuation ``cs`` (see :class:`Flywheel`).

        The sweep must cover one full cycle (360°, or 720° for a four-stroke engine) of an angle
        input at constant nonzero speed. The energy fluctuation is that of the continuous torque
        curve (a periodic cubic spline through the rows, the extrema of ∫(T − T_mean) located where
        it crosses T_mean), not of the output grid.
        """
        return flywheel(self, cs)

    def plot_torque(self, **kwargs):
        """Driving torque against the input: see :func:`loopsolve.output.forceplots.plot_drive`."""
        from ..output.forceplots import plot_drive

        return plot_drive(self, **kwargs)

    def plot_joint_forces(self, **kwargs):
        """Polar plots of the joint forces: see :func:`loopsolve.output.forceplots.plot_joint_forces`."""
        from ..output.forceplots import plot_joint_forces

        return plot_joint_forces(self, **kwargs)

    def plot_shaking(self, **kwargs):
        """Polar plot of the shaking force: see :func:`loopsolve.output.forceplots.plot_shaking`."""
        from ..output.forceplots import plot_shaking

        return plot_shaking(self, **kwargs)


def _ro(a):
    a = np.array(a)
    a.setflags(write=False)
    return a


def _f(v: float) -> str:
    return "nan" if not math.isfinite(v) else f"{v + 0.0:.6g}"


def flywheel(fs: ForceSweep, cs: float) -> Flywheel:
    """Flywheel inertia for a coefficient of speed fluctuation ``cs`` from a one-cycle force sweep.

    Examples
    --------
    >>> mech = ls.load(ls.models_dir() / "thesis_crank_rocker_dynamics.toml")
    >>> fw = ls.forces(mech, 0, 360, 2, speed="300rpm").flywheel(0.02)
    >>> fw.inertia > 0
    True
    """
    ck = fs.sweep.compiled
    inp = ck.inputs[0]
    if fs.drive_name != "input_torque":
        raise ModelError("flywheel sizing needs a crank (an angle input)")
    if not cs > 0:
        raise ModelError(f"the coefficient of speed fluctuation must be positive, got {cs!r}")
    i = ck.index(inp)
    x = fs.sweep.z[:, i]
    w = fs.sweep.z1[:, i]
    if len(x) < 3 or not np.all(np.isfinite(fs._arrays["drive"])):
        raise ModelError("flywheel sizing needs the driving torque at every point of a full cycle "
                         "(the sweep has singular points or too few rows)")
    if np.ptp(w) > 1e-9 * max(abs(w[0]), 1e-300) or w[0] == 0:
        raise ModelError("flywheel sizing needs a sweep at constant nonzero speed (--speed, no --accel)")
    span = abs(x[-1] - x[0])
    if min(abs(span - 2 * math.pi), abs(span - 4 * math.pi)) > 1e-6:
        raise ModelError(f"flywheel sizing needs one full cycle of {inp!r}: one turn (e.g. --from 0 --to 360) or "
                         f"two for a four-stroke engine (--to 720); this sweep spans {math.degrees(span):.6g} degrees")
    from scipy.interpolate import CubicSpline

    T = np.array(fs._arrays["drive"], dtype=float)
    order = np.argsort(x)
    xo, To = x[order], T[order]
    # the torque is periodic over the cycle: a periodic cubic spline through the rows is the
    # continuous curve (error O(h^4)); its antiderivative is the work, exactly integrated, and the
    # extrema of the energy E = ∫(T − T_mean) are located where the curve crosses T_mean
    To[-1] = To[0] = 0.5 * (To[0] + To[-1])
    spline = CubicSpline(xo, To, bc_type="periodic")
    work = spline.antiderivative()
    mean = float((work(xo[-1]) - work(xo[0])) / (xo[-1] - xo[0]))
    roots = spline.solve(mean, extrapolate=False)
    cand = np.unique(np.concatenate([xo, roots[np.isfinite(roots)]]))
    energy = work(cand) - work(xo[0]) - mean * (cand - xo[0])
    dE = float(energy.max() - energy.min())
    omega = abs(float(w[0]))
    from ..kinematics.results import in_display_units

    def shown(v):
        return float(in_display_units(ck, inp, 0, v, wrap=False))

    return Flywheel(mean, dE, dE / (cs * omega**2), omega, float(cs),
                    shown(cand[int(np.argmax(energy))]), shown(cand[int(np.argmin(energy))]))
