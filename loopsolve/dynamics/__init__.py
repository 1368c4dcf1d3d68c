"""Forces, the equation of motion and simulation of one-degree-of-freedom mechanisms.

See ARCHITECTURE.md for the layers and what lives where."""



def __getattr__(name):
    """``loopsolve.dynamics`` was one module before issue 24: its names answer here too, with a DeprecationWarning
    naming the new path (:mod:`loopsolve._moved`)."""
    from .._moved import old_name

    return old_name(__name__, name)
