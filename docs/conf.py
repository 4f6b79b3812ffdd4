"""Sphinx configuration of the vsi_numba documentation.

Build (from the repository root)::

    python -m sphinx -W -b html docs docs/_build/html

A small directive keeps a page in step with the code: ``verification-table`` renders a
CSV file kept beside the page (the ``verification.csv`` written by ``vsi verify``, the
gallery's result tables written by ``docs/gallery/make_figures.py``).  (The key reference,
``reference/config_keys.md``, is generated from the config models and committed.)
"""

from __future__ import annotations

import ast
import csv
import datetime
from pathlib import Path

from docutils import nodes
from docutils.parsers.rst import Directive, directives

ROOT = Path(__file__).resolve().parent.parent

project = "vsi_numba"
author = "the vsi_numba developers"
copyright = f"2026-{datetime.date.today().year}, {author}"  # noqa: A001


def _version() -> str:
    for node in ast.parse((ROOT / "vsi_numba" / "__init__.py").read_text("utf-8")).body:
        if isinstance(node, ast.Assign) and getattr(node.targets[0], "id", "") == "__version__":
            return node.value.value
    return "unknown"


release = version = _version()
extensions = ["myst_parser", "sphinx.ext.autodoc", "sphinx.ext.napoleon"]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
exclude_patterns = ["_build"]
myst_heading_anchors = 3
myst_enable_extensions = ["dollarmath"]
napoleon_google_docstring = False
autodoc_typehints = "none"
html_theme = "alabaster"
html_static_path: list[str] = []


class VerificationTable(Directive):
    """A table of the chosen columns of a CSV file (path relative to the page)."""

    required_arguments = 1
    option_spec = {"columns": directives.unchanged, "unique": directives.flag}

    def run(self):
        env = self.state.document.settings.env
        rel, path = env.relfn2path(self.arguments[0], env.docname)
        env.note_dependency(rel)
        with open(path, encoding="utf-8", newline="") as fh:
            rows = list(csv.DictReader(fh))
        cols = [c.strip() for c in self.options.get(
            "columns", "id,quantity,reference,computed,error,tolerance,pass").split(",")]
        table = nodes.table()
        group = nodes.tgroup(cols=len(cols))
        table += group
        group.extend(nodes.colspec(colwidth=1) for _ in cols)

        def row(cells):
            r = nodes.row()
            for c in cells:
                r += nodes.entry("", nodes.paragraph(text=c))
            return r

        def show(name, value):
            if name in ("reference", "computed"):
                return f"{float(value):.6g}"
            if name in ("error", "tolerance"):
                return f"{float(value):+.2e}" if name == "error" else f"{float(value):.1e}"
            return value

        body = [[show(c, r[c]) for c in cols] for r in rows]
        if "unique" in self.options:
            body = [list(t) for t in dict.fromkeys(tuple(b) for b in body)]
        group += nodes.thead("", row(cols))
        group += nodes.tbody("", *(row(b) for b in body))
        return [table]


def setup(app):
    app.add_directive("verification-table", VerificationTable)
    return {"parallel_read_safe": True}
