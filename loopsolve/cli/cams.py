"""``loopsolve cam MODEL NAME``: a cam's motion law, pressure angle, curvature and profile."""

from __future__ import annotations

from .common import EXIT_OK, check_writable, load_model, temporary_output, write_output
from .fileargs import file_argument


def add_cam_parser(sub) -> None:
    """Add ``loopsolve cam`` to the subcommands ``sub``."""
    p = sub.add_parser("cam", help="a cam's SVAJ, pressure angle and radius of curvature over one turn, and its "
                       "profile (DXF, SVG or CSV)")
    file_argument(p, "model", role="input", help="model file (TOML) with [cams.NAME]")
    p.add_argument("name", help="the cam (the NAME of [cams.NAME])")
    p.add_argument("--svaj", action="store_true", help="list every row (s, v, a, j, pressure angle, radius of "
                   "curvature) in the table, not only the summary")
    p.add_argument("--step", type=float, help="angle between rows in the model's angle unit (default 1 degree)")
    file_argument(p, "-o", "--output", role="output", fmt="cam", help="write the profile to this file: .dxf, .svg "
                  "or .csv")
    p.add_argument("--format", choices=("table", "json"), default="table")
    p.set_defaults(func=cmd_cam)


def cmd_cam(args) -> int:
    from pathlib import Path

    from ..errors import ModelError
    from ..output.camprofile import cam_report, format_cam, write_cam_profile

    if args.output:
        check_writable(args.output)
        fmt = Path(args.output).suffix.lower().lstrip(".")
        if fmt == "dxf":
            from ..output.cad import check_cad_output

            check_cad_output(args.output)
    mech = load_model(args.model)
    report = cam_report(mech, args.name, step=args.step)
    write_output(format_cam(report, args.format, svaj=args.svaj), None)
    if args.output:
        with temporary_output(args.output) as tmp:
            write_cam_profile(mech, args.name, tmp)
        import sys

        print(f"wrote {args.output}", file=sys.stderr)
    if report["defects"]:  # reported in full above; the declaration is still wrong
        raise ModelError(f"{mech.source or mech.name}: {report['defects'][0]}")
    return EXIT_OK
