"""Declarations: parameters, joint variables, vectors, loops, points and the Mechanism.

A :class:`Mechanism` is a frozen, validated declaration. It is built in one place,
:func:`loopsolve.model.spec.build_mechanism`, from a plain ``dict`` shaped like the TOML model file;
both front doors (the model file, :mod:`loopsolve.model.modelfile`, and the Python
:class:`loopsolve.model.builder.MechanismBuilder`) go through it, so they give identical declarations
and identical derivations.

Unit conventions
----------------
Inside the library angles are radians and lengths are in the model's length unit. Expressions
in a model are read like a calculator set to the model's angle unit: angle symbols and the
arguments of ``sin``/``cos``/``tan`` are in that unit, and an ``angle`` field is in that unit.
In a degree model ``angle = "theta4 + 30"`` is θ4 + 30°. Because ``pi`` would silently mean
π degrees there, ``pi`` is rejected in angle context of a degree model.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from . import expr as _expr
from .bodies import Dynamics
from ..errors import ModelError
from .units import Kind

__all__ = ["Units", "Parameter", "Variable", "Vector", "Loop", "Point", "Mechanism"]


@dataclass(frozen=True, slots=True)
class Units:
    """Display units of a model: ``length`` (e.g. ``"mm"``) and ``angle`` (``"deg"``/``"rad"``)."""

    length: str = "mm"
    angle: str = "deg"


@dataclass(frozen=True, slots=True)
class Parameter:
    """A named constant. ``value`` is in internal units (radians for angles)."""

    name: str
    value: float
    kind: Kind
    text: str = ""


@dataclass(frozen=True, slots=True)
class Variable:
    """A joint variable (an angle or a length).

    ``guess``, ``speed``, ``accel`` and ``jerk`` are in internal units (radians, rad/s...)
    or ``None`` when not given. ``input`` marks the declared input.
    """

    name: str
    kind: Kind
    guess: float | None = None
    input: bool = False
    speed: float | None = None
    accel: float | None = None
    jerk: float | None = None


@dataclass(frozen=True, slots=True)
class Vector:
    """A vector of the loops: polar (``length``, ``angle`` [+ ``offset``]) or Cartesian (``x``, ``y``).

    The fields are parsed expressions (:mod:`loopsolve.model.expr` trees) in model units.
    """

    name: str
    length: _expr.Node | None = None
    angle: _expr.Node | None = None
    offset: _expr.Node | None = None
    x: _expr.Node | None = None
    y: _expr.Node | None = None

    @property
    def cartesian(self) -> bool:
        return self.x is not None


@dataclass(frozen=True, slots=True)
class Loop:
    """A vector loop ``Σ sign·vector = 0`` (left side minus right side of the equation)."""

    name: str
    terms: tuple[tuple[int, str], ...]
    text: str
    lhs: tuple[tuple[int, str], ...] = ()
    rhs: tuple[tuple[int, str], ...] = ()


@dataclass(frozen=True, slots=True)
class Point:
    """A point of interest: a sum of vectors with optional scalar factors, from the origin.

    ``terms`` are the signed vector names; ``factors`` (same length, or empty when every factor
    is 1) holds for each term its scalar factor as a parsed expression of numbers and parameters,
    or ``None`` for a factor of 1 (``G3 = "r2 + 0.5*r3"`` has terms ``((1, 'r2'), (1, 'r3'))``
    and factors ``(None, Num(0.5))``). ``"0"`` is the origin (no terms).
    """

    name: str
    terms: tuple[tuple[int, str], ...]
    text: str
    factors: tuple = ()

    def factor(self, i: int):
        """The factor of term ``i`` (``None`` for 1)."""
        return self.factors[i] if self.factors else None

    @property
    def plain(self) -> bool:
        """True when every factor is 1 (the point is a walk along whole vectors)."""
        return not any(f is not None for f in self.factors)


@dataclass(frozen=True)
class Mechanism:
    """A validated, immutable mechanism declaration.

    Build one with :func:`loopsolve.load` (model file), :class:`MechanismBuilder` (Python) or
    the factories of :mod:`loopsolve.kinematics.classic`. The methods are thin doors to the pipeline
    stages (derive, compile, solve, sweep, export); nothing is ever written back onto the
    declaration.

    The constructor takes already-validated parts: build a mechanism with :func:`loopsolve.load`,
    :func:`loopsolve.loads`, :func:`loopsolve.build_mechanism` or :class:`MechanismBuilder`,
    which validate a declaration and give these fields back as attributes of the same names.

    Parameters
    ----------
    name : str
        The mechanism's name.
    units : Units
        Length and angle units of the declaration.
    parameters, variables, vectors, loops, points : tuple
        The declared parameters, joint variables, vectors, vector loops and output points.
    source : str, optional
        The model file it came from.
    spec : dict, optional
        The validated declaration as a dict (what :func:`loopsolve.dumps` writes).
    mode_aliases : dict, optional
        Names of assembly modes (``{"open": "-"}``).
    dynamics : Dynamics, optional
        Bodies, masses and loads, when declared.
    pairs : object, optional
        Higher pairs (gears, cams, slots...), when declared.

    Examples
    --------
    >>> mech = ls.fourbar(r1=60, r2=25, r3=70, r4=45, name="thesis")
    >>> mech.inputs, mech.unknowns()
    (('theta2',), ('theta3', 'theta4'))
    """

    name: str
    units: Units
    parameters: tuple[Parameter, ...]
    variables: tuple[Variable, ...]
    vectors: tuple[Vector, ...]
    loops: tuple[Loop, ...]
    points: tuple[Point, ...] = ()
    source: str | None = None
    spec: Mapping[str, Any] = field(default_factory=dict, compare=False, repr=False)
    mode_aliases: Mapping[str, str] = field(default_factory=dict, compare=False)
    dynamics: Dynamics | None = field(default=None, compare=False, repr=False)
    #: gears, cams, slots, rolling contacts, constraints and friction (:mod:`loopsolve.model.pairs`)
    pairs: Any = field(default=None, repr=False)

    # ----------------------------------------------------------------- lookups
    @property
    def n_equations(self) -> int:
        """Scalar equations of Φ: two per loop and one per constraint, gear pair, cam, slot or rolling contact."""
        return 2 * len(self.loops) + (self.pairs.n_rows if self.pairs is not None else 0)

    @property
    def equation_names(self) -> tuple[str, ...]:
        """The name of every row of Φ: ``<loop>.x``, ``<loop>.y``, then ``<section>.<name>`` of each higher pair."""
        names = tuple(f"{lp.name}.{c}" for lp in self.loops for c in "xy")
        return names + (self.pairs.row_names if self.pairs is not None else ())

    @property
    def inputs(self) -> tuple[str, ...]:
        """Names of the declared input variables."""
        return tuple(v.name for v in self.variables if v.input)

    def variable(self, name: str) -> Variable:
        for v in self.variables:
            if v.name == name:
                return v
        raise ModelError(
            f"unknown variable {name!r} in {self.name!r}; the variables are "
            + ", ".join(v.name for v in self.variables)
        )

    def vector(self, name: str) -> Vector:
        for v in self.vectors:
            if v.name == name:
                return v
        raise ModelError(f"unknown vector {name!r} in {self.name!r}")

    def resolve_inputs(self, input: str | Sequence[str] | None = None) -> tuple[str, ...]:
        """The input variables for a solve: ``input`` when given, else the declared ones.

        Raises :class:`ModelError` for an unknown name or a count that does not leave as many
        unknowns as scalar loop equations.
        """
        if input is None:
            names = self.inputs
        elif isinstance(input, str):
            names = (input,)
            declared = self.inputs
            if len(declared) > 1:  # keep the other declared inputs held
                if input in declared:  # drive this one, hold the others
                    names = (input,) + tuple(n for n in declared if n != input)
                else:  # replaces the first declared input
                    names = (input,) + tuple(declared[1:])
        else:
            names = tuple(input)
        for n in names:
            self.variable(n)
        if len(set(names)) != len(names):
            raise ModelError(f"input {names} names a variable twice")
        n_eq = self.n_equations
        n_unknown = len(self.variables) - len(names)
        if not names:
            raise ModelError(
                f"{self.name!r} declares no input: mark one variable with `input = true` "
                "in [variables] or pass --input NAME"
            )
        if n_unknown != n_eq:
            raise ModelError(
                f"{self.name!r} with input(s) {', '.join(names)} has {n_unknown} unknowns but "
                f"{n_eq} scalar {'loop ' if n_eq == 2 * len(self.loops) else 'loop and higher-pair '}equations "
                f"({len(self.loops)} loop(s)"
                + (f", {self.pairs.n_rows} higher pair(s)" if n_eq != 2 * len(self.loops) else "")
                + f"); a single-DOF mechanism needs exactly {len(self.variables) - n_eq} input(s)"
            )
        return names

    def unknowns(self, input: str | Sequence[str] | None = None) -> tuple[str, ...]:
        """Names of the unknown variables when ``input`` drives the mechanism."""
        ins = self.resolve_inputs(input)
        return tuple(v.name for v in self.variables if v.name not in ins)

    # ----------------------------------------------------------- pipeline doors
    def derive(self, input: str | Sequence[str] | None = None):
        """Symbolic derivation (sympy): see :func:`loopsolve.derive`."""
        from ..symbolic.loop_equations import derive

        return derive(self, input=input)

    def derive_dynamics(self, input: str | None = None):
        """The equation of motion in symbols (M, M′, Q and their values): see :func:`loopsolve.derive_dynamics`."""
        from ..dynamics.eom import derive_dynamics

        return derive_dynamics(self, input=input)

    def compile(self, input: str | Sequence[str] | None = None, *, cache: bool = True):
        """Compiled numeric kinematics: see :func:`loopsolve.compile_mechanism`."""
        from ..symbolic.compiled import compile_mechanism

        ck = compile_mechanism(self, input=input, cache=cache)
        if self.mode_aliases and tuple(ck.inputs) == self.inputs:  # also when the code came from the cache
            bad = [f"modes.{a} = {sig!r}" for a, sig in self.mode_aliases.items() if len(sig) != len(ck.blocks)]
            if bad:
                raise ModelError(f"{self.source or self.name}: {'; '.join(bad)}: a mode signature of this model "
                                 f"has {len(ck.blocks)} sign(s), one per diagonal block of the Jacobian")
        return ck

    def solve(self, at=None, *, speed=None, accel=None, jerk=None, input: 'str | None' = None,
              guess: 'dict | None' = None, mode: 'str | None' = None, compiled: 'CompiledKinematics | None' = None,
              settings: 'Newton | None' = None) -> 'State':
        """Positions and rates at one input value: see :func:`loopsolve.solve`."""
        from ..kinematics.solve import solve

        return solve(self, at, speed=speed, accel=accel, jerk=jerk, input=input, guess=guess, mode=mode,
                     compiled=compiled, settings=settings)

    def sweep(self, start, stop, step, *, speed=None, accel=None, jerk=None, input: 'str | None' = None,
              mode: 'str | None' = None, guess: 'dict | None' = None, compiled=None, through_limits: 'bool' = False,
              progress: 'bool | None' = None, method: 'str' = 'auto', derivatives: 'int' = 3,
              control: 'StepControl | None' = None, settings: 'Newton | None' = None, max_rows: 'int' = 1000000,
              limit_rows: 'bool' = False, engine: 'str | None' = None) -> 'Sweep':
        """Sweep the input: see :func:`loopsolve.sweep`."""
        from ..kinematics.sweep import sweep

        return sweep(self, start, stop, step, speed=speed, accel=accel, jerk=jerk, input=input, mode=mode,
                     guess=guess, compiled=compiled, through_limits=through_limits, progress=progress,
                     method=method, derivatives=derivatives, control=control, settings=settings, max_rows=max_rows,
                     limit_rows=limit_rows, engine=engine)

    def forces(self, at=None, stop=None, step=None, *, speed=None, accel=None, input=None, mode=None,
               through_limits: 'bool' = False, progress=False, method: 'str' = 'auto'):
        """Driving torque, joint forces, shaking force, energies: see :func:`loopsolve.forces`."""
        from ..dynamics.kinetostatics import forces

        return forces(self, at, stop, step, speed=speed, accel=accel, input=input, mode=mode,
                      through_limits=through_limits, progress=progress, method=method)

    def simulate(self, duration: 'float', *, step: 'float' = 0.01, torque=0.0, speed0=None, at=None, input=None,
                 mode=None, rtol: 'float' = 1e-11, atol: 'float' = 1e-12, method: 'str' = 'DOP853',
                 max_steps: 'int | None' = None) -> 'Simulation':
        """Integrate the equation of motion: see :func:`loopsolve.simulate`."""
        from ..dynamics.simulation import simulate

        return simulate(self, duration, step=step, torque=torque, speed0=speed0, at=at, input=input, mode=mode,
                        rtol=rtol, atol=atol, method=method, max_steps=max_steps)

    def modes(self, at=None, *, input: 'str | None' = None, compiled=None) -> 'tuple[Mode, ...]':
        """Every real assembly mode at one input: see :func:`loopsolve.kinematics.modes.assembly_modes`."""
        from ..kinematics.modes import assembly_modes

        return assembly_modes(self, at, input=input, compiled=compiled)

    def to_latex(self, *, input: 'str | Sequence[str] | None' = None, at=None, snippet: 'bool' = False,
                 inline: 'bool' = False) -> 'str':
        """The derivation as a LaTeX document: see :func:`loopsolve.output.latex.to_latex`."""
        from ..output.latex import to_latex

        return to_latex(self, input=input, at=at, snippet=snippet, inline=inline)

    def info(self, *, input=None, reach: 'bool' = True) -> 'dict':
        """Structure summary (mobility, loops, blocks...): see :func:`loopsolve.kinematics.info.info`."""
        from ..kinematics.info import info

        return info(self, input=input, reach=reach)

    def draw(self, at=None, *, input=None, mode=None, vectors=False, output=None, ax=None, **solve_kwargs):
        """The kinematic diagram at one input: see :func:`loopsolve.output.plotting.draw`."""
        from ..output.plotting import draw

        return draw(self, at, input=input, mode=mode, vectors=vectors, output=output, ax=ax, **solve_kwargs)

    def with_parameters(self, **values: float) -> "Mechanism":
        """A copy with some parameter values replaced (numbers in the model's units)."""
        spec = deep_copy(self.spec)
        params = spec.setdefault("parameters", {})
        for k, v in values.items():
            if k not in params:
                raise ModelError(f"unknown parameter {k!r} in {self.name!r}")
            params[k] = v
        from .spec import build_mechanism

        return build_mechanism(spec, source=self.source)

    def _repr_latex_(self) -> str:
        from ..output.latex import to_latex

        return "$\\displaystyle " + to_latex(self, snippet=True, inline=True) + "$"


def deep_copy(obj):
    """A copy of a model dict: its mappings and lists copied at every level, other values shared."""
    if isinstance(obj, Mapping):
        return {k: deep_copy(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [deep_copy(v) for v in obj]
    return obj
