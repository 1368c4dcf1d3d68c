"""Curve descriptors: free of position, orientation, scale, sampling and starting point, to tolerances
written from the method; the 180° ambiguity; open curves and their reverse; Procrustes windows; bad curves."""

from __future__ import annotations

import math

import numpy as np
import pytest

from loopsolve.design.atlas import descriptors as d
from loopsolve.errors import ModelError

H = 10


def curve(t):
    """A smooth closed test curve (a dented ellipse) at parameters t, and its curvature there."""
    x = 3 * np.cos(t) + 0.5 * np.cos(2 * t)
    y = 1.7 * np.sin(t) - 0.25 * np.sin(3 * t)
    dx = -3 * np.sin(t) - 1.0 * np.sin(2 * t)
    dy = 1.7 * np.cos(t) - 0.75 * np.cos(3 * t)
    ddx = -3 * np.cos(t) - 2.0 * np.cos(2 * t)
    ddy = -1.7 * np.sin(t) + 2.25 * np.sin(3 * t)
    kappa = np.abs(dx * ddy - dy * ddx) / (dx * dx + dy * dy) ** 1.5
    return np.stack([x, y], axis=1), kappa


def similar(xy, angle, scale, shift):
    c, s = math.cos(angle), math.sin(angle)
    return (xy @ np.array([[c, -s], [s, c]]).T) * scale + np.asarray(shift)


def closest_variant(xy, ref):
    V = d.efd_variants(xy, H)
    return float(np.min(np.max(np.abs(V - ref), axis=1)))


def max_side(xy):
    return float(np.max(np.hypot(*np.diff(np.vstack([xy, xy[:1]]), axis=0).T)))


@pytest.fixture(scope="module")
def base():
    t = np.linspace(0, 2 * np.pi, 400, endpoint=False)
    xy, kappa = curve(t)
    return xy, float(kappa.max()), d.efd_variants(xy, H)[0]


def test_moved_turned_scaled_and_restarted_polygon_has_the_same_descriptor(base):
    xy, _, ref = base
    for k, (ang, sc, sh, roll) in enumerate([(0.7, 2.5, (4, -3), 0), (-2.9, 0.01, (1e3, 7), 123),
                                              (math.pi, 40.0, (0, 0), 200), (1.0, 1.0, (-5, 5), 399)]):
        other = np.roll(similar(xy, ang, sc, sh), roll, axis=0)
        # the same polygon: only round-off (coefficients are O(1) after normalization)
        assert closest_variant(other, ref) < 1e-10, k


def test_resampled_curve_has_the_same_descriptor_within_the_polygon_error(base):
    """Another polygon of the same curve (other count, other spacing, other start) differs from the curve by at
    most κ h²/8 (h its longest side, κ the curvature); a Fourier coefficient of that difference is at most twice
    its largest value, and the normalization divides by the semi-major axis E and turns by angles that move by
    as much relative to E. So the descriptors differ by at most C κ h² / (8 E) with C = 2 (coefficients) × 2
    (both polygons) × 2 (normalization's turn and start) — written here with C = 8 as the tolerance."""
    xy, kappa, ref = base
    E = float(d.efd_normalize(d.efd(xy, H))[3])
    for n, warp, start in [(350, 0.0, 0.3), (611, 0.35, 2.0), (450, 0.2, 5.1)]:
        u = np.linspace(0, 2 * np.pi, n, endpoint=False)
        t = u + warp * np.sin(u) + start  # uneven spacing, another first point
        other, _ = curve(t)
        h = max(max_side(xy), max_side(other))
        tol = 8 * kappa * h * h / (8 * E)
        assert tol < 0.01
        moved = similar(other, 1.3, 0.2, (9, 9))
        assert closest_variant(moved, ref) <= tol, (n, closest_variant(moved, ref), tol)


def test_the_other_end_of_the_major_axis_flips_the_even_harmonics(base):
    """Normalizing with θ₁ + π instead of θ₁ (written out here from Kuhl & Giardina) gives the coefficients of
    harmonic n times (−1)^(n+1): the second row of efd_variants."""
    xy, _, _ = base
    C = d.efd(xy, H)
    N1, theta, _, _, _ = d.efd_normalize(C)
    th = theta + math.pi
    out = []
    for n in range(1, H + 1):
        a, b, c, dd = C[n - 1]
        cn, sn = math.cos(n * th), math.sin(n * th)
        out.append([[a * cn + b * sn, -a * sn + b * cn], [c * cn + dd * sn, -c * sn + dd * cn]])
    M = np.array(out)
    psi = math.atan2(M[0, 1, 0], M[0, 0, 0])
    E = math.hypot(M[0, 0, 0], M[0, 1, 0])
    R = np.array([[math.cos(psi), math.sin(psi)], [-math.sin(psi), math.cos(psi)]])
    N2 = np.array([(R @ m) / E for m in M]).reshape(H, 4)
    sign = (-1.0) ** (np.arange(1, H + 1) + 1)
    assert np.allclose(N2, N1 * sign[:, None], atol=1e-12)
    assert np.allclose(d.efd_variants(xy, H)[1], d.efd_descriptor(N2), atol=1e-12)
    assert abs(N1[0, 0] - 1) < 1e-12 and abs(N1[0, 1]) < 1e-12 and abs(N1[0, 2]) < 1e-12


def test_a_reversed_closed_curve_is_one_of_the_variants_and_runs_the_other_way(base):
    xy, _, ref = base
    rev = xy[::-1]
    assert closest_variant(rev, ref) < 1e-10
    # d1 (minor/major with the sense of travel) changes sign with the direction
    assert np.sign(d.efd_variants(rev, H)[0][0]) == -np.sign(ref[0])


def test_different_curves_are_far_apart(base):
    xy, _, ref = base
    t = np.linspace(0, 2 * np.pi, 300, endpoint=False)
    ellipse = np.stack([3 * np.cos(t), 1.7 * np.sin(t)], axis=1)
    assert closest_variant(ellipse, ref) > 0.05


def test_open_curve_its_reverse_and_its_moved_copy_have_distance_zero(base):
    xy, _, _ = base
    arc = xy[40:170]
    assert d.open_distance(arc, arc[::-1]) < 1e-12
    assert d.open_distance(arc, similar(arc, 2.2, 13.0, (3, -8))) < 1e-12
    assert d.open_distance(arc, similar(arc[::-1], -0.4, 0.5, (1, 1))) < 1e-12
    # a resampled copy: the same arc-length points up to the polygon error
    t = np.linspace(40 / 400 * 2 * np.pi, 169 / 400 * 2 * np.pi, 77)
    other, _ = curve(t)
    assert d.open_distance(arc, other) < 2e-3
    assert d.open_distance(arc, xy[200:330]) > 0.05


def test_open_normalization_undone_by_its_placement(base):
    xy, _, _ = base
    arc = similar(xy[10:150], 0.9, 3.0, (5, 2))
    Q, (x, y, ang, s) = d.open_normalize(arc, 64)
    back = similar(Q, ang, s, (x, y))
    assert np.allclose(back, d.resample(arc, 64, closed=False), atol=1e-12)


def test_procrustes_finds_a_moved_stretch_of_a_stored_curve(base):
    xy, _, _ = base
    N = 64
    stored = d.resample_many(np.stack([xy, similar(xy, 0.5, 2.0, (1, 1))]), [len(xy)] * 2, N, [True, False])
    # a stretch of stored curve 0: points 50 … 50 + 8·3 (wrapping), moved; then its reverse
    zc = stored[0]
    idx = (50 + 3 * np.arange(9)) % N
    stretch = similar(zc[idx], -1.1, 7.0, (3, 4))
    dist, start, stride, fac, mean = d.procrustes(stored, [True, False], stretch, strides=(1, 2, 3, 4))
    # the distance is the square root of 1 − |C|²/var: round-off of 1e-16 there is 1e-8 here
    assert dist[0] < 1e-6 and start[0] == 50 and stride[0] == 3
    assert dist[1] > dist[0]
    # the fit maps the window onto the normalized target
    t, c, nrm = d.target_vector(stretch)
    w = zc[idx, 0] + 1j * zc[idx, 1]
    assert np.allclose(fac[0] * (w - mean[0]), t, atol=1e-9)
    # the whole closed curve from any start point
    dist, start, stride, _, _ = d.procrustes(stored[:1], [True], similar(np.roll(zc, -17, axis=0), 2, 3, (0, 0)))
    assert dist[0] < 1e-6 and start[0] == 17


def _windows_by_hand(Z, closed, t, strides):
    """The least Procrustes distance over every window of one stored curve ``Z`` (complex, N points), written out:
    points s, s + Δ, … (wrapping only when ``closed``), the target ``t`` centred with norm 1."""
    N, m = len(Z), len(t)
    best = (math.inf, None, None)
    for dlt in strides:
        for s in range(N):
            idx = s + dlt * np.arange(m)
            if idx[-1] >= N and not closed or (m - 1) * dlt > N - 1:
                continue
            w = Z[idx % N]
            wc = w - w.mean()
            dist = math.sqrt(max(1.0 - abs(np.vdot(wc, t)) ** 2 / np.vdot(wc, wc).real, 0.0))
            if dist < best[0] - 1e-12:
                best = (dist, s, dlt)
    return best


@pytest.mark.parametrize("single", [False, True])
def test_procrustes_windows_equal_the_windows_written_out(single):
    """The FFT window sums (two strides' squared moduli in one transform, blocks of rows, an open curve's windows
    not wrapping) against every window computed directly, both directions, six strides (the last longer than the
    curve), in double and in single precision (whose squared distances carry ~1e-5 of round-off)."""
    rng = np.random.default_rng(3)
    N, E = 64, 6
    u = np.linspace(0, 2 * np.pi, N, endpoint=False)
    curves = np.stack([np.stack([np.cos(u) * a + 0.3 * np.cos(k * u + p), np.sin(u) * b + 0.2 * np.sin(2 * u)], axis=1)
                       for a, b, k, p in zip(rng.uniform(1, 3, E), rng.uniform(0.5, 2, E), rng.integers(2, 4, E),
                                             rng.uniform(0, 6, E))])
    closed = np.array([True, False, True, False, True, False])
    target = np.stack([np.linspace(0, 2, 9), 0.3 * np.linspace(0, 2, 9) ** 2], axis=1)
    strides = (1, 2, 3, 4, 6, 8)
    fw, bw = d._procrustes_blocks(curves.astype(np.float32 if single else float), closed, target, strides, True,
                                  single=single)
    t, _, _ = d.target_vector(target)
    for e in range(E):
        Z = curves[e, :, 0] + 1j * curves[e, :, 1]
        for res, tt in ((fw, t), (bw, t[::-1])):
            dist, s, dlt = _windows_by_hand(Z, closed[e], tt, strides)
            if single:  # 1 − |C|²/var from single-precision transforms of 64 points: ~1e-5 of round-off
                assert res[0][e] ** 2 == pytest.approx(dist ** 2, abs=3e-5)
            else:
                assert res[0][e] == pytest.approx(dist, abs=1e-12)
                assert (res[1][e], res[2][e]) == (s, dlt)


@pytest.mark.parametrize("rows,closed,message", [
    ([[0, 0], [1, 0], [1, 1], [0, 1]], True, "at least 5"),
    ([[0, 0], [1, 0], [np.nan, 1], [0, 1], [0, 2], [1, 3]], True, "point 3 is not a finite"),
    ([[0, 0], [1, 0], [1, 0], [0, 1], [0, 2], [1, 3]], False, "points 2 and 3 are the same"),
    ([[2, 2]] * 7, True, "every point is the same"),
])
def test_bad_curves_are_refused_naming_the_row(rows, closed, message):
    with pytest.raises(ModelError, match=message):
        d.check_curve(np.array(rows, dtype=float), closed=closed)


def test_a_closed_curve_drawn_back_to_its_start_drops_the_repeated_point():
    t = np.linspace(0, 2 * np.pi, 9)
    xy = np.stack([np.cos(t), np.sin(t)], axis=1)
    xy[-1] = xy[0]
    assert len(d.check_curve(xy, closed=True)) == 8
    assert len(d.check_curve(xy, closed=False)) == 9


def test_a_closed_curve_back_at_its_start_to_round_off_drops_the_repeated_point():
    """x = 10 + 10 cos φ, y = 10 + 8 sin φ at φ = 0°, 40°, …, 360°: the tenth point is the first to round-off only."""
    phi = np.radians(np.arange(0, 361, 40))
    xy = np.stack([10 + 10 * np.cos(phi), 10 + 8 * np.sin(phi)], axis=1)
    assert not np.array_equal(xy[0], xy[-1])
    assert len(d.check_curve(xy, closed=True)) == 9


@pytest.mark.parametrize("rerank", [True, False])
def test_a_planted_stretch_is_ranked_first_among_thousands_of_near_copies(base, monkeypatch, rerank):
    """An atlas-sized batch is ranked in single precision, whose distances near 0 carry ~1e-3 of round-off:
    among 5000 curves a few 1e-5 apart, every good window reads about 0. The best of them are ranked again
    in double, so the curve the stretch was cut from comes first with its window; without that second
    ranking (``rerank=False``, the old code) it does not — the test shows the single-precision tie."""
    xy, _, _ = base
    N, E, planted = 64, 5000, 3217
    ref = d.resample(xy, N, closed=True)
    rng = np.random.default_rng(7)
    bump = np.stack([np.sin(3 * np.linspace(0, 2 * np.pi, N, endpoint=False) + p) for p in (0.3, 1.1)], axis=1)
    size = np.ptp(ref, axis=0).max()
    stored = ref[None] + (1e-5 * size * rng.uniform(0.2, 1.0, E))[:, None, None] * bump[None]
    stored[planted] = ref
    idx = (20 + 2 * np.arange(9)) % N
    stretch = similar(ref[idx], 0.7, 3.0, (5, -2))
    if not rerank:
        monkeypatch.setattr(d, "_RERANK", 1)
        monkeypatch.setattr(d, "_SINGLE_TIE", 0.0)
    fw, bw = d.procrustes_both(stored, np.ones(E, bool), stretch, strides=(1, 2, 3))
    best = int(np.argmin(np.minimum(fw[0], bw[0])))
    if rerank:
        assert best == planted and fw[0][planted] < 1e-6 and fw[1][planted] == 20 and fw[2][planted] == 2
    else:
        assert best != planted
