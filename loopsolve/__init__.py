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
from .model import bodies, diagram, expr, topology, units
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
from .design import freudenstein as _freudenstein_module  # noqa: E402, F401
from .design import burmester as _burmester_module  # noqa: E402, F401


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
    from .symbolic.derivation import derive as _derive

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


def solve(mech, at=None, **kwargs):
    """Solve one position, with velocities, accelerations and jerks.

    The same as :meth:`Mechanism.solve`; the keyword arguments are those of the solver.

    Parameters
    ----------
    mech : Mechanism
        The mechanism.
    at : float or str, optional
        The input value, in the model's unit or with a unit (``90``, ``"1.2rad"``); default the
        input's guess.
    **kwargs
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

    return _solve(mech, at, **kwargs)


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


def sweep(mech, start, stop, step, **kwargs):
    """Sweep the input over a grid, tracking the assembly mode.

    The same as :meth:`Mechanism.sweep`.

    Parameters
    ----------
    mech : Mechanism
        The mechanism.
    start, stop, step : float or str
        Rows at ``start + k*step`` towards ``stop``, in the input's unit or with a unit.
    **kwargs
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

    return _sweep(mech, start, stop, step, **kwargs)


def study(mech, vary, start, stop, step, **kwargs):
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
    **kwargs
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

    return _study(mech, vary, start, stop, step, **kwargs)


def build_atlas(mech, **kwargs):
    """An atlas of coupler curves for shape synthesis: see :func:`loopsolve.design.atlas.build_atlas`."""
    from .design.atlas import build_atlas as _build_atlas

    return _build_atlas(mech, **kwargs)


def open_atlas(path, mech=None):
    """Open an atlas (checked): see :func:`loopsolve.design.atlas.open_atlas`."""
    from .design.atlas import open_atlas as _open_atlas

    return _open_atlas(path, mech)


def synthesize(mech, **kwargs):
    """Dimensional synthesis: the parameters that make a model generate a path, function or motion.

    Every reported design is certified by the tracker; the report's fields are in
    :doc:`/reference/results`, the method in :doc:`/explanation/synthesis`.

    Parameters
    ----------
    mech : Mechanism
        The model; its parameters are the design variables.
    **kwargs
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
    from .design.synthrun import synthesize as _synthesize

    return _synthesize(mech, **kwargs)


def forces(mech, at=None, stop=None, step=None, **kwargs):
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
    **kwargs
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

    return _forces(mech, at, stop, step, **kwargs)


def simulate(mech, duration, **kwargs):
    """Integrate the one-degree-of-freedom equation of motion over time.

    Parameters
    ----------
    mech : Mechanism
        A mechanism with ``[bodies]``.
    duration : float
        Seconds to simulate.
    **kwargs
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

    return _simulate(mech, duration, **kwargs)


def freudenstein(function, x_range, input_range, output_range, **kwargs):
    """Four-bar function generation by Freudenstein's equation, every design checked by the tracker.

    Parameters
    ----------
    function : callable
        y = f(x), vectorized.
    x_range : (float, float)
        The range of x.
    input_range, output_range : (float, float)
        The input and output angles (degrees) that x and y map to.
    **kwargs
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
    return _freudenstein_module.freudenstein(function, x_range, input_range, output_range, **kwargs)


def burmester(poses, **kwargs):
    """Five-pose motion generation by Burmester theory, every four-bar checked by the tracker.

    Parameters
    ----------
    poses : sequence of (x, y, angle)
        Five poses of a coupler point and the coupler's angle (degrees).
    **kwargs
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
    return _burmester_module.burmester(poses, **kwargs)


def burmester_curves(poses, **kwargs):
    """Centre-point and circle-point curves of four poses (Burmester theory).

    Parameters
    ----------
    poses : sequence of (x, y, angle)
        Four poses of a coupler point and the coupler's angle (degrees).
    **kwargs
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
    return _burmester_module.burmester_curves(poses, **kwargs)


def export_cad(mech, output, at=None, **kwargs):
    """The linkage at one pose as a CAD drawing (``.dxf`` with ezdxf, or ``.svg``), layers by role.

    Parameters
    ----------
    mech : Mechanism
        The mechanism.
    output : str or path
        ``.dxf`` (needs the ``cad`` extra) or ``.svg``.
    at : float or str, optional
        The input value of the pose (default the input's guess).
    **kwargs
        ``input``, ``mode``, ``curves`` (points whose paths to draw), ``step``, and the keywords
        of :func:`solve`.

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

    return _export_cad(mech, output, at, **kwargs)


# The flat modules' names before the subpackages (issue 24, ARCHITECTURE.md): ``ls.classic`` and
# ``from loopsolve import classic`` still give loopsolve.kinematics.classic, imported on first use
# (so ``import loopsolve`` stays as light as before); ``model``, ``symbolic`` and ``dynamics`` are the
# subpackages, which answer for the names of the module they replace. New code imports the new paths.
_MOVED = {
    "spec": "model.spec", "expr": "model.expr", "exprcheck": "model.exprcheck", "units": "model.units",
    "unitlib": "model.unitlib", "files": "model.files", "modelfile": "model.modelfile",
    "builder": "model.builder", "factories": "model.factories", "model": "model",
    "topology": "model.topology", "diagram": "model.diagram", "diagrambodies": "model.diagrambodies",
    "bodies": "model.bodies", "symbolic": "symbolic", "compiled": "symbolic.compiled",
    "texprint": "symbolic.texprint", "newton": "kinematics.newton", "kernel": "kinematics.kernel",
    "solve": "kinematics.solve", "modes": "kinematics.modes", "continuation": "kinematics.continuation",
    "sweep": "kinematics.sweep", "batch": "kinematics.batch", "assemblable": "kinematics.assemblable",
    "results": "kinematics.results", "export": "kinematics.export", "info": "kinematics.info",
    "classic": "kinematics.classic", "declcheck": "dynamics.declcheck",
    "kinetostatics": "dynamics.kinetostatics", "dynamics": "dynamics", "eom": "dynamics.eom",
    "simulation": "dynamics.simulation", "forceresults": "dynamics.forceresults",
    "designs": "design.designs", "lockstep": "design.lockstep", "studies": "design.studies",
    "metrics": "design.metrics", "sensitivity": "design.sensitivity", "synthesis": "design.synthesis",
    "synthbatch": "design.synthbatch", "certify": "design.certify", "synthrun": "design.synthrun",
    "freudenstein": "design.freudenstein", "burmester": "design.burmester",
    "classicsynth": "design.classicsynth", "linkcheck": "design.linkcheck", "structerr": "design.structerr",
    "plotting": "output.plotting", "forceplots": "output.forceplots", "drawstyle": "output.drawstyle",
    "geometry": "output.geometry", "view": "output.view", "cad": "output.cad", "latex": "output.latex",
    "latex_dynamics": "output.latex_dynamics",
}


def __getattr__(name):
    path = _MOVED.get(name)
    if path is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    import importlib

    module = importlib.import_module(f".{path}", __name__)
    globals()[name] = module
    return module


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
]
