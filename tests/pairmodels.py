"""Model files with higher pairs (constraints, gears, cams, slots, rolling, friction) that several test
files share, as TOML text; each test writes what it needs and checks it against formulas of its own."""

import loopsolve as ls

#: a five-bar of two cranks (O1 at the origin, O5 at (40, 0)), written as one vector loop; with
#: ``extra`` a constraint or a gear pair couples the cranks (one input left)
FIVEBAR = """
name = "five-bar"
units = {{ length = "mm", angle = "deg" }}

[parameters]
r1 = 40
r2 = 20
r3 = 50
r4 = 50
r5 = 20

[variables]
theta2 = {{ input = true, guess = 90 }}
theta3 = {{ guess = 66.42 }}
theta4 = {{ guess = 113.58 }}
theta5 = {{ guess = 90 }}

[vectors]
r1 = {{ length = "r1", angle = 0 }}
r2 = {{ length = "r2", angle = "theta2" }}
r3 = {{ length = "r3", angle = "theta3" }}
r4 = {{ length = "r4", angle = "theta4" }}
r5 = {{ length = "r5", angle = "theta5" }}

[[loops]]
equation = "r2 + r3 = r1 + r5 + r4"

[points]
A = "r2"
B = "r1 + r5"
P = "r2 + r3"

{extra}
"""


def fivebar(extra: str, **params) -> ls.Mechanism:
    """The five-bar with ``extra`` TOML appended (a [constraints] or [gears] table), parameters replaced."""
    mech = ls.loads(FIVEBAR.format(extra=extra))
    return mech.with_parameters(**params) if params else mech
