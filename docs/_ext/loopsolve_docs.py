"""Pages the documentation generates from the project itself, at build time.

* **The gallery** (``docs/gallery/``): one page per shipped model in ``models/``, made with the
  product's own commands run in-process (``loopsolve.cli.main``): the model file, ``info``, the
  drawing (``draw``), a sweep plot (``plot``), the interactive page (``view``, embedded) and the
  derivation (``latex --snippet``, rendered by ``sphinx.ext.imgmath``). A model whose command
  fails fails the build: the gallery is also a check that every shipped model works.
* **The notebooks** (``docs/notebooks/``): ``notebooks/*.ipynb`` executed with nbclient in their
  own directory (as ``tests/test_notebooks.py`` runs them), rendered by myst-nb without executing
  again.
* **The landing picture** (``docs/_static/generated/``): the crank-rocker drawn by ``loopsolve draw``.

Why a generator of our own rather than sphinx-gallery: sphinx-gallery turns Python *scripts* into
pages; the gallery here is of *model files* shown through the command line, each page the same
five outputs of one file. Fifty lines of code that call ``loopsolve.cli.main`` are simpler than
wrapping every model in a script that shells out.

Everything generated is cached under ``docs/_build/.loopsolve-cache`` by a key made of the input
file and the source of the ``loopsolve`` package, so a rebuild after editing prose takes seconds
and a change of the code recomputes every output. Nothing generated is committed (``.gitignore``).
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import os
import re
import shutil
from pathlib import Path

DOCS = Path(__file__).resolve().parents[1]
ROOT = DOCS.parent
MODELS = ROOT / "models"
NOTEBOOKS = ROOT / "notebooks"
CACHE = DOCS / "_build" / ".loopsolve-cache"
GALLERY = DOCS / "gallery"
NB_OUT = DOCS / "notebooks"
EXTRA = DOCS / "_build" / ".loopsolve-extra"  # html_extra_path: the interactive pages
GENERATED_STATIC = DOCS / "_static" / "generated"

# per model: sweep options of the plot and the page (the default range and step otherwise)
SWEEP = {"thesis_crank_rocker.toml": ["--from", "0", "--to", "360", "--step", "2"],
         # the cycles of the geared models: five sun turns per crank turn, three input turns per coupler curve
         "planetary_geared_crank.toml": ["--from", "0", "--to", "1800", "--step", "10"],
         "geared_fivebar.toml": ["--from", "90", "--to", "1170", "--step", "5"]}
STEP = "2"


def _source_hash() -> str:
    h = hashlib.sha256()
    for path in sorted((ROOT / "loopsolve").rglob("*")):
        if path.is_file() and path.suffix in (".py", ".js", ".css"):
            h.update(str(path.relative_to(ROOT)).encode())
            h.update(path.read_bytes())
    return h.hexdigest()[:16]


def _run(argv: list[str]) -> str:
    """``loopsolve ARGV`` in this process; its standard output. A failing command fails the build."""
    from loopsolve.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        status = main(argv)
    if status != 0:
        raise RuntimeError(f"loopsolve {' '.join(argv)} exited {status}: {err.getvalue().strip()}")
    return out.getvalue()


_USED: set[str] = set()


def _cached(key: str, make) -> Path:
    """The directory ``CACHE/key``, made by ``make(directory)`` unless it exists."""
    _USED.add(key)
    target = CACHE / key
    if not (target / ".done").exists():
        if target.exists():
            shutil.rmtree(target)
        tmp = CACHE / (key + ".tmp")
        if tmp.exists():
            shutil.rmtree(tmp)
        tmp.mkdir(parents=True)
        make(tmp)
        (tmp / ".done").write_text("")
        tmp.rename(target)
    return target


# ------------------------------------------------------------------ the gallery
def _derivation_rst(tex: str) -> str:
    """``latex --snippet`` output as one reST math block (one LaTeX run per model: imgmath runs LaTeX
    and dvisvgm once per block, and a block per equation made the gallery the slowest part of the
    build); each ``% comment`` of the snippet becomes a bold heading inside it."""
    body = []
    for line in tex.splitlines():
        if line.startswith("% loopsolve:"):
            continue
        if line.startswith("% "):
            body.append(r"\par\medskip\noindent\textbf{" + line[2:].strip() + r"}\par")
        elif line.strip():
            body.append(line)
    text = "\n".join("      " + b for b in body)
    return f".. math::\n   :nowrap:\n\n      \\noindent\n{text}\n"


def _model_outputs(model: Path, directory: Path) -> None:
    stem = model.stem
    sweep = SWEEP.get(model.name, ["--step", STEP])
    _run(["draw", str(model), "-o", str(directory / f"{stem}_draw.png")])
    _run(["plot", str(model), *sweep, "-q", "-o", str(directory / f"{stem}_plot.png")])
    _run(["view", str(model), *sweep, "-q", "-o", str(directory / f"{stem}.html")])
    (directory / "info.txt").write_text(_run(["info", str(model)]))
    (directory / "derivation.tex").write_text(_run(["latex", str(model), "--snippet"]))


def _gallery(app) -> None:
    import loopsolve as ls

    src = app.config.loopsolve_source_hash
    GALLERY.mkdir(exist_ok=True)
    (EXTRA / "gallery-pages").mkdir(parents=True, exist_ok=True)
    images = GALLERY / "_images"
    images.mkdir(exist_ok=True)
    entries = []
    for model in sorted(MODELS.glob("*.toml")):
        key = "model-" + hashlib.sha256(model.read_bytes() + src.encode()).hexdigest()[:16]
        done = _cached(key, lambda d, m=model: _model_outputs(m, d))
        stem = model.stem
        for name in (f"{stem}_draw.png", f"{stem}_plot.png"):
            shutil.copyfile(done / name, images / name)
        shutil.copyfile(done / f"{stem}.html", EXTRA / "gallery-pages" / f"{stem}.html")
        mech = ls.load(model)
        title = f"{mech.name}"
        description = (getattr(mech, "description", "") or "").strip()
        sweep = " ".join(SWEEP.get(model.name, ["--step", STEP]))
        info = (done / "info.txt").read_text().rstrip()
        derivation = _derivation_rst((done / "derivation.tex").read_text())
        page = f"""\
.. This page is generated by docs/_ext/loopsolve_docs.py from models/{model.name}; do not edit.

.. _gallery-{stem}:

{title}
{'=' * len(title)}

``models/{model.name}`` {('— ' + description) if description else ''}

.. literalinclude:: ../../models/{model.name}
   :language: toml
   :caption: models/{model.name}

Structure
---------

.. code-block:: console

   $ loopsolve info models/{model.name}
{_indent(info, 3)}

Drawing
-------

.. code-block:: console

   $ loopsolve draw models/{model.name} -o {stem}.png

.. figure:: _images/{stem}_draw.png
   :alt: {title}: the kinematic diagram at the guesses
   :class: gallery-figure

Sweep
-----

.. code-block:: console

   $ loopsolve plot models/{model.name} {sweep} -o {stem}_plot.png

.. figure:: _images/{stem}_plot.png
   :alt: {title}: positions, velocities and accelerations against the input
   :class: gallery-figure

Interactive page
----------------

.. code-block:: console

   $ loopsolve view models/{model.name} {sweep} -o {stem}.html

.. raw:: html

   <iframe class="loopsolve-page" src="../gallery-pages/{stem}.html" title="{title}: interactive page"
           loading="lazy"></iframe>
   <p><a href="../gallery-pages/{stem}.html">Open the page on its own.</a></p>

Derivation
----------

.. code-block:: console

   $ loopsolve latex models/{model.name} --snippet

{derivation}
"""
        _write_if_changed(GALLERY / f"{stem}.rst", page)
        entries.append((stem, title))
    cards = "\n".join(
        f"   * - .. image:: _images/{stem}_draw.png\n          :target: {stem}.html\n          :alt: {title}\n"
        f"     - :doc:`{stem}`" for stem, title in entries)
    index = f"""\
.. This page is generated by docs/_ext/loopsolve_docs.py; do not edit.

.. _gallery:

Gallery
=======

Every model file shipped in ``models/``, shown with the product's own commands: the model, its
structure (``info``), its drawing (``draw``), a sweep (``plot``), the interactive page (``view``)
and the derivation (``latex``). The pages are made when the documentation is built, so each is
also a check that the model loads, solves, sweeps and derives.

.. list-table::
   :class: gallery-table
   :widths: 40 60

{cards}

.. toctree::
   :hidden:

{_indent(chr(10).join(stem for stem, _ in entries), 3)}
"""
    _write_if_changed(GALLERY / "index.rst", index)


def _indent(text: str, n: int) -> str:
    pad = " " * n
    return "\n".join(pad + line if line.strip() else "" for line in text.splitlines())


def _write_if_changed(path: Path, text: str) -> None:
    if not path.exists() or path.read_text() != text:
        path.write_text(text)


# ------------------------------------------------------------------ notebooks
def _execute(nb_path: Path, directory: Path) -> None:
    import nbclient
    import nbformat

    nb = nbformat.read(nb_path, as_version=4)
    client = nbclient.NotebookClient(nb, timeout=600, kernel_name="python3",
                                     resources={"metadata": {"path": str(nb_path.parent)}})
    client.execute()
    nbformat.write(nb, directory / nb_path.name)


def _for_sphinx(data: bytes) -> bytes:
    import nbformat

    nb = nbformat.reads(data.decode("utf-8"), as_version=4)
    for cell in nb.cells:
        for out in cell.get("outputs", []):
            latex = out.get("data", {}).get("text/latex")
            if latex and "\\begin{align*}" in latex:
                out["data"]["text/latex"] = _one_display(latex)
    return nbformat.writes(nb).encode("utf-8")


def _one_display(latex: str) -> str:
    """A LaTeX snippet of several ``align*`` environments and ``%`` headings (``mech.to_latex(snippet=True)``
    displayed in a notebook) as one display-math body: Jupyter's MathJax typesets the environments one
    by one, but Sphinx puts a math output inside one display environment, where ``align*`` cannot be."""
    parts, table = [], None
    for line in latex.splitlines():
        if line.startswith("% loopsolve:") or not line.strip() or line.strip() in (r"\begin{center}", r"\end{center}"):
            continue
        if table is not None or line.startswith(r"\begin{tabular}"):  # a numeric table: text inside the display
            table = (table or []) + [line]
            if line.startswith(r"\end{tabular}"):
                parts.append(r"\text{" + "\n".join(table) + r"}\\[2ex]")
                table = None
        elif line.startswith("% "):
            parts.append(r"\text{\textbf{" + line[2:].strip() + r"}}\\[1ex]")
        else:
            parts.append(line.replace(r"\begin{align*}", r"\begin{aligned}").replace(r"\end{align*}",
                                                                                   r"\end{aligned}\\[2ex]"))
    return "\\begin{gathered}\n" + "\n".join(parts) + "\n\\end{gathered}"


def _notebooks(app) -> None:
    src = app.config.loopsolve_source_hash
    NB_OUT.mkdir(exist_ok=True)
    names = []
    for nb_path in sorted(NOTEBOOKS.glob("*.ipynb")):
        key = "nb-" + hashlib.sha256(nb_path.read_bytes() + src.encode()).hexdigest()[:16]
        done = _cached(key, lambda d, p=nb_path: _execute(p, d))
        target = NB_OUT / nb_path.name
        data = _for_sphinx((done / nb_path.name).read_bytes())
        if not target.exists() or target.read_bytes() != data:
            target.write_bytes(data)
        names.append(nb_path.stem)
    readme = (NOTEBOOKS / "README.md").read_text()
    # the notebooks' README is the index; its links to notebook files become links to their pages
    readme = re.sub(r"`(\d\d_[a-z0-9_]+)\.ipynb`", r"{doc}`\1`", readme)
    readme += "\n```{toctree}\n:hidden:\n\n" + "\n".join(names) + "\n```\n"
    _write_if_changed(NB_OUT / "index.md", readme)


# ------------------------------------------------------------------ the landing picture
def _landing(app) -> None:
    model = MODELS / "thesis_crank_rocker.toml"
    key = "landing-" + hashlib.sha256(model.read_bytes() + app.config.loopsolve_source_hash.encode()).hexdigest()[:16]

    def make(d):
        _run(["draw", str(model), "--at", "60", "--vectors", "-o", str(d / "crank_rocker.png")])
        _run(["plot", str(model), "--from", "0", "--to", "360", "--step", "2", "-q", "--vars", "theta3", "theta4",
              "-o", str(d / "crank_rocker_plot.png")])

    done = _cached(key, make)
    GENERATED_STATIC.mkdir(parents=True, exist_ok=True)
    for name in ("crank_rocker.png", "crank_rocker_plot.png"):
        shutil.copyfile(done / name, GENERATED_STATIC / name)


def _generate(app) -> None:
    os.environ.setdefault("MPLBACKEND", "Agg")
    CACHE.mkdir(parents=True, exist_ok=True)
    EXTRA.mkdir(parents=True, exist_ok=True)
    app.config.loopsolve_source_hash = _source_hash()
    _landing(app)
    _gallery(app)
    _notebooks(app)
    for old in CACHE.iterdir():  # entries of older sources or models: never read again
        if old.name not in _USED:
            shutil.rmtree(old, ignore_errors=True)


def setup(app):
    app.add_config_value("loopsolve_source_hash", "", "env")
    app.connect("builder-inited", _generate)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
