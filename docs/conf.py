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
autodoc_typehints = "description"  # the signatures' types, under Parameters and Returns
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
