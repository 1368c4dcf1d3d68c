"""A cam declared by the points of its pitch curve (``profile = "pitch.csv"``) against closed forms written here.

The pitch curves are computed here from closed forms (a law over segments; an eccentric circle) and
written as points; the cam declared by those points must move its follower as the closed form says.

Tolerances. The displacement is interpolated through the points (spacing δθ = 1° of cam angle) by a
smooth (quintic) spline, so where the law itself is smooth the error is far below any drawing
tolerance; but the jerk of the law below jumps at every join (by 4π²h/β³ at the cycloidal rise's ends,
60h/β³ at the 3-4-5 return's; ΔJ below is the larger), and no smooth interpolant follows a jump: near
a join the acceleration may be off by a fraction of ΔJ·δθ (the jump spread over one spacing), the
velocity by ΔJ·δθ² and the displacement by ΔJ·δθ³. The checks allow a quarter of those near the joins
(within six spacings: an interpolating spline's response to a jump decays by about a factor three per
spacing) and 1e-4 of the peak value elsewhere.
"""

import math

import numpy as np
import pytest

import loopsolve as ls

PI = math.pi
H = 25.0  # the rise (mm)
RISE, DWELL, RETURN = (0.0, 90.0), (90.0, 150.0), (150.0, 270.0)
DT = math.radians(1.0)


def law(theta_deg):
    """s, s′, s″ (per radian) of cycloidal rise 0–90°, dwell, 3-4-5 return 150–270°, dwell; closed forms."""
    th = np.radians(np.mod(theta_deg, 360.0))
    s, v, a = (np.zeros_like(th) for _ in range(3))
    b = math.radians(90)
    m = th < b
    u = th[m] / b
    s[m] = H * (u - np.sin(2 * PI * u) / (2 * PI))
    v[m] = H / b * (1 - np.cos(2 * PI * u))
    a[m] = H / b**2 * 2 * PI * np.sin(2 * PI * u)
    m = (th >= b) & (th < math.radians(150))
    s[m] = H
    lo, b = math.radians(150), math.radians(120)
    m = (th >= lo) & (th < lo + b)
    u = (th[m] - lo) / b
    s[m] = H * (1 - (10 * u**3 - 15 * u**4 + 6 * u**5))
    v[m] = -H / b * (30 * u**2 - 60 * u**3 + 30 * u**4)
    a[m] = -H / b**2 * (60 * u - 180 * u**2 + 120 * u**3)
    return s, v, a


JERK_JUMP = max(4 * PI**2 * H / math.radians(90) ** 3, 60 * H / math.radians(120) ** 3)


def near_joins(theta_deg):
    """Within 6° of a join of the law (where its jerk jumps)."""
    t = np.mod(theta_deg, 360.0)
    return np.min([np.abs(t - j) for j in (0, 90, 150, 270, 360)], axis=0) < 6


def rot(P, a):
    c, s = np.cos(a), np.sin(a)
    return np.stack([c * P[..., 0] - s * P[..., 1], s * P[..., 0] + c * P[..., 1]], axis=-1)


def write_points(path, P):
    with open(path, "w") as fh:
        fh.write("x,y\n")
        for x, y in P:
            fh.write(f"{float(x)!r},{float(y)!r}\n")


LAW = ('law = [ { to = 90, rise = "25mm", curve = "cycloidal" }, { to = 150, dwell = true },\n'
       '        { to = 270, return = "25mm", curve = "3-4-5" }, { to = 360, dwell = true } ]\n')


def model(tmp_path, body, how, name="cam.toml", speed=""):
    path = tmp_path / name
    path.write_text(f"""
name = "cam"
units = {{ length = "mm", angle = "deg" }}
[variables]
theta2 = {{ input = true, guess = 0{speed} }}
f = {{ guess = 0 }}
[cams.c1]
cam = "theta2"
follower = "f"
{body}
{how}
""")
    return ls.load(path)


def report(mech, step=None):
    from loopsolve.output.camprofile import cam_report

    rep = cam_report(mech, "c1", step=step)
    return {k: np.array([r[k] if r[k] is not None else np.nan for r in rep["rows"]]) for k in rep["rows"][0]}, rep


def check_svaj(ang, s, v, a, ref, scale=1.0):
    """``s, v, a`` against ``ref`` (s, s′, s″) within the tolerances of the module notes (``scale``: the
    law's height in the follower's unit over H)."""
    rs, rv, ra = ref
    near = near_joins(ang)
    dj = JERK_JUMP * scale
    for got, want, tol_near, peak in ((s, rs, dj * DT**3 / 4, H * scale), (v, rv, dj * DT**2 / 4, np.abs(rv).max()),
                                      (a, ra, dj * DT / 4, np.abs(ra).max())):
        assert np.abs(got - want)[near].max() <= tol_near
        assert np.abs(got - want)[~near].max() <= 1e-4 * peak


def test_offset_translating_roller_profile_moves_as_its_law(tmp_path):
    """The roller centre of an offset (ε = 5) translating follower is C = (ε, √(R_p² − ε²) + s(θ)) in the
    fixed frame, on the cam R(−θ)C; 360 points of it give back s, v, a, the pressure angle
    tan φ = (s′ − ε)/(s + √(R_p² − ε²)) and the radius of curvature of the law-declared cam."""
    eps, Rp = 5.0, 48.0
    th = np.radians(np.arange(360.0))
    C = np.stack([np.full(360, eps), math.sqrt(Rp**2 - eps**2) + law(np.arange(360.0))[0]], axis=-1)
    write_points(tmp_path / "pitch.csv", rot(C, -th))
    body = 'kind = "translating"\ncontact = "roller"\nroller = "8mm"\noffset = "5mm"'
    mech = model(tmp_path, body, 'profile = "pitch.csv"')
    rows, rep = report(mech, step=0.25)  # four rows between points
    ang = rows["angle"]
    s, v, a = law(ang)
    check_svaj(ang, rows["s"], rows["v"], rows["a"], (s, v, a))
    phi = np.degrees(np.arctan((v - eps) / (s + math.sqrt(Rp**2 - eps**2))))
    assert np.abs(rows["pressure_angle"] - phi).max() < 1e-3  # degrees
    assert rep["undercut"] is False and rep["discontinuities"] == []
    # the curvature of the same cam declared by its law (itself checked against the textbook's formula)
    ref, _ = report(model(tmp_path, body + '\nbase = "40mm"', LAW, "law.toml"), step=0.25)
    rho, rho_ref = rows["curvature_radius"], ref["curvature_radius"]
    # ρ = (r² + r′²)^{3/2}/(r² + 2r′² − r r″) moves by at most about (ρ/r)² δr″ for an error δr″ of the
    # acceleration, r ≥ R_p; elsewhere 1e-3 relative where the curve is not nearly straight
    near, small = near_joins(ang), np.abs(rho_ref) < 500
    assert (np.abs(rho - rho_ref) <= (rho_ref / Rp) ** 2 * JERK_JUMP * DT / 4)[near].all()
    assert (np.abs(rho - rho_ref) <= 1e-3 * np.abs(rho_ref))[small & ~near].all()
    # the loops: a sweep moves the follower variable by the same law, with its rates
    sw = mech.sweep(0, 720, 7.5)
    s, v, a = law(np.asarray(sw["theta2"]))
    assert np.abs(np.asarray(sw["f"]) - s).max() < JERK_JUMP * DT**3 / 4
    assert np.abs(np.asarray(sw["f_vel"]) - v).max() < JERK_JUMP * DT**2 / 4


def test_eccentric_circle_radial_follower(tmp_path):
    """A circle of radius R whose centre is e from the cam centre (on +y at θ = 0): its centre turns to
    (−e sin θ, e cos θ), so a radial follower's pitch point is at y = e cos θ + √(R² − e² sin² θ); lowest
    (R − e) at θ = 180°: s = e cos θ + √(R² − e² sin² θ) − (R − e), v = −e sin θ − e² sin θ cos θ / √(…)."""
    R, e = 50.0, 12.0
    t = np.linspace(0, 2 * PI, 97, endpoint=False)  # points not at whole degrees
    write_points(tmp_path / "circle.csv", np.stack([R * np.cos(t), e + R * np.sin(t)], axis=-1))
    mech = model(tmp_path, 'kind = "translating"\ncontact = "knife"', 'profile = "circle.csv"')
    rows, rep = report(mech, step=0.5)
    th = np.radians(rows["angle"])
    root = np.sqrt(R**2 - e**2 * np.sin(th) ** 2)
    assert np.allclose(rows["s"], e * np.cos(th) + root - (R - e), atol=1e-6 * R)
    assert np.allclose(rows["v"], -e * np.sin(th) - e**2 * np.sin(th) * np.cos(th) / root, atol=1e-5 * R)
    # a circle's pitch curve has radius of curvature R everywhere
    assert np.allclose(rows["curvature_radius"], R, rtol=1e-4)
    sol = mech.solve(at=90)
    assert sol["f"] == pytest.approx(math.sqrt(R**2 - e**2) - (R - e), abs=1e-6 * R)


def test_oscillating_roller_profile_moves_as_its_law(tmp_path):
    """An oscillating roller follower (pivot 80 from the cam centre, arm 60, pitch base circle 36): the
    roller centre C = A + L(cos γ, sin γ), γ = γ₀ + σψ(θ), ψ = the law with a 15° lift, on the cam R(−θ)C."""
    d, L, Rp = 80.0, 60.0, 36.0
    lift = math.radians(15) / H  # the law's height 15° in radians, in units of H
    g0 = PI - math.acos((d * d + L * L - Rp * Rp) / (2 * d * L))
    C0 = np.array([d + L * math.cos(g0), L * math.sin(g0)])
    sigma = 1.0 if C0 @ np.array([-math.sin(g0), math.cos(g0)]) > 0 else -1.0
    deg = np.arange(360.0)
    g = g0 + sigma * lift * law(deg)[0]
    C = np.stack([d + L * np.cos(g), L * np.sin(g)], axis=-1)
    write_points(tmp_path / "pitch.csv", rot(C, -np.radians(deg)))
    body = 'kind = "oscillating"\ncontact = "roller"\nroller = "6mm"\npivot = "80mm"\narm = "60mm"'
    mech = model(tmp_path, body, 'profile = "pitch.csv"')
    rows, _ = report(mech, step=0.25)
    ang = rows["angle"]
    s, v, a = (lift * x for x in law(ang))
    check_svaj(ang, np.radians(rows["s"]), rows["v"], rows["a"], (s, v, a), scale=lift)
    law_body = body + '\nbase = "30mm"'
    ref, _ = report(model(tmp_path, law_body, LAW.replace('"25mm"', '"15deg"'), "law.toml"), step=0.25)
    assert np.abs(rows["pressure_angle"] - ref["pressure_angle"]).max() < 1e-3


def test_flat_face_profile_moves_as_its_law(tmp_path):
    """A translating flat face: its profile is the envelope of the face y = R_b + s(θ) turned by −θ; the
    contact point (fixed frame) is (s′, R_b + s). Points of that envelope give back s, v, a."""
    Rb = 60.0
    deg = np.arange(360.0)
    s, v, _ = law(deg)
    X = np.stack([v, Rb + s], axis=-1)
    write_points(tmp_path / "profile.csv", rot(X, -np.radians(deg)))
    mech = model(tmp_path, 'kind = "translating"\ncontact = "flat"', 'profile = "profile.csv"')
    rows, rep = report(mech, step=0.25)
    ang = rows["angle"]
    # the envelope's points are spaced unevenly in cam angle; the support is found on the spline through them
    s, v, a = law(ang)
    near = near_joins(ang)
    assert np.abs(rows["s"] - s).max() < 1e-3
    assert np.abs(rows["v"] - v)[~near].max() < 1e-3 * np.abs(v).max()
    assert np.abs(rows["a"] - a)[~near].max() < 1e-2 * np.abs(a).max()
    assert rep["flat_face"]["min_base_radius"] == pytest.approx(float(np.max(-(s + a))), abs=0.5)


def test_a_profile_cam_needs_a_file_and_no_law(tmp_path):
    t = np.linspace(0, 2 * PI, 12, endpoint=False)
    write_points(tmp_path / "c.csv", np.stack([40 * np.cos(t), 40 * np.sin(t)], -1))
    with pytest.raises(ls.ModelError, match=r"cams\.c1.*exactly one of `law`"):
        model(tmp_path, 'kind = "translating"\ncontact = "knife"\nbase = "40mm"', 'profile = "c.csv"\n' + LAW)
    with pytest.raises(ls.ModelError, match=r"cams\.c1\.base: a cam declared by its `profile` has no `base`"):
        model(tmp_path, 'kind = "translating"\ncontact = "knife"\nbase = "40mm"', 'profile = "c.csv"')
