"""Geometry of a disk cam and its follower: pitch curve, profile, pressure angle, radius of curvature.

Everything is computed in the cam's own frame of analysis, in numbers (numpy): the cam turns
counter-clockwise about the origin by its angle θ; a translating follower moves along +y, offset by
``ε`` along +x; an oscillating follower's pivot sits at ``(d, 0)`` and its arm of length ``L`` carries
the roller (or knife) on the ``side`` of the line from the cam centre to the pivot (left: +y). A
mechanism places this frame at the cam's ``center``, turned by its follower's direction
(:attr:`CamNumbers.frame_angle`).

With the follower's pitch point ``C(θ)`` in the fixed frame (the roller centre, the knife edge) and its
derivatives, the pitch curve on the cam is ``P = R(−θ) C``; its tangent ``R(−θ)(C′ − J C)`` (``J`` a
quarter turn) and curvature follow in closed form. The pressure angle is the signed angle from the
follower's direction of motion at ``C`` to the contact normal: for an offset translating roller
follower ``tan φ = (s′ − ε)/(s + √(R_p² − ε²))``. A flat face is a line ``n·X = p`` in the fixed frame;
the profile is the envelope of its positions on the cam, whose radius of curvature is ``p + d²p/dα²``
(``R_b + s + s″`` for a translating face). Undercut: a roller larger than a convex radius of curvature
of the pitch curve (the profile folds into a cusp), or a flat-face profile whose radius of curvature
turns negative.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .camlaws import Law, law_values

__all__ = ["CamNumbers", "analyse", "follower_pose"]


def _J(v):
    """A quarter turn counter-clockwise of ``(N, 2)`` vectors."""
    return np.stack([-v[..., 1], v[..., 0]], axis=-1)


def _rot(v, a):
    c, s = np.cos(a), np.sin(a)
    return np.stack([c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1]], axis=-1)


def _cross(a, b):
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


@dataclass(frozen=True)
class CamNumbers:
    """A cam in numbers: radians and the model's length unit. ``kind`` translating/oscillating,
    ``contact`` knife/roller/flat; ``base`` the base circle of the profile, ``roller`` its radius
    (0: knife or flat), ``offset`` ε of a translating follower; ``pivot`` d, ``arm`` L, ``side`` ±1 of an
    oscillating one; ``frame_angle`` turns the frame of analysis into the mechanism's."""

    kind: str
    contact: str
    law: Law
    base: float
    roller: float = 0.0
    offset: float = 0.0
    pivot: float = 0.0
    arm: float = 0.0
    side: int = 1
    frame_angle: float = 0.0

    @property
    def pitch_base(self) -> float:
        """R_p: the base circle of the pitch curve (base + roller)."""
        return self.base + self.roller

    def arm_start(self) -> tuple[float, int]:
        """``(γ₀, σ)`` of an oscillating follower: the arm's angle at zero lift and the sense in which a
        positive lift turns it (away from the cam centre). Raises ValueError if no such pose exists."""
        d, L = self.pivot, self.arm
        A = np.array([d, 0.0])
        if self.contact == "flat":  # the face, a line through the pivot, tangent to the base circle
            if self.base >= d:
                raise ValueError("the pivot lies inside the base circle")
            g0 = math.pi - self.side * math.asin(self.base / d)
            n = np.array([-math.sin(g0), math.cos(g0)])  # normal of the face, away from the cam centre
            if n @ A < 0:
                n = -n
            # turning the face by +dγ moves it away from the centre when d(n·A)/dγ = (J n)·A > 0
            return g0, (1 if np.array([-n[1], n[0]]) @ A > 0 else -1)
        R = self.pitch_base
        c = (d * d + L * L - R * R) / (2 * d * L)
        if abs(c) > 1:
            raise ValueError("the arm cannot reach the base circle of the pitch curve")
        g0 = math.pi - self.side * math.acos(c)  # from the pivot back towards the cam, on the chosen side
        C = A + L * np.array([math.cos(g0), math.sin(g0)])
        dC = L * np.array([-math.sin(g0), math.cos(g0)])
        return g0, (1 if C @ dC > 0 else -1)


def follower_pose(cam: CamNumbers, theta):
    """The follower's pitch point ``C`` and its first three derivatives in θ (fixed frame of analysis),
    and the direction ``m`` in which it moves as the lift grows: arrays ``(N, 2)``."""
    s, s1, s2, s3 = law_values(cam.law, theta)
    n = np.size(s)
    if cam.kind == "translating":
        y0 = math.sqrt(cam.pitch_base**2 - cam.offset**2)
        C = np.stack([np.full(n, cam.offset), y0 + s], axis=-1)
        z = np.zeros(n)
        return (C, np.stack([z, s1], -1), np.stack([z, s2], -1), np.stack([z, s3], -1),
                np.tile([0.0, 1.0], (n, 1)))
    g0, sigma = cam.arm_start()
    g, g1, g2, g3 = g0 + sigma * s, sigma * s1, sigma * s2, sigma * s3
    e = np.stack([np.cos(g), np.sin(g)], axis=-1)
    Je = _J(e)
    L = cam.arm
    C = np.array([cam.pivot, 0.0]) + L * e
    C1 = L * g1[:, None] * Je
    C2 = L * (g2[:, None] * Je - (g1**2)[:, None] * e)
    C3 = L * (g3[:, None] * Je - 3 * (g1 * g2)[:, None] * e - (g1**3)[:, None] * Je)
    return C, C1, C2, C3, sigma * Je


def _face(cam: CamNumbers, theta):
    """A flat face in the fixed frame: unit normal ``n`` (away from the cam), ``p`` (n·X = p on the face),
    the rates of ``p`` and of the normal's angle ``α`` in θ, and the direction of motion of a point of
    the face at ``X`` (a function of X)."""
    s, s1, s2, s3 = law_values(cam.law, theta)
    n_ = np.size(s)
    if cam.kind == "translating":
        nrm = np.tile([0.0, 1.0], (n_, 1))
        return nrm, cam.base + s, s1, s2, np.zeros(n_), np.zeros(n_), lambda X: np.tile([0.0, 1.0], (len(X), 1))
    g0, sigma = cam.arm_start()
    g, g1, g2 = g0 + sigma * s, sigma * s1, sigma * s2
    A = np.array([cam.pivot, 0.0])
    nrm = np.stack([-np.sin(g), np.cos(g)], axis=-1)
    flip = np.where(nrm @ A < 0, -1.0, 1.0)
    nrm = nrm * flip[:, None]
    Jn = _J(nrm)
    p = nrm @ A
    p1 = g1 * (Jn @ A)
    p2 = g2 * (Jn @ A) - g1**2 * p
    return nrm, p, p1, p2, g1, g2, lambda X: sigma * _J(X - A)


def analyse(cam: CamNumbers, theta) -> dict:
    """SVAJ, pitch curve, profile, pressure angle and radius of curvature at cam angles ``theta``.

    Returns arrays: ``s``, ``v``, ``a``, ``j`` (per radian), ``pressure`` (radians), ``rho`` (the pitch
    curve's radius of curvature; the profile's for a flat face; negative where concave), ``pitch`` and
    ``profile`` ``(N, 2)`` on the cam (frame of analysis at θ = 0), ``contact`` ``(N, 2)`` the contact
    point in the fixed frame and ``normal`` the contact normal there; ``undercut`` (bool array) and, for a
    flat face, ``face_offset``: where along the face the contact is, from the foot of the perpendicular
    from the cam centre (``s′`` for a translating face).
    """
    th = np.asarray(theta, dtype=float)
    s, v, a, j = law_values(cam.law, th)
    out = {"s": s, "v": v, "a": a, "j": j}
    if cam.contact == "flat":
        nrm, p, p1, p2, al1, al2, motion = _face(cam, th)
        alpha1 = al1 - 1.0  # the normal turns with γ on the follower and by −θ on the cam
        Jn = _J(nrm)
        X = p[:, None] * nrm + (p1 / alpha1)[:, None] * Jn
        rho = p + (p2 * alpha1 - p1 * al2) / alpha1**3
        m = motion(X)
        m = m / np.linalg.norm(m, axis=1)[:, None]
        out.update(pressure=np.arctan2(_cross(m, nrm), np.sum(m * nrm, axis=1)), rho=rho,
                   pitch=_rot(X, -th), profile=_rot(X, -th), contact=X, normal=nrm,
                   undercut=rho <= 0, face_offset=-p1 / alpha1)
        return out
    C, C1, C2, _, m = follower_pose(cam, th)
    T = C1 - _J(C)
    T1 = C2 - 2 * _J(C1) - C
    speed = np.linalg.norm(T, axis=1)
    N = _J(T) / speed[:, None]  # outward: the pitch point runs clockwise round the cam
    with np.errstate(divide="ignore", invalid="ignore"):
        rho = -speed**3 / _cross(T, T1)
    m = m / np.linalg.norm(m, axis=1)[:, None]
    pressure = np.arctan2(_cross(m, N), np.sum(m * N, axis=1))
    pitch = _rot(C, -th)
    profile = _rot(C - cam.roller * N, -th)
    undercut = (rho > 0) & (rho <= cam.roller) if cam.roller > 0 else np.zeros(len(th), dtype=bool)
    out.update(pressure=pressure, rho=rho, pitch=pitch, profile=profile, contact=C - cam.roller * N, normal=N,
               undercut=undercut)
    return out
