"""References for the synthesis tests: the log10 function generator's targets and its Freudenstein
constants by Cramer's rule, and the path-synthesis four-bar's traced coupler curves."""

import math
import tomllib

import numpy as np
import pytest

import loopsolve as ls

FOURBAR = ls.models_dir() / "fourbar_path_synthesis.toml"


def log10_targets():
    xs = [5.5 - 4.5 * math.cos(math.pi / 6), 5.5, 5.5 + 4.5 * math.cos(math.pi / 6)]  # Chebyshev, n = 3
    return [(45 + 60 * (x - 1) / 9, 135 + 90 * math.log10(x)) for x in xs]


def freudenstein_K(rows):
    """K1 cos t4 - K2 cos t2 + K3 = cos(t2 - t4) through three points (Cramer's rule, written out)."""
    A = [[math.cos(math.radians(b)), -math.cos(math.radians(a)), 1.0] for a, b in rows]
    r = [math.cos(math.radians(a - b)) for a, b in rows]

    def det(M):
        return (M[0][0] * (M[1][1] * M[2][2] - M[1][2] * M[2][1]) - M[0][1] * (M[1][0] * M[2][2] - M[1][2] * M[2][0])
                + M[0][2] * (M[1][0] * M[2][1] - M[1][1] * M[2][0]))

    D = det(A)
    out = []
    for j in range(3):
        M = [row[:] for row in A]
        for i in range(3):
            M[i][j] = r[i]
        out.append(det(M) / D)
    return out


def traced(r2, r3, r4, rcx, rcy, *, start=0.0, stop=360.0, step=9.0, turn=0.0, scale=1.0, shift=(0.0, 0.0)):
    """Coupler point P of the shipped path-synthesis four-bar (r1 = 4) over the crank angles, placed."""
    m = ls.load(FOURBAR).with_parameters(r2=r2, r3=r3, r4=r4, rcx=rcx, rcy=rcy)
    sw = m.sweep(start, stop, step, progress=False)
    xy = np.column_stack([sw["P_x"], sw["P_y"]])
    c, s = math.cos(math.radians(turn)), math.sin(math.radians(turn))
    return xy @ np.array([[c, s], [-s, c]]) * scale + np.asarray(shift)


def candidate_curve(toml: str, closed: bool) -> np.ndarray:
    """P's path on the candidate's model, solved here: a full turn of the crank in its own mode (closed), or
    the whole circuit through the limit positions both ways from the drawn pose (open)."""
    mech = ls.loads(toml)
    joints = tomllib.loads(toml)["joints"]
    o2, a = np.array(joints["O2"]["at"]), np.array(joints["A"]["at"])
    x0 = math.degrees(math.atan2(*(a - o2)[::-1]))
    st = mech.solve(x0)
    assert [st["A_x"], st["A_y"]] == pytest.approx(list(a), abs=1e-9)  # the drawn pose is the input's value x0
    assert [st["P_x"], st["P_y"]] == pytest.approx(joints["P"]["at"], abs=1e-9)
    if closed:  # the input turns fully, in the candidate's mode: no limit, no mode change
        sw = mech.sweep(x0, x0 + 360, 0.25, progress=False)
        assert not sw.events, sw.events
        rows = [sw]
    else:
        rows = [mech.sweep(x0, x0 + d, 0.25, through_limits=True, progress=False) for d in (360, -360)]
    return np.vstack([np.column_stack([sw["P_x"], sw["P_y"]]) for sw in rows])


def distance(targets: np.ndarray, curve: np.ndarray) -> np.ndarray:
    """Each target's distance to the polyline ``curve``."""
    a, d = curve[:-1], np.diff(curve, axis=0)
    dd = np.where((d * d).sum(1) > 0, (d * d).sum(1), 1.0)
    t = np.clip(((targets[:, None, :] - a[None]) * d[None]).sum(2) / dd[None], 0, 1)
    return np.hypot(*(targets[:, None, :] - a[None] - t[..., None] * d[None]).transpose(2, 0, 1)).min(1)
