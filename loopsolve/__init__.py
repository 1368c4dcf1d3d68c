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
    """Symbolic derivation: see :func:`loopsolve.symbolic.derivation.derive` (imports sympy)."""
    from .symbolic.derivation import derive as _derive

    return _derive(mech, input=input)


def derive_dynamics(mech, input=None):
    """The equation of motion in symbols: see :func:`loopsolve.dynamics.eom.derive_dynamics` (imports sympy)."""
    from .dynamics.eom import derive_dynamics as _derive_dynamics

    return _derive_dynamics(mech, input=input)


def compile_mechanism(mech, input=None, *, cache=True):
    """Compiled kinematics: see :func:`loopsolve.symbolic.compiled.compile_mechanism`."""
    from .symbolic.compiled import compile_mechanism as _compile

    return _compile(mech, input=input, cache=cache)


def solve(mech, at=None, **kwargs):
    """Solve one position: see :func:`loopsolve.solve.solve`."""
    from .kinematics.solve import solve as _solve

    return _solve(mech, at, **kwargs)


def guessed_mode(mech, at=None, *, input=None, compiled=None):
    """The assembly mode the guesses name: the signature of Φ_q's blocks at the guesses.

    What ``solve``, ``sweep``, ``study`` and ``forces`` solve in without ``mode`` (see
    :func:`loopsolve.solve.guessed_mode`); ``at`` matters only when the input has no guess.
    ``None`` when an unknown has no guess; a ``"0"`` marks a block the guesses leave singular.

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
    """Sweep the input: see :func:`loopsolve.sweep.sweep`."""
    from .kinematics.sweep import sweep as _sweep

    return _sweep(mech, start, stop, step, **kwargs)


def study(mech, vary, start, stop, step, **kwargs):
    """Design study over many parameter sets: see :func:`loopsolve.design.studies.study` (needs the ``study`` extra)."""
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
    """Dimensional synthesis (path, function, motion generation): see :func:`loopsolve.design.synthrun.synthesize`."""
    from .design.synthrun import synthesize as _synthesize

    return _synthesize(mech, **kwargs)


def forces(mech, at=None, stop=None, step=None, **kwargs):
    """Force and torque analysis: see :func:`loopsolve.dynamics.kinetostatics.forces` (imports sympy once)."""
    from .dynamics.kinetostatics import forces as _forces

    return _forces(mech, at, stop, step, **kwargs)


def simulate(mech, duration, **kwargs):
    """Forward dynamics: see :func:`loopsolve.dynamics.simulation.simulate`."""
    from .dynamics.simulation import simulate as _simulate

    return _simulate(mech, duration, **kwargs)


def freudenstein(function, x_range, input_range, output_range, **kwargs):
    """Four-bar function generation by Freudenstein's equation, checked by the tracker: see
    :func:`loopsolve.freudenstein.freudenstein`."""
    return _freudenstein_module.freudenstein(function, x_range, input_range, output_range, **kwargs)


def burmester(poses, **kwargs):
    """Five-pose motion generation by Burmester theory, every four-bar checked by the tracker: see
    :func:`loopsolve.burmester.burmester` (four poses: :func:`loopsolve.burmester.burmester_curves`)."""
    return _burmester_module.burmester(poses, **kwargs)


def burmester_curves(poses, **kwargs):
    """Centre-point and circle-point curves of four poses: see :func:`loopsolve.burmester.burmester_curves`."""
    return _burmester_module.burmester_curves(poses, **kwargs)


def export_cad(mech, output, at=None, **kwargs):
    """The linkage at one pose as a CAD drawing (``.dxf`` with ezdxf, or ``.svg``), layers by role: see
    :func:`loopsolve.output.cad.export_cad`."""
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
