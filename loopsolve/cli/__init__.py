"""The ``loopsolve`` command line: a thin argparse layer over the public functions.

Exit status: 0 success, 2 usage or model error (also: an output that cannot be written, a
model too large or too deeply nested for memory), 3 the mechanism cannot be assembled or the
solver failed (also: a numeric overflow or division by zero, or an unexpected internal error).
Errors are one line on stderr naming the cause, warnings one line ``loopsolve: warning: ...``
each (``LOOPSOLVE_DEBUG=1`` shows the traceback).

Every command that writes a file goes through :func:`write_output` (text) or :func:`temporary_output` (a
path for a writer such as a figure): the output never replaces an input file, is written to a
temporary file in the target's directory and renamed when complete, so a failure (missing
directory, read-only place, full disk) leaves any old file intact.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
import warnings
from pathlib import Path

from ..errors import LoopsolveError
from ..kinematics.numba_engine.jit import AUTO_ROWS
from .cams import add_cam_parser
from .common import (EXIT_OK, EXIT_SOLVE, EXIT_USAGE, INPUTS, Parser, add_rate_args, add_text_output, check_writable,
                     load_model, one_line, render, temporary_output, write_output)
from .edit import add_edit_parser
from .fileargs import check_files, file_argument, input_files
from .forces import add_force_parsers
from .synthesis import add_synthesis_parser
from .atlas import add_atlas_parsers

__all__ = ["main", "build_parser"]


def cmd_solve(args) -> int:
    from ..kinematics.solve import solve

    check_writable(args.output)
    mech = load_model(args.model)
    state = solve(mech, args.at, speed=args.speed, accel=args.accel, jerk=args.jerk, input=args.input,
                  mode=args.mode)
    write_output(render(state, args.format), args.output)
    return EXIT_OK


def cmd_sweep(args) -> int:
    check_writable(args.output)
    write_output(render(_sweep_for(args), args.format), args.output)
    return EXIT_OK


def cmd_info(args) -> int:
    import json

    from ..kinematics.info import format_info, info

    mech = load_model(args.model)
    data = info(mech, input=args.input)
    if args.format == "json":
        write_output(json.dumps(data, indent=1, allow_nan=False) + "\n", None)
    else:
        write_output(format_info(data), None)
    return EXIT_OK


def build_parser() -> argparse.ArgumentParser:
    from .. import __version__

    parser = Parser(prog="loopsolve", description="Kinematics of planar mechanisms from their vector loops.",
                     epilog="Exit status: 0 success, 2 usage or model error, 3 cannot assemble / solver failure.")
    parser.add_argument("--version", action="version", version=f"loopsolve {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=Parser)
    sub.required = True

    p = sub.add_parser("solve", help="positions, velocities, accelerations and jerks at one input value")
    file_argument(p, "model", role="input", help="model file (TOML)")
    p.add_argument("--at", help="input value in the model's unit (degrees by default) or with a unit: 90, 1.2rad, "
                   "30mm (default: the input's guess)")
    add_rate_args(p)
    p.add_argument("--format", choices=("table", "csv", "json"), default="table")
    add_text_output(p)
    p.set_defaults(func=cmd_solve)

    p = sub.add_parser("sweep", help="sweep the input, tracking the assembly mode")
    file_argument(p, "model", role="input", help="model file (TOML)")
    p.add_argument("--from", dest="start", required=True, help="first input value (the first row)")
    p.add_argument("--to", dest="stop", required=True, help="end of the range: rows at --from + k*step up to "
                   "--to (a row only when on that grid); limits anywhere up to --to are reported")
    p.add_argument("--step", required=True, help="output step, positive (the direction is from --from to --to; "
                   "the internal step adapts)")
    p.add_argument("--max-rows", type=int, default=1_000_000, help="refuse a grid of more rows (default 1000000)")
    add_rate_args(p)
    p.add_argument("--through-limits", action="store_true",
                   help="at a limit position, continue around the fold onto the other mode")
    p.add_argument("--method", choices=("auto", "tracked", "batched"), default="auto",
                   help="tracked: continuation to every output point; batched: vectorized Newton warm-started "
                   "from a coarse tracked pass (same results); auto: batched for dense grids (default)")
    p.add_argument("--engine", choices=("python", "numba", "auto"), default=None,
                   help="who takes the tracer's regular steps: python, or numba (the compiled fast lane, needs "
                   f"the fast extra); auto: numba once it pays (installed, the model covered, and {AUTO_ROWS} rows or "
                   "more asked for); default $LOOPSOLVE_ENGINE, else auto")
    p.add_argument("--format", choices=("table", "csv", "json"), default="table")
    add_text_output(p)
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_sweep)

    p = sub.add_parser("info", help="structure: variables, loops, mobility, solve order, Grashof class")
    file_argument(p, "model", role="input", help="model file (TOML)")
    p.add_argument("--input", metavar="NAME", help="drive this variable instead of the declared input")
    p.add_argument("--format", choices=("table", "json"), default="table")
    p.set_defaults(func=cmd_info)

    p = sub.add_parser("vectors", help="write a model (e.g. a kinematic diagram) as a vector-loop model file")
    file_argument(p, "model", role="input", help="model file (TOML)")
    file_argument(p, "-o", "--output", role="output", fmt="toml", help="write to this file (.toml) instead of "
                  "standard output")
    p.set_defaults(func=cmd_vectors)

    p = sub.add_parser("modes", help="every real assembly mode at one input value")
    file_argument(p, "model", role="input", help="model file (TOML)")
    p.add_argument("--at", help="input value (default: the input's guess)")
    p.add_argument("--input", metavar="NAME", help="drive this variable instead of the declared input")
    p.add_argument("--format", choices=("table", "json"), default="table")
    p.set_defaults(func=cmd_modes)

    p = sub.add_parser("latex", help="the symbolic derivation as a LaTeX document (or PDF)")
    file_argument(p, "model", role="input", help="model file (TOML)")
    file_argument(p, "-o", "--output", role="output", fmt="latex", help="output file (.tex, or .pdf with --pdf); "
                  "default: standard output")
    p.add_argument("--pdf", action="store_true", help="compile to PDF with pdflatex/latexmk")
    p.add_argument("--snippet", action="store_true", help="equations only, to paste into a document")
    p.add_argument("--at", help="also tabulate the numeric solution at this input value")
    p.add_argument("--input", metavar="NAME", help="derive for this input variable")
    p.set_defaults(func=cmd_latex)

    p = sub.add_parser("plot", help="positions, velocities and accelerations against the input")
    file_argument(p, "model", role="input", help="model file (TOML)")
    _sweep_args(p)
    p.add_argument("--vars", nargs="+", metavar="NAME", help="variables or point coordinates to plot "
                   "(default: the unknowns)")
    file_argument(p, "-o", "--output", role="output", fmt="figure", required=True,
                  help="image file: .png, .svg or .pdf")
    p.set_defaults(func=cmd_plot)

    p = sub.add_parser("draw", help="the kinematic diagram at one input value")
    file_argument(p, "model", role="input", help="model file (TOML)")
    p.add_argument("--at", help="input value (default: the input's guess)")
    p.add_argument("--input", metavar="NAME", help="drive this variable instead of the declared input")
    p.add_argument("--mode", metavar="SIGNATURE", help="assembly mode")
    p.add_argument("--vectors", action="store_true", help="draw the loop vectors with their names")
    p.add_argument("--cad", action="store_true", help="with .svg: a CAD drawing in model units (layers by role, "
                   "as the .dxf) instead of a figure")
    p.add_argument("--curve", action="append", metavar="POINT", help="CAD drawing: draw this point's path over a "
                   "sweep (repeat for more; default: the tracer points such as a coupler point)")
    p.add_argument("--no-curves", action="store_true", help="CAD drawing: no point paths")
    file_argument(p, "-o", "--output", role="output", fmt="draw", required=True, help="image file: .png, .svg or "
                  ".pdf; CAD drawing: .dxf (needs ezdxf: pip install 'loopsolve[cad]'), or .svg with --cad")
    p.set_defaults(func=cmd_draw)

    p = sub.add_parser("animate", help="the linkage moving over a sweep (GIF, or MP4 with ffmpeg)")
    file_argument(p, "model", role="input", help="model file (TOML)")
    _sweep_args(p)
    p.add_argument("--fps", type=float, default=20.0, help="frames per second (default 20)")
    p.add_argument("--max-frames", type=int, default=3600, metavar="N",
                   help="refuse animations of more than N frames, before rendering (default 3600)")
    file_argument(p, "-o", "--output", role="output", fmt="animation", required=True, help=".gif or .mp4 file")
    p.set_defaults(func=cmd_animate)

    p = sub.add_parser("view", help="an interactive page (one offline HTML file): the linkage moving over a sweep")
    file_argument(p, "model", role="input", help="model file (TOML)")
    _sweep_args(p)
    p.add_argument("--vars", nargs="+", metavar="NAME", help="variables or point coordinates to plot "
                   "(default: the unknowns)")
    file_argument(p, "--shape", role="input", what="--shape", metavar="R.json",
                  help="the page of a shape synthesis' report (synthesize --shape ... --report R.json) made with "
                  "MODEL: the target, the candidates, the chosen one moving")
    file_argument(p, "-o", "--output", role="output", fmt="page", required=True, help=".html file")
    p.set_defaults(func=cmd_view)
    p = sub.add_parser("study", help="sweep every design of a parameter grid or sample (xarray Dataset out)")
    file_argument(p, "model", role="input", help="model file (TOML)")
    p.add_argument("--vary", action="append", required=True, metavar="NAME=SPEC",
                   help="a varied parameter: NAME=START:STOP:COUNT (grid), NAME=V1,V2,... (list) or "
                   "NAME=LOW:HIGH (box, with --samples/--lhs); repeat for more parameters")
    p.add_argument("--samples", type=int, metavar="N", help="N random designs from the box instead of the grid "
                   "(every --vary is then NAME=LOW:HIGH)")
    p.add_argument("--lhs", type=int, metavar="N", help="N designs of a Latin hypercube of the box (every --vary is "
                   "then NAME=LOW:HIGH)")
    p.add_argument("--max-designs", type=int, default=100_000, metavar="N",
                   help="refuse more designs, before any work (default 100000)")
    p.add_argument("--max-cells", type=int, default=5_000_000, metavar="N",
                   help="refuse more designs x input rows, before any work (default 5000000)")
    p.add_argument("--seed", type=int, default=0, help="seed of --samples/--lhs (default 0)")
    p.add_argument("--from", dest="start", required=True, help="first input value")
    p.add_argument("--to", dest="stop", required=True, help="last input value")
    p.add_argument("--step", required=True, help="output step")
    p.add_argument("--speed", help="input speed (default: the model's, else 1)")
    p.add_argument("--accel", help="input acceleration (default: the model's, else 0)")
    p.add_argument("--jerk", help="input jerk (default: the model's, else 0)")
    p.add_argument("--mode", metavar="SIGNATURE", help="assembly mode of every design (sweeps them one by one)")
    p.add_argument("--metric", action="append", default=[], metavar="NAME=EXPR",
                   help="a reduction over the input, e.g. mu=min(abs(sin(theta4 - theta3))), or a built-in: "
                   "transmission(a, b), swing(v), stroke(v), time_ratio(v), max_acc(v), grashof(a, b, c, d)")
    p.add_argument("--sensitivity", action="store_true", help="add d<unknown>/d<parameter> at every row")
    p.add_argument("--chunk", type=int, default=None,
                   help="designs per chunk / Dask task (default: in this process one chunk up to 1.5e6 designs x "
                        "rows, tenths of a larger study; at least 4 chunks a worker on a cluster)")
    p.add_argument("--workers", type=int, metavar="N", help="run on a local Dask cluster of N worker processes "
                   "(at most the CPUs of this machine)")
    p.add_argument("--scheduler", metavar="ADDRESS", help="run on the Dask cluster at ADDRESS (tcp://host:port)")
    file_argument(p, "-o", "--output", role="output", fmt="study", required=True,
                  help=".nc (netCDF), .zarr or .csv (long format)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_study)
    add_synthesis_parser(sub)
    add_atlas_parsers(sub)
    add_force_parsers(sub)
    add_edit_parser(sub)
    add_cam_parser(sub)
    return parser


def _sweep_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--from", dest="start", help="first input value (default: 0, or where the mechanism "
                   "can be assembled)")
    p.add_argument("--to", dest="stop", help="end of the range (default: a full turn, or the end of the "
                   "reachable range, traced around its limits)")
    p.add_argument("--step", default="4", help="output step, positive (default 4)")
    p.add_argument("--max-rows", type=int, default=1_000_000, help="refuse a grid of more rows (default 1000000)")
    add_rate_args(p)
    p.add_argument("--through-limits", action="store_true", help="continue around limit positions")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")


def _sweep_for(args):
    from ..kinematics.sweep import sweep

    mech = load_model(args.model)
    start, stop, through = args.start, args.stop, args.through_limits
    if start is None or stop is None:
        from ..kinematics.solve import display_value, input_value
        from ..kinematics.reach import default_range

        ck = mech.compile(args.input)
        step = display_value(ck, input_value(ck, args.step, reduce=False))
        d_start, d_stop, d_through = default_range(ck, step, mode=args.mode)
        start = d_start if start is None else start
        stop = d_stop if stop is None else stop
        through = through or d_through
    return sweep(mech, start, stop, args.step, speed=args.speed, accel=args.accel, jerk=args.jerk,
                 input=args.input, mode=args.mode, through_limits=through,
                 progress=None if not args.quiet else False, method=getattr(args, "method", "auto"),
                 max_rows=args.max_rows, limit_rows=args.command in ("plot", "view"),
                 engine=getattr(args, "engine", None))


def cmd_vectors(args) -> int:
    from ..model.diagram import to_vector_model

    check_writable(args.output)
    write_output(to_vector_model(load_model(args.model)), args.output)
    return EXIT_OK


def cmd_modes(args) -> int:
    from ..kinematics.modes import assembly_modes, format_modes, modes_to_json

    mech = load_model(args.model)
    modes = assembly_modes(mech, args.at, input=args.input)
    if args.format == "json":
        write_output(modes_to_json(modes) + "\n", None)
        return EXIT_OK
    from .. import guessed_mode
    from ..kinematics.export import mode_label

    named = guessed_mode(mech, args.at, input=args.input)
    if named is None:
        note = "the guesses name no mode (an unknown has no guess): pass --mode to solve and sweep"
    elif "0" in named:
        note = f"the guesses sit on a singular configuration ({named}): they name no mode there; pass --mode"
    else:
        note = f"the guesses name mode {mode_label(mech, named)}: solve, sweep, study and forces use it"
    write_output(format_modes(modes) + note + "\n", None)
    return EXIT_OK


def cmd_latex(args) -> int:
    from ..errors import ModelError
    from ..output.latex import to_latex, write_pdf

    out = args.output or (Path(args.model).stem + ".pdf") if args.pdf else args.output
    suffix = Path(out).suffix.lower() if out else ""
    if args.pdf and suffix == ".tex":  # a PDF named .tex, or TeX named .pdf, opens as neither
        raise ModelError(f"--pdf writes a PDF, not LaTeX source, to {one_line(out)}: name it .pdf "
                         f"(-o {one_line(Path(out).with_suffix('.pdf').name)}), or leave out --pdf for the .tex")
    if not args.pdf and suffix == ".pdf":
        raise ModelError(f"-o {one_line(out)}: without --pdf the output is LaTeX source; add --pdf to compile "
                         "it, or name it .tex")
    check_writable(out)
    mech = load_model(args.model)
    tex = to_latex(mech, input=args.input, at=args.at, snippet=args.snippet)
    if args.pdf:
        with temporary_output(out) as tmp:
            write_pdf(tex, tmp)
        print(f"wrote {one_line(out)}", file=sys.stderr)
    else:
        write_output(tex, args.output)
    return EXIT_OK


def cmd_plot(args) -> int:
    from ..output.plotting import check_output, plot_sweep

    check_output(args.output, "figure")
    check_writable(args.output)
    sw = _sweep_for(args)
    with temporary_output(args.output) as tmp:
        plot_sweep(sw, args.vars, output=tmp)
    print(f"wrote {one_line(args.output)}", file=sys.stderr)
    return EXIT_OK


def cmd_draw(args) -> int:
    from ..output.plotting import check_output, draw

    if str(args.output).lower().endswith(".dxf") or args.cad:
        return _draw_cad(args)
    if args.curve or args.no_curves:
        from ..errors import ModelError

        raise ModelError("--curve and --no-curves are for CAD drawings (-o FILE.dxf, or .svg with --cad)")
    check_output(args.output, "figure")
    check_writable(args.output)
    mech = load_model(args.model)
    with temporary_output(args.output) as tmp:
        draw(mech, args.at, input=args.input, mode=args.mode, vectors=args.vectors, output=tmp)
    print(f"wrote {one_line(args.output)}", file=sys.stderr)
    return EXIT_OK


def _draw_cad(args) -> int:
    from ..output.cad import check_cad_output, export_cad
    from ..errors import ModelError

    if args.vectors:
        raise ModelError("--vectors draws the loop vectors on a figure (.png, .svg or .pdf without --cad), not in "
                         "a CAD drawing")
    check_cad_output(args.output)
    check_writable(args.output)
    mech = load_model(args.model)
    curves = [] if args.no_curves else args.curve
    with temporary_output(args.output) as tmp:
        export_cad(mech, tmp, args.at, input=args.input, mode=args.mode, curves=curves)
    print(f"wrote {one_line(args.output)}", file=sys.stderr)
    return EXIT_OK


def cmd_animate(args) -> int:
    from ..output.plotting import animate, check_frames, check_output, frames_before_sweep

    check_output(args.output, "animation")
    check_writable(args.output)
    n = frames_before_sweep(load_model(args.model), args.start, args.stop, args.step, input=args.input, mode=args.mode)
    check_frames(n or 0, args.max_frames)
    sw = _sweep_for(args)
    with temporary_output(args.output) as tmp:
        animate(sw, output=tmp, fps=args.fps, progress=None if not args.quiet else False,
                max_frames=args.max_frames)
    print(f"wrote {one_line(args.output)}", file=sys.stderr)
    return EXIT_OK


def cmd_view(args) -> int:
    from ..output.view import check_output, to_html

    check_output(args.output)
    check_writable(args.output)
    if args.shape:
        from .atlas import view_shape

        return view_shape(args)
    write_output(to_html(_sweep_for(args), args.vars), args.output)
    return EXIT_OK


def cmd_study(args) -> int:
    from ..design.designs import parse_vary
    from ..errors import ModelError
    from ..design.studies import study

    check_writable(args.output)
    mech = load_model(args.model)
    vary = {}
    box = args.samples is not None or args.lhs is not None
    for text in args.vary:
        name, values = parse_vary(text, max_count=args.max_designs)
        if name in vary:
            raise ModelError(f"--vary {name} given twice")
        if box and not isinstance(values, tuple):
            raise ModelError(f"--vary {text}: --{'samples' if args.samples is not None else 'lhs'} draws designs from "
                             f"the box NAME=LOW:HIGH; a COUNT or a list of values would not be used: give "
                             f"{name}=LOW:HIGH (or drop --samples/--lhs for a grid)")
        vary[name] = values
    ds = study(mech, vary, args.start, args.stop, args.step, samples=args.samples, lhs=args.lhs, seed=args.seed,
               metrics=args.metric, sensitivity=args.sensitivity, speed=args.speed, accel=args.accel,
               jerk=args.jerk, mode=args.mode, chunk_size=args.chunk, workers=args.workers,
               scheduler=args.scheduler, out=args.output, progress=None if not args.quiet else False,
               max_designs=args.max_designs, max_cells=args.max_cells)
    counts = {}
    for s in ds["status"].values.tolist():
        counts[s] = counts.get(s, 0) + 1
    print(f"wrote {args.output}: {ds.sizes['design']} designs ("
          + ", ".join(f"{v} {k}" for k, v in sorted(counts.items())) + ")", file=sys.stderr)
    return EXIT_OK


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """Warnings as one line ``loopsolve: warning: <message>`` (never a source line)."""
    try:
        print(f"loopsolve: warning: {one_line(message)}", file=sys.stderr if file is None else file)
    except (OSError, ValueError):  # stderr closed
        pass


def _fail(message: str, status: int) -> int:
    print(f"loopsolve: {one_line(message)}", file=sys.stderr)
    return status


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``loopsolve`` console script."""
    parser = build_parser()
    args = parser.parse_args(argv)
    debug = bool(os.environ.get("LOOPSOLVE_DEBUG"))
    from ..kinematics import export  # noqa: F401  (error formatting must not need an import when memory is short)

    exhausted = ""
    with warnings.catch_warnings():
        warnings.showwarning = _show_warning
        try:
            INPUTS[:] = input_files(parser, args)
            check_files(parser, args)  # outputs onto inputs, onto each other, wrong extensions: before any work
            return args.func(args)
        except LoopsolveError as exc:
            if debug:
                raise
            return _fail(f"{type(exc).__name__}: {exc}", exc.exit_code)
        except KeyboardInterrupt:
            print("loopsolve: interrupted", file=sys.stderr)
            return 130
        except BrokenPipeError:
            with contextlib.suppress(OSError, ValueError):
                devnull = os.open(os.devnull, os.O_WRONLY)
                os.dup2(devnull, sys.stdout.fileno())
            return EXIT_OK
        except (MemoryError, RecursionError) as exc:
            if debug:
                raise
            exhausted = type(exc).__name__  # reported below, once the exception's frames are freed
        except ArithmeticError as exc:
            if debug:
                raise
            return _fail(f"error: numeric failure ({type(exc).__name__}: {exc}); check the magnitudes of the "
                         "model's numbers and of the command's values", EXIT_SOLVE)
        except OSError as exc:
            if debug:
                raise
            where = f" {exc.filename!r}" if getattr(exc, "filename", None) else ""
            return _fail(f"error: cannot access{where}: {exc.strerror or exc}", EXIT_USAGE)
        except Exception as exc:  # noqa: BLE001 — the contract is one line, never a traceback
            if debug:
                raise
            return _fail(f"internal error: {type(exc).__name__}: {exc} (please report it; LOOPSOLVE_DEBUG=1 "
                         "shows the traceback)", EXIT_SOLVE)
        finally:
            INPUTS.clear()
    # no imports or formatting helpers here: memory may be short
    sys.stderr.write(f"loopsolve: error: out of memory or too deeply nested ({exhausted}); the model or the "
                     "requested output is too large for this machine\n")
    return EXIT_USAGE


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
