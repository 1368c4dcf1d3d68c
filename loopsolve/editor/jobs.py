"""Bounded work: the editor's computations run in worker processes, never in the server's.

* :class:`Worker`: one long-lived process that runs the edits and analyses of
  :mod:`loopsolve.editor.document` one at a time. A call that takes longer than its time limit
  is stopped (the process is killed and a fresh one started) and answered with
  :class:`WorkLimitError`, so a hostile or simply huge model cannot hold the server; the
  document is untouched (an edit only lands when its result comes back).
* :class:`Job`: a background synthesis in a process of its own, reporting progress and
  candidates as it goes; :meth:`Job.cancel` kills the process at once.

Processes are started with ``spawn`` (a fresh interpreter: safe with the server's threads) and
inherit the environment (the compile cache directory).
"""

from __future__ import annotations

import multiprocessing as mp
import os
import threading
import time
import traceback
import uuid
from typing import Any

from ..errors import LoopsolveError

__all__ = ["Worker", "Job", "WorkLimitError", "WorkerError", "time_limit"]


def time_limit() -> float:
    """Seconds of work one request may take: ``LOOPSOLVE_EDIT_TIME_LIMIT`` (default 120)."""
    try:
        v = float(os.environ.get("LOOPSOLVE_EDIT_TIME_LIMIT", "120"))
    except ValueError:
        v = 120.0
    return v if v > 0 else 120.0


class WorkLimitError(LoopsolveError):
    """A request needed more work than the editor allows for one request."""

    exit_code = 2


class WorkerError(LoopsolveError):
    """An error raised in a worker process: ``kind`` is its class name, the message is its text."""

    def __init__(self, message: str, *, kind: str = "LoopsolveError", status: int = 422):
        super().__init__(message)
        self.kind = kind
        self.status = status


def _describe(exc: BaseException) -> tuple[str, str, int]:
    if isinstance(exc, LoopsolveError):
        return type(exc).__name__, str(exc), 422
    if isinstance(exc, (MemoryError, RecursionError)):
        return type(exc).__name__, "out of memory or too deeply nested: the model is too large for the editor", 422
    if isinstance(exc, (ArithmeticError, ValueError, TypeError, KeyError)):
        return type(exc).__name__, f"{type(exc).__name__}: {exc}", 422
    return type(exc).__name__, f"internal error: {type(exc).__name__}: {exc}\n{traceback.format_exc(limit=6)}", 500


def _call(name: str, args: tuple) -> Any:
    if name == "apply":
        from .document import apply_op

        return apply_op(*args)
    if name == "analyze":
        from .analysis import analyze

        data, settings, source = (tuple(args) + (None, "<editor>"))[:3]
        return analyze(data, settings, source=source)
    if name == "export":
        from .exporting import export

        return export(*args)
    if name == "ping":
        return "pong"
    raise ValueError(f"unknown worker function {name!r}")


def _worker_main(conn) -> None:
    import warnings

    warnings.simplefilter("ignore")
    while True:
        try:
            msg = conn.recv()
        except (EOFError, OSError):
            return
        if msg is None:
            return
        name, args = msg
        try:
            conn.send(("ok", _call(name, args)))
        except BaseException as exc:  # noqa: BLE001 — everything goes back to the server as a message
            kind, text, status = _describe(exc)
            try:
                conn.send(("err", kind, text, status))
            except (OSError, ValueError):
                return


class Worker:
    """A worker process with a time limit per call (see the module notes)."""

    def __init__(self):
        self._ctx = mp.get_context("spawn")
        self._lock = threading.Lock()
        self._proc = None
        self._conn = None
        self._start()

    def _start(self) -> None:
        parent, child = self._ctx.Pipe()
        proc = self._ctx.Process(target=_worker_main, args=(child,), daemon=True, name="loopsolve-edit-worker")
        proc.start()
        child.close()
        self._proc, self._conn = proc, parent

    def _kill(self) -> None:
        if self._proc is not None and self._proc.is_alive():
            self._proc.kill()
            self._proc.join(5)
        if self._conn is not None:
            self._conn.close()
        self._proc = self._conn = None

    def call(self, name: str, *args, timeout: float | None = None) -> Any:
        """Run ``name(*args)`` in the worker; :class:`WorkLimitError` after ``timeout`` seconds."""
        limit = time_limit() if timeout is None else timeout
        with self._lock:
            if self._proc is None or not self._proc.is_alive():
                self._start()
            t0 = time.monotonic()
            try:
                self._conn.send((name, args))
                ready = self._conn.poll(limit)
            except (OSError, EOFError, BrokenPipeError):
                self._kill()
                raise WorkerError("the worker process stopped; the request was not carried out", kind="WorkerError",
                                  status=500) from None
            if not ready:
                self._kill()
                self._start()
                raise WorkLimitError(f"the request took more than {limit:g} s of work, the editor's limit per "
                                     "request (LOOPSOLVE_EDIT_TIME_LIMIT), and was stopped; nothing was changed")
            try:
                reply = self._conn.recv()
            except (EOFError, OSError):
                self._kill()
                raise WorkerError(f"the worker process died after {time.monotonic() - t0:.1f} s (out of memory?); "
                                  "nothing was changed", kind="WorkerError", status=500) from None
        if reply[0] == "ok":
            return reply[1]
        _, kind, text, status = reply
        raise WorkerError(text, kind=kind, status=status)

    def close(self) -> None:
        with self._lock:
            if self._conn is not None:
                try:
                    self._conn.send(None)
                except (OSError, ValueError):
                    pass
            if self._proc is not None:
                self._proc.join(2)
            self._kill()


def _job_main(conn, method: str, params: dict) -> None:
    import warnings

    warnings.simplefilter("ignore")
    from .synthpanel import run

    def progress(fraction: float, text: str) -> None:
        conn.send(("progress", float(fraction), str(text)))

    try:
        conn.send(("done", run(method, params, progress)))
    except BaseException as exc:  # noqa: BLE001
        kind, text, _ = _describe(exc)
        conn.send(("error", f"{kind}: {text}"))
    finally:
        conn.close()


class Job:
    """A background synthesis: ``state`` is ``running``, ``done``, ``failed`` or ``cancelled``."""

    def __init__(self, method: str, params: dict):
        self.id = uuid.uuid4().hex[:12]
        self.method = method
        self.state = "running"
        self.progress = 0.0
        self.message = "starting"
        self.result: dict | None = None
        self.error: str | None = None
        self.started = time.monotonic()
        ctx = mp.get_context("spawn")
        parent, child = ctx.Pipe()
        self._proc = ctx.Process(target=_job_main, args=(child, method, params), daemon=True,
                                 name=f"loopsolve-synthesis-{self.id}")
        self._proc.start()
        child.close()
        self._conn = parent
        self._lock = threading.Lock()
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        while True:
            try:
                msg = self._conn.recv()
            except (EOFError, OSError):
                break
            with self._lock:
                if self.state != "running":
                    break
                if msg[0] == "progress":
                    self.progress, self.message = msg[1], msg[2]
                elif msg[0] == "done":
                    self.result, self.state, self.progress = msg[1], "done", 1.0
                    n = len(msg[1].get("candidates", []))
                    self.message = f"{n} certified candidate{'s' if n != 1 else ''}"
                elif msg[0] == "error":
                    self.error, self.state, self.message = msg[1], "failed", msg[1]
        with self._lock:
            if self.state == "running":
                self.state, self.error = "failed", "the synthesis process stopped without an answer"
                self.message = self.error
        self._proc.join(5)

    def cancel(self) -> bool:
        """Stop the synthesis now (its process is killed); ``False`` if it had already ended."""
        with self._lock:
            if self.state != "running":
                return False
            self.state, self.message = "cancelled", "cancelled"
        if self._proc.is_alive():
            self._proc.kill()
        self._proc.join(5)
        try:
            self._conn.close()
        except OSError:
            pass
        return True

    def status(self) -> dict:
        with self._lock:
            return {"id": self.id, "method": self.method, "state": self.state, "progress": self.progress,
                    "message": self.message, "result": self.result, "error": self.error,
                    "seconds": round(time.monotonic() - self.started, 1)}
