"""Benchmark of loopsolve sweeps against closed forms, scipy and the PyPI peers (not a test).

Thesis crank-rocker four-bar (r1 = 60, r2 = 25, r3 = 70, r4 = 45 mm, open mode, crank at
10 rpm), positions + velocities + accelerations of the coupler and rocker angles. Prints, in
one run, the median times, the ratios against the vectorized closed form
(:mod:`loopsolve.kinematics.classic`: half-angle position, velocity and acceleration formulas) and each
method's largest error against it:

1. a 360-point tracked cycle: loopsolve tracked and batched, closed form, scipy ``fsolve``
   per point (with the analytic Jacobian, warm-started; rates by a 2×2 solve per point),
   ``pylinkage`` (pure-Python ``step_with_derivatives`` and ``step_fast_with_kinematics``, numba-compiled
   when numba is installed)
   and ``mechanism`` (``Mechanism.iterate``: fsolve for positions, velocities and accelerations);
2. 10⁶ points: loopsolve batched against the closed form (positions, velocities and
   accelerations: ``derivatives=2``; and with the jerks as well);
3. a fresh-process ``loopsolve sweep`` of a cached model against ``python -c "import numpy"``;
4. (``--overhead``) the per-call cost of a short sweep (10 rows, pos/vel/acc) with the default
   settings, against ``pylinkage``'s numba kernel for 10 steps and a hand-written numba closed
   form of the same 10 points (the floor), interleaved in one process.

Run from the repository root::

    pip install -e .[bench]
    python benchmarks/bench_sweep.py            # --quick for fewer repeats
    python benchmarks/bench_sweep.py --issue21  # issue 21's four rows as ratios (also runs bench_study's)
    python benchmarks/bench_sweep.py --overhead # issue 32's item 2: a 10-row sweep against pylinkage's call

A peer that does not import is skipped with the reason printed.
"""

from __future__ import annotations

import argparse
import math
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import loopsolve as ls
from loopsolve.kinematics import classic as C

R1, R2, R3, R4 = 60.0, 25.0, 70.0, 45.0
OMEGA = 10 * 2 * math.pi / 60  # 10 rpm
ROOT = Path(__file__).resolve().parents[1]
MODEL = ROOT / "models" / "thesis_crank_rocker.toml"


def median_time(fn, repeats, setup=None):
    times = []
    out = None
    for _ in range(repeats):
        arg = setup() if setup else None
        t = time.perf_counter()
        out = fn(arg) if setup else fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times), out


# ----------------------------------------------------------------------------- methods
# each returns (theta2, theta3, theta4, w3, w4, a3, a4) as arrays in radians / rad/s / rad/s^2


def closed_form(x):
    t3, t4 = C.fourbar_position(R1, R2, R3, R4, x, 1)
    w3, w4 = C.fourbar_velocity(R2, R3, R4, x, t3, t4, OMEGA)
    a3, a4 = C.fourbar_acceleration(R2, R3, R4, x, t3, t4, OMEGA, w3, w4, 0.0)
    return x, t3, t4, w3, w4, a3, a4


def loopsolve_sweep(mech, ck, start, stop, step, method, derivatives=2, engine="python"):
    def run():
        sw = ls.sweep(mech, start, stop, step, speed=OMEGA, accel=0.0, compiled=ck, method=method, progress=False,
                      max_rows=2_000_000,
                      derivatives=derivatives, engine=engine)
        z, z1, z2 = sw.z, sw.z1, sw.z2
        return z[:, 0], z[:, 1], z[:, 2], z1[:, 1], z1[:, 2], z2[:, 1], z2[:, 2]

    return run


def scipy_fsolve(x):
    from scipy.optimize import fsolve

    def f(q, t2):
        t3, t4 = q
        return [R2 * math.cos(t2) + R3 * math.cos(t3) - R1 - R4 * math.cos(t4),
                R2 * math.sin(t2) + R3 * math.sin(t3) - R4 * math.sin(t4)]

    def jac(q, t2):
        t3, t4 = q
        return [[-R3 * math.sin(t3), R4 * math.sin(t4)], [R3 * math.cos(t3), -R4 * math.cos(t4)]]

    out = np.empty((len(x), 6))
    q = np.radians([33.2, 58.4])
    for i, t2 in enumerate(x):
        q = fsolve(f, q, args=(t2,), fprime=jac, xtol=1e-12)
        t3, t4 = q
        J = np.array(jac(q, t2))
        w = np.linalg.solve(J, [R2 * OMEGA * math.sin(t2), -R2 * OMEGA * math.cos(t2)])
        b2 = [R2 * OMEGA**2 * math.cos(t2) + R3 * w[0] ** 2 * math.cos(t3) - R4 * w[1] ** 2 * math.cos(t4),
              R2 * OMEGA**2 * math.sin(t2) + R3 * w[0] ** 2 * math.sin(t3) - R4 * w[1] ** 2 * math.sin(t4)]
        a = np.linalg.solve(J, b2)
        out[i] = (t3, t4, w[0], w[1], a[0], a[1])
    return (x,) + tuple(out.T)


def _angles_from_points(B, Cp, vB, vC, aB, aC):
    """Coupler/rocker angles and rates from joint positions, velocities, accelerations (n, 2)."""
    r3 = Cp - B
    r4 = Cp - np.array([R1, 0.0])
    t3 = np.arctan2(r3[:, 1], r3[:, 0])
    t4 = np.arctan2(r4[:, 1], r4[:, 0])

    def cross(a, b):
        return a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]

    w3 = cross(r3, vC - vB) / np.sum(r3 * r3, axis=1)
    w4 = cross(r4, vC) / np.sum(r4 * r4, axis=1)
    a3 = cross(r3, aC - aB) / np.sum(r3 * r3, axis=1)
    a4 = cross(r4, aC) / np.sum(r4 * r4, axis=1)
    return t3, t4, w3, w4, a3, a4


def pylinkage_build():
    import pylinkage as pl

    o1 = pl.Ground(0.0, 0.0, name="O2")
    o2 = pl.Ground(R1, 0.0, name="O4")
    crank = pl.Crank(anchor=o1, radius=R2, angular_velocity=2 * math.pi / 360, initial_angle=0.0, name="B")
    t4 = math.radians(58.41)
    rocker = pl.RRRDyad(crank.output, o2, distance1=R3, distance2=R4, x=R1 + R4 * math.cos(t4),
                        y=R4 * math.sin(t4), name="C")
    linkage = pl.Linkage([o1, o2, crank, rocker], name="thesis")
    linkage.set_input_velocity(crank, omega=OMEGA, alpha=0.0)
    return linkage


def pylinkage_python(linkage):
    pos, vel, acc = [], [], []
    for p, v, a in linkage.step_with_derivatives(iterations=360):
        pos.append(p)
        vel.append(v)
        acc.append(a)
    return pos, vel, acc


def pylinkage_fast(linkage):
    return linkage.step_fast_with_kinematics(iterations=360)


def pylinkage_result(raw, fast):
    if fast:
        pos, vel, acc = (np.asarray(a, dtype=float) for a in raw)
    else:
        pos = np.array([[list(q) for q in p] for p in raw[0]], dtype=float)
        vel = np.array([[list(q) if q is not None else [0, 0] for q in v] for v in raw[1]], dtype=float)
        acc = np.array([[list(q) if q is not None else [0, 0] for q in a] for a in raw[2]], dtype=float)
    B, Cp = pos[:, 2], pos[:, 3]
    x = np.arctan2(B[:, 1], B[:, 0])
    return (x,) + _angles_from_points(B, Cp, vel[:, 2], vel[:, 3], acc[:, 2], acc[:, 3])


def mechanism_build(x):
    from mechanism import Mechanism, Vector, get_joints

    O, A, B, D = get_joints("O A B D")
    a = Vector((O, A), r=R2)
    b = Vector((A, B), r=R3)
    c = Vector((O, D), r=R1, theta=0, style="ground")
    d = Vector((D, B), r=R4)

    def loops(q, inp):
        return a(inp) + b(q[0]) - c() - d(q[1])

    guess = (np.radians([33.2, 58.4]), np.array([-0.78, -0.78]), np.array([0.9, 2.0]))
    m = Mechanism(vectors=(a, b, c, d), origin=O, loops=loops, pos=x, vel=np.full(len(x), OMEGA),
                  acc=np.zeros(len(x)), guess=guess)
    return m, (b, d)


def mechanism_run(built):
    m, _ = built
    m.iterate()
    return built


def mechanism_result(x, built):
    _, (b, d) = built
    return (x, b.pos.thetas.copy(), d.pos.thetas.copy(), b.vel.omegas.copy(), d.vel.omegas.copy(),
            b.acc.alphas.copy(), d.acc.alphas.copy())


def max_error(res, ref_fn):
    x = np.asarray(res[0], dtype=float)
    ref = ref_fn(x)
    err = 0.0
    for k in range(1, 7):
        d = np.asarray(res[k], dtype=float) - ref[k]
        if k <= 2:
            d = (d + math.pi) % (2 * math.pi) - math.pi
        err = max(err, float(np.max(np.abs(d))))
    return err


# ----------------------------------------------------------------------------- report


def table(title, rows, base):
    print(f"\n{title}")
    print(f"{'method':72s} {'median':>11s} {'vs closed form':>15s} {'max error':>10s}")
    for name, t, err in rows:
        if t is None:
            print(f"{name:72s} {'skipped':>11s}   {err}")
            continue
        print(f"{name:72s} {t * 1e3:9.2f} ms {t / base:14.2f}x {err:10.1e}")


def cli_times(repeats):
    """Medians of a fresh-process cached ``loopsolve sweep`` (361-row CSV) and of ``python -c "import numpy"``."""
    exe = shutil.which("loopsolve")
    cli = [exe] if exe else [sys.executable, "-m", "loopsolve.cli"]
    cmd = cli + ["sweep", str(MODEL), "--from", "0", "--to", "360", "--step", "1", "--format", "csv",
                 "-o", os.devnull, "-q"]
    subprocess.run(cmd, check=True, capture_output=True)  # make sure the compiled model is cached
    bare = [sys.executable, "-c", "import numpy"]
    t_cli, t_np = [], []
    for _ in range(repeats):
        for c_, acc in ((bare, t_np), (cmd, t_cli)):
            t = time.perf_counter()
            subprocess.run(c_, check=True, capture_output=True)
            acc.append(time.perf_counter() - t)
    return statistics.median(t_cli), statistics.median(t_np)


def issue21(args):
    """The four rows of issue 21's table, as ratios, in one run (rows 2 and 3 from bench_study.py)."""
    mech = ls.load(MODEL)
    ck = mech.compile()
    print("== issue 21: one tracked 360-point cycle (pos/vel/acc) against pylinkage's numba kernel ==")
    try:
        import numba  # noqa: F401
        import pylinkage  # noqa: F401
    except ImportError as exc:
        print(f"ROW 1  skipped: {exc} (pip install numba pylinkage)")
        t_pl = None
    else:
        tracked = {eng: loopsolve_sweep(mech, ck, 0, 359, 1, "tracked", derivatives=2, engine=eng)
                   for eng in ("numba", "python")}
        for fn in tracked.values():
            fn()  # numba: load or compile the model's fast lane outside the timing
        ref = loopsolve_sweep(mech, ck, 0, 359, 1, "tracked", derivatives=2)()
        agree = max(float(np.max(np.abs(np.asarray(u) - np.asarray(v))))
                    for u, v in zip(tracked["numba"](), ref))
        pylinkage_fast(pylinkage_build())  # JIT outside the timing
        t_ls = {eng: [] for eng in tracked}
        t_pl = []
        for _ in range(args.repeats):  # interleaved: all see the same load
            for eng, fn in tracked.items():
                t = time.perf_counter()
                fn()
                t_ls[eng].append(time.perf_counter() - t)
            lk = pylinkage_build()
            t = time.perf_counter()
            pylinkage_fast(lk)
            t_pl.append(time.perf_counter() - t)
        b = statistics.median(t_pl)
        print(f"pylinkage step_fast_with_kinematics (numba): {b * 1e3:.3f} ms (best {min(t_pl) * 1e3:.3f})")
        for eng, ts in t_ls.items():
            a = statistics.median(ts)
            print(f"loopsolve sweep(0, 359, 1, method='tracked', derivatives=2, engine={eng!r}): median "
                  f"{a * 1e3:.3f} ms (best {min(ts) * 1e3:.3f}) = {a / b:.2f}x pylinkage")
        a = statistics.median(t_ls["numba"])
        print(f"engines agree to {agree:.1e} (rows of positions and rates)")
        print(f"ROW 1  tracked cycle (engine='numba') / pylinkage numba: {a / b:.2f}x (best/best "
              f"{min(t_ls['numba']) / min(t_pl):.2f}x)  (goal <= 1x)")
    m_cli, m_np = cli_times(max(5, args.repeats // 10))
    print(f"== cached CLI, 361-row CSV, fresh process: {m_cli * 1e3:.0f} ms; python -c 'import numpy': "
          f"{m_np * 1e3:.0f} ms ==")
    print(f"ROW 4  cached CLI - bare numpy: +{(m_cli - m_np) * 1e3:.0f} ms  (goal <= +150 ms)")
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import bench_study

    bench_study.part_handoff(argparse.Namespace(handoff_designs=200, kernel_designs=2000, chunk_kernel=None,
                                                repeats=3))


_FLOOR_SRC = """
import math
import numpy as np
from numba import njit

@njit(cache=False)
def floor(r1, r2, r3, r4, t2s, w2, out):
    # theta3, theta4, their rates and accelerations of the open four-bar at every crank angle
    for i in range(t2s.shape[0]):
        t2 = t2s[i]
        bx, by = r2 * math.cos(t2), r2 * math.sin(t2)
        dx, dy = r1 - bx, -by
        d2 = dx * dx + dy * dy
        d = math.sqrt(d2)
        a = (r3 * r3 - r4 * r4 + d2) / (2 * d)
        h = math.sqrt(max(r3 * r3 - a * a, 0.0))
        cx = bx + (a * dx - h * dy) / d  # the open mode: C left of B->O4
        cy = by + (a * dy + h * dx) / d
        t3 = math.atan2(cy - by, cx - bx)
        t4 = math.atan2(cy, cx - r1)
        s34 = math.sin(t3 - t4)
        w3 = -r2 * w2 * math.sin(t2 - t4) / (r3 * s34)
        w4 = r2 * w2 * math.sin(t2 - t3) / (r4 * -s34)
        e3 = (r4 * w4 * w4 - r2 * w2 * w2 * math.cos(t2 - t4) - r3 * w3 * w3 * math.cos(t3 - t4)) / (r3 * s34)
        e4 = (r2 * w2 * w2 * math.cos(t2 - t3) + r3 * w3 * w3 - r4 * w4 * w4 * math.cos(t4 - t3)) / (r4 * -s34)
        out[0, i], out[1, i], out[2, i], out[3, i], out[4, i], out[5, i] = t3, t4, w3, w4, e3, e4
"""


def overhead(args):
    """Issue 32, item 2: the whole call of a 10-row sweep (pos, vel, acc) with the defaults."""
    from loopsolve.kinematics.numba_engine import jit as numba_jit

    mech = ls.load(MODEL)
    default = lambda: mech.sweep(0, 9, 1, derivatives=2)  # noqa: E731 - the user's call
    # the default engine ("auto") switches to numba once this process has swept AUTO_ROWS rows
    for _ in range(numba_jit.AUTO_ROWS // 10 + 2):
        ran = default().engine
    numba = lambda: mech.sweep(0, 9, 1, derivatives=2, engine="numba")  # noqa: E731
    python = lambda: mech.sweep(0, 9, 1, derivatives=2, engine="python")  # noqa: E731
    fns = {f"loopsolve mech.sweep(0, 9, 1, derivatives=2), default engine (ran {ran!r})": default,
           "the same, engine='numba'": numba, "the same, engine='python'": python}
    try:
        import pylinkage  # noqa: F401
    except ImportError as exc:
        print(f"pylinkage skipped: {exc}")
    else:
        lk = pylinkage_build()
        lk.step_fast_with_kinematics(iterations=10)  # JIT outside the timing
        fns["pylinkage step_fast_with_kinematics(iterations=10) (numba)"] = \
            lambda: lk.step_fast_with_kinematics(iterations=10)
    try:
        ns = {}
        exec(_FLOOR_SRC, ns)  # noqa: S102 - the benchmark's own constant source
        t2s = np.radians(np.arange(10.0))
        out = np.empty((6, 10))
        ref = default()
        w2 = float(ref["theta2_vel"][0])  # the model's input speed (rates are in rad/s, angles in degrees)
        ns["floor"](R1, R2, R3, R4, t2s, w2, out)
        err = max(float(np.max(np.abs((np.radians(ref[n]) if i < 2 else np.asarray(ref[n])) - out[i])))
                  for i, n in enumerate(("theta3", "theta4", "theta3_vel", "theta4_vel", "theta3_acc", "theta4_acc")))
        fns["floor: hand-written numba closed form, 10 points (pos, vel, acc)"] = \
            lambda: ns["floor"](R1, R2, R3, R4, t2s, w2, out)
        print(f"floor agrees with loopsolve's rows to {err:.1e} (rad, rad/s, rad/s^2)")
    except ImportError as exc:
        print(f"floor skipped: {exc}")
    runs = {k: [] for k in fns}
    batch = 50
    for _ in range(args.repeats):  # interleaved batches: every candidate sees the same load
        for k, fn in fns.items():
            t = time.perf_counter()
            for _ in range(batch):
                fn()
            runs[k].append((time.perf_counter() - t) / batch)
    base = next((k for k in fns if k.startswith("pylinkage")), None)
    b = statistics.median(runs[base]) if base else None
    print(f"== one short sweep, per call (median of {args.repeats} batches of {batch}; best batch) ==")
    for k, ts in runs.items():
        m = statistics.median(ts)
        ratio = f"  {m / b:6.2f}x pylinkage" if b else ""
        print(f"{k:78s} {m * 1e6:8.1f} us (best {min(ts) * 1e6:8.1f}){ratio}")
    if b:
        k0 = next(iter(fns))
        print(f"GOAL  default 10-row sweep <= 3x pylinkage's call: {statistics.median(runs[k0]) / b:.2f}x "
              f"(best/best {min(runs[k0]) / min(runs[base]):.2f}x)")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer repeats")
    ap.add_argument("--issue21", action="store_true",
                    help="only the four rows of issue 21's table, as ratios (rows 2 and 3 from bench_study.py)")
    ap.add_argument("--overhead", action="store_true",
                    help="only issue 32's item 2: a 10-row sweep's call against pylinkage's and the compiled floor")
    ap.add_argument("--repeats", type=int, default=101, help="--issue21, --overhead: interleaved runs")
    args = ap.parse_args(argv)
    if args.overhead:
        return overhead(args)
    if args.issue21:
        os.environ.setdefault("LOOPSOLVE_CACHE_DIR", tempfile.mkdtemp(prefix="loopsolve-cache-"))
        return issue21(args)
    rep = 3 if args.quick else 9
    rep_big = 3 if args.quick else 5

    import platform

    print(f"loopsolve {ls.__version__}, numpy {np.__version__}, Python {platform.python_version()}, "
          f"{platform.machine()} ({os.cpu_count()} cpu)")
    mech = ls.load(MODEL)
    ck = mech.compile()

    # ---- 1. a 360-point cycle
    x = np.radians(np.arange(360.0))
    rows = []
    t_cf, _ = median_time(lambda: closed_form(x), rep * 5)
    rows.append(("closed form, vectorized numpy (loopsolve.kinematics.classic)", t_cf, 0.0))
    for method in ("tracked", "batched"):
        fn = loopsolve_sweep(mech, ck, 0, 359, 1, method)
        fn()
        t, res = median_time(fn, rep * 3)
        rows.append((f"loopsolve sweep, {method}", t, max_error(res, closed_form)))
    try:
        import scipy  # noqa: F401

        t, res = median_time(lambda: scipy_fsolve(x), max(3, rep // 3))
        rows.append(("scipy fsolve per point (analytic Jacobian) + 2x2 rate solves", t, max_error(res, closed_form)))
    except ImportError as exc:
        rows.append(("scipy fsolve per point", None, f"scipy not importable: {exc}"))
    try:
        import pylinkage

        ver = getattr(pylinkage, "__version__", "?")
        t, raw = median_time(pylinkage_python, rep * 3, setup=pylinkage_build)
        rows.append((f"pylinkage {ver} step_with_derivatives (pure Python)", t,
                     max_error(pylinkage_result(raw, False), closed_form)))
        try:
            pylinkage_fast(pylinkage_build())  # compile (numba when installed) outside the timing
            t, raw = median_time(pylinkage_fast, rep * 3, setup=pylinkage_build)
            try:
                import numba  # noqa: F401

                how = "numba"
            except ImportError:
                how = "numba not installed: plain Python"
            rows.append((f"pylinkage step_fast_with_kinematics ({how})", t,
                         max_error(pylinkage_result(raw, True), closed_form)))
        except Exception as exc:  # noqa: BLE001 - report any failure of the peer
            rows.append(("pylinkage step_fast_with_kinematics", None, f"failed: {type(exc).__name__}: {exc}"))
    except ImportError as exc:
        rows.append(("pylinkage", None, f"not importable: {exc} (pip install -e .[bench])"))
    try:
        import importlib.metadata as md

        import mechanism  # noqa: F401

        ver = md.version("mechanism")
        t, built = median_time(mechanism_run, max(3, rep // 3), setup=lambda: mechanism_build(x))
        rows.append((f"mechanism {ver} Mechanism.iterate (fsolve pos/vel/acc)", t,
                     max_error(mechanism_result(x, built), closed_form)))
    except ImportError as exc:
        rows.append(("mechanism", None, f"not importable: {exc} (pip install -e .[bench])"))
    table("360-point cycle, positions + velocities + accelerations (theta3, theta4)", rows, t_cf)
    tracked = next(r for r in rows if r[0] == "loopsolve sweep, tracked")[1]
    peers = [r for r in rows if r[1] is not None and (r[0].startswith("pylinkage") or r[0].startswith("mechanism"))]
    if peers:
        ok = all(tracked < r[1] for r in peers)
        print(f"target: tracked 360-point cycle faster than every peer: {'MET' if ok else 'NOT MET'} "
              f"(tracked {tracked * 1e3:.2f} ms; fastest peer {min(r[1] for r in peers) * 1e3:.2f} ms)")

    # ---- 2. a million points
    n = 10**6
    step = 360.0 / n
    xb = np.radians(np.arange(n + 1) * step)
    t_cf_big, _ = median_time(lambda: closed_form(xb), rep_big)
    fn = loopsolve_sweep(mech, ck, 0, 360, step, "batched")
    t_b, res = median_time(fn, rep_big)
    err_b = max_error(res, closed_form)
    del res
    t_bj, res = median_time(loopsolve_sweep(mech, ck, 0, 360, step, "batched", derivatives=3), rep_big)
    rows = [("closed form, vectorized numpy", t_cf_big, 0.0),
            ("loopsolve sweep, batched (pos, vel, acc)", t_b, err_b),
            ("loopsolve sweep, batched, with jerks too", t_bj, max_error(res, closed_form))]
    del res
    table(f"{n + 1} points", rows, t_cf_big)
    print(f"target: batched 1e6 points <= 3x closed form (pos, vel, acc): "
          f"{'MET' if t_b <= 3 * t_cf_big else 'NOT MET'} ({t_b / t_cf_big:.2f}x; with jerks {t_bj / t_cf_big:.2f}x)")

    # ---- 3. fresh-process command line
    exe = shutil.which("loopsolve")
    cli = [exe] if exe else [sys.executable, "-m", "loopsolve.cli"]
    cmd = cli + ["sweep", str(MODEL), "--from", "0", "--to", "360", "--step", "1", "--format", "csv",
                 "-o", os.devnull, "-q"]
    subprocess.run(cmd, check=True, capture_output=True)  # make sure the compiled model is cached
    bare = [sys.executable, "-c", "import numpy"]
    t_cli, t_np = [], []
    for _ in range(rep + 2):
        for c_, acc in ((bare, t_np), (cmd, t_cli)):
            t = time.perf_counter()
            subprocess.run(c_, check=True, capture_output=True)
            acc.append(time.perf_counter() - t)
    m_cli, m_np = statistics.median(t_cli), statistics.median(t_np)
    print(f"\nfresh process (median of {len(t_cli)}):")
    labels = ('python -c "import numpy"', "loopsolve sweep models/thesis_crank_rocker.toml --step 1 (361 rows, CSV)")
    print(f"  {labels[0]:72s} {m_np * 1e3:8.1f} ms")
    print(f"  {labels[1]:72s} {m_cli * 1e3:8.1f} ms")
    print(f"target: cached CLI <= 0.3 s above bare numpy: {'MET' if m_cli - m_np <= 0.3 else 'NOT MET'} "
          f"(+{(m_cli - m_np) * 1e3:.0f} ms)")


if __name__ == "__main__":
    main()
