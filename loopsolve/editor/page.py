"""The editor's page: the interactive page's layout and script (``view.js``, ``view.css``) plus the
editor's own (``editor.js``, ``editor.css``), all inline, served by :mod:`loopsolve.editor.server`.

The page keeps the hooks of ``loopsolve view`` (``#loopsolve-input``, ``[data-point]`` circles
in model coordinates) and adds those of DESIGN.md, "Editor": the slider's ``data-value`` (the
input's value at the current row, model units) and ``data-joint="NAME"`` on every draggable
joint. It loads nothing from the network: the model and its analysis come from ``/api/state``
of the same server, and every asset is in the page.
"""

from __future__ import annotations

import secrets
from importlib import resources

__all__ = ["editor_page"]


def _asset(package: str, name: str) -> str:
    return resources.files(package).joinpath(name).read_text(encoding="utf-8")


def editor_page() -> tuple[str, str]:
    """``(html, nonce)``: the page with a fresh nonce on its inline style and scripts."""
    from .. import __version__

    nonce = secrets.token_urlsafe(18)
    view_css = _asset("loopsolve.output", "view.css")
    view_js = _asset("loopsolve.output", "view.js")
    css = _asset("loopsolve.editor", "editor.css")
    js = _asset("loopsolve.editor", "editor.js")
    on = ' class="on"'
    speeds = "".join(f"<option value=\"{s}\"{' selected' if s == '1' else ''}>{s}×</option>"
                     for s in ("0.25", "0.5", "1", "2", "4"))
    tools = "".join(f"<button type=\"button\" data-tool=\"{k}\" title=\"{t}\">{label}</button>" for k, label, t in (
        ("drag", "Drag", "drag a joint or ground pivot: the dimensions it defines change"),
        ("link", "+ Link", "click two joints (or empty places: new joints) to join them by a link"),
        ("point", "+ Point", "click a link to put a point on it (its coupler curve is traced)"),
        ("slider", "+ Slider", "click a joint to put it on a block sliding on the ground"),
        ("delete", "Delete", "click a joint or a link to delete it"),
        ("input", "Input", "click a ground pivot to drive it")))
    html = (
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
        "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
        f"<meta name=\"generator\" content=\"loopsolve {__version__}\">\n"
        "<meta name=\"referrer\" content=\"no-referrer\">\n"
        "<link rel=\"icon\" href=\"data:,\">\n"
        "<title>loopsolve edit</title>\n"
        f"<style nonce=\"{nonce}\">\n{view_css}\n{css}</style>\n</head>\n<body>\n"
        "<div id=\"ls-app\" class=\"le-editor\">\n"
        "<header><h1 id=\"le-title\">loopsolve edit</h1><div id=\"ls-status\"></div>"
        "<div id=\"le-doc\"></div></header>\n"
        "<div id=\"le-toolbar\" role=\"toolbar\">"
        f"<span class=\"le-group\" id=\"le-tools\">{tools}</span>"
        "<span class=\"le-group\"><button type=\"button\" id=\"le-undo\" title=\"undo (Ctrl+Z)\">↶ Undo</button>"
        "<button type=\"button\" id=\"le-redo\" title=\"redo (Ctrl+Y)\">↷ Redo</button></span>"
        "<span class=\"le-group\"><button type=\"button\" id=\"le-save\">Save</button>"
        "<button type=\"button\" id=\"le-saveas\">Save as…</button>"
        "<button type=\"button\" id=\"le-share-btn\" title=\"a link that opens this design in loopsolve edit\">"
        "Share link</button></span>"
        "<span class=\"le-group\" id=\"le-export\">export "
        + "".join(f"<a id=\"le-export-{f}\" data-format=\"{f}\" download>{f.upper() if f != 'tex' else 'LaTeX'}</a>"
                  for f in ("png", "svg", "dxf", "tex"))
        + "</span></div>\n"
        "<div id=\"ls-controls\">"
        "<button id=\"ls-play\" type=\"button\" title=\"play / pause (space)\">▶</button>"
        f"<label class=\"ls-speed\">speed <select id=\"ls-speed\">{speeds}</select></label>"
        "<div class=\"ls-slider\"><input type=\"range\" id=\"loopsolve-input\" min=\"0\" max=\"0\" step=\"1\" "
        "value=\"0\" aria-label=\"input value\"><svg id=\"ls-marks\" aria-hidden=\"true\"></svg></div>"
        "<span id=\"ls-row\"></span></div>\n"
        "<div id=\"le-message\" role=\"status\" aria-live=\"polite\"></div>\n"
        "<main>\n<section id=\"ls-diagram-box\"><svg id=\"ls-diagram\" role=\"img\" "
        "aria-label=\"kinematic diagram\"></svg><div id=\"ls-legend\"></div></section>\n"
        "<aside>\n<nav id=\"le-panels\">"
        + "".join(f"<button type=\"button\" data-panel=\"{k}\"{on if k == 'analysis' else ''}>{t}</button>"
                  for k, t in (("analysis", "Analysis"), ("dimensions", "Dimensions"), ("forces", "Forces"),
                               ("synthesis", "Synthesis")))
        + "</nav>\n"
        "<div class=\"le-panel on\" id=\"le-panel-analysis\"><div id=\"le-info\"></div>"
        "<div id=\"ls-tabs\"></div><div id=\"ls-plots\"></div><table id=\"ls-values\"></table>"
        "<ul id=\"ls-events\"></ul><form id=\"le-range\" class=\"le-form\"></form></div>\n"
        "<div class=\"le-panel\" id=\"le-panel-dimensions\"><div id=\"le-dims\"></div></div>\n"
        "<div class=\"le-panel\" id=\"le-panel-forces\"><div id=\"le-forces\"></div></div>\n"
        "<div class=\"le-panel\" id=\"le-panel-synthesis\"><div id=\"le-synth\"></div></div>\n"
        "</aside>\n</main>\n"
        "<footer>drag joints · ← → step · space play/pause · Ctrl+Z undo · Ctrl+Y redo · made with loopsolve</footer>\n"
        "</div>\n"
        "<div id=\"le-dialog\" hidden><div class=\"le-dialog-box\"><p id=\"le-dialog-text\"></p>"
        "<input id=\"le-dialog-input\" type=\"text\" autocomplete=\"off\" spellcheck=\"false\">"
        "<div class=\"le-dialog-buttons\"><button type=\"button\" id=\"le-dialog-ok\">OK</button>"
        "<button type=\"button\" id=\"le-dialog-cancel\">Cancel</button></div></div></div>\n"
        "<script type=\"application/json\" id=\"ls-data\"></script>\n"
        f"<script nonce=\"{nonce}\">\n{view_js}</script>\n"
        f"<script nonce=\"{nonce}\">\n{js}</script>\n</body>\n</html>\n")
    return html, nonce
