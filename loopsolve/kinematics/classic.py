"""Closed-form kinematics of the classic planar linkages.

These are *independent* reference solutions, written straight from the textbook
vector-loop derivations (half-angle substitution, Freudenstein's equation, Cramer's
rule on the 2x2 velocity/acceleration systems). They do not use the general Newton
solver of :mod:`loopsolve` and are meant to cross-check it.

Every function broadcasts over numpy arrays of its arguments; angles are in radians.
Scalar inputs give numpy float scalars. Positions that cannot be assembled (negative
discriminant) are returned as NaN, never raised.

Conventions
-----------
``e(a) = (cos a, sin a)``.

Four-bar (ground pivots O2 at the origin, O4 at ``r1 e(theta1)``)::

    r2 e(theta2) + r3 e(theta3) = r1 e(theta1) + r4 e(theta4)

``r2`` is the crank (input), ``r3`` the coupler, ``r4`` the output (rocker), ``r1``
the frame. Assembly mode ``+1``: ``sin(theta4 - theta3) > 0``; ``-1``: ``< 0``.

Slider-crank (offset ``r4`` perpendicular to the line of sliding)::

    r2 e(theta2) + r3 e(theta3) = r1 e(theta1) + r4 e(theta1 + pi/2)

``r1`` is the slider position along the line at angle ``theta1``, ``r4`` the offset.
Case i (``theta2`` given): mode ``+1`` is the larger ``r1``.
Case ii (``r1`` given): mode ``+1`` is the solution with ``sin(theta3 - theta2) > 0``.

All returned angles lie in ``(-pi, pi]``.
"""

from __future__ import annotations

import math

import numpy as np

from loopsolve.errors import ModelError

__all__ = [
    "fourbar_position",
    "freudenstein_residual",
    "fourbar_velocity",
    "fourbar_acceleration",
    "slider_crank_position",
    "slider_crank_velocity",
    "slider_crank_acceleration",
    "slider_crank_inversion_position",
    "GrashofClass",
    "grashof",
    "is_grashof",
    "fourbar_input_range",
    "fourbar_toggle_angles",
    "transmission_angle",
    "transmission_angle_range",
    "gruebler",
    "quick_return",
]

TWO_PI = 2.0 * math.pi
#: relative slack (w.r.t. the sum of the link lengths) under which a distance that
#: violates an assembly inequality by rounding only is snapped onto the limit (toggle)
ASSEMBLY_TOL = 64.0 * np.finfo(float).eps


# --------------------------------------------------------------------------- helpers
def scalar_or_array(x):
    """Return 0-d arrays as numpy float scalars, leave other arrays alone."""
    x = np.asarray(x, dtype=float)
    return x[()] if x.ndim == 0 else x


def _wrap(angle):
    """Map angles onto (-pi, pi] (an exact no-op for angles already in range)."""
    angle = np.asarray(angle, dtype=float)
    angle = np.where(angle > math.pi, angle - TWO_PI, angle)
    return np.where(angle <= -math.pi, angle + TWO_PI, angle)


def positive_length(name, value):
    """``value`` as a float array; a model error naming link ``name`` unless every entry is positive."""
    value = np.asarray(value, dtype=float)
    if np.any(value <= 0):
        raise ModelError(f"link length {name} must be positive, got {value!r}")
    return value


def _mode(mode):
    mode = np.asarray(mode)
    if mode.size == 0 or not np.all((mode == 1) | (mode == -1)):
        raise ModelError(f"mode must be +1 or -1, got {mode!r}")
    return mode.astype(float)


def _snap(gap, scale):
    """Snap slightly negative assembly gaps (rounding noise) to zero."""
    return np.where((gap < 0) & (gap >= -ASSEMBLY_TOL * scale), 0.0, gap)


def _half_angle_root(a, b, c, sqrt_disc, mode):
    """Angle ``x`` solving ``a t^2 + b t + c = 0`` with ``t = tan(x/2)``.

    Takes ``t = (-b - mode*sqrt_disc) / (2a)``, evaluated as the angle of the vector
    (numerator, denominator) so that ``a = 0`` (``x = pi``) needs no special case, or,
    when that numerator would suffer cancellation, through the equivalent form
    ``t = 2c / (-b + mode*sqrt_disc)``: the form with the larger components is used.
    """
    num1, den1 = -b - mode * sqrt_disc, 2.0 * a
    num2, den2 = 2.0 * c, -b + mode * sqrt_disc
    use1 = np.abs(num1) + np.abs(den1) >= np.abs(num2) + np.abs(den2)
    half = np.arctan2(np.where(use1, num1, num2), np.where(use1, den1, den2))
    return _wrap(2.0 * half)


def _fourbar_coefficients(r1, r2, r3, r4, theta2, theta1=0.0):
    """Coefficients ``(A, B, C)`` of the notes' quadratic ``A t^2 + B t + C = 0``,
    ``t = tan(theta4/2)`` (eq. 8 after the half-angle substitution)."""
    r1, r2, r3, r4, theta2, theta1 = np.broadcast_arrays(
        *(np.asarray(v, dtype=float) for v in (r1, r2, r3, r4, theta2, theta1))
    )
    a1 = 2 * r1 * r4 * np.cos(theta1) - 2 * r2 * r4 * np.cos(theta2)
    b1 = 2 * r1 * r4 * np.sin(theta1) - 2 * r2 * r4 * np.sin(theta2)
    c1 = r1**2 + r2**2 + r4**2 - r3**2 - 2 * r1 * r2 * np.cos(theta1 - theta2)
    return c1 - a1, 2 * b1, c1 + a1


# ------------------------------------------------------------------------- four-bar
def fourbar_position(r1, r2, r3, r4, theta2, mode=+1, theta1=0.0):
    """Coupler and output angles of a four-bar by the half-angle method.

    Solves ``r2 e(theta2) + r3 e(theta3) = r1 e(theta1) + r4 e(theta4)``: eliminating
    ``theta3`` gives the notes' eq. (8), ``A1 cos theta4 + B1 sin theta4 + C1 = 0`` with
    ``A1 = 2 r1 r4 cos theta1 - 2 r2 r4 cos theta2``,
    ``B1 = 2 r1 r4 sin theta1 - 2 r2 r4 sin theta2``,
    ``C1 = r1^2 + r2^2 + r4^2 - r3^2 - 2 r1 r2 cos(theta1 - theta2)``, and with
    ``t = tan(theta4/2)`` the quadratic ``A t^2 + B t + C = 0``, ``A = C1 - A1``,
    ``B = 2 B1``, ``C = C1 + A1``. Then ``theta3 = atan2(r1 sin theta1 + r4 sin theta4 -
    r2 sin theta2, r1 cos theta1 + r4 cos theta4 - r2 cos theta2)`` (quadrant kept).

    The discriminant ``B^2 - 4AC = 4 ((r3 + r4)^2 - BD^2)(BD^2 - (r3 - r4)^2)``, with
    ``BD = |r1 e(theta1) - r2 e(theta2)|`` the crank-pin-to-O4 diagonal, is evaluated in
    that factored form for accuracy; the root uses a cancellation-free form, so
    ``A = 0`` (``theta4 = pi``) is handled.

    Parameters
    ----------
    r1, r2, r3, r4 : array_like
        Frame, crank, coupler and output lengths (positive).
    theta2 : array_like
        Crank angle.
    mode : {+1, -1} or array_like
        Assembly mode. ``+1`` is the configuration with ``sin(theta4 - theta3) > 0``
        (the output turns counter-clockwise from the coupler; the thesis' "open"
        crank-rocker 60/25/70/45 with O4 to the right), ``-1`` the mirror image
        about the diagonal BD (``sin(theta4 - theta3) < 0``, "crossed"). This is the
        ``-`` sign of ``tan(theta4/2) = (-B -+ sqrt(B^2 - 4AC)) / (2A)`` in the notes.
    theta1 : array_like, optional
        Frame angle (direction of O4 from O2), default 0.

    Returns
    -------
    theta3, theta4 : ndarray
        Angles in ``(-pi, pi]``; NaN where the linkage cannot be assembled.

    Examples
    --------
    >>> import numpy as np
    >>> t3, t4 = fourbar_position(60, 25, 70, 45, np.radians(90))
    >>> round(float(np.degrees(t3)), 2), round(float(np.degrees(t4)), 2)
    (16.1, 80.72)
    """
    r1, r2, r3, r4 = (positive_length(n, v) for n, v in zip(("r1", "r2", "r3", "r4"), (r1, r2, r3, r4)))
    mode = _mode(mode)
    theta2 = np.asarray(theta2, dtype=float)
    theta1 = np.asarray(theta1, dtype=float)
    a, b, c = _fourbar_coefficients(r1, r2, r3, r4, theta2, theta1)
    # diagonal from the crank pin B to O4 and the two assembly gaps
    bd = np.hypot(r1 * np.cos(theta1) - r2 * np.cos(theta2), r1 * np.sin(theta1) - r2 * np.sin(theta2))
    scale = r1 + r2 + r3 + r4
    gap_out = _snap(r3 + r4 - bd, scale)  # >= 0: BD <= r3 + r4
    gap_in = _snap(bd - np.abs(r3 - r4), scale)  # >= 0: BD >= |r3 - r4|
    ok = (gap_out >= 0) & (gap_in >= 0)
    with np.errstate(invalid="ignore"):
        disc = 4.0 * (r3 + r4 + bd) * gap_out * (bd + np.abs(r3 - r4)) * gap_in
        sqrt_disc = np.sqrt(np.where(ok, disc, np.nan))
    theta4 = _half_angle_root(a, b, c, sqrt_disc, mode)
    theta3 = np.arctan2(
        r1 * np.sin(theta1) + r4 * np.sin(theta4) - r2 * np.sin(theta2),
        r1 * np.cos(theta1) + r4 * np.cos(theta4) - r2 * np.cos(theta2),
    )
    theta3 = np.where(ok, theta3, np.nan)
    return scalar_or_array(theta3), scalar_or_array(theta4)


def freudenstein_residual(r1, r2, r3, r4, theta2, theta4):
    """Residual of Freudenstein's equation for the loop convention (``theta1 = 0``).

    ``K1 cos theta4 - K2 cos theta2 + K3 - cos(theta2 - theta4)`` with ``K1 = r1/r2``,
    ``K2 = r1/r4``, ``K3 = (r1^2 + r2^2 + r4^2 - r3^2) / (2 r2 r4)``. This is exactly
    the notes' printed eq. (A), ``K1 cos theta4 - K2 cos theta2 + K3 = cos(theta2 -
    theta4)``, moved to one side: squaring ``r3 e(theta3) = r1 + r4 e(theta4) -
    r2 e(theta2)`` and dividing by ``2 r2 r4`` gives it with these signs, so no sign
    change is needed for O4 at ``(r1, 0)``. It vanishes at every assembled position
    (either mode).

    Parameters
    ----------
    r1, r2, r3, r4 : array_like
        Frame, crank, coupler and output lengths.
    theta2, theta4 : array_like
        Crank and output angles.

    Returns
    -------
    ndarray
        The dimensionless residual.

    Examples
    --------
    >>> import numpy as np
    >>> t3, t4 = fourbar_position(60, 25, 70, 45, 0.7)
    >>> abs(float(freudenstein_residual(60, 25, 70, 45, 0.7, t4))) < 1e-12
    True
    """
    r1, r2, r3, r4, theta2, theta4 = (np.asarray(v, dtype=float) for v in (r1, r2, r3, r4, theta2, theta4))
    k1 = r1 / r2
    k2 = r1 / r4
    k3 = (r1**2 + r2**2 + r4**2 - r3**2) / (2 * r2 * r4)
    return scalar_or_array(k1 * np.cos(theta4) - k2 * np.cos(theta2) + k3 - np.cos(theta2 - theta4))


def fourbar_velocity(r2, r3, r4, theta2, theta3, theta4, omega2):
    """Coupler and output angular velocities of a four-bar.

    From the notes (differentiated loop, frame fixed)::

        omega4 = r2 sin(theta2 - theta3) / (r4 sin(theta4 - theta3)) * omega2
        omega3 = r2 sin(theta2 - theta4) / (r3 sin(theta4 - theta3)) * omega2

    Both signs agree with the loop ``r2 e2 + r3 e3 = r1 e1 + r4 e4`` (checked against
    finite differences of :func:`fourbar_position` in the tests). Infinite/NaN at a
    toggle (``sin(theta4 - theta3) = 0``).

    Parameters
    ----------
    r2, r3, r4 : array_like
        Crank, coupler and output lengths.
    theta2, theta3, theta4 : array_like
        A solved position.
    omega2 : array_like
        Crank angular velocity.

    Returns
    -------
    omega3, omega4 : ndarray

    Examples
    --------
    >>> import numpy as np
    >>> t3, t4 = fourbar_position(60, 25, 70, 45, 0.0)
    >>> w3, w4 = fourbar_velocity(25, 70, 45, 0.0, t3, t4, 1.0)
    >>> round(float(w3), 4), round(float(w4), 4)
    (-0.7143, -0.7143)
    """
    r2, r3, r4, theta2, theta3, theta4, omega2 = (
        np.asarray(v, dtype=float) for v in (r2, r3, r4, theta2, theta3, theta4, omega2)
    )
    with np.errstate(divide="ignore", invalid="ignore"):
        s43 = np.sin(theta4 - theta3)
        omega4 = r2 * np.sin(theta2 - theta3) / (r4 * s43) * omega2
        omega3 = r2 * np.sin(theta2 - theta4) / (r3 * s43) * omega2
    return scalar_or_array(omega3), scalar_or_array(omega4)


def fourbar_acceleration(r2, r3, r4, theta2, theta3, theta4, omega2, omega3, omega4, alpha2):
    """Coupler and output angular accelerations of a four-bar (Cramer's rule).

    The notes' system (19), with ``r4`` for the output (the printed ``r1`` there is a
    typo) and ``si = sin theta_i``, ``ci = cos theta_i``::

        [-r3 s3  r4 s4] [alpha3]   [E]   E = r2 alpha2 s2 + r2 w2^2 c2 + r3 w3^2 c3 - r4 w4^2 c4
        [-r3 c3  r4 c4] [alpha4] = [G],  G = r2 alpha2 c2 - r2 w2^2 s2 - r3 w3^2 s3 + r4 w4^2 s4

    has determinant ``r3 r4 sin(theta4 - theta3)``, so::

        alpha3 = (E c4 - G s4) / (r3 sin(theta4 - theta3))
        alpha4 = (E c3 - G s3) / (r4 sin(theta4 - theta3))

    Parameters
    ----------
    r2, r3, r4 : array_like
        Crank, coupler and output lengths.
    theta2, theta3, theta4 : array_like
        A solved position.
    omega2, omega3, omega4 : array_like
        The matching angular velocities (see :func:`fourbar_velocity`).
    alpha2 : array_like
        Crank angular acceleration.

    Returns
    -------
    alpha3, alpha4 : ndarray

    Examples
    --------
    >>> t3, t4 = fourbar_position(60, 25, 70, 45, 0.0)
    >>> w3, w4 = fourbar_velocity(25, 70, 45, 0.0, t3, t4, 1.0)
    >>> a3, a4 = fourbar_acceleration(25, 70, 45, 0.0, t3, t4, 1.0, w3, w4, 0.0)
    >>> round(float(a3), 4), round(float(a4), 4)
    (0.753, 1.871)
    """
    r2, r3, r4, theta2, theta3, theta4, omega2, omega3, omega4, alpha2 = (
        np.asarray(v, dtype=float)
        for v in (r2, r3, r4, theta2, theta3, theta4, omega2, omega3, omega4, alpha2)
    )
    s2, c2 = np.sin(theta2), np.cos(theta2)
    s3, c3 = np.sin(theta3), np.cos(theta3)
    s4, c4 = np.sin(theta4), np.cos(theta4)
    e = r2 * alpha2 * s2 + r2 * omega2**2 * c2 + r3 * omega3**2 * c3 - r4 * omega4**2 * c4
    g = r2 * alpha2 * c2 - r2 * omega2**2 * s2 - r3 * omega3**2 * s3 + r4 * omega4**2 * s4
    with np.errstate(divide="ignore", invalid="ignore"):
        s43 = np.sin(theta4 - theta3)
        alpha3 = (e * c4 - g * s4) / (r3 * s43)
        alpha4 = (e * c3 - g * s3) / (r4 * s43)
    return scalar_or_array(alpha3), scalar_or_array(alpha4)


# --------------------------------------------------------------------- slider-crank
def slider_crank_position(r2, r3, theta2, offset=0.0, mode=+1, theta1=0.0):
    """Slider position and coupler angle of a slider-crank, crank angle given (case i).

    Loop ``r2 e(theta2) + r3 e(theta3) = r1 e(theta1) + r4 e(theta1 + pi/2)`` with
    ``r4 = offset``. Squaring and adding gives the notes' quadratic
    ``r1^2 + B r1 + C = 0``, ``B = -2 r2 cos(theta1 - theta2)``,
    ``C = r2^2 + r4^2 - r3^2 - 2 r2 r4 cos(theta2 - theta4)``, ``theta4 = theta1 + pi/2``,
    so ``r1 = (-B +- sqrt(B^2 - 4C)) / 2``; ``B^2 - 4C = 4 (r3^2 - (r4 - r2
    sin(theta2 - theta1))^2)`` is evaluated in that factored form. Then ``theta3`` from
    the atan2 of the two loop components, quadrant kept.

    Parameters
    ----------
    r2, r3 : array_like
        Crank and connecting-rod lengths (positive).
    theta2 : array_like
        Crank angle.
    offset : array_like, optional
        Offset ``r4`` of the line of sliding (any sign; 0 for an in-line slider-crank).
    mode : {+1, -1} or array_like
        ``+1``: the larger root ``r1`` (the ``+`` sign; slider on the +x side for
        ``theta1 = 0``, the usual configuration); ``-1``: the smaller one.
    theta1 : array_like, optional
        Direction of the line of sliding, default 0.

    Returns
    -------
    r1, theta3 : ndarray
        NaN where the linkage cannot be assembled.

    Examples
    --------
    >>> import numpy as np
    >>> r1, t3 = slider_crank_position(5, 8, np.radians(45))
    >>> round(float(r1), 4), round(float(np.degrees(t3)), 4)
    (10.7119, -26.2278)
    """
    r2 = positive_length("r2", r2)
    r3 = positive_length("r3", r3)
    mode = _mode(mode)
    theta2, offset, theta1 = (np.asarray(v, dtype=float) for v in (theta2, offset, theta1))
    r4 = offset
    theta4 = theta1 + math.pi / 2
    big_b = -2 * r2 * np.cos(theta1 - theta2)
    # C = r2^2 + r4^2 - r3^2 - 2 r2 r4 cos(theta2 - theta4); only its factored
    # discriminant is needed below
    h = r4 - r2 * np.sin(theta2 - theta1)  # crank-pin to slider-pin, across the line
    gap = _snap(r3 - np.abs(h), r2 + r3 + np.abs(r4))
    ok = gap >= 0
    with np.errstate(invalid="ignore"):
        sqrt_disc = 2.0 * np.sqrt(np.where(ok, (r3 + np.abs(h)) * gap, np.nan))
    r1 = (-big_b + mode * sqrt_disc) / 2
    theta3 = np.arctan2(
        r1 * np.sin(theta1) + r4 * np.sin(theta4) - r2 * np.sin(theta2),
        r1 * np.cos(theta1) + r4 * np.cos(theta4) - r2 * np.cos(theta2),
    )
    theta3 = np.where(ok, theta3, np.nan)
    return scalar_or_array(r1), scalar_or_array(theta3)


def slider_crank_velocity(r2, r3, theta2, theta3, omega2, theta1=0.0):
    """Slider speed and coupler angular velocity of a slider-crank (crank input).

    The notes' system ``[-cos theta1, -r3 sin theta3; -sin theta1, r3 cos theta3]
    [r1_dot, omega3]^T = [r2 omega2 sin theta2, -r2 omega2 cos theta2]^T`` has
    determinant ``-r3 cos(theta3 - theta1)``; by Cramer's rule::

        r1_dot = -r2 omega2 sin(theta2 - theta3) / cos(theta3 - theta1)
        omega3 = -r2 omega2 cos(theta2 - theta1) / (r3 cos(theta3 - theta1))

    Parameters
    ----------
    r2, r3 : array_like
        Crank and connecting-rod lengths.
    theta2, theta3 : array_like
        A solved position (see :func:`slider_crank_position`).
    omega2 : array_like
        Crank angular velocity.
    theta1 : array_like, optional
        Direction of the line of sliding, default 0.

    Returns
    -------
    r1_dot, omega3 : ndarray

    Examples
    --------
    >>> import numpy as np
    >>> r1, t3 = slider_crank_position(5, 8, np.radians(45))
    >>> v, w3 = slider_crank_velocity(5, 8, np.radians(45), t3, 10.0)
    >>> round(float(v), 4), round(float(w3), 4)
    (-52.7737, -4.9266)
    """
    r2, r3, theta2, theta3, omega2, theta1 = (
        np.asarray(v, dtype=float) for v in (r2, r3, theta2, theta3, omega2, theta1)
    )
    with np.errstate(divide="ignore", invalid="ignore"):
        c31 = np.cos(theta3 - theta1)
        r1_dot = -r2 * omega2 * np.sin(theta2 - theta3) / c31
        omega3 = -r2 * omega2 * np.cos(theta2 - theta1) / (r3 * c31)
    return scalar_or_array(r1_dot), scalar_or_array(omega3)


def slider_crank_acceleration(r2, r3, theta2, theta3, omega2, omega3, alpha2, theta1=0.0):
    """Slider acceleration and coupler angular acceleration of a slider-crank.

    Same coefficient matrix as the velocities (the notes' acceleration matrix prints
    ``+cos theta1`` top-left; differentiating the loop gives ``-cos theta1``)::

        [-cos theta1  -r3 sin theta3] [r1_ddot]   [E]
        [-sin theta1   r3 cos theta3] [alpha3 ] = [F]

        E =  r2 alpha2 sin theta2 + r2 w2^2 cos theta2 + r3 w3^2 cos theta3
        F = -r2 alpha2 cos theta2 + r2 w2^2 sin theta2 + r3 w3^2 sin theta3

    so ``r1_ddot = -(E cos theta3 + F sin theta3) / cos(theta3 - theta1)`` and
    ``alpha3 = (F cos theta1 - E sin theta1) / (r3 cos(theta3 - theta1))``.

    Parameters
    ----------
    r2, r3 : array_like
        Crank and connecting-rod lengths.
    theta2, theta3 : array_like
        A solved position.
    omega2, omega3 : array_like
        Crank and coupler angular velocities.
    alpha2 : array_like
        Crank angular acceleration.
    theta1 : array_like, optional
        Direction of the line of sliding, default 0.

    Returns
    -------
    r1_ddot, alpha3 : ndarray

    Examples
    --------
    >>> import numpy as np
    >>> th2 = np.radians(45)
    >>> r1, t3 = slider_crank_position(5, 8, th2)
    >>> v, w3 = slider_crank_velocity(5, 8, th2, t3, 10.0)
    >>> a, a3 = slider_crank_acceleration(5, 8, th2, t3, 10.0, w3, 0.0)
    >>> round(float(a), 3), round(float(a3), 3)
    (-395.831, 37.309)
    """
    r2, r3, theta2, theta3, omega2, omega3, alpha2, theta1 = (
        np.asarray(v, dtype=float) for v in (r2, r3, theta2, theta3, omega2, omega3, alpha2, theta1)
    )
    s2, c2 = np.sin(theta2), np.cos(theta2)
    s3, c3 = np.sin(theta3), np.cos(theta3)
    e = r2 * alpha2 * s2 + r2 * omega2**2 * c2 + r3 * omega3**2 * c3
    f = -r2 * alpha2 * c2 + r2 * omega2**2 * s2 + r3 * omega3**2 * s3
    with np.errstate(divide="ignore", invalid="ignore"):
        c31 = np.cos(theta3 - theta1)
        r1_ddot = -(e * c3 + f * s3) / c31
        alpha3 = (f * np.cos(theta1) - e * np.sin(theta1)) / (r3 * c31)
    return scalar_or_array(r1_ddot), scalar_or_array(alpha3)


def slider_crank_inversion_position(r1, r2, r3, offset=0.0, mode=+1, theta1=0.0):
    """Crank and coupler angles of a slider-crank, slider position given (case ii).

    With the slider pin at ``P = r1 e(theta1) + r4 e(theta1 + pi/2)`` (``r4 = offset``)
    the notes' eq. ``A1 cos theta2 + B1 sin theta2 + C1 = 0`` has
    ``A1 = -2 r1 r2 cos theta1 - 2 r2 r4 cos theta4``,
    ``B1 = -2 r1 r2 sin theta1 - 2 r2 r4 sin theta4``,
    ``C1 = r1^2 + r2^2 + r4^2 - r3^2`` (``theta4 = theta1 + pi/2``); ``t = tan(theta2/2)``
    gives ``A t^2 + B t + C = 0``, ``A = C1 - A1``, ``B = 2 B1``, ``C = C1 + A1``. The
    discriminant equals ``4 ((r2 + r3)^2 - |P|^2)(|P|^2 - (r2 - r3)^2)`` (used in that
    form) and the root is taken in a cancellation-free form (``A = 0`` is fine).

    Parameters
    ----------
    r1 : array_like
        Slider position along the line of sliding (any sign).
    r2, r3 : array_like
        Crank and connecting-rod lengths (positive).
    offset : array_like, optional
        Offset ``r4`` of the line of sliding.
    mode : {+1, -1} or array_like
        ``+1``: the solution with ``sin(theta3 - theta2) > 0`` (the rod turns
        counter-clockwise from the crank; for an in-line slider at ``r1 > 0`` the crank
        is below the line of sliding); ``-1``: its mirror image about O2-P with
        ``sin(theta3 - theta2) < 0``. Well defined wherever the linkage assembles (both
        coincide at the dead centres). It is the ``-`` sign of ``(-B -+ sqrt(B^2 -
        4AC)) / (2A)`` in the notes.
    theta1 : array_like, optional
        Direction of the line of sliding, default 0.

    Returns
    -------
    theta2, theta3 : ndarray
        NaN where the linkage cannot be assembled.

    Examples
    --------
    >>> import numpy as np
    >>> r1, _ = slider_crank_position(5, 8, np.radians(45))
    >>> t2, t3 = slider_crank_inversion_position(r1, 5, 8, mode=-1)
    >>> round(float(np.degrees(t2)), 6), round(float(np.degrees(t3)), 4)
    (45.0, -26.2278)
    """
    r2 = positive_length("r2", r2)
    r3 = positive_length("r3", r3)
    mode = _mode(mode)
    r1, offset, theta1 = (np.asarray(v, dtype=float) for v in (r1, offset, theta1))
    r4 = offset
    theta4 = theta1 + math.pi / 2
    a1 = -2 * r1 * r2 * np.cos(theta1) - 2 * r2 * r4 * np.cos(theta4)
    b1 = -2 * r1 * r2 * np.sin(theta1) - 2 * r2 * r4 * np.sin(theta4)
    c1 = r1**2 + r2**2 + r4**2 - r3**2 + 2 * r1 * r4 * np.cos(theta1 - theta4)
    a, b, c = c1 - a1, 2 * b1, c1 + a1
    p = np.hypot(r1, r4)
    scale = r2 + r3 + np.abs(r1) + np.abs(r4)
    gap_out = _snap(r2 + r3 - p, scale)
    gap_in = _snap(p - np.abs(r2 - r3), scale)
    ok = (gap_out >= 0) & (gap_in >= 0)
    with np.errstate(invalid="ignore"):
        disc = 4.0 * (r2 + r3 + p) * gap_out * (p + np.abs(r2 - r3)) * gap_in
        sqrt_disc = np.sqrt(np.where(ok, disc, np.nan))
    theta2 = _half_angle_root(a, b, c, sqrt_disc, mode)
    theta3 = np.arctan2(
        r1 * np.sin(theta1) + r4 * np.sin(theta4) - r2 * np.sin(theta2),
        r1 * np.cos(theta1) + r4 * np.cos(theta4) - r2 * np.cos(theta2),
    )
    theta3 = np.where(ok, theta3, np.nan)
    return scalar_or_array(theta2), scalar_or_array(theta3)


# The limits and classes (Grashof, input range, toggles, transmission angle, mobility, quick
# return) live in classic_limits.py, which uses the helpers above; they answer here too.
_LIMITS = {"GrashofClass", "grashof", "is_grashof", "fourbar_input_range", "fourbar_toggle_angles",
           "transmission_angle", "transmission_angle_range", "gruebler", "quick_return"}


def __getattr__(name):
    if name in _LIMITS:
        from . import classic_limits

        return getattr(classic_limits, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
