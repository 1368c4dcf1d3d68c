"""loopsolve: kinematics of planar mechanisms from their vector loops.

Declare a mechanism (a TOML model file or the Python builder), and loopsolve derives the
loop-closure equations with sympy, compiles them once, solves positions by Newton with branch
tracking, and gives velocities, accelerations and jerks, sweeps, plots and the LaTeX derivation.

>>> import loopsolve as ls
>>> mech = ls.load(ls.models_dir() / "thesis_crank_rocker.toml")
>>> round(mech.solve(90)["theta4"], 2)
80.72
"""

__version__ = "0.1.0"

from . import errors
from . import _moved

_moved.install()  # old module paths (loopsolve.design.synthesis.classical.burmester, ...) still import, with a warning
from .model import bodies, diagram, expr, topology, units  # noqa: E402
from .kinematics import newton  # noqa: E402
from .errors import (  # noqa: E402
    AssemblyError,
    ModeError,
    BranchError,
    ConvergenceError,
    LoopsolveError,
    LoopsolveWarning,
    MissingDependencyError,
    PowerBalanceError,
    ModelError,
    ModelFileError,
    SingularPositionError,
    SolveError,
    SynthesisError,
    TopologyError,
)
from .model.factories import fourbar, inverted_slider_crank, slider_crank  # noqa: E402
from .model.builder import MechanismBuilder  # noqa: E402
from .model.mechanism import Mechanism  # noqa: E402
from .model.spec import build_mechanism  # noqa: E402
from .model.modelfile import dumps, load, loads, models_dir  # noqa: E402
from .kinematics.results import Event, EventKind, State, Sweep  # noqa: E402

# the submodules solve and sweep are loaded before the functions of the same names are defined
# below, so that importing them later cannot replace ``loopsolve.kinematics.solve``/``loopsolve.kinematics.sweep``
from .kinematics import solve as _solve_module  # noqa: E402, F401
from .kinematics import sweep as _sweep_module  # noqa: E402, F401
from .design.synthesis.classical import freudenstein as _freudenstein_module  # noqa: E402, F401
from .design.synthesis.classical import burmester as _burmester_module  # noqa: E402, F401
from .design.atlas.build import build_atlas, open_atlas  # noqa: E402  (the implementation is the public door)


def derive(mech, input=None):
    """The symbolic derivation: Φ, the coefficient matrix Φ_q and b₁, b₂, b₃ as sympy objects.

    Imports sympy (the solvers never do: they run the compiled code).

    Parameters
    ----------
    mech : Mechanism
        The mechanism.
    input : str, optional
        Derive for this input variable instead of the declared one.

    Returns
    -------
    Kinematics
        ``phi``, ``jac`` (Φ_q), ``b1``, ``b2``, ``b3``, the unknowns ``q`` and the points.

    Examples
    --------
    >>> kin = ls.derive(ls.load(ls.models_dir() / "thesis_crank_rocker.toml"))
    >>> kin.jac.shape
    (2, 2)
    """
    from .symbolic.loop_equations import derive as _derive

    return _derive(mech, input=input)


def derive_dynamics(mech, input=None):
    """The equation of motion M(x)ẍ + ½M′(x)ẋ² = Q + T in symbols (imports sympy).

    Parameters
    ----------
    mech : Mechanism
        A mechanism with ``[bodies]`` (and optionally ``gravity`` and ``[[loads]]``).
    input : str, optional
        Derive for this input variable instead of the declared one.

    Returns
    -------
    Dynamics
        ``M``, ``dM``, ``Q`` (sympy, SI), ``values`` (the numbers of the symbols), ``subs``,
        ``compact`` and ``coefficients``; see :doc:`/explanation/forces`.

    Examples
    --------
    >>> d = ls.derive_dynamics(ls.load(ls.models_dir() / "thesis_crank_rocker_dynamics.toml"))
    >>> sorted(str(s) for s in d.M.free_symbols)[:2]
    ['I_coupler', 'I_crank']
    """
    from .dynamics.eom import derive_dynamics as _derive_dynamics

    return _derive_dynamics(mech, input=input)


def compile_mechanism(mech, input=None, *, cache=True):
    """The mechanism's equations compiled to numpy code (cached on disk, checked before it runs).

    Parameters
    ----------
    mech : Mechanism
        The mechanism.
    input : str, optional
        Compile for this input variable instead of the declared one.
    cache : bool, default True
        Read and write the disk cache (``$LOOPSOLVE_CACHE_DIR``).

    Returns
    -------
    CompiledKinematics
        What :func:`solve`, :func:`sweep` and the others take as ``compiled=``.

    Examples
    --------
    >>> ck = ls.compile_mechanism(ls.load(ls.models_dir() / "thesis_crank_rocker.toml"))
    >>> ck.unknowns
    ('theta3', 'theta4')
    """
    from .symbolic.compiled import compile_mechanism as _compile

    return _compile(mech, input=input, cache=cache)


def solve(mech: 'Mechanism', at=None, *, speed=None, accel=None, jerk=None, input: 'str | None' = None,
          guess: 'dict | None' = None, mode: 'str | None' = None, compiled: 'CompiledKinematics | None' = None,
          settings: 'Newton | None' = None) -> 'State':
    """Solve one position, with velocities, accelerations and jerks.

    The same as :meth:`Mechanism.solve`; the keyword arguments are those of the solver.

    Parameters
    ----------
    mech : Mechanism
        The mechanism.
    at : float or str, optional
        The input value, in the model's unit or with a unit (``90``, ``"1.2rad"``); default the
        input's guess.
    speed, accel, jerk, input, guess, mode, compiled, settings : optional
        ``speed``, ``accel``, ``jerk`` (the input's motion, default the model's, else 1 rad/s or 1
        length unit/s, 0, 0), ``input`` (drive another variable), ``mode`` (a signature or alias),
        ``guess`` (a dict of unknowns), ``compiled``, ``settings`` (Newton's tolerances).

    Returns
    -------
    State
        ``state[name]``, ``state[name + "_vel"]``, ... in the model's units (rates in rad/s...).

    Raises
    ------
    AssemblyError
        The mechanism cannot be assembled at ``at``.
    ModeError
        Not in the mode asked for.

    Examples
    --------
    >>> mech = ls.load(ls.models_dir() / "thesis_crank_rocker.toml")
    >>> round(ls.solve(mech, 90)["theta4"], 4)
    80.7225
    """
    from .kinematics.solve import solve as _solve

    return _solve(mech, at, speed=speed, accel=accel, jerk=jerk, input=input, guess=guess, mode=mode,
                  compiled=compiled, settings=settings)


def guessed_mode(mech, at=None, *, input=None, compiled=None):
    """The assembly mode the guesses name: the signature of Φ_q's blocks at the guesses.

    What ``solve``, ``sweep``, ``study`` and ``forces`` solve in without ``mode`` (see
    :func:`solve`); ``at`` matters only when the input has no guess.
    ``None`` when an unknown has no guess; a ``"0"`` marks a block the guesses leave singular.

    Parameters
    ----------
    mech : Mechanism
        The mechanism.
    at : float or str, optional
        The input value, used only when the input has no guess.
    input : str, optional
        Another input variable.
    compiled : CompiledKinematics, optional
        Its compiled kinematics, if at hand.

    Returns
    -------
    str or None
        The signature, one sign per diagonal block of Φ_q.

    Examples
    --------
    >>> ls.guessed_mode(ls.load(ls.models_dir() / "thesis_crank_rocker.toml"))
    '-'
    """
    from .kinematics.solve import guessed_mode as _guessed, input_value

    ck = compiled if compiled is not None else mech.compile(input)
    x = None if at is None else input_value(ck, at)
    return _guessed(ck, x)


def sweep(mech, start, stop, step, *, speed=None, accel=None, jerk=None, input: 'str | None' = None,
          mode: 'str | None' = None, guess: 'dict | None' = None, compiled=None, through_limits: 'bool' = False,
          progress: 'bool | None' = None, method: 'str' = 'auto', derivatives: 'int' = 3,
          control: 'StepControl | None' = None, settings: 'Newton | None' = None, max_rows: 'int' = 1000000,
          limit_rows: 'bool' = False, engine: 'str | None' = None) -> 'Sweep':
    """Sweep the input over a grid, tracking the assembly mode.

    The same as :meth:`Mechanism.sweep`.

    Parameters
    ----------
    mech : Mechanism
        The mechanism.
    start, stop, step : float or str
        Rows at ``start + k*step`` towards ``stop``, in the input's unit or with a unit.
    speed, accel, jerk, input, mode, guess, compiled, through_limits, progress, method, derivatives, control, settings, max_rows, limit_rows, engine : optional
        ``speed``, ``accel``, ``jerk``, ``input``, ``mode``, ``guess``, ``compiled``,
        ``through_limits`` (continue around limit positions), ``limit_rows`` (a row at each limit),
        ``method`` (``"auto"``, ``"tracked"``, ``"batched"``), ``derivatives`` (0–3), ``engine``
        (``"python"``, ``"numba"``, ``"auto"``), ``max_rows``, ``progress``, ``control``,
        ``settings``.

    Returns
    -------
    Sweep
        The rows (``sweep["theta3"]`` is a numpy array), events and modes.

    Examples
    --------
    >>> mech = ls.load(ls.models_dir() / "thesis_crank_rocker.toml")
    >>> sw = ls.sweep(mech, 0, 360, 30)
    >>> len(sw), round(float(sw["theta4"][3]), 4)
    (13, 80.7225)
    """
    from .kinematics.sweep import sweep as _sweep

    return _sweep(mech, start, stop, step, speed=speed, accel=accel, jerk=jerk, input=input, mode=mode, guess=guess,
                  compiled=compiled, through_limits=through_limits, progress=progress, method=method,
                  derivatives=derivatives, control=control, settings=settings, max_rows=max_rows,
                  limit_rows=limit_rows, engine=engine)


def study(mech, vary, start, stop, step, *, samples: 'int | None' = None, lhs: 'int | None' = None,
          seed: 'int | None' = 0, metrics: 'Sequence[str] | Mapping[str, str]' = (), sensitivity: 'bool' = False,
          speed=None, accel=None, jerk=None, mode: 'str | None' = None, derivatives: 'int' = 3,
          chunk_size: 'int | None' = None, client=None, workers: 'int | None' = None, scheduler: 'str | None' = None,
          out=None, progress: 'bool | None' = None, method: 'str' = 'lockstep', max_designs: 'int' = 100000,
          max_cells: 'int' = 5000000):
    """Sweep every design of a parameter grid or sample at once; an xarray Dataset back.

    Needs the ``study`` extra. Fields, statuses and units: :doc:`/reference/results`.

    Parameters
    ----------
    mech : Mechanism
        The mechanism.
    vary : dict
        ``{name: values}`` (a grid: the cartesian product) or ``{name: (low, high)}`` with
        ``samples=`` or ``lhs=``.
    start, stop, step : float or str
        The input grid, as for :func:`sweep`.
    samples, lhs, seed, metrics, sensitivity, speed, accel, jerk, mode, derivatives, chunk_size, client, workers, scheduler, out, progress, method, max_designs, max_cells : optional
        ``samples``, ``lhs``, ``seed``, ``metrics``, ``sensitivity``, ``speed``, ``accel``,
        ``jerk``, ``mode``, ``derivatives``, ``chunk_size``, ``client``, ``workers``,
        ``scheduler``, ``out``, ``progress``, ``method``, ``max_designs``, ``max_cells``.

    Returns
    -------
    xarray.Dataset
        Dims ``design`` and the input; every column, ``status``, ``stop``, ``events``, ``mode``.

    Examples
    --------
    >>> mech = ls.load(ls.models_dir() / "thesis_crank_rocker.toml")
    >>> ds = ls.study(mech, {"r2": [20, 25]}, 0, 360, 90, progress=False)
    >>> [str(s) for s in ds.status.values]
    ['ok', 'ok']
    """
    from .design.studies import study as _study

    return _study(mech, vary, start, stop, step, samples=samples, lhs=lhs, seed=seed, metrics=metrics,
                  sensitivity=sensitivity, speed=speed, accel=accel, jerk=jerk, mode=mode, derivatives=derivatives,
                  chunk_size=chunk_size, client=client, workers=workers, scheduler=scheduler, out=out,
                  progress=progress, method=method, max_designs=max_designs, max_cells=max_cells)


def synthesize(mech, *, path=None, function=None, motion=None, link=None, targets=None, inputs=None, vary=None,
               crank: 'bool' = False, transmission=None, runs: 'int' = 1, seed: 'int' = 0,
               mode: 'str | None' = 'any', popsize: 'int' = 15, maxiter: 'int' = 60, tol: 'float' = 0.001,
               restarts: 'int' = 1, strategy: 'str' = 'best1bin', polish_candidates: 'int' = 6,
               starts: 'int | None' = None, de_starts: 'int' = 10, lm_iters: 'int' = 60,
               workers: 'int | None' = None, scheduler: 'str | None' = None, client=None,
               progress: 'bool | None' = None, method: 'str' = 'general', input_range=None, desired=None,
               max_cells: 'int | None' = None, max_targets: 'int | None' = None, shape=None, closed: 'bool' = True,
               atlas=None, top: 'int' = 5):
    """Dimensional synthesis: the parameters that make a model generate a path, function or motion.

    Every reported design is certified by the tracker; the report's fields are in
    :doc:`/reference/results`, the method in :doc:`/explanation/synthesis`.

    Parameters
    ----------
    mech : Mechanism
        The model; its parameters are the design variables.
    path, function, motion, link, targets, inputs, vary, crank, transmission, runs, seed, mode, popsize, maxiter, tol, restarts, strategy, polish_candidates, starts, de_starts, lm_iters, workers, scheduler, client, progress, method, input_range, desired, max_cells, max_targets, shape, closed, atlas, top : optional
        The task: ``path="P"``, ``function="theta4"`` or ``motion="P"`` with ``link="theta3"``;
        ``targets`` (a CSV path or a dict of columns), ``inputs`` (prescribed timing), ``vary``
        (``{name: (low, high)}``), ``crank``, ``transmission``, ``runs``, ``seed``, ``mode``,
        ``method`` (``"general"``, ``"freudenstein"``, ``"burmester"``), ``input_range``,
        ``desired``, the search's ``popsize``, ``maxiter``, ``tol``, ``restarts``, ``strategy``,
        ``polish_candidates``, ``starts``, ``de_starts``, ``lm_iters``, and ``workers``,
        ``scheduler``, ``client``, ``progress``, ``max_cells``, ``max_targets``.

    Returns
    -------
    SynthesisResult
        ``.mechanism``, ``.objective``, ``.report``, ``.to_toml()``, ``.plot()``.

    Raises
    ------
    SynthesisError
        No certified design (the report is attached).

    Examples
    --------
    >>> mech = ls.load(ls.models_dir() / "prob1_fourbar.toml")
    >>> targets = [(50, 70.0), (75, 77.0), (100, 88.0)]   # (input, output) in degrees
    >>> res = ls.synthesize(mech, method="freudenstein", function="theta4", targets=targets)
    >>> res.report["task"], res.report["certificate"]["defects"]
    ('function', [])
    """
    from .design.synthesis.run import synthesize as _synthesize

    return _synthesize(mech, path=path, function=function, motion=motion, link=link, targets=targets, inputs=inputs,
                       vary=vary, crank=crank, transmission=transmission, runs=runs, seed=seed, mode=mode,
                       popsize=popsize, maxiter=maxiter, tol=tol, restarts=restarts, strategy=strategy,
                       polish_candidates=polish_candidates, starts=starts, de_starts=de_starts, lm_iters=lm_iters,
                       workers=workers, scheduler=scheduler, client=client, progress=progress, method=method,
                       input_range=input_range, desired=desired, max_cells=max_cells, max_targets=max_targets,
                       shape=shape, closed=closed, atlas=atlas, top=top)


def forces(mech, at=None, stop=None, step=None, *, speed=None, accel=None, input=None, mode=None,
           through_limits: 'bool' = False, progress=False, method: 'str' = 'auto'):
    """Force and torque analysis: driving torque, joint forces, shaking force, energies.

    Derives the dynamics with sympy once per process. Columns, units and signs:
    :doc:`/reference/results`.

    Parameters
    ----------
    mech : Mechanism
        A mechanism with ``[bodies]``.
    at : float or str, optional
        One input value; or the start of a sweep when ``stop`` and ``step`` are given.
    stop, step : float or str, optional
        The sweep's end and step.
    speed, accel, input, mode, through_limits, progress, method : optional
        ``speed``, ``accel``, ``input``, ``mode``, ``through_limits``, ``progress``, ``method``.

    Returns
    -------
    ForceSweep
        ``drive``, ``joint_forces``, ``shaking_force``, ``shaking_moment``, energies,
        ``power_residual``, ``condition``, ``units()``, ``flywheel(cs)``.

    Examples
    --------
    >>> mech = ls.load(ls.models_dir() / "thesis_crank_rocker_dynamics.toml")
    >>> fs = ls.forces(mech, 0, 360, 90)
    >>> fs.units()["drive"]
    'N*m'
    """
    from .dynamics.kinetostatics import forces as _forces

    return _forces(mech, at, stop, step, speed=speed, accel=accel, input=input, mode=mode,
                   through_limits=through_limits, progress=progress, method=method)


def simulate(mech, duration: 'float', *, step: 'float' = 0.01, torque=0.0, speed0=None, at=None, input=None,
             mode=None, rtol: 'float' = 1e-11, atol: 'float' = 1e-12, method: 'str' = 'DOP853',
             max_steps: 'int | None' = None) -> 'Simulation':
    """Integrate the one-degree-of-freedom equation of motion over time.

    Parameters
    ----------
    mech : Mechanism
        A mechanism with ``[bodies]``.
    duration : float
        Seconds to simulate.
    step, torque, speed0, at, input, mode, rtol, atol, method, max_steps : optional
        ``step`` (output step, s), ``torque`` (a number, a quantity, an SI expression of the input,
        ``<input>_vel`` and ``t``, or a callable ``f(t, x, xd)``), ``speed0``, ``at``, ``input``,
        ``mode``, ``rtol``, ``atol``, ``method``, ``max_steps``.

    Returns
    -------
    Simulation
        ``t``, ``x`` (model units), ``xd`` (rad/s), energies, ``units()``.

    Examples
    --------
    >>> mech = ls.load(ls.models_dir() / "thesis_crank_rocker_dynamics.toml")
    >>> sim = ls.simulate(mech, 0.1, step=0.05, speed0="60rpm")
    >>> len(sim.t)
    3
    """
    from .dynamics.simulation import simulate as _simulate

    return _simulate(mech, duration, step=step, torque=torque, speed0=speed0, at=at, input=input, mode=mode,
                     rtol=rtol, atol=atol, method=method, max_steps=max_steps)


def freudenstein(function: 'Callable | None', x_range: 'Sequence[float]', input_range: 'Sequence[float]',
                 output_range: 'Sequence[float]', *, points: 'int | Sequence[float]' = 3,
                 spacing: 'str' = 'chebyshev', fit: 'str' = 'exact', free_offsets: 'bool' = False,
                 ground: 'float' = 100.0, length_unit: 'str' = 'mm',
                 name: 'str' = 'Freudenstein function generator', samples: 'int' = 1201,
                 max_link_ratio: 'float | None' = None, starts: 'int' = 4) -> 'FunctionDesign':
    """Four-bar function generation by Freudenstein's equation, every design checked by the tracker.

    Parameters
    ----------
    function : callable
        y = f(x), vectorized.
    x_range : (float, float)
        The range of x.
    input_range, output_range : (float, float)
        The input and output angles (degrees) that x and y map to.
    points, spacing, fit, free_offsets, ground, length_unit, name, samples, max_link_ratio, starts : optional
        ``points`` (3, or the x values), ``spacing`` (``"chebyshev"``), ``fit`` (``"exact"``,
        ``"least-squares"``, ``"minimax"``), ``free_offsets``, ``ground``, ``length_unit``,
        ``name``, ``samples``, ``max_link_ratio``, ``starts``.

    Returns
    -------
    FunctionDesign
        ``K``, the lengths, ``mechanism``, ``mode``, ``grashof``, ``defects``, ``max_error``,
        ``alternative()``; see :doc:`/howto/classical_synthesis`.

    Examples
    --------
    >>> d = ls.freudenstein(np.log10, (1, 10), (45, 105), (135, 225))
    >>> [round(k, 5) for k in d.K]
    [2.00276, -0.69862, 1.0842]
    """
    return _freudenstein_module.freudenstein(function, x_range, input_range, output_range, points=points,
                                             spacing=spacing, fit=fit, free_offsets=free_offsets, ground=ground,
                                             length_unit=length_unit, name=name, samples=samples,
                                             max_link_ratio=max_link_ratio, starts=starts)


def burmester(poses, *, length_unit: 'str' = 'mm', name: 'str' = 'Burmester four-bar') -> 'BurmesterResult':
    """Five-pose motion generation by Burmester theory, every four-bar checked by the tracker.

    Parameters
    ----------
    poses : sequence of (x, y, angle)
        Five poses of a coupler point and the coupler's angle (degrees).
    length_unit, name : optional
        ``length_unit``, ``name``.

    Returns
    -------
    BurmesterResult
        Every four-bar from a pair of Ball–Burmester dyads, with defects; ``usable`` the
        certified ones. Four poses: :func:`burmester_curves`.

    Examples
    --------
    >>> mech = ls.fourbar(60, 25, 70, 45)
    >>> poses = []
    >>> for a in (20, 70, 120, 170, 220):
    ...     s = mech.solve(a)
    ...     poses.append((s["C_x"], s["C_y"], s["theta3"]))
    >>> len(ls.burmester(poses).usable) >= 1
    True
    """
    return _burmester_module.burmester(poses, length_unit=length_unit, name=name)


def burmester_curves(poses, *, samples: 'int' = 1440) -> 'BurmesterCurves':
    """Centre-point and circle-point curves of four poses (Burmester theory).

    Parameters
    ----------
    poses : sequence of (x, y, angle)
        Four poses of a coupler point and the coupler's angle (degrees).
    samples : optional
        ``samples`` (angles of the lines through the pole, default 1440).

    Returns
    -------
    BurmesterCurves
        ``center`` (ground pivots), ``circle`` (coupler pins in the first pose),
        ``circle_moving``, polylines with NaN rows between pieces, and the poles.

    Examples
    --------
    >>> curves = ls.burmester_curves([(0, 0, 0), (10, 2, 15), (18, 8, 35), (22, 16, 60)])
    >>> curves.center.shape[1]
    2
    """
    return _burmester_module.burmester_curves(poses, samples=samples)


def export_cad(mech, output, at=None, *, input: 'str | None' = None, mode: 'str | None' = None,
               curves: 'list[str] | None' = None, step=None, **solve_kwargs):
    """The linkage at one pose as a CAD drawing (``.dxf`` with ezdxf, or ``.svg``), layers by role.

    Parameters
    ----------
    mech : Mechanism
        The mechanism.
    output : str or path
        ``.dxf`` (needs the ``cad`` extra) or ``.svg``.
    at : float or str, optional
        The input value of the pose (default the input's guess).
    input, mode, curves, step : optional
        ``input``, ``mode``: as for :func:`solve`; ``curves``: the points whose paths to draw; ``step``: their
        sweep's step.
    **solve_kwargs
        The other keywords of :func:`solve` (``speed``, ``guess``, ``settings``...).

    Returns
    -------
    list of Entity
        What was written: one entity (line, circle, polyline, text) per item, on the layers ``LINKS``, ``PINS``, ``GROUND``, ``SLIDERS``, ``POINTS``,
        ``CURVES``, ``LABELS`` (:doc:`/howto/export_dxf`).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "fourbar.svg"
    >>> entities = ls.export_cad(ls.fourbar(60, 25, 70, 45), out, at=30)
    >>> out.exists(), len(entities) > 0
    (True, True)
    """
    from .output.cad import export_cad as _export_cad

    return _export_cad(mech, output, at, input=input, mode=mode, curves=curves, step=step, **solve_kwargs)


#: The types users hold, importable from the top (``from loopsolve import ForceSweep``); each is
#: imported on first use, so ``import loopsolve`` stays light (no sympy, xarray or matplotlib).
_TYPES = {
    "CompiledKinematics": "symbolic.compiled", "Kinematics": "symbolic.loop_equations",
    "DynamicsDerivation": "dynamics.eom", "Newton": "kinematics.newton", "StepControl": "kinematics.continuation",
    "Mode": "kinematics.modes", "ForceSweep": "dynamics.forceresults", "Flywheel": "dynamics.forceresults",
    "Simulation": "dynamics.simulation", "SynthesisResult": "design.synthesis.run", "ShapeResult": "design.synthesis.shape.run",
    "FunctionDesign": "design.synthesis.classical.freudenstein", "BurmesterResult": "design.synthesis.classical.burmester",
    "BurmesterCurves": "design.synthesis.classical.burmester", "Atlas": "design.atlas.build", "Page": "output.view",
}

# The flat modules' names before the subpackages (issue 24, ARCHITECTURE.md). ``ls.classic`` and
# ``from loopsolve import classic`` still give loopsolve.kinematics.classic, with one
# DeprecationWarning naming the new path; they are removed in loopsolve 0.3 (not before 2027-06-01).
_MOVED = {
    "spec": "model.spec", "exprcheck": "model.exprcheck", "unitlib": "model.unitlib", "files": "model.files",
    "modelfile": "model.modelfile", "builder": "model.builder", "factories": "model.factories",
    "diagrambodies": "model.diagrambodies", "compiled": "symbolic.compiled", "texprint": "symbolic.texprint",
    "kernel": "kinematics.scalar_solver", "modes": "kinematics.modes", "continuation": "kinematics.continuation",
    "batch": "kinematics.batch", "assemblable": "kinematics.assemblable", "results": "kinematics.results",
    "export": "kinematics.export", "info": "kinematics.info", "classic": "kinematics.classic",
    "declcheck": "dynamics.declcheck", "kinetostatics": "dynamics.kinetostatics", "eom": "dynamics.eom",
    "simulation": "dynamics.simulation", "forceresults": "dynamics.forceresults", "designs": "design.designs",
    "lockstep": "design.lockstep", "studies": "design.studies", "metrics": "design.metrics",
    "sensitivity": "design.sensitivity", "synthesis": "design.synthesis.problem", "synthbatch": "design.synthesis.candidates",
    "certify": "design.synthesis.certificate", "synthrun": "design.synthesis.run", "classicsynth": "design.synthesis.classical.run",
    "linkcheck": "design.synthesis.classical.verdict", "structerr": "design.synthesis.structural_error", "plotting": "output.plotting",
    "forceplots": "output.forceplots", "drawstyle": "output.drawstyle", "geometry": "output.geometry",
    "view": "output.view", "cad": "output.cad", "latex": "output.latex", "latex_dynamics": "output.latex_dynamics",
}
from .errors import COMPAT_REMOVAL  # noqa: E402


def __getattr__(name):
    import importlib

    if name in _TYPES:
        value = getattr(importlib.import_module(f".{_TYPES[name]}", __name__), name)
    elif name in ("model", "symbolic", "dynamics", "kinematics", "design", "output", "editor", "cli"):
        value = importlib.import_module(f".{name}", __name__)  # the subpackages themselves
    elif name in _MOVED:
        import warnings

        warnings.warn(f"loopsolve.{name} is loopsolve.{_MOVED[name]} now; the old name is removed in {COMPAT_REMOVAL}",
                      DeprecationWarning, stacklevel=2)
        return importlib.import_module(f".{_MOVED[name]}", __name__)  # not cached: every old use is told
    else:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    globals()[name] = value
    return value


__all__ = [
    "__version__",
    "AssemblyError",
    "ModeError",
    "BranchError",
    "ConvergenceError",
    "Event",
    "EventKind",
    "LoopsolveError",
    "LoopsolveWarning",
    "Mechanism",
    "MechanismBuilder",
    "MissingDependencyError",
    "PowerBalanceError",
    "ModelError",
    "ModelFileError",
    "SingularPositionError",
    "SolveError",
    "SynthesisError",
    "State",
    "Sweep",
    "TopologyError",
    "build_mechanism",
    "burmester",
    "burmester_curves",
    "compile_mechanism",
    "derive",
    "derive_dynamics",
    "dumps",
    "export_cad",
    "forces",
    "fourbar",
    "freudenstein",
    "guessed_mode",
    "inverted_slider_crank",
    "load",
    "loads",
    "models_dir",
    "slider_crank",
    "simulate",
    "solve",
    "study",
    "sweep",
    "synthesize",
    "build_atlas",
    "open_atlas",
    *_TYPES,
]
