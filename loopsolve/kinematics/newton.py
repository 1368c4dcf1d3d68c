"""Damped Newton iteration for square systems, with a status that says what happened.

The step is the Newton step when the Jacobian is well conditioned and a Levenberg–Marquardt
step otherwise; a backtracking line search on ‖f‖² makes it globally convergent to a
solution *or* to a local minimum of the residual. The two are told apart at the end: a
minimum with a residual well above the tolerance means the equations have no real solution
near the start (a mechanism that cannot be assembled there).

References: J. E. Dennis and R. B. Schnabel, *Numerical Methods for Unconstrained
Optimization and Nonlinear Equations*, SIAM 1996, ch. 6.
"""

from __future__ import annotations

import enum
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

__all__ = ["Newton", "NewtonStatus", "NewtonResult", "newton"]


class NewtonStatus(enum.Enum):
    """Outcome of :func:`newton`; each value says what it means and what to do."""

    CONVERGED = "converged"
    STALLED = ("stalled at a nonzero minimum of the residual: the equations have no real solution "
               "near the starting point (the mechanism cannot be assembled there)")
    MAX_ITER = "iteration limit reached while the residual was still decreasing: raise max_iter or improve the guess"
    NOT_FINITE = "the residual became NaN or infinite: check the parameters (zero lengths?)"


@dataclass(frozen=True, slots=True)
class Newton:
    """Settings of :func:`~loopsolve.kinematics.newton.newton` (``settings=`` of :func:`loopsolve.solve` and :func:`loopsolve.sweep`).

    ``atol`` is relative to the system's length scale (the residual of a loop is a length);
    ``rtol`` bounds the final step relative to ``1 + |x|``.

    Parameters
    ----------
    atol : float, optional
        Absolute tolerance on the loop-closure residual, relative to the system's length scale
        (the residual of a loop is a length); default 1e-12.
    rtol : float, optional
        Bound on the final Newton step relative to ``1 + |x|``; default 1e-12.
    max_iter : int, optional
        Iterations allowed; default 60.
    stall_tol : float, optional
        A residual that stops decreasing above this (relative to the length scale) is a stall:
        the loops have no real solution there (an :class:`AssemblyError`); default 1e-9.

    Examples
    --------
    >>> import loopsolve as ls
    >>> mech = ls.load(ls.models_dir() / "thesis_crank_rocker.toml")
    >>> loose = ls.Newton(atol=1e-8, max_iter=20)
    >>> round(ls.solve(mech, 90, settings=loose)["theta4"], 4)
    80.7225
    >>> loose.max_iter, ls.Newton().atol
    (20, 1e-12)
    """

    atol: float = 1e-12
    rtol: float = 1e-12
    max_iter: int = 60
    stall_tol: float = 1e-9


@dataclass(frozen=True, slots=True)
class NewtonResult:
    """``x`` reached, its residual norm (∞-norm), iterations, status."""

    x: np.ndarray
    residual: float
    n_iter: int
    status: NewtonStatus

    @property
    def success(self) -> bool:
        return self.status is NewtonStatus.CONVERGED


def newton(fun: Callable[[np.ndarray], np.ndarray], jac: Callable[[np.ndarray], np.ndarray],
           x0: np.ndarray, *, scale: float = 1.0, settings: Newton = Newton()) -> NewtonResult:
    """Solve ``fun(x) = 0`` from ``x0``.

    Examples
    --------
    >>> import numpy as np
    >>> r = ls.newton.newton(lambda x: np.array([x[0]**2 - 2]), lambda x: np.array([[2*x[0]]]),
    ...                      np.array([1.0]))
    >>> r.status.name, round(float(r.x[0]), 12)
    ('CONVERGED', 1.414213562373)
    """
    with np.errstate(all="ignore"):  # overflow and NaN are detected and reported by status
        return _newton(fun, jac, x0, scale=scale, settings=settings)


def _newton(fun, jac, x0, *, scale, settings) -> NewtonResult:
    fun, jac = _guarded(fun), _guarded(jac, matrix=True)
    x = np.array(x0, dtype=float)
    if not np.all(np.isfinite(x)):
        return NewtonResult(x, float("nan"), 0, NewtonStatus.NOT_FINITE)
    f = fun(x)
    fn = float(np.max(np.abs(f))) if f.size else 0.0
    tol = settings.atol * scale
    polished = False
    for it in range(1, settings.max_iter + 1):
        if not np.isfinite(fn):
            return NewtonResult(x, fn, it, NewtonStatus.NOT_FINITE)
        J = jac(x)
        dx = _step(J, f)
        if not np.all(np.isfinite(dx)):
            return NewtonResult(x, fn, it, NewtonStatus.NOT_FINITE)
        # backtracking line search on the 2-norm of f (compared as norms: f·f overflows past 1e154)
        f2 = _norm2(f)
        t = 1.0
        while True:
            x_new = x + t * dx
            f_new = fun(x_new)
            f2_new = _norm2(f_new)
            if np.isfinite(f2_new) and (f2_new <= np.sqrt(1 - 1e-4 * t) * f2 or f2 <= tol * 1e-3):
                break
            t *= 0.5
            if t < 1e-10:
                # no descent possible along the (regularized) Newton direction
                if fn <= settings.stall_tol * scale:
                    return NewtonResult(x, fn, it, NewtonStatus.CONVERGED)
                return NewtonResult(x, fn, it, NewtonStatus.STALLED)
        step = float(np.max(np.abs(t * dx))) if dx.size else 0.0
        x, f = x_new, f_new
        fn = float(np.max(np.abs(f))) if f.size else 0.0
        if fn <= tol:
            if polished or step <= settings.rtol * (1.0 + float(np.max(np.abs(x)))):
                return NewtonResult(x, fn, it, NewtonStatus.CONVERGED)
            polished = True  # one more step: quadratic convergence reaches machine precision
    if fn <= tol:
        return NewtonResult(x, fn, settings.max_iter, NewtonStatus.CONVERGED)
    return NewtonResult(x, fn, settings.max_iter, NewtonStatus.MAX_ITER)


def _guarded(fn: Callable[[np.ndarray], np.ndarray], *, matrix: bool = False) -> Callable[[np.ndarray], np.ndarray]:
    """``fn`` with math errors (``sqrt`` of a negative, ``0.0**-1``, overflow) turned into NaN.

    Generated scalar code uses :mod:`math`, which raises where numpy would give NaN/inf; Newton
    then backtracks (line search) or reports ``NOT_FINITE`` instead of leaking a bare error.
    The system is square, so the NaN result has shape ``(n,)`` or ``(n, n)`` for ``x`` of size n.
    """

    def wrapped(x: np.ndarray) -> np.ndarray:
        try:
            return fn(x)
        except (ArithmeticError, ValueError):
            n = len(x)
            return np.full((n, n) if matrix else n, np.nan)

    return wrapped


def _norm2(f: np.ndarray) -> float:
    """Euclidean norm without overflow of the squares (inf or NaN when ``f`` is not finite)."""
    if not f.size:
        return 0.0
    big = float(np.max(np.abs(f)))
    if not np.isfinite(big):
        return big if not np.isnan(big) else float("nan")
    if big == 0.0:
        return 0.0
    return big * float(np.sqrt(np.sum((f / big) ** 2)))


def _step(J: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Newton step, or a Levenberg–Marquardt step when ``J`` is (nearly) singular.

    ``J`` and ``f`` are divided by the largest entry of ``J`` first (the step is unchanged),
    so ``JᵀJ`` cannot overflow for a model whose lengths are near the float range.
    """
    if not np.all(np.isfinite(J)):
        return np.full(J.shape[1], np.nan)
    big = float(np.max(np.abs(J))) if J.size else 0.0
    if big > 0.0:
        J, f = J / big, f / big
    try:
        cond = np.linalg.cond(J)
    except np.linalg.LinAlgError:
        cond = np.inf
    if np.isfinite(cond) and cond < 1e10:
        return np.linalg.solve(J, -f)
    g = J.T @ f
    mu = 1e-6 * max(float(np.max(np.abs(J.T @ J))), 1e-300)
    return np.linalg.solve(J.T @ J + mu * np.eye(J.shape[1]), -g)
