"""``loopsolve forces`` and ``loopsolve simulate``: their arguments and outputs.
"""

from __future__ import annotations

import math
import sys

from .common import (EXIT_OK, add_rate_args, add_text_output, check_writable, load_model, one_line, temporary_output,
                     write_output)
from .fileargs import file_argument


def add_force_parsers(sub) -> None:
    """``loopsolve forces`` and ``loopsolve simulate`` (see :mod:`loopsolve.dynamics.kinetostatics`, :mod:`loopsolve.simulate`)."""
    p = sub.add_parser("forces", help="driving torque, joint forces, shaking force and energies (at one input "
                       "or along a sweep)")
    file_argument(p, "model", role="input", help="model file (TOML) with [bodies]")
    p.add_argument("--at", help="one input value (or use --from/--to/--step for a sweep)")
    p.add_argument("--from", dest="start", help="first input value of a sweep")
    p.add_argument("--to", dest="stop", help="last input value of a sweep")
    p.add_argument("--step", help="output step of a sweep")
    add_rate_args(p)
    p.add_argument("--through-limits", action="store_true", help="continue around limit positions")
    p.add_argument("--flywheel", metavar="CS", type=float, help="size a flywheel for this coefficient of speed "
                   "fluctuation (e.g. 0.02) over a cycle at constant speed: the --from/--to range (360 or 720 "
                   "degrees), else one turn from --at (default 0)")
    file_argument(p, "--plot", role="output", fmt="figure", metavar="FILE", help="also write the driving torque (and joint-force and "
                   "shaking-force polar plots for a sweep) to this image file (.png/.svg/.pdf)")
    p.add_argument("--format", choices=("table", "csv", "json"), default="table")
    add_text_output(p)
    p.set_defaults(func=cmd_forces)

    p = sub.add_parser("simulate", help="integrate the equation of motion (forward dynamics)")
    file_argument(p, "model", role="input", help="model file (TOML) with [bodies]")
    p.add_argument("--duration", required=True, type=float, help="simulated time (s)")
    p.add_argument("--step", type=float, default=0.01, help="output time step (s, default 0.01)")
    p.add_argument("--torque", default="0", help="driving torque (N*m) or force (N): a number or an expression "
                   "of the input, <input>_vel and t (default 0)")
    p.add_argument("--speed0", help="initial input speed (default: the model's, else 0)")
    p.add_argument("--max-steps", type=int, metavar="N", help="bound on the integrator's steps (default 20000 + "
                   "200 per output row); the rows so far are kept when it is reached")
    p.add_argument("--at", help="initial input value (default: the input's guess)")
    p.add_argument("--input", metavar="NAME", help="drive this variable instead of the declared input")
    p.add_argument("--mode", metavar="SIGNATURE", help="assembly mode")
    p.add_argument("--format", choices=("table", "csv", "json"), default="table")
    add_text_output(p)
    p.set_defaults(func=cmd_simulate)



def cmd_forces(args) -> int:
    from ..errors import ModelError
    from ..dynamics.kinetostatics import forces

    check_writable(args.output)
    if args.plot:
        from ..output.plotting import check_output

        check_output(args.plot, "figure")
        check_writable(args.plot)
    mech = load_model(args.model)
    sweep_args = (args.start, args.stop, args.step)
    if args.flywheel is not None and all(a is None for a in sweep_args):
        # one cycle of the input by default (from --at, else 0), 360 rows
        import math

        from ..model.units import Kind, parse_quantity

        turn = 360.0 if mech.units.angle == "deg" else 2 * math.pi
        x0 = 0.0
        if args.at is not None:
            x0 = parse_quantity(args.at, Kind.ANGLE, angle_unit=mech.units.angle, length_unit=mech.units.length,
                                where="--at")
            x0 = math.degrees(x0) if mech.units.angle == "deg" else x0
            args.at = None
        sweep_args = (x0, x0 + turn, turn / 360)
        args.start, args.stop, args.step = sweep_args
    if any(a is not None for a in sweep_args):
        if args.at is not None or any(a is None for a in sweep_args):
            raise ModelError("give either --at, or --from, --to and --step")
        result = forces(mech, args.start, args.stop, args.step, speed=args.speed, accel=args.accel,
                        input=args.input, mode=args.mode, through_limits=args.through_limits)
    else:
        result = forces(mech, args.at, speed=args.speed, accel=args.accel, input=args.input, mode=args.mode)
    fw = result.flywheel(args.flywheel) if args.flywheel is not None else None
    if args.plot:
        from ..output.forceplots import plot_forces

        with temporary_output(args.plot) as tmp:
            plot_forces(result, output=tmp, flywheel=fw)
        print(f"wrote {one_line(args.plot)}", file=sys.stderr)
    if args.format == "json":
        text = result.to_json(flywheel=fw) + "\n"
    elif args.format == "csv":
        text = result.to_csv()
    else:
        text = result.table() + (f"\n{fw}\n" if fw is not None else "")
    if fw is not None and args.format == "csv":
        print(str(fw), file=sys.stderr)
    write_output(text, args.output)
    return EXIT_OK



def cmd_simulate(args) -> int:
    from ..dynamics.simulation import simulate

    check_writable(args.output)
    mech = load_model(args.model)
    sim = simulate(mech, args.duration, step=args.step, torque=args.torque, speed0=args.speed0, at=args.at,
                   input=args.input, mode=args.mode, max_steps=args.max_steps)
    write_output(sim.to_json() + "\n" if args.format == "json" else sim.to_csv() if args.format == "csv"
           else sim.table(), args.output)
    return EXIT_OK
