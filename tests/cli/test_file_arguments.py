"""Nothing lost (issue 29): every output option of every command, against every way it could destroy data.

The commands and their file options are read from the parser itself (the roles that
``loopsolve.cli.fileargs.file_argument`` puts on the actions), so an output option added later is
in the table without editing it; a command with outputs but no base command line below fails
:func:`test_every_command_with_outputs_has_a_base_command_line`. For each output option, each
case — the output onto an input (the model, the targets), through a symlink or a hard link to
an input, two outputs of one command on one file, an extension that says another format — must be
refused before any work: exit status 2, one line naming the option and the path, every input
byte-identical afterwards and no output written.
"""

from __future__ import annotations

import hashlib
import os
import re
from pathlib import Path

import pytest

import loopsolve as ls
from loopsolve.cli import build_parser, main
from loopsolve.cli.fileargs import FORMATS, command_parsers, file_actions

MODELS = ls.models_dir()
PARSER = build_parser()
COMMANDS = command_parsers(PARSER)

# a command line for each command that writes files; {m} the model, {t} the targets file
BASE = {
    "solve": ["solve", "{m}", "--at", "30"],
    "sweep": ["sweep", "{m}", "--from", "0", "--to", "60", "--step", "30", "-q"],
    "vectors": ["vectors", "{m}"],
    "latex": ["latex", "{m}"],
    "plot": ["plot", "{m}", "--from", "0", "--to", "60", "--step", "30", "-q"],
    "draw": ["draw", "{m}", "--at", "30"],
    "animate": ["animate", "{m}", "--from", "0", "--to", "60", "--step", "30", "-q"],
    "view": ["view", "{m}", "--from", "0", "--to", "60", "--step", "30", "-q"],
    "study": ["study", "{m}", "--vary", "r2=0.8:1.2:2", "--from", "0", "--to", "60", "--step", "30", "-q"],
    "synthesize": ["synthesize", "{m}", "--path", "P", "--targets", "{t}", "--inputs", "30,60,90", "--vary",
                   "r2=0.5:2", "-q"],
    "forces": ["forces", "{m}", "--at", "30"],
    "simulate": ["simulate", "{m}", "--duration", "0.1"],
    "cam": ["cam", "{m}", "c1"],
}
MODEL_OF = {"forces": "thesis_crank_rocker_dynamics.toml", "simulate": "thesis_crank_rocker_dynamics.toml",
            "cam": str(Path(__file__).resolve().parent.parent / "data" / "cam_follower.toml")}
TARGETS = "x,y\n1.247635,2.261923\n1.125070,2.556968\n0.759129,2.635152\n"


def _flag(action):
    return action.option_strings[0] if action.option_strings else action.dest


def _outputs(command):
    return file_actions(COMMANDS[command], "output")


def _inputs(command):
    return file_actions(COMMANDS[command], "input")


class _Args:
    """What a format rule reads: every option at its parser default (``--format table``, no ``--pdf``)."""

    def __init__(self, command):
        for a in COMMANDS[command]._actions:
            setattr(self, a.dest, a.default)
        self.command = command


def _good_suffix(command, action):
    return FORMATS[action.file_format](_Args(command))[0][0]


def _wrong_suffix(command, action):
    allowed = FORMATS[action.file_format](_Args(command))[0]
    return next(s for s in (".dxf", ".toml", ".json", ".png", ".csv") if s not in allowed)


def _cases():
    out = []
    for command in sorted(COMMANDS):
        outs = _outputs(command)
        for o in outs:
            for i in _inputs(command):
                for how in ("onto", "symlink", "hardlink"):
                    out.append(pytest.param(command, _flag(o), how, _flag(i), None,
                                            id=f"{command}-{_flag(o)}-{how}-{_flag(i)}"))
            out.append(pytest.param(command, _flag(o), "extension", None, None, id=f"{command}-{_flag(o)}-extension"))
            for o2 in outs:
                if o2 is not o:
                    out.append(pytest.param(command, _flag(o), "twice", None, _flag(o2),
                                            id=f"{command}-{_flag(o)}-twice-{_flag(o2)}"))
    return out


def _digest(p: Path) -> str:
    return hashlib.sha256(p.read_bytes()).hexdigest()


@pytest.fixture
def files(tmp_path):
    def make(command):
        model = tmp_path / "model.toml"
        src = MODEL_OF.get(command, "fourbar_path_synthesis.toml")
        model.write_bytes((MODELS / src).read_bytes())
        targets = tmp_path / "targets.csv"
        targets.write_text(TARGETS, encoding="utf-8")
        report = tmp_path / "report.json"  # view --shape R.json: the report of a shape synthesis
        report.write_text("{}", encoding="utf-8")
        return {"model": model, "--targets": targets, "--shape": report}
    return make


@pytest.mark.parametrize("command, out_flag, how, in_flag, other_flag", _cases())
def test_every_output_option_refuses_what_would_lose_data(capsys, tmp_path, files, command, out_flag, how, in_flag,
                                                          other_flag):
    paths = files(command)
    argv = [a.format(m=paths["model"], t=paths["--targets"]) for a in BASE[command]]
    if in_flag and in_flag.startswith("--") and in_flag not in argv:  # an optional input the base line leaves out
        argv += [in_flag, str(paths[in_flag])]
    action = next(a for a in _outputs(command) if _flag(a) == out_flag)
    if how == "onto":
        target = paths[in_flag]
    elif how in ("symlink", "hardlink"):
        target = tmp_path / f"link{_good_suffix(command, action)}"
        (target.symlink_to if how == "symlink" else lambda p: os.link(p, target))(paths[in_flag])
    elif how == "extension":
        target = tmp_path / f"out{_wrong_suffix(command, action)}"
    else:  # two outputs on one file
        target = tmp_path / f"same{_good_suffix(command, action)}"
        argv += [other_flag, str(target)]
    argv += [out_flag, str(target)]
    before = {k: _digest(p) for k, p in paths.items()}
    listing = sorted(p.name for p in tmp_path.iterdir())

    status = main(argv)
    err = capsys.readouterr().err

    assert status == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("loopsolve: "), err
    assert out_flag in lines[0] and target.name in lines[0], lines[0]
    if how == "twice":
        assert other_flag in lines[0] and "same file" in lines[0], lines[0]
    elif how == "extension":
        assert "must end in" in lines[0], lines[0]
    else:
        assert "input file" in lines[0] and paths[in_flag].name in lines[0], lines[0]
    assert {k: _digest(p) for k, p in paths.items()} == before
    assert sorted(p.name for p in tmp_path.iterdir()) == listing  # nothing written, no debris


def test_every_command_with_outputs_has_a_base_command_line():
    with_outputs = {c for c in COMMANDS if _outputs(c)}
    assert with_outputs == set(BASE), "add the new command to BASE (and its model to MODEL_OF if needed)"
    for c in with_outputs:
        assert any(a.dest == "model" for a in _inputs(c)), f"{c}: the model is not declared as an input"


_FILE_WORDS = re.compile(r"\b(file|write|writes|written)\b", re.I)


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_every_option_naming_a_file_declares_its_role(command):
    """An option whose help or metavar speaks of a file must be declared with file_argument (role and format)."""
    for a in COMMANDS[command]._actions:
        if a.dest == "help":
            continue
        text = f"{a.help or ''}"
        metavar = a.metavar if isinstance(a.metavar, str) else ""
        looks_like_file = bool(_FILE_WORDS.search(text)) or bool(re.search(r"\w\.[A-Za-z]+$", metavar)) or \
            a.dest in ("output", "report", "plot", "model", "targets")
        if looks_like_file:
            assert getattr(a, "file_role", None) in ("input", "output"), (command, a.option_strings or a.dest)


@pytest.mark.parametrize("fmt, name", [("table", "rows.txt"), ("csv", "rows.csv"), ("json", "rows.json"),
                                       ("csv", "rows"), ("table", "rows.DAT")])
def test_text_outputs_with_a_matching_or_no_extension_are_written(capsys, tmp_path, fmt, name):
    model = tmp_path / "m.toml"
    model.write_bytes((MODELS / "thesis_crank_rocker.toml").read_bytes())
    out = tmp_path / name
    assert main(["solve", str(model), "--at", "90", "--format", fmt, "-o", str(out)]) == 0, capsys.readouterr().err
    text = out.read_text(encoding="utf-8")
    assert ("theta4" in text) and (not text.lstrip().startswith("{") or fmt == "json")


@pytest.mark.parametrize("fmt, name, words", [
    ("csv", "rows.json", ["CSV", ".csv", "--format"]),
    ("json", "rows.csv", ["JSON", ".json"]),
    ("table", "rows.csv", ["text table", ".txt", "--format"]),
])
def test_sweep_output_extension_follows_the_format(capsys, tmp_path, fmt, name, words):
    model = tmp_path / "m.toml"
    model.write_bytes((MODELS / "thesis_crank_rocker.toml").read_bytes())
    status = main(["sweep", str(model), "--from", "0", "--to", "30", "--step", "10", "-q", "--format", fmt,
                   "-o", str(tmp_path / name)])
    err = capsys.readouterr().err
    assert status == 2 and len(err.splitlines()) == 1 and "-o" in err and name in err, err
    for w in words:
        assert w in err, err
    assert not (tmp_path / name).exists()


def test_synthesize_refusals_as_the_issue_states_them(capsys, tmp_path):
    """`--targets tgt.csv -o tgt.csv`, `--report tgt.csv`, `-o X --report X`, `-o x.dxf`: refused, the targets intact."""
    model = tmp_path / "m.toml"
    model.write_bytes((MODELS / "fourbar_path_synthesis.toml").read_bytes())
    tgt = tmp_path / "tgt.csv"
    tgt.write_text(TARGETS, encoding="utf-8")
    base = ["synthesize", str(model), "--path", "P", "--targets", str(tgt), "--inputs", "30,60,90", "--vary",
            "r2=0.5:2", "-q"]
    for extra, words in ((["-o", str(tgt)], ["-o", "tgt.csv", "input file"]),
                         (["--report", str(tgt)], ["--report", "tgt.csv", "input file"]),
                         (["-o", str(tmp_path / "X"), "--report", str(tmp_path / "X")], ["-o", "--report", "same file"]),
                         (["-o", str(tmp_path / "x.dxf")], ["-o", "x.dxf", ".toml"])):
        status = main(base + extra)
        err = capsys.readouterr().err
        assert status == 2 and len(err.splitlines()) == 1, err
        for w in words:
            assert w in err, err
        assert tgt.read_text(encoding="utf-8") == TARGETS
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.toml", "tgt.csv"]
