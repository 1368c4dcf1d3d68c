"""A ``loopsolve edit`` server started and stopped by the tests (a real process; no mocks), and a
small HTTP client that can send any Host, Origin or body (http.client)."""

from __future__ import annotations

import http.client
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from urllib.parse import urlsplit


class EditorServer:
    """``python -m loopsolve.cli edit [MODEL] --no-browser`` in ``cwd``; ``url``, ``port``, ``token``."""

    def __init__(self, model=None, *, cwd, env=None, args=()):
        cmd = [sys.executable, "-m", "loopsolve.cli", "edit"] + ([os.fspath(model)] if model else []) + \
            ["--no-browser", *args]
        self.proc = subprocess.Popen(cmd, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                     env=dict(os.environ, **(env or {})))
        self.url = self.proc.stdout.readline().strip()
        if not self.url.startswith("http://127.0.0.1:"):
            err = self.proc.communicate(timeout=60)[1]
            raise RuntimeError(f"loopsolve edit did not start: {self.url!r} {err}")
        parts = urlsplit(self.url)
        self.port = parts.port
        self.token = parts.query.split("token=", 1)[1]
        self.cwd = Path(cwd)

    def request(self, method, path, body=None, *, token=True, host=None, headers=None, raw=None,
                content_type="application/json", timeout=900):
        conn = http.client.HTTPConnection("127.0.0.1", self.port, timeout=timeout)
        hdrs = {"Host": host or f"127.0.0.1:{self.port}"}
        if token is True:
            hdrs["X-Loopsolve-Token"] = self.token
        elif isinstance(token, str):
            hdrs["X-Loopsolve-Token"] = token
        data = raw
        if body is not None:
            data = json.dumps(body).encode("utf-8")
        if data is not None and content_type:
            hdrs["Content-Type"] = content_type
        hdrs.update(headers or {})
        conn.request(method, path, body=data, headers=hdrs)
        resp = conn.getresponse()
        payload = resp.read()
        conn.close()
        try:
            parsed = json.loads(payload)
        except ValueError:
            parsed = payload
        return resp.status, parsed, dict(resp.getheaders())

    def get(self, path, **kw):
        return self.request("GET", path, **kw)

    def post(self, path, body=None, **kw):
        return self.request("POST", path, {} if body is None and "raw" not in kw else body, **kw)

    def model(self) -> dict:
        status, body, _ = self.get(f"/api/model?token={self.token}", token=False)
        assert status == 200, body
        return body

    def wait_job(self, job_id, *, until=("done", "failed", "cancelled"), pause=0.5):
        while True:
            status, body, _ = self.get(f"/api/synthesis/{job_id}")
            assert status == 200, body
            if body["state"] in until:
                return body
            time.sleep(pause)

    def stop(self):
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(30)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(10)
        self.proc.stdout.close()
        self.proc.stderr.close()
