"""The documentation site (docs/), built and opened as a reader opens it.

Which build: ``LOOPSOLVE_DOCS_HTML`` names a site already built (CI builds it once, with
``python -m sphinx -W --keep-going -n -b html docs docs/_build/html``, and points this variable at
it, so the site is not built twice); without it the test builds the site itself into a temporary
directory, with the same warnings-as-errors options, when Sphinx and the ``docs`` extra are
installed. Without them the tests skip, unless ``LOOPSOLVE_REQUIRE_DOCS`` is set (CI), when they
fail.

Checked: the site refers to nothing on the network for its scripts, style sheets, fonts and
images (it is read offline); every public name of ``loopsolve.__all__`` has its page; every shipped
model has its gallery page with its pictures and interactive page; every command of the parser is
in the command-line reference; and headless Chromium, with the network switched off, shows the
index, an API page, a gallery page with its figure and the search page with a result.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path
from urllib.parse import quote

import pytest

import loopsolve as ls

ROOT = Path(__file__).resolve().parents[2]


def _missing(what: str):
    if os.environ.get("LOOPSOLVE_REQUIRE_DOCS"):
        pytest.fail(f"{what}, but LOOPSOLVE_REQUIRE_DOCS is set")
    pytest.skip(f"{what}; set LOOPSOLVE_REQUIRE_DOCS=1 to make this a failure")


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    given = os.environ.get("LOOPSOLVE_DOCS_HTML")
    if given:
        path = Path(given)
        if not (path / "index.html").is_file():
            pytest.fail(f"LOOPSOLVE_DOCS_HTML={given} holds no built site (index.html)")
        return path
    try:
        import numpydoc  # noqa: F401
        import pydata_sphinx_theme  # noqa: F401
        import sphinx  # noqa: F401
        import sphinxarg  # noqa: F401
        import myst_nb  # noqa: F401
    except ImportError as exc:
        _missing(f"the docs extra is not installed ({exc.name}: pip install -e '.[test,docs]')")
    if not shutil.which("latex") or not shutil.which("dvisvgm"):
        _missing("latex and dvisvgm are needed for the math (apt install texlive-latex-base dvisvgm)")
    out = tmp_path_factory.mktemp("site")
    proc = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-n", "-q", "-b", "html",
                           "-d", str(out / ".doctrees"), str(ROOT / "docs"), str(out / "html")],
                          capture_output=True, text=True, env=dict(os.environ, MPLBACKEND="Agg"))
    assert proc.returncode == 0, proc.stderr[-4000:]
    return out / "html"


# ------------------------------------------------------------------ the files
_URL_ATTR = re.compile(r"""<(script|link|img|iframe|source|embed|object)\b[^>]*?\b(src|href|data)\s*=\s*["']([^"']+)""",
                       re.I)


def test_nothing_is_loaded_from_the_network(site):
    """No script, style sheet, font, image or frame of any page comes from http(s) or a protocol-relative URL."""
    remote = []
    for page in site.rglob("*.html"):
        text = page.read_text(encoding="utf-8", errors="replace")
        for tag, _attr, url in _URL_ATTR.findall(text):
            if tag.lower() == "link" and not re.search(r"""rel=["'](stylesheet|preload|icon|modulepreload|"""
                                                     r"""shortcut icon|prefetch)""", _tag_around(text, url), re.I):
                continue
            if re.match(r"(https?:)?//", url.strip(), re.I):
                remote.append(f"{page.relative_to(site)}: <{tag}> {url}")
        remote += [f"{page.relative_to(site)}: @import {u}" for u in re.findall(r"@import\s+url\(['\"]?(https?:[^)'\"]+)",
                                                                               text)]
    for sheet in list(site.rglob("*.css")) + list(site.rglob("*.js")):
        text = sheet.read_text(encoding="utf-8", errors="replace")
        for url in re.findall(r"url\(\s*['\"]?((?:https?:)?//[^)'\"]+)", text):
            remote.append(f"{sheet.relative_to(site)}: url({url})")
        for url in re.findall(r"@import\s+['\"]((?:https?:)?//[^'\"]+)", text):
            remote.append(f"{sheet.relative_to(site)}: @import {url}")
    assert not remote, "\n".join(remote[:20])
    index = (site / "index.html").read_text(encoding="utf-8")
    assert "mathjax" not in index.lower() and "cdn." not in index.lower()


def _tag_around(text: str, url: str) -> str:
    i = text.find(url)
    return text[text.rfind("<", 0, i): text.find(">", i) + 1]


def test_every_public_name_has_its_page(site):
    generated = site / "reference" / "generated"
    missing = [name for name in ls.__all__ if not name.startswith("__")
               and not (generated / f"loopsolve.{name}.html").is_file()]
    assert not missing, f"no API page for {missing}"
    listing = (generated / "loopsolve.html").read_text(encoding="utf-8")
    assert all(f"loopsolve.{name}.html" in listing for name in ls.__all__ if not name.startswith("__"))


def test_every_model_is_in_the_gallery(site):
    models = sorted(ls.models_dir().glob("*.toml")) or sorted((ROOT / "models").glob("*.toml"))
    assert models
    index = (site / "gallery" / "index.html").read_text(encoding="utf-8")
    for model in models:
        page = site / "gallery" / f"{model.stem}.html"
        assert page.is_file(), model.name
        text = page.read_text(encoding="utf-8")
        for picture in (f"{model.stem}_draw.png", f"{model.stem}_plot.png"):
            src = re.search(r'src="([^"]*' + re.escape(picture) + ')"', text)
            assert src, f"{model.stem}: no {picture}"
            assert (page.parent / src.group(1)).stat().st_size > 1000
        frame = re.search(r'<iframe[^>]*src="([^"]+)"', text)
        assert frame and (page.parent / frame.group(1)).resolve().is_file(), f"{model.stem}: no interactive page"
        assert 'id="loopsolve-input"' in (page.parent / frame.group(1)).read_text(encoding="utf-8")
        assert f"{model.stem}.html" in index
        derivation = text[text.index('id="derivation"'):]  # the derivation, rendered as math (not an empty picture)
        svg = re.search(r'<img src="([^"]+\.svg)"', derivation)
        assert svg and (page.parent / svg.group(1)).stat().st_size > 2000, f"{model.stem}: no derivation"


def test_cli_reference_has_every_command_and_option(site):
    from loopsolve.cli import build_parser

    text = (site / "reference" / "cli.html").read_text(encoding="utf-8")
    parser = build_parser()
    sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    for name, command in sub.choices.items():
        assert re.search(rf">\s*{re.escape(name)}\s*<", text), f"command {name} missing"
        for action in command._actions:
            for option in action.option_strings:
                assert option in text, f"{name} {option} missing"


# ------------------------------------------------------------------ in the browser
@pytest.fixture(scope="module")
def browser(chromium):
    with chromium(window=(1280, 900), offline=True, performance=True, file_access=True) as driver:
        yield driver


def _requests(driver) -> list[str]:
    urls = []
    for entry in driver.get_log("performance"):
        msg = json.loads(entry["message"])["message"]
        if msg.get("method") == "Network.requestWillBeSent":
            urls.append(msg["params"]["request"]["url"])
    return urls


def _open(driver, page: Path, query: str = ""):
    driver.get_log("performance")
    driver.get(page.resolve().as_uri() + query)
    _wait(driver, lambda d: d.execute_script("return document.readyState") == "complete")


def _wait(driver, condition, timeout=60):
    from selenium.webdriver.support.ui import WebDriverWait

    return WebDriverWait(driver, timeout).until(condition)


def _image_loaded(driver, element) -> bool:
    driver.execute_script("arguments[0].scrollIntoView()", element)
    return bool(driver.execute_script("return arguments[0].complete && arguments[0].naturalWidth > 0", element))


def _only_local(driver) -> None:
    urls = _requests(driver)
    remote = [u for u in urls if re.match(r"(https?|wss?|ftp):|//", u, re.I)]  # chrome:// is the browser's own
    assert not remote, remote


def test_index_in_the_browser(site, browser):
    from selenium.webdriver.common.by import By

    _open(browser, site / "index.html")
    assert "loopsolve" in browser.title
    images = browser.find_elements(By.CSS_SELECTOR, "article img")
    assert images, "the landing page shows no picture"
    assert all(_wait(browser, lambda d, im=im: _image_loaded(d, im)) for im in images)
    links = {a.text.strip() for a in browser.find_elements(By.CSS_SELECTOR, "article a")}
    assert {"Tutorials", "How-to guides", "Reference", "Explanation", "Gallery"} <= links, links
    # the theme's own script and style ran: its navigation bar is laid out
    nav = browser.find_element(By.CSS_SELECTOR, "nav.bd-header, header.bd-header, .bd-header")
    assert nav.size["height"] > 20
    _only_local(browser)


def test_api_page_in_the_browser(site, browser):
    from selenium.webdriver.common.by import By

    _open(browser, site / "reference" / "generated" / "loopsolve.sweep.html")
    sig = browser.find_element(By.CSS_SELECTOR, "dl.py.function > dt")
    assert sig.get_attribute("id") == "loopsolve.sweep" and "sweep(" in sig.text
    body = browser.find_element(By.CSS_SELECTOR, "dl.py.function > dd").text
    assert "Parameters" in body and "Examples" in body
    _only_local(browser)


def test_gallery_page_in_the_browser(site, browser):
    from selenium.webdriver.common.by import By

    _open(browser, site / "gallery" / "thesis_crank_rocker.html")
    figures = browser.find_elements(By.CSS_SELECTOR, "figure img")
    assert len(figures) >= 2
    assert all(_wait(browser, lambda d, im=im: _image_loaded(d, im)) for im in figures)
    assert figures[0].size["width"] > 200
    maths = browser.find_elements(By.CSS_SELECTOR, "img.math, div.math img, p img.math")
    assert maths and _wait(browser, lambda d: _image_loaded(d, maths[0]))
    frame = browser.find_element(By.CSS_SELECTOR, "iframe.loopsolve-page")
    browser.execute_script("arguments[0].scrollIntoView()", frame)
    browser.switch_to.frame(frame)
    try:
        slider = _wait(browser, lambda d: d.find_element(By.ID, "loopsolve-input"))
        assert int(slider.get_attribute("max")) > 100
        assert browser.find_elements(By.CSS_SELECTOR, '[data-point="C"]')
    finally:
        browser.switch_to.default_content()
    _only_local(browser)


def test_search_in_the_browser(site, browser):
    from selenium.webdriver.common.by import By

    _open(browser, site / "search.html", "?q=" + quote("Freudenstein"))
    results = _wait(browser, lambda d: d.find_elements(By.CSS_SELECTOR, "#search-results ul.search li"), timeout=90)
    titles = " ".join(r.text for r in results)
    assert "synthesis" in titles.lower() or "Freudenstein" in titles, titles
    _only_local(browser)
