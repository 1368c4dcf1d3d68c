"""Symbolic derivation (sympy), the generated numeric code and its cache, the TeX printer.

See ARCHITECTURE.md for the layers and what lives where."""



def __getattr__(name):
    """``loopsolve.symbolic`` was one module before issue 24: its names answer here too, with a DeprecationWarning
    naming the new path (:mod:`loopsolve._moved`)."""
    from .._moved import old_name

    return old_name(__name__, name)
