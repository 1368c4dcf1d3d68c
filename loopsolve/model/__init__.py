"""The declaration of a mechanism: model files, expressions, units, topology, diagrams, bodies.

See ARCHITECTURE.md for the layers and what lives where."""



def __getattr__(name):
    """``loopsolve.model`` was the module now at ``loopsolve.model.mechanism``: its names answer here too, with a DeprecationWarning naming the new path."""
    import importlib
    import os
    from types import ModuleType

    if name.startswith("__") or os.path.exists(os.path.join(os.path.dirname(__file__), name + ".py")):
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")  # a submodule not imported yet
    value = getattr(importlib.import_module(f"{__name__}.mechanism"), name, None)
    if value is None or isinstance(value, ModuleType):
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    import warnings

    from ..errors import COMPAT_REMOVAL

    warnings.warn(f"{__name__}.{name} is {__name__}.mechanism.{name} now; the old name is removed in {COMPAT_REMOVAL}",
                  DeprecationWarning, stacklevel=2)
    return value
