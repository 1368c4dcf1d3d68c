"""The key-probe four-bar (a tilted ground link) as model text with any field changed, and its
closed-form positions (two circles' intersection) for the compiled-code tests."""

import math

import loopsolve as ls


BASE = dict(
    length="mm", angle="deg", AD="80", AB="20", BC="66", CD="56",
    gnd_angle="10", ab_angle="theta2", bc_angle="theta3", dc_angle="theta4", ab_len="AB", dc_len="CD",
    dc_offset="", bc_vec='{ length = "BC", angle = "theta3" }',
    loop="rAB + rBC = rAD + rDC", points='B = "rAB"\nC = "rAB + rBC"', guesses=(0, 60, 100),
)


TEMPLATE = """
name = "key probe"
units = {{ length = "{length}", angle = "{angle}" }}

[parameters]
AD = {AD}
AB = {AB}
BC = {BC}
CD = {CD}

[variables]
theta2 = {{ input = true, guess = {g0} }}
theta3 = {{ guess = {g1} }}
theta4 = {{ guess = {g2} }}

[vectors]
rAD = {{ length = "AD", angle = {gnd_angle} }}
rAB = {{ length = "{ab_len}", angle = "{ab_angle}" }}
rBC = {bc_vec}
rDC = {{ length = "{dc_len}", angle = "{dc_angle}"{dc_offset} }}

[[loops]]
equation = "{loop}"

[points]
{points}
"""


def model_text(**changes) -> str:
    fields = dict(BASE, **changes)
    g0, g1, g2 = fields.pop("guesses")
    return TEMPLATE.format(g0=g0, g1=g1, g2=g2, **fields)


def model(**changes):
    return ls.loads(model_text(**changes), source="probe.toml")


def fourbar_positions(a, b, c, d, gamma, theta2):
    """Both closures (theta3, theta4) [rad] of B = a·e(theta2), C = B + b·e(theta3) = D + c·e(theta4)
    with D = d·e(gamma): the intersections of the circles |C - B| = b and |C - D| = c."""
    bx, by = a * math.cos(theta2), a * math.sin(theta2)
    dx, dy = d * math.cos(gamma), d * math.sin(gamma)
    ux, uy = dx - bx, dy - by
    L = math.hypot(ux, uy)
    ux, uy = ux / L, uy / L
    h = (b * b - c * c + L * L) / (2 * L)
    k = math.sqrt(b * b - h * h)
    out = []
    for s in (1, -1):
        cx, cy = bx + h * ux - s * k * uy, by + h * uy + s * k * ux
        out.append((math.atan2(cy - by, cx - bx), math.atan2(cy - dy, cx - dx)))
    return out


def wrap_angle(a):
    return (a + math.pi) % (2 * math.pi) - math.pi


def assert_is_a_closure(theta3, theta4, expected, tol=1e-9):
    """(theta3, theta4) [rad] equals one of the closed-form closures."""
    err = min(max(abs(wrap_angle(theta3 - t3)), abs(wrap_angle(theta4 - t4))) for t3, t4 in expected)
    assert err < tol, (theta3, theta4, expected)


def solve_rad(mech, at):
    """theta3, theta4 of ``mech.solve(at)`` in radians whatever the model's angle unit."""
    s = mech.solve(at)
    k = math.pi / 180 if mech.units.angle == "deg" else 1.0
    return s["theta3"] * k, s["theta4"] * k
