"""Old module paths of loopsolve, before the modules were named by concept (issue 31).

One table, :data:`MOVED_MODULES` (old path: new path, both under ``loopsolve.``), and one mechanism:
``import loopsolve.design.burmester`` (or ``from loopsolve.kinematics.fastlane import ...``) gives the
module at its new path, with one DeprecationWarning naming that path and the release that removes the
old one (:data:`loopsolve.errors.COMPAT_REMOVAL`). An old path that is a package now
(``loopsolve.design.synthesis``, ``loopsolve.design.atlas``, and ``loopsolve.symbolic`` and
``loopsolve.dynamics``, which were single modules before issue 24) answers the old module's names
through :func:`old_name`, with the same warning. ``import loopsolve`` installs the finder.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys
import warnings
from pathlib import Path
from types import ModuleType

from .errors import COMPAT_REMOVAL

MOVED_MODULES = {
    "design.synthesis": "design.synthesis.problem",
    "design.synthrun": "design.synthesis.run",
    "design.synthbatch": "design.synthesis.candidates",
    "design.synthlm": "design.synthesis.lockstep_lm",
    "design.synthreq": "design.synthesis.requirements",
    "design.synthreport": "design.synthesis.report",
    "design.synthlimits": "design.synthesis.limits",
    "design.synthdesign": "design.synthesis.design_model",
    "design.certify": "design.synthesis.certificate",
    "design.structerr": "design.synthesis.structural_error",
    "design.targets": "design.synthesis.targets",
    "design.classicsynth": "design.synthesis.classical.run",
    "design.classicmap": "design.synthesis.classical.transplant",
    "design.classicmotion": "design.synthesis.classical.motion",
    "design.freudenstein": "design.synthesis.classical.freudenstein",
    "design.burmester": "design.synthesis.classical.burmester",
    "design.burmsearch": "design.synthesis.classical.burmester_search",
    "design.linkcheck": "design.synthesis.classical.verdict",
    "design.shape": "design.synthesis.shape.run",
    "design.shapematch": "design.synthesis.shape.retrieval",
    "design.pathatlas": "design.synthesis.shape.path_starts",
    "design.atlas": "design.atlas.build",
    "design.atlasdefault": "design.atlas.defaults",
    "design.atlasstore": "design.atlas.store",
    "design.atlastrace": "design.atlas.trace",
    "design.descriptors": "design.atlas.descriptors",
    "design.frame": "design.atlas.frame",
    "design.chunklimits": "design.lockstep_limits",
    "kinematics.kernel": "kinematics.scalar_solver",
    "kinematics.fastlane": "kinematics.numba_engine.steps",
    "kinematics.numbakin": "kinematics.numba_engine.jit",
    "symbolic.derivation": "symbolic.loop_equations",
    "dynamics.derivation": "dynamics.dynamics_model",
    # packages that were one module before issue 24: their names answer through old_name
    "symbolic": "symbolic.loop_equations",
    "dynamics": "dynamics.dynamics_model",
}

_PACKAGE = Path(__file__).parent


def _warn(old: str, new: str) -> None:
    warnings.warn(f"{old} is {new} now; the old path is removed in {COMPAT_REMOVAL}", DeprecationWarning,
                  stacklevel=4)  # the caller of the package's __getattr__


def old_name(package: str, name: str):
    """``package.name`` where ``package`` was the module now at ``MOVED_MODULES[package]``: that module's
    ``name``, with a DeprecationWarning; AttributeError for anything else (a submodule not imported yet)."""
    short = package.removeprefix("loopsolve.")
    where = _PACKAGE.joinpath(*short.split("."), name)
    if name.startswith("__") or where.with_suffix(".py").exists() or where.is_dir():
        raise AttributeError(f"module {package!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f"loopsolve.{MOVED_MODULES[short]}"), name, None)
    if value is None or isinstance(value, ModuleType):
        raise AttributeError(f"module {package!r} has no attribute {name!r}")
    _warn(f"{package}.{name}", f"loopsolve.{MOVED_MODULES[short]}.{name}")
    return value


class _OldPaths(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Finds an old module path that no file answers any more, and loads the module at its new path."""

    def find_spec(self, fullname, path=None, target=None):
        short = fullname.removeprefix("loopsolve.")
        if fullname.startswith("loopsolve.") and short in MOVED_MODULES:
            return importlib.util.spec_from_loader(fullname, self)
        return None

    def create_module(self, spec):
        return None  # the default module, replaced in sys.modules by exec_module

    def exec_module(self, module):
        new = f"loopsolve.{MOVED_MODULES[module.__name__.removeprefix('loopsolve.')]}"
        warnings.warn(f"{module.__name__} is {new} now; the old path is removed in {COMPAT_REMOVAL}",
                      DeprecationWarning, stacklevel=2)
        sys.modules[module.__name__] = importlib.import_module(new)  # the import system returns this entry


def install() -> None:
    """Put the finder last on ``sys.meta_path`` (the real files are found first), once."""
    if not any(isinstance(f, _OldPaths) for f in sys.meta_path):
        sys.meta_path.append(_OldPaths())
