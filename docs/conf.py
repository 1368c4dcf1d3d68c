"""Sphinx configuration of the loopsolve documentation.

Build (from the repository root, after ``pip install -e ".[test,docs]"``)::

    python -m sphinx -W --keep-going -n -b html docs docs/_build/html

The site is built fully offline: the pydata-sphinx-theme's assets are in the package, math is
rendered to SVG at build time (``sphinx.ext.imgmath`` with LaTeX and dvisvgm), nothing refers to
a CDN (``tests/docs/test_site.py`` checks the built HTML). Pages generated at build time (the
gallery, the executed notebooks, the picture of the landing page) are written by the small
extensions in ``docs/_ext`` and are not committed.
"""

import os
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path.insert(0, str(DOCS / "_ext"))
sys.path.insert(0, str(ROOT))
os.environ.setdefault("MPLBACKEND", "Agg")

import loopsolve  # noqa: E402

project = "loopsolve"
author = "the loopsolve developers"
copyright = "the loopsolve developers, MIT licence"
version = release = loopsolve.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "numpydoc",
    "sphinx.ext.imgmath",
    "sphinxarg.ext",
    "myst_nb",
    "loopsolve_docs",  # docs/_ext: gallery, executed notebooks, the landing picture, the key checks
]

exclude_patterns = ["_build", "**.ipynb_checkpoints", "README.md"]
templates_path = ["_templates"]
html_static_path = ["_static"]
# the interactive pages of the gallery, written by loopsolve_docs (copied to the site as they are)
(DOCS / "_build" / ".loopsolve-extra").mkdir(parents=True, exist_ok=True)
html_extra_path = ["_build/.loopsolve-extra"]
source_suffix = {".rst": "restructuredtext", ".md": "myst-nb", ".ipynb": "myst-nb"}

# ---------------------------------------------------------------- strictness
nitpicky = True
# Offline: no intersphinx, so names from other packages cannot resolve; ignore those (and only those).
nitpick_ignore_regex = [
    (r"py:(class|obj|exc|func|data|meth|mod|attr)",
     r"(numpy|np|scipy|sympy|sp|xarray|xr|dask|distributed|matplotlib|pathlib|os|collections|typing|"
     r"enum|argparse|io|pint|networkx|nx|datetime|types|concurrent|ezdxf)(\..*)?"),
    (r"py:(class|obj)", r"(array_like|array-like|ndarray|callable|optional|iterable|sequence|mapping|"
     r"path-like|file-like|scalar|dict-like|int|float|str|bool|dict|list|tuple|set|None|bytes|object|"
     r"complex|type|Any|Path|PathLike|Mapping|Sequence|Iterable|Callable|Iterator|Literal|Matrix|Expr|"
     r"Symbol|Figure|Axes|Dataset|DataArray|Client|Enum|Self)(\W.*)?"),
    (r"py:(class|obj)", r".*\b(of|or|and|default|shape|optional)\b.*"),  # numpydoc's prose types
    (r"py:class", r"loopsolve\..*\._.*"),  # private helpers named in signatures
    # The implementation's module paths (loopsolve.kinematics.sweep, ...) are not documented pages: the
    # API is the top-level names (reference/api.rst), and those paths are being renamed (issue 31).
    # A docstring that names one reads as text until it names the public function instead.
    (r"py:(func|class|mod|meth|attr|data|obj)",
     r"loopsolve\.(model|symbolic|kinematics|dynamics|design|output|editor|cli)(\..*)?"),
    (r"py:(func|data|obj)", r"(angle_turns|MAX_KEY_PARTS|MAX_DEPTH)"),
]

# ---------------------------------------------------------------- API reference
autosummary_generate = True
autosummary_ignore_module_all = False  # a package's page lists what its __all__ says, nothing else
autosummary_imported_members = True  # the top-level names are defined in the layers and imported
autodoc_default_options = {"members": True, "inherited-members": False}
autodoc_typehints = "none"  # numpydoc sections carry the types; annotations would repeat them
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
numpydoc_validation_checks = set()
add_module_names = False

# ---------------------------------------------------------------- math without a CDN
imgmath_image_format = "svg"
# TeX Live as CI installs it (texlive-latex-base, -recommended) has neither preview.sty nor anyfontsize.sty
# (both in texlive-latex-extra): no preview (no baseline depth for inline math), and a stand-in
# anyfontsize.sty in docs/_tex (the math is set at the document's 12pt, so no other size is needed)
imgmath_use_preview = False
os.environ["TEXINPUTS"] = str(DOCS / "_tex") + os.pathsep + os.environ.get("TEXINPUTS", "")
# a page tall and wide enough for a whole derivation (the gallery renders each model's as one image; imgmath
# converts the first page only, and the picture is cropped to its ink)
imgmath_latex_preamble = r"\setlength{\textwidth}{60em}\setlength{\textheight}{500cm}"
imgmath_font_size = 12

# ---------------------------------------------------------------- notebooks
nb_execution_mode = "off"  # executed once by loopsolve_docs (cached), like tests/test_notebooks.py does
nb_execution_timeout = 600  # per cell, for the pages that execute (explanation/verification.md)
myst_enable_extensions = ["dollarmath", "amsmath"]
suppress_warnings = ["mystnb.unknown_mime_type", "myst.header"]  # the notebooks skip heading levels

# ---------------------------------------------------------------- theme (assets bundled in the package)
html_theme = "pydata_sphinx_theme"
html_title = f"loopsolve {release}"
html_css_files = ["loopsolve.css"]
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "header_links_before_dropdown": 7,
    "icon_links": [],
    "footer_start": ["copyright"],
    "footer_end": ["sphinx-version"],
}
html_sidebars = {"index": [], "gallery/index": []}
html_show_sourcelink = False
html_copy_source = False
