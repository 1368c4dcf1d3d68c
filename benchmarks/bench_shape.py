"""Shape synthesis and atlas benchmarks (issue 30): literature curves, free-timing path problems, speed.

Three parts, each with the defaults a user gets (the default four-bar atlas of
``models/fourbar_path_synthesis.toml``, built once into the cache on first use):

* ``literature`` — target curves of the atlas-synthesis literature, each with the linkage its
  paper published. The point lists and the reference linkages are those distributed with
  four-bar-rs (github.com/KmolYuan/four-bar-rs, ``test-fb``/``syn-examples``), where the papers'
  tables were typed in:

  - McGarva, J. R. (1994). Rapid search and selection of path generating mechanisms from a library.
    Mechanism and Machine Theory 29(2), 223–235 (closed, 35 points);
  - Ullah, I., Kota, S. (1997). Optimal synthesis of mechanisms for path generation using Fourier
    descriptors and global search methods. ASME J. Mech. Des. 119(4), 504–510 (closed, 140 points);
  - Yu, H., Tang, D., Wang, Z. (2007). Study on a new computer path synthesis method of a four-bar
    linkage. Mechanism and Machine Theory 42(4), 383–392 (closed, 20 points);
  - Wu, J., Ge, Q. J., Gao, F., Guo, W. Z. (2011). On the extension of a Fourier descriptor based
    method for planar four-bar linkage synthesis for generation of open and closed paths.
    J. Mechanisms Robotics 3(3) (open, 60 points).

  Each reference linkage is written as four-bar-rs writes it (ground pivot p0, ground angle a,
  links l1 ground, l2 driver, l3 coupler, l4 follower, coupler point l5 at g from the coupler,
  circuit ``inv``) and its coupler curve computed here by circle intersection over its whole
  motion (0.01°). Both the reference and loopsolve's best certified design are measured the same
  way: the RMS and largest distance of the target points to the design's curve.
* ``path`` — the free-timing problems of the issue through ``ls.synthesize(path=...)``: the ellipse
  (ten points, the tenth repeating the first, crank, lengths [5, 80], placement [−80, 80]; a design
  with Σ|P − T|² = 4.02e-4 is published), six points on a vertical line (crank; an exact solution
  exists), the half circle of 8 points and the eighteen-point closed curve of Bulatović et al. (MKH)
  with free timing: median and best of ``--runs`` seeded runs and how many were certified, with
  the atlas starts (default) and, with ``--compare``, without them (``atlas=False``).
* ``speed`` — CPU seconds (``time.process_time``, this process) of a shape query (retrieval, and
  retrieval + polish + certificates) against the default atlas once loaded — the ellipse (closed) and
  Wu et al.'s open curve — and of one free-timing ``--path`` run on the ellipse; the atlas build rate (designs per second, wall clock) in this
  process and on local Dask clusters of 1 and 2 workers.

    python benchmarks/bench_shape.py                       # everything (the README's figures)
    python benchmarks/bench_shape.py --only literature
    python benchmarks/bench_shape.py --only path --runs 5 --compare
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import time

import numpy as np

import loopsolve as ls

MODEL = ls.models_dir() / "fourbar_path_synthesis.toml"

MCGARVA = [(53.129710635271394, 71.09548499062436), (43.88075278565084, 71.12057099863611),
           (34.78160925198469, 70.85023434303328), (27.182660455254414, 69.57166588355919),
           (21.947350879671248, 66.98830542625824), (17.15750757515258, 63.540602931307575),
           (14.416032479975563, 59.947254090866124), (12.65682494666995, 54.50134434447122),
           (11.789696022302618, 49.14527267701302), (11.799466715687087, 44.3832980197824),
           (11.573203202188205, 38.642229320146654), (11.58343424485069, 33.66777640979497),
           (11.577748827657164, 28.48382492755202), (11.600870418177685, 24.325586118193065),
           (11.575210056457536, 19.56552000892165), (11.60761067692598, 15.969681563765272),
           (11.6058362188868, 14.180576525204753), (11.48444898607098, 12.957358191381187),
           (11.52190927026825, 12.186228831518758), (11.551954375908867, 11.36490063762871),
           (11.654725443149985, 10.645226088319745), (12.494754772828372, 11.921320586914634),
           (13.133110638566805, 12.904500646899207), (14.288439202715658, 15.312954042452937),
           (15.831210096010986, 17.20711288996677), (18.030243231375596, 20.180863710817494),
           (22.7401256868248, 24.378923980315804), (27.365985146232077, 28.76740068523864),
           (32.08110231437042, 33.442845138497916), (37.83568766271256, 39.14327289515019),
           (43.910939689649226, 43.94515034393466), (50.04595182417367, 48.98630838725289),
           (56.088336036554466, 54.79424876988042), (59.90199840530059, 61.70391535005011),
           (59.20415282231929, 67.7921691846899)]
ULLAH = [(0.15365, 0.17546), (0.20218, 0.12808), (0.25368, 0.08651), (0.31516, 0.05578), (0.37999, 0.03533),
         (0.44668, 0.01838), (0.517, 0.00774), (0.58799, 0.00971), (0.6568, 0.01006), (0.73041, 0.008),
         (0.80203, 0.00946), (0.86746, 0.00943), (0.93823, 0.00935), (1.00791, 0.01661), (1.08036, 0.01681),
         (1.14952, 0.02159), (1.21364, 0.02354), (1.28637, 0.02464), (1.35818, 0.01962), (1.42908, 0.02439),
         (1.50008, 0.02676), (1.56467, 0.02839), (1.63532, 0.02328), (1.7008, 0.02577), (1.77981, 0.02988),
         (1.84533, 0.03387), (1.91738, 0.03536), (1.97947, 0.04367), (2.04542, 0.0667), (2.11289, 0.08628),
         (2.18338, 0.10947), (2.23424, 0.15448), (2.2858, 0.20703), (2.33571, 0.25704), (2.36874, 0.31778),
         (2.38824, 0.38176), (2.40484, 0.44633), (2.41917, 0.52044), (2.42066, 0.58547), (2.39718, 0.65479),
         (2.38198, 0.71921), (2.36471, 0.78734), (2.33491, 0.84337), (2.29805, 0.90345), (2.2614, 0.96605),
         (2.22529, 1.02228), (2.18607, 1.08091), (2.15395, 1.13472), (2.11819, 1.19525), (2.07614, 1.25041),
         (2.03295, 1.30863), (2.0004, 1.36319), (1.9757, 1.4312), (1.93959, 1.48669), (1.90043, 1.54601),
         (1.86442, 1.60395), (1.82518, 1.66426), (1.7998, 1.72078), (1.75979, 1.77621), (1.72423, 1.83912),
         (1.69222, 1.89794), (1.65594, 1.95919), (1.62307, 2.0145), (1.58591, 2.07784), (1.5478, 2.1362),
         (1.51269, 2.189), (1.47663, 2.24912), (1.44469, 2.31505), (1.4087, 2.3681), (1.37443, 2.42516),
         (1.33719, 2.48532), (1.30294, 2.55072), (1.26593, 2.60929), (1.22924, 2.66099), (1.19459, 2.72006),
         (1.16207, 2.7836), (1.13171, 2.84073), (1.09344, 2.90051), (1.05508, 2.95797), (1.01865, 3.01972),
         (0.98626, 3.07689), (0.94876, 3.13605), (0.91797, 3.19337), (0.87953, 3.25694), (0.84017, 3.31451),
         (0.8073, 3.37489), (0.77478, 3.42713), (0.72462, 3.47617), (0.65626, 3.49305), (0.59191, 3.50679),
         (0.52223, 3.52178), (0.45042, 3.5087), (0.38586, 3.48956), (0.3164, 3.47198), (0.25188, 3.44123),
         (0.20447, 3.39426), (0.15723, 3.34466), (0.10213, 3.29127), (0.07021, 3.2312), (0.05071, 3.1704),
         (0.0347, 3.09996), (0.01541, 3.03121), (0.01306, 2.966), (0.01431, 2.89161), (0.01258, 2.8234),
         (0.015, 2.75885), (0.01686, 2.68461), (0.01699, 2.61578), (0.01485, 2.54332), (0.01363, 2.4754),
         (0.01121, 2.4054), (0.01272, 2.33603), (0.01419, 2.27316), (0.0138, 2.20237), (0.01571, 2.1308),
         (0.00907, 2.06461), (0.00427, 1.99213), (0.00181, 1.92568), (0.00519, 1.85328), (0.00761, 1.78948),
         (0.00672, 1.71309), (0.0041, 1.65055), (0.00398, 1.58082), (0.00535, 1.51205), (0.00443, 1.43776),
         (0.00748, 1.37096), (0.00778, 1.30525), (0.00983, 1.23225), (0.01021, 1.16732), (0.01162, 1.09623),
         (0.01221, 1.0288), (0.01441, 0.95364), (0.0103, 0.89048), (0.01245, 0.81741), (0.01016, 0.74988),
         (0.01337, 0.67768), (0.01549, 0.60928), (0.01423, 0.53894), (0.0266, 0.47467), (0.0296, 0.46319)]
YU1 = [(-27.0, 1.0), (-21.857, -3.214), (-16.7, -7.428), (-11.571, -11.642), (-6.428, -15.857), (-1.285, -20.071),
       (3.857, -24.285), (9.0, -28.5), (15.0, -29.9), (20.0, -30.0), (27.2, -25.0), (29.2, -20.0), (28.0, -10.0),
       (22.7, 2.0), (15.0, 10.6), (5.0, 16.5), (-10.0, 19.6), (-22.0, 17.0), (-28.0, 11.0), (-29.0, 5.0)]


def _wu3():
    """Wu et al. (2011), the open path: 60 points as the four-bar-rs example lists them (rounded there)."""
    pts = """45.0,-19.0;48.42581120445897,-20.544582223866758;52.098866741880045,-21.97636275435283;
    56.01520797243689,-23.284889500844205;60.16896856506435,-24.46010809831239;64.55233181198156,-25.492462301199048;
    69.15550794506002,-26.372991602924984;73.96673202640261,-27.093425005162935;78.9722827574334,-27.646269896418502;
    84.15652231792492,-28.02489504659484;89.50195711133293,-28.22360678256477;94.98931905822458,-28.237717478699256;
    100.59766684812385,-28.06360557504899;106.3045063343788,-27.698766423573897;112.08592903923368,-27.141853358498718;
    117.91676752963032,-26.392708489474376;123.77076623071426,-25.452382824611544;129.62076606577884,-24.32314544341404;
    135.43890115047867,-23.008481555922238;141.19680562741146,-21.513079402681818;146.8658286062304,-19.842806069164823;
    152.41725507569225,-18.004672406658404;157.82253057860692,-16.006787368082623;163.05348738941493,-13.85830218040138;
    168.08256990767407,-11.569344883987785;172.88305697942607,-9.150945872281813;177.429278882269,-6.614955161187001;
    181.6968267587488,-3.97395220582015;185.6627523558875,-1.2411491614701786;189.3057560254789,1.569711444941758;
    192.6063610591623,4.4444636077542405;195.5470725729021,7.368628227043489;198.11251931581168,10.327525876062891;
    200.28957695648583,13.306390819321647;202.06747159417208,16.290485137697953;203.43786245006217,19.265211818238583;
    204.39490291340834,22.21622568006852;204.9352793456288,25.12954103395944;205.05822728051908,27.991635011287013;
    204.76552489751774,30.78954554790258;204.06146388503072,33.51096306929465;202.95279804942507,36.144314994624764;
    201.4486702598085,38.67884225798725;199.5605185465098,41.104667134647656;197.3019623897311,43.412851757052735;
    194.6886704417371,45.59544680897716;191.7382111188759,47.6455299951139;188.46988767656478,49.557233996496166;
    184.9045595391533,51.32576373808773;181.06445179556314,52.94740291238719;176.9729548892503,54.41950982064523;
    172.65441662607626,55.74050270996049;168.13392869506148,56.90983489879876;163.43710994397057,57.92796009408455;
    158.58988867375808,58.79628840870598;153.61828621286742,59.517133687874235;148.54820400431026,60.09365284517066;
    143.40521638570536,60.52977799327288;138.21437116566662,60.83014222933732;133.0,61.0"""
    return [tuple(float(v) for v in p.split(",")) for p in pts.replace("\n", "").replace(" ", "").split(";")]


# the published linkages, as four-bar-rs writes them: (p0x, p0y, a, l1, l2, l3, l4, l5, g, inv)
LITERATURE = {
    "McGarva 1994": {"points": MCGARVA, "closed": True,
                     "reference": (54.6, -35.5, 1.95, 47.5, 24.3, 48.1, 47.0, 85.6, 0.9599310885968813, True)},
    "Ullah & Kota 1997": {"points": ULLAH, "closed": True,
                          "reference": (-11.77, 5.38, 4.9031534676276705, 9.33, 1.41, 7.39, 3.6, 13.57,
                                        0.7452555906015788, False)},
    "Yu et al. 2007": {"points": YU1, "closed": True,
                       "reference": (-11.55, -20.14, 2.981022362406315, 65.87, 17.43, 25.46, 64.57, 23.47,
                                     2.834414705238791, False)},
    "Wu et al. 2011 (open)": {"points": None, "closed": False,
                              "reference": (198.6, -82.5, 2.670353755551324, 368.5, 74.0, 230.8, 213.6, 150.6,
                                            5.462880558742252, False)},
}


def reference_curve(p0x, p0y, a, l1, l2, l3, l4, l5, g, inv, step_deg=0.01):
    """The reference linkage's coupler curve over its whole motion (circle intersection), NaN where it breaks."""
    b = np.radians(np.arange(0.0, 360.0, step_deg))
    p0 = p0x + 1j * p0y
    p1 = p0 + l1 * np.exp(1j * a)
    p2 = p0 + l2 * np.exp(1j * (a + b))
    d = p1 - p2
    r = np.abs(d)
    along = 0.5 * (l3 * l3 - l4 * l4 + r * r) / r
    h2 = l3 * l3 - along * along
    h = np.sqrt(np.where(h2 >= 0, h2, np.nan)) * (-1.0 if inv else 1.0)
    u = d / r
    p3 = p2 + along * u + 1j * h * u
    p4 = p2 + l5 * np.exp(1j * (np.angle(p3 - p2) + g))
    return p4


def distances(targets, curve):
    """Distance of every target to the polyline through the curve's consecutive finite points."""
    q = np.asarray(targets, dtype=float)
    q = q[:, 0] + 1j * q[:, 1]
    c = np.append(curve, curve[0])
    a, b = c[:-1], c[1:]
    ok = np.isfinite(a) & np.isfinite(b)
    a, b = a[ok], b[ok]
    out = np.empty(len(q))
    for i, z in enumerate(q):
        dd = b - a
        t = np.clip(np.real((z - a) * np.conj(dd)) / np.maximum(np.abs(dd) ** 2, 1e-300), 0, 1)
        out[i] = np.min(np.abs(z - (a + t * dd)))
    return out


def literature(args, out):
    mech = ls.load(MODEL)
    rows = []
    for name, case in LITERATURE.items():
        pts = np.array(case["points"] if case["points"] is not None else _wu3(), dtype=float)
        ref = distances(pts, reference_curve(*case["reference"]))
        c0 = time.process_time()
        t0 = time.perf_counter()
        try:
            res = ls.synthesize(mech, shape="P", targets={"x": pts[:, 0], "y": pts[:, 1]}, closed=case["closed"],
                                top=5, progress=False)
            best = res.report["candidates"][0]
            ours = (best["shape_error"]["rms"], best["shape_error"]["max"], best["certificate"]["defects"] == [])
        except ls.SynthesisError as exc:
            ours = (math.inf, math.inf, False)
            print(f"{name}: no certified design ({exc})")
        row = {"curve": name, "points": len(pts), "closed": case["closed"],
               "reference_rms": float(np.sqrt(np.mean(ref ** 2))), "reference_max": float(ref.max()),
               "loopsolve_rms": ours[0], "loopsolve_max": ours[1], "certified": ours[2],
               "cpu_seconds": time.process_time() - c0, "seconds": time.perf_counter() - t0}
        rows.append(row)
        print(f"{name}: {len(pts)} points; reference rms {row['reference_rms']:.4g} (max {row['reference_max']:.4g}); "
              f"loopsolve rms {row['loopsolve_rms']:.4g} (max {row['loopsolve_max']:.4g}), certified {ours[2]}; "
              f"ratio {row['loopsolve_rms'] / row['reference_rms']:.3g}; {row['cpu_seconds']:.1f} s CPU", flush=True)
    out["literature"] = rows


def _ellipse():
    phi = np.radians(np.arange(0, 361, 40))
    return {"x": 10 + 10 * np.cos(phi), "y": 10 + 8 * np.sin(phi)}


PLACE = 80.0
PATH_PROBLEMS = {
    "ellipse (10 points, crank; published 4.02e-4)": {
        "targets": _ellipse(), "crank": True, "published": 4.02e-4,
        "vary": {**{f"r{i}": (5, 80) for i in range(1, 5)}, "rcx": (-80, 80), "rcy": (-80, 80), "x0": (-80, 80),
                 "y0": (-80, 80), "theta0": (0, 360)}},
    "vertical line (6 points, crank; exact exists)": {
        "targets": {"x": [20.0] * 6, "y": [10.0, 15.0, 20.0, 25.0, 30.0, 35.0]}, "crank": True, "published": 0.0,
        "vary": {**{f"r{i}": (5, 60) for i in range(1, 5)}, "rcx": (-60, 60), "rcy": (-60, 60), "x0": (-60, 60),
                 "y0": (-60, 60), "theta0": (0, 360)}},
    "half circle (8 points)": {
        "targets": {"x": list(np.cos(np.radians(np.linspace(0, 180, 8)))),
                    "y": list(np.sin(np.radians(np.linspace(0, 180, 8))))}, "crank": False, "published": 0.0,
        "vary": {**{f"r{i}": (0.2, 50) for i in range(1, 5)}, "rcx": (-50, 50), "rcy": (-50, 50), "x0": (-50, 50),
                 "y0": (-50, 50), "theta0": (0, 360)}},
    "eighteen points (MKH, crank, free timing)": {
        "targets": {"x": [0.5, 0.4, 0.3, 0.2, 0.1, 0.05, 0.02, 0, 0, 0.03, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5, 0.6, 0.6],
                    "y": [1.1, 1.1, 1.1, 1.0, 0.9, 0.75, 0.6, 0.5, 0.4, 0.3, 0.25, 0.2, 0.3, 0.4, 0.5, 0.7, 0.9, 1.0]},
        "crank": True, "published": 9.11e-3,
        "vary": {**{f"r{i}": (0.2, 50) for i in range(1, 5)}, "rcx": (-50, 50), "rcy": (-50, 50), "x0": (-50, 50),
                 "y0": (-50, 50), "theta0": (0, 360)}},
}


def _path_runs(name, prob, runs, atlas):
    mech = ls.load(MODEL)
    fs, secs, cpus, certified = [], [], [], 0
    for seed in range(runs):
        t0, c0 = time.perf_counter(), time.process_time()
        try:
            r = ls.synthesize(mech, path="P", targets=prob["targets"], vary=prob["vary"], crank=prob["crank"], seed=seed,
                              atlas=atlas, progress=False)
            fs.append(r.objective)
            certified += 1
        except ls.SynthesisError:
            fs.append(math.inf)
        secs.append(time.perf_counter() - t0)
        cpus.append(time.process_time() - c0)
        print(f"  {name} {'atlas' if atlas is None else 'no atlas'} seed {seed}: f={fs[-1]:.4g} "
              f"({secs[-1]:.1f} s, {cpus[-1]:.1f} s CPU)", flush=True)
    fin = [f for f in fs if math.isfinite(f)]
    return {"problem": name, "atlas": atlas is None, "runs": runs, "certified": certified,
            "median": statistics.median(fs) if fs else None, "best": min(fin) if fin else None,
            "median_seconds": statistics.median(secs), "median_cpu_seconds": statistics.median(cpus),
            "published": prob["published"]}


def path(args, out):
    rows = []
    for name, prob in PATH_PROBLEMS.items():
        if args.problem and args.problem not in name:
            continue
        for atlas in ([None, False] if args.compare else [None]):
            row = _path_runs(name, prob, args.runs, atlas)
            rows.append(row)
            print(f"{name}, {'with' if atlas is None else 'without'} atlas starts: median {row['median']:.4g}, best "
                  f"{row['best'] if row['best'] is None else format(row['best'], '.4g')}, certified "
                  f"{row['certified']}/{row['runs']}, median {row['median_seconds']:.1f} s "
                  f"({row['median_cpu_seconds']:.1f} s CPU)", flush=True)
    out["path"] = rows


def speed(args, out):
    from loopsolve.design.atlas.build import build_atlas
    from loopsolve.design.atlas.defaults import default_atlas

    mech = ls.load(MODEL)
    c0 = time.process_time()
    atlas = default_atlas(mech, "P", progress=False)
    load = time.process_time() - c0
    ell = _ellipse()
    xy = np.stack([ell["x"][:-1], ell["y"][:-1]], axis=1)
    res = ls.synthesize(mech, shape="P", targets=xy, atlas=atlas, top=5, progress=False)
    cpu = res.report["statistics"]["cpu_seconds"]
    shape_total = cpu["retrieval"] + cpu["polish_certify"]
    # an open curve: Wu et al.'s 60 points, compared with every window of every stored curve
    wu = np.array(_wu3())
    res_o = ls.synthesize(mech, shape="P", targets=wu, closed=False, atlas=atlas, top=5, progress=False)
    cpu_o = res_o.report["statistics"]["cpu_seconds"]
    open_total = cpu_o["retrieval"] + cpu_o["polish_certify"]
    print(f"speed: Wu et al.'s open curve as a shape query: retrieval {cpu_o['retrieval']:.2f} s, retrieval + polish + "
          f"certificates {open_total:.2f} s CPU (rms {res_o.report['candidates'][0]['shape_error']['rms']:.4g})",
          flush=True)
    c0 = time.process_time()
    prob = PATH_PROBLEMS["ellipse (10 points, crank; published 4.02e-4)"]
    try:
        ls.synthesize(mech, path="P", targets=prob["targets"], vary=prob["vary"], crank=True, seed=0, atlas=False,
                      progress=False)
    except ls.SynthesisError:
        pass
    path_cpu = time.process_time() - c0
    row = {"atlas_load_cpu": load, "retrieval_cpu": cpu["retrieval"], "shape_cpu": shape_total,
           "shape_rms": res.report["candidates"][0]["shape_error"]["rms"], "path_free_timing_cpu": path_cpu,
           "ratio_path_over_shape": path_cpu / shape_total, "open_retrieval_cpu": cpu_o["retrieval"],
           "open_shape_cpu": open_total, "open_shape_rms": res_o.report["candidates"][0]["shape_error"]["rms"]}
    print(f"speed: default atlas opened in {load:.2f} s CPU; ellipse shape query: retrieval {cpu['retrieval']:.2f} s, "
          f"retrieval + polish + certificates {shape_total:.2f} s CPU (rms {row['shape_rms']:.3g}); "
          f"--path free timing, one run without atlas starts: {path_cpu:.1f} s CPU: {row['ratio_path_over_shape']:.1f}x",
          flush=True)
    vary = {"r2": (0.4, 4), "r3": (1.6, 16), "r4": (1.6, 16), "rcx": (-8, 16), "rcy": (-12, 12)}
    n = args.build_size
    rates = {}
    for label, workers in (("this process", None), ("1 Dask worker", 1), ("2 Dask workers", 2)):
        t0 = time.perf_counter()
        build_atlas(mech, point="P", vary=vary, size=n, chunk=max(n // 8, 256), workers=workers, step_deg=4.0,
                    progress=False)
        rates[label] = n / (time.perf_counter() - t0)
        print(f"build rate, {label}: {rates[label]:.0f} designs/s ({n} designs)", flush=True)
    row["build_rates"] = rates
    out["speed"] = row


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", choices=("literature", "path", "speed"))
    ap.add_argument("--runs", type=int, default=30)
    ap.add_argument("--compare", action="store_true", help="path problems also without the atlas starts")
    ap.add_argument("--problem", help="only the path problems whose name holds this text (ellipse, line, ...)")
    ap.add_argument("--build-size", type=int, default=16384)
    ap.add_argument("--json", help="write the figures to this file")
    args = ap.parse_args()
    out = {}
    for part, fn in (("literature", literature), ("path", path), ("speed", speed)):
        if args.only in (None, part):
            fn(args, out)
    if args.json:
        with open(args.json, "w", encoding="utf-8") as f:
            json.dump(out, f, indent=1)


if __name__ == "__main__":
    main()
