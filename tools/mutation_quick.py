"""A bounded mutation run for a busy machine: sampled mutants against their module's own tests.

``tools/mutation.sh`` lets mutmut first run its whole test selection once under tracing to learn
which tests reach which function; on a shared machine that pass alone can outlast the time
there is. This script skips it: it takes every Nth mutant of the named modules (round robin
over the modules, so a run cut short still covers each), runs the test files listed for the
module below with ``MUTANT_UNDER_TEST`` set (in ``./mutants``, made by
``tools/mutation_summary.py --generate``), and records each exit code in mutmut's meta files,
so ``tools/mutation.sh --summary`` reports it like a mutmut run. A mutant whose tests exceed
``--timeout`` is left unchecked (not counted as killed). Results are also appended to
``mutants/quick.tsv``.

    python3 tools/mutation_summary.py --generate
    nice -n 19 python3 tools/mutation_quick.py --every 140 --until 17:35 design.studies output.view
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from collections import defaultdict
from pathlib import Path

STUDY = ["tests/design/test_study_angle_parameter.py", "tests/design/test_study_units.py", "tests/design/test_study_range_end.py",
         "tests/design/test_study_slider_crank.py", "tests/design/test_metrics_swing.py", "tests/design/test_metrics_time_ratio.py",
         "tests/design/test_study_modes.py", "tests/design/test_study.py"]
TRACKER = ["tests/kinematics/test_tracker_hand_values.py", "tests/kinematics/test_tracking.py",
           "tests/kinematics/test_location_precision.py"]
FORCES = ["tests/dynamics/test_force_outputs.py", "tests/dynamics/test_body_quantities.py", "tests/dynamics/test_forces.py"]
DW = "tests/output/test_drawn_where_solved.py::"
PL = "tests/output/test_plotting.py::"
#: the drawing: the pictures' places against the solve (the page's Chromium test and the every-model sweeps left out)
DRAWING = [PL + "test_draw_fourbar", PL + "test_draw_slider_blocks_and_guides", PL + "test_geometry_matches_solved_points",
           PL + "test_coupler_point_is_drawn_as_a_point_and_traced", PL + "test_watt1_vectors_tip_to_tail_on_the_joints",
           DW + "test_slider_crank_coupler_point_is_a_tracer", DW + "test_dxf_circles_have_the_drawing_s_radius"]
C = "tests/output/test_cad.py::"
#: the CAD export: read back from the written DXF/SVG (small selections: a mutant costs seconds, not minutes)
CAD = [C + "test_dxf_round_trip", C + "test_svg_round_trip", C + "test_entities_read_as_a_summary",
       DW + "test_dxf_header_names_the_model_s_length_unit", DW + "test_dxf_circles_have_the_drawing_s_radius",
       C + "test_cli_synthesized_design_file_draws_to_dxf_at_the_solve", C + "test_dxf_without_ezdxf_is_a_one_line_error"]
UNITS = ["tests/model/test_units.py", "tests/model/test_unit_registry.py"]
SO = "tests/design/test_synthesis_outputs.py::"
SM = "tests/design/test_classical_defects_and_structural_error.py::"
SYNTH = [SO + "test_to_json_refuses_a_nan", SO + "test_freudenstein_report_values_are_the_written_designs"]
CERT = [SO + "test_every_certificate_agrees_with_its_defects"]
LM = ["tests/design/test_lockstep_lm.py::test_batch_lm_crosses_the_periodic_bound_and_recovers_the_planted_design",
      "tests/design/test_lockstep_lm.py::test_reassemble_from_a_nearby_position_matches_the_closed_form",
      SO + "test_crank_finds_a_certified_crank_when_the_best_fit_is_not_one"]  # the polish within --crank
STRUCT = [SM + "test_structural_error_of_the_freudenstein_design_against_the_closed_form"]
CS = "tests/design/test_classical_synthesis.py::"
CLASSIC = [CS + "test_freudenstein_door_meets_the_targets", SO + "test_freudenstein_report_values_are_the_written_designs",
           SO + "test_freudenstein_design_is_the_users_model_with_its_names"]
MOTION = [CS + "test_burmester_door_recovers_and_writes_a_loadable_model", SO + "test_burmester_design_is_the_users_model_with_its_names",
          CS + "test_burmester_candidates_report_their_crank_angles_at_the_poses_in_the_model_unit"]
EOM = "tests/dynamics/test_eom.py::"
LATEX = [EOM + "test_named_symbols_and_values", EOM + "TestLatexSection::test_thesis_symbols_then_numbers",
         EOM + "TestLatexSection::test_pdf_compiles_and_reads_like_the_notes[engine_slider_crank]",
         "tests/output/test_latex_at_tables.py"]
#: the test files of each module, fast ones first (pytest -x stops at the first failure)
TESTS = {"model.bodies": FORCES + ["tests/model/test_diagram_bodies.py"],
         "dynamics.dynamics_model": FORCES + ["tests/model/test_diagram_bodies.py"],
         "dynamics.forceresults": FORCES, "dynamics.simulation": FORCES, "design.lockstep": STUDY,
         "design.studies": STUDY + ["tests/design/test_study_progress.py"],
         "design.sensitivity": STUDY, "design.designs": STUDY, "design.metrics": STUDY,
         "output.view": ["tests/output/test_page_values.py", "tests/output/test_view.py"],
         "kinematics.grid": TRACKER, "kinematics.reach": TRACKER, "kinematics.rows": TRACKER + ["tests/kinematics/test_batch.py"],
         "output.cad": CAD, "output.geometry": DRAWING, "output.skeleton": DRAWING,
         "model.unitlib": UNITS, "model.units": UNITS,
         "design.synthesis.report": SYNTH, "design.synthesis.certificate": CERT, "design.synthesis.lockstep_lm": LM, "design.synthesis.structural_error": STRUCT,
         "design.synthesis.classical.run": CLASSIC, "design.synthesis.classical.motion": MOTION, "design.synthesis.classical.transplant": CLASSIC[2:] + MOTION[1:],
         "design.synthesis.classical.freudenstein": CLASSIC, "design.synthesis.classical.burmester": MOTION,
         "output.latex_dynamics": LATEX}


def module_of(name: str) -> str:
    """``loopsolve.kinematics.sweep.x_sweep__mutmut_3`` -> ``kinematics.sweep`` (``xǁClassǁmethod`` too)."""
    parts = name.split(".")
    i = next(k for k, part in enumerate(parts) if part.startswith(("x_", "xǁ")))
    return ".".join(parts[1:i])


def meta_path(root: Path, mod: str) -> Path:
    return root / "loopsolve" / (mod.replace(".", "/") + ".py.meta")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("modules", nargs="*", default=sorted(TESTS), help="modules (default: all listed above)")
    ap.add_argument("--every", type=int, default=100, help="every Nth mutant of each module")
    ap.add_argument("--timeout", type=float, default=1500, help="seconds per mutant")
    ap.add_argument("--until", help="HH:MM (UTC): start no mutant after this time")
    args = ap.parse_args(argv)
    root = Path("mutants")
    by = defaultdict(list)
    for mod in args.modules:
        meta = json.loads(meta_path(root, mod).read_text())
        names = sorted(meta["exit_code_by_key"], key=lambda n: (n.rpartition("__mutmut_")[0],
                                                                int(n.rpartition("__mutmut_")[2])))
        by[mod] = names[:: args.every]
    order = []
    while any(by.values()):
        for mod in by:  # in the order the modules are named (the ones to check first, first)
            if by[mod]:
                order.append(by[mod].pop(0))
    env = dict(os.environ, PYTHONPATH=str(root.resolve()), MPLBACKEND="Agg")
    env.pop("LOOPSOLVE_DEBUG", None)
    tsv = root / "quick.tsv"
    done = {ln.split("\t")[0] for ln in tsv.read_text(encoding="utf-8").splitlines()
            if ln.split("\t")[1:2] != ["None"]} if tsv.exists() else set()
    log = tsv.open("a", encoding="utf-8")
    for name in order:
        if name in done:  # a run cut short resumes where it stopped (timeouts are tried again)
            continue
        if args.until and time.strftime("%H:%M", time.gmtime()) >= args.until:
            break
        mod = module_of(name)
        env["MUTANT_UNDER_TEST"] = name
        t0 = time.time()
        try:
            r = subprocess.run([sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "-q", "-x", "-W", "ignore",
                                *TESTS[mod]], cwd=root, env=env, capture_output=True, text=True, timeout=args.timeout)
            code = r.returncode
            tail = [ln for ln in r.stdout.splitlines() if ln.startswith("FAILED") or " passed" in ln][-1:]
        except subprocess.TimeoutExpired:
            code, tail = None, ["timeout: left unchecked"]
        path = meta_path(root, mod)
        meta = json.loads(path.read_text())
        meta["exit_code_by_key"][name] = code
        path.write_text(json.dumps(meta))
        log.write(f"{name}\t{code}\t{time.time() - t0:.0f}s\t{' '.join(tail)}\n")
        log.flush()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
