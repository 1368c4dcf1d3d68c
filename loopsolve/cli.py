"""The ``loopsolve`` command line: a thin argparse layer over the public functions.

Exit status: 0 success, 2 usage or model error, 3 the mechanism cannot be assembled or the
solver failed. Errors are one line on stderr naming the cause (``LOOPSOLVE_DEBUG=1`` shows the
traceback).
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from .errors import LoopsolveError

__all__ = ["main", "build_parser"]

EXIT_OK, EXIT_USAGE, EXIT_SOLVE = 0, 2, 3


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, exit 2
        self.exit(EXIT_USAGE, f"loopsolve: error: {message} (see `{self.prog} --help`)\n")


def _load(path: str):
    from .modelfile import load

    return load(path)


def _write(text: str, out: str | None) -> None:
    if out in (None, "-"):
        sys.stdout.write(text)
    else:
        Path(out).write_text(text, encoding="utf-8")
        print(f"wrote {out}", file=sys.stderr)


def _render(obj, fmt: str) -> str:
    from . import export

    if fmt == "json":
        return export.to_json(obj) + "\n"
    if fmt == "csv":
        return export.to_csv(obj)
    return export.to_table(obj)


def _rate_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--speed", help="input speed, e.g. 10rpm, 10.5 (rad/s), 2rad/s, 5mm/s (default: the "
                   "model's, else 1: rates are then kinematic coefficients)")
    p.add_argument("--accel", help="input acceleration, e.g. 0, 2rad/s^2 (default: the model's, else 0)")
    p.add_argument("--jerk", help="input jerk (default: the model's, else 0)")
    p.add_argument("--input", metavar="NAME", help="drive this variable instead of the declared input")
    p.add_argument("--mode", metavar="SIGNATURE", help="assembly mode to use: a signature such as + or -+, or "
                   "an alias declared by the model (open, crossed)")


def cmd_solve(args) -> int:
    from .solve import solve

    mech = _load(args.model)
    state = solve(mech, args.at, speed=args.speed, accel=args.accel, jerk=args.jerk, input=args.input,
                  mode=args.mode)
    _write(_render(state, args.format), args.output)
    return EXIT_OK


def cmd_sweep(args) -> int:
    _write(_render(_sweep_for(args), args.format), args.output)
    return EXIT_OK


def cmd_info(args) -> int:
    import json

    from .info import format_info, info

    mech = _load(args.model)
    data = info(mech, input=args.input)
    if args.format == "json":
        _write(json.dumps(data, indent=1) + "\n", None)
    else:
        _write(format_info(data), None)
    return EXIT_OK


def build_parser() -> argparse.ArgumentParser:
    from . import __version__

    parser = _Parser(prog="loopsolve", description="Kinematics of planar mechanisms from their vector loops.",
                     epilog="Exit status: 0 success, 2 usage or model error, 3 cannot assemble / solver failure.")
    parser.add_argument("--version", action="version", version=f"loopsolve {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True

    p = sub.add_parser("solve", help="positions, velocities, accelerations and jerks at one input value")
    p.add_argument("model", help="model file (TOML)")
    p.add_argument("--at", help="input value in the model's unit (degrees by default) or with a unit: 90, 1.2rad, "
                   "30mm (default: the input's guess)")
    _rate_args(p)
    p.add_argument("--format", choices=("table", "csv", "json"), default="table")
    p.add_argument("-o", "--output", help="write to this file instead of standard output")
    p.set_defaults(func=cmd_solve)

    p = sub.add_parser("sweep", help="sweep the input, tracking the assembly mode")
    p.add_argument("model", help="model file (TOML)")
    p.add_argument("--from", dest="start", required=True, help="first input value")
    p.add_argument("--to", dest="stop", required=True, help="last input value")
    p.add_argument("--step", required=True, help="output step (the internal step adapts)")
    _rate_args(p)
    p.add_argument("--through-limits", action="store_true",
                   help="at a limit position, continue around the fold onto the other mode")
    p.add_argument("--method", choices=("auto", "tracked", "batched"), default="auto",
                   help="tracked: continuation to every output point; batched: vectorized Newton warm-started "
                   "from a coarse tracked pass (same results); auto: batched for dense grids (default)")
    p.add_argument("--format", choices=("table", "csv", "json"), default="table")
    p.add_argument("-o", "--output", help="write to this file instead of standard output")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_sweep)

    p = sub.add_parser("info", help="structure: variables, loops, mobility, solve order, Grashof class")
    p.add_argument("model", help="model file (TOML)")
    p.add_argument("--input", metavar="NAME", help="drive this variable instead of the declared input")
    p.add_argument("--format", choices=("table", "json"), default="table")
    p.set_defaults(func=cmd_info)

    p = sub.add_parser("vectors", help="write a model (e.g. a kinematic diagram) as a vector-loop model file")
    p.add_argument("model", help="model file (TOML)")
    p.add_argument("-o", "--output", help="write to this file instead of standard output")
    p.set_defaults(func=cmd_vectors)

    p = sub.add_parser("modes", help="every real assembly mode at one input value")
    p.add_argument("model", help="model file (TOML)")
    p.add_argument("--at", help="input value (default: the input's guess)")
    p.add_argument("--input", metavar="NAME", help="drive this variable instead of the declared input")
    p.add_argument("--format", choices=("table", "json"), default="table")
    p.set_defaults(func=cmd_modes)

    p = sub.add_parser("latex", help="the symbolic derivation as a LaTeX document (or PDF)")
    p.add_argument("model", help="model file (TOML)")
    p.add_argument("-o", "--output", help="output file (.tex, or .pdf with --pdf); default: standard output")
    p.add_argument("--pdf", action="store_true", help="compile to PDF with pdflatex/latexmk")
    p.add_argument("--snippet", action="store_true", help="equations only, to paste into a document")
    p.add_argument("--at", help="also tabulate the numeric solution at this input value")
    p.add_argument("--input", metavar="NAME", help="derive for this input variable")
    p.set_defaults(func=cmd_latex)

    p = sub.add_parser("plot", help="positions, velocities and accelerations against the input")
    p.add_argument("model", help="model file (TOML)")
    _sweep_args(p)
    p.add_argument("--vars", nargs="+", metavar="NAME", help="variables or point coordinates to plot "
                   "(default: the unknowns)")
    p.add_argument("-o", "--output", required=True, help="image file: .png, .svg or .pdf")
    p.set_defaults(func=cmd_plot)

    p = sub.add_parser("draw", help="the kinematic diagram at one input value")
    p.add_argument("model", help="model file (TOML)")
    p.add_argument("--at", help="input value (default: the input's guess)")
    p.add_argument("--input", metavar="NAME", help="drive this variable instead of the declared input")
    p.add_argument("--mode", metavar="SIGNATURE", help="assembly mode")
    p.add_argument("--vectors", action="store_true", help="draw the loop vectors with their names")
    p.add_argument("-o", "--output", required=True, help="image file: .png, .svg or .pdf")
    p.set_defaults(func=cmd_draw)

    p = sub.add_parser("animate", help="the linkage moving over a sweep (GIF, or MP4 with ffmpeg)")
    p.add_argument("model", help="model file (TOML)")
    _sweep_args(p)
    p.add_argument("--fps", type=float, default=20.0, help="frames per second (default 20)")
    p.add_argument("-o", "--output", required=True, help=".gif or .mp4 file")
    p.set_defaults(func=cmd_animate)
    _force_parsers(sub)
    return parser


def _force_parsers(sub) -> None:
    """``loopsolve forces`` and ``loopsolve simulate`` (see :mod:`loopsolve.kinetostatics`, :mod:`loopsolve.simulate`)."""
    p = sub.add_parser("forces", help="driving torque, joint forces, shaking force and energies (at one input "
                       "or along a sweep)")
    p.add_argument("model", help="model file (TOML) with [bodies]")
    p.add_argument("--at", help="one input value (or use --from/--to/--step for a sweep)")
    p.add_argument("--from", dest="start", help="first input value of a sweep")
    p.add_argument("--to", dest="stop", help="last input value of a sweep")
    p.add_argument("--step", help="output step of a sweep")
    _rate_args(p)
    p.add_argument("--through-limits", action="store_true", help="continue around limit positions")
    p.add_argument("--flywheel", metavar="CS", type=float, help="size a flywheel for this coefficient of speed "
                   "fluctuation (a full-turn sweep at constant speed; e.g. 0.02)")
    p.add_argument("--plot", metavar="FILE", help="also write the driving torque (and joint-force and "
                   "shaking-force polar plots for a sweep) to this image file (.png/.svg/.pdf)")
    p.add_argument("--format", choices=("table", "csv", "json"), default="table")
    p.add_argument("-o", "--output", help="write to this file instead of standard output")
    p.set_defaults(func=cmd_forces)

    p = sub.add_parser("simulate", help="integrate the equation of motion (forward dynamics)")
    p.add_argument("model", help="model file (TOML) with [bodies]")
    p.add_argument("--duration", required=True, type=float, help="simulated time (s)")
    p.add_argument("--step", type=float, default=0.01, help="output time step (s, default 0.01)")
    p.add_argument("--torque", default="0", help="driving torque (N*m) or force (N): a number or an expression "
                   "of the input, <input>_vel and t (default 0)")
    p.add_argument("--speed0", help="initial input speed (default: the model's, else 0)")
    p.add_argument("--at", help="initial input value (default: the input's guess)")
    p.add_argument("--input", metavar="NAME", help="drive this variable instead of the declared input")
    p.add_argument("--mode", metavar="SIGNATURE", help="assembly mode")
    p.add_argument("--format", choices=("table", "csv", "json"), default="table")
    p.add_argument("-o", "--output", help="write to this file instead of standard output")
    p.set_defaults(func=cmd_simulate)


def cmd_forces(args) -> int:
    from .errors import ModelError
    from .kinetostatics import forces

    mech = _load(args.model)
    sweep_args = (args.start, args.stop, args.step)
    if any(a is not None for a in sweep_args):
        if args.at is not None or any(a is None for a in sweep_args):
            raise ModelError("give either --at, or --from, --to and --step")
        result = forces(mech, args.start, args.stop, args.step, speed=args.speed, accel=args.accel,
                        input=args.input, mode=args.mode, through_limits=args.through_limits)
    else:
        result = forces(mech, args.at, speed=args.speed, accel=args.accel, input=args.input, mode=args.mode)
    fw = result.flywheel(args.flywheel) if args.flywheel is not None else None
    if args.plot:
        from .forceplots import plot_forces
        from .plotting import check_output

        check_output(args.plot, "figure")
        plot_forces(result, output=args.plot, flywheel=fw)
        print(f"wrote {args.plot}", file=sys.stderr)
    if args.format == "json":
        text = result.to_json(flywheel=fw) + "\n"
    elif args.format == "csv":
        text = result.to_csv()
    else:
        text = result.table() + (f"\n{fw}\n" if fw is not None else "")
    if fw is not None and args.format == "csv":
        print(str(fw), file=sys.stderr)
    _write(text, args.output)
    return EXIT_OK


def cmd_simulate(args) -> int:
    from .simulation import simulate

    mech = _load(args.model)
    sim = simulate(mech, args.duration, step=args.step, torque=args.torque, speed0=args.speed0, at=args.at,
                   input=args.input, mode=args.mode)
    _write(sim.to_json() + "\n" if args.format == "json" else sim.to_csv() if args.format == "csv"
           else sim.table(), args.output)
    return EXIT_OK


def _sweep_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--from", dest="start", help="first input value (default: 0, or where the mechanism "
                   "can be assembled)")
    p.add_argument("--to", dest="stop", help="last input value (default: a full turn, or the end of the "
                   "reachable range, traced around its limits)")
    p.add_argument("--step", default="4", help="output step (default 4)")
    _rate_args(p)
    p.add_argument("--through-limits", action="store_true", help="continue around limit positions")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")


def _sweep_for(args):
    from .tracking import sweep

    mech = _load(args.model)
    start, stop, through = args.start, args.stop, args.through_limits
    if start is None or stop is None:
        from .solve import display_value, input_value
        from .tracking import default_range

        ck = mech.compile(args.input)
        step = display_value(ck, input_value(ck, args.step))
        d_start, d_stop, d_through = default_range(ck, step, mode=args.mode)
        start = d_start if start is None else start
        stop = d_stop if stop is None else stop
        through = through or d_through
    return sweep(mech, start, stop, args.step, speed=args.speed, accel=args.accel, jerk=args.jerk,
                 input=args.input, mode=args.mode, through_limits=through,
                 progress=None if not args.quiet else False, method=getattr(args, "method", "auto"))


def cmd_vectors(args) -> int:
    from .diagram import to_vector_model

    _write(to_vector_model(_load(args.model)), args.output)
    return EXIT_OK


def cmd_modes(args) -> int:
    from .modes import assembly_modes, format_modes, modes_to_json

    mech = _load(args.model)
    modes = assembly_modes(mech, args.at, input=args.input)
    _write(modes_to_json(modes) + "\n" if args.format == "json" else format_modes(modes), None)
    return EXIT_OK


def cmd_latex(args) -> int:
    from .latex import to_latex, write_pdf

    mech = _load(args.model)
    tex = to_latex(mech, input=args.input, at=args.at, snippet=args.snippet)
    if args.pdf:
        out = args.output or (Path(args.model).stem + ".pdf")
        write_pdf(tex, out)
        print(f"wrote {out}", file=sys.stderr)
    else:
        _write(tex, args.output)
    return EXIT_OK


def cmd_plot(args) -> int:
    from .plotting import check_output, plot_sweep

    check_output(args.output, "figure")
    plot_sweep(_sweep_for(args), args.vars, output=args.output)
    print(f"wrote {args.output}", file=sys.stderr)
    return EXIT_OK


def cmd_draw(args) -> int:
    from .plotting import check_output, draw

    check_output(args.output, "figure")
    mech = _load(args.model)
    draw(mech, args.at, input=args.input, mode=args.mode, vectors=args.vectors, output=args.output)
    print(f"wrote {args.output}", file=sys.stderr)
    return EXIT_OK


def cmd_animate(args) -> int:
    from .plotting import animate, check_output

    check_output(args.output, "animation")
    animate(_sweep_for(args), output=args.output, fps=args.fps, progress=None if not args.quiet else False)
    print(f"wrote {args.output}", file=sys.stderr)
    return EXIT_OK


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``loopsolve`` console script."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except LoopsolveError as exc:
        if os.environ.get("LOOPSOLVE_DEBUG"):
            raise
        msg = "; ".join(line.strip() for line in str(exc).strip().splitlines() if line.strip()).replace(":; ", ": ")
        print(f"loopsolve: {type(exc).__name__}: {msg}", file=sys.stderr)
        return exc.exit_code
    except KeyboardInterrupt:
        print("loopsolve: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        return EXIT_OK


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
