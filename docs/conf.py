"""Sphinx configuration of the imucalib documentation.

Build it with ``python -m sphinx -W -b html docs docs/_build/html`` from the
repository's root (``pip install -e ".[docs]"`` installs what it needs). The
recording guide's figures are drawn from the simulator by :mod:`figures` when
the build starts (the ``figures`` extension below), into ``docs/_generated``.
"""

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "src"))  # the code next to these pages, installed or not
sys.path.insert(0, str(HERE))  # figures.py, methodlist.py

import imucalib  # noqa: E402

project = "imucalib"
author = "the imucalib authors"
copyright = "the imucalib authors, BSD-3-Clause"
version = release = imucalib.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx-mathjax-offline",  # MathJax served from _static/mathjax: the formulas render offline
    "numpydoc",
    "figures",
    "methodlist",  # the API page's list of the methods' calibrate functions, from the registry
]

exclude_patterns = ["_build", "_generated/*.py", "examples"]
templates_path = []
autosummary_generate = False
autodoc_default_options = {"members": False}
# the annotations in the signatures; the numpydoc Parameters and Returns sections say what each value is
# (autodoc's "description" would repeat the types as a second Parameters block and a "Return type")
autodoc_typehints = "signature"
autodoc_typehints_format = "short"
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
default_role = "literal"
nitpicky = False
toc_object_entries_show_parents = "all"  # the page menu tells imucalib.calibrate from imucalib.methods.calibrate

html_theme = "pydata_sphinx_theme"
html_title = f"imucalib {release}"
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
}
# no primary sidebar: the pages are reached from the top bar, and a page's own sections are in the right-hand menu
html_sidebars = {"**": []}
html_static_path = ["_static"]
html_css_files = ["imucalib.css"]
html_js_files = ["imucalib.js"]  # long names in the page menu break after a dot or an underscore


def _no_type_docstring(app, what, name, obj, options, lines):
    """A constant's docstring when it is only its type's (``tuple``, ``float``): left out, the page describes it.

    A constant re-exported by a package (``imucalib.io.READERS``) has no ``#:`` comment there, and autodoc
    would show the built-in type's text ("Built-in immutable sequence…") as its description.
    """
    if what == "data" and lines and type(obj).__doc__ and \
            " ".join(" ".join(lines).split()) == " ".join(type(obj).__doc__.split()):
        lines.clear()


def setup(app):
    app.connect("autodoc-process-docstring", _no_type_docstring, priority=100)
