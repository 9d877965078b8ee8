"""The API page's list of the methods' own ``calibrate`` functions, made from the registry.

The documentation build runs this module as a Sphinx extension (``methodlist`` in ``conf.py``): the
directive ``.. method-functions::`` stands for one ``.. autofunction::`` per method of
:data:`imucalib.methods.METHODS`, in the registry's order, so that a new method appears on the page
without editing it. :func:`autofunction_lines` gives those lines (the API page's test reads them too).
"""

from __future__ import annotations

from docutils import nodes
from docutils.statemachine import StringList
from sphinx.util.docutils import SphinxDirective

from imucalib.methods import METHODS


def autofunction_lines() -> list[str]:
    """One ``.. autofunction::`` line per method's ``calibrate``, in the registry's order."""
    return [f".. autofunction:: {module.__name__}.calibrate" for module in METHODS.values()]


class MethodFunctions(SphinxDirective):
    """``.. method-functions::``: the ``autofunction`` of every method's ``calibrate``."""

    has_content = False

    def run(self) -> list[nodes.Node]:
        source, line = self.get_source_info()
        content = StringList([text for entry in autofunction_lines() for text in (entry, "")],
                             source=source, parent_offset=line)
        container = nodes.container()
        self.state.nested_parse(content, self.content_offset, container)
        return container.children


def setup(app) -> dict:
    """Sphinx extension: the ``method-functions`` directive."""
    app.add_directive("method-functions", MethodFunctions)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
