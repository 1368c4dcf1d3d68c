"""Four-bar function generation by Freudenstein's equation, checked by the tracker.

With the ground r1 along +x from the input pivot, input r2 at θ2, coupler r3, output r4 at θ4
(loop ``r2 + r3 = r1 + r4``), squaring the loop to eliminate θ3 gives Freudenstein's equation
(the notes, ../shared/seeds/000_*.txt, eq. (A))::

    K1 cos θ4 − K2 cos θ2 + K3 = cos(θ2 − θ4),
    K1 = r1/r2,  K2 = r1/r4,  K3 = (r1² + r2² + r4² − r3²) / (2 r2 r4).

It is linear in K: three precision points (θ2ᵢ, θ4ᵢ) give K exactly, more points a linear
least-squares K. A negative K1 or K2 means a negative r2 or r4: the physical link points the
other way (its angle is the Freudenstein angle + 180°), which the built model says with an
``offset``. The input and output angles of the model are those of the function generator:
``theta2`` (the input, x mapped linearly onto the input range) and ``theta4`` (the output).

The closed form says nothing about whether the linkage can move through its precision points,
nor what it does between them: :func:`freudenstein` builds the model and lets the tracker
answer (:class:`FunctionDesign`): the mode through the precision points, a ``range`` defect with
the located limit when part of the intended input range is unreachable, ``branch``/``circuit``
defects when the precision points are not on one motion, the structural error over the whole
input range and the Grashof class. ``fit="minimax"`` (optionally with ``free_offsets=True``,
the input and output reference angles α, β as design variables) minimizes the largest
structural error over the range instead of meeting a few points exactly.

References: F. Freudenstein, "Approximate synthesis of four-bar linkages", Trans. ASME 77 (1955);
Chebyshev spacing as in Norton, *Design of Machinery*, and Sandor & Erdman, *Advanced
Mechanism Design*.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from ....kinematics.classic import GrashofClass, grashof
from ....errors import ModelError, SolveError
from .verdict import Defect, circuit_sign, track_between

__all__ = ["FunctionDesign", "chebyshev_spacing", "freudenstein", "freudenstein_points", "freudenstein_constants",
           "links_from_constants", "fourbar_output"]


def chebyshev_spacing(lo: float, hi: float, n: int = 3) -> np.ndarray:
    """Chebyshev spacing of ``n`` precision points on ``[lo, hi]``.

    ``xⱼ = (lo + hi)/2 − (hi − lo)/2 · cos((2j − 1)π / 2n)``, j = 1 … n.

    Examples
    --------
    >>> from loopsolve.design.synthesis.classical.freudenstein import chebyshev_spacing
    >>> [round(float(v), 4) for v in chebyshev_spacing(1, 10, 3)]
    [1.6029, 5.5, 9.3971]
    """
    if not (isinstance(n, (int, np.integer)) and n >= 1):
        raise ModelError(f"points = {n!r}: need a whole number of precision points, at least 1")
    if not (math.isfinite(lo) and math.isfinite(hi) and hi != lo):
        raise ModelError(f"range [{lo}, {hi}]: need two different finite ends")
    j = np.arange(1, n + 1)
    return (lo + hi) / 2 - (hi - lo) / 2 * np.cos((2 * j - 1) * np.pi / (2 * n))


def freudenstein_constants(theta2, theta4) -> np.ndarray:
    """K = (K1, K2, K3) from precision points (radians): exact for three, least squares for more.

    Examples
    --------
    >>> from loopsolve.design.synthesis.classical.freudenstein import freudenstein_constants
    >>> t2, t4 = np.radians([40, 60, 80]), np.radians([70, 85, 105])
    >>> K = freudenstein_constants(t2, t4)
    >>> bool(np.allclose(K[0] * np.cos(t4) - K[1] * np.cos(t2) + K[2], np.cos(t2 - t4)))
    True
    """
    t2, t4 = np.asarray(theta2, dtype=float), np.asarray(theta4, dtype=float)
    if t2.shape != t4.shape or t2.ndim != 1 or len(t2) < 3:
        raise ModelError(f"Freudenstein's equation needs at least three precision points (got {t2.size})")
    a = np.column_stack([np.cos(t4), -np.cos(t2), np.ones_like(t2)])
    b = np.cos(t2 - t4)
    if np.linalg.matrix_rank(a, tol=1e-10 * max(1.0, np.abs(a).max())) < 3:
        raise ModelError("the precision points do not determine K1, K2, K3 (repeated or symmetric angles): "
                         "choose other points")
    if len(t2) == 3:
        return np.linalg.solve(a, b)
    return np.linalg.lstsq(a, b, rcond=None)[0]


def links_from_constants(K, r1: float = 1.0) -> tuple[float, float, float, float]:
    """Signed lengths (r1, r2, r3, r4) from K; r2 or r4 negative when K1 or K2 is.

    Raises :class:`ModelError` when r3² ≤ 0 (no real coupler: K describes no four-bar).

    Examples
    --------
    >>> from loopsolve.design.synthesis.classical.freudenstein import links_from_constants
    >>> [round(v, 4) for v in links_from_constants((2.0, 1.5, 0.9), 1.0)]
    [1.0, 0.5, 1.0462, 0.6667]
    """
    k1, k2, k3 = (float(v) for v in K)
    if k1 == 0 or k2 == 0:
        raise ModelError(f"K1 = {k1:g}, K2 = {k2:g}: a zero constant means an infinite link; choose other points")
    r2, r4 = r1 / k1, r1 / k2
    r3sq = r1 * r1 + r2 * r2 + r4 * r4 - 2 * r2 * r4 * k3
    if not r3sq > 0:
        raise ModelError(f"K = ({k1:.6g}, {k2:.6g}, {k3:.6g}) gives r3² = {r3sq:.6g} ≤ 0: no four-bar meets these "
                         "precision points; choose other points or ranges")
    return r1, r2, math.sqrt(r3sq), r4


def fourbar_output(K, theta2, sign: int):
    """Output angle θ4 (radians) of the Freudenstein linkage at inputs θ2, in the root ``sign``.

    Returns ``(theta4, ok)``; ``ok`` is False where the linkage cannot be assembled.
    ``(K1 − cos θ2) cos θ4 − sin θ2 sin θ4 + (K3 − K2 cos θ2) = 0`` is
    ``R cos(θ4 − ψ) = −C``: θ4 = ψ ± acos(−C/R); one sign is one assembly mode.
    """
    k1, k2, k3 = K
    t2 = np.asarray(theta2, dtype=float)
    a, b, c = k1 - np.cos(t2), -np.sin(t2), k3 - k2 * np.cos(t2)
    r = np.hypot(a, b)
    with np.errstate(invalid="ignore", divide="ignore"):
        q = -c / r
    ok = np.abs(q) <= 1.0
    return np.arctan2(b, a) + sign * np.arccos(np.clip(q, -1.0, 1.0)), ok


def _wrap(a):
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


def _root_sign(K, t2, t4) -> int:
    """The root of :func:`fourbar_output` that holds (θ2, θ4)."""
    e = [abs(float(_wrap(fourbar_output(K, t2, s)[0] - t4))) for s in (1, -1)]
    return 1 if e[0] <= e[1] else -1


@dataclass(frozen=True)
class FunctionDesign:
    """A four-bar function generator and the tracker's verdict on it.

    Angles in degrees; ``x``/``y`` in the function's units. ``K`` are Freudenstein's constants
    for the angles θ2 + α, θ4 + β. ``lengths`` are the physical (positive) r1 … r4 in the model's
    length unit. ``mechanism`` is the model (input ``theta2``, output ``theta4``) with the guesses
    at the first precision point, in the mode that passes through it (``mode``).
    ``defects`` empty means certified: one motion of the input in ``mode``, crossing no limit,
    meets every precision point and covers the whole intended input range.
    ``precision`` holds the wanted values ``(x, y, input angle, output angle)`` of each point (never
    the linkage's), ``outputs`` the linkage's output angle at each point's input (degrees, within
    half a turn of the wanted one; None where it cannot be assembled); ``root`` the sign of the
    closed-form output (:func:`~loopsolve.design.synthesis.classical.freudenstein.fourbar_output`) the design follows.
    ``max_error`` is the largest ``|θ4 − θ4_desired|`` over the reachable part of the input range
    (degrees of output; from precision points alone: the largest ``|output − wanted|`` at them),
    ``max_error_y`` the same in the function's units (``max_error`` times the function units per
    output degree); ``error_input``/``error`` the curve it comes from (input angle, signed error
    design − wanted, degrees).

    Users receive a design from :func:`loopsolve.freudenstein`; they need not construct one.

    Parameters
    ----------
    K, lengths, offsets, fit, precision, input_range, output_range
        The design asked for and found (see Attributes).
    mechanism, mode, grashof, defects
        Its model and the tracker's verdict.
    max_error, max_error_y, error_input, error, reachable, suggestion, redesign, outputs, root
        Its structural error and what to do about it.

    Attributes
    ----------
    K : tuple of float
        Freudenstein's constants (K1, K2, K3) for the angles θ2 + α, θ4 + β.
    lengths : tuple of float
        r1 (ground), r2 (input), r3 (coupler), r4 (output), positive, in the model's length unit.
    offsets : tuple of float
        α and β (degrees): the input and output links' angles are θ2 + α, θ4 + β.
    fit : str
        ``"exact"`` (three precision points) or ``"least-squares"``.
    precision : tuple of tuple of float
        The wanted ``(x, y, input angle, output angle)`` of each precision point.
    input_range, output_range : tuple of float
        The intended input and output angle ranges (degrees).
    mechanism : Mechanism
        The model (input ``theta2``, output ``theta4``), its guesses at the first precision point.
    mode : str
        The assembly mode that passes through the first precision point.
    grashof : GrashofClass
        The linkage's Grashof class (crank-rocker, triple rocker...).
    defects : tuple of Defect
        Empty means certified; each names a defect (``kind``, ``message``, ``input``).
    max_error : float
        The largest ``|θ4 − θ4_desired|`` over the reachable part of the input range (degrees).
    max_error_y : float
        The same in the function's units.
    error_input, error : numpy.ndarray
        The error curve: input angle and signed error design − wanted (degrees).
    reachable : tuple of float or None
        The reachable part of the input range (degrees), when it is not the whole range.
    suggestion : str
        A hint for a better design, when there are defects.
    redesign : callable or None
        Re-runs the design with changed options.
    outputs : tuple
        The linkage's output angle at each precision point's input (degrees; None where it cannot
        be assembled).
    root : int
        The sign of the closed-form output the design follows.

    Examples
    --------
    >>> import numpy as np
    >>> import loopsolve as ls
    >>> d = ls.freudenstein(np.log10, (1, 10), (45, 105), (135, 225))
    >>> [round(r, 2) for r in d.lengths], d.mode, d.grashof.name
    ([100.0, 49.93, 220.18, 143.14], '-', 'TRIPLE_ROCKER')
    >>> [x.kind for x in d.defects], round(d.max_error, 2)
    (['range'], 5.68)
    """

    K: tuple[float, float, float]
    lengths: tuple[float, float, float, float]
    offsets: tuple[float, float]
    fit: str
    precision: tuple[tuple[float, float, float, float], ...]
    input_range: tuple[float, float]
    output_range: tuple[float, float]
    mechanism: object
    mode: str
    grashof: GrashofClass
    defects: tuple[Defect, ...]
    max_error: float
    max_error_y: float
    error_input: np.ndarray = field(repr=False)
    error: np.ndarray = field(repr=False)
    reachable: tuple[float, float] | None = None
    suggestion: str = ""
    redesign: Callable | None = field(default=None, repr=False, compare=False)
    outputs: tuple = ()
    root: int = 1

    @property
    def certified(self) -> bool:
        return not self.defects

    def alternative(self, **changes) -> "FunctionDesign":
        """The same job designed another way: by default ``fit="minimax", points=7, free_offsets=True``.

        ``changes`` override any option of :func:`freudenstein` (``fit``, ``points``,
        ``free_offsets``, ``max_link_ratio``, ...); the function and the ranges stay.

        Examples
        --------
        >>> d = ls.freudenstein(np.log10, (1, 10), (45, 105), (135, 225))
        >>> alt = d.alternative()
        >>> d.certified, alt.certified, round(alt.max_error, 2)
        (False, True, 0.08)
        """
        if self.redesign is None:
            raise ModelError("this design was made from precision points alone (no function): call "
                             "freudenstein(...) with the function to design it another way")
        options = {"fit": "minimax", "points": 7, "free_offsets": True, **changes}
        return self.redesign(**options)

    def to_dict(self) -> dict:
        """A JSON-ready summary (the numbers and the defects)."""
        return {"method": "freudenstein", "fit": self.fit, "K": list(self.K), "lengths": list(self.lengths),
                "offsets": list(self.offsets), "mode": self.mode, "grashof": self.grashof.value,
                "precision": [dict(zip(("x", "y", "input", "output"), p), design_output=o,
                                   error=None if o is None else o - p[3])
                              for p, o in zip(self.precision, self.outputs or [None] * len(self.precision))],
                "max_error_deg": self.max_error, "max_error_y": self.max_error_y,
                "reachable": list(self.reachable) if self.reachable else None,
                "certified": self.certified, "defects": [d.to_dict() for d in self.defects],
                "suggestion": self.suggestion}


def _build(lengths_signed, offsets, z0_deg, name: str, length_unit: str):
    """The four-bar model: theta2/theta4 are the generator's input/output angles."""
    from ....model.builder import MechanismBuilder

    r1, r2, r3, r4 = lengths_signed
    al, be = offsets
    b = MechanismBuilder(name, length_unit=length_unit, angle_unit="deg")
    for n, v in (("r1", r1), ("r2", abs(r2)), ("r3", r3), ("r4", abs(r4)), ("alpha", al), ("beta", be)):
        b.parameter(n, round(float(v), 12))
    t2, t3, t4 = z0_deg
    b.variable("theta2", input=True, guess=round(float(t2), 9)).variable("theta3", guess=round(float(t3), 9))
    b.variable("theta4", guess=round(float(t4), 9))
    b.vector("r1", length="r1", angle=0)
    b.vector("r2", length="r2", angle="theta2", offset="alpha + 180" if r2 < 0 else "alpha")
    b.vector("r3", length="r3", angle="theta3")
    b.vector("r4", length="r4", angle="theta4", offset="beta + 180" if r4 < 0 else "beta")
    b.loop("r2 + r3 = r1 + r4").point("O2", "0").point("B", "r2").point("C", "r2 + r3").point("O4", "r1")
    return b.build()


def _theta3(lengths_signed, t2f, t4f) -> float:
    r1, r2, r3, r4 = lengths_signed
    v = r1 + r4 * complex(math.cos(t4f), math.sin(t4f)) - r2 * complex(math.cos(t2f), math.sin(t2f))
    return math.atan2(v.imag, v.real)


def _ratio_excess(K, max_ratio) -> float:
    """How far the link ratio (longest/shortest) exceeds ``max_ratio`` (and r3² ≤ 0), 0 when within."""
    k1, k2, k3 = K
    if k1 == 0 or k2 == 0:
        return 1e3
    r2, r4 = 1.0 / k1, 1.0 / k2
    r3sq = 1.0 + r2 * r2 + r4 * r4 - 2 * r2 * r4 * k3
    if r3sq <= 0:
        return 1.0 - r3sq
    if max_ratio is None:
        return 0.0
    L = np.array([1.0, abs(r2), math.sqrt(r3sq), abs(r4)])
    return max(0.0, float(L.max() / L.min()) - max_ratio)


def _fit_minimax(K0, sign, t2, t4, free_offsets: bool, offsets0=(0.0, 0.0), max_ratio=None):
    """Minimize max |θ4(θ2) − θ4_desired| over the samples (radians), the root ``sign`` fixed.

    Returns ``(p, max error)`` or None when no design assembles over the whole range (and keeps
    the link ratio within ``max_ratio``).
    """
    from scipy.optimize import least_squares, minimize

    def errors(p):
        K = p[:3]
        al, be = (p[3], p[4]) if free_offsets else offsets0
        out, ok = fourbar_output(K, t2 + al, sign)
        e = _wrap(out - be - t4)
        return e, ok

    def resid(p):  # beyond a limit: the clipped angle's error plus a penalty that leads back
        K = p[:3]
        al = p[3] if free_offsets else offsets0[0]
        e, ok = errors(p)
        k1, k2, k3 = K
        a, b, c = k1 - np.cos(t2 + al), -np.sin(t2 + al), k3 - k2 * np.cos(t2 + al)
        excess = np.maximum(np.abs(c) / np.maximum(np.hypot(a, b), 1e-300) - 1.0, 0.0)
        return e + np.sign(e + 1e-300) * 10.0 * excess

    def resid_all(p):
        return np.r_[resid(p), 10.0 * _ratio_excess(p[:3], max_ratio)]

    def feasible(p):
        return errors(p)[1].all() and _ratio_excess(p[:3], max_ratio) <= 1e-9

    p0 = np.r_[K0, offsets0] if free_offsets else np.asarray(K0, dtype=float)
    p = least_squares(resid_all, p0, method="lm", xtol=1e-14, ftol=1e-14).x
    if not feasible(p):
        return None
    e = errors(p)[0]
    n = len(p)
    cons = [{"type": "ineq", "fun": lambda v: np.r_[v[n] - resid(v[:n]), v[n] + resid(v[:n])]}]
    if max_ratio is not None:
        cons.append({"type": "ineq", "fun": lambda v: -_ratio_excess(v[:3], max_ratio)})
    r = minimize(lambda v: v[n], np.r_[p, np.abs(e).max()], constraints=cons, method="SLSQP",
                 options={"maxiter": 400, "ftol": 1e-16})
    q = r.x[:n]
    eq = errors(q)[0]
    if feasible(q) and np.abs(eq).max() < np.abs(e).max():
        p, e = q, eq
    return p, float(np.abs(e).max())


def _free_offset_starts(t2, t4, count: int = 4, max_ratio=None):
    """The ``count`` best (K, α, β, sign) of linear least-squares designs over a grid of reference angles."""
    found = []
    for al in np.radians(np.arange(-180, 180, 30)):
        for be in np.radians(np.arange(-180, 180, 30)):
            try:
                K = freudenstein_constants(t2 + al, t4 + be)
            except ModelError:
                continue
            for s in (1, -1):
                out, ok = fourbar_output(K, t2 + al, s)
                if not ok.all():
                    continue
                m = float(np.abs(_wrap(out - be - t4)).max()) + _ratio_excess(K, max_ratio)
                found.append((m, tuple(K), al, be, s))
    found.sort(key=lambda t: t[0])
    return found[:count]


def freudenstein(function: Callable | None, x_range: Sequence[float], input_range: Sequence[float],
                 output_range: Sequence[float], *, points: int | Sequence[float] = 3, spacing: str = "chebyshev",
                 fit: str = "exact", free_offsets: bool = False, ground: float = 100.0,
                 length_unit: str = "mm", name: str = "Freudenstein function generator",
                 samples: int = 1201, max_link_ratio: float | None = None, starts: int = 4) -> FunctionDesign:
    """Design a four-bar function generator y = f(x) and have the tracker check it.

    Parameters
    ----------
    function : callable
        y = f(x), vectorized over numpy arrays.
    x_range : (x0, x1)
        The function's input range; x0 maps to the first input angle.
    input_range, output_range : (deg, deg)
        Input angle for x0 → x1 and output angle for f(x0) → f(x1) (linear maps).
    points : int or sequence of x
        Number of precision points (spaced by ``spacing``) or their x values.
    spacing : {"chebyshev", "uniform"}
    fit : {"exact", "least-squares", "minimax"}
        ``exact``: three precision points met exactly; ``least-squares``: linear least squares
        on K over the points; ``minimax``: start from the least-squares K and minimize the
        largest output error over the whole range (``samples`` points).
    free_offsets : bool
        With ``fit="minimax"``: the reference angles α, β (model parameters ``alpha``, ``beta``:
        the input link is at θ2 + α, the output at θ4 + β from the ground line) are design
        variables too; the ranges' spans stay.
    ground : float
        Ground length r1 (model length unit).
    max_link_ratio : float, optional
        With ``fit="minimax"``: the longest link at most this many times the shortest.
    starts : int
        With ``free_offsets``: how many of the best linear least-squares designs over a 30° grid
        of (α, β) are polished (the best polished one is kept).

    Returns
    -------
    FunctionDesign

    Examples
    --------
    >>> d = ls.freudenstein(np.log10, (1, 10), (45, 105), (135, 225))
    >>> [round(k, 5) for k in d.K], d.grashof.value
    ([2.00276, -0.69862, 1.0842], 'triple rocker')
    >>> [(x.kind, round(x.input, 2)) for x in d.defects]
    [('range', 48.95)]
    """
    if fit not in ("exact", "least-squares", "minimax"):
        raise ModelError(f"fit = {fit!r}: expected 'exact', 'least-squares' or 'minimax'")
    if spacing not in ("chebyshev", "uniform"):
        raise ModelError(f"spacing = {spacing!r}: expected 'chebyshev' or 'uniform'")
    if function is None or not callable(function):
        raise ModelError("function: pass the function y = f(x) to generate (a callable on numpy arrays)")
    (x0, x1), (a0, a1), (b0, b1) = (tuple(float(v) for v in r) for r in (x_range, input_range, output_range))
    if x0 == x1 or a0 == a1 or b0 == b1:
        raise ModelError("x_range, input_range and output_range each need two different ends")
    y0, y1 = float(function(np.array([x0]))[0]), float(function(np.array([x1]))[0])
    if not (math.isfinite(y0) and math.isfinite(y1)) or y0 == y1:
        raise ModelError(f"f({x0:g}) = {y0:g} and f({x1:g}) = {y1:g}: need two different finite values")

    def th2(x):
        return a0 + (a1 - a0) * (np.asarray(x, dtype=float) - x0) / (x1 - x0)

    def th4(y):
        return b0 + (b1 - b0) * (np.asarray(y, dtype=float) - y0) / (y1 - y0)

    if isinstance(points, (int, np.integer)):
        if fit == "exact" and points != 3:
            raise ModelError(f"fit='exact' meets exactly three precision points (got points={points}); use "
                             "fit='least-squares' for more")
        xs = chebyshev_spacing(x0, x1, int(points)) if spacing == "chebyshev" else np.linspace(x0, x1, int(points))
    else:
        xs = np.asarray(points, dtype=float)
    ys = np.asarray(function(xs), dtype=float)
    t2p, t4p = np.radians(th2(xs)), np.radians(th4(ys))
    xg = np.linspace(x0, x1, samples)
    t2g, t4g = np.radians(th2(xg)), np.radians(th4(function(xg)))
    offsets = (0.0, 0.0)
    K = freudenstein_constants(t2p, t4p)
    sign = _root_sign(K, t2p[0], t4p[0])
    if fit == "minimax":
        if free_offsets:
            starts = _free_offset_starts(t2g[::10], t4g[::10], starts, max_link_ratio)
            fits = [(_fit_minimax(np.array(K), sg, t2g, t4g, True, (al, be), max_link_ratio), sg)
                    for _, K, al, be, sg in starts]
        else:
            fits = [(_fit_minimax(K, sg, t2g, t4g, False, max_ratio=max_link_ratio), sg) for sg in (1, -1)]
        fits = [(f, sg) for f, sg in fits if f is not None]
        if not fits:
            raise ModelError("the minimax fit found no four-bar that assembles over the whole input range"
                             + (f" with links within {max_link_ratio:g}:1" if max_link_ratio else "")
                             + (" from the least-squares starts; try other ranges" if free_offsets else
                                "; try free_offsets=True or other ranges"))
        (p, _), sign = min(fits, key=lambda t: t[0][1])
        K = p[:3]
        if free_offsets:
            offsets = (float(p[3]), float(p[4]))
    K = tuple(float(v) for v in K)
    lengths = links_from_constants(K, float(ground))
    offs_deg = tuple(float(math.degrees(_wrap(o))) for o in offsets)
    # the first precision point (or the range's start for minimax) fixes the guesses and the mode
    i0 = 0
    t4w = t4p.copy()  # the wanted output angles (the linkage's replace t4p below)
    if fit != "exact":  # the linkage's own outputs at the points (met only approximately)
        if fit == "least-squares":
            sign = min((1, -1), key=lambda sg: float(np.nansum(np.where(
                fourbar_output(K, t2p, sg)[1], np.abs(_wrap(fourbar_output(K, t2p, sg)[0] - t4p)), np.pi))))
        t4p, ok = fourbar_output(K, t2p + offsets[0], sign)
        t4p = t4p - offsets[1]
        if not ok.any():
            raise ModelError(f"the {fit} design cannot be assembled at any of its points; try fit='minimax' or "
                             "other ranges")
        i0 = int(np.argmax(ok))
    t2p, t4p, t4w = np.r_[t2p[i0:], t2p[:i0]], np.r_[t4p[i0:], t4p[:i0]], np.r_[t4w[i0:], t4w[:i0]]
    t2f0, t4f0 = t2p[0] + offsets[0], t4p[0] + offsets[1]
    t3 = _theta3(lengths, t2f0, t4f0)
    z0 = (math.degrees(t2p[0]), math.degrees(t3), math.degrees(t4p[0]))
    mech = _build(lengths, offs_deg, z0, name, length_unit)
    pos = tuple(abs(v) for v in lengths)
    cls = grashof(*pos)
    xs, ys = np.r_[xs[i0:], xs[:i0]], np.r_[ys[i0:], ys[:i0]]
    prec = tuple((float(x), float(y), float(math.degrees(a)), float(math.degrees(b)))
                 for x, y, a, b in zip(xs, ys, t2p, t4p))
    design = _analyse(mech, K, lengths, offs_deg, fit, prec, tuple(np.degrees(t4w)), (a0, a1), (b0, b1), cls, sign,
                      lambda t: np.degrees(fourbar_output(K, np.radians(t) + offsets[0], sign)[0]) - offs_deg[1],
                      lambda t: th4(function(x0 + (np.asarray(t) - a0) / (a1 - a0) * (x1 - x0))),
                      (y1 - y0) / (b1 - b0))
    keep = {"spacing": spacing, "ground": ground, "length_unit": length_unit, "name": name, "samples": samples,
            "max_link_ratio": max_link_ratio, "starts": starts, "points": points, "fit": fit,
            "free_offsets": free_offsets}

    def redesign(**changes):
        return freudenstein(function, x_range, input_range, output_range, **{**keep, **changes})

    return replace(design, redesign=redesign)


def freudenstein_points(inputs, outputs, *, fit: str = "exact", ground: float = 100.0, length_unit: str = "mm",
                        name: str = "Freudenstein function generator", input_range=None) -> FunctionDesign:
    """A function generator through precision points given as angles (degrees), checked by the tracker.

    ``inputs``/``outputs``: the input and output angles of each target, in the order the input
    must meet them; three (``fit="exact"``) or more (``fit="least-squares"``). The intended
    input range is ``input_range`` (degrees; default from the first to the last target: a limit
    inside it is a ``range`` defect); ``max_error`` is the largest output error
    at the targets (the function between them is not known here).

    Examples
    --------
    >>> from loopsolve.design.synthesis.classical.freudenstein import freudenstein_points
    >>> d = freudenstein_points([49.019, 75.0, 100.981], [153.441, 201.633, 222.570])
    >>> round(d.K[0], 3), [x.kind for x in d.defects]
    (2.003, [])
    """
    if fit not in ("exact", "least-squares"):
        raise ModelError(f"fit = {fit!r}: expected 'exact' or 'least-squares' for targets given as angles")
    a = np.asarray(inputs, dtype=float).ravel()
    b = np.asarray(outputs, dtype=float).ravel()
    if a.shape != b.shape:
        raise ModelError(f"{a.size} input angles but {b.size} output angles")
    if fit == "exact" and a.size != 3:
        raise ModelError(f"fit='exact' meets exactly three precision points (got {a.size}); use fit='least-squares' "
                         "for more")
    if not np.isfinite(a).all() or not np.isfinite(b).all():
        raise ModelError("every target angle must be a finite number")
    _refuse_repeated_inputs(a)
    t2p, t4p = np.radians(a), np.radians(b)
    K = freudenstein_constants(t2p, t4p)
    sign = _root_sign(K, t2p[0], t4p[0])
    if fit != "exact":
        sign = min((1, -1), key=lambda sg: float(np.sum(np.where(
            fourbar_output(K, t2p, sg)[1], np.abs(_wrap(fourbar_output(K, t2p, sg)[0] - t4p)), np.pi))))
        if not fourbar_output(K, t2p[:1], sign)[1][0]:
            raise ModelError(f"the least-squares design cannot be assembled at the first target (input {a[0]:.6g}°)")
    K = tuple(float(v) for v in K)
    lengths = links_from_constants(K, float(ground))
    t4_0 = float(fourbar_output(K, t2p[:1], sign)[0][0]) if fit != "exact" else t4p[0]
    t3 = _theta3(lengths, t2p[0], t4_0)
    mech = _build(lengths, (0.0, 0.0), (a[0], math.degrees(t3), math.degrees(t4_0)), name, length_unit)
    # the linkage's outputs (degrees; NaN where it cannot be assembled) hold the configurations, the
    # targets stay what they are
    outs, ok = fourbar_output(K, t2p, sign)
    outs = np.where(ok, np.degrees(outs), np.nan) if fit != "exact" else b
    prec = tuple((float(x), float(y), float(x), float(o)) for x, y, o in zip(a, b, outs))
    cls = grashof(*(abs(v) for v in lengths))
    in_rng = (float(a[0]), float(a[-1]))
    if input_range is not None:
        lo, hi = sorted(float(v) for v in input_range)
        if not (lo <= min(a) and max(a) <= hi):
            raise ModelError(f"input range {lo:g}°:{hi:g}° does not hold every target input ({min(a):g}°…{max(a):g}°)")
        in_rng = (lo, hi) if a[-1] >= a[0] else (hi, lo)
    return _analyse(mech, K, lengths, (0.0, 0.0), fit, prec, tuple(float(v) for v in b), in_rng,
                    (float(b[0]), float(b[-1])), cls, sign,
                    lambda t: np.degrees(fourbar_output(K, np.radians(t), sign)[0]), None, 1.0)


def _refuse_repeated_inputs(a) -> None:
    """Two targets at one input angle (also a turn apart: the same crank position) ask for one
    output twice, or for two outputs at once: refused, naming them (1-based)."""
    w = np.mod(a, 360.0)
    order = np.argsort(w, kind="stable")
    gaps = np.diff(w[order])
    same = np.flatnonzero(np.abs(gaps) <= 1e-9)
    if same.size:
        i, j = sorted((int(order[same[0]]), int(order[same[0] + 1])))
        turn = "" if a[i] == a[j] else " (a whole number of turns apart: the same crank position)"
        raise ModelError(f"targets {i + 1} and {j + 1} are at the same input angle ({a[i]:g}° and {a[j]:g}°){turn}; "
                         "every target needs its own input")


def _signed_angles(lengths, t2f, t3, t4f):
    """Absolute directions of the physical vectors (positive lengths)."""
    r1, r2, r3, r4 = lengths
    return (0.0, t2f + (math.pi if r2 < 0 else 0.0), t3, t4f + (math.pi if r4 < 0 else 0.0))


def _analyse(mech, K, lengths, offs, fit, prec, wanted, in_rng, out_rng, cls, sign, closed, desired, y_per_deg):
    """The tracker's verdict. ``prec``: ``(x, y, input, linkage output)`` per point (degrees; the output
    holds the configuration), ``wanted``: the wanted output angle of each point (degrees)."""
    ck = mech.compile()
    al, be = (math.radians(v) for v in offs)
    pos = tuple(abs(v) for v in lengths)
    zs = []
    for _, _, a, b in prec:
        t2f, t4f = math.radians(a) + al, math.radians(b) + be
        t3 = _theta3(lengths, t2f, t4f)
        zs.append(np.array([math.radians(a), t3, math.radians(b)]))
    mode = ck.signature(zs[0])
    defects: list[Defect] = []
    circ0 = circuit_sign(pos, _signed_angles(lengths, zs[0][0] + al, zs[0][1], zs[0][2] + be))
    a0, a1 = in_rng
    d = 1 if a1 > a0 else -1
    # the precision points: one motion of the input (towards the range's end) in one mode
    for i in range(1, len(zs)):
        if fit != "exact":
            break  # points met only approximately: the range sweep below decides
        prev, cur = zs[i - 1], zs[i]
        sig = ck.signature(cur)
        circ = circuit_sign(pos, _signed_angles(lengths, cur[0] + al, cur[1], cur[2] + be))
        a_prev, a_cur = prec[i - 1][2], prec[i][2]
        if d * (a_cur - a_prev) <= 0:
            defects.append(Defect("order", f"precision point {i + 1} (input {a_cur:.6g}°) is not beyond point {i} "
                                  f"({a_prev:.6g}°) in the input's direction", a_cur))
            continue
        if circ != circ0:
            defects.append(Defect("circuit", f"precision point {i + 1} (input {a_cur:.6g}°) lies on the other "
                                  "circuit: the linkage cannot move there without being taken apart", a_cur))
            continue
        z, lim = track_between(mech, prev, a_cur, direction=d)
        if lim is not None or sig != mode:
            if lim is not None:
                text = (f"between precision points {i} and {i + 1} the linkage reaches a limit position at input "
                        f"{lim:.6g}° (point {i + 1} is in mode {sig}, point 1 in {mode})")
            else:
                text = (f"precision point {i + 1} (input {a_cur:.6g}°) is on the other branch (mode {sig}, point 1 in "
                        f"{mode}): the linkage reaches it only through a limit position")
            defects.append(Defect("branch", text, lim if lim is not None else a_cur))
        elif z is not None and abs(math.degrees(float(_wrap(z[2] - cur[2])))) > 1e-6:
            defects.append(Defect("branch", f"the tracked motion misses precision point {i + 1}", a_cur))
    # the whole intended range, tracked in the mode from the first precision point both ways
    start = prec[0][2]  # the first point where the design assembles
    reach = [a0, a1]
    xs_all, err_all = [], []
    for end, k in ((a0, 0), (a1, 1)):
        if abs(end - start) < 1e-12:
            continue
        n = max(8, int(abs(end - start) / (abs(a1 - a0) / 1000)))
        guess = {"theta3": float(zs[0][1]), "theta4": float(zs[0][2])}
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                sw = mech.sweep(start, end, abs(end - start) / n, guess=guess, mode=mode, progress=False,
                                method="tracked", derivatives=1, limit_rows=True)
            except SolveError as exc:
                defects.append(Defect("assembly", f"cannot be assembled at the first precision point: {exc}", start))
                continue
        lim = next((e.input for e in sw.events if e.kind.value == "limit"), None)
        x = np.asarray(sw["theta2"], dtype=float)
        if lim is None and (len(x) == 0 or abs(x[-1] - end) > 1e-6 * max(1.0, abs(end))):
            stop = float(x[-1]) if len(x) else start
            defects.append(Defect("range", f"the tracked motion stops at theta2 = {stop:.6g}° before the end of the "
                                  f"intended input range at {end:g}° ("
                                  + "; ".join(e.message for e in sw.events[:1]) + ")", stop))
        y = np.asarray(sw["theta4"], dtype=float)
        good = np.isfinite(y)
        x, y = x[good], y[good]
        err = (y - desired(x) + 180.0) % 360.0 - 180.0 if desired is not None else np.zeros_like(x)
        xs_all.append(x[::-1] if k == 0 else x)
        err_all.append(err[::-1] if k == 0 else err)
        if lim is not None:
            reach[k] = lim
            lo, hi = sorted((end, lim))
            defects.append(Defect("range", f"input limit at theta2 = {lim:.2f}° ({abs(lim - start):.2f}° before "
                                  f"the point at {start:.2f}°): {lo:.2f}°–{hi:.2f}° of the intended input range "
                                  f"{a0:g}°–{a1:g}° cannot be reached ({cls.value} linkage)"
                                  if k == 0 else
                                  f"input limit at theta2 = {lim:.2f}°: {lo:.2f}°–{hi:.2f}° of the intended input "
                                  f"range {a0:g}°–{a1:g}° cannot be reached ({cls.value} linkage)", lim))
    if xs_all:
        xe = np.concatenate(xs_all)
        ee = np.concatenate(err_all)
        order = np.argsort(xe)
        xe, ee = xe[order], ee[order]
    else:
        xe, ee = np.array([start]), np.array([0.0])
    max_err = float(np.abs(ee).max())
    if desired is None:  # targets only: the error at each target (against the wanted output), within reach
        max_err = 0.0
        for (_, _, a, _), b in zip(prec, wanted):
            if reach[0] - 1e-9 <= a <= reach[1] + 1e-9 or reach[1] - 1e-9 <= a <= reach[0] + 1e-9:
                out = float(closed(np.array([a]))[0])
                max_err = max(max_err, abs((out - b + 180.0) % 360.0 - 180.0))
    suggestion = ""
    if defects:
        suggestion = ("this design is defective; alternatives: design.alternative() (a minimax fit over the whole "
                      "input range, which keeps it assemblable, with the reference angles α, β free), or "
                      "fit='least-squares' with more points (e.g. points=7): check the new design's defects")
    outputs = []
    for (_, _, a, _), b in zip(prec, wanted):
        o = float(closed(np.array([a]))[0])
        ok = bool(np.isfinite(o)) and fourbar_ok(K, math.radians(a) + al, sign)
        outputs.append(float(b + (o - b + 180.0) % 360.0 - 180.0) if ok else None)
    precision = tuple((x, y, a, float(b)) for (x, y, a, _), b in zip(prec, wanted))
    return FunctionDesign(tuple(K), tuple(abs(v) for v in lengths), offs, fit, precision, tuple(in_rng),
                          tuple(out_rng), mech, mode, cls, tuple(defects), max_err, max_err * abs(y_per_deg),
                          xe, ee, (float(min(reach)), float(max(reach))), suggestion, None, tuple(outputs), sign)


def fourbar_ok(K, theta2: float, sign: int) -> bool:
    """Whether the Freudenstein linkage ``K`` assembles at the input angle ``theta2`` (radians)."""
    return bool(fourbar_output(K, np.array([theta2]), sign)[1][0])
