"""``synthesize``: runs of search + polish + certificate, the report, the result object.

See :mod:`loopsolve.design.synthesis.problem` for the design (problem, batched objective, search, polish) and
:mod:`loopsolve.design.synthesis.certificate` for the certificate. One run is: a seeded differential-evolution search
per mode (:func:`loopsolve.design.synthesis.problem.search`) and a Latin-hypercube multistart
(:func:`loopsolve.design.synthesis.lockstep_lm.multistart`); the distinct best members of the DE populations and the
best sampled designs are polished together by the lockstep Levenberg–Marquardt
(:func:`loopsolve.design.synthesis.lockstep_lm.batch_lm`, one batch per iteration); the distinct basins they end in
(duplicates dropped, :func:`loopsolve.design.synthesis.lockstep_lm.distinct`) get the exact least-squares polish and
the tracker's certificate, best first; the run's result is its best certified design. ``runs``
runs use the seeds ``seed, seed + 1, ...`` and run one after the other, or as Dask tasks (``workers``/``scheduler``/``client``, as studies do).
"""

from __future__ import annotations

import json
import math
import sys
import time

import numpy as np

from ...errors import ModelError
from ...errors import SynthesisError
from .design_model import certify_design, clean, design_model
from .problem import define, polish, search_many, sign_string

__all__ = ["synthesize", "SynthesisResult"]


class SynthesisResult:
    """The certified best design of a synthesis.

    Users receive one from :func:`loopsolve.synthesize` (general method); they need not construct
    one. ``to_toml()`` writes the design as a model file, ``plot()`` draws it over the targets.

    Parameters
    ----------
    problem : object
        The synthesis problem (the model, the targets, the varied parameters).
    mechanism : Mechanism
        The model with the found values.
    report : dict
        The synthesis contract's report (``objective``, ``parameters``, ``certificate``,
        ``targets``, ``runs``...).
    values : numpy.ndarray
        The varied parameters' values (model units), in the order of ``vary``.
    inputs : numpy.ndarray
        The input at each target (internal units: radians or the model's length unit).
    positions : numpy.ndarray
        ``(nv, T)``: every variable at each target (internal units).

    Attributes
    ----------
    mechanism : Mechanism
        The model with the found values; its guesses are the pose at the first target, so they
        name its mode.
    objective : float
        The objective reached: the sum of squared target errors (the report's units: squared
        model length unit for a path, radians squared for a function).
    report : dict
        As the parameter.
    problem, values, inputs, positions
        As the parameters of the same names.

    Examples
    --------
    The coupler point of the model's own four-bar at three crank angles; find the crank length
    and the coupler point again:

    >>> import loopsolve as ls
    >>> mech = ls.load(ls.models_dir() / "fourbar_path_synthesis.toml")
    >>> targets = {"x": [1.247635, 1.125070, 0.759129], "y": [2.261923, 2.556968, 2.635152]}
    >>> res = ls.synthesize(mech, path="P", targets=targets, inputs=[30, 60, 90],
    ...                     vary={"r2": (0.5, 2), "rcx": (0, 3)}, popsize=5, maxiter=5,
    ...                     mode="guesses", polish_candidates=1, progress=False)
    >>> [round(float(v), 3) for v in res.values], res.objective < 1e-9, res.positions.shape
    ([1.0, 1.5], True, (3, 3))
    >>> res.report["certificate"]["defects"]
    []
    """

    def __init__(self, problem, mechanism, report, values, inputs, positions):
        self.problem = problem
        self.mechanism = mechanism
        self.report = report
        self.objective = report["objective"]
        self.values = values
        self.inputs = inputs
        self.positions = positions

    def __repr__(self) -> str:
        return (f"SynthesisResult(task={self.report['task']!r}, objective={self.objective:.6g}, "
                f"mode={self.report['mode']!r}, defects={self.report['certificate']['defects']})")

    def to_toml(self) -> str:
        """The design as a model file (TOML text)."""
        from ...model.modelfile import dumps

        return dumps(self.mechanism)

    def to_json(self) -> str:
        return json.dumps(self.report, indent=2, allow_nan=False)

    def plot(self, *, ax=None, output=None, linkages: bool = True):
        """Targets, the design's curve over the motion and (``linkages``) the linkage at each target."""
        from ...output.plotting import draw
        from ...kinematics.solve import display_value

        import matplotlib.pyplot as plt

        pr = self.problem
        mech = self.mechanism
        if ax is None:
            fig, ax = plt.subplots(figsize=(7, 6))
        else:
            fig = ax.figure
        ck = mech.compile()
        x0 = float(self.inputs[0])
        d = self.report["direction"]
        a = display_value(ck, x0)
        span = 2 * math.pi if (pr.crank or ck.kinds[ck.input_idx[0]].name == "ANGLE") else float(
            abs(self.inputs[-1] - x0))
        b = display_value(ck, x0 + d * span)
        try:
            sw = mech.sweep(a, b, abs(b - a) / 360, progress=False, derivatives=1)
            if pr.task != "function":
                ax.plot(sw.columns[f"{pr.point}_x"], sw.columns[f"{pr.point}_y"], "-", color="C0", lw=1.2,
                        label=f"{pr.point} (design)")
            else:
                ax.plot(sw.columns[ck.inputs[0]], sw.columns[pr.output], "-", color="C0", label=f"{pr.output}(input)")
        except Exception:  # noqa: BLE001 — the curve is a picture; the report already holds the figures
            pass
        if pr.task == "function":
            ax.plot(pr.display_input(self.inputs), np.degrees(pr.targets[:, 0]) if mech.units.angle == "deg"
                    else pr.targets[:, 0], "o", color="C3", label="targets")
            ax.set_xlabel(ck.inputs[0])
            ax.set_ylabel(pr.output)
        else:
            if linkages:
                for t, x in enumerate(self.inputs):
                    try:
                        guess = {n: float(self.positions[i, t]) for i, n in enumerate(ck.variables)}
                        draw(mech, display_value(ck, float(x)), ax=ax, guess=guess)
                    except Exception:  # noqa: BLE001
                        pass
            ax.plot(pr.targets[:, 0], pr.targets[:, 1], "o", mfc="none", color="C3", ms=9, label="targets")
            ax.set_aspect("equal", adjustable="datalim")
        ax.legend(loc="best", fontsize=8)
        ax.set_title(f"{mech.name}: {pr.task} synthesis, f = {self.objective:.4g}")
        if output is not None:
            fig.savefig(output, dpi=120, bbox_inches="tight")
        return fig


def _distinct(V, f, k, lo, hi):
    """Indices of up to ``k`` members, best first, at least 1 % of the box apart."""
    out = []
    span = hi - lo
    for i in np.argsort(f, kind="stable"):
        if not np.isfinite(f[i]):
            continue
        if all(np.max(np.abs(V[i] - V[j]) / span) > 0.01 for j in out):
            out.append(i)
        if len(out) >= k:
            break
    return out


#: the multistart samples this many designs per start kept (sampling is one cheap batch; on the
#: eighteen-point benchmark 10 per start gave the 9.03e-3 basin in 18 of 30 runs, 30 in the six
#: missed seeds tried)
_SAMPLE_RATIO = 30

#: free timing: the lockstep LM's stall stop (a start whose objective fell by less than ``_STALL_DROP``, relative,
#: over its last ``_STALL`` iterations stops: the basins are told apart early and the exact polish
#: finishes the best ones; the crawling starts were most of the free-timing LM's iterations) and the largest
#: change of a free input per step (radians: a longer jump can pass a branch point or a limit of the motion)
_STALL = 5
_STALL_DROP = 1e-3
_FREE_INPUT_STEP = math.radians(10.0)

#: a basin whose lockstep-LM objective exceeds this factor times the best polished design's (or
#: :func:`_polish_floor`, if larger) is not polished
_POLISH_MARGIN = 10.0


#: the exact-fit floor of free timing, relative to the targets' spread squared per target. Free timing
#: fits the inputs too, so a design either meets its targets to round-off or stops at a real optimum;
#: the prescribed-timing floor (1e-6) was about twice the published ellipse's optimum (4.05e-4 against
#: 8.2e-4), so every near-optimal basin counted as exact and the lockstep LM and the exact polish stopped
#: short of the optimum (median 4.5e-4). 1e-12 is an exact fit to round-off of the free inputs' traces.
_FREE_FLOOR = 1e-12


def _polish_floor(problem) -> float:
    """A millionth of the targets' spread squared per target (free timing: :data:`_FREE_FLOOR` of it): below it
    every basin counts as exact."""
    rel = _FREE_FLOOR if problem.free else 1e-6
    return rel * problem.T * float(np.sum(np.var(problem.targets, axis=0)))


def _repeats_exact_fit(p, cands, floor) -> bool:
    """Whether the polished ``p`` lands on the best polished candidate and that is an exact fit (≤ ``floor``).

    Then the exact fit is confirmed by two starts, and (once it is certified) the basins still to
    polish are not: their lockstep values are worse (on the five-point benchmark all six polished
    basins ended at 7.4158e-7: starts the lockstep LM had stopped short of the same bottom).
    """
    if not cands:
        return False
    best = min(cands, key=lambda c: c["objective"])
    fb, fp = best["objective"], p["objective"]
    return fb <= floor and abs(fp - fb) <= 1e-6 * fb + 1e-12 * floor


def _closing_turn(problem, p):
    """A free-timing target list whose last target repeats the first (a closed curve written back to its start):
    the optimum meets it a whole turn after the first, where the certificate's order (within one turn) fails by
    a hair. Such a last input is set just short of the turn (2π·(1 − 1e-10)), its pose the first's."""
    if not problem.free or problem.T < 3 or not math.isfinite(p.get("objective", math.inf)):
        return p
    t = problem.targets
    if not np.allclose(t[0], t[-1], rtol=0, atol=1e-12 * (1 + float(np.max(np.abs(t))))):
        return p
    x = np.asarray(p["inputs"], dtype=float).copy()
    turn = 2 * math.pi
    if abs(x[-1] - x[0]) < turn * (1 - 1e-10) or p.get("Z") is None:
        return p
    x[-1] = x[0] + math.copysign(turn * (1 - 1e-10), x[-1] - x[0])
    Z = p["Z"].copy()
    Z[:, -1] = Z[:, 0]
    Z[problem.batch.ix, -1] = x[-1]
    P = problem.batch.params(np.asarray(p["values"])[None])
    r = problem.residuals(Z[:, :, None], P)
    return dict(p, inputs=x, Z=Z, objective=float(np.sum(r * r)), errors=np.sqrt(np.sum(r * r, axis=0))[:, 0])


def one_run(problem, seed, opts):
    """One run: ``(best candidate dict or None, rejected list, seconds, statistics)``."""
    import dataclasses

    t0 = time.perf_counter()
    if problem.mode == "any":  # one search per mode: a basin of one mode cannot crowd out the other's
        subs = [dataclasses.replace(problem, mode=sign_string(sg)) for sg in problem.batch.all_signs()]
    else:
        subs = [problem]
    gens, nev, history = 0, 0, []
    rng = np.random.default_rng(seed)
    seeds = [[int(rng.integers(2**31)) for _ in range(opts["restarts"])] for _ in subs]
    # the searches of every mode run in lockstep: one batch per generation for all of them
    flat = [(sub, s) for sub, ss in zip(subs, seeds) for s in ss]
    res = search_many(problem, [s for _, s in flat], problems=[sub for sub, _ in flat], popsize=opts["popsize"],
                      maxiter=opts["maxiter"], tol=opts["tol"], strategy=opts["strategy"]) if flat else []
    found = [(sub, r) for (sub, _), r in zip(flat, res)]
    starts = []  # (V (D, k), signs (nb, D), X (T, D), direction (D,)) from every source
    for sub, (V, f, mi, di, X, g, n, hist) in found:
        gens += g
        nev += n
        history.append({"mode": sub.mode, "best": hist})
        modes = sub.modes(sub.batch.params(V))
        ix = _distinct(V, f, opts["de_starts"], sub.lo, sub.hi)
        if ix:
            starts.append((V[ix], np.stack([modes[mi[i]][:, i] for i in ix], axis=1), X[:, ix], di[ix]))
    if opts["starts"]:
        from .lockstep_lm import multistart

        n = opts["starts"] * _SAMPLE_RATIO
        Vm, Sm, Xm, fm = multistart(problem, n, opts["starts"], int(rng.integers(2**31)),
                                    chunk=opts.get("chunk", 4000))
        nev += n
        if len(fm):
            dm = (np.sign(Xm[-1] - Xm[0]) if problem.free else np.ones(len(fm))).astype(int)
            starts.append((Vm, Sm, Xm, np.where(dm == 0, 1, dm)))
    if opts.get("atlas") is not False and problem.task == "path" and problem.free:
        from .shape.path_starts import atlas_starts  # the targets as a curve: its nearest atlas designs, placed on it

        got = atlas_starts(problem, atlas=opts.get("atlas"))
        if got is not None:
            starts.append(got)
    if starts:
        from .lockstep_lm import batch_lm, distinct
        from .problem import periodic

        V = np.vstack([s[0] for s in starts])
        S = np.hstack([s[1] for s in starts])
        X = np.hstack([s[2] for s in starts])
        di = np.concatenate([s[3] for s in starts])
        # every start polished at once (one batch per iteration); only distinct basins go on
        V0, X0 = V, X
        # (the plain pass stops at the prescribed-timing floor, as before: only the second pass needs the round-off one)
        V, X, f = batch_lm(problem, V, S, X, iters=opts["lm_iters"],
                           floor=_polish_floor(problem) * (1e-6 / _FREE_FLOOR if problem.free else 1.0))
        if problem.free:  # again with MINPACK's scaling, an active set on the bounds, a stall stop, capped input
            # steps; both polishes' ends go on (each reaches basins the other misses: the ellipse's optimum, with
            # a length on its bound, only with these; the vertical line's exact fit of seed 2 only without them)
            Vt, Xt, ft = batch_lm(problem, V0, S, X0, iters=opts["lm_iters"], floor=_polish_floor(problem),
                                  trust=True, stall=(_STALL, _STALL_DROP), pin=True, free_step=_FREE_INPUT_STEP)
            V, X, f = np.vstack([V, Vt]), np.hstack([X, Xt]), np.concatenate([f, ft])
            S, di = np.hstack([S, S]), np.concatenate([di, di])
        per, period = periodic(problem)
        order = distinct(V, f, problem.lo, problem.hi, k=opts["polish"], rtol_f=1e-3, dist=0.02,
                         periodic_mask=per, period=period)
    else:
        order = []
    # exact polish of the distinct basins, best first, skipping those whose lockstep value is far
    # above the best polished one (the polish lowers a value by a few per cent once LM has all but
    # converged); then the certificate, best polished first, until one holds
    floor = _polish_floor(problem)
    cands = []
    for i in order:
        if cands and f[i] > _POLISH_MARGIN * max(min(c["objective"] for c in cands), floor):
            break
        p = polish(problem, V[i], signs=S[:, i], inputs=X[:, i] if problem.free else None)
        p = _closing_turn(problem, p)
        if math.isfinite(p.get("objective", math.inf)):
            p["direction"] = int(di[i]) if problem.free else (1 if problem.inputs[-1] >= problem.inputs[0]
                                                             else -1)
            again = _repeats_exact_fit(p, cands, floor)
            cands.append(p)
            if again:  # a second start polished onto the best, an exact fit: if that one is certified,
                # the basins left (worse lockstep values) are not polished
                b = min(cands, key=lambda c: c["objective"])
                b["certificate"] = certify_design(problem, b["values"], b["inputs"], b["signs"], b["Z"])
                if not b["certificate"]["defects"]:
                    break
    cands.sort(key=lambda c: c["objective"])
    rejected, best = [], None
    for c in cands:
        if "certificate" not in c:
            c["certificate"] = certify_design(problem, c["values"], c["inputs"], c["signs"], c["Z"])
        cert = c["certificate"]
        if not cert["defects"]:
            best = c
            break
        rejected.append({"seed": seed, "objective": c["objective"],
                         "parameters": dict(zip(problem.names, map(float, c["values"]))),
                         "defects": cert["defects"], "notes": cert["notes"]})
    return best, rejected, time.perf_counter() - t0, {"generations": gens, "evaluations": nev, "history": history}


def _run_task(args):
    """A Dask task: rebuild the problem on the worker, run once; plain data back."""
    kwargs, seed, opts = args
    from ...model.modelfile import loads

    kwargs = dict(kwargs)
    kwargs["mech"] = loads(kwargs.pop("model_text"), source=kwargs.pop("source"))
    mech = kwargs.pop("mech")
    problem = define(mech, **kwargs)
    return one_run(problem, seed, opts)


def synthesize(mech, *, path=None, function=None, motion=None, link=None, targets=None, inputs=None, vary=None,
               crank: bool = False, transmission=None, runs: int = 1, seed: int = 0, mode: str | None = "any",
               popsize: int = 15, maxiter: int = 60, tol: float = 1e-3, restarts: int = 1,
               strategy: str = "best1bin", polish_candidates: int = 6, starts: int | None = None,
               de_starts: int = 10, lm_iters: int = 60,
               workers: int | None = None, scheduler: str | None = None, client=None,
               progress: bool | None = None, method: str = "general", input_range=None, desired=None,
               max_cells: int | None = None, max_targets: int | None = None,
               shape=None, closed: bool = True, atlas=None, top: int = 5):
    """Find parameter values that make ``mech`` do a job; only certified designs are returned.

    Parameters
    ----------
    mech : Mechanism
    path : str
        Path generation: the point that must pass through the targets (CSV ``x,y``).
    function : str
        Function generation: the unknown that must follow the targets (CSV ``input,output``).
    motion, link : str
        Motion generation: the point and the angle variable of the link (CSV ``x,y,angle``).
    targets : path, CSV text, mapping of columns or array
        With an ``input`` column the timing is prescribed.
    inputs : sequence or "X1,X2,...", optional
        Prescribed input values (model units), one per target; without them (and no ``input``
        column) the timing is free: the targets are met in order as the input moves one way,
        within one turn.
    vary : mapping name → (low, high)
        The design variables (model units).
    crank : bool
        The input must turn fully.
    transmission : (lo, hi) or "LO:HI", optional
        Bounds of the transmission angle over the motion (degrees).
    runs, seed : int
        Independent runs, seeded ``seed``, ``seed + 1``, ...
    mode : "any", None or a signature
        The assembly mode: ``"any"`` lets the search pick (the report says which), ``None``
        keeps the mode the guesses name, a signature (``"-"``) that mode.
    popsize, maxiter, tol, strategy : differential-evolution settings (scipy's meaning).
    restarts : int
        Short DE searches per mode in one run (seeded from the run's seed); each search's best
        ``de_starts`` distinct designs are starts of the lockstep Levenberg–Marquardt.
    starts : int, optional
        Latin-hypercube multistart: ``30 * starts`` designs are sampled and evaluated in one
        batch, the ``starts`` best are further starts of the lockstep Levenberg–Marquardt
        (default ``40 *`` the number of varied parameters; 0: none).
    de_starts, lm_iters : int
        Starts taken from each DE search; iterations of the lockstep Levenberg–Marquardt.
    polish_candidates : int
        Distinct basins (after the lockstep Levenberg–Marquardt) given the exact polish and the
        certificate, best first.
    workers, scheduler, client
        Spread the runs over a Dask cluster (as :func:`loopsolve.study` does).
    progress : bool, optional
        Runs completed on stderr (tqdm); default: on a terminal.
    max_cells, max_targets : int, optional
        Bounds checked before any work (:mod:`loopsolve.design.synthesis.limits`): the positions the
        synthesis may trace (runs × design evaluations × trace steps, default 10⁸, about an hour)
        and the number of targets (default 1000). Every option is checked too (whole numbers in
        range; ``workers`` within the machine's CPUs; at most 256 lockstep DE searches a run) and
        the targets (none at the same prescribed input; with free timing no repeat in a row; an
        angle input's values within one turn).
    method : {"general", "freudenstein", "burmester"}
        ``general`` (this engine); the classical four-bar methods (``function=`` for
        Freudenstein, ``motion=``/``link=`` with five poses for Burmester) go to
        :func:`loopsolve.design.synthesis.classical.run.classic_synthesize` (``vary`` and the search options are
        not used) and return its result; a design with defects raises :class:`SynthesisError`
        whose ``report`` lists them.
    input_range : (lo, hi), optional
        Function generation: the intended input range (model units; default the targets'
        span) over which the report's ``structural_error`` (largest |y(x) − y_wanted(x)|, the
        wanted curve being the PCHIP through the targets) is measured by tracking the design.
    desired : callable, optional
        Function generation: the wanted output y(x) (model units, vectorized) as the reference
        of ``structural_error`` instead of the PCHIP through the targets.

    shape, closed, atlas, top
        Shape synthesis: the point ``shape`` traces the curve ``targets`` (``closed`` or an open
        stretch), free in position, orientation, scale and timing, from ``atlas`` (default: the
        model's default atlas); the ``top`` best certified designs: see
        :func:`loopsolve.design.synthesis.shape.run.synthesize_shape` (``vary`` bounds or fixes parameters there).
        Path generation with free timing also takes starts from ``atlas`` (default: the model's
        default atlas when it has one; ``False``: none), see :mod:`loopsolve.design.synthesis.shape.path_starts`.

    Returns
    -------
    SynthesisResult (ClassicSynthesis for the classical methods, ShapeResult for ``shape``)

    Raises
    ------
    ModelError
        Bad targets, bounds, names, options out of range, work or memory beyond the bounds (exit
        2 on the command line).
    SynthesisError
        No run found a certified design (its ``report`` lists the rejected candidates).

    Examples
    --------
    The coupler point of the model's own four-bar at three crank angles; find the crank length
    and the coupler point again:

    >>> mech = ls.load(ls.models_dir() / "fourbar_path_synthesis.toml")
    >>> targets = {"x": [1.247635, 1.125070, 0.759129], "y": [2.261923, 2.556968, 2.635152]}
    >>> res = ls.synthesize(mech, path="P", targets=targets, inputs=[30, 60, 90],
    ...                     vary={"r2": (0.5, 2), "rcx": (0, 3)}, popsize=8, maxiter=30, restarts=1,
    ...                     mode="guesses", progress=False)
    >>> {k: round(v, 3) for k, v in res.report["parameters"].items()}, res.report["certificate"]["defects"]
    ({'r2': 1.0, 'rcx': 1.5}, [])
    """
    from .limits import MAX_CELLS, MAX_TARGETS, check_options, check_work, multistart_chunk

    max_cells = MAX_CELLS if max_cells is None else max_cells
    max_targets = MAX_TARGETS if max_targets is None else max_targets
    check_options(runs=runs, seed=seed, popsize=popsize, maxiter=maxiter, tol=tol, restarts=restarts, starts=starts,
                  de_starts=de_starts, lm_iters=lm_iters, polish_candidates=polish_candidates, strategy=strategy,
                  workers=workers, scheduler=scheduler, max_cells=max_cells, max_targets=max_targets)
    if shape is not None:
        from .shape.run import synthesize_shape

        for k, v in (("path", path), ("function", function), ("motion", motion), ("inputs", inputs)):
            if v is not None:
                raise ModelError(f"{k}= is not used with shape= (shape synthesis is free in timing)")
        return synthesize_shape(mech, shape=shape, targets=targets, closed=closed, atlas=atlas, top=top, crank=crank,
                                transmission=transmission, vary=vary, seed=seed, progress=progress,
                                max_targets=max_targets)
    if method != "general":
        return _classic(mech, method, path=path, function=function, motion=motion, link=link, targets=targets,
                        input_range=input_range, desired=desired, max_targets=max_targets, vary=vary, inputs=inputs,
                        crank=crank, transmission=transmission)
    if mode == "guesses":
        mode = None
    from ...model.gears import teeth_parameters

    if vary and set(vary) & teeth_parameters(mech):  # whole tooth numbers: every combination in the bounds
        return _over_teeth(mech, dict(vary), teeth_parameters(mech), dict(
            path=path, function=function, motion=motion, link=link, targets=targets, inputs=inputs, crank=crank,
            transmission=transmission, runs=runs, seed=seed, mode=mode, popsize=popsize, maxiter=maxiter, tol=tol,
            restarts=restarts, strategy=strategy, polish_candidates=polish_candidates, starts=starts,
            de_starts=de_starts, lm_iters=lm_iters, workers=workers, scheduler=scheduler, client=client,
            progress=progress, input_range=input_range, desired=desired, max_cells=max_cells,
            max_targets=max_targets))
    problem = define(mech, path=path, function=function, motion=motion, link=link, targets=targets, inputs=inputs,
                     vary=vary, crank=crank, transmission=transmission, mode=mode, max_targets=max_targets)
    opts = {"popsize": popsize, "maxiter": maxiter, "tol": tol, "polish": polish_candidates, "restarts": restarts,
            "strategy": strategy, "starts": 40 * len(problem.names) if starts is None else starts,
            "de_starts": de_starts, "lm_iters": lm_iters, "chunk": multistart_chunk(problem),
            "atlas": atlas if atlas is None or atlas is False else str(getattr(atlas, "path", atlas))}
    check_work(problem, runs=runs, popsize=popsize, maxiter=maxiter, restarts=restarts, starts=opts["starts"],
               de_starts=de_starts, lm_iters=lm_iters, max_cells=max_cells)
    seeds = [seed + r for r in range(runs)]
    if progress is None:
        progress = sys.stderr.isatty()
    bar = None
    if progress:
        try:
            from tqdm import tqdm

            bar = tqdm(total=runs, desc="synthesis runs", unit="run", file=sys.stderr)
        except ImportError:  # pragma: no cover
            bar = None
    if workers or scheduler or client is not None:
        outs = _dask_runs(problem, mech, dict(path=path, function=function, motion=motion, link=link,
                                              targets=problem_targets(problem, targets), inputs=inputs, vary=vary,
                                              crank=crank, transmission=transmission, mode=mode,
                                              max_targets=max_targets),
                          seeds, opts, workers, scheduler, client, bar)
    else:
        outs = []
        for s in seeds:
            outs.append(one_run(problem, s, opts))
            if bar is not None:
                bar.update(1)
    if bar is not None:
        bar.close()
    return _result(problem, outs, input_range, desired)


#: most combinations of tooth numbers one synthesis tries
MAX_TEETH_COMBINATIONS = 256


def _over_teeth(mech, vary, teeth, kwargs):
    """Synthesis with tooth numbers among the design variables: the continuous ones are synthesized for
    every combination of whole tooth numbers in their bounds; the best certified design wins."""
    import itertools

    names = [n for n in vary if n in teeth]
    ranges = []
    for n in names:
        lo, hi = (float(v) for v in vary[n])
        values = list(range(max(1, math.ceil(min(lo, hi))), math.floor(max(lo, hi)) + 1))
        if not values:
            raise ModelError(f"--vary {n}={lo:g}:{hi:g}: {n} is a number of teeth and no whole number lies in these "
                             "bounds")
        ranges.append(values)
    count = math.prod(len(r) for r in ranges)
    if count > MAX_TEETH_COMBINATIONS:
        raise ModelError(f"--vary {', '.join(names)}: {count} combinations of tooth numbers, more than "
                         f"{MAX_TEETH_COMBINATIONS}: narrow their bounds")
    rest = {n: v for n, v in vary.items() if n not in teeth}
    if not rest:
        raise ModelError("--vary: a synthesis varies at least one continuous parameter besides the tooth numbers "
                         f"({', '.join(names)}; a study tries tooth numbers alone)")
    best, last_error = None, None
    for combo in itertools.product(*ranges):
        fixed = dict(zip(names, combo))
        try:
            res = synthesize(mech.with_parameters(**fixed), vary=rest, **kwargs)
        except SynthesisError as exc:
            last_error = exc
            continue
        res.report["parameters"] = {**{n: float(v) for n, v in fixed.items()}, **res.report["parameters"]}
        if best is None or res.objective < best.objective:
            best = res
    if best is None:
        raise last_error
    return best


def _classic(mech, method, *, path, function, motion, link, targets, input_range, desired, crank, transmission,
             max_targets, **general_only):
    from .classical.run import METHODS, classic_synthesize

    if method not in METHODS:
        raise ModelError(f"method={method!r}: expected 'general', {', '.join(repr(m) for m in METHODS)}")
    if path is not None:
        raise ModelError(f"method={method!r} is for {'function' if method == 'freudenstein' else 'motion'} "
                         "generation; path generation uses the general method")
    for k, v in general_only.items():
        if v:
            raise ModelError(f"{k}= is not used by method={method!r} (it is for the general method)")
    from ...errors import SolveError

    try:
        res = classic_synthesize(mech, method=method, targets=targets, function=function, motion=motion, link=link,
                                 input_range=input_range, desired=desired, crank=crank, transmission=transmission,
                                 max_targets=max_targets)
    except SynthesisError:
        raise
    except SolveError as exc:  # no usable candidate: the same error as the general method's, with the report
        raise SynthesisError(str(exc), report=getattr(exc, "report", None)) from None
    defects = res.report["certificate"]["defects"]
    if defects:
        msgs = [d["message"] for d in res.report.get("design", {}).get("defects", [])[:2]] or \
            res.report["certificate"].get("notes", [])[:2]
        raise SynthesisError(f"{method}: the design has defects ({', '.join(defects)})"
                             + (": " + "; ".join(msgs) if msgs else "")
                             + "; try more targets (least squares) or the general method", report=res.report)
    return res


def _shown_targets(problem) -> np.ndarray:
    """The targets in model units (a function's angle output or a motion's angle in the model's angle unit)."""
    from ...model.units import Kind

    t = np.array(problem.targets, dtype=float)
    deg = problem.mech.units.angle == "deg"
    if problem.task == "function" and deg and problem.ck.kinds[problem.ck.index(problem.output)] is Kind.ANGLE:
        t = np.degrees(t)
    if problem.task == "motion" and deg:
        t[:, 2] = np.degrees(t[:, 2])
    return t


def _function_structural_error(problem, mech, report, input_range, desired=None):
    from .structural_error import structural_error
    from ...model.units import Kind

    ck = problem.ck
    y = problem.targets[:, 0]
    if ck.kinds[ck.index(problem.output)] is Kind.ANGLE:  # targets written in any turn: one continuous curve
        y = np.unwrap(y)
        if problem.mech.units.angle == "deg":
            y = np.degrees(y)
    x = np.array([t["input"] for t in report["targets"]], dtype=float)
    return structural_error(mech, problem.output, float(x[0]), targets=(x, y), input_range=input_range,
                            desired=desired)


def problem_targets(problem, targets):
    """Targets as plain columns (what a Dask task can carry)."""
    from .problem import read_targets

    return {k: v.tolist() for k, v in read_targets(targets, problem.task).items()}


def _dask_runs(problem, mech, kwargs, seeds, opts, workers, scheduler, client, bar):
    from ...model.modelfile import dumps

    from ..studies import make_client  # the studies' cluster rules (local processes or a scheduler)

    own = None
    if client is None:
        client = own = make_client(workers or 1, scheduler)
    kwargs = dict(kwargs, model_text=dumps(mech), source=mech.source or mech.name)
    try:
        futs = [client.submit(_run_task, (kwargs, s, opts), pure=False) for s in seeds]
        outs = []
        for fut in futs:
            outs.append(fut.result())
            if bar is not None:
                bar.update(1)
    finally:
        if own is not None:
            cluster = getattr(own, "cluster", None)
            own.close()
            if cluster is not None and not scheduler:
                cluster.close()
    return outs


def _result(problem, outs, input_range=None, desired=None) -> SynthesisResult:
    from ...kinematics.solve import display_value

    runs_f, secs, rejected, gens, nev, hist = [], [], [], [], 0, []
    best = None
    for cand, rej, sec, stats in outs:
        runs_f.append(cand["objective"] if cand else None)
        secs.append(sec)
        rejected.extend(rej)
        gens.append(stats["generations"])
        hist.append(stats.get("history", []))
        nev += stats["evaluations"]
        if cand and (best is None or cand["objective"] < best["objective"]):
            best = cand
    stats = {"generations": gens, "evaluations": nev, "certified_runs": sum(f is not None for f in runs_f),
             "rejected": rejected, "history": hist}
    report = {"task": problem.task, "objective": None, "parameters": None, "runs": runs_f, "seconds": secs,
              "mode": None, "direction": None, "targets": None, "certificate": None, "statistics": stats}
    if best is None:
        why = "; ".join(f"f={r['objective']:.3g}: {', '.join(r['defects'])}" for r in rejected[:4]) or \
            "no candidate could be traced through the targets in one motion"
        raise SynthesisError(f"{problem.mech.source or problem.mech.name}: no certified design in {len(outs)} run(s) "
                             f"({why}); widen the bounds, add runs (--runs) or relax --transmission/--crank",
                             report=clean(report))
    from .report import fit_block, target_entries, targets_scale

    ck = problem.ck
    cert = dict(best["certificate"])
    shown = [problem.shown_inputs[i] if problem.shown_inputs else display_value(ck, float(x))
             for i, x in enumerate(best["inputs"])]
    entries = target_entries(problem, best["values"], shown, best["Z"])
    report.update({
        "objective": best["objective"],
        "parameters": dict(zip(problem.names, map(float, best["values"]))),
        "mode": sign_string(best["signs"]),
        "direction": best["direction"],
        "targets": entries,
        "certificate": cert,
        "fit": fit_block([t["error"] for t in entries], targets_scale(problem.task, _shown_targets(problem))),
    })
    report = clean(report)
    mech = design_model(problem, best["values"], best["inputs"], best["Z"])
    if problem.task == "function":
        report["structural_error"] = clean(_function_structural_error(problem, mech, report, input_range,
                                                                                 desired))
    return SynthesisResult(problem, mech, report, np.asarray(best["values"]), np.asarray(best["inputs"]),
                           best["Z"])
