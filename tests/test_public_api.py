"""The public API, pinned: the names ``loopsolve`` exports, the real signature of each function, the
methods that are the same operation as a function, and the old names that warn before they go.

A change here is a change of what users call: make it on purpose, update the pins below, and say so
in the changelog of the release.
"""

from __future__ import annotations

import enum
import inspect
import re
import subprocess
import sys
import warnings

import pytest

import loopsolve as ls

NAMES = sorted("""
AssemblyError Atlas BranchError BurmesterCurves BurmesterResult CompiledKinematics ConvergenceError DynamicsDerivation
Event EventKind Flywheel ForceSweep FunctionDesign Kinematics LoopsolveError LoopsolveWarning Mechanism MechanismBuilder
MissingDependencyError Mode ModeError ModelError ModelFileError Newton Page PowerBalanceError ShapeResult Simulation
SingularPositionError SolveError State StepControl Sweep SynthesisError SynthesisResult TopologyError __version__
build_atlas build_mechanism burmester burmester_curves compile_mechanism derive derive_dynamics dumps export_cad forces
fourbar freudenstein guessed_mode inverted_slider_crank load loads models_dir open_atlas simulate slider_crank solve
study sweep synthesize
""".split())

#: every public function's signature as ``inspect`` (and so ``help()``) shows it, private parameters left out
SIGNATURES = {
    "build_atlas": "(mech, *, point: 'str', vary, size: 'int', seed: 'int' = 0, out=None, chunk: 'int' = 2048, workers: 'int | None' = None, scheduler: 'str | None' = None, client=None, max_size: 'int' = 2000000, progress: 'bool | None' = None, step_deg: 'float' = 3.0, curve_points: 'int' = 64, harmonics: 'int' = 10)",
    "build_mechanism": "(spec: 'Mapping[str, Any]', *, source: 'str | None' = None) -> 'Mechanism'",
    "burmester": "(poses, *, length_unit: 'str' = 'mm', name: 'str' = 'Burmester four-bar') -> 'BurmesterResult'",
    "burmester_curves": "(poses, *, samples: 'int' = 1440) -> 'BurmesterCurves'",
    "compile_mechanism": "(mech, input=None, *, cache=True)",
    "derive": "(mech, input=None)",
    "derive_dynamics": "(mech, input=None)",
    "dumps": "(mech_or_spec: 'Mechanism | Mapping[str, Any]') -> 'str'",
    "export_cad": "(mech, output, at=None, *, input: 'str | None' = None, mode: 'str | None' = None, curves: 'list[str] | None' = None, step=None, **solve_kwargs)",
    "forces": "(mech, at=None, stop=None, step=None, *, speed=None, accel=None, input=None, mode=None, through_limits: 'bool' = False, progress=False, method: 'str' = 'auto')",
    "fourbar": "(r1: 'float', r2: 'float', r3: 'float', r4: 'float', *, theta2: 'float' = 90.0, mode: 'str' = 'open', name: 'str' = 'four-bar', length_unit: 'str' = 'mm', speed=None, accel=None) -> 'Mechanism'",
    "freudenstein": "(function: 'Callable | None', x_range: 'Sequence[float]', input_range: 'Sequence[float]', output_range: 'Sequence[float]', *, points: 'int | Sequence[float]' = 3, spacing: 'str' = 'chebyshev', fit: 'str' = 'exact', free_offsets: 'bool' = False, ground: 'float' = 100.0, length_unit: 'str' = 'mm', name: 'str' = 'Freudenstein function generator', samples: 'int' = 1201, max_link_ratio: 'float | None' = None, starts: 'int' = 4) -> 'FunctionDesign'",
    "guessed_mode": "(mech, at=None, *, input=None, compiled=None)",
    "inverted_slider_crank": "(r2: 'float', d: 'float', *, theta2: 'float' = 0.0, name: 'str' = 'crank and slotted lever', length_unit: 'str' = 'mm', speed=None, accel=None) -> 'Mechanism'",
    "load": "(path: 'str | os.PathLike') -> 'Mechanism'",
    "loads": "(text: 'str', *, source: 'str' = '<string>') -> 'Mechanism'",
    "models_dir": "() -> 'Path'",
    "open_atlas": "(path, mech=None) -> 'Atlas'",
    "simulate": "(mech, duration: 'float', *, step: 'float' = 0.01, torque=0.0, speed0=None, at=None, input=None, mode=None, rtol: 'float' = 1e-11, atol: 'float' = 1e-12, method: 'str' = 'DOP853', max_steps: 'int | None' = None) -> 'Simulation'",
    "slider_crank": "(r2: 'float', r3: 'float', *, offset: 'float' = 0.0, theta2: 'float' = 45.0, mode: 'str' = 'right', name: 'str' = 'slider-crank', length_unit: 'str' = 'mm', speed=None, accel=None) -> 'Mechanism'",
    "solve": "(mech: 'Mechanism', at=None, *, speed=None, accel=None, jerk=None, input: 'str | None' = None, guess: 'dict | None' = None, mode: 'str | None' = None, compiled: 'CompiledKinematics | None' = None, settings: 'Newton | None' = None) -> 'State'",
    "study": "(mech, vary, start, stop, step, *, samples: 'int | None' = None, lhs: 'int | None' = None, seed: 'int | None' = 0, metrics: 'Sequence[str] | Mapping[str, str]' = (), sensitivity: 'bool' = False, speed=None, accel=None, jerk=None, mode: 'str | None' = None, derivatives: 'int' = 3, chunk_size: 'int | None' = None, client=None, workers: 'int | None' = None, scheduler: 'str | None' = None, out=None, progress: 'bool | None' = None, method: 'str' = 'lockstep', max_designs: 'int' = 100000, max_cells: 'int' = 5000000)",
    "sweep": "(mech, start, stop, step, *, speed=None, accel=None, jerk=None, input: 'str | None' = None, mode: 'str | None' = None, guess: 'dict | None' = None, compiled=None, through_limits: 'bool' = False, progress: 'bool | None' = None, method: 'str' = 'auto', derivatives: 'int' = 3, control: 'StepControl | None' = None, settings: 'Newton | None' = None, max_rows: 'int' = 1000000, limit_rows: 'bool' = False, engine: 'str | None' = None) -> 'Sweep'",
    "synthesize": "(mech, *, path=None, function=None, motion=None, link=None, targets=None, inputs=None, vary=None, crank: 'bool' = False, transmission=None, runs: 'int' = 1, seed: 'int' = 0, mode: 'str | None' = 'any', popsize: 'int' = 15, maxiter: 'int' = 60, tol: 'float' = 0.001, restarts: 'int' = 1, strategy: 'str' = 'best1bin', polish_candidates: 'int' = 6, starts: 'int | None' = None, de_starts: 'int' = 10, lm_iters: 'int' = 60, workers: 'int | None' = None, scheduler: 'str | None' = None, client=None, progress: 'bool | None' = None, method: 'str' = 'general', input_range=None, desired=None, max_cells: 'int | None' = None, max_targets: 'int | None' = None, shape=None, closed: 'bool' = True, atlas=None, top: 'int' = 5)",
}

#: (public function or method, the implementation it is): the same parameters, kinds and defaults
SAME_OPERATION = [
    ("solve", "loopsolve.kinematics.solve:solve"), ("sweep", "loopsolve.kinematics.sweep:sweep"),
    ("study", "loopsolve.design.studies:study"), ("synthesize", "loopsolve.design.synthesis.run:synthesize"),
    ("forces", "loopsolve.dynamics.kinetostatics:forces"), ("simulate", "loopsolve.dynamics.simulation:simulate"),
    ("freudenstein", "loopsolve.design.synthesis.classical.freudenstein:freudenstein"), ("burmester", "loopsolve.design.synthesis.classical.burmester:burmester"),
    ("burmester_curves", "loopsolve.design.synthesis.classical.burmester:burmester_curves"), ("export_cad", "loopsolve.output.cad:export_cad"),
    ("build_atlas", "loopsolve.design.atlas.build:build_atlas"), ("open_atlas", "loopsolve.design.atlas.build:open_atlas"),
    ("Mechanism.solve", "loopsolve.kinematics.solve:solve"), ("Mechanism.sweep", "loopsolve.kinematics.sweep:sweep"),
    ("Mechanism.forces", "loopsolve.dynamics.kinetostatics:forces"),
    ("Mechanism.simulate", "loopsolve.dynamics.simulation:simulate"),
    ("Mechanism.modes", "loopsolve.kinematics.modes:assembly_modes"), ("Mechanism.to_latex", "loopsolve.output.latex:to_latex"),
    ("Mechanism.info", "loopsolve.kinematics.info:info"), ("Mechanism.draw", "loopsolve.output.plotting:draw"),
    ("Sweep.to_json", "loopsolve.kinematics.export:to_json"), ("Sweep.to_csv", "loopsolve.kinematics.export:to_csv"),
    ("Sweep.plot", "loopsolve.output.plotting:plot_sweep"), ("Sweep.animate", "loopsolve.output.plotting:animate"),
    ("Sweep.to_html", "loopsolve.output.view:to_html"), ("Sweep.view", "loopsolve.output.view:to_html"),
]


def _resolve(dotted):
    import importlib

    module, _, name = dotted.partition(":")
    obj = importlib.import_module(module)
    for part in name.split("."):
        obj = getattr(obj, part)
    return obj


def _public(sig):
    return sig.replace(parameters=[p for p in sig.parameters.values() if not p.name.startswith("_")])


def _shape(fn, drop_first):
    """(name, kind, default) of each public parameter, the first (the mechanism, the sweep) left out."""
    params = list(_public(inspect.signature(fn)).parameters.values())[1 if drop_first else 0:]
    return [(p.name, p.kind, p.default) for p in params]


def test_the_exported_names_are_the_pinned_ones_and_each_resolves():
    assert sorted(ls.__all__) == NAMES
    for name in NAMES:
        assert getattr(ls, name) is not None, name
    namespace = {}
    exec("from loopsolve import *", namespace)  # noqa: S102 - our own package, not user text
    assert set(NAMES) - {"__version__"} <= set(namespace)


@pytest.mark.parametrize("name", sorted(SIGNATURES))
def test_each_public_function_has_its_pinned_signature_and_documents_it(name):
    fn = getattr(ls, name)
    assert str(_public(inspect.signature(fn))) == SIGNATURES[name]
    doc = inspect.getdoc(fn)
    assert "Examples\n--------" in doc, f"{name}: no Examples section"
    if _public(inspect.signature(fn)).parameters:
        assert "Parameters\n----------" in doc, f"{name}: no Parameters section"
        # every parameter is named in the Parameters section (numpydoc may group "a, b : type")
        section = doc.split("Parameters\n----------", 1)[1].split("\n\n", 1)[0] + doc
        for p in _public(inspect.signature(fn)).parameters.values():
            assert p.name in section, f"{name}: parameter {p.name} is not documented"
        params = re.split(r"\n\S[^\n]*\n-{3,}\n", doc.split("Parameters\n----------", 1)[1])[0]
        _each_entry_names_parameters(name, params)


#: the result types users receive and do not construct: numpydoc "Attributes" (what they read) besides
#: "Parameters" (the constructor)
RECEIVED = sorted("""
Atlas BurmesterCurves BurmesterResult CompiledKinematics DynamicsDerivation Event EventKind Flywheel ForceSweep
FunctionDesign Kinematics Mode Page ShapeResult Simulation State Sweep SynthesisResult
""".split())

PUBLIC_CLASSES = sorted(n for n in NAMES if inspect.isclass(getattr(ls, n, None)))


def _sections(doc):
    """numpydoc section titles of a docstring (a title line underlined by as many dashes)."""
    lines = doc.splitlines()
    return {a for a, b in zip(lines, lines[1:]) if a.strip() and b.strip() and set(b.strip()) == {"-"}
            and len(b.strip()) == len(a.strip())}


def test_every_public_class_and_function_is_in_the_documentation_pins():
    functions = {n for n in NAMES if inspect.isfunction(getattr(ls, n))}
    assert functions == set(SIGNATURES)
    assert set(RECEIVED) <= set(PUBLIC_CLASSES)


@pytest.mark.parametrize("name", PUBLIC_CLASSES)
def test_each_public_class_documents_its_constructor_and_shows_an_example(name):
    """A user reads ``help(ls.X)``: what X is built from (Parameters, every public constructor argument
    named), for a result type what it holds (Attributes), and an example that the doctests run."""
    cls = getattr(ls, name)
    doc = inspect.getdoc(cls)
    sections = _sections(doc)
    assert "Examples" in sections and ">>> " in doc.split("Examples\n--------", 1)[1], f"{name}: no Examples section"
    assert "Parameters" in sections, f"{name}: no Parameters section"
    if name in RECEIVED:
        assert "Attributes" in sections, f"{name}: a result type lists what it holds under Attributes"
    assert sections <= {"Parameters", "Attributes", "Returns", "Raises", "Warns", "See Also", "Notes",
                        "References", "Examples", "Methods"}, f"{name}: not a numpydoc section: {sections}"
    params = doc.split("Parameters\n----------", 1)[1]
    params = re.split(r"\n\S[^\n]*\n-{3,}\n", params, maxsplit=1)[0]
    if issubclass(cls, BaseException):
        assert re.search(r"^message : str", params, re.M), f"{name}: the message is not documented"
    if issubclass(cls, enum.Enum):  # EventKind("limit"): the value is its one argument
        names = ["value"]
    else:
        try:
            sig = _public(inspect.signature(cls))
        except ValueError:  # the builtin Exception's constructor (*args): the message, checked above
            assert issubclass(cls, BaseException), name
            sig = inspect.Signature()
        names = [p.name for p in sig.parameters.values() if p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)]
    for p in names:
        assert re.search(rf"^(\S.*[ ,])?{p}\b[^\n]*$", params, re.M), \
            f"{name}: constructor parameter {p} is not in the Parameters section"
    _each_entry_names_parameters(name, params)


def _each_entry_names_parameters(name, section):
    """numpydoc reads every unindented line of a Parameters section as ``name[, name...] [: type]``: a
    paragraph of prose there would be shown as a parameter (prose goes above the section)."""
    for line in section.strip("\n").splitlines():
        if line and not line[0].isspace():
            assert re.fullmatch(r"\*{0,2}\w+(, \*{0,2}\w+)*( : .+)?", line), f"{name}: not a parameter entry: {line!r}"


def test_no_public_function_hides_its_keywords_behind_kwargs():
    """``help()`` shows what a function takes: no ``**kwargs`` pass-through, but for the solve keywords a
    drawing forwards to :func:`loopsolve.solve` (named ``solve_kwargs`` and documented as such)."""
    for name in SIGNATURES:
        for p in inspect.signature(getattr(ls, name)).parameters.values():
            if p.kind is p.VAR_KEYWORD:
                assert p.name == "solve_kwargs", (name, p.name)
            assert p.kind is not p.VAR_POSITIONAL, (name, p.name)


@pytest.mark.parametrize("public, implementation", SAME_OPERATION, ids=[p for p, _ in SAME_OPERATION])
def test_a_function_and_a_method_of_the_same_name_take_the_same_arguments(public, implementation):
    cls, _, method = public.rpartition(".")
    fn = getattr(getattr(ls, cls), method) if cls else getattr(ls, public)
    assert _shape(fn, drop_first=True) == _shape(_resolve(implementation), drop_first=True), public


def test_methods_give_what_the_functions_give():
    mech = ls.load(ls.models_dir() / "thesis_crank_rocker.toml")
    assert mech.solve(90, speed="60rpm").row() == ls.solve(mech, 90, speed="60rpm").row()
    a, b = mech.sweep(0, 360, 45, derivatives=1), ls.sweep(mech, 0, 360, 45, derivatives=1)
    assert a.to_csv() == b.to_csv()
    with pytest.raises(TypeError, match="unexpected keyword argument 'sped'"):
        mech.solve(90, sped=1)


@pytest.mark.parametrize("old, new", [("classic", "loopsolve.kinematics.classic"), ("studies", "loopsolve.design.studies"),
                                      ("cad", "loopsolve.output.cad")])
def test_an_old_module_name_still_works_and_warns_with_the_new_path(old, new):
    with pytest.warns(DeprecationWarning, match=rf"loopsolve\.{old} is {new.replace('.', '[.]')} now; .*removed in loopsolve 0\.3"):
        module = getattr(ls, old)
    assert module is sys.modules[new]
    with pytest.warns(DeprecationWarning, match=old):
        exec(f"from loopsolve import {old}", {})  # noqa: S102 - our own package


@pytest.mark.parametrize("package, name, home", [("model", "Mechanism", "mechanism"), ("symbolic", "derive", "loop_equations"),
                                                 ("dynamics", "DynamicsModel", "dynamics_model")])
def test_a_subpackage_s_old_module_names_warn(package, name, home):
    real = _resolve(f"loopsolve.{package}.{home}:{name}")
    with pytest.warns(DeprecationWarning, match=rf"loopsolve\.{package}\.{name} is loopsolve\.{package}\.{home}\.{name} now"):
        assert getattr(getattr(ls, package), name) is real


def test_new_names_do_not_warn_and_types_are_the_implementations():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert ls.ForceSweep is _resolve("loopsolve.dynamics.forceresults:ForceSweep")
        assert ls.SynthesisResult is _resolve("loopsolve.design.synthesis.run:SynthesisResult")
        assert ls.Newton is _resolve("loopsolve.kinematics.newton:Newton")
        assert ls.kinematics.classic is sys.modules["loopsolve.kinematics.classic"]
        from loopsolve.model.mechanism import Mechanism

        assert Mechanism is ls.Mechanism


def test_import_loopsolve_stays_light():
    """The exported types are imported on first use: ``import loopsolve`` loads no sympy, matplotlib,
    xarray, dask or zarr (a CLI call or a script pays only for what it uses)."""
    code = ("import sys, loopsolve; print(sorted(m for m in ('sympy', 'matplotlib', 'xarray', 'dask', 'zarr')"
            " if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


@pytest.mark.parametrize("old, new", [
    ("loopsolve.design.burmester", "loopsolve.design.synthesis.classical.burmester"),
    ("loopsolve.design.synthlm", "loopsolve.design.synthesis.lockstep_lm"),
    ("loopsolve.design.chunklimits", "loopsolve.design.lockstep_limits"),
    ("loopsolve.kinematics.fastlane", "loopsolve.kinematics.numba_engine.steps"),
    ("loopsolve.kinematics.kernel", "loopsolve.kinematics.scalar_solver"),
    ("loopsolve.symbolic.derivation", "loopsolve.symbolic.loop_equations"),
])
def test_an_old_module_path_imports_the_new_module_and_warns(old, new):
    """Issue 31 named the modules by concept: a script importing an old path gets the module at its new one,
    told where it is and when the old path goes (errors.COMPAT_REMOVAL), in a fresh interpreter."""
    code = (f"import warnings, sys; warnings.simplefilter('error', DeprecationWarning)\n"
            f"try:\n    import {old}\nexcept DeprecationWarning as w:\n    print(w)\n"
            f"warnings.simplefilter('ignore')\nimport {old} as a, {new} as b\nprint(a is b, sys.modules['{old}'] is b)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.splitlines()
    assert out[0] == f"{old} is {new} now; the old path is removed in {ls.errors.COMPAT_REMOVAL}"
    assert out[1] == "True True"


def test_an_old_module_path_s_names_import_with_a_warning():
    real = _resolve("loopsolve.design.synthesis.classical.burmester:four_bar")
    code = "from loopsolve.design.burmester import four_bar"
    namespace: dict = {}
    with pytest.warns(DeprecationWarning, match=r"loopsolve\.design\.burmester is loopsolve\.design\.synthesis\.classical\.burmester now"):
        sys.modules.pop("loopsolve.design.burmester", None)
        exec(code, namespace)  # noqa: S102 - our own package
    assert namespace["four_bar"] is real


@pytest.mark.parametrize("package, name, home", [("loopsolve.design.synthesis", "define", "problem"),
                                                 ("loopsolve.design.atlas", "open_atlas", "build")])
def test_an_old_module_that_is_a_package_now_answers_its_names_with_a_warning(package, name, home):
    import importlib

    real = _resolve(f"{package}.{home}:{name}")
    with pytest.warns(DeprecationWarning, match=rf"{package.replace('.', '[.]')}\.{name} is {package.replace('.', '[.]')}\.{home}\.{name} now"):
        assert getattr(importlib.import_module(package), name) is real
    assert importlib.import_module(f"{package}.{home}") is sys.modules[f"{package}.{home}"]  # submodules still import


def test_the_old_module_paths_all_lead_to_modules():
    import importlib

    from loopsolve._moved import MOVED_MODULES

    for old, new in MOVED_MODULES.items():
        assert importlib.import_module(f"loopsolve.{new}").__name__ == f"loopsolve.{new}", old
