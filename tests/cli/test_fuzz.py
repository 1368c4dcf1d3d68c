"""A seeded fuzz corpus over the command line (issue 9, "Tests that must exist and pass").

The corpus is generated here, deterministically (seed :data:`SEED`), from the shipped models:
byte flips, deleted/duplicated lines, swapped values, type changes, huge/NaN/inf numbers, unit
mutations, injected code in every expression field, deep nesting, control characters, BOM, empty
files and binary junk (≥ 300 model files), plus hostile paths (FIFO, /dev/zero, a directory, a
missing file, a symlink loop, an unreadable file, a FIFO at the cache key) and hostile command
lines (bad numbers, ``--``, huge steps, unknown options, output onto the model).

Every run must exit 0, 2 or 3; a failing run prints exactly one line on stderr (a successful one
at most warning lines), never a traceback; a marker file proves no injected code ran. Most
cases run in-process through :func:`loopsolve.cli.main` (fast); hostile paths, huge steps and a
sample of the rest run as real subprocesses.

``FUZZ_REPORT=path`` writes per-category counts of failing cases (used for the issue's
before/after figures: run once with ``PYTHONPATH=/work/main`` and ``--import-mode=append``,
``FUZZ_NO_XFAIL=1``).
"""

from __future__ import annotations

import collections
import json
import os
import random
import re
import resource
import subprocess
import sys

import pytest

import loopsolve as ls
from loopsolve.cli import main

SEED = 20261122
MODELS = sorted(ls.models_dir().glob("*.toml"))
MARKER_NAME = "FUZZ_MARKER"
NO_XFAIL = bool(os.environ.get("FUZZ_NO_XFAIL"))
GUARD = float(os.environ.get("FUZZ_GUARD", "600"))  # hang guard for subprocesses (not a speed limit)
RESULTS: dict[str, list[tuple[str, bool]]] = collections.defaultdict(list)

INJECTIONS = [
    "__import__('os').system('touch {m}')",
    "open('{m}', 'w')",
    "eval(\\\"open('{m}', 'w')\\\")",
    "exec('import os')",
    "r1; __import__('os').system('touch {m}')",
    "().__class__.__base__.__subclasses__()",
    "(lambda: __import__('os').system('touch {m}'))()",
    "globals()['__builtins__']",
    "sin.__globals__",
    "theta2.__class__",
    "[x for x in ()]",
    "r1 if 1 else 2",
    "`touch {m}`",
    "$(touch {m})",
    "r1 @ r2",
    "f'{{r1}}'",
]
HUGE = ["1e308", "1e400", "-1e400", "nan", "inf", "-inf", "1" + "0" * 400, "1e-320", "0", "-0.0", "1" * 5000,
        "0x7fffffffffffffff", "1e308 * 10"]
UNITS = ["m", "mm", "deg", "rad", "rpm", "mm/s", "kg", "furlong", "rad/s^2", "%", "deg/s", "1/0", "m*m", "s"]
TYPE_VALUES = ["true", "[1, 2]", "{ a = 1 }", "1979-05-27", '""', '"  "', "[]", "{}", '["r1"]', "-5", "'r1'",
               '"""\nr1\n"""']
CONTROL = ["\\u001b[31m", "\\u0000", "\\r", "\\n", "\\u007f", "\\u009b", "\\b"]


def _strings(text):
    return [m.span(1) for m in re.finditer(r'"((?:[^"\\\n]|\\.)*)"', text)]


def _assignments(lines):
    return [i for i, ln in enumerate(lines) if re.match(r"^\s*[\w\"'.-]+\s*=\s*\S", ln)]


def _numbers(text):
    return [m.span() for m in re.finditer(r"(?<![\w.])-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?(?![\w.])", text)]


def corpus(marker: str):
    """(category, case id, bytes) for every mutated model file; deterministic for a seed."""
    rng = random.Random(SEED)
    sources = {p.stem: p.read_text(encoding="utf-8") for p in MODELS}
    names = sorted(sources)
    out = []

    def add(cat, base, data):
        out.append((cat, f"{cat}-{len([c for c in out if c[0] == cat]):03d}-{base}", data))

    for _ in range(40):
        b = rng.choice(names)
        data = bytearray(sources[b].encode())
        for _ in range(rng.randint(1, 4)):
            i = rng.randrange(len(data))
            data[i] = rng.choice([data[i] ^ (1 << rng.randrange(8)), rng.randrange(256)])
        add("byte-flip", b, bytes(data))
    for _ in range(30):
        b = rng.choice(names)
        lines = sources[b].splitlines()
        del lines[rng.randrange(len(lines))]
        add("delete-line", b, "\n".join(lines).encode())
    for _ in range(25):
        b = rng.choice(names)
        lines = sources[b].splitlines()
        i = rng.randrange(len(lines))
        lines.insert(rng.randrange(len(lines)), lines[i])
        add("duplicate-line", b, "\n".join(lines).encode())
    for _ in range(25):
        b = rng.choice(names)
        lines = sources[b].splitlines()
        idx = _assignments(lines)
        i, j = rng.sample(idx, 2)
        ki, vi = lines[i].split("=", 1)
        kj, vj = lines[j].split("=", 1)
        lines[i], lines[j] = f"{ki}={vj}", f"{kj}={vi}"
        add("swap-values", b, "\n".join(lines).encode())
    for _ in range(30):
        b = rng.choice(names)
        lines = sources[b].splitlines()
        i = rng.choice(_assignments(lines))
        k = lines[i].split("=", 1)[0]
        lines[i] = f"{k}= {rng.choice(TYPE_VALUES)}"
        add("type-change", b, "\n".join(lines).encode())
    for _ in range(35):
        b = rng.choice(names)
        text = sources[b]
        spans = _numbers(text)
        s, e = rng.choice(spans)
        h = rng.choice(HUGE)
        if not re.fullmatch(r"-?[\d.e+]+|nan|inf|-inf", h) or rng.random() < 0.4:
            h = f'"{h}"'
        add("huge-number", b, (text[:s] + h + text[e:]).encode())
    for _ in range(30):
        b = rng.choice(names)
        text = sources[b]
        spans = _numbers(text)
        s, e = rng.choice(spans)
        add("unit-mutation", b, (text[:s] + f'"{text[s:e]} {rng.choice(UNITS)}"' + text[e:]).encode())
    # injected code in every expression field (each string of each model, payloads in turn)
    k = 0
    for b in names:
        text = sources[b]
        for s, e in _strings(text):
            payload = INJECTIONS[k % len(INJECTIONS)].format(m=marker)
            k += 1
            add("injection", b, (text[:s] + payload + text[e:]).encode())
    for depth in (40, 200, 5000):
        b = rng.choice(names)
        add("deep-nesting", b, (sources[b] + f"\nx = {'[' * depth}{']' * depth}\n").encode())
        add("deep-nesting", b, (sources[b] + f"\ny = {'{ a = ' * depth}1{' }' * depth}\n").encode())
        add("deep-nesting", b, (sources[b] + "\n" + "z." * depth + "w = 1\n").encode())
    add("deep-nesting", "big-int", b"r = " + b"9" * 5000 + b"\n")
    for _ in range(20):
        b = rng.choice(names)
        text = sources[b]
        spans = _strings(text)
        s, e = rng.choice(spans)
        c = rng.choice(CONTROL)
        add("control-chars", b, (text[:s] + text[s:e] + c + text[e:]).encode())
    for b in names:
        add("bom", b, b"\xef\xbb\xbf" + sources[b].encode())
    junk = [b"", b"\n", b"\x00" * 100, b"\xff\xfe" + "name = 'x'".encode("utf-16-le"), bytes(range(256)),
            b"[[[[", b"name = ", b"\xc3\x28", b"= = =", b"[vectors]\n[vectors]\n", b"\x1b[2J\x1b[H",
            b"PK\x03\x04" + bytes(rng.randrange(256) for _ in range(200)), b"#!/bin/sh\nrm -rf /\n"]
    for j, d in enumerate(junk):
        add("junk", f"j{j}", d)
    for _ in range(6):
        b = rng.choice(names)
        data = sources[b].encode()
        add("junk", b, data[: rng.randrange(1, len(data))])
    return out


# Cases whose failure is another helper's area on this branch (found by running the corpus).
# cases known to fail, with the reason (none left: the huge-number and enormous-grid cases were fixed
# by the number and grid checks)
XFAIL: dict[str, str] = {}
# cases that take minutes: run only with FUZZ_HEAVY=1 (they count as failing otherwise)
SLOW: set[str] = set()
IS_ROOT = hasattr(os, "geteuid") and os.geteuid() == 0


def _check(status, err, out=""):
    """Exit 0/2/3; failure → exactly one `loopsolve: ` line; success → warning lines only."""
    lines = err.splitlines()
    problems = []
    if status not in (0, 2, 3):
        problems.append(f"exit status {status}")
    if "Traceback" in err:
        problems.append("traceback")
    if status in (2, 3) and (len(lines) != 1 or not lines[0].startswith("loopsolve: ")):
        problems.append(f"{len(lines)} stderr lines")
    if status == 0 and any(not ln.startswith("loopsolve: warning: ") and not ln.startswith("wrote ") for ln in lines):
        problems.append("stray stderr on success")
    if "\x1b" in err or "\x1b" in out or "\r" in err:
        problems.append("raw control character written")
    return problems


def _in_process(capsys, argv):
    try:
        status = main([str(a) for a in argv])
    except SystemExit as exc:  # argparse usage errors
        status = exc.code if isinstance(exc.code, int) else 2
    except BaseException as exc:  # noqa: BLE001 — a failure of the contract, reported below
        cap = capsys.readouterr()
        return 99, cap.out, cap.err + f"\nTraceback (escaped): {type(exc).__name__}: {exc}"
    cap = capsys.readouterr()
    return status, cap.out, cap.err


def _limits():  # pragma: no cover — runs in the child
    resource.setrlimit(resource.RLIMIT_AS, (3 << 30, 3 << 30))


def _subprocess(argv, env_extra=None):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in sys.path if p))
    env.pop("LOOPSOLVE_DEBUG", None)
    env.update(env_extra or {})
    try:
        proc = subprocess.run([sys.executable, "-m", "loopsolve.cli", *map(str, argv)], capture_output=True,
                              text=True, env=env, timeout=GUARD, preexec_fn=_limits, stdin=subprocess.DEVNULL)
    except subprocess.TimeoutExpired:
        return 124, "", f"hung for {GUARD:g} s"
    return proc.returncode, proc.stdout, proc.stderr


def _record(category, case, problems):
    RESULTS[category].append((case, not problems))
    if problems and case in XFAIL and not NO_XFAIL:
        pytest.xfail(XFAIL[case])
    assert not problems, f"{case}: {problems}"


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    d = tmp_path_factory.mktemp("fuzz")
    yield d
    assert not (d / MARKER_NAME).exists(), "injected code ran: the marker file exists"
    report = os.environ.get("FUZZ_REPORT")
    if report:
        summary = {cat: {"cases": len(v), "failed": sum(1 for _, ok in v if not ok),
                         "failing": [c for c, ok in v if not ok]} for cat, v in sorted(RESULTS.items())}
        summary["_loopsolve"] = ls.__file__
        with open(report, "w", encoding="utf-8") as f:
            json.dump(summary, f, indent=1)


_CASES = corpus(os.path.join("{workdir}", MARKER_NAME))
SUBPROCESS_SAMPLE = set(random.Random(SEED + 1).sample(range(len(_CASES)), 12))


def test_corpus_is_large_enough():
    cats = collections.Counter(c for c, _, _ in _CASES)
    assert len(_CASES) >= 300, len(_CASES)
    assert len(cats) >= 12, cats


@pytest.mark.parametrize("index", range(len(_CASES)), ids=[c[1] for c in _CASES])
def test_mutated_model(capsys, workdir, index):
    category, case, data = _CASES[index]
    data = data.replace(b"{workdir}", str(workdir).encode())
    path = workdir / f"{case}.toml"
    path.write_bytes(data)
    argv = ["solve", path]
    if index in SUBPROCESS_SAMPLE:
        status, out, err = _subprocess(argv)
    else:
        status, out, err = _in_process(capsys, argv)
    problems = _check(status, err, out)
    if category == "bom" and status != 0:
        problems.append("a BOM model does not load")
    if (workdir / MARKER_NAME).exists():
        problems.append("injected code ran")
    _record(category, case, problems)


def _hostile_paths(workdir):
    fifo = workdir / "model.fifo"
    if not fifo.exists():
        os.mkfifo(fifo)
    loop = workdir / "loop.toml"
    if not os.path.lexists(loop):
        os.symlink(loop, loop)
    unreadable = workdir / "unreadable.toml"
    unreadable.write_bytes(MODELS[0].read_bytes())
    os.chmod(unreadable, 0)
    big = workdir / "big.toml"
    with open(big, "wb") as f:
        f.truncate(50 << 20)  # sparse: 50 MB of NULs
    return {"fifo": fifo, "dev-zero": "/dev/zero", "dev-null": "/dev/null", "directory": workdir,
            "missing": workdir / "no-such.toml", "symlink-loop": loop, "unreadable": unreadable, "big-sparse": big,
            "empty-name": "", "dash": "-"}


HOSTILE_PATHS = ["fifo", "dev-zero", "dev-null", "directory", "missing", "symlink-loop", "unreadable", "big-sparse",
                 "empty-name", "dash"]


@pytest.mark.parametrize("name", HOSTILE_PATHS)
def test_hostile_path(workdir, name):
    path = _hostile_paths(workdir)[name]
    status, out, err = _subprocess(["solve", path])
    problems = _check(status, err, out)
    if status == 0 and not (name == "unreadable" and IS_ROOT):  # root reads a mode-000 file
        problems.append("a hostile path was accepted")
    _record("hostile-path", name, problems)


def test_fifo_at_the_cache_key(workdir, tmp_path):
    from loopsolve.symbolic.compiled import structure_key

    cache = tmp_path / "cache"
    cache.mkdir(mode=0o700)
    mech = ls.load(MODELS[0])
    os.mkfifo(cache / f"m_{structure_key(mech, mech.resolve_inputs(None))}.py")
    status, out, err = _subprocess(["solve", MODELS[0]], {"LOOPSOLVE_CACHE_DIR": str(cache)})
    problems = _check(status, err, out)
    if status != 0:
        problems.append(f"exit {status}")
    _record("hostile-path", "cache-fifo", problems)


THESIS = ls.models_dir() / "thesis_crank_rocker.toml"
COMMAND_LINES = {
    "at-word": ["solve", "{m}", "--at", "abc"],
    "at-dashdash-eq": ["solve", "{m}", "--at=--"],
    "at-dashdash": ["solve", "{m}", "--at", "--"],
    "at-neg": ["solve", "{m}", "--at", "-90"],
    "at-nan": ["solve", "{m}", "--at", "nan"],
    "at-inf": ["solve", "{m}", "--at", "inf"],
    "at-1e400": ["solve", "{m}", "--at", "1e400"],
    "at-empty": ["solve", "{m}", "--at", ""],
    "at-unit-wrong": ["solve", "{m}", "--at", "30kg"],
    "at-expr": ["solve", "{m}", "--at", "__import__('os').system('touch {marker}')"],
    "speed-word": ["solve", "{m}", "--speed", "fast"],
    "speed-nan": ["solve", "{m}", "--speed", "nan"],
    "mode-bad": ["solve", "{m}", "--mode", "++++"],
    "mode-esc": ["solve", "{m}", "--mode", "\x1b[31m"],
    "input-bad": ["solve", "{m}", "--input", "nosuch"],
    "format-bad": ["solve", "{m}", "--format", "xml"],
    "unknown-option": ["solve", "{m}", "--frobnicate"],
    "unknown-command": ["frobnicate", "{m}"],
    "no-args": [],
    "only-dashdash": ["--"],
    "solve-no-model": ["solve"],
    "sweep-missing-step": ["sweep", "{m}", "--from", "0", "--to", "10"],
    "sweep-step-zero": ["sweep", "{m}", "--from", "0", "--to", "10", "--step", "0", "-q"],
    "sweep-step-neg": ["sweep", "{m}", "--from", "0", "--to", "10", "--step", "-5", "-q"],
    "sweep-step-nan": ["sweep", "{m}", "--from", "0", "--to", "10", "--step", "nan", "-q"],
    "sweep-from-inf": ["sweep", "{m}", "--from", "-inf", "--to", "10", "--step", "1", "-q"],
    "sweep-step-tiny": ["sweep", "{m}", "--from", "0", "--to", "360", "--step", "1e-300", "-q"],
    "sweep-step-1e-9": ["sweep", "{m}", "--from", "0", "--to", "360", "--step", "1e-9", "-q"],
    "sweep-to-1e18": ["sweep", "{m}", "--from", "0", "--to", "1e18", "--step", "1", "-q"],
    "out-onto-model": ["solve", "{m}", "--at", "90", "-o", "{m}"],
    "sweep-out-onto-model": ["sweep", "{m}", "--from", "0", "--to", "90", "--step", "30", "-q", "-o", "{m}"],
    "latex-out-onto-model": ["latex", "{m}", "-o", "{m}"],
    "vectors-out-onto-model": ["vectors", "{m}", "-o", "{m}"],
    "out-missing-dir": ["solve", "{m}", "-o", "{w}/no/such/dir/out.txt"],
    "out-directory": ["solve", "{m}", "-o", "{w}"],
    "out-dev-full": ["solve", "{m}", "-o", "/dev/full"],
    "plot-bad-suffix": ["plot", "{m}", "-o", "{w}/x.jpg"],
    "modes-at-word": ["modes", "{m}", "--at", "x"],
    "info-input-bad": ["info", "{m}", "--input", "r1"],
    "latex-at-word": ["latex", "{m}", "--at", "zz"],
}
# run as subprocesses under a memory limit: on the landed code they allocate gigabytes or run long
HEAVY = {"sweep-step-tiny", "sweep-step-1e-9", "sweep-to-1e18", "no-args", "only-dashdash", "out-dev-full"}


@pytest.mark.parametrize("name", list(COMMAND_LINES))
def test_hostile_command_line(capsys, workdir, tmp_path, name):
    model = tmp_path / "m.toml"
    model.write_bytes(THESIS.read_bytes())
    marker = workdir / MARKER_NAME
    argv = [a.format(m=model, w=tmp_path, marker=marker) for a in COMMAND_LINES[name]]
    if name in SLOW and not os.environ.get("FUZZ_HEAVY"):
        _record("command-line", name, ["not run (slow on this branch; FUZZ_HEAVY=1 runs it)"])
    if name in HEAVY:
        status, out, err = _subprocess(argv)
    else:
        status, out, err = _in_process(capsys, argv)
    problems = _check(status, err, out)
    if model.read_bytes() != THESIS.read_bytes():
        problems.append("the model file was changed")
    if marker.exists():
        problems.append("injected code ran")
    _record("command-line", name, problems)


# ---------------------------------------------------------------- limits that must themselves be sane

@pytest.mark.parametrize("argv, option", [
    (["sweep", "thesis_crank_rocker.toml", "--from", "0", "--to", "10", "--step", "1", "--max-rows", "-5"],
     "--max-rows"),
    (["sweep", "thesis_crank_rocker.toml", "--from", "0", "--to", "10", "--step", "1", "--max-rows", "0"],
     "--max-rows"),
    (["simulate", "thesis_crank_rocker_dynamics.toml", "--duration", "0.1", "--max-steps", "-1"], "--max-steps"),
    (["simulate", "thesis_crank_rocker_dynamics.toml", "--duration", "0.1", "--max-steps", "0"], "--max-steps"),
])
def test_a_limit_below_one_is_refused_naming_it(argv, option, capsys):
    """``--max-rows -5`` read as 'more than -5 rows'; ``--max-steps -1`` integrated one step and warned."""
    argv = [argv[0], str(ls.models_dir() / argv[1])] + argv[2:]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and option in err[0] and "at least 1" in err[0]
