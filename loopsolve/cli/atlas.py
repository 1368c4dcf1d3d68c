"""``loopsolve atlas build|default|info`` and ``loopsolve synthesize --shape``: atlases and shape synthesis.

The contract is in ``DESIGN.md`` ("Atlas and shape synthesis"). Errors are one line, exit 2
(a bad curve, an atlas of another model, a foreign or damaged atlas), 3 (no certified design).
"""

from __future__ import annotations

import json
import math
import os
import sys

from .common import EXIT_OK, check_writable, load_model, write_output


def add_atlas_parsers(sub) -> None:
    """Add ``loopsolve atlas`` (``build``, ``default``, ``info``) to the subcommands ``sub``."""
    p = sub.add_parser("atlas", help="atlases of coupler curves for shape synthesis (build, info)")
    asub = p.add_subparsers(dest="atlas_command", metavar="ACTION")
    asub.required = True
    b = asub.add_parser("build", help="sample designs of a model, trace their point's curves, store them (zarr)")
    b.add_argument("model", help="model file (TOML)")
    b.add_argument("--point", required=True, metavar="P", help="the point whose curve is stored")
    b.add_argument("--vary", action="append", required=True, metavar="NAME=LOW:HIGH",
                   help="a sampled parameter and its box (model units; a positive length on a log scale); repeat")
    b.add_argument("--size", type=int, required=True, metavar="N", help="designs to sample")
    b.add_argument("--seed", type=int, default=0, help="seed of the Sobol sequence (default 0)")
    b.add_argument("--chunk", type=int, default=None, metavar="C", help="designs per chunk / Dask task (default 2048)")
    b.add_argument("--workers", type=int, metavar="N", help="build on a local Dask cluster of N processes")
    b.add_argument("--scheduler", metavar="ADDRESS", help="build on the Dask cluster at ADDRESS (tcp://host:port)")
    b.add_argument("--max-size", type=int, default=None, metavar="N",
                   help="refuse a larger --size before any work (default 2000000)")
    b.add_argument("-o", "--output", required=True, metavar="ATLAS.zarr",
                   help="the atlas (a directory); an atlas of the same model, point, box and seed there is grown "
                   "or resumed")
    b.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    b.set_defaults(func=cmd_atlas_build)
    d = asub.add_parser("default", help="build a model's default atlas into the cache now (else: on first use)")
    d.add_argument("model", help="model file (TOML)")
    d.add_argument("--point", default="P", metavar="P", help="the point (default P)")
    d.add_argument("--workers", type=int, metavar="N", help="build on a local Dask cluster of N processes")
    d.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    d.set_defaults(func=cmd_atlas_default)
    i = asub.add_parser("info", help="what an atlas holds (JSON)")
    i.add_argument("atlas", help="the atlas (ATLAS.zarr)")
    i.set_defaults(func=cmd_atlas_info)


def parse_vary(texts, *, allow_fixed: bool = False) -> dict:
    """``NAME=LOW:HIGH`` (and, with ``allow_fixed``, ``NAME=VALUE``: LOW = HIGH) options as a dict."""
    from ..errors import ModelError

    vary = {}
    for text in texts or ():
        name, sep, rest = text.partition("=")
        name = name.strip()
        parts = rest.split(":")
        if not sep or not name or len(parts) not in ((1, 2) if allow_fixed else (2,)):
            raise ModelError(f"--vary {text!r}: expected NAME=LOW:HIGH" + (" or NAME=VALUE" if allow_fixed else ""))
        try:
            vals = [float(v) for v in parts]
        except ValueError:
            raise ModelError(f"--vary {text!r}: the bounds must be numbers") from None
        if not all(math.isfinite(v) for v in vals):
            raise ModelError(f"--vary {text!r}: the bounds must be finite numbers")
        lo, hi = (vals[0], vals[0]) if len(vals) == 1 else vals
        if lo > hi or (lo == hi and not allow_fixed):
            raise ModelError(f"--vary {text!r}: LOW must be smaller than HIGH")
        if name in vary:
            raise ModelError(f"--vary {name} given twice")
        vary[name] = (lo, hi)
    return vary


def cmd_atlas_build(args) -> int:
    from ..design.atlas.build import DEFAULT_CHUNK, MAX_SIZE, build_atlas
    from ..errors import ModelError

    out = args.output
    if out in ("", "-"):
        raise ModelError("-o: an atlas is a directory (ATLAS.zarr), not standard output")
    if os.path.exists(out) and not os.path.isdir(out):
        raise ModelError(f"-o {out}: exists and is not an atlas (a file); choose another name")
    mech = load_model(args.model)
    atlas = build_atlas(mech, point=args.point, vary=parse_vary(args.vary), size=args.size, seed=args.seed,
                        out=out, chunk=args.chunk or DEFAULT_CHUNK, workers=args.workers, scheduler=args.scheduler,
                        max_size=args.max_size or MAX_SIZE, progress=None if not args.quiet else False)
    s = atlas.summary()
    print(f"wrote {out}: {s['size']} designs, {s['certified']} certified ({s['crank']} with a crank, "
          f"{s['rocker']} rocking), {s['not_assemblable']} not assemblable, {s['degenerate']} degenerate curves",
          file=sys.stderr)
    return EXIT_OK


def cmd_atlas_default(args) -> int:
    import time

    from ..design.atlas.defaults import default_atlas
    from ..design.studies import check_cluster

    check_cluster(args.workers, None)
    mech = load_model(args.model)
    t0 = time.perf_counter()
    a = default_atlas(mech, args.point, progress=None if not args.quiet else False, workers=args.workers)
    s = a.summary()
    print(f"default atlas of {s['model']!r} point {s['point']!r}: {a.path or '(in memory: the cache is off)'}: "
          f"{s['size']} designs, {s['certified']} certified ({s['crank']} with a crank); {time.perf_counter() - t0:.0f} s",
          file=sys.stderr)
    return EXIT_OK


def cmd_atlas_info(args) -> int:
    from ..design.atlas.build import open_atlas

    a = open_atlas(args.atlas)
    write_output(json.dumps(a.summary(), indent=1) + "\n", None)
    return EXIT_OK


def cmd_shape(args) -> int:
    """``synthesize MODEL --shape P ...``."""
    from ..design.synthesis.shape.run import synthesize_shape
    from ..errors import ModelError
    from .common import synthesis_output

    for flag, given in (("--function", args.function), ("--motion", args.motion), ("--link", args.link),
                        ("--inputs", args.inputs), ("--range", args.input_range), ("--runs", args.runs != 1),
                        ("--method", args.method != "general"), ("--no-atlas", args.no_atlas)):
        if given:
            raise ModelError(f"{flag} is not used by --shape (shape synthesis is free in timing; see --help)")
    for out in (args.output, args.report):
        check_writable(out)
    if args.atlas is not None and not os.path.isdir(args.atlas):
        from ..design.atlas.store import check_tree

        check_tree(args.atlas)  # a one-line error naming what is wrong
    mech = load_model(args.model)
    vary = parse_vary(args.vary, allow_fixed=True)
    rep = synthesis_output(args, lambda: synthesize_shape(
        mech, shape=args.shape, targets=args.targets, closed=not args.open, atlas=args.atlas, top=args.top,
        crank=args.crank, transmission=args.transmission, vary=vary, seed=args.seed,
        progress=None if not args.quiet else False, max_targets=args.max_targets), "")
    if rep is not None:
        c = rep["candidates"]
        print(f"shape: {len(c)} certified design(s), best rms {c[0]['shape_error']['rms']:.4g}, max "
              f"{c[0]['shape_error']['max']:.4g}; wrote {args.report}" + (f" and {args.output}" if args.output else ""),
              file=sys.stderr)
    return EXIT_OK


def view_shape(args) -> int:
    """``loopsolve view MODEL --shape R.json -o page.html``."""
    import numpy as np

    from ..errors import ModelError
    from ..model.files import read_regular
    from ..output.shapeview import shape_html, sweeps_from_report

    try:
        report = json.loads(read_regular(args.shape, 100_000_000, what="report").decode("utf-8"))
    except (OSError, ValueError) as exc:
        raise ModelError(f"--shape {args.shape}: cannot read the report ({exc})") from None
    mech = load_model(args.model)
    sweeps = sweeps_from_report(mech, report)
    try:
        xy = np.array([[t["x"], t["y"]] for t in report["targets"]], dtype=float)
    except (KeyError, TypeError, ValueError):
        raise ModelError(f"--shape {args.shape}: the report has no target coordinates") from None
    write_output(shape_html(xy, report, sweeps), args.output)
    return EXIT_OK
