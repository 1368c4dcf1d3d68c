"""Cam motion laws and cam geometry against the textbook closed forms written here."""

import math

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.model.camlaws import CURVES, curve

PI = math.pi


def textbook(name, u):
    """(S, S', S'', S''') of a normalized rise (h = 1, β = 1), as the handbooks print them.

    The modified trapezoid and modified sine in the constants of Norton, *Design of Machinery*, eqs. 8.13
    and 8.15 (eight digits), differentiated by hand."""
    u = np.asarray(u, dtype=float)
    if name == "cycloidal":
        return (u - np.sin(2 * PI * u) / (2 * PI), 1 - np.cos(2 * PI * u), 2 * PI * np.sin(2 * PI * u),
                4 * PI**2 * np.cos(2 * PI * u))
    if name == "harmonic":
        return ((1 - np.cos(PI * u)) / 2, PI / 2 * np.sin(PI * u), PI**2 / 2 * np.cos(PI * u),
                -PI**3 / 2 * np.sin(PI * u))
    if name == "3-4-5":
        return (10 * u**3 - 15 * u**4 + 6 * u**5, 30 * u**2 - 60 * u**3 + 30 * u**4, 60 * u - 180 * u**2 + 120 * u**3,
                60 - 360 * u + 360 * u**2)
    if name == "4-5-6-7":
        return (35 * u**4 - 84 * u**5 + 70 * u**6 - 20 * u**7, 140 * u**3 - 420 * u**4 + 420 * u**5 - 140 * u**6,
                420 * u**2 - 1680 * u**3 + 2100 * u**4 - 840 * u**5, 840 * u - 5040 * u**2 + 8400 * u**3 - 4200 * u**4)
    w = 4 * PI * u
    if name == "modified-trapezoid":
        a, b, c = 0.38898448, 0.0309544, 2.44406184
        pieces = [
            (u < 1 / 8, a * u - b * np.sin(w), a - b * 4 * PI * np.cos(w), b * 16 * PI**2 * np.sin(w),
             b * 64 * PI**3 * np.cos(w)),
            (u < 3 / 8, c * u**2 - 0.22203097 * u + 0.00723407, 2 * c * u - 0.22203097, 2 * c + 0 * u, 0 * u),
            (u < 5 / 8, 1.6110154 * u - b * np.sin(w - PI) - 0.3055077, 1.6110154 - b * 4 * PI * np.cos(w - PI),
             b * 16 * PI**2 * np.sin(w - PI), b * 64 * PI**3 * np.cos(w - PI)),
            (u < 7 / 8, -c * u**2 + 4.6660917 * u - 1.2292648, -2 * c * u + 4.6660917, -2 * c + 0 * u, 0 * u),
            (u <= 1, 0.6110154 + a * u + b * np.sin(w - 3 * PI), a + b * 4 * PI * np.cos(w - 3 * PI),
             -b * 16 * PI**2 * np.sin(w - 3 * PI), -b * 64 * PI**3 * np.cos(w - 3 * PI)),
        ]
    else:  # modified sine
        a, b, c = 0.43990085, 0.0350062, 0.31505577
        x = 4 * PI / 3 * u - PI / 6
        pieces = [
            (u < 1 / 8, a * u - b * np.sin(w), a - b * 4 * PI * np.cos(w), b * 16 * PI**2 * np.sin(w),
             b * 64 * PI**3 * np.cos(w)),
            (u < 7 / 8, 0.28004957 + a * u - c * np.cos(x), a + c * 4 * PI / 3 * np.sin(x),
             c * (4 * PI / 3) ** 2 * np.cos(x), -c * (4 * PI / 3) ** 3 * np.sin(x)),
            (u <= 1, 0.56009915 + a * u - b * np.sin(w), a - b * 4 * PI * np.cos(w), b * 16 * PI**2 * np.sin(w),
             b * 64 * PI**3 * np.cos(w)),
        ]
    out = []
    for k in range(4):
        val = np.full(u.shape, np.nan)
        done = np.zeros(u.shape, dtype=bool)
        for piece in pieces:
            m = piece[0] & ~done
            val[m] = np.broadcast_to(piece[k + 1], u.shape)[m]
            done |= piece[0]
        out.append(val)
    return tuple(out)


@pytest.mark.parametrize("name", CURVES)
def test_each_curve_against_its_closed_form(name):
    u = np.linspace(0, 1, 1001)
    ours = curve(name, u)
    ref = textbook(name, u)
    tol = 1e-6 if name.startswith("modified") else 1e-12  # the handbook's constants have eight digits
    for k in range(4):
        scale = max(1.0, float(np.max(np.abs(ref[k]))))
        assert np.max(np.abs(ours[k] - ref[k])) <= tol * scale, (name, k)
    assert ours[0][0] == pytest.approx(0, abs=1e-15) and ours[0][-1] == pytest.approx(1, abs=1e-15)


CAM = """
name = "cam"
units = {{ length = "mm", angle = "deg" }}
[variables]
theta2 = {{ input = true, guess = 0{speed} }}
f = {{ guess = 0 }}
[cams.c1]
cam = "theta2"
follower = "f"
{body}
law = [ {{ to = 100, rise = "{h}", curve = "{curve}" }}, {{ to = 160, dwell = true }},
        {{ to = 280, return = "{h}", curve = "{back}" }}, {{ to = 360, dwell = true }} ]
"""


def cam_model(body, h="20mm", curve="cycloidal", back="cycloidal", speed=""):
    return ls.loads(CAM.format(body=body, h=h, curve=curve, back=back, speed=speed))


def _report(mech, name="c1"):
    from loopsolve.output.camprofile import cam_report

    return cam_report(mech, name)


def _rows(rep, *keys):
    return [np.array([r[k] if r[k] is not None else np.nan for r in rep["rows"]]) for k in keys]


def law_closed_form(theta_deg, h, curve_up, curve_down):
    """s, s', s'', s''' (per radian) of the test's law: rise 0-100, dwell, return 160-280, dwell."""
    th = np.radians(theta_deg)
    out = [np.zeros_like(th) for _ in range(4)]
    for lo, hi, sign, base, name in ((0, 100, 1, 0.0, curve_up), (160, 280, -1, h, curve_down)):
        lo_r, beta = math.radians(lo), math.radians(hi - lo)
        m = (theta_deg >= lo) & (theta_deg < hi)
        S = textbook(name, (th[m] - lo_r) / beta)
        out[0][m] = base + sign * h * S[0]
        for k in (1, 2, 3):
            out[k][m] = sign * h * S[k] / beta**k
    out[0][(theta_deg >= 100) & (theta_deg < 160)] = h
    return out


@pytest.mark.parametrize("up, down", [("cycloidal", "3-4-5"), ("4-5-6-7", "modified-sine"),
                                      ("modified-trapezoid", "harmonic")])
def test_svaj_of_a_law_over_segments(up, down):
    mech = cam_model('kind = "translating"\ncontact = "knife"\nbase = "40mm"', curve=up, back=down)
    rep = _report(mech)
    ang, s, v, a, j = _rows(rep, "angle", "s", "v", "a", "j")
    ref = law_closed_form(ang, 20.0, up, down)
    tol = 5e-6 if "modified" in up + down else 1e-9
    for k, ours in enumerate((s, v, a, j)):
        assert np.allclose(ours, ref[k], atol=tol * max(1.0, np.max(np.abs(ref[k])))), k
    assert rep["units"]["v"] == "mm/rad" and rep["units"]["j"] == "mm/rad^3"
    # the harmonic return starts and ends with an acceleration jump: reported, not an error
    jumps = rep["discontinuities"]
    assert bool(jumps) == (down == "harmonic")


def test_svaj_per_second_when_the_cam_speed_is_declared():
    """ω = 10 rad/s, α = 3 rad/s²: v = s′ω, a = s″ω² + s′α."""
    mech = cam_model('kind = "translating"\ncontact = "knife"\nbase = "40mm"',
                     speed=', speed = 10, accel = 3')
    rep = _report(mech)
    ang, v, a = _rows(rep, "angle", "v", "a")
    ref = law_closed_form(ang, 20.0, "cycloidal", "cycloidal")
    assert np.allclose(v, ref[1] * 10) and np.allclose(a, ref[2] * 100 + ref[1] * 3)
    assert rep["units"]["a"] == "mm/s^2"


def test_pressure_angle_of_an_offset_translating_roller_follower():
    """tan φ = (s′ − ε)/(s + √(R_p² − ε²)) (Shigley/Uicker), R_p = base + roller."""
    mech = cam_model('kind = "translating"\ncontact = "roller"\nroller = "8mm"\nbase = "40mm"\noffset = "6mm"')
    rep = _report(mech)
    ang, phi = _rows(rep, "angle", "pressure_angle")
    s, s1, _, _ = law_closed_form(ang, 20.0, "cycloidal", "cycloidal")
    ref = np.degrees(np.arctan((s1 - 6) / (s + math.sqrt(48**2 - 6**2))))
    assert np.allclose(phi, ref, atol=1e-9)
    assert rep["extremes"]["pressure_angle"] == pytest.approx([ref.min(), ref.max()])


def test_radius_of_curvature_of_the_pitch_curve():
    """A radial follower: the pitch curve r = R_p + s in polar form, ρ = (r² + r′²)^{3/2} / (r² + 2r′² − r r″)."""
    mech = cam_model('kind = "translating"\ncontact = "roller"\nroller = "8mm"\nbase = "40mm"')
    rep = _report(mech)
    ang, rho = _rows(rep, "angle", "curvature_radius")
    s, s1, s2, _ = law_closed_form(ang, 20.0, "cycloidal", "cycloidal")
    r = 48 + s
    ref = (r**2 + s1**2) ** 1.5 / (r**2 + 2 * s1**2 - r * s2)
    assert np.allclose(rho, ref, rtol=1e-9)
    assert rho[np.isclose(ang, 120)][0] == pytest.approx(68.0)  # the dwell at the top: a circle of radius 48 + 20
    assert rep["undercut"] is False


def test_flat_face_width_and_smallest_base_circle():
    """A translating flat face: the contact sits s′ from the follower's axis (width max s′ − min s′); the
    profile's radius of curvature R_b + s + s″ stays positive when R_b > max(−(s + s″))."""
    mech = cam_model('kind = "translating"\ncontact = "flat"\nbase = "50mm"')
    rep = _report(mech)
    ff = rep["flat_face"]
    h, beta_up, beta_down = 20.0, math.radians(100), math.radians(120)
    assert ff["contact_offset"] == pytest.approx([-2 * h / beta_down, 2 * h / beta_up], rel=1e-6)
    assert ff["face_width"] == pytest.approx(2 * h / beta_up + 2 * h / beta_down, rel=1e-6)
    fine = np.linspace(0, 360, 360 * 200, endpoint=False)
    s, _, s2, _ = law_closed_form(fine, h, "cycloidal", "cycloidal")
    need = float(np.max(-(s + s2)))
    # the largest deceleration of the rise, −2πh/β², at u = 3/4, sets it (s there is h(3/4 + 1/2π))
    assert need == pytest.approx(2 * PI * h / beta_up**2 - h * (0.75 + 1 / (2 * PI)), rel=1e-2)
    assert ff["min_base_radius"] == pytest.approx(need, rel=1e-3)
    ang, rho = _rows(rep, "angle", "curvature_radius")
    s, _, s2, _ = law_closed_form(ang, h, "cycloidal", "cycloidal")
    assert np.allclose(rho, 50 + s + s2)
    # a base circle below it undercuts the flat face's profile: a model error naming the key
    small = cam_model(f'kind = "translating"\ncontact = "flat"\nbase = "{need * 0.9:.4f}mm"')
    with pytest.raises(ls.ModelError, match=r"cams\.c1\.base"):
        small.solve(10)


STEEP = """
name = "steep cam"
units = {{ length = "mm", angle = "deg" }}
[variables]
theta2 = {{ input = true, guess = 0 }}
f = {{ guess = 0 }}
[cams.c1]
cam = "theta2"
follower = "f"
contact = "roller"
roller = "{r}mm"
base = "{b}mm"
law = [ {{ to = 45, rise = "20mm", curve = "cycloidal" }}, {{ to = 180, dwell = true }},
        {{ to = 225, return = "20mm", curve = "cycloidal" }}, {{ to = 360, dwell = true }} ]
"""


def test_roller_larger_than_the_curvature_allows():
    """The same pitch curve (R_p = 25 mm, a steep rise) with a roller below and above its smallest convex
    radius of curvature: the second profile is undercut, a model error naming the roller."""
    ok = ls.loads(STEEP.format(r=2, b=23))
    rho_min = _report(ok)["min_convex_curvature_radius"]
    assert rho_min < 12 and _report(ok)["undercut"] is False
    r = rho_min + 1
    big = ls.loads(STEEP.format(r=r, b=25 - r))
    rep = _report(big)
    assert rep["undercut"] is True and rep["min_convex_curvature_radius"] == pytest.approx(rho_min, rel=1e-9)
    assert "cams.c1.roller" in rep["defects"][0]
    with pytest.raises(ls.ModelError, match=r"cams\.c1\.roller"):
        big.sweep(0, 360, 10)


def test_follower_in_the_loops_follows_the_law():
    """The follower's displacement is the law at the cam angle: position and rates along a sweep."""
    mech = cam_model('kind = "translating"\ncontact = "roller"\nroller = "8mm"\nbase = "40mm"', speed=", speed = 5")
    sw = mech.sweep(0, 360, 5)
    ang = np.asarray(sw["theta2"])
    s, s1, s2, s3 = law_closed_form(ang % 360, 20.0, "cycloidal", "cycloidal")
    assert np.allclose(sw["f"], s, atol=1e-10)
    assert np.allclose(sw["f_vel"], 5 * s1, atol=1e-9)
    assert np.allclose(sw["f_acc"], 25 * s2, atol=1e-7)
    assert np.allclose(sw["f_jerk"], 125 * s3, atol=1e-5)
    # a second turn repeats the first (the law is periodic in the cam angle)
    again = mech.sweep(360, 720, 5)
    assert np.allclose(again["f"], sw["f"], atol=1e-10)


def test_oscillating_roller_follower_geometry():
    """The pitch point of an oscillating follower C = A + L(cos γ, sin γ), γ = γ₀ + ψ, on the cam R(−θ) C; its
    pressure angle between the normal of the pitch curve and the arm's perpendicular, by differences here."""
    body = ('kind = "oscillating"\ncontact = "roller"\nroller = "6mm"\nbase = "30mm"\npivot = "80mm"\narm = "60mm"')
    mech = cam_model(body, h="15deg")
    rep = _report(mech)
    ang, psi, phi, rho = _rows(rep, "angle", "s", "pressure_angle", "curvature_radius")
    d, L, Rp = 80.0, 60.0, 36.0
    g0 = PI - math.acos((d * d + L * L - Rp * Rp) / (2 * d * L))  # left of the line from the cam to the pivot
    th = np.radians(ang)

    def pitch(t):
        s = law_closed_form(np.degrees(t) % 360, math.radians(15), "cycloidal", "cycloidal")[0]
        g = g0 + s * _sense(g0, d, L)
        C = np.stack([d + L * np.cos(g), L * np.sin(g)], axis=-1)
        c, sn = np.cos(-t), np.sin(-t)
        return np.stack([c * C[:, 0] - sn * C[:, 1], sn * C[:, 0] + c * C[:, 1]], axis=-1), C, g

    assert np.allclose(psi, np.degrees(law_closed_form(ang, math.radians(15), "cycloidal", "cycloidal")[0]))
    P, C, g = pitch(th)
    e = 1e-5
    Pp, Pm = pitch(th + e)[0], pitch(th - e)[0]
    T = (Pp - Pm) / (2 * e)
    T2 = (Pp - 2 * P + Pm) / e**2
    rho_fd = -np.linalg.norm(T, axis=1) ** 3 / (T[:, 0] * T2[:, 1] - T[:, 1] * T2[:, 0])
    ok = np.abs(rho_fd) < 1e4
    assert np.allclose(rho[ok], rho_fd[ok], rtol=1e-4)
    # the normal (fixed frame) against the arm's perpendicular, in the sense the lift turns it
    c, sn = np.cos(th), np.sin(th)
    Tf = np.stack([c * T[:, 0] - sn * T[:, 1], sn * T[:, 0] + c * T[:, 1]], axis=-1)
    N = np.stack([-Tf[:, 1], Tf[:, 0]], axis=-1)
    sense = _sense(g0, d, L)
    m = sense * np.stack([-np.sin(g), np.cos(g)], axis=-1)
    ref = np.degrees(np.arctan2(m[:, 0] * N[:, 1] - m[:, 1] * N[:, 0], np.sum(m * N, axis=1)))
    assert np.allclose(phi, ref, atol=1e-5)


def _sense(g0, d, L):
    """+1 when turning the arm counter-clockwise moves the roller away from the cam centre at γ₀."""
    C = np.array([d + L * math.cos(g0), L * math.sin(g0)])
    return 1.0 if C @ (L * np.array([-math.sin(g0), math.cos(g0)])) > 0 else -1.0


@pytest.mark.parametrize("law, key, words", [
    ('[ { to = 90, rise = "20mm", curve = "cycloidal" }, { to = 350, return = "20mm", curve = "cycloidal" } ]',
     "cams.c1.law", "covers 360"),
    ('[ { to = 90, rise = "20mm", curve = "cycloidal" }, { to = 360, return = "15mm", curve = "cycloidal" } ]',
     "cams.c1.law", "discontinuous in position"),
    ('[ { to = 90, rise = "20mm", curve = "parabolic" }, { to = 360, return = "20mm", curve = "cycloidal" } ]',
     "cams.c1.law[0].curve", "expected one of"),
    ('[ { to = 90, rise = "20mm", curve = "cycloidal" }, { to = 80, dwell = true }, '
     '{ to = 360, return = "20mm", curve = "cycloidal" } ]', "cams.c1.law[1].to", "does not come after"),
    ('[ { to = 90, rise = "20mm" }, { to = 360, return = "20mm", curve = "cycloidal" } ]',
     "cams.c1.law[0].curve", "needs its `curve`"),
])
def test_bad_laws_name_the_key(law, key, words):
    text = f"""
name = "bad cam"
units = {{ length = "mm", angle = "deg" }}
[variables]
theta2 = {{ input = true, guess = 0 }}
f = {{ guess = 0 }}
[cams.c1]
cam = "theta2"
follower = "f"
contact = "knife"
base = "40mm"
law = {law}
"""
    with pytest.raises(ls.ModelError) as err:
        ls.loads(text)
    assert key in str(err.value) and words in str(err.value)
