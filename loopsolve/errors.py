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
    """Base class of every error raised by loopsolve.

    Catch it to handle any problem loopsolve reports (a bad model, a failed solve, a missing
    extra); each subclass also inherits the builtin exception that describes it.

    Parameters
    ----------
    message : str
        What went wrong and what to do, in one line; ``str(error)`` gives it back.

    Attributes
    ----------
    exit_code : int
        The exit status the ``loopsolve`` command uses for this kind of error: 2 for a model or
        usage error, 3 for a solve or assembly failure.

    Examples
    --------
    >>> import loopsolve as ls
    >>> try:
    ...     ls.loads("[mechanism\\n")
    ... except ls.LoopsolveError as exc:
    ...     print(type(exc).__name__, exc.exit_code)
    ModelFileError 2
    """

    #: process exit status used by the command line for this kind of error
    exit_code = 2


class ModelError(LoopsolveError, ValueError):
    """A declaration is invalid (unknown name, wrong count, bad value...).

    Also a ``ValueError``. ``problems`` lists every problem found (one human-readable line each)
    when a whole declaration was validated at once.

    Parameters
    ----------
    message : str
        The error message.
    problems : sequence of str, optional
        Every problem found, one line each; defaults to ``(message,)``.

    Examples
    --------
    A four-bar whose links cannot close at the starting crank angle:

    >>> import loopsolve as ls
    >>> try:
    ...     ls.fourbar(60, 50, 40, 30, theta2=90)
    ... except ls.ModelError as exc:
    ...     print(exc)
    four-bar: cannot be assembled at theta2 = 90 deg; pass another theta2=
    """

    def __init__(self, message: str, *, problems: tuple[str, ...] | list[str] = ()):
        super().__init__(message)
        self.problems = tuple(problems) if problems else (message,)


class ModelFileError(ModelError):
    """A model file cannot be read; names the file, the key and the offending text.

    Raised by :func:`loopsolve.load` and :func:`loopsolve.loads` for TOML that does not parse
    and for a model whose declarations are invalid (every problem is listed at once).

    Parameters
    ----------
    message : str
        The error message.
    path : str, optional
        The model file (``"<string>"`` for :func:`loopsolve.loads`).
    key : str, optional
        The TOML key at fault, when one is.
    problems : sequence of str, optional
        Every problem found, one line each.

    Examples
    --------
    >>> import loopsolve as ls
    >>> try:
    ...     ls.loads('name = "empty"')
    ... except ls.ModelFileError as exc:
    ...     print(len(exc.problems), exc.problems[0])
    3 <string>: variables: no joint variables declared
    """

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
    """Links and joints do not form a valid mechanism (disconnected, DOF mismatch...).

    Raised mostly by kinematic-diagram models (``[[links]]``, ``[[joints]]``), where the vector
    loops are generated from the links and joints. A :class:`ModelError` (a ``ValueError``).

    Parameters
    ----------
    message : str
        The error message.
    problems : sequence of str, optional
        Every problem found, one line each.

    Examples
    --------
    >>> import loopsolve as ls
    >>> issubclass(ls.TopologyError, ls.ModelError), issubclass(ls.TopologyError, ValueError)
    (True, True)
    >>> exc = ls.TopologyError("no [input]: name the driving joint", problems=["no [input]"])
    >>> exc.problems, exc.exit_code
    (('no [input]',), 2)
    """


class SolveError(LoopsolveError, RuntimeError):
    """The numeric solution failed. ``input_value`` is in the model's display unit.

    The base of every solver failure (also a ``RuntimeError``); the command line exits with
    status 3 for it.

    Parameters
    ----------
    message : str
        The error message.
    input_value : float, optional
        The input value where it failed, in the model's display unit (degrees in a degree model).
    result : object, optional
        The partial solution (internal units), when there is one.

    Examples
    --------
    >>> import loopsolve as ls
    >>> triple_rocker = ls.fourbar(60, 50, 40, 30, theta2=10)
    >>> try:
    ...     ls.solve(triple_rocker, 180)
    ... except ls.SolveError as exc:
    ...     print(type(exc).__name__, exc.input_value, exc.exit_code)
    AssemblyError 180.0 3
    """

    exit_code = 3

    def __init__(self, message: str, *, input_value: float | None = None, result: Any = None):
        super().__init__(message)
        self.input_value = input_value
        self.result = result


class ConvergenceError(SolveError):
    """Newton iteration did not converge; ``result`` holds the partial solution.

    Raised by :func:`loopsolve.solve` when Newton's method neither converges nor stalls on a
    residual (a closed loop that has no solution is an :class:`AssemblyError` instead); better
    guesses (``guess=``) or more iterations (``settings=ls.Newton(max_iter=...)``) help.

    Parameters
    ----------
    message : str
        The error message.
    input_value : float, optional
        The input value (display unit).
    result : object, optional
        The last iterate: every variable, internal units.

    Examples
    --------
    The regular models of loopsolve converge in a few iterations, so this shows the fields:

    >>> import loopsolve as ls
    >>> exc = ls.ConvergenceError("no convergence at theta2 = 90 deg", input_value=90.0)
    >>> isinstance(exc, ls.SolveError), exc.input_value, exc.exit_code
    (True, 90.0, 3)
    """


class AssemblyError(SolveError):
    """The mechanism cannot be assembled at the requested input value.

    ``residual`` is the smallest loop-closure residual reached; ``nearest`` lists the
    nearest assemblable input values (display units) when they are known.

    Parameters
    ----------
    message : str
        The error message.
    input_value : float, optional
        The requested input value (display unit).
    residual : float, optional
        The smallest loop-closure residual reached (model length unit).
    nearest : tuple of float, optional
        The nearest assemblable input values (display unit).
    result : object, optional
        The closest approach found (internal units).

    Examples
    --------
    A triple rocker (60, 50, 40, 30) reaches only the crank angles within ±78.46° of 0:

    >>> import loopsolve as ls
    >>> triple_rocker = ls.fourbar(60, 50, 40, 30, theta2=10)
    >>> try:
    ...     ls.solve(triple_rocker, 90)
    ... except ls.AssemblyError as exc:
    ...     print(exc.input_value, [round(v, 2) for v in exc.nearest])
    90.0 [78.46, 281.54]
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

    Parameters
    ----------
    message : str
        The error message.
    mode : str, optional
        The assembly mode asked for (a signature such as ``"+-"``).
    modes : tuple of str, optional
        The signatures of the modes that exist at that input.
    input_value : float, optional
        The input value (display unit).
    result : object, optional
        The partial solution, when there is one.

    Examples
    --------
    >>> import loopsolve as ls
    >>> exc = ls.ModeError("no mode '++' at theta2 = 30 deg", mode="++", modes=("+-", "--"),
    ...                    input_value=30.0)
    >>> isinstance(exc, ls.AssemblyError), exc.mode, exc.modes
    (True, '++', ('+-', '--'))
    """

    def __init__(self, message: str, *, mode: str = "", modes: tuple[str, ...] = (),
                 input_value: float | None = None, result: Any = None):
        super().__init__(message, input_value=input_value, result=result)
        self.mode = mode
        self.modes = tuple(modes)


class SingularPositionError(SolveError):
    """The Jacobian is singular at the solved position (dead centre, toggle, change point).

    ``result`` holds the positions found; rates cannot be computed there.

    Parameters
    ----------
    message : str
        The error message.
    input_value : float, optional
        The input value (display unit).
    cond : float, optional
        The condition number of the coefficient matrix Φ_q there (``inf`` when exactly singular).
    result : object, optional
        The positions found (internal units).

    Examples
    --------
    At θ2 = 0 the triple rocker (60, 50, 40, 30) lies folded flat along the ground link:

    >>> import loopsolve as ls
    >>> triple_rocker = ls.fourbar(60, 50, 40, 30, theta2=10)
    >>> try:
    ...     ls.solve(triple_rocker, 0)
    ... except ls.SingularPositionError as exc:
    ...     print(exc.input_value, exc.cond > 1e6)
    0.0 True
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
    """Branch tracking failed: step below the minimum, or an ambiguous branch.

    A :class:`SolveError` (exit status 3). The sweeps of this release report such places as
    events of the :class:`Sweep` instead (see :class:`EventKind`), so catching
    :class:`SolveError` covers it too.

    Parameters
    ----------
    message : str
        The error message.
    input_value : float, optional
        The input value (display unit).
    result : object, optional
        The partial solution, when there is one.

    Examples
    --------
    >>> import loopsolve as ls
    >>> exc = ls.BranchError("step below the minimum at theta2 = 78.46 deg", input_value=78.46)
    >>> isinstance(exc, ls.SolveError), exc.input_value, exc.exit_code
    (True, 78.46, 3)
    """


class SynthesisError(SolveError):
    """A synthesis found no certified design; ``report`` holds the runs and the rejected candidates.

    Parameters
    ----------
    message : str
        The error message.
    report : dict, optional
        The synthesis report (the contract's dict: runs, rejected candidates), when there is one.

    Examples
    --------
    Three function targets that the Freudenstein four-bar meets only by being taken apart:

    >>> import loopsolve as ls
    >>> targets = {"input": [10, 20, 30], "output": [10, 200, 10]}
    >>> try:
    ...     ls.synthesize(ls.fourbar(60, 25, 70, 45), method="freudenstein", function="theta4",
    ...                   targets=targets)
    ... except ls.SynthesisError as exc:
    ...     print(sorted(exc.report["certificate"]["defects"]), exc.exit_code)
    ['branch', 'circuit'] 3
    """

    def __init__(self, message: str, *, report: Any = None):
        super().__init__(message)
        self.report = report


class MissingDependencyError(LoopsolveError, ImportError):
    """An optional dependency (an extra such as ``loopsolve[plot]``) or program is missing.

    Also an ``ImportError``; the message names the extra to install
    (``pip install 'loopsolve[cad]'``...).

    Parameters
    ----------
    message : str
        What is missing and how to install it.

    Examples
    --------
    >>> import loopsolve as ls
    >>> try:
    ...     raise ls.MissingDependencyError("DXF output needs ezdxf: pip install 'loopsolve[cad]'")
    ... except ImportError as exc:
    ...     print(exc.exit_code, exc)
    2 DXF output needs ezdxf: pip install 'loopsolve[cad]'
    """

    exit_code = 2


#: When the old names kept for compatibility (``loopsolve.classic``, ``loopsolve.model.Mechanism``...) go:
#: until then each use gives one DeprecationWarning naming the new path.
COMPAT_REMOVAL = "loopsolve 0.3 (not before 2027-06-01)"


class LoopsolveWarning(UserWarning):
    """Warnings issued by loopsolve.

    A ``UserWarning``: a sweep that stops at a limit position, guesses on a singular
    configuration, a power balance off by more than round-off... Filter them with the
    ``warnings`` module.

    Parameters
    ----------
    message : str
        The warning text.

    Examples
    --------
    A sweep of the triple rocker (60, 50, 40, 30) stops at its limit position:

    >>> import warnings
    >>> import loopsolve as ls
    >>> triple_rocker = ls.fourbar(60, 50, 40, 30, theta2=10)
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     sw = ls.sweep(triple_rocker, 10, 90, 10)
    >>> caught[0].category is ls.LoopsolveWarning, len(sw)
    (True, 7)
    """


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
    the cause is a declaration, not the solver).

    Parameters
    ----------
    message : str
        The error message.
    residual : float
        Driving power − (dE/dt − loads' power) at the worst row (W).
    scale : float
        The largest power term of that row (W).
    input_value : float
        The input value of that row (display unit).
    model : str, optional
        The model file or name.

    Examples
    --------
    >>> import loopsolve as ls
    >>> exc = ls.PowerBalanceError("the power balance fails at theta2 = 30", residual=2.5,
    ...                            scale=100.0, input_value=30.0, model="press.toml")
    >>> isinstance(exc, ls.ModelError), exc.residual / exc.scale, exc.exit_code
    (True, 0.025, 2)
    """

    def __init__(self, message: str, *, residual: float, scale: float, input_value: float, model: str = ""):
        super().__init__(message)
        self.residual = residual
        self.scale = scale
        self.input_value = input_value
        self.model = model
