"""Atlases: every entry's labels against the four-bar's closed forms, growth and Dask builds identical to one
build here (a killed worker's chunk recomputed), and atlases that must not be opened (other model, damaged,
foreign or writable by others)."""

from __future__ import annotations

import json
import math
import os
import threading
import time

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.design.atlas.build import build_atlas, open_atlas
from loopsolve.design.atlas.store import AtlasFileError
from loopsolve.kinematics.classic_limits import fourbar_input_range, grashof

pytest.importorskip("zarr", reason="atlases need zarr (the study extra)")

FOURBAR = ls.models_dir() / "fourbar_path_synthesis.toml"
VARY = {"r2": (0.4, 4.0), "r3": (1.6, 16.0), "r4": (1.6, 16.0), "rcx": (-8.0, 16.0), "rcy": (-12.0, 12.0)}
STEP = 4.0


@pytest.fixture(scope="module")
def fourbar():
    return ls.load(FOURBAR)


@pytest.fixture(scope="module")
def small(fourbar, tmp_path_factory):
    path = tmp_path_factory.mktemp("atlas") / "fb.zarr"
    return build_atlas(fourbar, point="P", vary=VARY, size=600, chunk=256, out=path, step_deg=STEP, progress=False)


def _wrap(a):
    return (a + math.pi) % (2 * math.pi) - math.pi


def test_every_entry_is_labelled_as_the_closed_forms_say(small):
    """Crank or not from Grashof's criterion; a rocker's swing within 4° of the closed-form limits of the input; the
    transmission angle at the traced rows from the law of cosines; the Grashof class and margin."""
    a = small
    r1 = 4.0
    h = math.radians(STEP)
    checked = {"crank": 0, "rocker": 0, "none": 0}
    for i in range(a.size):
        r2, r3, r4, rcx, rcy = a.params[i]
        rng = fourbar_input_range(r1, r2, r3, r4)
        cls = grashof(r1, r2, r3, r4).value
        if a.status[i] == 1:  # no assembly anywhere on the ring of inputs tried
            assert rng == [] or all(hi - lo < math.radians(30) for lo, hi in rng), i
            checked["none"] += 1
            continue
        if a.status[i] != 2:
            continue
        full = cls in ("crank-rocker", "double crank")
        assert bool(a.crank[i]) == full, (i, cls)
        srt = sorted((r1, r2, r3, r4))
        assert a.margin[i] == pytest.approx(srt[1] + srt[2] - srt[0] - srt[3], abs=1e-9)
        assert a.grashof(i) == cls
        lo, hi = a.x_range[i]
        if full:
            assert hi - lo == pytest.approx(2 * math.pi)
            checked["crank"] += 1
        else:
            # the interval of the closed form holding the traced start, its ends within one step outside the swing
            x0 = a.x_start[i]
            hit = [(p, q) for p, q in rng if (x0 - p) % (2 * math.pi) <= (q - p) + 1e-9]
            assert len(hit) == 1, (i, rng, x0)
            p, q = hit[0]
            shift = x0 - ((x0 - p) % (2 * math.pi)) - p  # the closed form's interval moved to the traced turn
            p, q = p + shift, q + shift
            assert p - 1e-9 <= lo <= p + h + 1e-9 and q - h - 1e-9 <= hi <= q + 1e-9, (i, (lo, hi), (p, q))
            checked["rocker"] += 1
        # transmission angle at the traced rows: mu = arccos((r3² + r4² − d²)/(2 r3 r4)), d the diagonal A–O4
        ks = np.arange(-200, 201)
        xs = a.x_start[i] + h * ks
        xs = xs[(xs >= lo - 1e-9) & (xs <= hi + 1e-9)]
        if full:
            xs = xs[xs < lo + 2 * math.pi - 1e-9]
        d2 = r1 * r1 + r2 * r2 - 2 * r1 * r2 * np.cos(xs)
        mu = np.degrees(np.arccos(np.clip((r3 * r3 + r4 * r4 - d2) / (2 * r3 * r4), -1, 1)))
        assert a.transmission[i][0] == pytest.approx(mu.min(), abs=1e-3)
        assert a.transmission[i][1] == pytest.approx(mu.max(), abs=1e-3)
    assert checked["crank"] > 50 and checked["rocker"] > 50 and checked["none"] > 20, checked


def test_stored_curve_and_placement_give_back_the_coupler_curve(small, fourbar):
    """centre + scale · R(angle) · stored curve = the coupler curve, computed here by circle intersection."""
    a = small
    i = int(np.flatnonzero(a.traced & a.crank)[3])
    r2, r3, r4, rcx, rcy = a.params[i]
    x, y, ang, s, _ = a.place[i]
    z = (a.curve[i][:, 0] + 1j * a.curve[i][:, 1]).astype(complex)
    back = x + 1j * y + s * np.exp(1j * ang) * z
    sign = a.mode[i][0]  # the sign of the dyad's determinant r3 r4 sin(theta3 - theta4)

    def coupler(t):
        A = r2 * np.exp(1j * t)
        O4 = 4.0
        dvec = O4 - A
        dd = np.abs(dvec)
        along = (r3 * r3 - r4 * r4 + dd * dd) / (2 * dd)
        hgt = np.sqrt(r3 * r3 - along * along)
        Ps = []
        for sg in (1, -1):
            B = A + dvec / dd * (along + 1j * sg * hgt)
            u = (B - A) / r3
            ok = np.sign(np.sin(np.angle(B - A) - np.angle(B - O4))) == sign
            Ps.append(np.where(ok, A + rcx * u + rcy * 1j * u, np.nan))
        return np.where(np.isfinite(Ps[0]), Ps[0], Ps[1])

    P = coupler(np.radians(np.arange(0, 360, 0.05)))
    gap = np.min(np.abs(back[:, None] - P[None, :]), axis=1)
    # the stored points lie on the chords of the traced polygon (rows every 4°): each is off the curve by at most
    # the polygon's largest sagitta (measured here on the closed form), plus float32 rounding of the stored curve
    x0 = a.x_start[i]
    rows = coupler(x0 + np.radians(STEP) * np.arange(91))
    mids = coupler(x0 + np.radians(STEP) * (np.arange(90) + 0.5))
    sagitta = np.max(np.abs(0.5 * (rows[:-1] + rows[1:]) - mids))
    assert 0 < np.max(gap) <= 1.5 * sagitta + 1e-6 * s


def test_grown_atlas_equals_the_atlas_built_at_once(fourbar, tmp_path):
    path = tmp_path / "g.zarr"
    build_atlas(fourbar, point="P", vary=VARY, size=300, chunk=128, out=path, step_deg=STEP, progress=False)
    grown = build_atlas(fourbar, point="P", vary=VARY, size=520, chunk=128, out=path, step_deg=STEP, progress=False)
    once = build_atlas(fourbar, point="P", vary=VARY, size=520, chunk=128, step_deg=STEP, progress=False)
    for k in once.arrays:
        assert np.array_equal(grown.arrays[k], once.arrays[k], equal_nan=True), k


def test_an_atlas_is_traced_in_numpy_whatever_its_process_traced_before(fourbar, monkeypatch):
    """Synthesis's ``auto`` engine turns compiled once its process has traced enough; an atlas chunk must not
    (its values would then depend on which process built it: one process, a cluster's fresh workers or a
    later growth). Here the process has "traced" 10¹² cells and the compiled module is off limits."""
    from loopsolve.design.atlas.trace import trace_chunk
    from loopsolve.design.synthesis import candidates
    from loopsolve.kinematics.numba_engine import jit

    monkeypatch.delenv("LOOPSOLVE_ENGINE", raising=False)
    monkeypatch.setattr(candidates, "_FOLLOW_SEEN", [10**12])
    monkeypatch.setattr(jit, "numba_module", lambda ck: pytest.fail("an atlas chunk asked for the compiled engine"))
    V = np.array([[1.0, 5.0, 5.0, 2.0, 1.0], [2.0, 8.0, 6.0, 0.0, 3.0]])
    out = trace_chunk(fourbar, "P", tuple(VARY), V, step_deg=STEP)
    assert out["status"].shape == (2,)


def test_an_interrupted_build_resumes(fourbar, tmp_path, monkeypatch):
    from loopsolve.design.atlas import build as atlas_mod

    path = tmp_path / "r.zarr"
    real = atlas_mod._chunk_task
    calls = []

    def dying(text, source, meta, c):
        if c == 2:
            raise KeyboardInterrupt
        calls.append(c)
        return real(text, source, meta, c)

    monkeypatch.setattr(atlas_mod, "_chunk_task", dying)
    with pytest.raises(KeyboardInterrupt):
        build_atlas(fourbar, point="P", vary=VARY, size=400, chunk=100, out=path, step_deg=STEP, progress=False)
    monkeypatch.setattr(atlas_mod, "_chunk_task", real)
    part = open_atlas(path)  # chunks 0 and 1 written, each with its count
    assert not part.complete and part.present.sum() == 200
    again = build_atlas(fourbar, point="P", vary=VARY, size=400, chunk=100, out=path, step_deg=STEP, progress=False)
    once = build_atlas(fourbar, point="P", vary=VARY, size=400, chunk=100, step_deg=STEP, progress=False)
    assert calls == [0, 1] and again.complete
    for k in once.arrays:
        assert np.array_equal(again.arrays[k], once.arrays[k], equal_nan=True), k


# ----------------------------------------------------------------------------- Dask


@pytest.fixture(scope="module")
def cluster():
    distributed = pytest.importorskip("distributed")
    cl = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=":0")
    client = distributed.Client(cl)
    yield client
    client.close()
    try:
        cl.close(timeout=60)
    except TimeoutError:  # a nanny still restarting a killed worker on a loaded machine: Dask's, not the product's
        pass


@pytest.fixture(scope="module")
def local_build(fourbar):
    return build_atlas(fourbar, point="P", vary=VARY, size=700, chunk=100, step_deg=STEP, progress=False)


def test_dask_build_equals_the_single_process_build(fourbar, cluster, local_build, tmp_path):
    remote = build_atlas(fourbar, point="P", vary=VARY, size=700, chunk=100, step_deg=STEP, client=cluster,
                         out=tmp_path / "d.zarr", progress=False)
    for k in local_build.arrays:
        assert np.array_equal(remote.arrays[k], local_build.arrays[k], equal_nan=True), k


def test_a_killed_workers_chunk_is_recomputed(fourbar, cluster, local_build, tmp_path):
    killed = {}

    def killer():
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and not killed:
            busy = {w: ts for w, ts in cluster.processing().items() if ts}
            if busy:
                addr = sorted(busy)[0]
                killed["addr"], killed["tasks"] = addr, list(busy[addr])
                try:
                    cluster.run(os._exit, 1, workers=[addr])
                except Exception:  # the worker dies before it answers
                    pass
                return
            time.sleep(0.01)

    t = threading.Thread(target=killer)
    t.start()
    again = build_atlas(fourbar, point="P", vary=VARY, size=700, chunk=100, step_deg=STEP, client=cluster,
                        progress=False)
    t.join()
    assert killed.get("tasks"), "no worker was building a chunk when the killer looked"
    for k in local_build.arrays:
        assert np.array_equal(again.arrays[k], local_build.arrays[k], equal_nan=True), k


# ----------------------------------------------------------------------------- atlases that must not be read


def test_an_atlas_of_another_model_is_refused(small):
    other = ls.load(ls.models_dir() / "watt2_sixbar_path.toml")
    with pytest.raises(AtlasFileError, match="not of 'Watt II six-bar path synthesis'"):
        open_atlas(small.path, other)
    # the same declaration with other numbers is the same model
    same = ls.load(FOURBAR).with_parameters(r1=10, rcx=0.3)
    assert open_atlas(small.path, same).size == small.size


def _copy(src, dst):
    import shutil

    shutil.copytree(src, dst)
    return dst


def test_a_damaged_chunk_is_an_error_not_wrong_numbers(small, tmp_path):
    path = _copy(small.path, tmp_path / "bad.zarr")
    chunk = path / "curve" / "c" / "1" / "0" / "0"
    data = bytearray(chunk.read_bytes())
    data[len(data) // 2] ^= 0xFF
    chunk.write_bytes(bytes(data))
    with pytest.raises(AtlasFileError, match="damaged"):
        open_atlas(path)


def test_metadata_that_is_not_an_atlas_is_refused(small, tmp_path):
    path = _copy(small.path, tmp_path / "meta.zarr")
    (path / "zarr.json").write_text("{not json")
    with pytest.raises(AtlasFileError, match="damaged"):
        open_atlas(path)
    path2 = _copy(small.path, tmp_path / "codec.zarr")
    meta = json.loads((path2 / "params" / "zarr.json").read_text())
    meta["codecs"].append({"name": "numcodecs.pickle", "configuration": {}})
    (path2 / "params" / "zarr.json").write_text(json.dumps(meta))
    with pytest.raises(AtlasFileError, match="not of this atlas' layout"):
        open_atlas(path2)


@pytest.mark.skipif(not hasattr(os, "getuid") or os.getuid() != 0, reason="changing a file's owner needs root")
def test_a_foreign_owned_atlas_is_refused(small, tmp_path):
    path = _copy(small.path, tmp_path / "foreign.zarr")
    os.chown(path / "efd" / "zarr.json", 4242, -1)
    with pytest.raises(AtlasFileError, match="belongs to another user"):
        open_atlas(path)


def test_an_atlas_others_can_write_is_refused(small, tmp_path):
    path = _copy(small.path, tmp_path / "open.zarr")
    os.chmod(path / "status", 0o777)
    with pytest.raises(AtlasFileError, match="writable by group or others"):
        open_atlas(path)


def test_a_symlinked_atlas_is_refused(small, tmp_path):
    link = tmp_path / "link.zarr"
    link.symlink_to(small.path)
    with pytest.raises(AtlasFileError, match="symlink"):
        open_atlas(link)


def test_build_refuses_too_large_and_another_atlas_in_place(fourbar, small, tmp_path):
    with pytest.raises(ls.ModelError, match="more than --max-size 100"):
        build_atlas(fourbar, point="P", vary=VARY, size=101, max_size=100, out=tmp_path / "x.zarr")
    assert not (tmp_path / "x.zarr").exists()
    with pytest.raises(AtlasFileError, match="holds another atlas"):
        build_atlas(fourbar, point="P", vary=dict(VARY, r2=(0.5, 4.0)), size=600, chunk=256, out=small.path,
                    step_deg=STEP)
    with pytest.raises(ls.ModelError, match="not a declared point"):
        build_atlas(fourbar, point="Q", vary=VARY, size=10)
    with pytest.raises(ls.ModelError, match="not a parameter"):
        build_atlas(fourbar, point="P", vary={"zz": (1, 2)}, size=10)


def test_zarr_2_is_refused_with_what_to_install(fourbar, tmp_path, monkeypatch):
    """An atlas is zarr format 3: with zarr 2 installed the build says which zarr is there and what to install,
    before any design is traced, and writes nothing."""
    import zarr

    from loopsolve.errors import MissingDependencyError

    monkeypatch.setattr(zarr, "__version__", "2.18.7")
    out = tmp_path / "a.zarr"
    with pytest.raises(MissingDependencyError, match=r"zarr 3 or newer \(this environment has zarr 2\.18\.7\).*zarr>=3"):
        build_atlas(fourbar, point="P", vary=VARY, size=64, out=out, progress=False)
    assert not out.exists()
