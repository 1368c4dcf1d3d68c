"""The mechanisms the tests share, each with its own closed-form reference where it has one.

Four-bars planted at known poses (the Burmester and synthesis references), the Watt II six-bar, the
higher-pair models (slotted lever, rolling disk, cam and follower, gear train, planetary stage,
five-bar), the fan of N four-bars for the scaling tests, and a helper that adds loads to a model.
"""

from __future__ import annotations

import math

import numpy as np

import loopsolve as ls


# -- a Watt II six-bar (two 2x2 dyad blocks)
def watt_sixbar(theta2=60.0):
    """A Watt II six-bar (two four-bars in series on the ternary rocker): two 2x2 dyad blocks."""
    b = ls.MechanismBuilder("Watt II six-bar")
    for k, v in dict(r1=60, r2=25, r3=70, r4=45, r4c=25, r5=65, r6=55).items():
        b.parameter(k, v)
    b.variable("theta2", input=True, guess=theta2)
    b.variable("theta3", guess=15.48).variable("theta4", guess=63.67)
    b.variable("theta5", guess=77.76).variable("theta6", guess=-170.86)
    b.vector("r1", length="r1", angle=0).vector("r2", length="r2", angle="theta2")
    b.vector("r3", length="r3", angle="theta3").vector("r4", length="r4", angle="theta4")
    b.vector("r4c", length="r4c", angle="theta4", offset=160).vector("r5", length="r5", angle="theta5")
    b.vector("r6", length="r6", angle="theta6").vector("r7", x=50, y=55)
    b.loop("r2 + r3 = r1 + r4").loop("r4c + r5 = r7 + r6")
    b.point("B", "r2 + r3").point("D", "r7 + r6")
    return b.build()


# -- a planted crank-rocker: the thesis four-bar moved and turned, its poses by circle intersection
O2 = np.array([1.0, 2.0])


T1 = math.radians(10.0)


R1, R2, R3, R4, RP, GP = 60.0, 25.0, 70.0, 45.0, 30.0, math.radians(40.0)


O4 = O2 + R1 * np.array([math.cos(T1), math.sin(T1)])


def circle_intersection(a, ra, b, rb, side):
    """The intersection of circles (a, ra), (b, rb) on the left (side=+1) or right of a→b, or None."""
    d = b - a
    L = float(np.hypot(*d))
    x = (ra * ra - rb * rb + L * L) / (2 * L)
    h2 = ra * ra - x * x
    if h2 < 0:
        return None
    h = math.sqrt(h2)
    return a + x * d / L + side * h * np.array([-d[1], d[0]]) / L


def planted_pose(t2_deg, side=1):
    t2 = math.radians(t2_deg)
    A = O2 + R2 * np.array([math.cos(t2), math.sin(t2)])
    B = circle_intersection(A, R3, O4, R4, side)
    th3 = math.atan2(B[1] - A[1], B[0] - A[0])
    P = A + RP * np.array([math.cos(th3 + GP), math.sin(th3 + GP)])
    return (float(P[0]), float(P[1]), math.degrees(th3)), A, B


POSES5 = [planted_pose(t)[0] for t in (20, 70, 120, 170, 220)]


# -- the path-synthesis four-bar (models/fourbar_path_synthesis.toml) by circle intersection, and a
#    planted design with its inputs and search box
def fourbar_point(p, theta2_deg, sign):
    """Coupler point P of the synthesis four-bar by circle intersection (independent of loopsolve).

    ``sign`` is the model's mode: the sign of det Φ_q = r3 r4 sin(θ3 − θ4). Returns None when
    the loop cannot close.
    """
    t0, ph = math.radians(p.get("theta0", 0.0)), math.radians(p.get("phi", 0.0))
    O2 = np.array([p.get("x0", 0.0), p.get("y0", 0.0)])
    O4 = O2 + p["r1"] * np.array([math.cos(t0), math.sin(t0)])
    a = math.radians(theta2_deg) + ph + t0
    A = O2 + p["r2"] * np.array([math.cos(a), math.sin(a)])
    d = np.linalg.norm(O4 - A)
    r3, r4 = p["r3"], p["r4"]
    if d > r3 + r4 or d < abs(r3 - r4):
        return None
    u = (O4 - A) / d
    along = (d * d + r3 * r3 - r4 * r4) / (2 * d)
    h = math.sqrt(max(r3 * r3 - along * along, 0.0))
    n = np.array([-u[1], u[0]])
    for B in (A + along * u + h * n, A + along * u - h * n):
        v3, v4 = B - A, B - O4  # coupler A->B, rocker O4->B
        det = v3[1] * v4[0] - v3[0] * v4[1]  # r3 r4 sin(θ3 − θ4)
        if np.sign(det) == sign:
            e3 = v3 / r3
            return A + p["rcx"] * e3 + p["rcy"] * np.array([-e3[1], e3[0]])
    return None


PLANTED = {"r1": 4.0, "r2": 1.5, "r3": 3.5, "r4": 3.2, "rcx": 1.2, "rcy": 0.8}


PLANT_INPUTS = [20, 45, 70, 95, 120, 145]


VARY6 = {"r1": (2, 6), "r2": (0.5, 3), "r3": (2, 6), "r4": (2, 6), "rcx": (-3, 3), "rcy": (-3, 3)}


def fourbar_angles(p, theta2_deg, sign):
    """(θ3, θ4) in degrees of the synthesis four-bar (θ0 = φ = 0) by circle intersection."""
    t = math.radians(theta2_deg)
    A = np.array([p["r2"] * math.cos(t), p["r2"] * math.sin(t)])
    O4 = np.array([p["r1"], 0.0])
    d = np.linalg.norm(O4 - A)
    u = (O4 - A) / d
    along = (d * d + p["r3"] ** 2 - p["r4"] ** 2) / (2 * d)
    h = math.sqrt(p["r3"] ** 2 - along ** 2)
    n = np.array([-u[1], u[0]])
    for B in (A + along * u + h * n, A + along * u - h * n):
        v3, v4 = B - A, B - O4
        if np.sign(v3[1] * v4[0] - v3[0] * v4[1]) == sign:
            return math.degrees(math.atan2(v3[1], v3[0])), math.degrees(math.atan2(v4[1], v4[0]))



def fourbar_open_angles(t2, r1=60.0, r2=25.0, r3=70.0, r4=45.0):
    """Open-mode (sin(θ4 − θ3) > 0) θ3, θ4 in radians of a four-bar grounded along x at crank angle ``t2``
    (radians), by circle intersection; the defaults are the thesis crank-rocker's lengths."""
    bx, by = r2 * math.cos(t2), r2 * math.sin(t2)
    dx, dy = r1 - bx, -by
    d = math.hypot(dx, dy)
    a = (r3**2 - r4**2 + d**2) / (2 * d)
    h = math.sqrt(r3**2 - a**2)
    for sgn in (1, -1):
        cx, cy = bx + a * dx / d - sgn * h * dy / d, by + a * dy / d + sgn * h * dx / d
        t3, t4 = math.atan2(cy - by, cx - bx), math.atan2(cy, cx - r1)
        if math.sin(t4 - t3) > 0:
            return t3, t4
    raise AssertionError("the loop does not close")

# -- a second planted crank-rocker (ground pivots G2, G4) for five-pose Burmester synthesis
G2 = np.array([-3.0, 5.0])


GT = math.radians(-15.0)


L1, L2, L3, L4, LP, GAMMA = 80.0, 30.0, 75.0, 60.0, 40.0, math.radians(30.0)


G4 = G2 + L1 * np.array([math.cos(GT), math.sin(GT)])


def intersect(a, ra, b, rb, side=1):
    d = b - a
    L = float(np.hypot(*d))
    x = (ra * ra - rb * rb + L * L) / (2 * L)
    h = math.sqrt(ra * ra - x * x)
    return a + x * d / L + side * h * np.array([-d[1], d[0]]) / L


def pose(t2_deg):
    t = math.radians(t2_deg)
    A = G2 + L2 * np.array([math.cos(t), math.sin(t)])
    B = intersect(A, L3, G4, L4)
    phi = math.atan2(B[1] - A[1], B[0] - A[0])
    P = A + LP * np.array([math.cos(phi + GAMMA), math.sin(phi + GAMMA)])
    return float(P[0]), float(P[1]), math.degrees(phi)


# -- a crank and slotted lever; a disk rolling on a line (each test replaces SIDE: nothing, or a side key)
SLOTTED = """
name = "crank and slotted lever"
units = { length = "mm", angle = "deg" }
[parameters]
d = 100
r2 = 40
L4 = 200
[variables]
theta2 = { input = true, guess = 0 }
theta4 = { guess = 68 }
[vectors]
r1 = { length = "d", angle = 90 }
r2 = { length = "r2", angle = "theta2" }
r4 = { length = "L4", angle = "theta4" }
[points]
O4 = "0"
O2 = "r1"
A = "r1 + r2"
D = "r4"
[slots]
s1 = { point = "A", link = "lever", line = "r4" }
"""


DISK = """
name = "rolling disk"
units = { length = "mm", angle = "deg" }
[parameters]
r = 50
[variables]
theta = { input = true, guess = 0 }
x = { guess = 0 }
[vectors]
rx = { length = "x", angle = 0 }
ry = { length = "r", angle = 90 }
rim = { length = "r", angle = "theta" }
[points]
C = "rx + ry"
Q = "rx + ry + rim"
[rolling]
wheel = { angle = "theta", radius = "r", on = "x"SIDE }
"""


# -- a cam and translating roller follower with mass properties and a load
CAM_FOLLOWER = """
name = "cam and follower"
units = { length = "mm", angle = "deg" }
[variables]
theta2 = { input = true, guess = 0 }
s = { guess = 0 }
[vectors]
re = { length = "e", angle = 0 }
rf = { length = "sqrt(48**2 - e**2) + s", angle = 90 }
[parameters]
e = 5
[points]
O = "0"
C = "re + rf"
[cams.c1]
cam = "theta2"
follower = "s"
kind = "translating"
contact = "roller"
roller = "8mm"
base = "40mm"
offset = "e"
law = [ { to = 90, rise = "25mm", curve = "cycloidal" }, { to = 150, dwell = true },
        { to = 270, rise = "-25mm", curve = "3-4-5" }, { to = 360, dwell = true } ]
[bodies]
cam = { mass = "1kg", inertia = "1e-3kg*m^2", com = "O", angle = "theta2", joints = ["O"] }
follower = { mass = "0.5kg", com = "C", guide = "rf", joints = [] }
[[loads]]
at = "C"
body = "follower"
force = [0, "-100N"]
"""


#: the same cam and follower declared by its pitch curve (``profile``) instead of a base circle and a law
#: (a profile cam's offset is a number: its displacement is computed from the curve when the model is read)
CAM_FOLLOWER_BY_POINTS = CAM_FOLLOWER.replace('base = "40mm"\n', "").replace('offset = "e"', 'offset = "5mm"').replace(
    CAM_FOLLOWER[CAM_FOLLOWER.index("law = ["):CAM_FOLLOWER.index("[bodies]")], 'profile = "pitch.csv"\n')


def write_pitch_cam(directory, angles_deg):
    """``directory/cam.toml`` (:data:`CAM_FOLLOWER_BY_POINTS`) and its ``pitch.csv``: the roller centre's pitch
    curve at the cam angles ``angles_deg`` for the harmonic lift s = 10(1 − cos θ) mm (offset ε = 5 mm, pitch
    radius 48 mm), in the cam's frame. Returns the model file's path."""
    th = np.radians(np.asarray(angles_deg, dtype=float))
    s = 10 * (1 - np.cos(th))
    cx, cy = np.full(th.shape, 5.0), math.sqrt(48**2 - 25) + s  # the roller centre in the ground frame
    x, y = np.cos(-th) * cx - np.sin(-th) * cy, np.sin(-th) * cx + np.cos(-th) * cy  # turned with the cam
    (directory / "pitch.csv").write_text("x,y\n" + "".join(f"{a!r},{b!r}\n" for a, b in zip(x.tolist(), y.tolist())))
    (directory / "cam.toml").write_text(CAM_FOLLOWER_BY_POINTS)
    return directory / "cam.toml"


# -- a gear pair with bodies and a load torque (a format template: d, rg, rm, extra, load)
GEAR_TRAIN = """
name = "gear train"
units = {{ length = "mm", angle = "deg" }}
[parameters]
d = {d}
[variables]
theta2 = {{ input = true, guess = 0 }}
theta5 = {{ guess = 0 }}
[vectors]
r0 = {{ x = "d", y = 0 }}
r2 = {{ length = 10, angle = "theta2" }}
r5 = {{ length = 10, angle = "theta5" }}
[points]
O2 = "0"
O5 = "r0"
A2 = "r2"
A5 = "r0 + r5"
[gears]
g = {{ gear = "theta2", mate = "theta5", radii = [{rg}, {rm}], {extra} }}
[bodies]
gear2 = {{ mass = "0.2kg", inertia = "2e-4kg*m^2", com = "O2", angle = "theta2", joints = ["O2"] }}
gear5 = {{ mass = "0.4kg", inertia = "6e-4kg*m^2", com = "O5", angle = "theta5", joints = ["O5"] }}
[[loads]]
body = "gear5"
torque = "{load}N*m"
"""


# -- a planetary stage with one member held (a format template: s, c, r, held, value)
PLANETARY = """
name = "planetary stage"
units = {{ length = "mm", angle = "deg" }}
[parameters]
Ns = 24
Np = 36
Nr = 96
[variables]
theta_s = {{ {s}guess = 10 }}
theta_c = {{ {c}guess = 20 }}
theta_p = {{ guess = -5 }}
theta_r = {{ {r}guess = 30 }}
[gears]
sun_planet = {{ gear = "theta_s", mate = "theta_p", teeth = ["Ns", "Np"], carrier = "theta_c" }}
ring_planet = {{ gear = "theta_r", mate = "theta_p", teeth = ["Nr", "Np"], internal = true, carrier = "theta_c" }}
[constraints]
held = "{held} = {value}"
"""


# -- loads added to any model with bodies
def with_extra_loads(mech: ls.Mechanism) -> ls.Mechanism:
    """The model plus a spring, a damper, a torsional spring and damper, and a rate-dependent torque."""
    spec = ls.model.mechanism.deep_copy(mech.spec)
    bodies = spec["bodies"]
    names = list(bodies)
    joints = [j for b in bodies.values() for j in b.get("joints", [])]
    last = names[-1]
    rot = [n for n, b in bodies.items() if "angle" in b]
    inp = mech.inputs[0]
    spec.setdefault("loads", [])
    spec["loads"] += [
        {"spring": [joints[1], joints[-1]], "stiffness": "300N/m", "free_length": 10,
         "bodies": [next(n for n, b in bodies.items() if joints[1] in b.get("joints", [])), last]},
        {"damper": [joints[1], joints[-1]], "damping": "2N*s/m",
         "bodies": [next(n for n, b in bodies.items() if joints[1] in b.get("joints", [])), last]},
        {"body": rot[-1], "stiffness": "0.4N*m/rad", "free_angle": 10, "damping": "0.01N*m*s/rad"},
        {"body": rot[0], "torque": f"-0.002*{inp}_vel + 0.01*sin({inp})"},
    ]
    spec["gravity"] = ["0.7m/s^2", "-9.81m/s^2"]  # a plain number is ambiguous in a mm model
    return ls.build_mechanism(spec)


# -- a fan of N four-bar loops driven by one crank (the scaling tests)
#
# Loop k: ``rA + c_k = g_k + o_k`` with the shared crank ``rA`` (length 1, angle θ2, the input),
# ground ``g_k`` (angle 0), coupler ``c_k`` (θ3_k) and rocker ``o_k`` (θ4_k); each loop is its own
# 2×2 block. Every fifth loop is short enough that it limits the crank (a rocker-input range);
# the others let the crank turn fully.


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


# -- a five-bar of two cranks, for constraints and gear pairs that couple them
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
