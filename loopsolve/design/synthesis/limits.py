"""Bounds of a synthesis, checked before any work: the options, the targets, the work and its memory.

:func:`loopsolve.design.synthesis.run.synthesize` (the command line's ``synthesize`` and ``ls.synthesize``)
calls these before the first design is evaluated, as studies bound their designs and cells
(``--max-designs``, ``--max-cells``). Every refusal is a :class:`~loopsolve.errors.ModelError`
(exit status 2) naming the option, its value and what to do.

* **Options** (:func:`check_options`): whole numbers in their range — ``runs`` ≥ 1, ``seed`` ≥ 0,
  ``popsize`` ≥ 1, ``maxiter`` ≥ 0, ``restarts`` ≥ 1, ``starts`` ≥ 0, ``workers`` from 1 to the
  machine's CPUs (as studies); ``restarts`` × assembly modes at most :data:`MAX_SEARCHES` (the DE
  searches of a run run in lockstep, one thread each).
* **Targets** (:func:`check_targets`): at most ``max_targets`` (default :data:`MAX_TARGETS`,
  ``--max-targets``); no two at the same prescribed input; with free timing no two consecutive
  targets at the same place (the motion would have to meet one point twice in a row); an angle
  input's prescribed values within one turn (a motion through its targets stays within a turn:
  more is an ``order`` defect of every design, and an input of 1e300° would be traced forever).
* **Work** (:func:`check_work`): an upper estimate of the positions traced — runs × design
  evaluations (every DE generation to ``maxiter``, its final population and archive, the
  multistart's samples, every lockstep Levenberg–Marquardt iteration of every start) × trace
  steps per evaluation (prescribed timing: the substeps of at most 10° between the targets;
  free timing: a turn each way in 10° steps, plus the targets) — at most ``max_cells`` (default
  :data:`MAX_CELLS`, about an hour on one core; ``--max-cells``).
* **Memory** (:func:`check_work`): the largest array of one batch — a DE generation of every
  search of a run, or the Jacobians of the lockstep polish (free timing: it grows with the square
  of the targets) — at most :data:`MAX_BATCH` values (400 MB); the multistart's chunks are sized
  to it (:func:`multistart_chunk`).
"""

from __future__ import annotations

import math
import numbers

import numpy as np

from ...errors import ModelError

__all__ = ["MAX_TARGETS", "MAX_CELLS", "MAX_SEARCHES", "MAX_BATCH", "STRATEGIES", "check_options", "check_target_count",
           "check_targets",
           "check_work", "multistart_chunk", "work_estimate"]

#: default bound on the targets of one synthesis (``max_targets=``, ``--max-targets``)
MAX_TARGETS = 1000
#: default bound on the positions one synthesis traces: runs × design evaluations × trace steps
#: (``max_cells=``, ``--max-cells``); measured at 2.5–3·10⁴ a second on one core, so about an hour
MAX_CELLS = 100_000_000
#: DE searches of one run (restarts × assembly modes): they run in lockstep, one thread each
MAX_SEARCHES = 256
#: values of the largest array of one batch (float64: 400 MB)
MAX_BATCH = 50_000_000
#: scipy's differential-evolution strategies
STRATEGIES = ("best1bin", "best1exp", "rand1bin", "rand1exp", "rand2bin", "rand2exp", "randtobest1bin",
              "randtobest1exp", "currenttobest1bin", "currenttobest1exp", "best2exp", "best2bin")

#: what the search and the polish trace (see loopsolve.design.synthesis.problem and .lockstep_lm)
_STEP = math.radians(10.0)
_FREE_GRID = 2 * int(round(2 * math.pi / _STEP)) + 1
_SAMPLE_RATIO = 30
_MULTISTART_CHUNK = 4000


def _whole(option: str, value, low: int, what: str) -> int:
    shown = f"{option} {value!r}" if option.startswith("--") else f"{option}={value!r}"
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise ModelError(f"{shown}: {what} must be a whole number (at least {low})")
    if value < low:
        raise ModelError(f"{shown}: {what} must be at least {low}")
    return int(value)


def _limit(option: str, value) -> int:
    return _whole(option, value, 1, "the limit")


def check_options(*, runs, seed, popsize, maxiter, tol, restarts, starts, de_starts, lm_iters, polish_candidates,
                  strategy, workers, scheduler, max_cells, max_targets) -> None:
    """Refuse, before any work, an option of :func:`~loopsolve.design.synthesis.run.synthesize` out of its range.

    Examples
    --------
    >>> from loopsolve.design.synthesis.limits import check_options
    >>> opts = dict(runs=1, seed=0, popsize=15, maxiter=60, tol=1e-3, restarts=1, starts=None, de_starts=10,
    ...             lm_iters=60, polish_candidates=6, strategy="best1bin", workers=None, scheduler=None,
    ...             max_cells=10**8, max_targets=1000)
    >>> check_options(**opts)
    >>> check_options(**dict(opts, seed=-1))
    Traceback (most recent call last):
    ...
    loopsolve.errors.ModelError: --seed -1: the seed of the first run must be at least 0
    """
    _whole("--runs", runs, 1, "the number of runs")
    _whole("--seed", seed, 0, "the seed of the first run")
    _whole("--popsize", popsize, 1, "the population per varied parameter")
    _whole("--maxiter", maxiter, 0, "the generations per search")
    _whole("--restarts", restarts, 1, "the DE searches per assembly mode")
    if starts is not None:
        _whole("--starts", starts, 0, "the number of multistart starts (0: none)")
    _whole("de_starts", de_starts, 1, "the starts taken from each search")
    _whole("lm_iters", lm_iters, 0, "the lockstep Levenberg-Marquardt's iterations")
    _whole("polish_candidates", polish_candidates, 1, "the basins polished")
    try:
        tol_ok = math.isfinite(float(tol)) and float(tol) >= 0
    except (TypeError, ValueError):
        tol_ok = False
    if not tol_ok:
        raise ModelError(f"tol={tol!r}: the DE's relative tolerance must be a finite number, at least 0")
    if strategy not in STRATEGIES:
        raise ModelError(f"strategy={strategy!r}: expected one of scipy's {', '.join(STRATEGIES)}")
    _limit("--max-cells", max_cells)
    _limit("--max-targets", max_targets)
    if workers is not None or scheduler is not None:
        from ..studies import check_cluster  # the studies' rules: 1..CPUs local processes, an address

        check_cluster(workers, scheduler)


def _rows(i: int, j: int) -> str:
    return f"targets {i + 1} and {j + 1}"


def check_target_count(T: int, where: str, max_targets: int) -> None:
    """Refuse more than ``max_targets`` targets (before they are converted)."""
    if T > max_targets:
        raise ModelError(f"--targets {where}: {T:,} targets, more than the limit of {max_targets:,}: thin them out, "
                         "or raise the limit with --max-targets (max_targets=)")


def check_targets(problem_ck, task: str, targets: np.ndarray, inputs, shown, where: str, option: str) -> None:
    """Refuse two targets at one prescribed input, free-timing repeats, angle inputs beyond a turn.

    ``targets`` ``(T, c)`` internal units; ``inputs`` the prescribed internal input values or
    None (free timing); ``shown`` the inputs as given (model units) for the messages; ``option``
    where the inputs came from (``--inputs`` or the targets' input column).
    """
    from ...model.units import Kind

    T = len(targets)
    if inputs is not None:
        xs = np.asarray(inputs, dtype=float)
        order = np.argsort(xs, kind="stable")
        same = np.flatnonzero(np.diff(xs[order]) == 0)
        if same.size:
            i, j = sorted((int(order[same[0]]), int(order[same[0] + 1])))
            v = shown[i] if shown is not None and shown[i] is not None else xs[i]
            raise ModelError(f"{option}: {_rows(i, j)} are at the same input value ({v:g}); every target needs "
                             "its own input value")
        ck = problem_ck
        name = ck.inputs[0]
        if ck.kinds[ck.index(name)] is Kind.ANGLE and T > 1:
            span = float(np.max(xs) - np.min(xs))
            if span >= 2 * math.pi:
                lo, hi = int(np.argmin(xs)), int(np.argmax(xs))
                show = (lambda k: shown[k] if shown is not None and shown[k] is not None else xs[k])
                raise ModelError(f"{option}: the prescribed values of {name} span {span / (2 * math.pi):.3g} turns "
                                 f"(target {lo + 1} at {show(lo):g}, target {hi + 1} at {show(hi):g}); a motion "
                                 "through the targets stays within one turn of the input")
    else:
        diff = np.diff(targets, axis=0)
        if task == "motion":  # the link's angle: one turn apart is the same pose
            diff[:, 2] = np.remainder(diff[:, 2] + math.pi, 2 * math.pi) - math.pi
        d = np.max(np.abs(diff), axis=1) if T > 1 else np.zeros(0)
        scale = float(np.max(np.abs(targets))) if targets.size else 0.0
        rep = np.flatnonzero(d <= 1e-12 * max(scale, 1e-300))
        if rep.size:
            i = int(rep[0])
            what = {"path": "point", "motion": "pose"}.get(task, "target")
            at = f" (x, y = {targets[i][0]:g}, {targets[i][1]:g})" if task in ("path", "motion") else ""
            raise ModelError(f"--targets {where}: {_rows(i, i + 1)} are the same {what}{at}: with free timing the "
                             f"motion would meet it twice in a row; drop the repeat (or prescribe the timing)")


def _per_design(problem) -> tuple[int, int]:
    """``(trace steps, values held)`` of one design's evaluation by the search objective."""
    T = problem.T
    nv = len(problem.ck.variables)
    if problem.free:
        return _FREE_GRID + T, T * _FREE_GRID + nv * _FREE_GRID
    xs = np.asarray(problem.inputs, dtype=float)
    with np.errstate(all="ignore"):
        sub = np.maximum(1.0, np.ceil(np.abs(np.diff(xs)) / _STEP - 1e-9))  # as the tracer counts them
    steps = 1.0 + float(np.sum(sub))
    if problem.crank:
        steps += 2 * math.pi / _STEP
    return steps, nv * (T + 1)


def multistart_chunk(problem) -> int:
    """Designs per batch of the multistart: at most 4000, fewer when one design's arrays are large."""
    _, held = _per_design(problem)
    return int(max(1, min(_MULTISTART_CHUNK, MAX_BATCH // max(1, held))))


def work_estimate(problem, *, runs, popsize, maxiter, restarts, starts, de_starts, lm_iters) -> dict:
    """The numbers :func:`check_work` bounds: design evaluations per run, trace steps per evaluation,
    cells (runs × evaluations × steps), DE searches per run, and the values of the largest batches."""
    k = len(problem.names)
    modes = len(problem.batch.all_signs()) if problem.mode == "any" else 1
    searches = modes * restarts
    members = max(5, popsize * k)
    de = searches * (members * (maxiter + 1) + members + 20 * max(1, k))
    lm_cols = searches * de_starts + starts
    evals = de + _SAMPLE_RATIO * starts + lm_cols * max(1, lm_iters)
    steps, held = _per_design(problem)
    m = {"path": 2, "function": 1, "motion": 3}[problem.task]
    T = problem.T
    return {"evaluations": evals, "steps": steps, "cells": float(runs) * evals * steps, "searches": searches,
            "modes": modes, "generation": searches * members * held, "members": searches * members,
            "lm": lm_cols * m * T * (k + (T if problem.free else 0)), "lm_starts": lm_cols}


def check_work(problem, *, runs, popsize, maxiter, restarts, starts, de_starts, lm_iters, max_cells) -> dict:
    """Refuse, before any work, a synthesis whose work or batch memory is beyond the bounds. Returns the estimate."""
    w = work_estimate(problem, runs=runs, popsize=popsize, maxiter=maxiter, restarts=restarts, starts=starts,
                      de_starts=de_starts, lm_iters=lm_iters)
    if w["searches"] > MAX_SEARCHES:
        raise ModelError(f"--restarts {restarts}: {w['modes']} assembly mode(s) × {restarts:,} DE searches run in "
                         f"lockstep, one thread each; at most {MAX_SEARCHES} (use --runs for more independent searches)")
    if w["generation"] > MAX_BATCH:
        raise ModelError(f"--popsize {popsize} with --restarts {restarts}: one generation of the run's "
                         f"{w['searches']} search(es) is {w['members']:,} designs × {problem.T:,} targets = "
                         f"{w['generation']:.3g} values, more than {MAX_BATCH:,} (400 MB): use a smaller --popsize, "
                         "fewer --restarts or fewer targets")
    if w["lm"] > MAX_BATCH:
        free = " (free timing: the input value of every target is a variable too)" if problem.free else ""
        raise ModelError(f"--starts {starts}: the lockstep polish of {w['lm_starts']:,} starts × {problem.T:,} targets "
                         f"holds {w['lm']:.3g} values{free}, more than {MAX_BATCH:,} (400 MB): give fewer --starts "
                         "(or --restarts), fewer targets" + (", or prescribe the timing (--inputs)" if free else ""))
    if not w["cells"] <= max_cells:
        travel = ""
        if not problem.free and w["steps"] > 100 * problem.T:
            xs = np.asarray(problem.inputs, dtype=float)
            travel = (f"the prescribed inputs (--inputs or the input column) take {w['steps']:.3g} trace steps "
                      f"between the targets (they travel {float(np.sum(np.abs(np.diff(xs)))):.3g} internal units "
                      f"of {problem.ck.inputs[0]}); ")
        raise ModelError(f"{travel}the synthesis would trace up to {w['cells']:.3g} positions (--runs {runs} × "
                         f"{w['evaluations']:,} design evaluations a run × {w['steps']:.3g} steps each), more than "
                         f"the limit of {max_cells:,} (about an hour): use fewer --runs, a smaller --popsize, "
                         "--maxiter, --restarts or --starts, or raise the limit with --max-cells (max_cells=)")
    return w
