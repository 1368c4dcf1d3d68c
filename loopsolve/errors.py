"""The loopsolve exception hierarchy.

Every error a user can provoke is a :class:`LoopsolveError`; each also inherits the builtin
that best describes it (``ValueError`` for bad declarations, ``RuntimeError`` for solver
failures) and carries structured fields naming what went wrong, so callers can react to it
without parsing the message.
"""

from __future__ import annotations

from typing import Any

__all__ = [
    "LoopsolveError",
    "ModelError",
    "ModelFileError",
    "TopologyError",
    "SolveError",
    "ConvergenceError",
    "AssemblyError",
    "ModeError",
    "SingularPositionError",
    "BranchError",
    "MissingDependencyError",
    "PowerBalanceError",
    "LoopsolveWarning",
]


class LoopsolveError(Exception):
    """Base class of every error raised by loopsolve."""

    #: process exit status used by the command line for this kind of error
    exit_code = 2


class ModelError(LoopsolveError, ValueError):
    """A declaration is invalid (unknown name, wrong count, bad value...).

    ``problems`` lists every problem found (one human-readable line each) when a whole
    declaration was validated at once.
    """

    def __init__(self, message: str, *, problems: tuple[str, ...] | list[str] = ()):
        super().__init__(message)
        self.problems = tuple(problems) if problems else (message,)


class ModelFileError(ModelError):
    """A model file cannot be read; names the file, the key and the offending text."""

    def __init__(
        self,
        message: str,
        *,
        path: str | None = None,
        key: str | None = None,
        problems: tuple[str, ...] | list[str] = (),
    ):
        super().__init__(message, problems=problems)
        self.path = path
        self.key = key


class TopologyError(ModelError):
    """Links and joints do not form a valid mechanism (disconnected, DOF mismatch...)."""


class SolveError(LoopsolveError, RuntimeError):
    """The numeric solution failed. ``input_value`` is in the model's display unit."""

    exit_code = 3

    def __init__(self, message: str, *, input_value: float | None = None, result: Any = None):
        super().__init__(message)
        self.input_value = input_value
        self.result = result


class ConvergenceError(SolveError):
    """Newton iteration did not converge; ``result`` holds the partial solution."""


class AssemblyError(SolveError):
    """The mechanism cannot be assembled at the requested input value.

    ``residual`` is the smallest loop-closure residual reached; ``nearest`` lists the
    nearest assemblable input values (display units) when they are known.
    """

    def __init__(
        self,
        message: str,
        *,
        input_value: float | None = None,
        residual: float | None = None,
        nearest: tuple[float, ...] = (),
        result: Any = None,
    ):
        super().__init__(message, input_value=input_value, result=result)
        self.residual = residual
        self.nearest = tuple(nearest)


class ModeError(AssemblyError):
    """The mechanism assembles at the requested input, but not in the requested assembly mode.

    ``mode`` is the signature asked for (by ``--mode`` or by the guesses), ``modes`` the
    signatures of the real solutions that exist there.
    """

    def __init__(self, message: str, *, mode: str = "", modes: tuple[str, ...] = (),
                 input_value: float | None = None, result: Any = None):
        super().__init__(message, input_value=input_value, result=result)
        self.mode = mode
        self.modes = tuple(modes)


class SingularPositionError(SolveError):
    """The Jacobian is singular at the solved position (dead centre, toggle, change point).

    ``state`` holds the positions found; rates cannot be computed there.
    """

    def __init__(
        self,
        message: str,
        *,
        input_value: float | None = None,
        cond: float | None = None,
        result: Any = None,
    ):
        super().__init__(message, input_value=input_value, result=result)
        self.cond = cond


class BranchError(SolveError):
    """Branch tracking failed: step below the minimum, or an ambiguous branch."""


class SynthesisError(SolveError):
    """A synthesis found no certified design; ``report`` holds the runs and the rejected candidates."""

    def __init__(self, message: str, *, report: Any = None):
        super().__init__(message)
        self.report = report


class MissingDependencyError(LoopsolveError, ImportError):
    """An optional dependency (an extra such as ``loopsolve[plot]``) or program is missing."""

    exit_code = 2


#: When the old names kept for compatibility (``loopsolve.classic``, ``loopsolve.model.Mechanism``...) go:
#: until then each use gives one DeprecationWarning naming the new path.
COMPAT_REMOVAL = "loopsolve 0.3 (not before 2027-06-01)"


class LoopsolveWarning(UserWarning):
    """Warnings issued by loopsolve."""


def warn(message: str) -> None:
    """Issue a :class:`LoopsolveWarning` attributed to the caller's code, not to loopsolve's internals."""
    import os
    import sys
    import warnings

    here = os.path.dirname(os.path.abspath(__file__)) + os.sep
    level, frame = 2, sys._getframe(1)  # stacklevel 2 is the frame that called warn()
    while frame is not None and os.path.abspath(frame.f_code.co_filename).startswith(here):
        frame, level = frame.f_back, level + 1
    warnings.warn(message, LoopsolveWarning, stacklevel=level)


class PowerBalanceError(ModelError):
    """The power balance of a force result fails: the declarations do not describe one mechanism.

    Driving power − (dE/dt − loads' power) is above round-off (exit status 2, as a model error:
    the cause is a declaration, not the solver). ``residual`` (W), ``scale`` (W, the largest power
    term of that row), ``input_value`` (display units), ``model``.
    """

    def __init__(self, message: str, *, residual: float, scale: float, input_value: float, model: str = ""):
        super().__init__(message)
        self.residual = residual
        self.scale = scale
        self.input_value = input_value
        self.model = model
