"""The numba engine (issue 21 item 1): the compiled fast lane gives the pure-Python tracer's rows.

* both engines agree to 1e-12 on every shipped model, in every assembly mode at the start,
  through limits (the fast lane hands the folds back to Python and resumes after them);
* the compiled rows match the four-bar half-angle closed form (loopsolve.kinematics.classic) and finite
  differences of the positions;
* the compiled template mirrors the Python grid, target and separation-ratio code it copies;
* the engine switch: errors, the environment variable, the CLI option;
* the numba disk cache keeps compiled.py's rules (a foreign or group-writable entry is not used).
"""

from __future__ import annotations

import hashlib
import importlib.util
import math
import os
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.kinematics import classic as C
from loopsolve.symbolic import compiled
from loopsolve.kinematics.numba_engine import jit, steps
from loopsolve.cli import main
from loopsolve.errors import LoopsolveWarning, MissingDependencyError
from loopsolve.kinematics.scalar_solver import Kernel, rho_2x3
from loopsolve.kinematics.modes import assembly_modes
from loopsolve.kinematics.sweep import Grid, default_range
from loopsolve.kinematics.continuation import Tracer

numba = pytest.importorskip("numba")

MODELS = sorted(Path(ls.models_dir()).glob("*.toml"))


@pytest.fixture
def spy(monkeypatch):
    """Counts the nodes the fast lane takes (appended to the path, or kept whole) and its calls."""
    calls = {"advance": 0, "nodes": 0}
    orig = steps.FastLane.advance

    def advance(self, tracer, path, *args):
        n0 = len(path.nodes)
        out = orig(self, tracer, path, *args)
        calls["advance"] += 1
        calls["nodes"] += len(path.nodes) - n0 + (len(self.whole[0]) if self.whole is not None else 0)
        return out

    monkeypatch.setattr(steps.FastLane, "advance", advance)
    return calls


def _close(a, b, tol=1e-12):
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    assert a.shape == b.shape
    same = (np.isnan(a) & np.isnan(b)) | (a == b)  # also equal infinities
    with np.errstate(invalid="ignore"):
        err = np.where(same, 0.0, np.abs(a - b) / (1.0 + np.abs(b)))
    assert not np.isnan(err).any()
    return float(err.max(initial=0.0))


def _agree(mech, start, stop, step, **kw):
    py = mech.sweep(start, stop, step, engine="python", progress=False, **kw)
    nb = mech.sweep(start, stop, step, engine="numba", progress=False, **kw)
    assert len(nb) == len(py) and nb.modes == py.modes and nb.mode == py.mode
    assert [e.kind for e in nb.events] == [e.kind for e in py.events]
    for e, f in zip(nb.events, py.events):
        assert abs(e.input - f.input) <= 1e-9 * (1 + abs(f.input))
    for q in ("z", "z1", "z2", "z3"):
        assert _close(getattr(nb, q), getattr(py, q)) <= 1e-12, q
    return py, nb


@pytest.mark.parametrize("path", MODELS, ids=lambda p: p.stem)
def test_engines_agree_on_every_shipped_model_every_mode_through_limits(path, spy):
    mech = ls.load(path)
    ck = mech.compile()
    kern = Kernel(ck)
    start, stop, _ = default_range(ck, 5.0)  # every shipped model has one: no model may drop out of this test
    angle = kern.angle_x
    step = 2.0 if angle else (stop - start) / 90
    modes = assembly_modes(mech, at=start, compiled=ck)
    assert modes
    swept = 0
    for m in modes:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", LoopsolveWarning)
            try:
                _agree(mech, start, stop, step, mode=m.signature, through_limits=True, compiled=ck)
            except ls.SingularPositionError:
                continue  # a start on a limit in this mode: both engines refuse alike (checked below)
        swept += 1
    # every shipped structure (1×1 and 2×2 blocks in any solve order) has a compiled lane (a double rocker
    # may never take a regular natural step: its range is arclength steps round its limits)
    assert jit.fast_lane(kern) is not None
    if path.stem.startswith(("thesis", "watt", "stephenson", "example1")) and swept:
        assert spy["nodes"] > 0  # the fast lane took the regular steps


@pytest.mark.parametrize("path", MODELS, ids=lambda p: p.stem)
def test_engines_agree_on_the_located_limits_of_every_shipped_model(path):
    """With the limit positions as rows (``limit_rows``): the rows at the located limits, their inputs
    and the events agree to round-off, in every mode, around the limits."""
    mech = ls.load(path)
    ck = mech.compile()
    start, stop, _ = default_range(ck, 5.0)
    step = 2.0 if Kernel(ck).angle_x else (stop - start) / 90
    for m in assembly_modes(mech, at=start, compiled=ck):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", LoopsolveWarning)
            try:
                py, nb = _agree(mech, start, stop, step, mode=m.signature, through_limits=True, limit_rows=True,
                                compiled=ck)
            except ls.SingularPositionError:
                continue
        for e, f in zip(nb.events, py.events):
            assert abs(e.input - f.input) <= 1e-12 * (1 + abs(f.input)), (e, f)


def _count_steps(monkeypatch):
    """The lanes the sweeps build, and the natural steps the Python tracer takes itself."""
    lanes, python_steps = [], [0]
    real = jit.fast_lane

    def lane(kern, **kw):
        fl = real(kern, **kw)
        lanes.append(fl)
        return fl

    monkeypatch.setattr(jit, "fast_lane", lane)
    natural = Tracer._natural_step

    def counted(self, *a, **kw):
        python_steps[0] += 1
        return natural(self, *a, **kw)

    monkeypatch.setattr(Tracer, "_natural_step", counted)
    return lanes, python_steps


@pytest.mark.parametrize("stem, blocks", [("example1_slider_crank", [1, 1]), ("watt1_sixbar", [2, 2]),
                                          ("stephenson3_sixbar", [2, 2]), ("whitworth_quick_return", [2, 1, 1]),
                                          ("thesis_crank_rocker_diagram", [2])])
def test_slider_cranks_six_bars_and_diagrams_take_compiled_steps(stem, blocks, monkeypatch):
    """engine="numba" on several blocks in solve order: the compiled lane takes (nearly) every natural
    step of a full turn — the Python tracer only the few that are not regular — and the rows are the
    Python engine's."""
    mech = ls.load(ls.models_dir() / f"{stem}.toml")
    ck = mech.compile()
    assert [len(c) for _, c in Kernel(ck).blocks] == blocks
    start, stop, _ = default_range(ck, 5.0)
    lanes, python_steps = _count_steps(monkeypatch)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LoopsolveWarning)
        nb = mech.sweep(start, stop, 1.0, engine="numba", method="tracked", progress=False, compiled=ck)
        lane_py = python_steps[0]
        py = mech.sweep(start, stop, 1.0, engine="python", method="tracked", progress=False, compiled=ck)
    assert len(lanes) == 1 and lanes[0] is not None
    assert lanes[0].steps >= len(nb) - 1 - lane_py  # every row but the start came from a step, most compiled
    assert lanes[0].steps >= 20 * max(lane_py, 1)
    assert python_steps[0] - lane_py >= len(py) - 1  # the Python engine took its steps itself
    assert _close(nb.z, py.z) <= 1e-12 and _close(nb.z1, py.z1) <= 1e-12


def test_the_python_and_numba_steps_are_one_source():
    """The two flavors of a generated step are the same text but for how the point reaches the model's
    functions (and the numba flavor's fused rates), for every shipped structure; the Python tracer runs
    the generated function and the numba module holds the same step."""
    from loopsolve.kinematics import stepgen

    def core(src):
        drop = ("zset(", "zt = bz", "orow", "rr[3]", "def natural_step(")
        return [ln for ln in src.splitlines()
                if not any(d in ln for d in drop) and not (ln.strip().startswith("bz[") and "= u" in ln)]

    seen = set()
    for path in MODELS:
        ck = ls.load(path).compile()
        kern = Kernel(ck)
        key = stepgen.structure(kern)
        if key in seen:
            continue
        seen.add(key)
        py_src, nb_src = stepgen.step_source(kern, "python"), stepgen.step_source(kern, "numba")
        assert core(py_src) == core(nb_src), path.stem
        assert nb_src in jit.numba_source(ck)
        tracer = Tracer(kern, Grid(0.0, 0.01, 0, 10, 0.0, 0.1, None), ls.StepControl(), land=True,
                        through_limits=False, x_start=0.0)
        assert tracer.step.__code__.co_filename.startswith("<loopsolve natural step")
    assert len(seen) >= 6  # 2×2; 1×1 + 1×1; 2×2 + 2×2; 2×2 + 1×1 + 1×1; 1×1 ×3; 1×1 + 2×2 ...


def test_rho_rows_is_the_singular_value_ratio():
    """The generated steps' separation ratio (one-sided Jacobi) against numpy's SVD, and rho_2x3 for n = 2."""
    from loopsolve.kinematics.stepgen import rho_rows

    rng = np.random.default_rng(11)
    for n in (1, 2, 3, 4, 5):
        for _ in range(60):
            a = rng.normal(size=(n, n + 1)) * rng.choice([1e-3, 1.0, 1e5])
            sv = np.linalg.svd(a, compute_uv=False)
            assert abs(rho_rows(tuple(a.ravel()), n) - sv[-1] / sv[0]) <= 1e-12
            if n == 2:
                assert abs(rho_rows(tuple(a.ravel()), 2) - rho_2x3(*a.ravel())) <= 1e-12
    a = rng.normal(size=(4, 5))
    a[3] = 2 * a[1] - a[0]  # rank 3: the ratio is 0 to round-off
    assert rho_rows(tuple(a.ravel()), 4) < 1e-14
    assert rho_rows((0.0,) * 12, 3) == 0.0 and rho_rows((1.0, math.inf, 0.0, 1.0, 2.0, 3.0), 2) == 0.0


def test_a_block_larger_than_2x2_has_no_generated_step_nor_lane():
    from types import SimpleNamespace

    from loopsolve.kinematics import stepgen

    big = SimpleNamespace(n=3, blocks=[((0, 1, 2), (0, 1, 2))], single2=False)
    assert not stepgen.supported(big) and jit.fast_lane(big) is None
    with pytest.raises(ValueError, match="larger than 2"):
        stepgen.step_source(big)
    assert stepgen.supported(SimpleNamespace(n=3, blocks=[((2,), (0,)), ((0, 1), (1, 2))], single2=False))
    # a fan of many four-bars: 2×2 blocks, but more unknowns than a generated step writes out
    fan = SimpleNamespace(n=2 * 40, blocks=[((2 * i, 2 * i + 1), (2 * i, 2 * i + 1)) for i in range(40)], single2=False)
    assert not stepgen.supported(fan) and jit.fast_lane(fan) is None


def test_fast_lane_hands_folds_back_and_resumes(spy):
    """A triple-rocker (4, 3, 3.5, 5) through both limits: natural steps in the middle, arclength
    steps round the folds, several hand-overs; the same rows and events."""
    mech = ls.fourbar(4, 3, 3.5, 5, theta2=90)
    ck = mech.compile()
    start, stop, through = default_range(ck, 1.0)
    py, nb = _agree(mech, start, stop, 1.0, through_limits=through, compiled=ck)
    kinds = [e.kind.value for e in nb.events]
    assert kinds.count("limit") >= 2 and "mode-change" in kinds
    assert spy["advance"] >= 2 and spy["nodes"] >= len(nb) // 2


def test_fast_lane_stops_at_a_limit_like_python():
    """(4, 3, 3.5, 5): the limit where coupler and rocker fold, |BO4| = r4 − r3: 360° − acos((4² + 3² − 1.5²)/(2·4·3))."""
    mech = ls.fourbar(4, 3, 3.5, 5)
    with pytest.warns(LoopsolveWarning):
        py, nb = _agree(mech, 300, 360, 1)
    lim = 360 - math.degrees(math.acos((4**2 + 3**2 - 1.5**2) / (2 * 4 * 3)))
    assert [e.kind.value for e in nb.events] == ["limit"]
    assert abs(nb.events[0].input - lim) < 1e-9


@pytest.mark.parametrize("seed", range(4))
def test_compiled_rows_match_the_closed_form_and_finite_differences(seed, spy):
    rng = np.random.default_rng(seed)
    while True:  # a Grashof crank-rocker: shortest link the crank, S + L < P + Q
        r1, r3, r4 = rng.uniform(40, 80, 3)
        r2 = rng.uniform(5, 0.9 * min(r1, r3, r4))
        s = sorted((r1, r2, r3, r4))
        if s[0] == r2 and s[0] + s[3] < s[1] + s[2] - 1:
            break
    mode = ("open", "crossed")[seed % 2]
    om, al = 3.0, -2.0
    sw = ls.fourbar(r1, r2, r3, r4, mode=mode, speed=om, accel=al).sweep(
        0, 359, 1, method="tracked", engine="numba", progress=False)
    assert len(sw) == 360 and sw.events == () and spy["nodes"] >= 300
    sgn = 1 if mode == "open" else -1
    t2 = np.radians(sw["theta2"])
    t3, t4 = C.fourbar_position(r1, r2, r3, r4, t2, sgn)
    w3, w4 = C.fourbar_velocity(r2, r3, r4, t2, t3, t4, om)
    a3, a4 = C.fourbar_acceleration(r2, r3, r4, t2, t3, t4, om, w3, w4, al)
    ck = sw.compiled
    i3, i4 = ck.index("theta3"), ck.index("theta4")

    def wrap(d):
        return (d + math.pi) % (2 * math.pi) - math.pi

    assert np.max(np.abs(wrap(sw.z[:, i3] - t3))) < 1e-10 and np.max(np.abs(wrap(sw.z[:, i4] - t4))) < 1e-10
    for got, ref in ((sw.z1[:, i3], w3), (sw.z1[:, i4], w4), (sw.z2[:, i3], a3), (sw.z2[:, i4], a4)):
        assert np.max(np.abs(got - ref)) < 1e-9 * (1 + np.max(np.abs(ref)))
    # velocities: central differences of the positions over the 1° grid (dθ/dt = ω dθ/dθ2)
    h = math.radians(1.0)
    u = np.unwrap(sw.z[:, i4])
    fd = (u[2:] - u[:-2]) / (2 * h) * om
    assert np.max(np.abs(fd - sw.z1[1:-1, i4])) < 1e-3 * (1 + np.max(np.abs(w4)))


def test_template_mirrors_the_python_grid_target_and_rho():
    """The compiled template's copies of Grid.value/next_after and rho_2x3, run as Python, are
    bit-for-bit the originals (the compiled module is compared in the agreement tests)."""
    rng = np.random.default_rng(3)
    for deg in (None, (12.5, 0.7), (-30.0, -2.5)):
        g = Grid(0.2, 0.0123 if deg is None else math.radians(deg[1]), -50, 400, -1.0, 9.0, deg)
        f = np.zeros(steps.F_SIZE)
        f[steps.F_G_START], f[steps.F_G_STEP] = g.start, g.step
        f[steps.F_G_LO], f[steps.F_G_HI] = g.lo, g.hi
        if deg is not None:
            f[steps.F_DEG0], f[steps.F_DEG1] = deg
        iv = np.zeros(steps.I_SIZE, dtype=np.int64)
        iv[steps.I_KMIN], iv[steps.I_KMAX], iv[steps.I_DEG] = g.kmin, g.kmax, 0 if deg is None else 1
        for k in range(-50, 401, 7):
            assert steps.grid_value(k, f, iv) == g.value(k)
        for x in rng.uniform(-2, 10, 200):
            for d in (1.0, -1.0):
                kn = g.next_after(float(x), d)
                assert steps.grid_next_after(float(x), d, f, iv) == (steps.NOGRID if kn is None else kn)
    for a in rng.normal(size=(200, 6)):
        assert steps.rho_2x3(*a) == rho_2x3(*a)


def test_compiled_grid_values_are_the_python_ones():
    """numba's math.radians/degrees/nextafter give the exact degree grid of Grid.value."""
    ck = ls.load(ls.models_dir() / "thesis_crank_rocker.toml").compile()
    mod = jit._numba_module(ck)
    f = np.zeros(steps.F_SIZE)
    f[steps.F_DEG0], f[steps.F_DEG1] = 0.0, 0.1
    iv = np.zeros(steps.I_SIZE, dtype=np.int64)
    iv[steps.I_DEG] = 1
    g = Grid(0.0, math.radians(0.1), -7200, 7200, 0, 0, (0.0, 0.1))
    assert all(mod.grid_value(k, f, iv) == g.value(k) for k in range(-7200, 7201, 13))


class TestEngineSwitch:
    def test_numba_without_numba_is_one_line_error(self, monkeypatch, capsys, tmp_path):
        real = importlib.util.find_spec
        monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "numba" else real(name, *a))
        monkeypatch.setitem(sys.modules, "numba", None)  # also when an earlier test imported it: not installed
        mech = ls.fourbar(60, 25, 70, 45)
        with pytest.raises(MissingDependencyError, match=r"needs numba: pip install 'loopsolve\[fast\]'") as ei:
            mech.sweep(0, 90, 10, engine="numba")
        assert isinstance(ei.value, ls.LoopsolveError) and "\n" not in str(ei.value)
        assert len(mech.sweep(0, 90, 10, engine="auto")) == 10  # auto: the Python tracer
        model = ls.models_dir() / "thesis_crank_rocker.toml"
        code = main(["sweep", str(model), "--from", "0", "--to", "90", "--step", "10", "--engine", "numba", "-q"])
        err = capsys.readouterr().err
        assert code == 2 and err.count("\n") == 1 and "numba" in err

    def test_unknown_engine_and_environment(self, monkeypatch, spy):
        mech = ls.fourbar(60, 25, 70, 45)
        with pytest.raises(ls.ModelError, match="engine='cuda'"):
            mech.sweep(0, 90, 10, engine="cuda")
        monkeypatch.setenv("LOOPSOLVE_ENGINE", "fortran")
        with pytest.raises(ls.ModelError, match="LOOPSOLVE_ENGINE='fortran'"):
            mech.sweep(0, 90, 10)
        monkeypatch.setenv("LOOPSOLVE_ENGINE", "numba")
        mech.sweep(0, 90, 10, method="tracked")
        assert spy["nodes"] > 0
        n = spy["nodes"]
        mech.sweep(0, 90, 10, engine="python")  # the argument wins over the environment
        assert spy["nodes"] == n

    def test_cli_engine_option(self, tmp_path, spy):
        model = ls.models_dir() / "thesis_crank_rocker.toml"
        outs = []
        for eng in ("python", "numba"):
            out = tmp_path / f"{eng}.csv"
            assert main(["sweep", str(model), "--from", "0", "--to", "360", "--step", "5", "--method", "tracked",
                         "--engine", eng, "--format", "csv", "-o", str(out), "-q"]) == 0
            outs.append(np.genfromtxt(out, delimiter=",", skip_header=1, usecols=range(1, 6)))
        assert spy["nodes"] > 0
        assert np.max(np.abs(outs[0] - outs[1])) <= 1e-9


class TestNumbaCache:
    def test_written_private_and_reused(self, tmp_path, monkeypatch):
        cache = tmp_path / "cache"
        monkeypatch.setenv("LOOPSOLVE_CACHE_DIR", str(cache))
        monkeypatch.setattr(jit, "_MEMO", {})
        monkeypatch.setattr(jit, "_BY_MODULE", {})
        ck = ls.fourbar(60, 25, 70, 45).compile()
        mod = jit._numba_module(ck)
        src = Path(mod.__file__)
        assert src.parent == cache and src.name.startswith("nb_")
        ls.sweep(ck.mechanism, 0, 30, 10, compiled=ck, engine="numba", method="tracked")
        pyc = cache / "__pycache__"
        entries = [e for e in os.listdir(pyc) if e.startswith(src.stem + ".")]
        assert any(e.endswith(".nbi") for e in entries)  # numba's machine code is cached next to it
        for p in [cache, pyc, src] + [pyc / e for e in entries]:
            assert not os.stat(p).st_mode & 0o022

    def test_foreign_or_open_cache_is_not_used(self, tmp_path, monkeypatch):
        cache = tmp_path / "cache"
        monkeypatch.setenv("LOOPSOLVE_CACHE_DIR", str(cache))
        ck = ls.fourbar(60, 25, 70, 45).compile()
        stem = "nb_" + hashlib.sha256(f"{numba.__version__}\n{jit.numba_source(ck)}".encode()).hexdigest()[:24]
        pyc = cache / "__pycache__"
        pyc.mkdir(parents=True)
        os.chmod(cache, 0o700)
        os.chmod(pyc, 0o700)
        (tmp_path / "evil").write_bytes(b"not numba")
        link = pyc / f"{stem}.run_steps-1.py311.nbi"
        os.symlink(tmp_path / "evil", link)
        with pytest.raises(compiled.Untrusted, match="not a regular file"):  # a planted symlink
            jit._check_pycache(cache, stem)
        link.unlink()
        os.chmod(pyc, 0o775)  # a __pycache__ others can write to: the whole sweep is compiled in memory
        monkeypatch.setattr(jit, "_MEMO", {})
        monkeypatch.setattr(jit, "_BY_MODULE", {})
        with pytest.warns(LoopsolveWarning, match="not using the compile cache"):
            mod = jit._numba_module(ck)
        assert mod.__file__.startswith("<loopsolve numba")
        assert not any(e.startswith(stem) for e in os.listdir(pyc))
        sw = ls.sweep(ck.mechanism, 0, 90, 30, compiled=ck, engine="numba", method="tracked")
        t3, t4 = C.fourbar_position(60, 25, 70, 45, np.radians(sw["theta2"]), 1)
        assert np.max(np.abs(np.radians(sw["theta4"]) - t4)) < 1e-10


class TestCompiledStart:
    """FastLane.start: the common case of start_position, compiled; None (Python decides) otherwise."""

    def lane(self, mech):
        ck = mech.compile()
        return ck, jit.fast_lane(Kernel(ck))

    def test_same_start_as_start_position(self):
        from loopsolve.kinematics.solve import start_position

        rng = np.random.default_rng(7)
        for mode in ("open", "crossed"):
            ck, lane = self.lane(ls.fourbar(60, 25, 70, 45, mode=mode))
            for x in rng.uniform(-math.pi, math.pi, 40):
                got = lane.start(float(x))
                ref = start_position(ck, float(x))
                assert got is not None
                assert np.max(np.abs(got[0] - ref[0])) <= 1e-13
                assert ck.signature(got[0]) == ck.signature(ref[0])

    def test_refuses_what_python_must_decide(self):
        ck, lane = self.lane(ls.fourbar(60, 25, 70, 45))
        assert lane.start(0.3, mode="crossed") is None  # a mode asked for: start_position's search
        on_line = {"theta3": 0.5, "theta4": 0.5}  # θ4 = θ3: a singular configuration names no mode
        assert lane.start(0.3, guess=on_line) is None
        # guesses of the other mode (θ3 ≈ θ4 + 60° is crossed): Newton may end in either; the mode
        # the guesses name is what the sweep must start in, whichever engine
        crossed = {"theta3": math.radians(110), "theta4": math.radians(50)}
        for x in np.linspace(-3, 3, 13):
            got = lane.start(float(x), guess=crossed)
            if got is not None:
                assert ck.signature(got[0]) == "+"
        mech = ck.mechanism
        py, nb = _agree(mech, 0, 350, 10, guess=crossed)
        assert set(nb.modes) == {"+"}


@pytest.mark.parametrize("derivatives", [1, 2, 3])
def test_compiled_rates_are_rates_v(derivatives):
    """FastLane.rates against loopsolve.kinematics.batch.rates_v, with a singular row (θ3 = θ4: NaN rates)."""
    from loopsolve.kinematics.batch import rates_v

    ck = ls.fourbar(60, 25, 70, 45).compile()
    lane = jit.fast_lane(Kernel(ck))
    rng = np.random.default_rng(11)
    Z = rng.uniform(-math.pi, math.pi, (3, 50))
    Z[2, 7] = Z[1, 7]  # Φ_q singular there
    rates = (2.0, -0.5, 0.25)
    got = lane.rates(Z, rates, derivatives)
    ref = rates_v(ck, Z.copy(), rates, derivatives=derivatives)
    for g, r in zip(got[:3], ref[:3]):
        assert np.array_equal(np.isnan(g), np.isnan(r))
        assert _close(g, r) <= 1e-12
    # a condition number beyond SINGULAR_COND is round-off (θ3 = θ4 gives det = 0 exactly or ~1e-17
    # depending on numpy's sine): both engines must call the same rows singular, and agree elsewhere
    from loopsolve.kinematics.batch import SINGULAR_COND
    singular = got[3] > SINGULAR_COND
    assert np.array_equal(singular, ref[3] > SINGULAR_COND) and singular[7]
    assert _close(got[3][~singular], ref[3][~singular]) <= 1e-12
    assert np.isnan(got[0][1:, 7]).all() and got[0][0, 7] == 2.0


def test_a_model_numba_cannot_compile_falls_back_to_python_with_one_warning(monkeypatch):
    from numba.core.errors import TypingError

    def broken(*args):
        raise TypingError("Failed in nopython mode pipeline (step: nopython frontend)")

    real = jit.fast_lane

    def lane(kern, **kw):
        fl = real(kern, **kw)
        fl.run = fl.start_run = fl.rates_run = broken
        return fl

    mech = ls.fourbar(60, 25, 70, 45)
    ref = mech.sweep(0, 350, 10, engine="python")
    monkeypatch.setattr(jit, "fast_lane", lane)
    with pytest.warns(LoopsolveWarning, match="numba could not compile") as rec:
        sw = mech.sweep(0, 350, 10, engine="numba")
    assert len([w for w in rec if "numba could not compile" in str(w.message)]) == 1
    assert np.array_equal(sw.z, ref.z) and np.array_equal(sw.z2, ref.z2)
