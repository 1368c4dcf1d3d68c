"""The tracer's natural step, generated per block structure: one source for both engines.

A natural step (:meth:`loopsolve.kinematics.continuation.Tracer._natural_step`) moves the input to
a target value and corrects the unknowns there: predictor from the node's tangent (plus a
second-order term from the previous natural node), Newton corrector solved block by block on
the block-triangular Φ_q, residual test, regularity check of every diagonal block, mode
signature (signs of the block determinants), natural tangent, correction check and the
separation ratio ρ of the new node (:meth:`Kernel.rho <loopsolve.kinematics.scalar_solver.Kernel.rho>`).

:func:`step_source` writes that step for one model *structure* — the solve order of the
diagonal blocks of Φ_q, their sizes (1×1 or 2×2) and the indices of the unknowns — as plain
Python with the structure unrolled: every block solve, determinant and check is written out
on scalars, the indices are constants. The same text serves both engines:

* the Python engine executes it as it is (:func:`python_step`, cached per kernel);
* the ``numba`` engine compiles it with the model's functions and the step loop
  (:mod:`loopsolve.kinematics.numba_engine.jit`, ``flavor="numba"``).

The two flavors differ only in how the corrected point is handed to the model's functions
(Python: the node's list, updated in place; numba: a tuple built by the generated ``zset``, so
that LLVM shares the sines and cosines Φ and Φ_q take of the same angles) and in the numba
flavor's fused rates of the node (single 2×2 block only); every arithmetic operation is the
same text in the same order, so the two engines' nodes agree to round-off and a fix of the
step lands in both.

Structures with a block larger than 2×2, or with more than :data:`MAX_UNKNOWNS` unknowns, have
no generated step (:func:`supported` is False): the tracer takes their natural steps with its
general Python code and the ``numba`` engine has no fast lane for them.
"""

from __future__ import annotations

import math
import types

from .scalar_solver import ROUNDOFF, rho_2x3

__all__ = ["supported", "structure", "step_source", "python_step", "step_config", "sig_of_mask", "mask_of_sig",
           "rho_rows"]


def rho_rows(a, n):
    """σ_min/σ_max of the n × (n+1) matrix ``a`` (flat, row-major) by one-sided Jacobi rotations of its
    rows (:meth:`Kernel.rho <loopsolve.kinematics.scalar_solver.Kernel.rho>` of a generated step with
    more than two unknowns; plain Python that numba compiles as it is). 0 when ``a`` is zero or not finite.
    """
    m = n + 1
    big = 0.0
    for i in range(n * m):
        v = abs(a[i])
        if not v <= big:
            big = v
    if not (0.0 < big < math.inf):
        return 0.0
    r = [0.0] * (n * m)
    for i in range(n * m):
        r[i] = a[i] / big  # a common factor does not change the ratio; no overflow below
    for _ in range(60):
        rotated = False
        for i in range(n - 1):
            for j in range(i + 1, n):
                al = 0.0
                be = 0.0
                ga = 0.0
                for c in range(m):
                    x = r[i * m + c]
                    y = r[j * m + c]
                    al += x * x
                    be += y * y
                    ga += x * y
                if ga != 0.0 and abs(ga) > 1e-15 * math.sqrt(al * be):
                    zeta = (be - al) / (2.0 * ga)
                    t = (1.0 if zeta >= 0 else -1.0) / (abs(zeta) + math.sqrt(1.0 + zeta * zeta))
                    cs = 1.0 / math.sqrt(1.0 + t * t)
                    sn = cs * t
                    for c in range(m):
                        x = r[i * m + c]
                        y = r[j * m + c]
                        r[i * m + c] = cs * x - sn * y
                        r[j * m + c] = sn * x + cs * y
                    rotated = True
        if not rotated:
            break
    smin = math.inf
    smax = 0.0
    for i in range(n):
        s = 0.0
        for c in range(m):
            s += r[i * m + c] * r[i * m + c]
        s = math.sqrt(s)
        smin = min(smin, s)
        smax = max(smax, s)
    if not smax > 0:
        return 0.0
    return smin / smax


def structure(kern):
    """The structure key of a :class:`~loopsolve.kinematics.scalar_solver.Kernel`: ``(n, nv, iu, ix, blocks)``."""
    return (kern.n, kern.nv, tuple(kern.iu), kern.ix, tuple(kern.blocks))


#: the most unknowns a generated step has: its text grows with the square of the unknowns (Φ_q written
#: out entry by entry) and its ρ (:func:`rho_rows`, plain Python) with their cube; larger models (a
#: fan of 40 four-bars) take the general Python step, whose ρ is numpy's SVD
MAX_UNKNOWNS = 12


def supported(kern) -> bool:
    """Whether the natural step of ``kern`` is generated: 1 to :data:`MAX_UNKNOWNS` unknowns, every block 1×1
    or 2×2."""
    return 0 < kern.n <= MAX_UNKNOWNS and all(len(cols) <= 2 for _, cols in kern.blocks)


def step_config(kern) -> list:
    """The floats a generated step reads: ``[tol, roundoff, scale, wx, w_0 .. w_{n-1}]``."""
    return [float(kern.tol), float(ROUNDOFF), float(kern.scale), float(kern.wx)] + [float(w) for w in kern.wu]


def mask_of_sig(sig: str) -> int:
    """The integer signature of a mode signature string (bit j: block j's determinant > 0); -1 with a '0'."""
    if "0" in sig:
        return -1
    return sum(1 << j for j, s in enumerate(sig) if s == "+")


def sig_of_mask(mask: int, nblocks: int) -> str:
    """The mode signature string of an integer signature (:func:`mask_of_sig`)."""
    return "".join("+" if mask >> j & 1 else "-" for j in range(nblocks))


def step_source(kern, flavor: str = "python") -> str:
    """Source of ``natural_step`` for the structure of ``kern`` (``flavor`` ``"python"`` or ``"numba"``).

    ``natural_step(az, at, has_prev, pt, xp, target, near, p, ex, f, max_iter, bz[, rr, orow])``:
    from the node ``(az, at)`` (``pt``, ``xp``: the previous natural node's tangent and input, used
    when ``has_prev``) to input ``target`` (≠ the node's); ``f`` is :func:`step_config`, ``bz`` a copy
    of ``az`` that receives the new point. Returns ``(ok, n_iter, residual, rho, mask, t, J)``: the
    new node's residual, separation ratio, integer signature (:func:`mask_of_sig`), unit tangent
    (scaled, a tuple of n + 1) and Φ_q (flat, of the corrector's last iteration: the point moved
    by a round-off-sized correction since). The numba flavor of a single 2×2 block also writes the
    node's rates (``node_rates``) into ``orow`` when ``rr[3] > 0``.
    """
    if not supported(kern):
        raise ValueError("no generated natural step for a block larger than 2×2")
    if flavor not in ("python", "numba"):
        raise ValueError(f"flavor {flavor!r}")
    n, iu, ix = kern.n, list(kern.iu), kern.ix
    blocks = kern.blocks
    nb = len(blocks)
    single2 = bool(kern.single2)
    numba = flavor == "numba"
    us = ", ".join(f"u{c}" for c in range(n))
    L: list[str] = []

    def w(line: str, ind: int = 1) -> None:
        L.append("    " * ind + line)

    def point(ind: int) -> None:
        if numba:
            w(f"zt = zset(bz, {us})", ind)
        else:
            for c in range(n):
                w(f"bz[{iu[c]}] = u{c}", ind)
            w("zt = bz", ind)

    fail = f"return False, it, 0.0, 0.0, 0, ({'0.0, ' * (n + 1)}), ({'0.0, ' * (n * n)})"
    jn = ", ".join(f"j{e}_{c}" for e in range(n) for c in range(n))
    fn = ", ".join(f"f{e}" for e in range(n))
    args = "az, at, has_prev, pt, xp, target, near, p, ex, f, max_iter, bz" + (", rr, orow" if numba else "")
    L.append(f"def natural_step({args}):")
    w(f'"""Natural step of the structure {tuple(blocks)} (unknowns at {tuple(iu)}, input at {ix}); generated."""')
    w("tol = f[0]")
    w("roundoff = f[1]")
    w("scale = f[2]")
    w("wx = f[3]")
    for c in range(n):
        w(f"w{c} = f[{4 + c}]")
    w(f"tx = at[{n}]")
    w("d = 1.0 if tx > 0 else -1.0")
    w(f"xa = az[{ix}]")
    w("delta = target - xa")
    # predictor: dq/dx from the tangent, plus the second-order term from the previous natural node
    w("r = wx / tx")
    for c in range(n):
        w(f"du{c} = at[{c}] / w{c} * r")
    for c in range(n):
        w(f"pr{c} = az[{iu[c]}] + delta * du{c}")
    w("if has_prev:")
    w("if (xa - xp) * d > 0:", 2)
    w(f"rq = wx / pt[{n}]", 3)
    w("c = 0.5 * delta * delta / (xa - xp)", 3)
    for c in range(n):
        w(f"pr{c} += c * (du{c} - pt[{c}] / w{c} * rq)", 3)
    w(f"bz[{ix}] = target")
    w("tiny = roundoff * (1.0" + "".join(f" + abs(pr{c}) * w{c}" for c in range(n)) + ")")
    w("prev = 0.0")
    for c in range(n):
        w(f"u{c} = pr{c}")
    point(1)
    w(f"{fn}, = phi(zt, p)" if n == 1 else f"{fn} = phi(zt, p)")
    w(f"{jn}, = jac(zt, p)" if n == 1 else f"{jn} = jac(zt, p)")
    for j in range(nb):
        w(f"det{j} = 0.0")
    w(", ".join(f"b{e}" for e in range(n)) + " = " + ", ".join("0.0" for _ in range(n)))
    w("it = 0")
    w("converged = False")
    w("for it in range(1, max_iter + 1):")
    # Newton step -Φ_q⁻¹ Φ, block by block in solve order (the earlier blocks' corrections known)
    done: list[int] = []

    def coupled(e: int, var: str, base: str) -> str:
        return base + "".join(f" + j{e}_{c} * {var}{c}" for c in done)

    for j, (eqs, cols) in enumerate(blocks):
        if len(cols) == 2:
            (e0, e1), (c0, c1) = eqs, cols
            w(f"det{j} = j{e0}_{c0} * j{e1}_{c1} - j{e0}_{c1} * j{e1}_{c0}", 2)
            w(f"if det{j} == 0:", 2)
            w(fail, 3)
            g0, g1 = (f"f{e0}", f"f{e1}") if not done else (f"g{e0}", f"g{e1}")
            if done:
                w(f"g{e0} = " + coupled(e0, "s", f"f{e0}"), 2)
                w(f"g{e1} = " + coupled(e1, "s", f"f{e1}"), 2)
            w(f"s{c0} = (j{e0}_{c1} * {g1} - j{e1}_{c1} * {g0}) / det{j}", 2)
            w(f"s{c1} = (j{e1}_{c0} * {g0} - j{e0}_{c0} * {g1}) / det{j}", 2)
            done += [c0, c1]
        else:
            (e0,), (c0,) = eqs, cols
            w(f"det{j} = j{e0}_{c0}", 2)
            w(f"if det{j} == 0:", 2)
            w(fail, 3)
            w(f"s{c0} = -({coupled(e0, 's', f'f{e0}')}) / det{j}", 2)
            done.append(c0)
    for c in range(n):
        w(f"u{c} += s{c}", 2)
    w("st = " + (f"max({', '.join(f'abs(s{c}) * w{c}' for c in range(n))})" if n > 1 else "abs(s0) * w0"), 2)
    point(2)
    w(f"{fn}, = phi(zt, p)" if n == 1 else f"{fn} = phi(zt, p)", 2)
    w("if st <= tiny or (prev != 0.0 and st * (st / prev) ** 2 <= tiny):", 2)
    w("converged = True", 3)
    bn = ", ".join(f"b{e}" for e in range(n))
    w(f"{bn}, = rhs1(zt, ex, p)" if n == 1 else f"{bn} = rhs1(zt, ex, p)", 3)
    if numba and single2:
        w("if rr[3] > 0:  # the node's rates, fused with the corrector's last Φ (as rates2)", 3)
        w(f"orow[0], orow[1], orow[2], orow[3], orow[4], orow[5], orow[6] = node_rates("
          f"zt, p, {iu[0]}, {iu[1]}, {ix}, rr[0], rr[1], rr[2], rr[3], rr[4])", 4)
    w("break", 3)
    w("if not st < math.inf:", 2)
    w(fail, 3)
    w("prev = st", 2)
    w(f"{jn}, = jac(zt, p)" if n == 1 else f"{jn} = jac(zt, p)", 2)
    if numba:
        for c in range(n):
            w(f"bz[{iu[c]}] = u{c}")
    w("if not converged:")
    w(fail, 2)
    w("res = " + (f"max({', '.join(f'abs(f{e})' for e in range(n))})" if n > 1 else "abs(f0)"))
    w("if not res <= tol:")
    w(fail, 2)
    # regularity of every diagonal block (columns of length unknowns scaled by the length scale)
    for c in range(n):
        w(f"cs{c} = 1.0 / w{c}")
    for j, (eqs, cols) in enumerate(blocks):
        if len(cols) == 2:
            (e0, e1), (c0, c1) = eqs, cols
            A, B, C, D = f"j{e0}_{c0}", f"j{e0}_{c1}", f"j{e1}_{c0}", f"j{e1}_{c1}"
            w(f"nr = 0.5 * (({A} * {A} + {C} * {C}) * cs{c0} * cs{c0} + ({B} * {B} + {D} * {D}) * cs{c1} * cs{c1})")
            w(f"if not abs(det{j}) * cs{c0} * cs{c1} >= near * nr:")
        else:
            w(f"if not min(1.0, abs(det{j} * cs{cols[0]}) / scale) >= near:")
        w(fail, 2)
    # natural tangent: dq/dx = Φ_q⁻¹ b₁, block by block, scaled and oriented along the input direction
    done = []
    for j, (eqs, cols) in enumerate(blocks):
        if len(cols) == 2:
            (e0, e1), (c0, c1) = eqs, cols
            r0, r1 = (f"b{e0}", f"b{e1}") if not done else (f"h{e0}", f"h{e1}")
            if done:
                w(f"h{e0} = b{e0}" + "".join(f" - j{e0}_{c} * v{c}" for c in done))
                w(f"h{e1} = b{e1}" + "".join(f" - j{e1}_{c} * v{c}" for c in done))
            w(f"v{c0} = (j{e1}_{c1} * {r0} - j{e0}_{c1} * {r1}) / det{j}")
            w(f"v{c1} = (j{e0}_{c0} * {r1} - j{e1}_{c0} * {r0}) / det{j}")
            done += [c0, c1]
        else:
            (e0,), (c0,) = eqs, cols
            w(f"v{c0} = (b{e0}" + "".join(f" - j{e0}_{c} * v{c}" for c in done) + f") / det{j}")
            done.append(c0)
    for c in range(n):
        w(f"tn{c} = v{c} * w{c} * d")
    w("tnx = wx * d")
    w("nrm = math.sqrt(" + " + ".join([f"tn{c} * tn{c}" for c in range(n)] + ["tnx * tnx"]) + ")")
    # the corrector stayed near the predictor: it did not jump to another piece of the curve
    w("corr = " + (f"max({', '.join(f'abs(u{c} - pr{c}) * w{c}' for c in range(n))})" if n > 1
                   else "abs(u0 - pr0) * w0"))
    w("step_len = math.sqrt(" + " + ".join([f"((u{c} - az[{iu[c]}]) * w{c}) ** 2" for c in range(n)]
                                          + ["(delta * wx) ** 2"]) + ")")
    w("if corr > 0.25 * step_len + 1e-12:")
    w(fail, 2)
    # separation ratio of the scaled [Φ_q Φ_x] (Φ_x = -b₁)
    rows = [[f"j{e}_{c} * cs{c}" for c in range(n)] + [f"-b{e} / wx"] for e in range(n)]
    if n == 2:
        w(f"rho = rho_2x3({', '.join(rows[0] + rows[1])})")
    else:
        w(f"rho = rho_rows(({', '.join(v for r in rows for v in r)},), {n})")
    w("mask = " + " | ".join(f"({1 << j} if det{j} > 0 else 0)" for j in range(nb)))
    t = ", ".join([f"tn{c} / nrm" for c in range(n)] + ["tnx / nrm"])
    w(f"return True, it, res, rho, mask, ({t},), ({jn},)")
    return "\n".join(L) + "\n"


#: the code of each structure's Python step (a study's many designs of one structure compile it once)
_CODE: dict = {}


def python_step(kern):
    """The generated ``natural_step`` of ``kern`` as a Python function (kept on the kernel), or None
    when its structure has a block larger than 2×2. The code is compiled once per structure; each
    kernel binds it to its own Φ, Φ_q and b₁."""
    step = kern.__dict__.get("_natural_step")
    if step is None and "_natural_step" not in kern.__dict__:
        if supported(kern):
            key = structure(kern)
            code = _CODE.get(key)
            if code is None:
                ns: dict = {}
                exec(compile(step_source(kern, "python"), f"<loopsolve natural step {key}>", "exec"), ns)
                code = _CODE[key] = ns["natural_step"].__code__
            ns = {"math": math, "phi": kern.phi_f, "jac": kern.jac_f, "rhs1": kern.rhs1_f, "rho_2x3": rho_2x3,
                  "rho_rows": rho_rows}
            step = types.FunctionType(code, ns, "natural_step")
        kern._natural_step = step
        kern._step_config = step_config(kern) if step is not None else None
        # the signature strings of the integer signatures (at most 2^MAX_UNKNOWNS)
        kern._sigs = [sig_of_mask(m, len(kern.blocks)) for m in range(1 << len(kern.blocks))] if step is not None \
            else None
    return step
