"""The editor's web application: Starlette on uvicorn, on the loopback only, one session token.

Why Starlette and uvicorn: both are small, widely used and actively maintained (the ASGI
reference stack under FastAPI), pure Python with few dependencies (anyio; click and h11), and
give what the security rules need without writing an HTTP server: a raw ASGI middleware sees
every request before any route (Host, Origin, the token, the client address, the body size),
responses carry our headers, and uvicorn serves a socket we bind ourselves to 127.0.0.1 on a
random port, with its access log off (the token is in the page's URL). The standard library's
``http.server`` was the alternative: it is documented as "not recommended for production" and
only implements basic security checks, serves one request at a time unless threaded, and
would need the request parsing, limits and routing written here by hand.

Every request must (or it is refused with 403 and a one-line reason):

* come from a loopback address, with ``Host`` naming this server (``127.0.0.1:PORT`` or
  ``localhost:PORT``: a DNS-rebinding page has another host name), and no ``Origin`` or one of
  those two origins, and not be marked ``Sec-Fetch-Site: cross-site``;
* carry the session token: ``?token=...`` in the URL (the page, ``GET /api/model``, exports)
  or the ``X-Loopsolve-Token`` header (the page's API calls); compared in constant time.

Bodies are JSON (``Content-Type: application/json``, so no other site can send one without a
CORS preflight, which is never granted) of at most :data:`MAX_BODY` bytes. Model text goes
through :func:`loopsolve.model.modelfile.loads`; work runs in :mod:`loopsolve.editor.jobs`
processes with a time limit. Responses forbid caching, framing, sniffing and referrers, and
the page's content security policy allows only its own inline code (a per-page nonce) and
requests to this server.
"""

from __future__ import annotations

import hmac
import ipaddress
import json
import os
import secrets
import socket
from pathlib import Path
from typing import Any
from urllib.parse import parse_qs

from starlette.applications import Starlette
from starlette.concurrency import run_in_threadpool
from starlette.requests import Request
from starlette.responses import HTMLResponse, JSONResponse, Response
from starlette.routing import Route

from ..errors import LoopsolveError, ModelError
from .document import Document, SaveConflict
from .jobs import Job, Worker, WorkerError, WorkLimitError

__all__ = ["EditorApp", "create_app", "serve", "MAX_BODY"]

#: the largest request body (bytes): a model of MAX_MODEL_TEXT characters as JSON, with room
MAX_BODY = 1 << 20

_SECURITY_HEADERS = [
    (b"cache-control", b"no-store"),
    (b"x-content-type-options", b"nosniff"),
    (b"x-frame-options", b"DENY"),
    (b"referrer-policy", b"no-referrer"),
    (b"cross-origin-opener-policy", b"same-origin"),
    (b"cross-origin-resource-policy", b"same-origin"),
]


def _plain(status: int, text: str):
    body = json.dumps({"error": text}).encode("utf-8")
    headers = [(b"content-type", b"application/json"), (b"content-length", str(len(body)).encode())]
    return status, headers + _SECURITY_HEADERS, body


class _Guard:
    """ASGI middleware: loopback, Host, Origin, token and body size, before any route runs."""

    def __init__(self, app, editor: "EditorApp"):
        self.app = app
        self.editor = editor

    async def _refuse(self, send, status: int, text: str) -> None:
        status, headers, body = _plain(status, text)
        await send({"type": "http.response.start", "status": status, "headers": headers})
        await send({"type": "http.response.body", "body": body})

    async def __call__(self, scope, receive, send):
        if scope["type"] == "lifespan":
            return await self.app(scope, receive, send)
        if scope["type"] != "http":  # no websockets
            return
        ed = self.editor
        headers = {}
        for k, v in scope.get("headers", []):
            headers.setdefault(k.decode("latin-1").lower(), v.decode("latin-1"))
        client = (scope.get("client") or ("", 0))[0]
        try:
            loop = ipaddress.ip_address(client).is_loopback
        except ValueError:
            loop = False
        if not loop:
            return await self._refuse(send, 403, f"refused: the editor answers the loopback only, not {client!r}")
        host = headers.get("host", "")
        if host not in ed.hosts:
            return await self._refuse(send, 403, f"refused: the Host header {host!r} is not this editor "
                                      f"({' or '.join(sorted(ed.hosts))}); open the URL loopsolve printed")
        origin = headers.get("origin")
        if origin is not None and origin not in ed.origins:
            return await self._refuse(send, 403, f"refused: requests from the origin {origin!r} are not accepted "
                                      "(only the editor's own page may call it)")
        if headers.get("sec-fetch-site") == "cross-site":
            return await self._refuse(send, 403, "refused: a cross-site request")
        token = headers.get("x-loopsolve-token")
        if token is None:
            q = parse_qs(scope.get("query_string", b"").decode("latin-1"))
            token = (q.get("token") or [None])[0]
        if token is None or not hmac.compare_digest(token.encode("utf-8", "replace"), ed.token.encode()):
            return await self._refuse(send, 403, "refused: missing or wrong session token (open the URL that "
                                      "`loopsolve edit` printed, with its ?token=...)")
        if scope["method"] not in ("GET", "HEAD", "POST"):
            return await self._refuse(send, 405, f"method {scope['method']} is not used by the editor")
        if scope["method"] == "POST":
            ctype = headers.get("content-type", "").split(";")[0].strip().lower()
            if ctype != "application/json":
                return await self._refuse(send, 415, "refused: the editor's API takes JSON (Content-Type: "
                                          "application/json)")
            try:
                length = int(headers.get("content-length", "0"))
            except ValueError:
                length = MAX_BODY + 1
            if length > MAX_BODY:
                return await self._refuse(send, 413, f"refused: the request body is {length} bytes, more than the "
                                          f"editor's limit {MAX_BODY}")
            total = 0

            async def capped():
                nonlocal total
                msg = await receive()
                if msg["type"] == "http.request":
                    total += len(msg.get("body", b""))
                    if total > MAX_BODY:
                        raise _TooLarge()
                return msg

            try:
                return await self.app(scope, capped, _with_headers(send))
            except _TooLarge:
                return await self._refuse(send, 413, f"refused: the request body is more than {MAX_BODY} bytes")
        return await self.app(scope, receive, _with_headers(send))


class _TooLarge(Exception):
    pass


def _with_headers(send):
    async def wrapped(message):
        if message["type"] == "http.response.start":
            present = {k.lower() for k, _ in message.get("headers", [])}
            message = dict(message)
            message["headers"] = list(message.get("headers", [])) + [h for h in _SECURITY_HEADERS if h[0] not in present]
        await send(message)
    return wrapped


class EditorApp:
    """The state of one editing session: the document, the worker, the synthesis jobs, the token."""

    def __init__(self, data, path: Path | None, *, port: int, token: str | None = None, base: Path | None = None):
        self.doc = Document(data, path, base=base)
        self.token = token or secrets.token_urlsafe(24)
        self.port = port
        self.hosts = {f"127.0.0.1:{port}", f"localhost:{port}"}
        self.origins = {f"http://127.0.0.1:{port}", f"http://localhost:{port}"}
        self.worker: Worker | None = None
        self.jobs: dict[str, Job] = {}

    def start(self) -> None:
        if self.worker is None:
            self.worker = Worker()

    def close(self) -> None:
        for job in self.jobs.values():
            job.cancel()
        if self.worker is not None:
            self.worker.close()
            self.worker = None

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}/?token={self.token}"

    async def call(self, name: str, *args) -> Any:
        self.start()
        return await run_in_threadpool(self.worker.call, name, *args)

    async def payload(self, analysis: dict | None = None) -> dict:
        if analysis is None:
            analysis = await self.call("analyze", self.doc.data, self.doc.settings, self._source())
            self.doc.analysis = analysis
        return {"document": self.doc.state(), "analysis": analysis, "model": self.doc.data}

    def _source(self) -> str:
        return os.fspath(self.doc.path) if self.doc.path else "<new model>"


def _error(exc: Exception) -> JSONResponse:
    if isinstance(exc, SaveConflict):
        return JSONResponse({"error": str(exc), "need": exc.need, "target": exc.target}, status_code=409)
    if isinstance(exc, WorkLimitError):
        return JSONResponse({"error": f"WorkLimitError: {exc}"}, status_code=422)
    if isinstance(exc, WorkerError):
        return JSONResponse({"error": f"{exc.kind}: {exc}"}, status_code=exc.status)
    return JSONResponse({"error": f"{type(exc).__name__}: {exc}"}, status_code=422)


async def _json(request: Request) -> dict:
    try:
        body = await request.json()
    except (ValueError, UnicodeDecodeError):
        raise ModelError("the request body is not JSON") from None
    if not isinstance(body, dict):
        raise ModelError("the request body must be a JSON object")
    return body


def create_app(editor: EditorApp) -> Starlette:
    """The Starlette application of one editing session, behind :class:`_Guard`."""
    from .page import editor_page

    async def page(request: Request):
        html, nonce = editor_page()
        csp = (f"default-src 'none'; script-src 'nonce-{nonce}'; style-src-elem 'nonce-{nonce}'; "
               "style-src-attr 'unsafe-inline'; "
               "img-src 'self' data: blob:; connect-src 'self'; base-uri 'none'; form-action 'none'; "
               "frame-ancestors 'none'")
        return HTMLResponse(html, headers={"content-security-policy": csp})

    async def model(request: Request):
        return JSONResponse(editor.doc.data)

    async def state(request: Request):
        try:
            return JSONResponse(await editor.payload())
        except (LoopsolveError, ValueError) as exc:
            return _error(exc)

    async def edit(request: Request):
        try:
            op = await _json(request)
            if op.get("op") == "settings":
                sett = {}
                for k in ("from", "to", "step"):
                    v = op.get(k)
                    if v is not None:
                        if isinstance(v, bool) or not isinstance(v, (int, float)):
                            raise ModelError(f"{k}: expected a number, got {v!r}")
                        sett[k] = float(v)
                if op.get("through") is not None:
                    sett["through"] = bool(op["through"])
                editor.doc.settings = sett
                return JSONResponse(await editor.payload())
            out = await editor.call("apply", editor.doc.data, op, editor.doc.settings)
            editor.doc.push(out["data"], out["analysis"])
            return JSONResponse(await editor.payload(out["analysis"]))
        except (LoopsolveError, ValueError) as exc:
            return _error(exc)

    async def history(request: Request):
        try:
            moved = editor.doc.undo() if request.url.path.endswith("/undo") else editor.doc.redo()
            body = await editor.payload()
            body["moved"] = moved
            return JSONResponse(body)
        except (LoopsolveError, ValueError) as exc:
            return _error(exc)

    async def save(request: Request):
        try:
            body = await _json(request)
            name = body.get("name")
            if name is not None and not isinstance(name, str):
                raise ModelError("name: expected a file name")
            path = editor.doc.save(name or None, overwrite=bool(body.get("overwrite")))
            return JSONResponse({"saved": os.fspath(path), "document": editor.doc.state()})
        except (LoopsolveError, OSError, ValueError) as exc:
            return _error(exc)

    async def synthesis(request: Request):
        try:
            body = await _json(request)
            method = body.get("method")
            params = body.get("params") or {}
            if not isinstance(method, str) or not isinstance(params, dict):
                raise ModelError('a synthesis request is {"method": ..., "params": {...}}')
            from .synthpanel import METHODS

            if method not in METHODS:
                raise ModelError(f"unknown synthesis method {method!r} (methods: {', '.join(METHODS)})")
            running = [j for j in editor.jobs.values() if j.state == "running"]
            if running:
                raise ModelError("a synthesis is running; cancel it or wait for it before starting another")
            params = dict(params, units=editor.doc.data.get("units") or {"length": "mm", "angle": "deg"})
            job = Job(method, params)
            editor.jobs[job.id] = job
            return JSONResponse(job.status())
        except (LoopsolveError, ValueError) as exc:
            return _error(exc)

    async def job_status(request: Request):
        job = editor.jobs.get(request.path_params["job"])
        if job is None:
            return JSONResponse({"error": "no such synthesis"}, status_code=404)
        return JSONResponse(job.status())

    async def job_cancel(request: Request):
        job = editor.jobs.get(request.path_params["job"])
        if job is None:
            return JSONResponse({"error": "no such synthesis"}, status_code=404)
        job.cancel()
        return JSONResponse(job.status())

    async def export(request: Request):
        q = request.query_params
        fmt = q.get("format", "")
        try:
            at = float(q["at"]) if q.get("at") not in (None, "") else None
            name, content, media = await editor.call("export", editor.doc.data, fmt, at, q.get("mode") or None)
        except (LoopsolveError, ValueError) as exc:
            return _error(exc)
        return Response(content, media_type=media,
                        headers={"content-disposition": f'attachment; filename="{name}"'})

    routes = [
        Route("/", page, methods=["GET"]),
        Route("/api/model", model, methods=["GET"]),
        Route("/api/state", state, methods=["GET"]),
        Route("/api/edit", edit, methods=["POST"]),
        Route("/api/undo", history, methods=["POST"]),
        Route("/api/redo", history, methods=["POST"]),
        Route("/api/save", save, methods=["POST"]),
        Route("/api/synthesis", synthesis, methods=["POST"]),
        Route("/api/synthesis/{job:str}", job_status, methods=["GET"]),
        Route("/api/synthesis/{job:str}/cancel", job_cancel, methods=["POST"]),
        Route("/api/export", export, methods=["GET"]),
    ]
    app = Starlette(routes=routes)
    return _Guard(app, editor)


def bind(port: int | None) -> socket.socket:
    """A listening socket on 127.0.0.1 (``port`` 0 or ``None``: a random free port)."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind(("127.0.0.1", int(port or 0)))
    except OSError as exc:
        sock.close()
        raise ModelError(f"--port {port}: cannot listen on 127.0.0.1:{port} ({exc.strerror or exc})") from None
    sock.listen(64)
    return sock


def serve(editor: EditorApp, sock: socket.socket) -> None:
    """Run the server on ``sock`` until interrupted (Ctrl+C); the worker processes are stopped after."""
    import uvicorn

    config = uvicorn.Config(create_app(editor), log_level="warning", access_log=False, server_header=False,
                            date_header=False, lifespan="off", limit_concurrency=64, timeout_keep_alive=5,
                            ws="none")
    server = uvicorn.Server(config)
    editor.start()
    try:
        server.run(sockets=[sock])
    finally:
        editor.close()
