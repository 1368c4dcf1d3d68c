"""Benchmark of design studies (not a test): many crank-rocker designs at once.

1. **2000 designs × 361 points** (θ2 = 0°, 1°, …, 360°), positions, velocities and accelerations
   (``derivatives=2``) of a crank-rocker family (r1 = 60, r4 = 45 mm fixed; r2 and r3 from a
   seeded sample of a box of crank-rockers), in this process:

   * ``ls.study`` (lockstep continuation; the whole Dataset with every column and point);
   * ``pylinkage``'s numba kernel ``Linkage.step_fast_with_kinematics`` looped over the
     designs the way its optimizers do: one linkage, new constraints and starting pose per
     design (``set_completely``), then the kernel;
   * the closed form, numpy on all designs at once (:mod:`loopsolve.kinematics.classic` half-angle
     position, velocity and acceleration formulas on (designs, points) arrays).

   Prints the median times, the ratios, and the largest error of loopsolve and pylinkage
   against the closed form.

2. **Zarr on a 2-worker local Dask cluster** (``--designs``, default 10⁵; ``--chunk``): the
   study streamed to a ``.zarr`` store; prints the wall time, design-points per second, the
   store size and the peak resident memory of the client and of each worker process
   (``ru_maxrss``), which a chunk bounds.

Run from the repository root::

    pip install -e .[bench,study] numba
    python benchmarks/bench_study.py                    # both parts
    python benchmarks/bench_study.py --part kernel      # part 1 only
    python benchmarks/bench_study.py --part handoff     # issue 21's rows 2 and 3: designs not assemblable
                                                        # at the start, limits (four-bars, slider-cranks),
                                                        # the mixed box
    nice python benchmarks/bench_study.py --part zarr --designs 20000
    python benchmarks/bench_study.py --part chunks      # the default chunk size against fixed ones: CPU time
                                                        # (untraced), peak memory over the result (2000, 20000
                                                        # designs); --engines python,numba --no-memory
                                                        # --chunk-sizes 128,256,512,1024 --repeats 3
"""

from __future__ import annotations

import argparse
import math
import os
import resource
import shutil
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

import loopsolve as ls
from loopsolve.kinematics import classic as C

ROOT = Path(__file__).resolve().parents[1]
MODEL = ROOT / "models" / "thesis_crank_rocker.toml"
R1, R4 = 60.0, 45.0
OMEGA = 10 * 2 * math.pi / 60  # the model's 10 rpm
BOX = {"r2": (15.0, 28.0), "r3": (55.0, 75.0)}  # every design a Grashof crank-rocker
#: designs of a warm-up study: 64 x 361 rows pass the "auto" engine's AUTO_ROWS, so the warm-up loads (or
#: compiles, once per cache) the numba engine the measured studies then run, as a user's later studies do
WARM = 64


def designs(n, seed=0):
    from loopsolve.design.designs import sample

    return sample(BOX, n, seed=seed)


def best_times(fns, repeats):
    """Best-of-``repeats`` time of each function, the runs interleaved (the machine is shared: the
    minimum is the least disturbed run of each, and interleaving exposes all to the same load)."""
    times = {k: [] for k in fns}
    outs = {}
    for _ in range(repeats):
        for k, fn in fns.items():
            t = time.perf_counter()
            outs[k] = fn()
            times[k].append(time.perf_counter() - t)
    return {k: (min(v), statistics.median(v)) for k, v in times.items()}, outs


def closed_form(r2, r3, x):
    """θ3, θ4, ω3, ω4, α3, α4 (rad, rad/s, rad/s²) of all designs (D, 1) at all inputs (K,) at once."""
    t2 = np.radians(x)[None, :]
    r2, r3 = r2[:, None], r3[:, None]
    t3, t4 = C.fourbar_position(R1, r2, r3, R4, t2, mode=1)  # open: the model's mode
    w3, w4 = C.fourbar_velocity(r2, r3, R4, t2, t3, t4, OMEGA)
    a3, a4 = C.fourbar_acceleration(r2, r3, R4, t2, t3, t4, OMEGA, w3, w4, 0.0)
    return t3, t4, w3, w4, a3, a4


def wrap(a):
    return (a + math.pi) % (2 * math.pi) - math.pi


def part_kernel(args):
    mech = ls.load(MODEL)
    d = designs(args.kernel_designs)
    r2, r3 = d.values["r2"], d.values["r3"]
    x = np.arange(361.0)
    D = len(r2)
    print(f"== {D} crank-rocker designs x {len(x)} points, positions + velocities + accelerations ==")
    ls.study(mech, d.slice(0, WARM), 0, 360, 1, derivatives=2)  # imports, compile, warm caches

    fns = {"loopsolve": lambda: ls.study(mech, d, 0, 360, 1, derivatives=2, chunk_size=args.chunk_kernel,
                                         progress=False, max_cells=D * len(x)),
           "closed form": lambda: closed_form(r2, r3, x)}
    kernel = None
    try:
        import pylinkage as pl

        try:
            import numba  # noqa: F401

            kernel = "numba"
        except ImportError:
            kernel = "pure Python (numba not installed)"
        o1, o2 = pl.Ground(0.0, 0.0, name="O2"), pl.Ground(R1, 0.0, name="O4")
        crank = pl.Crank(anchor=o1, radius=25.0, angular_velocity=2 * math.pi / 360, initial_angle=0.0, name="B")
        c4 = closed_form(r2, r3, x[:1])[1][:, 0]
        rocker = pl.RRRDyad(crank.output, o2, distance1=70.0, distance2=R4, x=R1 + R4 * math.cos(c4[0]),
                            y=R4 * math.sin(c4[0]), name="C")
        lk = pl.Linkage([o1, o2, crank, rocker], name="crank-rocker")
        lk.set_input_velocity(crank, omega=OMEGA, alpha=0.0)
        lk.step_fast_with_kinematics(iterations=361)  # JIT compile outside the timing
        poses = [[(0.0, 0.0), (R1, 0.0), (float(r2[i]), 0.0),
                  (R1 + R4 * math.cos(c4[i]), R4 * math.sin(c4[i]))] for i in range(D)]

        def run_pylinkage():
            out = []
            for i in range(D):  # as its optimizers do: one linkage, new constraints and pose per design
                lk.set_completely([float(r2[i]), float(r3[i]), R4], poses[i])
                lk.set_input_velocity(crank, omega=OMEGA, alpha=0.0)
                out.append(lk.step_fast_with_kinematics(iterations=361))
            return out

        fns["pylinkage"] = run_pylinkage
    except ImportError as exc:
        print(f"pylinkage skipped: {exc}")
    times, outs = best_times(fns, args.repeats)
    ds, cf = outs["loopsolve"], outs["closed form"]
    err = 0.0
    for name, ref in (("theta3", cf[0]), ("theta4", cf[1])):
        err = max(err, float(np.max(np.abs(wrap(np.radians(ds[name].values) - ref)))))
    for name, ref in (("theta3_vel", cf[2]), ("theta4_vel", cf[3]), ("theta3_acc", cf[4]), ("theta4_acc", cf[5])):
        err = max(err, float(np.max(np.abs(ds[name].values - ref))))
    t_ls, t_cf = times["loopsolve"][0], times["closed form"][0]
    print(f"(best of {args.repeats} interleaved runs; median in brackets)")
    print(f"loopsolve study ({int(ds.lockstep.sum())}/{D} designs lockstep): {t_ls:.3f} s "
          f"[{times['loopsolve'][1]:.3f}]   max error vs closed form {err:.1e}")
    print(f"closed form, numpy, all designs at once:      {t_cf:.4f} s [{times['closed form'][1]:.4f}]")
    t_pl = None
    if "pylinkage" in times:
        t_pl = times["pylinkage"][0]
        res = outs["pylinkage"]
        e = {0: 0.0, 1: 0.0}
        for i in range(0, D, max(1, D // 50)):  # pylinkage's θ4 against the closed form, on a sample of designs
            Cp = np.asarray(res[i][0])[:, 3]
            t4 = np.arctan2(Cp[:, 1], Cp[:, 0] - R1)
            for shift in (0, 1):  # its row k may be the pose after k + 1 steps
                ref = cf[1][i][shift:shift + len(t4)]
                e[shift] = max(e[shift], float(np.max(np.abs(wrap(t4[:len(ref)] - ref)))))
        print(f"pylinkage step_fast_with_kinematics ({kernel}) looped: {t_pl:.3f} s "
              f"[{times['pylinkage'][1]:.3f}]   max θ4 error vs closed form {min(e.values()):.1e} "
              f"(rows aligned {'as' if e[0] <= e[1] else 'one step after'} the input grid)")
    print("-- ratios --")
    if t_pl is not None:
        print(f"pylinkage loop / loopsolve study : {t_pl / t_ls:.2f}x  (loopsolve faster when > 1)")
    print(f"loopsolve study / closed form    : {t_ls / t_cf:.1f}x")
    print(f"loopsolve design-points per second (one process): {D * len(x) / t_ls:,.0f}")


MIXED_BOX = {"r2": (15.0, 30.0), "r3": (62.0, 75.0), "r4": (40.0, 50.0)}  # issue 21: 1.4 % not assemblable at 0
JAM_BOX = {"r2": (35.0, 45.0), "r3": (40.0, 50.0), "r4": (40.0, 50.0)}  # triple rockers: stop at a limit
GAP_BOX = {"r2": (28.0, 30.0), "r3": (73.0, 75.0), "r4": (40.0, 41.0)}  # r3 - r4 > r1 - r2: none assemblable at 0


def _pylinkage_loop(r2, r3, r4, x):
    """pylinkage's numba kernel looped over the designs (one linkage, new constraints and pose per design),
    or None when pylinkage does not import. Designs it cannot assemble are skipped, as its optimizers do."""
    try:
        import pylinkage as pl
    except ImportError as exc:
        print(f"pylinkage skipped: {exc}")
        return None
    o1, o2 = pl.Ground(0.0, 0.0, name="O2"), pl.Ground(R1, 0.0, name="O4")
    crank = pl.Crank(anchor=o1, radius=25.0, angular_velocity=2 * math.pi / 360, initial_angle=0.0, name="B")
    rocker = pl.RRRDyad(crank.output, o2, distance1=70.0, distance2=45.0, x=R1 + 45.0 * math.cos(1.0),
                        y=45.0 * math.sin(1.0), name="C")
    lk = pl.Linkage([o1, o2, crank, rocker], name="crank-rocker")
    lk.set_input_velocity(crank, omega=OMEGA, alpha=0.0)
    lk.step_fast_with_kinematics(iterations=len(x))  # JIT compile outside the timing
    t4 = np.zeros(len(r2))
    ok = np.zeros(len(r2), dtype=bool)
    for i in range(len(r2)):  # the open solution at θ2 = 0, where one exists (pylinkage needs a starting pose)
        with np.errstate(all="ignore"):
            try:
                t3i, t4i = C.fourbar_position(R1, r2[i], r3[i], r4[i], 0.0, 1)
            except Exception:  # noqa: BLE001 - no assembly
                continue
        if np.isfinite(t4i):
            t4[i], ok[i] = float(t4i), True
    poses = [[(0.0, 0.0), (R1, 0.0), (float(r2[i]), 0.0),
              (R1 + r4[i] * math.cos(t4[i]), r4[i] * math.sin(t4[i]))] for i in range(len(r2))]

    def run():
        out = []
        for i in np.flatnonzero(ok):
            lk.set_completely([float(r2[i]), float(r3[i]), float(r4[i])], poses[i])
            lk.set_input_velocity(crank, omega=OMEGA, alpha=0.0)
            out.append(lk.step_fast_with_kinematics(iterations=len(x)))
        return out

    return run


def part_handoff(args):
    """Issue 21, rows 2 and 3: designs the lockstep path hands off (not assemblable at the start, limits)."""
    import warnings

    from loopsolve.design.designs import Designs, sample

    warnings.filterwarnings("ignore", category=ls.LoopsolveWarning)  # designs stopping at limits
    mech = ls.load(MODEL)
    ls.study(mech, sample(MIXED_BOX, WARM, seed=0), 0, 360, 1, derivatives=2, progress=False)  # warm up
    n = args.handoff_designs
    na = sample(GAP_BOX, n, seed=2)
    ordinary = designs(n, seed=3)
    ordinary = Designs(("r2", "r3", "r4"), {**ordinary.values, "r4": np.full(n, R4)})

    def run(d):
        return lambda: ls.study(mech, d, 0, 360, 1, derivatives=2, chunk_size=args.chunk_kernel, progress=False)

    jam = sample(JAM_BOX, n, seed=5)
    times, outs = best_times({"not assemblable": run(na), "limit": run(jam), "ordinary": run(ordinary)},
                             args.repeats)
    t_na, t_ok, t_jam = times["not assemblable"][0], times["ordinary"][0], times["limit"][0]
    st = outs["not assemblable"].status.values
    print(f"== {n} designs not assemblable at theta2 = 0 (r2, r3, r4 in {GAP_BOX}) vs {n} crank-rockers, "
          f"361 points, pos/vel/acc ==")
    print(f"not assemblable ({int((st == 'not-assemblable').sum())}/{n}): {t_na:.3f} s "
          f"[{times['not assemblable'][1]:.3f}], {t_na / n * 1e3:.2f} ms per design")
    print(f"crank-rockers:                {t_ok:.3f} s [{times['ordinary'][1]:.3f}], {t_ok / n * 1e3:.2f} ms per design")
    print(f"ROW 2  not-assemblable study / ordinary study: {t_na / t_ok:.1f}x  (goal <= 2x)")
    sj = outs["limit"].status.values
    print(f"designs that stop at a limit ({int((sj == 'limit').sum())}/{n} limit, "
          f"{int(outs['limit'].lockstep.sum())} in lockstep; r2, r3, r4 in {JAM_BOX}): {t_jam:.3f} s "
          f"[{times['limit'][1]:.3f}], {t_jam / n * 1e3:.2f} ms per design")
    print(f"ROW 2b limit-design study / ordinary study: {t_jam / t_ok:.1f}x")
    _slider_crank_limits(args)

    m = args.kernel_designs
    d = sample(MIXED_BOX, m, seed=4)
    r2, r3, r4 = (d.values[k] for k in ("r2", "r3", "r4"))
    x = np.arange(361.0)
    fns = {"loopsolve": lambda: ls.study(mech, d, 0, 360, 1, derivatives=2, chunk_size=args.chunk_kernel,
                                         progress=False)}
    pl_run = _pylinkage_loop(r2, r3, r4, x)
    if pl_run is not None:
        fns["pylinkage"] = pl_run
    times, outs = best_times(fns, args.repeats)
    ds = outs["loopsolve"]
    counts = {s: int((ds.status.values == s).sum()) for s in np.unique(ds.status.values)}
    print(f"== mixed box: {m} designs, r1 = 60, {MIXED_BOX}, 361 points, pos/vel/acc: {counts}, "
          f"{int(ds.lockstep.sum())} lockstep ==")
    t_ls = times["loopsolve"][0]
    print(f"loopsolve study: {t_ls:.3f} s [{times['loopsolve'][1]:.3f}]")
    if "pylinkage" in times:
        t_pl = times["pylinkage"][0]
        print(f"pylinkage numba kernel looped over the {len(outs['pylinkage'])} designs it can start: "
              f"{t_pl:.3f} s [{times['pylinkage'][1]:.3f}]")
        print(f"ROW 3  mixed-box study / pylinkage loop: {t_ls / t_pl:.2f}x  (goal <= 1x)")


SC_MODEL = ROOT / "models" / "prob2_offset_slider_crank.toml"
SC_BOX = {"r2": (400.0, 560.0), "r3": (1400.0, 1700.0), "e": (0.0, 200.0)}  # crank shorter than the rod: ok
SC_LIMIT_BOX = {"r2": (1100.0, 1400.0), "r3": (500.0, 900.0), "e": (0.0, 100.0)}  # longer: a limit on the way


def _slider_crank_limits(args):
    """Row 2c: offset slider-cranks whose crank is longer than the rod (they stop where
    |r2 sin θ2 − e| = r3) against ordinary ones, the same number, 361 points, pos/vel/acc."""
    from loopsolve.design.designs import sample

    mech = ls.load(SC_MODEL)
    n = args.handoff_designs
    ls.study(mech, sample(SC_BOX, WARM, seed=0), 0, 360, 1, derivatives=2, progress=False)  # warm up

    def run(d):
        return lambda: ls.study(mech, d, 0, 360, 1, derivatives=2, chunk_size=args.chunk_kernel, progress=False)

    times, outs = best_times({"limit": run(sample(SC_LIMIT_BOX, n, seed=6)),
                              "ordinary": run(sample(SC_BOX, n, seed=7))}, args.repeats)
    t_lim, t_ok = times["limit"][0], times["ordinary"][0]
    sl = outs["limit"].status.values
    print(f"== {n} offset slider-cranks stopping at a limit ({int((sl == 'limit').sum())}/{n} limit, "
          f"{int(outs['limit'].lockstep.sum())} in lockstep; {SC_LIMIT_BOX}) vs {n} ordinary ({SC_BOX}), "
          f"361 points, pos/vel/acc ==")
    print(f"limit designs: {t_lim:.3f} s [{times['limit'][1]:.3f}], {t_lim / n * 1e3:.2f} ms per design; "
          f"ordinary: {t_ok:.3f} s [{times['ordinary'][1]:.3f}], {t_ok / n * 1e3:.2f} ms per design")
    print(f"ROW 2c slider-crank limit-design study / ordinary slider-crank study: {t_lim / t_ok:.1f}x")


def _rss_peak_mb():
    r = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return r / 1024.0  # KiB on Linux


def part_zarr(args):
    from distributed import Client, LocalCluster

    mech = ls.load(MODEL)
    n = args.designs
    d = designs(n, seed=1)
    tmp = Path(tempfile.mkdtemp(prefix="loopsolve-bench-"))
    store = tmp / "study.zarr"
    print(f"== {n} designs x 361 points to Zarr on a 2-worker local cluster (chunk {args.chunk}, "
          f"derivatives={args.derivatives}) ==")
    try:
        with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                          dashboard_address=":0") as cluster, Client(cluster) as client:
            ls.study(mech, d.slice(0, 4), 0, 360, 1, client=client, progress=False)  # warm the workers
            t = time.perf_counter()
            ds = ls.study(mech, d, 0, 360, 1, client=client, chunk_size=args.chunk, out=store, progress=args.progress,
                          derivatives=args.derivatives, max_cells=n * 361, max_designs=max(n, 100_000))
            wall = time.perf_counter() - t
            workers = client.run(_rss_peak_mb)
        size = sum(f.stat().st_size for f in store.rglob("*") if f.is_file())
        pts = n * 361
        print(f"wall {wall:.1f} s, {pts / wall:,.0f} design-points/s, {int((ds.status == 'ok').sum())} ok, "
              f"store {size / 1e9:.2f} GB")
        print(f"peak RSS: client {_rss_peak_mb():.0f} MB; workers " +
              ", ".join(f"{v:.0f} MB" for v in workers.values()))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def part_chunks(args):
    """The default chunk size against fixed ones on the mixed box (designs not assemblable at the start
    included): CPU time, best of ``--repeats`` with the sizes (and engines) interleaved and nothing traced;
    then, unless ``--no-memory``, one more run of each under ``tracemalloc`` for the peak of numpy's memory
    over the result's size.

    Timed apart from the memory: tracemalloc traces every allocation, and a chunk's start, not-assemblable
    test, limits and columns make thousands of small numpy arrays, so under it each chunk cost ~0.2–0.3 s
    more CPU (issue 32: the "per-chunk cost outside the lockstep" that made small chunks look twice as
    slow at 20000 designs was this; untraced, a chunk of the compiled lockstep costs ~0.05 s)."""
    import tracemalloc
    import warnings

    from loopsolve.design.designs import sample
    from loopsolve.design.studies import default_chunk

    warnings.filterwarnings("ignore", category=ls.LoopsolveWarning)
    mech = ls.load(MODEL)
    engines = [e.strip() for e in args.engines.split(",")]
    before = os.environ.get("LOOPSOLVE_ENGINE")

    def engine(e):  # "default": as a user gets it ($LOOPSOLVE_ENGINE if set, else "auto")
        if e == "default":
            if before is None:
                os.environ.pop("LOOPSOLVE_ENGINE", None)
            else:
                os.environ["LOOPSOLVE_ENGINE"] = before
        else:
            os.environ["LOOPSOLVE_ENGINE"] = e

    for e in engines:  # warm up: imports, and the compiled lockstep loaded (or compiled once per cache)
        engine(e)
        ls.study(mech, sample(MIXED_BOX, WARM, seed=0), 0, 360, 1, derivatives=2, progress=False)
    for n in [int(v) for v in args.chunk_designs.split(",")]:
        d = sample(MIXED_BOX, n, seed=4)
        sizes = [None] + [int(c) for c in args.chunk_sizes.split(",") if int(c) < n]
        print(f"== {n} designs of the mixed box x 361 points, pos/vel/acc; default chunk {default_chunk(n, 361)}; "
              f"CPU best of {args.repeats} (median), interleaved ==", flush=True)

        def run(c):
            return ls.study(mech, d, 0, 360, 1, derivatives=2, chunk_size=c, progress=False, max_cells=n * 361)

        cpu = {(e, c): [] for e in engines for c in sizes}
        for _ in range(args.repeats):
            for e, c in cpu:
                engine(e)
                t = time.process_time()
                run(c)
                cpu[e, c].append(time.process_time() - t)
        for (e, c), v in cpu.items():
            line = (f"engine {e:>7} chunk {'default' if c is None else c:>7}: {min(v):6.2f} s CPU "
                    f"({statistics.median(v):.2f})")
            if not args.no_memory:
                engine(e)
                tracemalloc.start()
                ds = run(c)
                peak = tracemalloc.get_traced_memory()[1]
                tracemalloc.stop()
                line += f", peak {peak / 1e6:7.1f} MB = {peak / ds.nbytes:.2f}x the result ({ds.nbytes / 1e6:.1f} MB)"
                del ds
            print(line, flush=True)
    engine("default")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--part", choices=("all", "kernel", "handoff", "zarr", "chunks"), default="all")
    ap.add_argument("--handoff-designs", type=int, default=200, help="designs of each kind in row 2 (default 200)")
    ap.add_argument("--kernel-designs", type=int, default=2000)
    ap.add_argument("--chunk-kernel", type=int, default=None,
                    help="designs per chunk in part 1 (default: the API's, as a user gets it)")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--designs", type=int, default=100_000, help="designs of part 2 (default 10^5)")
    ap.add_argument("--chunk", type=int, default=None, help="designs per Dask task in part 2 (default: the API's)")
    ap.add_argument("--chunk-sizes", default="256,1024,4096",
                    help="--part chunks: the chunk sizes compared with the default (comma-separated)")
    ap.add_argument("--chunk-designs", default="2000,20000", help="--part chunks: the studies' sizes (comma-separated)")
    ap.add_argument("--engines", default="default",
                    help="--part chunks: engines compared (comma-separated: default, python, numba, auto)")
    ap.add_argument("--no-memory", action="store_true", help="--part chunks: CPU times only (no traced run)")
    ap.add_argument("--derivatives", type=int, default=2, help="part 2: 2 = positions, velocities, accelerations")
    ap.add_argument("--progress", action="store_true")
    args = ap.parse_args()
    os.environ.setdefault("LOOPSOLVE_CACHE_DIR", tempfile.mkdtemp(prefix="loopsolve-cache-"))
    if args.part in ("all", "kernel"):
        part_kernel(args)
    if args.part in ("all", "handoff"):
        part_handoff(args)
    if args.part in ("all", "zarr"):
        part_zarr(args)
    if args.part == "chunks":
        part_chunks(args)


if __name__ == "__main__":
    main()
