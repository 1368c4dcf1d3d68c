"""The editor's server (DESIGN.md, "Editor"; issue 34): what it refuses and how, what it writes.

Every test talks to a real ``loopsolve edit`` process over the loopback (started and stopped
here, see ``support/editor.py``): requests without the token, with another Host or Origin, with
oversized or hostile model text, save names that leave the working directory, a synthesis
cancelled midway — each refused or handled with a clear message, and the user's model (and
files) untouched. The page's numbers are the command line's for the same model.
"""

from __future__ import annotations

import json
import math
import os
import re
import shutil
import subprocess
import sys
import time
import tomllib

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.model.modelfile import dumps

from support.editor import EditorServer
from support.synthesis import candidate_curve, distance, traced

pytest.importorskip("starlette")
pytest.importorskip("uvicorn")

MODEL = ls.models_dir() / "thesis_crank_rocker_dynamics_diagram.toml"


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    d = tmp_path_factory.mktemp("edit-work")
    shutil.copy(MODEL, d / "crank_rocker.toml")
    return d


@pytest.fixture(scope="module")
def server(workdir):
    srv = EditorServer(workdir / "crank_rocker.toml", cwd=workdir)
    try:
        yield srv
    finally:
        srv.stop()


# ------------------------------------------------------------------------------ who may ask
def test_requests_without_the_token_are_refused(server):
    for method, path in (("GET", "/"), ("GET", "/api/model"), ("GET", "/api/state"), ("POST", "/api/edit"),
                         ("POST", "/api/save"), ("GET", "/api/export?format=svg")):
        status, body, _ = server.request(method, path, {} if method == "POST" else None, token=False)
        assert status == 403, (path, status)
        assert "token" in body["error"], body
    status, body, _ = server.get("/api/model?token=" + "x" * len(server.token), token=False)
    assert status == 403 and "token" in body["error"]
    status, body, _ = server.get("/api/model", token="wrong")
    assert status == 403
    # with it: the page, and the model file's dict
    status, page, headers = server.get(f"/?token={server.token}", token=False)
    assert status == 200 and b'id="loopsolve-input"' in page
    assert "default-src 'none'" in headers["content-security-policy"]
    assert headers["referrer-policy"] == "no-referrer" and headers["cache-control"] == "no-store"
    text = page.decode("utf-8")
    # nothing from the network: no src/href but the empty icon, no http(s) URL but the SVG namespace
    assert re.findall(r"""\b(?:src|href|srcset)\s*=\s*"([^"]*)\"""", text) == ["data:,"]
    assert set(re.findall(r"https?://[^\s\"')]+", text)) == {"http://www.w3.org/2000/svg"}
    assert "@import" not in text
    assert server.model() == tomllib.loads(MODEL.read_text())


def test_other_hosts_and_origins_are_refused(server):
    port = server.port
    status, body, _ = server.get("/api/model", host=f"evil.example:{port}")  # DNS rebinding: another name
    assert status == 403 and "Host" in body["error"]
    status, body, _ = server.get("/api/model", host="127.0.0.1")  # no port: not this server's URL
    assert status == 403
    status, body, _ = server.post("/api/edit", {"op": "name", "name": "pwned"},
                                  headers={"Origin": "http://evil.example"})
    assert status == 403 and "origin" in body["error"].lower()
    status, body, _ = server.get("/api/model", headers={"Sec-Fetch-Site": "cross-site"})
    assert status == 403
    status, body, _ = server.post("/api/edit", raw=b'{"op": "name", "name": "pwned"}', content_type="text/plain")
    assert status == 415 and "JSON" in body["error"]
    assert server.model()["name"] == tomllib.loads(MODEL.read_text())["name"]
    # the editor's own origins are fine
    for origin in (f"http://127.0.0.1:{port}", f"http://localhost:{port}"):
        status, body, _ = server.get("/api/model", headers={"Origin": origin})
        assert status == 200
    status, body, _ = server.get("/api/model", host=f"localhost:{port}")
    assert status == 200


def test_server_listens_on_the_loopback_only(server):
    import socket

    addrs = {a[4][0] for a in socket.getaddrinfo(socket.gethostname(), None, socket.AF_INET)} - {"127.0.0.1"}
    addrs = {a for a in addrs if not a.startswith("127.")}
    for addr in addrs:
        with socket.socket() as s:
            s.settimeout(2)
            assert s.connect_ex((addr, server.port)) != 0, addr


# ------------------------------------------------------------------------------ hostile input
def test_oversized_and_hostile_model_text_is_refused(server):
    before = server.model()
    status, body, _ = server.post("/api/edit", raw=b"x" * (2 << 20))
    assert status == 413 and "limit" in body["error"]
    big = "name = \"big\"\n" + "# " + "x" * 300_000 + "\n" + MODEL.read_text()
    status, body, _ = server.post("/api/edit", {"op": "replace", "toml": big})
    assert status == 422 and "too large" in body["error"], body
    hostile = {
        "nesting": "a = " + "[" * 500 + "]" * 500,
        "huge integer": MODEL.read_text().replace("O2 = { at = [0, 0] }", "O2 = { at = [1" + "0" * 400 + ", 0] }"),
        "code": MODEL.read_text().replace('torque = "-0.05N*m"', 'torque = "__import__(\'os\').system(\'true\')"'),
        "control character": MODEL.read_text().replace('name = "', 'name = "\\u001b[2J'),
        "not TOML": "this is not = = toml",
        "not a string": 42,
    }
    for what, text in hostile.items():
        status, body, _ = server.post("/api/edit", {"op": "replace", "toml": text})
        assert status == 422, (what, status, body)
        assert body["error"] and "\n" not in body["error"].strip()[:200], (what, body)
    status, body, _ = server.post("/api/edit", {"op": "nonsense"})
    assert status == 422 and "unknown edit" in body["error"]
    status, body, _ = server.post("/api/edit", raw=b"{not json")
    assert status == 422 and "JSON" in body["error"]
    status, body, _ = server.post("/api/edit", {"op": "move", "joint": "O4", "to": [1e300, 0], "at": 0})
    assert status == 422
    assert server.model() == before, "nothing of the user's model changed"


def test_mode_keeping_edit_is_refused_with_the_reason(server):
    before = server.model()
    # C dragged across the line B-O4 at the drawn pose (crank at 90°): the crossed assembly
    status, body, _ = server.post("/api/edit", {"op": "move", "joint": "C", "to": [30, -10], "at": 90, "mode": "-"})
    assert status == 422 and "assembly mode" in body["error"] and "ModeError" in body["error"], body
    assert server.model() == before


def test_time_limit_per_request(workdir):
    """A request that needs more work than LOOPSOLVE_EDIT_TIME_LIMIT is stopped with a clear message."""
    srv = EditorServer(workdir / "crank_rocker.toml", cwd=workdir, env={"LOOPSOLVE_EDIT_TIME_LIMIT": "0.05"})
    try:
        before = srv.model()
        six = (ls.models_dir() / "watt2_sixbar.toml").read_text()
        status, body, _ = srv.post("/api/edit", {"op": "replace", "toml": six})
        assert status == 422 and "WorkLimitError" in body["error"] and "0.05 s" in body["error"], body
        assert srv.model() == before
        status, body, _ = srv.get("/api/model")  # the server still answers
        assert status == 200
    finally:
        srv.stop()


# ------------------------------------------------------------------------------ saving
def test_save_names_cannot_leave_the_working_directory(server, workdir, tmp_path):
    outside = tmp_path / "outside"
    outside.mkdir()
    (workdir / "link_out").symlink_to(outside, target_is_directory=True)
    (workdir / "sub").mkdir()
    bad = ["../escape.toml", "/tmp/escape.toml", "sub/../../escape.toml", "link_out/escape.toml", "design.txt", " ",
           "a\x00b.toml", "nosuchdir/design.toml", "~/design.toml", "..\\escape.toml"]
    for name in bad:
        status, body, _ = server.post("/api/save", {"name": name})
        assert status == 422, (name, status, body)
        assert body["error"], name
    assert not list(outside.iterdir()) and not (workdir.parent / "escape.toml").exists()
    assert not (workdir / "design.txt").exists()
    status, body, _ = server.post("/api/save", {"name": "sub/design.toml"})
    assert status == 200, body
    saved = workdir / "sub" / "design.toml"
    assert tomllib.loads(saved.read_text()) == server.model()
    assert saved.read_text() == dumps(server.model())
    # never over an existing file without asking
    status, body, _ = server.post("/api/save", {"name": "sub/design.toml"})
    assert status == 409 and body["need"] == "confirm" and "exists" in body["error"]
    status, body, _ = server.post("/api/save", {"name": "sub/design.toml", "overwrite": True})
    assert status == 200


def test_save_to_the_model_file_asks_first(workdir):
    path = workdir / "asks.toml"
    shutil.copy(MODEL, path)
    original = path.read_bytes()
    srv = EditorServer(path, cwd=workdir)
    try:
        status, body, _ = srv.post("/api/edit", {"op": "name", "name": "Renamed four-bar"})
        assert status == 200, body
        status, body, _ = srv.post("/api/save", {})
        assert status == 409 and body["need"] == "confirm"
        assert path.read_bytes() == original
        status, body, _ = srv.post("/api/save", {"overwrite": True})
        assert status == 200
        data = tomllib.loads(path.read_text())
        assert data["name"] == "Renamed four-bar"
        assert {k: v for k, v in data.items() if k != "name"} == \
            {k: v for k, v in tomllib.loads(original.decode()).items() if k != "name"}
        assert not [p for p in workdir.iterdir() if p.name.startswith(".asks.toml.")], "no temporary file left"
    finally:
        srv.stop()


def test_new_model_asks_for_a_name(workdir):
    srv = EditorServer(None, cwd=workdir)
    try:
        status, body, _ = srv.post("/api/save", {})
        assert status == 409 and body["need"] == "name"
        status, body, _ = srv.post("/api/save", {"name": "fresh.toml"})
        assert status == 200
        mech = ls.load(workdir / "fresh.toml")
        assert round(mech.solve(90)["theta_rocker"], 3) == -99.278  # the template four-bar
    finally:
        srv.stop()


# ------------------------------------------------------------------------------ background synthesis
def test_synthesis_cancelled_midway(server):
    before = server.model()
    pts = [[40 + 20 * math.cos(t), 30 + 15 * math.sin(t)] for t in [0.3 * k for k in range(8)]]
    status, body, _ = server.post("/api/synthesis", {"method": "path", "params": {"points": pts, "runs": 5}})
    assert status == 200 and body["state"] == "running", body
    job = body["id"]
    status, again, _ = server.post("/api/synthesis", {"method": "path", "params": {"points": pts, "runs": 1}})
    assert status == 422 and "running" in again["error"]
    deadline = time.monotonic() + 600
    while time.monotonic() < deadline:  # wait until the first run is under way
        st = server.get(f"/api/synthesis/{job}")[1]
        if "run 1" in st["message"]:
            break
        time.sleep(0.3)
    status, st, _ = server.post(f"/api/synthesis/{job}/cancel")
    assert status == 200 and st["state"] == "cancelled", st
    assert server.get(f"/api/synthesis/{job}")[1]["state"] == "cancelled"
    assert server.model() == before
    status, body, _ = server.post("/api/synthesis", {"method": "nope", "params": {}})
    assert status == 422 and "unknown synthesis method" in body["error"]
    status, body, _ = server.post("/api/synthesis", {"method": "path", "params": {"points": [[0, 0]]}})
    assert status == 200
    final = server.wait_job(body["id"])
    assert final["state"] == "failed" and "3 to" in final["error"]


def test_shape_synthesis_cancelled_while_the_atlas_builds_then_certified(workdir, tmp_path):
    """The page's default method: the first use builds the default atlas (here a small one in a fresh cache) and
    says so in the job's progress; cancelling stops it; the next run gives certified four-bars whose coupler
    curves (solved here from each candidate's model) pass through the drawn curve of a known four-bar."""
    pytest.importorskip("zarr", reason="atlases need zarr (the study extra)")
    srv = EditorServer(workdir / "crank_rocker.toml", cwd=workdir,
                       env={"LOOPSOLVE_CACHE_DIR": str(tmp_path / "cache"), "LOOPSOLVE_ATLAS_SIZE": "4096"})
    try:
        before, on_disk = srv.model(), (workdir / "crank_rocker.toml").read_text()
        targets = traced(0.8, 3.0, 3.2, 1.5, -1.0, stop=351, turn=120, scale=25.0, shift=(60.0, 40.0))
        params = {"points": targets.tolist(), "top": 2}
        status, body, _ = srv.post("/api/synthesis", {"method": "shape", "params": params})
        assert status == 200 and body["state"] == "running", body
        job = body["id"]
        messages = []
        while True:
            st = srv.get(f"/api/synthesis/{job}")[1]
            messages.append(st["message"])
            if "building the default four-bar atlas" in st["message"] or st["state"] != "running":
                break
            time.sleep(0.1)
        assert st["state"] == "running", messages
        status, st, _ = srv.post(f"/api/synthesis/{job}/cancel")
        assert status == 200 and st["state"] == "cancelled", st
        assert srv.model() == before
        status, body, _ = srv.post("/api/synthesis", {"method": "shape", "params": params})
        assert status == 200, body
        final = srv.wait_job(body["id"])
        assert final["state"] == "done", final
        res = final["result"]
        assert res["task"] == "shape" and res["closed"] is True and 1 <= len(res["candidates"]) <= 2
        size = float(np.ptp(targets, axis=0).max())
        for c in res["candidates"]:
            assert c["certificate"]["defects"] == []
            dist = distance(targets, candidate_curve(c["toml"], True))
            assert dist.max() < 5e-3 * size, (dist.max(), c["max"])  # half a percent of the drawing: on top of it
            assert c["max"] == pytest.approx(dist.max(), abs=1e-3 * size)  # the page's number is the measured one
        # the page's Use: the candidate becomes the edited mechanism
        status, body, _ = srv.post("/api/edit", {"op": "replace", "toml": res["candidates"][0]["toml"],
                                                 "source": "synthesis candidate 1"})
        assert status == 200, body
        assert set(srv.model()["joints"]) == {"O2", "A", "B", "O4", "P"}
        assert (workdir / "crank_rocker.toml").read_text() == on_disk  # nothing saved behind the user
    finally:
        srv.stop()


# ------------------------------------------------------------------------------ numbers
def _cli_json(*args):
    proc = subprocess.run([sys.executable, "-m", "loopsolve.cli", *args, "--format", "json"], capture_output=True,
                          text=True)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


def test_page_numbers_equal_the_cli(server):
    status, body, _ = server.get("/api/state")
    assert status == 200
    A = body["analysis"]
    s = A["settings"]
    assert (s["from"], s["to"], s["step"]) == (0, 360, 2)
    rows = _cli_json("sweep", str(MODEL), "--from", "0", "--to", "360", "--step", "2")["rows"]
    page = A["page"]
    assert page["rows"] == len(rows)
    series = {x["name"]: x for x in page["series"]}
    for r in range(0, len(rows), 7):
        assert page["input"]["x"][r] == pytest.approx(rows[r]["theta_crank"], abs=1e-9)
        for name, ser in series.items():
            for k, suffix in enumerate(("", "_vel", "_acc")):
                assert ser["q"][k][r] == pytest.approx(rows[r][name + suffix], rel=1e-9, abs=1e-9), (r, name, k)
    frows = _cli_json("forces", str(MODEL), "--from", "0", "--to", "360", "--step", "2")["rows"]
    cols = A["forces"]["columns"]
    for r in range(0, len(frows), 7):
        for key in ("input_torque", "F_O2_x", "F_O2_y", "F_C_x", "F_C_y", "shaking_moment", "kinetic_energy"):
            assert cols[key][r] == pytest.approx(frows[r][key], rel=1e-9, abs=1e-12), (r, key)
    extra = {e["name"]: e["q"][0] for e in page["extra"]}
    for r in range(0, len(frows), 11):
        assert extra["input_torque"][r] == pytest.approx(frows[r]["input_torque"], rel=1e-9, abs=1e-12)
        assert extra["|F_B|"][r] == pytest.approx(math.hypot(frows[r]["F_B_x"], frows[r]["F_B_y"]), rel=1e-9)
        mu = abs((rows[r]["theta_coupler"] - rows[r]["theta_rocker"] + 180) % 360 - 180)
        assert extra["mu_coupler/rocker"][r] == pytest.approx(mu, abs=1e-9)
    fb = A["info"]["fourbars"][0]
    assert fb["grashof"] == "crank-rocker"


def test_undo_redo_and_exports(server):
    before = server.model()
    status, body, _ = server.post("/api/edit", {"op": "name", "name": "Undo me"})
    assert status == 200 and body["model"]["name"] == "Undo me"
    status, body, _ = server.post("/api/undo")
    assert status == 200 and body["moved"] and server.model() == before
    status, body, _ = server.post("/api/redo")
    assert server.model()["name"] == "Undo me"
    server.post("/api/undo")
    for fmt, magic in (("svg", b"<svg"), ("png", b"\x89PNG"), ("dxf", b"SECTION"), ("tex", b"\\documentclass")):
        status, content, headers = server.get(f"/api/export?format={fmt}&at=30")
        assert status == 200, (fmt, content)
        content = content if isinstance(content, bytes) else json.dumps(content).encode()
        assert magic in content[:4000], fmt
        assert "attachment" in headers["content-disposition"]
    status, body, _ = server.get("/api/export?format=exe")
    assert status == 422 and "format" in body["error"]


def test_edit_without_the_extra_is_one_line(tmp_path):
    code = ("import sys; sys.modules['starlette'] = None; from loopsolve.cli import main; "
            "sys.exit(main(['edit', '--no-browser']))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "MissingDependencyError" in lines[0] and "loopsolve[edit]" in lines[0], proc.stderr
    assert proc.stdout == ""


def test_share_link_and_port_arguments(workdir):
    """``loopsolve edit LINK`` opens a share link's design; ``--port`` takes that port (or says why not)."""
    import base64
    import socket

    text = (ls.models_dir() / "fourbar_coupler_curve.toml").read_text()
    code = base64.urlsafe_b64encode(text.encode()).decode().rstrip("=")
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    srv = EditorServer(f"http://127.0.0.1:1/?token=abc#model={code}", cwd=workdir, args=("--port", str(port)))
    try:
        assert srv.port == port
        assert srv.model() == tomllib.loads(text)
        status, body, _ = srv.post("/api/save", {})
        assert status == 409 and body["need"] == "name"  # a shared design has no file yet
        busy = subprocess.run([sys.executable, "-m", "loopsolve.cli", "edit", "--no-browser", "--port", str(port)],
                              capture_output=True, text=True, cwd=workdir, timeout=120)
        assert busy.returncode == 2 and len(busy.stderr.strip().splitlines()) == 1
        assert f"--port {port}" in busy.stderr and busy.stdout == ""
    finally:
        srv.stop()
    bad = subprocess.run([sys.executable, "-m", "loopsolve.cli", "edit", "--no-browser", "x#model=%%%"],
                         capture_output=True, text=True, cwd=workdir, timeout=120)
    assert bad.returncode == 2 and "share link" in bad.stderr
