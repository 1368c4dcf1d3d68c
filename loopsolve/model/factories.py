"""Factories for the classic linkages: ordinary :class:`~loopsolve.model.mechanism.Mechanism` objects.

They build the same declarations a user would write in a model file (and ``dumps`` prints
that file), with guesses that select the requested assembly mode.
"""

from __future__ import annotations

import math

from ..errors import ModelError
from .builder import MechanismBuilder
from .mechanism import Mechanism

__all__ = ["fourbar", "slider_crank", "inverted_slider_crank"]


def _circle_guess(ax, ay, ra, bx, by, rb, sign):
    """Intersection of circles (A, ra) and (B, rb) on the side ``sign`` of A→B, or None."""
    dx, dy = bx - ax, by - ay
    d = math.hypot(dx, dy)
    if d == 0 or d > ra + rb or d < abs(ra - rb):
        return None
    a = (ra * ra - rb * rb + d * d) / (2 * d)
    h = math.sqrt(max(ra * ra - a * a, 0.0))
    mx, my = ax + a * dx / d, ay + a * dy / d
    return mx - sign * h * dy / d, my + sign * h * dx / d


def fourbar(r1: float, r2: float, r3: float, r4: float, *, theta2: float = 90.0, mode: str = "open",
            name: str = "four-bar", length_unit: str = "mm", speed=None, accel=None) -> Mechanism:
    """A four-bar: ground r1 (O2 at the origin, O4 at (r1, 0)), crank r2, coupler r3, rocker r4.

    Loop ``r2 + r3 = r1 + r4``; input θ2 (degrees). ``mode`` is ``"open"`` (sin(θ4 − θ3) > 0,
    signature ``"-"``) or ``"crossed"`` (signature ``"+"``); both names are aliases of the
    signatures for ``--mode``. Points: B (crank pin) and C (coupler–rocker pin).

    Parameters
    ----------
    r1, r2, r3, r4 : float
        Ground, crank, coupler and rocker lengths (``length_unit``).
    theta2 : float, optional
        The crank angle of the guesses (degrees).
    mode : {"open", "crossed"}, optional
        The assembly mode the guesses are in.
    name, length_unit, speed, accel : optional
        The mechanism's name, length unit and the crank's speed and acceleration.

    Returns
    -------
    Mechanism

    Examples
    --------
    >>> s = ls.fourbar(60, 25, 70, 45).solve(90)
    >>> round(s["theta3"], 2), round(s["theta4"], 2)
    (16.1, 80.72)
    """
    if mode not in ("open", "crossed"):
        raise ModelError(f"mode {mode!r}: expected 'open' or 'crossed'")
    b = MechanismBuilder(name, length_unit=length_unit, angle_unit="deg")
    for n, v in (("r1", r1), ("r2", r2), ("r3", r3), ("r4", r4)):
        if not (isinstance(v, (int, float)) and v > 0):
            raise ModelError(f"{name}: link length {n} = {v!r} must be a positive number")
        b.parameter(n, v)
    t2 = math.radians(theta2)
    bx, by = r2 * math.cos(t2), r2 * math.sin(t2)
    # open: C on the left of B->O4, so that sin(theta4 - theta3) > 0
    c = _circle_guess(bx, by, r3, r1, 0.0, r4, 1 if mode == "open" else -1)
    if c is None:
        raise ModelError(f"{name}: cannot be assembled at theta2 = {theta2:g} deg; pass another theta2=")
    t3 = math.degrees(math.atan2(c[1] - by, c[0] - bx))
    t4 = math.degrees(math.atan2(c[1], c[0] - r1))
    b.variable("theta2", input=True, guess=theta2, speed=speed, accel=accel)
    b.variable("theta3", guess=round(t3, 9)).variable("theta4", guess=round(t4, 9))
    b.vector("r1", length="r1", angle=0).vector("r2", length="r2", angle="theta2")
    b.vector("r3", length="r3", angle="theta3").vector("r4", length="r4", angle="theta4")
    b.loop("r2 + r3 = r1 + r4").point("B", "r2").point("C", "r2 + r3")
    b.mode("open", "-").mode("crossed", "+")
    return b.build()


def slider_crank(r2: float, r3: float, *, offset: float = 0.0, theta2: float = 45.0, mode: str = "right",
                 name: str = "slider-crank", length_unit: str = "mm", speed=None, accel=None) -> Mechanism:
    """An offset slider-crank in the notes' vectors: ``r2 + r3 = r1 + r4``.

    r2 = crank (θ2, input), r3 = connecting rod (θ3), r1 = slider position ``x`` along +x,
    r4 = the offset ``e`` perpendicular to the line of sliding. ``mode`` ``"right"`` puts the
    slider on the +x side of the crank pin. Points: B (crank pin) and C (slider).

    Parameters
    ----------
    r2, r3 : float
        Crank and connecting-rod lengths (``length_unit``).
    offset : float, optional
        The offset ``e`` of the line of sliding from the crank pivot.
    theta2 : float, optional
        The crank angle of the guesses (degrees).
    mode : {"right", "left"}, optional
        The side of the crank pin the slider is on.
    name, length_unit, speed, accel : optional
        The mechanism's name, length unit and the crank's speed and acceleration.

    Returns
    -------
    Mechanism

    Examples
    --------
    >>> s = ls.slider_crank(5, 8, theta2=45).solve(45)
    >>> round(8 * math.sin(math.radians(s["theta3"])), 6) == round(-5 / math.sqrt(2), 6)
    True
    """
    if mode not in ("right", "left"):
        raise ModelError(f"mode {mode!r}: expected 'right' or 'left'")
    t2 = math.radians(theta2)
    bx, by = r2 * math.cos(t2), r2 * math.sin(t2)
    dy = offset - by
    if abs(dy) > r3:
        raise ModelError(f"{name}: cannot be assembled at theta2 = {theta2:g} deg; pass another theta2=")
    dx = math.sqrt(r3 * r3 - dy * dy) * (1 if mode == "right" else -1)
    b = MechanismBuilder(name, length_unit=length_unit, angle_unit="deg")
    b.parameter("r2", r2).parameter("r3", r3).parameter("e", offset)
    b.variable("theta2", input=True, guess=theta2, speed=speed, accel=accel)
    b.variable("theta3", guess=round(math.degrees(math.atan2(dy, dx)), 9))
    b.variable("x", guess=round(bx + dx, 12))
    b.vector("r1", length="x", angle=0).vector("r2", length="r2", angle="theta2")
    b.vector("r3", length="r3", angle="theta3").vector("r4", length="e", angle=90)
    b.loop("r2 + r3 = r1 + r4").point("B", "r2").point("C", "r1 + r4")
    return b.build()


def inverted_slider_crank(r2: float, d: float, *, theta2: float = 0.0, name: str = "crank and slotted lever",
                          length_unit: str = "mm", speed=None, accel=None) -> Mechanism:
    """Quick-return (crank and slotted lever): crank r2 about O2, lever pivot O4 a distance d below O2.

    Origin at O4; loop ``r1 + r2 = r4`` with r1 = O4→O2 (fixed, length d, 90°), r2 the crank
    (θ2, input) and r4 = O4→block (variable length ``s``, angle θ4). The block slides on the
    rotating lever, so its acceleration has a Coriolis part (see ``State.acceleration_components``).

    Parameters
    ----------
    r2 : float
        The crank's length.
    d : float
        The distance O4→O2 (greater than ``r2``).
    theta2 : float, optional
        The crank angle of the guesses (degrees).
    name, length_unit, speed, accel : optional
        The mechanism's name, length unit and the crank's speed and acceleration.

    Returns
    -------
    Mechanism

    Examples
    --------
    >>> qr = ls.inverted_slider_crank(50, 150, speed="30rpm")
    >>> round(qr.solve(0)["theta4"], 4)
    71.5651
    """
    if not d > r2 > 0:
        raise ModelError(f"{name}: need d > r2 > 0 for a crank and slotted lever (got r2={r2}, d={d})")
    t2 = math.radians(theta2)
    ax, ay = r2 * math.cos(t2), d + r2 * math.sin(t2)
    b = MechanismBuilder(name, length_unit=length_unit, angle_unit="deg")
    b.parameter("r2", r2).parameter("d", d)
    b.variable("theta2", input=True, guess=theta2, speed=speed, accel=accel)
    b.variable("theta4", guess=round(math.degrees(math.atan2(ay, ax)), 9))
    b.variable("s", guess=round(math.hypot(ax, ay), 12))
    b.vector("r1", length="d", angle=90).vector("r2", length="r2", angle="theta2")
    b.vector("r4", length="s", angle="theta4")
    b.loop("r1 + r2 = r4").point("A", "r1 + r2")
    return b.build()
