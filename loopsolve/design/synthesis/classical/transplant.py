"""A classical four-bar design written into the user's own model: its names kept, its values found.

Why: Freudenstein and Burmester compute a four-bar as pivots and pins (their own model, with
their own names). A user who synthesizes with ``-o design.toml`` reads the design back with the
names of the model they gave (``B_x`` is their coupler pin, not whatever the method calls B), so
the design must be *their* model with values in it — as the general method writes it
(:func:`loopsolve.design.synthesis.design_model.design_model`: the parameter values and, as guesses, the pose at
the first target).

How: :func:`fourbar_layout` finds the model's four-bar (the loop of four vectors of constant
length, one of fixed direction: the frame) and, from the loop's walk (the left side forward, the
right side backward, as :mod:`loopsolve.kinematics.info` reads it), which end of each side is the
ground pivot, so every vector of the loop is a known signed difference of two joints.
:func:`transplant` then finds the values: unknowns are the model's parameters (internal units,
link lengths kept positive) and, at every precision configuration, the variables the task does
not fix; residuals are the differences between each loop vector (from the model's compiled
vector kernel) and the classical design's joints, and between the model's task point and the
design's. Least squares from the model's own values; where no parameter can give a vector its
direction (a negative Freudenstein length is a link pointing the other way; a Burmester coupler
whose pins are not along the pose's angle), the numeric ``offset`` of that vector is changed
(added to), the only change to the declaration besides values and guesses, and the report lists
it. A design the model cannot hold (its frame is not a parameter, the task point is a joint, a
length is a constant) is refused with the reason. The result is checked: the written model,
solved at every configuration, must give the design's joints and task point (to 1e-9 of the
design's size).
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field

import numpy as np

from ....errors import ModelError
from ....model.units import Kind

__all__ = ["FourBarLayout", "fourbar_layout", "Transplant", "transplant", "offset_text"]

_OFF = "ls_offset_"



@dataclass(frozen=True)
class FourBarLayout:
    """Which vector of the model is which link, and how it runs between the joints.

    ``vectors``: role (``ground``, ``input``, ``coupler``, ``output``) → vector name; ``ends``:
    role → ``(sign, tail joint, head joint)`` with the vector equal to ``sign·(head − tail)``
    (joints ``O2``, ``A``, ``B``, ``O4``: input pivot, input pin, output pin, output pivot);
    ``variables``: role → the variable of the vector's angle (None for the ground).
    """

    loop: str
    vectors: dict
    ends: dict
    variables: dict


def fourbar_layout(mech, method: str) -> FourBarLayout:
    """The four-bar of ``mech`` for ``--method method``, or a :class:`ModelError` saying why not."""
    from ....kinematics.info import loop_walk
    from ....model import expr as _expr

    try:
        fbs = mech.info(reach=False).get("fourbars") or []
    except Exception as exc:  # noqa: BLE001 — any failure to read the model is "not a four-bar" here
        raise ModelError(f"--method {method}: cannot read the four-bar of {mech.name!r} ({exc}); use the general "
                         "method") from None
    if len(mech.loops) != 1 or len(fbs) != 1:
        raise ModelError(f"--method {method} is for four-bar models (one loop of four vectors, one input); "
                         f"{mech.name!r} has {len(mech.loops)} loop(s): use the general method")
    fb = fbs[0]
    links = fb["links"]
    loop = mech.loops[0]
    walk = loop_walk(loop)
    names = [n for _, n in walk]
    sign = {n: s for s, n in walk}
    k = names.index(links["ground"])
    order = names[k:] + names[:k]  # frame, side 1, coupler, side 3
    side1 = order[1]
    joints = {}
    if side1 == links["input"]:  # frame: O4 -> O2, side 1: O2 -> A, coupler: A -> B, side 3: B -> O4
        joints = {"ground": ("O4", "O2"), "input": ("O2", "A"), "coupler": ("A", "B"), "output": ("B", "O4")}
    else:  # frame: O2 -> O4, side 1: O4 -> B, coupler: B -> A, side 3: A -> O2
        joints = {"ground": ("O2", "O4"), "output": ("O4", "B"), "coupler": ("B", "A"), "input": ("A", "O2")}
    var_names = {v.name for v in mech.variables}
    variables, ends, vectors = {}, {}, {}
    for role, vname in links.items():
        v = mech.vector(vname)
        if v.cartesian:
            raise ModelError(f"--method {method}: the {role} link {vname} is a Cartesian vector; the classical "
                             "methods need polar links (length, angle)")
        av = (_expr.names(v.angle) | (_expr.names(v.offset) if v.offset is not None else set())) & var_names
        variables[role] = next(iter(av)) if av else None
        vectors[role] = vname
        ends[role] = (sign[vname],) + joints[role]
    return FourBarLayout(loop.name, vectors, ends, variables)


@dataclass
class Transplant:
    """The user's model with a classical design's values: ``mechanism`` (built), ``spec`` (its dict),
    ``parameters`` (model units, every parameter), ``offsets`` (vector → degrees or radians added, model
    angle unit), ``Z`` ``(nvar, n)`` the positions at the configurations (internal units)."""

    mechanism: object
    spec: dict
    parameters: dict
    offsets: dict
    Z: np.ndarray = field(repr=False)


def offset_text(old, delta: float):
    """A vector's ``offset`` entry with ``delta`` (model units) added: a number stays a number."""
    if old is None:
        return round(float(delta), 12)
    if isinstance(old, (int, float)) and not isinstance(old, bool):
        return round(float(old) + float(delta), 12)
    return f"({old}) + {round(float(delta), 12)!r}"


def _probe(mech, names):
    """The model with one angle parameter added to the offset of each vector of ``names`` (value 0)."""
    from ....model.spec import build_mechanism

    spec = copy.deepcopy(mech.spec)
    params = spec.setdefault("parameters", {})
    for n in names:
        v = spec["vectors"][n]
        old = v.get("offset")
        v["offset"] = f"{_OFF}{n}" if old is None else f"({old}) + {_OFF}{n}"
        params[f"{_OFF}{n}"] = 0
    return build_mechanism(spec, source=mech.source or mech.name)


def _names(v) -> set:
    from ....model import expr as _expr

    out = set()
    for f in ("length", "angle", "offset", "x", "y"):
        n = getattr(v, f)
        if n is not None:
            out |= _expr.names(n)
    return out


def _wrap(a):
    return (np.asarray(a) + math.pi) % (2 * math.pi) - math.pi


def transplant(mech, layout: FourBarLayout, joints, known, *, point: str | None = None, what: str,
               cache: dict | None = None) -> Transplant:
    """Put a classical four-bar into ``mech``: see the module docstring.

    Parameters
    ----------
    joints : list of dict
        At each configuration, the design's joints ``O2``, ``A``, ``B``, ``O4`` (and ``P``, the
        task point, when ``point`` is given) as ``(x, y)`` in the model's length unit.
    known : list of dict
        At each configuration, the variables the task fixes (internal units), e.g. the input and
        the output of a function generator, the coupler angle of a motion.
    point : str, optional
        The model's point that must be at ``P``.
    what : str
        The method's name for the messages.
    cache : dict, optional
        Keeps the compiled probe model between calls on the same model (many candidates).
    """
    from scipy.optimize import least_squares

    from ....model.modelfile import dumps, loads
    from ....model.spec import checked_links

    ck0 = mech.compile()
    polar = [v.name for v in mech.vectors if not v.cartesian]
    movable = set(layout.vectors.values())
    if point is not None:
        pt = next(p for p in mech.points if p.name == point)
        movable |= {n for _, n in pt.terms if n in polar}
    movable = [n for n in polar if n in movable]
    key = ("probe", tuple(movable))
    if cache is not None and key in cache:
        probe = cache[key]
    else:
        probe = _probe(mech, movable)
        if cache is not None:
            cache[key] = probe
    ck = probe.compile()
    pnames = [p.name for p in mech.parameters]
    npar = len(pnames)
    p0 = np.array([p.value for p in probe.parameters], dtype=float)
    offs_ix = [next(i for i, p in enumerate(probe.parameters) if p.name == f"{_OFF}{n}") for n in movable]
    vix = {n: ck.vectors.index(n) for n in ck.vectors}
    roles = list(layout.vectors)
    n_cfg = len(joints)
    scale = max(max(np.linalg.norm(np.asarray(j[a], float) - np.asarray(j[b], float)) for j in joints
                    for a, b in (("O2", "A"), ("A", "B"), ("B", "O4"), ("O4", "O2"))), 1e-300)
    # the variables each configuration leaves free, and the vectors' required world values
    nv = len(ck.variables)
    free = [[i for i, v in enumerate(ck.variables) if v not in kn] for kn in known]
    want = []
    for j in joints:
        w = {}
        for role in roles:
            s, tail, head = layout.ends[role]
            w[layout.vectors[role]] = s * (np.asarray(j[head], float) - np.asarray(j[tail], float))
        want.append(w)
    # length parameters of links stay positive (a model refuses a link of negative length)
    # and a loop vector's length parameter keeps its sign (a ground of length -49.5 turned by half a turn is the
    # same frame, but not what a designer reads)
    from ....model import expr as _expr

    link_len = set()
    for v in checked_links(mech.vectors, mech.parameters, mech.variables):
        if isinstance(v.length, _expr.Name) and v.length.id in pnames:
            link_len.add(v.length.id)
    negative = set()
    for n in layout.vectors.values():
        v = mech.vector(n)
        if isinstance(v.length, _expr.Name) and v.length.id in pnames:
            (negative if p0[pnames.index(v.length.id)] < 0 else link_len).add(v.length.id)
    lo = np.array([1e-12 * scale if n in link_len else -np.inf for n in pnames])
    hi = np.array([-1e-12 * scale if n in negative else np.inf for n in pnames])

    known_ix = [[ck.index(nm) for nm in kn] for kn in known]
    known_val = [[float(v) for v in kn.values()] for kn in known]
    n_fit = len(roles) * 2 * n_cfg + (2 * n_cfg if point else 0)
    ipt = ck.points.index(point) if point is not None else None
    wantv = np.array([[want[c][layout.vectors[r]] for r in roles] for c in range(n_cfg)])  # (cfg, roles, 2)
    rvix = [vix[layout.vectors[r]] for r in roles]
    Pwant = np.array([np.asarray(j["P"], float) for j in joints]) if point is not None else None

    def z_of(u, offs):
        p = p0.copy()
        p[:npar] = u[:npar]
        p[[offs_ix[k] for k in offs]] = u[npar:npar + len(offs)]
        Z = np.zeros((nv, n_cfg))
        a = npar + len(offs)
        for c in range(n_cfg):
            Z[known_ix[c], c] = known_val[c]
            Z[free[c], c] = u[a:a + len(free[c])]
            a += len(free[c])
        return p, Z

    free_rows = [(c, i) for c in range(n_cfg) for i in free[c]]

    def fit_many(U, offs):
        """Fit residuals ``(n_fit, K)`` of the unknown vectors ``U`` ``(n_u, K)``: one kernel call for all."""
        K = U.shape[1]
        P = np.repeat(p0[:, None], K, axis=1)
        P[:npar] = U[:npar]
        P[[offs_ix[k] for k in offs]] = U[npar:npar + len(offs)]
        Z = np.zeros((nv, K, n_cfg))
        for c in range(n_cfg):
            Z[known_ix[c], :, c] = np.asarray(known_val[c])[:, None]
        a = npar + len(offs)
        for r, (c, i) in enumerate(free_rows):
            Z[i, :, c] = U[a + r]
        Zf, Pf = Z.reshape(nv, K * n_cfg), np.repeat(P, n_cfg, axis=1)
        try:
            with np.errstate(all="ignore"):
                vals = np.asarray(ck.module.vectors0_v(Zf, Pf), dtype=float).reshape(-1, 2, K, n_cfg)
                L, th = vals[rvix, 0], vals[rvix, 1]  # (roles, K, cfg)
                V = np.stack([L * np.cos(th), L * np.sin(th)], axis=-1) - wantv.transpose(1, 0, 2)[:, None]
                out = [V.transpose(2, 0, 3, 1).reshape(-1, K)]  # rows: cfg, role, xy
                if ipt is not None:
                    pts = np.asarray(ck.module.points0_v(Zf, Pf), dtype=float).reshape(-1, 2, K, n_cfg)[ipt]
                    out.append((pts - Pwant.T[:, None, :]).transpose(2, 0, 1).reshape(-1, K))
        except (ArithmeticError, ValueError):
            return np.full((n_fit, K), 1e6)
        R = np.concatenate(out, axis=0) / scale
        return np.where(np.isfinite(R), R, 1e6)

    def fit_resid(u, offs):
        return fit_many(np.asarray(u, dtype=float)[:, None], offs)[:, 0]

    def fd_jac(u, offs):
        """Forward differences, every column in the same kernel call."""
        h = 1e-7 * np.maximum(1.0, np.abs(u))
        U = np.column_stack([u, u[:, None] + np.diag(h)])
        R = fit_many(U, offs)
        return (R[:, 1:] - R[:, :1]) / h

    def resid(u, offs):
        return fit_resid(u, offs)

    def held(u, offs):
        """Parameters the fit cannot tell from the free variables or from earlier parameters (e.g. an input
        phase when the timing is free): their columns add nothing to the rank of the fit's Jacobian."""
        J = fd_jac(u, offs)
        acc = J[:, npar + len(offs):]
        out = np.zeros(npar, dtype=bool)
        for i in range(npar):
            col = J[:, i]
            size = float(np.linalg.norm(col))
            if acc.shape[1]:
                rest = col - acc @ np.linalg.lstsq(acc, col, rcond=None)[0]
            else:
                rest = col
            if size == 0.0 or float(np.linalg.norm(rest)) <= 1e-5 * size:
                out[i] = True
            else:
                acc = np.column_stack([acc, col])
        return out

    def start_free(p):
        """Each free variable from the direction its vector must take (the vector's angle is var + c)."""
        u = []
        for c in range(n_cfg):
            z = np.zeros(nv)
            for name, val in known[c].items():
                z[ck.index(name)] = val
            for i in free[c]:
                var = ck.variables[i]
                role = next((r for r in roles if layout.variables[r] == var), None)
                if role is None:
                    u.append(0.0)
                    continue
                n = layout.vectors[role]
                z0 = z.copy()
                z0[i] = 0.0
                z1 = z.copy()
                z1[i] = 1.0
                a0 = float(ck.module.vectors0(z0, p)[2 * vix[n] + 1])
                a1 = float(ck.module.vectors0(z1, p)[2 * vix[n] + 1])
                k = a1 - a0
                target = math.atan2(want[c][n][1], want[c][n][0])
                u.append(float((math.remainder(target - a0, 2 * math.pi)) / k) if abs(abs(k) - 1) < 1e-9 else 0.0)
        return np.array(u)

    def solve(offs, u_start):
        lb = np.r_[lo, np.full(len(offs), -np.inf), np.full(sum(map(len, free)), -np.inf)]
        ub = np.r_[hi, np.full(len(lb) - npar, np.inf)]
        hold = np.r_[held(np.clip(u_start, lb, ub), offs), np.zeros(len(u_start) - npar, dtype=bool)]
        width = np.maximum(1e-12 * np.maximum(np.abs(u_start), 1.0), 1e-300)
        lb = np.where(hold, u_start - width, lb)  # a held parameter stays (within round-off) where it is
        ub = np.where(hold, u_start + width, ub)
        with np.errstate(invalid="ignore"):  # -inf + inf on an unbounded side: np.where keeps the bound
            u_start = np.clip(u_start, np.where(np.isfinite(lb), lb + 1e-12 * np.abs(lb) + 1e-300, lb),
                              np.where(np.isfinite(ub), ub - 1e-12 * np.abs(ub) - 1e-300, ub))
        res = least_squares(resid, u_start, jac=fd_jac, args=(offs,), bounds=(lb, ub), method="trf", xtol=1e-15,
                            ftol=1e-15, gtol=1e-15, max_nfev=400)
        x = np.where(hold, u_start, res.x)  # exactly the model's own value
        return x, float(np.max(np.abs(fit_resid(x, offs))))

    def mismatch(u, offs):
        """Per moving vector of the loop: its largest miss (the fit residual's rows for it)."""
        r = fit_resid(u, offs)[:len(roles) * 2 * n_cfg].reshape(n_cfg, len(roles), 2)
        return {layout.vectors[ro]: float(np.max(np.abs(r[:, k]))) for k, ro in enumerate(roles)}

    def needed(u, offs, names):
        """The turn each vector of ``names`` still misses at the first configuration."""
        p, Z = z_of(u, offs)
        out = []
        for n in names:
            th = float(ck.module.vectors0(Z[:, 0], p)[2 * vix[n] + 1])
            role = next((r for r in roles if layout.vectors[r] == n), None)
            fixed = role is not None and (layout.variables[role] is None or layout.variables[role] in known[0])
            out.append(math.remainder(math.atan2(want[0][n][1], want[0][n][0]) - th, 2 * math.pi) if fixed else 0.0)
        return out

    pstart = np.clip(p0[:npar], lo, hi)
    pfull = p0.copy()
    pfull[:npar] = pstart
    offs = []
    u, err = solve(offs, np.r_[pstart, start_free(pfull)])
    if err > 1e-10:  # a link that must point the other way starts where its angle parameter is stationary:
        # try each angle parameter turned by half a turn (the least shared first)
        ang = [i for i in range(npar) if mech.parameters[i].kind is Kind.ANGLE]
        uses = {i: sum(mech.parameters[i].name in _names(v) for v in mech.vectors) for i in ang}
        for i in sorted(ang, key=lambda i: uses[i]):
            q = pfull.copy()
            q[i] += math.pi
            u2, err2 = solve(offs, np.r_[q[:npar], start_free(q)])
            if err2 < err:
                u, err = u2, err2
            if err <= 1e-10:
                break
    if err > 1e-10:  # no parameter gives some vector its direction: that vector's offset changes too
        # only vectors whose direction no parameter turns (else a parameter and the offset would trade off)
        pz, Zz = z_of(u, offs)
        base = np.asarray(ck.module.vectors0(Zz[:, 0], pz), dtype=float).reshape(-1, 2)[:, 1]
        turned = set()
        for i in range(npar):
            q = pz.copy()
            q[i] += 1e-3
            moved = np.asarray(ck.module.vectors0(Zz[:, 0], q), dtype=float).reshape(-1, 2)[:, 1]
            turned |= {n for n in movable if abs(math.remainder(moved[vix[n]] - base[vix[n]], 2 * math.pi)) > 1e-9}
        fixed_dir = [n for n in movable if n not in turned]
        miss = mismatch(u, offs)
        links = [movable.index(n) for n in fixed_dir if miss.get(n, 0.0) > 1e-8]
        tries = [links, [movable.index(n) for n in fixed_dir]]
        for cand in tries:
            if not cand or cand == offs:
                continue
            p_try, _ = z_of(u, offs)
            d0 = needed(u, offs, [movable[k] for k in cand])
            p_try[[offs_ix[k] for k in cand]] = d0
            u2, err2 = solve(cand, np.r_[u[:npar], d0, start_free(p_try)])
            if err2 < err:
                u, err, offs = u2, err2, cand
            if err <= 1e-10:
                break
    if err > 1e-9:
        raise ModelError(_why(mech, layout, point, what, err * scale))
    p, Zm = z_of(u, offs)
    Zs = [Zm[:, c] for c in range(n_cfg)]
    # write: the parameters (model units), changed offsets, the guesses at the first configuration
    deg = mech.units.angle == "deg"
    spec = copy.deepcopy(mech.spec)
    params = spec.setdefault("parameters", {})
    values = {}
    for i, par in enumerate(mech.parameters):
        v = float(p[i])
        if par.kind is Kind.ANGLE:  # within half a turn of the model's own value
            v = float(p0[i] + math.remainder(v - p0[i], 2 * math.pi))
        if par.kind is Kind.ANGLE and deg:
            v = math.degrees(v)
        values[par.name] = v
        params[par.name] = v
    offsets = {}
    for k in offs:
        n, ix = movable[k], offs_ix[k]
        if True:
            d = -float(_wrap(-p[ix]))  # in (-half turn, half turn]
            if abs(d) > 1e-12:
                dm = math.degrees(d) if deg else d
                spec["vectors"][n]["offset"] = offset_text(spec["vectors"][n].get("offset"), dm)
                offsets[n] = dm
    variables = spec.get("variables", {})
    z0 = Zs[0]
    for i, name in enumerate(ck0.variables):
        val = float(z0[ck.index(name)])
        if ck0.kinds[i] is Kind.ANGLE:
            val = math.degrees(math.remainder(val, 2 * math.pi)) if deg else math.remainder(val, 2 * math.pi)
        entry = variables.get(name)
        if isinstance(entry, dict):
            entry["guess"] = round(val, 12)
        else:
            variables[name] = {"guess": round(val, 12)}
    try:
        out = loads(dumps(spec), source=mech.source or "<synthesized>")
    except ModelError as exc:
        raise ModelError(f"--method {what}: the design does not fit {mech.name!r}: {exc}") from None
    Z = np.column_stack([np.array([z[ck.index(n)] for n in ck0.variables]) for z in Zs])
    _verify(out, layout, joints, Z, point, scale, what)
    return Transplant(out, spec, values, offsets, Z)


def _verify(mech, layout, joints, Z, point, scale, what):
    """The written model at every configuration: its loop closes and its vectors and point are the design's."""
    ck = mech.compile()
    for c in range(Z.shape[1]):
        z = Z[:, c]
        bad = float(np.max(np.abs(ck.phi(z)))) > 1e-9 * scale
        vals = ck.vector_values(0, z)
        for role, n in layout.vectors.items():
            s, tail, head = layout.ends[role]
            w = s * (np.asarray(joints[c][head], float) - np.asarray(joints[c][tail], float))
            L, th = vals[ck.vectors.index(n)]
            bad |= float(np.linalg.norm(L * np.array([math.cos(th), math.sin(th)]) - w)) > 1e-9 * scale
        if point is not None:
            P = ck.point_values(0, z)[ck.points.index(point)]
            bad |= float(np.linalg.norm(P - np.asarray(joints[c]["P"], float))) > 1e-9 * scale
        if bad:
            raise ModelError(f"--method {what}: the design written into {mech.name!r} does not reproduce the "
                             f"{what} four-bar at configuration {c + 1}; use the general method")


def _why(mech, layout, point, what, err) -> str:
    """Why the model cannot hold the design: what a designer would change."""
    cart = [v.name for v in mech.vectors if v.cartesian]
    hint = []
    if point is not None and not cart:
        hint.append("its frame (the ground pivot's place) is not a parameter: add a vector such as "
                    "r0 = { x = \"x0\", y = \"y0\" } to the points, and a ground angle parameter, as "
                    "models/fourbar_path_synthesis.toml does")
    if point is not None:
        hint.append(f"point {point} must be a coupler point placed by parameters (e.g. "
                    "P = \"r0 + r2 + rcx*u3 + rcy*n3\")")
    return (f"--method {what}: {mech.name!r} cannot hold the {what} four-bar (off by {err:.3g} "
            f"{mech.units.length}): " + "; ".join(hint or ["a link's length or direction is not a parameter"])
            + "; or use the general method (--vary)")
