"""Limits and classes of the classic linkages, in closed form: Grashof's classification, the
four-bar's input range and toggle positions, the transmission angle, Gruebler's mobility and
the quick-return ratio.

Conventions of :mod:`loopsolve.kinematics.classic`, which also answers for these names: numpy broadcasting, radians, NaN where a linkage cannot be assembled.
"""

from __future__ import annotations

import enum
import math
import operator

import numpy as np

from ..errors import ModelError
from .classic import ASSEMBLY_TOL, TWO_PI, positive_length, scalar_or_array

#: relative tolerance of the Grashof equality S + L == P + Q
_GRASHOF_RTOL = 1e-9


# ------------------------------------------------------------------------- Grashof
class GrashofClass(enum.Enum):
    """Four-bar categories of the Grashof table (Myszka, Table 1 of the thesis)."""

    DOUBLE_CRANK = "double crank"
    CRANK_ROCKER = "crank-rocker"
    ROCKER_CRANK = "rocker-crank"
    DOUBLE_ROCKER = "double rocker"
    CHANGE_POINT = "change point"
    TRIPLE_ROCKER = "triple rocker"



def _grashof_sums(r1, r2, r3, r4):
    lengths = [float(v) for v in (r1, r2, r3, r4)]
    for name, v in zip(("r1", "r2", "r3", "r4"), lengths):
        if not (v > 0 and math.isfinite(v)):
            raise ModelError(f"link length {name} must be positive and finite, got {v!r}")
    ordered = sorted(lengths)
    s_plus_l = ordered[0] + ordered[3]
    p_plus_q = ordered[1] + ordered[2]
    return lengths, s_plus_l, p_plus_q



def grashof(r1, r2, r3, r4):
    """Classify a four-bar by Grashof's criterion (scalar lengths).

    With S, L the shortest and longest links and P, Q the others:

    * ``S + L == P + Q`` (relative tolerance 1e-9): ``CHANGE_POINT``;
    * ``S + L > P + Q``: ``TRIPLE_ROCKER`` (no link fully rotates);
    * ``S + L < P + Q`` and the shortest link is the frame ``r1``: ``DOUBLE_CRANK``;
      the input ``r2``: ``CRANK_ROCKER``; the output ``r4``: ``ROCKER_CRANK`` (the output
      fully rotates while the input rocks); the coupler ``r3``: ``DOUBLE_ROCKER`` (Grashof
      double rocker, the coupler fully rotates).

    Parameters
    ----------
    r1, r2, r3, r4 : float
        Frame, crank, coupler and output lengths (positive).

    Returns
    -------
    GrashofClass

    Examples
    --------
    >>> grashof(60, 25, 70, 45).value
    'crank-rocker'
    """
    lengths, s_plus_l, p_plus_q = _grashof_sums(r1, r2, r3, r4)
    if abs(s_plus_l - p_plus_q) <= _GRASHOF_RTOL * p_plus_q:
        return GrashofClass.CHANGE_POINT
    if s_plus_l > p_plus_q:
        return GrashofClass.TRIPLE_ROCKER
    shortest = int(np.argmin(lengths))  # unique when S + L < P + Q
    if shortest == 0:
        return GrashofClass.DOUBLE_CRANK
    if shortest == 2:
        return GrashofClass.DOUBLE_ROCKER
    if shortest == 3:
        return GrashofClass.ROCKER_CRANK
    return GrashofClass.CRANK_ROCKER



def is_grashof(r1, r2, r3, r4):
    """True when ``S + L <= P + Q`` (within 1e-9 relative): some link fully rotates.

    Change-point linkages count as Grashof.

    Parameters
    ----------
    r1, r2, r3, r4 : float
        Frame, crank, coupler and output lengths (positive).

    Returns
    -------
    bool

    Examples
    --------
    >>> is_grashof(60, 25, 70, 45), is_grashof(4, 3, 3.5, 5)
    (True, False)
    """
    _, s_plus_l, p_plus_q = _grashof_sums(r1, r2, r3, r4)
    return bool(s_plus_l <= p_plus_q * (1 + _GRASHOF_RTOL))



# ---------------------------------------------------------- input range, toggles
def _limit_angle(r1, r2, ell):
    """Crank angle in ``[0, pi]`` where the diagonal ``BD`` equals ``ell``.

    ``BD`` grows from ``|r1 - r2|`` at ``theta2 = 0`` to ``r1 + r2`` at ``pi``; from
    ``cos theta2 = (r1^2 + r2^2 - ell^2) / (2 r1 r2)`` in the half-angle form
    ``tan^2(theta2/2) = (ell^2 - (r1 - r2)^2) / ((r1 + r2)^2 - ell^2)`` (factored, so
    accurate near 0 and pi). Returns ``"below"`` if ``BD > ell`` at every angle,
    ``"above"`` if ``BD < ell`` at every angle; gaps within rounding snap to 0 or pi.
    """
    lo, hi = abs(r1 - r2), r1 + r2
    tol = ASSEMBLY_TOL * (r1 + r2 + ell)
    g0, gpi = ell - lo, hi - ell
    g0 = 0.0 if abs(g0) <= tol else g0
    gpi = 0.0 if abs(gpi) <= tol else gpi
    if g0 < 0:
        return "below"
    if gpi < 0:
        return "above"
    return 2.0 * math.atan2(math.sqrt(g0 * (ell + lo)), math.sqrt(gpi * (hi + ell)))



def _limits(r1, r2, r3, r4):
    r1, r2, r3, r4 = (float(positive_length(n, v)) for n, v in zip(("r1", "r2", "r3", "r4"), (r1, r2, r3, r4)))
    return _limit_angle(r1, r2, r3 + r4), _limit_angle(r1, r2, abs(r3 - r4))



def fourbar_input_range(r1, r2, r3, r4):
    """Intervals of the crank angle ``theta2`` where the four-bar assembles.

    The crank-pin-to-O4 diagonal ``BD^2 = r1^2 + r2^2 - 2 r1 r2 cos theta2`` must lie in
    ``[|r3 - r4|, r3 + r4]`` (frame along +x).

    Parameters
    ----------
    r1, r2, r3, r4 : float
        Frame, crank, coupler and output lengths.

    Returns
    -------
    list of (float, float)
        Closed intervals ``(start, end)``, ``start < end``, sorted: ``[(-pi, pi)]`` for
        a fully rotating crank, ``[(-a, a)]`` around ``theta2 = 0``, ``[(a, 2 pi - a)]``
        around ``pi`` (the end then exceeds pi), ``[(-b, -a), (a, b)]`` for two
        symmetric arcs, ``[]`` if it never assembles.

    Examples
    --------
    >>> import math
    >>> fourbar_input_range(60, 25, 70, 45) == [(-math.pi, math.pi)]
    True
    >>> [tuple(round(x, 4) for x in iv) for iv in fourbar_input_range(4, 3, 3.5, 5)]
    [(0.3242, 5.959)]
    """
    out, inn = _limits(r1, r2, r3, r4)
    if out == "below" or inn == "above":  # BD > r3 + r4 or BD < |r3 - r4| everywhere
        return []
    a_out = math.pi if out == "above" else out  # |theta2| <= a_out
    a_in = 0.0 if inn == "below" else inn  # |theta2| >= a_in
    if a_in == 0.0 and a_out == math.pi:
        return [(-math.pi, math.pi)]
    if a_in == 0.0:
        return [(-a_out, a_out)]
    if a_out == math.pi:
        return [(a_in, TWO_PI - a_in)]
    return [(-a_out, -a_in), (a_in, a_out)]



def fourbar_toggle_angles(r1, r2, r3, r4):
    """Crank angles at which ``BD = r3 + r4`` or ``BD = |r3 - r4|``.

    These are the limit positions of the input (coupler and output collinear), or, for a
    change-point linkage, its change points.

    Parameters
    ----------
    r1, r2, r3, r4 : float
        Frame, crank, coupler and output lengths.

    Returns
    -------
    ndarray
        Sorted, distinct angles in ``(-pi, pi]`` (empty for a fully rotating crank of a
        non-change-point linkage).

    Examples
    --------
    >>> [round(float(a), 4) for a in fourbar_toggle_angles(4, 3, 3.5, 5)]
    [-0.3242, 0.3242]
    """
    angles = set()
    for a in _limits(r1, r2, r3, r4):
        if isinstance(a, float):
            angles.add(a)
            angles.add(math.pi if a == math.pi else -a)
    return np.array(sorted(angles), dtype=float)



# ------------------------------------------------------------ transmission angle
def transmission_angle(theta3, theta4):
    """Angle between coupler and output, ``|theta4 - theta3|`` folded into ``[0, pi]``.

    Parameters
    ----------
    theta3, theta4 : array_like
        Coupler and output angles.

    Returns
    -------
    ndarray
        The transmission angle ``mu`` in ``[0, pi]``.

    Examples
    --------
    >>> import numpy as np
    >>> round(float(np.degrees(transmission_angle(np.radians(170), np.radians(-170)))), 6)
    20.0
    """
    d = np.asarray(theta4, dtype=float) - np.asarray(theta3, dtype=float)
    return scalar_or_array(np.abs(np.arctan2(np.sin(d), np.cos(d))))



def transmission_angle_range(r1, r2, r3, r4):
    """Extreme transmission angles over the assemblable input range.

    ``cos mu = (r3^2 + r4^2 - BD^2) / (2 r3 r4)`` increases ``mu`` with ``BD``, and BD
    sweeps ``[max(|r1 - r2|, |r3 - r4|), min(r1 + r2, r3 + r4)]``.

    Parameters
    ----------
    r1, r2, r3, r4 : float
        Frame, crank, coupler and output lengths.

    Returns
    -------
    (float, float)
        ``(mu_min, mu_max)`` in ``[0, pi]``; ``(nan, nan)`` if it never assembles.

    Examples
    --------
    >>> import numpy as np
    >>> lo, hi = transmission_angle_range(60, 25, 70, 45)
    >>> round(float(np.degrees(lo)), 2), round(float(np.degrees(hi)), 2)
    (25.21, 92.73)
    """
    r1, r2, r3, r4 = (float(positive_length(n, v)) for n, v in zip(("r1", "r2", "r3", "r4"), (r1, r2, r3, r4)))
    bd_lo = max(abs(r1 - r2), abs(r3 - r4))
    bd_hi = min(r1 + r2, r3 + r4)
    if bd_lo > bd_hi + ASSEMBLY_TOL * (r1 + r2 + r3 + r4):
        return (math.nan, math.nan)

    def mu(bd):
        return math.acos(min(1.0, max(-1.0, (r3**2 + r4**2 - bd**2) / (2 * r3 * r4))))

    return (mu(bd_lo), mu(bd_hi))



# --------------------------------------------------------------------- mobility
def gruebler(n_links, n_full_joints, n_half_joints=0):
    """Gruebler/Kutzbach mobility ``M = 3 (n - 1) - 2 j1 - j2`` of a planar linkage.

    Parameters
    ----------
    n_links : int
        Number of links, frame included (>= 1).
    n_full_joints : int
        One-degree-of-freedom joints (pins, sliders), >= 0.
    n_half_joints : int, optional
        Two-degree-of-freedom joints (cam, rolling-with-slip), >= 0.

    Returns
    -------
    int

    Examples
    --------
    >>> gruebler(4, 4)
    1
    """
    try:
        n, j1, j2 = (operator.index(v) for v in (n_links, n_full_joints, n_half_joints))
    except TypeError as exc:
        raise ModelError(f"link and joint counts must be integers: {exc}") from None
    problems = []
    if n < 1:
        problems.append(f"n_links must be >= 1, got {n}")
    if j1 < 0:
        problems.append(f"n_full_joints must be >= 0, got {j1}")
    if j2 < 0:
        problems.append(f"n_half_joints must be >= 0, got {j2}")
    if problems:
        raise ModelError("; ".join(problems), problems=problems)
    return 3 * (n - 1) - 2 * j1 - j2



# ------------------------------------------------------------------ quick return
def quick_return(r2, d):
    """Crank-and-slotted-lever quick return: time ratio and stroke angles.

    Crank ``r2`` about O2, slotted link pivoted at O4 a distance ``d`` from O2. The limit
    positions have the crank perpendicular to the slotted link; the crank angle between
    them on the O4 side is ``beta = 2 acos(r2 / d)`` (return stroke), the rest
    ``2 pi - beta`` is the advance (working) stroke.

    Parameters
    ----------
    r2 : array_like
        Crank radius (positive).
    d : array_like
        Distance O2-O4, ``d > r2``.

    Returns
    -------
    time_ratio, advance_angle, return_angle, rocking_angle : ndarray
        ``(2 pi - beta) / beta`` (> 1), ``2 pi - beta``, ``beta`` and the swing of the
        slotted link ``2 asin(r2 / d)``.

    Raises
    ------
    ModelError
        If ``r2 <= 0`` or ``d <= r2``: then the slotted link rotates fully (a Whitworth
        quick return), there are no limit positions.

    Examples
    --------
    >>> import numpy as np
    >>> ratio, adv, ret, rock = quick_return(1.0, 2.0)
    >>> round(float(ratio), 4), round(float(np.degrees(rock)), 4)
    (2.0, 60.0)
    """
    r2 = positive_length("r2", r2)
    d = np.asarray(d, dtype=float)
    if np.any(d <= r2):
        raise ModelError(
            "quick_return needs d > r2; with d <= r2 the slotted link rotates fully "
            "(Whitworth quick return) and has no limit positions"
        )
    beta = 2 * np.arccos(r2 / d)
    return (
        scalar_or_array((TWO_PI - beta) / beta),
        scalar_or_array(TWO_PI - beta),
        scalar_or_array(beta),
        scalar_or_array(2 * np.arcsin(r2 / d)),
    )
