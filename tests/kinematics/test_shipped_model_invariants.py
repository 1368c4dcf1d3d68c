"""The same invariant suite for every model file in ``models/`` (globbed, so new models join in).

For each model and many input values around its range:

* loop closure: the declared vector loops, evaluated straight from the declaration with the
  pure-Python expression evaluator (no sympy, no generated code), close to 1e-10 of the model's
  length scale;
* velocity, acceleration and jerk of every variable and every point agree with high-order
  central finite differences of the *solved positions* (Newton at neighbouring inputs), with
  input speed, acceleration and jerk all nonzero so every chain-rule term is exercised;
* Φ_q agrees with finite differences of Φ;
* the degrees of freedom equal the nullity of the full Jacobian [Φ_q Φ_x] (= the number of
  inputs), and Φ_q itself is regular away from singular positions.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.model import expr as lexpr
from loopsolve.kinematics.solve import initial_z, solve_position, solve_rates
from loopsolve.model.units import Kind, angle_factor

MODELS = sorted(ls.models_dir().glob("*.toml"))

#: shipped models whose input turns a full revolution: every sampled input must assemble
FULL_ROTATION = {
    "thesis_crank_rocker",
    "thesis_crank_rocker_diagram",
    "prob1_fourbar",
    "example1_slider_crank",
    "prob2_offset_slider_crank",
    "quick_return",
}

#: shipped models none of whose unknowns has a bounded range (driven, each takes every angle): the
#: geared five-bar's cranks and couplers all turn fully over the three input turns of its cycle
EVERY_UNKNOWN_TURNS = {"geared_fivebar"}

N_SAMPLES = 48  # inputs per model for the closure test
N_FD = 10  # inputs per model for the finite-difference tests
OFFSETS = np.arange(-4, 5)  # 9-point central stencil


def _stencil(order: int) -> np.ndarray:
    """Weights w with Σ w_k f(x + k h) ≈ h**order f^(order)(x) on OFFSETS (exact to degree 8)."""
    n = len(OFFSETS)
    a = np.vander(OFFSETS.astype(float), n, increasing=True).T  # a[p, k] = k**p
    rhs = np.zeros(n)
    rhs[order] = math.factorial(order)
    return np.linalg.solve(a, rhs)


W = {k: _stencil(k) for k in (1, 2, 3)}


def test_stencils_are_exact_on_polynomials():
    """The finite-difference weights differentiate degree-8 polynomials exactly (a check of the checker)."""
    rng = np.random.default_rng(1)
    c = rng.normal(size=9)
    poly = np.polynomial.Polynomial(c)
    x0, h = 0.3, 0.05
    f = poly(x0 + OFFSETS * h)
    for k in (1, 2, 3):
        assert W[k] @ f / h**k == pytest.approx(poly.deriv(k)(x0), rel=1e-9)


@pytest.fixture(scope="module", params=MODELS, ids=lambda p: p.stem)
def model(request):
    mech = ls.load(request.param)
    ck = mech.compile()
    return request.param.stem, mech, ck


def test_models_are_shipped():
    names = {p.stem for p in MODELS}
    assert FULL_ROTATION - {"thesis_crank_rocker_diagram"} <= names


# ----------------------------------------------------------------------------- helpers


def _input_step(ck) -> float:
    """Finite-difference step of the driving input (internal units)."""
    kind = ck.kinds[ck.input_idx[0]]
    return 0.01 if kind is Kind.ANGLE else 0.005 * ck.scale


def _samples(ck) -> np.ndarray:
    """Input values (internal units) around the range, starting at the declared guess."""
    i = ck.input_idx[0]
    z0 = initial_z(ck, warn=False)
    x0 = z0[i]
    if ck.kinds[i] is Kind.ANGLE:
        return x0 + np.linspace(0.0, 2 * math.pi, N_SAMPLES, endpoint=False)
    return x0 + ck.scale * np.linspace(-0.5, 0.5, N_SAMPLES)


def _trace(ck, xs):
    """Solve at each input, warm-starting from the previous solution (continuation).

    Returns ``[(x, z or None)]``; an input that cannot be assembled gives None (and the next
    input restarts from the last solution found).
    """
    i = ck.input_idx[0]
    z = initial_z(ck, warn=False)
    out = []
    for x in xs:
        z_try = z.copy()
        z_try[i] = x
        try:
            z_new, _, _ = solve_position(ck, z_try)
        except ls.AssemblyError:
            out.append((x, None))
            continue
        z = z_new
        out.append((x, z.copy()))
    return out


def _declared_phi(mech, z_internal: dict[str, float]) -> np.ndarray | None:
    """Loop residuals evaluated from the declaration itself (expression trees, pure Python).

    Expressions are read in model units (a degree model is a calculator in degree mode), so
    angle variables and angle parameters enter in the model's angle unit. Returns None when an
    expression uses a length literal with a unit (the tree evaluator does not convert lengths).
    """
    k = angle_factor(mech.units.angle)
    env = {}
    for p in mech.parameters:
        env[p.name] = p.value / k if p.kind is Kind.ANGLE else p.value
    for v in mech.variables:
        val = z_internal[v.name]
        env[v.name] = val / k if v.kind is Kind.ANGLE else val
    xy = {}
    try:
        for vec in mech.vectors:
            if vec.cartesian:
                xy[vec.name] = np.array([lexpr.evaluate(vec.x, env, angle_unit_factor=k),
                                         lexpr.evaluate(vec.y, env, angle_unit_factor=k)])
            else:
                length = lexpr.evaluate(vec.length, env, angle_unit_factor=k)
                ang = lexpr.evaluate(vec.angle, env, angle_unit_factor=k)
                if vec.offset is not None:
                    ang += lexpr.evaluate(vec.offset, env, angle_unit_factor=k)
                ang *= k
                xy[vec.name] = length * np.array([math.cos(ang), math.sin(ang)])
    except lexpr.ExpressionError as exc:
        if "units are not converted" in str(exc):
            return None
        raise
    res = []
    for loop in mech.loops:
        total = sum((sign * xy[name] for sign, name in loop.terms), np.zeros(2))
        res.extend(total)
    res.extend(_gear_rows(mech, env, z_internal, k))
    return np.array(res)


def _gear_rows(mech, env, z_internal, k) -> list:
    """Willis' formula of every gear pair, written here from the declaration (radians; a rack's in the
    length unit): ``(θ_m − θ_c) ± ρ (θ_g − θ_c) = phase``, ρ = N_g/N_m (or r_g/r_m), + external, − internal,
    each angle measured from its guess when no ``phase`` is given. A higher pair ties unknowns that may
    be in no vector loop (a planet gear's angle): its row is part of the declared Φ."""
    if mech.pairs is None:
        return []
    rows = []
    for g in mech.pairs.gears:
        def val(node):
            return lexpr.evaluate(node, env, angle_unit_factor=k)

        def ang(name, ref):
            return 0.0 if not name else z_internal[name] - (ref if g.phase is None else 0.0)

        ref = g.ref if g.phase is None else (0.0, 0.0, 0.0)
        tg, tm, tc = ang(g.gear, ref[0]), ang(g.mate, ref[1]), ang(g.carrier, ref[2])
        if g.kind == "rack":
            radius = val(g.radii[0]) if g.radii is not None else val(g.module) * val(g.teeth[0]) / 2
            phase = val(g.phase) if g.phase is not None else 0.0
            rows.append(tm - radius * (tg - tc) - phase)
            continue
        pair = g.teeth if g.teeth is not None else g.radii
        rho = val(pair[0]) / val(pair[1])
        phase = val(g.phase) * k if g.phase is not None else 0.0
        rows.append((tm - tc) + (-1 if g.kind == "internal" else 1) * rho * (tg - tc) - phase)
    return rows


def _fd_positions(ck, x0, z0, h):
    """Solved positions (and points) at x0 + k h for the stencil offsets, warm-started from z0."""
    i = ck.input_idx[0]
    zs, ps = [], []
    for k in OFFSETS:
        zt = z0.copy()
        zt[i] = x0 + k * h
        z, _, _ = solve_position(ck, zt)
        zs.append(z)
        ps.append(ck.point_values(0, z) if ck.points else np.zeros((0, 2)))
    return np.array(zs), np.array(ps)


def _cam_joins(mech) -> list[tuple[str, list[float]]]:
    """``[(cam variable, [join angles, radians])]``: where a cam law's segments meet (written here from the
    declared ``to`` of each segment and ``start``)."""
    if mech.pairs is None:
        return []
    k = angle_factor(mech.units.angle)
    env = {p.name: (p.value / k if p.kind is Kind.ANGLE else p.value) for p in mech.parameters}
    out = []
    for cam in mech.pairs.cams:
        ends = [lexpr.evaluate(seg.end, env, angle_unit_factor=k) * k for seg in cam.segments]
        start = lexpr.evaluate(cam.start, env, angle_unit_factor=k) * k if cam.start is not None else 0.0
        out.append((cam.cam, [start] + ends))
    return out


def _smooth_near(mech, ck, z, span) -> bool:
    """No cam-law join within the stencil around ``z`` (``span`` of the input each side): a law is
    piecewise (its jerk, or acceleration, jumps where two segments meet), so finite differences across
    a join do not converge to the one-sided rates there."""
    cams = _cam_joins(mech)
    if not cams:
        return True
    try:
        rates = solve_rates(ck, z, (1.0, 0.0, 0.0))[0]
    except ls.LoopsolveError:  # a singular pose: no stencil here anyway
        return False
    for var, joins in cams:
        j = ck.index(var)
        reach = 2 * span * max(1.0, abs(rates[j])) + 1e-9
        for a in joins:
            if abs((z[j] - a + math.pi) % (2 * math.pi) - math.pi) < reach:
                return False
    return True


def _well_conditioned(ck, traced, n, max_cond=1e5):
    good = [(x, z) for x, z in traced if z is not None and np.linalg.cond(ck.jac(z)) < max_cond]
    if len(good) <= n:
        return good
    idx = np.linspace(0, len(good) - 1, n).round().astype(int)
    return [good[j] for j in idx]


# ----------------------------------------------------------------------------- loop closure


def test_loop_closure_at_many_inputs(model):
    """Every assemblable sampled input closes the loops to 1e-10 of the model scale."""
    name, mech, ck = model
    traced = _trace(ck, _samples(ck))
    solved = [(x, z) for x, z in traced if z is not None]
    if name in FULL_ROTATION:
        assert len(solved) == len(traced), f"{name}: a full-rotation model failed to assemble somewhere"
    else:
        assert len(solved) >= 1
    tol = 1e-10 * ck.scale
    for x, z in solved:
        assert np.max(np.abs(ck.phi(z))) <= tol
        declared = _declared_phi(mech, dict(zip(ck.variables, z)))
        if declared is not None:
            assert np.max(np.abs(declared)) <= tol, (name, x, declared)


def test_declared_phi_detects_an_open_loop(model):
    """The independent closure check is not vacuous: moving an unknown off the solution opens a loop."""
    name, mech, ck = model
    z, _, _ = solve_position(ck, initial_z(ck, warn=False))
    for j in ck.unknown_idx:
        zz = z.copy()
        zz[j] += 0.05 if ck.kinds[j] is Kind.ANGLE else 0.05 * ck.scale
        declared = _declared_phi(mech, dict(zip(ck.variables, zz)))
        residual = declared if declared is not None else ck.phi(zz)
        assert np.max(np.abs(residual)) > 1e-4 * ck.scale


def test_assembly_failures_are_typed(model):
    """Where the sampled input cannot be assembled, the public solve says so with AssemblyError."""
    name, mech, ck = model
    traced = _trace(ck, _samples(ck))
    missing = [x for x, z in traced if z is None]
    i = ck.input_idx[0]
    for x in missing[:3]:
        k = angle_factor(mech.units.angle) if ck.kinds[i] is Kind.ANGLE else 1.0
        with pytest.raises(ls.AssemblyError) as info:
            mech.solve(x / k)
        assert info.value.input_value == pytest.approx(x / k)


def test_assembly_failures_are_typed_when_an_unknown_drives(model):
    """Every model: driving an unknown with a bounded range (a rocker, a slider...) outside that range
    is an AssemblyError naming the input value (the test above only bites on models whose own input
    is bounded)."""
    name, mech, ck0 = model
    for u in ck0.unknowns:
        inputs = [u if n == ck0.inputs[0] else n for n in ck0.inputs]
        ck = mech.compile(inputs)
        try:
            missing = [x for x, z in _trace(ck, _samples(ck)) if z is None]
        except ls.ConvergenceError:
            continue
        # the trace's Newton from the last pose may fail where the public solve, which searches the
        # assembly modes, finds a pose (a cam follower driven from a dwell, where the cam angle is
        # singular; a geared five-bar's other branches): such a pose must close the loops; where solve
        # fails, it says so with AssemblyError naming the input value
        i = ck.input_idx[0]
        k = angle_factor(mech.units.angle) if ck.kinds[i] is Kind.ANGLE else 1.0
        # (the first AssemblyError is enough: each costs a search for the nearest assemblable inputs,
        # seconds on a cam model whose follower block has no closed form)
        raised = 0
        for x in missing[:: max(1, len(missing) // 6)]:
            try:
                state = mech.solve(x / k, compiled=ck)
            except ls.AssemblyError as exc:
                assert exc.input_value == pytest.approx(x / k)
                raised += 1
                break
            assert state.input_value == pytest.approx(x / k)
            assert np.max(np.abs(ck.phi(np.asarray(state.z, dtype=float)))) <= 1e-9 * ck.scale
        if raised:
            break
    else:
        # no unknown of bounded range: every pose found where the trace failed was checked above
        assert name in EVERY_UNKNOWN_TURNS, f"{name}: no unknown of bounded range found"
        return
    assert name not in EVERY_UNKNOWN_TURNS, f"{name}: an unknown is bounded after all"


# ----------------------------------------------------------------------------- rates vs finite differences


FD_TOL = {1: 1e-9, 2: 1e-8, 3: 1e-6}
RATES = (1.3, -0.7, 2.1)  # input speed, acceleration, jerk (internal units): every chain-rule term counts


def _chain(d1, d2, d3, rates):
    """Time derivatives from the input-derivatives d^k q/dx^k for input rates (ẋ, ẍ, x⃛)."""
    v, a, j = rates
    return d1 * v, d2 * v**2 + d1 * a, d3 * v**3 + 3 * d2 * v * a + d1 * j


def test_rates_match_finite_differences_of_positions(model):
    """q̇, q̈, q⃛ and the points' rates equal FD of the solved positions (9-point stencils).

    Tolerances (relative to max(|value|, 1 rad or the model's length scale)): 1e-9 for the
    velocity, 1e-8 for the acceleration, 1e-6 for the jerk. With h = 0.01 rad the stencils'
    truncation error is O(h^8) for the velocity and O(h^6) for the jerk; measured worst cases over
    the shipped models were 3e-13, 7e-11 and 3e-8. A wrong sign or a missing term (e.g. the
    3 q'' ẋ ẍ term of the jerk) is O(1) of the scale.
    """
    name, mech, ck = model
    traced = _trace(ck, _samples(ck))
    h = _input_step(ck)
    i = ck.input_idx[0]
    points = _well_conditioned(ck, [(x, z) for x, z in traced if z is not None and _smooth_near(mech, ck, z, 4 * h)],
                               N_FD)
    assert points
    for x0, z0 in points:
        z1, z2, z3, pts, _ = solve_rates(ck, z0, RATES)
        # near a limit position (a double rocker lives next to its toggles) the truncation error
        # of the h-stencil grows; h/2 and h/4 are further opinions (a wrong term fails them all)
        stencils = [_fd_positions(ck, x0, z0, h / 2**m) for m in range(3)]
        fds = [_chain(*[np.tensordot(W[k], zs, axes=1) / (h / 2**m) ** k for k in (1, 2, 3)], RATES)
               for m, (zs, _) in enumerate(stencils)]
        fdps = [_chain(*[np.tensordot(W[k], ps, axes=1) / (h / 2**m) ** k for k in (1, 2, 3)], RATES)
                for m, (_, ps) in enumerate(stencils)]
        for k, exact in enumerate((z1, z2, z3), start=1):
            scale = np.maximum(np.abs(exact), np.where(np.array(ck.kinds) == Kind.LENGTH, ck.scale, 1.0))
            err = np.min([np.abs(exact - fd[k - 1]) for fd in fds], axis=0) / scale
            assert np.all(err < FD_TOL[k]), (name, k, x0, exact, [fd[k - 1] for fd in fds])
        # the input itself moves at the requested rates
        assert (z1[i], z2[i], z3[i]) == pytest.approx(RATES)
        if ck.points:
            for k in (1, 2, 3):
                err = np.min([np.abs(pts[k] - fdp[k - 1]) for fdp in fdps], axis=0)
                err = err / np.maximum(np.abs(pts[k]), ck.scale)
                assert np.all(err < FD_TOL[k]), (name, "points", k, x0)
            ps = stencils[0][1]
            assert np.allclose(pts[0], ps[len(OFFSETS) // 2], rtol=0, atol=1e-12 * ck.scale)


def test_finite_difference_check_catches_a_wrong_term(model):
    """Sanity check of the tolerance: dropping the input-acceleration term of q̈ fails it."""
    name, mech, ck = model
    traced = _trace(ck, _samples(ck))
    x0, z0 = _well_conditioned(ck, traced, 1)[0]
    h = _input_step(ck)
    _, z2, _, _, _ = solve_rates(ck, z0, RATES)
    zs, _ = _fd_positions(ck, x0, z0, h)
    d1 = W[1] @ zs / h
    d2 = W[2] @ zs / h**2
    wrong = d2 * RATES[0] ** 2  # missing q' ẍ
    scale = np.maximum(np.abs(z2), np.where(np.array(ck.kinds) == Kind.LENGTH, ck.scale, 1.0))
    moving = np.abs(d1[ck.unknown_idx]) > 1e-3
    if moving.any():
        assert np.max((np.abs(z2 - wrong) / scale)[ck.unknown_idx][moving]) > 100 * FD_TOL[2]


def test_state_rows_match_solver_arrays(model):
    """The public State (display units) carries the same numbers as the raw solve."""
    name, mech, ck = model
    s = mech.solve(speed=RATES[0], accel=RATES[1], jerk=RATES[2])
    row = s.row()
    k = angle_factor(mech.units.angle)
    for j, (n, kind) in enumerate(zip(ck.variables, ck.kinds)):
        if kind is Kind.ANGLE:
            # unknowns are wrapped to (-180, 180]; compare on the circle
            diff = (row[n] * k - s.z[j] + math.pi) % (2 * math.pi) - math.pi
            assert abs(diff) < 1e-12
        else:
            assert row[n] == pytest.approx(s.z[j], rel=1e-14, abs=1e-12 * ck.scale)
        assert row[n + "_vel"] == pytest.approx(s.z1[j], rel=1e-14, abs=1e-300)
        assert row[n + "_acc"] == pytest.approx(s.z2[j], rel=1e-14, abs=1e-300)
        assert row[n + "_jerk"] == pytest.approx(s.z3[j], rel=1e-14, abs=1e-300)


# ----------------------------------------------------------------------------- Jacobians and DOF


def _fd_jacobian(ck, z, columns):
    """Central-difference Jacobian of Φ with respect to z[columns] (relative steps)."""
    cols = []
    for j in columns:
        hj = 1e-6 if ck.kinds[j] is Kind.ANGLE else 1e-6 * ck.scale
        zp, zm = z.copy(), z.copy()
        zp[j] += hj
        zm[j] -= hj
        cols.append((ck.phi(zp) - ck.phi(zm)) / (2 * hj))
    return np.array(cols).T


def test_phi_q_matches_finite_differences(model):
    """Φ_q (compiled from the symbolic Jacobian) equals FD of Φ, at solutions and at random points."""
    name, mech, ck = model
    rng = np.random.default_rng(7)
    z_sol, _, _ = solve_position(ck, initial_z(ck, warn=False))
    zs = [z_sol]
    for _ in range(5):
        z = z_sol.copy()
        for j, kind in enumerate(ck.kinds):
            z[j] += rng.normal() * (0.5 if kind is Kind.ANGLE else 0.1 * ck.scale)
        zs.append(z)
    for z in zs:
        J = ck.jac(z)
        fd = _fd_jacobian(ck, z, ck.unknown_idx)
        assert J.shape == (len(ck.unknowns), len(ck.unknowns))
        assert np.max(np.abs(J - fd)) <= 1e-7 * max(1.0, np.max(np.abs(J)))


def test_dof_is_nullity_of_full_jacobian(model):
    """Mobility = number of inputs = nullity of [Φ_q Φ_x]; Φ_q is regular at generic positions."""
    name, mech, ck = model
    kin = mech.derive()
    import sympy as sp

    subs = dict(zip(kin.params, kin.param_values))
    f_full = sp.lambdify([kin.z], (kin.jac.row_join(kin.jac_inputs)).subs(subs), "numpy")
    traced = _trace(ck, _samples(ck))
    for x, z in _well_conditioned(ck, traced, 6):
        full_sym = np.array(f_full(z), dtype=float)
        # column order of the symbolic full Jacobian: unknowns then inputs
        order = [ck.index(n) for n in kin.unknowns] + [ck.index(n) for n in kin.inputs]
        full_fd = _fd_jacobian(ck, z, order)
        assert np.max(np.abs(full_sym - full_fd)) <= 1e-7 * max(1.0, np.max(np.abs(full_sym)))
        sv = np.linalg.svd(full_sym, compute_uv=False)
        rank = int(np.sum(sv > 1e-9 * sv[0]))
        assert len(ck.variables) - rank == len(mech.inputs) == len(ck.inputs)
        assert np.linalg.matrix_rank(ck.jac(z)) == len(ck.unknowns)


@pytest.mark.parametrize("path", [p for p in MODELS if p.stem in FULL_ROTATION], ids=lambda p: p.stem)
def test_signature_is_constant_along_full_rotation(path):
    """For the full-rotation shipped models the assembly mode never changes around the cycle."""
    mech = ls.load(path)
    ck = mech.compile()
    traced = _trace(ck, _samples(ck))
    sigs = {ck.signature(z) for _, z in traced if z is not None}
    assert len(sigs) == 1
