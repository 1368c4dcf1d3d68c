"""``loopsolve edit``: the local editor in the browser (DESIGN.md, "Editor")."""

from __future__ import annotations

import importlib
import os
import sys
from pathlib import Path

from .common import EXIT_OK
from .fileargs import file_argument


def add_edit_parser(sub) -> None:
    """Add ``loopsolve edit`` to the subcommands ``sub``."""
    p = sub.add_parser("edit", help="a local editor in the browser: drag joints, analyse, synthesize, save")
    file_argument(p, "model", role="input", nargs="?", help="model file (TOML) to edit, or a share link of the "
                  "editor; without it the editor starts from a template four-bar and asks for a name when saving "
                  "(the editor saves through its own checks: it asks before replacing a file)")
    p.add_argument("--port", type=int, default=0, help="port on 127.0.0.1 (default: a random free port)")
    p.add_argument("--no-browser", action="store_true", help="print the URL only; do not open a browser")
    p.set_defaults(func=cmd_edit)


def _from_link(link: str) -> dict:
    """The model of a share link (``...#model=<base64url of the TOML>``)."""
    import base64

    from ..editor.document import model_from_text
    from ..errors import ModelError

    frag = link.split("#", 1)[1] if "#" in link else ""
    parts = dict(p.split("=", 1) for p in frag.split("&") if "=" in p)
    code = parts.get("model", "")
    if not code or len(code) > 400_000:
        raise ModelError("the share link has no model (expected ...#model=<base64url of the TOML>)")
    try:
        text = base64.urlsafe_b64decode(code + "=" * (-len(code) % 4)).decode("utf-8")
    except (ValueError, UnicodeDecodeError):
        raise ModelError("the share link's model is not base64url-encoded UTF-8 text") from None
    return model_from_text(text, source="<share link>")


def cmd_edit(args) -> int:
    from ..errors import MissingDependencyError, ModelError

    missing = []
    for name in ("starlette", "uvicorn"):
        try:
            importlib.import_module(name)
        except ImportError:
            missing.append(name)
    if missing:
        raise MissingDependencyError(f"loopsolve edit needs the edit extra ({', '.join(missing)} missing): "
                                     "pip install 'loopsolve[edit]'")
    from ..editor.editing import template
    from ..editor.server import EditorApp, bind, serve

    if args.port is not None and not 0 <= args.port <= 65535:
        raise ModelError(f"--port {args.port}: expected 0 to 65535")
    path = None
    if args.model is None:
        data = template()
    elif "#model=" in args.model or "&model=" in args.model:
        data = _from_link(args.model)
    else:
        import tomllib

        from ..model.files import read_regular
        from ..model.modelfile import MAX_FILE_SIZE, load

        load(args.model)  # every check of a model file, with its messages
        data = tomllib.loads(read_regular(args.model, MAX_FILE_SIZE, what="model file").decode("utf-8").lstrip("\ufeff"))
        path = Path(args.model).resolve()
    sock = bind(args.port)
    editor = EditorApp(data, path, port=sock.getsockname()[1], base=Path(os.getcwd()))
    print(editor.url, flush=True)
    print("loopsolve edit: serving on the loopback only; press Ctrl+C to stop", file=sys.stderr, flush=True)
    if not args.no_browser:
        import webbrowser

        try:
            webbrowser.open(editor.url)
        except Exception:  # noqa: BLE001 — no browser: the URL is printed
            pass
    try:
        serve(editor, sock)
    except KeyboardInterrupt:
        pass
    finally:
        sock.close()
    return EXIT_OK
