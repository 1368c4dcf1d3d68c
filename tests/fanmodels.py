"""Model text of a fan of N four-bar loops driven by one crank (for the scaling tests and benchmarks).

Loop k: ``rA + c_k = g_k + o_k`` with the shared crank ``rA`` (length 1, angle θ2, the input),
ground ``g_k`` (angle 0), coupler ``c_k`` (θ3_k) and rocker ``o_k`` (θ4_k); each loop is its own
2×2 block. Every fifth loop is short enough that it limits the crank (a rocker-input range);
the others let the crank turn fully.
"""

from __future__ import annotations

import math


def fan_lengths(n: int) -> list[tuple[float, float, float]]:
    """``(ground, coupler, rocker)`` of each loop (crank length 1)."""
    out = []
    for k in range(n):
        if k % 5 == 4:
            out.append((4.0 + 0.01 * (k % 7), 1.6 + 0.02 * (k % 3), 2.0 + 0.01 * (k % 11)))
        else:
            out.append((4.0 + 0.3 * (k % 7), 3.5 + 0.4 * (k % 5), 3.0 + 0.5 * (k % 3)))
    return out


def _open_pose(g, c, o, t2):
    """θ3, θ4 of the loop at crank angle t2 (law of cosines), the branch with θ4 above the diagonal."""
    bx, by = math.cos(t2) - g, math.sin(t2)  # B relative to the rocker pivot
    d = math.hypot(bx, by)
    phi = math.atan2(by, bx)
    gam = math.acos((o * o + d * d - c * c) / (2 * o * d))
    t4 = phi + gam
    cx, cy = g + o * math.cos(t4), o * math.sin(t4)
    t3 = math.atan2(cy - math.sin(t2), cx - math.cos(t2))
    return t3, t4


def fan_model(n: int) -> str:
    """TOML text of the N-loop fan (θ2 guess 0, each loop near its branch at θ2 = 0)."""
    lines = [f'name = "fan of {n} four-bars"', 'units = { length = "mm", angle = "deg" }', "", "[parameters]",
             "A = 1"]
    L = fan_lengths(n)
    for k, (g, c, o) in enumerate(L):
        lines.append(f"G{k} = {g!r}\nC{k} = {c!r}\nO{k} = {o!r}")
    lines += ["", "[variables]", "theta2 = { input = true, guess = 0 }"]
    for k, (g, c, o) in enumerate(L):
        t3, t4 = _open_pose(g, c, o, 0.0)
        lines.append(f"t3_{k} = {{ guess = {round(math.degrees(t3), 3)!r} }}")
        lines.append(f"t4_{k} = {{ guess = {round(math.degrees(t4), 3)!r} }}")
    lines += ["", "[vectors]", 'rA = { length = "A", angle = "theta2" }']
    for k in range(n):
        lines.append(f'g{k} = {{ length = "G{k}", angle = 0 }}')
        lines.append(f'c{k} = {{ length = "C{k}", angle = "t3_{k}" }}')
        lines.append(f'o{k} = {{ length = "O{k}", angle = "t4_{k}" }}')
    for k in range(n):
        lines += ["", "[[loops]]", f'name = "L{k}"', f'equation = "rA + c{k} = g{k} + o{k}"']
    return "\n".join(lines) + "\n"


def crank_range(g: float, c: float, o: float) -> tuple[float, float] | None:
    """Closed-form crank interval (radians, symmetric about 0) of one loop, None if it turns fully.

    The diagonal from the crank pin to the rocker pivot, d² = 1 + g² − 2g cos θ2, must lie in
    [|c − o|, c + o].
    """
    lo_d, hi_d = abs(c - o), c + o
    # cos θ2 = (1 + g² − d²) / (2g): d grows with |θ2|
    cmax = (1 + g * g - lo_d ** 2) / (2 * g)  # smallest d allowed -> upper bound on cos
    cmin = (1 + g * g - hi_d ** 2) / (2 * g)
    if cmax < 1:
        raise ValueError("a loop whose crank range excludes θ2 = 0 is not covered by this helper")
    if cmin <= -1:
        return None
    return (-math.acos(cmin), math.acos(cmin))
