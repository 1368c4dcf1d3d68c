"""``loopsolve synthesize``: its arguments, the general and classical methods, the report.
"""

from __future__ import annotations

import math
import sys

from .common import EXIT_OK, check_writable, load_model, synthesis_output
from .fileargs import file_argument


def add_synthesis_parser(sub) -> None:
    """Add ``loopsolve synthesize`` to the subcommands ``sub``."""
    p = sub.add_parser("synthesize", help="find parameter values for a path, a function or a motion "
                       "(certified designs only)")
    file_argument(p, "model", role="input", help="model file (TOML)")
    task = p.add_mutually_exclusive_group(required=True)
    task.add_argument("--path", metavar="POINT", help="path generation: POINT through the targets (CSV x,y)")
    task.add_argument("--function", metavar="OUT", help="function generation: unknown OUT of the input "
                      "(CSV input,output)")
    task.add_argument("--motion", metavar="POINT", help="motion generation: POINT and the --link angle "
                      "(CSV x,y,angle)")
    task.add_argument("--shape", metavar="POINT", help="shape synthesis: POINT traces the curve of --targets (CSV "
                      "x,y), free in position, orientation, scale and timing, from an atlas")
    closure = p.add_mutually_exclusive_group()
    closure.add_argument("--closed", action="store_true", help="with --shape: the curve is closed (default)")
    closure.add_argument("--open", action="store_true", help="with --shape: the curve is an open stretch")
    p.add_argument("--atlas", metavar="ATLAS", help="with --shape (and --path with free timing: its starts): "
                   "the atlas, a directory ATLAS.zarr (default: the model's default atlas, built once into the cache "
                   "on first use)")
    p.add_argument("--top", type=int, default=5, metavar="K", help="with --shape: certified designs reported "
                   "(default 5)")
    p.add_argument("--no-atlas", action="store_true", help="with --path and free timing: no starts from the "
                   "model's default atlas")
    p.add_argument("--link", metavar="VAR", help="with --motion: the angle variable of the guided link")
    file_argument(p, "--targets", role="input", what="--targets", required=True, metavar="T.csv",
                  help="targets (CSV with a header line; an input column prescribes the timing)")
    p.add_argument("--inputs", metavar="X1,X2,...", help="prescribed input value of every target (model units)")
    p.add_argument("--vary", action="append", metavar="NAME=LOW:HIGH",
                   help="a design variable and its bounds (model units); repeat for more (general method)")
    p.add_argument("--method", choices=("general", "freudenstein", "burmester"), default="general",
                   help="general (default: any model, --vary), or the classical four-bar methods: freudenstein "
                   "(--function) and burmester (--motion --link, three to five poses; candidates ranked, "
                   "see the report's ranking)")
    p.add_argument("--range", dest="input_range", metavar="LO:HI", help="with --function: the intended input range "
                   "(model units; default: the targets' inputs), checked and reported as the structural error")
    p.add_argument("--crank", action="store_true", help="the input must turn fully")
    p.add_argument("--transmission", metavar="LO:HI", help="transmission angle bounds over the motion (degrees)")
    p.add_argument("--mode", default="any", metavar="any|guesses|SIGNATURE",
                   help="assembly mode: the search's choice (any, default), the guesses', or a signature")
    p.add_argument("--runs", type=int, default=1, metavar="N", help="independent seeded runs (default 1)")
    p.add_argument("--seed", type=int, default=0, help="seed of the first run (default 0)")
    p.add_argument("--popsize", type=int, default=15, help="differential evolution: population per variable")
    p.add_argument("--maxiter", type=int, default=60, help="differential evolution: generations at most per search")
    p.add_argument("--restarts", type=int, default=1, help="DE searches per assembly mode in a run (default 1)")
    p.add_argument("--starts", type=int, metavar="N", help="multistart: the N best of 30·N sampled designs are "
                   "polished in lockstep with the DE's (default 40 per varied parameter; 0: none)")
    p.add_argument("--workers", type=int, metavar="N", help="run the runs on a local Dask cluster of N processes "
                   "(at most the CPUs of this machine)")
    p.add_argument("--scheduler", metavar="ADDRESS", help="run the runs on the Dask cluster at ADDRESS")
    file_argument(p, "-o", "--output", role="output", fmt="toml", metavar="design.toml",
                  help="write the best design as a model file (.toml)")
    file_argument(p, "--report", role="output", fmt="json", metavar="R.json", help="write the report (.json)")
    p.add_argument("--max-cells", type=int, default=100_000_000, metavar="N", help="refuse, before any work, a "
                   "synthesis that may trace more positions (runs x design evaluations x trace steps; default "
                   "100000000, about an hour)")
    p.add_argument("--max-targets", type=int, default=1000, metavar="N", help="refuse more targets (default 1000)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_synthesize)



def cmd_synthesize(args) -> int:
    from ..errors import ModelError
    from ..design.synthesis.run import synthesize

    if args.shape is not None:
        from .atlas import cmd_shape

        return cmd_shape(args)
    for flag, given in (("--closed", args.closed), ("--open", args.open), ("--top", args.top != 5)):
        if given:
            raise ModelError(f"{flag} is for shape synthesis (--shape POINT)")
    if (args.atlas or args.no_atlas) and not (args.path and not args.inputs):
        raise ModelError("--atlas/--no-atlas are for shape synthesis and for path synthesis with free timing")

    for out in (args.output, args.report):
        check_writable(out)
    input_range = _parse_range(args.input_range) if args.input_range else None
    if input_range is not None and not args.function:
        raise ModelError("--range is for function generation (--function OUT)")
    if args.method != "general":
        return _classic_synthesize(args, input_range)
    if not args.vary:
        raise ModelError("synthesize: the general method needs the design variables (--vary NAME=LOW:HIGH, "
                         "repeatable), or --method freudenstein|burmester on a four-bar model")
    mech = load_model(args.model)
    vary = {}
    for text in args.vary:
        name, sep, rest = text.partition("=")
        name = name.strip()
        parts = rest.split(":")
        if not sep or not name or len(parts) != 2:
            raise ModelError(f"--vary {text!r}: expected NAME=LOW:HIGH")
        try:
            lo, hi = float(parts[0]), float(parts[1])
        except ValueError:
            raise ModelError(f"--vary {text!r}: LOW and HIGH must be numbers") from None
        if name in vary:
            raise ModelError(f"--vary {name} given twice")
        vary[name] = (lo, hi)
    rep = synthesis_output(args, lambda: synthesize(
        mech, path=args.path, function=args.function, motion=args.motion, link=args.link,
        targets=args.targets, inputs=args.inputs, vary=vary, crank=args.crank,
        transmission=args.transmission, runs=args.runs, seed=args.seed, mode=args.mode,
        popsize=args.popsize, maxiter=args.maxiter, restarts=args.restarts, starts=args.starts, workers=args.workers,
        scheduler=args.scheduler, progress=None if not args.quiet else False,
        input_range=input_range, max_cells=args.max_cells, max_targets=args.max_targets,
        atlas=False if args.no_atlas else args.atlas), "")
    if rep is not None:
        print(f"objective {rep['objective']:.6g} (mode {rep['mode']}, certified{_fit_phrase(rep)}); wrote "
              f"{args.report}" + (f" and {args.output}" if args.output else ""), file=sys.stderr)
    return EXIT_OK


def _fit_phrase(rep) -> str:
    from ..design.synthesis.report import fit_phrase

    return fit_phrase(rep.get("fit"))



def _parse_range(text):
    from ..errors import ModelError

    parts = str(text).split(":")
    try:
        lo, hi = (float(v) for v in parts)
    except ValueError:
        raise ModelError(f"--range {text!r}: expected LO:HI (two numbers, model units)") from None
    if not (math.isfinite(lo) and math.isfinite(hi)) or lo == hi:
        raise ModelError(f"--range {text!r}: LO and HI must be two different finite numbers")
    return (lo, hi)



def _classic_synthesize(args, input_range) -> int:
    """``synthesize --method freudenstein|burmester``: exit 3 (report still written) when not usable."""
    from ..errors import ModelError
    from ..design.synthesis.run import synthesize

    for flag, given in (("--path", args.path), ("--vary", args.vary), ("--inputs", args.inputs),
                        ("--workers", args.workers), ("--scheduler", args.scheduler)):
        if given is not None and given is not False:
            raise ModelError(f"{flag} is not used by --method {args.method} (it is for the general method)")
    mech = load_model(args.model)
    rep = synthesis_output(args, lambda: synthesize(mech, method=args.method, targets=args.targets,
                                                     function=args.function, motion=args.motion, link=args.link,
                                                     input_range=input_range, runs=args.runs, seed=args.seed,
                                                     popsize=args.popsize, maxiter=args.maxiter,
                                                     restarts=args.restarts, starts=args.starts,
                                                     max_cells=args.max_cells, max_targets=args.max_targets,
                                                     crank=args.crank, transmission=args.transmission),
                            args.method)
    if rep is not None:
        rank = rep.get("ranking")
        more = f", best of {rank['certified']} certified candidates by the ranking rule" if rank else ""
        print(f"{args.method}: objective {rep['objective']:.6g} (certified{more}{_fit_phrase(rep)}); wrote "
              f"{args.report}" + (f" and {args.output}" if args.output else ""), file=sys.stderr)
    return EXIT_OK
