"""Burmester motion generation against computations written here.

The planted linkage: a crank-rocker with ground pivots O2 = (1, 2), O4 = O2 + 60∠10°, crank 25,
coupler 70, rocker 45 (the thesis four-bar, moved and turned), coupler point 30 from the crank
pin at 40° from the coupler line. Its poses come from the circle intersection written here.
"""

import itertools
import math

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.errors import ModelError

from support.models import circle_intersection, O2, O4, planted_pose, POSES5, R1, R2, R3, R4


def rot(a):
    return np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])


POSES4 = [planted_pose(t)[0] for t in (20, 70, 120, 170)]


@pytest.fixture(scope="module")
def curves():
    """Computed once for the tests of :class:`TestCurves` (a module function: pytest retires class-scoped
    fixtures defined as instance methods)."""
    return ls.burmester_curves(POSES4)


class TestCurves:
    def test_every_dyad_keeps_its_distance(self, curves):
        # the four-pose condition itself: the pin k (coupler frame) stays at one distance from m
        ok = np.isfinite(curves.center[:, 0])
        assert ok.sum() > 1000
        for m, k in zip(curves.center[ok][::25], curves.circle_moving[ok][::25]):
            d = [np.hypot(*(np.array(p[:2]) + rot(math.radians(p[2])) @ k - m)) for p in POSES4]
            assert max(d) - min(d) < 1e-7 * max(d), (m, d)

    def test_centre_points_satisfy_the_compatibility_determinant(self, curves):
        # compatibility written with complex numbers: z_j = p_j - m, e_j = e^{i phi_j};
        # |z_j + e_j k|^2 - |z_0 + e_0 k|^2 = 0 is linear in k = (kx, ky):
        # 2 Re(conj(z_j) e_j k) - 2 Re(conj(z_0) e_0 k) + |z_j|^2 - |z_0|^2 = 0
        span = max(math.dist(a[:2], b[:2]) for a, b in itertools.combinations(POSES4, 2))
        ok = np.isfinite(curves.center[:, 0])
        for m in curves.center[ok][::40]:
            rows = []
            z0 = complex(*(np.array(POSES4[0][:2]) - m))
            e0 = complex(math.cos(math.radians(POSES4[0][2])), math.sin(math.radians(POSES4[0][2])))
            for p in POSES4[1:]:
                zj = complex(*(np.array(p[:2]) - m))
                ej = complex(math.cos(math.radians(p[2])), math.sin(math.radians(p[2])))
                wx = 2 * ((zj.conjugate() * ej).real - (z0.conjugate() * e0).real)
                wy = 2 * (-(zj.conjugate() * ej).imag + (z0.conjugate() * e0).imag)
                rows.append([wx, wy, abs(zj) ** 2 - abs(z0) ** 2])
            scale = np.prod([np.linalg.norm(r) for r in rows])
            assert abs(np.linalg.det(np.array(rows))) < 1e-9 * scale, m
        # the planted ground pivots are centre points, their pins circle points
        for piv in (O2, O4):
            assert np.min(np.hypot(*(curves.center[ok] - piv).T)) < 0.02 * span

    def test_the_six_poles_lie_on_the_centre_point_curve(self, curves):
        # pole P_ij: the coupler point with the same world position in poses i and j, from
        # (R_i - R_j) q = p_j - p_i (written here); the centre-point curve passes through all six
        span = max(math.dist(a[:2], b[:2]) for a, b in itertools.combinations(POSES4, 2))
        ok = np.isfinite(curves.center[:, 0])
        centroid = np.mean([p[:2] for p in POSES4], axis=0)
        checked = 0
        for (pi, pj) in itertools.combinations(POSES4, 2):
            Ri, Rj = rot(math.radians(pi[2])), rot(math.radians(pj[2]))
            q = np.linalg.solve(Ri - Rj, np.array(pj[:2]) - np.array(pi[:2]))
            pole = np.array(pi[:2]) + Ri @ q
            if np.hypot(*(pole - centroid)) > 20 * span:
                continue  # far out along an asymptote, beyond the drawn curve
            assert np.min(np.hypot(*(curves.center[ok] - pole).T)) < 0.01 * span, pole
            checked += 1
        assert checked >= 4

    def test_circle_points_are_the_pins_in_the_first_pose(self, curves):
        ok = np.isfinite(curves.center[:, 0])
        p0 = np.array(POSES4[0][:2])
        want = p0 + curves.circle_moving[ok] @ rot(math.radians(POSES4[0][2])).T
        assert np.allclose(curves.circle[ok], want, atol=1e-9)

    def test_four_poses_needed(self):
        with pytest.raises(ModelError, match="exactly four poses"):
            ls.burmester_curves(POSES5)


def expected_verdict(cand, poses):
    """The defects a candidate must have, from the circle intersection (written here)."""
    mech = cand.mechanism
    p = {q.name: q.value for q in mech.parameters}
    o2 = np.array([p["x0"], p["y0"]])
    t1 = p["t1"]  # internal radians
    o4 = o2 + p["r1"] * np.array([math.cos(t1), math.sin(t1)])
    r2, r3, r4 = p["r2"], p["r3"], p["r4"]
    sides, errs = [], []
    for pose, t2 in zip(poses, cand.inputs):
        A = o2 + r2 * np.array([math.cos(math.radians(t2)), math.sin(math.radians(t2))])
        best = None
        for side in (1, -1):
            B = circle_intersection(A, r3, o4, r4, side)
            th3 = math.atan2(B[1] - A[1], B[0] - A[0])
            phi = th3 - p["d3"]
            P = A + p["rp"] * np.array([math.cos(phi + p["gp"]), math.sin(phi + p["gp"])])
            e = math.hypot(P[0] - pose[0], P[1] - pose[1]) + abs((math.degrees(phi) - pose[2] + 180) % 360 - 180)
            if best is None or e < best[0]:
                best = (e, side)
        errs.append(best[0])
        sides.append(best[1])
    return sides, errs, (o2, o4, r2, r3, r4)


def limit_angles(o2, o4, r2, r3, r4):
    """Crank angles (deg) where |A - O4| = r3 + r4 or |r3 - r4| (law of cosines), absolute."""
    d = o4 - o2
    r1, t1 = math.hypot(*d), math.atan2(d[1], d[0])
    out = []
    for ell in (r3 + r4, abs(r3 - r4)):
        c = (r1 * r1 + r2 * r2 - ell * ell) / (2 * r1 * r2)
        if -1 <= c <= 1:
            a = math.acos(c)
            out += [math.degrees(t1 + a), math.degrees(t1 - a)]
    return out


def crosses(a, b, d, angles):
    """Does the input moving from a to b in direction d pass one of ``angles``?"""
    span = (d * (b - a)) % 360
    return any(0 < (d * (x - a)) % 360 < span for x in angles)


@pytest.fixture(scope="module")
def result():
    """Computed once for the tests of :class:`TestFivePoses` (a module function: pytest retires class-scoped
    fixtures defined as instance methods)."""
    return ls.burmester(POSES5)


class TestFivePoses:
    def test_planted_linkage_recovered(self, result):
        centres = [np.array(d.center) for d in result.dyads]
        assert len(result.dyads) in (2, 4)
        assert min(np.hypot(*(c - O2)) for c in centres) < 1e-8
        assert min(np.hypot(*(c - O4)) for c in centres) < 1e-8
        planted = [c for c in result.candidates if np.allclose(sorted(c.lengths), sorted((R1, R2, R3, R4)), atol=1e-8)]
        assert len(planted) == 1
        c = planted[0]
        assert c.certified and c.grashof.value == "crank-rocker"
        assert c.lengths == pytest.approx((R1, R2, R3, R4), abs=1e-8)
        assert c.inputs == pytest.approx([20, 70, 120, 170, -140], abs=1e-8)
        assert max(c.pose_errors) < 1e-9
        # the model reproduces a pose between the precision poses (crank at 95°)
        s = c.mechanism.solve(95, mode=c.mode)
        want, _, _ = planted_pose(95)
        assert (s["P_x"], s["P_y"]) == pytest.approx(want[:2], abs=1e-9)
        assert s["phi"] == pytest.approx(want[2], abs=1e-9)

    def test_every_dyad_is_exact(self, result):
        for d in result.dyads:
            pins = [np.array(p[:2]) + rot(math.radians(p[2])) @ np.array(d.circle) for p in POSES5]
            dist = [math.hypot(*(w - np.array(d.center))) for w in pins]
            assert max(dist) - min(dist) < 1e-8 * max(dist)
            assert d.radius == pytest.approx(dist[0], rel=1e-9)

    def test_each_certificate_against_the_circle_intersection(self, result):
        assert len(result.candidates) == len(result.dyads) * (len(result.dyads) - 1) // 2
        for c in result.candidates:
            sides, errs, geo = expected_verdict(c, POSES5)
            assert max(errs) < 1e-7  # every pose is an assembly of this four-bar
            kinds = {d.kind for d in c.defects}
            lim = limit_angles(*geo)
            steps = [(c.inputs[j + 1] - c.inputs[j] + 180) % 360 - 180 for j in range(4)]
            d = 1 if steps[0] > 0 else -1
            if not lim:  # the crank turns fully (either way): one side (circuit), within one turn
                want_order = min(sum((dd * s) % 360 for s in steps) for dd in (1, -1)) >= 360
                if not want_order:
                    assert sum((c.direction * s) % 360 for s in steps) < 360
                want_circuit = len(set(sides)) > 1 and not want_order
                assert ("order" in kinds) == want_order, c
                assert ("circuit" in kinds) == want_circuit, c
            elif any(s * d <= 0 for s in steps):
                assert "order" in kinds, c
            else:
                passes = any(crosses(c.inputs[j], c.inputs[j + 1], d, lim) for j in range(4))
                want_branch = passes or len(set(sides)) > 1
                assert bool(kinds & {"branch", "circuit"}) == want_branch, c
            assert c.certified == (not kinds)
            cert = c.certificate
            assert cert["defects"] == sorted(kinds)
            assert cert["order"] == ("order" not in kinds)

    def test_order_defect_flagged(self):
        # the same crank-rocker, poses listed out of the crank's order: 20, 120, 70, 170, 220
        poses = [planted_pose(t)[0] for t in (20, 120, 70, 170, 220)]
        res = ls.burmester(poses)
        planted = [c for c in res.candidates if np.allclose(sorted(c.lengths), sorted((R1, R2, R3, R4)), atol=1e-8)]
        assert len(planted) == 1
        assert [d.kind for d in planted[0].defects] == ["order"]
        assert not planted[0].certified

    def test_circuit_defect_flagged(self):
        # poses 1-4 on the open circuit, pose 5 on the crossed one of the same crank-rocker
        poses = [planted_pose(t)[0] for t in (20, 70, 120, 170)] + [planted_pose(220, side=-1)[0]]
        res = ls.burmester(poses)
        planted = [c for c in res.candidates if np.allclose(sorted(c.lengths), sorted((R1, R2, R3, R4)), atol=1e-8)]
        assert len(planted) == 1
        assert "circuit" in {d.kind for d in planted[0].defects}

    @pytest.mark.parametrize("poses, match", [
        (POSES4, "exactly five poses"),
        ([(0, 0)] * 5, "three numbers"),
        ([(0, 0, "a")] * 5, "three numbers"),
        ([(0, 0, float("nan"))] * 5, "finite"),
        ([(0, 0, 5), (1, 0, 5), (2, 0, 5), (3, 1, 5), (4, 4, 5)], "same angle"),
    ])
    def test_bad_poses(self, poses, match):
        with pytest.raises(ModelError, match=match):
            ls.burmester(poses)


def test_four_pose_design_from_chosen_centre_points():
    # four poses: the planted pivots are centre points; the four-bar through them is the planted one
    from loopsolve.design.synthesis.classical.burmester import dyad_for_center, four_bar

    c = four_bar(POSES4, tuple(O2), tuple(O4))
    assert c.lengths == pytest.approx((R1, R2, R3, R4), abs=1e-8)
    assert c.certified and c.inputs == pytest.approx([20, 70, 120, 170], abs=1e-8)
    _, A, B = planted_pose(20)
    d = dyad_for_center(POSES4, tuple(O2))
    assert np.allclose(d.pin(POSES4[0]), A, atol=1e-9) and d.radius == pytest.approx(R2)
    with pytest.raises(ModelError, match="not a centre point"):
        dyad_for_center(POSES4, (O2[0] + 5, O2[1]))
