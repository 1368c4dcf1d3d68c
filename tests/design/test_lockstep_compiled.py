"""The compiled lockstep of a study chunk (issue 32, item 3) against the numpy lockstep.

``sweep_chunk(engine="numba")`` runs the continuation of a chunk's designs in the model's numba
module (:mod:`loopsolve.kinematics.numba_engine.lockstep_kernel`), ``engine="python"`` in numpy.
On a four-bar, an offset slider-crank (blocks 1×1), an engine slider-crank whose guesses are not
at the start, and a Stephenson III six-bar (two 2×2 blocks), each on a small box with ordinary,
limit and not-assemblable designs, the two give the same status, stop, nearest inputs, events,
mode, lockstep flags and rows (positions, rates, points) to round-off.
"""

from __future__ import annotations

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.design import lockstep

numba = pytest.importorskip("numba", reason="the compiled lockstep needs numba")


@pytest.fixture
def runs(monkeypatch):
    """Which engine ran each chunk's continuation: a list of True (compiled) / False (numpy)."""
    seen = []
    real = lockstep._run_compiled

    def spy(*a, **k):
        ok = real(*a, **k)
        seen.append(ok)
        return ok

    monkeypatch.setattr(lockstep, "_run_compiled", spy)
    return seen


def _agree(mech, names, values, runs, start=0, stop=360, step=5.0, derivatives=3):
    """Both engines on one chunk; asserts they agree and returns the compiled chunk."""
    a, _, _ = lockstep.sweep_chunk(mech, names, values, start, stop, step, derivatives=derivatives, engine="python")
    assert runs == []  # the numpy lockstep
    b, _, _ = lockstep.sweep_chunk(mech, names, values, start, stop, step, derivatives=derivatives, engine="numba")
    assert runs == [True]  # the compiled lockstep
    # it wrote the chunk's own rows in place, each design's together (not one value a cache line)
    assert np.moveaxis(b.rows, -1, 0).flags.c_contiguous and all(np.shares_memory(z, b.rows) for z in b.Z)
    assert b.status.tolist() == a.status.tolist()
    assert b.events.tolist() == a.events.tolist()
    assert b.nearest.tolist() == a.nearest.tolist()
    assert b.mode.tolist() == a.mode.tolist()
    assert b.lockstep.tolist() == a.lockstep.tolist()
    np.testing.assert_allclose(b.stop, a.stop, rtol=0, atol=1e-9, equal_nan=True)
    for za, zb in zip(a.Z, b.Z):
        assert np.array_equal(np.isnan(za), np.isnan(zb))
        np.testing.assert_allclose(zb, za, rtol=1e-11, atol=1e-11 * np.nanmax(np.abs(za)), equal_nan=True)
    if a.points is not None:
        assert np.array_equal(np.isnan(a.points), np.isnan(b.points))
        for k in range(derivatives + 1):
            scale = np.nanmax(np.abs(a.points[k]))
            np.testing.assert_allclose(b.points[k], a.points[k], rtol=1e-11, atol=1e-11 * scale, equal_nan=True)
    return b


@pytest.mark.filterwarnings("ignore:.*limit position")
def test_fourbar_chunk_compiled_equals_numpy(runs):
    rng = np.random.default_rng(32)
    # ordinary crank-rockers, cranks too long (limits), and designs not assemblable at 0°
    v = np.vstack([np.column_stack([rng.uniform(15, 25, 12), rng.uniform(60, 80, 12)]),
                   np.column_stack([rng.uniform(35, 45, 6), rng.uniform(55, 70, 6)]),
                   np.column_stack([rng.uniform(30, 40, 4), rng.uniform(25, 30, 4)])])
    b = _agree(ls.fourbar(60, 25, 70, 45), ("r2", "r3"), v, runs)
    st = set(b.status.tolist())
    assert {"ok", "limit", "not-assemblable"} <= st, st
    assert b.lockstep[b.status == "ok"].all()


@pytest.mark.filterwarnings("ignore:.*limit position")
def test_a_chunk_in_the_numpy_layout_gets_the_same_compiled_rows(runs, monkeypatch):
    """The kernel writes design-major arrays; a chunk laid out for the numpy loop (design last in memory)
    gets them copied back: the same values to the bit, the rows after a limit NaN."""
    mech = ls.fourbar(60, 25, 70, 45)
    v = np.array([[20.0, 70.0], [22.0, 65.0], [45.0, 55.0], [44.0, 58.0]])  # the last two stop at limits
    a, _, _ = lockstep.sweep_chunk(mech, ("r2", "r3"), v, 0, 360, 10, derivatives=2, engine="numba")

    class NumpyLayout(lockstep.Chunk):
        def __init__(self, *args, design_major=False, **kw):
            super().__init__(*args, **kw)

    monkeypatch.setattr(lockstep, "Chunk", NumpyLayout)
    b, _, _ = lockstep.sweep_chunk(mech, ("r2", "r3"), v, 0, 360, 10, derivatives=2, engine="numba")
    assert runs == [True, True]
    assert b.rows.flags.c_contiguous and not a.rows.flags.c_contiguous
    assert "limit" in a.status.tolist() and b.status.tolist() == a.status.tolist()
    for za, zb in zip(a.Z, b.Z):
        assert np.array_equal(za, zb, equal_nan=True)
    assert np.array_equal(a.points, b.points, equal_nan=True)


@pytest.mark.filterwarnings("ignore:.*limit position")
def test_offset_slider_crank_chunk_compiled_equals_numpy(runs):
    rng = np.random.default_rng(21)

    def box(n, *ranges):
        return np.column_stack([rng.uniform(*r, n) for r in ranges])

    v = np.vstack([box(8, (400, 560), (1400, 1700), (-200, 200)),
                   box(4, (1100, 1400), (500, 900), (-100, 100)),  # a limit before 90°
                   box(3, (900, 1000), (850, 900), (150, 250)),  # a limit after 180°
                   box(3, (400, 560), (400, 550), (600, 800))])  # not assemblable at 0°
    b = _agree(ls.load(ls.models_dir() / "prob2_offset_slider_crank.toml"), ("r2", "r3", "e"), v, runs,
               step=3.0)
    assert {"ok", "limit", "not-assemblable"} <= set(b.status.tolist())


@pytest.mark.filterwarnings("ignore:.*limit position")
def test_guesses_off_the_start_compiled_equals_numpy(runs):
    """The slider-crank's guesses are at θ2 = 0, the range starts at 40°: the path runs from the guesses to the
    start first (cranks longer than the rod have their limit on the way: started in the chunk, or swept alone)."""
    rng = np.random.default_rng(23)
    v = np.column_stack([np.concatenate([rng.uniform(400, 560, 6), rng.uniform(1100, 1400, 4)]),
                         np.concatenate([rng.uniform(1400, 1700, 6), rng.uniform(500, 900, 4)]),
                         rng.uniform(-100, 100, 10)])
    _agree(ls.load(ls.models_dir() / "prob2_offset_slider_crank.toml"), ("r2", "r3", "e"), v, runs, start=40,
           stop=400, derivatives=1)


@pytest.mark.filterwarnings("ignore:.*limit position")
def test_sixbar_chunk_compiled_equals_numpy(runs):
    rng = np.random.default_rng(22)

    def box(n, *ranges):
        return np.column_stack([rng.uniform(*r, n) for r in ranges])

    four = ((24, 26), (68, 72), (44, 46))
    v = np.vstack([box(8, *four, (55, 65), (65, 75)),
                   box(4, *four, (40, 46), (40, 46)),  # the output dyad does not reach C all the way round
                   box(3, (35, 42), (40, 50), (40, 50), (55, 65), (65, 75)),  # triple rockers
                   box(2, *four, (10, 12), (10, 12))])  # the output dyad reaches C nowhere
    b = _agree(ls.load(ls.models_dir() / "stephenson3_sixbar.toml"),
               ("r_crank", "r_coupler", "r_rocker", "r_link5", "r_link6"), v, runs, derivatives=2)
    assert "limit" in set(b.status.tolist())


def test_python_engine_and_small_auto_chunks_stay_numpy(runs, monkeypatch):
    from loopsolve.kinematics.numba_engine import jit

    monkeypatch.setattr(jit, "_AUTO_SEEN", [0])
    mech = ls.fourbar(60, 25, 70, 45)
    ch, _, _ = lockstep.sweep_chunk(mech, ("r2",), np.array([[20.0], [22.0]]), 0, 360, 90, engine="python")
    assert ch.lockstep.all() and runs == []
    ch, _, _ = lockstep.sweep_chunk(mech, ("r2",), np.array([[20.0], [22.0]]), 0, 360, 90, engine="auto")
    assert ch.lockstep.all() and runs == []  # 10 rows: not worth numba's import under "auto"


def test_auto_compiles_a_study_by_its_own_size_not_by_what_the_process_swept(monkeypatch):
    """``"auto"`` (the default) runs the continuation compiled from AUTO_CELLS designs × rows on in chunks of
    fewer than AUTO_CHUNK designs, and in numpy below it even after the process swept millions of rows (a small study does not pay numba's import and
    the kernel's first compile); ``LOOPSOLVE_ENGINE`` and ``engine=`` decide otherwise."""
    from loopsolve.kinematics.numba_engine import jit

    monkeypatch.delenv("LOOPSOLVE_ENGINE", raising=False)
    monkeypatch.setattr(jit, "_AUTO_SEEN", [10**9])
    ck = ls.fourbar(60, 25, 70, 45).compile()
    assert lockstep.lockstep_engine(ck, None, lockstep.AUTO_CELLS - 1) == "python"
    assert lockstep.lockstep_engine(ck, None, lockstep.AUTO_CELLS) == "numba"
    # in chunks of AUTO_CHUNK designs or more the numpy lockstep is as fast per design: no numba
    assert lockstep.lockstep_engine(ck, None, lockstep.AUTO_CELLS, lockstep.AUTO_CHUNK - 1) == "numba"
    assert lockstep.lockstep_engine(ck, None, 10 * lockstep.AUTO_CELLS, lockstep.AUTO_CHUNK) == "python"
    assert lockstep.lockstep_engine(ck, "numba", 10 * lockstep.AUTO_CELLS, 10 * lockstep.AUTO_CHUNK) == "numba"
    assert lockstep.lockstep_engine(ck, "numba", 10) == "numba"
    monkeypatch.setenv("LOOPSOLVE_ENGINE", "python")
    assert lockstep.lockstep_engine(ck, None, 10 * lockstep.AUTO_CELLS) == "python"


def test_a_study_decides_its_engine_once_by_its_cells_and_its_chunks(monkeypatch):
    """``ls.study`` asks the rule once, with its designs × rows and the chunk size it will use (given, or the
    default for this process), and hands the answer to every chunk."""
    seen, chunks = [], []
    rule = lockstep.lockstep_engine
    monkeypatch.setattr(lockstep, "lockstep_engine", lambda ck, engine, cells, designs=None:
                        seen.append((engine, cells, designs)) or rule(ck, engine, cells, designs))
    real = lockstep.sweep_chunk

    def spy(*a, **kw):
        chunks.append(kw.get("engine"))
        return real(*a, **kw)

    from loopsolve.design import studies

    monkeypatch.setattr(studies, "sweep_chunk", spy)
    mech = ls.fourbar(60, 25, 70, 45)
    ls.study(mech, {"r2": (20, 30)}, 0, 360, 90, lhs=6, chunk_size=3, progress=False)
    assert seen[0] == (None, 6 * 5, 3), seen
    assert len(chunks) == 2 and set(chunks) == {"python"}, chunks  # 30 cells: numpy, decided once for both
