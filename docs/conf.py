"""Sphinx configuration of the sassi_bench documentation site.

Build: ``pip install -e ".[docs]"`` then ``sphinx-build -W docs docs/_build/html``. Pages
are MyST Markdown; the API reference is generated from the numpydoc docstrings; the
notebooks of ``notebooks/`` are copied in and rendered as stored, never executed.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import sassi_bench

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent

project = "sassi_bench"
author = "sassi_bench developers"
copyright = "sassi_bench developers"
release = sassi_bench.__version__ if hasattr(sassi_bench, "__version__") else ""

extensions = [
    "myst_nb",
    "numpydoc",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.intersphinx",
    "sphinx.ext.viewcode",
]

# .rst first: autosummary writes its generated API pages with the first suffix.
source_suffix = {".rst": "restructuredtext", ".md": "myst-nb", ".ipynb": "myst-nb"}
exclude_patterns = ["_build", "_data", "Thumbs.db", ".DS_Store", "**.ipynb_checkpoints"]
templates_path = ["_templates"]

# Notebooks: rendered as committed (outputs stripped), never run while building.
nb_execution_mode = "off"
myst_enable_extensions = ["colon_fence", "deflist"]
myst_heading_anchors = 3

# API reference: one page per module, generated from the docstrings.
autosummary_generate = True
autosummary_imported_members = False
# Each object on the page of the module that defines it: a package's face re-exports
# names in its __all__, which would describe them twice.
autodoc_default_options = {"members": True, "show-inheritance": True, "ignore-module-all": True}
autodoc_typehints = "none"  # numpydoc's Parameters sections carry the types
autodoc_mock_imports = ["torch", "fast_slic", "cupy"]
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
numpydoc_validation_checks: set[str] = set()

intersphinx_mapping: dict[str, tuple[str, None]] = {}

html_theme = "pydata_sphinx_theme"
html_title = "sassi_bench"
html_static_path = ["_static"]
html_css_files = ["tables.css"]
html_theme_options = {
    "header_links_before_dropdown": 5,
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "secondary_sidebar_items": ["page-toc"],
}
html_sidebars = {"index": []}
html_show_sourcelink = False


def _copy_notebooks() -> None:
    """Copy the guided notebooks into the source tree (they live in ``notebooks/``)."""
    target = DOCS / "_notebooks"
    target.mkdir(exist_ok=True)
    for notebook in sorted((ROOT / "notebooks").glob("*.ipynb")):
        copy = target / notebook.name
        if not copy.exists() or copy.read_bytes() != notebook.read_bytes():
            shutil.copyfile(notebook, copy)


_copy_notebooks()


def _unlisted_pages_glob(app, docname: str, source: list[str]) -> None:
    """Keep a table of contents' closing ``*`` glob only while it has pages to pick up.

    The indexes list their pages in order and end with ``*``, so a page added to their
    folder later appears with no index edit; with no such page, the glob would match
    nothing, which Sphinx reports as a warning (and ``-W`` as an error).
    """
    if "```{toctree}" not in source[0] or "\n*\n" not in source[0]:
        return
    folder = docname.rpartition("/")[0]
    prefix = f"{folder}/" if folder else ""
    body = source[0].split("```{toctree}", 1)[1].split("```", 1)[0]
    listed = {prefix + line.strip() for line in body.splitlines() if line.strip()}
    siblings = {
        name
        for name in app.env.found_docs
        if name.startswith(prefix) and "/" not in name[len(prefix) :] and name != docname
    }
    if not siblings - listed:
        source[0] = source[0].replace("\n*\n", "\n", 1)


def _skip_foreign_members(app, what, name, obj, skip, options):
    """Leave out what a module imports from other packages (scipy's cKDTree, say)."""
    module = getattr(obj, "__module__", None)
    if what == "module" and isinstance(module, str) and not module.startswith("sassi_bench"):
        return True
    return None


def setup(app):
    app.connect("source-read", _unlisted_pages_glob)
    app.connect("autodoc-skip-member", _skip_foreign_members)
